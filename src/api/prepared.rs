//! Prepared hits: a material's methods split into one per-hit stage and
//! per-direction calls that read what it computed (see `ir::split`).
//!
//! A renderer calls several methods at each hit (`sample`, `eval_pdf` per
//! light sample, the delta lobes, `emission`); without a split, each one
//! evaluates the whole texture tree again. A [`HitMaterial`] runs the tree
//! once, in [`HitMaterial::prepare`], and the [`PreparedHit`] it returns
//! answers every method from that. The hit borrows its material, so it can
//! be used with no other and cannot outlive the compiled code.

use super::outputs::{BsdfSample, EvalPdf, MAX_RESULT_WORDS};
use super::{Backend, Color, Entry, Error, Function, Part, Program};
use crate::check::{Method, Ty};
use crate::globals::ShadingGlobals;
use crate::ir::Module as IrModule;
use crate::ir::lower::{EntryKind, HitEntry, HitGroup, HitMethod, hit_inputs, lower_hit_groups};
use crate::syntax::ast::{Expr, ExprKind};
use std::sync::Arc;

/// What a path tracer calls at a hit after `prepare`: the hit group the
/// renderer compiles (`emission`, needed only by emitters, stays a call of
/// its own).
pub const PATH_METHODS: &[HitMethod] =
    &[HitMethod::Interface(Method::Sample), HitMethod::EvalPdf, HitMethod::DeltaLobes];

/// What a Whitted ray tracer calls at a hit after `prepare`: `reflection`
/// once per light sample and the perfect directions.
pub const WHITTED_METHODS: &[HitMethod] = &[HitMethod::Interface(Method::Reflection), HitMethod::DeltaLobes];

/// A material compiled for prepared hits: its `prepare` stage and the
/// methods of one hit group.
#[derive(Clone)]
pub struct HitMaterial {
    program: Program,
    prepare: Function,
    methods: Vec<(HitMethod, Function)>,
    record_words: usize,
}

impl std::fmt::Debug for HitMaterial {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("HitMaterial")
            .field("name", &self.prepare.ir().name)
            .field("record_words", &self.record_words)
            .finish()
    }
}

impl Program {
    /// Compiles named materials (as [`Program::material`] accepts) for
    /// prepared hits with the given methods ([`PATH_METHODS`] is what a path
    /// tracer needs).
    ///
    /// ```
    /// use tsl::{Backend, Compiler, ShadingGlobals};
    /// use tsl::PATH_METHODS;
    /// let program = Compiler::new()
    ///     .source("m.tsl", "material m = mix(noise(P) * 0.5 + 0.5, lambert, phong);")
    ///     .compile()
    ///     .unwrap();
    /// let m = &program.hit_materials(&["m"], PATH_METHODS).unwrap()[0];
    /// let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ng: [0.0, 0.0, 1.0], ..Default::default() };
    /// let eta = program.rgb(1.0, 1.0, 1.0);
    /// let mut hit = m.prepare(Backend::Jit, &g, [0.0, 0.0, 1.0], &eta);
    /// let s = hit.sample(0.3, [0.4, 0.6]).unwrap();
    /// let (f, pdf) = hit.eval_pdf(s.wi).unwrap();
    /// assert!((pdf - s.pdf).abs() < 1e-4 && f.brightness() > 0.0);
    /// ```
    pub fn hit_materials(&self, names: &[&str], methods: &[HitMethod]) -> Result<Vec<HitMaterial>, Error> {
        let exprs: Vec<Expr> = names
            .iter()
            .map(|n| {
                self.material(n)?;
                Ok(Expr { kind: ExprKind::Name((*n).into()), span: Default::default(), depth: 1 })
            })
            .collect::<Result<_, Error>>()?;
        let materials: Vec<(String, &Expr)> = names.iter().map(|n| n.to_string()).zip(&exprs).collect();
        self.compile_hit_groups(&materials, methods)
    }

