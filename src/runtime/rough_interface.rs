//! What a rough dielectric interface lets through, for `rough_plastic`'s
//! diffuse base: the integrals Mitsuba 3's `roughplastic` tabulates.
//!
//! For a smooth-ish coat of relative index `eta` and isotropic microfacet
//! roughness `alpha` (Beckmann or GGX, Smith's masking as the stdlib's):
//!
//! - the *transmittance* `T(cos θ)`: the fraction of light arriving at
//!   `cos θ` from outside that the interface refracts inside, single
//!   scattering, `∫ D_wi(m) (1 − F(wi·m)) G1(wt, m) dm` over the visible
//!   normals `D_wi` of `wi` (Walter et al. 2007, Heitz 2014);
//! - the *internal reflectance*: the hemispherical average
//!   `2 ∫ R(μ) μ dμ` of the reflectance `R` seen from inside (index
//!   `1 / eta`), the part of the base's diffuse light that the coat sends
//!   back down.
//!
//! Both integrals are taken as Mitsuba takes them, so the numbers agree
//! with it to quadrature error: a Gauss–Legendre rule on the unit square
//! warped onto the visible normals (32² nodes for an index above 1, 128²
//! below, where total internal reflection makes the integrand jump), the
//! transmittance at [`ROUGH_INTERFACE_NODES`] values of `cos θ` spaced
//! evenly over [0, 1] (interpolated linearly between them), the
//! hemispherical average as the mean over the same nodes.
//!
//! One [`RoughInterface`] is computed per (alpha, eta, distribution) and
//! kept for the whole process (about a quarter of a second in a debug
//! build, mostly the 128² rule of the internal reflectance): lowering reads its transmittance as a
//! constant table when alpha and eta are constants (`Op::Table`, no call
//! per hit), and the natives [`tsl_rough_transmittance`] and
//! [`tsl_rough_internal_reflectance`] look it up when they are not (a
//! run-time-bound instance). Both read the same table with the same
//! interpolation ([`lerp_transmittance`]), so specialised and bound code
//! agree bit for bit. At most [`MAX_ROUGH_INTERFACES`] are kept; past
//! that, the natives integrate at every call (right, but slow).

use std::cell::Cell;
use std::collections::HashMap;
use std::f64::consts::PI;
use std::sync::{Mutex, OnceLock};

use crate::ir::semantics::{float_to_int, fmax, fmin};

/// The values of `cos θ` the transmittance is tabulated at, evenly spaced
/// over [0, 1] (Mitsuba's `MI_ROUGH_TRANSMITTANCE_RES`, 64): a power of
/// two, as an IR table needs.
pub const ROUGH_INTERFACE_NODES: usize = 64;

/// The most distinct (alpha, eta, distribution) tables the process keeps
/// (1024, about 270 KB). Past it a new combination is integrated at every
/// call instead of being kept, so a material whose roughness varies per
/// point cannot grow memory without bound.
pub const MAX_ROUGH_INTERFACES: usize = 1024;

/// The roughness range the integrals accept: below it the stdlib clamps
/// too (Mitsuba's 1e-4), above it no surface is realistic and the
/// quadrature would only lose accuracy.
pub const ROUGH_ALPHA_RANGE: (f32, f32) = (1e-4, 4.0);

/// The relative index range accepted (1/16 to 16, every real coating and
/// its inverse); indices outside are clamped.
pub const ROUGH_ETA_RANGE: (f32, f32) = (1.0 / 16.0, 16.0);

/// The tabulated transmittance and the internal reflectance of one
/// interface.
#[derive(Debug)]
pub struct RoughInterface {
    /// `T(cos θ)` at `cos θ = k / 63`, as f32 bits (an IR table's words).
    pub transmittance: [u32; ROUGH_INTERFACE_NODES],
    /// The hemispherical average reflectance seen from inside.
    pub internal_reflectance: f32,
}

