//! The shading globals: the surface-point record every material method and
//! generator reads, shared with generated code.
//!
//! Invariant: the layout is 50 consecutive 4-byte words: the 34 of the
//! globals shaders name, in the order of `check::GLOBALS` (`word_of` gives
//! each one's first word), then 16 that only the compiler reads: the
//! wavelengths of a hero-sampled color's lanes and their `to_rgb` weights
//! ([`WAVELENGTH_WORD`], [`RGB_WEIGHT_WORD`]). Generated code reads words by
//! offset, so the layout test below must never fail.

use crate::check::{GLOBALS, Ty};
use crate::color::{HERO_DEFAULT_WAVELENGTHS, HERO_LANES, LAMBDA_MAX, LAMBDA_MIN};

/// The surface point being shaded, as the renderer (or a host) fills it.
///
/// ```
/// let g = tsl::ShadingGlobals { u: 0.5, v: 0.25, n: [0.0, 1.0, 0.0], ..Default::default() };
/// assert_eq!(g.face, 0);
/// ```
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadingGlobals {
    /// `P`: hit point, world space.
    pub p: [f32; 3],
    /// `Pl`: hit point, object space.
    pub pl: [f32; 3],
    /// `N`: shading normal.
    pub n: [f32; 3],
    /// `Ng`: geometric normal.
    pub ng: [f32; 3],
    pub u: f32,
    pub v: f32,
    pub dpdu: [f32; 3],
    pub dpdv: [f32; 3],
    /// Surface number (box faces 0–5, ...).
    pub face: i32,
    /// Ray length.
    pub t: f32,
    /// Pixel footprint: change of P, u and v to the next pixel in x and y.
    pub dpdx: [f32; 3],
    pub dpdy: [f32; 3],
    pub dudx: f32,
    pub dudy: f32,
    pub dvdx: f32,
    pub dvdy: f32,
    /// `frame`: the frame being rendered (the same at every point).
    pub frame: i32,
    /// `time`: the frame's time in seconds (the same at every point).
    pub time: f32,
    /// [`ColorModel::Hero`](crate::ColorModel::Hero): the wavelength (nm)
    /// of each lane of a color, drawn per camera sample by the renderer
    /// (`tsl::render::HeroSample`). Other models ignore it. Default:
    /// [`HERO_DEFAULT_WAVELENGTHS`].
    pub wavelengths: [f32; HERO_LANES],
    /// `ColorModel::Hero`: what `to_rgb` (and so `to_xyz` and `brightness`)
    /// weighs each lane by, rows R, G, B
    /// ([`color::hero_rgb_weights`](crate::color::hero_rgb_weights) of the
    /// wavelengths). Default: those of the default wavelengths drawn
    /// uniformly.
    pub rgb_weights: [[f32; HERO_LANES]; 3],
}

impl Default for ShadingGlobals {
    fn default() -> Self {
        static WEIGHTS: std::sync::OnceLock<[[f32; HERO_LANES]; 3]> = std::sync::OnceLock::new();
        let rgb_weights = *WEIGHTS.get_or_init(|| {
            let uniform = [1.0 / (LAMBDA_MAX - LAMBDA_MIN); HERO_LANES];
            crate::color::hero_rgb_weights(&HERO_DEFAULT_WAVELENGTHS, &uniform)
        });
        ShadingGlobals {
            p: [0.0; 3],
            pl: [0.0; 3],
            n: [0.0; 3],
            ng: [0.0; 3],
            u: 0.0,
            v: 0.0,
            dpdu: [0.0; 3],
            dpdv: [0.0; 3],
            face: 0,
            t: 0.0,
            dpdx: [0.0; 3],
            dpdy: [0.0; 3],
            dudx: 0.0,
            dudy: 0.0,
            dvdx: 0.0,
            dvdy: 0.0,
            frame: 0,
            time: 0.0,
            wavelengths: HERO_DEFAULT_WAVELENGTHS,
            rgb_weights,
        }
    }
}

/// Number of 4-byte words in [`ShadingGlobals`].
pub const GLOBAL_WORDS: u32 = NAMED_WORDS + 4 * HERO_LANES as u32;
/// The words of the globals shaders name (`check::GLOBALS`).
pub const NAMED_WORDS: u32 = 34;
/// The first word of [`ShadingGlobals::wavelengths`].
pub const WAVELENGTH_WORD: u32 = NAMED_WORDS;
/// The first word of [`ShadingGlobals::rgb_weights`] (row R; then G, B).
pub const RGB_WEIGHT_WORD: u32 = WAVELENGTH_WORD + HERO_LANES as u32;

/// Lanes of a global's type.
fn lanes(ty: &Ty) -> u32 {
    if ty.is_triple() { 3 } else { 1 }
}

/// The first word of the named global, and its type.
pub fn word_of(name: &str) -> Option<(u32, Ty)> {
    let mut word = 0;
    for (n, ty, _) in GLOBALS {
        if *n == name {
            return Some((word, ty.clone()));
        }
        word += lanes(ty);
    }
    None
}

/// The global that word `word` belongs to: its name, its type and the
/// word's lane in it, or `None` past the record.
pub fn word_global(word: u32) -> Option<(&'static str, Ty, u32)> {
    let mut first = 0;
    for (name, ty, _) in GLOBALS {
        let n = lanes(ty);
        if word < first + n {
            return Some((*name, ty.clone(), word - first));
        }
        first += n;
    }
    None
}

