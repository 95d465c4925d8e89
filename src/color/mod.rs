//! Color models: the constant weights that turn TSL's opaque `color` into
//! per-lane arithmetic.
//!
//! A [`ColorModel`] says what a `color` value is at run time: three lanes of
//! linear sRGB ([`ColorModel::Rgb`]) or `samples` lanes of a spectrum
//! ([`ColorModel::Spectral`]). The compiler lowers every color operation into
//! scalar arithmetic per lane, so everything here is exposed as plain
//! constant vectors and matrices of `f32` for a given model: `brightness(c)`
//! becomes `sum_i luminance_weights[i] * lane_i`, and so on. Nothing here
//! panics or does I/O; all arithmetic is done in `f64` and rounded to `f32`
//! at the end. Weights that integrate the CIE tables are computed once per
//! model and kept ([`reduction_weights`]), so a host converting colors
//! pays a few dozen multiply-adds. This module is a leaf: it depends on
//! nothing else in the crate.
//!
//! # The maths
//!
//! **Lanes.** A binned model (`Spectral`, `Smits`) with `n` lanes splits
//! [`LAMBDA_MIN`]..[`LAMBDA_MAX`] (380–780 nm) into `n` equal bins;
//! [`ColorModel::wavelengths`] gives the bin centres. A measured curve
//! (`spectrum(...)`, [`resample_weights`]) and a Smits spectrum fill lane `i`
//! with their *average* over bin `i`; a Jakob–Hanika spectrum with its value
//! at the bin centre. `Spectral` lanes are read as samples at the centres:
//! the film integrates the piecewise cubic through them (fourth order in the
//! bin width, for products of spectra along a path too), `Smits` lanes as
//! constant over their bins.
//! A `Hero` color's four lanes are its values at the wavelengths in the
//! shading globals, drawn per camera sample by the renderer.
//!
//! **Whites.** Spectra are relative to a white whose lanes are all 1: D65
//! for `Spectral`, `Hero` and the RGB model's view of curves (sRGB's white;
//! Mitsuba's and pbrt's RGB illuminants are D65-based), the equal-energy E
//! for `Smits` (Smits designed his basis for it). The renderer measures
//! light as lanes times the white, so an RGB light is its reflectance curve
//! times D65, exactly as Mitsuba's `srgb_d65` emitters.
//!
//! **Colour matching.** The CIE 1931 2° standard observer and D65, tabulated
//! every 5 nm from 380 to 780 nm in `cie1931.rs` and `d65.rs` (generated from
//! colour-science by `scripts/gen_color_data.py`), are interpolated linearly
//! between the table rows. [`rgb_matching`] is
//! `scale · XYZ_TO_SRGB · cmf(λ) · white(λ) / ∫ ȳ · white`: a spectrum's
//! linear sRGB is its integral against it, and the binned models' `to_rgb`
//! weights are its integrals over each bin (`Smits`) or against each lane's
//! cardinal cubic (`Spectral`), exact: Gauss–Legendre on every piece between
//! table rows and centres, where the integrand is a polynomial. `scale` is a
//! per-channel factor (a von Kries scale in the sRGB primaries) that makes
//! the flat spectrum exactly `(1, 1, 1)`, so greys survive RGB → spectrum →
//! RGB: for D65 it is within 4e-4 of 1 (the table's D65 against sRGB's
//! rounded white), for E it is Smits' convention (colour-science's
//! `RGB_COLOURSPACE_SMITS1999`). Only 380–780 nm is integrated, in every
//! model.
//!
//! **RGB to spectrum.** `Spectral` and `Hero`: Jakob and Hanika (2019), see
//! [`jakob_hanika`]: constants and run-time values alike from the
//! coefficient table. `Smits`: B. Smits, "An RGB-to-Spectrum Conversion for
//! Reflectances", Journal of Graphics Tools 4(4), 1999: the spectrum is a
//! non-negative sum of seven basis spectra (white, cyan, magenta, yellow,
//! red, green, blue) whose multiples come from a few comparisons of the
//! components ([`smits_coefficients`]); the basis table is the paper's, 10
//! bins of 34 nm from 380 to 720 nm, the last bin held to 780 nm (the
//! numbers of colour-science's `DATA_SMITS1999`; `smits1999.rs`). Smits'
//! coefficients are linear in `(r, g, b)` for a given ordering of the
//! components, so emission values above 1 scale linearly.
//!
//! **XYZ and brightness.** [`to_xyz_weights`] gives the XYZ *of the displayed
//! linear sRGB colour* (`SRGB_TO_XYZ · to_rgb`), relative to D65 (the white
//! of sRGB), so that `to_xyz` means the same in every model: `rgb(1, 1, 1)`
//! and the flat spectrum both give the D65 white `(0.9505, 1, 1.089)`.
//! `brightness` ([`luminance_weights`]) is the Y row of that: it equals
//! `0.2126 R + 0.7152 G + 0.0722 B` of `to_rgb` in both models, and it is 1 for
//! the flat spectrum. (It differs from the plain `∫ ȳ` of the spectrum by the
//! white balance above.)
//!
//! **Measured curves.** [`resample_weights`] takes the wavelengths of a curve
//! given as `(λ_j, value_j)` samples, interpolated linearly and held constant
//! beyond its ends, and returns the matrix that averages it into the lanes:
//! lane values are `weights · values`, so the values may vary at run time
//! while the wavelengths are constant. For the RGB model the matrix gives the
//! linear sRGB of the curve through the same spectral → XYZ → sRGB path, with
//! the integrals taken exactly (the limit of an infinitely fine spectral
//! model).
//!
//! # Accuracy (checked by the tests)
//!
//! Worst channel error against colour-science 0.4.7 (1 nm CIE table, same
//! conventions; `tests/data/color_oracle.json`), the ColorChecker's 24
//! patches resampled with [`resample_weights`] from their measured 380–780 nm
//! data (under D65 for `rgb` and `spectralN`, under E for `smitsN`):
//! `rgb` 4.1e-4 (the 5 nm table's interpolation), `spectral16` 7.0e-3,
//! `spectral64` 6.8e-4 (box-averaged lanes: second order for smooth curves).
//!
//! RGB round trips (RGB → spectrum → RGB), in the limit of infinitely many
//! lanes: Jakob–Hanika's table median 1.7e-4, 99% 6e-4, worst 3.7e-3 over
//! random colors, 4.2e-4 on the ColorChecker (exact fits,
//! [`jakob_hanika::upsample_exact`], within 1e-6); in
//! `spectral16`/`32`/`64` the round trip is within 1.1e-2, 5.1e-4, 3.0e-4 on
//! saturated colors, and the film of the Cornell red wall lit by its light
//! (a product of spectra) within 1.8e-4 of the exact integral at 64 lanes. Smits (1999): 8.8e-3 saturated, 3.6e-3 unsaturated in the limit,
//! 2.0e-2 / 1.1e-2 in `smits16`. Greys survive within 1e-5 (Jakob–Hanika)
//! and 6e-4 relative (Smits, whose white dips to 0.9992), and the flat
//! spectrum is `(1, 1, 1)` with brightness 1 to `f32` rounding.

