//! The texturing library in `stdlib/`: CPG shapes and their transforms,
//! CSG solids, and the first paper's techniques, measured the way their
//! documentation promises (areas, volumes, ranges, energy).

use tsl::{Backend, ColorModel, Compiler, Program, ShadingGlobals};

mod common;
use common::Rng;

fn program(src: &str, model: ColorModel) -> Program {
    Compiler::new().color_model(model).source("t.tsl", src).compile().unwrap_or_else(|e| panic!("{e}"))
}

/// Calls a float function at `g` on both back ends; they must agree.
fn value(p: &Program, name: &str, g: &ShadingGlobals) -> f32 {
    let f = p.function(name).unwrap_or_else(|| panic!("no {name}"));
    let (mut a, mut b) = ([0u32; 1], [0u32; 1]);
    f.call_words(Backend::Jit, g, &[], &mut a).unwrap();
    f.call_words(Backend::Interpreter, g, &[], &mut b).unwrap();
    assert_eq!(a, b, "{name} at {g:?}");
    f32::from_bits(a[0])
}

/// The area of `name`'s inside over [0, 1]^2 in (u, v), by a midpoint grid.
fn area(p: &Program, name: &str) -> f64 {
    let n = 200;
    let mut sum = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            let g =
                ShadingGlobals { u: (i as f32 + 0.5) / n as f32, v: (j as f32 + 0.5) / n as f32, ..Default::default() };
            sum += f64::from(value(p, name, &g));
        }
    }
    sum / (n * n) as f64
}

const SHAPES: &str = r#"
    float circle() { return cpg_circle((0.5, 0.5), 0.3); }
    float square() { return cpg_square((0.5, 0.5), 0.2); }
    float triangle() { return cpg_triangle((0.1, 0.1), (0.9, 0.1), (0.1, 0.9)); }
    // An L: the unit square minus its top-right quarter (concave).
    float ell() { return cpg_polygon([(0.1, 0.1), (0.9, 0.1), (0.9, 0.5), (0.5, 0.5), (0.5, 0.9), (0.1, 0.9), (0, 0), (0, 0)], 6); }
    float hexagon() { return cpg_ngon((0.5, 0.5), 0.4, 6, 10); }
    // A square whose bottom edge bulges down: control point 0.4 below its middle.
    float bulged() {
        return cpg_bezier([(0.2, 0.5), (0.5, 0.1), (0.8, 0.5), (0.8, 0.65), (0.8, 0.8), (0.5, 0.8), (0.2, 0.8), (0.2, 0.65),
                           (0, 0), (0, 0), (0, 0), (0, 0), (0, 0), (0, 0), (0, 0), (0, 0)], 4);
    }
    float rotated() { return cpg_square((0.5, 0.5), 0.2, cpg_rotate((u, v), 45)); }
    float moved() { return cpg_circle((0.5, 0.5), 0.1, cpg_translate((u, v), (0.3, 0))); }
    float scaled() { return cpg_square((0.5, 0.5), 0.1, cpg_scale((u, v), (2, 1.5))); }
    float matrixed() { return cpg_circle((0.5, 0.5), 0.1, cpg_transform((u, v), translate((0.2, 0.1, 0)))); }
    float ring() { return cpg_difference(cpg_circle((0.5, 0.5), 0.4), cpg_circle((0.5, 0.5), 0.2)); }
    float both() { return cpg_intersect(cpg_square((0.4, 0.5), 0.2), cpg_square((0.6, 0.5), 0.2)); }
    float either() { return cpg_union(cpg_square((0.3, 0.5), 0.1), cpg_square((0.7, 0.5), 0.1)); }
"#;

#[test]
fn cpg_shapes_have_their_areas() {
    let p = program(SHAPES, ColorModel::Rgb);
    let pi = std::f64::consts::PI;
    let cases: &[(&str, f64)] = &[
        ("circle", pi * 0.09),
        ("square", 0.16),
        ("triangle", 0.32),
        ("ell", 0.64 - 0.16),
        ("hexagon", 3.0 * 3f64.sqrt() / 2.0 * 0.16),
        // The square 0.6 x 0.3 plus the parabolic segment under the chord,
        // 2/3 of the triangle (0.2, 0.5), (0.5, 0.1), (0.8, 0.5).
        ("bulged", 0.18 + 2.0 / 3.0 * 0.12),
        ("rotated", 0.16),
        ("moved", pi * 0.01),
        ("scaled", 0.04 * 3.0),
        ("matrixed", pi * 0.01),
        ("ring", pi * (0.16 - 0.04)),
        ("both", 0.2 * 0.4),
        ("either", 0.08),
    ];
    for (name, want) in cases {
        let got = area(&p, name);
        assert!((got - want).abs() < 0.004, "{name}: area {got}, expected {want}");
    }
}

