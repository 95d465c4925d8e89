//! Lowering a checked program to scalar IR, for one color model.
//!
//! Each entry point is built by inlining: user functions, material methods
//! and whole texture trees become one straight [`Function`]. Along the way
//! constants fold (a material instance such as `phong(kd: rgb(1, 0, 0))`
//! compiles with `kd` as a constant, OSL's runtime specialisation), and a
//! generator called again with the same arguments in the same coordinate
//! context reuses the first result (the second paper's caching).

mod noise;
mod sampling;

use super::*;
use crate::check::{INTERFACE, InterfaceMethod, Program, Symbol, SymbolKind, TextureCall, Ty, interface_method};
use crate::color::{self, ColorModel};
use crate::diag::{Diagnostic, Span};
use crate::globals;
use crate::syntax::ast::{self, AssignOp, BinaryOp, Expr, ExprKind, Item, Stmt, StmtKind, UnaryOp};
use crate::texture::Sampler;
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

/// Lowers every entry point of a checked program: each function whose
/// parameters and result are plain values, and each interface method of
/// each material that needs no arguments.
pub fn lower_program(program: &Program, model: ColorModel) -> (Module, Vec<Entry>, Vec<Diagnostic>) {
    lower_entries(program, model, |_, _| true)
}

/// Lowers the entry points of the global names `keep` accepts.
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
                    f.params.iter().map(|p| (p.name.name.clone(), Ty::from_ast(&p.ty))).collect();
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
    (module, entries, lw.diags)
}

/// Lowers one expression of the root program that reads no shading global
/// (a scene property's value) to a function without parameters whose
/// results are the value's words, converted to `to`.
pub fn lower_value(
    program: &Program,
    model: ColorModel,
    name: &str,
    expr: &Expr,
    to: &Ty,
) -> (Function, Vec<Diagnostic>) {
    let mut lw = Lowerer::new(program, model);
    let mut b = Builder::new(name);
    let ctx = lw.root_ctx();
    let mut fr = lw.new_frame(false, HashSet::default());
    let v = lw.expr_as(&mut b, &mut fr, &ctx, expr, to);
    let lanes = lw.lanes(&mut b, v, to);
    lw.write_results(&mut b, to, &lanes);
    (b.finish(), lw.diags)
}

/// Lowers material expressions of the root program (a scene object's
/// `material` value) to entry points `NAME.method`, one per interface
/// method, as [`lower_entries`] does for named materials.
pub fn lower_material_exprs(
    program: &Program,
    model: ColorModel,
    materials: &[(String, &Expr)],
) -> (Module, Vec<Entry>, Vec<Diagnostic>) {
    let mut lw = Lowerer::new(program, model);
    let mut module = Module::default();
    let mut entries = Vec::new();
    for (name, expr) in materials {
        for im in INTERFACE {
            let fname = format!("{name}.{}", im.name);
            let mut b = Builder::new(&fname);
            let params: Vec<(String, Ty)> = im.params.iter().map(|(n, t)| (n.to_string(), t.clone())).collect();
            let args = lw.method_args(&mut b, &params);
            let ctx = lw.root_ctx();
            let mat = Mat::of_root(expr);
            let result = lw.mat_method(&mut b, &mat, im, &args, &ctx);
            lw.write_results(&mut b, &im.ret, &result);
            module.functions.push(b.finish());
            entries.push(Entry { name: fname, kind: EntryKind::Method(im.name), params, ret: im.ret.clone() });
        }
    }
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
    let Some(im) = interface_method("reflection") else { return (module, entries, lw.diags) };
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
        let mut sum: Option<Vec<Value>> = None;
        for k in 0..lights {
            let one =
                lw.mat_method(&mut b, &mat, im, &[args[2 * k].clone(), args[2 * k + 1].clone(), wo.clone()], &ctx);
            sum = Some(match sum {
                None => one,
                Some(acc) => b.map2(BinOp::FAdd, &acc, &one),
            });
        }
        let sum = sum.unwrap_or_else(|| b.zeros(lw.lanes));
        lw.write_results(&mut b, &Ty::Color, &sum);
        module.functions.push(b.finish());
        entries.push(Entry { name: fname, kind: EntryKind::Method("reflection"), params, ret: Ty::Color });
    }
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
    let methods = ["reflection_dir", "reflection", "refraction_dir", "refraction"].map(interface_method);
    let [Some(reflection_dir), Some(reflection), Some(refraction_dir), Some(refraction)] = methods else {
        return (module, entries, lw.diags);
    };
    for (name, expr) in materials {
        let fname = format!("{name}.delta_lobes");
        let mut b = Builder::new(&fname);
        let params: Vec<(String, Ty)> = vec![("wo".into(), Ty::Vector), ("eta".into(), Ty::Color)];
        let args = lw.method_args(&mut b, &params);
        let (wo, eta) = (args[0].clone(), args[1].clone());
        let ctx = lw.root_ctx();
        let mat = Mat::of_root(expr);
        let one = b.f(1.0);
        let ones = vec![one; lw.lanes];
        let dr = lw.mat_method(&mut b, &mat, reflection_dir, std::slice::from_ref(&wo), &ctx);
        let wr = lw.mat_method(&mut b, &mat, reflection, &[dr.clone(), ones.clone(), wo.clone()], &ctx);
        let dt = lw.mat_method(&mut b, &mat, refraction_dir, &[wo.clone(), eta.clone()], &ctx);
        let wt = lw.mat_method(&mut b, &mat, refraction, &[dt.clone(), ones, eta, wo], &ctx);
        let (function, ret) = finish_words(b, &[dr, wr, dt, wt].concat());
        module.functions.push(function);
        entries.push(Entry { name: fname, kind: EntryKind::Method("delta_lobes"), params, ret });
    }
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
    let Some(pdf) = interface_method("pdf") else { return (module, entries, lw.diags) };
    for (name, expr) in materials {
        let fname = format!("{name}.eval_pdf");
        let mut b = Builder::new(&fname);
        let params: Vec<(String, Ty)> =
            vec![("wi".into(), Ty::Vector), ("wo".into(), Ty::Vector), ("eta".into(), Ty::Color)];
        let args = lw.method_args(&mut b, &params);
        let ctx = lw.root_ctx();
        let mat = Mat::of_root(expr);
        let mut results = lw.eval_at(&mut b, &mat, &args[0], &args[1], &args[2], &ctx);
        results.extend(lw.mat_method(&mut b, &mat, pdf, &args, &ctx));
        let (function, ret) = finish_words(b, &results);
        module.functions.push(function);
        entries.push(Entry { name: fname, kind: EntryKind::Method("eval_pdf"), params, ret });
    }
    (module, entries, lw.diags)
}

/// Finishes an entry that returns `results` as float words (a combination
/// of methods), with the array type hosts read them as.
fn finish_words(mut b: Builder, results: &[Value]) -> (Function, Ty) {
    b.func.results = vec![Scalar::F32; results.len()];
    for (k, x) in results.iter().enumerate() {
        b.push(Inst::Output(k as u32, *x));
    }
    (b.finish(), Ty::Array(Box::new(Ty::Float), results.len() as u32))
}

struct Lowerer<'p> {
    program: &'p Program,
    model: ColorModel,
    lanes: usize,
    diags: Vec<Diagnostic>,
    next_id: u32,
    /// One sampler per image, filter and address modes.
    samplers: HashMap<TextureCall, Arc<Sampler>>,
    /// Set while a mixture samples one of its children: the outermost
    /// mixture computes the weight at the direction drawn, so nested ones
    /// only choose (see `sampling::sample_mixture`).
    direction_only: bool,
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
    Unit,
}

#[derive(Debug, Clone)]
enum ArrayVal {
    Elems(Vec<Vec<Value>>),
    Ir { arrays: Vec<ArrayId>, len: u32 },
}

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

/// Builds one IR function: instruction lists, constant folding and scoped
/// value numbering.
struct Builder {
    func: Function,
    /// Global loads, hoisted so they dominate every use.
    prologue: Vec<Inst>,
    stack: Vec<Vec<Inst>>,
    consts: HashMap<Value, Const>,
    memo: Vec<HashMap<MemoKey, Vec<Value>>>,
    globals: HashMap<u32, Value>,
    /// Values defined in the prologue (constants, global loads): they
    /// dominate everything.
    in_prologue: HashSet<Value>,
    /// How many more noise sites are expanded inline; later ones call the
    /// native (see [`NOISE_INLINE_SITES`]).
    noise_budget: u32,
}

