//! The integrators' calls of material methods: through a prepared hit's
//! record where the object has a hit group (`prepare` once per vertex,
//! then each method by its index), else through each method on its own.

use super::{Drawn, JIT, Lobes, Refraction, Shading, Tracer, push_words, v3};
use crate::ShadingGlobals;
use crate::render::Vec3;
use crate::render::scene::Object;
use crate::render::spectrum::Spectrum;

impl<'s, const N: usize> Tracer<'s, N> {
    pub(super) fn reflection(&mut self, sh: &Shading, wi: Vec3, light: &Spectrum<N>) -> Spectrum<N> {
        if let Some(hit) = &sh.object.hit
            && let Some(index) = hit.reflection
        {
            return self.prepared_reflection(&hit.material, index, sh.g, wi, light);
        }
        let mut out = Spectrum::ZERO;
        sh.object.material.reflection_into(sh.g, v3(wi), &light.0, v3(sh.wo), &mut out.0);
        out
    }

    /// [`Self::reflection`] from a prepared hit's record; out of line for
    /// the same reason as [`Self::call_prepared`].
    #[inline(never)]
    fn prepared_reflection(
        &mut self,
        hit: &crate::HitMaterial,
        index: usize,
        g: &ShadingGlobals,
        wi: Vec3,
        light: &Spectrum<N>,
    ) -> Spectrum<N> {
        let mut out = Spectrum::ZERO;
        let lanes = self.lanes;
        let args = self.own_args(hit);
        push_words(args, &v3(wi));
        push_words(args, &light.0[..lanes]);
        if self.call_prepared(hit, index, g) {
            for (o, w) in out.0.iter_mut().zip(&self.lobe_out[..self.lanes]) {
                *o = f32::from_bits(*w);
            }
        }
        out
    }

    /// The words of a call on the prepared hit, its record, to which the
    /// caller pushes the method's own argument words.
    fn own_args(&mut self, hit: &crate::HitMaterial) -> &mut Vec<u32> {
        self.hit_words.truncate(hit.record_words());
        &mut self.hit_words
    }

    /// Calls the method at `index` of a prepared hit with the words of
    /// [`Self::own_args`], into `lobe_out`. Out of line, as
    /// [`Self::prepare`]: the integrator's hot functions stay as small as
    /// without prepared hits, and so are inlined as before (5-9% of
    /// cornell's time otherwise).
    #[inline(never)]
    fn call_prepared(&mut self, hit: &crate::HitMaterial, index: usize, g: &ShadingGlobals) -> bool {
        hit.call_at(JIT, index, g, &self.hit_words, &mut self.lobe_out).is_ok()
    }

    /// Runs the per-hit stage of a prepared material: every call below,
    /// until the next hit, reads its record. Only the test is inline: most
    /// hits of most scenes have nothing to prepare.
    pub(super) fn prepare(&mut self, sh: &Shading, eta: &Spectrum<N>) {
        if let Some(hit) = &sh.object.hit {
            self.prepare_hit(&hit.material, sh.g, sh.wo, eta);
        }
    }

    #[inline(never)]
    fn prepare_hit(&mut self, hit: &crate::HitMaterial, g: &ShadingGlobals, wo: Vec3, eta: &Spectrum<N>) {
        self.lobe_args.clear();
        push_words(&mut self.lobe_args, &v3(wo));
        push_words(&mut self.lobe_args, &eta.0[..self.lanes]);
        hit.prepare_words(JIT, g, &self.lobe_args, &mut self.hit_words);
    }

    pub(super) fn refraction(&self, sh: &Shading, wi: Vec3, light: &Spectrum<N>, eta: &Spectrum<N>) -> Spectrum<N> {
        let mut out = Spectrum::ZERO;
        sh.object.material.refraction_into(sh.g, v3(wi), &light.0, &eta.0, v3(sh.wo), &mut out.0);
        out
    }

    pub(super) fn emission(&self, object: &Object, g: &ShadingGlobals, wo: Vec3) -> Spectrum<N> {
        if !object.emissive {
            return Spectrum::ZERO;
        }
        let mut out = Spectrum::ZERO;
        object.material.emission_into(g, v3(wo), &mut out.0);
        if let Some(scale) = &object.emission_scale {
            out *= self.scene_color(scale);
        }
        out
    }

    pub(super) fn refraction_index(&self, object: &Object, g: &ShadingGlobals) -> Spectrum<N> {
        if !object.refracts {
            return self.ones;
        }
        if let Some(ior) = &object.constant_ior {
            return Spectrum::from_lanes(ior);
        }
        let mut out = Spectrum::ZERO;
        object.material.refraction_index_into(g, &mut out.0);
        out
    }

