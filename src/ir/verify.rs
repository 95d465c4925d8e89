//! The IR verifier: checks that a [`Function`] keeps the invariants the
//! back ends rely on instead of checking them again.
//!
//! The interpreter indexes its value, variable and array tables directly,
//! and the JIT turns each value into a Cranelift SSA value that must
//! dominate its uses and have the type the operation expects. A function
//! that breaks a rule here would panic in one back end and miscompile in
//! the other, so the rules are checked once, on the IR:
//!
//! - every [`Value`], [`Var`], [`ArrayId`] and [`Label`] is one the
//!   function declares; each value is defined once, each label opens one
//!   `Block` or `Loop`, and every array has at least one element;
//! - every use of a value is dominated by its definition: in the structured
//!   IR, the definition comes earlier in the same body or in a body around
//!   it (a value defined in an `If`, `Block` or `Loop` body is not visible
//!   after that instruction, nor in a sibling body);
//! - `Break` names an enclosing `Block` or `Loop`, `Continue` an enclosing
//!   `Loop`;
//! - `Param`, `Global` and `Output` words exist (the function's parameters,
//!   the [`ShadingGlobals`](crate::ShadingGlobals) record, its results) and
//!   have the value's type, and every result word is written (a back end
//!   would otherwise leave the host's word as it was); natives exist and
//!   get as many arguments as they take;
//! - operands have the scalar types their operation takes (f32 arithmetic
//!   on f32 values, bool conditions, i32 indices and loop bounds) and each
//!   definition has the type its operation gives.
//!
//! Lowering runs the verifier on every function it builds, before and
//! after dead code elimination, in debug builds (so in every test);
//! release builds do not pay for it.

use super::{ArrayId, BinOp, Function, Inst, Label, Module, Op, Scalar, UnOp, Value, Var, inst_line, scalar_name};
use std::fmt;

/// What is wrong with one function.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct VerifyError {
    /// The function's name.
    pub function: String,
    /// One sentence per problem: where it is (`body[2].then[0]`, the path of
    /// indices from the function's body), the instruction, and what is wrong.
    pub problems: Vec<String>,
}

impl fmt::Display for VerifyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "invalid IR in `{}`:", self.function)?;
        for p in &self.problems {
            write!(f, "\n  {p}")?;
        }
        Ok(())
    }
}

impl std::error::Error for VerifyError {}

/// Checks every rule of the module documentation on `func`.
pub fn verify_function(func: &Function) -> Result<(), VerifyError> {
    let mut v = Verifier {
        func,
        defined: vec![false; func.values.len()],
        in_scope: vec![false; func.values.len()],
        label_opened: vec![false; func.labels as usize],
        enclosing: Vec::new(),
        path: Vec::new(),
        current: None,
        written: vec![false; func.results.len()],
        problems: Vec::new(),
    };
    for (k, (_, len)) in func.arrays.iter().enumerate() {
        if *len == 0 {
            v.report(format!("a{k} has no elements (a clamped index needs one)"));
        }
    }
    v.body(&func.body, "body");
    for k in 0..func.results.len() {
        if !v.written[k] {
            v.report(format!("out[{k}] is never written (the function has {} result words)", func.results.len()));
        }
    }
    if v.problems.is_empty() { Ok(()) } else { Err(VerifyError { function: func.name.clone(), problems: v.problems }) }
}

/// Verifies every function of `module`, and that no two share a name
/// (hosts and the JIT find entry points by name).
pub fn verify_module(module: &Module) -> Result<(), Vec<VerifyError>> {
    let mut errors: Vec<VerifyError> = module.functions.iter().filter_map(|f| verify_function(f).err()).collect();
    let mut names: Vec<&str> = module.functions.iter().map(|f| f.name.as_str()).collect();
    names.sort_unstable();
    let mut repeated: Vec<&str> = names.windows(2).filter(|p| p[0] == p[1]).map(|p| p[0]).collect();
    repeated.dedup();
    for name in repeated {
        errors.push(VerifyError {
            function: name.to_string(),
            problems: vec!["another function of the module has the same name".into()],
        });
    }
    if errors.is_empty() { Ok(()) } else { Err(errors) }
}