/// Noise sites per function expanded into IR (about 150 operations each
/// for 3D noise); beyond them a function calls the native, which computes
/// the same noise in f64 (within 1e-6). Inline noise is several times
/// faster in a loop such as fBm, but every copy costs compile time.
const NOISE_INLINE_SITES: u32 = 4;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Const {
    F(f32),
    I(i32),
    B(bool),
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
enum MemoKey {
    Op(OpKey),
    Const(ConstKey),
    Call {
        item: (usize, usize),
        ctx: u32,
        args: Vec<Value>,
    },
    Method {
        instance: u32,
        method: &'static str,
        ctx: u32,
        args: Vec<Value>,
    },
    /// Inlined noise at these coordinates.
    Noise(Vec<Value>),
    /// A texture lookup: the sampler's address and the coordinates.
    Texture {
        sampler: usize,
        coords: [Value; 6],
    },
}

/// An operation as a value-numbering key: floats compare by bits, so
/// `0.0` and `-0.0` (or two NaNs) are never confused.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
enum OpKey {
    Param(u32),
    Global(u32),
    Unary(UnOp, Value),
    Binary(BinOp, Value, Value),
    Select(Value, Value, Value),
    Call(&'static str, Vec<Value>),
    Table(usize, Value),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum ConstKey {
    F(u32),
    I(i32),
    B(bool),
}

impl OpKey {
    /// The key of a pure operation; `None` for reads of mutable state and
    /// for constants (keyed separately).
    fn of(op: &Op) -> Option<OpKey> {
        Some(match op {
            Op::Param(k) => OpKey::Param(*k),
            Op::Global(k) => OpKey::Global(*k),
            Op::Unary(u, a) => OpKey::Unary(*u, *a),
            Op::Binary(b, x, y) => OpKey::Binary(*b, *x, *y),
            Op::Select { cond, then_value, else_value } => OpKey::Select(*cond, *then_value, *else_value),
            Op::Call { native, args } => OpKey::Call(native, args.clone()),
            Op::Table { table, index } => OpKey::Table(table.as_ptr() as usize, *index),
            Op::F32(_) | Op::I32(_) | Op::Bool(_) | Op::Get(_) | Op::Load { .. } => return None,
        })
    }
}

impl Builder {
    fn new(name: &str) -> Builder {
        Builder {
            func: Function { name: name.to_string(), ..Function::default() },
            prologue: Vec::new(),
            stack: vec![Vec::new()],
            consts: HashMap::default(),
            memo: vec![HashMap::default()],
            globals: HashMap::default(),
            in_prologue: std::collections::HashSet::default(),
            noise_budget: NOISE_INLINE_SITES,
        }
    }

    fn finish(mut self) -> Function {
        let body = self.stack.pop().unwrap_or_default();
        self.prologue.extend(body);
        self.func.body = self.prologue;
        super::opt::eliminate_dead_code(&mut self.func);
        self.func
    }

    fn push(&mut self, inst: Inst) {
        if let Some(top) = self.stack.last_mut() {
            top.push(inst);
        }
    }

    fn fresh_value(&mut self, ty: Scalar) -> Value {
        self.func.values.push(ty);
        Value(self.func.values.len() as u32 - 1)
    }

    fn var(&mut self, ty: Scalar) -> Var {
        self.func.vars.push(ty);
        Var(self.func.vars.len() as u32 - 1)
    }

    fn label(&mut self) -> Label {
        self.func.labels += 1;
        Label(self.func.labels - 1)
    }

    fn ty(&self, v: Value) -> Scalar {
        self.func.value_type(v)
    }

    fn konst(&self, v: Value) -> Option<Const> {
        self.consts.get(&v).copied()
    }

    fn fconst(&self, v: Value) -> Option<f32> {
        match self.konst(v) {
            Some(Const::F(x)) => Some(x),
            _ => None,
        }
    }

    /// Defines a value, folding constants and reusing an identical pure
    /// operation already computed in a dominating scope.
    fn def(&mut self, ty: Scalar, op: Op) -> Value {
        if let Some(c) = self.fold(&op) {
            return self.constant(c);
        }
        let key = OpKey::of(&op).map(MemoKey::Op);
        if let Some(v) = key.as_ref().and_then(|k| self.lookup(k)) {
            return v[0];
        }
        let v = self.fresh_value(ty);
        match op {
            Op::Global(_) => {
                self.in_prologue.insert(v);
                self.prologue.push(Inst::Def(v, op));
            }
            op => self.push(Inst::Def(v, op)),
        }
        if let Some(key) = key {
            self.remember(key, vec![v]);
        }
        v
    }

    fn constant(&mut self, c: Const) -> Value {
        let key = MemoKey::Const(match c {
            Const::F(x) => ConstKey::F(x.to_bits()),
            Const::I(x) => ConstKey::I(x),
            Const::B(x) => ConstKey::B(x),
        });
        if let Some(v) = self.memo[0].get(&key) {
            return v[0];
        }
        let (ty, op) = match c {
            Const::F(x) => (Scalar::F32, Op::F32(x)),
            Const::I(x) => (Scalar::I32, Op::I32(x)),
            Const::B(x) => (Scalar::Bool, Op::Bool(x)),
        };
        let v = self.fresh_value(ty);
        // Constants live in the prologue so they dominate everything.
        self.prologue.push(Inst::Def(v, op));
        self.in_prologue.insert(v);
        self.consts.insert(v, c);
        self.memo[0].insert(key, vec![v]);
        v
    }

    fn f(&mut self, x: f32) -> Value {
        self.constant(Const::F(x))
    }

    fn i(&mut self, x: i32) -> Value {
        self.constant(Const::I(x))
    }

    fn b(&mut self, x: bool) -> Value {
        self.constant(Const::B(x))
    }

    fn lookup(&self, key: &MemoKey) -> Option<Vec<Value>> {
        self.memo.iter().rev().find_map(|m| m.get(key).cloned())
    }

    fn remember(&mut self, key: MemoKey, v: Vec<Value>) {
        if let Some(top) = self.memo.last_mut() {
            top.insert(key, v);
        }
    }

    fn fold(&self, op: &Op) -> Option<Const> {
        use Const::*;
        match op {
            Op::Unary(u, a) => {
                let a = self.konst(*a)?;
                Some(match (u, a) {
                    (UnOp::FNeg, F(x)) => F(-x),
                    (UnOp::FAbs, F(x)) => F(x.abs()),
                    (UnOp::Sqrt, F(x)) => F(x.sqrt()),
                    (UnOp::Floor, F(x)) => F(x.floor()),
                    (UnOp::Ceil, F(x)) => F(x.ceil()),
                    (UnOp::Trunc, F(x)) => F(x.trunc()),
                    (UnOp::INeg, I(x)) => I(x.wrapping_neg()),
                    (UnOp::Not, B(x)) => B(!x),
                    (UnOp::IToF, I(x)) => F(x as f32),
                    (UnOp::FToI, F(x)) => I(x as i32),
                    (UnOp::BToI, B(x)) => I(i32::from(x)),
                    _ => return None,
                })
            }
            Op::Binary(op, a, b) => {
                let (a, b) = (self.konst(*a)?, self.konst(*b)?);
                Some(match (op, a, b) {
                    (BinOp::FAdd, F(x), F(y)) => F(x + y),
                    (BinOp::FSub, F(x), F(y)) => F(x - y),
                    (BinOp::FMul, F(x), F(y)) => F(x * y),
                    (BinOp::FDiv, F(x), F(y)) => F(x / y),
                    (BinOp::FMin, F(x), F(y)) => F(if x < y { x } else { y }),
                    (BinOp::FMax, F(x), F(y)) => F(if x > y { x } else { y }),
                    (BinOp::IAdd, I(x), I(y)) => I(x.wrapping_add(y)),
                    (BinOp::ISub, I(x), I(y)) => I(x.wrapping_sub(y)),
                    (BinOp::IMul, I(x), I(y)) => I(x.wrapping_mul(y)),
                    (BinOp::IDiv, I(x), I(y)) => I(crate::interp::int_div(x, y)),
                    (BinOp::IRem, I(x), I(y)) => I(crate::interp::int_rem(x, y)),
                    (BinOp::IAnd, I(x), I(y)) => I(x & y),
                    (BinOp::FLt, F(x), F(y)) => B(x < y),
                    (BinOp::FLe, F(x), F(y)) => B(x <= y),
                    (BinOp::FEq, F(x), F(y)) => B(x == y),
                    (BinOp::ILt, I(x), I(y)) => B(x < y),
                    (BinOp::ILe, I(x), I(y)) => B(x <= y),
                    (BinOp::IEq, I(x), I(y)) => B(x == y),
                    (BinOp::BEq, B(x), B(y)) => B(x == y),
                    (BinOp::And, B(x), B(y)) => B(x && y),
                    (BinOp::Or, B(x), B(y)) => B(x || y),
                    _ => return None,
                })
            }
            Op::Select { cond, then_value, else_value } => {
                let chosen = match self.konst(*cond)? {
                    B(true) => *then_value,
                    _ => *else_value,
                };
                self.konst(chosen)
            }
            _ => None,
        }
    }

    fn bin(&mut self, op: BinOp, a: Value, b: Value) -> Value {
        // Algebraic identities that keep specialised code small.
        match (op, self.fconst(a), self.fconst(b)) {
            (BinOp::FMul, Some(1.0), _) => return b,
            (BinOp::FMul, _, Some(1.0)) => return a,
            (BinOp::FAdd, Some(x), _) if x == 0.0 && x.is_sign_negative() => return b,
            (BinOp::FAdd, _, Some(y)) if y == 0.0 && y.is_sign_negative() => return a,
            (BinOp::FSub, _, Some(y)) if y == 0.0 && y.is_sign_positive() => return a,
            (BinOp::FDiv, _, Some(1.0)) => return a,
            _ => {}
        }
        // `true && x` is x, `false || x` is x.
        if matches!(op, BinOp::And | BinOp::Or) {
            let unit = Const::B(op == BinOp::And);
            if self.konst(a) == Some(unit) {
                return b;
            }
            if self.konst(b) == Some(unit) {
                return a;
            }
        }
        self.def(op.result(), Op::Binary(op, a, b))
    }

    fn un(&mut self, op: UnOp, a: Value) -> Value {
        let ty = match op {
            UnOp::FNeg | UnOp::FAbs | UnOp::Sqrt | UnOp::Floor | UnOp::Ceil | UnOp::Trunc | UnOp::IToF => Scalar::F32,
            UnOp::INeg | UnOp::FToI | UnOp::BToI => Scalar::I32,
            UnOp::Not => Scalar::Bool,
        };
        self.def(ty, Op::Unary(op, a))
    }

    fn select(&mut self, cond: Value, a: Value, b: Value) -> Value {
        if a == b {
            return a;
        }
        // A constant condition picks its side, constant or not.
        match self.konst(cond) {
            Some(Const::B(true)) => return a,
            Some(Const::B(false)) => return b,
            _ => {}
        }
        let ty = self.ty(a);
        self.def(ty, Op::Select { cond, then_value: a, else_value: b })
    }

    fn call(&mut self, native: &'static str, args: Vec<Value>) -> Value {
        // pow(1, e) = 1 and pow(x, 1) = x for every e and x, NaN included
        // (IEEE 754): Beer's law with a clear transmittance folds away.
        if native == "tsl_pow" && args.len() == 2 {
            if self.fconst(args[0]) == Some(1.0) {
                return self.f(1.0);
            }
            if self.fconst(args[1]) == Some(1.0) {
                return args[0];
            }
            // A small whole exponent (Phong's ns) is a few multiplications
            // instead of a libm call; exact to a few ulps, NaN, infinities
            // and signed zeros as pow.
            if let Some(e) = self.fconst(args[1]).filter(|e| e.fract() == 0.0 && (2.0..=64.0).contains(e)) {
                return self.powi(args[0], e as u32);
            }
        }
        self.def(Scalar::F32, Op::Call { native, args })
    }

    /// A texture lookup (value-numbered: a lookup is pure): R, G, B, A.
    fn texture(&mut self, sampler: &Arc<Sampler>, coords: [Value; 6]) -> [Value; 4] {
        let key = MemoKey::Texture { sampler: Arc::as_ptr(sampler) as usize, coords };
        if let Some(v) = self.lookup(&key) {
            return [v[0], v[1], v[2], v[3]];
        }
        let out = ArrayId(self.func.arrays.len() as u32);
        self.func.arrays.push((Scalar::F32, 4));
        self.push(Inst::Texture { sampler: SamplerRef(sampler.clone()), coords, out });
        let rgba = std::array::from_fn(|k| {
            let index = self.i(k as i32);
            let v = self.fresh_value(Scalar::F32);
            self.push(Inst::Def(v, Op::Load { array: out, index }));
            v
        });
        self.remember(key, rgba.to_vec());
        rgba
    }

    /// x^n for n >= 1 by repeated squaring.
    fn powi(&mut self, x: Value, n: u32) -> Value {
        let mut result: Option<Value> = None;
        let (mut base, mut n) = (x, n);
        while n > 0 {
            if n & 1 == 1 {
                result = Some(match result {
                    Some(r) => self.fmul(r, base),
                    None => base,
                });
            }
            n >>= 1;
            if n > 0 {
                base = self.fmul(base, base);
            }
        }
        result.unwrap_or(x)
    }

    fn get(&mut self, var: Var) -> Value {
        let ty = self.func.vars[var.0 as usize];
        self.def(ty, Op::Get(var))
    }

    fn global(&mut self, word: u32, ty: Scalar) -> Value {
        if let Some(v) = self.globals.get(&word) {
            return *v;
        }
        let v = self.def(ty, Op::Global(word));
        self.globals.insert(word, v);
        v
    }

    /// Like [`Builder::nested`] for the body of a `Block` (which is entered
    /// unconditionally). Returns the body split in two: the instructions
    /// before its first possible exit, which run whenever the block runs
    /// and so go before it, and the rest, which stays in the block. What the
    /// first part defines dominates the code after the block, so its memo
    /// entries stay visible there: a method body inlined twice (a
    /// reflection sum) shares the texture its first copy computed.
    fn block_body(&mut self, f: impl FnOnce(&mut Builder)) -> (Vec<Inst>, Vec<Inst>) {
        self.stack.push(Vec::new());
        self.memo.push(HashMap::default());
        f(self);
        let scope = self.memo.pop().unwrap_or_default();
        let mut body = self.stack.pop().unwrap_or_default();
        let split = body.iter().position(may_leave).unwrap_or(body.len());
        let rest = body.split_off(split);
        let prefix = body;
        let mut inside = HashSet::default();
        defined_values(&rest, &mut inside);
        let mut nested = Vec::new();
        for inst in &prefix {
            if !matches!(inst, Inst::Def(..)) {
                nested.push(inst.clone());
            }
        }
        defined_values(&nested, &mut inside);
        if let Some(parent) = self.memo.last_mut() {
            for (key, values) in scope {
                if values.iter().all(|v| !inside.contains(v)) {
                    parent.insert(key, values);
                }
            }
        }
        (prefix, rest)
    }

    /// Runs `f` with a fresh instruction list and memo scope; returns the list.
    fn nested(&mut self, f: impl FnOnce(&mut Builder)) -> Vec<Inst> {
        self.stack.push(Vec::new());
        self.memo.push(HashMap::default());
        f(self);
        self.memo.pop();
        self.stack.pop().unwrap_or_default()
    }

    /// `if cond { then } else { else }` producing lanes through variables.
    /// `cx` is handed to both branches (they cannot both borrow it).
    fn branch<C>(
        &mut self,
        cx: &mut C,
        cond: Value,
        tys: &[Scalar],
        then_f: impl FnOnce(&mut Builder, &mut C) -> Vec<Value>,
        else_f: impl FnOnce(&mut Builder, &mut C) -> Vec<Value>,
    ) -> Vec<Value> {
        match self.konst(cond) {
            Some(Const::B(true)) => return then_f(self, cx),
            Some(Const::B(false)) => return else_f(self, cx),
            _ => {}
        }
        let vars: Vec<Var> = tys.iter().map(|t| self.var(*t)).collect();
        let mut then_vals = Vec::new();
        let then_body = self.nested(|b| {
            then_vals = then_f(b, cx);
            for (var, v) in vars.iter().zip(&then_vals) {
                b.push(Inst::Set(*var, *v));
            }
        });
        let mut else_vals = Vec::new();
        let else_body = self.nested(|b| {
            else_vals = else_f(b, cx);
            for (var, v) in vars.iter().zip(&else_vals) {
                b.push(Inst::Set(*var, *v));
            }
        });
        // Both sides gave the same values, which therefore come from before
        // the branch (values made inside a branch are never shared with the
        // other side): the branch is not needed. Its bodies only write
        // variables of their own, so dropping them is safe.
        if then_vals == else_vals {
            return then_vals;
        }
        self.push(Inst::If { cond, then_body, else_body });
        vars.iter().map(|v| self.get(*v)).collect()
    }

    /// `if cond { body }`, giving `otherwise` when the condition is false.
    /// A body whose result was already computed before the branch (say, a
    /// default method returning its argument) needs no branch: its values
    /// are returned as they are. Callers use `otherwise` to skip work, never
    /// for its value, so that is sound.
    fn guarded<C>(
        &mut self,
        cx: &mut C,
        cond: Value,
        otherwise: Vec<Value>,
        f: impl FnOnce(&mut Builder, &mut C) -> Vec<Value>,
    ) -> Vec<Value> {
        match self.konst(cond) {
            Some(Const::B(true)) => return f(self, cx),
            Some(Const::B(false)) => return otherwise,
            _ => {}
        }
        let start = self.func.values.len() as u32;
        let mut vals = Vec::new();
        let mut then_body = self.nested(|b| vals = f(b, cx));
        if vals.iter().all(|v| v.0 < start || self.in_prologue.contains(v)) {
            // The body's own code computes nothing the result needs.
            return vals;
        }
        let vars: Vec<Var> = otherwise.iter().map(|v| self.var(self.ty(*v))).collect();
        then_body.extend(vars.iter().zip(&vals).map(|(var, v)| Inst::Set(*var, *v)));
        let else_body = vars.iter().zip(&otherwise).map(|(var, v)| Inst::Set(*var, *v)).collect();
        self.push(Inst::If { cond, then_body, else_body });
        vars.iter().map(|v| self.get(*v)).collect()
    }
}

// ---------------------------------------------------------------- lane arithmetic

impl Builder {
    fn fadd(&mut self, a: Value, b: Value) -> Value {
        self.bin(BinOp::FAdd, a, b)
    }
    fn fsub(&mut self, a: Value, b: Value) -> Value {
        self.bin(BinOp::FSub, a, b)
    }
    fn fmul(&mut self, a: Value, b: Value) -> Value {
        self.bin(BinOp::FMul, a, b)
    }
    fn fdiv(&mut self, a: Value, b: Value) -> Value {
        self.bin(BinOp::FDiv, a, b)
    }
    fn flt(&mut self, a: Value, b: Value) -> Value {
        self.bin(BinOp::FLt, a, b)
    }
    fn feq(&mut self, a: Value, b: Value) -> Value {
        self.bin(BinOp::FEq, a, b)
    }
    fn fmin(&mut self, a: Value, b: Value) -> Value {
        self.bin(BinOp::FMin, a, b)
    }
    fn fmax(&mut self, a: Value, b: Value) -> Value {
        self.bin(BinOp::FMax, a, b)
    }
    fn and(&mut self, a: Value, b: Value) -> Value {
        self.bin(BinOp::And, a, b)
    }
    fn not(&mut self, a: Value) -> Value {
        self.un(UnOp::Not, a)
    }

    fn map2(&mut self, op: BinOp, a: &[Value], b: &[Value]) -> Vec<Value> {
        a.iter().zip(b).map(|(x, y)| self.bin(op, *x, *y)).collect()
    }

    fn scale(&mut self, a: &[Value], s: Value) -> Vec<Value> {
        a.iter().map(|x| self.fmul(*x, s)).collect()
    }

    fn dot(&mut self, a: &[Value], b: &[Value]) -> Value {
        let mut acc = self.fmul(a[0], b[0]);
        for k in 1..a.len() {
            let p = self.fmul(a[k], b[k]);
            acc = self.fadd(acc, p);
        }
        acc
    }

    /// Σ w_k x_k with constant weights, skipping zeros.
    fn weighted(&mut self, weights: &[f32], xs: &[Value]) -> Value {
        let mut acc: Option<Value> = None;
        for (w, x) in weights.iter().zip(xs) {
            if *w == 0.0 {
                continue;
            }
            let wv = self.f(*w);
            let term = self.fmul(wv, *x);
            acc = Some(match acc {
                None => term,
                Some(a) => self.fadd(a, term),
            });
        }
        acc.unwrap_or_else(|| self.f(0.0))
    }

    fn length(&mut self, a: &[Value]) -> Value {
        let d = self.dot(a, a);
        self.un(UnOp::Sqrt, d)
    }

    /// `a / |a|`, and the zero vector for a zero vector: one division,
    /// then a multiplication per lane.
    fn normalize(&mut self, a: &[Value]) -> Vec<Value> {
        let len = self.length(a);
        let (zero, one) = (self.f(0.0), self.f(1.0));
        let positive = self.flt(zero, len);
        let inv = self.fdiv(one, len);
        a.iter()
            .map(|x| {
                let q = self.fmul(*x, inv);
                self.select(positive, q, zero)
            })
            .collect()
    }

    fn cross(&mut self, a: &[Value], b: &[Value]) -> Vec<Value> {
        let mut out = Vec::with_capacity(3);
        for (i, j) in [(1, 2), (2, 0), (0, 1)] {
            let p = self.fmul(a[i], b[j]);
            let q = self.fmul(a[j], b[i]);
            out.push(self.fsub(p, q));
        }
        out
    }

    /// Blends lanes: `a (1 - t) + b t`.
    fn lerp(&mut self, t: Value, a: &[Value], b: &[Value]) -> Vec<Value> {
        let one = self.f(1.0);
        let s = self.fsub(one, t);
        a.iter()
            .zip(b)
            .map(|(x, y)| {
                let p = self.fmul(*x, s);
                let q = self.fmul(*y, t);
                self.fadd(p, q)
            })
            .collect()
    }

    fn clamp(&mut self, x: Value, lo: Value, hi: Value) -> Value {
        let m = self.fmax(x, lo);
        self.fmin(m, hi)
    }

    fn zeros(&mut self, n: usize) -> Vec<Value> {
        let z = self.f(0.0);
        vec![z; n]
    }
}

// ---------------------------------------------------------------- entry points

impl<'p> Lowerer<'p> {
    fn new(program: &'p Program, model: ColorModel) -> Lowerer<'p> {
        Lowerer {
            program,
            model,
            lanes: model.lanes(),
            diags: Vec::new(),
            next_id: 0,
            samplers: HashMap::default(),
            direction_only: false,
        }
    }

    fn item(&self, sym: Symbol) -> &'p Item {
        &self.program.loaded.modules[sym.module].ast.items[sym.item]
    }

    fn is_prelude(&self, sym: Symbol) -> bool {
        self.program.loaded.modules[sym.module].is_prelude
    }

    fn id(&mut self) -> u32 {
        self.next_id += 1;
        self.next_id
    }

    /// Types that scalarize: everything but arrays, strings, materials, void.
    fn is_plain(&self, t: &Ty) -> bool {
        !matches!(t, Ty::Array(..) | Ty::String | Ty::Material | Ty::Void | Ty::Error)
    }

    fn lanes_of(&self, t: &Ty) -> usize {
        match t {
            Ty::Float | Ty::Int | Ty::Bool => 1,
            Ty::Vec2 => 2,
            Ty::Vector | Ty::Point | Ty::Normal => 3,
            Ty::Color => self.lanes,
            Ty::Matrix => 12,
            // wi, weight, pdf, and delta as 0 or 1.
            Ty::BsdfSample => 5 + self.lanes,
            _ => 0,
        }
    }

    /// Which lanes of a value of type `ty` member `field` is.
    fn field_lanes(&self, ty: &Ty, field: &str) -> std::ops::Range<usize> {
        if *ty == Ty::BsdfSample {
            let mut start = 0;
            for (name, t) in crate::check::SAMPLE_FIELDS {
                let n = self.lanes_of(t);
                if *name == field {
                    return start..start + n;
                }
                start += n;
            }
        }
        let k = match field {
            "x" => 0,
            "y" => 1,
            _ => 2,
        };
        k..k + 1
    }

    /// `s.delta` is stored as a float lane, 1 for true.
    fn is_flag_field(ty: &Ty, field: &str) -> bool {
        *ty == Ty::BsdfSample && field == "delta"
    }

    fn scalar_of(t: &Ty) -> Scalar {
        match t {
            Ty::Int => Scalar::I32,
            Ty::Bool => Scalar::Bool,
            _ => Scalar::F32,
        }
    }

    fn words(&self, t: &Ty) -> Vec<Scalar> {
        vec![Self::scalar_of(t); self.lanes_of(t)]
    }

    fn root_ctx(&mut self) -> Ctx {
        let id = self.id();
        Ctx { id, overrides: Rc::new(HashMap::default()) }
    }

    /// Reads a method's parameters from the argument words, as lanes.
    fn method_args(&self, b: &mut Builder, params: &[(String, Ty)]) -> Vec<Vec<Value>> {
        self.params_from_args(b, params)
            .into_iter()
            .map(|v| match v {
                Val::Lanes(l) => l,
                _ => Vec::new(),
            })
            .collect()
    }

    /// Reads parameters from the argument words.
    fn params_from_args(&self, b: &mut Builder, params: &[(String, Ty)]) -> Vec<Val<'p>> {
        let mut word = 0;
        let mut out = Vec::new();
        for (_, ty) in params {
            let scalar = Self::scalar_of(ty);
            let lanes: Vec<Value> = (0..self.lanes_of(ty))
                .map(|_| {
                    b.func.params.push(scalar);
                    word += 1;
                    b.def(scalar, Op::Param(word - 1))
                })
                .collect();
            out.push(Val::Lanes(lanes));
        }
        out
    }

    fn write_results(&self, b: &mut Builder, ret: &Ty, v: &[Value]) {
        b.func.results = self.words(ret);
        for (k, x) in v.iter().enumerate() {
            b.push(Inst::Output(k as u32, *x));
        }
    }

    fn lower_function_entry(
        &mut self,
        name: &str,
        sym: Symbol,
        f: &'p ast::Function,
        params: &[(String, Ty)],
        ret: &Ty,
    ) -> Function {
        let mut b = Builder::new(name);
        let args = self.params_from_args(&mut b, params);
        let ctx = self.root_ctx();
        let result = self.inline_function(&mut b, sym, f, args, &ctx);
        let lanes = self.lanes(&mut b, result, ret);
        self.write_results(&mut b, ret, &lanes);
        b.finish()
    }

    fn material_entries(&mut self, name: &str, sym: Symbol, module: &mut Module, entries: &mut Vec<Entry>) {
        let expr = self.material_name_expr(sym);
        for im in INTERFACE {
            let fname = format!("{name}.{}", im.name);
            let mut b = Builder::new(&fname);
            let params: Vec<(String, Ty)> = im.params.iter().map(|(n, t)| (n.to_string(), t.clone())).collect();
            let args = self.method_args(&mut b, &params);
            let ctx = self.root_ctx();
            let mat = match expr {
                MatSource::Tree(e) => {
                    Mat { expr: e, env: Rc::new(HashMap::default()), in_prelude: self.is_prelude(sym) }
                }
                MatSource::Def => {
                    let inst = self.instance_from_def(&mut b, sym, &[], &ctx, &Rc::new(HashMap::default()), false);
                    let result = self.instance_method(&mut b, &inst, im, &args, &ctx);
                    self.write_results(&mut b, &im.ret, &result);
                    module.functions.push(b.finish());
                    entries.push(Entry { name: fname, kind: EntryKind::Method(im.name), params, ret: im.ret.clone() });
                    continue;
                }
            };
            let result = self.mat_method(&mut b, &mat, im, &args, &ctx);
            self.write_results(&mut b, &im.ret, &result);
            module.functions.push(b.finish());
            entries.push(Entry { name: fname, kind: EntryKind::Method(im.name), params, ret: im.ret.clone() });
        }
    }

    fn material_name_expr(&self, sym: Symbol) -> MatSource<'p> {
        match self.item(sym) {
            Item::MaterialTree(t) => MatSource::Tree(&t.body),
            _ => MatSource::Def,
        }
    }
}

enum MatSource<'p> {
    Tree(&'p Expr),
    Def,
}

// ---------------------------------------------------------------- functions and statements

impl<'p> Lowerer<'p> {
    fn ty_of(&self, e: &Expr) -> Ty {
        self.program.expr_types.get(&e.span).cloned().unwrap_or(Ty::Error)
    }

    fn error(&mut self, span: Span, msg: impl Into<String>) {
        self.diags.push(Diagnostic::error(span, msg));
    }

    /// The lanes of a plain value (anything else is a checker bug; it
    /// lowers to nothing rather than panicking).
    fn lanes(&mut self, b: &mut Builder, v: Val<'p>, ty: &Ty) -> Vec<Value> {
        match v {
            Val::Lanes(l) => l,
            _ => b.zeros(self.lanes_of(ty)),
        }
    }

    /// Converts `v` of type `from` to `to` (int → float; triples are alike).
    fn coerce(&mut self, b: &mut Builder, v: Val<'p>, from: &Ty, to: &Ty) -> Val<'p> {
        match (from, to, v) {
            (Ty::Int, Ty::Float, Val::Lanes(l)) => Val::Lanes(vec![b.un(UnOp::IToF, l[0])]),
            (Ty::Array(fe, _), Ty::Array(te, _), Val::Array(ArrayVal::Elems(es)))
                if **fe == Ty::Int && **te == Ty::Float =>
            {
                Val::Array(ArrayVal::Elems(es.into_iter().map(|e| vec![b.un(UnOp::IToF, e[0])]).collect()))
            }
            (_, _, v) => v,
        }
    }

    fn expr_as(&mut self, b: &mut Builder, fr: &mut Frame<'p>, ctx: &Ctx, e: &'p Expr, to: &Ty) -> Val<'p> {
        let v = self.expr(b, fr, ctx, e);
        let from = self.ty_of(e);
        self.coerce(b, v, &from, to)
    }

    fn new_frame(&self, in_prelude: bool, assigned: HashSet<String>) -> Frame<'p> {
        Frame { scopes: vec![HashMap::default()], ret: None, loops: Vec::new(), material: None, assigned, in_prelude }
    }

    /// Binds a name in the innermost scope: as a value when it is never
    /// assigned (so it folds), else in variables.
    fn bind(&mut self, b: &mut Builder, fr: &mut Frame<'p>, name: &str, v: Val<'p>, ty: &Ty) {
        let binding = if fr.assigned.contains(name) {
            match v {
                Val::Lanes(lanes) => {
                    let vars: Vec<Var> = lanes
                        .iter()
                        .map(|x| {
                            let var = b.var(b.ty(*x));
                            b.push(Inst::Set(var, *x));
                            var
                        })
                        .collect();
                    Binding::Vars(vars)
                }
                Val::Array(a) => Binding::Val(Val::Array(self.materialize(b, a, ty))),
                other => Binding::Val(other),
            }
        } else {
            Binding::Val(v)
        };
        if let Some(scope) = fr.scopes.last_mut() {
            scope.insert(name.to_string(), binding);
        }
    }

    /// Copies an array into fresh IR arrays (arrays have value semantics).
    fn materialize(&mut self, b: &mut Builder, a: ArrayVal, ty: &Ty) -> ArrayVal {
        let Ty::Array(elem, len) = ty else { return a };
        let lanes = self.lanes_of(elem);
        let scalar = Self::scalar_of(elem);
        let arrays: Vec<ArrayId> = (0..lanes)
            .map(|_| {
                b.func.arrays.push((scalar, *len));
                ArrayId(b.func.arrays.len() as u32 - 1)
            })
            .collect();
        for k in 0..*len {
            let elem_vals = self.array_elem_const(b, &a, k, lanes);
            let idx = b.i(k as i32);
            for (lane, arr) in arrays.iter().enumerate() {
                b.push(Inst::Store { array: *arr, index: idx, value: elem_vals[lane] });
            }
        }
        ArrayVal::Ir { arrays, len: *len }
    }

    fn array_elem_const(&mut self, b: &mut Builder, a: &ArrayVal, k: u32, lanes: usize) -> Vec<Value> {
        match a {
            ArrayVal::Elems(es) => es.get(k as usize).cloned().unwrap_or_else(|| b.zeros(lanes)),
            ArrayVal::Ir { arrays, .. } => {
                let idx = b.i(k as i32);
                arrays
                    .iter()
                    .map(|arr| {
                        let ty = b.func.arrays[arr.0 as usize].0;
                        b.def(ty, Op::Load { array: *arr, index: idx })
                    })
                    .collect()
            }
        }
    }

    fn array_elems(&mut self, b: &mut Builder, a: &ArrayVal, lanes: usize) -> Vec<Vec<Value>> {
        let len = match a {
            ArrayVal::Elems(es) => es.len() as u32,
            ArrayVal::Ir { len, .. } => *len,
        };
        (0..len).map(|k| self.array_elem_const(b, a, k, lanes)).collect()
    }

    /// Inlines a call of a user function, reusing an earlier identical call.
    fn inline_function(
        &mut self,
        b: &mut Builder,
        sym: Symbol,
        f: &'p ast::Function,
        args: Vec<Val<'p>>,
        ctx: &Ctx,
    ) -> Val<'p> {
        let ret = Ty::from_ast(&f.ret);
        let plain_args: Option<Vec<Value>> = args
            .iter()
            .map(|a| match a {
                Val::Lanes(l) => Some(l.clone()),
                _ => None,
            })
            .collect::<Option<Vec<_>>>()
            .map(|v| v.concat());
        let key = plain_args.map(|args| MemoKey::Call { item: (sym.module, sym.item), ctx: ctx.id, args });
        if let Some(key) = &key
            && let Some(v) = b.lookup(key)
        {
            return Val::Lanes(v);
        }
        let mut fr = self.new_frame(self.is_prelude(sym), assigned_names(&f.body));
        for (p, a) in f.params.iter().zip(args) {
            let ty = Ty::from_ast(&p.ty);
            self.bind(b, &mut fr, &p.name.name, a, &ty);
        }
        let result = self.body_with_return(b, &mut fr, ctx, &f.body, &ret);
        if let (Some(key), Val::Lanes(l)) = (key, &result) {
            b.remember(key, l.clone());
        }
        result
    }

    /// Lowers a function or method body and returns its result. A body whose
    /// only `return` is its last statement needs no result variables.
    fn body_with_return(
        &mut self,
        b: &mut Builder,
        fr: &mut Frame<'p>,
        ctx: &Ctx,
        body: &'p ast::Block,
        ret: &Ty,
    ) -> Val<'p> {
        let returns = count_returns(&body.stmts);
        if let Some(Stmt { kind: StmtKind::Return(value), .. }) = body.stmts.last()
            && returns == 1
        {
            for s in &body.stmts[..body.stmts.len() - 1] {
                if self.stmt(b, fr, ctx, s) {
                    break;
                }
            }
            return match value {
                Some(e) => self.expr_as(b, fr, ctx, e, ret),
                None => Val::Unit,
            };
        }
        if *ret == Ty::Void {
            return Val::Unit;
        }
        let label = b.label();
        let vars: Vec<Var> = self.words(ret).into_iter().map(|s| b.var(s)).collect();
        // Result variables start at zero: every path returns (checked), so
        // this only keeps unreachable paths defined.
        for v in &vars {
            let zero = match b.func.vars[v.0 as usize] {
                Scalar::F32 => b.f(0.0),
                Scalar::I32 => b.i(0),
                Scalar::Bool => b.b(false),
            };
            b.push(Inst::Set(*v, zero));
        }
        fr.ret = Some((label, vars.clone(), ret.clone()));
        let (prefix, inner) = b.block_body(|b| {
            for s in &body.stmts {
                if self.stmt(b, fr, ctx, s) {
                    break;
                }
            }
        });
        for inst in prefix {
            b.push(inst);
        }
        b.push(Inst::Block { label, body: inner });
        let lanes = vars.iter().map(|v| b.get(*v)).collect();
        Val::Lanes(lanes)
    }

    fn lookup<'f>(&self, fr: &'f Frame<'p>, name: &str) -> Option<&'f Binding<'p>> {
        fr.scopes.iter().rev().find_map(|s| s.get(name))
    }

    /// Lowers a statement; returns true when control never falls through.
    fn stmt(&mut self, b: &mut Builder, fr: &mut Frame<'p>, ctx: &Ctx, s: &'p Stmt) -> bool {
        match &s.kind {
            StmtKind::Let { ty, name, init } => {
                let ty = Ty::from_ast(ty);
                let v = match init {
                    Some(e) => self.expr_as(b, fr, ctx, e, &ty),
                    None => self.zero_value(b, &ty),
                };
                self.bind(b, fr, &name.name, v, &ty);
                false
            }
            StmtKind::Assign { target, op, value } => {
                self.assign(b, fr, ctx, target, *op, value);
                false
            }
            // Functions are pure: an expression statement does nothing.
            StmtKind::Expr(_) => false,
            StmtKind::If { cond, then_block, else_branch } => {
                let c = self.expr(b, fr, ctx, cond);
                let c = self.scalar(b, c);
                match b.konst(c) {
                    Some(Const::B(true)) => return self.block(b, fr, ctx, then_block),
                    Some(Const::B(false)) => {
                        return match else_branch {
                            Some(e) => self.stmt(b, fr, ctx, e),
                            None => false,
                        };
                    }
                    _ => {}
                }
                let mut then_ends = false;
                let then_body = b.nested(|b| then_ends = self.block(b, fr, ctx, then_block));
                let mut else_ends = false;
                let else_body = b.nested(|b| {
                    if let Some(e) = else_branch {
                        else_ends = self.stmt(b, fr, ctx, e);
                    }
                });
                b.push(Inst::If { cond: c, then_body, else_body });
                then_ends && else_ends
            }
            StmtKind::For { var, start, end, body } => {
                let lo = self.expr(b, fr, ctx, start);
                let lo = self.scalar(b, lo);
                let hi = self.expr(b, fr, ctx, end);
                let hi = self.scalar(b, hi);
                let label = b.label();
                let counter = b.var(Scalar::I32);
                fr.loops.push(label);
                let inner = b.nested(|b| {
                    fr.scopes.push(HashMap::default());
                    let i = b.get(counter);
                    if let Some(scope) = fr.scopes.last_mut() {
                        scope.insert(var.name.clone(), Binding::Val(Val::Lanes(vec![i])));
                    }
                    self.block(b, fr, ctx, body);
                    fr.scopes.pop();
                });
                fr.loops.pop();
                b.push(Inst::Loop { label, counter, start: lo, end: hi, body: inner });
                false
            }
            StmtKind::While { .. } => false,
            StmtKind::Break | StmtKind::Continue => {
                if let Some(l) = fr.loops.last() {
                    b.push(if matches!(s.kind, StmtKind::Break) { Inst::Break(*l) } else { Inst::Continue(*l) });
                }
                true
            }
            StmtKind::Return(value) => {
                if let Some((label, vars, ret_ty)) = fr.ret.clone() {
                    if let Some(e) = value {
                        let v = self.expr_as(b, fr, ctx, e, &ret_ty);
                        let lanes = self.lanes(b, v, &ret_ty);
                        for (var, x) in vars.iter().zip(lanes) {
                            b.push(Inst::Set(*var, x));
                        }
                    }
                    b.push(Inst::Break(label));
                }
                true
            }
            StmtKind::Block(block) => self.block(b, fr, ctx, block),
        }
    }

    fn block(&mut self, b: &mut Builder, fr: &mut Frame<'p>, ctx: &Ctx, block: &'p ast::Block) -> bool {
        fr.scopes.push(HashMap::default());
        let mut ends = false;
        for s in &block.stmts {
            if self.stmt(b, fr, ctx, s) {
                ends = true;
                break;
            }
        }
        fr.scopes.pop();
        ends
    }

    fn zero_value(&mut self, b: &mut Builder, ty: &Ty) -> Val<'p> {
        match ty {
            Ty::Array(e, n) => {
                let lanes = self.lanes_of(e);
                let z = self.zero_lanes(b, e, lanes);
                Val::Array(ArrayVal::Elems(vec![z; *n as usize]))
            }
            Ty::String => Val::Str(Rc::from("")),
            t => {
                let n = self.lanes_of(t);
                Val::Lanes(self.zero_lanes(b, t, n))
            }
        }
    }

    fn zero_lanes(&mut self, b: &mut Builder, ty: &Ty, n: usize) -> Vec<Value> {
        let z = match ty {
            Ty::Int => b.i(0),
            Ty::Bool => b.b(false),
            _ => b.f(0.0),
        };
        vec![z; n]
    }

    fn scalar(&mut self, b: &mut Builder, v: Val<'p>) -> Value {
        match v {
            Val::Lanes(l) if !l.is_empty() => l[0],
            _ => b.f(0.0),
        }
    }

    fn assign(
        &mut self,
        b: &mut Builder,
        fr: &mut Frame<'p>,
        ctx: &Ctx,
        target: &'p Expr,
        op: AssignOp,
        value: &'p Expr,
    ) {
        let target_ty = self.ty_of(target);
        let new = match op.binary() {
            None => self.expr_as(b, fr, ctx, value, &target_ty),
            Some(bop) => {
                let old = self.expr(b, fr, ctx, target);
                let value_ty = self.ty_of(value);
                let v = self.expr(b, fr, ctx, value);
                self.binary(b, bop, old, &target_ty, v, &value_ty, &target_ty)
            }
        };
        let new_lanes = match new {
            Val::Lanes(l) => l,
            Val::Array(a) => {
                // Whole-array assignment: copy element by element.
                if let ExprKind::Name(n) = &target.kind
                    && let Some(Binding::Val(Val::Array(ArrayVal::Ir { arrays, .. }))) = self.lookup(fr, n).cloned()
                {
                    let lanes = arrays.len();
                    for (k, elem) in self.array_elems(b, &a, lanes).into_iter().enumerate() {
                        let idx = b.i(k as i32);
                        for (arr, v) in arrays.iter().zip(elem) {
                            b.push(Inst::Store { array: *arr, index: idx, value: v });
                        }
                    }
                }
                return;
            }
            _ => return,
        };
        self.store(b, fr, ctx, target, new_lanes);
    }

    /// Writes lanes into an assignable place.
    fn store(&mut self, b: &mut Builder, fr: &mut Frame<'p>, ctx: &Ctx, target: &'p Expr, lanes: Vec<Value>) {
        match &target.kind {
            ExprKind::Name(n) => {
                if let Some(Binding::Vars(vars)) = self.lookup(fr, n).cloned() {
                    for (var, v) in vars.iter().zip(lanes) {
                        b.push(Inst::Set(*var, v));
                    }
                }
            }
            ExprKind::Member { base, field } => {
                let base_ty = self.ty_of(base);
                let range = self.field_lanes(&base_ty, &field.name);
                let mut lanes = lanes;
                if Self::is_flag_field(&base_ty, &field.name) && !lanes.is_empty() {
                    let (one, zero) = (b.f(1.0), b.f(0.0));
                    lanes = vec![b.select(lanes[0], one, zero)];
                }
                let old = self.expr(b, fr, ctx, base);
                if let Val::Lanes(mut l) = old
                    && range.end <= l.len()
                    && lanes.len() == range.len()
                {
                    l[range].copy_from_slice(&lanes);
                    self.store(b, fr, ctx, base, l);
                }
            }
            ExprKind::Index { base, index } => {
                let i = self.expr(b, fr, ctx, index);
                let i = self.scalar(b, i);
                match self.expr(b, fr, ctx, base) {
                    Val::Array(ArrayVal::Ir { arrays, .. }) => {
                        for (arr, v) in arrays.iter().zip(lanes) {
                            b.push(Inst::Store { array: *arr, index: i, value: v });
                        }
                    }
                    Val::Lanes(old) if !lanes.is_empty() => {
                        // A vector lane chosen at run time.
                        let n = old.len() as i32;
                        let i = self.clamp_index(b, i, n);
                        let new: Vec<Value> = old
                            .iter()
                            .enumerate()
                            .map(|(k, x)| {
                                let kv = b.i(k as i32);
                                let hit = b.bin(BinOp::IEq, i, kv);
                                b.select(hit, lanes[0], *x)
                            })
                            .collect();
                        self.store(b, fr, ctx, base, new);
                    }
                    _ => {}
                }
            }
            _ => {}
        }
    }

    fn clamp_index(&mut self, b: &mut Builder, i: Value, n: i32) -> Value {
        let zero = b.i(0);
        let last = b.i(n - 1);
        let below = b.bin(BinOp::ILt, i, zero);
        let i = b.select(below, zero, i);
        let above = b.bin(BinOp::ILt, last, i);
        b.select(above, last, i)
    }
}

