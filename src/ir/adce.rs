//! Aggressive dead code elimination: everything the outputs do not depend
//! on goes, loop-carried cycles included.
//!
//! [`super::opt::eliminate_dead_code`] keeps a write while anything reads
//! the variable, so an accumulator whose only reader is its own update
//! (`sum = sum + noise(..)` in a loop whose result nobody needs) survives.
//! That is rare in lowered code but the rule of the per-hit split
//! (`ir::split`) after replacing values by record reads: here liveness
//! starts at the outputs and flows backwards through values, variables,
//! arrays and the control flow around live instructions (LLVM's ADCE).

use super::{ArrayId, Function, Inst, Label, Op, Value, Var};

/// Removes every instruction the outputs do not depend on.
pub fn eliminate_dead_code_aggressive(f: &mut Function) {
    let mut live = Live {
        values: vec![false; f.values.len()],
        vars: vec![false; f.vars.len()],
        arrays: vec![false; f.arrays.len()],
        labels: vec![false; f.labels as usize],
        changed: true,
    };
    while live.changed {
        live.changed = false;
        live.mark(&f.body);
    }
    f.body = live.sweep(std::mem::take(&mut f.body));
}

struct Live {
    values: Vec<bool>,
    vars: Vec<bool>,
    arrays: Vec<bool>,
    /// Blocks and loops that hold something live (so do their exits).
    labels: Vec<bool>,
    changed: bool,
}

fn set(flag: &mut bool, changed: &mut bool) {
    if !*flag {
        *flag = true;
        *changed = true;
    }
}

impl Live {
    fn value(&mut self, v: Value) {
        set(&mut self.values[v.0 as usize], &mut self.changed);
    }

    fn var(&mut self, v: Var) {
        set(&mut self.vars[v.0 as usize], &mut self.changed);
    }

    fn array(&mut self, a: ArrayId) {
        set(&mut self.arrays[a.0 as usize], &mut self.changed);
    }

    fn label(&mut self, l: Label) {
        set(&mut self.labels[l.0 as usize], &mut self.changed);
    }

    /// Marks backwards through `body` (uses before definitions); returns
    /// whether it holds a live instruction.
    fn mark(&mut self, body: &[Inst]) -> bool {
        let mut any = false;
        for inst in body.iter().rev() {
            any |= self.mark_inst(inst);
        }
        any
    }

    fn mark_inst(&mut self, inst: &Inst) -> bool {
        match inst {
            Inst::Def(v, op) => {
                if !self.values[v.0 as usize] {
                    return false;
                }
                match op {
                    Op::Get(var) => self.var(*var),
                    Op::Load { array, index } => {
                        self.array(*array);
                        self.value(*index);
                    }
                    _ => super::opt::for_each_operand(op, |x| self.value(x)),
                }
                true
            }
            Inst::Set(var, v) => {
                let live = self.vars[var.0 as usize];
                if live {
                    self.value(*v);
                }
                live
            }
            Inst::Store { array, index, value } => {
                let live = self.arrays[array.0 as usize];
                if live {
                    self.value(*index);
                    self.value(*value);
                }
                live
            }
            Inst::Texture { coords, out, .. } => {
                let live = self.arrays[out.0 as usize];
                if live {
                    coords.iter().for_each(|c| self.value(*c));
                }
                live
            }
            Inst::Output(_, v) => {
                self.value(*v);
                true
            }
            Inst::If { cond, then_body, else_body } => {
                let live = self.mark(then_body) | self.mark(else_body);
                if live {
                    self.value(*cond);
                }
                live
            }
            Inst::Block { label, body } => {
                let live = self.mark(body);
                if live {
                    self.label(*label);
                }
                live
            }
            Inst::Loop { label, counter, start, end, body } => {
                let live = self.mark(body) | self.vars[counter.0 as usize];
                if live {
                    self.label(*label);
                    self.value(*start);
                    self.value(*end);
                }
                live
            }
            // An exit matters when what it skips or repeats does.
            Inst::Break(l) | Inst::Continue(l) => self.labels[l.0 as usize],
        }
    }

