//! The plain dead code pass: removes definitions nobody uses, writes to
//! variables and arrays nobody reads, and control flow left empty, to a
//! fixpoint. Lowering runs the aggressive pass (`ir::adce`), which also
//! removes cycles of dead work; this one is the reference its tests
//! compare against, so it is compiled for tests only.

use super::for_each_operand;
use crate::ir::{ArrayId, Function, Inst, Label, Op, Value, Var};
use std::collections::HashSet;

/// Removes dead definitions, writes and empty control flow, to a fixpoint.
pub fn eliminate_dead_code(f: &mut Function) {
    while sweep_once(f) {}
}

fn operands(op: &Op, out: &mut Vec<Value>) {
    for_each_operand(op, |v| out.push(v));
}

/// What the body reads: variables, arrays, and the definitions of values.
#[derive(Default)]
struct Uses {
    vars_read: HashSet<Var>,
    arrays_read: HashSet<ArrayId>,
    defs: Vec<Option<Op>>,
    roots: Vec<Value>,
}

fn scan(body: &[Inst], u: &mut Uses) {
    for inst in body {
        match inst {
            Inst::Def(v, op) => {
                match op {
                    Op::Get(var) => {
                        u.vars_read.insert(*var);
                    }
                    Op::Load { array, .. } => {
                        u.arrays_read.insert(*array);
                    }
                    _ => {}
                }
                u.defs[v.0 as usize] = Some(op.clone());
            }
            Inst::Output(_, v) => u.roots.push(*v),
            Inst::If { cond, then_body, else_body } => {
                u.roots.push(*cond);
                scan(then_body, u);
                scan(else_body, u);
            }
            Inst::Block { body, .. } => scan(body, u),
            Inst::Loop { start, end, body, .. } => {
                u.roots.extend([*start, *end]);
                scan(body, u);
            }
            Inst::Set(..) | Inst::Store { .. } | Inst::Texture { .. } | Inst::Break(_) | Inst::Continue(_) => {}
        }
    }
}

/// Roots that depend on which variables and arrays are read.
fn write_roots(body: &[Inst], u: &Uses, out: &mut Vec<Value>) {
    for inst in body {
        match inst {
            Inst::Set(var, v) if u.vars_read.contains(var) => out.push(*v),
            Inst::Store { array, index, value } if u.arrays_read.contains(array) => out.extend([*index, *value]),
            Inst::Texture { coords, out: array, .. } if u.arrays_read.contains(array) => out.extend(coords),
            Inst::If { then_body, else_body, .. } => {
                write_roots(then_body, u, out);
                write_roots(else_body, u, out);
            }
            Inst::Block { body, .. } | Inst::Loop { body, .. } => write_roots(body, u, out),
            _ => {}
        }
    }
}

fn sweep_once(f: &mut Function) -> bool {
    let mut u = Uses { defs: vec![None; f.values.len()], ..Uses::default() };
    scan(&f.body, &mut u);
    let mut roots = std::mem::take(&mut u.roots);
    write_roots(&f.body, &u, &mut roots);
    let mut live = vec![false; f.values.len()];
    let mut stack = roots;
    let mut ops = Vec::new();
    while let Some(v) = stack.pop() {
        if std::mem::replace(&mut live[v.0 as usize], true) {
            continue;
        }
        if let Some(op) = &u.defs[v.0 as usize] {
            ops.clear();
            operands(op, &mut ops);
            stack.extend(ops.iter().copied());
        }
    }
    let before = count(&f.body);
    f.body = sweep(std::mem::take(&mut f.body), &live, &u);
    count(&f.body) != before
}

fn count(body: &[Inst]) -> usize {
    body.iter()
        .map(|i| match i {
            Inst::If { then_body, else_body, .. } => 1 + count(then_body) + count(else_body),
            Inst::Block { body, .. } | Inst::Loop { body, .. } => 1 + count(body),
            _ => 1,
        })
        .sum()
}

