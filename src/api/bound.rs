//! Run-time-bound instances (OSL's instance parameters, Mitsuba's
//! `traverse`): a shader is compiled once for each combination of the
//! values that change its code (`material` parameters, strings), and its
//! numeric, vector, color and bool parameters are words of the instance's
//! parameter block, which the compiled code reads at every call
//! (`Op::InstanceWord`). Binding an instance, or binding it again after a
//! value changed, compiles nothing: it writes the block.
//!
//! The block's layout is computed here, once per compiled combination:
//! the run-time parameters in declaration order, each as many words as
//! its type has lanes in the program's color model (a color: the model's
//! lanes, converted from RGB as [`Program::rgb`] does, which is what
//! lowering folds a constant `rgb(...)` to; a [`Color`](crate::Color) of
//! the model, its lanes). In the `Hero` model, whose lanes' wavelengths
//! are drawn per camera sample, a color is RGB, upsampled by the code at
//! the hit's wavelengths as a run-time `rgb(...)` is. A specialised
//! instance given a value TSL has no text for (a spectral color's lanes)
//! folds the same words in as constants ([`Instance::constant_block`]).

use super::param_value::{ParamType, ParamValue};
use super::shader::{Instance, ParamInfo};
use super::{Error, Function, Material, MaterialFacts, Program};
use crate::check::check_material_expr;
use crate::color::ColorModel;
use crate::diag::{Diagnostic, Span};
use crate::ir::Scalar;
use crate::ir::lower::{InstanceBlock, lower_material_with_instance};
use std::sync::Arc;

/// The most compiled combinations a program keeps for binding (of all its
/// shaders together): past it, a new combination is compiled for its
/// bind alone and not kept, so a host that binds ever new `material`
/// values cannot grow the cache without bound. Each kept combination
/// holds one compiled function per interface method.
pub const MAX_BOUND_COMBINATIONS: usize = 1024;

/// A shader's code for one combination of code-changing values, shared
/// by every instance bound with that combination.
pub(super) struct InstanceCode {
    /// By [`Method`](crate::check::Method), each reading the block.
    methods: Vec<Function>,
    /// Each parameter's first word in the block, by parameter index;
    /// `None` for a parameter bound in the code.
    offsets: Vec<Option<u32>>,
    /// The block's length in words.
    words: usize,
    /// What the code reads and does, the same for every block.
    facts: MaterialFacts,
}

/// The block words of a parameter that can be read at run time; `None`
/// for one that changes the code (material, string) or that a host sets
/// in source only (array, matrix).
fn block_words(p: &ParamInfo, model: ColorModel) -> Option<Vec<Scalar>> {
    if p.array_len.is_some() {
        return None;
    }
    Some(match p.ty {
        ParamType::Float => vec![Scalar::F32],
        ParamType::Int => vec![Scalar::I32],
        ParamType::Bool => vec![Scalar::Bool],
        ParamType::Vector | ParamType::Point | ParamType::Normal => vec![Scalar::F32; 3],
        ParamType::Vec2 => vec![Scalar::F32; 2],
        // Hero: RGB, upsampled in the code at the hit's wavelengths.
        ParamType::Color if model == ColorModel::Hero => vec![Scalar::F32; 3],
        ParamType::Color => vec![Scalar::F32; model.lanes()],
        ParamType::Matrix | ParamType::BsdfSample | ParamType::String | ParamType::Material => return None,
    })
}

/// `value`'s block words (checked against the parameter's type when set;
/// a default is of that type).
fn encode(program: &Program, ty: ParamType, value: &ParamValue, out: &mut Vec<u32>) {
    let hero = program.color_model() == ColorModel::Hero;
    match value {
        ParamValue::Float(x) => out.push(x.to_bits()),
        ParamValue::Int(i) if ty == ParamType::Float => out.push((*i as f32).to_bits()),
        ParamValue::Int(i) => out.push(*i as u32),
        ParamValue::Bool(b) => out.push(u32::from(*b)),
        ParamValue::Triple(rgb) if ty == ParamType::Color && hero => out.extend(rgb.iter().map(|x| x.to_bits())),
        // Not reached: a Hero program takes RGB, and its color defaults
        // stay in the code (see `bind`); the words' count still holds.
        ParamValue::Color(c) if hero => out.extend(c.to_rgb().iter().map(|x| x.to_bits())),
        ParamValue::Triple([r, g, b]) if ty == ParamType::Color => {
            out.extend(program.rgb(*r, *g, *b).lanes().iter().map(|x| x.to_bits()));
        }
        ParamValue::Triple(t) => out.extend(t.iter().map(|x| x.to_bits())),
        ParamValue::Vec2(v) => out.extend(v.iter().map(|x| x.to_bits())),
        ParamValue::Color(c) => out.extend(c.lanes().iter().map(|x| x.to_bits())),
        ParamValue::Matrix(_) | ParamValue::String(_) | ParamValue::Material(_) => {}
    }
}

