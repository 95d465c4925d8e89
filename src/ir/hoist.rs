//! Hoisting in hit groups: a generator called under a per-call condition
//! is lowered where the condition does not reach.
//!
//! A hit group (`ir::lower::hit`) lowers every method a renderer calls at
//! one hit into one function, so that lowering's memo shares what they
//! have in common. The memo is scoped, though: a child's texture first met
//! inside `sample`'s choice of a lobe (`if u1 < w`) is invisible to the
//! methods lowered after it, which compute it again; and the per-hit split
//! (`ir::split`) cannot move the copy under the condition when it holds a
//! loop (fBm's octaves). So while lowering a hit group the builder knows
//! which values are *per-call* (they depend on a method's own arguments:
//! `wi`, random numbers) and which scopes it entered under a per-call
//! condition, and an inlined function whose inputs are available above
//! those scopes is lowered there, its memo entry with it.
//!
//! Moving pure code up is always sound (IR operations are pure and
//! total); it is speculation, as the split's `prepare` already does for
//! everything point-only under a per-call condition. A scope entered under
//! a point-only condition (`select` by face, `mix` at a weight of 0 or 1)
//! stops the move: `prepare` keeps those branches.
//!
//! The same move to the function's outermost scope
//! ([`Builder::outermost`]) lowers constants, in every function: their
//! values read only the frame globals, so they are computed once there.

use super::builder::Builder;
use super::{ArrayId, Inst, Op, Value, Var};
use rustc_hash::FxHashSet as HashSet;

/// What the builder of a hit group tracks for hoisting.
#[derive(Debug, Default)]
pub(crate) struct Hoisting {
    /// Argument words from here on are the methods' own.
    first_own_word: u32,
    /// Per value: whether it depends on a method's own arguments.
    per_call: Vec<bool>,
    /// Per value: the depth of the scope it was defined in.
    depth: Vec<u32>,
    per_call_vars: HashSet<Var>,
    per_call_arrays: HashSet<ArrayId>,
    /// Per open scope: entered under a per-call condition.
    conditional: Vec<bool>,
}

impl Hoisting {
    fn per_call(&self, v: Value) -> bool {
        self.per_call.get(v.0 as usize).copied().unwrap_or(false)
    }
}

impl Builder {
    /// Turns hoisting on: argument words from `first_own_word` on are
    /// per-call. Call before any value is defined.
    pub(crate) fn hoist_above_per_call(&mut self, first_own_word: u32) {
        let n = self.func.values.len();
        self.hoisting = Some(Hoisting {
            first_own_word,
            per_call: vec![false; n],
            depth: vec![0; n],
            conditional: vec![false; self.stack.len()],
            ..Hoisting::default()
        });
    }

    /// Records a new value (defined by `op`, or a constant when `None`).
    pub(super) fn note_value(&mut self, v: Value, op: Option<&Op>) {
        let depth = self.stack.len().saturating_sub(1) as u32;
        let Some(h) = &mut self.hoisting else { return };
        let per_call = match op {
            None | Some(Op::Global(_) | Op::InstanceWord(_)) => false,
            Some(Op::Param(k)) => *k >= h.first_own_word,
            Some(Op::Get(var)) => h.per_call_vars.contains(var),
            Some(Op::Load { array, index }) => h.per_call_arrays.contains(array) || h.per_call(*index),
            Some(op) => {
                let mut any = false;
                super::opt::for_each_operand(op, |x| any |= h.per_call(x));
                any
            }
        };
        let k = v.0 as usize;
        if h.per_call.len() <= k {
            h.per_call.resize(k + 1, false);
            h.depth.resize(k + 1, 0);
        }
        h.per_call[k] = per_call;
        h.depth[k] = depth;
    }

    /// Records what an instruction writes: a variable or array written
    /// with a per-call value or under a per-call condition is per-call.
    pub(super) fn note_write(&mut self, inst: &Inst) {
        let Some(h) = &mut self.hoisting else { return };
        let under = h.conditional.iter().any(|c| *c);
        let pc = |v: &Value| h.per_call(*v);
        match inst {
            Inst::Set(var, v) if under || pc(v) => {
                h.per_call_vars.insert(*var);
            }
            Inst::Store { array, index, value } if under || pc(index) || pc(value) => {
                h.per_call_arrays.insert(*array);
            }
            Inst::Texture { coords, out, .. } if under || coords.iter().any(pc) => {
                h.per_call_arrays.insert(*out);
            }
            _ => {}
        }
    }