/// A cache key: the canonical alpha and eta by their bits.
type Key = (u32, u32, bool);

/// The interface for `alpha`, `eta` and the distribution, computed on
/// first use and kept for the process; `None` for a NaN argument or once
/// [`MAX_ROUGH_INTERFACES`] are kept.
pub fn rough_interface(alpha: f32, eta: f32, ggx: bool) -> Option<&'static RoughInterface> {
    let (alpha, eta) = canonical(alpha, eta)?;
    let key = (alpha.to_bits(), eta.to_bits(), ggx);
    thread_local! {
        // The last interface this thread used: a bound instance calls with
        // the same roughness at every hit, and this skips the lock.
        static LAST: Cell<Option<(Key, &'static RoughInterface)>> = const { Cell::new(None) };
    }
    if let Some((k, table)) = LAST.get()
        && k == key
    {
        return Some(table);
    }
    // Held while integrating: threads wanting the same table wait for it
    // rather than computing it again.
    let mut kept = kept().lock().unwrap_or_else(|e| e.into_inner());
    let table = match kept.get(&key) {
        Some(t) => *t,
        None if kept.len() >= MAX_ROUGH_INTERFACES => return None,
        None => {
            let computed = RoughInterface {
                transmittance: transmittance_table(alpha, eta, ggx).map(f32::to_bits),
                internal_reflectance: internal_reflectance(alpha, eta, ggx),
            };
            let leaked: &'static RoughInterface = Box::leak(Box::new(computed));
            kept.insert(key, leaked);
            leaked
        }
    };
    LAST.set(Some((key, table)));
    Some(table)
}

/// Every interface computed so far.
fn kept() -> &'static Mutex<HashMap<Key, &'static RoughInterface>> {
    static KEPT: OnceLock<Mutex<HashMap<Key, &'static RoughInterface>>> = OnceLock::new();
    KEPT.get_or_init(Default::default)
}

/// `"rough_transmittance"` for the table of a kept interface, for printing IR.
pub fn table_name(table: &[u32]) -> Option<&'static str> {
    let kept = kept().lock().unwrap_or_else(|e| e.into_inner());
    kept.values().any(|t| std::ptr::eq(t.transmittance.as_slice(), table)).then_some("rough_transmittance")
}

/// Alpha and eta clamped into their ranges, or `None` if either is NaN.
fn canonical(alpha: f32, eta: f32) -> Option<(f32, f32)> {
    if alpha.is_nan() || eta.is_nan() {
        return None;
    }
    Some((alpha.clamp(ROUGH_ALPHA_RANGE.0, ROUGH_ALPHA_RANGE.1), eta.clamp(ROUGH_ETA_RANGE.0, ROUGH_ETA_RANGE.1)))
}

/// The table read at `cos_theta`, linearly between its nodes: the exact
/// operations lowering emits for a constant table, so both agree.
pub fn lerp_transmittance(table: &[u32; ROUGH_INTERFACE_NODES], cos_theta: f32) -> f32 {
    let last = (ROUGH_INTERFACE_NODES - 1) as f32;
    let x = fmin(fmax(cos_theta, 0.0), 1.0) * last;
    let k = float_to_int(x);
    let k = if k < ROUGH_INTERFACE_NODES as i32 - 2 { k } else { ROUGH_INTERFACE_NODES as i32 - 2 };
    let w = x - k as f32;
    let a = f32::from_bits(table[k as usize]);
    let b = f32::from_bits(table[k as usize + 1]);
    a + (b - a) * w
}

/// `T(cos θ)` of the interface (native `rough_transmittance`; `ggx` is
/// nonzero for GGX). NaN for a NaN roughness or index.
pub extern "C" fn tsl_rough_transmittance(cos_theta: f32, alpha: f32, eta: f32, ggx: f32) -> f32 {
    let ggx = ggx != 0.0;
    if let Some(t) = rough_interface(alpha, eta, ggx) {
        return lerp_transmittance(&t.transmittance, cos_theta);
    }
    match canonical(alpha, eta) {
        Some((alpha, eta)) => lerp_transmittance(&transmittance_table(alpha, eta, ggx).map(f32::to_bits), cos_theta),
        None => f32::NAN,
    }
}

