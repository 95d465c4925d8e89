//! Colors in the spectral models: RGB to lanes (Jakob–Hanika's table
//! looked up in IR for values known only at run time, Smits' basis for the
//! Smits models), and for hero sampling the lanes' wavelengths and weights
//! read from the shading globals: upsampled RGB, `spectrum(...)` curves and
//! the reductions (`brightness`, `to_rgb`, `to_xyz`) at run-time
//! wavelengths.

use super::builtins::smits_coefficients;
use super::*;
use crate::color::{HERO_LANES, LAMBDA_MAX, LAMBDA_MIN, jakob_hanika};
use std::sync::{Mutex, OnceLock};

/// `t = (λ − 380) / 400`, the sigmoid's variable, of `nm` as constants.
pub(super) fn normalised(nm: f32) -> f32 {
    (nm - LAMBDA_MIN) / (LAMBDA_MAX - LAMBDA_MIN)
}

impl<'p> Lowerer<'p> {
    /// An RGB triple in the color model: itself (`Rgb`), Smits' upsampling
    /// (`Smits`), or the Jakob–Hanika spectrum at the lanes' wavelengths
    /// (`Spectral`: the bin centres; `Hero`: the globals'). Constants are
    /// upsampled at compile time ([`color::rgb_to_lanes`]); other values
    /// look the same table up in the code, so both agree.
    pub(super) fn rgb_to_lanes(&mut self, b: &mut Builder, rgb: [Value; 3]) -> Vec<Value> {
        let constant = match (b.fconst(rgb[0]), b.fconst(rgb[1]), b.fconst(rgb[2])) {
            (Some(r), Some(g), Some(bl)) => Some([r, g, bl]),
            _ => None,
        };
        match self.model {
            ColorModel::Rgb => rgb.to_vec(),
            ColorModel::Smits { .. } => match constant {
                Some(c) => color::rgb_to_lanes(self.model, c).into_iter().map(|x| b.f(x)).collect(),
                None => self.smits_lanes(b, rgb),
            },
            ColorModel::Spectral { .. } => match constant {
                Some(c) => color::rgb_to_lanes(self.model, c).into_iter().map(|x| b.f(x)).collect(),
                None => {
                    let (coefficients, scale) = jakob_hanika_lookup(b, rgb);
                    let ts: Vec<Value> = self.model.wavelengths().iter().map(|&l| b.f(normalised(l))).collect();
                    sigmoid_lanes(b, coefficients, scale, &ts)
                }
            },
            ColorModel::Hero => {
                let (coefficients, scale) = match constant {
                    // A grey is the same at every wavelength.
                    Some([r, g, bl]) if r == g && g == bl && r.is_finite() => {
                        return vec![b.f(r.max(0.0)); HERO_LANES];
                    }
                    Some(c) => {
                        let s = jakob_hanika::upsample(c);
                        (s.coefficients.map(|x| b.f(x)), b.f(s.scale))
                    }
                    None => jakob_hanika_lookup(b, rgb),
                };
                let ts = hero_normalised_wavelengths(b);
                sigmoid_lanes(b, coefficients, scale, &ts)
            }
        }
    }

    /// Smits (1999) for values known only at run time: the case analysis
    /// as selects, then the basis spectra weighed per lane.
    fn smits_lanes(&mut self, b: &mut Builder, rgb: [Value; 3]) -> Vec<Value> {
        let coef = smits_coefficients(b, rgb);
        let basis = color::smits_basis(self.model);
        let spectra = basis.spectra();
        (0..self.lanes)
            .map(|i| {
                let weights: Vec<Value> = spectra.iter().map(|s| b.f(s[i])).collect();
                b.dot(&weights, &coef)
            })
            .collect()
    }

    /// The weights of `to_rgb`, rows R, G, B, one weight per lane: constants,
    /// or for hero sampling the globals' ([`crate::ShadingGlobals::rgb_weights`]).
    pub(super) fn rgb_weight_rows(&mut self, b: &mut Builder) -> [Vec<Value>; 3] {
        if self.model == ColorModel::Hero {
            return [0, 1, 2].map(|c| {
                (0..HERO_LANES)
                    .map(|i| b.global(globals::RGB_WEIGHT_WORD + (c * HERO_LANES + i) as u32, Scalar::F32))
                    .collect()
            });
        }
        color::to_rgb_weights(self.model).map(|row| row.iter().map(|&w| b.f(w)).collect())
    }

