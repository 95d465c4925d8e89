//! The per-hit split: one function run once per hit point, and the
//! methods, which read what it computed instead of computing it again.
//!
//! The input is a *combined* function: every method a renderer calls at a
//! hit, lowered into one body so that lowering's memo and value numbering
//! already share what the methods have in common (the texture tree's
//! generators, `bump`'s normal). Its first argument words are the *hit
//! inputs* (`wo`, `eta`: the same for every call at one hit); after them
//! come each method's own arguments (`wi`, random numbers, light).
//!
//! The rule: a value is **point-only** when it depends only on the shading
//! globals, the hit inputs and constants: a constant, a global or a hit
//! input, or a pure operation whose operands are point-only, or a read of
//! a variable or array every write of which stores point-only values under
//! point-only control (conditions, loop bounds and exits that are
//! themselves point-only). A texture lookup is pure: its array is
//! point-only when its coordinates are, wherever it stands.
//!
//! `prepare` computes every point-only value that method code needs (one
//! defined outside the point-only loops, so it has one value per call) and
//! writes it to the *hit record*; in each method, those values become
//! record reads, and what only they used goes (aggressive dead code
//! elimination). Point-only work under a per-call condition is computed
//! speculatively by `prepare` (IR operations are pure and total), which
//! is why the group of methods should be the ones a renderer does call.
//!
//! A method's arguments are `[record | own arguments]`, so a host keeps one
//! buffer per hit: `prepare` writes its front, each call its own words
//! after it. A slot written under a point-only branch is read only under
//! the same branch, so the buffer need not be cleared between hits (the
//! tests fill it with NaNs before `prepare`). A record is at most [`MAX_RECORD_WORDS`] words; a group that
//! would need more passes only its hit inputs through the record.

use super::adce::eliminate_dead_code_aggressive;
use super::{Function, Inst, Op, Value};
use std::ops::Range;

/// The most words a hit record holds (16 KiB). A `select` over several
/// textured trees needs the slots of all of them (only the chosen one's
/// are written at a hit): `texture_tree`'s cube uses about 800.
pub const MAX_RECORD_WORDS: usize = 4096;

/// One method's share of a combined function.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Part {
    /// The method's function name.
    pub name: String,
    /// Its own argument words in the combined function (after the hit inputs).
    pub params: Range<u32>,
    /// Its result words in the combined function.
    pub results: Range<u32>,
}

/// A combined function split into the per-hit stage and the methods.
#[derive(Debug, Clone)]
pub struct Split {
    /// Arguments: the hit inputs. Results: the hit record.
    pub prepare: Function,
    /// One per [`Part`], in order: arguments `[record | own arguments]`.
    pub methods: Vec<Function>,
}

impl Split {
    /// The number of words of the hit record.
    pub fn record_words(&self) -> usize {
        self.prepare.results.len()
    }
}

