//! The renderer against analytic answers: furnace tests, inverse-square
//! point lights, the depth convention, energy conservation and reciprocity
//! of the stdlib materials, determinism across thread counts, and clear
//! errors for bad scenes.

mod common;

use tsl::render::{self, IntegratorKind, Overrides, RenderOptions, RenderedImage, Scene};
use tsl::{ColorModel, Compiler, ShadingGlobals};

fn scene_of(src: &str, model: ColorModel, overrides: &Overrides) -> Scene {
    let program =
        Compiler::new().color_model(model).source("test.tsl", src).compile().unwrap_or_else(|e| panic!("{e}"));
    Scene::build(&program, overrides).unwrap_or_else(|e| panic!("{e}"))
}

fn render_src(src: &str, model: ColorModel, overrides: &Overrides) -> RenderedImage {
    let scene = scene_of(src, model, overrides);
    render::render(&scene, &RenderOptions::default()).unwrap().0
}

fn mean(image: &RenderedImage) -> [f64; 3] {
    let mut sum = [0.0f64; 3];
    for p in &image.color {
        for c in 0..3 {
            sum[c] += f64::from(p[c]);
        }
    }
    sum.map(|s| s / image.color.len() as f64)
}

/// A camera inside a closed sphere whose inner surface emits `le` and
/// reflects diffusely with albedo `a`: every point sees
/// `le (1 - a^depth) / (1 - a)` with path depth `depth`.
fn furnace(depth: u32, model: ColorModel) -> f64 {
    let src = r#"
        scene {
            camera { from (0, 0, 0); to (0, 0, -1); fov 60; }
            render { width 8; height 8; spp 64; integrator "path"; }
            object sphere { center (0, 0, 0); radius 1; material emitter(radiance: gray(0.2), kd: gray(0.8), two_sided: true); }
        }
    "#;
    let image = render_src(src, model, &Overrides { max_depth: Some(depth), ..Default::default() });
    let m = mean(&image);
    (m[0] + m[1] + m[2]) / 3.0
}

#[test]
fn furnace_inside_an_emitting_sphere_matches_the_geometric_series() {
    for (depth, model) in [(1, ColorModel::Rgb), (2, ColorModel::Rgb), (3, ColorModel::Rgb), (40, ColorModel::Rgb)] {
        let expected = 0.2 * (1.0 - 0.8f64.powi(depth as i32)) / 0.2;
        let got = furnace(depth, model);
        let tolerance = if depth == 1 { 1e-5 } else { 0.02 * expected };
        assert!((got - expected).abs() <= tolerance, "depth {depth}: {got} vs {expected}");
    }
}

#[test]
fn furnace_in_spectral_mode_agrees() {
    let got = furnace(40, ColorModel::Spectral { samples: 16 });
    let expected = 1.0 - 0.8f64.powi(40);
    // Gray spectra convert back to gray within the color tests' tolerance.
    assert!((got - expected).abs() <= 0.03, "{got} vs {expected}");
}

#[test]
fn a_white_sphere_in_a_white_environment_disappears() {
    let src = r#"
        scene {
            background gray(1);
            camera { from (0, 0, 4); to (0, 0, 0); fov 30; }
            render { width 8; height 8; spp 32; max_depth 16; integrator "path"; }
            object sphere { center (0, 0, 0); radius 1; material lambert(kd: gray(1)); }
        }
    "#;
    // Found by material sampling alone (light sampling of the environment
    // adds noise, tests/environment.rs), one bounce off a convex object,
    // then the background: exactly 1 in expectation, and each sample
    // weight is 1 too.
    let mut scene = scene_of(src, ColorModel::Rgb, &Overrides::default());
    scene.settings.strategy = tsl::render::scene::Strategy::Material;
    let (image, stats) = render::render(&scene, &RenderOptions::default()).unwrap();
    assert_eq!(stats.rays.shadow_rays, 0);
    for p in &image.color {
        for c in p {
            assert!((c - 1.0).abs() < 1e-3, "{p:?}");
        }
    }
}

/// The mean of a sphere of `material` filling the frame in a white
/// environment, path-traced to `depth`.
fn sphere_in_white_furnace(material: &str, depth: u32) -> f64 {
    let src = format!(
        r#"
        scene {{
            background gray(1);
            camera {{ from (0, 0, 4); to (0, 0, 0); fov 18; }}
            render {{ width 12; height 12; spp 48; integrator "path"; }}
            object sphere {{ center (0, 0, 0); radius 1; material {material}; }}
        }}
    "#
    );
    let image = render_src(&src, ColorModel::Rgb, &Overrides { max_depth: Some(depth), ..Default::default() });
    let m = mean(&image);
    (m[0] + m[1] + m[2]) / 3.0
}

/// A lossless dielectric sphere in a white furnace: every path ends in the
/// background, so with depth enough the sphere vanishes (radiance 1), a
/// slightly rough one nearly so, and at every depth a nearly smooth rough
/// dielectric renders as the smooth one. A renderer that gave a
/// transmitting material without a perfect refraction direction the index
/// 1 (`rough_dielectric` rendered 58% too dark) fails each of these.
#[test]
fn transmitting_materials_keep_their_energy_in_a_white_furnace() {
    let smooth = "glass(ior: gray(1.5))";
    let rough = |alpha: f32, distribution: &str| {
        format!("rough_dielectric(int_ior: 1.5, ext_ior: 1, alpha: {alpha}, distribution: \"{distribution}\")")
    };
    for depth in [3, 8] {
        let (a, b) = (sphere_in_white_furnace(smooth, depth), sphere_in_white_furnace(&rough(0.01, "ggx"), depth));
        assert!((a - b).abs() <= 0.03 * a, "depth {depth}: glass {a} vs rough_dielectric at alpha 0.01 {b}");
    }
    let deep = 64;
    let glass = sphere_in_white_furnace(smooth, deep);
    assert!((glass - 1.0).abs() <= 0.02, "glass at depth {deep}: {glass}");
    for (alpha, distribution) in [(0.01, "ggx"), (0.2, "ggx"), (0.2, "beckmann")] {
        let m = sphere_in_white_furnace(&rough(alpha, distribution), deep);
        // Single-scattering microfacets lose a little energy as they roughen.
        assert!((0.9..=1.02).contains(&m), "rough_dielectric {alpha} {distribution} at depth {deep}: {m}");
    }
}