/// Names assigned anywhere in a block (so they need variables).
/// Every value an instruction list defines, nested bodies included.
fn defined_values(body: &[Inst], out: &mut HashSet<Value>) {
    for inst in body {
        match inst {
            Inst::Def(v, _) => {
                out.insert(*v);
            }
            Inst::If { then_body, else_body, .. } => {
                defined_values(then_body, out);
                defined_values(else_body, out);
            }
            Inst::Block { body, .. } | Inst::Loop { body, .. } => defined_values(body, out),
            _ => {}
        }
    }
}

/// Whether running `inst` may leave the enclosing block early (it holds a
/// `Break` or `Continue` somewhere).
fn may_leave(inst: &Inst) -> bool {
    match inst {
        Inst::Break(_) | Inst::Continue(_) => true,
        Inst::If { then_body, else_body, .. } => then_body.iter().chain(else_body).any(may_leave),
        Inst::Block { body, .. } | Inst::Loop { body, .. } => body.iter().any(may_leave),
        _ => false,
    }
}

fn assigned_names(block: &ast::Block) -> HashSet<String> {
    let mut out = HashSet::default();
    let mut stack: Vec<&Stmt> = block.stmts.iter().collect();
    while let Some(s) = stack.pop() {
        match &s.kind {
            StmtKind::Assign { target, .. } => {
                let mut t = target;
                loop {
                    match &t.kind {
                        ExprKind::Member { base, .. } | ExprKind::Index { base, .. } => t = base,
                        ExprKind::Name(n) => {
                            out.insert(n.clone());
                            break;
                        }
                        _ => break,
                    }
                }
            }
            StmtKind::If { then_block, else_branch, .. } => {
                stack.extend(then_block.stmts.iter());
                if let Some(e) = else_branch {
                    stack.push(e);
                }
            }
            StmtKind::For { body, .. } | StmtKind::While { body, .. } => stack.extend(body.stmts.iter()),
            StmtKind::Block(b) => stack.extend(b.stmts.iter()),
            _ => {}
        }
    }
    out
}

