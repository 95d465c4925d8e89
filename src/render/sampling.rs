//! Random numbers and the warps that turn them into directions and points.
//!
//! Invariant: a [`Sampler`]'s numbers are a pure function of (seed, pixel,
//! sample index, dimension): no state is shared between pixels or threads,
//! so renders are reproducible bit for bit however the work is split.
//! Every warp comes with its pdf, and the chi² tests below check each pair.

use super::Vec3;
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI, TAU};

/// Counter-based random numbers for one camera sample.
///
/// ```
/// use tsl::render::sampling::Sampler;
/// let mut a = Sampler::new(7, 10, 20, 3);
/// let mut b = Sampler::new(7, 10, 20, 3);
/// assert_eq!(a.next_1d(), b.next_1d());
/// assert!(a.next_1d() < 1.0);
/// ```
#[derive(Debug, Clone)]
pub struct Sampler {
    key: u64,
    dimension: u32,
}

/// A 64-bit finaliser (splitmix64's): every input bit affects every
/// output bit, so neighbouring keys give unrelated numbers.
pub fn mix64(mut x: u64) -> u64 {
    x ^= x >> 30;
    x = x.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x ^= x >> 27;
    x = x.wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

impl Sampler {
    pub fn new(seed: u64, px: u32, py: u32, sample: u32) -> Sampler {
        let pixel = (u64::from(px) << 32) | u64::from(py);
        let key = mix64(mix64(seed ^ 0x9e37_79b9_7f4a_7c15) ^ pixel);
        Sampler { key: mix64(key ^ u64::from(sample).wrapping_mul(0xd1b5_4a32_d192_ed03)), dimension: 0 }
    }

    /// Uniform in [0, 1): 24 random bits, so never 1.0.
    pub fn next_1d(&mut self) -> f32 {
        let bits = mix64(self.key ^ u64::from(self.dimension).wrapping_mul(0x9e37_79b9_7f4a_7c15));
        self.dimension += 1;
        (bits >> 40) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    pub fn next_2d(&mut self) -> [f32; 2] {
        [self.next_1d(), self.next_1d()]
    }
}

/// Shirley and Chiu's concentric map of the square onto the unit disk:
/// area-preserving, and it keeps strata compact.
pub fn square_to_uniform_disk_concentric(u: [f32; 2]) -> [f32; 2] {
    let (a, b) = (2.0 * u[0] - 1.0, 2.0 * u[1] - 1.0);
    if a == 0.0 && b == 0.0 {
        return [0.0, 0.0];
    }
    let (r, phi) = if a.abs() > b.abs() { (a, FRAC_PI_4 * (b / a)) } else { (b, FRAC_PI_2 - FRAC_PI_4 * (a / b)) };
    [r * phi.cos(), r * phi.sin()]
}

/// Cosine-weighted directions about +z (Malley's method).
pub fn square_to_cosine_hemisphere(u: [f32; 2]) -> Vec3 {
    let [x, y] = square_to_uniform_disk_concentric(u);
    let z = (1.0 - x * x - y * y).max(0.0).sqrt();
    Vec3::new(x, y, z)
}

pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) / PI
}

