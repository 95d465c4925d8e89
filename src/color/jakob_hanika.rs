//! RGB to spectrum by W. Jakob and J. Hanika, "A Low-Dimensional Function
//! Space for Efficient Spectral Upsampling" (Eurographics 2019), the method
//! of Mitsuba 3 and pbrt-v4.
//!
//! A reflectance `rgb` in `[0, 1]³` becomes the smooth spectrum
//! `S(λ) = sigmoid(c0 t² + c1 t + c2)`, `t = (λ − 380) / 400` (so `t` runs
//! over `[0, 1]` on the models' 380–780 nm), with `sigmoid(x) = 1/2 +
//! x / (2 √(1 + x²))`: bounded in `(0, 1)`, and the three coefficients are
//! chosen so that the spectrum, lit by D65 and seen through the CIE 1931
//! observer, *is* `rgb` in linear sRGB ([`super::reflectance_to_rgb`]).
//!
//! The coefficients come from a precomputed table over RGB, as in the
//! paper: three blocks (which channel is largest), each `RES³` cells over
//! `(z, y, x)` where `z` is the largest channel (on a grid denser near 0
//! and 1, [`z_grid`]) and `x`, `y` the next two channels divided by it.
//! Each cell is fitted by Gauss–Newton on the CIELAB difference, starting
//! from its neighbour's solution ([`fit_table`]); lookups interpolate the
//! coefficients trilinearly ([`Table::fetch`]). The table is made offline by
//! `cargo run --release --example make_rgb2spec` and committed as
//! `src/color/data/rgb2spec_srgb.bin`.
//!
//! Beyond the table, [`upsample`] handles what it cannot: greys get the
//! exact constant spectrum (as pbrt-v4 does), black is 0, and colours
//! brighter than 1 (emission) are upsampled as Mitsuba's emitters are:
//! `2m · S_{rgb / 2m}(λ)` with `m` the largest channel.

use super::{HI, LO, reflectance_rgb_nodes};

/// Cells per axis of the table.
pub const RES: usize = 64;

/// The darkest largest channel the table covers: a darker reflectance is
/// the spectrum of its colour scaled up to this, scaled back down (the
/// sigmoid cannot make dark saturated colours within bounded coefficients).
pub const Z_MIN: f32 = 0.05;

/// Fitted coefficients are kept below this in size.
const FIT_BOUND: f64 = 1000.0;

/// The file the table is read from: a header (`b"JH19"`, then the
/// resolution as a little-endian `u32`), the `RES` values of the `z` grid,
/// then `3 · RES³` cells of three coefficients, all little-endian `f32`,
/// cell `((block · RES + z) · RES + y) · RES + x`.
static TABLE_BYTES: &[u8] = include_bytes!("data/rgb2spec_srgb.bin");

/// The magic number the table file starts with.
pub const MAGIC: &[u8; 4] = b"JH19";

/// A coefficient a grey of exactly 0 or 1 would need (±∞) is clamped to
/// this, where the sigmoid is 0 or 1 to `f32` precision.
pub const COEFFICIENT_BOUND: f32 = 1e4;

/// The spectrum `scale · sigmoid(c0 t² + c1 t + c2)` of one RGB colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sigmoid {
    /// `c0, c1, c2`, for `t = (λ − 380) / 400`.
    pub coefficients: [f32; 3],
    /// 1 for reflectances; `2 · max(rgb)` for colours brighter than 1; 0
    /// for black.
    pub scale: f32,
}

impl Sigmoid {
    /// The spectrum at `nm` nanometres.
    pub fn eval(&self, nm: f32) -> f32 {
        // The compiled code's operations in its order (no fused
        // multiply-add), so a color folded when the program is compiled
        // has the bits of the same color computed at run time.
        let t = (nm - LO as f32) / (HI - LO) as f32;
        let [c0, c1, c2] = self.coefficients;
        let x = (c0 * t + c1) * t + c2;
        let half_scale = 0.5 * self.scale;
        half_scale + half_scale * (x / (x * x + 1.0).sqrt())
    }

