//! Helpers the unit tests share: temporary directories and the chi²
//! goodness-of-fit test of samples against a density.

use crate::render::Vec3;
use crate::render::sampling::Sampler;
use std::f32::consts::TAU;
use std::path::PathBuf;

/// A fresh, empty directory for one test, unique to this process.
pub fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tsl-unit-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The regularised lower incomplete gamma function P(a, x)
/// (Numerical Recipes: series below a + 1, continued fraction above).
pub fn gamma_p(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let ln_gamma_a = ln_gamma(a);
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
        sum * (-x + a * x.ln() - ln_gamma_a).exp()
    } else {
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
        1.0 - (-x + a * x.ln() - ln_gamma_a).exp() * h
    }
}

/// Lanczos approximation of ln Γ(x), x > 0.
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

/// p-value of Pearson's chi² test of observed against expected counts,
/// pooling cells expected below 5 (as Mitsuba's chi2 test).
pub fn chi2_p_value(observed: &[f64], expected: &[f64]) -> f64 {
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
    dof -= 1;
    1.0 - gamma_p(dof as f64 / 2.0, chi2 / 2.0)
}

/// The p-value of directions from `sample` (fed `samples` uniform points
/// from `seed`) against the density `pdf`: bins in (cos theta, phi) about
/// +z, each compared with the pdf integrated over it (midpoint rule on a
/// finer grid).
pub fn direction_chi2(sample: impl Fn([f32; 2]) -> Vec3, pdf: impl Fn(Vec3) -> f32, seed: u64, samples: usize) -> f64 {
    const NT: usize = 20;
    const NP: usize = 40;
    let mut observed = vec![0.0; NT * NP];
    for k in 0..samples as u32 {
        let d = sample(Sampler::new(seed, k, 0, 0).next_2d());
        let t = (((1.0 - d.z) / 2.0) * NT as f32).clamp(0.0, NT as f32 - 1.0) as usize;
        let phi = d.y.atan2(d.x).rem_euclid(TAU);
        let p = ((phi / TAU) * NP as f32).clamp(0.0, NP as f32 - 1.0) as usize;
        observed[t * NP + p] += 1.0;
    }
    let mut expected = vec![0.0; NT * NP];
    const SUB: usize = 8;
    for t in 0..NT {
        for p in 0..NP {
            let mut integral = 0.0f64;
            for i in 0..SUB {
                for j in 0..SUB {
                    let z = 1.0 - 2.0 * (t as f32 + (i as f32 + 0.5) / SUB as f32) / NT as f32;
                    let phi = TAU * (p as f32 + (j as f32 + 0.5) / SUB as f32) / NP as f32;
                    let r = (1.0 - z * z).max(0.0).sqrt();
                    integral += f64::from(pdf(Vec3::new(r * phi.cos(), r * phi.sin(), z)));
                }
            }
            // The bin's solid angle is 4 pi / (NT NP).
            expected[t * NP + p] =
                integral / (SUB * SUB) as f64 * (4.0 * std::f64::consts::PI) / (NT * NP) as f64 * samples as f64;
        }
    }
    chi2_p_value(&observed, &expected)
}