pub fn square_to_uniform_sphere(u: [f32; 2]) -> Vec3 {
    let z = 1.0 - 2.0 * u[0];
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = TAU * u[1];
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

pub fn square_to_uniform_hemisphere(u: [f32; 2]) -> Vec3 {
    let z = u[0];
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = TAU * u[1];
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

pub const UNIFORM_HEMISPHERE_PDF: f32 = 1.0 / TAU;

/// Uniform directions within `cos_max` of +z.
pub fn square_to_uniform_cone(u: [f32; 2], cos_max: f32) -> Vec3 {
    let z = 1.0 - u[0] * (1.0 - cos_max);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = TAU * u[1];
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (TAU * (1.0 - cos_max))
}

/// Uniform barycentrics `(b1, b2)` over a triangle (the point is
/// `(1 - b1 - b2) v0 + b1 v1 + b2 v2`).
pub fn square_to_uniform_triangle(u: [f32; 2]) -> (f32, f32) {
    let s = u[0].sqrt();
    (1.0 - s, u[1] * s)
}

/// Directions toward a sphere seen from `from`, uniform over the cone it
/// subtends, with their solid-angle pdf; `None` from inside the sphere
/// (sample its area instead).
pub fn sample_sphere_solid_angle(center: Vec3, radius: f32, from: Vec3, u: [f32; 2]) -> Option<(Vec3, f32)> {
    let d = center - from;
    let d2 = d.length_squared();
    if d2 <= radius * radius {
        return None;
    }
    let cos_max = (1.0 - radius * radius / d2).max(0.0).sqrt();
    let local = square_to_uniform_cone(u, cos_max);
    let frame = Frame::new(d / d2.sqrt());
    Some((frame.to_world(local), uniform_cone_pdf(cos_max)))
}

/// The pdf of [`sample_sphere_solid_angle`] (0 from inside the sphere).
pub fn sphere_solid_angle_pdf(center: Vec3, radius: f32, from: Vec3) -> f32 {
    let d2 = (center - from).length_squared();
    if d2 <= radius * radius {
        return 0.0;
    }
    uniform_cone_pdf((1.0 - radius * radius / d2).max(0.0).sqrt())
}

/// An orthonormal frame about a unit normal (Duff et al. 2017, "Building
/// an Orthonormal Basis, Revisited": branchless, no precision loss near
/// the poles).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    pub fn new(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }

    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }
}

/// Veach's power heuristic (beta = 2) for `nf` samples of pdf `f_pdf`
/// against `ng` of `g_pdf`. An infinite `f_pdf` (a delta) gets weight 1.
pub fn power_heuristic(nf: f32, f_pdf: f32, ng: f32, g_pdf: f32) -> f32 {
    let f = nf * f_pdf;
    let g = ng * g_pdf;
    if f.is_infinite() {
        return 1.0;
    }
    let (f2, g2) = (f * f, g * g);
    if f2 + g2 <= 0.0 || !(f2 + g2).is_finite() {
        return if f > g { 1.0 } else { 0.0 };
    }
    f2 / (f2 + g2)
}

/// The largest f32 below 1: where remapped and sampled points are clamped
/// so that they stay in [0, 1).
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// `x` clamped into [0, 1); NaN becomes 0.
fn to_unit(x: f32) -> f32 {
    if x >= 0.0 { x.min(ONE_MINUS_EPSILON) } else { 0.0 }
}

/// A piecewise-constant distribution over indices, proportional to
/// non-negative weights (lights by power, triangles by area).
#[derive(Debug, Clone, PartialEq)]
pub struct Distribution1D {
    /// Cumulative sums normalised to end at 1.
    cdf: Vec<f32>,
    pmf: Vec<f32>,
}

impl Distribution1D {
    /// `None` when there are no weights or they sum to zero; negative or
    /// non-finite weights count as zero.
    pub fn new(weights: &[f32]) -> Option<Distribution1D> {
        let clean: Vec<f64> =
            weights.iter().map(|w| if w.is_finite() && *w > 0.0 { f64::from(*w) } else { 0.0 }).collect();
        let total: f64 = clean.iter().sum();
        if total <= 0.0 {
            return None;
        }
        let mut acc = 0.0;
        let mut cdf = Vec::with_capacity(clean.len());
        for w in &clean {
            acc += w;
            cdf.push((acc / total) as f32);
        }
        // From the last entry that has weight on, the cdf is exactly 1, so
        // no `u` below 1 can land on a zero-weight tail.
        let last = clean.iter().rposition(|w| *w > 0.0).unwrap_or(0);
        cdf[last..].fill(1.0);
        Some(Distribution1D { cdf, pmf: clean.iter().map(|w| (w / total) as f32).collect() })
    }

