//! Building one IR function: instruction lists and structured control
//! flow, constant folding, algebraic identities and scoped value numbering,
//! and arithmetic over lanes. It knows nothing of the syntax tree: the
//! lowering drives it.

use super::*;
use crate::texture::Sampler;
use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};
use std::sync::Arc;

/// Builds one IR function: instruction lists, constant folding and scoped
/// value numbering.
pub(crate) struct Builder {
    pub(crate) func: Function,
    /// Global loads, hoisted so they dominate every use.
    pub(crate) prologue: Vec<Inst>,
    pub(crate) stack: Vec<Vec<Inst>>,
    pub(crate) consts: HashMap<Value, Const>,
    pub(crate) memo: super::memo::Memo,
    pub(crate) globals: HashMap<u32, Value>,
    /// Values defined in the prologue (constants, global loads): they
    /// dominate everything.
    pub(crate) in_prologue: HashSet<Value>,
    /// How many more noise sites are expanded inline; later ones call the
    /// native (see [`NOISE_INLINE_SITES`]).
    pub(crate) noise_budget: u32,
    /// The id of each coordinate context made in this function, by its
    /// parent and its changes: the same `bump` or `transform` lowered for
    /// two methods gets one id, so their generator calls share the memo.
    pub(crate) contexts: HashMap<(u32, GlobalChanges), u32>,
    /// In a hit group: what is per-call, for [`Builder::hoisted`].
    pub(crate) hoisting: Option<super::hoist::Hoisting>,
    /// Conditions known inside the scope being built (innermost last):
    /// a hit group lowers all its methods under one branch of a `select`,
    /// and each method's own branch on the same condition folds.
    pub(crate) facts: Vec<(Value, bool)>,
    /// Set once the function has defined more than [`MAX_FUNCTION_VALUES`]
    /// values: lowering then stops inlining and reports the entry point.
    pub(crate) too_large: bool,
}

/// The most values one IR function may define while it is lowered (2^20,
/// 1,048,576; folded constants count), checked as they are defined.
/// Inlining copies a function or a material at every use that cannot
/// share the first copy's code (other arguments, another coordinate
/// context, another lobe to sample), so a small program can ask for
/// exponentially many; past this bound lowering stops and reports the
/// entry point instead of allocating gigabytes (reaching it took 2-3 s
/// and 250-350 MB in release builds). The largest entry of the examples, texture_tree's
/// `cube.sample`, defines about 8,600 values (22,000 in `spectral64`); a
/// generated 100,000-term sum about 100,000, a sum of 100,000 constants
/// about 300,000.
pub const MAX_FUNCTION_VALUES: usize = 1 << 20;

/// Shading globals replaced in a coordinate context, by name.
pub(crate) type GlobalChanges = Vec<(&'static str, Vec<Value>)>;

/// Noise sites per function expanded into IR (about 150 operations each
/// for 3D noise); beyond them a function calls the native, which computes
/// the same noise in f64 (within 1e-6). Inline noise is several times
/// faster in a loop such as fBm, but every copy costs compile time.
pub(crate) const NOISE_INLINE_SITES: u32 = 4;

#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Const {
    F(f32),
    I(i32),
    B(bool),
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub(crate) enum MemoKey {
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
        coords: Vec<Value>,
    },
    /// The value of a `const` item (module, item), remembered in the
    /// outermost scope (see [`Builder::outermost`]).
    Constant((usize, usize)),
}