mod cie1931;
mod d65;
pub mod jakob_hanika;
mod reduction;
mod smits1999;
#[cfg(test)]
mod tests;

use cie1931::{CMF_1931, CMF_START_NM, CMF_STEP_NM};
use smits1999::{SMITS_1999, SMITS_BINS, SMITS_END_NM, SMITS_START_NM};

use reduction::smits_lane_averages;
pub use reduction::{ReductionWeights, reduction_weights};

/// The most lanes a spectral model may have.
pub const MAX_SAMPLES: usize = 64;
/// Lower end of the spectral range, nm.
pub const LAMBDA_MIN: f32 = 380.0;
/// Upper end of the spectral range, nm.
pub const LAMBDA_MAX: f32 = 780.0;
/// The wavelengths a [`ColorModel::Hero`] color carries.
pub const HERO_LANES: usize = 4;
/// The wavelengths a hero color is evaluated at outside a render (a host's
/// constant, `Program::rgb`): the centres of four equal bins.
pub const HERO_DEFAULT_WAVELENGTHS: [f32; HERO_LANES] = [430.0, 530.0, 630.0, 730.0];

const LO: f64 = LAMBDA_MIN as f64;
const HI: f64 = LAMBDA_MAX as f64;

/// Linear sRGB → CIE XYZ (D65), the matrix of IEC 61966-2-1 (as in
/// colour-science's `RGB_COLOURSPACE_sRGB.matrix_RGB_to_XYZ`). Rows are X, Y,
/// Z; the Y row is the Rec. 709 luminance 0.2126, 0.7152, 0.0722.
pub const SRGB_TO_XYZ: [[f64; 3]; 3] = [[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]];

/// CIE XYZ (D65) → linear sRGB: the exact inverse of [`SRGB_TO_XYZ`]
/// (computed here rather than the standard's rounded inverse, so that
/// `xyz_to_linear_srgb(linear_srgb_to_xyz(c)) == c` up to rounding).
pub const XYZ_TO_SRGB: [[f64; 3]; 3] = invert3(SRGB_TO_XYZ);

/// What a `color` is at run time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ColorModel {
    /// Three lanes of linear sRGB.
    Rgb,
    /// `samples` lanes, each the value of a spectrum at the centre of one of
    /// `samples` equal bins of 380–780 nm (a measured curve's average over
    /// the bin); RGB upsampled by Jakob and Hanika (2019),
    /// spectra relative to D65. Valid models have `samples` in
    /// `1..=MAX_SAMPLES` (see [`ColorModel::spectral`]); the functions of this
    /// module do not panic on others (0 lanes gives empty vectors; more than
    /// `MAX_SAMPLES` works, at a cost in proportion).
    Spectral { samples: usize },
    /// As `Spectral`, but RGB upsampled by Smits (1999) and spectra relative
    /// to the equal-energy white E (TSL's spectral model before Jakob–Hanika).
    Smits { samples: usize },
    /// [`HERO_LANES`] wavelengths drawn per camera sample (hero wavelength
    /// sampling): lane `i` is the spectrum's value at the wavelength in
    /// `ShadingGlobals::wavelengths[i]`. RGB upsampled by Jakob–Hanika,
    /// spectra relative to D65.
    Hero,
}

/// The illuminant a model's spectra are relative to: the white whose
/// lanes are all 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum White {
    /// The equal-energy spectrum (Smits' convention).
    E,
    /// CIE D65 (sRGB's white; Mitsuba's and pbrt's RGB illuminants).
    D65,
}

impl ColorModel {
    /// A spectral model, or `None` unless `1 <= samples <= MAX_SAMPLES`.
    pub fn spectral(samples: usize) -> Option<ColorModel> {
        (1..=MAX_SAMPLES).contains(&samples).then_some(ColorModel::Spectral { samples })
    }

    /// True for `Rgb`, `Hero` and for binned models with
    /// `1..=MAX_SAMPLES` lanes.
    pub fn is_valid(self) -> bool {
        match self {
            ColorModel::Rgb | ColorModel::Hero => true,
            ColorModel::Spectral { samples } | ColorModel::Smits { samples } => (1..=MAX_SAMPLES).contains(&samples),
        }
    }

    /// Number of `f32` lanes of a color: 3 for `Rgb`, `samples` for the
    /// binned models, [`HERO_LANES`] for `Hero`.
    pub fn lanes(self) -> usize {
        match self {
            ColorModel::Rgb => 3,
            ColorModel::Spectral { samples } | ColorModel::Smits { samples } => samples,
            ColorModel::Hero => HERO_LANES,
        }
    }