/// Verifies `func` after `stage` in debug builds: an invalid function is a
/// compiler bug, reported where it was made rather than as a panic or a
/// miscompilation in a back end. Compiles to nothing in release builds.
#[inline]
pub(crate) fn debug_verify(func: &Function, stage: &str) {
    if cfg!(debug_assertions) {
        let result = verify_function(func);
        debug_assert!(
            result.is_ok(),
            "after {stage}: {}\n{func}",
            result.as_ref().err().map(|e| e.to_string()).unwrap_or_default()
        );
    }
}

/// Verifies a whole module in debug builds: each function (again, cheap
/// next to lowering) and that entry names are unique.
#[inline]
pub(crate) fn debug_verify_module(module: &Module, stage: &str) {
    if cfg!(debug_assertions)
        && let Err(errors) = verify_module(module)
    {
        let text: Vec<String> = errors.iter().map(|e| e.to_string()).collect();
        debug_assert!(false, "after {stage}: {}", text.join("\n"));
    }
}

struct Verifier<'f> {
    func: &'f Function,
    /// Whether each value's definition has been seen.
    defined: Vec<bool>,
    /// Whether each value is defined in the current body or one around it.
    in_scope: Vec<bool>,
    label_opened: Vec<bool>,
    /// The labels of the blocks and loops around the current instruction,
    /// innermost last; `true` for a loop.
    enclosing: Vec<(Label, bool)>,
    /// Where the current instruction is: (body, index) from the outside in.
    path: Vec<(&'static str, usize)>,
    /// The instruction being checked.
    current: Option<&'f Inst>,
    /// Whether each result word has an `Output`.
    written: Vec<bool>,
    problems: Vec<String>,
}

impl<'f> Verifier<'f> {
    fn report(&mut self, problem: String) {
        let mut at = String::new();
        for (k, (body, index)) in self.path.iter().enumerate() {
            if k > 0 {
                at.push('.');
            }
            at.push_str(&format!("{body}[{index}]"));
        }
        let message = match self.current {
            Some(inst) => format!("{at} `{}`: {problem}", inst_line(self.func, inst)),
            None => problem,
        };
        self.problems.push(message);
    }

    fn body(&mut self, body: &'f [Inst], name: &'static str) {
        let outer = self.current;
        let mut defined_here = Vec::new();
        for (k, inst) in body.iter().enumerate() {
            self.path.push((name, k));
            self.current = Some(inst);
            self.inst(inst, &mut defined_here);
            self.path.pop();
        }
        // The body's values go out of scope with it.
        for v in defined_here {
            self.in_scope[v] = false;
        }
        self.current = outer;
    }

