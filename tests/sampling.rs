//! Material sampling, tested as pbrt-v4 and Mitsuba 3 test their BSDFs:
//! a chi² goodness-of-fit test of every material's `sample` against its
//! own `pdf` (several `wo`, roughnesses and anisotropies), the pdf
//! integrating to at most 1, and each sample's weight equal to
//! `f · cos / pdf` of the material at the direction drawn. Texture trees are
//! tested the same way: their sampling composes their children's.

mod common;

use common::Rng;
use tsl::render::chi2::{Chi2Result, DirectionTest};
use tsl::{Color, Compiler, Material, Program, ShadingGlobals};

/// Every chi² test of this file together is held to a 1% false-failure
/// rate (Bonferroni).
const ALPHA: f64 = 0.01 / 200.0;
const SAMPLES: usize = 100_000;

fn compile(src: &str) -> Program {
    Compiler::new().source("sampling.tsl", src).compile().unwrap_or_else(|e| panic!("{e}"))
}

/// A flat surface point with normal +z and tangents along x and y.
fn surface() -> ShadingGlobals {
    ShadingGlobals {
        p: [0.1, 0.2, 0.0],
        pl: [0.1, 0.2, 0.0],
        n: [0.0, 0.0, 1.0],
        ng: [0.0, 0.0, 1.0],
        u: 0.3,
        v: 0.6,
        dpdu: [1.0, 0.0, 0.0],
        dpdv: [0.0, 1.0, 0.0],
        t: 1.0,
        ..ShadingGlobals::default()
    }
}

/// The surface of a dielectric seen from +z: from outside (the normal +z)
/// when the index beyond it is above 1, else from inside (the normal -z).
fn facing(eta: f32) -> ShadingGlobals {
    let mut g = surface();
    if eta < 1.0 {
        (g.n, g.ng) = ([0.0, 0.0, -1.0], [0.0, 0.0, -1.0]);
    }
    g
}

/// A unit `wo` at `theta` degrees from the normal, in the xz plane tilted
/// toward +y by `phi` degrees.
fn direction(theta: f32, phi: f32) -> [f32; 3] {
    let (t, p) = (theta.to_radians(), phi.to_radians());
    [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]
}

/// `f · cos` toward `wo` for unit light from `wi`: reflection on the side
/// of the normal, refraction across it (the rule of `eval_at`).
fn eval(m: &Material, g: &ShadingGlobals, wi: [f32; 3], wo: [f32; 3], eta: &Color) -> Color {
    let one = Color::from_lanes(eta.model(), &vec![1.0; eta.lanes().len()]);
    if (wi[2] * g.ng[2]) * (wo[2] * g.ng[2]) > 0.0 {
        m.reflection(g, wi, &one, wo)
    } else {
        m.refraction(g, wi, &one, eta, wo)
    }
}

struct Report {
    chi2: Chi2Result,
    /// The largest relative difference between a sample's weight and
    /// `f · cos / pdf`, and between its pdf and `pdf(wi)`.
    weight_error: f32,
    pdf_error: f32,
}

/// Tests material `name` of `p` at `g` for light leaving toward `wo`.
fn test_sampling(p: &Program, name: &str, g: &ShadingGlobals, wo: [f32; 3], eta: f32, seed: u64) -> Report {
    let m = p.material(name).unwrap_or_else(|e| panic!("{e}"));
    let eta = p.rgb(eta, eta, eta);
    // Delta lobes answer `reflection` near their direction: not the smooth part.
    let deltas = [m.reflection_dir(g, wo), m.refraction_dir(g, wo, &eta)];
    let in_delta_cone = |wi: [f32; 3]| deltas.iter().any(|d| wi[0] * d[0] + wi[1] * d[1] + wi[2] * d[2] >= 0.9999);
    let mut rng = Rng(seed);
    let mut weight_error = 0.0f32;
    let mut pdf_error = 0.0f32;
    let chi2 = DirectionTest { subdivisions: 10, ..DirectionTest::new(20, 40) }.run(
        SAMPLES,
        || {
            let (uc, u) = (rng.range(0.0, 1.0), [rng.range(0.0, 1.0), rng.range(0.0, 1.0)]);
            let s = m.sample(g, wo, &eta, uc, u);
            if s.delta || s.pdf <= 0.0 || s.wi == [0.0; 3] {
                return None;
            }
            let pdf = m.pdf(g, s.wi, wo, &eta);
            pdf_error = pdf_error.max((pdf - s.pdf).abs() / s.pdf.max(pdf));
            if in_delta_cone(s.wi) {
                return Some(s.wi);
            }
            let f = eval(&m, g, s.wi, wo, &eta);
            for (w, f) in s.weight.lanes().iter().zip(f.lanes()) {
                let want = f / s.pdf;
                weight_error = weight_error.max((w - want).abs() / want.abs().max(1e-3));
            }
            Some(s.wi)
        },
        |wi| f64::from(m.pdf(g, wi, wo, &eta)),
    );
    Report { chi2, weight_error, pdf_error }
}

fn assert_sampling(p: &Program, name: &str, g: &ShadingGlobals, wo: [f32; 3], eta: f32, seed: u64) -> Report {
    let r = test_sampling(p, name, g, wo, eta, seed);
    let what = format!("`{name}` at wo = {wo:?}");
    assert!(r.chi2.p_value > ALPHA, "{what}: sampling does not follow its pdf: {:?}", r.chi2);
    assert!(r.chi2.pdf_integral <= 1.01, "{what}: the pdf integrates to {}", r.chi2.pdf_integral);
    assert!(r.weight_error < 2e-3, "{what}: weight differs from f cos / pdf by {}", r.weight_error);
    assert!(r.pdf_error < 2e-3, "{what}: the sample's pdf differs from pdf(wi) by {}", r.pdf_error);
    r
}

const VIEWS: [(f32, f32); 3] = [(0.0, 0.0), (40.0, 30.0), (75.0, 200.0)];

#[test]
fn default_sampling_follows_the_default_pdf() {
    // A material without sample() or pdf(): cosine about normal().
    let p = compile(
        "material plain(color kd = gray(0.7)) {
            color reflection(vector wi, color light, vector wo) {
                return light * kd * max(dot(faceforward(N, -wo), wi), 0) * INV_PI;
            }
        }
        material tilted(color kd = gray(0.7)) {
            color reflection(vector wi, color light, vector wo) {
                return light * kd * max(dot(normal(), wi), 0) * INV_PI;
            }
            normal normal() { return normalize(normal(0.3, 0, 1)); }
        }",
    );
    for (k, (t, ph)) in VIEWS.iter().enumerate() {
        let g = surface();
        let r = assert_sampling(&p, "plain", &g, direction(*t, *ph), 1.0, 11 + k as u64);
        assert!((r.chi2.pdf_integral - 1.0).abs() < 1e-2, "a cosine lobe integrates to 1: {:?}", r.chi2);
        assert_sampling(&p, "tilted", &g, direction(*t, *ph), 1.0, 21 + k as u64);
    }
}

