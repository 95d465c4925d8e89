//! The native functions compiled shaders call: math that Cranelift has no
//! instruction for, noise, and the rough dielectric interface integrals of
//! `rough_plastic` ([`rough_interface`]).
//!
//! The interpreter and the JIT call these very functions (the JIT registers
//! [`Native::ptr`] as a symbol; the interpreter calls [`Native::f`]), so
//! both back ends agree bit for bit by construction. Every function is a
//! plain `extern "C" fn` over `f32` and is total: no input, NaN, infinity or
//! huge coordinate included, makes it panic or index out of bounds.
//!
//! # Noise
//!
//! [`tsl_noise1`], [`tsl_noise2`], [`tsl_noise3`] are Ken Perlin's improved
//! gradient noise (2002): his permutation table, the quintic fade
//! `6t^5 - 15t^4 + 10t^3`, linear interpolation of the corner gradients'
//! dot products. The gradients and output scales per dimension:
//!
//! | Form | Gradients | Raw bound (exact sup) | Scale |
//! |------|-----------|-----------------------|-------|
//! | 1D | `±1, ±2, …, ±8` (16 values) | 4 | `0.25` |
//! | 2D | 8 unit vectors, every 45° | `1/√2` | `√2` |
//! | 3D | Perlin's 12 edge directions `(±1, ±1, 0)`… | 1.0363538 | `0.9649` |
//!
//! The raw bound is the supremum over every point of a cell and every choice
//! of corner gradients (in 3D at `(0.3553, 0.4815, 0.5)` and its mirror
//! images), so the scaled result is within [-1, 1]; it is also clamped
//! there, which only guards against the last bit of rounding. Perlin's
//! table does realise the worst cases: the largest `|noise|` is 1 in 1D and
//! 2D (cell centres) and 0.99998 in 3D (at `(12.355257, 187.51851, 5.5)`,
//! found by scanning all 256³ cells), while 100,000 uniform random points
//! reach 0.99999, 0.959 and 0.909. Noise is 0 at every integer lattice
//! point and repeats every 256 units along each axis (the permutation
//! table's period).
//!
//! [`tsl_pnoise1`], [`tsl_pnoise2`], [`tsl_pnoise3`] take a period per axis,
//! rounded half away from zero to an integer in [1, 2^62] (NaN and anything
//! below 0.5 count as 1; +inf counts as 2^62, which like every multiple of
//! 256 gives plain noise). The lattice coordinates are reduced modulo the
//! period before hashing, so `pnoise(x + p, p) == pnoise(x, p)` bit for bit
//! whenever `x + p` is exact in `f32` (and within the rounding of that
//! addition otherwise).
//!
//! [`tsl_cellnoise1`], [`tsl_cellnoise2`], [`tsl_cellnoise3`] hash the
//! integer cell `floor(p)` with xxHash32 and return a value in [0, 1)
//! (24 bits of the hash), constant inside each cell.
//!
//! Any non-finite coordinate makes noise, pnoise and cellnoise return 0.
//! The math functions follow `f32` (NaN in, NaN out).

pub mod rough_interface;

pub use rough_interface::{tsl_rough_internal_reflectance, tsl_rough_transmittance};

/// A native function pointer, by arity.
#[derive(Clone, Copy, Debug)]
pub enum NativeFn {
    F1(extern "C" fn(f32) -> f32),
    F2(extern "C" fn(f32, f32) -> f32),
    F3(extern "C" fn(f32, f32, f32) -> f32),
    F4(extern "C" fn(f32, f32, f32, f32) -> f32),
    F6(extern "C" fn(f32, f32, f32, f32, f32, f32) -> f32),
}

impl NativeFn {
    /// The number of `f32` arguments.
    pub const fn arity(&self) -> usize {
        match self {
            NativeFn::F1(_) => 1,
            NativeFn::F2(_) => 2,
            NativeFn::F3(_) => 3,
            NativeFn::F4(_) => 4,
            NativeFn::F6(_) => 6,
        }
    }

    /// Calls the native with `args` (at least its arity of them).
    pub fn call(&self, args: &[f32]) -> f32 {
        match *self {
            NativeFn::F1(g) => g(args[0]),
            NativeFn::F2(g) => g(args[0], args[1]),
            NativeFn::F3(g) => g(args[0], args[1], args[2]),
            NativeFn::F4(g) => g(args[0], args[1], args[2], args[3]),
            NativeFn::F6(g) => g(args[0], args[1], args[2], args[3], args[4], args[5]),
        }
    }