    fn inst(&mut self, inst: &'f Inst, defined_here: &mut Vec<usize>) {
        match inst {
            Inst::Def(v, op) => {
                let ty = self.func.values.get(v.0 as usize).copied();
                if ty.is_none() {
                    self.report(format!(
                        "v{} is not a value of this function (it has {})",
                        v.0,
                        self.func.values.len()
                    ));
                }
                self.op(op, ty);
                // Defined after its operands are checked: `v1 = f(v1)` is an error.
                if let Some(d) = self.defined.get_mut(v.0 as usize) {
                    if std::mem::replace(d, true) {
                        self.report(format!("v{} is defined a second time", v.0));
                    } else {
                        self.in_scope[v.0 as usize] = true;
                        defined_here.push(v.0 as usize);
                    }
                }
            }
            Inst::Set(var, v) => {
                let want = self.var(*var);
                self.operand(*v, want, "the value");
            }
            Inst::Store { array, index, value } => {
                let elem = self.array(*array);
                self.operand(*index, Some(Scalar::I32), "the index");
                self.operand(*value, elem, "the value");
            }
            Inst::Output(k, v) => {
                let want = self.func.results.get(*k as usize).copied();
                if let Some(w) = self.written.get_mut(*k as usize) {
                    *w = true;
                }
                if want.is_none() {
                    self.report(format!(
                        "out[{k}] is not a result word (the function has {})",
                        self.func.results.len()
                    ));
                }
                self.operand(*v, want, "the result");
            }
            Inst::Texture { sampler, coords, out } => {
                let arity = if sampler.0.spectral.is_some() { 10 } else { 6 };
                if coords.len() != arity {
                    self.report(format!("a texture lookup with {} coordinates, not {arity}", coords.len()));
                }
                for c in coords {
                    self.operand(*c, Some(Scalar::F32), "a coordinate");
                }
                let words = sampler.0.spectral_lanes();
                if let Some(&(elem, len)) = self.func.arrays.get(out.0 as usize) {
                    if elem != Scalar::F32 || (len as usize) < words {
                        self.report(format!(
                            "a{} is {len} {} words; a texture writes {words} f32 words",
                            out.0,
                            scalar_name(elem)
                        ));
                    }
                } else {
                    self.array(*out);
                }
            }
            Inst::If { cond, then_body, else_body } => {
                self.operand(*cond, Some(Scalar::Bool), "the condition");
                self.body(then_body, "then");
                self.body(else_body, "else");
            }
            Inst::Block { label, body } => {
                self.open(*label);
                self.enclosing.push((*label, false));
                self.body(body, "body");
                self.enclosing.pop();
            }
            Inst::Loop { label, counter, start, end, body } => {
                self.operand(*start, Some(Scalar::I32), "the start");
                self.operand(*end, Some(Scalar::I32), "the end");
                if let Some(ty) = self.var(*counter)
                    && ty != Scalar::I32
                {
                    self.report(format!("the counter x{} is {}, not i32", counter.0, scalar_name(ty)));
                }
                self.open(*label);
                self.enclosing.push((*label, true));
                self.body(body, "body");
                self.enclosing.pop();
            }
            Inst::Break(label) => {
                if !self.enclosing.iter().any(|(l, _)| l == label) {
                    self.report(format!("L{} is not a block or loop around this break", label.0));
                }
            }
            Inst::Continue(label) => match self.enclosing.iter().find(|(l, _)| l == label) {
                Some((_, true)) => {}
                Some((_, false)) => self.report(format!("L{} is a block; only a loop can be continued", label.0)),
                None => self.report(format!("L{} is not a loop around this continue", label.0)),
            },
        }
    }

