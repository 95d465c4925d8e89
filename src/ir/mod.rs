//! The typed, scalar IR shared by the interpreter and the JIT.
//!
//! Lowering (`lower`) turns a checked program into one IR [`Function`] per
//! entry point: each method of each material (the whole texture tree
//! flattened into it) and each generator function. Everything is inlined,
//! which is possible because TSL has no recursion, and every value is a
//! scalar: vectors are three lanes, colors as many lanes as the color model
//! has, so back ends never see a color type.
//!
//! Invariants:
//! - Control flow is structured (`If`, `Block`, `Loop`), and a [`Value`] is
//!   only used where its definition dominates the use; values that cross
//!   control flow go through [`Var`]s.
//! - Every operation is total: integer division by zero gives 0, array
//!   indices are clamped, a loop runs at most [`MAX_LOOP_ITERATIONS`] times
//!   and a call at most [`MAX_CALL_ITERATIONS`] loop iterations in all,
//!   float to int conversion saturates. No IR program can trap or hang.
//!   [`semantics`] defines these answers; the back ends import them from
//!   here, never from the front end.
//! - Every function that lowering and [`opt`] produce passes [`verify`]
//!   (checked in debug builds, so in every test).

mod adce;
mod builder;
mod gvn;
mod hoist;
pub mod lower;
mod memo;
pub mod opt;
pub mod semantics;
pub mod split;
#[cfg(test)]
mod tests;
pub mod verify;

pub use builder::MAX_FUNCTION_VALUES;
pub use semantics::{MAX_CALL_ITERATIONS, MAX_LOOP_ITERATIONS};

use std::fmt::{self, Write};

/// The type of a scalar.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Scalar {
    F32,
    I32,
    Bool,
}

/// A value defined once by an [`Inst::Def`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Value(pub u32);

/// A mutable scalar variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Var(pub u32);

/// A mutable array of scalars, indexed with clamping.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ArrayId(pub u32);

/// A target for `Break` and `Continue`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Label(pub u32);

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum UnOp {
    FNeg,
    FAbs,
    Sqrt,
    Floor,
    Ceil,
    Trunc,
    INeg,
    Not,
    /// int → float.
    IToF,
    /// float → int, saturating; NaN gives 0.
    FToI,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BinOp {
    FAdd,
    FSub,
    FMul,
    FDiv,
    /// `a < b ? a : b`, the same on every back end (NaN handling included).
    FMin,
    FMax,
    IAdd,
    ISub,
    IMul,
    /// Wrapping; division by zero gives 0.
    IDiv,
    /// Wrapping; remainder by zero gives 0.
    IRem,
    /// Bitwise and.
    IAnd,
    FLt,
    FLe,
    FEq,
    ILt,
    ILe,
    IEq,
    BEq,
    And,
    Or,
}

impl BinOp {
    pub fn result(self) -> Scalar {
        use BinOp::*;
        match self {
            FAdd | FSub | FMul | FDiv | FMin | FMax => Scalar::F32,
            IAdd | ISub | IMul | IDiv | IRem | IAnd => Scalar::I32,
            FLt | FLe | FEq | ILt | ILe | IEq | BEq | And | Or => Scalar::Bool,
        }
    }
}

/// A value-producing operation.
#[derive(Debug, Clone, PartialEq)]
pub enum Op {
    F32(f32),
    I32(i32),
    Bool(bool),
    /// Word `i` of the argument array.
    Param(u32),
    /// Word `i` of the shading globals (see `ShadingGlobals`).
    Global(u32),
    /// Word `i` of the instance parameter block: a run-time-bound
    /// instance's values ([`Function::instance_words`]), read like the
    /// globals (unchanged during a call).
    InstanceWord(u32),
    Get(Var),
    Load {
        array: ArrayId,
        index: Value,
    },
    Unary(UnOp, Value),
    Binary(BinOp, Value, Value),
    Select {
        cond: Value,
        then_value: Value,
        else_value: Value,
    },
    /// Word `index & (len - 1)` of a constant table whose length is a
    /// power of two, read as the value's type: the permutation and
    /// gradients of inlined noise. The mask is the lookup's own, so no
    /// index can leave the table.
    Table {
        table: &'static [u32],
        index: Value,
    },
    /// A native function from `runtime` (f32 arguments, f32 result).
    Call {
        native: &'static str,
        args: Vec<Value>,
    },
}

#[derive(Debug, Clone, PartialEq)]
pub enum Inst {
    Def(Value, Op),
    Set(Var, Value),
    Store {
        array: ArrayId,
        index: Value,
        value: Value,
    },
    /// Word `i` of the result array.
    Output(u32, Value),
    /// A filtered image lookup at `coords` = (s, t, ds/dx, dt/dx, ds/dy,
    /// dt/dy), writing R, G, B, A into words 0..4 of the f32 array `out`;
    /// with a spectral sampler, four more coords (the hero lanes'
    /// normalised wavelengths) and one word per lane
    /// ([`crate::texture::Sampler::spectral_lanes`]).
    Texture {
        sampler: SamplerRef,
        coords: Vec<Value>,
        out: ArrayId,
    },
    If {
        cond: Value,
        then_body: Vec<Inst>,
        else_body: Vec<Inst>,
    },
    /// A block that `Break(label)` leaves early.
    Block {
        label: Label,
        body: Vec<Inst>,
    },
    /// `counter` runs from `start` while below `end`, at most
    /// `MAX_LOOP_ITERATIONS` times and while the call's budget of
    /// `MAX_CALL_ITERATIONS` iterations over all loops lasts. `Break(label)` leaves the loop,
    /// `Continue(label)` goes to the next iteration.
    Loop {
        label: Label,
        counter: Var,
        start: Value,
        end: Value,
        body: Vec<Inst>,
    },
    Break(Label),
    Continue(Label),
}

/// The sampler of a texture instruction: shared, compared by identity, and
/// printed by its image and modes.
#[derive(Clone)]
pub struct SamplerRef(pub std::sync::Arc<crate::texture::Sampler>);

impl PartialEq for SamplerRef {
    fn eq(&self, other: &Self) -> bool {
        std::sync::Arc::ptr_eq(&self.0, &other.0)
    }
}

impl fmt::Debug for SamplerRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.0;
        write!(f, "\"{}\" {:?} {:?}/{:?}", s.image.name(), s.filter, s.wrap[0], s.wrap[1])
    }
}