#[test]
fn mixtures_sample_their_children_by_weight() {
    let p = compile(
        "material two = mix(0.3, lambert(kd: gray(0.6)), phong(kd: gray(0.1), ks: gray(0.8), ns: 40));
        material varying = mix(saturate(u + 0.2 * noise(P * 3)), lambert, phong(ns: 10));
        material three = blend(0.4, [lambert, phong(ns: 20), blinn_phong(ns: 60)], spline: true);
        material tinted = scale(rgb(0.9, 0.5, 0.2), mix(0.5, lambert, phong(ns: 15)));
        material nested = mix(0.5, mix(0.25, lambert, phong(ns: 30)), blend(0.7, [lambert, phong]));
        material chosen = select(face, [lambert, phong(ns: 25)]);",
    );
    for name in ["two", "varying", "three", "tinted", "nested", "chosen"] {
        for (k, (t, ph)) in VIEWS.iter().enumerate() {
            let mut g = surface();
            g.face = k as i32 % 2;
            assert_sampling(&p, name, &g, direction(*t, *ph), 1.0, 100 + k as u64);
        }
    }
}

#[test]
fn the_pdf_of_a_mix_is_the_weighted_sum_of_its_childrens() {
    let p = compile(
        "material a = lambert;
        material b = phong(ns: 30);
        material m = mix(0.3, a, b);",
    );
    let (a, b, m) = (p.material("a").unwrap(), p.material("b").unwrap(), p.material("m").unwrap());
    let g = surface();
    let eta = p.rgb(1.0, 1.0, 1.0);
    let mut rng = Rng(5);
    for _ in 0..200 {
        let (wi, wo) = (rng.unit(), direction(rng.range(0.0, 80.0), rng.range(0.0, 360.0)));
        let want = 0.7 * a.pdf(&g, wi, wo, &eta) + 0.3 * b.pdf(&g, wi, wo, &eta);
        let got = m.pdf(&g, wi, wo, &eta);
        assert!((got - want).abs() <= 1e-5 * want.max(1.0), "{got} != {want} at wi {wi:?}, wo {wo:?}");
    }
}

