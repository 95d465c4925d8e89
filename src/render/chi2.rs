//! Pearson's chi² goodness-of-fit test of a direction sampler against its
//! pdf, as pbrt-v4 and Mitsuba 3 test their BSDFs and lights: directions
//! are binned over the sphere by (cos θ, φ), each bin's expected count is
//! the pdf integrated over it, and the p-value says how likely counts this
//! far from the expectation are if the sampler draws from the pdf.
//!
//! Public so that hosts can test the sampling of their own materials the
//! same way (`tests/sampling.rs` tests every stdlib material with it).
//!
//! ```
//! use tsl::render::chi2::DirectionTest;
//! // Uniform directions on the sphere against the uniform pdf.
//! let mut state = 1u64;
//! let mut next = move || {
//!     state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
//!     (state >> 40) as f32 / (1u64 << 24) as f32
//! };
//! let test = DirectionTest::new(10, 20);
//! let result = test.run(
//!     100_000,
//!     || {
//!         let z = 1.0 - 2.0 * next();
//!         let phi = std::f32::consts::TAU * next();
//!         let r = (1.0 - z * z).max(0.0).sqrt();
//!         Some([r * phi.cos(), r * phi.sin(), z])
//!     },
//!     |_| 1.0 / (4.0 * std::f64::consts::PI),
//! );
//! assert!(result.p_value > 1e-3, "{result:?}");
//! assert!((result.pdf_integral - 1.0).abs() < 1e-3);
//! ```

use std::f64::consts::{PI, TAU};

/// Bins of the sphere: `theta` bands times `phi` sectors, about the z axis.
#[derive(Debug, Clone, Copy)]
pub struct DirectionTest {
    pub theta_bins: usize,
    pub phi_bins: usize,
    /// Midpoint-rule points per bin side when integrating the pdf.
    pub subdivisions: usize,
    pub bands: Bands,
}

/// How the `theta` bands divide the sphere.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bands {
    /// Equal angles: fine at the poles, where glossy lobes about the normal
    /// and refracted lobes lie (Mitsuba's choice).
    Angle,
    /// Equal in cos θ, so equal in solid angle: band edges fall on round
    /// cosines, such as the edge of a cone.
    Cosine,
}

/// What [`DirectionTest::run`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct Chi2Result {
    /// The probability of a deviation at least this large under the
    /// hypothesis that the samples follow the pdf.
    pub p_value: f64,
    pub chi2: f64,
    pub degrees_of_freedom: i64,
    /// The pdf integrated over the sphere: 1 for a sampler that always
    /// draws a direction, less when it may draw none (or a delta lobe).
    pub pdf_integral: f64,
    /// The fraction of draws that gave a direction (counted in bins).
    pub drawn: f64,
}

impl DirectionTest {
    pub fn new(theta_bins: usize, phi_bins: usize) -> DirectionTest {
        DirectionTest { theta_bins, phi_bins, subdivisions: 8, bands: Bands::Angle }
    }

    fn bin(&self, d: [f32; 3]) -> Option<usize> {
        let [x, y, z] = d.map(f64::from);
        let len = (x * x + y * y + z * z).sqrt();
        if !(len > 0.5 && len < 1.5) {
            return None;
        }
        let cos = (z / len).clamp(-1.0, 1.0);
        let at = match self.bands {
            Bands::Angle => cos.acos() / PI,
            Bands::Cosine => (1.0 - cos) / 2.0,
        };
        let t = (at * self.theta_bins as f64).clamp(0.0, self.theta_bins as f64 - 1.0) as usize;
        let phi = y.atan2(x).rem_euclid(TAU);
        let p = (phi / TAU * self.phi_bins as f64).clamp(0.0, self.phi_bins as f64 - 1.0) as usize;
        Some(t * self.phi_bins + p)
    }

