//! Participating media for the integrators: the stack of media a ray is
//! inside, the globals each was entered at, absorption along a segment,
//! and the relative index of refraction at a crossing.

use super::{Shading, Tracer, ZERO_GLOBALS};
use crate::ShadingGlobals;
use crate::render::spectrum::Spectrum;

/// A medium the ray is inside: the object entered, and where the globals
/// of the point it was entered at (for its `absorption` and
/// `refraction_index`) are kept in [`Tracer::entered`]; [`NO_GLOBALS`]
/// when the material reads neither. Small, so media copy cheaply.
#[derive(Clone, Copy)]
pub(super) struct Medium {
    pub(super) object: u32,
    g: u32,
}

const NO_GLOBALS: u32 = u32::MAX;

/// Media are nested at most this deep; deeper entries are ignored.
const MAX_MEDIA: usize = 4;

/// The media a ray is inside, innermost last; a copyable fixed stack so
/// that refraction does not allocate.
#[derive(Clone, Copy)]
pub(super) struct Media {
    items: [Medium; MAX_MEDIA],
    len: usize,
}

/// No media: rays start in vacuum. A static, so passing it by reference
/// copies nothing.
pub(super) static NO_MEDIA: Media = Media::NONE;

impl Media {
    pub(super) const NONE: Media = Media { items: [Medium { object: u32::MAX, g: NO_GLOBALS }; MAX_MEDIA], len: 0 };

    pub(super) fn as_slice(&self) -> &[Medium] {
        &self.items[..self.len]
    }

    pub(super) fn innermost(&self) -> Option<&Medium> {
        self.as_slice().last()
    }
}

impl<'s, const N: usize> Tracer<'s, N> {
    /// Light left after `distance` inside `medium`.
    pub(super) fn absorb(&self, medium: Option<&Medium>, light: Spectrum<N>, distance: f32) -> Spectrum<N> {
        let Some(m) = medium else { return light };
        let object = self.scene.object(m.object);
        if object.clear {
            return light;
        }
        let mut out = Spectrum::ZERO;
        object.material.absorption_into(self.entry_globals(m), &light.0, distance, &mut out.0);
        out
    }

    /// The globals where a medium was entered.
    pub(super) fn entry_globals(&self, m: &Medium) -> &ShadingGlobals {
        // Media whose material reads them always have them.
        self.entered.get(m.g as usize).unwrap_or(&ZERO_GLOBALS)
    }

    /// The relative index `n_entered / n_left` for light crossing the
    /// surface from the `wo` side, and whether crossing enters the object.
    pub(super) fn eta(&self, sh: &Shading, media: &Media) -> (Spectrum<N>, bool) {
        let entering = sh.surface.ng.dot(sh.wo) > 0.0;
        let inside = |m: &&Medium| m.object != sh.hit.object;
        let other = match media.as_slice().iter().rev().find(inside) {
            Some(m) => self.refraction_index(self.scene.object(m.object), self.entry_globals(m)),
            None => self.ones,
        };
        let own = self.refraction_index(sh.object, sh.g);
        if entering { (own.safe_div(&other), true) } else { (other.safe_div(&own), false) }
    }

    /// The media after crossing the surface of `sh` (entering pushes it,
    /// leaving removes it). Straight-through crossings (eta 1, the ray not
    /// bent: cutouts, thin sheets) are not media.
    pub(super) fn crossed(&mut self, sh: &Shading, media: &Media, entering: bool, straight: bool) -> Media {
        let mut out = *media;
        if straight {
            return out;
        }
        if entering {
            if out.len < MAX_MEDIA {
                let o = sh.object;
                let g = if o.clear && (!o.refracts || o.constant_ior.is_some()) {
                    NO_GLOBALS
                } else {
                    self.entered.push(*sh.g);
                    self.entered.len() as u32 - 1
                };
                out.items[out.len] = Medium { object: sh.hit.object, g };
                out.len += 1;
            }
        } else if let Some(k) = out.as_slice().iter().rposition(|m| m.object == sh.hit.object) {
            out.items.copy_within(k + 1..out.len, k);
            out.len -= 1;
        }
        out
    }

    /// The relative index of refraction at `sh` (reached through `media`)
    /// and whether crossing the surface enters the object; 1 and false for
    /// materials light cannot cross.
    pub(super) fn crossing(&self, sh: &Shading, media: &Media) -> (Spectrum<N>, bool) {
        if sh.object.transmits { self.eta(sh, media) } else { (self.ones, false) }
    }
}