/// The internal reflectance of the interface (native
/// `rough_internal_reflectance`). NaN for a NaN roughness or index.
pub extern "C" fn tsl_rough_internal_reflectance(alpha: f32, eta: f32, ggx: f32) -> f32 {
    let ggx = ggx != 0.0;
    if let Some(t) = rough_interface(alpha, eta, ggx) {
        return t.internal_reflectance;
    }
    match canonical(alpha, eta) {
        Some((alpha, eta)) => internal_reflectance(alpha, eta, ggx),
        None => f32::NAN,
    }
}

// ------------------------------------------------------------- integrals

/// `cos θ` of node `k` (Mitsuba keeps the first off zero: 1e-6).
fn node_cos(k: usize) -> f64 {
    (k as f64 / (ROUGH_INTERFACE_NODES - 1) as f64).max(1e-6)
}

fn transmittance_table(alpha: f32, eta: f32, ggx: bool) -> [f32; ROUGH_INTERFACE_NODES] {
    let (alpha, eta) = (f64::from(alpha), f64::from(eta));
    let rule = GaussLegendre::new(if eta > 1.0 { 32 } else { 128 });
    std::array::from_fn(|k| {
        let wi = incident(node_cos(k));
        integrate_visible_normals(&rule, wi, alpha, ggx, |m| {
            let f = fresnel(dot(wi, m), eta);
            let Some(wt) = f.refract(wi, m) else { return 0.0 };
            if wt[2] * wi[2] >= 0.0 { 0.0 } else { smith_g1(wt, m, alpha, ggx) * (1.0 - f.reflectance) }
        }) as f32
    })
}

fn internal_reflectance(alpha: f32, eta: f32, ggx: bool) -> f32 {
    let (alpha, eta) = (f64::from(alpha), 1.0 / f64::from(eta));
    let rule = GaussLegendre::new(if eta > 1.0 { 32 } else { 128 });
    let sum: f64 = (0..ROUGH_INTERFACE_NODES)
        .map(|k| {
            let wi = incident(node_cos(k));
            let r = integrate_visible_normals(&rule, wi, alpha, ggx, |m| {
                let c = dot(wi, m);
                let wr = sub(scale(m, 2.0 * c), wi);
                if wr[2] <= 0.0 { 0.0 } else { smith_g1(wr, m, alpha, ggx) * fresnel(c, eta).reflectance }
            });
            r * wi[2]
        })
        .sum();
    (2.0 * sum / ROUGH_INTERFACE_NODES as f64) as f32
}

type V3 = [f64; 3];

fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

fn normalize(a: V3) -> V3 {
    scale(a, 1.0 / dot(a, a).sqrt())
}

/// The direction at `cos θ` in the xz plane (isotropic: one azimuth does).
fn incident(cos_theta: f64) -> V3 {
    [(1.0 - cos_theta * cos_theta).max(0.0).sqrt(), 0.0, cos_theta]
}

/// An n-point Gauss–Legendre rule moved to [0, 1].
struct GaussLegendre {
    nodes: Vec<f64>,
    weights: Vec<f64>,
}

impl GaussLegendre {
    fn new(n: usize) -> Self {
        let (mut nodes, mut weights) = (vec![0.0; n], vec![0.0; n]);
        for i in 0..n.div_ceil(2) {
            // Newton's method on P_n from Tricomi's estimate of the root.
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    (p0, p1) = (p1, p2);
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let step = p1 / dp;
                x -= step;
                if step.abs() < 1e-15 {
                    break;
                }
            }
            let w = 2.0 / ((1.0 - x * x) * dp * dp);
            // Symmetric pairs; on [0, 1] a node x is (1 + x) / 2 and the
            // weights halve.
            nodes[i] = 0.5 - 0.5 * x;
            nodes[n - 1 - i] = 0.5 + 0.5 * x;
            weights[i] = 0.5 * w;
            weights[n - 1 - i] = 0.5 * w;
        }
        GaussLegendre { nodes, weights }
    }
}

