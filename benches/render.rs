//! `cargo bench --bench render`: how fast the renderer renders the example
//! scenes at their specified settings (../shared/scenes/*/spec.md).
//!
//! Prints `name: value unit` lines: for each scene, the scene build time
//! (compile, meshes, BVH), the render time on one thread and on all, and
//! rays per second; for `heavy`, the BVH build of its 999,698 triangles
//! (the mesh is generated into `target/bench-gen/` first). Whole-process
//! comparisons with POV-Ray and Mitsuba are in `scripts/compare-peers.sh`.
//! A generated scene of a million spheres: `tslc check` and a small render
//! of it, whole processes, with peak memory (`-- objects` runs it alone).
//!
//! The per-hit split (`ir::split`): path-traced `bump_procedural`, `room`
//! and `texture_tree` rendered with each method compiled on its own (the
//! code before the split), split, and split with the optimising tier for
//! large functions (what renders of `render::OPTIMIZE_FROM_SAMPLES` or more
//! get), in turn, three times each; the medians, their ratios, the scene
//! builds, and the noise evaluated at
//! each camera hit of a textured object by the path tracer's calls there
//! (`Function::count_ops`: the interpreter, which counts).

use std::path::Path;
use std::time::Instant;
use tsl::render::{self, IntegratorKind, Overrides, RenderOptions, Scene};

fn figure(name: &str, value: f64, unit: &str) {
    println!("{name}: {value:.3} {unit}");
}

fn bench_scene(name: &str, file: &Path, spp: Option<u32>) {
    let start = Instant::now();
    let program = match tsl::Compiler::new().file(file).compile() {
        Ok(p) => p,
        Err(e) => {
            eprintln!("{e}");
            return;
        }
    };
    let scene = match Scene::build(&program, &Overrides { spp, ..Default::default() }) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{e}");
            return;
        }
    };
    figure(&format!("{name} scene build"), start.elapsed().as_secs_f64() * 1e3, "ms");
    let label = format!("{name} {}x{} {}spp", scene.settings.width, scene.settings.height, scene.settings.spp);
    let mut times = Vec::new();
    for threads in [1, 0] {
        let options = RenderOptions { threads, ..Default::default() };
        let Ok((_, stats)) = render::render(&scene, &options) else { return };
        let which = if threads == 1 { "1 thread".to_string() } else { format!("{} threads", stats.threads) };
        figure(&format!("{label} render {which}"), stats.seconds, "s");
        figure(&format!("{label} rays/s {which}"), stats.total_rays() as f64 / stats.seconds / 1e6, "M");
        times.push(stats.seconds);
    }
    figure(&format!("{label} speed-up"), times[0] / times[1], "x");
}

