//! A small host program: compile a TSL material, shade a grid of points on a
//! sphere with it, and print an ASCII preview.
//!
//! `cargo run --release --example embed [FILE.tsl] [MATERIAL] [--spectral]`

use tsl::{ColorModel, Compiler, ShadingGlobals};

const DEFAULT: &str = r#"
float rings(float scale = 6) { return fract(length(vec2(Pl.x, Pl.z)) * scale + 0.4 * noise(Pl * 3)); }
material wood = mix(rings(), phong(kd: rgb(0.6, 0.4, 0.2)), phong(kd: rgb(0.35, 0.2, 0.08)));
"#;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let model = if std::env::args().any(|a| a == "--spectral") {
        ColorModel::Spectral { samples: 16 }
    } else {
        ColorModel::Rgb
    };
    let compiler = Compiler::new().color_model(model);
    let compiler = match args.first() {
        Some(path) => compiler.file(path),
        None => compiler.source("embedded.tsl", DEFAULT),
    };
    let program = compiler.compile()?;
    let material = program.material(args.get(1).map_or("wood", String::as_str))?;

    // A unit sphere seen from +z, lit from the upper left.
    let light_dir = normalize([-0.5, 0.6, 0.6]);
    let light = program.rgb(3.0, 3.0, 3.0);
    let ramp: Vec<char> = " .:-=+*#%@".chars().collect();
    let (w, h) = (64, 32);
    for y in 0..h {
        let mut line = String::new();
        for x in 0..w {
            let px = (x as f32 + 0.5) / w as f32 * 2.0 - 1.0;
            let py = 1.0 - (y as f32 + 0.5) / h as f32 * 2.0;
            let r2 = px * px + py * py;
            if r2 > 1.0 {
                line.push(' ');
                continue;
            }
            let n = [px, py, (1.0 - r2).sqrt()];
            let g = ShadingGlobals {
                p: n,
                pl: n,
                n,
                ng: n,
                u: 0.5 + n[0].atan2(n[2]) / std::f32::consts::TAU,
                v: 0.5 + n[1].asin() / std::f32::consts::PI,
                ..Default::default()
            };
            let c = material.reflection(&g, light_dir, &light, [0.0, 0.0, 1.0]);
            let level = (c.brightness().clamp(0.0, 0.999) * ramp.len() as f32) as usize;
            line.push(ramp[level]);
        }
        println!("{line}");
    }
    println!(
        "{} entry points compiled (on first use), color model {}",
        program.functions().len(),
        program.color_model().name()
    );
    Ok(())
}

fn normalize(v: [f32; 3]) -> [f32; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / l, v[1] / l, v[2] / l]
}
