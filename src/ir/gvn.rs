//! Value numbering over a finished function: a pure operation computed
//! again where an identical one dominates it is replaced by the first.
//!
//! Lowering numbers values as it builds, but a generator first evaluated
//! inside a branch (one child of a mixture, sampled) is not visible to the
//! next method of a hit group; the per-hit split (`ir::split`) flattens
//! such branches in `prepare`, where the copies become siblings and this
//! pass merges them. Texture lookups into arrays written once are pure too.

use super::builder::{ConstKey, OpKey};
use super::{ArrayId, Function, Inst, Op, SamplerRef, Value};
use rustc_hash::FxHashMap as HashMap;

#[derive(Clone, PartialEq, Eq, Hash)]
enum Key {
    Op(OpKey),
    Const(ConstKey),
    /// A load from an array written once, by a lookup.
    Load(ArrayId, Value),
    Texture(usize, Vec<Value>),
}

/// Merges repeated pure operations and texture lookups of `f`.
pub fn value_number(f: &mut Function) {
    let lookup = super::lookup_arrays(f);
    let mut n = Numbering {
        values: (0..f.values.len() as u32).map(Value).collect(),
        arrays: (0..f.arrays.len() as u32).map(ArrayId).collect(),
        lookup,
        scopes: vec![HashMap::default()],
    };
    f.body = n.body(std::mem::take(&mut f.body));
}

struct Numbering {
    /// What each value (array) was replaced by.
    values: Vec<Value>,
    arrays: Vec<ArrayId>,
    lookup: Vec<bool>,
    scopes: Vec<HashMap<Key, Value>>,
}

impl Numbering {
    fn v(&self, v: Value) -> Value {
        self.values[v.0 as usize]
    }

    fn find(&self, key: &Key) -> Option<Value> {
        self.scopes.iter().rev().find_map(|s| s.get(key).copied())
    }

    fn remember(&mut self, key: Key, v: Value) {
        if let Some(top) = self.scopes.last_mut() {
            top.insert(key, v);
        }
    }

    fn nested(&mut self, body: Vec<Inst>) -> Vec<Inst> {
        self.scopes.push(HashMap::default());
        let body = self.body(body);
        self.scopes.pop();
        body
    }

    fn op(&self, op: Op) -> Op {
        let v = |x: Value| self.v(x);
        match op {
            Op::Load { array, index } => Op::Load { array: self.arrays[array.0 as usize], index: v(index) },
            Op::Table { table, index } => Op::Table { table, index: v(index) },
            Op::Unary(u, a) => Op::Unary(u, v(a)),
            Op::Binary(b, x, y) => Op::Binary(b, v(x), v(y)),
            Op::Select { cond, then_value, else_value } => {
                Op::Select { cond: v(cond), then_value: v(then_value), else_value: v(else_value) }
            }
            Op::Call { native, args } => Op::Call { native, args: args.into_iter().map(v).collect() },
            other => other,
        }
    }

    fn key(&self, op: &Op) -> Option<Key> {
        match op {
            Op::F32(x) => Some(Key::Const(ConstKey::F(x.to_bits()))),
            Op::I32(x) => Some(Key::Const(ConstKey::I(*x))),
            Op::Bool(x) => Some(Key::Const(ConstKey::B(*x))),
            Op::Load { array, index } if self.lookup[array.0 as usize] => Some(Key::Load(*array, *index)),
            _ => OpKey::of(op).map(Key::Op),
        }
    }

    fn body(&mut self, body: Vec<Inst>) -> Vec<Inst> {
        let mut out = Vec::with_capacity(body.len());
        for inst in body {
            let inst = match inst {
                Inst::Def(v, op) => {
                    let op = self.op(op);
                    let key = self.key(&op);
                    if let Some(w) = key.as_ref().and_then(|k| self.find(k)) {
                        self.values[v.0 as usize] = w;
                        continue;
                    }
                    if let Some(k) = key {
                        self.remember(k, v);
                    }
                    Inst::Def(v, op)
                }
                Inst::Set(var, v) => Inst::Set(var, self.v(v)),
                Inst::Store { array, index, value } => {
                    Inst::Store { array, index: self.v(index), value: self.v(value) }
                }
                Inst::Output(k, v) => Inst::Output(k, self.v(v)),
                Inst::Texture { sampler, coords, out: array } => {
                    let coords: Vec<Value> = coords.into_iter().map(|c| self.v(c)).collect();
                    if self.lookup[array.0 as usize] {
                        let key = Key::Texture(sampler_id(&sampler), coords.clone());
                        // An earlier identical lookup: read its array instead.
                        if let Some(Value(earlier)) = self.find(&key) {
                            self.arrays[array.0 as usize] = ArrayId(earlier);
                            continue;
                        }
                        self.remember(key, Value(array.0));
                    }
                    Inst::Texture { sampler, coords, out: array }
                }
                Inst::If { cond, then_body, else_body } => {
                    let cond = self.v(cond);
                    Inst::If { cond, then_body: self.nested(then_body), else_body: self.nested(else_body) }
                }
                Inst::Block { label, body } => Inst::Block { label, body: self.nested(body) },
                Inst::Loop { label, counter, start, end, body } => {
                    let (start, end) = (self.v(start), self.v(end));
                    Inst::Loop { label, counter, start, end, body: self.nested(body) }
                }
                other => other,
            };
            out.push(inst);
        }
        out
    }
}

/// Lookups through the same sampler compare equal.
fn sampler_id(s: &SamplerRef) -> usize {
    std::sync::Arc::as_ptr(&s.0) as usize
}
