//! RGB to spectrum by W. Jakob and J. Hanika, "A Low-Dimensional Function
//! Space for Efficient Spectral Upsampling" (Eurographics 2019), the method
//! of Mitsuba 3 and pbrt-v4.
//!
//! A reflectance `rgb` in `[0, 1]³` becomes the smooth spectrum
//! `S(λ) = sigmoid(c0 t² + c1 t + c2)`, `t = (λ − 380) / 400` (so `t` runs
//! over `[0, 1]` on the models' 380–780 nm), with `sigmoid(x) = 1/2 +
//! x / (2 √(1 + x²))`: bounded in `(0, 1)`, and the three coefficients are
//! chosen so that the spectrum, lit by D65 and seen through the CIE 1931
//! observer, *is* `rgb` in linear sRGB ([`reflectance_to_rgb`]).
//!
//! The coefficients come from a precomputed table over RGB, as in the
//! paper: three blocks (which channel is largest), each `RES³` cells over
//! `(z, y, x)` where `z` is the largest channel and `x`, `y` the next two
//! channels divided by it. On every axis the nodes are denser toward both
//! ends, where the coefficients change fastest ([`grid_coordinate`]; the
//! paper spaces only `z` so, by `smoothstep(smoothstep(·))`). Each cell is
//! fitted by Gauss–Newton on the CIELAB difference, starting from its
//! neighbour's solution ([`fit_table`]); lookups interpolate the
//! coefficients trilinearly in grid coordinates ([`Table::fetch`]). The
//! table is made offline by `cargo run --release --example make_rgb2spec`
//! and committed as `src/color/data/rgb2spec_srgb.bin`.
//!
//! Beyond the table, [`upsample`] handles what it cannot: greys get the
//! exact constant spectrum (as pbrt-v4 does), black is 0, colours nearer
//! white than black are the complement of the spectrum of `1 − rgb` (the
//! table is read away from white, where its coefficients diverge), and
//! colours brighter than 1 (emission) are upsampled as Mitsuba's emitters
//! are: `2m · S_{rgb / 2m}(λ)` with `m` the largest channel.

use super::{HI, LO, reflectance_rgb_nodes};

/// Cells per axis of the table.
pub const RES: usize = 64;

/// The darkest largest channel the table covers: a darker reflectance is
/// the spectrum of its colour scaled up to this, scaled back down (the
/// sigmoid cannot make dark saturated colours within bounded coefficients).
pub const Z_MIN: f32 = 0.05;

/// Fitted coefficients are kept below this in size.
const FIT_BOUND: f64 = 1000.0;

/// The file the table is read from: a header (`b"JHg2"`, then the
/// resolution as a little-endian `u32`), the `RES` node positions of
/// [`grid`] (a check that the table was made for this code's grid), then
/// `3 · RES³` cells of three coefficients, all little-endian `f32`, cell
/// `((block · RES + z) · RES + y) · RES + x`.
static TABLE_BYTES: &[u8] = include_bytes!("data/rgb2spec_srgb.bin");

/// The magic number the table file starts with.
pub const MAGIC: &[u8; 4] = b"JHg2";

/// A coefficient a grey of exactly 0 or 1 would need (±∞) is clamped to
/// this, where the sigmoid is 0 or 1 to `f32` precision.
pub const COEFFICIENT_BOUND: f32 = 1e4;