impl Instance {
    /// The instance as a material whose numeric, vector, color and bool
    /// parameters are read at run time from its own parameter block: the
    /// shader's code is compiled on the first bind of each combination of
    /// `material` and `string` values (cached by the program), so binding
    /// again after [`Instance::set`] compiles nothing
    /// ([`Program::compiled_functions`] is unchanged) and costs
    /// microseconds. The results equal [`Instance::specialise`]'s within
    /// float rounding. An error when a required parameter has no value.
    ///
    /// A program keeps at most [`MAX_BOUND_COMBINATIONS`] compiled
    /// combinations; past it a new one compiles on every bind.
    ///
    /// A parameter whose default is not one constant (it reads the
    /// shading point) and that has no value keeps its default in the code;
    /// setting it later compiles once more for that combination. So does
    /// a color's default in the `Hero` model, where the block holds a set
    /// color as RGB, upsampled at each hit's wavelengths.
    ///
    /// ```
    /// use tsl::{Compiler, ShadingGlobals};
    /// let program = Compiler::new().source("m.tsl", "material m = lambert;").compile()?;
    /// let mut metal = program.shader("rough_conductor")?.instance();
    /// let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ..Default::default() };
    /// let white = program.rgb(1.0, 1.0, 1.0);
    /// let wi = [0.6f32, 0.0, 0.8];
    /// let smooth = metal.set("alpha", 0.05)?.bind()?.reflection(&g, wi, &white, [0.0, 0.0, 1.0]);
    /// let compiled = program.compiled_functions();
    /// let rough = metal.set("alpha", 0.6)?.bind()?.reflection(&g, wi, &white, [0.0, 0.0, 1.0]);
    /// assert_eq!(program.compiled_functions(), compiled);
    /// assert_ne!(smooth.to_rgb(), rough.to_rgb());
    /// # Ok::<(), tsl::Error>(())
    /// ```
    pub fn bind(&self) -> Result<Material, Error> {
        self.check_required()?;
        let program = self.shader().program();
        let model = program.color_model();
        let params = self.shader().params();
        // Which parameters the block holds: those of a plain type with a
        // value to write (set, or a constant default). A Hero color's
        // default is evaluated at the default wavelengths, so it stays in
        // the code, which evaluates it at the hit's.
        let hero_color = |p: &ParamInfo| p.ty == ParamType::Color && model == ColorModel::Hero;
        let in_block: Vec<bool> = params
            .iter()
            .zip(self.values())
            .map(|(p, v)| block_words(p, model).is_some() && (v.is_some() || (p.default.is_some() && !hero_color(p))))
            .collect();
        // Code-changing values by name, and which parameters are in the
        // block: the cache key. A required run-time parameter is written
        // too (the call must have it), but its value is not read.
        let mut args = Vec::new();
        let mut code_args = Vec::new();
        for ((p, v), read) in params.iter().zip(self.values()).zip(&in_block) {
            let Some(v) = v else { continue };
            let arg = format!("{}: {}", p.name, v.call_text(p.ty));
            if !read {
                code_args.push(arg.clone());
            }
            if !read || p.required() {
                args.push(arg);
            }
        }
        let mask: String = in_block.iter().map(|r| if *r { '1' } else { '0' }).collect();
        let key = format!("{}({}) {mask}", self.shader().name(), code_args.join(", "));
        let cached = program.inner.instance_code.lock().unwrap_or_else(|e| e.into_inner()).get(&key).cloned();
        let code = match cached {
            Some(code) => code,
            None => {
                let source = format!("{}({})", self.shader().name(), args.join(", "));
                let code = Arc::new(self.compile_bound(&source, &in_block)?);
                // Two threads binding at once may both compile; either
                // code is right, and the first kept is used from then on.
                let mut cache = program.inner.instance_code.lock().unwrap_or_else(|e| e.into_inner());
                if cache.len() < MAX_BOUND_COMBINATIONS || cache.contains_key(&key) {
                    cache.entry(key).or_insert(code).clone()
                } else {
                    code
                }
            }
        };
        let mut block = Vec::with_capacity(code.words);
        for ((p, v), offset) in params.iter().zip(self.values()).zip(&code.offsets) {
            if offset.is_none() {
                continue;
            }
            if let Some(value) = v.as_ref().or(p.default.as_ref()) {
                encode(program, p.ty, value, &mut block);
            }
        }
        if block.len() != code.words {
            return Err(Error::plain(format!(
                "internal error: `{}`'s parameter block has {} words, not {}",
                self.shader().name(),
                block.len(),
                code.words
            )));
        }
        let block: Arc<[u32]> = block.into();
        let mut methods = Vec::with_capacity(code.methods.len());
        for f in &code.methods {
            methods.push(Some(f.with_instance(block.clone()).map_err(Error::plain)?));
        }
        let facts = code.facts.clone();
        Ok(Material::with_facts(program.clone(), method_code(self.shader().name(), methods), facts))
    }