    /// Compiles material expressions of the root program for prepared hits.
    pub(crate) fn compile_hit_groups(
        &self,
        materials: &[(String, &Expr)],
        methods: &[HitMethod],
    ) -> Result<Vec<HitMaterial>, Error> {
        let (groups, diags) = lower_hit_groups(&self.inner.program, self.inner.model, materials, methods);
        self.lowering_errors(diags)?;
        self.compile_split_groups(groups, false)
    }

    /// Compiles lowered hit groups together, one [`HitMaterial`] each.
    fn compile_split_groups(&self, groups: Vec<HitGroup>, optimize_large: bool) -> Result<Vec<HitMaterial>, Error> {
        let mut ir = IrModule::default();
        let mut entries = Vec::new();
        add_split_groups(&groups, &mut ir, &mut entries);
        let mut options = self.inner.jit_options.clone();
        options.optimize_large |= optimize_large;
        let part = self.jit_part_with(ir, entries, &options)?;
        let out = self.hit_materials_in(&part, &groups)?;
        if let Ok(mut parts) = self.inner.parts.write() {
            parts.push(part);
        }
        Ok(out)
    }

    /// The [`HitMaterial`]s of `groups`, compiled into `part` by
    /// [`add_split_groups`].
    pub(super) fn hit_materials_in(&self, part: &Arc<Part>, groups: &[HitGroup]) -> Result<Vec<HitMaterial>, Error> {
        let handle = |name: &str| -> Result<Function, Error> {
            let index = part.ir.functions.iter().position(|f| f.name == name);
            match (index, part.jit.function(name)) {
                (Some(index), Some(native)) => Ok(Function::new(part.clone(), index, native)),
                _ => Err(Error::plain(format!("internal error: `{name}` was not compiled"))),
            }
        };
        let mut out = Vec::with_capacity(groups.len());
        for HitGroup { split, entries: methods, .. } in groups {
            let prepare = handle(&split.prepare.name)?;
            let mut compiled = Vec::with_capacity(methods.len());
            for (e, f) in methods.iter().zip(&split.methods) {
                compiled.push((e.method, handle(&f.name)?));
            }
            out.push(HitMaterial {
                program: self.clone(),
                prepare,
                methods: compiled,
                record_words: split.record_words(),
            });
        }
        Ok(out)
    }
}

/// Adds the functions and entries of split hit groups to a module.
pub(super) fn add_split_groups(groups: &[HitGroup], ir: &mut IrModule, entries: &mut Vec<Entry>) {
    {
        for HitGroup { split, entries: methods, .. } in groups {
            let record = ("hit".to_string(), Ty::Array(Box::new(Ty::Int), split.record_words() as u32));
            ir.functions.push(split.prepare.clone());
            entries.push(Entry {
                name: split.prepare.name.clone(),
                kind: EntryKind::Method("prepare"),
                params: hit_inputs(),
                ret: record.1.clone(),
            });
            for (HitEntry { method, params, ret }, f) in methods.iter().zip(&split.methods) {
                ir.functions.push(f.clone());
                let params = std::iter::once(record.clone()).chain(params.iter().cloned()).collect();
                entries.push(Entry { name: f.name.clone(), kind: EntryKind::Hit(*method), params, ret: ret.clone() });
            }
        }
    }
}

/// Whether running `prepare` once per hit saves work: it looks up a
/// texture or evaluates noise (what a texture tree spends its time on).
/// Without either, a material (`lambert`, a rough metal) is faster with
/// each method on its own: measured with `cargo bench --bench render --
/// split`, `cornell` rendered 18% and `glossy` 5% slower split, as the
/// extra call and the record cost more than the arithmetic they share.
pub(crate) fn worth_preparing(prepare: &crate::ir::Function) -> bool {
    crate::ir::has_costly(&prepare.body)
}

