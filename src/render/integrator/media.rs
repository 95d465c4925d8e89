//! Participating media for the integrators: the stack of media a ray is
//! inside, the globals each was entered at, absorption along a segment,
//! and the relative index of refraction at a crossing.

use super::{DELTA_CONE, Shading, Tracer, ZERO_GLOBALS};
use crate::render::Vec3;
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
    /// Light left after `distance` inside `medium`. Only the test is
    /// inline: most paths travel through no medium.
    #[inline]
    pub(super) fn absorb(&mut self, medium: Option<&Medium>, light: Spectrum<N>, distance: f32) -> Spectrum<N> {
        match medium {
            Some(m) => self.absorb_in(m, light, distance),
            None => light,
        }
    }

    #[inline(never)]
    fn absorb_in(&mut self, m: &Medium, light: Spectrum<N>, distance: f32) -> Spectrum<N> {
        let object = self.scene.object(m.object);
        let g = self.entered.get(m.g as usize).unwrap_or(&ZERO_GLOBALS);
        object.material.at(g, [0.0; 3], &self.ones, &mut self.scratch).absorption(&light, distance)
    }

    /// The relative index `n_entered / n_left` for light crossing the
    /// surface from the `wo` side, and whether crossing enters the object.
    pub(super) fn eta(&mut self, sh: &Shading, media: &Media) -> (Spectrum<N>, bool) {
        let entering = sh.surface.ng.dot(sh.wo) > 0.0;
        let inside = |m: &&Medium| m.object != sh.hit.object;
        let other = match media.as_slice().iter().rev().find(inside) {
            Some(m) => {
                let g = self.entered.get(m.g as usize).unwrap_or(&ZERO_GLOBALS);
                refraction_index(self.scene.object(m.object), g, &self.ones, &mut self.scratch)
            }
            None => self.ones,
        };
        let own = refraction_index(sh.object, sh.g, &self.ones, &mut self.scratch);
        if entering { (own.safe_div(&other), true) } else { (other.safe_div(&own), false) }
    }

    /// The media after light left the surface of `sh` along `wi` on its
    /// other side (entering pushes it, leaving removes it). A pass straight
    /// through a surface of index 1 (a cutout's hole, a thin sheet) enters
    /// nothing; glass sends light straight on at normal incidence too, but
    /// into itself: its index tells them apart.
    pub(super) fn crossed(&mut self, sh: &Shading, media: &Media, entering: bool, wi: Vec3) -> Media {
        let mut out = *media;
        if self.passes_straight(sh, wi) {
            return out;
        }
        if entering {
            if out.len < MAX_MEDIA {
                let o = sh.object;
                let facts = o.material.facts();
                // The medium's globals are kept when its index or its
                // absorption must be evaluated again from inside.
                let g = if facts.clear && facts.constant_ior.is_some() {
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

    /// Whether light leaving `sh` along `wi` on the far side went straight
    /// through without crossing an interface: unbent (within
    /// [`DELTA_CONE`]) by a surface whose own index is 1 in every lane.
    /// The index is read only for unbent light, which is rare but for holes.
    pub(super) fn passes_straight(&mut self, sh: &Shading, wi: Vec3) -> bool {
        if wi.dot(-sh.wo) < DELTA_CONE {
            return false;
        }
        let own = refraction_index(sh.object, sh.g, &self.ones, &mut self.scratch);
        self.is_unit_index(&own)
    }

    /// Whether an index is 1 in every lane of this render.
    pub(super) fn is_unit_index(&self, eta: &Spectrum<N>) -> bool {
        eta.0[..self.lanes].iter().all(|e| *e == 1.0)
    }

    /// The relative index of refraction at `sh` (reached through `media`)
    /// and whether crossing the surface enters the object; 1 and false for
    /// materials light cannot cross.
    pub(super) fn crossing(&mut self, sh: &Shading, media: &Media) -> (Spectrum<N>, bool) {
        if sh.object.material.facts().transmits() { self.eta(sh, media) } else { (self.ones, false) }
    }
}

/// The index of refraction of `object`'s material at `g` (1, with no call,
/// for one light cannot cross). Every material light crosses has its
/// index read, not only those with a perfect refraction direction: a rough
/// dielectric's `sample` and `pdf` need it as much as glass's.
fn refraction_index<const N: usize>(
    object: &crate::render::scene::Object,
    g: &crate::ShadingGlobals,
    ones: &Spectrum<N>,
    scratch: &mut crate::SurfaceRecord,
) -> Spectrum<N> {
    if !object.material.facts().transmits() {
        return *ones;
    }
    object.material.at(g, [0.0; 3], ones, scratch).refraction_index()
}