fn count_returns(stmts: &[Stmt]) -> usize {
    let mut n = 0;
    let mut stack: Vec<&Stmt> = stmts.iter().collect();
    while let Some(s) = stack.pop() {
        match &s.kind {
            StmtKind::Return(_) => n += 1,
            StmtKind::If { then_block, else_branch, .. } => {
                stack.extend(then_block.stmts.iter());
                if let Some(e) = else_branch {
                    stack.push(e);
                }
            }
            StmtKind::For { body, .. } | StmtKind::While { body, .. } => stack.extend(body.stmts.iter()),
            StmtKind::Block(b) => stack.extend(b.stmts.iter()),
            _ => {}
        }
    }
    n
}

// ---------------------------------------------------------------- expressions

impl<'p> Lowerer<'p> {
    fn symbol(&self, fr_prelude: bool, name: &str) -> Option<Symbol> {
        let table = if fr_prelude { &self.program.prelude_symbols } else { &self.program.symbols };
        table.get(name).copied()
    }

    fn global(&mut self, b: &mut Builder, ctx: &Ctx, name: &str) -> Option<Vec<Value>> {
        if let Some(v) = ctx.overrides.get(name) {
            return Some(v.clone());
        }
        let (word, ty) = globals::word_of(name)?;
        let scalar = Self::scalar_of(&ty);
        Some((0..self.lanes_of(&ty) as u32).map(|k| b.global(word + k, scalar)).collect())
    }

    fn expr(&mut self, b: &mut Builder, fr: &mut Frame<'p>, ctx: &Ctx, e: &'p Expr) -> Val<'p> {
        let ty = self.ty_of(e);
        match &e.kind {
            ExprKind::Int(i) => Val::Lanes(vec![b.i(*i)]),
            ExprKind::Float(x) => Val::Lanes(vec![b.f(*x as f32)]),
            ExprKind::Bool(x) => Val::Lanes(vec![b.b(*x)]),
            ExprKind::Str(s) => Val::Str(Rc::from(s.as_str())),
            ExprKind::Name(n) => self.name(b, fr, ctx, n, e),
            ExprKind::Call { callee, args } => self.call(b, fr, ctx, callee, args, e),
            ExprKind::Construct { ty: base, args, .. } => self.construct(b, fr, ctx, *base, args, e),
            ExprKind::Member { base, field } => {
                let base_ty = self.ty_of(base);
                let range = self.field_lanes(&base_ty, &field.name);
                let v = self.expr(b, fr, ctx, base);
                match v {
                    Val::Lanes(l) if Self::is_flag_field(&base_ty, &field.name) && range.end <= l.len() => {
                        let zero = b.f(0.0);
                        Val::Lanes(vec![b.flt(zero, l[range.start])])
                    }
                    Val::Lanes(l) if range.end <= l.len() => Val::Lanes(l[range].to_vec()),
                    _ => self.zero_value(b, &ty),
                }
            }
            ExprKind::Index { base, index } => {
                let i = self.expr(b, fr, ctx, index);
                let i = self.scalar(b, i);
                let base_ty = self.ty_of(base);
                let v = self.expr(b, fr, ctx, base);
                self.index(b, v, &base_ty, i)
            }
            ExprKind::Unary { op, operand } => {
                let v = self.expr(b, fr, ctx, operand);
                let lanes = self.lanes(b, v, &ty);
                let out = match (op, &ty) {
                    (UnaryOp::Not, _) => lanes.iter().map(|x| b.not(*x)).collect(),
                    (UnaryOp::Neg, Ty::Int) => lanes.iter().map(|x| b.un(UnOp::INeg, *x)).collect(),
                    (UnaryOp::Neg, _) => lanes.iter().map(|x| b.un(UnOp::FNeg, *x)).collect(),
                };
                Val::Lanes(out)
            }
            ExprKind::Binary { op, lhs, rhs } => {
                let (lt, rt) = (self.ty_of(lhs), self.ty_of(rhs));
                let l = self.expr(b, fr, ctx, lhs);
                let r = self.expr(b, fr, ctx, rhs);
                self.binary(b, *op, l, &lt, r, &rt, &ty)
            }
            ExprKind::Ternary { cond, then_expr, else_expr } => {
                let c = self.expr(b, fr, ctx, cond);
                let c = self.scalar(b, c);
                if ty == Ty::Material {
                    return Val::Material(Mat { expr: e, env: self.mat_env(fr), in_prelude: fr.in_prelude });
                }
                // Both sides are pure: evaluate both and select lane by lane.
                let a = self.expr_as(b, fr, ctx, then_expr, &ty);
                let z = self.expr_as(b, fr, ctx, else_expr, &ty);
                match (a, z) {
                    (Val::Lanes(a), Val::Lanes(z)) => {
                        Val::Lanes(a.iter().zip(&z).map(|(x, y)| b.select(c, *x, *y)).collect())
                    }
                    (a, _) => a,
                }
            }
            ExprKind::Array(items) => {
                if ty == Ty::Material || matches!(&ty, Ty::Array(e, _) if **e == Ty::Material) {
                    return Val::Unit;
                }
                let elem_ty = match &ty {
                    Ty::Array(e, _) => (**e).clone(),
                    _ => Ty::Float,
                };
                let elems = items
                    .iter()
                    .map(|it| {
                        let v = self.expr_as(b, fr, ctx, it, &elem_ty);
                        self.lanes(b, v, &elem_ty)
                    })
                    .collect();
                Val::Array(ArrayVal::Elems(elems))
            }
            ExprKind::Tuple(items) => {
                let lanes = items
                    .iter()
                    .map(|it| {
                        let v = self.expr_as(b, fr, ctx, it, &Ty::Float);
                        self.scalar(b, v)
                    })
                    .collect();
                Val::Lanes(lanes)
            }
        }
    }

    /// The template bindings visible from the current frame (materials and
    /// values bound by a template call).
    fn mat_env(&self, fr: &Frame<'p>) -> Rc<HashMap<String, Val<'p>>> {
        let mut env = HashMap::default();
        for scope in &fr.scopes {
            for (k, v) in scope {
                if let Binding::Val(v) = v {
                    env.insert(k.clone(), v.clone());
                }
            }
        }
        Rc::new(env)
    }

    fn index(&mut self, b: &mut Builder, v: Val<'p>, base_ty: &Ty, i: Value) -> Val<'p> {
        match v {
            Val::Array(a) => {
                let Ty::Array(elem, len) = base_ty else { return Val::Unit };
                let lanes = self.lanes_of(elem);
                if let Some(Const::I(k)) = b.konst(i) {
                    let k = crate::interp::clamp_index(k, *len as usize) as u32;
                    return Val::Lanes(self.array_elem_const(b, &a, k, lanes));
                }
                let a = match a {
                    ArrayVal::Elems(_) => self.materialize(b, a, base_ty),
                    ir => ir,
                };
                let ArrayVal::Ir { arrays, .. } = a else { return Val::Unit };
                Val::Lanes(
                    arrays
                        .iter()
                        .map(|arr| {
                            let ty = b.func.arrays[arr.0 as usize].0;
                            b.def(ty, Op::Load { array: *arr, index: i })
                        })
                        .collect(),
                )
            }
            Val::Lanes(l) => {
                let i = self.clamp_index(b, i, l.len() as i32);
                let mut acc = l[0];
                for (k, x) in l.iter().enumerate().skip(1) {
                    let kv = b.i(k as i32);
                    let hit = b.bin(BinOp::IEq, i, kv);
                    acc = b.select(hit, *x, acc);
                }
                Val::Lanes(vec![acc])
            }
            other => other,
        }
    }

    fn name(&mut self, b: &mut Builder, fr: &mut Frame<'p>, ctx: &Ctx, n: &str, e: &'p Expr) -> Val<'p> {
        if let Some(binding) = self.lookup(fr, n).cloned() {
            return match binding {
                Binding::Val(v) => v,
                Binding::Vars(vars) => Val::Lanes(vars.iter().map(|v| b.get(*v)).collect()),
            };
        }
        if let Some(g) = self.global(b, ctx, n) {
            return Val::Lanes(g);
        }
        match self.symbol(fr.in_prelude, n) {
            Some(sym) if sym.kind == SymbolKind::Const => {
                let Item::Const(c) = self.item(sym) else { return Val::Unit };
                // Constants fold, so lowering the value at each use is cheap.
                let ty = Ty::from_ast(&c.ty);
                let mut cfr = self.new_frame(self.is_prelude(sym), HashSet::default());
                self.expr_as(b, &mut cfr, ctx, &c.value, &ty)
            }
            Some(_) => Val::Material(Mat { expr: e, env: self.mat_env(fr), in_prelude: fr.in_prelude }),
            None => Val::Unit,
        }
    }

    fn call(
        &mut self,
        b: &mut Builder,
        fr: &mut Frame<'p>,
        ctx: &Ctx,
        callee: &'p ast::Ident,
        args: &'p [ast::Arg],
        e: &'p Expr,
    ) -> Val<'p> {
        let name = callee.name.as_str();
        // A sibling method inside a material.
        if let (Some(inst), Some(im)) = (fr.material.clone(), interface_method(name)) {
            let params: Vec<(&str, Ty)> = im.params.iter().map(|(n, t)| (*n, t.clone())).collect();
            let bound = bind_args(&params, args);
            let mut lanes = Vec::new();
            for ((_, ty), a) in params.iter().zip(bound) {
                let v = match a {
                    Some(a) => self.expr_as(b, fr, ctx, a, ty),
                    None => self.zero_value(b, ty),
                };
                lanes.push(self.lanes(b, v, ty));
            }
            return Val::Lanes(self.instance_method(b, &inst, im, &lanes, ctx));
        }
        if let Some(sym) = self.program.resolutions.get(&callee.span).copied() {
            return match self.item(sym) {
                Item::Function(f) => {
                    let params: Vec<(&str, Ty)> =
                        f.params.iter().map(|p| (p.name.name.as_str(), Ty::from_ast(&p.ty))).collect();
                    let bound = bind_args(&params, args);
                    let mut vals = Vec::new();
                    for (p, a) in f.params.iter().zip(bound) {
                        let ty = Ty::from_ast(&p.ty);
                        let v = match a {
                            Some(a) => self.expr_as(b, fr, ctx, a, &ty),
                            None => match &p.default {
                                // Defaults are evaluated in the callee's scope.
                                Some(d) => {
                                    let mut dfr = self.new_frame(self.is_prelude(sym), HashSet::default());
                                    self.expr_as(b, &mut dfr, ctx, d, &ty)
                                }
                                None => self.zero_value(b, &ty),
                            },
                        };
                        vals.push(v);
                    }
                    self.inline_function(b, sym, f, vals, ctx)
                }
                _ => Val::Material(Mat { expr: e, env: self.mat_env(fr), in_prelude: fr.in_prelude }),
            };
        }
        if matches!(name, "mix" | "blend" | "select" | "bump" | "scale" | "transform") && self.ty_of(e) == Ty::Material
        {
            return Val::Material(Mat { expr: e, env: self.mat_env(fr), in_prelude: fr.in_prelude });
        }
        self.builtin(b, fr, ctx, name, args, e)
    }
}

/// Matches call arguments to parameters by position and name.
fn bind_args<'a>(params: &[(&str, Ty)], args: &'a [ast::Arg]) -> Vec<Option<&'a Expr>> {
    let mut bound: Vec<Option<&Expr>> = vec![None; params.len()];
    for (k, a) in args.iter().enumerate() {
        let slot = match &a.name {
            Some(n) => params.iter().position(|(p, _)| *p == n.name),
            None => Some(k),
        };
        if let Some(s) = slot.filter(|s| *s < bound.len()) {
            bound[s] = Some(&a.value);
        }
    }
    bound
}

// ---------------------------------------------------------------- operators

impl<'p> Lowerer<'p> {
    /// Lanes of `v` (of type `t`) as floats, broadcast to `n` lanes.
    fn float_lanes(&mut self, b: &mut Builder, v: Val<'p>, t: &Ty, n: usize) -> Vec<Value> {
        let lanes = self.lanes(b, v, t);
        let lanes: Vec<Value> =
            if *t == Ty::Int { lanes.iter().map(|x| b.un(UnOp::IToF, *x)).collect() } else { lanes };
        if lanes.len() == 1 && n > 1 { vec![lanes[0]; n] } else { lanes }
    }