/// Splits `combined`, whose first `hit_inputs` argument words are the hit
/// inputs, into `prepare` and one function per part.
pub fn split(combined: &Function, hit_inputs: u32, parts: &[Part]) -> Split {
    split_with(combined, hit_inputs, parts, Hoist::PointOnly)
        .unwrap_or_else(|| split_with(combined, hit_inputs, parts, Hoist::InputsOnly).expect("the inputs fit"))
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Hoist {
    PointOnly,
    /// Only the hit inputs go through the record (the fallback when the
    /// point-only values would not fit).
    InputsOnly,
}

fn split_with(combined: &Function, hit_inputs: u32, parts: &[Part], hoist: Hoist) -> Option<Split> {
    let point = PointOnly::analyse(combined, hit_inputs);
    let eligible: Vec<bool> = (0..combined.values.len())
        .map(|v| match point.leaves[v] {
            Leaf::Param => point.values[v],
            Leaf::Free => false,
            Leaf::Work => hoist == Hoist::PointOnly && point.values[v] && !point.in_loop[v],
        })
        .collect();

    // Each eligible value gets a candidate slot; methods read slot `s` as
    // argument word `first_slot + s` until the slots used are known.
    let first_slot = combined.params.len() as u32;
    let mut slot_of = vec![None; combined.values.len()];
    let mut slot_values = Vec::new();
    let mut prepare_body = Vec::new();
    point.extract(&combined.body, true, &eligible, &mut slot_of, &mut slot_values, &mut prepare_body);
    let rewritten = replace_by_slots(&combined.body, &slot_of, first_slot);

    let mut methods = Vec::with_capacity(parts.len());
    let mut used = vec![false; slot_values.len()];
    for part in parts {
        let mut f =
            Function { name: part.name.clone(), body: only_outputs(&rewritten, &part.results), ..combined.clone() };
        f.results = combined.results[part.results.start as usize..part.results.end as usize].to_vec();
        eliminate_dead_code_aggressive(&mut f);
        super::for_each_op(&f.body, &mut |op| {
            if let Op::Param(k) = op
                && *k >= first_slot
            {
                used[(*k - first_slot) as usize] = true;
            }
        });
        methods.push(f);
    }
    let mut record_slot = vec![None; slot_values.len()];
    let mut record = Vec::new();
    for (s, v) in slot_values.iter().enumerate() {
        if used[s] {
            record_slot[s] = Some(record.len() as u32);
            record.push(combined.value_type(*v));
        }
    }
    if record.len() > MAX_RECORD_WORDS {
        return None;
    }
    let words = record.len() as u32;

    let mut prepare = Function {
        name: format!("{}.prepare", combined.name),
        params: combined.params[..hit_inputs as usize].to_vec(),
        results: record,
        body: renumber_outputs(prepare_body, &record_slot),
        ..combined.clone()
    };
    // Flattened branches leave copies of one computation side by side.
    super::gvn::value_number(&mut prepare);
    eliminate_dead_code_aggressive(&mut prepare);
    for (f, part) in methods.iter_mut().zip(parts) {
        let own = &combined.params[part.params.start as usize..part.params.end as usize];
        f.params = prepare.results.iter().chain(own).copied().collect();
        f.record_words = words;
        f.body = remap_params(std::mem::take(&mut f.body), &|k| {
            if k >= first_slot {
                record_slot[(k - first_slot) as usize].expect("a used slot")
            } else {
                debug_assert!(part.params.contains(&k), "{}: reads argument {k} of another method", part.name);
                words + k - part.params.start
            }
        });
    }
    super::verify::debug_verify(&prepare, "the per-hit split");
    for f in &methods {
        super::verify::debug_verify(f, "the per-hit split");
    }
    Some(Split { prepare, methods })
}

/// What a definition is, for the choice of what goes into the record.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Leaf {
    /// An argument word: a hit input goes through the record whatever else does.
    Param,
    /// A constant or a global: no cheaper to read from the record.
    Free,
    /// Everything else: worth hoisting when point-only.
    Work,
}

impl Leaf {
    fn of(op: &Op) -> Leaf {
        match op {
            Op::Param(_) => Leaf::Param,
            Op::F32(_) | Op::I32(_) | Op::Bool(_) | Op::Global(_) | Op::InstanceWord(_) => Leaf::Free,
            _ => Leaf::Work,
        }
    }
}

/// Which values, variables and arrays are point-only (the module's rule).
struct PointOnly {
    hit_inputs: u32,
    /// What each definition is, for the choice of what to hoist.
    leaves: Vec<Leaf>,
    values: Vec<bool>,
    /// Defined in a point-only loop: one value per iteration, not per call.
    in_loop: Vec<bool>,
    vars: Vec<bool>,
    arrays: Vec<bool>,
    /// Arrays written once, by a texture lookup.
    lookups: Vec<bool>,
    /// Blocks and loops left or repeated under per-call control.
    per_call_exit: Vec<bool>,
    changed: bool,
}

impl PointOnly {
    fn analyse(f: &Function, hit_inputs: u32) -> PointOnly {
        let lookups = super::lookup_arrays(f);
        let mut p = PointOnly {
            hit_inputs,
            leaves: vec![Leaf::Free; f.values.len()],
            values: vec![false; f.values.len()],
            in_loop: vec![false; f.values.len()],
            vars: vec![true; f.vars.len()],
            arrays: vec![true; f.arrays.len()],
            lookups,
            per_call_exit: vec![false; f.labels as usize],
            changed: true,
        };
        // Only demotions happen, so this ends.
        while p.changed {
            p.changed = false;
            p.walk(&f.body, true, false);
        }
        p
    }

