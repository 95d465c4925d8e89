//! Compiling materials for a renderer: one entry point
//! ([`Program::compile_surfaces`]), one lowering of each entry and one JIT
//! module for all of a scene's materials.
//!
//! Per material, in one pass: the interface methods a hit group would not
//! serve; then the hit group (when the renderer asks for one), kept when
//! its per-hit stage saves work ([`super::worth_preparing`]); then, for a
//! material left unsplit, the methods the group would have served and the
//! combined entries (`eval_pdf`, `delta_lobes`, a reflection sum). A
//! textured material is thus lowered once: as its group, plus the methods
//! outside it.

use super::material::{Code, Prepared};
use super::prepared::add_split_groups;
use super::{Entry, Error, Function, Material, PATH_METHODS, Part, Program, WHITTED_METHODS, worth_preparing};
use crate::check::{MaterialRef, Method};
use crate::diag::Diagnostic;
use crate::ir::Module as IrModule;
use crate::ir::lower::{self, HitGroup, HitMethod};
use crate::syntax::ast::{Expr, ExprKind};
use std::sync::Arc;

/// The calls a renderer makes at every hit, which a textured material's
/// hit group serves from one per-hit stage.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HitCalls {
    /// A path tracer's: `sample`, `eval_pdf` per light sample, the delta lobes.
    Path,
    /// A Whitted ray tracer's: `reflection` per light, the delta lobes.
    Whitted,
}

impl HitCalls {
    fn methods(self) -> &'static [HitMethod] {
        match self {
            HitCalls::Path => PATH_METHODS,
            HitCalls::Whitted => WHITTED_METHODS,
        }
    }
}

/// How [`Program::compile_surfaces`] compiles materials.
#[derive(Debug, Clone, Default)]
pub struct SurfaceOptions {
    /// The calls at each hit to serve from a per-hit stage (for textured
    /// materials); `None` compiles every method on its own.
    pub hit_calls: Option<HitCalls>,
    /// Compile, for materials that only reflect and are not split,
    /// `reflection` summed over this many lights in one call.
    pub summed_lights: Option<usize>,
    /// Materials that only reflect get the sum rather than a hit group
    /// (one evaluation per hit already).
    pub sums_instead_of_groups: bool,
    /// Cranelift's optimising tier for large functions, and the cases of a
    /// root `mix` in hit groups (`lower_hit_groups_with`).
    pub optimize_large: bool,
}

/// A material to compile: a material value of the program, or a material
/// of the program or its prelude by name (`emitter`).
#[derive(Debug, Clone, PartialEq)]
pub enum MaterialSource {
    Ref(MaterialRef),
    Named(String),
}