    /// The lanes of a binned model (`Spectral`, `Smits`), else `None`.
    pub fn bins(self) -> Option<usize> {
        match self {
            ColorModel::Spectral { samples } | ColorModel::Smits { samples } => Some(samples),
            ColorModel::Rgb | ColorModel::Hero => None,
        }
    }

    /// Whether lanes are spectral samples (every model but `Rgb`).
    pub fn is_spectral(self) -> bool {
        self != ColorModel::Rgb
    }

    /// The white the model's spectra are relative to.
    pub fn white(self) -> White {
        match self {
            ColorModel::Smits { .. } => White::E,
            _ => White::D65,
        }
    }

    /// Bin centres in nm for the binned models,
    /// `380 + (i + 0.5) · 400 / samples`; [`HERO_DEFAULT_WAVELENGTHS`] for
    /// `Hero`; empty for `Rgb`.
    pub fn wavelengths(self) -> Vec<f32> {
        match self {
            ColorModel::Rgb => Vec::new(),
            ColorModel::Hero => HERO_DEFAULT_WAVELENGTHS.to_vec(),
            ColorModel::Spectral { samples } | ColorModel::Smits { samples } => {
                (0..samples).map(|i| to_f32(0.5 * (bin(samples, i).0 + bin(samples, i).1))).collect()
            }
        }
    }

    /// `"rgb"`, `"spectral<N>"` (e.g. `"spectral16"`), `"smits<N>"` or
    /// `"hero"`; [`ColorModel::parse`] reads it back.
    pub fn name(self) -> String {
        match self {
            ColorModel::Rgb => "rgb".to_string(),
            ColorModel::Spectral { samples } => format!("spectral{samples}"),
            ColorModel::Smits { samples } => format!("smits{samples}"),
            ColorModel::Hero => "hero".to_string(),
        }
    }

    /// Reads a [`ColorModel::name`]: `"rgb"`, `"hero"`, or `"spectral<N>"`
    /// or `"smits<N>"` with `1 <= N <= MAX_SAMPLES`; `None` otherwise.
    /// `"spectral"` alone is `Hero`: wavelengths sampled per camera sample,
    /// as the spectral modes of Mitsuba 3 and pbrt-v4 are.
    ///
    /// ```
    /// use tsl::ColorModel;
    /// assert_eq!(ColorModel::parse("spectral"), Some(ColorModel::Hero));
    /// assert_eq!(ColorModel::parse("spectral16"), Some(ColorModel::Spectral { samples: 16 }));
    /// assert_eq!(ColorModel::parse("spectral65"), None);
    /// ```
    pub fn parse(name: &str) -> Option<ColorModel> {
        match name {
            "rgb" => return Some(ColorModel::Rgb),
            "hero" | "spectral" => return Some(ColorModel::Hero),
            _ => {}
        }
        let (digits, smits) = match name.strip_prefix("spectral") {
            Some(d) => (d, false),
            None => (name.strip_prefix("smits")?, true),
        };
        if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        let samples: usize = digits.parse().ok()?;
        let model = if smits { ColorModel::Smits { samples } } else { ColorModel::Spectral { samples } };
        model.is_valid().then_some(model)
    }
}

/// Weights of `brightness(c) = sum_i weights[i] * lane_i`: the CIE Y of
/// [`to_xyz_weights`] (D65-relative Y of the displayed linear sRGB color).
/// `Rgb`: exactly `[0.2126, 0.7152, 0.0722]` (Rec. 709 / IEC 61966-2-1).
/// Spectral: the Y row of the spectral → XYZ weights described in the module
/// documentation; they sum to 1, so a flat spectrum of 1 has brightness 1.
/// `Hero`: the weights at [`HERO_DEFAULT_WAVELENGTHS`] (a render computes
/// its own per camera sample, [`hero_rgb_weights`]). A copy of
/// [`reduction_weights`]' row.
pub fn luminance_weights(model: ColorModel) -> Vec<f32> {
    reduction_weights(model).luminance.clone()
}

/// Weights of `to_xyz(c)`: rows X, Y, Z, each with one weight per lane, so
/// `X = sum_i rows[0][i] * lane_i`. The result is the CIE XYZ (D65-relative)
/// of the color's linear sRGB, `SRGB_TO_XYZ · to_rgb(c)`: for `Rgb` the rows
/// of [`SRGB_TO_XYZ`]; otherwise those of [`to_rgb_weights`] mapped through it.
/// A copy of [`reduction_weights`]' rows.
pub fn to_xyz_weights(model: ColorModel) -> [Vec<f32>; 3] {
    reduction_weights(model).to_xyz.clone()
}

/// Weights of `to_rgb(c)`: linear sRGB rows R, G, B, one weight per lane.
/// `Rgb`: the identity. Binned models: CIE 1931 times the model's white
/// integrated over each bin (`Smits`) or against the lane's cardinal cubic
/// (`Spectral`, lanes read as samples at the centres), with Y of the white
/// = 1, [`XYZ_TO_SRGB`], then a per-channel scale that makes the flat
/// spectrum exactly `(1, 1, 1)`.
/// `Hero`: [`hero_rgb_weights`] at [`HERO_DEFAULT_WAVELENGTHS`] drawn
/// uniformly. A copy of [`reduction_weights`]' rows.
pub fn to_rgb_weights(model: ColorModel) -> [Vec<f32>; 3] {
    reduction_weights(model).to_rgb.clone()
}