    /// `to_rgb(c)` (`xyz: false`) or `to_xyz(c)` of a color's lanes.
    pub(super) fn color_rows(&mut self, b: &mut Builder, c: &[Value], xyz: bool) -> Vec<Value> {
        if self.model != ColorModel::Hero {
            let rows = if xyz { color::to_xyz_weights(self.model) } else { color::to_rgb_weights(self.model) };
            return rows.iter().map(|w| b.weighted(w, c)).collect();
        }
        let rows = self.rgb_weight_rows(b);
        let rgb: Vec<Value> = rows.iter().map(|w| b.dot(w, c)).collect();
        if !xyz {
            return rgb;
        }
        color::SRGB_TO_XYZ.iter().map(|m| b.weighted(&m.map(|w| w as f32), &rgb)).collect()
    }

    /// `brightness(c)`: the Y of `to_rgb`.
    pub(super) fn brightness_of(&mut self, b: &mut Builder, c: &[Value]) -> Value {
        if self.model != ColorModel::Hero {
            let w = color::luminance_weights(self.model);
            return b.weighted(&w, c);
        }
        let rows = self.rgb_weight_rows(b);
        let y = &color::SRGB_TO_XYZ[1];
        let weights: Vec<Value> = (0..HERO_LANES)
            .map(|i| {
                let lane = [rows[0][i], rows[1][i], rows[2][i]];
                b.weighted(&y.map(|w| w as f32), &lane)
            })
            .collect();
        b.dot(&weights, c)
    }

    /// The hero lanes of the curve through `(wavelengths[j], values[j])`
    /// (linear, constant beyond its ends): a 1 nm table looked up when every
    /// value is a constant, else the interpolation spelled out.
    pub(super) fn hero_curve(&mut self, b: &mut Builder, wavelengths: &[f32], values: &[Value]) -> Vec<Value> {
        let mut order: Vec<usize> = (0..wavelengths.len()).filter(|&j| wavelengths[j].is_finite()).collect();
        order.sort_by(|&a, &c| wavelengths[a].total_cmp(&wavelengths[c]));
        if order.is_empty() {
            return b.zeros(HERO_LANES);
        }
        let lambdas: Vec<Value> =
            (0..HERO_LANES).map(|i| b.global(globals::WAVELENGTH_WORD + i as u32, Scalar::F32)).collect();
        let constants: Option<Vec<f32>> = order.iter().map(|&j| b.fconst(values[j])).collect();
        if let Some(constants) = constants {
            let xs: Vec<f32> = order.iter().map(|&j| wavelengths[j]).collect();
            let table = curve_table(&xs, &constants);
            return lambdas.iter().map(|&l| nm_table_lookup(b, table, l)).collect();
        }
        // v_0 + Σ_j clamp((λ − x_j) / (x_{j+1} − x_j), 0, 1) · (v_{j+1} − v_j):
        // linear between knots, held beyond the ends; a repeated wavelength
        // is a step.
        lambdas
            .iter()
            .map(|&l| {
                let mut acc = values[order[0]];
                for pair in order.windows(2) {
                    let (x0, x1) = (wavelengths[pair[0]], wavelengths[pair[1]]);
                    let dv = b.fsub(values[pair[1]], values[pair[0]]);
                    let t = if x1 > x0 {
                        let x0v = b.f(x0);
                        let d = b.fsub(l, x0v);
                        let inv = b.f(1.0 / (x1 - x0));
                        let t = b.fmul(d, inv);
                        let (zero, one) = (b.f(0.0), b.f(1.0));
                        let t = b.fmax(t, zero);
                        b.fmin(t, one)
                    } else {
                        let x0v = b.f(x0);
                        let below = b.flt(l, x0v);
                        let (zero, one) = (b.f(0.0), b.f(1.0));
                        b.select(below, zero, one)
                    };
                    let step = b.fmul(t, dv);
                    acc = b.fadd(acc, step);
                }
                acc
            })
            .collect()
    }
}

/// The normalised wavelength `t` of each hero lane, from the globals.
pub(super) fn hero_normalised_wavelengths(b: &mut Builder) -> Vec<Value> {
    let inv = b.f(1.0 / (LAMBDA_MAX - LAMBDA_MIN));
    let offset = b.f(-LAMBDA_MIN / (LAMBDA_MAX - LAMBDA_MIN));
    (0..HERO_LANES)
        .map(|i| {
            let l = b.global(globals::WAVELENGTH_WORD + i as u32, Scalar::F32);
            let scaled = b.fmul(l, inv);
            b.fadd(scaled, offset)
        })
        .collect()
}

