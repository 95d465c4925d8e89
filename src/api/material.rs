//! `Material`: the generic material interface of a compiled program, as
//! native calls with their argument words packed on the stack.

use super::outputs::{BsdfSample, MAX_RESULT_WORDS};
use super::{Color, Function, Program};
use crate::check::Method;
use crate::color::{ColorModel, MAX_SAMPLES};
use crate::globals::ShadingGlobals;
use std::fmt;

/// A compiled material: the generic material interface, as native calls.
/// Cheap to clone (the objects of a scene that name one material share it).
#[derive(Clone)]
pub struct Material {
    program: Program,
    /// In the order of `check::INTERFACE`.
    methods: std::sync::Arc<[Function]>,
    facts: Facts,
}

/// What a material's compiled code shows about it, found once.
#[derive(Debug, Clone, Copy)]
struct Facts {
    may_emit: bool,
    always_opaque: bool,
    may_reflect_dir: bool,
    may_refract: bool,
    /// Bit `k` is set when some method reads word `k` of the globals.
    globals_read: u64,
    /// `absorption` returns its light unchanged (a clear medium).
    clear: bool,
}

impl Facts {
    fn of(methods: &[Function]) -> Facts {
        let constant = |m: Method| methods[m as usize].ir().constant_results();
        let zero = |m: Method| constant(m).is_some_and(|w| w.iter().all(|x| f32::from_bits(*x) == 0.0));
        let mut globals_read = 0u64;
        for m in methods {
            crate::ir::for_each_op(&m.ir().body, &mut |op| {
                if let crate::ir::Op::Global(w) = op {
                    globals_read |= 1u64.checked_shl(*w).unwrap_or(0);
                }
            });
        }
        // absorption(light, d) writing its light words straight back.
        let absorption = methods[Method::Absorption as usize].ir();
        let lanes = absorption.results.len();
        let mut outputs = vec![None; lanes];
        let mut params = std::collections::HashMap::new();
        let mut plain = true;
        for inst in &absorption.body {
            match inst {
                crate::ir::Inst::Def(v, crate::ir::Op::Param(k)) => {
                    params.insert(*v, *k);
                }
                crate::ir::Inst::Output(k, v) => {
                    if let Some(slot) = outputs.get_mut(*k as usize) {
                        *slot = params.get(v).copied();
                    }
                }
                _ => plain = false,
            }
        }
        let clear = plain && outputs.iter().enumerate().all(|(k, p)| *p == Some(k as u32));
        Facts {
            clear,
            may_emit: !zero(Method::Emission),
            always_opaque: constant(Method::Opaque).is_some_and(|w| w.first() == Some(&1)),
            may_reflect_dir: !zero(Method::ReflectionDir),
            may_refract: !zero(Method::RefractionDir),
            globals_read,
        }
    }
}

impl fmt::Debug for Material {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Material").field("name", &self.methods[Method::Reflection as usize].ir().name).finish()
    }
}

/// The most argument words a method takes: `refraction(wi, light, eta, wo)`.
const MAX_ARG_WORDS: usize = 3 + 2 * MAX_SAMPLES + 3;

/// The direction part of a sample from [`Material::sample_into`], whose
/// weight goes to a lane slice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampledDir {
    pub wi: [f32; 3],
    pub pdf: f32,
    pub delta: bool,
}

/// Argument words for a method call, filled front to back.
struct Args {
    words: [std::mem::MaybeUninit<u32>; MAX_ARG_WORDS],
    len: usize,
}

impl Args {
    fn new() -> Args {
        // No zeroing: only the first `len` words are ever read. (A `const`
        // block: `[MaybeUninit::uninit(); N]` compiles to a memset.)
        Args { words: [const { std::mem::MaybeUninit::uninit() }; MAX_ARG_WORDS], len: 0 }
    }
    /// Appends words with one bounds check and one length update.
    fn extend(&mut self, xs: &[f32]) {
        let end = self.len + xs.len();
        for (w, x) in self.words[self.len..end].iter_mut().zip(xs) {
            *w = std::mem::MaybeUninit::new(x.to_bits());
        }
        self.len = end;
    }
    fn v(&mut self, v: [f32; 3]) -> &mut Args {
        self.extend(&v);
        self
    }
    fn f(&mut self, x: f32) -> &mut Args {
        self.extend(&[x]);
        self
    }
    fn c(&mut self, c: &Color) -> &mut Args {
        self.extend(c.lanes());
        self
    }
}