fn rgb_weights_f64(model: ColorModel) -> [Vec<f64>; 3] {
    match model {
        ColorModel::Rgb => [vec![1.0, 0.0, 0.0], vec![0.0, 1.0, 0.0], vec![0.0, 0.0, 1.0]],
        ColorModel::Hero => {
            let pdf = [1.0 / (HI - LO) as f32; HERO_LANES];
            hero_rgb_weights(&HERO_DEFAULT_WAVELENGTHS, &pdf).map(|row| row.iter().map(|&w| f64::from(w)).collect())
        }
        ColorModel::Spectral { samples } | ColorModel::Smits { samples } => {
            spectral_rgb_weights(samples, model.white())
        }
    }
}

/// The reflectance → linear sRGB matching functions at `nm`, for spectra
/// relative to `white`: `∫ S(λ) rgb_matching(λ) dλ` over 380–780 nm is the
/// `to_rgb` of `S` in the limit of infinitely many lanes.
pub fn rgb_matching(white: White, nm: f64) -> [f64; 3] {
    let norm = white_norm(white);
    let w = white_spd(white, nm);
    let xyz = cmf(nm).map(|v| v * w / norm.y);
    let rgb = mat_apply(&XYZ_TO_SRGB, xyz);
    [0, 1, 2].map(|c| rgb[c] * norm.scale[c])
}

/// The `to_rgb` weights of one hero sample: `wavelengths` drawn with
/// densities `pdf` (per nm). The film's unbiased estimate of a radiance's
/// linear sRGB is `Σ_c rows[c] · lanes` with the rows *unnormalised*,
/// `rgb_matching(λ_i) / (pdf_i · n)` ([`hero_film_weights`]); the weights
/// shaders see (`to_rgb`, `to_xyz`, `brightness`) are these divided by their
/// luminance sum, so that a flat spectrum has brightness exactly 1 on
/// every sample.
pub fn hero_rgb_weights(wavelengths: &[f32; HERO_LANES], pdf: &[f32; HERO_LANES]) -> [[f32; HERO_LANES]; 3] {
    let film = hero_film_weights(wavelengths, pdf);
    let y: f32 = (0..HERO_LANES).map(|i| (0..3).map(|c| SRGB_TO_XYZ[1][c] as f32 * film[c][i]).sum::<f32>()).sum();
    let norm = if y > 0.0 && y.is_finite() { 1.0 / y } else { 0.0 };
    film.map(|row| row.map(|w| w * norm))
}

/// The film's weights of one hero sample: `rgb_matching(λ_i) / (pdf_i · n)`
/// per lane (0 where the pdf is 0).
pub fn hero_film_weights(wavelengths: &[f32; HERO_LANES], pdf: &[f32; HERO_LANES]) -> [[f32; HERO_LANES]; 3] {
    let mut rows = [[0.0f32; HERO_LANES]; 3];
    for i in 0..HERO_LANES {
        if pdf[i].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            continue;
        }
        let m = rgb_matching(White::D65, f64::from(wavelengths[i]));
        for c in 0..3 {
            rows[c][i] = (m[c] / (f64::from(pdf[i]) * HERO_LANES as f64)) as f32;
        }
    }
    rows
}

/// The seven basis spectra of Smits (1999), each with one value per lane.
///
/// For the spectral models: the paper's 10-bin table (380–720 nm, last bin
/// held to 780 nm) averaged over each lane's bin (`Hero`: its values at
/// [`HERO_DEFAULT_WAVELENGTHS`]). For `Rgb`: the ideal colours
/// (white = (1, 1, 1), cyan = (0, 1, 1), …, blue = (0, 0, 1)), with which
/// Smits' algorithm is exactly the identity.
#[derive(Debug, Clone, PartialEq)]
pub struct SmitsBasis {
    pub white: Vec<f32>,
    pub cyan: Vec<f32>,
    pub magenta: Vec<f32>,
    pub yellow: Vec<f32>,
    pub red: Vec<f32>,
    pub green: Vec<f32>,
    pub blue: Vec<f32>,
}

impl SmitsBasis {
    /// The seven spectra in the order of [`smits_coefficients`]: white, cyan,
    /// magenta, yellow, red, green, blue.
    pub fn spectra(&self) -> [&[f32]; 7] {
        [&self.white, &self.cyan, &self.magenta, &self.yellow, &self.red, &self.green, &self.blue]
    }
}

/// The Smits (1999) basis spectra in the model's lanes; see [`SmitsBasis`].
pub fn smits_basis(model: ColorModel) -> SmitsBasis {
    let spectra: [Vec<f32>; 7] = match model {
        ColorModel::Rgb => {
            [[1., 1., 1.], [0., 1., 1.], [1., 0., 1.], [1., 1., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]]
                .map(|c: [f32; 3]| c.to_vec())
        }
        ColorModel::Hero => SMITS_1999.map(|table| {
            HERO_DEFAULT_WAVELENGTHS
                .iter()
                .map(|&l| to_f32(smits_average(&table, f64::from(l), f64::from(l))))
                .collect()
        }),
        ColorModel::Spectral { samples } | ColorModel::Smits { samples } => {
            smits_lane_averages(samples).each_ref().map(|lanes| to_f32s(lanes))
        }
    };
    let [white, cyan, magenta, yellow, red, green, blue] = spectra;
    SmitsBasis { white, cyan, magenta, yellow, red, green, blue }
}

