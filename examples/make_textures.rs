//! Writes the small images the example scenes use into `examples/textures/`:
//!
//! - `painting.png` (256 x 192, sRGB): a landscape "painting" for the image
//!   texture examples (the room's picture, the second paper's Figure 2);
//! - `tiles_height.png` (256 x 256, gray): the height of 4 x 4 ceramic
//!   tiles with rounded edges and grout, for bump mapping from an image;
//! - `perforated.png` (256 x 256, RGBA): a brass-coloured sheet whose
//!   alpha is 0 in a staggered grid of round holes, for cutouts;
//! - `bricks_normal.png` (256 x 256, RGB): a tangent-space normal map
//!   (OpenGL convention: green is +v, up the picture) of staggered
//!   bricks with bevelled edges, mortar joints and a grain, for normal
//!   mapping; it tiles.
//! - `udim/planks.1001.png`, `.1002`, `.1011`, `.1012` (64 x 64 each, sRGB):
//!   a UDIM tile set of wooden planks, one wood per tile (oak, red paint,
//!   pine, teal paint), for the UDIM example's crate.
//!
//! ```sh
//! cargo run --release --example make_textures
//! ```
//!
//! The output is the same bytes on every run; the images are committed, so
//! the examples need not run this first.

use std::path::Path;

/// A hash of integer lattice coordinates to [0, 1).
fn hash(x: i32, y: i32, seed: u32) -> f32 {
    let mut h =
        (x as u32).wrapping_mul(0x8da6_b343) ^ (y as u32).wrapping_mul(0xd816_3841) ^ seed.wrapping_mul(0xcb1a_b31f);
    h ^= h >> 13;
    h = h.wrapping_mul(0x5bd1_e995);
    h ^= h >> 15;
    (h >> 8) as f32 / (1u32 << 24) as f32
}

/// Smooth value noise in [0, 1).
fn value_noise(x: f32, y: f32, seed: u32) -> f32 {
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (sx, sy) = (fx * fx * (3.0 - 2.0 * fx), fy * fy * (3.0 - 2.0 * fy));
    let (i, j) = (x0 as i32, y0 as i32);
    let a = hash(i, j, seed) + sx * (hash(i + 1, j, seed) - hash(i, j, seed));
    let b = hash(i, j + 1, seed) + sx * (hash(i + 1, j + 1, seed) - hash(i, j + 1, seed));
    a + sy * (b - a)
}

fn fbm(x: f32, y: f32, seed: u32) -> f32 {
    (0..4).map(|o| value_noise(x * (1 << o) as f32, y * (1 << o) as f32, seed + o) / (1 << o) as f32).sum::<f32>()
        / 1.875
}

fn mix(a: [f32; 3], b: [f32; 3], t: f32) -> [f32; 3] {
    let t = t.clamp(0.0, 1.0);
    [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t]
}