/// Noise evaluated at the first hit of camera rays over the image, by the
/// path tracer's calls there, counted by [`tsl::Function::count_ops`]:
/// `prepare` and the group's methods for a prepared object; otherwise
/// `sample`, the delta lobes, and for the lights either one `eval_pdf` each
/// or the reflection sum over the delta lights. Returns the mean per hit of
/// a textured object (one whose methods evaluate noise), and how many hits.
fn noise_per_hit(scene: &Scene) -> (f64, usize) {
    // Runs `f` through the interpreter, adding what it evaluated to `c`.
    fn run_counting(f: &tsl::Function, g: &tsl::ShadingGlobals, args: &[u32], out: &mut [u32], c: &mut tsl::OpCounts) {
        *c += f.count_ops(g, args, out).expect("the bench passes enough words");
    }
    let lanes = scene.model.lanes();
    let (width, height) = (scene.settings.width, scene.settings.height);
    let (mut total, mut hits) = (0.0, 0);
    let words = |xs: &[f32]| xs.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
    let mut out = vec![0u32; 64 + 2 * lanes];
    for py in (0..height).step_by(4) {
        for px in (0..width).step_by(4) {
            let Some((k, g, wo)) = render::camera_hit(scene, px, py) else { continue };
            let o = &scene.objects[k];
            let eta = vec![1.0f32; lanes];
            let hit_inputs = words(&[&wo[..], &eta[..]].concat());
            let (wi, u) = (words(&g.n), words(&[0.37, 0.61, 0.29]));
            let mut c = tsl::OpCounts::default();
            let lights = scene.lights.len();
            let [eval_pdf, delta_lobes, reflection_sum] = o.material.combined_functions();
            let facts = o.material.facts();
            match o.material.hit_group() {
                Some(h) => {
                    let mut record = vec![0u32; h.record_words()];
                    run_counting(h.prepare_function(), &g, &hit_inputs, &mut record, &mut c);
                    let own = |m| match m {
                        tsl::HitMethod::EvalPdf => (wi.clone(), lights),
                        tsl::HitMethod::DeltaLobes => (Vec::new(), usize::from(facts.reflects || facts.refracts)),
                        _ => (u.clone(), 1),
                    };
                    for m in tsl::PATH_METHODS {
                        let (args, times) = own(*m);
                        let args = [&record[..], &args[..]].concat();
                        for _ in 0..times {
                            if let Some(f) = h.method_function(*m) {
                                run_counting(f, &g, &args, &mut out, &mut c);
                            }
                        }
                    }
                }
                None => {
                    let sample_args = [&hit_inputs[..], &u[..]].concat();
                    if let Some(f) = o.material.method(tsl::check::Method::Sample) {
                        run_counting(f, &g, &sample_args, &mut out, &mut c);
                    }
                    if let Some(f) = delta_lobes {
                        run_counting(f, &g, &hit_inputs, &mut out, &mut c);
                    }
                    let delta = scene.lights.iter().filter(|l| l.is_delta()).count();
                    let summed = reflection_sum.filter(|_| delta > 0);
                    if let Some(f) = summed {
                        let mut args = Vec::new();
                        for _ in 0..delta {
                            args.extend(&wi);
                            args.extend(words(&eta));
                        }
                        args.extend(words(&wo));
                        run_counting(f, &g, &args, &mut out, &mut c);
                    }
                    let unsummed = if summed.is_some() { lights - delta } else { lights };
                    if let Some(f) = eval_pdf {
                        let args = [&wi[..], &hit_inputs[..]].concat();
                        for _ in 0..unsummed {
                            run_counting(f, &g, &args, &mut out, &mut c);
                        }
                    }
                }
            }
            if c.noise > 0.0 {
                total += c.noise;
                hits += 1;
            }
        }
    }
    (if hits > 0 { total / hits as f64 } else { 0.0 }, hits)
}

fn bench_split(name: &str, file: &Path) {
    let Ok(program) = tsl::Compiler::new().file(file).compile() else { return };
    // Per method (quick code), split (quick code), split with the
    // optimising tier for large functions (long renders get it).
    let variants = [("per method", true, false), ("split", false, false), ("split optimised", false, true)];
    let mut builds = [0.0; 3];
    let mut scenes = Vec::new();
    for (k, (_, unsplit, optimize)) in variants.into_iter().enumerate() {
        let overrides = Overrides {
            resolution: Some((160, 120)),
            spp: Some(4),
            integrator: Some(IntegratorKind::Path),
            unsplit,
            optimize_code: Some(optimize),
            ..Default::default()
        };
        let start = Instant::now();
        match Scene::build(&program, &overrides) {
            Ok(s) => scenes.push(s),
            Err(e) => {
                eprintln!("{e}");
                return;
            }
        }
        builds[k] = start.elapsed().as_secs_f64() * 1e3;
    }
    let mut times = [Vec::new(), Vec::new(), Vec::new()];
    for _ in 0..3 {
        for (k, scene) in scenes.iter().enumerate() {
            let Ok((_, stats)) = render::render(scene, &RenderOptions::default()) else { return };
            times[k].push(stats.seconds);
        }
    }
    let median = |t: &mut Vec<f64>| {
        t.sort_by(f64::total_cmp);
        t[t.len() / 2]
    };
    let label = format!("{name} path 160x120 4spp");
    let medians: Vec<f64> = times.iter_mut().map(median).collect();
    for (k, (which, _, _)) in variants.iter().enumerate() {
        figure(&format!("{label} scene build {which}"), builds[k], "ms");
        figure(&format!("{label} render {which}"), medians[k], "s");
    }
    figure(&format!("{label} split speed-up"), medians[0] / medians[1], "x");
    figure(&format!("{label} split optimised speed-up"), medians[0] / medians[2], "x");
    let prepared = scenes[1].objects.iter().filter(|o| o.material.is_prepared()).count();
    figure(&format!("{label} objects prepared (of {})", scenes[1].objects.len()), prepared as f64, "");
    // Noise run at the camera hits of textured objects, counted by the interpreter.
    for (unsplit, scene) in [true, false].into_iter().zip(&scenes) {
        let (noise, hits) = noise_per_hit(scene);
        let which = if unsplit { "per method" } else { "split" };
        figure(&format!("{label} noise evaluations per textured hit {which} (of {hits} hits)"), noise, "");
    }
}