impl HitMaterial {
    /// Whether running this material's prepare function once per hit saves
    /// work (it looks up a texture or evaluates noise): what the renderer
    /// decides by, and what `tslc emit hit` reports.
    ///
    /// ```
    /// let src = "material plain = lambert; material grain = scale(gray(noise(Pl * 4)), lambert);";
    /// let p = tsl::Compiler::new().source("m.tsl", src).compile()?;
    /// let hits = p.hit_materials(&["plain", "grain"], tsl::PATH_METHODS)?;
    /// assert!(!hits[0].worth_preparing());
    /// assert!(hits[1].worth_preparing());
    /// # Ok::<(), tsl::Error>(())
    /// ```
    pub fn worth_preparing(&self) -> bool {
        worth_preparing(self.prepare.ir())
    }

    /// The words of this material's hit record.
    pub fn record_words(&self) -> usize {
        self.record_words
    }

    /// The compiled methods of the group, in order.
    pub(crate) fn functions(&self) -> impl Iterator<Item = &Function> {
        self.methods.iter().map(|(_, f)| f)
    }

    /// The compiled `prepare` stage (arguments `wo`, `eta`; results the record).
    pub fn prepare_function(&self) -> &Function {
        &self.prepare
    }

    /// The compiled method, if the group has it (arguments `[record | own]`).
    pub fn method_function(&self, method: HitMethod) -> Option<&Function> {
        self.methods.iter().find(|(m, _)| *m == method).map(|(_, f)| f)
    }

    /// Where `method` is among the methods the material was compiled with:
    /// its position in the `methods` given to [`Program::hit_materials`],
    /// for [`HitMaterial::call_at`]. Renderers look a method up once, not
    /// at every call (comparing names cost 2.7% of a textured render).
    pub fn method_index(&self, method: HitMethod) -> Option<usize> {
        self.methods.iter().position(|(m, _)| *m == method)
    }

    /// Runs the per-hit stage for the view direction `wo` and the relative
    /// index `eta` at `g`.
    pub fn prepare(&self, backend: Backend, g: &ShadingGlobals, wo: [f32; 3], eta: &Color) -> PreparedHit<'_> {
        let mut words = vec![0u32; self.record_words];
        let inputs: Vec<u32> = wo.iter().chain(eta.lanes()).map(|x| x.to_bits()).collect();
        // The argument and result lengths are this function's own.
        let _ = self.prepare.call_words(backend, g, &inputs, &mut words);
        PreparedHit { material: self, backend, globals: *g, words }
    }

    /// [`HitMaterial::prepare`] into a reused buffer, for renderers:
    /// `words` becomes the record, to be passed to [`HitMaterial::call_words`].
    pub fn prepare_words(&self, backend: Backend, g: &ShadingGlobals, inputs: &[u32], words: &mut Vec<u32>) {
        // Not zeroed first (1% of a textured render): a method reads a
        // slot only under the point-only branches that `prepare` wrote it
        // under at this hit, so words left from another hit are never read.
        words.resize(self.record_words, 0);
        let _ = self.prepare.call_words(backend, g, inputs, words);
    }

    /// Calls `method` with the record `words` (from [`HitMaterial::prepare_words`])
    /// and its own argument words; `words` keeps the record in front.
    pub fn call_words(
        &self,
        backend: Backend,
        method: HitMethod,
        g: &ShadingGlobals,
        words: &mut Vec<u32>,
        own: &[u32],
        out: &mut [u32],
    ) -> Result<(), String> {
        let index = self
            .method_index(method)
            .ok_or_else(|| format!("`{}` was compiled without {method:?}", self.prepare.ir().name))?;
        if words.len() < self.record_words {
            return Err("the record is shorter than the material's: prepare it first".into());
        }
        words.truncate(self.record_words);
        words.extend_from_slice(own);
        self.call_at(backend, index, g, words, out)
    }

    /// Calls the method at `index` ([`HitMaterial::method_index`]) with
    /// `words`: the record of [`HitMaterial::prepare_words`] followed by
    /// the method's own argument words, which renderers push after
    /// [`HitMaterial::record_words`] words in place.
    ///
    /// ```
    /// use tsl::{Backend, Compiler, HitMethod, PATH_METHODS, ShadingGlobals};
    /// let program = Compiler::new()
    ///     .source("m.tsl", "material m = mix(noise(P) * 0.5 + 0.5, lambert, phong);")
    ///     .compile()
    ///     .unwrap();
    /// let m = &program.hit_materials(&["m"], PATH_METHODS).unwrap()[0];
    /// // Once, before the hits.
    /// let eval_pdf = m.method_index(HitMethod::EvalPdf).unwrap();
    /// let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ng: [0.0, 0.0, 1.0], ..Default::default() };
    /// let bits = |xs: &[f32]| xs.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
    /// let mut words = Vec::new();
    /// // At each hit: `wo` and `eta`, then `wi` after the record.
    /// m.prepare_words(Backend::Jit, &g, &bits(&[0.0, 0.0, 1.0, 1.0, 1.0, 1.0]), &mut words);
    /// words.truncate(m.record_words());
    /// words.extend(bits(&[0.0, 0.6, 0.8]));
    /// let mut out = [0u32; 4]; // f · cos (three RGB lanes), then the pdf
    /// m.call_at(Backend::Jit, eval_pdf, &g, &words, &mut out).unwrap();
    /// assert!(f32::from_bits(out[3]) > 0.0);
    /// ```
    #[inline]
    pub fn call_at(
        &self,
        backend: Backend,
        index: usize,
        g: &ShadingGlobals,
        words: &[u32],
        out: &mut [u32],
    ) -> Result<(), String> {
        match self.methods.get(index) {
            Some((_, f)) => f.call_words(backend, g, words, out),
            None => Err(format!("`{}` has no method {index}", self.prepare.ir().name)),
        }
    }
}