fn byte(x: f32) -> u8 {
    (x.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Sky, sun, two ranges of hills and a lake, with brush-stroke noise.
fn painting() -> image::RgbImage {
    let (w, h) = (256u32, 192u32);
    image::RgbImage::from_fn(w, h, |px, py| {
        let (x, y) = (px as f32 / w as f32, 1.0 - py as f32 / h as f32);
        let stroke = fbm(x * 24.0, y * 6.0, 1) - 0.5;
        let horizon = 0.42;
        let far_hills = 0.55 + 0.06 * (x * 9.0).sin() + 0.04 * (x * 23.0 + 1.0).sin();
        let near_hills = 0.47 + 0.08 * (x * 5.0 + 2.0).sin() + 0.03 * (x * 17.0).sin();
        let mut c = if y > far_hills {
            let sky = mix([0.95, 0.6, 0.3], [0.25, 0.45, 0.85], (y - far_hills) / (1.0 - far_hills) * 1.4);
            let sun = ((x - 0.7).powi(2) + (y - 0.72).powi(2)).sqrt();
            mix(sky, [1.0, 0.95, 0.7], 1.0 - (sun - 0.06) / 0.015)
        } else if y > near_hills {
            mix([0.35, 0.45, 0.6], [0.45, 0.55, 0.7], (y - near_hills) * 8.0)
        } else if y > horizon {
            mix([0.2, 0.4, 0.15], [0.35, 0.55, 0.2], fbm(x * 12.0, y * 12.0, 7))
        } else {
            // The lake mirrors the sky, darker, with ripples.
            let ripple = 0.5 + 0.5 * ((y * 90.0) + 4.0 * fbm(x * 8.0, y * 30.0, 3)).sin();
            mix([0.15, 0.25, 0.45], [0.6, 0.5, 0.45], ripple * (1.0 - (horizon - y) * 2.0) * 0.6)
        };
        for ch in &mut c {
            *ch *= 1.0 + 0.25 * stroke;
        }
        image::Rgb(c.map(byte))
    })
}

/// Pillow-shaped tiles: flat tops, rounded edges, a grout groove between.
fn tiles_height() -> image::GrayImage {
    let size = 256u32;
    let tile = size as f32 / 4.0;
    image::GrayImage::from_fn(size, size, |px, py| {
        let (fx, fy) = ((px as f32 + 0.5) % tile / tile, (py as f32 + 0.5) % tile / tile);
        // Distance to the tile's nearest edge, in tile units.
        let edge = fx.min(1.0 - fx).min(fy).min(1.0 - fy);
        let grout = 0.04;
        let height = if edge < grout { 0.1 } else { 0.1 + 0.9 * ((edge - grout) / 0.12).min(1.0).powf(0.5) };
        image::Luma([byte(height)])
    })
}

/// Brass with a staggered grid of round holes (alpha 0), edges antialiased.
fn perforated() -> image::RgbaImage {
    let size = 256u32;
    let pitch = size as f32 / 8.0;
    image::RgbaImage::from_fn(size, size, |px, py| {
        let (x, y) = (px as f32 + 0.5, py as f32 + 0.5);
        let row = (y / pitch).floor();
        let shift = if row as i32 % 2 == 0 { 0.0 } else { 0.5 * pitch };
        let cx = ((x - shift) / pitch).floor() * pitch + shift + 0.5 * pitch;
        let cy = row * pitch + 0.5 * pitch;
        let d = ((x - cx).powi(2) + (y - cy).powi(2)).sqrt();
        let alpha = ((d - 0.3 * pitch) / 1.0 + 0.5).clamp(0.0, 1.0);
        image::Rgba([byte(0.8), byte(0.62), byte(0.3), byte(alpha)])
    })
}

/// The height of staggered bricks (8 rows of 4, 256 x 256 texels, row y
/// from the top): 0 in the mortar, bevelled up to 1 on each brick, each
/// brick slightly tilted and grained. Periodic, so the map tiles.
fn brick_height(px: i32, py: i32) -> f32 {
    let (size, brick_w, brick_h) = (256, 64, 32);
    let (px, py) = (px.rem_euclid(size), py.rem_euclid(size));
    let row = py / brick_h;
    let x = (px + if row % 2 == 1 { brick_w / 2 } else { 0 }).rem_euclid(size);
    let col = x / brick_w;
    let (fx, fy) = ((x % brick_w) as f32 + 0.5, (py % brick_h) as f32 + 0.5);
    // Distance to the brick's nearest edge, in texels.
    let edge = fx.min(brick_w as f32 - fx).min(fy).min(brick_h as f32 - fy);
    let (mortar, bevel) = (2.5, 5.0);
    if edge < mortar {
        return 0.0;
    }
    let t = ((edge - mortar) / bevel).min(1.0);
    let tilt = (hash(col, row, 5) - 0.5) * (fx / brick_w as f32 - 0.5)
        + (hash(col, row, 6) - 0.5) * (fy / brick_h as f32 - 0.5);
    let grain = 0.5 * (hash(px, py, 9) - 0.5) + 0.5 * ((px as f32 * 0.4).sin() * (py as f32 * 0.7).sin());
    t * t * (3.0 - 2.0 * t) + 0.6 * tilt + 0.04 * grain
}

/// The UDIM tiles of the crate and each one's wood colour (as stored: sRGB).
const PLANK_TILES: [(u32, [f32; 3]); 4] =
    [(1001, [0.62, 0.42, 0.24]), (1002, [0.6, 0.16, 0.12]), (1011, [0.85, 0.7, 0.45]), (1012, [0.2, 0.45, 0.5])];

/// One 64 x 64 tile of four horizontal planks in `wood`: grain along the
/// planks, a dark seam between them and a nail at each end.
fn planks(number: u32, wood: [f32; 3]) -> image::RgbImage {
    image::RgbImage::from_fn(64, 64, |px, py| {
        let (x, y) = (px as f32 + 0.5, py as f32 + 0.5);
        let plank = py / 16;
        let grain = fbm(x / 24.0, y / 2.0 + plank as f32 * 7.0, number);
        let mut c = wood.map(|w| w * (0.75 + 0.5 * grain));
        let seam = py % 16 == 0;
        let nail = [6.0, 58.0].iter().any(|&nx| (x - nx).powi(2) + (y - (plank as f32 * 16.0 + 8.0)).powi(2) < 2.5);
        if seam || nail {
            c = c.map(|w| w * 0.3);
        }
        image::Rgb(c.map(byte))
    })
}

/// [`brick_height`]'s normals by central differences, encoded `(n + 1) / 2`
/// with green up the picture (OpenGL), as 8-bit RGB.
fn bricks_normal() -> image::RgbImage {
    let slope = 2.0;
    image::RgbImage::from_fn(256, 256, |px, py| {
        let (x, y) = (px as i32, py as i32);
        let dx = 0.5 * (brick_height(x + 1, y) - brick_height(x - 1, y));
        let dy_up = 0.5 * (brick_height(x, y - 1) - brick_height(x, y + 1));
        let n = [-dx * slope, -dy_up * slope, 1.0];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        image::Rgb(n.map(|c| byte(0.5 * c / len + 0.5)))
    })
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/textures");
    std::fs::create_dir_all(&dir)?;
    painting().save(dir.join("painting.png"))?;
    tiles_height().save(dir.join("tiles_height.png"))?;
    perforated().save(dir.join("perforated.png"))?;
    bricks_normal().save(dir.join("bricks_normal.png"))?;
    std::fs::create_dir_all(dir.join("udim"))?;
    for (number, wood) in PLANK_TILES {
        planks(number, wood).save(dir.join(format!("udim/planks.{number}.png")))?;
    }
    println!(
        "wrote painting.png, tiles_height.png, perforated.png, bricks_normal.png and udim/planks.*.png to {}",
        dir.display()
    );
    Ok(())
}