/// Smits' (1999) multiples of the seven basis spectra for `rgb`, in the
/// order white, cyan, magenta, yellow, red, green, blue; the color's lanes
/// are `sum_k coef[k] * basis_k` ([`smits_basis`]).
///
/// The logic (the branchy part of the algorithm, which the compiler can emit
/// as is): if red is the smallest component, take `r` of white, then
/// `min(g, b) - r` of cyan and `|g - b|` of blue (if `g <= b`) or of green;
/// if green is smallest, `g` of white, `min(r, b) - g` of magenta and
/// `|r - b|` of blue (`r <= b`) or red; otherwise `b` of white,
/// `min(r, g) - b` of yellow and `|r - g|` of green (`r <= g`) or red. Ties
/// go to the first case that applies, as in the paper and colour-science.
pub fn smits_coefficients(rgb: [f32; 3]) -> [f32; 7] {
    let [r, g, b] = rgb;
    let mut c = [0.0f32; 7];
    const WHITE: usize = 0;
    const CYAN: usize = 1;
    const MAGENTA: usize = 2;
    const YELLOW: usize = 3;
    const RED: usize = 4;
    const GREEN: usize = 5;
    const BLUE: usize = 6;
    if r <= g && r <= b {
        c[WHITE] = r;
        if g <= b {
            c[CYAN] = g - r;
            c[BLUE] = b - g;
        } else {
            c[CYAN] = b - r;
            c[GREEN] = g - b;
        }
    } else if g <= r && g <= b {
        c[WHITE] = g;
        if r <= b {
            c[MAGENTA] = r - g;
            c[BLUE] = b - r;
        } else {
            c[MAGENTA] = b - g;
            c[RED] = r - b;
        }
    } else {
        c[WHITE] = b;
        if r <= g {
            c[YELLOW] = r - b;
            c[GREEN] = g - r;
        } else {
            c[YELLOW] = g - b;
            c[RED] = r - g;
        }
    }
    c
}

/// The lanes of the constant `rgb(r, g, b)` (linear sRGB): `Rgb` → the
/// triple itself; `Spectral` → the Jakob–Hanika spectrum
/// ([`jakob_hanika::upsample`]) at each bin's centre; `Smits` → Smits
/// (1999), `sum_k smits_coefficients(rgb)[k] * smits_basis(model)_k`;
/// `Hero` → the Jakob–Hanika spectrum at [`HERO_DEFAULT_WAVELENGTHS`].
pub fn rgb_to_lanes(model: ColorModel, rgb: [f32; 3]) -> Vec<f32> {
    match model {
        ColorModel::Rgb => rgb.to_vec(),
        ColorModel::Spectral { .. } => {
            let s = jakob_hanika::upsample(rgb);
            model.wavelengths().iter().map(|&l| s.eval(l)).collect()
        }
        ColorModel::Hero => {
            let s = jakob_hanika::upsample(rgb);
            HERO_DEFAULT_WAVELENGTHS.iter().map(|&l| s.eval(l)).collect()
        }
        ColorModel::Smits { samples } => {
            let coef = smits_coefficients(rgb);
            let basis = smits_lane_averages(samples);
            let mut lanes = vec![0.0f64; samples];
            for (spectrum, &k) in basis.iter().zip(&coef) {
                if k == 0.0 {
                    continue;
                }
                for (lane, average) in lanes.iter_mut().zip(spectrum) {
                    *lane += f64::from(k) * average;
                }
            }
            to_f32s(&lanes)
        }
    }
}

/// CIE XYZ (D65-relative, Y = 1 for white) → linear sRGB, with
/// [`XYZ_TO_SRGB`].
pub fn xyz_to_linear_srgb(xyz: [f32; 3]) -> [f32; 3] {
    mat3_apply(&XYZ_TO_SRGB, xyz)
}

/// Linear sRGB → CIE XYZ (D65), with [`SRGB_TO_XYZ`] (IEC 61966-2-1).
pub fn linear_srgb_to_xyz(rgb: [f32; 3]) -> [f32; 3] {
    mat3_apply(&SRGB_TO_XYZ, rgb)
}

/// The matrix (lanes × inputs) that resamples a measured curve into the
/// model's lanes: `lane_i = sum_j w[i][j] * value_j`.
///
/// The curve is given by samples `(wavelengths_nm[j], value_j)`, interpolated
/// linearly and held constant beyond the first and last sample (a single
/// sample is a constant curve). For `Spectral`, lane `i` is the exact average
/// of the curve over bin `i`, so every row sums to 1 and a flat curve stays
/// flat. For `Rgb`, the three rows give the linear sRGB of the curve through
/// the spectral → XYZ → sRGB path of [`to_rgb_weights`] (the curve lit by
/// D65), with the integrals of curve × [`rgb_matching`] taken exactly
/// (Simpson's rule on the merged knots, exact for these piecewise cubics): a
/// flat curve of 1 gives `(1, 1, 1)`. For `Hero`, the rows interpolate the
/// curve at [`HERO_DEFAULT_WAVELENGTHS`].
///
/// Wavelengths need not be sorted (samples are sorted by wavelength, ties
/// kept in order, which makes a step); a sample with a non-finite wavelength
/// is ignored (its column is 0), and with no usable sample every weight is 0.
pub fn resample_weights(model: ColorModel, wavelengths_nm: &[f32]) -> Vec<Vec<f32>> {
    resample_weights_over(model, wavelengths_nm, false)
}

/// [`resample_weights`] for a curve of absolute spectral power (a scene
/// light's `spectrum(...)`, as Mitsuba reads an emitter's spectrum): the
/// curve is divided by the model's white ([`white_power`]) before it
/// becomes lanes, so the flat curve of 1 is the equal-energy light of
/// luminance 1 (sRGB about `(1.205, 0.948, 0.909)`), not the model's white.
/// `Smits` models, whose white is E, take curves as they are.
pub fn emission_resample_weights(model: ColorModel, wavelengths_nm: &[f32]) -> Vec<Vec<f32>> {
    resample_weights_over(model, wavelengths_nm, true)
}