/// An operation as a value-numbering key: floats compare by bits, so
/// `0.0` and `-0.0` (or two NaNs) are never confused.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub(crate) enum OpKey {
    Param(u32),
    Global(u32),
    InstanceWord(u32),
    Unary(UnOp, Value),
    Binary(BinOp, Value, Value),
    Select(Value, Value, Value),
    Call(&'static str, Vec<Value>),
    Table(usize, Value),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum ConstKey {
    F(u32),
    I(i32),
    B(bool),
}

impl OpKey {
    /// The key of a pure operation; `None` for reads of mutable state and
    /// for constants (keyed separately).
    pub(crate) fn of(op: &Op) -> Option<OpKey> {
        Some(match op {
            Op::Param(k) => OpKey::Param(*k),
            Op::Global(k) => OpKey::Global(*k),
            Op::InstanceWord(k) => OpKey::InstanceWord(*k),
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
    pub(crate) fn new(name: &str) -> Builder {
        Builder {
            func: Function { name: name.to_string(), ..Function::default() },
            prologue: Vec::new(),
            stack: vec![Vec::new()],
            consts: HashMap::default(),
            memo: super::memo::Memo::new(),
            globals: HashMap::default(),
            in_prologue: std::collections::HashSet::default(),
            noise_budget: NOISE_INLINE_SITES,
            contexts: HashMap::default(),
            hoisting: None,
            facts: Vec::new(),
            too_large: false,
        }
    }

    pub(crate) fn finish(mut self) -> Function {
        let body = self.stack.pop().unwrap_or_default();
        self.prologue.extend(body);
        self.func.body = self.prologue;
        verify::debug_verify(&self.func, "lowering");
        // Aggressive dead code elimination: it also removes what only feeds
        // itself, such as a bump's height loop inside `refraction_index`.
        // (The plain pass before it gave the same IR on every example and
        // the stdlib, and cost 15% of lowering.)
        super::adce::eliminate_dead_code_aggressive(&mut self.func);
        verify::debug_verify(&self.func, "dead code elimination");
        self.func
    }

    pub(crate) fn push(&mut self, inst: Inst) {
        self.note_write(&inst);
        if let Some(top) = self.stack.last_mut() {
            top.push(inst);
        }
    }

    pub(crate) fn fresh_value(&mut self, ty: Scalar) -> Value {
        self.too_large |= self.func.values.len() >= MAX_FUNCTION_VALUES;
        self.func.values.push(ty);
        Value(self.func.values.len() as u32 - 1)
    }

    pub(crate) fn var(&mut self, ty: Scalar) -> Var {
        self.func.vars.push(ty);
        Var(self.func.vars.len() as u32 - 1)
    }

    pub(crate) fn label(&mut self) -> Label {
        self.func.labels += 1;
        Label(self.func.labels - 1)
    }

    pub(crate) fn ty(&self, v: Value) -> Scalar {
        self.func.value_type(v)
    }

    pub(crate) fn konst(&self, v: Value) -> Option<Const> {
        match self.consts.get(&v) {
            Some(c) => Some(*c),
            None => self.facts.iter().rev().find(|(f, _)| *f == v).map(|(_, known)| Const::B(*known)),
        }
    }

    pub(crate) fn fconst(&self, v: Value) -> Option<f32> {
        match self.konst(v) {
            Some(Const::F(x)) => Some(x),
            _ => None,
        }
    }

    /// What the boolean `op` is known to be here (a constant, or a fact
    /// about the value computing it), without defining anything.
    pub(crate) fn known(&self, op: &Op) -> Option<bool> {
        let c = match self.fold(op) {
            Some(c) => Some(c),
            None => OpKey::of(op).and_then(|k| self.memo.get(&MemoKey::Op(k))).and_then(|v| self.konst(v[0])),
        };
        match c {
            Some(Const::B(x)) => Some(x),
            _ => None,
        }
    }

    /// Defines a value, folding constants and reusing an identical pure
    /// operation already computed in a dominating scope.
    pub(crate) fn def(&mut self, ty: Scalar, op: Op) -> Value {
        if let Some(c) = self.fold(&op) {
            return self.constant(c);
        }
        let key = OpKey::of(&op).map(MemoKey::Op);
        if let Some(v) = key.as_ref().and_then(|k| self.memo.get(k)) {
            return v[0];
        }
        let v = self.fresh_value(ty);
        self.note_value(v, Some(&op));
        if let Some(d) = self.anchor_of(&op) {
            // Point-only work under a per-call condition (`ir::hoist`).
            self.place_at(v, d);
            self.stack[d].push(Inst::Def(v, op));
            if let Some(key) = key {
                self.memo.insert_at(d, key, &[v]);
            }
            return v;
        }
        match op {
            Op::Global(_) | Op::InstanceWord(_) => {
                self.in_prologue.insert(v);
                self.prologue.push(Inst::Def(v, op));
            }
            op => self.push(Inst::Def(v, op)),
        }
        if let Some(key) = key {
            self.remember(key, &[v]);
        }
        v
    }

    pub(crate) fn constant(&mut self, c: Const) -> Value {
        let key = MemoKey::Const(match c {
            Const::F(x) => ConstKey::F(x.to_bits()),
            Const::I(x) => ConstKey::I(x),
            Const::B(x) => ConstKey::B(x),
        });
        if let Some(v) = self.memo.get_outermost(&key) {
            return v[0];
        }
        let (ty, op) = match c {
            Const::F(x) => (Scalar::F32, Op::F32(x)),
            Const::I(x) => (Scalar::I32, Op::I32(x)),
            Const::B(x) => (Scalar::Bool, Op::Bool(x)),
        };
        let v = self.fresh_value(ty);
        self.note_value(v, None);
        // Constants live in the prologue so they dominate everything.
        self.prologue.push(Inst::Def(v, op));
        self.in_prologue.insert(v);
        self.consts.insert(v, c);
        self.memo.insert_at(0, key, &[v]);
        v
    }

    pub(crate) fn f(&mut self, x: f32) -> Value {
        self.constant(Const::F(x))
    }

    pub(crate) fn i(&mut self, x: i32) -> Value {
        self.constant(Const::I(x))
    }

    pub(crate) fn b(&mut self, x: bool) -> Value {
        self.constant(Const::B(x))
    }

    /// What `key` stands for in an open scope.
    pub(crate) fn lookup(&self, key: &MemoKey) -> Option<Vec<Value>> {
        self.memo.get(key).map(<[Value]>::to_vec)
    }

    /// Remembers `key` in the innermost scope.
    pub(crate) fn remember(&mut self, key: MemoKey, values: &[Value]) {
        self.memo.insert(key, values);
    }

    pub(crate) fn fold(&self, op: &Op) -> Option<Const> {
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
                    (UnOp::FToI, F(x)) => I(semantics::float_to_int(x)),
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
                    (BinOp::FMin, F(x), F(y)) => F(semantics::fmin(x, y)),
                    (BinOp::FMax, F(x), F(y)) => F(semantics::fmax(x, y)),
                    (BinOp::IAdd, I(x), I(y)) => I(x.wrapping_add(y)),
                    (BinOp::ISub, I(x), I(y)) => I(x.wrapping_sub(y)),
                    (BinOp::IMul, I(x), I(y)) => I(x.wrapping_mul(y)),
                    (BinOp::IDiv, I(x), I(y)) => I(semantics::int_div(x, y)),
                    (BinOp::IRem, I(x), I(y)) => I(semantics::int_rem(x, y)),
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
            // Natives are pure: constant arguments give a constant, computed
            // by the same function the code would call (the same bits).
            Op::Call { native, args } => {
                let n = crate::runtime::native(native).filter(|n| n.arity == args.len())?;
                let args: Vec<f32> = args.iter().map(|a| self.fconst(*a)).collect::<Option<_>>()?;
                Some(F(n.f.call(&args)))
            }
            _ => None,
        }
    }

    pub(crate) fn bin(&mut self, op: BinOp, a: Value, b: Value) -> Value {
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

    pub(crate) fn un(&mut self, op: UnOp, a: Value) -> Value {
        let ty = match op {
            UnOp::FNeg | UnOp::FAbs | UnOp::Sqrt | UnOp::Floor | UnOp::Ceil | UnOp::Trunc | UnOp::IToF => Scalar::F32,
            UnOp::INeg | UnOp::FToI => Scalar::I32,
            UnOp::Not => Scalar::Bool,
        };
        self.def(ty, Op::Unary(op, a))
    }

    pub(crate) fn select(&mut self, cond: Value, a: Value, b: Value) -> Value {
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

    pub(crate) fn call(&mut self, native: &'static str, args: Vec<Value>) -> Value {
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

    /// A texture lookup (value-numbered: a lookup is pure): R, G, B, A,
    /// or with a spectral sampler one value per lane (`coords` then has
    /// the four hero wavelengths after the six of the lookup).
    pub(crate) fn texture(&mut self, sampler: &Arc<Sampler>, coords: Vec<Value>) -> Vec<Value> {
        let key = MemoKey::Texture { sampler: Arc::as_ptr(sampler) as usize, coords: coords.clone() };
        if let Some(v) = self.lookup(&key) {
            return v;
        }
        let words = sampler.spectral_lanes();
        let out = ArrayId(self.func.arrays.len() as u32);
        self.func.arrays.push((Scalar::F32, words as u32));
        self.push(Inst::Texture { sampler: SamplerRef(sampler.clone()), coords, out });
        let values: Vec<Value> = (0..words)
            .map(|k| {
                let index = self.i(k as i32);
                let v = self.fresh_value(Scalar::F32);
                let load = Op::Load { array: out, index };
                self.note_value(v, Some(&load));
                self.push(Inst::Def(v, load));
                v
            })
            .collect();
        self.remember(key, &values);
        values
    }

    /// x^n for n >= 1 by repeated squaring.
    pub(crate) fn powi(&mut self, x: Value, n: u32) -> Value {
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

    pub(crate) fn get(&mut self, var: Var) -> Value {
        let ty = self.func.vars[var.0 as usize];
        self.def(ty, Op::Get(var))
    }

    pub(crate) fn global(&mut self, word: u32, ty: Scalar) -> Value {
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
    pub(crate) fn block_body(&mut self, f: impl FnOnce(&mut Builder)) -> (Vec<Inst>, Vec<Inst>) {
        self.stack.push(Vec::new());
        self.memo.push();
        self.note_scope(false);
        f(self);
        self.note_scope_end();
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
        self.memo.pop_into_parent(|v| !inside.contains(v));
        (prefix, rest)
    }

    /// Runs `f` with a fresh instruction list and memo scope, for a body
    /// run depending on `control` (a branch's condition, a loop's bounds);
    /// returns the list.
    pub(crate) fn nested_under(&mut self, control: &[Value], f: impl FnOnce(&mut Builder)) -> Vec<Inst> {
        let per_call = control.iter().any(|v| self.is_per_call(*v));
        self.scope(per_call, f)
    }

    fn scope(&mut self, per_call: bool, f: impl FnOnce(&mut Builder)) -> Vec<Inst> {
        self.stack.push(Vec::new());
        self.memo.push();
        self.note_scope(per_call);
        f(self);
        self.note_scope_end();
        self.memo.pop();
        self.stack.pop().unwrap_or_default()
    }

    /// `if cond { then } else { else }` producing lanes through variables.
    /// `cx` is handed to both branches (they cannot both borrow it).
    pub(crate) fn branch<C>(
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
        let then_body = self.nested_under(&[cond], |b| {
            then_vals = then_f(b, cx);
            for (var, v) in vars.iter().zip(&then_vals) {
                b.push(Inst::Set(*var, *v));
            }
        });
        let mut else_vals = Vec::new();
        let else_body = self.nested_under(&[cond], |b| {
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
    pub(crate) fn guarded<C>(
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
        let mut vals = Vec::new();
        let mut then_body = self.nested_under(&[cond], |b| vals = f(b, cx));
        let mut inside = HashSet::default();
        defined_values(&then_body, &mut inside);
        if vals.iter().all(|v| !inside.contains(v)) {
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
    pub(crate) fn fadd(&mut self, a: Value, b: Value) -> Value {
        self.bin(BinOp::FAdd, a, b)
    }
    pub(crate) fn fsub(&mut self, a: Value, b: Value) -> Value {
        self.bin(BinOp::FSub, a, b)
    }
    pub(crate) fn fmul(&mut self, a: Value, b: Value) -> Value {
        self.bin(BinOp::FMul, a, b)
    }
    pub(crate) fn fdiv(&mut self, a: Value, b: Value) -> Value {
        self.bin(BinOp::FDiv, a, b)
    }
    pub(crate) fn flt(&mut self, a: Value, b: Value) -> Value {
        self.bin(BinOp::FLt, a, b)
    }
    pub(crate) fn feq(&mut self, a: Value, b: Value) -> Value {
        self.bin(BinOp::FEq, a, b)
    }
    pub(crate) fn fmin(&mut self, a: Value, b: Value) -> Value {
        self.bin(BinOp::FMin, a, b)
    }
    pub(crate) fn fmax(&mut self, a: Value, b: Value) -> Value {
        self.bin(BinOp::FMax, a, b)
    }
    pub(crate) fn and(&mut self, a: Value, b: Value) -> Value {
        self.bin(BinOp::And, a, b)
    }
    pub(crate) fn not(&mut self, a: Value) -> Value {
        self.un(UnOp::Not, a)
    }

    pub(crate) fn map2(&mut self, op: BinOp, a: &[Value], b: &[Value]) -> Vec<Value> {
        a.iter().zip(b).map(|(x, y)| self.bin(op, *x, *y)).collect()
    }

    pub(crate) fn scale(&mut self, a: &[Value], s: Value) -> Vec<Value> {
        a.iter().map(|x| self.fmul(*x, s)).collect()
    }

    pub(crate) fn dot(&mut self, a: &[Value], b: &[Value]) -> Value {
        let mut acc = self.fmul(a[0], b[0]);
        for k in 1..a.len() {
            let p = self.fmul(a[k], b[k]);
            acc = self.fadd(acc, p);
        }
        acc
    }

    /// Σ w_k x_k with constant weights, skipping zeros.
    pub(crate) fn weighted(&mut self, weights: &[f32], xs: &[Value]) -> Value {
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

    pub(crate) fn length(&mut self, a: &[Value]) -> Value {
        let d = self.dot(a, a);
        self.un(UnOp::Sqrt, d)
    }

    /// `a / |a|`, and the zero vector for a zero vector: one division,
    /// then a multiplication per lane.
    pub(crate) fn normalize(&mut self, a: &[Value]) -> Vec<Value> {
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

    pub(crate) fn cross(&mut self, a: &[Value], b: &[Value]) -> Vec<Value> {
        let mut out = Vec::with_capacity(3);
        for (i, j) in [(1, 2), (2, 0), (0, 1)] {
            let p = self.fmul(a[i], b[j]);
            let q = self.fmul(a[j], b[i]);
            out.push(self.fsub(p, q));
        }
        out
    }

    /// Blends lanes: `a (1 - t) + b t`.
    pub(crate) fn lerp(&mut self, t: Value, a: &[Value], b: &[Value]) -> Vec<Value> {
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

    pub(crate) fn clamp(&mut self, x: Value, lo: Value, hi: Value) -> Value {
        let m = self.fmax(x, lo);
        self.fmin(m, hi)
    }

    pub(crate) fn zeros(&mut self, n: usize) -> Vec<Value> {
        let z = self.f(0.0);
        vec![z; n]
    }
}

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