    /// The perfect directions of the material at `sh` with their weights,
    /// from one `delta_lobes` call; `eta` and `entering` from [`Self::crossing`].
    pub(super) fn lobes(&mut self, sh: &Shading, eta: &Spectrum<N>, entering: bool) -> Lobes<N> {
        let mut lobes = Lobes { reflect: None, refract: None };
        if let Some(hit) = &sh.object.hit {
            let Some(index) = hit.delta_lobes.filter(|_| sh.object.reflects || sh.object.refracts) else {
                return lobes;
            };
            // `delta_lobes` takes no words of its own: the record is all.
            if !self.call_prepared(&hit.material, index, sh.g) {
                return lobes;
            }
        } else {
            let Some(f) = &sh.object.delta_lobes else { return lobes };
            self.lobe_args.clear();
            self.lobe_args.extend(v3(sh.wo).iter().chain(&eta.0[..self.lanes]).map(|x| x.to_bits()));
            if f.call_words(JIT, sh.g, &self.lobe_args, &mut self.lobe_out).is_err() {
                return lobes;
            }
        }
        let decoded: crate::DeltaLobes<Spectrum<N>> = crate::DeltaLobes::from_words(self.scene.model, &self.lobe_out);
        lobes.reflect = decoded.reflect.map(|l| (Vec3::from(l.dir), l.weight));
        lobes.refract = decoded.refract.map(|l| Refraction { dir: Vec3::from(l.dir), weight: l.weight, entering });
        lobes
    }

    /// `f · cos` toward the viewer for unit light from `wi`, and the
    /// material's pdf of drawing `wi`, from one `eval_pdf` call.
    pub(super) fn eval_pdf(&mut self, sh: &Shading, wi: Vec3, eta: &Spectrum<N>) -> (Spectrum<N>, f32) {
        let lanes = self.lanes;
        if let Some(hit) = &sh.object.hit {
            let Some(index) = hit.eval_pdf else { return (Spectrum::ZERO, 0.0) };
            push_words(self.own_args(&hit.material), &v3(wi));
            if !self.call_prepared(&hit.material, index, sh.g) {
                return (Spectrum::ZERO, 0.0);
            }
            let out = &self.lobe_out;
            let f = Spectrum(std::array::from_fn(|k| if k < lanes { f32::from_bits(out[k]) } else { 0.0 }));
            return (f, f32::from_bits(out[lanes]));
        }
        let Some(f) = &sh.object.eval_pdf else {
            // An emitter of `light rect`/`light sphere`: the interface itself.
            let same_side = sh.surface.ng.dot(wi) * sh.surface.ng.dot(sh.wo) > 0.0;
            let ones = self.ones;
            let f = if same_side { self.reflection(sh, wi, &ones) } else { Spectrum::ZERO };
            return (f, sh.object.material.pdf_lanes(sh.g, v3(wi), v3(sh.wo), &eta.0));
        };
        let args = &mut self.lobe_args;
        args.clear();
        push_words(args, &v3(wi));
        push_words(args, &v3(sh.wo));
        push_words(args, &eta.0[..lanes]);
        if f.call_words(JIT, sh.g, args, &mut self.lobe_out).is_err() {
            return (Spectrum::ZERO, 0.0);
        }
        let out = &self.lobe_out;
        let f = Spectrum(std::array::from_fn(|k| if k < lanes { f32::from_bits(out[k]) } else { 0.0 }));
        (f, f32::from_bits(out[lanes]))
    }

    /// The material's `sample` at `sh`, through the tracer's buffers.
    pub(super) fn sample(&mut self, sh: &Shading, eta: &Spectrum<N>, u1: f32, u2: [f32; 2]) -> Option<Drawn<N>> {
        let lanes = self.lanes;
        if let Some(hit) = &sh.object.hit {
            let index = hit.sample?;
            push_words(self.own_args(&hit.material), &[u1, u2[0], u2[1]]);
            if !self.call_prepared(&hit.material, index, sh.g) {
                return None;
            }
        } else {
            let args = &mut self.lobe_args;
            args.clear();
            push_words(args, &v3(sh.wo));
            push_words(args, &eta.0[..lanes]);
            push_words(args, &[u1, u2[0], u2[1]]);
            sh.object.sample.call_words(JIT, sh.g, args, &mut self.lobe_out).ok()?;
        }
        let word = |k: usize| f32::from_bits(self.lobe_out[k]);
        Some(Drawn {
            wi: Vec3::new(word(0), word(1), word(2)).normalize_or_zero(),
            weight: Spectrum(std::array::from_fn(|k| if k < lanes { word(3 + k) } else { 0.0 })),
            pdf: word(3 + lanes),
            delta: word(4 + lanes) > 0.0,
        })
    }
}