    /// The spectrum at `nm`, in `f64`.
    pub fn eval64(&self, nm: f64) -> f64 {
        let t = (nm - LO) / (HI - LO);
        let [c0, c1, c2] = self.coefficients.map(f64::from);
        f64::from(self.scale) * sigmoid((c0 * t + c1) * t + c2)
    }

    /// The average of the spectrum over `[a, b]` nm (Gauss–Legendre on
    /// pieces of at most 5 nm: exact to ~1e-9 for these smooth curves).
    pub fn average(&self, a: f64, b: f64) -> f64 {
        if b <= a {
            return self.eval64(a);
        }
        let pieces = ((b - a) / 5.0).ceil().max(1.0) as usize;
        let h = (b - a) / pieces as f64;
        let mut sum = 0.0;
        for p in 0..pieces {
            let lo = a + h * p as f64;
            for (x, w) in GAUSS_LEGENDRE_4 {
                sum += w * 0.5 * h * self.eval64(lo + 0.5 * h * (x + 1.0));
            }
        }
        sum / (b - a)
    }
}

/// Four-point Gauss–Legendre nodes and weights on `[-1, 1]`.
pub(super) const GAUSS_LEGENDRE_4: [(f64, f64); 4] = [
    (-0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
    (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
];

/// `1/2 + x / (2 √(1 + x²))`; 0 and 1 at ∓∞.
pub fn sigmoid(x: f64) -> f64 {
    if x.is_infinite() {
        return if x > 0.0 { 1.0 } else { 0.0 };
    }
    0.5 + x / (2.0 * (1.0 + x * x).sqrt())
}

/// The Jakob–Hanika spectrum of a linear sRGB colour (see the module
/// documentation): negative channels count as 0. Compile-time constants and
/// run-time values (compiled code spells the same lookup out in IR) get
/// the same spectrum, so specialising a constant never changes a result.
pub fn upsample(rgb: [f32; 3]) -> Sigmoid {
    let rgb = rgb.map(|c| if c > 0.0 { c } else { 0.0 });
    let m = rgb[0].max(rgb[1]).max(rgb[2]);
    if m.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) || !m.is_finite() {
        return Sigmoid { coefficients: [0.0; 3], scale: 0.0 };
    }
    let scale = range_scale(m);
    // The compiled lookup's arithmetic, operation for operation (a
    // reciprocal, then products): any other rounding would let a
    // specialised constant differ from the same value at run time.
    let inv_scale = 1.0 / scale;
    let v = rgb.map(|c| (c * inv_scale).min(1.0));
    let coefficients = if v[0] == v[1] && v[1] == v[2] { grey_coefficients(v[0]) } else { table().fetch(v) };
    Sigmoid { coefficients, scale }
}

/// The spectrum of `rgb` fitted exactly (Gauss–Newton from the table's
/// coefficients, round trip within 1e-6): for tools and tests; the color
/// models use [`upsample`].
pub fn upsample_exact(rgb: [f32; 3]) -> Sigmoid {
    let s = upsample(rgb);
    let v = rgb.map(|c| (c.max(0.0) / s.scale).min(1.0));
    if s.scale == 0.0 || s.coefficients[..2] == [0.0, 0.0] {
        return s;
    }
    let c = Fitter::get().fit(v.map(f64::from), s.coefficients.map(f64::from));
    Sigmoid { coefficients: c.map(|x| x as f32), ..s }
}

/// What a colour whose largest channel is `m > 0` is divided by before the
/// table is read: `2m` above 1 (Mitsuba's emitters), `m / Z_MIN` below
/// [`Z_MIN`], else 1.
pub fn range_scale(m: f32) -> f32 {
    if m > 1.0 {
        2.0 * m
    } else if m < Z_MIN {
        m * (1.0 / Z_MIN) // as the compiled lookup rounds
    } else {
        1.0
    }
}

/// The constant spectrum `v`: `sigmoid(c2) = v`, in single precision as
/// the compiled lookup computes it.
pub fn grey_coefficients(v: f32) -> [f32; 3] {
    let c2 = (v - 0.5) / (v * (1.0 - v)).sqrt();
    let bound = COEFFICIENT_BOUND;
    [0.0, 0.0, if c2.is_nan() { bound } else { c2.clamp(-bound, bound) }]
}

/// The coefficient table.
pub struct Table {
    pub res: usize,
    /// The `z` value of each of the `res` slices ([`z_grid`]).
    pub z: Vec<f32>,
    /// `3 · res³` cells of `[c0, c1, c2]`.
    pub cells: Vec<[f32; 3]>,
}

/// The committed table, decoded on first use.
pub fn table() -> &'static Table {
    static TABLE: std::sync::OnceLock<Table> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        Table::from_bytes(TABLE_BYTES)
            .unwrap_or_else(|e| unreachable!("the committed table src/color/data/rgb2spec_srgb.bin: {e}"))
    })
}

