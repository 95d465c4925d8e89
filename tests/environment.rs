//! Environment lighting and light selection, end to end: furnace tests in
//! constant environments, material sampling, light sampling and their
//! combination agreeing, a small bright sun converging far faster with
//! light sampling, choosing among many lights by power at the cost of one,
//! the scene syntax and its located errors.

mod common;

use tsl::render::environment::{Environment, EnvironmentMap, EnvironmentSource};
use tsl::render::scene::Strategy;
use tsl::render::{self, LightSampling, Overrides, RenderOptions, RenderStats, RenderedImage, Scene, Vec3};
use tsl::{ColorModel, Compiler};

fn scene_of(src: &str, model: ColorModel) -> Scene {
    let program =
        Compiler::new().color_model(model).source("test.tsl", src).compile().unwrap_or_else(|e| panic!("{e}"));
    Scene::build(&program, &Overrides::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn render_scene(scene: &Scene) -> (RenderedImage, RenderStats) {
    render::render(scene, &RenderOptions::default()).unwrap()
}

/// The green channel of every pixel.
fn green(image: &RenderedImage) -> Vec<f64> {
    image.color.iter().map(|p| f64::from(p[1])).collect()
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

fn variance(v: &[f64]) -> f64 {
    let m = mean(v);
    v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64
}

/// How many standard errors apart two images' means are, from their
/// pixel-by-pixel differences: each difference has expectation zero when
/// the images render the same thing, whatever the pixel's own value.
fn z_score(a: &[f64], b: &[f64]) -> f64 {
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    mean(&d) / (variance(&d) / d.len() as f64).sqrt()
}

/// Writes a `w x h` lat-long EXR whose texel (i, j) is `f(i, j)`.
fn write_sky(path: &std::path::Path, w: u32, h: u32, f: impl Fn(u32, u32) -> [f32; 3]) {
    let color = (0..h).flat_map(|j| (0..w).map(move |i| (i, j))).map(|(i, j)| f(i, j)).collect();
    let image = RenderedImage {
        full_width: w,
        full_height: h,
        x0: 0,
        y0: 0,
        width: w,
        height: h,
        color,
        albedo: None,
        normal: None,
        depth: None,
        object: None,
    };
    render::image_io::write_image(path, &image).unwrap();
}

// ---------------------------------------------------------------- furnaces

#[test]
fn a_lambert_sphere_in_a_constant_environment_reflects_its_albedo() {
    // The sphere fills the view; convex, so every reflected ray escapes:
    // each pixel sees kd * L in expectation.
    for (kd, model) in [(0.8, ColorModel::Rgb), (1.0, ColorModel::Rgb), (0.8, ColorModel::Spectral { samples: 16 })] {
        let src = format!(
            r#"scene {{
                light environment {{ radiance gray(0.5); }}
                camera {{ from (0, 0, 4); to (0, 0, 0); fov 12; }}
                render {{ width 12; height 12; spp 64; max_depth 8; }}
                object sphere {{ center (0, 0, 0); radius 1; material lambert(kd: gray({kd})); }}
            }}"#
        );
        let scene = scene_of(&src, model);
        let (image, stats) = render_scene(&scene);
        assert!(stats.rays.shadow_rays > 0, "the environment is sampled as a light");
        let m = mean(&green(&image));
        let expected = 0.5 * kd;
        assert!((m - expected).abs() < 0.01 * expected, "kd {kd}, {model:?}: {m} vs {expected}");
        // Light and material samples weigh each other: no longer exact per
        // sample, but every pixel is near.
        for p in &image.color {
            assert!((f64::from(p[1]) - expected).abs() < 0.15 * expected, "{p:?}");
        }
    }
}

#[test]
fn a_rough_conductor_sphere_with_fresnel_one_in_a_constant_environment_nearly_vanishes() {
    // Fresnel 1 and a convex sphere: all light the surface sends back is
    // the environment's, less what single scattering loses between facets
    // (little at low roughness, more at grazing angles and high roughness).
    for (alpha, distribution, floor) in [(0.05, "ggx", 0.97), (0.05, "beckmann", 0.97), (0.3, "ggx", 0.85)] {
        let src = format!(
            r#"scene {{
                light environment {{ radiance gray(0.5); }}
                camera {{ from (0, 0, 4); to (0, 0, 0); fov 12; }}
                render {{ width 12; height 12; spp 64; max_depth 8; }}
                object sphere {{ center (0, 0, 0); radius 1;
                    material rough_conductor(alpha: {alpha}, distribution: "{distribution}"); }}
            }}"#
        );
        let scene = scene_of(&src, ColorModel::Rgb);
        let m = mean(&green(&render_scene(&scene).0)) / 0.5;
        assert!(m <= 1.005 && m >= floor, "alpha {alpha} {distribution}: the sphere returns {m} of the environment");
    }
}