/// `∫ g(m) D_wi(m) dm` over the visible normals of `wi`: the rule on the
/// unit square, warped by visible-normal sampling (which makes the density
/// one, however peaked the distribution).
fn integrate_visible_normals(rule: &GaussLegendre, wi: V3, alpha: f64, ggx: bool, mut g: impl FnMut(V3) -> f64) -> f64 {
    // The stretched direction: the unit-roughness configuration.
    let cos_s = normalize([alpha * wi[0], alpha * wi[1], wi[2]])[2];
    let n = rule.nodes.len();
    // Beckmann's slopes are separable in the two sample coordinates.
    let beckmann: Option<(Vec<f64>, Vec<f64>)> = (!ggx).then(|| {
        let xs = rule.nodes.iter().map(|&u| beckmann_visible_slope_x(cos_s, u)).collect();
        let ys = rule.nodes.iter().map(|&u| erf_inv(2.0 * clamp_sample(u) - 1.0)).collect();
        (xs, ys)
    });
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let slope = match &beckmann {
                Some((xs, ys)) => (xs[i], ys[j]),
                None => ggx_visible_slope(cos_s, rule.nodes[i], rule.nodes[j]),
            };
            let m = normalize([-slope.0 * alpha, -slope.1 * alpha, 1.0]);
            sum += g(m) * rule.weights[i] * rule.weights[j];
        }
    }
    sum
}

fn clamp_sample(u: f64) -> f64 {
    u.clamp(1e-6, 1.0 - 1e-6)
}

/// The x slope of Beckmann's visible normals at `cos θ` (unit roughness)
/// for sample `u`: Jakob 2014's CDF, inverted by three Newton steps in
/// the erf domain from the grazing-angle solution.
fn beckmann_visible_slope_x(cos_theta: f64, u: f64) -> f64 {
    const INV_SQRT_PI: f64 = 0.564_189_583_547_756_3;
    let tan_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt() / cos_theta;
    let cot_theta = 1.0 / tan_theta;
    let top = libm::erf(cot_theta);
    let u = clamp_sample(u);
    let mut x = top - (top + 1.0) * libm::erf((-u.ln()).sqrt());
    let target = u * (1.0 + top + INV_SQRT_PI * tan_theta * (-cot_theta * cot_theta).exp());
    for _ in 0..3 {
        let slope = erf_inv(x);
        let value = 1.0 + x + INV_SQRT_PI * tan_theta * (-slope * slope).exp() - target;
        x -= value / (1.0 - slope * tan_theta);
    }
    erf_inv(x)
}

/// The slopes of GGX's visible normals at `cos θ` (unit roughness) for
/// sample `(u, v)`: a point of the concentric disk, squeezed onto the
/// visible half of the projected hemisphere (Heitz and d'Eon 2014).
fn ggx_visible_slope(cos_theta: f64, u: f64, v: f64) -> (f64, f64) {
    let (a, b) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    let (x, y) = if a == 0.0 && b == 0.0 {
        (0.0, 0.0)
    } else if a.abs() > b.abs() {
        let phi = PI / 4.0 * b / a;
        (a * phi.cos(), a * phi.sin())
    } else {
        let phi = PI / 2.0 - PI / 4.0 * a / b;
        (b * phi.cos(), b * phi.sin())
    };
    let s = 0.5 * (1.0 + cos_theta);
    let y = (1.0 - s) * (1.0 - x * x).max(0.0).sqrt() + s * y;
    let z = (1.0 - x * x - y * y).max(0.0).sqrt();
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let norm = 1.0 / (sin_theta * y + cos_theta * z);
    ((cos_theta * y - sin_theta * z) * norm, x * norm)
}