/// The `z` grid of the table: the paper's
/// `smoothstep(smoothstep(k / (res − 1)))`, dense near the ends where the
/// coefficients change fastest, mapped onto `[Z_MIN, 1]`.
pub fn z_grid(res: usize) -> Vec<f64> {
    let smoothstep = |x: f64| x * x * (3.0 - 2.0 * x);
    let lo = f64::from(Z_MIN);
    (0..res).map(|k| lo + (1.0 - lo) * smoothstep(smoothstep(k as f64 / (res - 1) as f64))).collect()
}

/// The block (largest channel, ties to the later one, as the paper) and
/// the `(x, y, z)` coordinates of `rgb` in it.
pub fn coordinates(rgb: [f32; 3]) -> (usize, [f32; 3]) {
    let mut i = 0;
    for j in 1..3 {
        if rgb[j] >= rgb[i] {
            i = j;
        }
    }
    let z = rgb[i];
    let inv = if z > 0.0 { 1.0 / z } else { 0.0 };
    (i, [rgb[(i + 1) % 3] * inv, rgb[(i + 2) % 3] * inv, z])
}

impl Table {
    /// Reads the table file format (see [`TABLE_BYTES`]).
    pub fn from_bytes(bytes: &[u8]) -> Result<Table, String> {
        if bytes.len() < 8 || &bytes[..4] != MAGIC {
            return Err("not a coefficient table (no JH19 header)".into());
        }
        let res = u32::from_le_bytes([bytes[4], bytes[5], bytes[6], bytes[7]]) as usize;
        let floats: Vec<f32> =
            bytes[8..].chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
        if !(2..=256).contains(&res) || floats.len() != res + 9 * res * res * res {
            return Err(format!("a table of resolution {res} with {} numbers", floats.len()));
        }
        let z = floats[..res].to_vec();
        let cells = floats[res..].chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        Ok(Table { res, z, cells })
    }

    /// The file format of [`Table::from_bytes`].
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = MAGIC.to_vec();
        out.extend((self.res as u32).to_le_bytes());
        for x in self.z.iter().chain(self.cells.iter().flatten()) {
            out.extend(x.to_le_bytes());
        }
        out
    }

    /// The coefficients of a reflectance `rgb` in `[0, 1]³`, interpolated
    /// trilinearly between the cells around it.
    pub fn fetch(&self, rgb: [f32; 3]) -> [f32; 3] {
        let res = self.res;
        let rgb = rgb.map(|c| c.clamp(0.0, 1.0));
        let (block, _) = coordinates(rgb);
        let z = rgb[block];
        // As the compiled lookup rounds: `n · ((res − 1) / z)`.
        let last = (res - 1) as f32;
        let per_z = last / z.max(1e-30);
        let cell = |n: f32| (n * per_z).clamp(0.0, last);
        let (x, y) = (cell(rgb[(block + 1) % 3]), cell(rgb[(block + 2) % 3]));
        let z = z.max(self.z[0]);
        let xi = (x as usize).min(res - 2);
        let yi = (y as usize).min(res - 2);
        let zi = self.z.partition_point(|&g| g <= z).saturating_sub(1).min(res - 2);
        let (fx, fy) = (x - xi as f32, y - yi as f32);
        let fz = (z - self.z[zi]) / (self.z[zi + 1] - self.z[zi]);
        let cell =
            |dz: usize, dy: usize, dx: usize| self.cells[((block * res + zi + dz) * res + yi + dy) * res + xi + dx];
        let lerp = |a: [f32; 3], b: [f32; 3], t: f32| [0, 1, 2].map(|k| a[k] + (b[k] - a[k]) * t);
        let plane = |dz| {
            let lo = lerp(cell(dz, 0, 0), cell(dz, 0, 1), fx);
            let hi = lerp(cell(dz, 1, 0), cell(dz, 1, 1), fx);
            lerp(lo, hi, fy)
        };
        lerp(plane(0), plane(1), fz)
    }
}

