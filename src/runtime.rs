//! The native functions compiled shaders call: math that Cranelift has no
//! instruction for, and noise.
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

    /// The code address, for a JIT symbol table.
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
    crate::ir::lower::curve_table_name(table)
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
mod tests {
    use super::*;

    /// A small deterministic generator (PCG32) for test points.
    struct Rng(u64);

    impl Rng {
        fn next_u32(&mut self) -> u32 {
            let old = self.0;
            self.0 = old.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
            xorshifted.rotate_right((old >> 59) as u32)
        }

        /// Uniform in [lo, hi).
        fn range(&mut self, lo: f32, hi: f32) -> f32 {
            let u = (self.next_u32() >> 8) as f32 / 16_777_216.0;
            lo + (hi - lo) * u
        }
    }

    type Noise3 = Box<dyn Fn(f32, f32, f32) -> f32>;

    /// Every noise form as a function of three coordinates.
    fn noise_fns() -> [(&'static str, Noise3); 6] {
        [
            ("noise1", Box::new(|x, _, _| tsl_noise1(x))),
            ("noise2", Box::new(|x, y, _| tsl_noise2(x, y))),
            ("noise3", Box::new(|x, y, z| tsl_noise3(x, y, z))),
            ("pnoise1", Box::new(|x, _, _| tsl_pnoise1(x, 7.0))),
            ("pnoise2", Box::new(|x, y, _| tsl_pnoise2(x, y, 5.0, 3.0))),
            ("pnoise3", Box::new(|x, y, z| tsl_pnoise3(x, y, z, 4.0, 6.0, 9.0))),
        ]
    }

    /// Perlin's reference `ImprovedNoise.noise` (Java, 2002), transcribed.
    fn reference_noise3(x: f64, y: f64, z: f64) -> f64 {
        let p = |i: i32| PERM[(i & 255) as usize] as i32;
        let (xf, yf, zf) = (x.floor(), y.floor(), z.floor());
        let (xi, yi, zi) = ((xf as i32) & 255, (yf as i32) & 255, (zf as i32) & 255);
        let (x, y, z) = (x - xf, y - yf, z - zf);
        let (u, v, w) = (fade(x), fade(y), fade(z));
        let a = p(xi) + yi;
        let (aa, ab) = (p(a) + zi, p(a + 1) + zi);
        let b = p(xi + 1) + yi;
        let (ba, bb) = (p(b) + zi, p(b + 1) + zi);
        let g = |h: i32, x, y, z| grad3(h as usize, x, y, z);
        lerp(
            w,
            lerp(
                v,
                lerp(u, g(p(aa), x, y, z), g(p(ba), x - 1.0, y, z)),
                lerp(u, g(p(ab), x, y - 1.0, z), g(p(bb), x - 1.0, y - 1.0, z)),
            ),
            lerp(
                v,
                lerp(u, g(p(aa + 1), x, y, z - 1.0), g(p(ba + 1), x - 1.0, y, z - 1.0)),
                lerp(u, g(p(ab + 1), x, y - 1.0, z - 1.0), g(p(bb + 1), x - 1.0, y - 1.0, z - 1.0)),
            ),
        )
    }

    #[test]
    fn noise3_is_perlins_reference_scaled() {
        let mut rng = Rng(7);
        for _ in 0..20_000 {
            let (x, y, z) = (rng.range(-300.0, 300.0), rng.range(-300.0, 300.0), rng.range(-300.0, 300.0));
            let want = (reference_noise3(x.into(), y.into(), z.into()) * SCALE3) as f32;
            assert_eq!(tsl_noise3(x, y, z), want, "({x}, {y}, {z})");
        }
    }

    #[test]
    fn deterministic_and_pinned() {
        let mut rng = Rng(1);
        for _ in 0..1000 {
            let (x, y, z) = (rng.range(-50.0, 50.0), rng.range(-50.0, 50.0), rng.range(-50.0, 50.0));
            for (name, f) in noise_fns() {
                assert_eq!(f(x, y, z).to_bits(), f(x, y, z).to_bits(), "{name}");
            }
            assert_eq!(tsl_cellnoise3(x, y, z).to_bits(), tsl_cellnoise3(x, y, z).to_bits());
        }
        // Pinned values: renders must not change silently. Only +, -, *,
        // floor and conversions are involved, so these hold on every target.
        let got = [
            tsl_noise1(0.3),
            tsl_noise2(0.3, 1.7),
            tsl_noise3(0.3, 1.7, -2.2),
            tsl_pnoise3(0.3, 1.7, -2.2, 3.0, 3.0, 3.0),
            tsl_cellnoise1(0.3),
            tsl_cellnoise2(0.3, 1.7),
            tsl_cellnoise3(0.3, 1.7, -2.2),
        ];
        let got: Vec<u32> = got.iter().map(|v| v.to_bits()).collect();
        assert_eq!(got, PINNED, "{:?}", got.iter().map(|b| f32::from_bits(*b)).collect::<Vec<_>>());
    }

    /// 0.473613, -0.636296, -0.45946094, 0.101279184 (noise), then
    /// 0.034528315, 0.8517155, 0.22836185 (cellnoise: checked against the
    /// reference xxHash32 implementation).
    const PINNED: [u32; 7] = [1056079207, 3206734923, 3203087991, 1037003638, 1024290192, 1062865415, 1047123888];

    #[test]
    fn zero_at_lattice_points() {
        for i in -40..40 {
            for j in -12..12 {
                for k in [-300, -5, 0, 1, 7, 255, 256, 1000] {
                    let (x, y, z) = (i as f32, j as f32, k as f32);
                    for (name, f) in noise_fns() {
                        assert_eq!(f(x, y, z), 0.0, "{name}({x}, {y}, {z})");
                    }
                }
            }
        }
        for big in [1e9f32, -1e9, 3.0e9, 1e20, f32::MAX, f32::MIN] {
            assert_eq!(tsl_noise1(big), 0.0);
            assert_eq!(tsl_noise3(big, -big, big), 0.0);
            assert_eq!(tsl_pnoise3(big, big, big, 7.0, 1e9, 3.0), 0.0);
        }
    }

    #[test]
    fn range_within_unit_interval() {
        let mut rng = Rng(42);
        let mut max = [0f32; 3];
        for _ in 0..100_000 {
            let (x, y, z) = (rng.range(-100.0, 100.0), rng.range(-100.0, 100.0), rng.range(-100.0, 100.0));
            for (d, v) in [tsl_noise1(x), tsl_noise2(x, y), tsl_noise3(x, y, z)].into_iter().enumerate() {
                assert!((-1.0..=1.0).contains(&v), "noise{}({x}, {y}, {z}) = {v}", d + 1);
                max[d] = max[d].max(v.abs());
            }
        }
        eprintln!("max |noise| over 100k random points, 1D/2D/3D: {max:?}");
        // The noise uses its range: not squeezed by an over-cautious scale.
        assert!(max[0] > 0.9 && max[1] > 0.8 && max[2] > 0.8, "{max:?}");
    }

    /// The worst cases the scales were derived from: the cell centre in 1D
    /// and 2D; near (0.355, 0.481, 0.5) in 3D.
    #[test]
    fn extremes_stay_in_range() {
        let mut max = [0f32; 3];
        for i in -256..256 {
            let c = i as f32 + 0.5;
            max[0] = max[0].max(tsl_noise1(c).abs());
            for j in -256..256 {
                max[1] = max[1].max(tsl_noise2(c, j as f32 + 0.5).abs());
            }
        }
        let mut rng = Rng(3);
        for _ in 0..200_000 {
            let (i, j, k) =
                (rng.range(0.0, 256.0).floor(), rng.range(0.0, 256.0).floor(), rng.range(0.0, 256.0).floor());
            let v = tsl_noise3(i + 0.3553, j + 0.4815, k + 0.5);
            let w = tsl_noise3(i + 0.5, j + 0.3553, k + 0.4815);
            max[2] = max[2].max(v.abs()).max(w.abs());
        }
        // The 3D worst case over all 256^3 cells.
        max[2] = max[2].max(tsl_noise3(12.355257, 187.51851, 5.5).abs());
        eprintln!("max |noise| at the worst-case positions, 1D/2D/3D: {max:?}");
        assert!(max.iter().all(|m| *m <= 1.0), "{max:?}");
        // Perlin's table realises every bound: the scales are tight.
        assert!(max[0] == 1.0 && max[1] == 1.0 && max[2] > 0.9999, "{max:?}");
    }

    #[test]
    fn continuous() {
        let mut rng = Rng(9);
        let h = 1e-3f32;
        for _ in 0..20_000 {
            let (x, y, z) = (rng.range(-20.0, 20.0), rng.range(-20.0, 20.0), rng.range(-20.0, 20.0));
            for (name, f) in noise_fns() {
                let v = f(x, y, z);
                for (dx, dy, dz) in [(h, 0.0, 0.0), (0.0, h, 0.0), (0.0, 0.0, h)] {
                    let d = (f(x + dx, y + dy, z + dz) - v).abs();
                    // Gradients are bounded (about 4 per unit at worst), so
                    // a step of 1e-3 moves the value by well under 1e-2.
                    assert!(d < 1e-2, "{name} jumps by {d} at ({x}, {y}, {z})");
                }
            }
        }
        // Across cell boundaries too.
        for i in -10..10 {
            let b = i as f32;
            for f in
                [|x| tsl_noise1(x), |x| tsl_noise2(x, 0.37), |x| tsl_noise3(0.61, x, 0.37), |x| tsl_pnoise1(x, 3.0)]
            {
                assert!((f(b - h) - f(b + h)).abs() < 1e-2);
            }
        }
    }

    #[test]
    fn pnoise_repeats() {
        let mut rng = Rng(11);
        for p in [1.0f32, 2.0, 3.0, 5.0, 7.0, 16.0, 100.0, 255.0, 256.0, 300.0] {
            for _ in 0..500 {
                // Multiples of 1/64 below 512: x + k p is exact in f32, so
                // the repetition is exact too.
                let q = |r: &mut Rng| (r.range(-256.0, 256.0) * 64.0).floor() / 64.0;
                let (x, y, z) = (q(&mut rng), q(&mut rng), q(&mut rng));
                let v1 = tsl_pnoise1(x, p);
                let v2 = tsl_pnoise2(x, y, p, 3.0);
                let v3 = tsl_pnoise3(x, y, z, 2.0, p, 5.0);
                for k in [-2.0f32, -1.0, 1.0, 3.0] {
                    assert_eq!(tsl_pnoise1(x + k * p, p).to_bits(), v1.to_bits(), "1D p={p} x={x} k={k}");
                    assert_eq!(tsl_pnoise2(x + k * p, y, p, 3.0).to_bits(), v2.to_bits());
                    assert_eq!(tsl_pnoise2(x, y + 3.0 * k, p, 3.0).to_bits(), v2.to_bits());
                    assert_eq!(tsl_pnoise3(x + 2.0 * k, y + k * p, z, 2.0, p, 5.0).to_bits(), v3.to_bits());
                    assert_eq!(tsl_pnoise3(x, y, z + 5.0 * k, 2.0, p, 5.0).to_bits(), v3.to_bits());
                }
                // With inexact sums the repetition is as close as the input.
                let x = rng.range(-50.0, 50.0);
                assert!((tsl_pnoise1(x + p, p) - tsl_pnoise1(x, p)).abs() < 1e-3);
            }
        }
    }

    #[test]
    fn pnoise_periods_round_and_default() {
        let mut rng = Rng(5);
        for _ in 0..2000 {
            let (x, y, z) = (rng.range(-600.0, 600.0), rng.range(-600.0, 600.0), rng.range(-600.0, 600.0));
            // Period 256 is the table's own: periodic noise is plain noise.
            assert_eq!(tsl_pnoise1(x, 256.0), tsl_noise1(x));
            assert_eq!(tsl_pnoise2(x, y, 256.0, 256.0), tsl_noise2(x, y));
            assert_eq!(tsl_pnoise3(x, y, z, 256.0, 256.0, 256.0), tsl_noise3(x, y, z));
            // Periods round to the nearest integer.
            assert_eq!(tsl_pnoise1(x, 3.4), tsl_pnoise1(x, 3.0));
            assert_eq!(tsl_pnoise1(x, 2.5), tsl_pnoise1(x, 3.0));
            // Below 1, and NaN, mean 1.
            for p in [0.0f32, 0.49, -4.0, f32::NAN, f32::NEG_INFINITY] {
                assert_eq!(tsl_pnoise2(x, y, p, p), tsl_pnoise2(x, y, 1.0, 1.0), "period {p}");
            }
            // Multiples of 256, infinite periods included, give plain noise.
            let inf = f32::INFINITY;
            assert_eq!(tsl_pnoise3(x, y, z, inf, inf, inf), tsl_noise3(x, y, z));
            assert_eq!(tsl_pnoise3(x, y, z, 512.0, 1e30, 2.0e9 * 256.0), tsl_noise3(x, y, z));
        }
    }

    #[test]
    fn cellnoise_cells() {
        let mut rng = Rng(13);
        let mut sum = 0f64;
        let mut bins = [0u32; 10];
        let n = 100_000;
        for _ in 0..n {
            let (x, y, z) = (rng.range(-1e4, 1e4), rng.range(-1e4, 1e4), rng.range(-1e4, 1e4));
            let (cx, cy, cz) = (x.floor(), y.floor(), z.floor());
            let v = [tsl_cellnoise1(x), tsl_cellnoise2(x, y), tsl_cellnoise3(x, y, z)];
            // Constant within the cell, lower corner included.
            let w = (rng.range(0.0, 1.0).min(0.999), rng.range(0.0, 1.0).min(0.999), 0.0);
            assert_eq!(v[0], tsl_cellnoise1(cx));
            assert_eq!(v[0], tsl_cellnoise1(cx + w.0));
            assert_eq!(v[1], tsl_cellnoise2(cx + w.0, cy + w.1));
            assert_eq!(v[2], tsl_cellnoise3(cx + w.0, cy + w.1, cz));
            for u in v {
                assert!((0.0..1.0).contains(&u), "{u}");
            }
            // Neighbouring cells differ.
            assert_ne!(v[0], tsl_cellnoise1(cx + 1.0));
            assert_ne!(v[1], tsl_cellnoise2(cx, cy + 1.0));
            assert_ne!(v[2], tsl_cellnoise3(cx, cy, cz - 1.0));
            sum += f64::from(v[2]);
            bins[(v[2] * 10.0) as usize] += 1;
        }
        let mean = sum / n as f64;
        assert!((mean - 0.5).abs() < 0.005, "mean {mean}");
        for b in bins {
            assert!((b as f64 - n as f64 / 10.0).abs() < 0.05 * n as f64 / 10.0, "{bins:?}");
        }
        // Every cell of a 1D run and a 2D block distinct (24-bit values:
        // a collision among 10k would be bad luck, and this is pinned).
        let mut seen = std::collections::HashSet::new();
        for i in -5000..5000 {
            seen.insert(tsl_cellnoise1(i as f32).to_bits());
        }
        assert!(seen.len() > 9990, "{}", seen.len());
        let mut seen = std::collections::HashSet::new();
        for i in -50..50 {
            for j in -50..50 {
                seen.insert(tsl_cellnoise2(i as f32, j as f32).to_bits());
            }
        }
        assert!(seen.len() > 9990, "{}", seen.len());
        // Large coordinates still give distinct cells.
        assert_ne!(tsl_cellnoise1(-1.0), tsl_cellnoise1(0.0));
        assert_ne!(tsl_cellnoise1(4_294_967_296.0), tsl_cellnoise1(0.0));
        assert_ne!(tsl_cellnoise1(1e9), tsl_cellnoise1(1e9 + 64.0));
    }

    const SPECIAL: [f32; 14] = [
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        0.0,
        -0.0,
        1e-45,
        -1e-30,
        0.999_999_94,
        1e9,
        -1e9,
        1e20,
        -3e30,
        f32::MAX,
        f32::MIN,
    ];

    #[test]
    fn special_inputs_never_panic() {
        let check = |name: &str, v: f32| {
            let cell = name.starts_with("tsl_cellnoise");
            let noise = name.contains("noise");
            if cell {
                assert!((0.0..1.0).contains(&v), "{name} = {v}");
            } else if noise {
                assert!((-1.0..=1.0).contains(&v), "{name} = {v}");
            }
        };
        for n in natives() {
            let s = SPECIAL;
            match n.f {
                NativeFn::F1(f) => s.iter().for_each(|&a| check(n.name, f(a))),
                NativeFn::F2(f) => s.iter().for_each(|&a| s.iter().for_each(|&b| check(n.name, f(a, b)))),
                NativeFn::F3(f) => {
                    for a in s {
                        for b in s {
                            s.iter().for_each(|&c| check(n.name, f(a, b, c)));
                        }
                    }
                }
                NativeFn::F4(f) => {
                    for a in s {
                        for b in s {
                            for c in s {
                                s.iter().for_each(|&d| check(n.name, f(a, b, c, d)));
                            }
                        }
                    }
                }
                NativeFn::F6(f) => {
                    let mut rng = Rng(17);
                    let mut pick = || s[rng.next_u32() as usize % s.len()];
                    for _ in 0..50_000 {
                        check(n.name, f(pick(), pick(), pick(), pick(), pick(), pick()));
                    }
                }
            }
        }
        // Non-finite coordinates give 0.
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            assert_eq!(tsl_noise1(bad), 0.0);
            assert_eq!(tsl_noise2(0.5, bad), 0.0);
            assert_eq!(tsl_noise3(0.5, 0.5, bad), 0.0);
            assert_eq!(tsl_pnoise3(bad, 0.5, 0.5, 2.0, 2.0, 2.0), 0.0);
            assert_eq!(tsl_cellnoise3(0.5, bad, 0.5), 0.0);
        }
    }