    /// Draws `n` times from `sample` (`None`: nothing drawn, as for a delta
    /// lobe or an absorbed path) and compares the directions with `pdf`.
    pub fn run(
        &self,
        n: usize,
        mut sample: impl FnMut() -> Option<[f32; 3]>,
        pdf: impl Fn([f32; 3]) -> f64,
    ) -> Chi2Result {
        let bins = self.theta_bins * self.phi_bins;
        let mut observed = vec![0.0; bins];
        let mut drawn = 0usize;
        for _ in 0..n {
            if let Some(k) = sample().and_then(|d| self.bin(d)) {
                observed[k] += 1.0;
                drawn += 1;
            }
        }
        let sub = self.subdivisions;
        let (dt, dp) = (PI / (self.theta_bins * sub) as f64, TAU / (self.phi_bins * sub) as f64);
        let mut expected = vec![0.0; bins];
        let mut integral = 0.0;
        for t in 0..self.theta_bins {
            for p in 0..self.phi_bins {
                // The midpoint rule in (θ, φ) with the area element sin θ dθ,
                // or in (cos θ, φ), where it is d cos θ.
                let mut mass = 0.0;
                for i in 0..sub {
                    let at = ((t * sub + i) as f64 + 0.5) / (self.theta_bins * sub) as f64;
                    let (sin_t, cos_t, area) = match self.bands {
                        Bands::Angle => {
                            let (s, c) = (at * PI).sin_cos();
                            (s, c, s * dt)
                        }
                        Bands::Cosine => {
                            let c = 1.0 - 2.0 * at;
                            ((1.0 - c * c).max(0.0).sqrt(), c, 2.0 / (self.theta_bins * sub) as f64)
                        }
                    };
                    for j in 0..sub {
                        let phi = (p * sub + j) as f64 * dp + dp / 2.0;
                        let d = [(sin_t * phi.cos()) as f32, (sin_t * phi.sin()) as f32, cos_t as f32];
                        let v = pdf(d);
                        mass += if v.is_finite() { v * area * dp } else { 0.0 };
                    }
                }
                integral += mass;
                expected[t * self.phi_bins + p] = mass * n as f64;
            }
        }
        let (chi2, dof) = chi2_statistic(&observed, &expected);
        Chi2Result {
            p_value: 1.0 - gamma_p(dof as f64 / 2.0, chi2 / 2.0),
            chi2,
            degrees_of_freedom: dof,
            pdf_integral: integral,
            drawn: drawn as f64 / n as f64,
        }
    }
}

/// Pearson's statistic and its degrees of freedom, pooling the cells
/// expected below 5 into one (as Mitsuba's test does).
pub fn chi2_statistic(observed: &[f64], expected: &[f64]) -> (f64, i64) {
    let (mut chi2, mut dof) = (0.0, 0i64);
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for (o, e) in observed.iter().zip(expected) {
        if *e < 5.0 {
            pool_o += o;
            pool_e += e;
            continue;
        }
        chi2 += (o - e) * (o - e) / e;
        dof += 1;
    }
    if pool_e > 0.0 {
        chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e.max(1e-9);
        dof += 1;
    }
    (chi2, (dof - 1).max(1))
}

/// The p-value of Pearson's test of `observed` against `expected` counts.
pub fn p_value(observed: &[f64], expected: &[f64]) -> f64 {
    let (chi2, dof) = chi2_statistic(observed, expected);
    1.0 - gamma_p(dof as f64 / 2.0, chi2 / 2.0)
}

/// The regularised lower incomplete gamma function P(a, x): the series
/// below a + 1, Lentz's continued fraction above.
pub fn gamma_p(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let scale = (-x + a * x.ln() - ln_gamma(a)).exp();
    if x < a + 1.0 {
        let (mut sum, mut term, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        return sum * scale;
    }
    let tiny = 1e-300;
    let mut b = x + 1.0 - a;
    let mut c = 1.0 / tiny;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..10_000 {
        let an = -(i as f64) * (i as f64 - a);
        b += 2.0;
        d = an * d + b;
        if d.abs() < tiny {
            d = tiny;
        }
        c = b + an / c;
        if c.abs() < tiny {
            c = tiny;
        }
        d = 1.0 / d;
        let delta = d * c;
        h *= delta;
        if (delta - 1.0).abs() < 1e-15 {
            break;
        }
    }
    1.0 - scale * h
}

/// ln Γ(x) for x > 0 (Lanczos, g = 5, six terms).
fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 6] = [
        76.18009172947146,
        -86.50532032941677,
        24.01409824083091,
        -1.231739572450155,
        0.1208650973866179e-2,
        -0.5395239384953e-5,
    ];
    let mut y = x;
    let tmp = x + 5.5;
    let tmp = tmp - (x + 0.5) * tmp.ln();
    let mut ser = 1.000000000190015;
    for g in G {
        y += 1.0;
        ser += g / y;
    }
    -tmp + (2.5066282746310005 * ser / x).ln()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gamma_p_matches_known_values() {
        // P(1, x) = 1 - e^-x; P(0.5, x) = erf(sqrt(x)).
        assert!((gamma_p(1.0, 2.0) - (1.0 - (-2.0f64).exp())).abs() < 1e-12);
        assert!((gamma_p(0.5, 1.0) - 0.842_700_792_949_715).abs() < 1e-9);
        // Q(10, 30) = e^-30 sum_{k<10} 30^k / k! = 7.12e-6.
        assert!((1.0 - gamma_p(10.0, 30.0) - 7.12e-6).abs() < 1e-7);
    }

    #[test]
    fn a_wrong_pdf_fails() {
        let mut state = 7u64;
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        // Uniform hemisphere samples tested against the cosine pdf.
        let result = DirectionTest::new(10, 20).run(
            100_000,
            || {
                let z = next();
                let phi = std::f32::consts::TAU * next();
                let r = (1.0 - z * z).max(0.0).sqrt();
                Some([r * phi.cos(), r * phi.sin(), z])
            },
            |d| f64::from(d[2]).max(0.0) / PI,
        );
        assert!(result.p_value < 1e-6, "{result:?}");
        assert!((result.pdf_integral - 1.0).abs() < 1e-3);
    }
}