/// The spectrum of one RGB colour: `scale · sigmoid(c0 t² + c1 t + c2)`,
/// or for a negative `scale` its complement `1 + scale · sigmoid(...)`
/// (`1 − |scale| · sigmoid`: bright colours, see [`upsample`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sigmoid {
    /// `c0, c1, c2`, for `t = (λ − 380) / 400`.
    pub coefficients: [f32; 3],
    /// 1 for reflectances; `2 · max(rgb)` for colours brighter than 1; 0
    /// for black; `−1`, or above `−1` for the brightest, for the complement
    /// of the spectrum of `1 − rgb`.
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
        self.base() + half_scale * (x / (x * x + 1.0).sqrt())
    }

    /// The spectrum where the polynomial is 0: `scale / 2`, plus 1 for a
    /// complement; lanes are `base + scale / 2 · x / √(x² + 1)`.
    pub fn base(&self) -> f32 {
        0.5 * self.scale + if self.scale < 0.0 { 1.0 } else { 0.0 }
    }

    /// The spectrum at `nm`, in `f64`.
    pub fn eval64(&self, nm: f64) -> f64 {
        let t = (nm - LO) / (HI - LO);
        let [c0, c1, c2] = self.coefficients.map(f64::from);
        let complement = if self.scale < 0.0 { 1.0 } else { 0.0 };
        complement + f64::from(self.scale) * sigmoid((c0 * t + c1) * t + c2)
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
///
/// A reflectance nearer white than black (`min + max > 1`, not a grey) is
/// the complement of the spectrum of `1 − rgb`: the flat spectrum 1 is
/// exactly white, so `1 − S` has the colour `1 − rgb`. Since
/// `1 − sigmoid(p) = sigmoid(−p)`, that is the same sigmoid the table
/// holds for `rgb` itself, but read where the table is accurate: toward
/// white the coefficients grow without bound and interpolating them is
/// off by up to 1.5%. When `1 − rgb` is darker than [`Z_MIN`] (every
/// channel above 0.95) it is scaled as dark colours are, and the spectrum
/// is `1 − s · sigmoid`, no longer a plain sigmoid.
pub fn upsample(rgb: [f32; 3]) -> Sigmoid {
    upsample_in(table(), rgb)
}

/// [`upsample`] with another table (the generator's report, tests).
pub fn upsample_in(table: &Table, rgb: [f32; 3]) -> Sigmoid {
    match lookup_point(rgb) {
        None => Sigmoid { coefficients: [0.0; 3], scale: 0.0 },
        Some((v, scale)) => {
            let coefficients = if v[0] == v[1] && v[1] == v[2] { grey_coefficients(v[0]) } else { table.fetch(v) };
            Sigmoid { coefficients, scale }
        }
    }
}

/// Where [`upsample`] reads the table for `rgb`, and the scale of the
/// spectrum (negative for a complement); `None` for black and infinite
/// colours, whose spectrum is 0.
pub fn lookup_point(rgb: [f32; 3]) -> Option<([f32; 3], f32)> {
    let rgb = rgb.map(|c| if c > 0.0 { c } else { 0.0 });
    let m = rgb[0].max(rgb[1]).max(rgb[2]);
    if m.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) || !m.is_finite() {
        return None;
    }
    let min = rgb[0].min(rgb[1]).min(rgb[2]);
    let grey = rgb[0] == rgb[1] && rgb[1] == rgb[2];
    let complement = m <= 1.0 && min + m > 1.0 && !grey;
    // 1 − max(1 − c) is 1 − min(c) exactly: subtraction rounds monotonically.
    let (rgb, m) = if complement { (rgb.map(|c| 1.0 - c), 1.0 - min) } else { (rgb, m) };
    let scale = range_scale(m);
    // The compiled lookup's arithmetic, operation for operation (a
    // reciprocal, then products): any other rounding would let a
    // specialised constant differ from the same value at run time.
    let inv_scale = 1.0 / scale;
    let v = rgb.map(|c| (c * inv_scale).min(1.0));
    Some((v, if complement { -scale } else { scale }))
}