    /// The code address, for a JIT symbol table (`runtime::tests` compares it
    /// with the table's pointer).
    #[cfg(test)]
    pub fn ptr(&self) -> *const u8 {
        match *self {
            NativeFn::F1(f) => f as *const u8,
            NativeFn::F2(f) => f as *const u8,
            NativeFn::F3(f) => f as *const u8,
            NativeFn::F4(f) => f as *const u8,
            NativeFn::F6(f) => f as *const u8,
        }
    }
}

/// Name, pointer and arity of every native, for the JIT's symbol table and
/// the interpreter. `ptr` is the address of `f`.
#[derive(Debug)]
pub struct Native {
    pub name: &'static str,
    pub arity: usize,
    pub ptr: *const u8,
    pub f: NativeFn,
}

// SAFETY: `ptr` is the address of an `extern "C" fn` (immutable code that
// lives for the whole program), never written through nor read as data, so
// sharing it between threads is as safe as sharing the fn pointer in `f`.
unsafe impl Sync for Native {}
// SAFETY: as above.
unsafe impl Send for Native {}

macro_rules! natives {
    ($($name:ident: $kind:ident),* $(,)?) => {
        static NATIVES: &[Native] = &[$({
            let f = NativeFn::$kind($name);
            Native { name: stringify!($name), arity: f.arity(), ptr: $name as *const u8, f }
        }),*];
    };
}

// Sorted by name: `native` searches by bisection (a test keeps this so).
natives! {
    tsl_acos: F1,
    tsl_asin: F1,
    tsl_atan: F1,
    tsl_atan2: F2,
    tsl_cellnoise1: F1,
    tsl_cellnoise2: F2,
    tsl_cellnoise3: F3,
    tsl_cos: F1,
    tsl_exp: F1,
    tsl_log: F1,
    tsl_noise1: F1,
    tsl_noise2: F2,
    tsl_noise3: F3,
    tsl_pnoise1: F2,
    tsl_pnoise2: F4,
    tsl_pnoise3: F6,
    tsl_pow: F2,
    tsl_rough_internal_reflectance: F3,
    tsl_rough_transmittance: F4,
    tsl_round: F1,
    tsl_sin: F1,
    tsl_tan: F1,
}

/// Every native, sorted by name.
pub fn natives() -> &'static [Native] {
    NATIVES
}

/// The native called `name`, if any.
pub fn native(name: &str) -> Option<&'static Native> {
    NATIVES.binary_search_by(|n| n.name.cmp(name)).ok().map(|i| &NATIVES[i])
}

// ---------------------------------------------------------------- math

/// `sin(x)`, radians.
pub extern "C" fn tsl_sin(x: f32) -> f32 {
    x.sin()
}

/// `cos(x)`, radians.
pub extern "C" fn tsl_cos(x: f32) -> f32 {
    x.cos()
}

/// `tan(x)`, radians.
pub extern "C" fn tsl_tan(x: f32) -> f32 {
    x.tan()
}

/// `asin(x)`; NaN outside [-1, 1].
pub extern "C" fn tsl_asin(x: f32) -> f32 {
    x.asin()
}

/// `acos(x)`; NaN outside [-1, 1].
pub extern "C" fn tsl_acos(x: f32) -> f32 {
    x.acos()
}

/// `atan(x)`, in [-π/2, π/2].
pub extern "C" fn tsl_atan(x: f32) -> f32 {
    x.atan()
}

/// `atan2(y, x)`, in [-π, π].
pub extern "C" fn tsl_atan2(y: f32, x: f32) -> f32 {
    y.atan2(x)
}

/// `e^x`.
pub extern "C" fn tsl_exp(x: f32) -> f32 {
    x.exp()
}

/// Natural logarithm; `-inf` at 0, NaN below.
pub extern "C" fn tsl_log(x: f32) -> f32 {
    x.ln()
}

/// `x^e` (`f32::powf`).
pub extern "C" fn tsl_pow(x: f32, e: f32) -> f32 {
    x.powf(e)
}