    fn op(&self, op: &Op) -> bool {
        match op {
            Op::F32(_) | Op::I32(_) | Op::Bool(_) | Op::Global(_) | Op::InstanceWord(_) => true,
            Op::Param(k) => *k < self.hit_inputs,
            Op::Get(var) => self.vars[var.0 as usize],
            Op::Load { array, index } => self.arrays[array.0 as usize] && self.values[index.0 as usize],
            _ => {
                let mut all = true;
                super::opt::for_each_operand(op, |v| all &= self.values[v.0 as usize]);
                all
            }
        }
    }

    fn v(&self, v: Value) -> bool {
        self.values[v.0 as usize]
    }

    fn demote(flag: &mut bool, changed: &mut bool) {
        if *flag {
            *flag = false;
            *changed = true;
        }
    }

    /// `control`: whether whether and how often this body runs is
    /// point-only. `in_loop`: inside a point-only loop.
    fn walk(&mut self, body: &[Inst], control: bool, in_loop: bool) {
        for inst in body {
            match inst {
                Inst::Def(v, op) => {
                    let k = v.0 as usize;
                    self.values[k] = self.op(op);
                    self.in_loop[k] = in_loop;
                    self.leaves[k] = Leaf::of(op);
                }
                Inst::Set(var, v) => {
                    if !(control && self.v(*v)) {
                        Self::demote(&mut self.vars[var.0 as usize], &mut self.changed);
                    }
                }
                Inst::Store { array, index, value } => {
                    if !(control && self.v(*index) && self.v(*value)) {
                        Self::demote(&mut self.arrays[array.0 as usize], &mut self.changed);
                    }
                }
                Inst::Texture { coords, out, .. } => {
                    let inputs = coords.iter().all(|c| self.v(*c));
                    if !(inputs && (control || self.lookups[out.0 as usize])) {
                        Self::demote(&mut self.arrays[out.0 as usize], &mut self.changed);
                    }
                }
                Inst::Output(..) => {}
                Inst::If { cond, then_body, else_body } => {
                    let c = control && self.v(*cond);
                    self.walk(then_body, c, in_loop);
                    self.walk(else_body, c, in_loop);
                }
                Inst::Block { label, body } => {
                    let c = control && !self.per_call_exit[label.0 as usize];
                    self.walk(body, c, in_loop);
                }
                Inst::Loop { label, counter, start, end, body } => {
                    let c = control && self.v(*start) && self.v(*end) && !self.per_call_exit[label.0 as usize];
                    if !c {
                        Self::demote(&mut self.vars[counter.0 as usize], &mut self.changed);
                    }
                    self.walk(body, c, in_loop || c);
                }
                Inst::Break(l) | Inst::Continue(l) => {
                    let k = l.0 as usize;
                    if !control && !self.per_call_exit[k] {
                        self.per_call_exit[k] = true;
                        self.changed = true;
                    }
                }
            }
        }
    }

    /// The point-only part of `body`: per-call control flow is flattened
    /// (its point-only content runs unconditionally, once), and each
    /// eligible value is written to a slot right after its definition.
    fn extract(
        &self,
        body: &[Inst],
        control: bool,
        eligible: &[bool],
        slot_of: &mut [Option<u32>],
        slot_values: &mut Vec<Value>,
        out: &mut Vec<Inst>,
    ) {
        for inst in body {
            match inst {
                Inst::Def(v, _) if self.v(*v) => {
                    out.push(inst.clone());
                    if eligible[v.0 as usize] {
                        let s = slot_values.len() as u32;
                        slot_values.push(*v);
                        slot_of[v.0 as usize] = Some(s);
                        out.push(Inst::Output(s, *v));
                    }
                }
                Inst::Set(var, _) if self.vars[var.0 as usize] => out.push(inst.clone()),
                Inst::Store { array, .. } | Inst::Texture { out: array, .. } if self.arrays[array.0 as usize] => {
                    out.push(inst.clone())
                }
                Inst::If { cond, then_body, else_body } => {
                    if control && self.v(*cond) {
                        let mut t = Vec::new();
                        let mut e = Vec::new();
                        self.extract(then_body, true, eligible, slot_of, slot_values, &mut t);
                        self.extract(else_body, true, eligible, slot_of, slot_values, &mut e);
                        out.push(Inst::If { cond: *cond, then_body: t, else_body: e });
                    } else {
                        self.extract(then_body, false, eligible, slot_of, slot_values, out);
                        self.extract(else_body, false, eligible, slot_of, slot_values, out);
                    }
                }
                Inst::Block { label, body } => {
                    if control && !self.per_call_exit[label.0 as usize] {
                        let mut b = Vec::new();
                        self.extract(body, true, eligible, slot_of, slot_values, &mut b);
                        out.push(Inst::Block { label: *label, body: b });
                    } else {
                        self.extract(body, false, eligible, slot_of, slot_values, out);
                    }
                }
                Inst::Loop { label, counter, start, end, body } => {
                    if self.vars[counter.0 as usize] {
                        let mut b = Vec::new();
                        self.extract(body, true, eligible, slot_of, slot_values, &mut b);
                        out.push(Inst::Loop { label: *label, counter: *counter, start: *start, end: *end, body: b });
                    } else {
                        self.extract(body, false, eligible, slot_of, slot_values, out);
                    }
                }
                Inst::Break(_) | Inst::Continue(_) if control => out.push(inst.clone()),
                _ => {}
            }
        }
    }
}