impl Material {
    pub(super) fn new(program: Program, methods: Vec<Function>) -> Material {
        let facts = Facts::of(&methods);
        Material { program, methods: methods.into(), facts }
    }

    /// The compiled entry of one interface method (`"sample"`, ...), for
    /// hosts that pack argument words themselves and reuse their buffers
    /// ([`Function::call_words`]); `None` for a name not in the interface.
    pub fn method(&self, name: &str) -> Option<&Function> {
        self.methods.get(Method::from_name(name)? as usize)
    }

    /// The `sample` entry.
    pub(crate) fn sample_entry(&self) -> &Function {
        &self.methods[Method::Sample as usize]
    }

    /// Bit `k` is set when some method reads word `k` of [`ShadingGlobals`]
    /// (see `globals::word_of`): a renderer can skip computing what no
    /// method reads, such as the pixel footprint.
    pub fn globals_read(&self) -> u64 {
        self.facts.globals_read
    }

    /// Calls method `k`, writing its result words into `out`.
    fn call_into(&self, method: Method, g: &ShadingGlobals, args: &Args, out: *mut u32) {
        let f = &self.methods[method as usize];
        debug_assert_eq!(args.len, f.ir().params.len());
        // SAFETY: `args` holds exactly the words method `k` of the material
        // interface takes (the wrappers below build them from the
        // interface signature, checked in debug builds), all initialised;
        // `out` has room for its results (at most SAMPLE_WORDS words); the
        // code lives as long as the method's part.
        unsafe { (f.native)((g as *const ShadingGlobals).cast(), args.words.as_ptr().cast(), out) }
    }

    fn color(&self, method: Method, g: &ShadingGlobals, args: &Args) -> Color {
        let mut c = Color::black(self.program.color_model());
        self.call_into(method, g, args, c.lanes.as_mut_ptr().cast());
        c
    }

    fn vector(&self, method: Method, g: &ShadingGlobals, args: &Args) -> [f32; 3] {
        let mut v = [0.0f32; 3];
        self.call_into(method, g, args, v.as_mut_ptr().cast());
        v
    }

    /// Light arriving from `wi` reflected toward `wo`.
    pub fn reflection(&self, g: &ShadingGlobals, wi: [f32; 3], light: &Color, wo: [f32; 3]) -> Color {
        self.color(Method::Reflection, g, Args::new().v(wi).c(light).v(wo))
    }

    /// [`Material::reflection`] without a [`Color`] by value, for hot loops:
    /// `light` and `out` hold the color model's lanes (3 for RGB).
    ///
    /// ```
    /// # use tsl::{Compiler, ShadingGlobals};
    /// let program = Compiler::new().source("m.tsl", "material m = lambert;").compile()?;
    /// let m = program.material("m")?;
    /// let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ..Default::default() };
    /// let mut out = [0.0f32; 3];
    /// m.reflection_into(&g, [0.0, 0.0, 1.0], &[1.0, 1.0, 1.0], [0.0, 0.0, 1.0], &mut out);
    /// assert!((out[0] - 0.8 / std::f32::consts::PI).abs() < 1e-6);
    /// # Ok::<(), tsl::Error>(())
    /// ```
    ///
    /// # Panics
    /// When `light` or `out` is shorter than the color model's lane count.
    pub fn reflection_into(&self, g: &ShadingGlobals, wi: [f32; 3], light: &[f32], wo: [f32; 3], out: &mut [f32]) {
        let lanes = self.program.color_model().lanes();
        assert!(light.len() >= lanes && out.len() >= lanes, "light and out need {lanes} lanes");
        let mut args = Args::new();
        args.v(wi);
        args.extend(&light[..lanes]);
        args.v(wo);
        self.call_into(Method::Reflection, g, &args, out.as_mut_ptr().cast());
    }

    /// Calls a color method with `args` words, writing the model's lanes
    /// to `out`.
    fn color_into(&self, method: Method, g: &ShadingGlobals, args: &Args, out: &mut [f32]) {
        let lanes = self.program.color_model().lanes();
        assert!(out.len() >= lanes, "out needs {lanes} lanes");
        self.call_into(method, g, args, out.as_mut_ptr().cast());
    }

    /// [`Material::refraction`] on lane slices (see [`Material::reflection_into`]).
    pub fn refraction_into(
        &self,
        g: &ShadingGlobals,
        wi: [f32; 3],
        light: &[f32],
        eta: &[f32],
        wo: [f32; 3],
        out: &mut [f32],
    ) {
        let lanes = self.program.color_model().lanes();
        assert!(light.len() >= lanes && eta.len() >= lanes, "light and eta need {lanes} lanes");
        let mut args = Args::new();
        args.v(wi);
        args.extend(&light[..lanes]);
        args.extend(&eta[..lanes]);
        args.v(wo);
        self.color_into(Method::Refraction, g, &args, out);
    }