#[test]
fn a_mix_renders_as_the_mix_of_its_two_images() {
    // The path-traced image of mix(0.3, a, b) is, in expectation, 0.7 of
    // a's image plus 0.3 of b's: sampling composes without bias.
    let scene_with = |material: &str| {
        let src = format!(
            r#"scene {{
                light environment {{ radiance rgb(0.6, 0.5, 0.4); }}
                light sphere {{ center (2, 3, 2); radius 0.5; radiance gray(20); }}
                camera {{ from (0, 1.5, 4); to (0, 0.5, 0); fov 35; }}
                render {{ width 16; height 12; spp 256; max_depth 6; }}
                object sphere {{ center (0, 0.6, 0); radius 0.6; material {material}; }}
                object plane {{ point (0, 0, 0); normal (0, 1, 0); material lambert(kd: gray(0.5)); }}
            }}"#
        );
        green(&render_scene(&scene_of(&src, ColorModel::Rgb)).0)
    };
    let a = "rough_conductor(alpha: 0.1, eta: CU_ETA, k: CU_K)";
    let b = "lambert(kd: rgb(0.2, 0.6, 0.3))";
    let (ia, ib, im) = (scene_with(a), scene_with(b), scene_with(&format!("mix(0.3, {a}, {b})")));
    let expected: Vec<f64> = ia.iter().zip(&ib).map(|(x, y)| 0.7 * x + 0.3 * y).collect();
    let z = z_score(&im, &expected);
    assert!(z.abs() < 4.0, "mix {} vs mixed images {}: z = {z}", mean(&im), mean(&expected));
    assert!((mean(&im) - mean(&expected)).abs() < 0.02 * mean(&expected));
}

// ---------------------------------------------------------------- strategies

#[test]
fn mis_and_each_strategy_alone_agree() {
    // A diffuse sphere on a floor under a sky with a soft bright patch:
    // shadows need transmittance toward the environment, the sphere's
    // underside light bounced off the floor.
    let dir = common::temp_dir("env-strategies");
    let sky = dir.join("sky.exr");
    write_sky(&sky, 32, 16, |i, j| {
        let patch = if (8..12).contains(&i) && (3..6).contains(&j) { 6.0 } else { 0.0 };
        let v = 0.3 + 0.05 * j as f32 + patch;
        [v, 0.8 * v, 0.6 * v + 0.1]
    });
    let src = format!(
        r#"scene {{
            light environment {{ file "{}"; rotate (0, 40, 0); }}
            camera {{ from (0, 2, 5); to (0, 0.5, 0); fov 40; }}
            render {{ width 16; height 12; spp 64; max_depth 4; }}
            object sphere {{ center (0, 1, 0); radius 1; material lambert(kd: gray(0.7)); }}
            object plane {{ point (0, 0, 0); normal (0, 1, 0); material lambert(kd: gray(0.5)); }}
        }}"#,
        sky.display()
    );
    let mut scene = scene_of(&src, ColorModel::Rgb);
    let mut images = Vec::new();
    for strategy in [Strategy::Mis, Strategy::Material, Strategy::Light] {
        scene.settings.strategy = strategy;
        images.push((strategy, green(&render_scene(&scene).0)));
    }
    let _ = std::fs::remove_dir_all(&dir);
    let (mis, material, light) = (&images[0].1, &images[1].1, &images[2].1);
    for (name, other) in [("material", material), ("light", light)] {
        let z = z_score(mis, other);
        assert!(z.abs() < 4.0, "MIS vs {name} sampling: means {} vs {}, z = {z}", mean(mis), mean(other));
    }
    // MIS is no worse than either alone.
    let noise = |a: &[f64]| variance(&a.iter().zip(mis).map(|(x, y)| x - y).collect::<Vec<_>>());
    assert!(noise(material) > 0.0 && noise(light) > 0.0);
}

