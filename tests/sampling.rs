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
    let mut rng = Rng(seed);
    let mut weight_error = 0.0f32;
    let mut pdf_error = 0.0f32;
    let chi2 = DirectionTest::new(16, 32).run(
        SAMPLES,
        || {
            let (uc, u) = (rng.range(0.0, 1.0), [rng.range(0.0, 1.0), rng.range(0.0, 1.0)]);
            let s = m.sample(g, wo, &eta, uc, u);
            if s.delta || s.pdf <= 0.0 || s.wi == [0.0; 3] {
                return None;
            }
            let pdf = m.pdf(g, s.wi, wo, &eta);
            pdf_error = pdf_error.max((pdf - s.pdf).abs() / s.pdf.max(pdf));
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
