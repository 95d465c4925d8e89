//! Weights that integrate the CIE tables, computed once per colour model
//! and kept: a host converting colors (`Color::to_rgb`, `brightness`) and
//! texture loading (`rgb_to_lanes` in the Smits models, per texel) pay a
//! few dozen multiply-adds instead of the integrals.

use super::*;
use std::borrow::Cow;
use std::sync::OnceLock;

/// A model's reductions of a color to a few numbers, each a row of one
/// weight per lane: `to_rgb` (rows R, G, B), `to_xyz` (rows X, Y, Z) and
/// `brightness` (the Y row). The binned models' weights integrate the CIE
/// table, so they are computed once per model and kept
/// ([`reduction_weights`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ReductionWeights {
    /// [`to_rgb_weights`].
    pub to_rgb: [Vec<f32>; 3],
    /// [`to_xyz_weights`].
    pub to_xyz: [Vec<f32>; 3],
    /// [`luminance_weights`].
    pub luminance: Vec<f32>,
    /// `to_rgb` by lane, `[r, g, b]` of lane `i`, widened to `f64` (as
    /// [`weighted_rgb`] widens them): one pass over the lanes reads each
    /// lane's three weights together.
    rgb_by_lane: Vec<[f64; 3]>,
}

impl ReductionWeights {
    /// The weights of `model`, computed (the integrals of the module
    /// documentation; tens of microseconds for a binned model).
    fn compute(model: ColorModel) -> ReductionWeights {
        let (to_rgb, to_xyz, luminance) = match model {
            ColorModel::Rgb => (
                [vec![1.0, 0.0, 0.0], vec![0.0, 1.0, 0.0], vec![0.0, 0.0, 1.0]],
                SRGB_TO_XYZ.map(|row| row.iter().map(|&w| to_f32(w)).collect()),
                vec![0.2126, 0.7152, 0.0722],
            ),
            _ => {
                let rgb = rgb_weights_f64(model);
                let to_xyz = mat_times_rows(&SRGB_TO_XYZ, &rgb).map(|row| to_f32s(&row));
                let luminance = to_xyz[1].clone();
                (rgb.map(|row| to_f32s(&row)), to_xyz, luminance)
            }
        };
        let [r, g, b] = &to_rgb;
        let rgb_by_lane = r.iter().zip(g).zip(b).map(|((&r, &g), &b)| [r, g, b].map(f64::from)).collect();
        ReductionWeights { to_rgb, to_xyz, luminance, rgb_by_lane }
    }

    /// The linear sRGB of `lanes`, `to_rgb · lanes`: the bits of
    /// [`weighted_rgb`], in one pass over the lanes (each row summed lane
    /// by lane from -0.0 in `f64`, as `Iterator::sum` does; the three sums
    /// are independent, so they run side by side).
    pub fn rgb(&self, lanes: &[f32]) -> [f32; 3] {
        let mut sums = [-0.0f64; 3];
        for (w, &l) in self.rgb_by_lane.iter().zip(lanes) {
            let l = f64::from(l);
            sums[0] += w[0] * l;
            sums[1] += w[1] * l;
            sums[2] += w[2] * l;
        }
        sums.map(|s| s as f32)
    }

    /// The brightness (CIE Y) of `lanes`, `luminance · lanes`, summed in
    /// `f32` lane by lane.
    pub fn brightness(&self, lanes: &[f32]) -> f32 {
        self.luminance.iter().zip(lanes).map(|(w, x)| w * x).sum()
    }
}

/// The [`ReductionWeights`] of `model`: computed on first use and kept for
/// the life of the process for the valid models (`Rgb`, `Hero`, binned
/// models of `1..=MAX_SAMPLES` lanes: at most 130 sets, 220 KB), after
/// which a call is an atomic load, with no lock (`Color::to_rgb` and
/// `brightness` call it per color); computed at every call for other
/// models.
///
/// ```
/// use tsl::{ColorModel, color::reduction_weights};
/// let weights = reduction_weights(ColorModel::Spectral { samples: 16 });
/// let flat = [1.0f32; 16];
/// assert!((weights.brightness(&flat) - 1.0).abs() < 1e-5);
/// assert!(weights.rgb(&flat).iter().all(|c| (c - 1.0).abs() < 1e-5));
/// ```
pub fn reduction_weights(model: ColorModel) -> Cow<'static, ReductionWeights> {
    static RGB: OnceLock<ReductionWeights> = OnceLock::new();
    static HERO: OnceLock<ReductionWeights> = OnceLock::new();
    static SPECTRAL: PerLaneCount<ReductionWeights> = PerLaneCount::new();
    static SMITS: PerLaneCount<ReductionWeights> = PerLaneCount::new();
    let compute = || ReductionWeights::compute(model);
    let cached = match model {
        ColorModel::Rgb => Some(RGB.get_or_init(compute)),
        ColorModel::Hero => Some(HERO.get_or_init(compute)),
        ColorModel::Spectral { samples } => SPECTRAL.get_or_init(samples, compute),
        ColorModel::Smits { samples } => SMITS.get_or_init(samples, compute),
    };
    cached.map_or_else(|| Cow::Owned(compute()), Cow::Borrowed)
}

/// One value per lane count of a binned model (`1..=MAX_SAMPLES`), each
/// computed on first use; reading one computed already is an atomic load.
struct PerLaneCount<T>([OnceLock<T>; MAX_SAMPLES]);

impl<T> PerLaneCount<T> {
    const fn new() -> Self {
        PerLaneCount([const { OnceLock::new() }; MAX_SAMPLES])
    }

    /// The value for `samples` lanes, or `None` outside `1..=MAX_SAMPLES`.
    fn get_or_init(&self, samples: usize, compute: impl FnOnce() -> T) -> Option<&T> {
        let cell = self.0.get(samples.checked_sub(1)?)?;
        Some(cell.get_or_init(compute))
    }
}

/// The seven Smits basis spectra averaged over each of `n` lanes' bins
/// ([`smits_bin_average`]), computed once per lane count for
/// `1..=MAX_SAMPLES` (at most 116 KB; `rgb_to_lanes` upsamples every texel
/// of an image).
pub(super) fn smits_lane_averages(n: usize) -> Cow<'static, [Vec<f64>; 7]> {
    static CACHE: PerLaneCount<[Vec<f64>; 7]> = PerLaneCount::new();
    let compute = || SMITS_1999.map(|table| (0..n).map(|i| smits_bin_average(&table, n, i)).collect());
    CACHE.get_or_init(n, compute).map_or_else(|| Cow::Owned(compute()), Cow::Borrowed)
}
