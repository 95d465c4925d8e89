//! `Material`: a compiled material, what its code shows about it
//! ([`MaterialFacts`]), and the calls a host makes without a [`Surface`]
//! (`material.reflection(&g, ...)`, each a surface of one call).
//!
//! A material holds the interface methods compiled one by one, the
//! combined entries (`eval_pdf`, `delta_lobes`, a reflection sum) and, when
//! the compiler split it, its prepared hit group; [`Material::at`] hands out
//! the [`Surface`] that chooses between them.

use super::outputs::{BsdfSample, MAX_RESULT_WORDS};
use super::surface::{Surface, SurfaceRecord};
use super::{Color, Function, HitMaterial, Program};
use crate::check::Method;
use crate::color::{ColorModel, MAX_SAMPLES};
use crate::globals::ShadingGlobals;
use crate::ir::lower::HitMethod;
use std::fmt;
use std::sync::Arc;

/// A compiled material: the generic material interface, as native calls.
/// Cheap to clone (the objects of a scene that name one material share it),
/// `Send + Sync`.
#[derive(Clone)]
pub struct Material {
    pub(super) program: Program,
    pub(super) code: Arc<Code>,
    facts: MaterialFacts,
    /// The color model's lane count, read at every surface call.
    pub(super) lanes: usize,
}

/// The compiled entries of a material.
pub(super) struct Code {
    pub name: String,
    /// By [`Method`]; `None` for a method its hit group serves.
    pub methods: [Option<Function>; Method::ALL.len()],
    pub eval_pdf: Option<Function>,
    pub delta_lobes: Option<Function>,
    /// `reflection` summed over this many lights.
    pub reflection_sum: Option<(usize, Function)>,
    pub hit: Option<Prepared>,
}

impl Code {
    /// The interface methods alone, in [`Method`] order (missing ones
    /// `None`): no combined entries, no hit group.
    pub fn methods_only(name: String, methods: impl IntoIterator<Item = Option<Function>>) -> Code {
        let mut methods = methods.into_iter();
        let methods = Method::ALL.map(|_| methods.next().flatten());
        Code { name, methods, eval_pdf: None, delta_lobes: None, reflection_sum: None, hit: None }
    }
}

/// A hit group with the positions of the methods a surface calls through
/// it, looked up once (comparing at every call cost 2.7% of a textured
/// render).
pub(super) struct Prepared {
    pub material: HitMaterial,
    /// By [`Method`]: the group's index of the interface method, if any.
    pub methods: [Option<usize>; Method::ALL.len()],
    pub eval_pdf: Option<usize>,
    pub delta_lobes: Option<usize>,
}

impl Prepared {
    pub fn new(material: HitMaterial) -> Prepared {
        Prepared {
            methods: Method::ALL.map(|m| material.method_index(HitMethod::Interface(m))),
            eval_pdf: material.method_index(HitMethod::EvalPdf),
            delta_lobes: material.method_index(HitMethod::DeltaLobes),
            material,
        }
    }
}

/// What a material's compiled code shows about it, found once when it is
/// compiled: a renderer skips the calls whose answers are known.
#[derive(Debug, Clone, PartialEq)]
pub struct MaterialFacts {
    /// `emission` is not the constant black: the material may be a light.
    pub may_emit: bool,
    /// `opaque` is the constant `true`: shadow rays need not ask.
    pub always_opaque: bool,
    /// `reflection_dir` is not the default zero (a mirror direction).
    pub reflects: bool,
    /// `refraction_dir` is not the default zero (light passes through).
    pub refracts: bool,
    /// `absorption` gives back the light it is given (a clear medium).
    pub clear: bool,
    /// `refraction_index` when it is a constant, in the model's lanes.
    pub constant_ior: Option<Vec<f32>>,
    /// Bit `k` is set when some method reads word `k` of [`ShadingGlobals`]
    /// (see `globals::word_of`).
    pub globals_read: u64,
    /// [`MaterialFacts::reads_footprint`] and [`MaterialFacts::reads_uv`],
    /// found once: a renderer asks at every hit, and finding the globals'
    /// words by name there cost 6% of a Cornell box render.
    reads_footprint: bool,
    reads_uv: bool,
}

impl MaterialFacts {
    /// Light may cross the surface: it refracts, or is not always opaque
    /// (a rough dielectric has no perfect direction but lets paths through).
    pub fn transmits(&self) -> bool {
        self.refracts || !self.always_opaque
    }

    /// Some method reads the pixel footprint (dPdx .. dvdy).
    pub fn reads_footprint(&self) -> bool {
        self.reads_footprint
    }

    /// Some method reads u, v, dPdu or dPdv (or the footprint, which needs them).
    pub fn reads_uv(&self) -> bool {
        self.reads_uv
    }