/// Rounds half away from zero (`f32::round`).
pub extern "C" fn tsl_round(x: f32) -> f32 {
    x.round()
}

// ---------------------------------------------------------------- noise

/// Ken Perlin's permutation table (the reference implementation's `p`).
const PERM: [u8; 256] = [
    151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30, 69, 142, 8, 99, 37, 240,
    21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94, 252, 219, 203, 117, 35, 11, 32, 57, 177, 33, 88,
    237, 149, 56, 87, 174, 20, 125, 136, 171, 168, 68, 175, 74, 165, 71, 134, 139, 48, 27, 166, 77, 146, 158, 231, 83,
    111, 229, 122, 60, 211, 133, 230, 220, 105, 92, 41, 55, 46, 245, 40, 244, 102, 143, 54, 65, 25, 63, 161, 1, 216,
    80, 73, 209, 76, 132, 187, 208, 89, 18, 169, 200, 196, 135, 130, 116, 188, 159, 86, 164, 100, 109, 198, 173, 186,
    3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147, 118, 126, 255, 82, 85, 212, 207, 206, 59, 227, 47, 16, 58, 17,
    182, 189, 28, 42, 223, 183, 170, 213, 119, 248, 152, 2, 44, 154, 163, 70, 221, 153, 101, 155, 167, 43, 172, 9, 129,
    22, 39, 253, 19, 98, 108, 110, 79, 113, 224, 232, 178, 185, 112, 104, 218, 246, 97, 228, 251, 34, 242, 193, 238,
    210, 144, 12, 191, 179, 162, 241, 81, 51, 145, 235, 249, 14, 239, 107, 49, 192, 214, 31, 181, 199, 106, 157, 184,
    84, 204, 176, 115, 121, 50, 45, 127, 4, 150, 254, 138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141, 128, 195,
    78, 66, 215, 61, 156, 180,
];

/// 1D output scale: gradients reach ±8 and the fade-weighted sum of two
/// opposite ones peaks at half the gradient (at the cell centre): 4.
const SCALE1: f64 = 0.25;
/// 2D output scale: the unit diagonals pointing at the cell centre give the
/// supremum `1/√2` there.
const SCALE2: f64 = std::f64::consts::SQRT_2;
/// 3D output scale, a little below `1 / 1.036353811211803`. That bound is
/// the maximum over a cell of `Σ w_c · max_g (g · d_c)` (corner weight times
/// the best of the 12 gradients against the offset to that corner), which
/// bounds every gradient assignment the permutation can produce; it is
/// reached at `(0.3553, 0.4815, 0.5)` and its mirror images.
const SCALE3: f64 = 0.9649;

/// The eight 2D gradients: axes and diagonals, all of unit length.
const GRAD2: [(f64, f64); 8] = {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0), (s, s), (-s, s), (s, -s), (-s, -s)]
};

// The tables inlined noise reads (`ir::lower::noise`), as IR words: the
// permutation as integers, the gradients as f32 bits.

/// [`PERM`] as words.
pub static PERM_WORDS: [u32; 256] = {
    let mut w = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        w[i] = PERM[i] as u32;
        i += 1;
    }
    w
};

/// The 1D gradient of hash `h & 15`: `±(1 + (h & 7))`, negative when bit 3 is set.
pub static GRAD1_WORDS: [u32; 16] = {
    let mut w = [0u32; 16];
    let mut h = 0;
    while h < 16 {
        let g = (1 + (h & 7)) as f32;
        w[h] = if h & 8 == 0 { g.to_bits() } else { (-g).to_bits() };
        h += 1;
    }
    w
};

/// The x and y components of the 2D gradients ([`GRAD2`]) of hash `h & 7`.
pub static GRAD2_WORDS: [[u32; 8]; 2] = {
    let mut w = [[0u32; 8]; 2];
    let mut h = 0;
    while h < 8 {
        w[0][h] = (GRAD2[h].0 as f32).to_bits();
        w[1][h] = (GRAD2[h].1 as f32).to_bits();
        h += 1;
    }
    w
};