/// Writes the generated scene of `count` spheres: a fixed pseudo-random
/// cloud (a 64-bit LCG, the same every run), one `object` block each, as
/// generated scenes are written.
fn write_spheres(w: &mut impl std::io::Write, count: u64) -> std::io::Result<()> {
    writeln!(w, "material red = lambert(kd: rgb(0.8, 0.2, 0.2));")?;
    writeln!(w, "scene {{")?;
    writeln!(w, "    camera {{ from (0, 0, -60); to (0, 0, 0); fov 40; }}")?;
    writeln!(w, "    light point {{ at (0, 50, -50); intensity rgb(5000, 5000, 5000); }}")?;
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        ((state >> 40) as f64 / (1u64 << 24) as f64) * 40.0 - 20.0
    };
    for _ in 0..count {
        let (x, y, z) = (next(), next(), next());
        writeln!(w, "    object sphere {{ center ({x:.3}, {y:.3}, {z:.3}); radius 0.05; material red; }}")?;
    }
    writeln!(w, "}}")
}

/// The generated scene of `TSL_BENCH_SCENE_OBJECTS` (default 100,000)
/// spheres, in memory and in this process: the time per object of each
/// stage of scene construction (parsing, checking, describing, building
/// the renderable scene with its BVH), medians of three runs.
fn bench_scene_construction() {
    let count: u64 = std::env::var("TSL_BENCH_SCENE_OBJECTS").ok().and_then(|s| s.parse().ok()).unwrap_or(100_000);
    let mut text = Vec::new();
    if write_spheres(&mut text, count).is_err() {
        return;
    }
    let text = String::from_utf8(text).unwrap_or_default();
    let options = tsl::LoadOptions::default();
    let stages = ["parse", "check", "describe", "build"];
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); stages.len()];
    for _ in 0..3 {
        let start = Instant::now();
        let (loaded, diags) = tsl::load::load_source("spheres.tsl", &text, &options);
        times[0].push(start.elapsed().as_secs_f64());
        let start = Instant::now();
        let (program, more) = tsl::check::check(loaded);
        times[1].push(start.elapsed().as_secs_f64());
        let start = Instant::now();
        let (scene, described) = tsl::scene::describe(&program, tsl::ColorModel::Rgb, None);
        times[2].push(start.elapsed().as_secs_f64());
        let diagnostics: Vec<_> = diags.into_iter().chain(more).chain(described).collect();
        let checked = tsl::Checked { program, scene, diagnostics };
        let start = Instant::now();
        let built = tsl::Compiler::new().compile_checked(checked).and_then(|p| {
            Scene::build(&p, &Overrides { resolution: Some((64, 64)), spp: Some(1), ..Default::default() })
        });
        if let Err(e) = built {
            eprintln!("{e}");
            return;
        }
        times[3].push(start.elapsed().as_secs_f64());
    }
    let mut total = 0.0;
    for (stage, t) in stages.iter().zip(&mut times) {
        t.sort_by(f64::total_cmp);
        total += t[1];
        figure(&format!("{count} spheres in memory: {stage} per object"), t[1] / count as f64 * 1e6, "us");
    }
    figure(&format!("{count} spheres in memory: total per object"), total / count as f64 * 1e6, "us");
}