    /// A loop's counter is per-call when its bounds are.
    pub(crate) fn note_loop_counter(&mut self, counter: Var, bounds: [Value; 2]) {
        if bounds.iter().any(|v| self.is_per_call(*v))
            && let Some(h) = &mut self.hoisting
        {
            h.per_call_vars.insert(counter);
        }
    }

    /// Whether `v` depends on a method's own arguments (false when not
    /// hoisting).
    pub(crate) fn is_per_call(&self, v: Value) -> bool {
        self.hoisting.as_ref().is_some_and(|h| h.per_call(v))
    }

    pub(super) fn note_scope(&mut self, conditional: bool) {
        if let Some(h) = &mut self.hoisting {
            h.conditional.push(conditional);
        }
    }

    pub(super) fn note_scope_end(&mut self) {
        if let Some(h) = &mut self.hoisting {
            h.conditional.pop();
        }
    }

    /// The innermost open scope not entered under a per-call condition,
    /// if it is not the current one.
    fn anchor(&self) -> Option<usize> {
        let h = self.hoisting.as_ref()?;
        let anchor = h.conditional.iter().rposition(|c| !c).unwrap_or(0);
        (anchor + 1 < self.stack.len()).then_some(anchor)
    }

    /// Whether `v` may be read in scope `depth`: it is not per-call and is
    /// defined at or above that scope.
    fn movable_to(&self, v: Value, depth: usize) -> bool {
        let defined_above = |h: &Hoisting| h.depth.get(v.0 as usize).is_some_and(|d| *d as usize <= depth);
        !self.is_per_call(v) && (self.in_prologue.contains(&v) || self.hoisting.as_ref().is_some_and(defined_above))
    }

    /// Where to define `op` instead of the current scope: the anchor, for
    /// a pure operation on values that are available there and not
    /// per-call. (Reads of variables and arrays stay: a write between the
    /// anchor and here would change them.)
    pub(super) fn anchor_of(&self, op: &Op) -> Option<usize> {
        if matches!(op, Op::Get(_) | Op::Load { .. } | Op::Param(_) | Op::Global(_) | Op::InstanceWord(_)) {
            return None;
        }
        let anchor = self.anchor()?;
        let mut ok = true;
        super::opt::for_each_operand(op, |x| ok &= self.movable_to(x, anchor));
        ok.then_some(anchor)
    }

    /// Records that `v` was defined in scope `depth`.
    pub(super) fn place_at(&mut self, v: Value, depth: usize) {
        if let Some(h) = &mut self.hoisting {
            h.depth[v.0 as usize] = depth as u32;
        }
    }

    /// Runs `f` in the innermost open scope not entered under a per-call
    /// condition, if every value of `inputs` is available there; otherwise
    /// where the builder is. What `f` defines and remembers lands in that
    /// scope, before the per-call construct being built.
    pub(crate) fn hoisted<R>(&mut self, inputs: &[Value], f: impl FnOnce(&mut Builder) -> R) -> R {
        let Some(anchor) = self.anchor() else { return f(self) };
        if !inputs.iter().all(|v| self.movable_to(*v, anchor)) {
            return f(self);
        }
        self.in_scope(anchor, f)
    }

    /// Runs `f` in the function's outermost scope, wherever the builder
    /// is: what `f` defines and remembers there dominates every later
    /// instruction. For code whose inputs are all defined at the top (the
    /// value of a constant, which reads only the frame globals). The
    /// conditions known in the scopes left (`facts`) are hidden from `f`.
    pub(crate) fn outermost<R>(&mut self, f: impl FnOnce(&mut Builder) -> R) -> R {
        if self.stack.len() == 1 && self.facts.is_empty() {
            return f(self);
        }
        let facts = std::mem::take(&mut self.facts);
        let result = self.in_scope(0, f);
        self.facts = facts;
        result
    }

    /// Runs `f` in the open scope at `depth`, then reopens the inner ones.
    fn in_scope<R>(&mut self, depth: usize, f: impl FnOnce(&mut Builder) -> R) -> R {
        let stack = self.stack.split_off(depth + 1);
        let memo = self.memo.split_off(depth + 1);
        let conditional = self.hoisting.as_mut().map(|h| h.conditional.split_off(depth + 1)).unwrap_or_default();
        let result = f(self);
        self.stack.extend(stack);
        self.memo.restore(memo);
        if let Some(h) = &mut self.hoisting {
            h.conditional.extend(conditional);
        }
        result
    }
}
