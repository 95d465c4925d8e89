//! The integrators' calls of material methods, all through the material's
//! [`Surface`](crate::Surface): the calls at a path vertex resume the
//! vertex's record (its per-hit stage, when the material has one, runs once
//! from [`Tracer::prepare`]); calls at other points (shadow rays, light
//! samples on emitters, media) use a scratch record, so they never disturb
//! the vertex's.

use super::{Drawn, Lobes, Refraction, Shading, Tracer, v3};
use crate::ShadingGlobals;
use crate::render::Vec3;
use crate::render::scene::Object;
use crate::render::spectrum::Spectrum;

impl<'s, const N: usize> Tracer<'s, N> {
    /// Starts the calls at a vertex: the material's per-hit stage (if it
    /// has one) runs here, for the index `eta` the crossing gives, and
    /// every call below until the next vertex reads its record.
    pub(super) fn prepare(&mut self, sh: &Shading, eta: &Spectrum<N>) {
        self.vertex_eta = *eta;
        sh.object.material.at(sh.g, v3(sh.wo), eta, &mut self.record).prepare();
    }

    pub(super) fn reflection(&mut self, sh: &Shading, wi: Vec3, light: &Spectrum<N>) -> Spectrum<N> {
        let eta = self.vertex_eta;
        sh.object.material.resume(sh.g, v3(sh.wo), &eta, &mut self.record).reflection(v3(wi), light)
    }

    pub(super) fn refraction(&mut self, sh: &Shading, wi: Vec3, light: &Spectrum<N>, eta: &Spectrum<N>) -> Spectrum<N> {
        sh.object.material.at(sh.g, v3(sh.wo), eta, &mut self.scratch).refraction(v3(wi), light)
    }

    /// Light `object` emits toward `wo` at `g`. Only the test is inline:
    /// most hits are not on lights.
    #[inline]
    pub(super) fn emission(&mut self, object: &Object, g: &ShadingGlobals, wo: Vec3) -> Spectrum<N> {
        if !object.emissive() {
            return Spectrum::ZERO;
        }
        self.emitted(object, g, wo)
    }

    #[inline(never)]
    fn emitted(&mut self, object: &Object, g: &ShadingGlobals, wo: Vec3) -> Spectrum<N> {
        let ones = self.ones;
        let mut out = object.material.at(g, v3(wo), &ones, &mut self.scratch).emission();
        if let Some(scale) = &object.emission_scale {
            out *= self.scene_color(scale);
        }
        out
    }

    /// The perfect directions of the material at `sh` with their weights,
    /// from one `delta_lobes` call; `entering` from [`Self::crossing`].
    /// Only the test is inline: most materials have no perfect direction.
    #[inline]
    pub(super) fn lobes(&mut self, sh: &Shading, entering: bool) -> Lobes<N> {
        let facts = sh.object.material.facts();
        if !facts.reflects && !facts.refracts {
            return Lobes { reflect: None, refract: None };
        }
        self.lobes_of(sh, entering)
    }

    #[inline(never)]
    fn lobes_of(&mut self, sh: &Shading, entering: bool) -> Lobes<N> {
        let eta = self.vertex_eta;
        let lobes = sh.object.material.resume(sh.g, v3(sh.wo), &eta, &mut self.record).delta_lobes();
        Lobes {
            reflect: lobes.reflect.map(|l| (Vec3::from(l.dir), l.weight)),
            refract: lobes.refract.map(|l| Refraction { dir: Vec3::from(l.dir), weight: l.weight, entering }),
        }
    }

    /// `f · cos` toward the viewer for unit light from `wi`, and the
    /// material's pdf of drawing `wi`, from one `eval_pdf` call.
    pub(super) fn eval_pdf(&mut self, sh: &Shading, wi: Vec3, eta: &Spectrum<N>) -> (Spectrum<N>, f32) {
        let e = sh.object.material.resume(sh.g, v3(sh.wo), eta, &mut self.record).eval_pdf(v3(wi));
        (e.value, e.pdf)
    }

    /// The material's `sample` at `sh`.
    pub(super) fn sample(&mut self, sh: &Shading, u1: f32, u2: [f32; 2]) -> Option<Drawn<N>> {
        let eta = self.vertex_eta;
        let s = sh.object.material.resume(sh.g, v3(sh.wo), &eta, &mut self.record).sample(u1, u2);
        Some(Drawn { wi: Vec3::from(s.wi).normalize_or_zero(), weight: s.weight, pdf: s.pdf, delta: s.delta })
    }
}