#[test]
fn cpg_transforms_move_shapes_where_they_say() {
    let p = program(SHAPES, ColorModel::Rgb);
    let at = |u: f32, v: f32| ShadingGlobals { u, v, ..Default::default() };
    // translate by (0.3, 0): the circle is now around (0.8, 0.5).
    assert_eq!(value(&p, "moved", &at(0.8, 0.5)), 1.0);
    assert_eq!(value(&p, "moved", &at(0.5, 0.5)), 0.0);
    // A square turned 45 degrees reaches further along the diagonals' axes.
    assert_eq!(value(&p, "rotated", &at(0.5 + 0.27, 0.5)), 1.0);
    assert_eq!(value(&p, "rotated", &at(0.5 + 0.19, 0.5 + 0.19)), 0.0);
    // Scaled by 2 along u: half-width 0.2 now.
    assert_eq!(value(&p, "scaled", &at(0.68, 0.5)), 1.0);
    assert_eq!(value(&p, "scaled", &at(0.5, 0.68)), 0.0);
    assert_eq!(value(&p, "matrixed", &at(0.7, 0.6)), 1.0);
}

#[test]
fn cpg_edges_are_antialiased_by_the_footprint() {
    let p = program(SHAPES, ColorModel::Rgb);
    let edge = |fw: f32| ShadingGlobals { u: 0.8, v: 0.5, dudx: fw, dvdy: fw, ..Default::default() };
    // Exactly on the circle's edge: half covered with a footprint.
    assert!((value(&p, "circle", &edge(0.05)) - 0.5).abs() < 1e-5);
    for name in ["square", "triangle", "ell", "hexagon", "bulged"] {
        let mut rng = Rng(3);
        let mut partial = 0;
        for _ in 0..2000 {
            let g = ShadingGlobals {
                u: rng.range(0.0, 1.0),
                v: rng.range(0.0, 1.0),
                dudx: 0.02,
                dvdy: 0.02,
                ..Default::default()
            };
            let x = value(&p, name, &g);
            assert!((0.0..=1.0).contains(&x), "{name}: {x}");
            if x > 0.0 && x < 1.0 {
                partial += 1;
            }
            // Without a footprint the edge is sharp.
            let sharp = value(&p, name, &ShadingGlobals { dudx: 0.0, dvdy: 0.0, ..g });
            assert!(sharp == 0.0 || sharp == 1.0, "{name}: {sharp}");
        }
        assert!(partial > 20, "{name}: only {partial} points on a smoothed edge");
    }
}

#[test]
fn csg_solids_have_their_volumes() {
    let src = r#"
        float ball() { return csg_sphere((0, 0, 0), 0.8); }
        float cube() { return csg_box((-0.5, -0.5, -0.5), (0.5, 0.5, 0.5)); }
        float can() { return csg_cylinder((0, -0.5, 0), (0, 1, 0), 0.5); }
        float bitten() { return csg_difference(csg_box((-1, -1, -1), (1, 1, 1)), csg_sphere((1, 1, 1), 1)); }
        float lower() { return csg_halfspace((0, 0.25, 0), (0, 1, 0)); }
        float lens() { return csg_intersect(csg_sphere((-0.3, 0, 0), 0.6), csg_sphere((0.3, 0, 0), 0.6)); }
    "#;
    let p = program(src, ColorModel::Rgb);
    let pi = std::f64::consts::PI;
    // The lens: two caps of height h = r - d/2 = 0.3, each pi h^2 (3r - h) / 3.
    let cap = pi * 0.09 * (1.8 - 0.3) / 3.0;
    let cases: &[(&str, f64)] = &[
        ("ball", 4.0 / 3.0 * pi * 0.512),
        ("cube", 1.0),
        ("can", pi * 0.25),
        ("bitten", 1.0 * 8.0 - 4.0 / 3.0 * pi / 8.0),
        ("lower", 8.0 * 1.25 / 2.0),
        ("lens", 2.0 * cap),
    ];
    let mut rng = Rng(5);
    let n = 40_000;
    let pts: Vec<ShadingGlobals> = (0..n)
        .map(|_| {
            let pl = [rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)];
            ShadingGlobals { pl, ..Default::default() }
        })
        .collect();
    for (name, want) in cases {
        let inside: f64 = pts.iter().map(|g| f64::from(value(&p, name, g))).sum();
        let got = 8.0 * inside / n as f64;
        // Monte Carlo over 40,000 points: a few standard errors.
        assert!((got - want).abs() < 0.06, "{name}: volume {got}, expected {want}");
    }
}