/// The type of the global that word `word` belongs to (`face` and `frame`
/// are `int`; every other word is a float lane), or `None` past the record.
pub fn word_type(word: u32) -> Option<Ty> {
    if (NAMED_WORDS..GLOBAL_WORDS).contains(&word) {
        return Some(Ty::Float);
    }
    word_global(word).map(|(_, ty, _)| ty)
}

/// How printed IR names word `word`: `u`, `N.y`, `wavelength[2]`,
/// `rgb_weight.g[0]`; `None` past the record.
pub fn word_name(word: u32) -> Option<String> {
    if (WAVELENGTH_WORD..RGB_WEIGHT_WORD).contains(&word) {
        return Some(format!("wavelength[{}]", word - WAVELENGTH_WORD));
    }
    if (RGB_WEIGHT_WORD..GLOBAL_WORDS).contains(&word) {
        let k = (word - RGB_WEIGHT_WORD) as usize;
        return Some(format!("rgb_weight.{}[{}]", ["r", "g", "b"][k / HERO_LANES], k % HERO_LANES));
    }
    let (name, ty, lane) = word_global(word)?;
    Some(if lanes(&ty) == 1 { name.to_string() } else { format!("{name}.{}", ["x", "y", "z"][lane as usize]) })
}

impl ShadingGlobals {
    /// The record as words, for the interpreter.
    pub fn words(&self) -> [u32; GLOBAL_WORDS as usize] {
        // SAFETY: `ShadingGlobals` is `repr(C)`, 200 bytes of 4-byte fields
        // with no padding (asserted in the tests), so it is 50 valid words.
        unsafe { std::mem::transmute::<ShadingGlobals, [u32; GLOBAL_WORDS as usize]>(*self) }
    }

    /// The record whose words are `words` (the inverse of [`ShadingGlobals::words`]).
    pub fn from_words(words: &[u32; GLOBAL_WORDS as usize]) -> ShadingGlobals {
        // SAFETY: as above; every bit pattern is a valid f32 or i32.
        unsafe { std::mem::transmute::<[u32; GLOBAL_WORDS as usize], ShadingGlobals>(*words) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::offset_of;

    #[test]
    fn layout_matches_the_word_table() {
        assert_eq!(std::mem::size_of::<ShadingGlobals>(), 4 * GLOBAL_WORDS as usize);
        assert_eq!(std::mem::align_of::<ShadingGlobals>(), 4);
        let fields = [
            ("P", offset_of!(ShadingGlobals, p)),
            ("Pl", offset_of!(ShadingGlobals, pl)),
            ("N", offset_of!(ShadingGlobals, n)),
            ("Ng", offset_of!(ShadingGlobals, ng)),
            ("u", offset_of!(ShadingGlobals, u)),
            ("v", offset_of!(ShadingGlobals, v)),
            ("dPdu", offset_of!(ShadingGlobals, dpdu)),
            ("dPdv", offset_of!(ShadingGlobals, dpdv)),
            ("face", offset_of!(ShadingGlobals, face)),
            ("t", offset_of!(ShadingGlobals, t)),
            ("dPdx", offset_of!(ShadingGlobals, dpdx)),
            ("dPdy", offset_of!(ShadingGlobals, dpdy)),
            ("dudx", offset_of!(ShadingGlobals, dudx)),
            ("dudy", offset_of!(ShadingGlobals, dudy)),
            ("dvdx", offset_of!(ShadingGlobals, dvdx)),
            ("dvdy", offset_of!(ShadingGlobals, dvdy)),
            ("frame", offset_of!(ShadingGlobals, frame)),
            ("time", offset_of!(ShadingGlobals, time)),
        ];
        assert_eq!(fields.len(), GLOBALS.len());
        assert_eq!(offset_of!(ShadingGlobals, wavelengths), 4 * WAVELENGTH_WORD as usize);
        assert_eq!(offset_of!(ShadingGlobals, rgb_weights), 4 * RGB_WEIGHT_WORD as usize);
        assert_eq!(word_global(NAMED_WORDS), None);
        for (name, offset) in fields {
            assert_eq!(word_of(name).unwrap().0 as usize * 4, offset, "{name}");
        }
        let g = ShadingGlobals { face: 7, u: 0.5, ..Default::default() };
        assert_eq!(g.words()[20], 7);
        assert_eq!(f32::from_bits(g.words()[12]), 0.5);
        assert_eq!(word_type(20), Some(Ty::Int));
        assert_eq!((word_type(2), word_type(NAMED_WORDS - 1)), (Some(Ty::Point), Some(Ty::Float)));
        assert_eq!(word_type(NAMED_WORDS - 2), Some(Ty::Int));
        assert_eq!(word_type(GLOBAL_WORDS - 1), Some(Ty::Float));
        assert_eq!(word_type(GLOBAL_WORDS), None);
        assert_eq!(
            [
                word_name(12),
                word_name(7),
                word_name(WAVELENGTH_WORD + 2),
                word_name(RGB_WEIGHT_WORD + HERO_LANES as u32 + 1),
                word_name(GLOBAL_WORDS)
            ],
            [Some("u".into()), Some("N.y".into()), Some("wavelength[2]".into()), Some("rgb_weight.g[1]".into()), None]
        );
        assert_eq!(
            f32::from_bits(ShadingGlobals::default().words()[WAVELENGTH_WORD as usize + 1]),
            HERO_DEFAULT_WAVELENGTHS[1]
        );
    }
}