/// One entry point: `extern "C" fn(globals, args, out)`.
#[derive(Debug, Clone, Default)]
pub struct Function {
    pub name: String,
    /// The argument words and their types.
    pub params: Vec<Scalar>,
    /// The result words and their types.
    pub results: Vec<Scalar>,
    pub values: Vec<Scalar>,
    pub vars: Vec<Scalar>,
    /// Element type and length of each array.
    pub arrays: Vec<(Scalar, u32)>,
    pub labels: u32,
    /// The first argument words that are a hit record written by a
    /// `prepare` function ([`split`]); 0 for functions called on their own.
    pub record_words: u32,
    /// The instance parameter block's words and their types
    /// ([`Op::InstanceWord`]); empty for code with its values folded in.
    pub instance_words: Vec<Scalar>,
    pub body: Vec<Inst>,
}

impl Function {
    pub fn value_type(&self, v: Value) -> Scalar {
        self.values[v.0 as usize]
    }

    /// The samplers this function looks up at the shading point's own
    /// (u, v): lookups whose coordinates are the globals `u` and `v` as
    /// read, not computed from them (nor moved by a `transform` or a
    /// `triplanar`), so a mesh's texture coordinates say which part of the
    /// image they read (the scene's UDIM tile check).
    pub fn lookups_at_uv(&self) -> Vec<&SamplerRef> {
        let word = |name| crate::globals::word_of(name).map(|(w, _)| w);
        let (Some(u), Some(v)) = (word("u"), word("v")) else { return Vec::new() };
        let mut globals: std::collections::HashMap<Value, u32> = std::collections::HashMap::new();
        for_each_inst(&self.body, &mut |inst| {
            if let Inst::Def(value, Op::Global(w)) = inst {
                globals.insert(*value, *w);
            }
        });
        let mut found: Vec<&SamplerRef> = Vec::new();
        for_each_inst(&self.body, &mut |inst| {
            if let Inst::Texture { sampler, coords, .. } = inst
                && coords.len() >= 2
                && globals.get(&coords[0]) == Some(&u)
                && globals.get(&coords[1]) == Some(&v)
                && !found.contains(&sampler)
            {
                found.push(sampler);
            }
        });
        found
    }
}

/// All entry points of a program, for one color model.
#[derive(Debug, Clone, Default)]
pub struct Module {
    pub functions: Vec<Function>,
}

impl Module {
    /// The function named `name` (tests look entry points up by name).
    #[cfg(test)]
    pub fn function(&self, name: &str) -> Option<&Function> {
        self.functions.iter().find(|f| f.name == name)
    }
}

// ---------------------------------------------------------------- printing

impl fmt::Display for Module {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, func) in self.functions.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{func}")?;
        }
        Ok(())
    }
}