/// The inverse error function: Giles' approximation, then two Newton steps.
fn erf_inv(y: f64) -> f64 {
    if y <= -1.0 {
        return f64::NEG_INFINITY;
    }
    if y >= 1.0 {
        return f64::INFINITY;
    }
    let w = -((1.0 - y) * (1.0 + y)).ln();
    let mut x = if w < 5.0 {
        let w = w - 2.5;
        let p = [
            2.810_226_36e-08,
            3.432_739_39e-07,
            -3.523_387_7e-06,
            -4.391_506_54e-06,
            0.000_218_580_87,
            -0.001_253_725_03,
            -0.004_177_681_64,
            0.246_640_727,
            1.501_409_41,
        ];
        p.iter().fold(0.0, |acc, c| acc * w + c) * y
    } else {
        let w = w.sqrt() - 3.0;
        let p = [
            -0.000_200_214_257,
            0.000_100_950_558,
            0.001_349_343_22,
            -0.003_673_428_44,
            0.005_739_507_73,
            -0.007_622_461_3,
            0.009_438_870_47,
            1.001_674_06,
            2.832_976_82,
        ];
        p.iter().fold(0.0, |acc, c| acc * w + c) * y
    };
    for _ in 0..2 {
        let slope = 2.0 / PI.sqrt() * (-x * x).exp();
        if slope > 0.0 {
            x -= (libm::erf(x) - y) / slope;
        }
    }
    x
}

/// Smith's masking of `v` by facets `m`: Walter's rational fit for
/// Beckmann, exact for GGX; zero when `v` sees the facet's back.
fn smith_g1(v: V3, m: V3, alpha: f64, ggx: bool) -> f64 {
    if dot(v, m) * v[2] <= 0.0 {
        return 0.0;
    }
    let xy = alpha * alpha * (v[0] * v[0] + v[1] * v[1]);
    if xy == 0.0 {
        return 1.0;
    }
    let tan2 = xy / (v[2] * v[2]);
    if ggx {
        return 2.0 / (1.0 + (1.0 + tan2).sqrt());
    }
    let a = 1.0 / tan2.sqrt();
    if a >= 1.6 { 1.0 } else { (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a) }
}

/// The dielectric Fresnel term at `cos_i` for relative index `eta` (seen
/// from the side `cos_i` points to), with what refraction needs.
struct Fresnel {
    reflectance: f64,
    /// `cos θt`, of the opposite sign to `cos_i`.
    cos_t: f64,
    /// The index ratio of the incident side to the transmitted side.
    eta_ti: f64,
}

fn fresnel(cos_i: f64, eta: f64) -> Fresnel {
    let outside = cos_i >= 0.0;
    let (eta_it, eta_ti) = if outside { (eta, 1.0 / eta) } else { (1.0 / eta, eta) };
    let cos_t2 = 1.0 - eta_ti * eta_ti * (1.0 - cos_i * cos_i);
    let (ci, ct) = (cos_i.abs(), cos_t2.max(0.0).sqrt());
    let reflectance = if eta == 1.0 {
        0.0
    } else if ci == 0.0 || cos_t2 <= 0.0 {
        1.0
    } else {
        let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
        let a_p = (eta_it * ci - ct) / (eta_it * ci + ct);
        0.5 * (a_s * a_s + a_p * a_p)
    };
    Fresnel { reflectance, cos_t: if outside { -ct } else { ct }, eta_ti }
}

impl Fresnel {
    /// `wi` refracted through facet `m`; `None` under total internal
    /// reflection.
    fn refract(&self, wi: V3, m: V3) -> Option<V3> {
        if self.reflectance >= 1.0 {
            return None;
        }
        let along = dot(wi, m) * self.eta_ti + self.cos_t;
        Some(sub(scale(m, along), scale(wi, self.eta_ti)))
    }
}

#[cfg(test)]
mod tests;