/// The x, y and z components of Perlin's 3D gradients of hash `h & 15`
/// (what [`grad3`] dots with the offset).
pub static GRAD3_WORDS: [[u32; 16]; 3] = {
    let mut w = [[0u32; 16]; 3];
    let mut h = 0;
    while h < 16 {
        // grad3 adds ±u and ±v: u is x below 8, else y; v is y below 4,
        // x for 12 and 14, else z.
        let su: f32 = if h & 1 == 0 { 1.0 } else { -1.0 };
        let sv: f32 = if h & 2 == 0 { 1.0 } else { -1.0 };
        let mut g = [0.0f32; 3];
        if h < 8 {
            g[0] = su;
        } else {
            g[1] = su;
        }
        if h < 4 {
            g[1] += sv;
        } else if h == 12 || h == 14 {
            g[0] += sv;
        } else {
            g[2] += sv;
        }
        w[0][h] = g[0].to_bits();
        w[1][h] = g[1].to_bits();
        w[2][h] = g[2].to_bits();
        h += 1;
    }
    w
};

/// The name of a table above, by identity, for printing IR: `perm`,
/// `grad1`, `grad2.x`, `grad3.z`, ... (an address would differ between
/// runs and machines).
pub fn table_name(table: &[u32]) -> Option<&'static str> {
    let named: [(&'static str, &[u32]); 7] = [
        ("perm", &PERM_WORDS),
        ("grad1", &GRAD1_WORDS),
        ("grad2.x", &GRAD2_WORDS[0]),
        ("grad2.y", &GRAD2_WORDS[1]),
        ("grad3.x", &GRAD3_WORDS[0]),
        ("grad3.y", &GRAD3_WORDS[1]),
        ("grad3.z", &GRAD3_WORDS[2]),
    ];
    if let Some((name, _)) = named.iter().find(|(_, t)| std::ptr::eq(*t, table)) {
        return Some(name);
    }
    let jh = crate::color::jakob_hanika::table_words();
    let spectral = [("rgb2spec.c0", jh.coefficients[0]), ("rgb2spec.c1", jh.coefficients[1])];
    let spectral = spectral.into_iter().chain([("rgb2spec.c2", jh.coefficients[2])]);
    if let Some((name, _)) = spectral.into_iter().find(|(_, t)| std::ptr::eq(*t, table)) {
        return Some(name);
    }
    crate::ir::lower::curve_table_name(table).or_else(|| rough_interface::table_name(table))
}

/// The output scales of 1D, 2D and 3D noise, as f32.
pub const NOISE_SCALES: [f32; 3] = [SCALE1 as f32, SCALE2 as f32, SCALE3 as f32];

/// The period of the permutation table: plain noise is periodic noise with
/// this period on every axis.
const TABLE_PERIOD: i64 = 256;

#[inline]
fn perm(i: usize) -> usize {
    PERM[i & 255] as usize
}

#[inline]
fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

#[inline]
fn lerp(t: f64, a: f64, b: f64) -> f64 {
    a + t * (b - a)
}

#[inline]
fn grad1(h: usize, x: f64) -> f64 {
    let g = (1 + (h & 7)) as f64;
    if h & 8 == 0 { g * x } else { -g * x }
}

#[inline]
fn grad2(h: usize, x: f64, y: f64) -> f64 {
    let (gx, gy) = GRAD2[h & 7];
    gx * x + gy * y
}

/// Perlin's `grad`: 12 edge directions of a cube, 4 of them twice.
#[inline]
fn grad3(h: usize, x: f64, y: f64, z: f64) -> f64 {
    let h = h & 15;
    let u = if h < 8 { x } else { y };
    let v = if h < 4 {
        y
    } else if h == 12 || h == 14 {
        x
    } else {
        z
    };
    (if h & 1 == 0 { u } else { -u }) + (if h & 2 == 0 { v } else { -v })
}

/// One axis of a lattice cell: the table indices (0..=255) of its two
/// corners and the fractional position in it.
#[derive(Clone, Copy)]
struct Axis {
    i0: usize,
    i1: usize,
    t: f64,
}

/// The largest period: a multiple of 256, so it, like +inf, which it
/// stands for, gives plain noise.
const MAX_PERIOD: f32 = 4_611_686_018_427_387_904.0; // 2^62

/// A period as an integer in [1, 2^62]: rounded half away from zero; NaN
/// and anything below 1 after rounding are 1.
#[inline]
fn period(p: f32) -> i64 {
    let r = p.round();
    if r >= 1.0 { r.min(MAX_PERIOD) as i64 } else { 1 }
}