/// The spectral power of the white a model's lanes are relative to, at
/// `nm`, normalised to the luminance of the flat spectrum 1: D65 times
/// `∫ ȳ / ∫ ȳ · D65` (over 380–780 nm), or 1 for E. Lanes of all 1 are this
/// light.
pub fn white_power(white: White, nm: f64) -> f64 {
    match white {
        White::E => 1.0,
        White::D65 => {
            static RATIO: std::sync::OnceLock<f64> = std::sync::OnceLock::new();
            let ratio = RATIO.get_or_init(|| cmf_integral(LO, HI, White::E)[1] / white_norm(White::D65).y);
            d65(nm) * ratio
        }
    }
}

fn resample_weights_over(model: ColorModel, wavelengths_nm: &[f32], absolute: bool) -> Vec<Vec<f32>> {
    let white = model.white();
    let factor = |l: f64| if absolute { 1.0 / white_power(white, l) } else { 1.0 };
    let inputs = wavelengths_nm.len();
    let mut order: Vec<usize> = (0..inputs).filter(|&j| wavelengths_nm[j].is_finite()).collect();
    order.sort_by(|&a, &b| wavelengths_nm[a].total_cmp(&wavelengths_nm[b]));
    let xs: Vec<f64> = order.iter().map(|&j| f64::from(wavelengths_nm[j])).collect();
    // Rows over the sorted samples, then scattered back to the caller's order.
    let sorted_rows: Vec<Vec<f64>> = match model {
        ColorModel::Spectral { samples } | ColorModel::Smits { samples } => (0..samples)
            .map(|i| {
                let (a, b) = bin(samples, i);
                let knots = if absolute { cmf_knots() } else { Vec::new() };
                hat_integrals(&xs, a, b, factor, &knots).into_iter().map(|w| w / (b - a)).collect()
            })
            .collect(),
        ColorModel::Hero => HERO_DEFAULT_WAVELENGTHS
            .iter()
            .map(|&l| {
                let l = f64::from(l);
                interpolation_weights(&xs, l).into_iter().map(|w| w * factor(l)).collect()
            })
            .collect(),
        ColorModel::Rgb => {
            let knots = cmf_knots();
            (0..3).map(|c| hat_integrals(&xs, LO, HI, |l| rgb_matching(white, l)[c] * factor(l), &knots)).collect()
        }
    };
    sorted_rows
        .into_iter()
        .map(|row| {
            let mut out = vec![0.0f32; inputs];
            for (&j, w) in order.iter().zip(row) {
                out[j] = to_f32(w);
            }
            out
        })
        .collect()
}

/// The linear sRGB of a color's lanes, `to_rgb_weights(model) · lanes`
/// (identity for `Rgb`), with the model's cached weights
/// ([`reduction_weights`]). Missing lanes count as 0, extra lanes are
/// ignored.
pub fn lanes_to_rgb(model: ColorModel, lanes: &[f32]) -> [f32; 3] {
    reduction_weights(model).rgb(lanes)
}

/// The linear sRGB of `lanes` under `weights` (rows R, G, B), summed in
/// `f64` lane by lane.
pub fn weighted_rgb(weights: &[Vec<f32>; 3], lanes: &[f32]) -> [f32; 3] {
    let dot = |row: &[f32]| row.iter().zip(lanes).map(|(w, l)| f64::from(*w) * f64::from(*l)).sum::<f64>() as f32;
    let [r, g, b] = weights;
    if r.len() != g.len() || g.len() != b.len() {
        return [dot(r), dot(g), dot(b)];
    }
    // The three rows in one pass: three independent chains of additions
    // instead of one three times as long. Each row
    // is still summed lane by lane from -0.0, as `Iterator::sum` does, so
    // the results are the bits of `dot`.
    let mut sums = [-0.0f64; 3];
    for (((&l, &r), &g), &b) in lanes.iter().zip(r).zip(g).zip(b) {
        let l = f64::from(l);
        sums[0] += f64::from(r) * l;
        sums[1] += f64::from(g) * l;
        sums[2] += f64::from(b) * l;
    }
    sums.map(|s| s as f32)
}

// ---------------------------------------------------------------------------
// Internals, all in f64.

fn to_f32(x: f64) -> f32 {
    x as f32
}

fn to_f32s(xs: &[f64]) -> Vec<f32> {
    xs.iter().map(|&x| to_f32(x)).collect()
}

/// Bin `i` of `n` equal bins of 380–780 nm.
fn bin(n: usize, i: usize) -> (f64, f64) {
    let width = (HI - LO) / n as f64;
    (LO + width * i as f64, if i + 1 == n { HI } else { LO + width * (i + 1) as f64 })
}

/// The wavelengths of the rows of the CIE table.
fn cmf_knots() -> Vec<f64> {
    (0..CMF_1931.len()).map(|k| CMF_START_NM + CMF_STEP_NM * k as f64).collect()
}

/// Row `k` and the fraction toward row `k + 1` of the 5 nm tables at `l`
/// nm, held constant beyond them (only 380–780 nm is ever integrated).
fn table_position(l: f64) -> (usize, f64) {
    let last = CMF_1931.len() - 1;
    let t = ((l - CMF_START_NM) / CMF_STEP_NM).clamp(0.0, last as f64);
    let k = (t.floor() as usize).min(last - 1);
    (k, t - k as f64)
}

/// The CIE 1931 functions at `l` nm, interpolated linearly between the table
/// rows.
fn cmf(l: f64) -> [f64; 3] {
    let (k, f) = table_position(l);
    let (a, b) = (CMF_1931[k], CMF_1931[k + 1]);
    [0, 1, 2].map(|c| a[c] + (b[c] - a[c]) * f)
}

/// CIE D65 at `l` nm (100 at 560 nm), interpolated linearly between the
/// table rows.
pub(crate) fn d65(l: f64) -> f64 {
    let (k, f) = table_position(l);
    d65::D65[k] + (d65::D65[k + 1] - d65::D65[k]) * f
}

/// The spectral power of `white` at `l` nm (unnormalised).
fn white_spd(white: White, l: f64) -> f64 {
    match white {
        White::E => 1.0,
        White::D65 => d65(l),
    }
}