/// OpenPBR Surface's translucent base is a rough dielectric: in a white
/// furnace a fully translucent sphere renders as `rough_dielectric` of the
/// same alpha (roughness squared) at a shallow depth, and nearly vanishes
/// at a deep one; a partly translucent, coated one never creates energy.
#[test]
fn open_pbr_transmission_keeps_its_energy_in_a_white_furnace() {
    let open_pbr = |r: f32| format!("open_pbr_surface(transmission_weight: 1, specular_roughness: {r})");
    let rough =
        |alpha: f32| format!("rough_dielectric(int_ior: 1.5, ext_ior: 1, alpha: {alpha}, distribution: \"ggx\")");
    for depth in [3, 8] {
        let (a, b) = (sphere_in_white_furnace(&open_pbr(0.3), depth), sphere_in_white_furnace(&rough(0.09), depth));
        assert!((a - b).abs() <= 0.03 * b, "depth {depth}: open_pbr_surface {a} vs rough_dielectric {b}");
    }
    let deep = sphere_in_white_furnace(&open_pbr(0.1), 64);
    assert!((0.95..=1.02).contains(&deep), "a translucent open_pbr_surface at depth 64: {deep}");
    let partly = "open_pbr_surface(transmission_weight: 0.6, base_color: gray(1), coat_weight: 1, coat_roughness: 0.2)";
    let m = sphere_in_white_furnace(partly, 64);
    // From inside, light meeting the opaque part of the surface (0.4 of
    // it) is absorbed: 0.75 at this depth.
    assert!((0.6..=1.02).contains(&m), "a partly translucent coated open_pbr_surface at depth 64: {m}");
}

/// Light through an absorbing glass slab seen head-on keeps its Beer's-law
/// share: a ray refracted at normal incidence goes on straight, as through
/// a hole, but it entered the glass all the same (it was once taken for a
/// straight pass, within 2.4 degrees of the normal, and met no medium). A
/// slab of thickness 1 and transmittance t = 0.5 against a white
/// background, reflections and all: F + (1 - F)^2 t / (1 - F t) with
/// F = 0.04 at index 1.5 (1 without the absorption), for both integrators.
#[test]
fn glass_at_normal_incidence_is_entered_as_a_medium() {
    let src = r#"
        scene {
            background gray(1);
            camera { from (0, 0, 4); to (0, 0, 0); fov 2; }
            render { width 8; height 8; spp 32; max_depth 16; }
            object box { min (-5, -5, -0.5); max (5, 5, 0.5); material glass(ior: gray(1.5), transmittance: gray(0.5)); }
        }
    "#;
    let (f, t) = (0.04f64, 0.5f64);
    let want = f + (1.0 - f).powi(2) * t / (1.0 - f * t);
    for integrator in [IntegratorKind::Whitted, IntegratorKind::Path] {
        let image = render_src(src, ColorModel::Rgb, &Overrides { integrator: Some(integrator), ..Default::default() });
        let got = mean(&image)[1];
        assert!((got - want).abs() <= 0.02 * want, "{integrator:?}: {got}, want {want}");
    }
}

