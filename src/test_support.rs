//! Helpers the unit tests share: temporary directories and the chi²
//! goodness-of-fit test of samples against a density.

mod random;

pub use random::{Rng, shading_point};

use crate::ShadingGlobals;
use crate::render::Vec3;
use crate::render::chi2::{Bands, DirectionTest};
use crate::render::sampling::Sampler;
use std::path::PathBuf;

/// A fresh, empty directory for one test, unique to this process.
pub fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tsl-unit-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

pub use crate::render::chi2::{gamma_p, p_value as chi2_p_value};

/// The p-value of directions from `sample` (fed `samples` uniform points
/// from `seed`) against the density `pdf` (see [`DirectionTest`]).
pub fn direction_chi2(sample: impl Fn([f32; 2]) -> Vec3, pdf: impl Fn(Vec3) -> f32, seed: u64, samples: usize) -> f64 {
    let mut k = 0u32;
    let draw = || {
        let d = sample(Sampler::new(seed, k, 0, 0).next_2d());
        k += 1;
        Some(d.to_array())
    };
    // Bands equal in cos θ put band edges on the cones the warps cut.
    let test = DirectionTest { bands: Bands::Cosine, ..DirectionTest::new(20, 40) };
    test.run(samples, draw, |d| f64::from(pdf(Vec3::from(d)))).p_value
}
