//! Tests that read the IR itself (operation counts, tables, function
//! shapes): they live in the crate because `ir` is not public API.

mod bounded;
mod deep_chain;
mod lowering;
mod prepared;
mod scene_constants;

use crate::ShadingGlobals;
use crate::ir::Scalar;

/// A small deterministic generator (xorshift), so failures reproduce (the
/// integration tests' `tests/common::Rng`).
pub(super) struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * ((self.next() >> 40) as f32 / (1u64 << 24) as f32)
    }

    /// A random unit vector.
    pub fn unit(&mut self) -> [f32; 3] {
        loop {
            let v = [self.range(-1.0, 1.0), self.range(-1.0, 1.0), self.range(-1.0, 1.0)];
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            if l > 0.1 && l <= 1.0 {
                return [v[0] / l, v[1] / l, v[2] / l];
            }
        }
    }
}

/// A random shading point around the origin, as `tests/common::shading_point`
/// draws it (the same sequence for a seed); `face` runs from -1 to 6 so
/// clamped selections are exercised too.
pub(super) fn shading_point(rng: &mut Rng) -> ShadingGlobals {
    let p = [rng.range(-3.0, 3.0), rng.range(-3.0, 3.0), rng.range(-3.0, 3.0)];
    let n = rng.unit();
    ShadingGlobals {
        p,
        pl: [p[0] * 0.5, p[1] * 0.5, p[2] * 0.5],
        n,
        ng: n,
        u: rng.range(0.0, 1.0),
        v: rng.range(0.0, 1.0),
        dpdu: rng.unit(),
        dpdv: rng.unit(),
        face: (rng.next() % 8) as i32 - 1,
        t: rng.range(0.0, 10.0),
        dpdx: [rng.range(0.0, 0.01), 0.0, 0.0],
        dpdy: [0.0, rng.range(0.0, 0.01), 0.0],
        dudx: rng.range(0.0, 0.01),
        dudy: 0.0,
        dvdx: 0.0,
        dvdy: rng.range(0.0, 0.01),
        frame: (rng.next() % 100) as i32 - 10,
        time: rng.range(-1.0, 4.0),
        ..Default::default()
    }
}

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