    /// [`Material::refraction_index`] into a lane slice.
    pub fn refraction_index_into(&self, g: &ShadingGlobals, out: &mut [f32]) {
        self.color_into(Method::RefractionIndex, g, &Args::new(), out);
    }

    /// [`Material::refraction_dir`] with `eta` as a lane slice.
    pub fn refraction_dir_lanes(&self, g: &ShadingGlobals, wo: [f32; 3], eta: &[f32]) -> [f32; 3] {
        let lanes = self.program.color_model().lanes();
        assert!(eta.len() >= lanes, "eta needs {lanes} lanes");
        let mut args = Args::new();
        args.v(wo);
        args.extend(&eta[..lanes]);
        self.vector(Method::RefractionDir, g, &args)
    }

    /// [`Material::emission`] into a lane slice.
    pub fn emission_into(&self, g: &ShadingGlobals, wo: [f32; 3], out: &mut [f32]) {
        self.color_into(Method::Emission, g, Args::new().v(wo), out);
    }

    /// [`Material::absorption`] on lane slices.
    pub fn absorption_into(&self, g: &ShadingGlobals, light: &[f32], distance: f32, out: &mut [f32]) {
        let lanes = self.program.color_model().lanes();
        assert!(light.len() >= lanes, "light needs {lanes} lanes");
        let mut args = Args::new();
        args.extend(&light[..lanes]);
        args.f(distance);
        self.color_into(Method::Absorption, g, &args, out);
    }

    /// [`Material::diffuse`] into a lane slice.
    pub fn diffuse_into(&self, g: &ShadingGlobals, out: &mut [f32]) {
        self.color_into(Method::Diffuse, g, &Args::new(), out);
    }

    /// False when `emission` is the interface default (black everywhere),
    /// known from the compiled code: renderers skip such materials when
    /// they look for light sources.
    pub fn may_emit(&self) -> bool {
        self.facts.may_emit
    }

    /// False when `reflection_dir` is the default (no mirror direction).
    pub fn may_reflect_dir(&self) -> bool {
        self.facts.may_reflect_dir
    }

    /// False when `refraction_dir` is the default (nothing passes through).
    pub fn may_refract(&self) -> bool {
        self.facts.may_refract
    }

    /// True when `absorption` gives back the light it is given: light
    /// crosses the material's inside unchanged.
    pub fn clear(&self) -> bool {
        self.facts.clear
    }

    /// The refraction index when it is the same everywhere (a constant),
    /// in the color model's lanes.
    pub fn constant_refraction_index(&self) -> Option<Vec<f32>> {
        self.methods[Method::RefractionIndex as usize]
            .ir()
            .constant_results()
            .map(|w| w.into_iter().map(f32::from_bits).collect())
    }

    /// True when `opaque` is the constant `true`: shadow rays need not ask.
    pub fn always_opaque(&self) -> bool {
        self.facts.always_opaque
    }

    /// The color model the material was compiled for.
    pub fn color_model(&self) -> ColorModel {
        self.program.color_model()
    }

    /// Light arriving from `wi` transmitted toward `wo`.
    pub fn refraction(&self, g: &ShadingGlobals, wi: [f32; 3], light: &Color, eta: &Color, wo: [f32; 3]) -> Color {
        self.color(Method::Refraction, g, Args::new().v(wi).c(light).c(eta).v(wo))
    }

    pub fn refraction_index(&self, g: &ShadingGlobals) -> Color {
        self.color(Method::RefractionIndex, g, &Args::new())
    }

    /// The mirror direction for an outgoing `wo`; zero when there is none.
    pub fn reflection_dir(&self, g: &ShadingGlobals, wo: [f32; 3]) -> [f32; 3] {
        self.vector(Method::ReflectionDir, g, Args::new().v(wo))
    }

    /// The refracted direction; zero on total internal reflection or none.
    pub fn refraction_dir(&self, g: &ShadingGlobals, wo: [f32; 3], eta: &Color) -> [f32; 3] {
        self.vector(Method::RefractionDir, g, Args::new().v(wo).c(eta))
    }

    pub fn emission(&self, g: &ShadingGlobals, wo: [f32; 3]) -> Color {
        self.color(Method::Emission, g, Args::new().v(wo))
    }

