//! The environment: light from infinitely far away, given by a lat-long
//! image or a constant color, scaled and rotated. Rays that leave the scene
//! see it, and the path tracer samples it as a light: an image in
//! proportion to its radiance (a [`Distribution2D`] over its texels), a
//! constant uniformly over the sphere.
//!
//! Invariants: [`Environment::sample`] and [`Environment::pdf`] are
//! densities per unit solid angle of world directions and agree with each
//! other; the density is positive wherever the radiance is, so sampling
//! the environment alone is unbiased. An unrotated environment of scale 1
//! looks up exactly what the lat-long convention gives, bit for bit.

use super::Vec3;
use super::sampling::{self, Distribution2D};
use crate::color::HERO_LANES;
use glam::Mat3A;
use std::f32::consts::{PI, TAU};

/// A lat-long image: `u = 0.5 + atan2(x, -z) / 2 pi` across, `v = acos(y) /
/// pi` down (+y at the top row), looked up bilinearly (wrapping across,
/// clamped at the poles). Texels hold the color model's lanes, row by row.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvironmentMap {
    pub width: u32,
    pub height: u32,
    pub lanes: usize,
    pub texels: Vec<f32>,
}

/// What the environment's radiance comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum EnvironmentSource {
    /// The same radiance (lanes) from every direction.
    Constant(Vec<f32>),
    Image(EnvironmentMap),
}

/// Light arriving from infinitely far away (see the module documentation).
#[derive(Debug, Clone)]
pub struct Environment {
    source: EnvironmentSource,
    /// Texels by their share of the light, for images.
    distribution: Option<Distribution2D>,
    /// The bilinear warp within cells, for images cut into 2 x 2 cells a
    /// texel.
    cell_warp: Option<CellWarp>,
    scale: f32,
    /// Environment to world and back; `None` without a rotation, so that
    /// lookups are exactly those of the lat-long convention.
    rotation: Option<(Mat3A, Mat3A)>,
    /// The integral over the sphere of the radiance's mean lane, scale
    /// included (W/m², the irradiance a sphere of unit cross-section would
    /// see from all around, over pi).
    integral: f32,
}

/// Two pi squared: the Jacobian of the lat-long map is `2 pi^2 sin(theta)`.
const TWO_PI_SQUARED: f32 = 2.0 * PI * PI;

impl Environment {
    /// An environment of `source` times `scale`, turned by `rotate`
    /// (degrees about x, then y, then z, as an object's `rotate`; world =
    /// R · environment). A negative or non-finite scale counts as zero
    /// (the scene builder refuses them before), and so does a texel lane
    /// that is not a number (the scene loader replaced and reported those
    /// of a file already; a host's own map is held to the same rule, so no
    /// NaN reaches the sampling distribution).
    pub fn new(mut source: EnvironmentSource, scale: f32, rotate: Vec3) -> Environment {
        if let EnvironmentSource::Image(map) = &mut source {
            map.texels.iter_mut().filter(|v| !v.is_finite()).for_each(|v| *v = 0.0);
        }
        let scale = if scale.is_finite() && scale > 0.0 { scale } else { 0.0 };
        let rotation = (rotate != Vec3::ZERO).then(|| {
            let r = Mat3A::from_rotation_z(rotate.z.to_radians())
                * Mat3A::from_rotation_y(rotate.y.to_radians())
                * Mat3A::from_rotation_x(rotate.x.to_radians());
            (r, r.transpose())
        });
        let (distribution, cell_warp, integral) = match &source {
            EnvironmentSource::Constant(c) => (None, None, 4.0 * PI * mean_lane(c)),
            EnvironmentSource::Image(map) => {
                // Each texel's mean lane, which both the distribution and
                // the warp within its cells follow.
                let (width, height) = (map.width as usize, map.height as usize);
                let level: Vec<f32> = map.texels.chunks(map.lanes.max(1)).take(width * height).map(mean_lane).collect();
                let (distribution, integral) = image_distribution(&level, width, height);
                (Some(distribution), CellWarp::new(level, width, height), integral)
            }
        };
        Environment { source, distribution, cell_warp, scale, rotation, integral: integral * scale }
    }

