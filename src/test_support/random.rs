//! Random shading inputs shared by the crate's unit tests and the
//! integration tests (`tests/common` includes this file by path), so both
//! draw the same sequences from a seed. Each user names `ShadingGlobals` in
//! its parent module; each uses part of what is here.
#![allow(dead_code)]

use super::ShadingGlobals;

/// A small deterministic generator (xorshift), so failures reproduce.
pub struct Rng(pub u64);

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

    /// Mostly ordinary floats, sometimes an extreme one.
    pub fn float(&mut self) -> f32 {
        match self.next() % 16 {
            0 => [0.0, -0.0, 1e30, -1e30, f32::INFINITY, f32::NAN, 1e-30, 16777217.0][(self.next() % 8) as usize],
            _ => self.range(-3.0, 3.0),
        }
    }

    /// Mostly small ints, sometimes an extreme one.
    pub fn int(&mut self) -> i32 {
        match self.next() % 10 {
            0 => [i32::MIN, i32::MAX, -1, 0, 1_000_000][(self.next() % 5) as usize],
            _ => (self.next() % 12) as i32 - 3,
        }
    }
}

/// A random shading point around the origin; `face` runs from -1 to 6 so
/// clamped selections are exercised too.
pub fn shading_point(rng: &mut Rng) -> ShadingGlobals {
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
