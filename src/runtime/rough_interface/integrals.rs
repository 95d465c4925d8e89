//! The integrals behind a rough interface's tables, taken as Mitsuba 3's
//! `roughplastic` takes them: a Gauss–Legendre product rule on the unit
//! square warped onto the visible normals of the incident direction.

use std::f64::consts::PI;
use std::sync::OnceLock;

use super::ROUGH_INTERFACE_NODES;

/// `cos θ` of node `k` (Mitsuba keeps the first off zero: 1e-6).
pub(super) fn node_cos(k: usize) -> f64 {
    (k as f64 / (ROUGH_INTERFACE_NODES - 1) as f64).max(1e-6)
}

/// `T(cos θ)` at the [`ROUGH_INTERFACE_NODES`] values of `cos θ`.
pub(super) fn transmittance_table(alpha: f32, eta: f32, ggx: bool) -> [f32; ROUGH_INTERFACE_NODES] {
    let (alpha, eta) = (f64::from(alpha), f64::from(eta));
    let rule = GaussLegendre::for_index(eta);
    std::array::from_fn(|k| {
        let wi = incident(node_cos(k));
        integrate_visible_normals(rule, wi, alpha, ggx, |m| {
            let f = fresnel(dot(wi, m), eta);
            let Some(wt) = f.refract(wi, m) else { return 0.0 };
            if wt[2] * wi[2] >= 0.0 { 0.0 } else { smith_g1(wt, m, alpha, ggx) * (1.0 - f.reflectance) }
        }) as f32
    })
}

/// The hemispherical average reflectance seen from inside.
pub(super) fn internal_reflectance(alpha: f32, eta: f32, ggx: bool) -> f32 {
    let (alpha, eta) = (f64::from(alpha), 1.0 / f64::from(eta));
    let rule = GaussLegendre::for_index(eta);
    let sum: f64 = (0..ROUGH_INTERFACE_NODES)
        .map(|k| {
            let wi = incident(node_cos(k));
            let r = integrate_visible_normals(rule, wi, alpha, ggx, |m| {
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

/// An n-point Gauss–Legendre rule moved to [0, 1], with the product rule's
/// nodes mapped onto the concentric disk (GGX's visible-normal warp starts
/// there, whatever the direction).
pub(super) struct GaussLegendre {
    pub(super) nodes: Vec<f64>,
    pub(super) weights: Vec<f64>,
    /// `concentric_disk(nodes[i], nodes[j])` at `i * n + j`.
    disk: Vec<(f64, f64)>,
}

impl GaussLegendre {
    /// Mitsuba's rule for an interface of relative index `eta`: 32² nodes
    /// above 1, 128² below (total internal reflection makes the integrand
    /// jump). Both are built once per process.
    fn for_index(eta: f64) -> &'static GaussLegendre {
        static COARSE: OnceLock<GaussLegendre> = OnceLock::new();
        static FINE: OnceLock<GaussLegendre> = OnceLock::new();
        if eta > 1.0 {
            COARSE.get_or_init(|| GaussLegendre::new(32))
        } else {
            FINE.get_or_init(|| GaussLegendre::new(128))
        }
    }

    pub(super) fn new(n: usize) -> Self {
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
        let disk = nodes.iter().flat_map(|&u| nodes.iter().map(move |&v| concentric_disk(u, v))).collect();
        GaussLegendre { nodes, weights, disk }
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
                None => ggx_visible_slope(cos_s, rule.disk[i * n + j]),
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

/// Shirley and Chiu's concentric map of the unit square onto the disk.
fn concentric_disk(u: f64, v: f64) -> (f64, f64) {
    let (a, b) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    if a == 0.0 && b == 0.0 {
        (0.0, 0.0)
    } else if a.abs() > b.abs() {
        let phi = PI / 4.0 * b / a;
        (a * phi.cos(), a * phi.sin())
    } else {
        let phi = PI / 2.0 - PI / 4.0 * a / b;
        (b * phi.cos(), b * phi.sin())
    }
}

/// The slopes of GGX's visible normals at `cos θ` (unit roughness) for
/// the disk point `(x, y)` of a sample: squeezed onto the visible half of
/// the projected hemisphere (Heitz and d'Eon 2014).
fn ggx_visible_slope(cos_theta: f64, (x, y): (f64, f64)) -> (f64, f64) {
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