/// `scale · sigmoid(c0 t² + c1 t + c2)` at each `t`, or for a negative
/// `scale` the complement `1 + scale · sigmoid(...)`
/// ([`jakob_hanika::Sigmoid::eval`], operation for operation).
fn sigmoid_lanes(b: &mut Builder, c: [Value; 3], scale: Value, ts: &[Value]) -> Vec<Value> {
    let (zero, half, one) = (b.f(0.0), b.f(0.5), b.f(1.0));
    let hs = b.fmul(half, scale);
    let complement = b.flt(scale, zero);
    let offset = b.select(complement, one, zero);
    let base = b.fadd(hs, offset);
    ts.iter()
        .map(|&t| {
            let x = b.fmul(c[0], t);
            let x = b.fadd(x, c[1]);
            let x = b.fmul(x, t);
            let x = b.fadd(x, c[2]);
            let xx = b.fmul(x, x);
            let xx1 = b.fadd(xx, one);
            let root = b.un(UnOp::Sqrt, xx1);
            let y = b.fdiv(x, root);
            let hy = b.fmul(hs, y);
            b.fadd(base, hy)
        })
        .collect()
}

/// `a + (c − a) · t`.
fn lerp(b: &mut Builder, a: Value, c: Value, t: Value) -> Value {
    let d = b.fsub(c, a);
    let dt = b.fmul(d, t);
    b.fadd(a, dt)
}

/// `table[index]` as a float.
fn table_f32(b: &mut Builder, table: &'static [u32], index: Value) -> Value {
    b.def(Scalar::F32, Op::Table { table, index })
}

