//! Tests that read the IR itself (operation counts, tables, function
//! shapes): they live in the crate because `ir` is not public API.

mod bounded;
mod deep_chain;
mod lowering;
mod prepared;
mod scene_constants;

use crate::ir::Scalar;

pub(super) use crate::test_support::{Rng, shading_point};

/// Whether two result words agree: exactly, or within 1e-5 relative for
/// floats (both NaN counts as agreeing), as `tests/common::close`.
pub(super) fn close(a: u32, b: u32, ty: Scalar) -> bool {
    if a == b {
        return true;
    }
    if ty != Scalar::F32 {
        return false;
    }
    let (x, y) = (f32::from_bits(a), f32::from_bits(b));
    (x.is_nan() && y.is_nan()) || (x - y).abs() <= 1e-5 * x.abs().max(y.abs()).max(1.0)
}
