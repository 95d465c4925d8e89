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
use std::mem::MaybeUninit;

/// The buffers of surface calls, reused from hit to hit: the prepared
/// hit's record, argument words and result words. One per thread.
#[derive(Debug, Clone)]
pub struct SurfaceRecord {
    /// The record `prepare` wrote, then each prepared call's own words.
    record: Vec<u32>,
    /// Whether `record` holds this hit's stage.
    prepared: bool,
    args: Vec<u32>,
    /// Result words: an array, so a call checks no length and a surface
    /// resizes nothing.
    out: [u32; MAX_RESULT_WORDS],
}

impl Default for SurfaceRecord {
    fn default() -> Self {
        SurfaceRecord::new()
    }
}

impl SurfaceRecord {
    pub fn new() -> SurfaceRecord {
        SurfaceRecord { record: Vec::new(), prepared: false, args: Vec::new(), out: [0; MAX_RESULT_WORDS] }
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

/// One argument of a surface call: floats, or a color's model lanes.
#[derive(Clone, Copy)]
enum Arg<'x, C> {
    F(&'x [f32]),
    C(&'x C),
}

/// The argument words of one call, on the stack: no capacity check and
/// no length in memory per word pushed, no zeroing.
struct ArgWords {
    words: [MaybeUninit<u32>; MAX_ARG_WORDS],
    len: usize,
}

impl ArgWords {
    #[inline(always)]
    fn new() -> ArgWords {
        // A `const` block: `[MaybeUninit::uninit(); N]` compiles to a memset.
        ArgWords { words: [const { MaybeUninit::uninit() }; MAX_ARG_WORDS], len: 0 }
    }

    /// Writes `args` in place (a filled `ArgWords` returned by value is a
    /// copy of all its words).
    #[inline(always)]
    fn fill<C: Lanes>(&mut self, args: &[Arg<C>], lanes: usize) {
        for a in args {
            match *a {
                Arg::F(xs) => self.push(xs, xs.len()),
                Arg::C(c) => self.push_color(c, lanes),
            }
        }
    }

    /// Writes `xs`, keeps the first `keep` of them (words past the end are
    /// dropped: the call's length check then fails).
    #[inline(always)]
    fn push(&mut self, xs: &[f32], keep: usize) {
        let n = xs.len().min(MAX_ARG_WORDS - self.len);
        for (w, x) in self.words[self.len..self.len + n].iter_mut().zip(xs) {
            w.write(x.to_bits());
        }
        self.len += keep.min(n);
    }

    /// A color's first `lanes` lanes. A type of a few lanes (a renderer's
    /// `Spectrum<N>`) has all of them written, a fixed count: a few moves
    /// rather than a copy of a length known only at run time.
    #[inline(always)]
    fn push_color<C: Lanes>(&mut self, c: &C, lanes: usize) {
        let all = c.lanes();
        if all.len() <= 16 { self.push(all, lanes) } else { self.push(&all[..lanes.min(all.len())], lanes) }
    }

    #[inline(always)]
    fn as_slice(&self) -> &[u32] {
        // SAFETY: the first `len` words were written by `push`.
        unsafe { std::slice::from_raw_parts(self.words.as_ptr().cast(), self.len) }
    }
}

impl<'a, C: Lanes> Surface<'a, C> {
    pub(super) fn new(
        material: &'a Material,
        g: &'a ShadingGlobals,
        wo: [f32; 3],
        eta: &'a C,
        buffers: &'a mut SurfaceRecord,
    ) -> Self {
        Surface { material, g, wo, eta, buffers }
    }

    #[inline]
    fn lanes(&self) -> usize {
        self.material.lanes
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
    #[inline(always)]
    fn call(&mut self, f: &Function) {
        if f.call_words(JIT, self.g, &self.buffers.args, &mut self.buffers.out).is_err() {
            self.buffers.out.fill(0);
        }
    }

    /// Calls `f` with `args`, into `out`, as [`Surface::call`].
    #[inline(always)]
    fn call_with(&mut self, f: &Function, args: &[Arg<C>]) {
        let mut words = ArgWords::new();
        words.fill(args, self.lanes());
        if f.call_words(JIT, self.g, words.as_slice(), &mut self.buffers.out).is_err() {
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
        let lanes = self.lanes();
        let Some(hit) = &self.material.code.hit else { return };
        let args = &mut self.buffers.args;
        args.clear();
        push(args, &self.wo);
        self.eta.push_lanes(lanes, args);
        hit.material.prepare_words(JIT, self.g, args, &mut self.buffers.record);
        self.buffers.prepared = true;
    }

    /// Calls the prepared method at `index` with its own words `own`. The
    /// words are pushed inline, where their shapes are known (a loop over
    /// them out of line cost a quarter of a textured render's seam); the
    /// stage and the call are out of line.
    #[inline(always)]
    fn call_prepared(&mut self, index: usize, own: &[Arg<C>]) {
        if !self.buffers.prepared {
            self.run_stage();
        }
        let lanes = self.lanes();
        let Some(hit) = &self.material.code.hit else { return };
        let record = &mut self.buffers.record;
        record.truncate(hit.material.record_words());
        for a in own {
            push_arg(record, *a, lanes);
        }
        self.invoke_prepared(index);
    }

    /// Calls the prepared method at `index` with the record and the words
    /// pushed after it.
    #[inline(never)]
    fn invoke_prepared(&mut self, index: usize) {
        let Some(hit) = &self.material.code.hit else { return };
        if hit.material.call_at(JIT, index, self.g, &self.buffers.record, &mut self.buffers.out).is_err() {
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
    #[inline(always)]
    fn method(&mut self, method: Method, args: &[Arg<C>]) {
        let material: &'a Material = self.material;
        match &material.code.methods[method as usize] {
            Some(f) => self.call_with(f, args),
            None => self.buffers.out.fill(0),
        }
    }

    fn ones(&self) -> C {
        let lanes = self.lanes();
        let mut c = self.zero();
        c.lanes_mut()[..lanes].fill(1.0);
        c
    }

    // ---------------------------------------------------------- the interface

    /// Light arriving from `wi` reflected toward the viewer.
    pub fn reflection(&mut self, wi: [f32; 3], light: &C) -> C {
        if let Some(index) = self.prepared_method(Method::Reflection) {
            self.call_prepared(index, &[Arg::F(&wi), Arg::C(light)]);
        } else {
            let wo = self.wo;
            self.method(Method::Reflection, &[Arg::F(&wi), Arg::C(light), Arg::F(&wo)]);
        }
        self.out_color()
    }

    /// Light arriving from `wi` transmitted toward the viewer.
    pub fn refraction(&mut self, wi: [f32; 3], light: &C) -> C {
        let (wo, eta) = (self.wo, self.eta);
        self.method(Method::Refraction, &[Arg::F(&wi), Arg::C(light), Arg::C(eta), Arg::F(&wo)]);
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
        self.method(Method::ReflectionDir, &[Arg::F(&wo)]);
        self.out_vector()
    }

    /// The refracted direction; zero on total internal reflection or none.
    pub fn refraction_dir(&mut self) -> [f32; 3] {
        let (wo, eta) = (self.wo, self.eta);
        self.method(Method::RefractionDir, &[Arg::F(&wo), Arg::C(eta)]);
        self.out_vector()
    }

    /// Light emitted toward the viewer (black with no call when the
    /// material never emits).
    #[inline]
    pub fn emission(&mut self) -> C {
        if !self.material.facts().may_emit {
            return self.zero();
        }
        let wo = self.wo;
        self.method(Method::Emission, &[Arg::F(&wo)]);
        self.out_color()
    }

    /// The fraction of light from the viewer that the surface reflects
    /// (its directional albedo toward `wo`; what a `layer` above it would
    /// not let through).
    pub fn albedo(&mut self) -> C {
        let wo = self.wo;
        self.method(Method::Albedo, &[Arg::F(&wo)]);
        self.out_color()
    }

    pub fn ambient(&mut self, light: &C) -> C {
        self.method(Method::Ambient, &[Arg::C(light)]);
        self.out_color()
    }

    /// The light left of `light` after `distance` inside the material (the
    /// light itself with no call when the medium is clear).
    pub fn absorption(&mut self, light: &C, distance: f32) -> C {
        if self.material.facts().clear {
            return *light;
        }
        self.method(Method::Absorption, &[Arg::C(light), Arg::F(&[distance])]);
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
    #[inline]
    pub fn sample(&mut self, uc: f32, u: [f32; 2]) -> BsdfSample<C> {
        if let Some(index) = self.prepared_method(Method::Sample) {
            self.call_prepared(index, &[Arg::F(&[uc, u[0], u[1]])]);
        } else {
            let (wo, eta) = (self.wo, self.eta);
            self.method(Method::Sample, &[Arg::F(&wo), Arg::C(eta), Arg::F(&[uc, u[0], u[1]])]);
        }
        BsdfSample::from_words(self.material.color_model(), &self.buffers.out)
    }

    /// The density with which [`Surface::sample`] draws `wi`.
    pub fn pdf(&mut self, wi: [f32; 3]) -> f32 {
        let (wo, eta) = (self.wo, self.eta);
        self.method(Method::Pdf, &[Arg::F(&wi), Arg::F(&wo), Arg::C(eta)]);
        f32::from_bits(self.buffers.out[0])
    }

    /// `f · cos` for unit light from `wi` (reflection on the viewer's side
    /// of the geometric normal, refraction across it) and the pdf of
    /// sampling `wi`, in one call where the material was compiled with it.
    #[inline]
    pub fn eval_pdf(&mut self, wi: [f32; 3]) -> EvalPdf<C> {
        let model = self.material.color_model();
        let material: &'a Material = self.material;
        let code = &material.code;
        if let Some(index) = code.hit.as_ref().and_then(|h| h.eval_pdf) {
            self.call_prepared(index, &[Arg::F(&wi)]);
            return EvalPdf::from_words(model, &self.buffers.out);
        }
        let Some(f) = &code.eval_pdf else { return self.eval_pdf_by_methods(wi) };
        let (wo, eta) = (self.wo, self.eta);
        self.call_with(f, &[Arg::F(&wi), Arg::F(&wo), Arg::C(eta)]);
        EvalPdf::from_words(model, &self.buffers.out)
    }

    /// [`Surface::eval_pdf`] from the methods one by one, as the combined
    /// entry computes it (a material compiled without one).
    #[inline(never)]
    fn eval_pdf_by_methods(&mut self, wi: [f32; 3]) -> EvalPdf<C> {
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
            let (wo, eta) = (self.wo, self.eta);
            self.call_with(f, &[Arg::F(&wo), Arg::C(eta)]);
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
            light.push_lanes(lanes, args);
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

/// Appends an argument's words: a color's through [`Lanes::push_lanes`],
/// which copies a fixed count where it can (a `memcpy` call otherwise).
#[inline(always)]
fn push_arg<C: Lanes>(words: &mut Vec<u32>, arg: Arg<C>, lanes: usize) {
    match arg {
        Arg::F(xs) => push(words, xs),
        Arg::C(c) => c.push_lanes(lanes, words),
    }
}