/// The cell axis of finite `x` with lattice coordinates reduced modulo
/// `period` (>= 1). The fraction is exact: `f64` holds `x - floor(x)` for
/// every `f32`. `as i64` saturates beyond ±9.2e18, where `x` is an integer
/// anyway, and the modular arithmetic cannot overflow.
#[inline]
fn axis(x: f32, period: i64) -> Axis {
    let x = f64::from(x);
    // floor without a libm call (the baseline x86-64 target has no
    // rounding instruction): truncate, then step down for negative
    // fractions. Beyond 2^52 every f64 is an integer already.
    let floor = if x.abs() < 4_503_599_627_370_496.0 {
        let t = x as i64 as f64;
        if t > x { t - 1.0 } else { t }
    } else {
        x
    };
    let cell = floor as i64;
    // The table's own period needs no division: a mask is rem_euclid.
    let i0 = if period == TABLE_PERIOD { cell & 255 } else { cell.rem_euclid(period) };
    let i1 = if i0 + 1 == period { 0 } else { i0 + 1 };
    Axis { i0: (i0 & 255) as usize, i1: (i1 & 255) as usize, t: x - floor }
}

/// The scaled result as `f32`, clamped into [-1, 1].
#[inline]
fn finish(raw: f64, scale: f64) -> f32 {
    ((raw * scale) as f32).clamp(-1.0, 1.0)
}

fn noise1_at(a: Axis) -> f32 {
    let g0 = grad1(perm(a.i0), a.t);
    let g1 = grad1(perm(a.i1), a.t - 1.0);
    finish(lerp(fade(a.t), g0, g1), SCALE1)
}

fn noise2_at(a: Axis, b: Axis) -> f32 {
    let (x, y) = (a.t, b.t);
    let (h0, h1) = (perm(a.i0), perm(a.i1));
    let h = |hx: usize, iy: usize| perm(hx + iy);
    let u = fade(x);
    let lo = lerp(u, grad2(h(h0, b.i0), x, y), grad2(h(h1, b.i0), x - 1.0, y));
    let hi = lerp(u, grad2(h(h0, b.i1), x, y - 1.0), grad2(h(h1, b.i1), x - 1.0, y - 1.0));
    finish(lerp(fade(y), lo, hi), SCALE2)
}

#[inline]
fn noise3_at(a: Axis, b: Axis, c: Axis) -> f32 {
    let (x, y, z) = (a.t, b.t, c.t);
    let (x1, y1, z1) = (x - 1.0, y - 1.0, z - 1.0);
    let (u, v, w) = (fade(x), fade(y), fade(z));
    // Perlin's hash p[p[p[X] + Y] + Z] with every corner's own coordinates,
    // so periodic wrapping works on each axis independently.
    let (px0, px1) = (perm(a.i0), perm(a.i1));
    let (p00, p01, p10, p11) = (perm(px0 + b.i0), perm(px0 + b.i1), perm(px1 + b.i0), perm(px1 + b.i1));
    let face = |iz: usize, z: f64| {
        let lo = lerp(u, grad3(perm(p00 + iz), x, y, z), grad3(perm(p10 + iz), x1, y, z));
        let hi = lerp(u, grad3(perm(p01 + iz), x, y1, z), grad3(perm(p11 + iz), x1, y1, z));
        lerp(v, lo, hi)
    };
    let (f0, f1) = (face(c.i0, z), face(c.i1, z1));
    finish(lerp(w, f0, f1), SCALE3)
}

/// Improved Perlin noise in 1D, in [-1, 1], 0 at integers; 0 for non-finite `x`.
pub extern "C" fn tsl_noise1(x: f32) -> f32 {
    if !x.is_finite() {
        return 0.0;
    }
    noise1_at(axis(x, TABLE_PERIOD))
}

/// Improved Perlin noise in 2D, in [-1, 1], 0 at lattice points; 0 when a
/// coordinate is not finite.
pub extern "C" fn tsl_noise2(x: f32, y: f32) -> f32 {
    if !(x.is_finite() && y.is_finite()) {
        return 0.0;
    }
    noise2_at(axis(x, TABLE_PERIOD), axis(y, TABLE_PERIOD))
}