    /// The index whose cdf interval holds `u`, and its probability.
    pub fn sample(&self, u: f32) -> (usize, f32) {
        let mut k = self.cdf.partition_point(|c| *c <= u).min(self.cdf.len() - 1);
        // Skip zero-probability entries a rounding step could land on.
        while self.pmf[k] == 0.0 && k + 1 < self.pmf.len() {
            k += 1;
        }
        (k, self.pmf[k])
    }

    /// [`Distribution1D::sample`], and `u` stretched back to [0, 1) over
    /// the chosen entry's interval: a fresh uniform number for the next
    /// choice (pbrt's `PiecewiseConstant1D` remap). With one entry the
    /// number is `u` itself.
    pub fn sample_remapped(&self, u: f32) -> (usize, f32, f32) {
        let (k, p) = self.sample(u);
        let below = if k == 0 { 0.0 } else { self.cdf[k - 1] };
        let rest = if p > 0.0 { to_unit((u - below) / p) } else { 0.0 };
        (k, p, rest)
    }

    pub fn pmf(&self, index: usize) -> f32 {
        self.pmf.get(index).copied().unwrap_or(0.0)
    }

    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }
}

/// A piecewise-constant density over the unit square, proportional to
/// non-negative weights on a `width x height` grid of cells (row-major,
/// row 0 at y = 0): a marginal distribution picks the row, that row's
/// conditional distribution the cell, as pbrt's `PiecewiseConstant2D`.
/// Used for environment images, weighted by their radiance.
///
/// Cells of weight zero are never sampled and have density zero. When all
/// weights are zero (or the grid is empty) the density is uniform, so
/// sampling still gives finite points and pdfs.
#[derive(Debug, Clone, PartialEq)]
pub struct Distribution2D {
    width: usize,
    height: usize,
    /// Rows by their total weight; `None` when every weight is zero.
    marginal: Option<Distribution1D>,
    /// Cells within each row; `None` for rows of zero weight.
    rows: Vec<Option<Distribution1D>>,
}

impl Distribution2D {
    /// `weights` holds `width * height` values, row by row; missing
    /// values count as zero and extra ones are ignored.
    pub fn new(weights: &[f32], width: usize, height: usize) -> Distribution2D {
        let (width, height) = (width.max(1), height.max(1));
        let clean = |w: f32| if w.is_finite() && w > 0.0 { w } else { 0.0 };
        let mut rows = Vec::with_capacity(height);
        let mut totals = Vec::with_capacity(height);
        for j in 0..height {
            let row: Vec<f32> = (0..width).map(|i| weights.get(j * width + i).copied().map_or(0.0, clean)).collect();
            totals.push(row.iter().map(|w| f64::from(*w)).sum::<f64>() as f32);
            rows.push(Distribution1D::new(&row));
        }
        Distribution2D { width, height, marginal: Distribution1D::new(&totals), rows }
    }

    /// A point in [0, 1)^2 distributed by the density, from the uniform
    /// `u` (`u[1]` picks the row, `u[0]` the cell in it), and its density.
    pub fn sample(&self, u: [f32; 2]) -> ([f32; 2], f32) {
        let (w, h) = (self.width as f32, self.height as f32);
        let Some(marginal) = &self.marginal else { return (u.map(to_unit), 1.0) };
        let (j, p_row, v) = marginal.sample_remapped(u[1]);
        // A row the marginal picks has weight, so it has a distribution.
        let Some(row) = &self.rows[j] else { return (u.map(to_unit), 0.0) };
        let (i, p_cell, s) = row.sample_remapped(u[0]);
        let (x, y) = (to_unit((i as f32 + s) / w), to_unit((j as f32 + v) / h));
        ([x, y], p_row * h * p_cell * w)
    }