/// `∫_a^b` of each colour matching function times `white`: exact (the
/// integrand is a quadratic between table rows; four-point Gauss–Legendre
/// on each piece).
fn cmf_integral(a: f64, b: f64, white: White) -> [f64; 3] {
    let mut cuts: Vec<f64> = std::iter::once(a).chain(cmf_knots().into_iter().filter(|&x| x > a && x < b)).collect();
    cuts.push(b);
    let mut sum = [0.0; 3];
    for p in cuts.windows(2) {
        let (u, v) = (p[0], p[1]);
        for (x, w) in jakob_hanika::GAUSS_LEGENDRE_4 {
            let l = u + 0.5 * (v - u) * (x + 1.0);
            let f = cmf(l).map(|c| c * white_spd(white, l) * w * 0.5 * (v - u));
            for c in 0..3 {
                sum[c] += f[c];
            }
        }
    }
    sum
}

/// The normalisation of a white: `∫ ȳ · white` over 380–780 nm, and the
/// per-channel scale that makes the flat spectrum `(1, 1, 1)`,
/// `1 / (XYZ_TO_SRGB · ∫ cmf · white / ∫ ȳ · white)`.
struct WhiteNorm {
    y: f64,
    scale: [f64; 3],
}

fn white_norm(white: White) -> &'static WhiteNorm {
    fn compute(white: White) -> WhiteNorm {
        let xyz = cmf_integral(LO, HI, white);
        let flat = xyz.map(|v| v / xyz[1]);
        let rgb = mat_apply(&XYZ_TO_SRGB, flat);
        WhiteNorm { y: xyz[1], scale: rgb.map(|v| 1.0 / v) }
    }
    static E: std::sync::OnceLock<WhiteNorm> = std::sync::OnceLock::new();
    static D65: std::sync::OnceLock<WhiteNorm> = std::sync::OnceLock::new();
    match white {
        White::E => E.get_or_init(|| compute(White::E)),
        White::D65 => D65.get_or_init(|| compute(White::D65)),
    }
}

/// `to_rgb` weights of a binned model with `n` lanes relative to `white`,
/// in f64. `Smits` lanes are bin averages of a piecewise-constant basis:
/// each weighs its bin's integral. `Spectral` lanes are the spectrum at the
/// bin centres: the film integrates the piecewise cubic through them
/// ([`lane_cardinals`]), fourth order in the bin width where the bins'
/// integrals were second order (a product of saturated spectra, the red
/// Cornell wall's green under the light: 64 lanes +0.38% -> 0.01%).
fn spectral_rgb_weights(n: usize, white: White) -> [Vec<f64>; 3] {
    let norm = white_norm(white);
    let per_lane: Vec<[f64; 3]> = match white {
        White::E => (0..n).map(|i| bin(n, i)).map(|(a, b)| cmf_integral(a, b, white)).collect(),
        White::D65 => interpolated_lane_integrals(n, white),
    };
    let per_lane = per_lane.into_iter().map(|xyz| mat_apply(&XYZ_TO_SRGB, xyz.map(|v| v / norm.y)));
    let per_lane: Vec<[f64; 3]> = per_lane.collect();
    [0, 1, 2].map(|c| per_lane.iter().map(|v| v[c] * norm.scale[c]).collect())
}

/// The lanes at `l` nm of the piecewise-cubic interpolant through `n` lanes
/// at the bin centres: the first lane it reads and the weights of up to
/// four (Lagrange on the four centres around `l`, fewer when `n < 4`;
/// extrapolated over the half bins at the ends). Weights sum to 1.
fn lane_cardinals(n: usize, l: f64) -> (usize, [f64; 4]) {
    let degree = n.saturating_sub(1).min(3);
    // Lane i's centre is at t = i.
    let t = (l - LO) * n as f64 / (HI - LO) - 0.5;
    let below = t.floor() - (degree.saturating_sub(1) / 2) as f64;
    let first = below.clamp(0.0, (n - 1 - degree) as f64) as usize;
    let mut w = [0.0; 4];
    for (j, wj) in w.iter_mut().enumerate().take(degree + 1) {
        *wj = (0..=degree).filter(|&m| m != j).map(|m| (t - (first + m) as f64) / (j as f64 - m as f64)).product();
    }
    (first, w)
}

/// `∫ cmf · white · φ_i` over 380–780 nm for each lane's cardinal function
/// `φ_i` ([`lane_cardinals`]), exact: on pieces between the table rows and
/// the centres the integrand is a polynomial of degree 5, and four-point
/// Gauss–Legendre is exact to degree 7.
fn interpolated_lane_integrals(n: usize, white: White) -> Vec<[f64; 3]> {
    if n == 0 {
        return Vec::new();
    }
    let centres = (0..n).map(|i| LO + (HI - LO) * (i as f64 + 0.5) / n as f64);
    let mut cuts: Vec<f64> = cmf_knots().into_iter().chain(centres).filter(|&x| x > LO && x < HI).collect();
    cuts.extend([LO, HI]);
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    let mut sums = vec![[0.0; 3]; n];
    for p in cuts.windows(2) {
        let (u, v) = (p[0], p[1]);
        for (x, w) in jakob_hanika::GAUSS_LEGENDRE_4 {
            let l = u + 0.5 * (v - u) * (x + 1.0);
            let f = cmf(l).map(|c| c * white_spd(white, l) * w * 0.5 * (v - u));
            let (first, cardinals) = lane_cardinals(n, l);
            for (k, phi) in cardinals.iter().enumerate().filter(|(_, phi)| **phi != 0.0) {
                for c in 0..3 {
                    sums[first + k][c] += f[c] * phi;
                }
            }
        }
    }
    sums
}