fn scalar_name(s: Scalar) -> &'static str {
    match s {
        Scalar::F32 => "f32",
        Scalar::I32 => "i32",
        Scalar::Bool => "bool",
    }
}

impl fmt::Display for Function {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let list = |xs: &[Scalar]| xs.iter().map(|s| scalar_name(*s)).collect::<Vec<_>>().join(", ");
        let (record, args) = self.params.split_at((self.record_words as usize).min(self.params.len()));
        if record.is_empty() {
            writeln!(f, "fn {}(args: [{}]) -> [{}] {{", self.name, list(args), list(&self.results))?;
        } else {
            writeln!(
                f,
                "fn {}(hit: [{}], args: [{}]) -> [{}] {{",
                self.name,
                list(record),
                list(args),
                list(&self.results)
            )?;
        }
        let mut out = String::new();
        print_body(&mut out, self, &self.body, 1);
        f.write_str(&out)?;
        writeln!(f, "}}")
    }
}

fn print_body(out: &mut String, func: &Function, body: &[Inst], depth: usize) {
    let pad = "    ".repeat(depth);
    for inst in body {
        let _ = match inst {
            Inst::Def(v, op) => {
                // `?` for a value without a type: the verifier prints invalid functions too.
                let ty = func.values.get(v.0 as usize).map_or("?", |t| scalar_name(*t));
                writeln!(out, "{pad}v{}: {ty} = {}", v.0, print_op(func, op))
            }
            Inst::Set(var, v) => writeln!(out, "{pad}x{} = v{}", var.0, v.0),
            Inst::Store { array, index, value } => writeln!(out, "{pad}a{}[v{}] = v{}", array.0, index.0, value.0),
            Inst::Output(i, v) => writeln!(out, "{pad}out[{i}] = v{}", v.0),
            Inst::Texture { sampler, coords, out: array } => {
                let c: Vec<String> = coords.iter().map(|v| format!("v{}", v.0)).collect();
                let words = sampler.0.spectral_lanes();
                writeln!(out, "{pad}a{}[0..{words}] = texture({sampler:?}, {})", array.0, c.join(", "))
            }
            Inst::If { cond, then_body, else_body } => {
                let _ = writeln!(out, "{pad}if v{} {{", cond.0);
                print_body(out, func, then_body, depth + 1);
                if !else_body.is_empty() {
                    let _ = writeln!(out, "{pad}}} else {{");
                    print_body(out, func, else_body, depth + 1);
                }
                writeln!(out, "{pad}}}")
            }
            Inst::Block { label, body } => {
                let _ = writeln!(out, "{pad}block L{} {{", label.0);
                print_body(out, func, body, depth + 1);
                writeln!(out, "{pad}}}")
            }
            Inst::Loop { label, counter, start, end, body } => {
                let _ = writeln!(out, "{pad}loop L{} x{} in v{}..v{} {{", label.0, counter.0, start.0, end.0);
                print_body(out, func, body, depth + 1);
                writeln!(out, "{pad}}}")
            }
            Inst::Break(l) => writeln!(out, "{pad}break L{}", l.0),
            Inst::Continue(l) => writeln!(out, "{pad}continue L{}", l.0),
        };
    }
}

/// One instruction on one line, without the bodies it holds: how the
/// verifier names the instruction it complains about.
fn inst_line(func: &Function, inst: &Inst) -> String {
    let mut out = String::new();
    let header = match inst {
        Inst::If { cond, .. } => Inst::If { cond: *cond, then_body: vec![], else_body: vec![] },
        Inst::Block { label, .. } => Inst::Block { label: *label, body: vec![] },
        Inst::Loop { label, counter, start, end, .. } => {
            Inst::Loop { label: *label, counter: *counter, start: *start, end: *end, body: vec![] }
        }
        other => other.clone(),
    };
    print_body(&mut out, func, std::slice::from_ref(&header), 0);
    out.lines().next().unwrap_or_default().trim_end_matches(" {").to_string()
}

