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
use glam::Vec4;

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
    /// The lane of the hero, whose wavelength is `u`'s; the others are its
    /// companions.
    pub hero: usize,
    /// Where each lane reads a scene color's 64 bins ([`Self::tabulated`]):
    /// the lower bin and the fraction toward the next.
    bins: [u32; HERO_LANES],
    bin_fractions: [f32; HERO_LANES],
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

/// The cells of one lane's quarter of sample space: lane `j` draws from
/// `[j / n, (j + 1) / n)`, so the lanes of a sample share one position in
/// their quarters and one row of [`cells`].
const QUARTER_CELLS: usize = CDF_CELLS / HERO_LANES;
const _: () = assert!(HERO_LANES == 4, "a draw computes the lanes as one Vec4");

/// The bins of the scene colors' tables (`crate::Color::lanes`): where each
/// lane reads them is found once per sample, not once per lookup.
const SCENE_BINS: usize = 64;

/// Everything a draw reads for one cell position, for the four lanes at
/// once (`Vec4` lane `j` is quarter `j`'s cell), at the cell's start and as
/// the step to its end. Within a cell the wavelength is linear in `u` and
/// its density constant, so the film weights are interpolated too: the
/// film integrates against `rgb_matching` linear between the 1,025 nodes
/// (0.24 nm apart at 540 nm, 2 nm at the ends), and the estimate stays
/// unbiased for that curve.
#[derive(Default)]
struct Cell {
    wavelength: Vec4,
    wavelength_step: Vec4,
    pdf: Vec4,
    film: [Vec4; 3],
    film_step: [Vec4; 3],
}

/// What drawing a sample reads, made once from [`sample_visible`] at
/// `CDF_CELLS + 1` points and `rgb_matching` there: one [`Cell`] per
/// position in a quarter.
fn cells() -> &'static [Cell; QUARTER_CELLS] {
    static CELLS: std::sync::OnceLock<Box<[Cell; QUARTER_CELLS]>> = std::sync::OnceLock::new();
    CELLS.get_or_init(|| {
        let node = |k: usize| sample_visible(k as f32 / CDF_CELLS as f32);
        // `rgb_matching(λ) / (n p)` at `nm` for a cell of width `width` nm.
        let film = |nm: f32, width: f32| {
            let weight = f64::from(width) * (CDF_CELLS / HERO_LANES) as f64;
            color::rgb_matching(color::White::D65, f64::from(nm)).map(|m| (m * weight) as f32)
        };
        Box::new(std::array::from_fn(|c| {
            let mut cell = Cell::default();
            for j in 0..HERO_LANES {
                let k = j * QUARTER_CELLS + c;
                let (a, b) = (node(k), node(k + 1));
                let (film_a, film_b) = (film(a, b - a), film(b, b - a));
                cell.wavelength[j] = a;
                cell.wavelength_step[j] = b - a;
                cell.pdf[j] = 1.0 / (CDF_CELLS as f32 * (b - a));
                for ch in 0..3 {
                    cell.film[ch][j] = film_a[ch];
                    cell.film_step[ch][j] = film_b[ch] - film_a[ch];
                }
            }
            cell
        }))
    })
}

/// `x as usize` clamped to `0..=max`: the same index for every float (NaN
/// and negatives give 0), clamped as a float first so that the conversion
/// is one instruction, not a saturating one's compares and branches.
fn index(x: f32, max: usize) -> usize {
    // `f32::max` takes 0 for NaN.
    let x = x.max(0.0).min(max as f32);
    // SAFETY: x is finite and in 0..=max, which every table here keeps
    // far below i32::MAX.
    (unsafe { x.to_int_unchecked::<i32>() }) as usize
}