/// Quadrature nodes over 380–780 nm and, per node, its weight times the
/// reflectance → sRGB matching functions relative to D65, so that
/// `Σ_k weights[k] · S(nodes[k])` is `∫ S · rgb_matching` (exact to ~1e-9
/// for smooth `S`: four-point Gauss–Legendre on every 5 nm piece).
pub(crate) fn reflectance_rgb_nodes() -> (Vec<f64>, Vec<[f64; 3]>) {
    let knots = cmf_knots();
    let mut nodes = Vec::new();
    let mut weights = Vec::new();
    for p in knots.windows(2) {
        let (u, v) = (p[0], p[1]);
        for (x, w) in jakob_hanika::GAUSS_LEGENDRE_4 {
            let l = u + 0.5 * (v - u) * (x + 1.0);
            nodes.push(l);
            weights.push(rgb_matching(White::D65, l).map(|m| m * w * 0.5 * (v - u)));
        }
    }
    (nodes, weights)
}

/// The weights that interpolate the curve through knots `xs` (sorted;
/// linear, constant beyond the ends) at `l`.
fn interpolation_weights(xs: &[f64], l: f64) -> Vec<f64> {
    let n = xs.len();
    let mut w = vec![0.0; n];
    if n == 0 {
        return w;
    }
    let m = xs.partition_point(|&x| x <= l);
    if m == 0 {
        w[0] = 1.0;
    } else if m == n {
        w[n - 1] = 1.0;
    } else {
        let t = (l - xs[m - 1]) / (xs[m] - xs[m - 1]);
        w[m - 1] = 1.0 - t;
        w[m] = t;
    }
    w
}

/// `m · rows`, where `rows` are three vectors of equal length.
fn mat_times_rows(m: &[[f64; 3]; 3], rows: &[Vec<f64>; 3]) -> [Vec<f64>; 3] {
    let len = rows[0].len();
    m.map(|mr| (0..len).map(|i| mr[0] * rows[0][i] + mr[1] * rows[1][i] + mr[2] * rows[2][i]).collect())
}

fn mat3_apply(m: &[[f64; 3]; 3], v: [f32; 3]) -> [f32; 3] {
    mat_apply(m, v.map(f64::from)).map(to_f32)
}

fn mat_apply(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    m.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
}

/// The inverse of a 3×3 matrix (by cofactors), usable in constants.
const fn invert3(m: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let c00 = m[1][1] * m[2][2] - m[1][2] * m[2][1];
    let c01 = m[1][2] * m[2][0] - m[1][0] * m[2][2];
    let c02 = m[1][0] * m[2][1] - m[1][1] * m[2][0];
    let det = m[0][0] * c00 + m[0][1] * c01 + m[0][2] * c02;
    let d = 1.0 / det;
    [
        [c00 * d, (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * d, (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * d],
        [c01 * d, (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * d, (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * d],
        [c02 * d, (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * d, (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * d],
    ]
}

/// Average over lane `i` of `n` of a Smits basis spectrum: piecewise constant
/// on 10 bins of 34 nm from 380 nm, the last bin held to 780 nm.
fn smits_bin_average(table: &[f64; SMITS_BINS], n: usize, i: usize) -> f64 {
    let (a, b) = bin(n, i);
    smits_average(table, a, b)
}

/// Average of a Smits basis spectrum over `[a, b]` nm (its value at `a`
/// when `a == b`).
fn smits_average(table: &[f64; SMITS_BINS], a: f64, b: f64) -> f64 {
    if b <= a {
        let width = (SMITS_END_NM - SMITS_START_NM) / SMITS_BINS as f64;
        let k = (((a - SMITS_START_NM) / width).floor().max(0.0) as usize).min(SMITS_BINS - 1);
        return table[k];
    }
    let width = (SMITS_END_NM - SMITS_START_NM) / SMITS_BINS as f64;
    let mut sum = 0.0;
    for (k, value) in table.iter().enumerate() {
        let lo = SMITS_START_NM + width * k as f64;
        let hi = if k + 1 == SMITS_BINS { f64::INFINITY } else { lo + width };
        let overlap = b.min(hi) - a.max(lo);
        if overlap > 0.0 {
            sum += value * overlap;
        }
    }
    sum / (b - a)
}

/// For the curve through knots `xs` (sorted; interpolated linearly, constant
/// beyond the ends), the weights `w_j` with
/// `∫_a^b curve(λ) g(λ) dλ = sum_j w_j value_j`. Exact when `g` is linear
/// between consecutive `g_knots` (and between the curve's knots): each piece
/// of the product is a quadratic, integrated by Simpson's rule.
fn hat_integrals(xs: &[f64], a: f64, b: f64, g: impl Fn(f64) -> f64, g_knots: &[f64]) -> Vec<f64> {
    let n = xs.len();
    let mut w = vec![0.0; n];
    if n == 0 || b <= a {
        return w;
    }
    let mut cuts: Vec<f64> = std::iter::once(a)
        .chain(xs.iter().chain(g_knots).copied().filter(|&x| x > a && x < b))
        .chain(std::iter::once(b))
        .collect();
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    for pair in cuts.windows(2) {
        let (u, v) = (pair[0], pair[1]);
        let mid = 0.5 * (u + v);
        // The piece lies inside one segment of the curve: find it by its middle.
        let m = xs.partition_point(|&x| x <= mid);
        let h = (v - u) / 6.0;
        for (p, simpson) in [(u, h), (mid, 4.0 * h), (v, h)] {
            let weight = simpson * g(p);
            if m == 0 {
                w[0] += weight;
            } else if m == n {
                w[n - 1] += weight;
            } else {
                let t = (p - xs[m - 1]) / (xs[m] - xs[m - 1]);
                w[m - 1] += weight * (1.0 - t);
                w[m] += weight * t;
            }
        }
    }
    w
}
