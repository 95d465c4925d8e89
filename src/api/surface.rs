//! `Surface`: a material at one hit, the seam between compiled code and
//! any renderer (pbrt's `GetBSDF`, Mitsuba's `BSDF`). Every method of the
//! interface, the combined calls (`eval_pdf`, the delta lobes, a sum over
//! lights) and the AOVs return typed results; whether they come from a
//! prepared hit's record (the per-hit stage run once, then per-direction
//! calls), a combined entry or the methods one by one is decided here and
//! nowhere else.
//!
//! A surface borrows a [`SurfaceRecord`], the buffers its calls use, so a
//! renderer allocates nothing per hit: one record per thread.

use super::Lanes;
use super::material::{MAX_ARG_WORDS, Material};
use super::outputs::{BsdfSample, DeltaLobes, EvalPdf, MAX_RESULT_WORDS};
use super::{Backend, Function};
use crate::check::Method;
use crate::globals::ShadingGlobals;

/// The buffers of surface calls, reused from hit to hit: the prepared
/// hit's record, argument words and result words. One per thread.
#[derive(Debug, Clone, Default)]
pub struct SurfaceRecord {
    /// The record `prepare` wrote, then each prepared call's own words.
    record: Vec<u32>,
    /// Whether `record` holds this hit's stage.
    prepared: bool,
    args: Vec<u32>,
    out: Vec<u32>,
}

impl SurfaceRecord {
    pub fn new() -> SurfaceRecord {
        SurfaceRecord { record: Vec::new(), prepared: false, args: Vec::new(), out: vec![0; MAX_RESULT_WORDS] }
    }

    /// A new hit: the record must be prepared again before a prepared call.
    pub(super) fn new_hit(&mut self) {
        self.prepared = false;
    }
}

/// A material at one hit: see [`Material::at`].
pub struct Surface<'a, C: Lanes = crate::Color> {
    material: &'a Material,
    g: &'a ShadingGlobals,
    wo: [f32; 3],
    eta: &'a C,
    buffers: &'a mut SurfaceRecord,
}

/// Surfaces call compiled code.
const JIT: Backend = Backend::Jit;

impl<'a, C: Lanes> Surface<'a, C> {
    pub(super) fn new(
        material: &'a Material,
        g: &'a ShadingGlobals,
        wo: [f32; 3],
        eta: &'a C,
        buffers: &'a mut SurfaceRecord,
    ) -> Self {
        if buffers.out.len() < MAX_RESULT_WORDS {
            buffers.out.resize(MAX_RESULT_WORDS, 0);
        }
        Surface { material, g, wo, eta, buffers }
    }

    fn lanes(&self) -> usize {
        self.material.color_model().lanes()
    }

    fn zero(&self) -> C {
        C::zero(self.material.color_model())
    }

    /// The result words as a color of the model.
    fn out_color(&self) -> C {
        let lanes = self.lanes();
        C::from_words(self.material.color_model(), &self.buffers.out[..lanes])
    }

    fn out_vector(&self) -> [f32; 3] {
        let out = &self.buffers.out;
        [0, 1, 2].map(|k| f32::from_bits(out[k]))
    }

    // ---------------------------------------------------------- argument words

    fn args(&mut self) -> &mut Vec<u32> {
        self.buffers.args.clear();
        &mut self.buffers.args
    }

    /// Calls `f` with the argument words in `args`, into `out`. A call that
    /// fails its length check (a compiler bug) leaves zeros.
    #[inline]
    fn call(&mut self, f: &Function) {
        debug_assert!(self.buffers.args.len() <= MAX_ARG_WORDS || self.material.code.reflection_sum.is_some());
        if f.call_words(JIT, self.g, &self.buffers.args, &mut self.buffers.out).is_err() {
            self.buffers.out.fill(0);
        }
    }

    /// Runs the per-hit stage now, if the material has one and it has not
    /// run for this hit (the first call that needs it runs it otherwise):
    /// a renderer prepares where it knows the hit's `eta`.
    #[inline]
    pub fn prepare(&mut self) {
        if self.material.code.hit.is_some() && !self.buffers.prepared {
            self.run_stage();
        }
    }

    /// Runs the per-hit stage. Out of line: most hits of most scenes have
    /// nothing to prepare, and the callers stay small enough to be inlined
    /// into a renderer's loop.
    #[inline(never)]
    fn run_stage(&mut self) {
        let Some(hit) = &self.material.code.hit else { return };
        let lanes = self.lanes();
        let args = &mut self.buffers.args;
        args.clear();
        push(args, &self.wo);
        push(args, &self.eta.lanes()[..lanes]);
        hit.material.prepare_words(JIT, self.g, args, &mut self.buffers.record);
        self.buffers.prepared = true;
    }