/// The linear sRGB of a reflectance spectrum lit by D65, integrated over
/// 380–780 nm from the CIE 1931 and D65 tables: the `to_rgb` of the spectral
/// models in the limit of infinitely many lanes (exact to ~1e-9 for smooth
/// curves), what the coefficients are fitted to.
pub fn reflectance_to_rgb(spectrum: impl Fn(f64) -> f64) -> [f64; 3] {
    let fitter = Fitter::get();
    let mut rgb = [0.0; 3];
    for (t, w) in fitter.t.iter().zip(&fitter.weights) {
        let s = spectrum(LO + t * (HI - LO));
        for k in 0..3 {
            rgb[k] += w[k] * s;
        }
    }
    rgb
}

// ---------------------------------------------------------------------------
// Fitting.

/// What fitting one cell measures: the reflectance's linear sRGB
/// ([`super::reflectance_to_rgb`]) at quadrature nodes.
struct Fitter {
    /// Normalised wavelength `t` of each node.
    t: Vec<f64>,
    /// Per node: the node's weight times the reflectance → sRGB matching
    /// functions, so `rgb = Σ weights[k] · S(t_k)`.
    weights: Vec<[f64; 3]>,
}

/// The CIE Lab of a linear sRGB colour (white: sRGB's white).
fn lab(rgb: [f64; 3]) -> [f64; 3] {
    let xyz = super::mat_apply(&super::SRGB_TO_XYZ, rgb);
    let white = super::mat_apply(&super::SRGB_TO_XYZ, [1.0; 3]);
    let f = |t: f64| {
        let d: f64 = 6.0 / 29.0;
        if t > d * d * d { t.cbrt() } else { t / (3.0 * d * d) + 4.0 / 29.0 }
    };
    let [fx, fy, fz] = [0, 1, 2].map(|c| f(xyz[c] / white[c]));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

impl Fitter {
    fn get() -> &'static Fitter {
        static FITTER: std::sync::OnceLock<Fitter> = std::sync::OnceLock::new();
        FITTER.get_or_init(Fitter::new)
    }

    fn new() -> Fitter {
        let (nodes, weights) = reflectance_rgb_nodes();
        Fitter { t: nodes.iter().map(|l| (l - LO) / (HI - LO)).collect(), weights }
    }

    fn rgb(&self, c: [f64; 3]) -> [f64; 3] {
        let mut rgb = [0.0; 3];
        for (t, w) in self.t.iter().zip(&self.weights) {
            let s = sigmoid((c[0] * t + c[1]) * t + c[2]);
            for k in 0..3 {
                rgb[k] += w[k] * s;
            }
        }
        rgb
    }

    /// Lab(target) − Lab(spectrum of `c`).
    fn residual(&self, c: [f64; 3], target: [f64; 3]) -> [f64; 3] {
        let (a, b) = (lab(target), lab(self.rgb(c)));
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }

    /// Gauss–Newton from `c`, as the paper: at most 15 steps, central
    /// differences for the Jacobian, coefficients kept below [`FIT_BOUND`]
    /// in size (the paper: 200).
    fn fit(&self, target: [f64; 3], mut c: [f64; 3]) -> [f64; 3] {
        for _ in 0..15 {
            let r = self.residual(c, target);
            if r.iter().map(|x| x * x).sum::<f64>().sqrt() < 1e-6 {
                break;
            }
            let mut jac = [[0.0; 3]; 3];
            for j in 0..3 {
                let eps = 1e-5;
                let (mut lo, mut hi) = (c, c);
                lo[j] -= eps;
                hi[j] += eps;
                let (rl, rh) = (self.residual(lo, target), self.residual(hi, target));
                for i in 0..3 {
                    jac[i][j] = (rh[i] - rl[i]) / (2.0 * eps);
                }
            }
            let Some(step) = solve3(jac, r) else { break };
            for j in 0..3 {
                c[j] -= step[j];
            }
            let max = c.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            if max > FIT_BOUND {
                c = c.map(|x| x * FIT_BOUND / max);
            }
        }
        c
    }
}