    #[allow(clippy::too_many_arguments)]
    fn binary(&mut self, b: &mut Builder, op: BinaryOp, l: Val<'p>, lt: &Ty, r: Val<'p>, rt: &Ty, ty: &Ty) -> Val<'p> {
        use BinaryOp::*;
        match op {
            And | Or => {
                let (x, y) = (self.scalar(b, l), self.scalar(b, r));
                Val::Lanes(vec![b.bin(if op == And { BinOp::And } else { BinOp::Or }, x, y)])
            }
            Lt | Le | Gt | Ge => {
                let ints = *lt == Ty::Int && *rt == Ty::Int;
                let (mut x, mut y) = if ints {
                    (self.scalar(b, l), self.scalar(b, r))
                } else {
                    (self.float_lanes(b, l, lt, 1)[0], self.float_lanes(b, r, rt, 1)[0])
                };
                if matches!(op, Gt | Ge) {
                    std::mem::swap(&mut x, &mut y);
                }
                let bop = match (ints, matches!(op, Lt | Gt)) {
                    (true, true) => BinOp::ILt,
                    (true, false) => BinOp::ILe,
                    (false, true) => BinOp::FLt,
                    (false, false) => BinOp::FLe,
                };
                Val::Lanes(vec![b.bin(bop, x, y)])
            }
            Eq | Ne => {
                let eq = if let (Val::Str(x), Val::Str(y)) = (&l, &r) {
                    // Options are known when the item is compiled.
                    b.b(x == y)
                } else if *lt == Ty::Bool {
                    let (x, y) = (self.scalar(b, l), self.scalar(b, r));
                    b.bin(BinOp::BEq, x, y)
                } else if *lt == Ty::Int && *rt == Ty::Int {
                    let (x, y) = (self.scalar(b, l), self.scalar(b, r));
                    b.bin(BinOp::IEq, x, y)
                } else {
                    let n = self.lanes_of(lt).max(self.lanes_of(rt));
                    let x = self.float_lanes(b, l, lt, n);
                    let y = self.float_lanes(b, r, rt, n);
                    let mut acc = b.b(true);
                    for (p, q) in x.iter().zip(&y) {
                        let e = b.feq(*p, *q);
                        acc = b.and(acc, e);
                    }
                    acc
                };
                Val::Lanes(vec![if op == Ne { b.not(eq) } else { eq }])
            }
            Add | Sub | Mul | Div | Rem => {
                if *ty == Ty::Int {
                    let (x, y) = (self.scalar(b, l), self.scalar(b, r));
                    let bop = match op {
                        Add => BinOp::IAdd,
                        Sub => BinOp::ISub,
                        Mul => BinOp::IMul,
                        Div => BinOp::IDiv,
                        _ => BinOp::IRem,
                    };
                    return Val::Lanes(vec![b.bin(bop, x, y)]);
                }
                if *ty == Ty::Matrix {
                    let (x, y) = (self.lanes(b, l, lt), self.lanes(b, r, rt));
                    return Val::Lanes(mat_mul(b, &x, &y));
                }
                let n = self.lanes_of(ty);
                let x = self.float_lanes(b, l, lt, n);
                let y = self.float_lanes(b, r, rt, n);
                let out = x
                    .iter()
                    .zip(&y)
                    .map(|(p, q)| match op {
                        Add => b.fadd(*p, *q),
                        Sub => b.fsub(*p, *q),
                        Mul => b.fmul(*p, *q),
                        Div => b.fdiv(*p, *q),
                        // Float `%` truncates like C's fmod: a - b trunc(a / b).
                        _ => {
                            let d = b.fdiv(*p, *q);
                            let t = b.un(UnOp::Trunc, d);
                            let m = b.fmul(*q, t);
                            b.fsub(*p, m)
                        }
                    })
                    .collect();
                Val::Lanes(out)
            }
        }
    }
}

/// Composes two affine maps given as three rows of four.
fn mat_mul(b: &mut Builder, x: &[Value], y: &[Value]) -> Vec<Value> {
    let mut out = Vec::with_capacity(12);
    for r in 0..3 {
        for c in 0..4 {
            let mut acc = b.fmul(x[r * 4], y[c]);
            for k in 1..3 {
                let p = b.fmul(x[r * 4 + k], y[k * 4 + c]);
                acc = b.fadd(acc, p);
            }
            if c == 3 {
                acc = b.fadd(acc, x[r * 4 + 3]);
            }
            out.push(acc);
        }
    }
    out
}

fn transform_point(b: &mut Builder, m: &[Value], p: &[Value], translate: bool) -> Vec<Value> {
    (0..3)
        .map(|r| {
            let mut acc = b.fmul(m[r * 4], p[0]);
            for k in 1..3 {
                let t = b.fmul(m[r * 4 + k], p[k]);
                acc = b.fadd(acc, t);
            }
            if translate { b.fadd(acc, m[r * 4 + 3]) } else { acc }
        })
        .collect()
}

/// The inverse of an affine map (the zero map when it is singular).
#[allow(clippy::needless_range_loop)] // row/column index arithmetic reads best as loops
fn mat_inverse(b: &mut Builder, m: &[Value]) -> Vec<Value> {
    let a = |r: usize, c: usize| m[r * 4 + c];
    let mut cof = [[Value(0); 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
            let (c1, c2) = ((c + 1) % 3, (c + 2) % 3);
            let p = b.fmul(a(r1, c1), a(r2, c2));
            let q = b.fmul(a(r1, c2), a(r2, c1));
            cof[r][c] = b.fsub(p, q);
        }
    }
    let mut det = b.fmul(a(0, 0), cof[0][0]);
    for c in 1..3 {
        let t = b.fmul(a(0, c), cof[0][c]);
        det = b.fadd(det, t);
    }
    let zero = b.f(0.0);
    let singular = b.feq(det, zero);
    let one = b.f(1.0);
    let inv_det = b.fdiv(one, det);
    let inv_det = b.select(singular, zero, inv_det);
    let mut out = vec![zero; 12];
    for r in 0..3 {
        for c in 0..3 {
            // The inverse is the transposed cofactor matrix over the determinant.
            out[r * 4 + c] = b.fmul(cof[c][r], inv_det);
        }
    }
    let t = [a(0, 3), a(1, 3), a(2, 3)];
    let lin: Vec<Value> = out.clone();
    let moved = transform_point(b, &lin, &t, false);
    for r in 0..3 {
        out[r * 4 + 3] = b.un(UnOp::FNeg, moved[r]);
    }
    out
}

// ---------------------------------------------------------------- builtins

impl<'p> Lowerer<'p> {
    fn construct(
        &mut self,
        b: &mut Builder,
        fr: &mut Frame<'p>,
        ctx: &Ctx,
        base: ast::BaseType,
        args: &'p [ast::Arg],
        e: &'p Expr,
    ) -> Val<'p> {
        use ast::BaseType as B;
        if base == B::Normal
            && args.is_empty()
            && let Some(inst) = fr.material.clone()
        {
            let im = interface_method("normal").expect("normal is an interface method");
            return Val::Lanes(self.instance_method(b, &inst, im, &[], ctx));
        }
        let vals: Vec<(Val<'p>, Ty)> =
            args.iter().map(|a| (self.expr(b, fr, ctx, &a.value), self.ty_of(&a.value))).collect();
        match base {
            B::Int => {
                let (v, t) = vals.into_iter().next().unwrap_or((Val::Unit, Ty::Error));
                let x = self.scalar(b, v);
                Val::Lanes(vec![if t == Ty::Int { x } else { b.un(UnOp::FToI, x) }])
            }
            B::Float => {
                let (v, t) = vals.into_iter().next().unwrap_or((Val::Unit, Ty::Error));
                Val::Lanes(self.float_lanes(b, v, &t, 1))
            }
            B::Matrix if vals.is_empty() => Val::Lanes(identity(b)),
            B::BsdfSample => {
                // bsdf_sample(wi, weight, pdf): not a delta lobe.
                let mut lanes = Vec::new();
                for ((v, t), want) in vals.into_iter().zip([Ty::Vector, Ty::Color, Ty::Float]) {
                    let n = self.lanes_of(&want);
                    lanes.extend(self.float_lanes(b, v, &t, n));
                }
                lanes.push(b.f(0.0));
                Val::Lanes(lanes)
            }
            B::Matrix if vals.len() == 1 => {
                let (v, t) = vals.into_iter().next().unwrap_or((Val::Unit, Ty::Error));
                let s = self.float_lanes(b, v, &t, 1)[0];
                Val::Lanes(diag(b, [s, s, s]))
            }
            _ => {
                let n = self.lanes_of(&self.ty_of(e));
                let mut lanes = Vec::new();
                for (v, t) in vals {
                    lanes.extend(self.float_lanes(b, v, &t, 1));
                }
                if lanes.len() == 1 && n > 1 {
                    lanes = vec![lanes[0]; n];
                }
                Val::Lanes(lanes)
            }
        }
    }

    fn builtin(
        &mut self,
        b: &mut Builder,
        fr: &mut Frame<'p>,
        ctx: &Ctx,
        name: &str,
        args: &'p [ast::Arg],
        e: &'p Expr,
    ) -> Val<'p> {
        let ty = self.ty_of(e);
        let Some(spec) = crate::check::BUILTINS.iter().find(|s| s.name == name) else { return Val::Unit };
        let params: Vec<(&str, Ty)> = spec.params.iter().map(|p| (p.trim_end_matches('?'), Ty::Error)).collect();
        let bound = bind_args(&params, args);
        if matches!(name, "texture" | "texture_float") {
            return self.texture(b, fr, ctx, spec, &bound, e);
        }
        let mut vals: Vec<Option<(Val<'p>, Ty)>> = Vec::new();
        for a in &bound {
            vals.push(a.map(|a| (self.expr(b, fr, ctx, a), self.ty_of(a))));
        }
        let n = self.lanes_of(&ty);
        // Float lanes of argument k, broadcast to the result width.
        let mut arg = |me: &mut Self, b: &mut Builder, k: usize, width: usize| -> Vec<Value> {
            match vals.get_mut(k).and_then(Option::take) {
                Some((v, t)) => me.float_lanes(b, v, &t, width),
                None => b.zeros(width),
            }
        };
        let unary_native = |b: &mut Builder, native: &'static str, x: Vec<Value>| -> Val<'p> {
            Val::Lanes(x.into_iter().map(|v| b.call(native, vec![v])).collect())
        };

        match name {
            "abs" if ty == Ty::Int => {
                let x = self.scalar_arg(b, &bound, 0, fr, ctx);
                let neg = b.un(UnOp::INeg, x);
                let zero = b.i(0);
                let lt = b.bin(BinOp::ILt, x, zero);
                Val::Lanes(vec![b.select(lt, neg, x)])
            }
            "abs" => Val::Lanes(arg(self, b, 0, n).into_iter().map(|x| b.un(UnOp::FAbs, x)).collect()),
            "sign" => {
                let x = arg(self, b, 0, n);
                let (zero, one, minus) = (b.f(0.0), b.f(1.0), b.f(-1.0));
                Val::Lanes(
                    x.into_iter()
                        .map(|v| {
                            let pos = b.flt(zero, v);
                            let neg = b.flt(v, zero);
                            let s = b.select(neg, minus, zero);
                            b.select(pos, one, s)
                        })
                        .collect(),
                )
            }
            "floor" => Val::Lanes(arg(self, b, 0, n).into_iter().map(|x| b.un(UnOp::Floor, x)).collect()),
            "ceil" => Val::Lanes(arg(self, b, 0, n).into_iter().map(|x| b.un(UnOp::Ceil, x)).collect()),
            "fract" => Val::Lanes(
                arg(self, b, 0, n)
                    .into_iter()
                    .map(|x| {
                        let f = b.un(UnOp::Floor, x);
                        b.fsub(x, f)
                    })
                    .collect(),
            ),
            "sqrt" => Val::Lanes(arg(self, b, 0, n).into_iter().map(|x| b.un(UnOp::Sqrt, x)).collect()),
            n_ if unary_native_name(n_).is_some() => {
                let x = arg(self, b, 0, n);
                unary_native(b, unary_native_name(name).unwrap_or("tsl_round"), x)
            }
            "radians" | "degrees" => {
                let k =
                    b.f(if name == "radians" { std::f32::consts::PI / 180.0 } else { 180.0 / std::f32::consts::PI });
                Val::Lanes(arg(self, b, 0, n).into_iter().map(|x| b.fmul(x, k)).collect())
            }
            "atan2" => {
                let (y, x) = (arg(self, b, 0, 1)[0], arg(self, b, 1, 1)[0]);
                Val::Lanes(vec![b.call("tsl_atan2", vec![y, x])])
            }
            "pow" => {
                let x = arg(self, b, 0, n);
                let p = arg(self, b, 1, 1)[0];
                Val::Lanes(x.into_iter().map(|v| b.call("tsl_pow", vec![v, p])).collect())
            }
            "min" | "max" if ty == Ty::Int => {
                let x = self.scalar_arg(b, &bound, 0, fr, ctx);
                let y = self.scalar_arg(b, &bound, 1, fr, ctx);
                let lt = b.bin(BinOp::ILt, x, y);
                Val::Lanes(vec![if name == "min" { b.select(lt, x, y) } else { b.select(lt, y, x) }])
            }
            "min" | "max" => {
                let x = arg(self, b, 0, n);
                let y = arg(self, b, 1, n);
                let op = if name == "min" { BinOp::FMin } else { BinOp::FMax };
                Val::Lanes(b.map2(op, &x, &y))
            }
            "clamp" if ty == Ty::Int => {
                let x = self.scalar_arg(b, &bound, 0, fr, ctx);
                let lo = self.scalar_arg(b, &bound, 1, fr, ctx);
                let hi = self.scalar_arg(b, &bound, 2, fr, ctx);
                let below = b.bin(BinOp::ILt, x, lo);
                let x = b.select(below, lo, x);
                let above = b.bin(BinOp::ILt, hi, x);
                Val::Lanes(vec![b.select(above, hi, x)])
            }
            "mod" if ty == Ty::Int => {
                // Floored modulo: ((a % b) + b) % b, zero for b == 0.
                let x = self.scalar_arg(b, &bound, 0, fr, ctx);
                let y = self.scalar_arg(b, &bound, 1, fr, ctx);
                let r = b.bin(BinOp::IRem, x, y);
                let r = b.bin(BinOp::IAdd, r, y);
                Val::Lanes(vec![b.bin(BinOp::IRem, r, y)])
            }
            "clamp" => {
                let x = arg(self, b, 0, n);
                let lo = arg(self, b, 1, n);
                let hi = arg(self, b, 2, n);
                Val::Lanes((0..n).map(|k| b.clamp(x[k], lo[k], hi[k])).collect())
            }
            "mod" => {
                let x = arg(self, b, 0, n);
                let y = arg(self, b, 1, n);
                Val::Lanes(
                    (0..n)
                        .map(|k| {
                            let d = b.fdiv(x[k], y[k]);
                            let f = b.un(UnOp::Floor, d);
                            let m = b.fmul(y[k], f);
                            b.fsub(x[k], m)
                        })
                        .collect(),
                )
            }
            "step" => {
                let edge = arg(self, b, 0, n);
                let x = arg(self, b, 1, n);
                let (zero, one) = (b.f(0.0), b.f(1.0));
                Val::Lanes(
                    (0..n)
                        .map(|k| {
                            let below = b.flt(x[k], edge[k]);
                            b.select(below, zero, one)
                        })
                        .collect(),
                )
            }
            "smoothstep" => {
                let e0 = arg(self, b, 0, n);
                let e1 = arg(self, b, 1, n);
                let x = arg(self, b, 2, n);
                let (zero, one, two, three) = (b.f(0.0), b.f(1.0), b.f(2.0), b.f(3.0));
                Val::Lanes(
                    (0..n)
                        .map(|k| {
                            let num = b.fsub(x[k], e0[k]);
                            let den = b.fsub(e1[k], e0[k]);
                            let t = b.fdiv(num, den);
                            let t = b.clamp(t, zero, one);
                            let tt = b.fmul(t, t);
                            let two_t = b.fmul(two, t);
                            let s = b.fsub(three, two_t);
                            b.fmul(tt, s)
                        })
                        .collect(),
                )
            }
            "dot" => {
                let w = self.lanes_of(&bound[0].map(|a| self.ty_of(a)).unwrap_or(Ty::Vector));
                let x = arg(self, b, 0, w);
                let y = arg(self, b, 1, w);
                Val::Lanes(vec![b.dot(&x, &y)])
            }
            "cross" => {
                let x = arg(self, b, 0, 3);
                let y = arg(self, b, 1, 3);
                Val::Lanes(b.cross(&x, &y))
            }
            "length" | "normalize" => {
                let w = self.lanes_of(&bound[0].map(|a| self.ty_of(a)).unwrap_or(Ty::Vector));
                let x = arg(self, b, 0, w);
                Val::Lanes(if name == "length" { vec![b.length(&x)] } else { b.normalize(&x) })
            }
            "distance" => {
                let w = self.lanes_of(&bound[0].map(|a| self.ty_of(a)).unwrap_or(Ty::Vector));
                let x = arg(self, b, 0, w);
                let y = arg(self, b, 1, w);
                let d = b.map2(BinOp::FSub, &x, &y);
                Val::Lanes(vec![b.length(&d)])
            }
            "reflect" => {
                let i = arg(self, b, 0, 3);
                let nrm = arg(self, b, 1, 3);
                let d = b.dot(&nrm, &i);
                let two = b.f(2.0);
                let k = b.fmul(two, d);
                let s = b.scale(&nrm, k);
                Val::Lanes(b.map2(BinOp::FSub, &i, &s))
            }
            "refract" => {
                let i = arg(self, b, 0, 3);
                let nrm = arg(self, b, 1, 3);
                let eta = arg(self, b, 2, 1)[0];
                Val::Lanes(refract(b, &i, &nrm, eta))
            }
            "faceforward" => {
                let nrm = arg(self, b, 0, 3);
                let i = arg(self, b, 1, 3);
                let d = b.dot(&nrm, &i);
                let zero = b.f(0.0);
                let facing = b.flt(d, zero);
                Val::Lanes(
                    nrm.iter()
                        .map(|x| {
                            let neg = b.un(UnOp::FNeg, *x);
                            b.select(facing, *x, neg)
                        })
                        .collect(),
                )
            }
            "noise" => {
                let w = self.lanes_of(&bound[0].map(|a| self.ty_of(a)).unwrap_or(Ty::Float));
                let p = arg(self, b, 0, w);
                let key = MemoKey::Noise(p.clone());
                if let Some(v) = b.lookup(&key) {
                    return Val::Lanes(v);
                }
                if b.noise_budget == 0 {
                    return Val::Lanes(vec![b.call(native_name(name, w), p)]);
                }
                b.noise_budget -= 1;
                let v = noise::noise(b, &p);
                b.remember(key, vec![v]);
                Val::Lanes(vec![v])
            }
            "cellnoise" => {
                let w = self.lanes_of(&bound[0].map(|a| self.ty_of(a)).unwrap_or(Ty::Float));
                let p = arg(self, b, 0, w);
                let native = native_name(name, w);
                Val::Lanes(vec![b.call(native, p)])
            }
            "pnoise" => {
                let w = self.lanes_of(&bound[0].map(|a| self.ty_of(a)).unwrap_or(Ty::Float));
                let mut p = arg(self, b, 0, w);
                p.extend(arg(self, b, 1, w));
                Val::Lanes(vec![b.call(native_name(name, w), p)])
            }
            "rgb" => {
                let (r, g, bl) = (arg(self, b, 0, 1)[0], arg(self, b, 1, 1)[0], arg(self, b, 2, 1)[0]);
                Val::Lanes(self.rgb_to_lanes(b, [r, g, bl]))
            }
            "hsv" => {
                let (h, s, v) = (arg(self, b, 0, 1)[0], arg(self, b, 1, 1)[0], arg(self, b, 2, 1)[0]);
                let rgb = hsv_to_rgb(b, h, s, v);
                Val::Lanes(self.rgb_to_lanes(b, rgb))
            }
            "xyz" => {
                let xyz = [arg(self, b, 0, 1)[0], arg(self, b, 1, 1)[0], arg(self, b, 2, 1)[0]];
                let rgb = xyz_rows_to_rgb(b, xyz);
                Val::Lanes(self.rgb_to_lanes(b, rgb))
            }
            "gray" => {
                let x = arg(self, b, 0, 1)[0];
                Val::Lanes(vec![x; self.lanes])
            }
            "black" => Val::Lanes(b.zeros(self.lanes)),
            "spectrum" => self.spectrum(b, &mut vals, &bound),
            "delta_sample" => {
                // A delta lobe: pdf 0 (no density), the flag set.
                let mut lanes = arg(self, b, 0, 3);
                lanes.extend(arg(self, b, 1, self.lanes));
                lanes.push(b.f(0.0));
                lanes.push(b.f(1.0));
                Val::Lanes(lanes)
            }
            "no_sample" => Val::Lanes(b.zeros(n)),
            "brightness" => {
                let c = arg(self, b, 0, self.lanes);
                let w = color::luminance_weights(self.model);
                Val::Lanes(vec![b.weighted(&w, &c)])
            }
            "to_rgb" | "to_xyz" => {
                let c = arg(self, b, 0, self.lanes);
                let rows = if name == "to_rgb" {
                    color::to_rgb_weights(self.model)
                } else {
                    color::to_xyz_weights(self.model)
                };
                Val::Lanes(rows.iter().map(|w| b.weighted(w, &c)).collect())
            }
            "translate" => {
                let v = arg(self, b, 0, 3);
                let mut m = identity(b);
                m[3] = v[0];
                m[7] = v[1];
                m[11] = v[2];
                Val::Lanes(m)
            }
            "rotate" => {
                let deg = arg(self, b, 0, 1)[0];
                let axis = arg(self, b, 1, 3);
                Val::Lanes(rotation(b, deg, &axis))
            }
            "scale" => {
                let (v, t) = vals[0].take().unwrap_or((Val::Unit, Ty::Float));
                let s = self.float_lanes(b, v, &t, 3);
                Val::Lanes(diag(b, [s[0], s[1], s[2]]))
            }
            "inverse" => {
                let m = arg(self, b, 0, 12);
                Val::Lanes(mat_inverse(b, &m))
            }
            "transform_point" | "transform_vector" => {
                let m = arg(self, b, 0, 12);
                let p = arg(self, b, 1, 3);
                Val::Lanes(transform_point(b, &m, &p, name == "transform_point"))
            }
            "transform_normal" => {
                let m = arg(self, b, 0, 12);
                let nrm = arg(self, b, 1, 3);
                let inv = mat_inverse(b, &m);
                // Normals go through the inverse transpose.
                let t: Vec<Value> = (0..3)
                    .map(|r| {
                        let row: Vec<Value> = (0..3).map(|c| inv[c * 4 + r]).collect();
                        b.dot(&row, &nrm)
                    })
                    .collect();
                Val::Lanes(t)
            }
            "mix" => {
                let t = arg(self, b, 0, 1)[0];
                let x = arg(self, b, 1, n);
                let y = arg(self, b, 2, n);
                Val::Lanes(b.lerp(t, &x, &y))
            }
            "blend" => {
                let t = arg(self, b, 0, 1)[0];
                let spline = match vals.get_mut(2).and_then(Option::take) {
                    Some((v, _)) => self.scalar(b, v),
                    None => b.b(false),
                };
                let items = match vals.get_mut(1).and_then(Option::take) {
                    Some((Val::Array(a), Ty::Array(e, _))) => {
                        let lanes = self.lanes_of(&e);
                        let elems = self.array_elems(b, &a, lanes);
                        if *e == Ty::Int {
                            elems.into_iter().map(|l| vec![b.un(UnOp::IToF, l[0])]).collect()
                        } else {
                            elems
                        }
                    }
                    _ => Vec::new(),
                };
                let w = blend_weights(b, t, spline, items.len());
                let mut acc = b.zeros(n);
                for (wk, item) in w.iter().zip(&items) {
                    let s = b.scale(item, *wk);
                    acc = b.map2(BinOp::FAdd, &acc, &s);
                }
                Val::Lanes(acc)
            }
            "select" => {
                let i = self.scalar_arg(b, &bound, 0, fr, ctx);
                let (items, elem) = match vals.get_mut(1).and_then(Option::take) {
                    Some((Val::Array(a), Ty::Array(e, _))) => {
                        let lanes = self.lanes_of(&e);
                        (self.array_elems(b, &a, lanes), *e)
                    }
                    _ => (Vec::new(), Ty::Float),
                };
                if items.is_empty() {
                    return Val::Lanes(b.zeros(n));
                }
                let i = self.clamp_index(b, i, items.len() as i32);
                let mut acc = items[0].clone();
                for (k, item) in items.iter().enumerate().skip(1) {
                    let kv = b.i(k as i32);
                    let hit = b.bin(BinOp::IEq, i, kv);
                    acc = acc.iter().zip(item).map(|(a, x)| b.select(hit, *x, *a)).collect();
                }
                let _ = elem;
                Val::Lanes(acc)
            }
            _ => Val::Lanes(b.zeros(n)),
        }
    }