    /// Calls the prepared method at `index` with its own words `own`.
    #[inline(never)]
    fn call_prepared(&mut self, index: usize, own: &[&[f32]]) {
        if !self.buffers.prepared {
            self.run_stage();
        }
        let Some(hit) = &self.material.code.hit else { return };
        let record = &mut self.buffers.record;
        record.truncate(hit.material.record_words());
        for words in own {
            push(record, words);
        }
        if hit.material.call_at(JIT, index, self.g, record, &mut self.buffers.out).is_err() {
            self.buffers.out.fill(0);
        }
    }

    /// The hit group's index of `method`, if the material is prepared and
    /// its group has it.
    fn prepared_method(&self, method: Method) -> Option<usize> {
        self.material.code.hit.as_ref()?.methods[method as usize]
    }

    /// Calls interface method `method` on its own with `args`; zeros when
    /// the material has no such entry.
    fn method(&mut self, method: Method, args: &[&[f32]]) {
        let words = self.args();
        for a in args {
            push(words, a);
        }
        let material: &'a Material = self.material;
        match &material.code.methods[method as usize] {
            Some(f) => self.call(f),
            None => self.buffers.out.fill(0),
        }
    }

    fn ones(&self) -> C {
        let mut c = self.zero();
        let lanes = self.lanes();
        c.lanes_mut()[..lanes].fill(1.0);
        c
    }

    // ---------------------------------------------------------- the interface

    /// Light arriving from `wi` reflected toward the viewer.
    pub fn reflection(&mut self, wi: [f32; 3], light: &C) -> C {
        let lanes = self.lanes();
        if let Some(index) = self.prepared_method(Method::Reflection) {
            self.call_prepared(index, &[&wi, &light.lanes()[..lanes]]);
        } else {
            let wo = self.wo;
            self.method(Method::Reflection, &[&wi, &light.lanes()[..lanes], &wo]);
        }
        self.out_color()
    }

    /// Light arriving from `wi` transmitted toward the viewer.
    pub fn refraction(&mut self, wi: [f32; 3], light: &C) -> C {
        let lanes = self.lanes();
        let (wo, eta) = (self.wo, self.eta);
        self.method(Method::Refraction, &[&wi, &light.lanes()[..lanes], &eta.lanes()[..lanes], &wo]);
        self.out_color()
    }

    /// The material's index of refraction (its constant when it has one,
    /// with no call).
    pub fn refraction_index(&mut self) -> C {
        if let Some(ior) = &self.material.facts().constant_ior {
            let mut c = self.zero();
            c.lanes_mut()[..ior.len()].copy_from_slice(ior);
            return c;
        }
        self.method(Method::RefractionIndex, &[]);
        self.out_color()
    }

    /// The mirror direction; zero when there is none.
    pub fn reflection_dir(&mut self) -> [f32; 3] {
        let wo = self.wo;
        self.method(Method::ReflectionDir, &[&wo]);
        self.out_vector()
    }

    /// The refracted direction; zero on total internal reflection or none.
    pub fn refraction_dir(&mut self) -> [f32; 3] {
        let (wo, eta, lanes) = (self.wo, self.eta, self.lanes());
        self.method(Method::RefractionDir, &[&wo, &eta.lanes()[..lanes]]);
        self.out_vector()
    }

    /// Light emitted toward the viewer (black with no call when the
    /// material never emits).
    pub fn emission(&mut self) -> C {
        if !self.material.facts().may_emit {
            return self.zero();
        }
        let wo = self.wo;
        self.method(Method::Emission, &[&wo]);
        self.out_color()
    }

    pub fn ambient(&mut self, light: &C) -> C {
        let lanes = self.lanes();
        self.method(Method::Ambient, &[&light.lanes()[..lanes]]);
        self.out_color()
    }

    /// The light left of `light` after `distance` inside the material (the
    /// light itself with no call when the medium is clear).
    pub fn absorption(&mut self, light: &C, distance: f32) -> C {
        if self.material.facts().clear {
            return *light;
        }
        let lanes = self.lanes();
        self.method(Method::Absorption, &[&light.lanes()[..lanes], &[distance]]);
        self.out_color()
    }

    /// The shading normal (an AOV, and the frame of default sampling).
    pub fn normal(&mut self) -> [f32; 3] {
        self.method(Method::Normal, &[]);
        self.out_vector()
    }

    /// The diffuse albedo (the albedo AOV).
    pub fn diffuse(&mut self) -> C {
        self.method(Method::Diffuse, &[]);
        self.out_color()
    }

    /// Whether the surface stops light here (no call when it always does).
    pub fn opaque(&mut self) -> bool {
        if self.material.facts().always_opaque {
            return true;
        }
        self.method(Method::Opaque, &[]);
        self.buffers.out[0] != 0
    }

