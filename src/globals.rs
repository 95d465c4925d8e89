//! The shading globals: the surface-point record every material method and
//! generator reads, shared with generated code.
//!
//! Invariant: the layout is 34 consecutive 4-byte words in the order of
//! `check::GLOBALS`; `word_of` gives each global's first word. Generated
//! code reads words by offset, so the layout test below must never fail.

use crate::check::{GLOBALS, Ty};

/// The surface point being shaded, as the renderer (or a host) fills it.
///
/// ```
/// let g = tsl::ShadingGlobals { u: 0.5, v: 0.25, n: [0.0, 1.0, 0.0], ..Default::default() };
/// assert_eq!(g.face, 0);
/// ```
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
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
}

/// Number of 4-byte words in [`ShadingGlobals`].
pub const GLOBAL_WORDS: u32 = 34;

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
    word_global(word).map(|(_, ty, _)| ty)
}

/// How printed IR names word `word`: `u`, `N.y`; `None` past the record.
pub fn word_name(word: u32) -> Option<String> {
    let (name, ty, lane) = word_global(word)?;
    Some(if lanes(&ty) == 1 { name.to_string() } else { format!("{name}.{}", ["x", "y", "z"][lane as usize]) })
}

impl ShadingGlobals {
    /// The record as words, for the interpreter.
    pub fn words(&self) -> [u32; GLOBAL_WORDS as usize] {
        // SAFETY: `ShadingGlobals` is `repr(C)`, 136 bytes of 4-byte fields
        // with no padding (asserted in the tests), so it is 32 valid words.
        unsafe { std::mem::transmute::<ShadingGlobals, [u32; GLOBAL_WORDS as usize]>(*self) }
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
        for (name, offset) in fields {
            assert_eq!(word_of(name).unwrap().0 as usize * 4, offset, "{name}");
        }
        let g = ShadingGlobals { face: 7, u: 0.5, ..Default::default() };
        assert_eq!(g.words()[20], 7);
        assert_eq!(f32::from_bits(g.words()[12]), 0.5);
        assert_eq!(word_type(20), Some(Ty::Int));
        assert_eq!((word_type(2), word_type(GLOBAL_WORDS - 1)), (Some(Ty::Point), Some(Ty::Float)));
        assert_eq!(word_type(GLOBAL_WORDS - 2), Some(Ty::Int));
        assert_eq!(word_type(GLOBAL_WORDS), None);
        assert_eq!(
            [word_name(12), word_name(7), word_name(GLOBAL_WORDS)],
            [Some("u".into()), Some("N.y".into()), None]
        );
    }
}