/// The Jakob–Hanika coefficients and scale of `rgb` as compiled code:
/// [`jakob_hanika::upsample`] spelled out in IR (the complement of colours
/// nearer white, the range scale, the exact grey, the block of the largest
/// channel, the grid coordinates and trilinear interpolation of the three
/// coefficient tables).
fn jakob_hanika_lookup(b: &mut Builder, rgb: [Value; 3]) -> ([Value; 3], Value) {
    let words = jakob_hanika::table_words();
    let res = jakob_hanika::RES;
    let (zero, half, one) = (b.f(0.0), b.f(0.5), b.f(1.0));
    // Negative and NaN channels count as 0, as on the host (`fmax` would
    // keep a NaN).
    let rgb = rgb.map(|c| {
        let positive = b.flt(zero, c);
        b.select(positive, c, zero)
    });
    let m = b.fmax(rgb[0], rgb[1]);
    let m = b.fmax(m, rgb[2]);
    // Black, and infinite colors, are the zero spectrum (as on the host).
    let positive = b.flt(zero, m);
    let infinity = b.f(f32::INFINITY);
    let finite = b.flt(m, infinity);
    let lit = b.and(positive, finite);
    // A reflectance nearer white than black (min + max > 1, not a grey)
    // is the complement of the spectrum of 1 − rgb.
    let min = b.fmin(rgb[0], rgb[1]);
    let min = b.fmin(min, rgb[2]);
    let rg = b.feq(rgb[0], rgb[1]);
    let gb = b.feq(rgb[1], rgb[2]);
    let grey = b.and(rg, gb);
    let colored = b.not(grey);
    let above = b.flt(one, m);
    let reflectance = b.not(above);
    let sum = b.fadd(min, m);
    let nearer_white = b.flt(one, sum);
    let complement = b.and(reflectance, nearer_white);
    let complement = b.and(complement, colored);
    let rgb = rgb.map(|c| {
        let flipped = b.fsub(one, c);
        b.select(complement, flipped, c)
    });
    let flipped_max = b.fsub(one, min);
    let m = b.select(complement, flipped_max, m);
    // The range scale: 2m above 1, m / Z_MIN below Z_MIN, else 1.
    let two = b.f(2.0);
    let above = b.flt(one, m);
    let z_min = b.f(jakob_hanika::Z_MIN);
    let below = b.flt(m, z_min);
    let twice = b.fmul(two, m);
    let inv_z_min = b.f(1.0 / jakob_hanika::Z_MIN);
    let dark = b.fmul(m, inv_z_min);
    let low_or_one = b.select(below, dark, one);
    let scale = b.select(above, twice, low_or_one);
    let negated = b.un(UnOp::FNeg, scale);
    let signed = b.select(complement, negated, scale);
    let scale_or_zero = b.select(lit, signed, zero);
    let inv_scale = b.fdiv(one, scale);
    let v = rgb.map(|c| {
        let x = b.fmul(c, inv_scale);
        b.fmin(x, one)
    });
    // Greys: the constant spectrum.
    let rg = b.feq(v[0], v[1]);
    let gb = b.feq(v[1], v[2]);
    let grey = b.and(rg, gb);
    let one_minus = b.fsub(one, v[0]);
    let product = b.fmul(v[0], one_minus);
    let root = b.un(UnOp::Sqrt, product);
    let centred = b.fsub(v[0], half);
    let grey_c2 = b.fdiv(centred, root);
    let bound = jakob_hanika::COEFFICIENT_BOUND;
    let (lo, hi) = (b.f(-bound), b.f(bound));
    let grey_c2 = b.fmax(grey_c2, lo);
    let grey_c2 = b.fmin(grey_c2, hi);
    // The block: the largest channel, ties to the later one.
    let g_lt_r = b.flt(v[1], v[0]);
    let c1 = b.not(g_lt_r);
    let z01 = b.select(c1, v[1], v[0]);
    let b_lt = b.flt(v[2], z01);
    let c2 = b.not(b_lt);
    let z = b.select(c2, v[2], z01);
    let xn_01 = b.select(c1, v[2], v[1]);
    let xn = b.select(c2, v[0], xn_01);
    let yn_01 = b.select(c1, v[0], v[2]);
    let yn = b.select(c2, v[1], yn_01);
    let (i0, i1, i2) = (b.i(0), b.i(1), b.i(2));
    let block_01 = b.select(c1, i1, i0);
    let block = b.select(c2, i2, block_01);
    // Grid coordinates: x and y are the other channels over the largest,
    // z the largest over [Z_MIN, 1], each through
    // `jakob_hanika::grid_coordinate` onto the cells.
    let last = b.f((res - 1) as f32);
    let on_grid = |b: &mut Builder, x: Value| {
        let [k1, k2] = jakob_hanika::GRID_SLOPE.map(|k| b.f(k));
        let s = b.fmul(two, x);
        let s = b.fsub(s, one);
        let s2 = b.fmul(s, s);
        let s4 = b.fmul(s2, s2);
        let s5 = b.fmul(s4, s);
        let s5 = b.fadd(s5, one);
        let bend = b.fmul(s5, k1);
        let u = b.fadd(x, bend);
        let u = b.fmul(u, k2);
        let g = b.fmul(u, last);
        let g = b.fmax(g, zero);
        let g = b.fmin(g, last);
        let fl = b.un(UnOp::Floor, g);
        let top = b.f((res - 2) as f32);
        let fl = b.fmin(fl, top);
        let frac = b.fsub(g, fl);
        (b.un(UnOp::FToI, fl), frac)
    };
    let tiny = b.f(1e-30);
    let zsafe = b.fmax(z, tiny);
    let inv_z = b.fdiv(one, zsafe);
    let ratio = |b: &mut Builder, n: Value| {
        let x = b.fmul(n, inv_z);
        b.fmin(x, one)
    };
    let x = ratio(b, xn);
    let (xi, fx) = on_grid(b, x);
    let y = ratio(b, yn);
    let (yi, fy) = on_grid(b, y);
    let z_span = b.f(1.0 / (1.0 - jakob_hanika::Z_MIN));
    let zn = b.fsub(z, z_min);
    let zn = b.fmul(zn, z_span);
    let zn = b.fmax(zn, zero);
    let zn = b.fmin(zn, one);
    let (zi, fz) = on_grid(b, zn);
    // The cell ((block · res + zi) · res + yi) · res + xi and its neighbours.
    let resv = b.i(res as i32);
    let base = b.bin(BinOp::IMul, block, resv);
    let base = b.bin(BinOp::IAdd, base, zi);
    let base = b.bin(BinOp::IMul, base, resv);
    let base = b.bin(BinOp::IAdd, base, yi);
    let base = b.bin(BinOp::IMul, base, resv);
    let base = b.bin(BinOp::IAdd, base, xi);
    let corners: Vec<Value> = [0, 1]
        .iter()
        .flat_map(|&dz| [0, 1].iter().flat_map(move |&dy| [0, 1].iter().map(move |&dx| (dz, dy, dx))))
        .map(|(dz, dy, dx)| {
            let offset = b.i((dz * res * res + dy * res + dx) as i32);
            b.bin(BinOp::IAdd, base, offset)
        })
        .collect();
    let coefficients = [0, 1, 2].map(|k| {
        let t = words.coefficients[k];
        let at: Vec<Value> = corners.iter().map(|&i| table_f32(b, t, i)).collect();
        let x00 = lerp(b, at[0], at[1], fx);
        let x01 = lerp(b, at[2], at[3], fx);
        let x10 = lerp(b, at[4], at[5], fx);
        let x11 = lerp(b, at[6], at[7], fx);
        let y0 = lerp(b, x00, x01, fy);
        let y1 = lerp(b, x10, x11, fy);
        let c = lerp(b, y0, y1, fz);
        let g = if k == 2 { grey_c2 } else { zero };
        let c = b.select(grey, g, c);
        b.select(lit, c, zero)
    });
    (coefficients, scale_or_zero)
}

