//! Hero wavelength sampling (A. Wilkie, S. Nawaz, M. Droske, A. Weidlich
//! and J. Hanika, "Hero Wavelength Spectral Sampling", EGSR 2014) for
//! [`ColorModel::Hero`](crate::ColorModel::Hero): each camera sample carries
//! [`HERO_LANES`] wavelengths, one random "hero" and its companions evenly
//! rotated from it in sample space, each importance sampled by a density
//! shaped like the visible spectrum (pbrt-v4's `SampleVisibleWavelengths`,
//! `sech²(0.0072 (λ − 538))`, cut to 380–780 nm). The film's estimate
//! `Σ_i rgb_matching(λ_i) L(λ_i) / (n p(λ_i))` is unbiased for the exact
//! spectral integral, so a render converges to it, not to a binned
//! approximation.
//!
//! Where a path refracts through a surface whose index varies with
//! wavelength, one direction cannot serve every lane: the companions are
//! terminated there (pbrt-v4's `TerminateSecondary`), and the hero lane
//! carries the path on alone, weighed `n` times.

use super::spectrum::Spectrum;
use crate::color::{self, HERO_LANES, LAMBDA_MAX, LAMBDA_MIN};

/// The density's centre and rate (pbrt-v4's fit of the visible spectrum).
const CENTRE: f32 = 538.0;
const RATE: f32 = 0.0072;

/// The wavelengths of one camera sample and what weighs them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeroSample {
    /// nm; lane 0 is the hero.
    pub wavelengths: [f32; HERO_LANES],
    /// The density each was drawn with, per nm.
    pub pdf: [f32; HERO_LANES],
    /// The film's weights, rows R, G, B: `rgb_matching(λ_i) / (n p_i)`.
    pub film: [[f32; HERO_LANES]; 3],
    /// What shaders weigh lanes by (`ShadingGlobals::rgb_weights`).
    pub shader: [[f32; HERO_LANES]; 3],
    /// Where each lane reads a scene color's 64 bins ([`Self::tabulated`]).
    bins: [(usize, f32); HERO_LANES],
}

fn tanh_at(nm: f32) -> f32 {
    (RATE * (nm - CENTRE)).tanh()
}

/// The density of [`sample_visible`] at `nm` (0 outside 380–780 nm).
pub fn visible_pdf(nm: f32) -> f32 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&nm) {
        return 0.0;
    }
    let norm = tanh_at(LAMBDA_MAX) - tanh_at(LAMBDA_MIN);
    let c = (RATE * (nm - CENTRE)).cosh();
    RATE / (c * c * norm)
}

/// A wavelength in 380–780 nm with density [`visible_pdf`], by inverting its
/// distribution function (`tanh`) at `u` in [0, 1).
pub fn sample_visible(u: f32) -> f32 {
    let (a, b) = (tanh_at(LAMBDA_MIN), tanh_at(LAMBDA_MAX));
    let t = (a + u * (b - a)).clamp(-0.999_999, 0.999_999);
    (CENTRE + t.atanh() / RATE).clamp(LAMBDA_MIN, LAMBDA_MAX)
}

/// Cells of the tabulated inverse distribution function.
const CDF_CELLS: usize = 1024;

/// Entries of the `rgb_matching` table, one per nanometre of 380–780.
const MATCHING: usize = (LAMBDA_MAX - LAMBDA_MIN) as usize + 1;

/// The bins of the scene colors' tables (`crate::Color::lanes`): where each
/// lane reads them is found once per sample, not once per lookup.
const SCENE_BINS: usize = 64;

/// What drawing a sample reads, made once: the inverse distribution of
/// [`sample_visible`] at `CDF_CELLS + 1` points (drawing interpolates it,
/// and the density is that interpolation's own, so the estimate stays
/// unbiased), and `rgb_matching` every nanometre. Arrays, not vectors: the
/// clamped indices need no bounds checks.
struct Tables {
    inverse_cdf: [f32; CDF_CELLS + 1],
    matching: [[f32; 3]; MATCHING],
}

fn tables() -> &'static Tables {
    static TABLES: std::sync::OnceLock<Tables> = std::sync::OnceLock::new();
    TABLES.get_or_init(|| Tables {
        inverse_cdf: std::array::from_fn(|k| sample_visible(k as f32 / CDF_CELLS as f32)),
        matching: std::array::from_fn(|k| {
            color::rgb_matching(color::White::D65, f64::from(LAMBDA_MIN) + k as f64).map(|x| x as f32)
        }),
    })
}

/// `x as usize` clamped to `0..=max`: the same index for every float (NaN
/// and negatives give 0), clamped as a float first so that the conversion
/// is one instruction, not a saturating one's compares and branches (this
/// runs a dozen times per camera sample).
fn index(x: f32, max: usize) -> usize {
    // `f32::max` takes 0 for NaN.
    let x = x.max(0.0).min(max as f32);
    // SAFETY: x is finite and in 0..=max, which every table here keeps
    // far below i32::MAX.
    (unsafe { x.to_int_unchecked::<i32>() }) as usize
}