    /// Whether no direction carries light (then it is no light).
    pub fn is_black(&self) -> bool {
        self.integral <= 0.0 || !self.integral.is_finite()
    }

    /// The radiance arriving along `-dir` (seen looking along unit `dir`),
    /// into the first lanes of `out`. With hero `wavelengths`, a constant
    /// holds a curve at 64 bin centres (interpolated at them) and an image
    /// linear sRGB texels (the bilinear lookup upsampled by Jakob–Hanika).
    pub fn radiance(&self, dir: Vec3, wavelengths: Option<&[f32; HERO_LANES]>, out: &mut [f32]) {
        let d = match &self.rotation {
            Some((_, to_env)) => *to_env * dir,
            None => dir,
        };
        let lanes = match (&self.source, wavelengths) {
            (EnvironmentSource::Constant(c), None) => {
                out[..c.len()].copy_from_slice(c);
                c.len()
            }
            (EnvironmentSource::Constant(c), Some(wl)) => {
                for (o, l) in out.iter_mut().zip(wl) {
                    *o = super::wavelengths::interpolate_bins(c, *l);
                }
                HERO_LANES.min(out.len())
            }
            (EnvironmentSource::Image(map), None) => {
                lookup(map, d, out);
                map.lanes
            }
            (EnvironmentSource::Image(map), Some(wl)) => {
                let mut rgb = [0.0f32; 3];
                lookup(map, d, &mut rgb);
                let s = crate::color::jakob_hanika::upsample(rgb);
                for (o, l) in out.iter_mut().zip(wl) {
                    *o = s.eval(*l);
                }
                HERO_LANES.min(out.len())
            }
        };
        if self.scale != 1.0 {
            for o in &mut out[..lanes] {
                *o *= self.scale;
            }
        }
    }

    /// A direction toward the environment (unit, world space) chosen in
    /// proportion to its radiance, with its solid-angle density; `None`
    /// when the environment is black or the sample fell on a pole.
    pub fn sample(&self, u: [f32; 2]) -> Option<(Vec3, f32)> {
        if self.is_black() {
            return None;
        }
        let Some(distribution) = &self.distribution else {
            // A constant: uniform over the sphere (rotation changes nothing).
            return Some((sampling::square_to_uniform_sphere(u), sampling::UNIFORM_SPHERE_PDF));
        };
        let ([x, y], pdf_uv) = distribution.sample(u);
        let ([x, y], pdf_uv) = match &self.cell_warp {
            Some(warp) => warp.warp([x, y], pdf_uv),
            None => ([x, y], pdf_uv),
        };
        let (sin_theta, cos_theta) = (y * PI).sin_cos();
        if pdf_uv <= 0.0 || sin_theta <= 0.0 {
            return None;
        }
        let (sin_phi, cos_phi) = ((x - 0.5) * TAU).sin_cos();
        let d = Vec3::new(sin_theta * sin_phi, cos_theta, -sin_theta * cos_phi);
        let wi = match &self.rotation {
            Some((to_world, _)) => *to_world * d,
            None => d,
        };
        Some((wi, pdf_uv / (TWO_PI_SQUARED * sin_theta)))
    }

    /// The solid-angle density with which [`Environment::sample`] picks
    /// the unit direction `wi`.
    pub fn pdf(&self, wi: Vec3) -> f32 {
        if self.is_black() {
            return 0.0;
        }
        let Some(distribution) = &self.distribution else { return sampling::UNIFORM_SPHERE_PDF };
        let d = match &self.rotation {
            Some((_, to_env)) => *to_env * wi,
            None => wi,
        };
        let (u, v) = lat_long(d);
        // From the direction, not from `v`: acos loses precision near the poles.
        let sin_theta = (d.x * d.x + d.z * d.z).sqrt();
        if sin_theta <= 0.0 || !sin_theta.is_finite() {
            return 0.0;
        }
        let within = self.cell_warp.as_ref().map_or(1.0, |warp| warp.density([u, v]));
        distribution.pdf([u, v]) * within / (TWO_PI_SQUARED * sin_theta)
    }