    pub fn ambient(&self, g: &ShadingGlobals, light: &Color) -> Color {
        self.color(Method::Ambient, g, Args::new().c(light))
    }

    /// The light left of `light` after `distance` inside the material.
    pub fn absorption(&self, g: &ShadingGlobals, light: &Color, distance: f32) -> Color {
        self.color(Method::Absorption, g, Args::new().c(light).f(distance))
    }

    pub fn normal(&self, g: &ShadingGlobals) -> [f32; 3] {
        self.vector(Method::Normal, g, &Args::new())
    }

    pub fn diffuse(&self, g: &ShadingGlobals) -> Color {
        self.color(Method::Diffuse, g, &Args::new())
    }

    pub fn opaque(&self, g: &ShadingGlobals) -> bool {
        let mut word = 0u32;
        self.call_into(Method::Opaque, g, &Args::new(), &mut word);
        word != 0
    }

    /// Draws an incident direction for light leaving toward `wo`, from the
    /// uniform random numbers `uc` (which lobe) and `u` (where in it); `eta`
    /// is the relative index of refraction, as for [`Material::refraction`].
    ///
    /// ```
    /// # use tsl::{Compiler, ShadingGlobals};
    /// let program = Compiler::new().source("m.tsl", "material m = lambert(kd: gray(0.5));").compile()?;
    /// let m = program.material("m")?;
    /// let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ng: [0.0, 0.0, 1.0], ..Default::default() };
    /// let s = m.sample(&g, [0.0, 0.0, 1.0], &program.rgb(1.0, 1.0, 1.0), 0.5, [0.3, 0.7]);
    /// assert!(s.wi[2] > 0.0 && !s.delta);
    /// // Cosine sampling of a Lambertian surface: weight = albedo, pdf = cos / pi.
    /// assert!((s.weight.lanes()[0] - 0.5).abs() < 1e-5);
    /// assert!((s.pdf - s.wi[2] / std::f32::consts::PI).abs() < 1e-5);
    /// # Ok::<(), tsl::Error>(())
    /// ```
    pub fn sample(&self, g: &ShadingGlobals, wo: [f32; 3], eta: &Color, uc: f32, u: [f32; 2]) -> BsdfSample {
        let mut weight = Color::black(self.program.color_model());
        let d = self.sample_into(g, wo, eta.lanes(), uc, u, &mut weight.lanes);
        BsdfSample { wi: d.wi, weight, pdf: d.pdf, delta: d.delta }
    }

    /// [`Material::sample`] on lane slices: `eta` and `weight` hold the
    /// color model's lanes.
    ///
    /// # Panics
    /// When `eta` or `weight` is shorter than the color model's lane count.
    pub fn sample_into(
        &self,
        g: &ShadingGlobals,
        wo: [f32; 3],
        eta: &[f32],
        uc: f32,
        u: [f32; 2],
        weight: &mut [f32],
    ) -> SampledDir {
        let lanes = self.program.color_model().lanes();
        assert!(eta.len() >= lanes && weight.len() >= lanes, "eta and weight need {lanes} lanes");
        let mut args = Args::new();
        args.v(wo);
        args.extend(&eta[..lanes]);
        args.f(uc);
        args.extend(&u);
        let mut out = [0u32; MAX_RESULT_WORDS];
        self.call_into(Method::Sample, g, &args, out.as_mut_ptr());
        let s: BsdfSample = BsdfSample::from_words(self.color_model(), &out);
        weight[..lanes].copy_from_slice(s.weight.lanes());
        SampledDir { wi: s.wi, pdf: s.pdf, delta: s.delta }
    }

    /// The solid-angle density with which [`Material::sample`] draws `wi`
    /// for `wo` (0 for directions only a delta lobe gives).
    pub fn pdf(&self, g: &ShadingGlobals, wi: [f32; 3], wo: [f32; 3], eta: &Color) -> f32 {
        self.pdf_lanes(g, wi, wo, eta.lanes())
    }

    /// [`Material::pdf`] with `eta` as a lane slice.
    pub fn pdf_lanes(&self, g: &ShadingGlobals, wi: [f32; 3], wo: [f32; 3], eta: &[f32]) -> f32 {
        let lanes = self.program.color_model().lanes();
        assert!(eta.len() >= lanes, "eta needs {lanes} lanes");
        let mut args = Args::new();
        args.v(wi).v(wo);
        args.extend(&eta[..lanes]);
        let mut word = 0u32;
        self.call_into(Method::Pdf, g, &args, &mut word);
        f32::from_bits(word)
    }
}