/// Improved Perlin noise in 3D, in [-1, 1], 0 at lattice points; 0 when a
/// coordinate is not finite.
pub extern "C" fn tsl_noise3(x: f32, y: f32, z: f32) -> f32 {
    if !(x.is_finite() && y.is_finite() && z.is_finite()) {
        return 0.0;
    }
    noise3_at(axis(x, TABLE_PERIOD), axis(y, TABLE_PERIOD), axis(z, TABLE_PERIOD))
}

/// [`tsl_noise1`] repeating every `round(px)` (at least 1) units.
pub extern "C" fn tsl_pnoise1(x: f32, px: f32) -> f32 {
    if !x.is_finite() {
        return 0.0;
    }
    noise1_at(axis(x, period(px)))
}

/// [`tsl_noise2`] repeating every `round(px)`, `round(py)` (at least 1) units.
pub extern "C" fn tsl_pnoise2(x: f32, y: f32, px: f32, py: f32) -> f32 {
    if !(x.is_finite() && y.is_finite()) {
        return 0.0;
    }
    noise2_at(axis(x, period(px)), axis(y, period(py)))
}

/// [`tsl_noise3`] repeating every `round(px)`, `round(py)`, `round(pz)` (at
/// least 1) units.
pub extern "C" fn tsl_pnoise3(x: f32, y: f32, z: f32, px: f32, py: f32, pz: f32) -> f32 {
    if !(x.is_finite() && y.is_finite() && z.is_finite()) {
        return 0.0;
    }
    noise3_at(axis(x, period(px)), axis(y, period(py)), axis(z, period(pz)))
}

// ---------------------------------------------------------------- cellnoise

const XXH_P2: u32 = 0x85EB_CA77;
const XXH_P3: u32 = 0xC2B2_AE3D;
const XXH_P4: u32 = 0x27D4_EB2F;
const XXH_P5: u32 = 0x1656_67B1;
const XXH_P1: u32 = 0x9E37_79B1;

/// `floor(x)` as an integer, saturating like `as`, without a libm call (the
/// baseline x86-64 target has no rounding instruction): truncate, then
/// step down for negative fractions.
#[inline]
pub(crate) fn floor_to_i64(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) > x { t.saturating_sub(1) } else { t }
}

/// One 32-bit word per axis: `floor(x)` as an integer (saturating beyond
/// ±9.2e18), its high half folded in so cells beyond ±2^31 still differ.
#[inline]
fn cell(x: f32) -> u32 {
    let i = floor_to_i64(f64::from(x));
    (i as u32) ^ ((i >> 32) as u32).wrapping_mul(XXH_P1)
}

/// xxHash32 (seed 0) of the words as little-endian bytes, mapped to [0, 1)
/// through its top 24 bits (exact in `f32`, at most `1 - 2^-24`).
#[inline]
fn hash_unit(words: &[u32]) -> f32 {
    let mut h = XXH_P5.wrapping_add(4 * words.len() as u32);
    for &w in words {
        h = h.wrapping_add(w.wrapping_mul(XXH_P3)).rotate_left(17).wrapping_mul(XXH_P4);
    }
    h ^= h >> 15;
    h = h.wrapping_mul(XXH_P2);
    h ^= h >> 13;
    h = h.wrapping_mul(XXH_P3);
    h ^= h >> 16;
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// A value in [0, 1) per integer cell `floor(x)`; 0 for non-finite `x`.
pub extern "C" fn tsl_cellnoise1(x: f32) -> f32 {
    if !x.is_finite() {
        return 0.0;
    }
    hash_unit(&[cell(x)])
}

/// A value in [0, 1) per integer cell `floor(x, y)`; 0 when a coordinate is
/// not finite.
pub extern "C" fn tsl_cellnoise2(x: f32, y: f32) -> f32 {
    if !(x.is_finite() && y.is_finite()) {
        return 0.0;
    }
    hash_unit(&[cell(x), cell(y)])
}

/// A value in [0, 1) per integer cell `floor(x, y, z)`; 0 when a coordinate
/// is not finite.
pub extern "C" fn tsl_cellnoise3(x: f32, y: f32, z: f32) -> f32 {
    if !(x.is_finite() && y.is_finite() && z.is_finite()) {
        return 0.0;
    }
    hash_unit(&[cell(x), cell(y), cell(z)])
}

#[cfg(test)]
mod tests;