/// Radiance of a floor of albedo `kd` under `env`: `kd / pi * ∫ L cos dω`
/// over the upper hemisphere, integrated in lat-long coordinates finely
/// enough for the bilinear lookup.
fn floor_radiance(env: &Environment, kd: f64) -> f64 {
    let (nu, nv) = (2048, 1024);
    let mut sum = 0.0;
    let mut out = [0.0f32; 3];
    for j in 0..nv / 2 {
        let theta = std::f64::consts::PI * (j as f64 + 0.5) / nv as f64;
        for i in 0..nu {
            let phi = std::f64::consts::TAU * ((i as f64 + 0.5) / nu as f64 - 0.5);
            let d = Vec3::new((theta.sin() * phi.sin()) as f32, theta.cos() as f32, (-theta.sin() * phi.cos()) as f32);
            env.radiance(d, None, &mut out);
            sum += f64::from(out[1]) * theta.cos() * theta.sin();
        }
    }
    let d_omega = std::f64::consts::TAU / nu as f64 * std::f64::consts::PI / nv as f64;
    kd / std::f64::consts::PI * sum * d_omega
}

#[test]
fn a_small_sun_converges_far_faster_with_light_sampling() {
    // One texel of a 64 x 32 sky is a sun 10^5 times brighter than the rest.
    let dir = common::temp_dir("env-sun");
    let sky = dir.join("sun.exr");
    let texel = |i: u32, j: u32| if (i, j) == (20, 8) { [2.0e4; 3] } else { [0.2, 0.2, 0.25] };
    write_sky(&sky, 64, 32, texel);
    // An infinite floor seen from above: every point sees the same sky, so
    // every pixel has the same expectation and their spread is noise.
    let src = format!(
        r#"scene {{
            light environment {{ file "{}"; }}
            camera {{ from (0, 1, 0); to (0, 0, 0); up (0, 0, -1); fov 30; }}
            render {{ width 24; height 24; spp 16; max_depth 2; }}
            object plane {{ point (0, 0, 0); normal (0, 1, 0); material lambert(kd: gray(0.5)); }}
        }}"#,
        sky.display()
    );
    let mut scene = scene_of(&src, ColorModel::Rgb);
    let mis = green(&render_scene(&scene).0);
    scene.settings.strategy = Strategy::Material;
    let material = green(&render_scene(&scene).0);
    let _ = std::fs::remove_dir_all(&dir);

    let mut texels = Vec::new();
    for j in 0..32 {
        for i in 0..64 {
            texels.extend(texel(i, j));
        }
    }
    let map = EnvironmentMap { width: 64, height: 32, lanes: 3, texels };
    let expected = floor_radiance(&Environment::new(EnvironmentSource::Image(map), 1.0, Vec3::ZERO), 0.5);
    let m = mean(&mis);
    assert!((m - expected).abs() < 0.02 * expected, "MIS: {m} vs {expected}");
    let ratio = variance(&material) / variance(&mis);
    // About 170 here; material sampling's variance is itself estimated
    // from a few dozen sun hits.
    assert!(ratio > 50.0, "material sampling's variance is only {ratio} times MIS's");
}

// ---------------------------------------------------------------- many lights

/// A floor under `n` small sphere lights of different powers, seen from
/// below the lights; direct light only.
fn many_lights(n: usize, sampling: &str, spp: u32) -> (RenderedImage, RenderStats) {
    let mut lights = String::new();
    for k in 0..n {
        let (x, z) = ((k % 40) as f32 * 0.25 - 5.0, (k / 40) as f32 * 0.25 - 3.0);
        let radiance = 20.0 + 30.0 * (k % 7) as f32;
        lights.push_str(&format!("light sphere {{ center ({x}, 2, {z}); radius 0.03; radiance gray({radiance}); }}\n"));
    }
    let src = format!(
        r#"scene {{
            camera {{ from (0, 1, 0); to (0, 0, 0); up (0, 0, -1); fov 60; }}
            render {{ width 8; height 8; spp {spp}; max_depth 2; light_sampling "{sampling}"; }}
            {lights}
            object plane {{ point (0, 0, 0); normal (0, 1, 0); material lambert(kd: gray(0.8)); }}
        }}"#
    );
    render_scene(&scene_of(&src, ColorModel::Rgb))
}