    /// Checks an operation's operands, and that `ty` (the type of the value
    /// it defines, when that value exists) is the type it gives.
    fn op(&mut self, op: &Op, ty: Option<Scalar>) {
        use Scalar::*;
        let gives = match op {
            Op::F32(_) => Some(F32),
            Op::I32(_) => Some(I32),
            Op::Bool(_) => Some(Bool),
            Op::Param(k) => {
                let word = self.func.params.get(*k as usize).copied();
                if word.is_none() {
                    self.report(format!(
                        "args[{k}] is not a parameter word (the function has {})",
                        self.func.params.len()
                    ));
                }
                word
            }
            Op::Global(k) => {
                let word = crate::globals::word_type(*k).map(|t| if t == crate::check::Ty::Int { I32 } else { F32 });
                if word.is_none() {
                    self.report(format!(
                        "globals[{k}] is past the shading globals ({} words)",
                        crate::globals::GLOBAL_WORDS
                    ));
                }
                word
            }
            Op::InstanceWord(k) => {
                let word = self.func.instance_words.get(*k as usize).copied();
                if word.is_none() {
                    self.report(format!(
                        "instance[{k}] is past the instance parameter block ({} words)",
                        self.func.instance_words.len()
                    ));
                }
                word
            }
            Op::Get(var) => self.var(*var),
            Op::Load { array, index } => {
                self.operand(*index, Some(I32), "the index");
                self.array(*array)
            }
            Op::Table { table, index } => {
                if !table.len().is_power_of_two() {
                    self.report(format!("a table of {} words (a power of two is needed)", table.len()));
                }
                self.operand(*index, Some(I32), "the index");
                if ty == Some(Bool) {
                    self.report("a table word read as a bool".into());
                }
                ty
            }
            Op::Unary(u, a) => {
                let (takes, gives) = unary_types(*u);
                self.operand(*a, Some(takes), "the operand");
                Some(gives)
            }
            Op::Binary(b, x, y) => {
                let takes = binary_operands(*b);
                self.operand(*x, Some(takes), "the first operand");
                self.operand(*y, Some(takes), "the second operand");
                Some(b.result())
            }
            Op::Select { cond, then_value, else_value } => {
                self.operand(*cond, Some(Bool), "the condition");
                self.operand(*then_value, ty, "the first choice");
                self.operand(*else_value, ty, "the second choice");
                ty
            }
            Op::Call { native, args } => {
                match crate::runtime::native(native) {
                    None => self.report(format!("`{native}` is not a native function")),
                    Some(n) if n.arity != args.len() => {
                        self.report(format!("`{native}` takes {} arguments, given {}", n.arity, args.len()))
                    }
                    Some(_) => {}
                }
                for a in args {
                    self.operand(*a, Some(F32), "an argument");
                }
                Some(F32)
            }
        };
        if let (Some(ty), Some(gives)) = (ty, gives)
            && ty != gives
        {
            self.report(format!("the value is {}, but the operation gives {}", scalar_name(ty), scalar_name(gives)));
        }
    }

    /// Checks a use of `v`: that it exists, is in scope, and is a `want`.
    fn operand(&mut self, v: Value, want: Option<Scalar>, role: &str) {
        let k = v.0 as usize;
        let Some(&ty) = self.func.values.get(k) else {
            self.report(format!("{role} v{} is not a value of this function (it has {})", v.0, self.func.values.len()));
            return;
        };
        if !self.in_scope[k] {
            let why = if self.defined[k] {
                "is defined in a body that does not enclose this use"
            } else {
                "is used before its definition"
            };
            self.report(format!("{role} v{} {why}", v.0));
        }
        if let Some(want) = want
            && ty != want
        {
            self.report(format!("{role} v{} is {}, expected {}", v.0, scalar_name(ty), scalar_name(want)));
        }
    }

    /// The type of a declared variable.
    fn var(&mut self, var: Var) -> Option<Scalar> {
        let ty = self.func.vars.get(var.0 as usize).copied();
        if ty.is_none() {
            self.report(format!("x{} is not a variable of this function (it has {})", var.0, self.func.vars.len()));
        }
        ty
    }

    /// The element type of a declared array.
    fn array(&mut self, array: ArrayId) -> Option<Scalar> {
        let elem = self.func.arrays.get(array.0 as usize).map(|(t, _)| *t);
        if elem.is_none() {
            self.report(format!("a{} is not an array of this function (it has {})", array.0, self.func.arrays.len()));
        }
        elem
    }

    /// A `Block` or `Loop` opening `label`, which must be declared and not
    /// opened before (back ends map each label to one exit).
    fn open(&mut self, label: Label) {
        match self.label_opened.get_mut(label.0 as usize) {
            None => self.report(format!("L{} is not a label of this function (it has {})", label.0, self.func.labels)),
            Some(opened) if *opened => self.report(format!("L{} is opened a second time", label.0)),
            Some(opened) => *opened = true,
        }
    }
}

/// The operand and result types of a unary operation.
fn unary_types(op: UnOp) -> (Scalar, Scalar) {
    use Scalar::*;
    match op {
        UnOp::FNeg | UnOp::FAbs | UnOp::Sqrt | UnOp::Floor | UnOp::Ceil | UnOp::Trunc => (F32, F32),
        UnOp::INeg => (I32, I32),
        UnOp::Not => (Bool, Bool),
        UnOp::IToF => (I32, F32),
        UnOp::FToI => (F32, I32),
    }
}