    /// Draws an incident direction from the uniform numbers `uc` (which
    /// lobe) and `u` (where in it).
    pub fn sample(&mut self, uc: f32, u: [f32; 2]) -> BsdfSample<C> {
        if let Some(index) = self.prepared_method(Method::Sample) {
            self.call_prepared(index, &[&[uc, u[0], u[1]]]);
        } else {
            let (wo, eta, lanes) = (self.wo, self.eta, self.lanes());
            self.method(Method::Sample, &[&wo, &eta.lanes()[..lanes], &[uc, u[0], u[1]]]);
        }
        BsdfSample::from_words(self.material.color_model(), &self.buffers.out)
    }

    /// The density with which [`Surface::sample`] draws `wi`.
    pub fn pdf(&mut self, wi: [f32; 3]) -> f32 {
        let (wo, eta, lanes) = (self.wo, self.eta, self.lanes());
        self.method(Method::Pdf, &[&wi, &wo, &eta.lanes()[..lanes]]);
        f32::from_bits(self.buffers.out[0])
    }

    /// `f · cos` for unit light from `wi` (reflection on the viewer's side
    /// of the geometric normal, refraction across it) and the pdf of
    /// sampling `wi`, in one call where the material was compiled with it.
    pub fn eval_pdf(&mut self, wi: [f32; 3]) -> EvalPdf<C> {
        let model = self.material.color_model();
        let material: &'a Material = self.material;
        let code = &material.code;
        if let Some(index) = code.hit.as_ref().and_then(|h| h.eval_pdf) {
            self.call_prepared(index, &[&wi]);
            return EvalPdf::from_words(model, &self.buffers.out);
        }
        if let Some(f) = &code.eval_pdf {
            let (wo, eta, lanes) = (self.wo, self.eta, self.lanes());
            let args = self.args();
            push(args, &wi);
            push(args, &wo);
            push(args, &eta.lanes()[..lanes]);
            self.call(f);
            return EvalPdf::from_words(model, &self.buffers.out);
        }
        // The methods one by one, as the combined entry computes them.
        let ng = glam::Vec3::from(self.g.ng);
        let same_side = ng.dot(wi.into()) * ng.dot(self.wo.into()) > 0.0;
        let ones = self.ones();
        let value = if same_side { self.reflection(wi, &ones) } else { self.refraction(wi, &ones) };
        EvalPdf { value, pdf: self.pdf(wi) }
    }

    /// Both perfect directions with the responses to unit light along
    /// them; none, with no call, when the material has neither.
    pub fn delta_lobes(&mut self) -> DeltaLobes<C> {
        let facts = self.material.facts();
        if !facts.reflects && !facts.refracts {
            return DeltaLobes::NONE;
        }
        let model = self.material.color_model();
        let material: &'a Material = self.material;
        let code = &material.code;
        if let Some(index) = code.hit.as_ref().and_then(|h| h.delta_lobes) {
            self.call_prepared(index, &[]);
            return DeltaLobes::from_words(model, &self.buffers.out);
        }
        if let Some(f) = &code.delta_lobes {
            let (wo, eta, lanes) = (self.wo, self.eta, self.lanes());
            let args = self.args();
            push(args, &wo);
            push(args, &eta.lanes()[..lanes]);
            self.call(f);
            return DeltaLobes::from_words(model, &self.buffers.out);
        }
        let ones = self.ones();
        let lobe = |dir: [f32; 3], weight: C| {
            (dir != [0.0; 3] && dir.iter().all(|x| x.is_finite())).then_some(super::DeltaLobe { dir, weight })
        };
        let dr = self.reflection_dir();
        let reflect = lobe(dr, self.reflection(dr, &ones));
        let dt = self.refraction_dir();
        let refract = lobe(dt, self.refraction(dt, &ones));
        DeltaLobes { reflect, refract }
    }

    /// `reflection` summed over the lights `(wi, light)` in one call, when
    /// the material was compiled with a sum over that many lights (a
    /// renderer's delta lights); `None` otherwise.
    pub fn reflection_sum(&mut self, lights: &[([f32; 3], C)]) -> Option<C> {
        let material: &'a Material = self.material;
        let (count, f) = material.code.reflection_sum.as_ref()?;
        if *count != lights.len() {
            return None;
        }
        let (wo, lanes) = (self.wo, self.lanes());
        let args = self.args();
        for (wi, light) in lights {
            push(args, wi);
            push(args, &light.lanes()[..lanes]);
        }
        push(args, &wo);
        self.call(f);
        Some(self.out_color())
    }
}

/// Appends float words: one capacity check and a copy (the floats' bits
/// are the words), not a check per word.
#[inline]
fn push(words: &mut Vec<u32>, xs: &[f32]) {
    words.extend_from_slice(bytemuck::cast_slice(xs));
}