/// `body` with each value that has a slot read from argument word
/// `first_slot + slot` instead of computed.
fn replace_by_slots(body: &[Inst], slot_of: &[Option<u32>], first_slot: u32) -> Vec<Inst> {
    body.iter()
        .map(|inst| match inst {
            Inst::Def(v, _) if slot_of[v.0 as usize].is_some() => {
                Inst::Def(*v, Op::Param(first_slot + slot_of[v.0 as usize].unwrap_or_default()))
            }
            Inst::If { cond, then_body, else_body } => Inst::If {
                cond: *cond,
                then_body: replace_by_slots(then_body, slot_of, first_slot),
                else_body: replace_by_slots(else_body, slot_of, first_slot),
            },
            Inst::Block { label, body } => {
                Inst::Block { label: *label, body: replace_by_slots(body, slot_of, first_slot) }
            }
            Inst::Loop { label, counter, start, end, body } => Inst::Loop {
                label: *label,
                counter: *counter,
                start: *start,
                end: *end,
                body: replace_by_slots(body, slot_of, first_slot),
            },
            other => other.clone(),
        })
        .collect()
}

/// `body` with only the outputs in `range`, numbered from 0.
fn only_outputs(body: &[Inst], range: &Range<u32>) -> Vec<Inst> {
    map_body(body.to_vec(), &mut |inst| match inst {
        Inst::Output(k, v) if range.contains(&k) => Some(Inst::Output(k - range.start, v)),
        Inst::Output(..) => None,
        other => Some(other),
    })
}

/// `body` with slot outputs renumbered into the record, unused ones gone.
fn renumber_outputs(body: Vec<Inst>, record_slot: &[Option<u32>]) -> Vec<Inst> {
    map_body(body, &mut |inst| match inst {
        Inst::Output(s, v) => record_slot[s as usize].map(|k| Inst::Output(k, v)),
        other => Some(other),
    })
}

fn remap_params(body: Vec<Inst>, to: &impl Fn(u32) -> u32) -> Vec<Inst> {
    map_body(body, &mut |inst| match inst {
        Inst::Def(v, Op::Param(k)) => Some(Inst::Def(v, Op::Param(to(k)))),
        other => Some(other),
    })
}

