//! Radiance carried along paths: a fixed number of lanes, as many as the
//! color model has (3 for RGB, N spectral samples), rounded up to one of
//! a few capacities so the integrators are compiled for each capacity once.
//!
//! Invariant: lanes beyond the color model's count stay zero; every
//! operation here maps zeros to zeros, so they never leak into results.

use std::ops::{Add, AddAssign, Div, Mul, MulAssign};

/// `N` lanes of radiance (or throughput, or reflectance).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spectrum<const N: usize>(pub [f32; N]);

impl<const N: usize> Spectrum<N> {
    pub const ZERO: Spectrum<N> = Spectrum([0.0; N]);

    /// `x` in the first `lanes` lanes, zero after.
    pub fn splat(x: f32, lanes: usize) -> Self {
        let mut s = Self::ZERO;
        s.0[..lanes.min(N)].fill(x);
        s
    }

    /// Copies the first `N` lanes of `lanes` (fewer leave zeros).
    pub fn from_lanes(lanes: &[f32]) -> Self {
        // Lane by lane, not a memcpy into a zeroed array: reading that back
        // right away stalls on store forwarding.
        Spectrum(std::array::from_fn(|k| lanes.get(k).copied().unwrap_or(0.0)))
    }

    pub fn max_lane(&self) -> f32 {
        self.0.iter().copied().fold(0.0, f32::max)
    }

    pub fn is_black(&self) -> bool {
        self.0.iter().all(|x| *x == 0.0)
    }

    pub fn is_finite(&self) -> bool {
        self.0.iter().all(|x| x.is_finite())
    }

    /// Lane-wise quotient where the divisor is non-zero, else zero.
    pub fn safe_div(&self, d: &Self) -> Self {
        let mut s = Self::ZERO;
        for k in 0..N {
            if d.0[k] != 0.0 {
                s.0[k] = self.0[k] / d.0[k];
            }
        }
        s
    }

    /// The mean over the first `lanes` lanes.
    pub fn mean(&self, lanes: usize) -> f32 {
        let n = lanes.clamp(1, N);
        self.0[..n].iter().sum::<f32>() / n as f32
    }
}

impl<const N: usize> Add for Spectrum<N> {
    type Output = Self;
    fn add(mut self, o: Self) -> Self {
        self += o;
        self
    }
}

impl<const N: usize> AddAssign for Spectrum<N> {
    fn add_assign(&mut self, o: Self) {
        for k in 0..N {
            self.0[k] += o.0[k];
        }
    }
}

impl<const N: usize> Mul for Spectrum<N> {
    type Output = Self;
    fn mul(mut self, o: Self) -> Self {
        self *= o;
        self
    }
}

impl<const N: usize> MulAssign for Spectrum<N> {
    fn mul_assign(&mut self, o: Self) {
        for k in 0..N {
            self.0[k] *= o.0[k];
        }
    }
}

impl<const N: usize> Mul<f32> for Spectrum<N> {
    type Output = Self;
    fn mul(mut self, s: f32) -> Self {
        self.0.iter_mut().for_each(|x| *x *= s);
        self
    }
}

impl<const N: usize> MulAssign<f32> for Spectrum<N> {
    fn mul_assign(&mut self, s: f32) {
        self.0.iter_mut().for_each(|x| *x *= s);
    }
}

impl<const N: usize> Div<f32> for Spectrum<N> {
    type Output = Self;
    fn div(self, s: f32) -> Self {
        self * (1.0 / s)
    }
}

/// Material calls write radiance straight into a spectrum: its `N` lanes
/// hold the model's (the scene picks `N` at least the model's count).
impl<const N: usize> crate::Lanes for Spectrum<N> {
    fn zero(_: crate::ColorModel) -> Self {
        Spectrum::ZERO
    }
    fn lanes(&self) -> &[f32] {
        &self.0
    }
    fn lanes_mut(&mut self) -> &mut [f32] {
        &mut self.0
    }
    fn push_lanes(&self, lanes: usize, words: &mut Vec<u32>) {
        // A copy of N words in its own branch: a few moves, not a call.
        if lanes == N {
            words.extend_from_slice(bytemuck::cast_slice(&self.0));
        } else {
            words.extend_from_slice(bytemuck::cast_slice(&self.0[..lanes]));
        }
    }
    fn from_words(_: crate::ColorModel, words: &[u32]) -> Self {
        match words.get(..N) {
            Some(words) => Spectrum(std::array::from_fn(|k| f32::from_bits(words[k]))),
            None => {
                let mut c = Spectrum::ZERO;
                c.0.iter_mut().zip(words).for_each(|(x, w)| *x = f32::from_bits(*w));
                c
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_beyond_the_model_stay_zero() {
        let a = Spectrum::<8>::splat(2.0, 3);
        let b = Spectrum::<8>::from_lanes(&[1.0, 2.0, 4.0]);
        let c = (a * b + a) * 0.5 / 2.0;
        assert_eq!(c.0, [1.0, 1.5, 2.5, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(c.safe_div(&b).0[..4], [1.0, 0.75, 0.625, 0.0]);
        assert_eq!(c.max_lane(), 2.5);
        assert!((c.mean(3) - 5.0 / 3.0).abs() < 1e-6);
        assert!(!c.is_black() && Spectrum::<8>::ZERO.is_black());
        assert!(!(c * f32::NAN).is_finite());
    }
}