impl Program {
    /// Compiles materials for a renderer, one [`Material`] per source, in
    /// one lowering pass and one JIT module.
    pub fn compile_surfaces(
        &self,
        sources: &[MaterialSource],
        options: &SurfaceOptions,
    ) -> Result<Vec<Material>, Error> {
        let named: Vec<Expr> = sources
            .iter()
            .map(|s| match s {
                MaterialSource::Named(n) => {
                    self.material(n)?;
                    Ok(Expr { kind: ExprKind::Name(n.as_str().into()), span: Default::default(), depth: 1 })
                }
                MaterialSource::Ref(_) => Ok(Expr { kind: ExprKind::Int(0), span: Default::default(), depth: 1 }),
            })
            .collect::<Result<_, Error>>()?;
        let mut exprs: Vec<(String, &Expr)> = Vec::with_capacity(sources.len());
        for (k, (source, own)) in sources.iter().zip(&named).enumerate() {
            let expr = match source {
                MaterialSource::Ref(r) => self.inner.program.material_expr(*r).ok_or_else(|| {
                    Error::plain(format!("internal error: material {k} names no material of the program"))
                })?,
                MaterialSource::Named(_) => own,
            };
            exprs.push((format!("@surface{k}"), expr));
        }
        let (program, model) = (&self.inner.program, self.inner.model);
        let group_methods = options.hit_calls.map_or(&[][..], HitCalls::methods);
        let served = |m: Method| group_methods.contains(&HitMethod::Interface(m));
        let mut diags: Vec<Diagnostic> = Vec::new();
        let mut ir = IrModule::default();
        let mut entries: Vec<Entry> = Vec::new();
        let mut add = |(module, more, d): (IrModule, Vec<Entry>, Vec<Diagnostic>), diags: &mut Vec<Diagnostic>| {
            ir.functions.extend(module.functions);
            entries.extend(more);
            diags.extend(d);
        };

        // The methods outside any group, and what their code shows.
        let outside = lower::lower_material_methods(program, model, &exprs, |_, m| !served(m));
        let zero_dir = |name: &str, method: Method| {
            let fname = format!("{name}.{}", method.name());
            let f = outside.0.functions.iter().find(|f| f.name == fname);
            f.and_then(|f| f.constant_results()).is_some_and(|w| w.iter().all(|x| f32::from_bits(*x) == 0.0))
        };
        let (reflects, refracts): (Vec<bool>, Vec<bool>) = exprs
            .iter()
            .map(|(n, _)| (!zero_dir(n, Method::ReflectionDir), !zero_dir(n, Method::RefractionDir)))
            .unzip();
        let only_reflects = |k: usize| !reflects[k] && !refracts[k];
        add(outside, &mut diags);

        // Hit groups, kept where their stage saves work.
        let candidates: Vec<usize> = (0..exprs.len())
            .filter(|k| options.hit_calls.is_some() && !(options.sums_instead_of_groups && only_reflects(*k)))
            .collect();
        let mut group_of: Vec<Option<usize>> = vec![None; exprs.len()];
        let mut groups: Vec<HitGroup> = Vec::new();
        if !candidates.is_empty() {
            let chosen: Vec<(String, &Expr)> = candidates.iter().map(|k| exprs[*k].clone()).collect();
            let (lowered, d) =
                lower::lower_hit_groups_with(program, model, &chosen, group_methods, options.optimize_large);
            diags.extend(d);
            for (k, group) in candidates.iter().zip(lowered) {
                if worth_preparing(&group.split.prepare) {
                    group_of[*k] = Some(groups.len());
                    groups.push(group);
                }
            }
        }

        // The rest of each unsplit material.
        let unsplit: Vec<usize> = (0..exprs.len()).filter(|k| group_of[*k].is_none()).collect();
        let pick = |keep: &dyn Fn(usize) -> bool| -> Vec<(String, &Expr)> {
            unsplit.iter().filter(|k| keep(**k)).map(|k| exprs[*k].clone()).collect()
        };
        if !group_methods.is_empty() {
            let rest = lower::lower_material_methods(program, model, &pick(&|_| true), |_, m| served(m));
            add(rest, &mut diags);
        }
        if options.hit_calls == Some(HitCalls::Path) {
            add(lower::lower_eval_pdf(program, model, &pick(&|_| true)), &mut diags);
        }
        let specular = pick(&|k| reflects[k] || refracts[k]);
        if !specular.is_empty() {
            add(lower::lower_delta_lobes(program, model, &specular), &mut diags);
        }
        let summed = options.summed_lights.map(|lights| (lights, pick(&only_reflects)));
        if let Some((lights, materials)) = &summed
            && !materials.is_empty()
        {
            add(lower::lower_reflection_sums(program, model, materials, *lights), &mut diags);
        }
        self.lowering_errors(diags)?;

        add_split_groups(&groups, &mut ir, &mut entries);
        let mut jit_options = self.inner.jit_options.clone();
        jit_options.optimize_large |= options.optimize_large;
        let part = self.jit_part_with(ir, entries, &jit_options)?;
        let mut prepared = self.hit_materials_in(&part, &groups)?.into_iter().map(Some).collect::<Vec<_>>();
        let find = |name: String| find_in(&part, &name);
        let mut out = Vec::with_capacity(exprs.len());
        for (k, (name, _)) in exprs.iter().enumerate() {
            let hit = group_of[k].and_then(|g| prepared[g].take()).map(Prepared::new);
            let methods = Method::ALL.map(|m| find(format!("{name}.{}", m.name())));
            let reflection_sum = summed
                .as_ref()
                .and_then(|(lights, _)| Some((*lights, find(format!("{name}.reflection_sum{lights}"))?)));
            let code = Code {
                name: name.clone(),
                methods,
                eval_pdf: find(format!("{name}.eval_pdf")),
                delta_lobes: find(format!("{name}.delta_lobes")),
                reflection_sum,
                hit,
            };
            if Method::ALL.iter().any(|m| code.methods[*m as usize].is_none() && !served(*m)) {
                return Err(Error::plain(format!("internal error: the methods of `{name}` were not all compiled")));
            }
            out.push(Material::new(self.clone(), code));
        }
        if let Ok(mut parts) = self.inner.parts.write() {
            parts.push(part);
        }
        Ok(out)
    }
}

/// The compiled function `name` of `part`, if it has one.
fn find_in(part: &Arc<Part>, name: &str) -> Option<Function> {
    let index = part.ir.functions.iter().position(|f| f.name == name)?;
    Some(Function::new(part.clone(), index, part.jit.function(name)?))
}