#[test]
fn choosing_lights_by_power_costs_one_light_and_agrees_with_summing_all() {
    let (all, all_stats) = many_lights(1000, "all", 4);
    let (power, power_stats) = many_lights(1000, "power", 256);
    let per_ray = |s: &RenderStats| s.rays.shadow_rays as f64 / s.rays.camera_rays as f64;
    // One shading point per camera ray (depth 2): "power" traces at most
    // one shadow ray there, "all" one per light.
    assert!(per_ray(&power_stats) <= 1.0, "{}", per_ray(&power_stats));
    assert!(per_ray(&all_stats) > 900.0, "{}", per_ray(&all_stats));
    // Summing all lights is nearly noise-free; one light a sample by power
    // agrees within its noise.
    let (a, p) = (green(&all), green(&power));
    let error = (variance(&p) / p.len() as f64).sqrt();
    assert!((mean(&a) - mean(&p)).abs() < 4.0 * error + 1e-3 * mean(&a), "{} vs {} (± {error})", mean(&a), mean(&p));
    assert!(error < 0.05 * mean(&a), "power sampling is too noisy: ± {error} of {}", mean(&a));
}

// ---------------------------------------------------------------- scene syntax

#[test]
fn background_and_environment_blocks_are_the_same_light() {
    let dir = common::temp_dir("env-syntax");
    let sky = dir.join("sky.exr");
    write_sky(&sky, 8, 4, |i, j| [0.1 * i as f32, 0.2 + 0.1 * j as f32, 0.5]);
    let scene = |environment: &str| {
        format!(
            r#"scene {{
                {environment}
                camera {{ from (0, 0, 0); to (0.3, 0.2, -1); fov 90; }}
                render {{ width 8; height 6; spp 4; max_depth 3; }}
                object sphere {{ center (0, -1.5, -2); radius 1; material lambert; }}
            }}"#
        )
    };
    let file = sky.display();
    let bits = |src: &str| {
        let image = render_scene(&scene_of(src, ColorModel::Rgb)).0;
        image.color.iter().map(|p| p.map(f32::to_bits)).collect::<Vec<_>>()
    };
    let background = bits(&scene(&format!(r#"background "{file}";"#)));
    assert_eq!(background, bits(&scene(&format!(r#"light environment {{ file "{file}"; }}"#))));
    assert_eq!(
        background,
        bits(&scene(&format!(r#"light environment {{ file "{file}"; scale 1; rotate (0, 0, 0); }}"#)))
    );
    let constant = bits(&scene("background rgb(0.2, 0.3, 0.4);"));
    assert_eq!(constant, bits(&scene("light environment { radiance rgb(0.2, 0.3, 0.4); }")));
    // Seen directly, scale 2 doubles every sample exactly.
    let direct = |scale: f32| {
        let src = format!(
            r#"scene {{
                light environment {{ file "{file}"; scale {scale}; }}
                camera {{ from (0, 0, 0); to (0.3, 0.2, -1); fov 90; }}
                render {{ width 8; height 6; spp 2; }}
            }}"#
        );
        render_scene(&scene_of(&src, ColorModel::Rgb)).0
    };
    let (one, two) = (direct(1.0), direct(2.0));
    for (a, b) in one.color.iter().zip(&two.color) {
        assert_eq!(a.map(|x| 2.0 * x), *b);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn rotate_turns_the_environment_as_it_turns_objects() {
    // Columns 1 and 2 of a 4 x 2 sky (around -z, u = 0.5) are red, the
    // others blue. Turned 90 degrees about y, what was at -z is at -x, as
    // an object's `rotate (0, 90, 0)` turns -z to -x.
    let dir = common::temp_dir("env-rotate");
    let sky = dir.join("sky.exr");
    write_sky(&sky, 4, 2, |i, _| if i == 1 || i == 2 { [1.0, 0.0, 0.0] } else { [0.0, 0.0, 1.0] });
    let look_at_minus_x = |rotate: &str| {
        let src = format!(
            r#"scene {{
                light environment {{ file "{}"; {rotate} }}
                camera {{ from (0, 0, 0); to (-1, 0, 0); fov 1; }}
                render {{ width 1; height 1; spp 1; }}
            }}"#,
            sky.display()
        );
        render_scene(&scene_of(&src, ColorModel::Rgb)).0.color[0]
    };
    let plain = look_at_minus_x("");
    let turned = look_at_minus_x("rotate (0, 90, 0);");
    let _ = std::fs::remove_dir_all(&dir);
    assert!((plain[0] - 0.5).abs() < 1e-3 && (plain[2] - 0.5).abs() < 1e-3, "{plain:?}");
    assert!((turned[0] - 1.0).abs() < 1e-3 && turned[2].abs() < 1e-3, "{turned:?}");
}

#[test]
fn bad_environments_are_located_errors() {
    let camera = "camera { from (0, 0, 5); to (0, 0, 0); }";
    let src = format!(r#"scene {{ {camera} light environment {{ file "no/such/sky.hdr"; }} }}"#);
    let column = src.find("\"no/such").unwrap() + 1;
    let missing = common::build_error(&src);
    assert!(missing.contains(&format!("bad.tsl:1:{column}")) && missing.contains("sky.hdr"), "{missing}");
    let src = format!(r#"scene {{ {camera} background "no/such/sky.exr"; }}"#);
    let column = src.find("\"no/such").unwrap() + 1;
    let missing = common::build_error(&src);
    assert!(missing.contains(&format!("bad.tsl:1:{column}")), "{missing}");
    // Scales the checker cannot see: from a constant, and not finite.
    let src = format!(r#"const float S = -2; scene {{ {camera} light environment {{ radiance gray(1); scale S; }} }}"#);
    let negative = common::build_error(&src);
    assert!(negative.contains("bad.tsl:1:") && negative.contains("negative"), "{negative}");
    let src = format!(r#"scene {{ {camera} light environment {{ radiance gray(1); scale 1.0 / 0.0; }} }}"#);
    let infinite = common::build_error(&src);
    assert!(infinite.contains("bad.tsl:1:") && infinite.contains("finite"), "{infinite}");
    // Two environments do not compile; the checker points at the second.
    let src = format!(r#"scene {{ {camera} background gray(1); light environment {{ radiance gray(1); }} }}"#);
    let e = Compiler::new().source("bad.tsl", &src).compile().err().unwrap().to_string();
    let column = src.find("light environment").unwrap() + 1;
    assert!(e.contains("one environment") && e.contains(&format!("bad.tsl:1:{column}")), "{e}");
}

#[test]
fn environment_lit_images_do_not_depend_on_the_thread_count() {
    let dir = common::temp_dir("env-threads");
    let sky = dir.join("sky.exr");
    write_sky(&sky, 16, 8, |i, j| [0.1 + 0.05 * i as f32, 0.3, if (i, j) == (3, 2) { 50.0 } else { 0.2 }]);
    let src = format!(
        r#"scene {{
            light environment {{ file "{}"; scale 1.5; rotate (10, 20, 30); }}
            light point {{ at (1, 3, 1); intensity gray(4); }}
            camera {{ from (0, 2, 5); to (0, 0.5, 0); fov 40; }}
            render {{ width 20; height 14; spp 3; max_depth 5; }}
            object sphere {{ center (0, 1, 0); radius 1; material lambert(kd: gray(0.7)); }}
            object plane {{ point (0, 0, 0); normal (0, 1, 0); material lambert(kd: gray(0.5)); }}
        }}"#,
        sky.display()
    );
    let scene = scene_of(&src, ColorModel::Rgb);
    let _ = std::fs::remove_dir_all(&dir);
    let bits = |threads: usize| {
        let image = render::render(&scene, &RenderOptions { threads, ..Default::default() }).unwrap().0;
        image.color.iter().map(|p| p.map(f32::to_bits)).collect::<Vec<_>>()
    };
    assert_eq!(bits(1), bits(2));
    assert_eq!(scene.settings.light_sampling, LightSampling::Power);
}

// ------------------------------------------------------ non-finite texels

/// A scene lit by the environment image `sky` alone: a lambert sphere on a
/// plane, seen from above.
fn lit_by(sky: &std::path::Path, size: u32, spp: u32) -> String {
    format!(
        r#"scene {{
            light environment {{ file "{}"; }}
            camera {{ from (0, 2, 5); to (0, 0.5, 0); fov 40; }}
            render {{ width {size}; height {size}; spp {spp}; max_depth 3; }}
            object sphere {{ center (0, 1, 0); radius 1; material lambert(kd: gray(0.7)); }}
            object plane {{ point (0, 0, 0); normal (0, 1, 0); material lambert(kd: gray(0.5)); }}
        }}"#,
        sky.display()
    )
}

/// A value that is not a number at one texel of an environment image is
/// replaced by 0 when the image is read, with a warning at the file that
/// names the texel: the scene renders exactly as with a 0 written there
/// (an infinite texel made the environment's power infinite: "no light",
/// a black image).
#[test]
fn a_non_finite_environment_texel_is_replaced_by_zero_and_warned_of() {
    let dir = common::temp_dir("env-non-finite");
    let sky = |i: u32, j: u32| [0.2 + 0.05 * i as f32, 0.4, 0.3 + 0.1 * j as f32];
    let clean = dir.join("clean.exr");
    write_sky(&clean, 16, 8, |i, j| if (i, j) == (3, 2) { [0.0, 0.4, 0.5] } else { sky(i, j) });
    let clean_bits = {
        let image = render_scene(&scene_of(&lit_by(&clean, 12, 4), ColorModel::Rgb)).0;
        image.color.iter().map(|p| p.map(f32::to_bits)).collect::<Vec<_>>()
    };
    for (name, value, words) in [
        ("inf.exr", f32::INFINITY, "+inf in channel R of texel (3, 2)"),
        ("neg.exr", f32::NEG_INFINITY, "-inf in channel R of texel (3, 2)"),
        ("nan.exr", f32::NAN, "NaN in channel R of texel (3, 2)"),
    ] {
        let path = dir.join(name);
        write_sky(&path, 16, 8, |i, j| if (i, j) == (3, 2) { [value, 0.4, 0.5] } else { sky(i, j) });
        let src = lit_by(&path, 12, 4);
        let checked = tsl::check_source("sky.tsl", &src, &tsl::LoadOptions::default());
        let text = checked.render_diagnostics();
        // At the file's literal.
        let at = src.find(&format!("\"{}", path.display())).unwrap();
        let line = src[..at].matches('\n').count() + 1;
        let column = at - src[..at].rfind('\n').map_or(0, |k| k + 1) + 1;
        assert!(checked.is_ok() && checked.diagnostics.len() == 1, "{name}: {text}");
        let expected = format!("1 value that is not a number (NaN or infinite): it is {words}; it is replaced by 0");
        assert!(text.contains("warning") && text.contains(name) && text.contains(&expected), "{name}: {text}");
        assert!(text.contains(&format!("sky.tsl:{line}:{column}")), "{name}: {text}");
        let scene = scene_of(&src, ColorModel::Rgb);
        assert!(!scene.lights.is_empty(), "{name}: the environment is no light");
        let image = render_scene(&scene).0;
        let bits: Vec<_> = image.color.iter().map(|p| p.map(f32::to_bits)).collect();
        assert!(bits == clean_bits, "{name}: not the image of the sky with 0 at the texel");
        // `tslc render` shows the warning as `tslc check` does.
        let scene_file = dir.join("sky.tsl");
        std::fs::write(&scene_file, &src).unwrap();
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_tslc"))
            .args(["render", "--res", "8x4", "--spp", "1", "--quiet", "-o"])
            .arg(dir.join("out.png"))
            .arg(&scene_file)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{name}: {stderr}");
        assert!(stderr.contains("warning") && stderr.contains(&expected), "{name}: tslc render said {stderr}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// One NaN among 4096 texels: before, it spread through the sampling
/// distribution and dropped about half the samples, darkening the image
/// by 65%. Now the image's mean is within a percent of the clean sky's
/// (where that texel holds its neighbours' value).
#[test]
fn one_nan_among_4096_texels_leaves_the_image_as_bright_as_the_clean_sky() {
    let dir = common::temp_dir("env-one-nan");
    let sky = |i: u32, j: u32| [0.5 + 0.01 * i as f32, 0.6, 0.4 + 0.01 * j as f32];
    let (clean, spoiled) = (dir.join("clean.exr"), dir.join("spoiled.exr"));
    write_sky(&clean, 64, 64, sky);
    for (k, at) in [(20, 10), (63, 63), (0, 32)].into_iter().enumerate() {
        write_sky(&spoiled, 64, 64, |i, j| if (i, j) == at { [f32::NAN; 3] } else { sky(i, j) });
        let render = |path: &std::path::Path| render_scene(&scene_of(&lit_by(path, 16, 8), ColorModel::Rgb));
        let ((a, _), (b, stats)) = (render(&clean), render(&spoiled));
        assert_eq!(stats.dropped_samples, 0, "{at:?}: NaN samples");
        let (a, b) = (mean(&green(&a)), mean(&green(&b)));
        assert!((a - b).abs() < 0.01 * a, "{k}: {at:?}: clean {a}, with one NaN {b}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