/// Applies `f` to every non-control instruction (keeping it when `f`
/// returns one), recursing into control flow.
fn map_body(body: Vec<Inst>, f: &mut impl FnMut(Inst) -> Option<Inst>) -> Vec<Inst> {
    let mut out = Vec::with_capacity(body.len());
    for inst in body {
        let mapped = match inst {
            Inst::If { cond, then_body, else_body } => {
                Some(Inst::If { cond, then_body: map_body(then_body, f), else_body: map_body(else_body, f) })
            }
            Inst::Block { label, body } => Some(Inst::Block { label, body: map_body(body, f) }),
            Inst::Loop { label, counter, start, end, body } => {
                Some(Inst::Loop { label, counter, start, end, body: map_body(body, f) })
            }
            other => f(other),
        };
        out.extend(mapped);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::{BinOp, Label, Scalar, Var};

    /// `fbm`-like: a loop over a global accumulates noise (point-only, so
    /// `prepare` runs it whole), and the method multiplies the sum by its
    /// own argument.
    fn fbm_times_arg() -> Function {
        use Scalar::{F32, I32};
        Function {
            name: "m".into(),
            params: vec![F32, F32],
            results: vec![F32],
            values: vec![F32, I32, I32, F32, F32, F32, F32, F32, F32],
            vars: vec![F32, I32],
            labels: 1,
            body: vec![
                Inst::Def(Value(0), Op::Global(0)),
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
                Inst::Def(Value(6), Op::Get(Var(0))),
                Inst::Def(Value(7), Op::Param(1)),
                Inst::Def(Value(8), Op::Binary(BinOp::FMul, Value(6), Value(7))),
                Inst::Output(0, Value(8)),
            ],
            ..Function::default()
        }
    }

    #[test]
    fn a_point_only_loop_moves_to_prepare_and_the_method_reads_its_result() {
        let f = fbm_times_arg();
        let part = Part { name: "m.alone".into(), params: 1..2, results: 0..1 };
        let split = split(&f, 1, std::slice::from_ref(&part));
        let loops = |f: &Function| {
            let mut n = 0;
            crate::ir::for_each_inst(&f.body, &mut |i| n += usize::from(matches!(i, Inst::Loop { .. })));
            n
        };
        assert_eq!(
            (loops(&split.prepare), loops(&split.methods[0])),
            (1, 0),
            "{}\n{}",
            split.prepare,
            split.methods[0]
        );
        assert_eq!(split.record_words(), 1, "only the sum crosses:\n{}", split.prepare);
        let mut globals = vec![0u32; crate::globals::GLOBAL_WORDS as usize];
        for x in [0.3f32, -1.7, 5.25] {
            globals[0] = x.to_bits();
            let args = [0.0f32.to_bits(), 2.5f32.to_bits()];
            let mut want = [0u32];
            crate::interp::run(&f, &globals, &args, &mut want);
            let mut record = [0u32];
            crate::interp::run(&split.prepare, &globals, &args[..1], &mut record);
            let mut got = [0u32];
            crate::interp::run(&split.methods[0], &globals, &[record[0], args[1]], &mut got);
            assert_eq!(got, want, "at P.x = {x}");
        }
    }

    /// Work under a per-call condition is computed by `prepare` anyway;
    /// a variable written there stays the method's.
    #[test]
    fn per_call_branches_are_flattened_and_their_writes_stay() {
        use Scalar::{Bool, F32};
        let f = Function {
            name: "m".into(),
            params: vec![F32],
            results: vec![F32],
            values: vec![F32, F32, Bool, F32, F32, F32],
            vars: vec![F32],
            body: vec![
                Inst::Def(Value(0), Op::Global(0)),
                Inst::Def(Value(1), Op::Param(0)),
                Inst::Def(Value(2), Op::Binary(BinOp::FLt, Value(1), Value(0))),
                Inst::Set(Var(0), Value(1)),
                Inst::If {
                    cond: Value(2),
                    then_body: vec![
                        Inst::Def(Value(3), Op::Call { native: "tsl_noise1", args: vec![Value(0)] }),
                        Inst::Set(Var(0), Value(3)),
                    ],
                    else_body: vec![],
                },
                Inst::Def(Value(4), Op::Get(Var(0))),
                Inst::Def(Value(5), Op::Binary(BinOp::FMul, Value(4), Value(4))),
                Inst::Output(0, Value(5)),
            ],
            ..Function::default()
        };
        let part = Part { name: "m.alone".into(), params: 0..1, results: 0..1 };
        let split = split(&f, 0, std::slice::from_ref(&part));
        let method = &split.methods[0];
        let mut calls = 0;
        crate::ir::for_each_op(&method.body, &mut |op| calls += usize::from(matches!(op, Op::Call { .. })));
        assert_eq!(calls, 0, "the noise is prepared:\n{}\n{method}", split.prepare);
        let mut globals = vec![0u32; crate::globals::GLOBAL_WORDS as usize];
        for (p, a) in [(0.5f32, 0.25f32), (0.5, 0.75), (-2.0, -3.0)] {
            globals[0] = p.to_bits();
            let mut want = [0u32];
            crate::interp::run(&f, &globals, &[a.to_bits()], &mut want);
            let mut record = vec![0u32; split.record_words()];
            crate::interp::run(&split.prepare, &globals, &[], &mut record);
            let mut got = [0u32];
            crate::interp::run(method, &globals, &[record, vec![a.to_bits()]].concat(), &mut got);
            assert_eq!(got, want, "at P.x = {p}, argument {a}");
        }
    }
}
