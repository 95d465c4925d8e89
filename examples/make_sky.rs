//! Writes `examples/textures/sky.exr`, the environment of the environment-lit
//! comparison scene (`examples/envlight.tsl`, `scripts/peers/envlight.xml`):
//! a 512 x 256 lat-long sky in TSL's convention (direction `d` at
//! `u = 0.5 + atan2(d.x, -d.z) / 2 pi` across, `v = acos(d.y) / pi` down, +y
//! up; texel centres at half-integers), half-float RGB, ZIP compressed.
//!
//! - The sky: a gradient from a bright horizon (1.1, 1.05, 1.0) to a blue
//!   zenith (0.18, 0.32, 0.67), a warm glow around the sun, and a dark
//!   ground (0.18, 0.16, 0.14) below the horizon, blended across it over
//!   +-2 degrees.
//! - The sun: a disk of radius 1 degree at elevation 35 degrees, toward
//!   (-0.6, 0, -0.8) across (behind the spheres, to the left, seen from the
//!   scene's camera on +z), radiance (3200, 3000, 2700): about 5,000 times
//!   the sky's, and about half of the light on a horizontal surface.
//!
//! Each texel is the mean radiance over its solid angle (supersampled, 32 x 32
//! near the sun), so the image integrates to the analytic sky's power.
//! Mitsuba reads lat-long maps in another convention; the comparison script
//! converts this file for it (`scripts/peers/envmap_for_mitsuba.py`).
//!
//! ```sh
//! cargo run --release --example make_sky
//! ```
//!
//! The output is the same bytes on every run; the image is committed.

use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Image, ImageAttributes, Layer, LayerAttributes, WritableImage, f16,
};
use std::f64::consts::PI;

const WIDTH: usize = 512;
const HEIGHT: usize = 256;
const HORIZON: [f64; 3] = [1.1, 1.05, 1.0];
const ZENITH: [f64; 3] = [0.18, 0.32, 0.67];
const GROUND: [f64; 3] = [0.18, 0.16, 0.14];
const GLOW: [f64; 3] = [1.2, 0.9, 0.55];
const SUN: [f64; 3] = [3200.0, 3000.0, 2700.0];
const SUN_RADIUS_DEG: f64 = 1.0;
const SUN_ELEVATION_DEG: f64 = 35.0;
/// The sun's direction across, (x, z).
const SUN_ACROSS: [f64; 2] = [-0.6, -0.8];

type V3 = [f64; 3];

fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn lerp(a: V3, b: V3, t: f64) -> V3 {
    [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t]
}

fn sun_dir() -> V3 {
    let (s, c) = SUN_ELEVATION_DEG.to_radians().sin_cos();
    [c * SUN_ACROSS[0], s, c * SUN_ACROSS[1]]
}

/// The direction at lat-long coordinates (u, v) in TSL's convention.
fn direction(u: f64, v: f64) -> V3 {
    let (phi, theta) = (2.0 * PI * (u - 0.5), PI * v);
    [theta.sin() * phi.sin(), theta.cos(), -theta.sin() * phi.cos()]
}

/// The analytic sky's radiance toward unit direction `d`.
fn radiance(d: V3, sun: V3) -> V3 {
    let gamma = dot(d, sun).clamp(-1.0, 1.0).acos();
    let up = d[1].max(0.0);
    let glow = 1.5 * (-gamma / 0.25).exp();
    let sky = lerp(HORIZON, ZENITH, up.sqrt());
    let sky = [sky[0] + glow * GLOW[0], sky[1] + glow * GLOW[1], sky[2] + glow * GLOW[2]];
    let elevation = d[1].clamp(-1.0, 1.0).asin().to_degrees();
    let t = ((elevation + 2.0) / 4.0).clamp(0.0, 1.0);
    let mut l = lerp(GROUND, sky, t * t * (3.0 - 2.0 * t));
    if gamma.to_degrees() < SUN_RADIUS_DEG {
        for c in 0..3 {
            l[c] += SUN[c];
        }
    }
    l
}

/// The mean radiance over texel (i, j)'s solid angle.
fn texel(i: usize, j: usize, sun: V3) -> V3 {
    let centre = direction((i as f64 + 0.5) / WIDTH as f64, (j as f64 + 0.5) / HEIGHT as f64);
    let near_sun = dot(centre, sun).clamp(-1.0, 1.0).acos().to_degrees() < 4.0 * SUN_RADIUS_DEG;
    let n = if near_sun { 32 } else { 4 };
    let (mut sum, mut weight) = ([0.0; 3], 0.0);
    for b in 0..n {
        let v = (j as f64 + (b as f64 + 0.5) / n as f64) / HEIGHT as f64;
        let w = (PI * v).sin();
        for a in 0..n {
            let u = (i as f64 + (a as f64 + 0.5) / n as f64) / WIDTH as f64;
            let l = radiance(direction(u, v), sun);
            for c in 0..3 {
                sum[c] += w * l[c];
            }
            weight += w;
        }
    }
    sum.map(|s| s / weight)
}

fn main() {
    let sun = sun_dir();
    let mut planes = [Vec::new(), Vec::new(), Vec::new()];
    // Irradiance (luminance) on a surface facing up: all of it, from the
    // texels, and the sun's share, analytic.
    let lum = |c: V3| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    let e_sun = lum(SUN) * 2.0 * PI * (1.0 - SUN_RADIUS_DEG.to_radians().cos()) * sun[1];
    let mut e_all = 0.0;
    for j in 0..HEIGHT {
        for i in 0..WIDTH {
            let t = texel(i, j, sun);
            let d = direction((i as f64 + 0.5) / WIDTH as f64, (j as f64 + 0.5) / HEIGHT as f64);
            let solid_angle =
                (2.0 * PI / WIDTH as f64) * (PI / HEIGHT as f64) * (PI * (j as f64 + 0.5) / HEIGHT as f64).sin();
            e_all += lum(t) * d[1].max(0.0) * solid_angle;
            for c in 0..3 {
                planes[c].push(f16::from_f64(t[c]));
            }
        }
    }
    let [r, g, b] = planes;
    let channels = vec![
        AnyChannel::new("R", FlatSamples::F16(r)),
        AnyChannel::new("G", FlatSamples::F16(g)),
        AnyChannel::new("B", FlatSamples::F16(b)),
    ];
    let layer = Layer::new(
        (WIDTH, HEIGHT),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels.into()),
    );
    let image = Image::new(ImageAttributes::new(exr::prelude::IntegerBounds::from_dimensions((WIDTH, HEIGHT))), layer);
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/textures/sky.exr");
    image.write().to_file(&path).unwrap_or_else(|e| panic!("cannot write {}: {e}", path.display()));
    println!(
        "wrote {}: sun toward ({:.4}, {:.4}, {:.4}); horizontal irradiance (luminance) {e_all:.3}, of it the sun {e_sun:.3}",
        path.display(),
        sun[0],
        sun[1],
        sun[2]
    );
}
