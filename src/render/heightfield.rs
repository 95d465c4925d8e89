//! The `heavy` benchmark scene's mesh, generated rather than stored: a
//! regular grid of N x N vertices over x, z in [-2, 2] with height
//!
//! ```text
//! h(x, z) = 0.25 sin(3x) cos(2z) + 0.08 sin(9x + 7z) + 0.03 cos(17x - 13z)
//! ```
//!
//! the analytic unit normal `normalize(-dh/dx, 1, -dh/dz)`, uv `(i, j) /
//! (N - 1)` and two counter-clockwise triangles per cell (see
//! `../shared/scenes/heavy/spec.md`). N = 708 gives 999,698 triangles.
//!
//! Invariant: the OBJ text is byte for byte what the scene's reference
//! script `make_mesh.py` writes (numbers with six decimals, `%.6f`), so
//! every renderer reads the same geometry.

use std::io::{self, Write};

/// Vertices per side of the `heavy` mesh.
pub const HEAVY_N: usize = 708;

fn height(x: f64, z: f64) -> f64 {
    0.25 * (3.0 * x).sin() * (2.0 * z).cos() + 0.08 * (9.0 * x + 7.0 * z).sin() + 0.03 * (17.0 * x - 13.0 * z).cos()
}

fn gradient(x: f64, z: f64) -> (f64, f64) {
    let dx = 0.75 * (3.0 * x).cos() * (2.0 * z).cos() + 0.72 * (9.0 * x + 7.0 * z).cos()
        - 0.51 * (17.0 * x - 13.0 * z).sin();
    let dz = -0.5 * (3.0 * x).sin() * (2.0 * z).sin()
        + 0.56 * (9.0 * x + 7.0 * z).cos()
        + 0.39 * (17.0 * x - 13.0 * z).sin();
    (dx, dz)
}

/// Writes `x` as `%.6f` does: correctly rounded to six decimals, with
/// Python's sign for negative values that round to zero ("-0.000000").
fn fixed6(out: &mut Vec<u8>, x: f64) {
    // Rust's `{:.6}` rounds correctly (half to even on the exact binary
    // value, as C's printf) and keeps the sign of negative zero.
    let _ = write!(out, "{x:.6}");
}

/// Writes the height field with `n` vertices per side as OBJ.
pub fn write_height_field_obj(out: &mut impl Write, n: usize) -> io::Result<()> {
    let n = n.max(2);
    let vertices = n * n;
    let faces = 2 * (n - 1) * (n - 1);
    writeln!(out, "# heavy: height field, {vertices} vertices, {faces} triangles")?;
    let coord = |k: usize| -2.0 + 4.0 * (k as f64 / (n - 1) as f64);
    let mut line = Vec::with_capacity(64);
    let mut emit = |out: &mut dyn Write, prefix: &str, values: &[f64]| -> io::Result<()> {
        line.clear();
        line.extend_from_slice(prefix.as_bytes());
        for (k, v) in values.iter().enumerate() {
            if k > 0 {
                line.push(b' ');
            }
            fixed6(&mut line, *v);
        }
        line.push(b'\n');
        out.write_all(&line)
    };
    for j in 0..n {
        let z = coord(j);
        for i in 0..n {
            let x = coord(i);
            emit(out, "v ", &[x, height(x, z), z])?;
        }
    }
    for j in 0..n {
        let v = j as f64 / (n - 1) as f64;
        for i in 0..n {
            emit(out, "vt ", &[i as f64 / (n - 1) as f64, v])?;
        }
    }
    for j in 0..n {
        let z = coord(j);
        for i in 0..n {
            let (dx, dz) = gradient(coord(i), z);
            let inv = 1.0 / (dx * dx + 1.0 + dz * dz).sqrt();
            emit(out, "vn ", &[-dx * inv, inv, -dz * inv])?;
        }
    }
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let v00 = j * n + i + 1;
            let (v10, v01) = (v00 + 1, v00 + n);
            let v11 = v01 + 1;
            for (a, b, c) in [(v00, v01, v11), (v00, v11, v10)] {
                writeln!(out, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}")?;
            }
        }
    }
    Ok(())
}

/// Writes the `heavy` scene's mesh (N = 708).
pub fn write_heavy_obj(out: &mut impl Write) -> io::Result<()> {
    write_height_field_obj(out, HEAVY_N)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_small_grid_is_written_as_the_reference_script_does() {
        let mut out = Vec::new();
        write_height_field_obj(&mut out, 3).unwrap();
        let text = String::from_utf8(out).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "# heavy: height field, 9 vertices, 8 triangles");
        assert_eq!(lines.len(), 1 + 9 * 3 + 8);
        // Vertex (0, 0) at x = z = -2; uv and the first face as make_mesh.py.
        let h = height(-2.0, -2.0);
        assert_eq!(lines[1], format!("v -2.000000 {h:.6} -2.000000"));
        assert_eq!(lines[10], "vt 0.000000 0.000000");
        assert_eq!(lines[11], "vt 0.500000 0.000000");
        assert_eq!(lines[28], "f 1/1/1 4/4/4 5/5/5");
        assert_eq!(lines[29], "f 1/1/1 5/5/5 2/2/2");
        // Normals are unit length.
        for l in &lines[19..28] {
            let n: Vec<f64> = l[3..].split(' ').map(|x| x.parse().unwrap()).collect();
            assert!(((n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt() - 1.0).abs() < 1e-5, "{l}");
        }
    }

    #[test]
    fn rounding_matches_printf() {
        let f = |x: f64| {
            let mut v = Vec::new();
            fixed6(&mut v, x);
            String::from_utf8(v).unwrap()
        };
        assert_eq!(f(-1e-9), "-0.000000");
        assert_eq!(f(0.0000005), "0.000000"); // 5e-7 is just below a half in binary
        assert_eq!(f(2.5e-6), "0.000003");
        assert_eq!(f(-2.0), "-2.000000");
    }
}