/// A scene of `TSL_BENCH_OBJECTS` (default 1,000,000) spheres written out
/// ([`write_spheres`]): `tslc check` and a 64x64, 1 spp `tslc render` of
/// it, whole processes (issue 13's goals: 3 s and 6 s, under 1 GB), with
/// their peak memory from GNU time.
fn bench_many_objects() {
    let count: u64 = std::env::var("TSL_BENCH_OBJECTS").ok().and_then(|s| s.parse().ok()).unwrap_or(1_000_000);
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/bench-gen");
    let file = dir.join(format!("spheres-{count}.tsl"));
    if !file.exists() {
        use std::io::Write;
        let _ = std::fs::create_dir_all(&dir);
        let written = std::fs::File::create(&file).and_then(|f| {
            let mut w = std::io::BufWriter::new(f);
            write_spheres(&mut w, count)?;
            w.flush()
        });
        if let Err(e) = written {
            eprintln!("cannot write {}: {e}", file.display());
            return;
        }
    }
    let tslc = env!("CARGO_BIN_EXE_tslc");
    let image = dir.join("spheres.png");
    let runs: [(&str, Vec<&std::ffi::OsStr>); 2] = [
        ("check", vec!["check".as_ref(), file.as_os_str()]),
        (
            "render 64x64 1spp",
            vec![
                "render".as_ref(),
                file.as_os_str(),
                "--res".as_ref(),
                "64x64".as_ref(),
                "--spp".as_ref(),
                "1".as_ref(),
                "--quiet".as_ref(),
                "-o".as_ref(),
                image.as_os_str(),
            ],
        ),
    ];
    for (what, args) in runs {
        // GNU time prints the peak resident set (KB) on its last line.
        let start = Instant::now();
        let out = std::process::Command::new("/usr/bin/time").arg("-f").arg("%M").arg(tslc).args(&args).output();
        let seconds = start.elapsed().as_secs_f64();
        let Ok(out) = out else {
            eprintln!("{count} spheres {what}: needs GNU time (/usr/bin/time)");
            return;
        };
        if !out.status.success() {
            eprintln!("{count} spheres {what} failed: {}", String::from_utf8_lossy(&out.stderr));
            return;
        }
        let peak_kb: f64 =
            String::from_utf8_lossy(&out.stderr).lines().last().and_then(|l| l.trim().parse().ok()).unwrap_or(f64::NAN);
        figure(&format!("{count} spheres {what}"), seconds, "s");
        figure(&format!("{count} spheres {what} peak memory"), peak_kb / 1024.0, "MB");
    }
}

fn main() {
    if std::env::args().any(|a| a == "objects") {
        bench_scene_construction();
        bench_many_objects();
        return;
    }
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    bench_split("bump_procedural", &examples.join("techniques/bump_procedural.tsl"));
    bench_split("room", &examples.join("room.tsl"));
    bench_split("texture_tree", &examples.join("texture_tree.tsl"));
    // No slowdown where the trees are plain: the comparison scenes.
    bench_split("cornell", &examples.join("cornell.tsl"));
    bench_split("glossy", &examples.join("glossy.tsl"));
    if std::env::args().any(|a| a == "split") {
        return;
    }
    bench_scene_construction();
    bench_many_objects();
    bench_scene("whitted", &examples.join("whitted.tsl"), None);
    bench_scene("whitted", &examples.join("whitted.tsl"), Some(10));
    bench_scene("procedural", &examples.join("procedural.tsl"), None);
    bench_scene("procedural", &examples.join("procedural.tsl"), Some(10));
    bench_scene("cornell", &examples.join("cornell.tsl"), None);
    bench_scene("glossy", &examples.join("glossy.tsl"), None);
    bench_scene("envlight", &examples.join("envlight.tsl"), None);

    // heavy: generate the mesh once, then time the BVH over it.
    let gen_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/bench-gen");
    let obj = gen_dir.join("gen/heavy.obj");
    if !obj.exists() {
        let _ = std::fs::create_dir_all(obj.parent().unwrap_or(&gen_dir));
        let start = Instant::now();
        let written = std::fs::File::create(&obj).and_then(|f| {
            let mut w = std::io::BufWriter::new(f);
            render::heightfield::write_heavy_obj(&mut w)
        });
        if let Err(e) = written {
            eprintln!("cannot write {}: {e}", obj.display());
            return;
        }
        figure("heavy mesh generation", start.elapsed().as_secs_f64(), "s");
    }
    let scene_file = gen_dir.join("heavy.tsl");
    let text = std::fs::read_to_string(examples.join("heavy.tsl")).unwrap_or_default();
    if std::fs::write(&scene_file, text).is_err() {
        return;
    }
    let start = Instant::now();
    let mesh = render::mesh::Mesh::load(&obj, render::Mat4::IDENTITY);
    figure("heavy OBJ load", start.elapsed().as_secs_f64() * 1e3, "ms");
    if let Ok(mesh) = mesh {
        let bounds: Vec<_> = (0..mesh.triangles.len() as u32).map(|t| mesh.bounds(t)).collect();
        let start = Instant::now();
        let bvh = render::accel::Bvh::build(bounds.iter().copied());
        figure(&format!("heavy BVH build {} triangles", bvh.len()), start.elapsed().as_secs_f64() * 1e3, "ms");
    }
    bench_scene("heavy", &scene_file, None);
}