/// `table[λ − 380]` interpolated linearly: a curve sampled every nanometre
/// from 380 to 780 nm ([`curve_table`]).
fn nm_table_lookup(b: &mut Builder, table: &'static [u32], nm: Value) -> Value {
    let lo = b.f(LAMBDA_MIN);
    let x = b.fsub(nm, lo);
    let zero = b.f(0.0);
    let span = b.f(LAMBDA_MAX - LAMBDA_MIN);
    let x = b.fmax(x, zero);
    let x = b.fmin(x, span);
    let fl = b.un(UnOp::Floor, x);
    let top = b.f(LAMBDA_MAX - LAMBDA_MIN - 1.0);
    let fl = b.fmin(fl, top);
    let f = b.fsub(x, fl);
    let k = b.un(UnOp::FToI, fl);
    let one = b.i(1);
    let k1 = b.bin(BinOp::IAdd, k, one);
    let a = table_f32(b, table, k);
    let c = table_f32(b, table, k1);
    lerp(b, a, c, f)
}

/// Tables of constant curves, shared by every program of the process: a
/// curve compiled again (a stdlib metal in the next program) reuses its
/// table, so the memory they hold is bounded by the distinct curves.
fn curve_tables() -> &'static Mutex<HashMap<Vec<u32>, &'static [u32]>> {
    static TABLES: OnceLock<Mutex<HashMap<Vec<u32>, &'static [u32]>>> = OnceLock::new();
    TABLES.get_or_init(|| Mutex::new(HashMap::default()))
}

/// The curve through `(xs[j], values[j])` (sorted; linear, constant beyond
/// its ends) at 380, 381, …, 780 nm, as a table of 512 words.
fn curve_table(xs: &[f32], values: &[f32]) -> &'static [u32] {
    let xs64: Vec<f64> = xs.iter().map(|&x| f64::from(x)).collect();
    let mut words: Vec<u32> = (0..=(LAMBDA_MAX - LAMBDA_MIN) as usize)
        .map(|k| {
            let l = f64::from(LAMBDA_MIN) + k as f64;
            let m = xs64.partition_point(|&x| x <= l);
            let v = if m == 0 {
                values[0]
            } else if m == xs.len() {
                values[xs.len() - 1]
            } else {
                let t = ((l - xs64[m - 1]) / (xs64[m] - xs64[m - 1])) as f32;
                values[m - 1] + (values[m] - values[m - 1]) * t
            };
            v.to_bits()
        })
        .collect();
    words.resize(words.len().next_power_of_two(), 0);
    let mut tables = curve_tables().lock().unwrap_or_else(|e| e.into_inner());
    if let Some(t) = tables.get(&words) {
        return t;
    }
    let table: &'static [u32] = Box::leak(words.clone().into_boxed_slice());
    tables.insert(words, table);
    table
}

/// `"spectrum"` for a table of a constant curve, for printing IR.
pub fn curve_table_name(table: &[u32]) -> Option<&'static str> {
    let tables = curve_tables().lock().unwrap_or_else(|e| e.into_inner());
    tables.values().any(|t| std::ptr::eq(*t, table)).then_some("spectrum")
}