/// One hit, prepared: every method of the material's group, answered from
/// the record `prepare` wrote.
pub struct PreparedHit<'m> {
    material: &'m HitMaterial,
    backend: Backend,
    globals: ShadingGlobals,
    words: Vec<u32>,
}

impl PreparedHit<'_> {
    /// Calls `method` with its own argument words.
    pub fn call_words(&mut self, method: HitMethod, own: &[u32], out: &mut [u32]) -> Result<(), String> {
        self.material.call_words(self.backend, method, &self.globals, &mut self.words, own, out)
    }

    fn color(&mut self, method: HitMethod, own: &[u32]) -> Result<Color, String> {
        let model = self.material.program.color_model();
        let mut out = vec![0u32; model.lanes()];
        self.call_words(method, own, &mut out)?;
        let lanes: Vec<f32> = out.iter().map(|w| f32::from_bits(*w)).collect();
        Ok(Color::from_lanes(model, &lanes))
    }

    /// `reflection(wi, light, wo)` at this hit.
    pub fn reflection(&mut self, wi: [f32; 3], light: &Color) -> Result<Color, String> {
        let own: Vec<u32> = wi.iter().chain(light.lanes()).map(|x| x.to_bits()).collect();
        self.color(HitMethod::Interface(Method::Reflection), &own)
    }

    /// `emission(wo)` at this hit.
    pub fn emission(&mut self) -> Result<Color, String> {
        self.color(HitMethod::Interface(Method::Emission), &[])
    }

    /// `sample(wo, eta, u1, u2)` at this hit.
    pub fn sample(&mut self, u1: f32, u2: [f32; 2]) -> Result<BsdfSample, String> {
        let mut out = [0u32; MAX_RESULT_WORDS];
        let own = [u1, u2[0], u2[1]].map(f32::to_bits);
        self.call_words(HitMethod::Interface(Method::Sample), &own, &mut out)?;
        Ok(BsdfSample::from_words(self.material.program.color_model(), &out))
    }

    /// `f · cos` for unit light from `wi` and the pdf of sampling `wi`, in
    /// one call (Mitsuba's `eval_pdf`).
    pub fn eval_pdf(&mut self, wi: [f32; 3]) -> Result<(Color, f32), String> {
        let mut out = [0u32; MAX_RESULT_WORDS];
        self.call_words(HitMethod::EvalPdf, &wi.map(f32::to_bits), &mut out)?;
        let e: EvalPdf = EvalPdf::from_words(self.material.program.color_model(), &out);
        Ok((e.value, e.pdf))
    }
}