    type Direct = (&'static str, fn(&[f32]) -> f32);

    /// Every native called directly, by name.
    const DIRECT: [Direct; 20] = [
        ("tsl_acos", |a| tsl_acos(a[0])),
        ("tsl_asin", |a| tsl_asin(a[0])),
        ("tsl_atan", |a| tsl_atan(a[0])),
        ("tsl_atan2", |a| tsl_atan2(a[0], a[1])),
        ("tsl_cellnoise1", |a| tsl_cellnoise1(a[0])),
        ("tsl_cellnoise2", |a| tsl_cellnoise2(a[0], a[1])),
        ("tsl_cellnoise3", |a| tsl_cellnoise3(a[0], a[1], a[2])),
        ("tsl_cos", |a| tsl_cos(a[0])),
        ("tsl_exp", |a| tsl_exp(a[0])),
        ("tsl_log", |a| tsl_log(a[0])),
        ("tsl_noise1", |a| tsl_noise1(a[0])),
        ("tsl_noise2", |a| tsl_noise2(a[0], a[1])),
        ("tsl_noise3", |a| tsl_noise3(a[0], a[1], a[2])),
        ("tsl_pnoise1", |a| tsl_pnoise1(a[0], a[1])),
        ("tsl_pnoise2", |a| tsl_pnoise2(a[0], a[1], a[2], a[3])),
        ("tsl_pnoise3", |a| tsl_pnoise3(a[0], a[1], a[2], a[3], a[4], a[5])),
        ("tsl_pow", |a| tsl_pow(a[0], a[1])),
        ("tsl_round", |a| tsl_round(a[0])),
        ("tsl_sin", |a| tsl_sin(a[0])),
        ("tsl_tan", |a| tsl_tan(a[0])),
    ];

    const ARITIES: [(&str, usize); 20] = [
        ("tsl_acos", 1),
        ("tsl_asin", 1),
        ("tsl_atan", 1),
        ("tsl_atan2", 2),
        ("tsl_cellnoise1", 1),
        ("tsl_cellnoise2", 2),
        ("tsl_cellnoise3", 3),
        ("tsl_cos", 1),
        ("tsl_exp", 1),
        ("tsl_log", 1),
        ("tsl_noise1", 1),
        ("tsl_noise2", 2),
        ("tsl_noise3", 3),
        ("tsl_pnoise1", 2),
        ("tsl_pnoise2", 4),
        ("tsl_pnoise3", 6),
        ("tsl_pow", 2),
        ("tsl_round", 1),
        ("tsl_sin", 1),
        ("tsl_tan", 1),
    ];

    fn call(f: NativeFn, a: &[f32]) -> f32 {
        match f {
            NativeFn::F1(g) => g(a[0]),
            NativeFn::F2(g) => g(a[0], a[1]),
            NativeFn::F3(g) => g(a[0], a[1], a[2]),
            NativeFn::F4(g) => g(a[0], a[1], a[2], a[3]),
            NativeFn::F6(g) => g(a[0], a[1], a[2], a[3], a[4], a[5]),
        }
    }

    /// Calls through the raw pointer, as JIT-compiled code does.
    fn call_ptr(p: *const u8, arity: usize, a: &[f32]) -> f32 {
        // SAFETY: the table's pointers are `extern "C" fn`s of `arity` f32
        // arguments returning f32 (checked against `f` in the test).
        unsafe {
            match arity {
                1 => std::mem::transmute::<*const u8, extern "C" fn(f32) -> f32>(p)(a[0]),
                2 => std::mem::transmute::<*const u8, extern "C" fn(f32, f32) -> f32>(p)(a[0], a[1]),
                3 => std::mem::transmute::<*const u8, extern "C" fn(f32, f32, f32) -> f32>(p)(a[0], a[1], a[2]),
                4 => std::mem::transmute::<*const u8, extern "C" fn(f32, f32, f32, f32) -> f32>(p)(
                    a[0], a[1], a[2], a[3],
                ),
                _ => std::mem::transmute::<*const u8, extern "C" fn(f32, f32, f32, f32, f32, f32) -> f32>(p)(
                    a[0], a[1], a[2], a[3], a[4], a[5],
                ),
            }
        }
    }

    #[test]
    fn inline_noise_tables_match_the_gradient_functions() {
        let f = |w: u32| f64::from(f32::from_bits(w));
        for h in 0..256usize {
            let (x, y, z) = (0.3125, -0.71875, 0.125);
            let g = (f(GRAD3_WORDS[0][h & 15]), f(GRAD3_WORDS[1][h & 15]), f(GRAD3_WORDS[2][h & 15]));
            assert_eq!(g.0 * x + g.1 * y + g.2 * z, grad3(h, x, y, z), "grad3 {h}");
            assert_eq!(f(GRAD1_WORDS[h & 15]) * x, grad1(h, x), "grad1 {h}");
            let g2 = (f(GRAD2_WORDS[0][h & 7]), f(GRAD2_WORDS[1][h & 7]));
            assert!((g2.0 * x + g2.1 * y - grad2(h, x, y)).abs() < 1e-7, "grad2 {h}");
            assert_eq!(PERM_WORDS[h] as usize, perm(h));
        }
    }

    #[test]
    fn table_is_complete_and_consistent() {
        let table = natives();
        assert_eq!(table.len(), ARITIES.len());
        assert!(table.windows(2).all(|w| w[0].name < w[1].name), "the table must stay sorted by name");
        for (name, arity) in ARITIES {
            let n = native(name).unwrap_or_else(|| panic!("{name} missing"));
            assert_eq!((n.name, n.arity, n.f.arity()), (name, arity, arity));
            assert_eq!(n.ptr, n.f.ptr(), "{name}");
        }
        assert!(native("tsl_nope").is_none() && native("").is_none() && native("sin").is_none());
        let mut rng = Rng(23);
        for (name, direct) in DIRECT {
            let n = native(name).unwrap_or_else(|| panic!("{name} missing"));
            for _ in 0..200 {
                let a: Vec<f32> = (0..6).map(|_| rng.range(-3.0, 3.0)).collect();
                let want = direct(&a).to_bits();
                assert_eq!(call(n.f, &a).to_bits(), want, "{name}{a:?}");
                assert_eq!(call_ptr(n.ptr, n.arity, &a).to_bits(), want, "{name}{a:?} by pointer");
            }
        }
    }

    #[test]
    fn math_natives() {
        assert_eq!(tsl_round(0.5), 1.0);
        assert_eq!(tsl_round(-0.5), -1.0);
        assert_eq!(tsl_round(2.5), 3.0);
        assert_eq!(tsl_round(-2.4), -2.0);
        assert_eq!(tsl_atan2(1.0, 0.0), std::f32::consts::FRAC_PI_2);
        assert_eq!(tsl_atan2(0.0, -1.0), std::f32::consts::PI);
        assert_eq!(tsl_pow(2.0, 10.0), 1024.0);
        assert_eq!(tsl_log(1.0), 0.0);
        assert_eq!(tsl_exp(0.0), 1.0);
        assert!(tsl_asin(2.0).is_nan() && tsl_log(-1.0).is_nan() && tsl_sin(f32::NAN).is_nan());
    }
}
