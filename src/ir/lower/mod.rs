//! Lowering a checked program to scalar IR, for one color model.
//!
//! Each entry point is built by inlining: user functions, material methods
//! and whole texture trees become one straight [`Function`]. Along the way
//! constants fold (a material instance such as `phong(kd: rgb(1, 0, 0))`
//! compiles with `kd` as a constant, OSL's runtime specialisation), and a
//! generator called again with the same arguments in the same coordinate
//! context reuses the first result (the second paper's caching).

/// Marks a state the checker rules out: lowering runs only on programs
/// that checked without errors (`Compiler::compile` stops before it
/// otherwise), so reaching one is a compiler bug. Debug builds, and so
/// every test, stop here with the message; release builds go on with the
/// caller's fallback (zeros, no value), so no input can make the library
/// panic. A fallback that a valid program can reach is not marked: it is
/// either lowered properly or documented where it is.
macro_rules! ruled_out {
    ($($what:tt)+) => {
        debug_assert!(false, "lowering reached a state the checker rules out: {}", format_args!($($what)+))
    };
}

mod arithmetic;
mod builtins;
mod constants;
mod context;
mod expr;
mod hit;
mod layer;
mod layout;
mod material;
mod noise;
mod sampling;
mod spectral;
mod stmt;
mod texture;
mod tree;

use builtins::{blend_weights, identity};
use expr::{bind_args, bind_builtin_args, mat_inverse, transform_point};
use stmt::assigned_names;
use tree::empty_def;

pub use hit::{HitEntry, HitGroup, HitMethod, hit_inputs, lower_hit_groups, lower_hit_groups_with};
pub use layout::{DeltaLobesLayout, EvalPdfLayout, SampleLayout};
pub use spectral::curve_table_name;

use super::builder::{Builder, Const, MemoKey};
use super::*;
use crate::check::{
    BuiltinFn, INTERFACE, InterfaceMethod, Method, NormalMapConvention, Program, Symbol, SymbolKind, TextureCall,
    TreeNode, Ty, interface_method,
};
use crate::color::{self, ColorModel};
use crate::diag::{Diagnostic, Span};
use crate::globals;
use crate::syntax::ast::{self, AssignOp, BinaryOp, Expr, ExprKind, Item, Stmt, StmtKind, UnaryOp};
use crate::texture::{Sampler, SpectralLanes};
// Lowering hashes small keys (values, ops) millions of times: FxHash.
use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};
use std::rc::Rc;
use std::sync::Arc;