    /// `texture(file, st, ...)` and `texture_float(file, st, channel, ...)`.
    /// The footprint is `dx`/`dy` when given; else `st` is evaluated again at
    /// the neighbouring pixels (the globals moved by their derivatives), so
    /// any expression of the globals gets its true change per pixel. When
    /// that shows no change (`st` is a local or a parameter computed
    /// earlier), the footprint of (u, v) stands in.
    fn texture(
        &mut self,
        b: &mut Builder,
        fr: &mut Frame<'p>,
        ctx: &Ctx,
        spec: &crate::check::Builtin,
        bound: &[Option<&'p Expr>],
        e: &'p Expr,
    ) -> Val<'p> {
        let color = spec.name == "texture";
        let width = if color { self.lanes } else { 1 };
        let st_arg = spec.arg(bound, "st");
        let Some(sampler) = self.sampler(e.span) else {
            self.error(e.span, "internal error: this texture call has no loaded image");
            return Val::Lanes(b.zeros(width));
        };
        let eval_st = |me: &mut Self, b: &mut Builder, fr: &mut Frame<'p>, c: &Ctx| -> Vec<Value> {
            match st_arg {
                Some(st) => {
                    let v = me.expr_as(b, fr, c, st, &Ty::Vec2);
                    me.lanes(b, v, &Ty::Vec2)
                }
                None => {
                    let u = me.global(b, c, "u").unwrap_or_default();
                    let v = me.global(b, c, "v").unwrap_or_default();
                    vec![u[0], v[0]]
                }
            }
        };
        let st = eval_st(self, b, fr, ctx);
        let uv_footprint = |me: &mut Self, b: &mut Builder, axis: &str| -> Vec<Value> {
            let du = me.global(b, ctx, &format!("dud{axis}")).unwrap_or_default();
            let dv = me.global(b, ctx, &format!("dvd{axis}")).unwrap_or_default();
            vec![du[0], dv[0]]
        };
        let mut derivs = Vec::new();
        for (param, axis) in [("dx", "x"), ("dy", "y")] {
            let d = match spec.arg(bound, param) {
                Some(d) => {
                    let v = self.expr_as(b, fr, ctx, d, &Ty::Vec2);
                    self.lanes(b, v, &Ty::Vec2)
                }
                None if st_arg.is_none() => uv_footprint(self, b, axis),
                None => {
                    let shifted = self.pixel_neighbour(b, ctx, axis);
                    let moved = eval_st(self, b, fr, &shifted);
                    if moved == st { uv_footprint(self, b, axis) } else { b.map2(BinOp::FSub, &moved, &st) }
                }
            };
            derivs.push(d);
        }
        let coords = [st[0], st[1], derivs[0][0], derivs[0][1], derivs[1][0], derivs[1][1]];
        let rgba = b.texture(&sampler, coords);
        if color {
            return Val::Lanes(self.rgb_to_lanes(b, [rgba[0], rgba[1], rgba[2]]));
        }
        let channel = match spec.arg(bound, "channel") {
            Some(c) => {
                let v = self.expr(b, fr, ctx, c);
                self.scalar(b, v)
            }
            None => b.i(0),
        };
        self.index(b, Val::Lanes(rgba.to_vec()), &Ty::Float, channel)
    }

    /// The sampler of the texture call at `span`, made once per image,
    /// filter and address modes.
    fn sampler(&mut self, span: Span) -> Option<Arc<Sampler>> {
        let call = *self.program.texture_calls.get(&span)?;
        let image = self.program.images.get(call.image)?.image.clone()?;
        Some(
            self.samplers
                .entry(call)
                .or_insert_with(|| Arc::new(Sampler { image, filter: call.filter, wrap: call.wrap }))
                .clone(),
        )
    }

    /// The coordinate context of the next pixel in `axis` ("x" or "y"):
    /// P and Pl moved by dP/d`axis`, u and v by their derivatives.
    fn pixel_neighbour(&mut self, b: &mut Builder, ctx: &Ctx, axis: &str) -> Ctx {
        let g = |me: &mut Self, b: &mut Builder, name: &str| me.global(b, ctx, name).unwrap_or_default();
        let dp = g(self, b, &format!("dPd{axis}"));
        let mut changes = Vec::new();
        for name in ["P", "Pl"] {
            let p = g(self, b, name);
            changes.push((name, b.map2(BinOp::FAdd, &p, &dp)));
        }
        for name in ["u", "v"] {
            let x = g(self, b, name);
            let d = g(self, b, &format!("d{name}d{axis}"));
            changes.push((name, vec![b.fadd(x[0], d[0])]));
        }
        self.with_overrides(ctx, changes)
    }

    fn scalar_arg(
        &mut self,
        b: &mut Builder,
        bound: &[Option<&'p Expr>],
        k: usize,
        fr: &mut Frame<'p>,
        ctx: &Ctx,
    ) -> Value {
        match bound.get(k).copied().flatten() {
            Some(e) => {
                let v = self.expr(b, fr, ctx, e);
                self.scalar(b, v)
            }
            None => b.i(0),
        }
    }

    /// `spectrum([(nm, value), ...])`: wavelengths must be constants; values
    /// may vary. Each lane is a fixed weighting of the values.
    fn spectrum(&mut self, b: &mut Builder, vals: &mut [Option<(Val<'p>, Ty)>], bound: &[Option<&'p Expr>]) -> Val<'p> {
        let Some((Val::Array(a), _)) = vals.first_mut().and_then(Option::take) else {
            return Val::Lanes(b.zeros(self.lanes));
        };
        let elems = self.array_elems(b, &a, 2);
        let mut wavelengths = Vec::new();
        for e in &elems {
            match b.fconst(e[0]) {
                Some(nm) => wavelengths.push(nm),
                None => {
                    let span = bound.first().copied().flatten().map(|e| e.span).unwrap_or_default();
                    self.error(span, "spectrum wavelengths must be constants");
                    return Val::Lanes(b.zeros(self.lanes));
                }
            }
        }
        let values: Vec<Value> = elems.iter().map(|e| e[1]).collect();
        let w = color::resample_weights(self.model, &wavelengths);
        Val::Lanes(w.iter().map(|row| b.weighted(row, &values)).collect())
    }

    /// An RGB triple in the color model: itself, or Smits' upsampling.
    fn rgb_to_lanes(&mut self, b: &mut Builder, rgb: [Value; 3]) -> Vec<Value> {
        if let ColorModel::Rgb = self.model {
            return rgb.to_vec();
        }
        if let (Some(r), Some(g), Some(bl)) = (b.fconst(rgb[0]), b.fconst(rgb[1]), b.fconst(rgb[2])) {
            return color::rgb_to_lanes(self.model, [r, g, bl]).into_iter().map(|x| b.f(x)).collect();
        }
        let coef = smits_coefficients(b, rgb);
        let basis = color::smits_basis(self.model);
        let spectra = [&basis.white, &basis.cyan, &basis.magenta, &basis.yellow, &basis.red, &basis.green, &basis.blue];
        (0..self.lanes)
            .map(|i| {
                let weights: Vec<Value> = spectra.iter().map(|s| b.f(s[i])).collect();
                b.dot(&weights, &coef)
            })
            .collect()
    }
}

/// The native computing an elementwise builtin that Cranelift has no
/// instruction for.
fn unary_native_name(name: &str) -> Option<&'static str> {
    Some(match name {
        "round" => "tsl_round",
        "exp" => "tsl_exp",
        "log" => "tsl_log",
        "sin" => "tsl_sin",
        "cos" => "tsl_cos",
        "tan" => "tsl_tan",
        "asin" => "tsl_asin",
        "acos" => "tsl_acos",
        "atan" => "tsl_atan",
        _ => return None,
    })
}

fn native_name(name: &str, width: usize) -> &'static str {
    match (name, width) {
        ("noise", 1) => "tsl_noise1",
        ("noise", 2) => "tsl_noise2",
        ("noise", _) => "tsl_noise3",
        ("pnoise", 1) => "tsl_pnoise1",
        ("pnoise", 2) => "tsl_pnoise2",
        ("pnoise", _) => "tsl_pnoise3",
        ("cellnoise", 1) => "tsl_cellnoise1",
        ("cellnoise", 2) => "tsl_cellnoise2",
        _ => "tsl_cellnoise3",
    }
}

fn identity(b: &mut Builder) -> Vec<Value> {
    let one = b.f(1.0);
    diag(b, [one, one, one])
}

fn diag(b: &mut Builder, d: [Value; 3]) -> Vec<Value> {
    let zero = b.f(0.0);
    let mut m = vec![zero; 12];
    m[0] = d[0];
    m[5] = d[1];
    m[10] = d[2];
    m
}

/// Rodrigues' rotation by `deg` degrees about `axis`.
fn rotation(b: &mut Builder, deg: Value, axis: &[Value]) -> Vec<Value> {
    let a = b.normalize(axis);
    let k = b.f(std::f32::consts::PI / 180.0);
    let rad = b.fmul(deg, k);
    let (s, c) = (b.call("tsl_sin", vec![rad]), b.call("tsl_cos", vec![rad]));
    let one = b.f(1.0);
    let t = b.fsub(one, c);
    let zero = b.f(0.0);
    let mut m = vec![zero; 12];
    for r in 0..3 {
        for col in 0..3 {
            let aa = b.fmul(a[r], a[col]);
            let mut v = b.fmul(t, aa);
            if r == col {
                v = b.fadd(v, c);
            } else {
                // The cross-product term: +/- sin times the third axis component.
                let third = 3 - r - col;
                let sign = if (r + 1) % 3 == col { -1.0 } else { 1.0 };
                let sv = b.f(sign);
                let term = b.fmul(s, a[third]);
                let term = b.fmul(sv, term);
                v = b.fadd(v, term);
            }
            m[r * 4 + col] = v;
        }
    }
    m
}

fn refract(b: &mut Builder, i: &[Value], n: &[Value], eta: Value) -> Vec<Value> {
    let d = b.dot(n, i);
    let one = b.f(1.0);
    let dd = b.fmul(d, d);
    let sin2 = b.fsub(one, dd);
    let ee = b.fmul(eta, eta);
    let e_sin2 = b.fmul(ee, sin2);
    let k = b.fsub(one, e_sin2);
    let zero = b.f(0.0);
    let tir = b.flt(k, zero);
    let root = b.un(UnOp::Sqrt, k);
    let ed = b.fmul(eta, d);
    let coef = b.fadd(ed, root);
    (0..3)
        .map(|c| {
            let a = b.fmul(eta, i[c]);
            let m = b.fmul(coef, n[c]);
            let r = b.fsub(a, m);
            b.select(tir, zero, r)
        })
        .collect()
}