    fn sweep(&self, body: Vec<Inst>) -> Vec<Inst> {
        let mut out = Vec::with_capacity(body.len());
        for inst in body {
            let keep = match &inst {
                Inst::Def(v, _) => self.values[v.0 as usize],
                Inst::Set(var, _) => self.vars[var.0 as usize],
                Inst::Store { array, .. } | Inst::Texture { out: array, .. } => self.arrays[array.0 as usize],
                Inst::Output(..) => true,
                Inst::Break(l) | Inst::Continue(l) => self.labels[l.0 as usize],
                Inst::If { .. } => true,
                Inst::Block { label, .. } => self.labels[label.0 as usize],
                Inst::Loop { label, .. } => self.labels[label.0 as usize],
            };
            if !keep {
                continue;
            }
            out.push(match inst {
                Inst::If { cond, then_body, else_body } => {
                    let (then_body, else_body) = (self.sweep(then_body), self.sweep(else_body));
                    if then_body.is_empty() && else_body.is_empty() {
                        continue;
                    }
                    Inst::If { cond, then_body, else_body }
                }
                Inst::Block { label, body } => Inst::Block { label, body: self.sweep(body) },
                Inst::Loop { label, counter, start, end, body } => {
                    Inst::Loop { label, counter, start, end, body: self.sweep(body) }
                }
                other => other,
            });
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::{BinOp, Scalar};

    /// `sum` accumulates noise in a loop, but only its own update reads
    /// it: the plain pass keeps the loop, this one removes it.
    #[test]
    fn a_loop_whose_result_nobody_reads_goes() {
        let mut f = Function {
            params: vec![Scalar::F32],
            results: vec![Scalar::F32],
            values: vec![Scalar::F32, Scalar::I32, Scalar::I32, Scalar::F32, Scalar::F32, Scalar::F32],
            vars: vec![Scalar::F32, Scalar::I32],
            labels: 1,
            ..Function::default()
        };
        f.body = vec![
            Inst::Def(Value(0), Op::Param(0)),
            Inst::Def(Value(1), Op::I32(0)),
            Inst::Def(Value(2), Op::I32(4)),
            Inst::Set(Var(0), Value(0)),
            Inst::Loop {
                label: Label(0),
                counter: Var(1),
                start: Value(1),
                end: Value(2),
                body: vec![
                    Inst::Def(Value(3), Op::Get(Var(0))),
                    Inst::Def(Value(4), Op::Call { native: "tsl_noise1", args: vec![Value(3)] }),
                    Inst::Def(Value(5), Op::Binary(BinOp::FAdd, Value(3), Value(4))),
                    Inst::Set(Var(0), Value(5)),
                ],
            },
            Inst::Output(0, Value(0)),
        ];
        let mut plain = f.clone();
        crate::ir::opt::eliminate_dead_code(&mut plain);
        assert_eq!(plain.body, f.body, "the plain pass keeps the cycle");
        eliminate_dead_code_aggressive(&mut f);
        assert_eq!(f.body, vec![Inst::Def(Value(0), Op::Param(0)), Inst::Output(0, Value(0))]);
    }

    /// A break that skips live work keeps its condition and its block.
    #[test]
    fn exits_before_live_work_stay() {
        let mut f = Function {
            params: vec![Scalar::Bool, Scalar::F32],
            results: vec![Scalar::F32],
            values: vec![Scalar::Bool, Scalar::F32, Scalar::F32],
            vars: vec![Scalar::F32],
            labels: 1,
            ..Function::default()
        };
        f.body = vec![
            Inst::Def(Value(0), Op::Param(0)),
            Inst::Def(Value(1), Op::Param(1)),
            Inst::Set(Var(0), Value(1)),
            Inst::Block {
                label: Label(0),
                body: vec![
                    Inst::If { cond: Value(0), then_body: vec![Inst::Break(Label(0))], else_body: vec![] },
                    Inst::Set(Var(0), Value(1)),
                ],
            },
            Inst::Def(Value(2), Op::Get(Var(0))),
            Inst::Output(0, Value(2)),
        ];
        let before = f.body.clone();
        eliminate_dead_code_aggressive(&mut f);
        assert_eq!(f.body, before);
    }
}