/// What an entry point computes.
#[derive(Debug, Clone, PartialEq)]
pub enum EntryKind {
    /// A generator (a user or prelude function).
    Function,
    /// One interface method of a named material, or a combination of them
    /// (`reflection` for reflection sums, `delta_lobes`).
    Method(&'static str),
    /// A method of a hit group, reading the record its `prepare` wrote.
    Hit(HitMethod),
}

/// An entry point's name and its argument and result types, so hosts can
/// pack arguments and unpack results.
#[derive(Debug, Clone)]
pub struct Entry {
    /// `rings`, or `wood.reflection`.
    pub name: String,
    pub kind: EntryKind,
    pub params: Vec<(String, Ty)>,
    pub ret: Ty,
}

/// Lowers the entry points of the global names `keep` accepts: each
/// function whose parameters and result are plain values, and each
/// interface method of each material that needs no arguments.
pub fn lower_entries(
    program: &Program,
    model: ColorModel,
    keep: impl Fn(&str, &Symbol) -> bool,
) -> (Module, Vec<Entry>, Vec<Diagnostic>) {
    let mut lw = Lowerer::new(program, model);
    let mut module = Module::default();
    let mut entries = Vec::new();
    let mut names: Vec<(&String, &Symbol)> = program.symbols.iter().collect();
    names.sort_by_key(|(n, s)| (s.module, s.item, n.as_str()));
    names.retain(|(n, s)| keep(n, s));
    for (name, sym) in names {
        match (sym.kind, lw.item(*sym)) {
            (SymbolKind::Function, Item::Function(f)) => {
                let params: Vec<(String, Ty)> =
                    f.params.iter().map(|p| (p.name.name.to_string(), Ty::from_ast(&p.ty))).collect();
                let ret = Ty::from_ast(&f.ret);
                if ret == Ty::Void || !params.iter().chain([&(String::new(), ret.clone())]).all(|(_, t)| lw.is_plain(t))
                {
                    continue;
                }
                module.functions.push(lw.lower_function_entry(name, *sym, f, &params, &ret));
                entries.push(Entry { name: name.clone(), kind: EntryKind::Function, params, ret });
            }
            (SymbolKind::Material, Item::Material(d)) if d.params.iter().all(|p| p.default.is_some()) => {
                lw.material_entries(name, *sym, &mut module, &mut entries);
            }
            (SymbolKind::MaterialTree, Item::MaterialTree(t)) if t.params.is_none() => {
                lw.material_entries(name, *sym, &mut module, &mut entries);
            }
            _ => {}
        }
    }
    verify::debug_verify_module(&module, "lowering");
    (module, entries, lw.diags)
}

/// Lowers one expression of the root program that reads no shading global
/// (a scene property's value) to a function without parameters whose
/// results are the value's words, converted to `to`.
///
/// With `absolute_spectra` (a scene light's or emitter's value, as Mitsuba
/// reads them), `spectrum(...)` curves are spectral power, divided by the
/// model's D65 white to become lanes; RGB stays D65-based either way.
pub fn lower_value(
    program: &Program,
    model: ColorModel,
    name: &str,
    expr: &Expr,
    to: &Ty,
    absolute_spectra: bool,
) -> (Function, Vec<Diagnostic>) {
    ValueLowerer::new(program, model).lower(name, expr, to, absolute_spectra)
}

/// Lowers values one after another ([`lower_value`]), keeping what they
/// share: the constants already folded. A scene of a thousand objects
/// whose radius is the last of a long chain of constants evaluates the
/// chain once, not once per object.
pub struct ValueLowerer<'p> {
    program: &'p Program,
    model: ColorModel,
    folded: HashMap<MatId, constants::Folded>,
}

impl<'p> ValueLowerer<'p> {
    pub fn new(program: &'p Program, model: ColorModel) -> Self {
        ValueLowerer { program, model, folded: HashMap::default() }
    }

    /// [`lower_value`], with the constants of the values lowered before.
    pub fn lower(&mut self, name: &str, expr: &Expr, to: &Ty, absolute_spectra: bool) -> (Function, Vec<Diagnostic>) {
        let mut lw = Lowerer::new(self.program, self.model);
        lw.absolute_spectra = absolute_spectra;
        lw.evaluate_constants = true;
        std::mem::swap(&mut lw.folded_consts, &mut self.folded);
        let mut b = Builder::new(name);
        let ctx = lw.root_ctx();
        let mut fr = lw.new_frame(false, HashSet::default());
        let v = lw.expr_as(&mut b, &mut fr, &ctx, expr, to);
        let lanes = lw.lanes(&mut b, v, to);
        lw.write_results(&mut b, to, &lanes);
        let f = lw.finish_entry(b, expr.span, "this value");
        std::mem::swap(&mut lw.folded_consts, &mut self.folded);
        (f, lw.diags)
    }
}

/// Lowers material expressions of the root program (a scene object's
/// `material` value) to entry points `NAME.method`, one per interface
/// method, as [`lower_entries`] does for named materials.
pub fn lower_material_exprs(
    program: &Program,
    model: ColorModel,
    materials: &[(String, &Expr)],
) -> (Module, Vec<Entry>, Vec<Diagnostic>) {
    lower_material_methods(program, model, materials, |_, _| true)
}