    /// The power the environment sends into a scene of bounding radius
    /// `scene_radius`, for choosing lights by power: all of it crosses the
    /// scene's cross-section pi r², so `pi r² · ∫ L dω` (pbrt-v4's `Phi` of
    /// infinite lights), with L the mean lane.
    pub fn power(&self, scene_radius: f32) -> f32 {
        PI * scene_radius * scene_radius * self.integral
    }
}

/// The mean of the non-negative parts of a color's lanes.
fn mean_lane(lanes: &[f32]) -> f32 {
    if lanes.is_empty() {
        return 0.0;
    }
    lanes.iter().map(|x| if *x > 0.0 { *x } else { 0.0 }).sum::<f32>() / lanes.len() as f32
}

/// The lat-long coordinates of a unit direction (before any wrapping).
fn lat_long(d: Vec3) -> (f32, f32) {
    (0.5 + d.x.atan2(-d.z) / TAU, d.y.clamp(-1.0, 1.0).acos() / PI)
}

/// Bilinear lookup along unit `d`, wrapping across and clamped at the poles.
fn lookup(map: &EnvironmentMap, d: Vec3, out: &mut [f32]) {
    let EnvironmentMap { width, height, lanes, texels } = map;
    if *width == 0 || *height == 0 || texels.len() < *width as usize * *height as usize * lanes {
        out[..*lanes].fill(0.0);
        return;
    }
    let (u, v) = lat_long(d);
    let (w, h) = (*width as i64, *height as i64);
    // Texel centres at half-integers; NaN directions give texel 0.
    let (x, y) = (u * *width as f32 - 0.5, v * *height as f32 - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (fx, fy) = (if fx.is_finite() { fx } else { 0.0 }, if fy.is_finite() { fy } else { 0.0 });
    let column = |i: i64| (i.rem_euclid(w)) as usize;
    let row = |j: i64| j.clamp(0, h - 1) as usize;
    let (x0, y0) = (x0 as i64, y0 as i64);
    let corners = [
        (column(x0), row(y0), (1.0 - fx) * (1.0 - fy)),
        (column(x0 + 1), row(y0), fx * (1.0 - fy)),
        (column(x0), row(y0 + 1), (1.0 - fx) * fy),
        (column(x0 + 1), row(y0 + 1), fx * fy),
    ];
    out[..*lanes].fill(0.0);
    for (cx, cy, weight) in corners {
        let at = (cy * *width as usize + cx) * lanes;
        for (o, t) in out[..*lanes].iter_mut().zip(&texels[at..at + lanes]) {
            *o += weight * t;
        }
    }
}

/// The radiance (mean lane) of an image cut into 2 x 2 cells a texel, for
/// sampling within a cell. Each such cell lies inside one patch of the
/// bilinear lookup (patches run between texel centres, cells between
/// multiples of half a texel), so the lookup there is the bilinear blend of
/// its values at the cell's corners: sampling the cell in proportion to
/// that blend makes the density follow the radiance exactly but for
/// `sin(theta)` (pbrt-v4's `SampleBilinear`). Beside a small bright sun,
/// where the radiance changes severalfold within one cell, the piecewise
/// constant density alone left the light samples' weights varying as much.
#[derive(Debug, Clone)]
struct CellWarp {
    width: usize,
    height: usize,
    /// Each texel's mean lane, row by row.
    level: Vec<f32>,
}

impl CellWarp {
    /// The warp over `level` (each texel's mean lane, row by row), when
    /// the image is cut into 2 x 2 cells a texel.
    fn new(level: Vec<f32>, width: usize, height: usize) -> Option<CellWarp> {
        let usable = cells_per_texel(width) == 2 && width > 0 && height > 0 && level.len() == width * height;
        usable.then_some(CellWarp { width, height, level })
    }

    /// The bilinear lookup of the level at texel coordinates `(x, y)`
    /// (texel centres at half-integers), as [`lookup`] blends.
    fn level_at(&self, x: f32, y: f32) -> f32 {
        let (x, y) = (x - 0.5, y - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (w, h) = (self.width as i64, self.height as i64);
        let at = |i: i64, j: i64| self.level[(j.clamp(0, h - 1) * w + i.rem_euclid(w)) as usize];
        let (i, j) = (x0 as i64, y0 as i64);
        (1.0 - fx) * (1.0 - fy) * at(i, j)
            + fx * (1.0 - fy) * at(i + 1, j)
            + (1.0 - fx) * fy * at(i, j + 1)
            + fx * fy * at(i + 1, j + 1)
    }

    /// The cell holding `point` of the unit square, where in it the point
    /// lies (in [0, 1]²), and the level at the cell's corners: (x0, y0),
    /// (x1, y0), (x0, y1), (x1, y1).
    fn cell(&self, [x, y]: [f32; 2]) -> ([f32; 2], [f32; 4]) {
        let (cw, ch) = (2 * self.width, 2 * self.height);
        let index = |t: f32, n: usize| {
            let k = (t * n as f32).floor();
            if k.is_nan() { 0 } else { (k.max(0.0) as usize).min(n - 1) }
        };
        let (ci, cj) = (index(x, cw), index(y, ch));
        let within = [(x * cw as f32 - ci as f32).clamp(0.0, 1.0), (y * ch as f32 - cj as f32).clamp(0.0, 1.0)];
        let (x0, y0) = (ci as f32 * 0.5, cj as f32 * 0.5);
        let corners = [
            self.level_at(x0, y0),
            self.level_at(x0 + 0.5, y0),
            self.level_at(x0, y0 + 0.5),
            self.level_at(x0 + 0.5, y0 + 0.5),
        ];
        (within, corners)
    }

    /// The point the distribution drew (uniform within its cell, of
    /// density `pdf`) moved within its cell in proportion to the bilinear
    /// level, with its new density.
    fn warp(&self, point: [f32; 2], pdf: f32) -> ([f32; 2], f32) {
        let ([sx, sy], c) = self.cell(point);
        let ty = sample_linear(sy, c[0] + c[1], c[2] + c[3]);
        let tx = sample_linear(sx, lerp(ty, c[0], c[2]), lerp(ty, c[1], c[3]));
        let (cw, ch) = ((2 * self.width) as f32, (2 * self.height) as f32);
        let moved = [
            ((point[0] * cw).floor().clamp(0.0, cw - 1.0) + tx) / cw,
            ((point[1] * ch).floor().clamp(0.0, ch - 1.0) + ty) / ch,
        ];
        (
            [moved[0].min(sampling::ONE_MINUS_EPSILON), moved[1].min(sampling::ONE_MINUS_EPSILON)],
            pdf * relative(c, tx, ty),
        )
    }

    /// The density within its cell at `point`, relative to uniform.
    fn density(&self, point: [f32; 2]) -> f32 {
        let ([tx, ty], c) = self.cell(point);
        relative(c, tx, ty)
    }
}

fn lerp(t: f32, a: f32, b: f32) -> f32 {
    (1.0 - t) * a + t * b
}

/// The bilinear blend of corners `c` at `(tx, ty)` over its mean: the
/// density [`CellWarp::warp`] samples, relative to uniform (1 when the
/// corners are all zero, where the warp leaves points uniform).
fn relative(c: [f32; 4], tx: f32, ty: f32) -> f32 {
    let mean = 0.25 * (c[0] + c[1] + c[2] + c[3]);
    if mean <= 0.0 {
        return 1.0;
    }
    lerp(ty, lerp(tx, c[0], c[1]), lerp(tx, c[2], c[3])) / mean
}

/// A point of [0, 1] with density proportional to `(1 - x) a + x b`, from
/// the uniform `u` (pbrt-v4's `SampleLinear`; uniform when both are zero).
fn sample_linear(u: f32, a: f32, b: f32) -> f32 {
    if a + b <= 0.0 {
        return u;
    }
    if u == 0.0 && a == 0.0 {
        return 0.0;
    }
    let x = u * (a + b) / (a + lerp(u, a * a, b * b).sqrt());
    x.min(sampling::ONE_MINUS_EPSILON)
}

/// Cells of the sampling distribution per texel side: 2 x 2 for images up
/// to 512 texels wide, so that the piecewise-constant density follows the
/// bilinear lookup beside a small bright sun (where one cell a texel
/// leaves the radiance over the density varying several times within a
/// cell: noise). Measured on envlight at 64 spp: 2 x 2 cells cut the clay
/// sphere's RMSE by 14% for 10% more time; 4 x 4 by 18% for 60% more (the
/// larger distribution misses the caches), so not worth it; wide images
/// have small texels already.
fn cells_per_texel(width: usize) -> usize {
    if width <= 512 { 2 } else { 1 }
}

/// The sampling distribution of an image whose texels' mean lanes are
/// `level` (`w x h`, row by row) and its radiance integral.
///
/// Each texel's footprint in (u, v) is cut into `s x s` cells
/// ([`cells_per_texel`], 1 or 2); a cell's weight is the mean of the bilinear
/// lookup over it, times `sin(theta)` at its centre (rows near the poles
/// cover less solid angle). With `s` even every cell lies inside one
/// bilinear patch, where the mean is the value at the centre; with `s = 1`
/// it is the 3 x 3 texels around it with weights 1/8, 3/4, 1/8 along each
/// axis (wrapping across, clamped at the poles). Either way a cell has
/// weight wherever the lookup can be positive in it, which a texel's own
/// value alone would miss beside a lone bright texel.
fn image_distribution(level: &[f32], w: usize, h: usize) -> (Distribution2D, f32) {
    if w == 0 || h == 0 || level.len() < w * h {
        return (Distribution2D::new(&[], 1, 1), 0.0);
    }
    let at = |i: isize, j: isize| level[j.clamp(0, h as isize - 1) as usize * w + i.rem_euclid(w as isize) as usize];
    let s = cells_per_texel(w);
    let (cw, ch) = (w * s, h * s);
    let mut weights = vec![0.0f32; cw * ch];
    for cj in 0..ch {
        let sin_centre = ((cj as f32 + 0.5) * PI / ch as f32).sin();
        for ci in 0..cw {
            let mean = if s == 1 {
                const TENT: [(isize, f32); 3] = [(-1, 0.125), (0, 0.75), (1, 0.125)];
                let mut mean = 0.0;
                for (dj, wj) in TENT {
                    for (di, wi) in TENT {
                        mean += wi * wj * at(ci as isize + di, cj as isize + dj);
                    }
                }
                mean
            } else {
                // The bilinear lookup at the cell's centre, in texel units
                // (texel centres at half-integers).
                let x = (ci as f32 + 0.5) / s as f32 - 0.5;
                let y = (cj as f32 + 0.5) / s as f32 - 0.5;
                let (x0, y0) = (x.floor(), y.floor());
                let (fx, fy) = (x - x0, y - y0);
                let (i0, j0) = (x0 as isize, y0 as isize);
                (1.0 - fx) * (1.0 - fy) * at(i0, j0)
                    + fx * (1.0 - fy) * at(i0 + 1, j0)
                    + (1.0 - fx) * fy * at(i0, j0 + 1)
                    + fx * fy * at(i0 + 1, j0 + 1)
            };
            weights[cj * cw + ci] = mean * sin_centre;
        }
    }
    let mut integral = 0.0f64;
    for j in 0..h {
        let theta = |k: usize| k as f32 * PI / h as f32;
        // The solid angle of one texel of this row.
        let solid = TAU / w as f32 * (theta(j).cos() - theta(j + 1).cos());
        integral += level[j * w..(j + 1) * w].iter().map(|l| f64::from(*l) * f64::from(solid)).sum::<f64>();
    }
    (Distribution2D::new(&weights, cw, ch), integral as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::sampling::Sampler;
    use crate::test_support::{chi2_p_value, direction_chi2};

    /// A 16 x 8 sky: a gradient, a bright "sun" texel, a lone texel at the
    /// top row and one on the seam, and a black band.
    fn sky() -> EnvironmentMap {
        let (w, h) = (16usize, 8usize);
        let mut texels = Vec::new();
        for j in 0..h {
            for i in 0..w {
                let mut v = if j == 5 { 0.0 } else { 0.2 + 0.1 * j as f32 + 0.02 * i as f32 };
                if (i, j) == (11, 2) {
                    v = 50.0;
                }
                texels.extend([v, 0.5 * v, 2.0 * v]);
            }
        }
        EnvironmentMap { width: w as u32, height: h as u32, lanes: 3, texels }
    }

    /// Only three lit texels in the dark, one on a pole row and one on the seam.
    fn sparse() -> EnvironmentMap {
        let (w, h) = (12usize, 6usize);
        let mut texels = vec![0.0; w * h * 3];
        for (i, j) in [(4, 2), (0, 0), (11, 4)] {
            texels[(j * w + i) * 3 + 1] = 3.0;
        }
        EnvironmentMap { width: w as u32, height: h as u32, lanes: 3, texels }
    }

    /// A host's map with texels that are not numbers samples as the map
    /// with 0 there: no NaN or infinity reaches the distribution.
    #[test]
    fn texels_that_are_not_numbers_count_as_zero() {
        let clean = Environment::new(EnvironmentSource::Image(sky()), 1.0, Vec3::ZERO);
        for bad in [f32::INFINITY, f32::NAN, f32::NEG_INFINITY] {
            let mut map = sky();
            let mut zeroed = sky();
            for k in [(2 * 16 + 11) * 3, 7 * 16 * 3 + 1] {
                map.texels[k] = bad;
                zeroed.texels[k] = 0.0;
            }
            let env = Environment::new(EnvironmentSource::Image(map), 1.0, Vec3::ZERO);
            let reference = Environment::new(EnvironmentSource::Image(zeroed), 1.0, Vec3::ZERO);
            assert!(!env.is_black() && env.integral.is_finite(), "{bad}");
            assert_eq!(env.integral, reference.integral, "{bad}");
            assert!(env.integral < clean.integral, "{bad}: the sun is gone");
            for k in 0..64 {
                let u = Sampler::new(5, k, 0, 0).next_2d();
                let (a, b) = (env.sample(u), reference.sample(u));
                assert_eq!(a.map(|(d, p)| (d.to_array(), p)), b.map(|(d, p)| (d.to_array(), p)), "{bad}");
            }
        }
    }

    fn environments() -> Vec<(&'static str, Environment)> {
        let turn = Vec3::new(30.0, -70.0, 15.0);
        vec![
            ("constant", Environment::new(EnvironmentSource::Constant(vec![0.5, 1.0, 2.0]), 1.0, Vec3::ZERO)),
            ("rotated constant", Environment::new(EnvironmentSource::Constant(vec![1.0; 3]), 2.0, turn)),
            ("image", Environment::new(EnvironmentSource::Image(sky()), 1.0, Vec3::ZERO)),
            ("rotated image", Environment::new(EnvironmentSource::Image(sky()), 3.0, turn)),
            ("sparse image", Environment::new(EnvironmentSource::Image(sparse()), 1.0, Vec3::new(0.0, 90.0, 0.0))),
        ]
    }

    /// Midpoint rule over (cos theta, phi) about +z with `n x 2n` points.
    fn over_sphere(n: usize, mut f: impl FnMut(Vec3) -> f64) -> f64 {
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..2 * n {
                let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
                let phi = TAU * (j as f32 + 0.5) / (2 * n) as f32;
                let r = (1.0 - z * z).max(0.0).sqrt();
                sum += f(Vec3::new(r * phi.cos(), r * phi.sin(), z));
            }
        }
        sum * 4.0 * std::f64::consts::PI / (2 * n * n) as f64
    }

    #[test]
    fn pdfs_integrate_to_one_over_the_sphere() {
        for (name, env) in environments() {
            let integral = over_sphere(800, |d| f64::from(env.pdf(d)));
            assert!((integral - 1.0).abs() < 5e-3, "{name}: {integral}");
        }
    }

    #[test]
    fn samples_follow_the_pdf() {
        // Bonferroni over the four environments.
        let alpha = 0.01 / 4.0;
        for (k, (name, env)) in environments().into_iter().enumerate() {
            if name == "sparse image" {
                // Too peaked for bins that cut across its cells: below.
                continue;
            }
            // A sample on a cell's edge may be looked up in the next cell.
            let disagree = std::cell::Cell::new(0);
            let p = direction_chi2(
                |u| {
                    let (wi, pdf) = env.sample(u).unwrap_or_else(|| panic!("{name}: no sample for {u:?}"));
                    assert!((wi.length() - 1.0).abs() < 1e-4, "{name}: {wi}");
                    if (pdf - env.pdf(wi)).abs() > 2e-3 * pdf {
                        disagree.set(disagree.get() + 1);
                    }
                    wi
                },
                |d| env.pdf(d),
                40 + k as u64,
                200_000,
            );
            assert!(p > alpha, "{name}: p = {p}");
            assert!(disagree.get() < 20, "{name}: {} samples' pdfs disagree with `pdf`", disagree.get());
        }
    }

    #[test]
    fn light_samples_weigh_the_same_but_for_sin_theta() {
        // Radiance over density, the weight a light sample carries, is the
        // environment's integral times the sin(theta) ratio within a cell
        // (within 0.8-1.2 away from the poles), even beside the bright
        // texel, where a density constant over each cell gave 0.003-3.7.
        let env = Environment::new(EnvironmentSource::Image(sky()), 1.0, Vec3::ZERO);
        let mut weights = Vec::new();
        for k in 0..20_000 {
            let (wi, pdf) = env.sample(Sampler::new(46, k, 0, 0).next_2d()).unwrap();
            if wi.y.abs() > (PI / 8.0).cos() {
                continue;
            }
            let mut radiance = [0.0f32; 3];
            env.radiance(wi, None, &mut radiance);
            weights.push(mean_lane(&radiance) / pdf / env.integral);
        }
        let (least, most) = weights.iter().fold((f32::MAX, 0.0f32), |(lo, hi), w| (lo.min(*w), hi.max(*w)));
        assert!(weights.len() > 10_000 && least > 0.75 && most < 1.3, "{} weights in {least}..{most}", weights.len());
    }

    #[test]
    fn peaked_images_are_sampled_by_their_cells() {
        // Directions turned back into the image's (u, v) and binned 2 x 2
        // a texel.
        let env = Environment::new(EnvironmentSource::Image(sparse()), 1.0, Vec3::new(0.0, 90.0, 0.0));
        let distribution = env.distribution.as_ref().unwrap();
        let to_env = env.rotation.unwrap().1;
        let (nu, nv, samples) = (24usize, 12usize, 200_000u32);
        let mut observed = vec![0.0; nu * nv];
        for k in 0..samples {
            let (wi, _) = env.sample(Sampler::new(45, k, 0, 0).next_2d()).unwrap();
            let (u, v) = lat_long(to_env * wi);
            let (i, j) = (((u * nu as f32) as usize).min(nu - 1), ((v * nv as f32) as usize).min(nv - 1));
            observed[j * nu + i] += 1.0;
        }
        // The density is constant on cells that divide the bins: the mean
        // over an 8 x 8 grid in each bin is exact.
        const SUB: usize = 8;
        let expected: Vec<f64> = (0..nu * nv)
            .map(|b| {
                let mut sum = 0.0;
                for k in 0..SUB * SUB {
                    let x = ((b % nu) as f32 + ((k % SUB) as f32 + 0.5) / SUB as f32) / nu as f32;
                    let y = ((b / nu) as f32 + ((k / SUB) as f32 + 0.5) / SUB as f32) / nv as f32;
                    sum += f64::from(distribution.pdf([x, y]));
                }
                sum / (SUB * SUB) as f64 / (nu * nv) as f64 * f64::from(samples)
            })
            .collect();
        let empty = observed.iter().zip(&expected).filter(|(o, e)| **e == 0.0 && **o > 0.0).count();
        assert_eq!(empty, 0, "samples in cells of zero weight");
        assert!(chi2_p_value(&observed, &expected) > 0.01);
    }

    #[test]
    fn the_pdf_is_positive_wherever_there_is_light() {
        for (name, env) in environments() {
            let mut out = [0.0f32; 3];
            let mut lit = 0;
            for i in 0..400 {
                for j in 0..800 {
                    // Directions by lat-long coordinates, poles and seam included.
                    let (theta, phi) = (PI * i as f32 / 399.0, TAU * j as f32 / 799.0);
                    let d = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
                    env.radiance(d, None, &mut out);
                    if out.iter().any(|x| *x > 0.0) {
                        lit += 1;
                        let pdf = env.pdf(d);
                        assert!(pdf > 0.0 || theta.sin() < 1e-6, "{name}: radiance {out:?} but pdf {pdf} at {d}");
                    }
                }
            }
            assert!(lit > 0, "{name}");
        }
    }

    #[test]
    fn the_integral_and_power_follow_the_radiance() {
        for (name, env) in environments() {
            let mut out = [0.0f32; 3];
            let numeric = over_sphere(400, |d| {
                env.radiance(d, None, &mut out);
                f64::from(mean_lane(&out))
            });
            // Texel sums against the bilinear lookup: close, not equal.
            assert!(
                (numeric - f64::from(env.integral)).abs() < 0.03 * numeric,
                "{name}: {numeric} vs {}",
                env.integral
            );
            assert!((env.power(2.0) - 4.0 * PI * env.integral).abs() < 1e-3 * env.power(2.0));
        }
    }

    #[test]
    fn rotation_turns_the_environment() {
        // Turned and scaled: the world direction R d sees what d saw, doubled.
        let plain = Environment::new(EnvironmentSource::Image(sky()), 1.0, Vec3::ZERO);
        let turned = Environment::new(EnvironmentSource::Image(sky()), 2.0, Vec3::new(0.0, 90.0, 0.0));
        let (mut a, mut b) = ([0.0f32; 3], [0.0f32; 3]);
        for d in [Vec3::new(0.3, 0.5, -0.8).normalize(), Vec3::new(-0.9, -0.1, 0.4).normalize(), Vec3::Y] {
            plain.radiance(d, None, &mut a);
            turned.radiance(Mat3A::from_rotation_y(90f32.to_radians()) * d, None, &mut b);
            for c in 0..3 {
                assert!((b[c] - 2.0 * a[c]).abs() < 1e-4 * (1.0 + a[c]), "{d}: {a:?} vs {b:?}");
            }
        }
    }

    #[test]
    fn black_and_degenerate_environments_are_no_light() {
        let black = Environment::new(EnvironmentSource::Constant(vec![0.0; 3]), 1.0, Vec3::ZERO);
        assert!(black.is_black() && black.sample([0.5, 0.5]).is_none() && black.pdf(Vec3::Y) == 0.0);
        let zero = EnvironmentMap { width: 4, height: 2, lanes: 1, texels: vec![0.0; 8] };
        let dark = Environment::new(EnvironmentSource::Image(zero), 1.0, Vec3::ZERO);
        assert!(dark.is_black() && dark.sample([0.1, 0.9]).is_none() && dark.power(10.0) == 0.0);
        let empty = EnvironmentMap { width: 0, height: 0, lanes: 3, texels: vec![] };
        assert!(Environment::new(EnvironmentSource::Image(empty), 1.0, Vec3::ZERO).is_black());
        let nan_scale = Environment::new(EnvironmentSource::Constant(vec![1.0]), f32::NAN, Vec3::ZERO);
        assert!(nan_scale.is_black());
    }
}