/// HSV (all in [0, 1]) to RGB, the standard six-sector formula.
fn hsv_to_rgb(b: &mut Builder, h: Value, s: Value, v: Value) -> [Value; 3] {
    let six = b.f(6.0);
    let one = b.f(1.0);
    let hf = b.un(UnOp::Floor, h);
    let h = b.fsub(h, hf);
    let h6 = b.fmul(h, six);
    let sector = b.un(UnOp::Floor, h6);
    let f = b.fsub(h6, sector);
    let one_s = b.fsub(one, s);
    let p = b.fmul(v, one_s);
    let sf = b.fmul(s, f);
    let one_sf = b.fsub(one, sf);
    let q = b.fmul(v, one_sf);
    let one_f = b.fsub(one, f);
    let s1f = b.fmul(s, one_f);
    let one_s1f = b.fsub(one, s1f);
    let t = b.fmul(v, one_s1f);
    let table = [[v, t, p], [q, v, p], [p, v, t], [p, q, v], [t, p, v], [v, p, q]];
    let mut out = table[5];
    for (k, row) in table.iter().enumerate().take(5).rev() {
        let kv = b.f(k as f32);
        let hit = b.feq(sector, kv);
        for c in 0..3 {
            out[c] = b.select(hit, row[c], out[c]);
        }
    }
    out
}

fn xyz_rows_to_rgb(b: &mut Builder, xyz: [Value; 3]) -> [Value; 3] {
    // Columns of the XYZ → linear sRGB matrix, taken from the color module.
    let cols = [
        color::xyz_to_linear_srgb([1.0, 0.0, 0.0]),
        color::xyz_to_linear_srgb([0.0, 1.0, 0.0]),
        color::xyz_to_linear_srgb([0.0, 0.0, 1.0]),
    ];
    let mut out = [Value(0); 3];
    for (r, o) in out.iter_mut().enumerate() {
        let w = [cols[0][r], cols[1][r], cols[2][r]];
        *o = b.weighted(&w, &xyz);
    }
    out
}

/// Smits (1999): how much of each of the seven basis spectra (white, cyan,
/// magenta, yellow, red, green, blue) to add for an RGB triple. The same
/// case analysis as `color::smits_coefficients`, as selects.
fn smits_coefficients(b: &mut Builder, rgb: [Value; 3]) -> Vec<Value> {
    let [r, g, bl] = rgb;
    let zero = b.f(0.0);
    let mut coef = vec![zero; 7];
    // Case: red is smallest → white r, then cyan and blue/green.
    let c_r = {
        let rg = b.bin(BinOp::FLe, r, g);
        let rb = b.bin(BinOp::FLe, r, bl);
        b.and(rg, rb)
    };
    let c_g = {
        let gr = b.bin(BinOp::FLe, g, r);
        let gb = b.bin(BinOp::FLe, g, bl);
        b.and(gr, gb)
    };
    // Otherwise blue is smallest.
    let cases = [
        // (smallest, a, b, white, two-channel basis index, a-only, b-only)
        (r, g, bl, 1usize, 5usize, 6usize),
        (g, r, bl, 2, 4, 6),
        (bl, r, g, 3, 4, 5),
    ];
    let mut per_case: Vec<Vec<Value>> = Vec::new();
    for (min, a, c, pair, a_only, c_only) in cases {
        let mut k = vec![zero; 7];
        k[0] = min;
        let a_le_c = b.bin(BinOp::FLe, a, c);
        let da = b.fsub(a, min);
        let dc = b.fsub(c, min);
        let ca = b.fsub(c, a);
        let ac = b.fsub(a, c);
        // The pair colour takes the smaller excess; the remainder goes to the
        // single-channel basis of the larger channel.
        k[pair] = b.select(a_le_c, da, dc);
        k[c_only] = b.select(a_le_c, ca, zero);
        k[a_only] = b.select(a_le_c, zero, ac);
        per_case.push(k);
    }
    for i in 0..7 {
        let gb = b.select(c_g, per_case[1][i], per_case[2][i]);
        coef[i] = b.select(c_r, per_case[0][i], gb);
    }
    coef
}

/// Interpolation weights of `n` knots at `t` in [0, 1]: piecewise linear,
/// or uniform Catmull-Rom with the end knots repeated.
fn blend_weights(b: &mut Builder, t: Value, spline: Value, n: usize) -> Vec<Value> {
    if n == 0 {
        return Vec::new();
    }
    if n == 1 {
        return vec![b.f(1.0)];
    }
    let (zero, one) = (b.f(0.0), b.f(1.0));
    let t = b.clamp(t, zero, one);
    let span = b.f((n - 1) as f32);
    let x = b.fmul(t, span);
    let max_seg = b.f((n - 2) as f32);
    let fl = b.un(UnOp::Floor, x);
    let seg = b.fmin(fl, max_seg);
    let f = b.fsub(x, seg);
    let seg_i = b.un(UnOp::FToI, seg);
    // Catmull-Rom basis for knots seg-1 .. seg+2.
    let half = b.f(0.5);
    let f2 = b.fmul(f, f);
    let f3 = b.fmul(f2, f);
    let poly = |b: &mut Builder, c3: f32, c2: f32, c1: f32, c0: f32| {
        let (a3, a2, a1, a0) = (b.f(c3), b.f(c2), b.f(c1), b.f(c0));
        let t3 = b.fmul(a3, f3);
        let t2 = b.fmul(a2, f2);
        let t1 = b.fmul(a1, f);
        let s = b.fadd(t3, t2);
        let s = b.fadd(s, t1);
        let s = b.fadd(s, a0);
        b.fmul(half, s)
    };
    let basis = [
        poly(b, -1.0, 2.0, -1.0, 0.0),
        poly(b, 3.0, -5.0, 0.0, 2.0),
        poly(b, -3.0, 4.0, 1.0, 0.0),
        poly(b, 1.0, -1.0, 0.0, 0.0),
    ];
    let one_f = b.fsub(one, f);
    let last = (n - 1) as i32;
    (0..n)
        .map(|k| {
            let kv = b.i(k as i32);
            // Linear: the two knots around t.
            let at_seg = b.bin(BinOp::IEq, seg_i, kv);
            let next = b.i(1);
            let seg1 = b.bin(BinOp::IAdd, seg_i, next);
            let at_next = b.bin(BinOp::IEq, seg1, kv);
            let w_seg = b.select(at_seg, one_f, zero);
            let w_next = b.select(at_next, f, zero);
            let linear = b.fadd(w_seg, w_next);
            // Spline: knots seg-1 .. seg+2, indices clamped to the ends.
            let mut spl = zero;
            for (j, bj) in basis.iter().enumerate() {
                let off = b.i(j as i32 - 1);
                let idx = b.bin(BinOp::IAdd, seg_i, off);
                let lo = b.i(0);
                let hi = b.i(last);
                let below = b.bin(BinOp::ILt, idx, lo);
                let idx = b.select(below, lo, idx);
                let above = b.bin(BinOp::ILt, hi, idx);
                let idx = b.select(above, hi, idx);
                let hit = b.bin(BinOp::IEq, idx, kv);
                let term = b.select(hit, *bj, zero);
                spl = b.fadd(spl, term);
            }
            b.select(spline, spl, linear)
        })
        .collect()
}

// ---------------------------------------------------------------- materials