/// The spectrum of `rgb` fitted exactly (Gauss–Newton from the table's
/// coefficients, round trip within 1e-6): for tools and tests; the color
/// models use [`upsample`].
pub fn upsample_exact(rgb: [f32; 3]) -> Sigmoid {
    let s = upsample(rgb);
    let Some((v, _)) = lookup_point(rgb) else { return s };
    if s.coefficients[..2] == [0.0, 0.0] {
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
    /// The position in `[0, 1]` of each of the `res` nodes on every axis
    /// ([`grid`]).
    pub grid: Vec<f32>,
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

/// How much denser than average the nodes are at the ends of each axis:
/// `(1 + k) / (1 + k / 5)` with `k` = 6, 3.2 times (0.45 times in the
/// middle). Measured worst round trips (interior of `[0, 1]³` / its faces,
/// a channel at 0 or 1 as 8-bit texels often are): `k` = 3, 3.7e-4 /
/// 1.2e-3; 6, 4.6e-4 / 7.5e-4; 10, 1.0e-3 / 9.9e-4.
const GRID_K: f64 = 6.0;

/// Where `x` in `[0, 1]` falls on the table's axes, in `[0, 1]`:
/// `u(x) = (x + k (s⁵ + 1) / 10) / (1 + k / 5)` with `s = 2x − 1`, whose
/// slope `∝ 1 + k s⁴` puts the nodes `u = i / (RES − 1)` closer together
/// toward 0 and 1, where the coefficients change fastest (bright saturated
/// colours). Cheap enough for compiled code to evaluate, in this order
/// (`ir::lower::spectral` spells it out; constants and run-time values
/// must round alike).
pub fn grid_coordinate(x: f32) -> f32 {
    let s = 2.0 * x - 1.0;
    let s2 = s * s;
    let s5 = s2 * s2 * s;
    (x + (s5 + 1.0) * GRID_SLOPE[0]) * GRID_SLOPE[1]
}

/// `k / 10` and `1 / (1 + k / 5)` of [`grid_coordinate`].
pub const GRID_SLOPE: [f32; 2] = [(GRID_K / 10.0) as f32, (1.0 / (1.0 + GRID_K / 5.0)) as f32];

/// [`grid_coordinate`] in `f64`.
fn grid_coordinate64(x: f64) -> f64 {
    let s = 2.0 * x - 1.0;
    (x + GRID_K * (s.powi(5) + 1.0) / 10.0) / (1.0 + GRID_K / 5.0)
}

/// The nodes of the table's axes in `[0, 1]`: where [`grid_coordinate`]
/// is `i / (res − 1)` (by bisection, in `f64`). `x` and `y` are these;
/// `z` is `Z_MIN + (1 − Z_MIN)` times these.
pub fn grid(res: usize) -> Vec<f64> {
    let last = (res - 1) as f64;
    (0..res)
        .map(|i| {
            let u = i as f64 / last;
            let (mut lo, mut hi) = (0.0f64, 1.0f64);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if grid_coordinate64(mid) < u {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            match i {
                0 => 0.0,
                _ if i + 1 == res => 1.0,
                _ => 0.5 * (lo + hi),
            }
        })
        .collect()
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
    /// Reads the table file format (the embedded `TABLE_BYTES` is one).
    pub fn from_bytes(bytes: &[u8]) -> Result<Table, String> {
        if bytes.len() < 8 || &bytes[..4] != MAGIC {
            return Err("not a coefficient table (no JHg2 header)".into());
        }
        let res = u32::from_le_bytes([bytes[4], bytes[5], bytes[6], bytes[7]]) as usize;
        let floats: Vec<f32> =
            bytes[8..].chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
        if !(2..=256).contains(&res) || floats.len() != res + 9 * res * res * res {
            return Err(format!("a table of resolution {res} with {} numbers", floats.len()));
        }
        let nodes = floats[..res].to_vec();
        if nodes.iter().zip(grid(res)).any(|(&a, b)| a != b as f32) {
            return Err("a table made for another grid: remake it with make_rgb2spec".into());
        }
        let cells = floats[res..].chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        Ok(Table { res, grid: nodes, cells })
    }

    /// The file format of [`Table::from_bytes`].
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = MAGIC.to_vec();
        out.extend((self.res as u32).to_le_bytes());
        for x in self.grid.iter().chain(self.cells.iter().flatten()) {
            out.extend(x.to_le_bytes());
        }
        out
    }

    /// The coefficients of a reflectance `rgb` in `[0, 1]³` whose largest
    /// channel is at least [`Z_MIN`], interpolated trilinearly (in grid
    /// coordinates) between the cells around it.
    pub fn fetch(&self, rgb: [f32; 3]) -> [f32; 3] {
        let res = self.res;
        let (block, _) = coordinates(rgb);
        let z = rgb[block];
        // As the compiled lookup rounds.
        let last = (res - 1) as f32;
        let inv_z = 1.0 / z.max(1e-30);
        let on_grid = |x: f32| (grid_coordinate(x) * last).clamp(0.0, last);
        let x = on_grid((rgb[(block + 1) % 3] * inv_z).min(1.0));
        let y = on_grid((rgb[(block + 2) % 3] * inv_z).min(1.0));
        let z = on_grid(((z - Z_MIN) * (1.0 / (1.0 - Z_MIN))).clamp(0.0, 1.0));
        let split = |g: f32| {
            let i = g.floor().min(last - 1.0);
            (i as usize, g - i)
        };
        let ((xi, fx), (yi, fy), (zi, fz)) = (split(x), split(y), split(z));
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
/// ([`reflectance_to_rgb`]) at quadrature nodes.
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
    Table { res, grid: grid(res).iter().map(|&v| v as f32).collect(), cells }
}

/// The cells of one `(block, y, x)` column of the table at resolution
/// `res`, from `z = Z_MIN` up (see [`fit_table`]).
pub fn fit_column(res: usize, block: usize, y: usize, x: usize) -> Vec<[f32; 3]> {
    let fitter = Fitter::get();
    let nodes = grid(res);
    let lo = f64::from(Z_MIN);
    let z: Vec<f64> = nodes.iter().map(|u| lo + (1.0 - lo) * u).collect();
    let start = res / 5;
    let mut column = vec![[0.0; 3]; res];
    let target = |k: usize| {
        let mut rgb = [0.0; 3];
        rgb[block] = z[k];
        rgb[(block + 1) % 3] = nodes[x] * z[k];
        rgb[(block + 2) % 3] = nodes[y] * z[k];
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
/// length must be a power of two): each coefficient over the cells,
/// zero-padded.
pub struct TableWords {
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
        TableWords { coefficients: [0, 1, 2].map(|k| leak(t.cells.iter().map(|c| c[k].to_bits()).collect())) }
    })
}
