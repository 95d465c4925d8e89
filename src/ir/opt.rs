//! IR clean-up after lowering: what the dead code passes share.
//!
//! Texture trees lower to much code whose results turn out unused: a method
//! whose children all return the same constant still computed the
//! generators that would have blended them. Every IR operation is pure, so
//! a definition nobody uses can go, and so can writes to variables and
//! arrays nobody reads, and control flow left empty.

use super::{Op, Value};

#[cfg(test)]
mod plain;
#[cfg(test)]
pub(crate) use plain::eliminate_dead_code;

/// Calls `f` on each value `op` reads.
pub(crate) fn for_each_operand(op: &Op, mut f: impl FnMut(Value)) {
    match op {
        Op::F32(_) | Op::I32(_) | Op::Bool(_) | Op::Param(_) | Op::Global(_) | Op::InstanceWord(_) | Op::Get(_) => {}
        Op::Load { index, .. } | Op::Table { index, .. } => f(*index),
        Op::Unary(_, a) => f(*a),
        Op::Binary(_, a, b) => {
            f(*a);
            f(*b);
        }
        Op::Select { cond, then_value, else_value } => {
            f(*cond);
            f(*then_value);
            f(*else_value);
        }
        Op::Call { args, .. } => args.iter().for_each(|a| f(*a)),
    }
}