impl<'p> Lowerer<'p> {
    /// Binds a material definition's parameters: given arguments (lowered in
    /// the tree's context) or defaults.
    fn instance_from_def(
        &mut self,
        b: &mut Builder,
        sym: Symbol,
        args: &'p [ast::Arg],
        ctx: &Ctx,
        env: &Rc<HashMap<String, Val<'p>>>,
        env_prelude: bool,
    ) -> Rc<Instance<'p>> {
        let Item::Material(def) = self.item(sym) else {
            return Rc::new(Instance { id: 0, def: empty_def(), params: Vec::new(), in_prelude: false });
        };
        let params: Vec<(&str, Ty)> = def.params.iter().map(|p| (p.name.name.as_str(), Ty::from_ast(&p.ty))).collect();
        let bound = bind_args(&params, args);
        let mut values = Vec::new();
        for (p, a) in def.params.iter().zip(bound) {
            let ty = Ty::from_ast(&p.ty);
            let v = match a {
                Some(a) => {
                    let mut fr = self.env_frame(env, env_prelude);
                    self.expr_as(b, &mut fr, ctx, a, &ty)
                }
                None => match &p.default {
                    Some(d) => {
                        let mut fr = self.new_frame(self.is_prelude(sym), HashSet::default());
                        self.expr_as(b, &mut fr, ctx, d, &ty)
                    }
                    None => self.zero_value(b, &ty),
                },
            };
            values.push((p.name.name.clone(), v));
        }
        let id = self.id();
        Rc::new(Instance { id, def, params: values, in_prelude: self.is_prelude(sym) })
    }

    /// A frame whose only scope is a template environment.
    fn env_frame(&self, env: &Rc<HashMap<String, Val<'p>>>, in_prelude: bool) -> Frame<'p> {
        let mut fr = self.new_frame(in_prelude, HashSet::default());
        fr.scopes[0] = env.iter().map(|(k, v)| (k.clone(), Binding::Val(v.clone()))).collect();
        fr
    }

    /// One interface method of a material instance: its own body, or the
    /// documented default.
    fn instance_method(
        &mut self,
        b: &mut Builder,
        inst: &Rc<Instance<'p>>,
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let key = MemoKey::Method { instance: inst.id, method: im.name, ctx: ctx.id, args: args.concat() };
        if let Some(v) = b.lookup(&key) {
            return v;
        }
        let result = match inst.def.methods.iter().find(|m| m.name.name == im.name) {
            Some(m) => {
                let mut fr = self.new_frame(inst.in_prelude, assigned_names(&m.body));
                fr.material = Some(inst.clone());
                for (name, v) in &inst.params {
                    fr.scopes[0].insert(name.clone(), Binding::Val(v.clone()));
                }
                fr.scopes.push(HashMap::default());
                for (p, a) in m.params.iter().zip(args) {
                    let ty = Ty::from_ast(&p.ty);
                    self.bind(b, &mut fr, &p.name.name, Val::Lanes(a.clone()), &ty);
                }
                let v = self.body_with_return(b, &mut fr, ctx, &m.body, &im.ret);
                self.lanes(b, v, &im.ret)
            }
            None => self.default_method(b, inst, im, args, ctx),
        };
        b.remember(key, result.clone());
        result
    }

    fn default_method(
        &mut self,
        b: &mut Builder,
        inst: &Rc<Instance<'p>>,
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        match im.name {
            "refraction_index" => {
                let one = b.f(1.0);
                vec![one; self.lanes]
            }
            "ambient" => {
                let diffuse = interface_method("diffuse").expect("diffuse is an interface method");
                let d = self.instance_method(b, inst, diffuse, &[], ctx);
                b.map2(BinOp::FMul, &args[0], &d)
            }
            "absorption" => args[0].clone(),
            "normal" => self.global(b, ctx, "N").unwrap_or_default(),
            "opaque" => vec![b.b(true)],
            "sample" => self.default_sample(b, inst, args, ctx),
            "pdf" => self.default_pdf(b, inst, args, ctx),
            _ => b.zeros(self.lanes_of(&im.ret)),
        }
    }

    /// One interface method of a material expression (a texture tree).
    fn mat_method(
        &mut self,
        b: &mut Builder,
        mat: &Mat<'p>,
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let e = mat.expr;
        match &e.kind {
            ExprKind::Name(n) => {
                if let Some(Val::Material(m)) = mat.env.get(n) {
                    let m = m.clone();
                    return self.mat_method(b, &m, im, args, ctx);
                }
                match self.symbol(mat.in_prelude, n) {
                    Some(sym) => match self.item(sym) {
                        Item::MaterialTree(t) => {
                            let m = Mat {
                                expr: &t.body,
                                env: Rc::new(HashMap::default()),
                                in_prelude: self.is_prelude(sym),
                            };
                            self.mat_method(b, &m, im, args, ctx)
                        }
                        Item::Material(_) => {
                            let inst = self.instance_from_def(b, sym, &[], ctx, &mat.env, mat.in_prelude);
                            self.instance_method(b, &inst, im, args, ctx)
                        }
                        _ => b.zeros(self.lanes_of(&im.ret)),
                    },
                    None => b.zeros(self.lanes_of(&im.ret)),
                }
            }
            ExprKind::Ternary { cond, then_expr, else_expr } => {
                let mut fr = self.env_frame(&mat.env, mat.in_prelude);
                let c = self.expr(b, &mut fr, ctx, cond);
                let c = self.scalar(b, c);
                let tys = self.words(&im.ret);
                let (m1, m2) = (
                    Mat { expr: then_expr, env: mat.env.clone(), in_prelude: mat.in_prelude },
                    Mat { expr: else_expr, env: mat.env.clone(), in_prelude: mat.in_prelude },
                );
                b.branch(
                    self,
                    c,
                    &tys,
                    |b, me| me.mat_method(b, &m1, im, args, ctx),
                    |b, me| me.mat_method(b, &m2, im, args, ctx),
                )
            }
            ExprKind::Call { callee, args: call_args } => {
                if let Some(sym) = self.program.resolutions.get(&callee.span).copied() {
                    return match self.item(sym) {
                        Item::Material(_) => {
                            let inst = self.instance_from_def(b, sym, call_args, ctx, &mat.env, mat.in_prelude);
                            self.instance_method(b, &inst, im, args, ctx)
                        }
                        Item::MaterialTree(t) => {
                            let env = self.template_env(b, t, call_args, mat, ctx);
                            let m = Mat { expr: &t.body, env, in_prelude: self.is_prelude(sym) };
                            self.mat_method(b, &m, im, args, ctx)
                        }
                        _ => b.zeros(self.lanes_of(&im.ret)),
                    };
                }
                self.tree_node(b, mat, &callee.name, call_args, im, args, ctx)
            }
            _ => b.zeros(self.lanes_of(&im.ret)),
        }
    }

    /// Binds a template's parameters: materials stay expressions, values
    /// are lowered now.
    fn template_env(
        &mut self,
        b: &mut Builder,
        t: &'p ast::MaterialTree,
        call_args: &'p [ast::Arg],
        mat: &Mat<'p>,
        ctx: &Ctx,
    ) -> Rc<HashMap<String, Val<'p>>> {
        let params = t.params.as_deref().unwrap_or(&[]);
        let typed: Vec<(&str, Ty)> = params.iter().map(|p| (p.name.name.as_str(), Ty::from_ast(&p.ty))).collect();
        let bound = bind_args(&typed, call_args);
        let mut env = HashMap::default();
        for (p, a) in params.iter().zip(bound) {
            let ty = Ty::from_ast(&p.ty);
            let (expr, source_env, prelude) = match (a, &p.default) {
                (Some(a), _) => (a, mat.env.clone(), mat.in_prelude),
                (None, Some(d)) => (d, Rc::new(HashMap::default()), mat.in_prelude),
                (None, None) => continue,
            };
            let v = if ty == Ty::Material {
                Val::Material(Mat { expr, env: source_env, in_prelude: prelude })
            } else {
                let mut fr = self.env_frame(&source_env, prelude);
                self.expr_as(b, &mut fr, ctx, expr, &ty)
            };
            env.insert(p.name.name.clone(), v);
        }
        Rc::new(env)
    }

    /// Whether method `im` of the material expression is the interface
    /// default everywhere in its tree (no leaf defines it and no node
    /// changes it). Conservative: `false` when unsure.
    fn uses_default(&self, mat: &Mat<'p>, im: &'static InterfaceMethod, depth: u32) -> bool {
        if depth > 64 {
            return false;
        }
        let defines = |def: &ast::MaterialDef| def.methods.iter().any(|m| m.name.name == im.name);
        match &mat.expr.kind {
            ExprKind::Name(n) => {
                if let Some(Val::Material(m)) = mat.env.get(n) {
                    return self.uses_default(m, im, depth + 1);
                }
                match self.symbol(mat.in_prelude, n) {
                    Some(sym) => match self.item(sym) {
                        Item::MaterialTree(t) if t.params.is_none() => {
                            let m = Mat {
                                expr: &t.body,
                                env: Rc::new(HashMap::default()),
                                in_prelude: self.is_prelude(sym),
                            };
                            self.uses_default(&m, im, depth + 1)
                        }
                        Item::Material(def) => !defines(def),
                        _ => false,
                    },
                    None => false,
                }
            }
            ExprKind::Ternary { then_expr, else_expr, .. } => [then_expr, else_expr].iter().all(|e| {
                self.uses_default(&Mat { expr: e, env: mat.env.clone(), in_prelude: mat.in_prelude }, im, depth + 1)
            }),
            ExprKind::Call { callee, args: call_args } => {
                if let Some(sym) = self.program.resolutions.get(&callee.span).copied() {
                    return match self.item(sym) {
                        Item::Material(def) => !defines(def),
                        Item::MaterialTree(t) => {
                            // A template: its body, with its material
                            // parameters bound to the call's arguments.
                            let params = t.params.as_deref().unwrap_or(&[]);
                            let typed: Vec<(&str, Ty)> =
                                params.iter().map(|p| (p.name.name.as_str(), Ty::from_ast(&p.ty))).collect();
                            let mut env = HashMap::default();
                            for (p, a) in params.iter().zip(bind_args(&typed, call_args)) {
                                if Ty::from_ast(&p.ty) != Ty::Material {
                                    continue;
                                }
                                let bound = match (a, &p.default) {
                                    (Some(a), _) => Mat { expr: a, env: mat.env.clone(), in_prelude: mat.in_prelude },
                                    (None, Some(d)) => Mat {
                                        expr: d,
                                        env: Rc::new(HashMap::default()),
                                        in_prelude: self.is_prelude(sym),
                                    },
                                    (None, None) => continue,
                                };
                                env.insert(p.name.name.clone(), Val::Material(bound));
                            }
                            let body = Mat { expr: &t.body, env: Rc::new(env), in_prelude: self.is_prelude(sym) };
                            self.uses_default(&body, im, depth + 1)
                        }
                        _ => false,
                    };
                }
                // Only `spline:` (a value) may be named; a named material
                // child, or `only:` (which changes where a method comes
                // from), is not analysed.
                if call_args.iter().any(|a| a.name.as_ref().is_some_and(|n| n.name != "spline")) {
                    return false;
                }
                let positional: Vec<&'p ast::Arg> = call_args.iter().filter(|a| a.name.is_none()).collect();
                let child = |k: usize| {
                    positional.get(k).map(|a| Mat { expr: &a.value, env: mat.env.clone(), in_prelude: mat.in_prelude })
                };
                let all = |items: Vec<Mat<'p>>| {
                    !items.is_empty() && items.iter().all(|m| self.uses_default(m, im, depth + 1))
                };
                match callee.name.as_str() {
                    "mix" => all([child(1), child(2)].into_iter().flatten().collect()),
                    "blend" | "select" => all(self.material_items(child(1).map(|m| m.expr), mat)),
                    // bump changes the normal; transform moves the point.
                    "bump" => im.name != "normal" && all(child(2).into_iter().collect()),
                    "transform" => all(child(1).into_iter().collect()),
                    // scale keeps a black default black.
                    "scale" => {
                        matches!(
                            im.name,
                            "reflection"
                                | "refraction"
                                | "emission"
                                | "diffuse"
                                | "reflection_dir"
                                | "refraction_dir"
                                | "normal"
                                | "opaque"
                        ) && all(child(1).into_iter().collect())
                    }
                    _ => false,
                }
            }
            _ => false,
        }
    }

    /// The interface default of a method that needs no material to compute
    /// (every default but `ambient`, which reads `diffuse`).
    fn plain_default(
        &mut self,
        b: &mut Builder,
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Option<Vec<Value>> {
        Some(match im.name {
            "refraction_index" => {
                let one = b.f(1.0);
                vec![one; self.lanes]
            }
            "absorption" => args[0].clone(),
            "normal" => self.global(b, ctx, "N").unwrap_or_default(),
            "opaque" => vec![b.b(true)],
            // These read the material's other methods.
            "ambient" | "sample" | "pdf" => return None,
            _ => b.zeros(self.lanes_of(&im.ret)),
        })
    }

    /// The texture-tree nodes.
    #[allow(clippy::too_many_arguments)]
    fn tree_node(
        &mut self,
        b: &mut Builder,
        mat: &Mat<'p>,
        node: &str,
        call_args: &'p [ast::Arg],
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let Some(spec) = crate::check::BUILTINS.iter().find(|s| s.name == node) else {
            return b.zeros(self.lanes_of(&im.ret));
        };
        // A method no child defines is the default whatever the weights:
        // the weights (often noise) need not be computed at all.
        if matches!(node, "mix" | "blend" | "select") && self.uses_default(mat, im, 0) {
            if let Some(v) = self.plain_default(b, im, args, ctx) {
                return v;
            }
            // The default ambient, light * diffuse(), is linear: blending the
            // children's is the node's own, from the node's diffuse.
            if im.name == "ambient"
                && let Some(diffuse) = interface_method("diffuse")
            {
                let d = self.mat_method(b, mat, diffuse, &[], ctx);
                return b.map2(BinOp::FMul, &args[0], &d);
            }
        }
        let params: Vec<(&str, Ty)> = spec.params.iter().map(|p| (p.trim_end_matches('?'), Ty::Error)).collect();
        let bound = bind_args(&params, call_args);
        let child = |k: usize| {
            bound.get(k).copied().flatten().map(|e| Mat { expr: e, env: mat.env.clone(), in_prelude: mat.in_prelude })
        };
        let mut fr = self.env_frame(&mat.env, mat.in_prelude);
        let mut scalar = |me: &mut Self, b: &mut Builder, k: usize, ctx: &Ctx| -> Value {
            match bound.get(k).copied().flatten() {
                Some(e) => {
                    let v = me.expr_as(b, &mut fr, ctx, e, &Ty::Float);
                    me.scalar(b, v)
                }
                None => b.f(0.0),
            }
        };
        let tys = self.words(&im.ret);
        match node {
            "mix" => {
                let (Some(a), Some(c)) = (child(1), child(2)) else { return b.zeros(tys.len()) };
                if let Some(ExprKind::Str(only)) = bound.get(3).copied().flatten().map(|e| &e.kind) {
                    // A partial blend samples as its first child.
                    if im.name == "sample" {
                        return self.sample_as_first(b, mat, &a, args, ctx);
                    }
                    if im.name == "pdf" || only != im.name {
                        return self.mat_method(b, &a, im, args, ctx);
                    }
                }
                let t = scalar(self, b, 0, ctx);
                if matches!(im.name, "sample" | "pdf") {
                    let one = b.f(1.0);
                    let weights = [b.fsub(one, t), t];
                    let items = [a, c];
                    return if im.name == "sample" {
                        self.sample_mixture(b, mat, &weights, &items, args, ctx)
                    } else {
                        self.pdf_mixture(b, &weights, &items, args, ctx)
                    };
                }
                self.mix_children(b, t, &a, &c, im, args, ctx)
            }
            "blend" => {
                let t = scalar(self, b, 0, ctx);
                let spline = match bound.get(2).copied().flatten() {
                    Some(e) => {
                        let mut fr = self.env_frame(&mat.env, mat.in_prelude);
                        let v = self.expr(b, &mut fr, ctx, e);
                        self.scalar(b, v)
                    }
                    None => b.b(false),
                };
                let items = self.material_items(bound.get(1).copied().flatten(), mat);
                let w = blend_weights(b, t, spline, items.len());
                match im.name {
                    "sample" => self.sample_mixture(b, mat, &w, &items, args, ctx),
                    "pdf" => self.pdf_mixture(b, &w, &items, args, ctx),
                    _ => self.weighted_children(b, &w, &items, im, args, ctx),
                }
            }
            "select" => {
                let i = match bound.first().copied().flatten() {
                    Some(e) => {
                        let mut fr = self.env_frame(&mat.env, mat.in_prelude);
                        let v = self.expr(b, &mut fr, ctx, e);
                        self.scalar(b, v)
                    }
                    None => b.i(0),
                };
                let items = self.material_items(bound.get(1).copied().flatten(), mat);
                if items.is_empty() {
                    return b.zeros(tys.len());
                }
                let i = self.clamp_index(b, i, items.len() as i32);
                self.select_child(b, i, &items, 0, im, args, ctx)
            }
            "bump" => {
                let Some(m) = child(2) else { return b.zeros(tys.len()) };
                let amount = scalar(self, b, 1, ctx);
                let Some(height) = bound.first().copied().flatten() else { return b.zeros(tys.len()) };
                let bumped = self.bump_ctx(b, height, mat, amount, ctx);
                self.mat_method(b, &m, im, args, &bumped)
            }
            "scale" => {
                let Some(m) = child(1) else { return b.zeros(tys.len()) };
                let inner = self.mat_method(b, &m, im, args, ctx);
                if !matches!(im.name, "reflection" | "refraction" | "emission" | "ambient" | "diffuse" | "sample") {
                    return inner;
                }
                let c = match bound.first().copied().flatten() {
                    Some(e) => {
                        let mut fr = self.env_frame(&mat.env, mat.in_prelude);
                        let v = self.expr(b, &mut fr, ctx, e);
                        self.lanes(b, v, &Ty::Color)
                    }
                    None => return inner,
                };
                if im.name == "sample" {
                    return self.scale_sample(b, &inner, &c);
                }
                b.map2(BinOp::FMul, &inner, &c)
            }
            "transform" => {
                let Some(m) = child(1) else { return b.zeros(tys.len()) };
                let xf = match bound.first().copied().flatten() {
                    Some(e) => {
                        let mut fr = self.env_frame(&mat.env, mat.in_prelude);
                        let v = self.expr(b, &mut fr, ctx, e);
                        self.lanes(b, v, &Ty::Matrix)
                    }
                    None => identity(b),
                };
                let moved = self.transform_ctx(b, &xf, ctx);
                self.mat_method(b, &m, im, args, &moved)
            }
            _ => b.zeros(tys.len()),
        }
    }

    fn material_items(&self, e: Option<&'p Expr>, mat: &Mat<'p>) -> Vec<Mat<'p>> {
        match e.map(|e| &e.kind) {
            Some(ExprKind::Array(items)) => {
                items.iter().map(|it| Mat { expr: it, env: mat.env.clone(), in_prelude: mat.in_prelude }).collect()
            }
            _ => Vec::new(),
        }
    }

    /// `mix`: at t = 0 only `a` runs, at t = 1 only `b`; between, every
    /// result blends linearly (normals are renormalised; a blend is opaque
    /// when both children are).
    #[allow(clippy::too_many_arguments)]
    fn mix_children(
        &mut self,
        b: &mut Builder,
        t: Value,
        a: &Mat<'p>,
        c: &Mat<'p>,
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let (zero, one) = (b.f(0.0), b.f(1.0));
        let is_zero = b.feq(t, zero);
        let is_one = b.feq(t, one);
        let need_a = b.not(is_one);
        let need_c = b.not(is_zero);
        if im.ret == Ty::Bool {
            let yes = b.b(true);
            let oa = b.guarded(self, need_a, vec![yes], |b, me| me.mat_method(b, a, im, args, ctx));
            let oc = b.guarded(self, need_c, vec![yes], |b, me| me.mat_method(b, c, im, args, ctx));
            return vec![b.and(oa[0], oc[0])];
        }
        let n = self.lanes_of(&im.ret);
        let zeros = b.zeros(n);
        let va = b.guarded(self, need_a, zeros.clone(), |b, me| me.mat_method(b, a, im, args, ctx));
        let vc = b.guarded(self, need_c, zeros, |b, me| me.mat_method(b, c, im, args, ctx));
        if va == vc {
            // Both children agree (typically the same constant): no blend.
            return va;
        }
        let blended = b.lerp(t, &va, &vc);
        if im.name == "normal" { b.normalize(&blended) } else { blended }
    }

    /// `blend`: Σ w_k child_k, evaluating only children with nonzero weight.
    fn weighted_children(
        &mut self,
        b: &mut Builder,
        w: &[Value],
        items: &[Mat<'p>],
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let zero = b.f(0.0);
        if im.ret == Ty::Bool {
            let mut acc = b.b(true);
            for (wk, item) in w.iter().zip(items) {
                let used = b.feq(*wk, zero);
                let used = b.not(used);
                let yes = b.b(true);
                let o = b.guarded(self, used, vec![yes], |b, me| me.mat_method(b, item, im, args, ctx));
                acc = b.and(acc, o[0]);
            }
            return vec![acc];
        }
        let n = self.lanes_of(&im.ret);
        let mut results = Vec::new();
        for (wk, item) in w.iter().zip(items) {
            let used = b.feq(*wk, zero);
            let used = b.not(used);
            let zeros = b.zeros(n);
            results.push(b.guarded(self, used, zeros, |b, me| me.mat_method(b, item, im, args, ctx)));
        }
        if results.windows(2).all(|r| r[0] == r[1]) {
            // All children agree: the weights (which sum to one) change nothing.
            return results.pop().unwrap_or_else(|| b.zeros(n));
        }
        let mut acc = b.zeros(n);
        for (wk, v) in w.iter().zip(&results) {
            let s = b.scale(v, *wk);
            acc = b.map2(BinOp::FAdd, &acc, &s);
        }
        if im.name == "normal" { b.normalize(&acc) } else { acc }
    }

    #[allow(clippy::too_many_arguments)]
    fn select_child(
        &mut self,
        b: &mut Builder,
        i: Value,
        items: &[Mat<'p>],
        k: usize,
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        if k + 1 == items.len() {
            return self.mat_method(b, &items[k], im, args, ctx);
        }
        let kv = b.i(k as i32);
        let hit = b.bin(BinOp::IEq, i, kv);
        let tys = self.words(&im.ret);
        b.branch(
            self,
            hit,
            &tys,
            |b, me| me.mat_method(b, &items[k], im, args, ctx),
            |b, me| me.select_child(b, i, items, k + 1, im, args, ctx),
        )
    }

    fn with_overrides(&mut self, ctx: &Ctx, changes: Vec<(&'static str, Vec<Value>)>) -> Ctx {
        let mut map = (*ctx.overrides).clone();
        map.extend(changes);
        let id = self.id();
        Ctx { id, overrides: Rc::new(map) }
    }

    /// `transform`: the subtree sees P, Pl, (u, v) and the tangents mapped.
    fn transform_ctx(&mut self, b: &mut Builder, m: &[Value], ctx: &Ctx) -> Ctx {
        let mut changes = Vec::new();
        for name in ["P", "Pl"] {
            let p = self.global(b, ctx, name).unwrap_or_default();
            changes.push((name, transform_point(b, m, &p, true)));
        }
        for name in ["dPdu", "dPdv"] {
            let d = self.global(b, ctx, name).unwrap_or_default();
            changes.push((name, transform_point(b, m, &d, false)));
        }
        let u = self.global(b, ctx, "u").unwrap_or_default();
        let v = self.global(b, ctx, "v").unwrap_or_default();
        let zero = b.f(0.0);
        let uv = transform_point(b, m, &[u[0], v[0], zero], true);
        changes.push(("u", vec![uv[0]]));
        changes.push(("v", vec![uv[1]]));
        self.with_overrides(ctx, changes)
    }

    /// `bump`: the normal tilted by the gradient of `height` along the
    /// tangents, estimated by forward differences; the subtree sees it as N.
    fn bump_ctx(&mut self, b: &mut Builder, height: &'p Expr, mat: &Mat<'p>, amount: Value, ctx: &Ctx) -> Ctx {
        let h_at = |me: &mut Self, b: &mut Builder, c: &Ctx| -> Value {
            let mut fr = me.env_frame(&mat.env, mat.in_prelude);
            let v = me.expr_as(b, &mut fr, c, height, &Ty::Float);
            me.scalar(b, v)
        };
        let g = |me: &mut Self, b: &mut Builder, name: &str| me.global(b, ctx, name).unwrap_or_default();
        let (p, pl, u, v) = (g(self, b, "P"), g(self, b, "Pl"), g(self, b, "u"), g(self, b, "v"));
        let (dpdu, dpdv, n) = (g(self, b, "dPdu"), g(self, b, "dPdv"), g(self, b, "N"));
        let delta = b.f(BUMP_DELTA);
        let h0 = h_at(self, b, ctx);
        let mut gradient = Vec::new();
        for (tangent, param, pname) in [(&dpdu, &u, "u"), (&dpdv, &v, "v")] {
            let step = b.scale(tangent, delta);
            let moved_p = b.map2(BinOp::FAdd, &p, &step);
            let moved_pl = b.map2(BinOp::FAdd, &pl, &step);
            let moved_param = b.fadd(param[0], delta);
            let shifted = self.with_overrides(ctx, vec![("P", moved_p), ("Pl", moved_pl), (pname, vec![moved_param])]);
            let h = h_at(self, b, &shifted);
            let dh = b.fsub(h, h0);
            gradient.push(b.fdiv(dh, delta));
        }
        // dp/du' = dPdu + amount dh/du N (likewise v); N' = their cross product.
        let ku = b.fmul(amount, gradient[0]);
        let kv = b.fmul(amount, gradient[1]);
        let nu = b.scale(&n, ku);
        let nv = b.scale(&n, kv);
        let du = b.map2(BinOp::FAdd, &dpdu, &nu);
        let dv = b.map2(BinOp::FAdd, &dpdv, &nv);
        let c = b.cross(&du, &dv);
        let c = b.normalize(&c);
        // Keep the side of the original normal; fall back to it when the
        // tangents are degenerate.
        let zero = b.f(0.0);
        let facing = b.dot(&c, &n);
        let flip = b.flt(facing, zero);
        let len = b.dot(&c, &c);
        let degenerate = b.feq(len, zero);
        let new_n: Vec<Value> = (0..3)
            .map(|k| {
                let neg = b.un(UnOp::FNeg, c[k]);
                let oriented = b.select(flip, neg, c[k]);
                b.select(degenerate, n[k], oriented)
            })
            .collect();
        self.with_overrides(ctx, vec![("N", new_n)])
    }
}

/// The step of the forward differences in `bump`, in (u, v) units.
pub const BUMP_DELTA: f32 = 1.0 / 1024.0;

fn empty_def() -> &'static ast::MaterialDef {
    static EMPTY: std::sync::OnceLock<ast::MaterialDef> = std::sync::OnceLock::new();
    EMPTY.get_or_init(|| ast::MaterialDef {
        name: ast::Ident { name: String::new(), span: Span::default() },
        params: Vec::new(),
        methods: Vec::new(),
        span: Span::default(),
    })
}