/// Where lane `nm` reads a table of [`SCENE_BINS`] bins: the lower bin and
/// the fraction toward the next ([`interpolate_bins`]'s arithmetic).
fn bin_position(nm: f32) -> (usize, f32) {
    let x = (nm - LAMBDA_MIN) * (SCENE_BINS as f32 / (LAMBDA_MAX - LAMBDA_MIN)) - 0.5;
    let x = x.clamp(0.0, (SCENE_BINS - 1) as f32);
    let k = index(x, SCENE_BINS - 2);
    (k, x - k as f32)
}

impl HeroSample {
    /// The wavelengths of `u` (the camera sample's own random number): the
    /// hero at `u`, the companions at `u + i / n` wrapped into [0, 1), so
    /// they stratify the density.
    pub fn draw(u: f32) -> HeroSample {
        let t = tables();
        let mut wavelengths = [0.0; HERO_LANES];
        let mut pdf = [0.0; HERO_LANES];
        let mut film = [[0.0; HERO_LANES]; 3];
        let mut bins = [(0, 0.0); HERO_LANES];
        for i in 0..HERO_LANES {
            // `u + i / n` wrapped into [0, 1) without a call to `fract`
            // (this runs once per camera sample).
            let wrapped = u + i as f32 / HERO_LANES as f32;
            let wrapped = if wrapped >= 1.0 { wrapped - 1.0 } else { wrapped };
            let ui = wrapped * CDF_CELLS as f32;
            let k = index(ui, CDF_CELLS - 1);
            let (a, b) = (t.inverse_cdf[k], t.inverse_cdf[k + 1]);
            let l = a + (b - a) * (ui - k as f32);
            wavelengths[i] = l;
            pdf[i] = 1.0 / (CDF_CELLS as f32 * (b - a));
            let x = (l - LAMBDA_MIN).clamp(0.0, LAMBDA_MAX - LAMBDA_MIN);
            let j = index(x, MATCHING - 2);
            let f = x - j as f32;
            // 1 / (pdf · n), without dividing twice.
            let weight = (b - a) * (CDF_CELLS as f32 / HERO_LANES as f32);
            for (c, row) in film.iter_mut().enumerate() {
                let (m0, m1) = (t.matching[j][c], t.matching[j + 1][c]);
                row[i] = (m0 + (m1 - m0) * f) * weight;
            }
            bins[i] = bin_position(l);
        }
        // Shaders' weights: the film's over their luminance, so that a flat
        // spectrum's brightness is exactly 1 on every sample.
        let lum = |i: usize| 0.2126 * film[0][i] + 0.7152 * film[1][i] + 0.0722 * film[2][i];
        let y: f32 = (0..HERO_LANES).map(lum).sum();
        let norm = if y > 0.0 && y.is_finite() { 1.0 / y } else { 0.0 };
        let shader = film.map(|row| row.map(|w| w * norm));
        HeroSample { wavelengths, pdf, film, shader, bins }
    }

    /// The film's linear sRGB of radiance `l` at these wavelengths.
    pub fn to_rgb<const N: usize>(&self, l: &Spectrum<N>) -> [f32; 3] {
        self.film.map(|row| (0..HERO_LANES.min(N)).map(|i| row[i] * l.0[i]).sum())
    }

    /// A scene color tabulated at the 64 bin centres of 380–780 nm (how a
    /// hero render's scene describes its lights), at these wavelengths.
    pub fn tabulated<const N: usize>(&self, table: &[f32]) -> Spectrum<N> {
        let mut s = Spectrum::ZERO;
        if let Ok(table) = <&[f32; SCENE_BINS]>::try_from(table) {
            for (o, &(k, f)) in s.0.iter_mut().zip(&self.bins) {
                *o = table[k] + (table[k + 1] - table[k]) * f;
            }
            return s;
        }
        for (i, l) in self.wavelengths.iter().enumerate().take(N) {
            s.0[i] = interpolate_bins(table, *l);
        }
        s
    }
}