#[test]
fn spectral_perturbation_stays_within_its_range() {
    let src = r#"
        color perturbed(float p) { return spectral_perturbation(RUST, RUST * 0.5, p); }
        color mean() { return RUST; }
    "#;
    for model in [ColorModel::Rgb, ColorModel::Spectral { samples: 16 }] {
        let p = program(src, model);
        let f = p.function("perturbed").unwrap();
        let lanes = model.lanes();
        let mut mean = vec![0u32; lanes];
        p.function("mean").unwrap().call_words(Backend::Jit, &ShadingGlobals::default(), &[], &mut mean).unwrap();
        let mean: Vec<f32> = mean.into_iter().map(f32::from_bits).collect();
        let mut hit_top = false;
        for k in 0..=40 {
            let x = -2.0 + 0.1 * k as f32;
            let mut out = vec![0u32; lanes];
            f.call_words(Backend::Jit, &ShadingGlobals::default(), &[x.to_bits()], &mut out).unwrap();
            for (c, m) in out.iter().map(|w| f32::from_bits(*w)).zip(&mean) {
                assert!(c >= 0.5 * m - 1e-6 && c <= 1.5 * m + 1e-6, "p = {x}: {c} outside [{}, {}]", 0.5 * m, 1.5 * m);
                hit_top |= (c - 1.5 * m).abs() < 1e-6 && *m > 0.0;
            }
        }
        assert!(hit_top, "the range is reached at p = 1");
    }
}

#[test]
fn microvariation_keeps_kd_plus_ks_below_one_and_sharpens_with_ks() {
    let src = r#"
        material worn(float p) = microvariation(p: p, base: gray(1));
        material m0 = worn(0);
        material m5 = worn(0.5);
        material m1 = worn(1);
    "#;
    let p = program(src, ColorModel::Rgb);
    let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ng: [0.0, 0.0, 1.0], ..Default::default() };
    // diffuse() is kd: it falls as ks rises; kd + ks = base = 1.
    let kd: Vec<f32> = ["m0", "m5", "m1"].iter().map(|m| p.material(m).unwrap().diffuse(&g).lanes()[0]).collect();
    assert!(kd[0] > kd[1] && kd[1] > kd[2], "{kd:?}");
    assert!((kd[0] - 0.98).abs() < 1e-5 && (kd[2] - 0.6).abs() < 1e-5, "{kd:?}");
    // The specular peak: higher and narrower as p grows.
    let wi = [0.6f32, 0.0, 0.8];
    let mirror = [-0.6f32, 0.0, 0.8];
    let off = [-0.5f32, 0.0, (1.0f32 - 0.25).sqrt()];
    let light = p.rgb(1.0, 1.0, 1.0);
    let peak = |m: &str, wo: [f32; 3]| p.material(m).unwrap().reflection(&g, wi, &light, wo).lanes()[0];
    assert!(peak("m1", mirror) > peak("m5", mirror) && peak("m5", mirror) > peak("m0", mirror));
    let sharpness = |m: &str| peak(m, mirror) / peak(m, off);
    assert!(sharpness("m1") > sharpness("m5") && sharpness("m5") > sharpness("m0"));
}

#[test]
fn rusted_steel_mixes_two_spectral_curves() {
    let src = r#"
        material steel = rusted_steel(rust: 0);
        material rust = rusted_steel(rust: 1);
        material half = rusted_steel(rust: 0.5);
    "#;
    let p = program(src, ColorModel::Spectral { samples: 16 });
    let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ng: [0.0, 0.0, 1.0], ..Default::default() };
    let d = |m: &str| p.material(m).unwrap().diffuse(&g).lanes().to_vec();
    // Rust is dark in the blue and bright in the red; steel's diffuse is black.
    let rust = d("rust");
    assert!(rust[0] < 0.1 && rust[15] > 0.25, "{rust:?}");
    assert!(d("steel").iter().all(|x| *x == 0.0));
    for (h, r) in d("half").iter().zip(&rust) {
        assert!((h - 0.5 * r).abs() < 1e-5);
    }
}

#[test]
fn planar_uv_tiles_in_world_units() {
    let src = r#"
        float s_of() { return planar_uv(0.5).x; }
        float t_of() { return planar_uv(0.5).y; }
        float s_wall() { return planar_uv(2, (0, 0, 1)).x; }
    "#;
    let p = program(src, ColorModel::Rgb);
    let g = ShadingGlobals { p: [1.25, 7.0, -0.75], ..Default::default() };
    // On the ground (axis +y): s along +x, t along -z, per half metre.
    assert!((value(&p, "s_of", &g) - 2.5).abs() < 1e-6);
    assert!((value(&p, "t_of", &g) - 1.5).abs() < 1e-6);
    // A wall facing +z: s along +x again.
    assert!((value(&p, "s_wall", &g) - 0.625).abs() < 1e-6);
}