fn print_op(func: &Function, op: &Op) -> String {
    match op {
        Op::Param(i) if *i < func.record_words => format!("hit[{i}]"),
        Op::Param(i) => format!("args[{}]", i - func.record_words),
        Op::F32(x) => format!("{x:?}"),
        Op::I32(x) => format!("{x}i"),
        Op::Bool(b) => format!("{b}"),
        // By name: `global N.y` is word 7 (see `globals::word_name`).
        Op::Global(i) => match crate::globals::word_name(*i) {
            Some(name) => format!("global {name}"),
            None => format!("globals[{i}]"),
        },
        Op::InstanceWord(i) => format!("instance[{i}]"),
        Op::Get(v) => format!("x{}", v.0),
        Op::Load { array, index } => format!("a{}[v{}]", array.0, index.0),
        // By name, never by address, so printed IR is the same on every run.
        Op::Table { table, index } => match crate::runtime::table_name(table) {
            Some(name) => format!("{name}[v{}]", index.0),
            None => format!("table{}[v{}]", table.len(), index.0),
        },
        Op::Unary(u, a) => format!("{u:?}(v{})", a.0).to_lowercase(),
        Op::Binary(b, x, y) => format!("{}(v{}, v{})", format!("{b:?}").to_lowercase(), x.0, y.0),
        Op::Select { cond, then_value, else_value } => {
            format!("select(v{}, v{}, v{})", cond.0, then_value.0, else_value.0)
        }
        Op::Call { native, args } => {
            let args: Vec<String> = args.iter().map(|a| format!("v{}", a.0)).collect();
            format!("{native}({})", args.join(", "))
        }
    }
}

impl Function {
    /// The result words when the function computes constants only (its
    /// body is constant definitions and outputs), as f32 bits: how a
    /// renderer tells that a material's `emission` is the default black.
    pub fn constant_results(&self) -> Option<Vec<u32>> {
        let mut consts = std::collections::HashMap::new();
        let mut out = vec![None; self.results.len()];
        for inst in &self.body {
            match inst {
                Inst::Def(v, Op::F32(x)) => {
                    consts.insert(*v, x.to_bits());
                }
                Inst::Def(v, Op::I32(x)) => {
                    consts.insert(*v, *x as u32);
                }
                Inst::Def(v, Op::Bool(x)) => {
                    consts.insert(*v, u32::from(*x));
                }
                Inst::Output(k, v) => *out.get_mut(*k as usize)? = Some(*consts.get(v)?),
                _ => return None,
            }
        }
        out.into_iter().collect()
    }
}

/// For each array of `f`, whether it is written once, by a texture lookup:
/// such an array is a pure value, like a definition.
pub(crate) fn lookup_arrays(f: &Function) -> Vec<bool> {
    let mut writes = vec![0u32; f.arrays.len()];
    let mut lookup = vec![false; f.arrays.len()];
    for_each_inst(&f.body, &mut |inst| match inst {
        Inst::Store { array, .. } => writes[array.0 as usize] += 1,
        Inst::Texture { out, .. } => {
            writes[out.0 as usize] += 1;
            lookup[out.0 as usize] = true;
        }
        _ => {}
    });
    for (l, w) in lookup.iter_mut().zip(&writes) {
        *l &= *w == 1;
    }
    lookup
}

impl Inst {
    /// Whether the instruction looks up a texture or evaluates noise (a
    /// table read of inline noise, or a native noise call): what a texture
    /// tree spends its time on, so what makes a per-hit stage pay.
    pub fn is_costly(&self) -> bool {
        match self {
            Inst::Texture { .. } | Inst::Def(_, Op::Table { .. }) => true,
            Inst::Def(_, Op::Call { native, .. }) => native.contains("noise"),
            _ => false,
        }
    }
}

/// Whether `body` holds an instruction that [`Inst::is_costly`].
pub fn has_costly(body: &[Inst]) -> bool {
    let mut costly = false;
    for_each_inst(body, &mut |inst| costly |= inst.is_costly());
    costly
}

/// The number of instructions in `body`, nested bodies included.
pub fn count_insts(body: &[Inst]) -> usize {
    let mut n = 0;
    for_each_inst(body, &mut |_| n += 1);
    n
}

/// Calls `f` on every instruction of `body`, nested bodies included
/// (a nested body's instructions after the instruction that holds it).
pub fn for_each_inst<'a>(body: &'a [Inst], f: &mut impl FnMut(&'a Inst)) {
    for inst in body {
        f(inst);
        match inst {
            Inst::If { then_body, else_body, .. } => {
                for_each_inst(then_body, f);
                for_each_inst(else_body, f);
            }
            Inst::Block { body, .. } | Inst::Loop { body, .. } => for_each_inst(body, f),
            _ => {}
        }
    }
}

/// Calls `f` on every operation of `body`, nested bodies included.
pub fn for_each_op(body: &[Inst], f: &mut impl FnMut(&Op)) {
    for inst in body {
        match inst {
            Inst::Def(_, op) => f(op),
            Inst::If { then_body, else_body, .. } => {
                for_each_op(then_body, f);
                for_each_op(else_body, f);
            }
            Inst::Block { body, .. } | Inst::Loop { body, .. } => for_each_op(body, f),
            _ => {}
        }
    }
}