/// The value at `nm` of a curve given as `table.len()` equal-bin samples at
/// the bin centres of 380–780 nm: linear between centres, held beyond.
pub fn interpolate_bins(table: &[f32], nm: f32) -> f32 {
    let n = table.len();
    if n == 0 {
        return 0.0;
    }
    let x = (nm - LAMBDA_MIN) * (n as f32 / (LAMBDA_MAX - LAMBDA_MIN)) - 0.5;
    let x = x.clamp(0.0, (n - 1) as f32);
    let k = (x as usize).min(n.saturating_sub(2));
    if n == 1 {
        return table[0];
    }
    let f = x - k as f32;
    table[k] + (table[k + 1] - table[k]) * f
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn visible_sampling_inverts_its_distribution() {
        // The density integrates to 1 and sampling follows it: a histogram
        // of 200,000 stratified draws against the density, 20 nm bins.
        let steps = 40_000;
        let integral: f32 =
            (0..steps).map(|k| visible_pdf(380.0 + 400.0 * (k as f32 + 0.5) / steps as f32)).sum::<f32>() * 400.0
                / steps as f32;
        assert!((integral - 1.0).abs() < 1e-3, "{integral}");
        let n = 200_000;
        let mut bins = [0u32; 20];
        for k in 0..n {
            let l = sample_visible((k as f32 + 0.5) / n as f32);
            assert!((380.0..=780.0).contains(&l));
            bins[(((l - 380.0) / 20.0) as usize).min(19)] += 1;
        }
        for (b, count) in bins.iter().enumerate() {
            let lo = 380.0 + 20.0 * b as f32;
            let want: f32 = (0..200).map(|k| visible_pdf(lo + 0.1 * (k as f32 + 0.5)) * 0.1).sum();
            let got = *count as f32 / n as f32;
            assert!((got - want).abs() < 2e-3, "bin {b}: {got} vs {want}");
        }
    }

    #[test]
    fn the_estimate_of_a_flat_spectrum_averages_to_white() {
        // E[film weights · 1] over the hero draw is (1, 1, 1): average over
        // a fine grid of u (each draw already has four stratified lanes).
        let mut sum = [0.0f64; 3];
        let n = 4000;
        for k in 0..n {
            let h = HeroSample::draw((k as f32 + 0.5) / n as f32);
            let rgb = h.to_rgb(&Spectrum::<4>([1.0; 4]));
            for c in 0..3 {
                sum[c] += f64::from(rgb[c]) / n as f64;
            }
            // Shader weights: brightness of a flat spectrum is exactly 1.
            let y: f32 =
                (0..4).map(|i| 0.2126 * h.shader[0][i] + 0.7152 * h.shader[1][i] + 0.0722 * h.shader[2][i]).sum();
            assert!((y - 1.0).abs() < 1e-5, "{y}");
        }
        for c in 0..3 {
            assert!((sum[c] - 1.0).abs() < 2e-3, "{sum:?}");
        }
    }

    #[test]
    fn drawn_samples_match_the_exact_weights() {
        for k in 0..50 {
            let h = HeroSample::draw(k as f32 / 50.0);
            let film = color::hero_film_weights(&h.wavelengths, &h.pdf);
            for (i, (&l, &pdf)) in h.wavelengths.iter().zip(&h.pdf).enumerate() {
                let exact = visible_pdf(l);
                // The interpolated inverse distribution: within 1% of the exact density.
                assert!((pdf / exact - 1.0).abs() < 1e-2, "{pdf} vs {exact}");
                // rgb_matching interpolated every nanometre.
                for (got, want) in h.film.iter().zip(&film) {
                    let scale = want.iter().fold(0.0f32, |m, w| m.max(w.abs()));
                    assert!((got[i] - want[i]).abs() < 2e-3 * scale, "{} vs {}", got[i], want[i]);
                }
            }
        }
    }

    #[test]
    fn tabulated_lanes_are_the_interpolation_at_each_wavelength() {
        // The bins found once per draw give what interpolating each lookup
        // gives, bit for bit; other table sizes take the general path.
        let table: Vec<f32> = (0..64).map(|i| ((i * 37 % 64) as f32).sqrt()).collect();
        let short: Vec<f32> = (0..16).map(|i| i as f32 * 0.5).collect();
        for k in 0..=200 {
            let h = HeroSample::draw(k as f32 / 200.0);
            let got = h.tabulated::<4>(&table);
            let short_got = h.tabulated::<4>(&short);
            for (i, &l) in h.wavelengths.iter().enumerate() {
                assert_eq!(got.0[i].to_bits(), interpolate_bins(&table, l).to_bits(), "lane {i} at {l} nm");
                assert_eq!(short_got.0[i].to_bits(), interpolate_bins(&short, l).to_bits());
            }
        }
        // The draw's indices at the ends: u = 1 reads the last cell.
        for u in [0.0, 0.999_999_9, 1.0] {
            let h = HeroSample::draw(u);
            assert!(h.wavelengths.iter().all(|l| (LAMBDA_MIN..=LAMBDA_MAX).contains(l)), "{u}: {h:?}");
        }
    }

    #[test]
    fn bins_interpolate_between_centres() {
        let table: Vec<f32> = (0..64).map(|i| i as f32).collect();
        assert_eq!(interpolate_bins(&table, 380.0), 0.0);
        assert_eq!(interpolate_bins(&table, 780.0), 63.0);
        assert!((interpolate_bins(&table, 380.0 + 6.25 * 10.5) - 10.0).abs() < 1e-4);
        assert!((interpolate_bins(&table, 380.0 + 6.25 * 11.0) - 10.5).abs() < 1e-4);
    }
}