fn sweep(body: Vec<Inst>, live: &[bool], u: &Uses) -> Vec<Inst> {
    let mut out = Vec::with_capacity(body.len());
    for inst in body {
        match inst {
            Inst::Def(v, _) if !live[v.0 as usize] => {}
            Inst::Set(var, _) if !u.vars_read.contains(&var) => {}
            Inst::Store { array, .. } if !u.arrays_read.contains(&array) => {}
            Inst::Texture { out: array, .. } if !u.arrays_read.contains(&array) => {}
            Inst::If { cond, then_body, else_body } => {
                let (then_body, else_body) = (sweep(then_body, live, u), sweep(else_body, live, u));
                let inst = Inst::If { cond, then_body, else_body };
                if has_effects(std::slice::from_ref(&inst), &mut Vec::new()) {
                    out.push(inst);
                }
            }
            Inst::Block { label, body } => {
                let inst = Inst::Block { label, body: sweep(body, live, u) };
                if has_effects(std::slice::from_ref(&inst), &mut Vec::new()) {
                    out.push(inst);
                }
            }
            Inst::Loop { label, counter, start, end, body } => {
                let inst = Inst::Loop { label, counter, start, end, body: sweep(body, live, u) };
                if has_effects(std::slice::from_ref(&inst), &mut Vec::new()) {
                    out.push(inst);
                }
            }
            other => out.push(other),
        }
    }
    out
}

/// Whether running `body` can change anything outside it: a write, an
/// output, or a jump to a label it does not contain. (Definitions are pure:
/// a value that nothing uses is already gone.)
fn has_effects(body: &[Inst], inner: &mut Vec<Label>) -> bool {
    body.iter().any(|inst| match inst {
        Inst::Def(..) => false,
        Inst::Set(..) | Inst::Store { .. } | Inst::Texture { .. } | Inst::Output(..) => true,
        Inst::Break(l) | Inst::Continue(l) => !inner.contains(l),
        Inst::If { then_body, else_body, .. } => has_effects(then_body, inner) || has_effects(else_body, inner),
        Inst::Block { label, body } | Inst::Loop { label, body, .. } => {
            inner.push(*label);
            let effects = has_effects(body, inner);
            inner.pop();
            effects
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::{BinOp, Inst, Label, Op, Scalar};

    #[test]
    fn unused_work_and_empty_branches_go() {
        let mut f = Function {
            params: vec![Scalar::F32],
            results: vec![Scalar::F32],
            values: vec![Scalar::F32; 4],
            vars: vec![Scalar::F32],
            ..Function::default()
        };
        f.body = vec![
            Inst::Def(Value(0), Op::Param(0)),
            Inst::Def(Value(1), Op::Call { native: "tsl_noise1", args: vec![Value(0)] }),
            Inst::Def(Value(2), Op::Binary(BinOp::FLt, Value(1), Value(0))),
            // Writes a variable nobody reads, under a condition on the noise.
            Inst::If { cond: Value(2), then_body: vec![Inst::Set(Var(0), Value(0))], else_body: vec![] },
            Inst::Def(Value(3), Op::Binary(BinOp::FAdd, Value(0), Value(0))),
            Inst::Output(0, Value(3)),
        ];
        // A block whose only content is a break to itself goes too.
        f.labels = 1;
        f.body.insert(
            4,
            Inst::Block {
                label: Label(0),
                body: vec![Inst::If { cond: Value(2), then_body: vec![Inst::Break(Label(0))], else_body: vec![] }],
            },
        );
        eliminate_dead_code(&mut f);
        assert_eq!(
            f.body,
            vec![
                Inst::Def(Value(0), Op::Param(0)),
                Inst::Def(Value(3), Op::Binary(BinOp::FAdd, Value(0), Value(0))),
                Inst::Output(0, Value(3)),
            ]
        );
    }
}