/// [`lower_material_exprs`] for the methods `keep(k, method)` accepts of
/// material `k`: a renderer leaves out those a hit group serves.
pub fn lower_material_methods(
    program: &Program,
    model: ColorModel,
    materials: &[(String, &Expr)],
    keep: impl Fn(usize, Method) -> bool,
) -> (Module, Vec<Entry>, Vec<Diagnostic>) {
    lower_methods_with(Lowerer::new(program, model), materials, keep)
}

/// Which value parameters of a material call read the instance parameter
/// block at run time ([`Op::InstanceWord`]) instead of the call's
/// arguments: a run-time-bound instance, compiled once for all its values.
#[derive(Debug, Clone)]
pub struct InstanceBlock {
    /// The span of the material call so bound (the instance's own call;
    /// calls inside it keep their arguments).
    pub root: Span,
    /// Each parameter's first word in the block, by parameter index;
    /// `None` for a parameter bound in the code (a material, a string).
    pub offsets: Vec<Option<u32>>,
    /// The block's word types, which every function lowered reads by
    /// (its `instance_words`).
    pub words: Vec<Scalar>,
    /// The block's words when they are known now: lowered as constants,
    /// which fold as a literal's lanes do, and the functions read no
    /// block. A specialised instance given a value TSL has no text for (a
    /// spectral color's lanes) is compiled so.
    pub constants: Option<Vec<u32>>,
}

/// [`lower_material_exprs`] of one material call whose value parameters
/// `block` names read the instance parameter block, laid out as the host
/// says.
pub fn lower_material_with_instance(
    program: &Program,
    model: ColorModel,
    entry: &str,
    expr: &Expr,
    block: InstanceBlock,
) -> (Module, Vec<Entry>, Vec<Diagnostic>) {
    let mut lw = Lowerer::new(program, model);
    lw.instance_block = Some(block);
    lower_methods_with(lw, &[(entry.to_string(), expr)], |_, _| true)
}