    /// The density at `point` (clamped into the square).
    pub fn pdf(&self, point: [f32; 2]) -> f32 {
        let Some(marginal) = &self.marginal else { return 1.0 };
        let cell = |x: f32, n: usize| {
            let k = (x * n as f32).floor();
            if k.is_nan() { 0 } else { (k.max(0.0) as usize).min(n - 1) }
        };
        let (i, j) = (cell(point[0], self.width), cell(point[1], self.height));
        let p_cell = self.rows[j].as_ref().map_or(0.0, |r| r.pmf(i));
        marginal.pmf(j) * self.height as f32 * p_cell * self.width as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{chi2_p_value, gamma_p};

    fn uniform(n: usize, seed: u64) -> impl Iterator<Item = [f32; 2]> {
        (0..n as u32).map(move |k| Sampler::new(seed, k, 0, 0).next_2d())
    }

    const SAMPLES: usize = 200_000;
    /// Bonferroni: the tests below run about ten chi² tests together.
    const ALPHA: f64 = 0.01 / 10.0;

    fn direction_chi2(sample: impl Fn([f32; 2]) -> Vec3, pdf: impl Fn(Vec3) -> f32, seed: u64) -> f64 {
        crate::test_support::direction_chi2(sample, pdf, seed, SAMPLES)
    }

    #[test]
    fn sampler_is_deterministic_uniform_and_below_one() {
        let mut a = Sampler::new(1, 2, 3, 4);
        let mut b = Sampler::new(1, 2, 3, 4);
        for _ in 0..100 {
            assert_eq!(a.next_1d().to_bits(), b.next_1d().to_bits());
        }
        let first = |s: u64, x: u32, y: u32, k: u32| Sampler::new(s, x, y, k).next_1d();
        let base = first(1, 2, 3, 4);
        assert_ne!(base, first(2, 2, 3, 4));
        assert_ne!(base, first(1, 3, 3, 4));
        assert_ne!(base, first(1, 2, 4, 4));
        assert_ne!(base, first(1, 2, 3, 5));
        let (mut sum, mut sum2, n) = (0.0f64, 0.0f64, 100_000);
        let mut s = Sampler::new(9, 0, 0, 0);
        for _ in 0..n {
            let x = f64::from(s.next_1d());
            assert!((0.0..1.0).contains(&x));
            sum += x;
            sum2 += x * x;
        }
        let mean = sum / n as f64;
        assert!((mean - 0.5).abs() < 0.005, "{mean}");
        assert!((sum2 / n as f64 - mean * mean - 1.0 / 12.0).abs() < 0.002);
        // 2D uniformity over a 16 x 16 grid, across pixels.
        let mut observed = vec![0.0; 256];
        for u in uniform(SAMPLES, 3) {
            observed[(u[1] * 16.0) as usize * 16 + (u[0] * 16.0) as usize] += 1.0;
        }
        let expected = vec![SAMPLES as f64 / 256.0; 256];
        assert!(chi2_p_value(&observed, &expected) > ALPHA);
    }

    #[test]
    fn chi2_statistics_are_right() {
        // P(1, x) = 1 - e^-x; P(0.5, x) = erf(sqrt(x)).
        assert!((gamma_p(1.0, 2.0) - (1.0 - (-2.0f64).exp())).abs() < 1e-12);
        assert!((gamma_p(0.5, 0.25) - 0.520_499_877_813_046_5).abs() < 1e-9);
        assert!((gamma_p(3.0, 30.0) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn direction_warps_match_their_pdfs() {
        let checks: Vec<(&str, f64)> = vec![
            ("cosine", direction_chi2(square_to_cosine_hemisphere, |d| cosine_hemisphere_pdf(d.z), 1)),
            ("sphere", direction_chi2(square_to_uniform_sphere, |_| UNIFORM_SPHERE_PDF, 2)),
            (
                "hemisphere",
                direction_chi2(
                    square_to_uniform_hemisphere,
                    |d| if d.z >= 0.0 { UNIFORM_HEMISPHERE_PDF } else { 0.0 },
                    3,
                ),
            ),
            (
                "cone",
                direction_chi2(
                    |u| square_to_uniform_cone(u, 0.6),
                    |d| if d.z >= 0.6 { uniform_cone_pdf(0.6) } else { 0.0 },
                    4,
                ),
            ),
            (
                // Seen in the frame of the cone's axis, so the bins line up
                // with the cone's edge.
                "sphere light",
                direction_chi2(
                    |u| {
                        let c = Vec3::new(0.3, -0.2, 2.0);
                        let d = sample_sphere_solid_angle(c, 0.9, Vec3::ZERO, u).unwrap().0;
                        Frame::new(c.normalize()).to_local(d)
                    },
                    |d| {
                        let c = Vec3::new(0.3, -0.2, 2.0);
                        let cos_max = (1.0 - 0.81 / c.length_squared()).sqrt();
                        if d.z >= cos_max { sphere_solid_angle_pdf(c, 0.9, Vec3::ZERO) } else { 0.0 }
                    },
                    5,
                ),
            ),
        ];
        for (name, p) in checks {
            assert!(p > ALPHA, "{name}: p = {p}");
        }
    }

    #[test]
    fn a_wrong_pdf_is_rejected() {
        // Uniform hemisphere samples are not cosine distributed.
        let p = direction_chi2(square_to_uniform_hemisphere, |d| cosine_hemisphere_pdf(d.z), 6);
        assert!(p < 1e-6, "p = {p}");
    }

    #[test]
    fn area_warps_are_uniform() {
        // Disk: bins in the square; the expected count is the bin's area
        // inside the unit disk (estimated on a fine grid).
        const N: usize = 16;
        let mut observed = vec![0.0; N * N];
        for u in uniform(SAMPLES, 7) {
            let [x, y] = square_to_uniform_disk_concentric(u);
            assert!(x * x + y * y <= 1.0 + 1e-6);
            let i = (((x + 1.0) / 2.0) * N as f32).clamp(0.0, N as f32 - 1.0) as usize;
            let j = (((y + 1.0) / 2.0) * N as f32).clamp(0.0, N as f32 - 1.0) as usize;
            observed[j * N + i] += 1.0;
        }
        let mut expected = vec![0.0; N * N];
        const SUB: usize = 32;
        for j in 0..N {
            for i in 0..N {
                let mut inside = 0;
                for a in 0..SUB {
                    for b in 0..SUB {
                        let x = -1.0 + 2.0 * (i as f64 + (a as f64 + 0.5) / SUB as f64) / N as f64;
                        let y = -1.0 + 2.0 * (j as f64 + (b as f64 + 0.5) / SUB as f64) / N as f64;
                        inside += usize::from(x * x + y * y <= 1.0);
                    }
                }
                let area = inside as f64 / (SUB * SUB) as f64 * (4.0 / (N * N) as f64);
                expected[j * N + i] = area / std::f64::consts::PI * SAMPLES as f64;
            }
        }
        assert!(chi2_p_value(&observed, &expected) > ALPHA, "disk");
        // Triangle (0,0) (1,0) (0,1): bins of the unit square, lower half.
        let mut observed = vec![0.0; N * N];
        for u in uniform(SAMPLES, 8) {
            let (b1, b2) = square_to_uniform_triangle(u);
            assert!(b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 + 1e-6);
            let i = (b1 * N as f32).min(N as f32 - 1.0) as usize;
            let j = (b2 * N as f32).min(N as f32 - 1.0) as usize;
            observed[j * N + i] += 1.0;
        }
        let mut expected = vec![0.0; N * N];
        for j in 0..N {
            for i in 0..N {
                let area = match (i + j + 1).cmp(&N) {
                    std::cmp::Ordering::Less => 1.0,
                    std::cmp::Ordering::Equal => 0.5,
                    std::cmp::Ordering::Greater => 0.0,
                } / (N * N) as f64;
                expected[j * N + i] = area * 2.0 * SAMPLES as f64;
            }
        }
        assert!(chi2_p_value(&observed, &expected) > ALPHA, "triangle");
    }

    #[test]
    fn pdfs_integrate_to_one() {
        // Midpoint rule over (cos theta, phi).
        let n = 400;
        let integrate = |pdf: &dyn Fn(Vec3) -> f32| {
            let mut sum = 0.0f64;
            for i in 0..n {
                for j in 0..n {
                    let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
                    let phi = TAU * (j as f32 + 0.5) / n as f32;
                    let r = (1.0 - z * z).sqrt();
                    sum += f64::from(pdf(Vec3::new(r * phi.cos(), r * phi.sin(), z)));
                }
            }
            sum * 4.0 * std::f64::consts::PI / (n * n) as f64
        };
        assert!((integrate(&|d| cosine_hemisphere_pdf(d.z)) - 1.0).abs() < 1e-3);
        assert!((integrate(&|_| UNIFORM_SPHERE_PDF) - 1.0).abs() < 1e-3);
        assert!((integrate(&|d| if d.z >= 0.3 { uniform_cone_pdf(0.3) } else { 0.0 }) - 1.0).abs() < 1e-2);
    }

    #[test]
    fn frames_are_orthonormal() {
        for u in uniform(1000, 11) {
            let n = square_to_uniform_sphere(u);
            let f = Frame::new(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5 && (f.t.length() - 1.0).abs() < 1e-5);
            assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(n).abs() < 1e-5 && f.t.dot(n).abs() < 1e-5);
            assert!((f.s.cross(f.t) - n).length() < 1e-4, "right-handed");
            let v = Vec3::new(0.3, -0.5, 0.8);
            assert!((f.to_local(f.to_world(v)) - v).length() < 1e-5);
        }
        let f = Frame::new(Vec3::NEG_Z);
        assert!(f.s.is_finite() && f.t.is_finite());
    }

    #[test]
    fn power_heuristic_and_distributions() {
        assert_eq!(power_heuristic(1.0, 1.0, 1.0, 1.0), 0.5);
        assert!((power_heuristic(1.0, 3.0, 1.0, 1.0) - 0.9).abs() < 1e-6);
        assert_eq!(power_heuristic(1.0, f32::INFINITY, 1.0, 2.0), 1.0);
        assert_eq!(power_heuristic(1.0, 2.0, 1.0, 0.0), 1.0);
        assert_eq!(power_heuristic(1.0, 0.0, 1.0, 0.0), 0.0);

        assert!(Distribution1D::new(&[]).is_none());
        assert!(Distribution1D::new(&[0.0, -1.0, f32::NAN]).is_none());
        let d = Distribution1D::new(&[1.0, 0.0, 3.0, f32::INFINITY]).unwrap();
        assert_eq!((d.pmf(0), d.pmf(1), d.pmf(2), d.pmf(3)), (0.25, 0.0, 0.75, 0.0));
        let mut counts = [0.0; 4];
        for u in uniform(SAMPLES, 12) {
            let (k, p) = d.sample(u[0]);
            assert_eq!(p, d.pmf(k));
            counts[k] += 1.0;
        }
        assert_eq!(counts[1] + counts[3], 0.0);
        let expected = [0.25 * SAMPLES as f64, 0.0, 0.75 * SAMPLES as f64, 0.0];
        assert!(chi2_p_value(&[counts[0], counts[2]], &[expected[0], expected[2]]) > ALPHA);
        assert_eq!(d.sample(0.999_999_9).0, 2);
    }

    /// 7 x 5 cells with a zero row (row 2) and scattered zero cells.
    fn grid_weights() -> Vec<f32> {
        (0..35)
            .map(|k| {
                let (i, j) = (k % 7, k / 7);
                if j == 2 || (i + j) % 4 == 0 { 0.0 } else { 1.0 + ((i * 3 + j * 5) % 7) as f32 }
            })
            .collect()
    }

    #[test]
    fn distribution_2d_integrates_to_one_and_matches_its_samples() {
        let weights = grid_weights();
        let d = Distribution2D::new(&weights, 7, 5);
        // The density integrates to 1 (midpoint rule, 4 x 4 points a cell),
        // and is proportional to the weights.
        let total: f32 = weights.iter().sum();
        let mut integral = 0.0f64;
        for y in 0..20 {
            for x in 0..28 {
                let p = [(x as f32 + 0.5) / 28.0, (y as f32 + 0.5) / 20.0];
                let pdf = d.pdf(p);
                let w = weights[(y / 4) * 7 + x / 4];
                assert!((pdf - w / total * 35.0).abs() < 1e-4, "cell ({}, {}): {pdf}", x / 4, y / 4);
                integral += f64::from(pdf) / (28.0 * 20.0);
            }
        }
        assert!((integral - 1.0).abs() < 1e-5, "{integral}");
        // Samples: 2 x 2 bins a cell, so the density inside a cell is
        // checked too; zero cells are never hit; each pdf is the density.
        let mut observed = vec![0.0; 14 * 10];
        for u in uniform(SAMPLES, 21) {
            let ([x, y], pdf) = d.sample(u);
            assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y), "{x}, {y}");
            assert!((pdf - d.pdf([x, y])).abs() <= 1e-5 * pdf, "{pdf} vs {}", d.pdf([x, y]));
            assert!(weights[(y * 5.0) as usize * 7 + (x * 7.0) as usize] > 0.0, "a zero cell at ({x}, {y})");
            observed[(y * 10.0) as usize * 14 + (x * 14.0) as usize] += 1.0;
        }
        let expected: Vec<f64> = (0..14 * 10)
            .map(|k| f64::from(weights[(k / 14 / 2) * 7 + (k % 14) / 2] / total) / 4.0 * SAMPLES as f64)
            .collect();
        assert!(chi2_p_value(&observed, &expected) > ALPHA, "2D distribution");
    }

    #[test]
    fn degenerate_2d_distributions_are_uniform_and_finite() {
        for (weights, w, h) in
            [(vec![0.0; 12], 4, 3), (vec![f32::NAN, -1.0, f32::INFINITY, 0.0], 2, 2), (vec![], 3, 3), (vec![], 0, 0)]
        {
            let d = Distribution2D::new(&weights, w, h);
            for u in [[0.0, 0.0], [0.5, 0.25], [ONE_MINUS_EPSILON, ONE_MINUS_EPSILON], [f32::NAN, 0.5]] {
                let (p, pdf) = d.sample(u);
                assert!(p.iter().all(|x| (0.0..1.0).contains(x)), "{p:?}");
                assert_eq!(pdf, 1.0);
            }
            assert_eq!(d.pdf([0.3, 0.9]), 1.0);
            assert_eq!(d.pdf([f32::NAN, 2.0]), 1.0);
        }
        // One non-zero cell takes every sample.
        let mut weights = vec![0.0; 12];
        weights[7] = 2.0;
        let d = Distribution2D::new(&weights, 4, 3);
        for u in uniform(1000, 22) {
            let ([x, y], pdf) = d.sample(u);
            assert_eq!(((x * 4.0) as usize, (y * 3.0) as usize), (3, 1));
            assert_eq!(pdf, 12.0);
        }
        assert_eq!(d.pdf([0.1, 0.1]), 0.0);
        assert!(d.pdf([f32::NAN, f32::INFINITY]).is_finite());
    }

    #[test]
    fn remapped_samples_are_uniform_again() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0]).unwrap();
        assert_eq!(Distribution1D::new(&[5.0]).unwrap().sample_remapped(0.375), (0, 1.0, 0.375));
        let (k, p, rest) = d.sample_remapped(0.25 + 0.75 * 0.5);
        assert_eq!((k, p), (2, 0.75));
        assert!((rest - 0.5).abs() < 1e-6);
        // Zero-weight tails are never picked, however close to 1 u is.
        let tail = Distribution1D::new(&[1.0, 2.0, 0.0, 0.0]).unwrap();
        assert_eq!(tail.sample(ONE_MINUS_EPSILON).0, 1);
        assert!(tail.sample_remapped(ONE_MINUS_EPSILON).2 < 1.0);
    }
}
