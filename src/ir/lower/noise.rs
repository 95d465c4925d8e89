//! Perlin's improved noise lowered to IR instead of a native call, so the
//! JIT compiles it inline (no call, no spilled registers, shared work value
//! numbered) and the interpreter runs it as the oracle of every step.
//!
//! The algorithm is `runtime::tsl_noise1/2/3` exactly, in f32: the lattice
//! cell and the fraction are exact (`x - floor(x)` is exact in f32), the
//! cell is reduced modulo 256 in floating point (exact for every f32), the
//! hash and gradients come from the same tables, and only the fade and
//! interpolation round differently from the native's f64, by about 1e-7.
//! A non-finite coordinate gives 0, as the native.

use super::{Builder, Value};
use crate::ir::{BinOp, Op, Scalar, UnOp};
use crate::runtime::{GRAD1_WORDS, GRAD2_WORDS, GRAD3_WORDS, NOISE_SCALES, PERM_WORDS};

/// One axis of a lattice cell: the table indices of its two corners and
/// the fraction in it.
struct Axis {
    i0: Value,
    i1: Value,
    t: Value,
}

fn axis(b: &mut Builder, x: Value) -> Axis {
    let floor = b.un(UnOp::Floor, x);
    let t = b.fsub(x, floor);
    // floor mod 256 without integer overflow: floor - 256 floor(floor / 256)
    // is exact for every f32 (powers of two scale exactly).
    let (inv, period) = (b.f(1.0 / 256.0), b.f(256.0));
    let q = b.fmul(floor, inv);
    let q = b.un(UnOp::Floor, q);
    let q = b.fmul(q, period);
    let m = b.fsub(floor, q);
    let i0 = b.un(UnOp::FToI, m);
    let one = b.i(1);
    let i1 = b.bin(BinOp::IAdd, i0, one);
    let mask = b.i(255);
    let i1 = b.bin(BinOp::IAnd, i1, mask);
    Axis { i0, i1, t }
}

/// `PERM[i & 255]` (the table lookup masks its index).
fn perm(b: &mut Builder, i: Value) -> Value {
    b.def(Scalar::I32, Op::Table { table: &PERM_WORDS, index: i })
}

/// `perm(h + i)`: the next level of Perlin's nested hash.
fn hash(b: &mut Builder, h: Value, i: Value) -> Value {
    let sum = b.bin(BinOp::IAdd, h, i);
    perm(b, sum)
}

/// `words[h & (len - 1)]` as an f32.
fn table(b: &mut Builder, words: &'static [u32], h: Value) -> Value {
    b.def(Scalar::F32, Op::Table { table: words, index: h })
}

/// t^3 (t (6 t - 15) + 10).
fn fade(b: &mut Builder, t: Value) -> Value {
    let (six, fifteen, ten) = (b.f(6.0), b.f(15.0), b.f(10.0));
    let a = b.fmul(t, six);
    let a = b.fsub(a, fifteen);
    let a = b.fmul(t, a);
    let a = b.fadd(a, ten);
    let t2 = b.fmul(t, t);
    let t3 = b.fmul(t2, t);
    b.fmul(t3, a)
}

/// a + t (c - a): the native's form (`Builder::lerp` weighs both ends).
fn lerp(b: &mut Builder, t: Value, a: Value, c: Value) -> Value {
    let d = b.fsub(c, a);
    let d = b.fmul(t, d);
    b.fadd(a, d)
}

fn minus_one(b: &mut Builder, x: Value) -> Value {
    let one = b.f(1.0);
    b.fsub(x, one)
}

fn grad2(b: &mut Builder, h: Value, x: Value, y: Value) -> Value {
    let g = [table(b, &GRAD2_WORDS[0], h), table(b, &GRAD2_WORDS[1], h)];
    b.dot(&g, &[x, y])
}

fn grad3(b: &mut Builder, h: Value, d: [Value; 3]) -> Value {
    let g = [table(b, &GRAD3_WORDS[0], h), table(b, &GRAD3_WORDS[1], h), table(b, &GRAD3_WORDS[2], h)];
    b.dot(&g, &d)
}

/// `noise(p)` for a float, vec2 or point (1, 2 or 3 lanes): in [-1, 1].
pub(super) fn noise(b: &mut Builder, p: &[Value]) -> Value {
    let axes: Vec<Axis> = p.iter().map(|x| axis(b, *x)).collect();
    let raw = match axes.as_slice() {
        [a] => {
            let g0 = perm(b, a.i0);
            let g0 = table(b, &GRAD1_WORDS, g0);
            let g0 = b.fmul(g0, a.t);
            let g1 = perm(b, a.i1);
            let g1 = table(b, &GRAD1_WORDS, g1);
            let t1 = minus_one(b, a.t);
            let g1 = b.fmul(g1, t1);
            let u = fade(b, a.t);
            lerp(b, u, g0, g1)
        }
        [a, c] => {
            let (x, y) = (a.t, c.t);
            let (x1, y1) = (minus_one(b, x), minus_one(b, y));
            let (h0, h1) = (perm(b, a.i0), perm(b, a.i1));
            let u = fade(b, x);
            let h00 = hash(b, h0, c.i0);
            let h10 = hash(b, h1, c.i0);
            let h01 = hash(b, h0, c.i1);
            let h11 = hash(b, h1, c.i1);
            let (g00, g10) = (grad2(b, h00, x, y), grad2(b, h10, x1, y));
            let (g01, g11) = (grad2(b, h01, x, y1), grad2(b, h11, x1, y1));
            let lo = lerp(b, u, g00, g10);
            let hi = lerp(b, u, g01, g11);
            let v = fade(b, y);
            lerp(b, v, lo, hi)
        }
        [a, c, e] => {
            let (x, y, z) = (a.t, c.t, e.t);
            let (x1, y1, z1) = (minus_one(b, x), minus_one(b, y), minus_one(b, z));
            let (u, v, w) = (fade(b, x), fade(b, y), fade(b, z));
            let (px0, px1) = (perm(b, a.i0), perm(b, a.i1));
            let p00 = hash(b, px0, c.i0);
            let p01 = hash(b, px0, c.i1);
            let p10 = hash(b, px1, c.i0);
            let p11 = hash(b, px1, c.i1);
            let mut faces = Vec::with_capacity(2);
            for (iz, zz) in [(e.i0, z), (e.i1, z1)] {
                let corner = |b: &mut Builder, p: Value, d: [Value; 3]| {
                    let h = hash(b, p, iz);
                    grad3(b, h, d)
                };
                let c00 = corner(b, p00, [x, y, zz]);
                let c10 = corner(b, p10, [x1, y, zz]);
                let c01 = corner(b, p01, [x, y1, zz]);
                let c11 = corner(b, p11, [x1, y1, zz]);
                let lo = lerp(b, u, c00, c10);
                let hi = lerp(b, u, c01, c11);
                faces.push(lerp(b, v, lo, hi));
            }
            lerp(b, w, faces[0], faces[1])
        }
        _ => return b.f(0.0),
    };
    let scale = b.f(NOISE_SCALES[axes.len() - 1]);
    let scaled = b.fmul(raw, scale);
    let (lo, hi) = (b.f(-1.0), b.f(1.0));
    let clamped = b.fmax(scaled, lo);
    let clamped = b.fmin(clamped, hi);
    // A coordinate that is not finite makes its fraction `x - floor(x)`,
    // and so `raw`, NaN; finite ones never do. One test, not one per axis.
    let zero = b.f(0.0);
    let finite = b.feq(raw, raw);
    b.select(finite, clamped, zero)
}