    fn of(methods: &[Option<Function>], others: &[&Function]) -> MaterialFacts {
        let ir = |m: Method| methods[m as usize].as_ref().map(Function::ir);
        let constant = |m: Method| ir(m).and_then(|f| f.constant_results());
        let zero = |m: Method| constant(m).is_some_and(|w| w.iter().all(|x| f32::from_bits(*x) == 0.0));
        let mut globals_read = 0u64;
        for f in methods.iter().flatten().chain(others.iter().copied()) {
            crate::ir::for_each_op(&f.ir().body, &mut |op| {
                if let crate::ir::Op::Global(w) = op {
                    globals_read |= 1u64.checked_shl(*w).unwrap_or(0);
                }
            });
        }
        let reads_footprint = globals_read & globals_words("dPdx", "dvdy") != 0;
        MaterialFacts {
            clear: ir(Method::Absorption).is_some_and(returns_its_light),
            may_emit: !zero(Method::Emission),
            always_opaque: constant(Method::Opaque).is_some_and(|w| w.first() == Some(&1)),
            reflects: !zero(Method::ReflectionDir),
            refracts: !zero(Method::RefractionDir),
            constant_ior: constant(Method::RefractionIndex).map(|w| w.into_iter().map(f32::from_bits).collect()),
            globals_read,
            reads_footprint,
            reads_uv: reads_footprint || globals_read & globals_words("u", "dPdv") != 0,
        }
    }
}

/// The words of the globals from `first` to `last`, as bits.
fn globals_words(first: &str, last: &str) -> u64 {
    let ends = |name: &str| {
        crate::globals::word_of(name).map_or((0, 0), |(w, ty)| (w, w + if ty.is_triple() { 3 } else { 1 }))
    };
    (!0u64 << ends(first).0) & !(!0u64 << ends(last).1)
}

/// `absorption(light, d)` writing its light words straight back.
fn returns_its_light(absorption: &crate::ir::Function) -> bool {
    let lanes = absorption.results.len();
    let mut outputs = vec![None; lanes];
    let mut params = std::collections::HashMap::new();
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
            _ => return false,
        }
    }
    outputs.iter().enumerate().all(|(k, p)| *p == Some(k as u32))
}

impl fmt::Debug for Material {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Material").field("name", &self.code.name).field("prepared", &self.is_prepared()).finish()
    }
}

/// The most argument words a method takes: `refraction(wi, light, eta, wo)`.
pub(super) const MAX_ARG_WORDS: usize = 3 + 2 * MAX_SAMPLES + 3;

/// The direction part of a sample from [`Material::sample_into`], whose
/// weight goes to a lane slice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampledDir {
    pub wi: [f32; 3],
    pub pdf: f32,
    pub delta: bool,
}

impl Material {
    pub(super) fn new(program: Program, code: Code) -> Material {
        let others: Vec<&Function> = code
            .hit
            .iter()
            .flat_map(|h| std::iter::once(h.material.prepare_function()).chain(h.material.functions()))
            .collect();
        let facts = MaterialFacts::of(&code.methods, &others);
        Material::with_facts(program, code, facts)
    }

    /// The UDIM tile sets this material looks up at the shading point's own
    /// (u, v) ([`crate::ir::Function::lookups_at_uv`]), each once: a mesh's
    /// texture coordinates name the tiles such a lookup reads, so a scene
    /// can check them before rendering. Lookups at coordinates computed
    /// from (u, v) are not among them.
    pub fn udim_sets_at_uv(&self) -> Vec<Arc<crate::texture::UdimSet>> {
        let code = &self.code;
        let hit =
            code.hit.iter().flat_map(|h| std::iter::once(h.material.prepare_function()).chain(h.material.functions()));
        let functions = (code.methods.iter().flatten())
            .chain(&code.eval_pdf)
            .chain(&code.delta_lobes)
            .chain(code.reflection_sum.iter().map(|(_, f)| f))
            .chain(hit);
        let mut sets: Vec<Arc<crate::texture::UdimSet>> = Vec::new();
        for f in functions {
            for sampler in f.ir().lookups_at_uv() {
                if let crate::texture::TextureImage::Udim(set) = &sampler.0.image
                    && !sets.iter().any(|s| Arc::ptr_eq(s, set))
                {
                    sets.push(set.clone());
                }
            }
        }
        sets
    }

    /// A material of `code` whose facts are known already (those of other
    /// code compiled from the same IR): a run-time-bound instance's.
    pub(super) fn with_facts(program: Program, code: Code, facts: MaterialFacts) -> Material {
        let lanes = program.color_model().lanes();
        Material { program, code: Arc::new(code), facts, lanes }
    }