/// Russian roulette weighs a path by its throughput times the squared
/// indices it crossed (Mitsuba's and pbrt's rule): a rough dielectric's
/// transmission divides radiance by eta² (smooth `glass`'s does not),
/// which alone made roulette end paths inside rough glass as if they had
/// lost that much, and weigh the survivors up by as much: noise. In a
/// white furnace a nearly smooth rough dielectric sphere of index 8 (many
/// internal reflections) has 2.7x the pixel noise of glass of the same
/// index; without the rule, 17x.
#[test]
fn roulette_does_not_end_paths_for_crossing_into_glass() {
    let noise = |material: &str| {
        let src = format!(
            r#"
            scene {{
                background gray(1);
                camera {{ from (0, 0, 4); to (0, 0, 0); fov 18; }}
                render {{ width 16; height 16; spp 32; max_depth 64; integrator "path"; }}
                object sphere {{ center (0, 0, 0); radius 1; material {material}; }}
            }}
        "#
        );
        let image = render_src(&src, ColorModel::Rgb, &Overrides::default());
        let m = mean(&image)[1];
        let variance =
            image.color.iter().map(|p| (f64::from(p[1]) - m).powi(2)).sum::<f64>() / image.color.len() as f64;
        variance.sqrt()
    };
    let glass = noise("glass(ior: gray(8))");
    let rough = noise(r#"rough_dielectric(int_ior: 8, ext_ior: 1, alpha: 0.01, distribution: "ggx")"#);
    assert!(rough < 5.0 * glass, "pixel standard deviation: rough_dielectric {rough}, glass {glass}");
}

#[test]
fn a_point_light_falls_off_with_the_inverse_square() {
    // Looking straight down at a Lambertian floor under a point light:
    // L = albedo / pi * I / h^2 at the centre pixel.
    for integrator in [IntegratorKind::Whitted, IntegratorKind::Path] {
        let src = r#"
            scene {
                camera { from (0, 1, 0); to (0, 0, 0); up (0, 0, -1); fov 1; }
                render { width 1; height 1; spp 1; max_depth 2; }
                light point { at (0, 2, 0); intensity gray(8); }
                object quad { corner (-5, 0, 5); edge1 (10, 0, 0); edge2 (0, 0, -10); material lambert(kd: gray(0.5)); }
            }
        "#;
        let image = render_src(src, ColorModel::Rgb, &Overrides { integrator: Some(integrator), ..Default::default() });
        let expected = 0.5 / std::f32::consts::PI * 8.0 / 4.0;
        let got = image.color[0][1];
        assert!((got - expected).abs() < 1e-4 * expected, "{integrator:?}: {got} vs {expected}");
    }
}

#[test]
fn shadows_are_cast_and_the_light_power_is_split_over_the_sphere() {
    // `power` of a point light is spread over 4 pi sr; a blocker casts a
    // shadow.
    let src = |blocker: &str| {
        format!(
            r#"
            scene {{
                camera {{ from (0, 1, 0); to (0, 0, 0); up (0, 0, -1); fov 1; }}
                render {{ width 1; height 1; spp 1; integrator "whitted"; }}
                light point {{ at (0, 2, 0); power gray(100); }}
                object quad {{ corner (-5, 0, 5); edge1 (10, 0, 0); edge2 (0, 0, -10); material lambert(kd: gray(1)); }}
                {blocker}
            }}"#
        )
    };
    let lit = render_src(&src(""), ColorModel::Rgb, &Overrides::default()).color[0][0];
    let expected = 1.0 / std::f32::consts::PI * (100.0 / (4.0 * std::f32::consts::PI)) / 4.0;
    assert!((lit - expected).abs() < 1e-4 * expected, "{lit} vs {expected}");
    let blocker = "object sphere { center (0.0, 1.5, 0.0); radius 0.1; material lambert; }";
    let shadowed = render_src(&src(blocker), ColorModel::Rgb, &Overrides::default()).color[0][0];
    assert_eq!(shadowed, 0.0);
}

#[test]
fn images_do_not_depend_on_the_thread_count() {
    let src = std::fs::read_to_string("examples/cornell.tsl").unwrap();
    let program = Compiler::new().source("examples/cornell.tsl", &src).compile().unwrap();
    let overrides = Overrides { resolution: Some((24, 24)), spp: Some(4), ..Default::default() };
    let scene = Scene::build(&program, &overrides).unwrap();
    let one = render::render(&scene, &RenderOptions { threads: 1, ..Default::default() }).unwrap().0;
    let two = render::render(&scene, &RenderOptions { threads: 2, ..Default::default() }).unwrap().0;
    assert!(one.color.iter().zip(&two.color).all(|(a, b)| a.map(f32::to_bits) == b.map(f32::to_bits)));
    // A window renders the same pixels as the whole image.
    let window = render::render(&scene, &RenderOptions { window: Some((5, 7, 9, 4)), ..Default::default() }).unwrap().0;
    for y in 0..4 {
        for x in 0..9 {
            assert_eq!(window.color[y * 9 + x], one.color[(7 + y) * 24 + 5 + x]);
        }
    }
}

#[test]
fn sample_ranges_average_to_the_render_of_the_whole_range() {
    // A progressive renderer (`tslc watch`) renders 0..2, then 2..8, and
    // averages them by their lengths: the image of 0..8, up to rounding.
    let src = std::fs::read_to_string("examples/cornell.tsl").unwrap();
    let program = Compiler::new().source("examples/cornell.tsl", &src).compile().unwrap();
    let overrides = Overrides { resolution: Some((16, 16)), spp: Some(8), ..Default::default() };
    let scene = Scene::build(&program, &overrides).unwrap();
    let part = |samples| render::render(&scene, &RenderOptions { samples, ..Default::default() }).unwrap();
    let (whole, stats) = part(None);
    assert_eq!(stats.samples, 16 * 16 * 8);
    let (first, _) = part(Some(0..2));
    let (rest, stats) = part(Some(2..8));
    assert_eq!(stats.samples, 16 * 16 * 6);
    let mut differs = 0;
    for ((w, a), b) in whole.color.iter().zip(&first.color).zip(&rest.color) {
        for c in 0..3 {
            let averaged = (a[c] * 2.0 + b[c] * 6.0) / 8.0;
            assert!((averaged - w[c]).abs() <= 1e-5 * w[c].abs().max(1.0), "{averaged} vs {}", w[c]);
            differs += usize::from(a[c] != w[c]);
        }
    }
    assert!(differs > 100, "two samples should give a noisier image than eight");
    assert!(render::render(&scene, &RenderOptions { samples: Some(3..3), ..Default::default() }).is_err());
}

#[test]
fn a_cancelled_render_stops_at_the_next_tile_with_an_error() {
    use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
    let src = std::fs::read_to_string("examples/cornell.tsl").unwrap();
    let program = Compiler::new().source("examples/cornell.tsl", &src).compile().unwrap();
    let overrides = Overrides { resolution: Some((64, 64)), spp: Some(1), ..Default::default() };
    let scene = Scene::build(&program, &overrides).unwrap();
    let cancel = AtomicBool::new(true);
    let before = RenderOptions { cancel: Some(&cancel), ..Default::default() };
    assert_eq!(render::render(&scene, &before).unwrap_err(), render::CANCELLED);
    // Cancelled when the first tile finishes: the other 15 tiles are not rendered.
    let cancel = AtomicBool::new(false);
    let tiles_done = AtomicU32::new(0);
    let on_tile = |_, _| {
        tiles_done.fetch_add(1, Ordering::Relaxed);
        cancel.store(true, Ordering::Relaxed);
    };
    let during = RenderOptions { threads: 1, cancel: Some(&cancel), progress: Some(&on_tile), ..Default::default() };
    assert_eq!(render::render(&scene, &during).unwrap_err(), render::CANCELLED);
    assert_eq!(tiles_done.load(Ordering::Relaxed), 1);
}

#[test]
fn bad_scenes_are_located_errors() {
    let missing = common::build_error(
        r#"scene { camera { from (0, 0, 5); to (0, 0, 0); } object mesh { file "no/such/mesh.obj"; material lambert; } }"#,
    );
    assert!(missing.contains("bad.tsl:1:") && missing.contains("mesh.obj"), "{missing}");
    let camera = common::build_error(r#"scene { camera { from (1, 2, 3); to (1, 2, 3); } }"#);
    assert!(camera.contains("bad.tsl:1:") && camera.contains("differ"), "{camera}");
    let radius = common::build_error(
        r#"const float R = -1; scene { camera { from (0, 0, 5); to (0, 0, 0); } object sphere { center (0, 0, 0); radius R; material lambert; } }"#,
    );
    assert!(radius.contains("bad.tsl:1:") && radius.contains("positive"), "{radius}");

    let dir = std::env::temp_dir().join(format!("tsl-render-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let obj = dir.join("nan.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n").unwrap();
    let nan = common::build_error(&format!(
        r#"scene {{ camera {{ from (0, 0, 5); to (0, 0, 0); }} object mesh {{ file "{}"; material lambert; }} }}"#,
        obj.display()
    ));
    assert!(nan.contains("bad.tsl:1:") && nan.to_lowercase().contains("nan"), "{nan}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn zero_resolution_is_an_error() {
    let program =
        Compiler::new().source("z.tsl", "scene { camera { from (0, 0, 5); to (0, 0, 0); } }").compile().unwrap();
    let e = Scene::build(&program, &Overrides { resolution: Some((0, 4)), ..Default::default() }).err().unwrap();
    assert!(e.to_string().contains("size"), "{e}");
}

// ---------------------------------------------------------------- materials

/// Random unit vectors in the upper hemisphere (z up), from a fixed seed.
fn hemisphere_points(n: usize) -> Vec<[f32; 3]> {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..n)
        .map(|_| {
            let z = next();
            let phi = std::f32::consts::TAU * next();
            let r = (1.0 - z * z).max(0.0).sqrt();
            [r * phi.cos(), r * phi.sin(), z]
        })
        .collect()
}

const GLOSSY: &[&str] = &[
    "lambert",
    "phong",
    "phong(kd: gray(0), ks: gray(1), ns: 5)",
    "blinn_phong",
    "blinn_phong(kd: gray(0), ks: gray(1), ns: 10)",
    "cook_torrance",
    "cook_torrance(kd: gray(0), roughness: 0.5)",
    "ward",
    "ward(kd: gray(0), ks: gray(1), alpha_x: 0.3, alpha_y: 0.3)",
    "microvariation(p: 0)",
    "microvariation(p: 1, base: gray(1))",
    "microvariation(p: 0.6, base: gray(1), ks_hi: 0.9, ns_hi: 500)",
    "rusted_steel(rust: 0)",
    "rusted_steel(rust: 1)",
    "rusted_steel(rust: 0.4, roughness: 0.5)",
];

fn material(expr: &str) -> tsl::Material {
    let program = Compiler::new().source("m.tsl", &format!("material m = {expr};")).compile().unwrap();
    program.material("m").unwrap()
}

#[test]
fn stdlib_materials_conserve_energy() {
    // Directional albedo: the integral of reflection(wi, 1, wo) over the
    // hemisphere (uniform sampling, pdf 1 / 2 pi) is at most 1.
    let g = ShadingGlobals {
        n: [0.0, 0.0, 1.0],
        ng: [0.0, 0.0, 1.0],
        dpdu: [1.0, 0.0, 0.0],
        dpdv: [0.0, 1.0, 0.0],
        ..Default::default()
    };
    let wis = hemisphere_points(20_000);
    for expr in GLOSSY {
        let m = material(expr);
        for wo in hemisphere_points(6) {
            let mut sum = 0.0f64;
            let mut out = [0.0f32; 3];
            for wi in &wis {
                m.reflection_into(&g, *wi, &[1.0; 3], wo, &mut out);
                sum += f64::from(out.iter().copied().fold(0.0, f32::max));
            }
            let albedo = sum * std::f64::consts::TAU / wis.len() as f64;
            assert!(albedo <= 1.02, "{expr}: albedo {albedo} for wo {wo:?}");
        }
    }
    // Delta materials: the weights of their perfect directions.
    for expr in ["mirror", "glass", "glass(ior: gray(1.9))", "smoked_glass(p: 1)", "cutout(0, lambert)"] {
        let program = Compiler::new().source("m.tsl", &format!("material m = {expr};")).compile().unwrap();
        let m = program.material("m").unwrap();
        // Entering from vacuum: the relative index is the material's own.
        let eta = m.refraction_index(&g);
        let one = program.rgb(1.0, 1.0, 1.0);
        for wo in hemisphere_points(20) {
            let r = m.reflection(&g, m.reflection_dir(&g, wo), &one, wo).to_rgb()[1];
            let dt = m.refraction_dir(&g, wo, &eta);
            let t = if dt == [0.0; 3] { 0.0 } else { m.refraction(&g, dt, &one, &eta, wo).to_rgb()[1] };
            assert!(r + t <= 1.0 + 1e-4, "{expr}: {r} + {t} for wo {wo:?}");
        }
    }
}

#[test]
fn stdlib_brdfs_are_reciprocal() {
    // reflection includes cos(theta_i): f(wi, wo) = reflection(wi, wo) / cos_i.
    let g = ShadingGlobals {
        n: [0.0, 0.0, 1.0],
        ng: [0.0, 0.0, 1.0],
        dpdu: [1.0, 0.0, 0.0],
        dpdv: [0.0, 1.0, 0.0],
        ..Default::default()
    };
    let dirs = hemisphere_points(200);
    for expr in GLOSSY {
        let m = material(expr);
        let (mut a, mut b) = ([0.0f32; 3], [0.0f32; 3]);
        for pair in dirs.chunks(2) {
            let (wi, wo) = (pair[0], pair[1]);
            m.reflection_into(&g, wi, &[1.0; 3], wo, &mut a);
            m.reflection_into(&g, wo, &[1.0; 3], wi, &mut b);
            let (fa, fb) = (a[0] / wi[2], b[0] / wo[2]);
            assert!((fa - fb).abs() <= 1e-3 * fa.abs().max(fb.abs()).max(1e-3), "{expr}: {fa} vs {fb}");
        }
    }
}

// ---------------------------------------------------------------- image regression

/// Renders an example small and compares it with the reference in
/// `tests/data/render/` by 8 x 8 block means (noise averages out; a
/// changed light, material or camera does not). `UPDATE_EXPECT=1` rewrites
/// the references.
fn check_against_reference(example: &str, spp: u32) {
    check_against_reference_in(example, spp, ColorModel::Rgb);
}

/// [`check_against_reference`] in a color model; spectral references are
/// `NAME_spectral.exr`.
fn check_against_reference_in(example: &str, spp: u32, model: ColorModel) {
    let path = format!("examples/{example}.tsl");
    let program = Compiler::new().color_model(model).file(&path).compile().unwrap_or_else(|e| panic!("{e}"));
    let overrides = Overrides { resolution: Some((40, 40)), spp: Some(spp), ..Default::default() };
    let scene = Scene::build(&program, &overrides).unwrap_or_else(|e| panic!("{e}"));
    let image = render::render(&scene, &RenderOptions::default()).unwrap().0;
    let suffix = if model == ColorModel::Rgb { "" } else { "_spectral" };
    let reference = std::path::PathBuf::from(format!("tests/data/render/{example}{suffix}.exr"));
    if std::env::var_os("UPDATE_EXPECT").is_some() {
        std::fs::create_dir_all(reference.parent().unwrap()).unwrap();
        render::image_io::write_image(&reference, &image).unwrap();
        return;
    }
    let expected = render::image_io::read_exr(&reference).unwrap_or_else(|e| panic!("{e} (run with UPDATE_EXPECT=1)"));
    assert_eq!((expected.width, expected.height), (40, 40));
    let block = |img: &RenderedImage, bx: usize, by: usize| {
        let mut sum = [0.0f64; 3];
        for y in by * 8..by * 8 + 8 {
            for x in bx * 8..bx * 8 + 8 {
                for (s, v) in sum.iter_mut().zip(img.color[y * 40 + x]) {
                    *s += f64::from(v) / 64.0;
                }
            }
        }
        sum
    };
    for by in 0..5 {
        for bx in 0..5 {
            let (got, want) = (block(&image, bx, by), block(&expected, bx, by));
            for c in 0..3 {
                let tolerance = 0.02 + 0.1 * want[c].abs();
                assert!(
                    (got[c] - want[c]).abs() <= tolerance,
                    "{example}: block ({bx}, {by}) channel {c}: {} vs reference {}",
                    got[c],
                    want[c]
                );
            }
        }
    }
}

#[test]
fn whitted_matches_its_reference_image() {
    check_against_reference("whitted", 4);
}

#[test]
fn procedural_matches_its_reference_image() {
    check_against_reference("procedural", 4);
}

#[test]
fn cornell_matches_its_reference_image() {
    check_against_reference("cornell", 32);
}

#[test]
fn texture_tree_matches_its_reference_image() {
    check_against_reference("texture_tree", 2);
}

// ---------------------------------------------------------------- lights, cutouts, NaNs

/// The radiance of the centre pixel looking straight down at a white
/// Lambertian floor lit by `light`.
fn floor_radiance(light: &str, integrator: &str) -> f32 {
    let src = format!(
        r#"
        scene {{
            camera {{ from (0, 1, 0); to (0, 0, 0); up (0, 0, -1); fov 1; }}
            render {{ width 1; height 1; spp 1; integrator "{integrator}"; }}
            {light}
            object quad {{ corner (-50, 0, 50); edge1 (100, 0, 0); edge2 (0, 0, -100); material lambert(kd: gray(1)); }}
        }}"#
    );
    render_src(&src, ColorModel::Rgb, &Overrides::default()).color[0][0]
}

#[test]
fn spot_and_directional_lights_follow_their_definitions() {
    let pi = std::f32::consts::PI;
    // Directional: E = irradiance * cos; L = E / pi.
    let l = floor_radiance("light directional { direction (0, -1, -1); irradiance gray(2); }", "whitted");
    assert!((l - 2.0 * std::f32::consts::FRAC_1_SQRT_2 / pi).abs() < 1e-4, "{l}");
    // A spot pointing at the point: full intensity; pointing 45 degrees
    // away with a 30 degree cone: nothing.
    let on = floor_radiance("light spot { at (0, 2, 0); to (0, 0, 0); intensity gray(8); cone 30; }", "whitted");
    assert!((on - 8.0 / 4.0 / pi).abs() < 1e-4, "{on}");
    let off = floor_radiance("light spot { at (0, 2, 0); to (2, 0, 0); intensity gray(8); cone 30; }", "path");
    assert_eq!(off, 0.0);
    // Inside the falloff band the light is between the two.
    let edge = floor_radiance(
        "light spot { at (0, 2, 0); to (0.9, 0, 0); intensity gray(8); cone 26; falloff 6; }",
        "whitted",
    );
    assert!(edge > 0.0 && edge < on, "{edge}");
}

#[test]
fn area_lights_by_power_and_by_radiance_agree() {
    // A 1 x 1 rect light facing down: power P is radiance P / (pi * area).
    let by_power = floor_radiance(
        "light rect { corner (-0.5, 3, -0.5); edge1 (1, 0, 0); edge2 (0, 0, 1); power gray(10); }",
        "path",
    );
    let by_radiance = floor_radiance(
        &format!(
            "light rect {{ corner (-0.5, 3, -0.5); edge1 (1, 0, 0); edge2 (0, 0, 1); radiance gray({}); }}",
            10.0 / std::f32::consts::PI
        ),
        "path",
    );
    assert!(by_power > 0.0 && (by_power - by_radiance).abs() < 1e-4 * by_power, "{by_power} vs {by_radiance}");
}

#[test]
fn environment_backgrounds_light_the_scene() {
    let dir = std::env::temp_dir().join(format!("tsl-env-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let sky = dir.join("sky.exr");
    let image = RenderedImage {
        full_width: 4,
        full_height: 2,
        x0: 0,
        y0: 0,
        width: 4,
        height: 2,
        color: vec![[0.5; 3]; 8],
        albedo: None,
        normal: None,
        depth: None,
        object: None,
    };
    render::image_io::write_image(&sky, &image).unwrap();
    // A white diffuse floor under a uniform sky of 0.5 reflects 0.5 (one
    // bounce, the sky fills the upper hemisphere).
    let src = format!(
        r#"scene {{
            background "{}";
            camera {{ from (0, 1, 0); to (0, 0, 0); up (0, 0, -1); fov 1; }}
            render {{ width 2; height 2; spp 256; max_depth 2; integrator "path"; }}
            object quad {{ corner (-50, 0, 50); edge1 (100, 0, 0); edge2 (0, 0, -100); material lambert(kd: gray(1)); }}
        }}"#,
        sky.display()
    );
    let out = render_src(&src, ColorModel::Rgb, &Overrides::default());
    let _ = std::fs::remove_dir_all(&dir);
    let m = mean(&out)[0];
    assert!((m - 0.5).abs() < 0.03, "{m}");
}

#[test]
fn object_layer_names_the_first_object_each_pixel_centre_sees() {
    // Fov 90 on 8 x 4 pixels: pixel (i, j) looks along
    // (-1 + (i + 0.5) / 4, 0.5 - (j + 0.5) / 4, -1).
    let src = r#"
        scene {
            camera { from (0, 0, 0); to (0, 0, -1); fov 90; }
            render { width 8; height 4; spp 4; integrator "whitted"; }
            object quad { corner (-2, -2, -1); edge1 (2, 0, 0); edge2 (0, 4, 0); material lambert; }   // 0: left half
            light rect { corner (0, 0, -2); edge1 (4, 0, 0); edge2 (0, 4, 0); radiance gray(1); }     // 1: top right
            object quad { corner (-6, -6, -3); edge1 (5.5, 0, 0); edge2 (0, 12, 0); material lambert; } // 2: behind 0
            object sphere { center (2.5, -1.5, -4); radius 0.3; material lambert; }                    // 3: pixel (6, 3)
        }
    "#;
    let scene = scene_of(src, ColorModel::Rgb, &Overrides::default());
    let image = render::render(&scene, &RenderOptions { aov: true, ..Default::default() }).unwrap().0;
    let object = image.object.expect("--aov gives the object layer");
    let at = |i: usize, j: usize| object[j * 8 + i];
    for j in 0..4 {
        for i in 0..4 {
            assert_eq!(at(i, j), 0, "pixel ({i}, {j})");
        }
    }
    assert_eq!([at(4, 0), at(7, 0), at(4, 1), at(7, 1)], [1; 4]);
    assert_eq!([at(6, 3), at(4, 2), at(7, 2), at(5, 3)], [3, render::NO_OBJECT, render::NO_OBJECT, render::NO_OBJECT]);
    assert!(!object.contains(&2), "object 2 is hidden behind object 0");
    let plain = render::render(&scene, &RenderOptions::default()).unwrap().0;
    assert!(plain.object.is_none() && plain.color == image.color, "the layer changes no pixel");
}

#[test]
fn cutouts_let_light_and_camera_rays_through_their_holes() {
    // A sheet with holes (u < 0.5) between a point light and the floor.
    let src = |x: f32| {
        format!(
            r#"
            material sheet() {{
                bool opaque() {{ return u >= 0.5; }}
                vector refraction_dir(vector wo, color eta) {{ return opaque() ? vector(0) : -wo; }}
                color refraction(vector wi, color light, color eta, vector wo) {{ return light; }}
                color reflection(vector wi, color light, vector wo) {{
                    return light * gray(0.5) * max(dot(faceforward(N, -wo), wi), 0) * INV_PI;
                }}
            }}
            scene {{
                camera {{ from ({x}, 1, 0); to ({x}, 0, 0); up (0, 0, -1); fov 1; }}
                render {{ width 1; height 1; spp 1; integrator "whitted"; }}
                light point {{ at ({x}, 4, 0); intensity gray(16); }}
                object quad {{ corner (-50, 0, 50); edge1 (100, 0, 0); edge2 (0, 0, -100); material lambert(kd: gray(1)); }}
                object quad {{ corner (-1, 2, -1); edge1 (2, 0, 0); edge2 (0, 0, 2); material sheet; }}
            }}"#
        )
    };
    // x = -0.5 is under a hole (u = 0.25), x = 0.5 under the sheet (u = 0.75).
    let hole = render_src(&src(-0.5), ColorModel::Rgb, &Overrides::default()).color[0][0];
    let solid = render_src(&src(0.5), ColorModel::Rgb, &Overrides::default()).color[0][0];
    assert!((hole - 1.0 / std::f32::consts::PI).abs() < 1e-4, "lit through the hole: {hole}");
    assert_eq!(solid, 0.0, "in the sheet's shadow");
}

#[test]
fn stdlib_cutouts_of_image_alpha_let_shadow_and_camera_rays_through() {
    // The same setup with the stdlib `cutout` over an image whose left half
    // is transparent, lit by a point light and seen by both integrators.
    let dir = std::env::temp_dir().join(format!("tsl-cutout-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    image::RgbaImage::from_fn(8, 8, |x, _| image::Rgba([200, 150, 60, if x < 4 { 0 } else { 255 }]))
        .save(dir.join("holes.png"))
        .unwrap();
    let file = dir.join("cutout.tsl");
    let scene = |x: f32, integrator: &str| {
        let src = format!(
            r#"
            material panel = cutout(texture_float("holes.png", channel: 3, filter: "nearest"), lambert(kd: gray(0.5)));
            scene {{
                camera {{ from ({x}, 3, 0); to ({x}, 0, 0); up (0, 0, -1); fov 1; }}
                render {{ width 1; height 1; spp 1; max_depth 3; integrator "{integrator}"; }}
                light point {{ at ({x}, 4, 0); intensity gray(16); }}
                object quad {{ corner (-50, 0, 50); edge1 (100, 0, 0); edge2 (0, 0, -100); material lambert(kd: gray(1)); }}
                object quad {{ corner (-1, 2, 1); edge1 (2, 0, 0); edge2 (0, 0, -2); material panel; }}
            }}"#
        );
        std::fs::write(&file, src).unwrap();
        let program = Compiler::new().file(&file).compile().unwrap_or_else(|e| panic!("{e}"));
        let scene = Scene::build(&program, &Overrides::default()).unwrap_or_else(|e| panic!("{e}"));
        render::render(&scene, &RenderOptions::default()).unwrap().0.color[0][0]
    };
    // The camera, between the light and the sheet, looks down: at x = -0.5
    // through the transparent half (u = 0.25) at the floor lit through it,
    // at x = 0.5 at the sheet itself.
    let pi = std::f32::consts::PI;
    let (hole, solid) = (scene(-0.5, "whitted"), scene(0.5, "whitted"));
    assert!((hole - 1.0 / pi).abs() < 1e-3, "lit through the hole: {hole}");
    assert!((solid - 0.5 / pi * 16.0 / 4.0).abs() < 1e-3, "the sheet: {solid}");
    // The path tracer adds a little light bounced between floor and sheet.
    let (hole, solid) = (scene(-0.5, "path"), scene(0.5, "path"));
    assert!(hole >= 0.99 / pi && hole < 1.2 / pi, "path: lit through the hole: {hole}");
    assert!((solid - 0.5 / pi * 4.0).abs() < 0.05, "path: the sheet: {solid}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn nan_samples_are_dropped_and_counted() {
    let src = r#"
        material broken() { color emission(vector wo) { float zero = 0; return gray(zero / zero); } }
        scene {
            camera { from (0, 0, 3); to (0, 0, 0); fov 30; }
            render { width 4; height 4; spp 2; integrator "path"; }
            object sphere { center (0, 0, 0); radius 1; material broken; }
        }
    "#;
    let scene = scene_of(src, ColorModel::Rgb, &Overrides::default());
    let (image, stats) = render::render(&scene, &RenderOptions::default()).unwrap();
    assert!(stats.dropped_samples > 0);
    assert!(image.color.iter().all(|p| p.iter().all(|c| c.is_finite())));
}

/// A normal map changes what a sphere looks like (light grazing its ridges)
/// and never makes a sample that is not a number, with either integrator,
/// even where the tangents vanish (the poles).
#[test]
fn a_normal_mapped_sphere_differs_from_a_plain_one_and_stays_finite() {
    let src = |material: &str, integrator: &str| {
        format!(
            r#"
            vector ridges() {{ return (0.5 + 0.45 * sin(u * 120), 0.5 + 0.45 * cos(v * 60), 0.6); }}
            scene {{
                camera {{ from (0, 0.5, 3); to (0, 0, 0); fov 45; }}
                render {{ width 24; height 24; spp 4; max_depth 3; integrator "{integrator}"; }}
                light directional {{ direction (1, -0.3, -0.2); irradiance gray(3); }}
                object sphere {{ center (0, 0, 0); radius 1; material {material}; }}
            }}"#
        )
    };
    for integrator in ["path", "whitted"] {
        let render = |material: &str| {
            let scene = scene_of(&src(material, integrator), ColorModel::Rgb, &Overrides::default());
            render::render(&scene, &RenderOptions::default()).unwrap()
        };
        let plain_material = "phong(kd: gray(0.6), ks: gray(0.2), ns: 30)";
        let (plain, _) = render(plain_material);
        let (mapped, stats) = render(&format!("normal_map(ridges(), {plain_material})"));
        assert_eq!(stats.dropped_samples, 0, "{integrator}: no NaN samples");
        assert!(mapped.color.iter().all(|p| p.iter().all(|c| c.is_finite())), "{integrator}");
        let differs = plain
            .color
            .iter()
            .zip(&mapped.color)
            .filter(|(a, b)| (a[0] - b[0]).abs() > 0.05 * a[0].abs().max(0.05))
            .count();
        assert!(differs * 4 >= plain.color.len() / 4, "{integrator}: only {differs} pixels changed");
    }
}

/// AOV samples whose albedo or normal is NaN or infinite are dropped from
/// those layers and counted, as radiance samples are, and `tslc render`
/// says how many: the layers hold only numbers. (A material's normal that
/// is not a number already falls back to the surface's.)
#[test]
fn nan_aov_samples_are_dropped_and_counted() {
    let src = |albedo: &str, normal: &str| {
        format!(
            r#"
            material broken() {{
                color diffuse() {{ float zero = 0; return {albedo}; }}
                normal normal() {{ float zero = 0; return {normal}; }}
                color reflection(vector wi, color light, vector wo) {{ return light * 0.5; }}
            }}
            scene {{
                camera {{ from (0, 0, 3); to (0, 0, 0); fov 30; }}
                render {{ width 4; height 4; spp 2; integrator "path"; }}
                light point {{ at (0, 2, 3); intensity gray(5); }}
                object sphere {{ center (0, 0, 0); radius 1; material broken; }}
            }}
        "#
        )
    };
    let with_aov = RenderOptions { aov: true, ..Default::default() };
    for (albedo, normal) in
        [("gray(zero / zero)", "N"), ("rgb(0.5, 1 / zero, 0.5)", "N"), ("gray(-1 / zero)", "N * (zero / zero)")]
    {
        let scene = scene_of(&src(albedo, normal), ColorModel::Rgb, &Overrides::default());
        let (image, stats) = render::render(&scene, &with_aov).unwrap();
        // The sphere fills the middle 2 x 2 pixels at least.
        assert!(stats.dropped_aov_samples >= 8, "{albedo}, {normal}: {}", stats.dropped_aov_samples);
        let finite = |layer: &Option<Vec<[f32; 3]>>| layer.as_ref().unwrap().iter().flatten().all(|x| x.is_finite());
        assert!(finite(&image.albedo) && finite(&image.normal), "{albedo}, {normal}");
    }
    let scene = scene_of(&src("gray(0.5)", "N"), ColorModel::Rgb, &Overrides::default());
    assert_eq!(render::render(&scene, &with_aov).unwrap().1.dropped_aov_samples, 0);
    // The summary of `tslc render` reports them.
    let dir = common::temp_dir("nan-aov");
    let file = dir.join("broken.tsl");
    std::fs::write(&file, src("gray(zero / zero)", "N")).unwrap();
    let out = dir.join("out.exr");
    let o = common::tslc(&["render", file.to_str().unwrap(), "-o", out.to_str().unwrap(), "--aov", "--threads", "1"]);
    let err = common::stderr(&o);
    assert!(o.status.success() && err.contains("AOV samples (albedo or normal) were NaN or infinite"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

// The texturing examples: one scene per technique of the two papers, and
// the room that combines them, in RGB and spectrally.

#[test]
fn technique_examples_match_their_reference_images() {
    for example in [
        "bump_procedural",
        "bump_image",
        "normal_map",
        "triplanar",
        "microvariation",
        "image_spectral",
        "spectral_perturbation",
        "smoked_glass",
        "rusted_steel",
        "cutout",
        "reversal_tiling",
        "shapes",
        "clear_coat",
    ] {
        check_against_reference(&format!("techniques/{example}"), 4);
    }
}

#[test]
fn spectral_technique_examples_match_their_reference_images() {
    for example in ["image_spectral", "spectral_perturbation", "smoked_glass", "rusted_steel"] {
        check_against_reference_in(&format!("techniques/{example}"), 4, ColorModel::Spectral { samples: 16 });
    }
}

#[test]
fn room_matches_its_reference_images() {
    check_against_reference("room", 8);
    check_against_reference_in("room", 8, ColorModel::Spectral { samples: 16 });
}

#[test]
fn environment_images_are_looked_up_bilinearly_and_wrap_across() {
    use tsl::render::environment::{Environment, EnvironmentMap, EnvironmentSource};
    // 4 x 2 texels, one lane: 0 1 2 3 on the top row, 10 11 12 13 below.
    let texels = vec![0.0, 1.0, 2.0, 3.0, 10.0, 11.0, 12.0, 13.0];
    let map = EnvironmentMap { width: 4, height: 2, lanes: 1, texels };
    let env = Environment::new(EnvironmentSource::Image(map), 1.0, tsl::render::Vec3::ZERO);
    let at = |u: f32, v: f32| {
        // The direction whose lat-long coordinates are (u, v).
        let (phi, theta) = ((u - 0.5) * std::f32::consts::TAU, v * std::f32::consts::PI);
        let d = tsl::render::Vec3::new(theta.sin() * phi.sin(), theta.cos(), -theta.sin() * phi.cos());
        let mut out = [0.0f32];
        env.radiance(d, None, &mut out);
        out[0]
    };
    // Texel centres.
    assert!((at(0.375, 0.25) - 1.0).abs() < 1e-4);
    assert!((at(0.625, 0.75) - 12.0).abs() < 1e-4);
    // Between two centres: the mean; at the poles rows are clamped.
    assert!((at(0.5, 0.25) - 1.5).abs() < 1e-4);
    assert!((at(0.5, 0.5) - 6.5).abs() < 1e-4);
    assert!((at(0.375, 0.01) - 1.0).abs() < 1e-3);
    // Across the seam at u = 0 / 1 the image wraps: texels 3 and 0 meet.
    assert!((at(0.0001, 0.25) - 1.5).abs() < 1e-2);
    assert!((at(0.9999, 0.25) - 1.5).abs() < 1e-2);
}

// ---------------------------------------------------------------- prepared hits

/// Both integrators render the same image with prepared hits as with one
/// call per method: the split changes where work happens, not what it
/// computes (inline noise in a hit group differs from the native by
/// 1e-6, so a rare random choice may flip; nearly every pixel agrees).
#[test]
fn prepared_hits_render_what_per_method_calls_render() {
    for (example, integrator) in [
        ("texture_tree", IntegratorKind::Whitted),
        ("texture_tree", IntegratorKind::Path),
        ("techniques/bump_procedural", IntegratorKind::Path),
        ("techniques/bump_procedural", IntegratorKind::Whitted),
    ] {
        let path = format!("examples/{example}.tsl");
        let program = Compiler::new().file(&path).compile().unwrap_or_else(|e| panic!("{e}"));
        let render = |unsplit| {
            let overrides = Overrides {
                resolution: Some((48, 36)),
                spp: Some(2),
                integrator: Some(integrator),
                unsplit,
                ..Default::default()
            };
            let scene = Scene::build(&program, &overrides).unwrap_or_else(|e| panic!("{e}"));
            let prepared = scene.objects.iter().filter(|o| o.material.is_prepared()).count();
            (render::render(&scene, &RenderOptions::default()).unwrap().0, prepared)
        };
        let ((split, prepared), (alone, none)) = (render(false), render(true));
        assert!(prepared > 0 && none == 0, "{example}: {prepared} objects prepared, {none} without the split");
        let close = split
            .color
            .iter()
            .zip(&alone.color)
            .filter(|(a, b)| a.iter().zip(b.iter()).all(|(x, y)| (x - y).abs() <= 1e-3 * x.abs().max(y.abs()).max(1.0)))
            .count();
        let pixels = split.color.len();
        assert!(close * 100 >= pixels * 97, "{example} ({integrator:?}): {close} of {pixels} pixels agree");
    }
}

/// The optimising tier for large functions (chosen for long renders) runs
/// the same operations as the quick one: the same image, bit for bit.
#[test]
fn optimised_code_renders_the_same_bits() {
    let program =
        Compiler::new().file("examples/techniques/bump_procedural.tsl").compile().unwrap_or_else(|e| panic!("{e}"));
    let render = |optimize| {
        let overrides = Overrides {
            resolution: Some((40, 30)),
            spp: Some(2),
            integrator: Some(IntegratorKind::Path),
            optimize_code: Some(optimize),
            ..Default::default()
        };
        let scene = Scene::build(&program, &overrides).unwrap_or_else(|e| panic!("{e}"));
        render::render(&scene, &RenderOptions::default()).unwrap().0
    };
    let (quick, optimised) = (render(false), render(true));
    assert!(quick.color.iter().any(|p| p.iter().any(|x| *x > 0.0)), "a black image proves nothing");
    assert_eq!(quick.color, optimised.color);
}

/// A film beyond the memory budget is refused before it is allocated, with
/// the way out: tiles.
#[test]
fn a_film_beyond_the_budget_says_to_render_in_tiles() {
    let src =
        "scene {\n    camera { from (0, 0, -4); to (0, 0, 0); }\n    render { width 16384; height 8192; spp 1; }\n}\n";
    let scene = scene_of(src, ColorModel::Rgb, &Overrides::default());
    let with_aov = RenderOptions { aov: true, ..Default::default() };
    let Err(e) = render::render(&scene, &with_aov) else { panic!("a film over the budget was allocated") };
    assert!(e.contains("--tile I/3"), "{e}");
    assert!(render::film_bytes(16384, 8192, false) <= render::FILM_BUDGET_BYTES);
}

/// `Compiler::lean` drops the syntax, types and resolutions of the scene's
/// objects once described, but renders the same image: named materials
/// shared, inline materials and transforms kept, light blocks untouched.
#[test]
fn a_lean_program_renders_the_same_image_with_less_kept() {
    let src = r#"
        material red = lambert(kd: rgb(0.8, 0.1, 0.1));
        material blue = lambert(kd: rgb(0.1, 0.1, 0.8));
        scene {
            camera { from (0, 1, 6); to (0, 0, 0); fov 50; }
            render { width 24; height 16; spp 4; integrator "path"; }
            light point { at (2, 4, 3); intensity rgb(30, 30, 30); }
            light sphere { center (-2, 3, 1); radius 0.3; radiance rgb(4, 4, 4); }
            object sphere { center (-1.5, 0, 0); radius 0.5; material red; }
            object sphere { center (0, -0.5 - 0.25, 0); radius 0.5; material blue; }
            object sphere { center (1.5, 0, -0); radius 0.5; material red; translate (0, 0.2, 0); }
            object box { min (-3, -1.5, -3); max (3, -1.25, 3); material lambert(kd: rgb(0.5, 0.5, 0.5)); }
            object sphere { center (0, 1.2, 0); radius 0.4; material blue; }
            object sphere { center (-0.7, 1.2, 1); radius -(-0.3); material red; }
        }
    "#;
    let compile = |lean| Compiler::new().source("lean.tsl", src).lean(lean).compile().unwrap_or_else(|e| panic!("{e}"));
    let (full, lean) = (compile(false), compile(true));
    let image = |program: &tsl::Program| {
        let scene = Scene::build(program, &Overrides::default()).unwrap_or_else(|e| panic!("{e}"));
        render::render(&scene, &RenderOptions::default()).unwrap().0
    };
    let (a, b) = (image(&full), image(&lean));
    assert_eq!(a.color, b.color);
    // Given its description, the builder frees the objects once placed.
    let mut given = compile(true);
    let desc = given.take_scene().unwrap();
    assert!(given.scene().is_none());
    let scene = Scene::build_owned(&given, desc, &Overrides::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(render::render(&scene, &RenderOptions::default()).unwrap().0.color, a.color);
    assert!(full.clone().take_scene().is_none(), "a shared program keeps its scene");
    // Kept: the first object of each material name and the inline material.
    let entries = |p: &tsl::Program| {
        p.checked()
            .loaded
            .modules
            .iter()
            .filter(|m| !m.is_prelude)
            .flat_map(|m| m.ast.items.iter())
            .find_map(|i| match i {
                tsl::syntax::ast::Item::Scene(s) => Some(s.entries.len()),
                _ => None,
            })
            .unwrap()
    };
    assert_eq!((entries(&full), entries(&lean)), (10, 7));
    let types = |p: &tsl::Program| p.checked().expr_types.len();
    assert!(types(&lean) < types(&full), "{} types kept of {}", types(&lean), types(&full));
    let resolutions = |p: &tsl::Program| p.checked().resolutions.len();
    assert_eq!(resolutions(&full) - resolutions(&lean), 3, "the later `red`, `blue` and `red`");
    // The same frame is the description kept; another cannot be made.
    let frame = |n| tsl::scene::FrameRequest { frame: n, fps: None };
    assert!(lean.scene_at(&frame(0)).unwrap().is_some());
    assert!(lean.scene_at(&frame(1)).is_err());
    assert!(full.scene_at(&frame(1)).unwrap().is_some());
}