    /// Compiles `source` (the instance's call with its code-changing
    /// values) with the parameters `in_block` says read from the block.
    fn compile_bound(&self, source: &str, in_block: &[bool]) -> Result<InstanceCode, Error> {
        let program = self.shader().program();
        let model = program.color_model();
        let (offsets, words) = self.layout(in_block);
        let name = format!("<bound instance of {}>", self.shader().name());
        let checked = check_material_expr(program.checked(), &name, source);
        let to_error =
            |diagnostics: Vec<Diagnostic>| Error { diagnostics, sources: checked.program.loaded.sources.clone() };
        let Some(expr) = checked.ok() else {
            return Err(to_error(checked.diagnostics.clone()));
        };
        let entry = format!("@{}", self.shader().name());
        let block = InstanceBlock { root: expr.span, offsets: offsets.clone(), words: words.clone(), constants: None };
        let (ir, entries, diags) = lower_material_with_instance(&checked.program, model, &entry, expr, block);
        if !diags.is_empty() {
            return Err(to_error(diags));
        }
        let part = program.jit_part(ir, entries)?;
        let methods = super::interface_functions(&part, &entry)?;
        // Facts come from the IR alone: found once, for every block.
        let unbound = Material::new(
            program.clone(),
            method_code(self.shader().name(), methods.iter().cloned().map(Some).collect()),
        );
        let facts = unbound.facts().clone();
        Ok(InstanceCode { methods, offsets, words: words.len(), facts })
    }

    /// The block layout of the parameters `in_block` marks: each one's
    /// first word (by parameter index) and the words' types.
    fn layout(&self, in_block: &[bool]) -> (Vec<Option<u32>>, Vec<Scalar>) {
        let model = self.shader().program().color_model();
        let mut offsets = Vec::new();
        let mut words = Vec::new();
        for (p, read) in self.shader().params().iter().zip(in_block) {
            match block_words(p, model).filter(|_| *read) {
                Some(w) => {
                    offsets.push(Some(words.len() as u32));
                    words.extend(w);
                }
                None => offsets.push(None),
            }
        }
        (offsets, words)
    }

    /// The parameters `which` marks (each with a value set) as a block of
    /// constants for the instance's call at `root`: their words as
    /// [`Instance::bind`] writes them, folded into the code instead of
    /// read. An error if a value's words do not fill its place.
    pub(super) fn constant_block(&self, root: Span, which: &[bool]) -> Result<InstanceBlock, Error> {
        let program = self.shader().program();
        let (offsets, words) = self.layout(which);
        let mut constants = Vec::with_capacity(words.len());
        for ((p, v), offset) in self.shader().params().iter().zip(self.values()).zip(&offsets) {
            if let (Some(_), Some(value)) = (offset, v) {
                encode(program, p.ty, value, &mut constants);
            }
        }
        if constants.len() != words.len() {
            return Err(Error::plain(format!(
                "internal error: `{}`'s folded values have {} words, not {}",
                self.shader().name(),
                constants.len(),
                words.len()
            )));
        }
        Ok(InstanceBlock { root, offsets, words, constants: Some(constants) })
    }
}

/// The material code of a bound instance's methods (by [`Method`](crate::check::Method)).
fn method_code(shader: &str, methods: Vec<Option<Function>>) -> super::material::Code {
    super::material::Code::methods_only(format!("@{shader}"), methods)
}