/// The type both operands of a binary operation have.
fn binary_operands(op: BinOp) -> Scalar {
    use BinOp::*;
    match op {
        FAdd | FSub | FMul | FDiv | FMin | FMax | FLt | FLe | FEq => Scalar::F32,
        IAdd | ISub | IMul | IDiv | IRem | IAnd | ILt | ILe | IEq => Scalar::I32,
        BEq | And | Or => Scalar::Bool,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::{SamplerRef, Scalar::*};
    use crate::texture::{Filter, Level, MipMap, Sampler, Wrap};

    /// A function with one f32 parameter and no result, variables x0: f32
    /// and x1: i32, arrays a0: [f32; 4] and a1: [i32; 1], two labels, and
    /// `values` as the value types.
    fn function(values: &[Scalar], body: Vec<Inst>) -> Function {
        Function {
            name: "t".into(),
            params: vec![F32],
            results: vec![],
            values: values.to_vec(),
            vars: vec![F32, I32],
            arrays: vec![(F32, 4), (I32, 1)],
            labels: 2,
            record_words: 0,
            instance_words: vec![],
            body,
        }
    }

    /// [`function`] with one f32 result word.
    fn returning(values: &[Scalar], body: Vec<Inst>) -> Function {
        Function { results: vec![F32], ..function(values, body) }
    }

    fn def(v: u32, op: Op) -> Inst {
        Inst::Def(Value(v), op)
    }

    fn add(a: u32, b: u32) -> Op {
        Op::Binary(BinOp::FAdd, Value(a), Value(b))
    }

    fn problems(f: &Function) -> Vec<String> {
        verify_function(f).err().map(|e| e.problems).unwrap_or_default()
    }

    /// `f` breaks exactly one rule, and the one problem reported says `what`.
    #[track_caller]
    fn caught(f: Function, what: &str) {
        let p = problems(&f);
        assert!(p.len() == 1 && p[0].contains(what), "expected one problem with {what:?}, got {p:#?}\n{f}");
    }

    fn sampler() -> SamplerRef {
        let image = MipMap::new("one", Level { width: 1, height: 1, texels: vec![[1.0; 4]] }, false);
        SamplerRef(std::sync::Arc::new(Sampler {
            image: crate::texture::TextureImage::Single(std::sync::Arc::new(image)),
            filter: Filter::Nearest,
            wrap: [Wrap::Repeat; 2],
            spectral: None,
        }))
    }

    /// Every construct, used correctly: the rules accept what lowering makes.
    fn valid() -> Function {
        returning(
            &[F32, F32, Bool, I32, I32, F32, F32, F32, I32, F32],
            vec![
                def(0, Op::Param(0)),
                def(1, Op::Global(12)),
                def(2, Op::Binary(BinOp::FLt, Value(0), Value(1))),
                def(3, Op::I32(0)),
                def(4, Op::Global(20)),
                Inst::Texture { sampler: sampler(), coords: vec![Value(0); 6], out: ArrayId(0) },
                Inst::If {
                    cond: Value(2),
                    then_body: vec![def(5, add(0, 1)), Inst::Set(Var(0), Value(5))],
                    else_body: vec![
                        def(6, Op::Load { array: ArrayId(0), index: Value(3) }),
                        Inst::Set(Var(0), Value(6)),
                    ],
                },
                Inst::Loop {
                    label: Label(0),
                    counter: Var(1),
                    start: Value(3),
                    end: Value(4),
                    body: vec![
                        Inst::Block {
                            label: Label(1),
                            body: vec![
                                Inst::If { cond: Value(2), then_body: vec![Inst::Break(Label(1))], else_body: vec![] },
                                Inst::If {
                                    cond: Value(2),
                                    then_body: vec![Inst::Continue(Label(0))],
                                    else_body: vec![],
                                },
                            ],
                        },
                        def(8, Op::Get(Var(1))),
                        Inst::Store { array: ArrayId(1), index: Value(3), value: Value(8) },
                    ],
                },
                def(7, Op::Get(Var(0))),
                def(9, Op::Call { native: "tsl_pow", args: vec![Value(7), Value(1)] }),
                Inst::Output(0, Value(9)),
            ],
        )
    }

    #[test]
    fn a_valid_function_verifies() {
        assert_eq!(problems(&valid()), Vec::<String>::new());
        assert!(verify_module(&Module { functions: vec![valid()] }).is_ok());
    }

    #[test]
    fn ids_must_be_declared() {
        caught(returning(&[F32], vec![def(0, Op::Param(0)), Inst::Output(0, Value(7))]), "v7 is not a value");
        caught(function(&[F32], vec![def(3, Op::F32(1.0))]), "v3 is not a value");
        caught(function(&[F32], vec![def(0, Op::Get(Var(2)))]), "x2 is not a variable");
        caught(function(&[F32], vec![def(0, Op::Param(0)), Inst::Set(Var(5), Value(0))]), "x5 is not a variable");
        let mut f =
            function(&[I32, F32], vec![def(0, Op::I32(0)), def(1, Op::Load { array: ArrayId(2), index: Value(0) })]);
        caught(f.clone(), "a2 is not an array");
        f.arrays[0].1 = 0;
        f.body.truncate(1);
        caught(f, "a0 has no elements");
        caught(function(&[], vec![Inst::Block { label: Label(2), body: vec![] }]), "L2 is not a label");
        caught(
            function(
                &[],
                vec![Inst::Block { label: Label(0), body: vec![] }, Inst::Block { label: Label(0), body: vec![] }],
            ),
            "L0 is opened a second time",
        );
    }

    #[test]
    fn values_are_defined_once_before_their_uses() {
        let neg = |v| Op::Unary(UnOp::FNeg, Value(v));
        caught(function(&[F32, F32], vec![def(0, neg(1)), def(1, Op::Param(0))]), "v1 is used before its definition");
        caught(function(&[F32], vec![def(0, neg(0))]), "v0 is used before its definition");
        caught(function(&[F32], vec![def(0, Op::Param(0)), def(0, Op::Param(0))]), "v0 is defined a second time");
    }

    #[test]
    fn values_defined_in_a_body_stay_in_it() {
        let cond = || def(1, Op::Bool(true));
        // After the `If` whose branch defines it.
        caught(
            returning(
                &[F32, Bool],
                vec![
                    cond(),
                    Inst::If { cond: Value(1), then_body: vec![def(0, Op::Param(0))], else_body: vec![] },
                    Inst::Output(0, Value(0)),
                ],
            ),
            "v0 is defined in a body that does not enclose this use",
        );
        // In the sibling branch.
        caught(
            returning(
                &[F32, Bool],
                vec![
                    cond(),
                    Inst::If {
                        cond: Value(1),
                        then_body: vec![def(0, Op::Param(0))],
                        else_body: vec![Inst::Output(0, Value(0))],
                    },
                ],
            ),
            "v0 is defined in a body",
        );
        // After a block, even before its first exit.
        caught(
            returning(
                &[F32],
                vec![Inst::Block { label: Label(0), body: vec![def(0, Op::Param(0))] }, Inst::Output(0, Value(0))],
            ),
            "v0 is defined in a body",
        );
        // After a loop.
        caught(
            returning(
                &[F32, I32],
                vec![
                    def(1, Op::I32(0)),
                    Inst::Loop {
                        label: Label(0),
                        counter: Var(1),
                        start: Value(1),
                        end: Value(1),
                        body: vec![def(0, Op::Param(0))],
                    },
                    Inst::Output(0, Value(0)),
                ],
            ),
            "v0 is defined in a body",
        );
        // Nested bodies see the values around them.
        let f = returning(
            &[F32, Bool],
            vec![
                def(0, Op::Param(0)),
                cond(),
                Inst::If {
                    cond: Value(1),
                    then_body: vec![Inst::Block { label: Label(0), body: vec![Inst::Output(0, Value(0))] }],
                    else_body: vec![],
                },
            ],
        );
        assert_eq!(problems(&f), Vec::<String>::new());
    }

    #[test]
    fn jumps_go_to_enclosing_labels() {
        caught(function(&[], vec![Inst::Break(Label(0))]), "L0 is not a block or loop around this break");
        caught(
            function(&[], vec![Inst::Block { label: Label(0), body: vec![] }, Inst::Break(Label(0))]),
            "L0 is not a block or loop around",
        );
        caught(
            function(&[], vec![Inst::Block { label: Label(0), body: vec![Inst::Continue(Label(0))] }]),
            "only a loop can be continued",
        );
        caught(function(&[], vec![Inst::Continue(Label(1))]), "L1 is not a loop around this continue");
        // A continue may leave an inner block for the loop around it.
        let f = function(
            &[I32],
            vec![
                def(0, Op::I32(3)),
                Inst::Loop {
                    label: Label(0),
                    counter: Var(1),
                    start: Value(0),
                    end: Value(0),
                    body: vec![Inst::Block { label: Label(1), body: vec![Inst::Continue(Label(0))] }],
                },
            ],
        );
        assert_eq!(problems(&f), Vec::<String>::new());
    }

    #[test]
    fn words_exist_and_have_their_types() {
        caught(function(&[F32], vec![def(0, Op::Param(1))]), "args[1] is not a parameter word");
        caught(function(&[I32], vec![def(0, Op::Param(0))]), "the value is i32, but the operation gives f32");
        caught(function(&[F32], vec![def(0, Op::Global(50))]), "globals[50] is past the shading globals");
        caught(function(&[F32], vec![def(0, Op::InstanceWord(0))]), "instance[0] is past the instance parameter block");
        let mut with_block = function(&[I32], vec![def(0, Op::InstanceWord(1))]);
        with_block.instance_words = vec![F32, F32];
        caught(with_block, "the value is i32, but the operation gives f32");
        // Words 20 and 32 are `face` and `frame`, the ints.
        caught(function(&[F32], vec![def(0, Op::Global(20))]), "the value is f32, but the operation gives i32");
        caught(function(&[F32], vec![def(0, Op::Global(32))]), "the value is f32, but the operation gives i32");
        caught(
            function(&[F32], vec![def(0, Op::Param(0)), Inst::Output(1, Value(0))]),
            "out[1] is not a result word (the function has 0)",
        );
        caught(
            returning(&[I32], vec![def(0, Op::I32(1)), Inst::Output(0, Value(0))]),
            "the result v0 is i32, expected f32",
        );
        caught(returning(&[F32], vec![def(0, Op::Param(0))]), "out[0] is never written");
    }

    #[test]
    fn operands_have_the_types_their_operations_take() {
        caught(
            function(&[I32, F32, F32], vec![def(0, Op::I32(1)), def(1, Op::F32(1.0)), def(2, add(1, 0))]),
            "the second operand v0 is i32, expected f32",
        );
        caught(
            function(&[F32, F32], vec![def(0, Op::F32(1.0)), def(1, Op::Binary(BinOp::FLt, Value(0), Value(0)))]),
            "but the operation gives bool",
        );
        caught(
            function(&[F32, F32], vec![def(0, Op::F32(1.0)), def(1, Op::Unary(UnOp::IToF, Value(0)))]),
            "the operand v0 is f32, expected i32",
        );
        caught(
            function(
                &[F32],
                vec![def(0, Op::F32(1.0)), Inst::If { cond: Value(0), then_body: vec![], else_body: vec![] }],
            ),
            "the condition v0 is f32, expected bool",
        );
        caught(
            function(
                &[Bool, F32, I32, F32],
                vec![
                    def(0, Op::Bool(true)),
                    def(1, Op::F32(1.0)),
                    def(2, Op::I32(1)),
                    def(3, Op::Select { cond: Value(0), then_value: Value(1), else_value: Value(2) }),
                ],
            ),
            "the second choice v2 is i32, expected f32",
        );
        caught(
            function(
                &[F32, I32],
                vec![
                    def(0, Op::F32(1.0)),
                    def(1, Op::I32(1)),
                    Inst::Loop { label: Label(0), counter: Var(1), start: Value(0), end: Value(1), body: vec![] },
                ],
            ),
            "the start v0 is f32",
        );
        let mut f = function(
            &[I32],
            vec![
                def(0, Op::I32(1)),
                Inst::Loop { label: Label(0), counter: Var(0), start: Value(0), end: Value(0), body: vec![] },
            ],
        );
        caught(f.clone(), "the counter x0 is f32, not i32");
        f.body = vec![def(0, Op::F32(1.0)), Inst::Set(Var(1), Value(0))];
        f.values = vec![F32];
        caught(f, "the value v0 is f32, expected i32");
        caught(
            function(&[F32, F32], vec![def(0, Op::F32(1.0)), def(1, Op::Load { array: ArrayId(0), index: Value(0) })]),
            "the index v0 is f32",
        );
        caught(
            function(
                &[I32, F32],
                vec![
                    def(0, Op::I32(0)),
                    def(1, Op::F32(1.0)),
                    Inst::Store { array: ArrayId(1), index: Value(0), value: Value(1) },
                ],
            ),
            "the value v1 is f32, expected i32",
        );
        caught(
            function(
                &[F32],
                vec![
                    def(0, Op::F32(0.0)),
                    Inst::Texture { sampler: sampler(), coords: vec![Value(0); 6], out: ArrayId(1) },
                ],
            ),
            "a1 is 1 i32 words; a texture writes 4 f32 words",
        );
    }

    #[test]
    fn natives_exist_and_get_their_arguments() {
        caught(
            function(&[F32], vec![def(0, Op::Call { native: "tsl_nope", args: vec![] })]),
            "`tsl_nope` is not a native",
        );
        caught(
            function(
                &[F32, F32],
                vec![def(0, Op::F32(1.0)), def(1, Op::Call { native: "tsl_pow", args: vec![Value(0)] })],
            ),
            "`tsl_pow` takes 2 arguments, given 1",
        );
        static ODD: [u32; 3] = [0; 3];
        caught(
            function(&[I32, I32], vec![def(0, Op::I32(0)), def(1, Op::Table { table: &ODD, index: Value(0) })]),
            "a table of 3 words",
        );
        static WORDS: [u32; 4] = [0; 4];
        caught(
            function(&[I32, Bool], vec![def(0, Op::I32(0)), def(1, Op::Table { table: &WORDS, index: Value(0) })]),
            "a table word read as a bool",
        );
    }

    #[test]
    fn problems_name_the_function_and_the_instruction() {
        let f = function(
            &[F32, Bool],
            vec![
                def(1, Op::Bool(true)),
                Inst::If {
                    cond: Value(1),
                    then_body: vec![def(0, Op::Param(0)), def(0, add(0, 0))],
                    else_body: vec![],
                },
            ],
        );
        let e = verify_function(&f).unwrap_err();
        assert_eq!(
            e.to_string(),
            "invalid IR in `t`:\n  body[1].then[1] `v0: f32 = fadd(v0, v0)`: v0 is defined a second time"
        );
        let twice = Module { functions: vec![valid(), valid()] };
        let errors = verify_module(&twice).unwrap_err();
        assert_eq!(errors.len(), 1);
        assert!(errors[0].problems[0].contains("same name"), "{errors:?}");
    }
}