impl HeroSample {
    /// The wavelengths of `u` (the camera sample's own random number): the
    /// hero at `u`, the companions at `u + i / n` wrapped into [0, 1), so
    /// they stratify the density. Lane `j` holds the one in the `j`th
    /// quarter of [0, 1), so the hero is lane [`Self::hero`], `⌊n u⌋`.
    pub fn draw(u: f32) -> HeroSample {
        let x = u * CDF_CELLS as f32;
        let k = index(x, CDF_CELLS - 1);
        let f = Vec4::splat(x - k as u32 as f32);
        let cell = &cells()[k % QUARTER_CELLS];
        let wavelength = cell.wavelength + f * cell.wavelength_step;
        let film: [Vec4; 3] = std::array::from_fn(|c| cell.film[c] + f * cell.film_step[c]);
        // Shaders' weights: the film's over their luminance, so that a flat
        // spectrum's brightness is exactly 1 on every sample.
        let y = (0.2126 * film[0] + 0.7152 * film[1] + 0.0722 * film[2]).element_sum();
        let norm = if y > 0.0 && y < f32::INFINITY { 1.0 / y } else { 0.0 };
        // Where each lane reads a table of 64 bins: `interpolate_bins`'
        // arithmetic, four lanes at once.
        let bin_x = ((wavelength - LAMBDA_MIN) * (SCENE_BINS as f32 / (LAMBDA_MAX - LAMBDA_MIN)) - 0.5)
            .clamp(Vec4::ZERO, Vec4::splat((SCENE_BINS - 1) as f32));
        let bin = bin_x.min(Vec4::splat((SCENE_BINS - 2) as f32)).floor();
        HeroSample {
            wavelengths: wavelength.to_array(),
            pdf: cell.pdf.to_array(),
            film: film.map(|row| row.to_array()),
            shader: film.map(|row| (row * norm).to_array()),
            hero: k / QUARTER_CELLS,
            // SAFETY: `bin` is finite and in 0..=62: the clamp's `max`
            // takes 0 for NaN.
            bins: bin.to_array().map(|k| unsafe { k.to_int_unchecked::<u32>() }),
            bin_fractions: (bin_x - bin).to_array(),
        }
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
            for ((o, &k), &f) in s.0.iter_mut().zip(&self.bins).zip(&self.bin_fractions) {
                // `k` is at most 62 (`draw` clamps it).
                let k = (k as usize).min(SCENE_BINS - 2);
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
                // rgb_matching interpolated between the table's nodes (at
                // most 2 nm apart): off by a little more than rounding only
                // where a node pair straddles a kink of the CIE table.
                for (got, want) in h.film.iter().zip(&film) {
                    let scale = want.iter().fold(0.0f32, |m, w| m.max(w.abs()));
                    assert!((got[i] - want[i]).abs() < 6e-3 * scale, "{} vs {} at {l} nm", got[i], want[i]);
                }
            }
        }
    }

    #[test]
    fn the_film_integrates_against_the_exact_matching_functions() {
        // Averaged over u, the film's estimate of a smooth spectrum is its
        // integral against `rgb_matching` (by quadrature every 0.01 nm):
        // interpolating the weights inside cells costs nothing measurable.
        let radiance = |nm: f32| 1.0 + 0.5 * (nm / 23.0).sin();
        let n = 1 << 16;
        let mut got = [0.0f64; 3];
        for k in 0..n {
            let h = HeroSample::draw((k as f32 + 0.5) / n as f32);
            let l = Spectrum::<4>(h.wavelengths.map(radiance));
            for (g, x) in got.iter_mut().zip(h.to_rgb(&l)) {
                *g += f64::from(x) / f64::from(n);
            }
        }
        let steps = 40_000;
        let mut want = [0.0f64; 3];
        for k in 0..steps {
            let nm = 380.0 + 400.0 * (k as f64 + 0.5) / steps as f64;
            let m = color::rgb_matching(color::White::D65, nm);
            for c in 0..3 {
                want[c] += m[c] * f64::from(radiance(nm as f32)) * 400.0 / steps as f64;
            }
        }
        for c in 0..3 {
            assert!((got[c] / want[c] - 1.0).abs() < 2e-4, "channel {c}: {got:?} vs {want:?}");
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