/// Every stdlib material that samples itself, with parameters that make
/// its lobes distinct: glossy and rough, isotropic and anisotropic.
const STDLIB: &str = "
    material t_lambert = lambert(kd: rgb(0.8, 0.5, 0.2));
    material t_phong = phong(kd: gray(0.3), ks: gray(0.6), ns: 30);
    material t_phong_sharp = phong(kd: gray(0.05), ks: gray(0.9), ns: 150);
    material t_blinn = blinn_phong(kd: gray(0.4), ks: gray(0.5), ns: 80);
    material t_cook = cook_torrance(kd: gray(0.2), roughness: 0.3);
    material t_cook_sharp = cook_torrance(kd: gray(0.1), roughness: 0.12);
    material t_ward = ward(kd: gray(0.2), ks: gray(0.7), alpha_x: 0.15, alpha_y: 0.4);
    material t_emitter = emitter(kd: gray(0.5));
    material t_beckmann = rough_conductor(alpha: 0.3);
    material t_beckmann_sharp = rough_conductor(alpha: 0.08, eta: AU_ETA, k: AU_K);
    material t_ggx = rough_conductor(alpha: 0.3, distribution: \"ggx\");
    material t_ggx_aniso = rough_conductor(alpha_u: 0.1, alpha_v: 0.5, distribution: \"ggx\", eta: CU_ETA, k: CU_K);
    material t_beckmann_aniso = rough_conductor(alpha_u: 0.4, alpha_v: 0.1);
    material t_dielectric = rough_dielectric(alpha: 0.25);
    material t_dielectric_ggx = rough_dielectric(alpha: 0.15, distribution: \"ggx\");
    material t_plastic = plastic(diffuse_reflectance: rgb(0.7, 0.2, 0.1));
    material t_rough_plastic = rough_plastic(alpha: 0.2, distribution: \"ggx\");
    material t_glass = glass;
    material t_mirror = mirror;
    material t_conductor = conductor(eta: AG_ETA, k: AG_K);
    material t_standard = standard_surface(base_color: rgb(0.6, 0.3, 0.1), coat: 0.8, coat_roughness: 0.2);
    material t_coated = layer(glass, lambert);
    material t_standard_metal = standard_surface(metalness: 0.7, specular_roughness: 0.4, base_color: rgb(0.9, 0.6, 0.3));
";

#[test]
fn every_stdlib_material_samples_its_pdf() {
    let p = compile(STDLIB);
    let names = [
        "t_lambert",
        "t_phong",
        "t_phong_sharp",
        "t_blinn",
        "t_cook",
        "t_cook_sharp",
        "t_ward",
        "t_emitter",
        "t_beckmann",
        "t_beckmann_sharp",
        "t_ggx",
        "t_ggx_aniso",
        "t_beckmann_aniso",
        "t_plastic",
        "t_rough_plastic",
        "t_standard",
        "t_standard_metal",
    ];
    let mut seed = 1000;
    for name in names {
        for (t, ph) in VIEWS {
            seed += 1;
            assert_sampling(&p, name, &surface(), direction(t, ph), 1.0, seed);
        }
    }
}

#[test]
fn rough_dielectrics_sample_reflection_and_refraction() {
    let p = compile(STDLIB);
    let mut seed = 2000;
    for name in ["t_dielectric", "t_dielectric_ggx"] {
        // From outside (index 1.5 beyond the surface) and from inside (1 / 1.5).
        for eta in [1.5, 1.0 / 1.5] {
            for (t, ph) in VIEWS {
                seed += 1;
                let r = assert_sampling(&p, name, &facing(eta), direction(t, ph), eta, seed);
                assert!(r.chi2.pdf_integral > 0.9, "`{name}` reflects or refracts nearly everything: {:?}", r.chi2);
            }
        }
    }
}

#[test]
fn delta_materials_draw_their_perfect_directions() {
    let p = compile(STDLIB);
    let g = surface();
    let wo = direction(35.0, 20.0);
    let mirror_dir = [-wo[0], -wo[1], wo[2]];
    let names =
        [("t_mirror", true), ("t_conductor", true), ("t_glass", true), ("t_plastic", false), ("t_coated", false)];
    for (name, pure) in names {
        let m = p.material(name).unwrap();
        let eta = p.rgb(1.5, 1.5, 1.5);
        let mut rng = Rng(7);
        let mut deltas = 0;
        for _ in 0..1000 {
            let s = m.sample(&g, wo, &eta, rng.range(0.0, 1.0), [rng.range(0.0, 1.0), rng.range(0.0, 1.0)]);
            if !s.delta {
                continue;
            }
            deltas += 1;
            assert_eq!(s.pdf, 0.0, "`{name}`: a delta lobe has no density");
            let reflected = s.wi.iter().zip(mirror_dir).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max) < 1e-5;
            let refracted = m.refraction_dir(&g, wo, &eta);
            let through = s.wi.iter().zip(refracted).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max) < 1e-5;
            assert!(reflected || through, "`{name}`: {:?} is neither delta direction", s.wi);
            assert!(s.weight.lanes().iter().all(|w| w.is_finite() && *w >= 0.0), "`{name}`: {:?}", s.weight);
        }
        assert!(deltas > 0, "`{name}` never drew its delta lobe");
        if pure {
            assert_eq!(m.pdf(&g, mirror_dir, wo, &eta), 0.0, "`{name}`: no density at the mirror direction");
        }
    }
}

/// `∫ f cos dωi` toward `wo`, as the mean weight of `n` samples (importance
/// sampling with the material's own pdf), and `e²` times the transmitted
/// part of it (radiance is scaled by 1 / e² when it crosses into a medium
/// of relative index e, so that part times e² is the energy).
fn albedo(m: &Material, g: &ShadingGlobals, wo: [f32; 3], eta: &Color, n: usize) -> (f64, f64) {
    let mut rng = Rng(99);
    let e = f64::from(eta.brightness());
    let (mut reflected, mut transmitted) = (0.0, 0.0);
    for _ in 0..n {
        let s = m.sample(g, wo, eta, rng.range(0.0, 1.0), [rng.range(0.0, 1.0), rng.range(0.0, 1.0)]);
        let w = f64::from(s.weight.brightness());
        if s.wi[2] > 0.0 {
            reflected += w;
        } else {
            transmitted += w * e * e;
        }
    }
    (reflected / n as f64, transmitted / n as f64)
}

/// The directional albedo at normal incidence of a microfacet reflector
/// with Fresnel 1 (D, separable Smith G), by quadrature over the facet
/// angle in f64: an oracle written from the textbook formulas.
fn microfacet_albedo_at_normal(alpha: f64, ggx: bool) -> f64 {
    use std::f64::consts::PI;
    let tan2 = |c: f64| (1.0 - c * c) / (c * c);
    let d = |c: f64| {
        let t2 = tan2(c);
        if ggx {
            1.0 / (PI * alpha * alpha * c.powi(4) * (1.0 + t2 / (alpha * alpha)).powi(2))
        } else {
            (-t2 / (alpha * alpha)).exp() / (PI * alpha * alpha * c.powi(4))
        }
    };
    let g1 = |c: f64| {
        let t2 = tan2(c);
        if ggx {
            return 2.0 / (1.0 + (1.0 + alpha * alpha * t2).sqrt());
        }
        let a = 1.0 / (alpha * t2.sqrt());
        if a >= 1.6 { 1.0 } else { (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a) }
    };
    // wo is the normal; the facet at angle m reflects it to 2m, with
    // dωi = 4 cos(m) dωm, and f cos = D G1(wi) G1(wo) / 4.
    let n = 100_000;
    let step = PI / 4.0 / n as f64;
    (0..n)
        .map(|k| {
            let m = (k as f64 + 0.5) * step;
            d(m.cos()) * g1((2.0 * m).cos()) / 4.0 * 4.0 * m.cos() * m.sin() * step * 2.0 * PI
        })
        .sum()
}

#[test]
fn a_rough_conductor_with_fresnel_one_conserves_energy() {
    let p = compile(
        "material smooth_beckmann = rough_conductor(alpha: 0.02);
        material smooth_ggx = rough_conductor(alpha: 0.02, distribution: \"ggx\");
        material rough_beckmann = rough_conductor(alpha: 0.5);
        material rough_ggx = rough_conductor(alpha: 0.5, distribution: \"ggx\");",
    );
    let one = p.rgb(1.0, 1.0, 1.0);
    for (t, ph) in VIEWS {
        let wo = direction(t, ph);
        for name in ["smooth_beckmann", "smooth_ggx", "rough_beckmann", "rough_ggx"] {
            let (a, _) = albedo(&p.material(name).unwrap(), &surface(), wo, &one, 40_000);
            assert!(a <= 1.005, "`{name}` at {t} degrees reflects {a} of the light: more than it receives");
            if name.starts_with("smooth") {
                assert!(a >= 0.98, "`{name}` at {t} degrees reflects only {a}");
            }
            if t == 0.0 {
                // Single scattering loses what bounces between the facets
                // (31% for GGX at alpha 0.5): the quadrature says how much.
                let alpha = if name.starts_with("smooth") { 0.02 } else { 0.5 };
                let want = microfacet_albedo_at_normal(alpha, name.ends_with("ggx"));
                assert!((a - want).abs() < 0.01, "`{name}` at the normal reflects {a}, the formula says {want}");
            }
        }
    }
}

#[test]
fn dielectrics_conserve_energy() {
    let p = compile(
        "material frosted = rough_dielectric(alpha: 0.05, int_ior: 1.5, ext_ior: 1);
        material frosted_ggx = rough_dielectric(alpha: 0.3, distribution: \"ggx\", int_ior: 1.5, ext_ior: 1);
        material glossy_plastic = rough_plastic(alpha: 0.1, diffuse_reflectance: gray(1));
        material coat = plastic(diffuse_reflectance: gray(1));
        material layered = standard_surface(base_color: gray(1), coat: 1, coat_roughness: 0.2);
        material metal = standard_surface(base_color: gray(0.95), metalness: 1, specular_roughness: 0.2);",
    );
    for (t, ph) in VIEWS {
        let wo = direction(t, ph);
        for eta in [1.5f32, 1.0 / 1.5] {
            for name in ["frosted", "frosted_ggx"] {
                let eta_c = p.rgb(eta, eta, eta);
                let (r, tr) = albedo(&p.material(name).unwrap(), &facing(eta), wo, &eta_c, 20_000);
                assert!(r + tr <= 1.01, "`{name}` (eta {eta}) at {t} degrees: {r} + {tr} > 1");
                // What single scattering loses: little when nearly smooth.
                // (a quarter at grazing angles for GGX at alpha 0.3).
                let floor = if name == "frosted" { 0.95 } else { 0.7 };
                assert!(r + tr >= floor, "`{name}` (eta {eta}) at {t} degrees keeps only {r} + {tr}");
            }
        }
        // A white base under a clear coat: what the coat does not reflect
        // the base returns, up to the light the coat traps.
        for name in ["glossy_plastic", "coat", "layered", "metal"] {
            let (r, _) = albedo(&p.material(name).unwrap(), &surface(), wo, &p.rgb(1.0, 1.0, 1.0), 20_000);
            assert!((0.8..=1.01).contains(&r), "`{name}` at {t} degrees reflects {r}");
        }
    }
}

/// Mitsuba 3.9.1's `roughplastic` (scalar_rgb, its defaults: int_ior 1.49,
/// ext_ior 1.000277, nonlinear false) with a 0.5 grey base, seen head-on:
/// the directional albedo of its diffuse component alone (`ctx.component =
/// 1`, a 64² midpoint rule over the cosine-warped square) and of both
/// lobes, for (distribution, alpha). The first three are issue 32's
/// figures.
const MITSUBA_ROUGH_PLASTIC_ALBEDO: [(&str, f32, f64, f64); 6] = [
    ("ggx", 0.001, 0.4699, 0.5085),
    ("ggx", 0.1, 0.4364, 0.4747),
    ("ggx", 0.4, 0.2904, 0.3215),
    ("beckmann", 0.001, 0.4698, 0.5084),
    ("beckmann", 0.1, 0.4655, 0.5042),
    ("beckmann", 0.4, 0.3857, 0.4245),
];

#[test]
fn rough_plastic_albedo_matches_mitsuba_head_on() {
    for (distribution, alpha, diffuse, total) in MITSUBA_ROUGH_PLASTIC_ALBEDO {
        let p = compile(&format!(
            "material base_only = rough_plastic(alpha: {alpha}, distribution: \"{distribution}\", \
                 specular_reflectance: gray(0));
             material both = rough_plastic(alpha: {alpha}, distribution: \"{distribution}\");"
        ));
        let one = p.rgb(1.0, 1.0, 1.0);
        let head_on = [0.0, 0.0, 1.0];
        let (d, _) = albedo(&p.material("base_only").unwrap(), &surface(), head_on, &one, 40_000);
        let (t, _) = albedo(&p.material("both").unwrap(), &surface(), head_on, &one, 40_000);
        let what = format!("{distribution} alpha {alpha}");
        assert!((d / diffuse - 1.0).abs() < 0.01, "{what}: the base reflects {d}, Mitsuba's {diffuse}");
        assert!((t / total - 1.0).abs() < 0.01, "{what}: the albedo is {t}, Mitsuba's {total}");
    }
}

#[test]
fn rough_plastic_samples_its_pdf_at_several_roughnesses() {
    let p = compile(
        "material smooth = rough_plastic(alpha: 0.05, diffuse_reflectance: rgb(0.8, 0.3, 0.1));
         material medium = rough_plastic(alpha: 0.15, distribution: \"ggx\", nonlinear: true);
         material rough = rough_plastic(alpha: 0.6, diffuse_reflectance: gray(0.9), int_ior: 1.8);",
    );
    let mut seed = 3000;
    for name in ["smooth", "medium", "rough"] {
        for (t, ph) in VIEWS {
            seed += 1;
            assert_sampling(&p, name, &surface(), direction(t, ph), 1.0, seed);
        }
    }
}

#[test]
fn rough_plastic_never_reflects_more_than_it_receives() {
    // A white base: what the coat does not reflect, the base returns,
    // less what single scattering at the rough interface loses.
    for distribution in ["beckmann", "ggx"] {
        for alpha in [0.001, 0.1, 0.4, 1.0] {
            for nonlinear in [false, true] {
                let p = compile(&format!(
                    "material white = rough_plastic(alpha: {alpha}, distribution: \"{distribution}\", \
                         diffuse_reflectance: gray(1), nonlinear: {nonlinear});"
                ));
                for theta in [0.0, 45.0, 80.0, 89.0] {
                    let (r, _) = albedo(
                        &p.material("white").unwrap(),
                        &surface(),
                        direction(theta, 0.0),
                        &p.rgb(1.0, 1.0, 1.0),
                        20_000,
                    );
                    assert!(r <= 1.01, "{distribution} alpha {alpha} at {theta} degrees reflects {r}");
                }
            }
        }
    }
}

#[test]
fn conductor_fresnel_matches_the_exact_formula() {
    // fresnel_conductor against the textbook form with complex arithmetic.
    let p = compile(
        "color f(float cos_i) { return fresnel_conductor(cos_i, rgb(0.2, 0.9, 1.1), rgb(3.9, 2.4, 2.1)); }
        color none(float cos_i) { return fresnel_conductor(cos_i, gray(0), gray(1)); }",
    );
    let exact = |cos_i: f64, eta: f64, k: f64| {
        // r_s and r_p of n = eta + i k from vacuum.
        let sin2 = 1.0 - cos_i * cos_i;
        let (n2r, n2i) = (eta * eta - k * k, 2.0 * eta * k);
        // cos_t n = sqrt(n^2 - sin^2): complex square root.
        let (ar, ai) = (n2r - sin2, n2i);
        let m = (ar * ar + ai * ai).sqrt();
        let (sr, si) = (((m + ar) / 2.0).sqrt(), ((m - ar) / 2.0).sqrt().copysign(ai));
        let abs2 = |re: f64, im: f64| re * re + im * im;
        let rs = abs2(cos_i - sr, -si) / abs2(cos_i + sr, si);
        // r_p = (n^2 cos_i - s) / (n^2 cos_i + s), s = sqrt(n^2 - sin^2).
        let (pr, pi) = (n2r * cos_i, n2i * cos_i);
        let rp = abs2(pr - sr, pi - si) / abs2(pr + sr, pi + si);
        (rs + rp) / 2.0
    };
    let f = p.function("f").unwrap();
    let none = p.function("none").unwrap();
    for k in 0..=20 {
        let c = k as f32 / 20.0;
        let mut out = [0u32; 3];
        f.call_words(tsl::Backend::Jit, &ShadingGlobals::default(), &[c.to_bits()], &mut out).unwrap();
        for (lane, (eta, kk)) in [(0.2, 3.9), (0.9, 2.4), (1.1, 2.1)].into_iter().enumerate() {
            let got = f64::from(f32::from_bits(out[lane]));
            let want = exact(f64::from(c), eta, kk);
            assert!((got - want).abs() < 2e-4, "cos {c}, eta {eta} + {kk} i: {got} != {want}");
        }
        none.call_words(tsl::Backend::Jit, &ShadingGlobals::default(), &[c.to_bits()], &mut out).unwrap();
        assert!(out.iter().all(|w| f32::from_bits(*w) == 1.0), "eta 0, k 1 reflects exactly everything at cos {c}");
    }
}

/// Layers: `layer(top, base)` over stdlib and user materials, smooth and
/// rough tops, tops with and without `albedo`, and layers in mixtures.
const LAYERS: &str = "
    // A thin sheet that scatters diffusely both ways: a top whose samples
    // also go through the surface (they find the base's refraction).
    material translucent(color kr = gray(0.3), color kt = gray(0.4)) {
        color reflection(vector wi, color light, vector wo) {
            return light * kr * max(dot(faceforward(N, -wo), wi), 0) * INV_PI;
        }
        color refraction(vector wi, color light, color eta, vector wo) {
            return light * kt * max(-dot(faceforward(N, -wo), wi), 0) * INV_PI;
        }
        bsdf_sample sample(vector wo, color eta, float u1, vec2 u2) {
            normal n = faceforward(N, -wo);
            vector wi = u1 < 0.5 ? sample_cosine(n, u2) : sample_cosine(-n, u2);
            color f = u1 < 0.5 ? reflection(wi, gray(1), wo) : refraction(wi, gray(1), eta, wo);
            return weighted_sample(wi, f, pdf(wi, wo, eta));
        }
        float pdf(vector wi, vector wo, color eta) {
            return 0.5 * abs(dot(N, wi)) * INV_PI;
        }
        color albedo(vector wo) {
            return kr;
        }
        bool opaque() {
            return false;
        }
    }
    material l_rough = layer(coat(alpha: 0.2), lambert(kd: rgb(0.7, 0.4, 0.2)));
    material l_smooth = layer(coat, lambert(kd: gray(0.6)));
    material l_beckmann = layer(coat(alpha: 0.3, distribution: \"beckmann\"), phong(ns: 20));
    material l_translucent_top = layer(translucent, lambert);
    material l_glossy_top = layer(phong(kd: gray(0.1), ks: gray(0.3), ns: 60), lambert(kd: gray(0.5)));
    material l_over_mix = layer(coat(alpha: 0.1), mix(0.4, lambert, rough_conductor(alpha: 0.2)));
    material l_in_mix = mix(0.3, layer(coat(alpha: 0.05), lambert), phong(ns: 10));
    material l_nested = layer(coat(alpha: 0.4), layer(coat(alpha: 0.1, int_ior: 1.8), lambert(kd: gray(0.3))));
";

#[test]
fn layers_sample_their_pdf() {
    let p = compile(LAYERS);
    let mut seed = 3000;
    for (t, ph) in VIEWS {
        seed += 1;
        assert_sampling(&p, "l_rough", &surface(), direction(t, ph), 1.0, seed);
    }
    // One view each (a top without albedo estimates it from 64 samples a
    // call: `l_glossy_top` takes ten times as long as the others).
    let names = ["l_smooth", "l_beckmann", "l_over_mix", "l_in_mix", "l_nested", "l_translucent_top", "l_glossy_top"];
    for (k, name) in names.into_iter().enumerate() {
        let (t, ph) = [(20.0, 10.0), (55.0, 120.0), (70.0, 250.0)][k % 3];
        assert_sampling(&p, name, &surface(), direction(t, ph), 1.0, 3100 + k as u64);
    }
}

/// Fresnel reflectance of a smooth dielectric of relative index `eta`
/// (unpolarised, from outside), in f64.
fn fresnel(cos_i: f64, eta: f64) -> f64 {
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    (rs * rs + rp * rp) / 2.0
}

/// The closed form of a layer (MaterialX's albedo scaling): over a lambert
/// base of albedo `kd`, `R + (1 - E) kd`, R what the top reflects toward
/// `wo` and E its `albedo(wo)`. A smooth coat's E is R, its Fresnel term,
/// so over a white base it reflects all the light; a rough coat's E is
/// `1 - T`, T the interface's transmittance from rough_plastic's tables,
/// which also counts what single scattering loses, so `R + T <= 1`.
#[test]
fn a_coat_over_lambert_reflects_its_closed_form() {
    let p = compile(
        "material white_smooth = layer(coat, lambert(kd: gray(1)));
        material white_rough = layer(coat(alpha: 0.2), lambert(kd: gray(1)));
        material grey_rough = layer(coat(alpha: 0.3, distribution: \"beckmann\"), lambert(kd: gray(0.5)));
        material smooth_top = coat;
        material rough_top = coat(alpha: 0.2);
        material beckmann_top = coat(alpha: 0.3, distribution: \"beckmann\");",
    );
    let one = p.rgb(1.0, 1.0, 1.0);
    let g = surface();
    for t in [0.0f32, 45.0, 80.0] {
        let wo = direction(t, 40.0);
        let cos = f64::from(wo[2]);
        // The smooth coat's albedo is its Fresnel term.
        let e_smooth = f64::from(p.material("smooth_top").unwrap().albedo(&g, wo).brightness());
        let want = fresnel(cos, 1.5 / 1.000277);
        assert!((e_smooth - want).abs() < 1e-4, "smooth coat at {t} degrees: albedo {e_smooth}, Fresnel {want}");
        // The rough coat's albedo (its tables) is what its reflection
        // integrates to, and what single scattering loses.
        for (top, layer, kd) in [("rough_top", "white_rough", 1.0), ("beckmann_top", "grey_rough", 0.5)] {
            let e = f64::from(p.material(top).unwrap().albedo(&g, wo).brightness());
            let (reflected, _) = albedo(&p.material(top).unwrap(), &g, wo, &one, 20_000);
            let lost = e - reflected;
            // Single scattering loses up to 9% at 80 degrees (GGX, alpha 0.2).
            assert!((-0.005..0.12).contains(&lost), "`{top}` at {t} degrees: 1 - T = {e}, R = {reflected}");
            let want = reflected + (1.0 - e) * kd;
            let (got, _) = albedo(&p.material(layer).unwrap(), &g, wo, &one, 20_000);
            assert!((got - want).abs() < 0.01, "`{layer}` at {t} degrees reflects {got}; R + (1 - E) kd = {want}");
            assert!(got <= 1.005, "`{layer}` at {t} degrees reflects {got}: more than it receives");
            // The node's own albedo method composes the same way.
            let own = f64::from(p.material(layer).unwrap().albedo(&g, wo).brightness());
            let composed = e + (1.0 - e) * kd;
            assert!((own - composed).abs() < 1e-5, "`{layer}`'s albedo(wo) {own} vs E + (1 - E) kd = {composed}");
        }
        // Smooth: the delta reflection and the base through the coat.
        let (got, _) = albedo(&p.material("white_smooth").unwrap(), &g, wo, &one, 20_000);
        assert!((got - 1.0).abs() < 0.01 && got <= 1.005, "`white_smooth` at {t} degrees reflects {got}, not 1");
    }
}

#[test]
fn a_layer_under_a_top_that_reflects_nothing_is_its_base() {
    let p = compile(
        "material base = phong(kd: rgb(0.5, 0.3, 0.2), ks: gray(0.4), ns: 25);
        material clear = layer(coat(specular_reflectance: black()), base);
        material black_top = layer(lambert(kd: black()), base);",
    );
    let g = surface();
    let eta = p.rgb(1.0, 1.0, 1.0);
    let light = p.rgb(0.9, 0.7, 0.4);
    let base = p.material("base").unwrap();
    let mut rng = Rng(5);
    for name in ["clear", "black_top"] {
        let m = p.material(name).unwrap();
        for _ in 0..200 {
            let (wo, wi) = (rng.unit(), rng.unit());
            let wo = [wo[0], wo[1], wo[2].abs()];
            assert_eq!(m.reflection(&g, wi, &light, wo), base.reflection(&g, wi, &light, wo), "`{name}`");
            assert_eq!(m.pdf(&g, wi, wo, &eta), base.pdf(&g, wi, wo, &eta), "`{name}`");
            let (uc, u) = (rng.range(0.0, 1.0), [rng.range(0.0, 1.0), rng.range(0.0, 1.0)]);
            let (s, want) = (m.sample(&g, wo, &eta, uc, u), base.sample(&g, wo, &eta, uc, u));
            assert_eq!((s.wi, s.pdf, s.delta), (want.wi, want.pdf, want.delta), "`{name}`");
            for (a, b) in s.weight.lanes().iter().zip(want.weight.lanes()) {
                assert!((a - b).abs() <= 1e-6 * b.abs().max(1.0), "`{name}`: weight {a} vs the base's {b}");
            }
        }
    }
}

/// A top without `albedo` is estimated from its own sampling: a user's
/// lambert (its every sample weighs kd) exactly, a phong within 5% of a
/// long Monte Carlo integral (64 points against 100,000).
#[test]
fn the_default_albedo_integrates_the_materials_own_sampling() {
    let p = compile(
        "material own_lambert(color kd = gray(0.5)) {
            color reflection(vector wi, color light, vector wo) {
                return light * kd * max(dot(faceforward(N, -wo), wi), 0) * INV_PI;
            }
            bsdf_sample sample(vector wo, color eta, float u1, vec2 u2) {
                normal n = faceforward(N, -wo);
                vector wi = sample_cosine(n, u2);
                return bsdf_sample(wi, kd, cosine_pdf(n, wi));
            }
            float pdf(vector wi, vector wo, color eta) {
                return cosine_pdf(faceforward(N, -wo), wi);
            }
        }
        material user = own_lambert(kd: rgb(0.2, 0.4, 0.6));
        material glossy = phong(kd: gray(0.2), ks: gray(0.5), ns: 20);",
    );
    let g = surface();
    let one = p.rgb(1.0, 1.0, 1.0);
    for (t, ph) in VIEWS {
        let wo = direction(t, ph);
        let e = p.material("user").unwrap().albedo(&g, wo);
        for (got, want) in e.lanes().iter().zip([0.2f32, 0.4, 0.6]) {
            assert!((got - want).abs() < 1e-6, "the user lambert's albedo {got}, its kd {want}");
        }
        let glossy = p.material("glossy").unwrap();
        let estimate = f64::from(glossy.albedo(&g, wo).brightness());
        let (integrated, _) = albedo(&glossy, &g, wo, &one, 100_000);
        assert!(
            (estimate - integrated).abs() < 0.05 * integrated.max(0.1),
            "phong at {t} degrees: default albedo {estimate}, integral {integrated}"
        );
    }
}

/// OpenPBR Surface at parameters covering each of its lobes (metal, the
/// dielectric's specular over diffuse, anisotropy, a rough and a smooth
/// coat, F0 scaled by specular_weight).
const OPEN_PBR: &str = "
    material plastic_like = open_pbr_surface(base_color: rgb(0.7, 0.2, 0.1));
    material brushed = open_pbr_surface(base_metalness: 1, base_color: rgb(0.9, 0.6, 0.3), \
        specular_roughness: 0.4, specular_roughness_anisotropy: 0.7, specular_color: rgb(0.8, 0.9, 1));
    material half_metal = open_pbr_surface(base_metalness: 0.5, specular_roughness: 0.15, specular_weight: 0.6);
    material coated = open_pbr_surface(base_color: rgb(0.2, 0.5, 0.8), coat_weight: 1, coat_roughness: 0.2, \
        coat_color: rgb(0.9, 0.8, 0.7));
    material glossy_coat = open_pbr_surface(base_metalness: 1, specular_roughness: 0.6, coat_weight: 0.7, \
        coat_roughness: 0.2, coat_ior: 1.4);
    material velvet = open_pbr_surface(base_color: rgb(0.3, 0.05, 0.1), fuzz_weight: 1, fuzz_color: rgb(1, 0.6, 0.7), \
        fuzz_roughness: 0.3, coat_weight: 0.5, coat_roughness: 0.3);
    material iridescent = open_pbr_surface(base_color: rgb(0.1, 0.1, 0.2), base_metalness: 0.4, \
        specular_roughness: 0.3, thin_film_weight: 0.8, thin_film_thickness: 0.4);
    material brushed_coat = open_pbr_surface(base_color: rgb(0.6, 0.3, 0.1), coat_weight: 0.8, coat_roughness: 0.4, \
        coat_roughness_anisotropy: 0.8, specular_roughness: 0.5);
";

#[test]
fn open_pbr_surface_samples_its_pdf() {
    let p = compile(OPEN_PBR);
    let mut seed = 4000;
    for name in
        ["plastic_like", "brushed", "half_metal", "coated", "glossy_coat", "velvet", "iridescent", "brushed_coat"]
    {
        for (t, ph) in VIEWS {
            seed += 1;
            assert_sampling(&p, name, &surface(), direction(t, ph), 1.0, seed);
        }
    }
}

#[test]
fn open_pbr_surface_never_reflects_more_than_it_receives() {
    // A white base, every lobe at full strength: each layer passes on only
    // what the one above lets through.
    let mut src = String::new();
    let mut names = Vec::new();
    for metalness in [0.0, 0.5, 1.0] {
        for roughness in [0.0, 0.3, 0.8] {
            for (coat, coat_roughness) in [(0.0, 0.0), (1.0, 0.0), (1.0, 0.5)] {
                let name = format!("m{}", names.len());
                src += &format!(
                    "material {name} = open_pbr_surface(base_color: gray(1), base_metalness: {metalness}, \
                         specular_roughness: {roughness}, coat_weight: {coat}, coat_roughness: {coat_roughness}, \
                         specular_ior: 1.8);\n"
                );
                names.push((
                    name,
                    format!("metalness {metalness} roughness {roughness} coat {coat} ({coat_roughness})"),
                ));
            }
        }
    }
    let p = compile(&src);
    let one = p.rgb(1.0, 1.0, 1.0);
    for (name, what) in &names {
        let m = p.material(name).unwrap();
        for theta in [0.0, 45.0, 80.0] {
            let (r, _) = albedo(&m, &surface(), direction(theta, 30.0), &one, 20_000);
            assert!(r <= 1.01, "{what} at {theta} degrees reflects {r}");
            assert!(r >= 0.5, "{what} at {theta} degrees reflects only {r}");
        }
    }
}

#[test]
fn open_pbr_surface_keeps_all_the_light_where_nothing_is_lost() {
    // A white mirror-like metal (F82 with both colors white is 1) and a
    // white base with no specular reflect everything at every angle.
    let p = compile(
        "material white_metal = open_pbr_surface(base_color: gray(1), base_metalness: 1, specular_roughness: 0);
         material white_diffuse = open_pbr_surface(base_color: gray(1), specular_weight: 0);",
    );
    let one = p.rgb(1.0, 1.0, 1.0);
    for (t, ph) in VIEWS {
        for name in ["white_metal", "white_diffuse"] {
            let (r, _) = albedo(&p.material(name).unwrap(), &surface(), direction(t, ph), &one, 20_000);
            assert!((r - 1.0).abs() < 0.005, "`{name}` at {t} degrees reflects {r}, not 1");
        }
    }
}

/// The largest relative difference of `f · cos` between materials `a` and
/// `b` of `p` over a spread of directions.
fn largest_difference(p: &Program, a: &str, b: &str) -> f32 {
    let (ma, mb) = (p.material(a).unwrap(), p.material(b).unwrap());
    let one = p.rgb(1.0, 1.0, 1.0);
    let mut worst = 0.0f32;
    for (to, po) in VIEWS {
        for ti in [5.0, 30.0, 50.0, 70.0, 85.0] {
            for pi in [0.0, 100.0, 170.0, 215.0, 300.0] {
                let (wi, wo) = (direction(ti, pi), direction(to, po));
                let (fa, fb) = (eval(&ma, &surface(), wi, wo, &one), eval(&mb, &surface(), wi, wo, &one));
                for (x, y) in fa.lanes().iter().zip(fb.lanes()) {
                    worst = worst.max((x - y).abs() / x.abs().max(y.abs()).max(1e-3));
                }
            }
        }
    }
    worst
}

#[test]
fn open_pbr_surface_limits_are_the_stdlibs_materials() {
    let p = compile(
        "material white_metal = open_pbr_surface(base_color: gray(1), base_metalness: 1, specular_roughness: 0.5, \
             specular_roughness_anisotropy: 0.6);
         material conductor_none = rough_conductor(alpha_u: 0.32827, alpha_v: 0.13131, distribution: \"ggx\");
         material base_only = open_pbr_surface(base_color: rgb(0.7, 0.4, 0.2), specular_weight: 0);
         material lambertian = lambert(kd: rgb(0.7, 0.4, 0.2));",
    );
    // The specification's anisotropy: alpha_t = r^2 sqrt(2 / (1 + (1 - a)^2)), alpha_b = (1 - a) alpha_t.
    let d = largest_difference(&p, "white_metal", "conductor_none");
    assert!(d < 2e-3, "a white metal differs from rough_conductor reflecting everything by {d}");
    let d = largest_difference(&p, "base_only", "lambertian");
    assert!(d < 1e-4, "the base alone differs from lambert by {d}");
}

#[test]
fn open_pbr_colored_metals_stay_near_the_complex_fresnel() {
    // F82-tint Fresnel with a white tint (Schlick's) against a conductor of
    // the same reflectivity at normal incidence (eta (1 - r) / (1 + r) and
    // its k, Gulbrandsen's mapping at edge tint 1): the same head-on
    // (0.676 / 0.678 for this gold-like color), darker toward grazing
    // angles (0.655 / 0.721 at 60 degrees, 0.650 / 0.731 at 80): the
    // difference the stdlib's doc states.
    let r = [0.95f64, 0.64, 0.54];
    let eta: Vec<f64> = r.iter().map(|r| (1.0 - r) / (1.0 + r)).collect();
    let k: Vec<f64> =
        r.iter().zip(&eta).map(|(r, n)| ((r * (n + 1.0).powi(2) - (n - 1.0).powi(2)) / (1.0 - r)).sqrt()).collect();
    let p = compile(&format!(
        "material gold_like = open_pbr_surface(base_color: rgb({}, {}, {}), base_metalness: 1, specular_roughness: 0.4);
         material gold_complex = rough_conductor(alpha: 0.16, distribution: \"ggx\", \
             eta: rgb({}, {}, {}), k: rgb({}, {}, {}));",
        r[0], r[1], r[2], eta[0], eta[1], eta[2], k[0], k[1], k[2]
    ));
    let one = p.rgb(1.0, 1.0, 1.0);
    let (a, b) = (p.material("gold_like").unwrap(), p.material("gold_complex").unwrap());
    for theta in [0.0, 60.0, 80.0] {
        let (x, _) = albedo(&a, &surface(), direction(theta, 0.0), &one, 20_000);
        let (y, _) = albedo(&b, &surface(), direction(theta, 0.0), &one, 20_000);
        let what = format!("at {theta} degrees F82 reflects {x}, the complex index {y}");
        if theta == 0.0 {
            assert!((x / y - 1.0).abs() < 0.005, "{what}");
        } else {
            assert!(x < y && x / y > 0.85, "{what}");
        }
    }
}

/// With coat_darkening 0 the coat is plain albedo scaling: a `layer` of `coat`.
#[test]
fn an_open_pbr_coat_over_a_diffuse_base_is_a_layer_of_coat_over_lambert() {
    let p = compile(
        "material coated = open_pbr_surface(base_color: rgb(0.6, 0.3, 0.2), specular_weight: 0, coat_weight: 1, \
             coat_darkening: 0);
         material layered = layer(coat(int_ior: 1.6, ext_ior: 1), lambert(kd: rgb(0.6, 0.3, 0.2)));
         material half = open_pbr_surface(base_color: rgb(0.6, 0.3, 0.2), specular_weight: 0, coat_weight: 0.5, \
             coat_darkening: 0);
         material half_layered = mix(0.5, lambert(kd: rgb(0.6, 0.3, 0.2)), \
             layer(coat(int_ior: 1.6, ext_ior: 1), lambert(kd: rgb(0.6, 0.3, 0.2))));",
    );
    let one = p.rgb(1.0, 1.0, 1.0);
    for (a, b) in [("coated", "layered"), ("half", "half_layered")] {
        for theta in [0.0, 45.0, 75.0] {
            let (x, _) = albedo(&p.material(a).unwrap(), &surface(), direction(theta, 0.0), &one, 20_000);
            let (y, _) = albedo(&p.material(b).unwrap(), &surface(), direction(theta, 0.0), &one, 20_000);
            assert!((x / y - 1.0).abs() < 0.01, "`{a}` at {theta} degrees reflects {x}, `{b}` {y}");
        }
    }
}

#[test]
fn open_pbr_fuzz_is_a_sheen_toward_grazing_angles() {
    // On a black base the fuzz alone reflects: little head-on, more toward
    // grazing angles, and no more than its albedo lets it.
    let p = compile("material velvet = open_pbr_surface(base_color: gray(0), specular_weight: 0, fuzz_weight: 1);");
    let one = p.rgb(1.0, 1.0, 1.0);
    let m = p.material("velvet").unwrap();
    let at = |theta: f32| albedo(&m, &surface(), direction(theta, 0.0), &one, 20_000).0;
    let (head_on, grazing) = (at(0.0), at(80.0));
    assert!(head_on > 0.0 && grazing > 1.5 * head_on, "fuzz reflects {head_on} head-on, {grazing} at 80 degrees");
    assert!(grazing < 1.0, "fuzz reflects {grazing} at 80 degrees");
}

/// OpenPBR Surface with a translucent base: fully (rough glass), partly
/// under a tinted rough coat and a fuzz, and half metal.
const OPEN_PBR_TRANSLUCENT: &str = "
    material glassy = open_pbr_surface(transmission_weight: 1, specular_roughness: 0.5);
    material frosted_coated = open_pbr_surface(transmission_weight: 0.6, transmission_color: rgb(0.9, 0.5, 0.3), \
        base_color: rgb(0.2, 0.5, 0.8), specular_roughness: 0.4, specular_roughness_anisotropy: 0.5, \
        coat_weight: 1, coat_roughness: 0.3, coat_color: rgb(0.9, 0.9, 0.8), fuzz_weight: 0.5);
    material half_metal_glass = open_pbr_surface(transmission_weight: 1, base_metalness: 0.5, \
        specular_roughness: 0.4, specular_weight: 0.7);
    material iridescent_glass = open_pbr_surface(transmission_weight: 1, specular_roughness: 0.5, \
        thin_film_weight: 1, thin_film_thickness: 0.3, thin_film_ior: 1.8);
    material deep_glass = open_pbr_surface(transmission_weight: 0.8, transmission_color: rgb(0.2, 0.5, 0.9), \
        transmission_depth: 0.5, specular_roughness: 0.5, base_color: rgb(0.5, 0.4, 0.3));
    material thin_glass = open_pbr_surface(transmission_weight: 0.7, geometry_thin_walled: true, \
        specular_roughness: 0.5, transmission_color: rgb(0.8, 0.6, 0.4), coat_weight: 0.5, coat_roughness: 0.3, \
        base_color: rgb(0.5, 0.4, 0.3));
    material thin_leaf = open_pbr_surface(transmission_weight: 0.3, geometry_thin_walled: true, \
        specular_roughness: 0.5, subsurface_weight: 0.7, subsurface_color: rgb(0.3, 0.8, 0.2), base_color: gray(0.4), \
        fuzz_weight: 0.3);
";

#[test]
fn open_pbr_transmission_samples_its_pdf() {
    let p = compile(OPEN_PBR_TRANSLUCENT);
    let mut seed = 4100;
    // A thin wall ignores the index beyond it (it bends nothing): from the
    // back at 1 / 1.5 it is seen from its other side.
    for name in
        ["glassy", "frosted_coated", "half_metal_glass", "iridescent_glass", "deep_glass", "thin_glass", "thin_leaf"]
    {
        // From outside (index 1.5 beyond the surface) and from inside.
        for eta in [1.5, 1.0 / 1.5] {
            for (t, ph) in VIEWS {
                seed += 1;
                assert_sampling(&p, name, &facing(eta), direction(t, ph), eta, seed);
            }
        }
    }
}

#[test]
fn open_pbr_transmission_never_creates_energy() {
    let p = compile(OPEN_PBR_TRANSLUCENT);
    for (t, ph) in VIEWS {
        let wo = direction(t, ph);
        for eta in [1.5f32, 1.0 / 1.5] {
            let eta_c = p.rgb(eta, eta, eta);
            for name in ["glassy", "frosted_coated", "half_metal_glass", "iridescent_glass", "deep_glass"] {
                let (r, tr) = albedo(&p.material(name).unwrap(), &facing(eta), wo, &eta_c, 20_000);
                assert!(r + tr <= 1.01, "`{name}` (eta {eta}) at {t} degrees: {r} + {tr} > 1");
            }
            // Rough glass keeps most of it: single scattering loses more
            // toward grazing angles (0.78 at 75 degrees from inside), as
            // rough_dielectric's does.
            let (r, tr) = albedo(&p.material("glassy").unwrap(), &facing(eta), wo, &eta_c, 20_000);
            assert!(r + tr >= 0.7, "`glassy` (eta {eta}) at {t} degrees keeps only {r} + {tr}");
        }
    }
}

/// A fully translucent open_pbr_surface is rough_dielectric (GGX, alpha the
/// roughness squared): the same reflection, refraction and pdf from both
/// sides, noise-free through the Material API.
#[test]
fn open_pbr_transmission_is_rough_dielectric() {
    let p = compile(
        "material translucent = open_pbr_surface(transmission_weight: 1, specular_roughness: 0.5, \
             specular_roughness_anisotropy: 0.6);
         material dielectric = rough_dielectric(int_ior: 1.5, ext_ior: 1, alpha_u: 0.32827, alpha_v: 0.13131, \
             distribution: \"ggx\");",
    );
    let (a, b) = (p.material("translucent").unwrap(), p.material("dielectric").unwrap());
    let mut worst = 0.0f32;
    for eta in [1.5f32, 1.0 / 1.5] {
        let (g, eta_c) = (facing(eta), p.rgb(eta, eta, eta));
        assert_eq!(a.refraction_index(&g).lanes(), b.refraction_index(&g).lanes());
        for (to, po) in VIEWS {
            let wo = direction(to, po);
            for ti in [5.0, 30.0, 50.0, 70.0, 85.0, 95.0, 120.0, 150.0, 175.0] {
                for pi in [0.0, 100.0, 170.0, 215.0, 300.0] {
                    let wi = direction(ti, pi);
                    let (fa, fb) = (eval(&a, &g, wi, wo, &eta_c), eval(&b, &g, wi, wo, &eta_c));
                    let (pa, pb) = (a.pdf(&g, wi, wo, &eta_c), b.pdf(&g, wi, wo, &eta_c));
                    for (x, y) in fa.lanes().iter().zip(fb.lanes()).chain([(&pa, &pb)]) {
                        worst = worst.max((x - y).abs() / x.abs().max(y.abs()).max(1e-3));
                    }
                }
            }
        }
    }
    assert!(worst < 2e-3, "a translucent open_pbr_surface differs from rough_dielectric by {worst}");
}

/// The coat darkens a diffuse base as Mitsuba's roughplastic with
/// `nonlinear` (the coat's rough transmittance both ways, the light it
/// reflects back inside reflected again by the base): the same albedo per
/// channel at every angle (a red base: 0.487 / 0.180 / 0.127 head-on,
/// where coat_darkening 0's albedo scaling gives 0.711 / 0.327 / 0.231),
/// and no darkening for a white base beyond the coat's transmission.
#[test]
fn an_open_pbr_coat_darkens_its_base_as_rough_plastic_nonlinear() {
    let p = compile(
        "material coated = open_pbr_surface(base_color: rgb(0.7, 0.3, 0.2), specular_weight: 0, coat_weight: 1, \
             coat_roughness: 0.3162278, coat_ior: 1.49);
         material plastic = rough_plastic(diffuse_reflectance: rgb(0.7, 0.3, 0.2), alpha: 0.1, distribution: \"ggx\", \
             int_ior: 1.49, ext_ior: 1, nonlinear: true);
         material undarkened = open_pbr_surface(base_color: rgb(0.7, 0.3, 0.2), specular_weight: 0, coat_weight: 1, \
             coat_roughness: 0.3162278, coat_ior: 1.49, coat_darkening: 0);",
    );
    let one = p.rgb(1.0, 1.0, 1.0);
    let channels = |name: &str, theta: f32| {
        let m = p.material(name).unwrap();
        let (mut sum, mut rng, n) = ([0.0f64; 3], Rng(7), 50_000);
        for _ in 0..n {
            let (uc, u) = (rng.range(0.0, 1.0), [rng.range(0.0, 1.0), rng.range(0.0, 1.0)]);
            let s = m.sample(&surface(), direction(theta, 0.0), &one, uc, u);
            for (a, w) in sum.iter_mut().zip(s.weight.lanes()) {
                *a += f64::from(*w) / f64::from(n);
            }
        }
        sum
    };
    for theta in [0.0, 45.0, 80.0] {
        let (a, b, c) = (channels("coated", theta), channels("plastic", theta), channels("undarkened", theta));
        for k in 0..3 {
            assert!(
                (a[k] / b[k] - 1.0).abs() < 0.005,
                "at {theta} degrees channel {k}: coated {a:?}, rough_plastic {b:?}"
            );
            assert!(a[k] < 0.9 * c[k], "at {theta} degrees channel {k}: darkened {a:?}, undarkened {c:?}");
        }
    }
}

/// A `standard_surface` roughness of 0 is a sharp lobe: the squared
/// roughness is floored at 1e-4, as every stdlib microfacet alpha is (it
/// went through `rough_alpha`, whose 0 means "use the fallback", and the
/// fallback was 1: a fully rough lobe).
#[test]
fn a_standard_surface_roughness_of_zero_is_sharp() {
    let p = compile(
        "material sharp = standard_surface(base_color: gray(0.9), metalness: 1, specular_roughness: 0);
        material rough = standard_surface(base_color: gray(0.9), metalness: 1, specular_roughness: 1);
        material sharp_coat = standard_surface(base_color: black(), coat: 1, coat_roughness: 0, specular: 0);
        material rough_coat = standard_surface(base_color: black(), coat: 1, coat_roughness: 1, specular: 0);",
    );
    let g = surface();
    let light = p.rgb(1.0, 1.0, 1.0);
    let wo = direction(30.0, 0.0);
    // 20 degrees off the mirror direction.
    let wi = direction(50.0, 180.0);
    let at = |name: &str| p.material(name).unwrap().reflection(&g, wi, &light, wo).lanes()[0];
    for (sharp, rough) in [("sharp", "rough"), ("sharp_coat", "rough_coat")] {
        let (s, r) = (at(sharp), at(rough));
        assert!(r > 1e-3 && s < 1e-6 * r.max(1.0), "`{sharp}` {s} against `{rough}` {r} off the mirror direction");
    }
}