/// `x` with `a x = b`, by Cramer's rule; `None` when `a` is singular.
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    if d.abs() < 1e-300 || !d.is_finite() {
        return None;
    }
    Some([0, 1, 2].map(|j| {
        let mut m = a;
        for i in 0..3 {
            m[i][j] = b[i];
        }
        det(m) / d
    }))
}

/// Fits the coefficient table at resolution `res` (the paper's
/// optimisation; `cargo run --release --example make_rgb2spec` writes the
/// committed one). Each `(block, y, x)` column is fitted from a fifth of
/// the way up `z`, upward and then downward, each cell starting from the
/// previous one's solution; columns run in parallel.
pub fn fit_table(res: usize) -> Table {
    use rayon::prelude::*;
    let columns: Vec<(usize, usize, usize)> =
        (0..3).flat_map(|b| (0..res).flat_map(move |y| (0..res).map(move |x| (b, y, x)))).collect();
    let fitted: Vec<Vec<[f32; 3]>> = columns.par_iter().map(|&(block, y, x)| fit_column(res, block, y, x)).collect();
    let mut cells = vec![[0.0f32; 3]; 3 * res * res * res];
    for (&(block, y, x), column) in columns.iter().zip(&fitted) {
        for (k, c) in column.iter().enumerate() {
            cells[((block * res + k) * res + y) * res + x] = *c;
        }
    }
    Table { res, z: z_grid(res).iter().map(|&v| v as f32).collect(), cells }
}

/// The cells of one `(block, y, x)` column of the table at resolution
/// `res`, from `z = 0` up (see [`fit_table`]).
pub fn fit_column(res: usize, block: usize, y: usize, x: usize) -> Vec<[f32; 3]> {
    let fitter = Fitter::get();
    let z = z_grid(res);
    let start = res / 5;
    let mut column = vec![[0.0; 3]; res];
    let target = |k: usize| {
        let mut rgb = [0.0; 3];
        rgb[block] = z[k];
        rgb[(block + 1) % 3] = x as f64 / (res - 1) as f64 * z[k];
        rgb[(block + 2) % 3] = y as f64 / (res - 1) as f64 * z[k];
        rgb
    };
    let mut c = [0.0; 3];
    for (k, cell) in column.iter_mut().enumerate().skip(start) {
        c = fitter.fit(target(k), c);
        *cell = c.map(|v| v as f32);
    }
    c = [0.0; 3];
    for (k, cell) in column.iter_mut().enumerate().take(start).rev() {
        c = fitter.fit(target(k), c);
        *cell = c.map(|v| v as f32);
    }
    column
}

/// The table as the word tables compiled code reads (`ir::Op::Table`, whose
/// length must be a power of two): the `z` grid, and each coefficient over
/// the cells, zero-padded.
pub struct TableWords {
    pub z: &'static [u32],
    pub coefficients: [&'static [u32]; 3],
}

/// The committed table as [`TableWords`], made on first use and kept for
/// the whole process (compiled code holds the addresses).
pub fn table_words() -> &'static TableWords {
    static WORDS: std::sync::OnceLock<TableWords> = std::sync::OnceLock::new();
    WORDS.get_or_init(|| {
        let t = table();
        let leak = |mut words: Vec<u32>| -> &'static [u32] {
            words.resize(words.len().next_power_of_two(), 0);
            Box::leak(words.into_boxed_slice())
        };
        TableWords {
            z: leak(t.z.iter().map(|x| x.to_bits()).collect()),
            coefficients: [0, 1, 2].map(|k| leak(t.cells.iter().map(|c| c[k].to_bits()).collect())),
        }
    })
}