    /// The surface at a hit, seen from `wo` (unit, toward the viewer), with
    /// the relative index of refraction `eta` across it: every method of
    /// the interface, with typed results. Whether the compiler split the
    /// material into a per-hit stage is decided here: if so, the stage runs
    /// once, at the first call that needs it, into `record` (a buffer to
    /// reuse from hit to hit, one per thread).
    ///
    /// ```
    /// use tsl::{Compiler, ShadingGlobals, SurfaceRecord};
    /// let program = Compiler::new().source("m.tsl", "material m = lambert(kd: gray(0.5));").compile()?;
    /// let m = program.material("m")?;
    /// let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ng: [0.0, 0.0, 1.0], ..Default::default() };
    /// let eta = program.rgb(1.0, 1.0, 1.0);
    /// let mut record = SurfaceRecord::new();
    /// let mut surface = m.at(&g, [0.0, 0.0, 1.0], &eta, &mut record);
    /// let s = surface.sample(0.5, [0.3, 0.7]);
    /// let e = surface.eval_pdf(s.wi);
    /// assert!((e.pdf - s.pdf).abs() < 1e-5 && !s.delta);
    /// // Cosine sampling of a Lambertian surface: weight = albedo.
    /// assert!((s.weight.lanes()[0] - 0.5).abs() < 1e-5);
    /// assert!(surface.opaque() && surface.emission().brightness() == 0.0);
    /// # Ok::<(), tsl::Error>(())
    /// ```
    ///
    /// # Panics
    /// When `C` holds fewer lanes than the color model has.
    pub fn at<'a, C: super::Lanes>(
        &'a self,
        g: &'a ShadingGlobals,
        wo: [f32; 3],
        eta: &'a C,
        record: &'a mut SurfaceRecord,
    ) -> Surface<'a, C> {
        record.new_hit();
        self.resume(g, wo, eta, record)
    }

    /// [`Material::at`] for the hit `record` was last given to `at` with
    /// the same `g`, `wo` and `eta`: for a caller whose calls at one hit are
    /// interleaved with other work that needs `&mut` (a renderer tracing
    /// shadow rays), so the per-hit stage runs once. Given another hit's
    /// record, results are wrong but memory stays safe.
    #[inline]
    pub fn resume<'a, C: super::Lanes>(
        &'a self,
        g: &'a ShadingGlobals,
        wo: [f32; 3],
        eta: &'a C,
        record: &'a mut SurfaceRecord,
    ) -> Surface<'a, C> {
        let lanes = self.lanes;
        assert!(eta.lanes().len() >= lanes, "a color of {lanes} lanes at least");
        Surface::new(self, g, wo, eta, record)
    }

    /// The number of lights [`Surface::reflection_sum`] sums over, when
    /// the material was compiled with a sum.
    pub fn summed_lights(&self) -> Option<usize> {
        self.code.reflection_sum.as_ref().map(|(n, _)| *n)
    }

    /// What the material's code shows about it.
    pub fn facts(&self) -> &MaterialFacts {
        &self.facts
    }

    /// Whether the compiler split the material into a per-hit stage and
    /// per-direction calls (a textured material compiled for a renderer).
    pub fn is_prepared(&self) -> bool {
        self.code.hit.is_some()
    }

    /// The compiled entry of one interface method, for hosts that pack
    /// argument words themselves ([`Function::call_words`]); `None` when
    /// its hit group serves it (see [`Material::is_prepared`]).
    pub fn method(&self, method: Method) -> Option<&Function> {
        self.code.methods[method as usize].as_ref()
    }

    /// The hit group of a prepared material (for benchmarks that count
    /// what each entry computes).
    #[doc(hidden)]
    pub fn hit_group(&self) -> Option<&HitMaterial> {
        self.code.hit.as_ref().map(|h| &h.material)
    }

    /// The combined entries the material was compiled with: `eval_pdf`,
    /// `delta_lobes` and the reflection sum (for benchmarks).
    #[doc(hidden)]
    pub fn combined_functions(&self) -> [Option<&Function>; 3] {
        let code = &self.code;
        [code.eval_pdf.as_ref(), code.delta_lobes.as_ref(), code.reflection_sum.as_ref().map(|(_, f)| f)]
    }

    /// Bit `k` is set when some method reads word `k` of [`ShadingGlobals`].
    pub fn globals_read(&self) -> u64 {
        self.facts.globals_read
    }

    /// The color model the material was compiled for.
    pub fn color_model(&self) -> ColorModel {
        self.program.color_model()
    }

    /// One call on a surface of its own, for the methods below.
    fn once<R>(
        &self,
        g: &ShadingGlobals,
        wo: [f32; 3],
        eta: Option<&Color>,
        f: impl FnOnce(&mut Surface<Color>) -> R,
    ) -> R {
        let ones = self.program.rgb(1.0, 1.0, 1.0);
        let mut record = SurfaceRecord::new();
        f(&mut self.at(g, wo, eta.unwrap_or(&ones), &mut record))
    }

    /// Light arriving from `wi` reflected toward `wo`.
    pub fn reflection(&self, g: &ShadingGlobals, wi: [f32; 3], light: &Color, wo: [f32; 3]) -> Color {
        self.once(g, wo, None, |s| s.reflection(wi, light))
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
        let lanes = self.color_model().lanes();
        assert!(light.len() >= lanes && out.len() >= lanes, "light and out need {lanes} lanes");
        let light = Color::from_lanes(self.color_model(), light);
        let c = self.reflection(g, wi, &light, wo);
        out[..lanes].copy_from_slice(c.lanes());
    }

    /// Light arriving from `wi` transmitted toward `wo`.
    pub fn refraction(&self, g: &ShadingGlobals, wi: [f32; 3], light: &Color, eta: &Color, wo: [f32; 3]) -> Color {
        self.once(g, wo, Some(eta), |s| s.refraction(wi, light))
    }

    pub fn refraction_index(&self, g: &ShadingGlobals) -> Color {
        self.once(g, [0.0; 3], None, |s| s.refraction_index())
    }

    /// The mirror direction for an outgoing `wo`; zero when there is none.
    pub fn reflection_dir(&self, g: &ShadingGlobals, wo: [f32; 3]) -> [f32; 3] {
        self.once(g, wo, None, |s| s.reflection_dir())
    }

    /// The refracted direction; zero on total internal reflection or none.
    pub fn refraction_dir(&self, g: &ShadingGlobals, wo: [f32; 3], eta: &Color) -> [f32; 3] {
        self.once(g, wo, Some(eta), |s| s.refraction_dir())
    }

    pub fn emission(&self, g: &ShadingGlobals, wo: [f32; 3]) -> Color {
        self.once(g, wo, None, |s| s.emission())
    }

    /// The material's directional albedo toward `wo`: the fraction of
    /// light from `wo` it reflects (`albedo(wo)` in TSL), which a `layer`
    /// with this material on top does not let through to its base.
    ///
    /// ```
    /// # use tsl::{Compiler, ShadingGlobals};
    /// let program = Compiler::new().source("a.tsl", "material m = lambert(kd: gray(0.25));").compile()?;
    /// let m = program.material("m")?;
    /// let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ng: [0.0, 0.0, 1.0], ..ShadingGlobals::default() };
    /// assert_eq!(m.albedo(&g, [0.0, 0.0, 1.0]).lanes(), &[0.25; 3]);
    /// # Ok::<(), tsl::Error>(())
    /// ```
    pub fn albedo(&self, g: &ShadingGlobals, wo: [f32; 3]) -> Color {
        self.once(g, wo, None, |s| s.albedo())
    }

    pub fn ambient(&self, g: &ShadingGlobals, light: &Color) -> Color {
        self.once(g, [0.0; 3], None, |s| s.ambient(light))
    }

    /// The light left of `light` after `distance` inside the material.
    pub fn absorption(&self, g: &ShadingGlobals, light: &Color, distance: f32) -> Color {
        self.once(g, [0.0; 3], None, |s| s.absorption(light, distance))
    }

    pub fn normal(&self, g: &ShadingGlobals) -> [f32; 3] {
        self.once(g, [0.0; 3], None, |s| s.normal())
    }

    pub fn diffuse(&self, g: &ShadingGlobals) -> Color {
        self.once(g, [0.0; 3], None, |s| s.diffuse())
    }

    pub fn opaque(&self, g: &ShadingGlobals) -> bool {
        self.once(g, [0.0; 3], None, |s| s.opaque())
    }

    /// Draws an incident direction for light leaving toward `wo`, from the
    /// uniform random numbers `uc` (which lobe) and `u` (where in it); `eta`
    /// is the relative index of refraction, as for [`Material::refraction`].
    pub fn sample(&self, g: &ShadingGlobals, wo: [f32; 3], eta: &Color, uc: f32, u: [f32; 2]) -> BsdfSample {
        self.once(g, wo, Some(eta), |s| s.sample(uc, u))
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
        let lanes = self.color_model().lanes();
        assert!(eta.len() >= lanes && weight.len() >= lanes, "eta and weight need {lanes} lanes");
        let s = self.sample(g, wo, &Color::from_lanes(self.color_model(), eta), uc, u);
        weight[..lanes].copy_from_slice(s.weight.lanes());
        SampledDir { wi: s.wi, pdf: s.pdf, delta: s.delta }
    }

    /// The solid-angle density with which [`Material::sample`] draws `wi`
    /// for `wo` (0 for directions only a delta lobe gives).
    pub fn pdf(&self, g: &ShadingGlobals, wi: [f32; 3], wo: [f32; 3], eta: &Color) -> f32 {
        self.once(g, wo, Some(eta), |s| s.pdf(wi))
    }
}

const _: () = assert!(MAX_RESULT_WORDS >= MAX_SAMPLES);