fn lower_methods_with<'p>(
    mut lw: Lowerer<'p>,
    materials: &[(String, &'p Expr)],
    keep: impl Fn(usize, Method) -> bool,
) -> (Module, Vec<Entry>, Vec<Diagnostic>) {
    let mut module = Module::default();
    let mut entries = Vec::new();
    for (k, (name, expr)) in materials.iter().enumerate() {
        for im in Method::ALL.into_iter().filter(|m| keep(k, *m)).map(Method::interface) {
            let fname = format!("{name}.{}", im.name);
            let mut b = Builder::new(&fname);
            if let Some(block) = lw.instance_block.as_ref().filter(|block| block.constants.is_none()) {
                b.func.instance_words = block.words.clone();
            }
            let params: Vec<(String, Ty)> = im.params.iter().map(|(n, t)| (n.to_string(), t.clone())).collect();
            let args = lw.method_args(&mut b, &params);
            let ctx = lw.root_ctx();
            let mat = Mat::of_root(expr);
            let result = lw.mat_method(&mut b, &mat, im, &args, &ctx);
            lw.write_results(&mut b, &im.ret, &result);
            module.functions.push(lw.finish_entry(b, expr.span, "this material"));
            entries.push(Entry { name: fname, kind: EntryKind::Method(im.name), params, ret: im.ret.clone() });
        }
    }
    verify::debug_verify_module(&module, "lowering");
    (module, entries, lw.diags)
}

/// Lowers, for each material expression, one entry point `NAME.reflection_sum{lights}`
/// that returns the sum of `reflection` over `lights` lights:
/// parameters `wi_1, light_1, ..., wi_K, light_K, wo`. The K copies of the
/// method share one function and one coordinate context, so the texture
/// they all read (generator calls, normals) is computed once: a renderer
/// calls this once per hit instead of `reflection` once per light.
pub fn lower_reflection_sums(
    program: &Program,
    model: ColorModel,
    materials: &[(String, &Expr)],
    lights: usize,
) -> (Module, Vec<Entry>, Vec<Diagnostic>) {
    let mut lw = Lowerer::new(program, model);
    let mut module = Module::default();
    let mut entries = Vec::new();
    for (name, expr) in materials {
        let fname = format!("{name}.reflection_sum{lights}");
        let mut b = Builder::new(&fname);
        let mut params: Vec<(String, Ty)> = Vec::new();
        for k in 0..lights {
            params.push((format!("wi{k}"), Ty::Vector));
            params.push((format!("light{k}"), Ty::Color));
        }
        params.push(("wo".into(), Ty::Vector));
        let args = lw.method_args(&mut b, &params);
        let ctx = lw.root_ctx();
        let mat = Mat::of_root(expr);
        let wo = args[2 * lights].clone();
        let sum = lw.reflection_sum(&mut b, &mat, &args[..2 * lights], &wo, &ctx);
        lw.write_results(&mut b, &Ty::Color, &sum);
        module.functions.push(lw.finish_entry(b, expr.span, "this material"));
        entries.push(Entry { name: fname, kind: EntryKind::Method("reflection"), params, ret: Ty::Color });
    }
    verify::debug_verify_module(&module, "lowering");
    (module, entries, lw.diags)
}

/// Lowers, for each material expression, one entry point `NAME.delta_lobes`
/// with parameters `wo, eta` that returns both perfect directions with their
/// weights, the responses to unit light: `reflection_dir(wo)`,
/// `reflection(that, 1, wo)`, `refraction_dir(wo, eta)` and
/// `refraction(that, 1, eta, wo)`, in that order (3 + lanes + 3 + lanes
/// words). One call instead of four, and what the methods share (the
/// faced normal, Fresnel terms, the texture) is computed once.
pub fn lower_delta_lobes(
    program: &Program,
    model: ColorModel,
    materials: &[(String, &Expr)],
) -> (Module, Vec<Entry>, Vec<Diagnostic>) {
    let mut lw = Lowerer::new(program, model);
    let mut module = Module::default();
    let mut entries = Vec::new();
    for (name, expr) in materials {
        let fname = format!("{name}.delta_lobes");
        let mut b = Builder::new(&fname);
        let params: Vec<(String, Ty)> = vec![("wo".into(), Ty::Vector), ("eta".into(), Ty::Color)];
        let args = lw.method_args(&mut b, &params);
        let (wo, eta) = (args[0].clone(), args[1].clone());
        let ctx = lw.root_ctx();
        let mat = Mat::of_root(expr);
        let lobes = lw.delta_lobes(&mut b, &mat, &wo, &eta, &ctx);
        let (function, ret) = finish_words(&mut lw, b, &lobes, expr.span);
        module.functions.push(function);
        entries.push(Entry { name: fname, kind: EntryKind::Method("delta_lobes"), params, ret });
    }
    verify::debug_verify_module(&module, "lowering");
    (module, entries, lw.diags)
}

/// Lowers, for each material expression, one entry point `NAME.eval_pdf`
/// with parameters `wi, wo, eta` that returns what next-event estimation
/// needs of a light sample: `f · cos` for unit light from `wi` (reflection
/// on the side of the geometric normal, refraction across it) and the
/// material's `pdf(wi, wo, eta)`, in that order (lanes + 1 words). One call
/// instead of two, sharing the texture (Mitsuba's `eval_pdf`).
pub fn lower_eval_pdf(
    program: &Program,
    model: ColorModel,
    materials: &[(String, &Expr)],
) -> (Module, Vec<Entry>, Vec<Diagnostic>) {
    let mut lw = Lowerer::new(program, model);
    let mut module = Module::default();
    let mut entries = Vec::new();
    for (name, expr) in materials {
        let fname = format!("{name}.eval_pdf");
        let mut b = Builder::new(&fname);
        let params: Vec<(String, Ty)> =
            vec![("wi".into(), Ty::Vector), ("wo".into(), Ty::Vector), ("eta".into(), Ty::Color)];
        let args = lw.method_args(&mut b, &params);
        let ctx = lw.root_ctx();
        let mat = Mat::of_root(expr);
        let results = lw.eval_pdf(&mut b, &mat, &args[0], &args[1], &args[2], &ctx);
        let (function, ret) = finish_words(&mut lw, b, &results, expr.span);
        module.functions.push(function);
        entries.push(Entry { name: fname, kind: EntryKind::Method("eval_pdf"), params, ret });
    }
    verify::debug_verify_module(&module, "lowering");
    (module, entries, lw.diags)
}

impl<'p> Lowerer<'p> {
    /// `reflection` summed over lights: `pairs` is `wi_1, light_1, ...`.
    fn reflection_sum(
        &mut self,
        b: &mut Builder,
        mat: &Mat<'p>,
        pairs: &[Vec<Value>],
        wo: &[Value],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let reflection = Method::Reflection.interface();
        let mut sum: Option<Vec<Value>> = None;
        for pair in pairs.chunks(2) {
            let one = self.mat_method(b, mat, reflection, &[pair[0].clone(), pair[1].clone(), wo.to_vec()], ctx);
            sum = Some(match sum {
                None => one,
                Some(acc) => b.map2(BinOp::FAdd, &acc, &one),
            });
        }
        sum.unwrap_or_else(|| b.zeros(self.lanes))
    }

    /// Both perfect directions and their responses to unit light, as
    /// [`lower_delta_lobes`] returns them.
    fn delta_lobes(&mut self, b: &mut Builder, mat: &Mat<'p>, wo: &[Value], eta: &[Value], ctx: &Ctx) -> Vec<Value> {
        let one = b.f(1.0);
        let ones = vec![one; self.lanes];
        let (wo, eta) = (wo.to_vec(), eta.to_vec());
        let dr = self.mat_method(b, mat, Method::ReflectionDir.interface(), std::slice::from_ref(&wo), ctx);
        let wr = self.mat_method(b, mat, Method::Reflection.interface(), &[dr.clone(), ones.clone(), wo.clone()], ctx);
        let dt = self.mat_method(b, mat, Method::RefractionDir.interface(), &[wo.clone(), eta.clone()], ctx);
        let wt = self.mat_method(b, mat, Method::Refraction.interface(), &[dt.clone(), ones, eta, wo], ctx);
        DeltaLobesLayout { lanes: self.lanes }.assemble(&dr, &wr, &dt, &wt)
    }

    /// `f · cos` for unit light from `wi` and the pdf, as [`lower_eval_pdf`]
    /// returns them.
    fn eval_pdf(
        &mut self,
        b: &mut Builder,
        mat: &Mat<'p>,
        wi: &[Value],
        wo: &[Value],
        eta: &[Value],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let value = self.eval_at(b, mat, wi, wo, eta, ctx);
        let args = [wi.to_vec(), wo.to_vec(), eta.to_vec()];
        let pdf = self.mat_method(b, mat, Method::Pdf.interface(), &args, ctx);
        EvalPdfLayout { lanes: self.lanes }.assemble(&value, pdf[0])
    }
}

/// Finishes an entry for the material at `at` that returns `results` as
/// float words (a combination of methods), with the array type hosts read
/// them as.
fn finish_words(lw: &mut Lowerer, mut b: Builder, results: &[Value], at: Span) -> (Function, Ty) {
    b.func.results = vec![Scalar::F32; results.len()];
    for (k, x) in results.iter().enumerate() {
        b.push(Inst::Output(k as u32, *x));
    }
    (lw.finish_entry(b, at, "this material"), Ty::Array(Box::new(Ty::Float), results.len() as u32))
}

struct Lowerer<'p> {
    program: &'p Program,
    model: ColorModel,
    lanes: usize,
    diags: Vec<Diagnostic>,
    next_id: u32,
    /// One sampler per image, filter and address modes.
    samplers: HashMap<(TextureCall, bool), Arc<Sampler>>,
    /// Set while a mixture samples one of its children: the outermost
    /// mixture computes the weight at the direction drawn, so nested ones
    /// only choose (see `sampling::sample_mixture`).
    direction_only: bool,
    /// `spectrum(...)` curves are absolute spectral power (a scene light's
    /// value), not D65-relative: [`color::emission_resample_weights`].
    absolute_spectra: bool,
    /// The checker's types of expressions already lowered: inlined
    /// functions ask for the same expressions' types many times, and a
    /// hash probe is cheaper than the checker's bisection.
    types: std::cell::RefCell<HashMap<Span, &'p Ty>>,
    /// The checker's types of the constant being lowered, set while it is:
    /// its expressions are lowered once, so neither the bisection of the
    /// whole program nor a cache entry pays (see `constants`).
    constant_types: Option<crate::check::ExprTypesWithin<'p>>,
    /// Whether scalar arithmetic constants are computed without IR (the
    /// scene description's values; see `arithmetic`).
    evaluate_constants: bool,
    /// The constants whose values folded to literal words, for every
    /// function this lowerer builds (see `constants`).
    folded_consts: HashMap<(usize, usize), constants::Folded>,
    /// Whether a named material uses a method's interface default
    /// throughout its tree, by (module, item) and method (see
    /// `uses_default`).
    default_methods: std::cell::RefCell<HashMap<(MatId, &'static str), bool>>,
    /// Set once an entry point was too large (see `finish_entry`): the
    /// lowering has failed, and the entries after it are not inlined.
    gave_up: bool,
    /// Set when lowering a run-time-bound instance (see
    /// [`lower_material_with_instance`]).
    instance_block: Option<InstanceBlock>,
}

// ---------------------------------------------------------------- values

/// A lowered TSL value.
#[derive(Debug, Clone)]
enum Val<'p> {
    /// Scalars: 1 for float/int/bool, 2 for vec2, 3 for triples, the color
    /// model's lanes for colors, 12 for matrices (three rows of an affine map).
    Lanes(Vec<Value>),
    /// An array: either known element values or IR arrays (one per lane).
    Array(ArrayVal),
    /// A string: only literals exist, used by nodes and options at
    /// compile time.
    Str(Rc<str>),
    Material(Mat<'p>),
    /// The materials of a `material[N]` template parameter.
    Materials(Vec<Mat<'p>>),
    Unit,
}

#[derive(Debug, Clone)]
enum ArrayVal {
    Elems(Vec<Vec<Value>>),
    Ir { arrays: Vec<ArrayId>, len: u32 },
}

/// A named material (a definition, or a tree without parameters): its
/// (module, item).
type MatId = (usize, usize);

/// A material expression with the template bindings it sees.
#[derive(Debug, Clone)]
struct Mat<'p> {
    expr: &'p Expr,
    env: Rc<HashMap<String, Val<'p>>>,
    /// The item whose code the expression is in (prelude or user).
    in_prelude: bool,
}

impl<'p> Mat<'p> {
    /// A material expression of the root program (a scene object's
    /// material): user code, no template bindings.
    fn of_root(expr: &'p Expr) -> Mat<'p> {
        Mat { expr, env: Rc::new(HashMap::default()), in_prelude: false }
    }
}

/// A material instance: a definition with its parameters bound.
#[derive(Debug)]
struct Instance<'p> {
    id: u32,
    def: &'p ast::MaterialDef,
    params: Vec<(String, Val<'p>)>,
    in_prelude: bool,
}

/// The coordinate context: globals replaced by `transform` and `bump`.
#[derive(Debug, Clone)]
struct Ctx {
    id: u32,
    overrides: Rc<HashMap<&'static str, Vec<Value>>>,
}

#[derive(Debug, Clone)]
enum Binding<'p> {
    Val(Val<'p>),
    Vars(Vec<Var>),
}

/// One inlined body: its scopes, where `return` goes, enclosing loops.
struct Frame<'p> {
    scopes: Vec<HashMap<String, Binding<'p>>>,
    ret: Option<(Label, Vec<Var>, Ty)>,
    loops: Vec<Label>,
    material: Option<Rc<Instance<'p>>>,
    assigned: HashSet<String>,
    in_prelude: bool,
}
