//! `cargo bench --bench render`: how fast the renderer renders the example
//! scenes at their specified settings (../shared/scenes/*/spec.md).
//!
//! Prints `name: value unit` lines: for each scene, the scene build time
//! (compile, meshes, BVH), the render time on one thread and on all, and
//! rays per second; for `heavy`, the BVH build of its 999,698 triangles
//! (the mesh is generated into `target/bench-gen/` first). Whole-process
//! comparisons with POV-Ray and Mitsuba are in `scripts/compare-peers.sh`.
//!
//! The per-hit split (`ir::split`): path-traced `bump_procedural`, `room`
//! and `texture_tree` rendered with each method compiled on its own (the
//! code before the split), split, and split with the optimising tier for
//! large functions (what renders of `render::OPTIMIZE_FROM_SAMPLES` or more
//! get), in turn, three times each; the medians, their ratios, the scene
//! builds, and the noise evaluated at
//! each camera hit of a textured object by the path tracer's calls there
//! (run through the interpreter, which counts).

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
/// path tracer's calls there, run through the interpreter (which counts):
/// `prepare` and the group's methods for a prepared object; otherwise
/// `sample`, the delta lobes, and for the lights either one `eval_pdf` each
/// or the reflection sum over the delta lights. Returns the mean per hit of
/// a textured object (one whose methods evaluate noise), and how many hits.
fn noise_per_hit(scene: &Scene) -> (f64, usize) {
    use tsl::interp::{Counts, run_counting};
    let lanes = scene.model.lanes();
    let (width, height) = (scene.settings.width, scene.settings.height);
    let (mut total, mut hits) = (0.0, 0);
    let words = |xs: &[f32]| xs.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
    let mut out = vec![0u32; 64 + 2 * lanes];
    for py in (0..height).step_by(4) {
        for px in (0..width).step_by(4) {
            let Some((k, g, wo)) = render::camera_hit(scene, px, py) else { continue };
            let o = &scene.objects[k];
            let globals = g.words();
            let eta = vec![1.0f32; lanes];
            let hit_inputs = words(&[&wo[..], &eta[..]].concat());
            let (wi, u) = (words(&g.n), words(&[0.37, 0.61, 0.29]));
            let mut c = Counts::default();
            let lights = scene.lights.len();
            match &o.hit {
                Some(h) => {
                    let mut record = vec![0u32; h.record_words()];
                    run_counting(h.prepare_function().ir(), &globals, &hit_inputs, &mut record, &mut c);
                    let own = |m| match m {
                        tsl::ir::lower::HitMethod::EvalPdf => (wi.clone(), lights),
                        tsl::ir::lower::HitMethod::DeltaLobes => (Vec::new(), usize::from(o.reflects || o.refracts)),
                        _ => (u.clone(), 1),
                    };
                    for m in tsl::PATH_METHODS {
                        let (args, times) = own(*m);
                        let args = [&record[..], &args[..]].concat();
                        for _ in 0..times {
                            if let Some(f) = h.method_function(*m) {
                                run_counting(f.ir(), &globals, &args, &mut out, &mut c);
                            }
                        }
                    }
                }
                None => {
                    let sample_args = [&hit_inputs[..], &u[..]].concat();
                    run_counting(o.sample.ir(), &globals, &sample_args, &mut out, &mut c);
                    if let Some(f) = &o.delta_lobes {
                        run_counting(f.ir(), &globals, &hit_inputs, &mut out, &mut c);
                    }
                    let delta = scene.lights.iter().filter(|l| l.is_delta()).count();
                    let summed = o.reflection_sum.as_ref().filter(|_| delta > 0);
                    if let Some(f) = summed {
                        let mut args = Vec::new();
                        for _ in 0..delta {
                            args.extend(&wi);
                            args.extend(words(&eta));
                        }
                        args.extend(words(&wo));
                        run_counting(f.ir(), &globals, &args, &mut out, &mut c);
                    }
                    let unsummed = if summed.is_some() { lights - delta } else { lights };
                    if let Some(f) = &o.eval_pdf {
                        let args = [&wi[..], &hit_inputs[..]].concat();
                        for _ in 0..unsummed {
                            run_counting(f.ir(), &globals, &args, &mut out, &mut c);
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
    let prepared = scenes[1].objects.iter().filter(|o| o.hit.is_some()).count();
    figure(&format!("{label} objects prepared (of {})", scenes[1].objects.len()), prepared as f64, "");
    // Noise run at the camera hits of textured objects, counted by the interpreter.
    for (unsplit, scene) in [true, false].into_iter().zip(&scenes) {
        let (noise, hits) = noise_per_hit(scene);
        let which = if unsplit { "per method" } else { "split" };
        figure(&format!("{label} noise evaluations per textured hit {which} (of {hits} hits)"), noise, "");
    }
}

fn main() {
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
    let mesh = render::mesh::Mesh::load_obj(&obj, render::Mat4::IDENTITY);
    figure("heavy OBJ load", start.elapsed().as_secs_f64() * 1e3, "ms");
    if let Ok(mesh) = mesh {
        let bounds: Vec<_> = (0..mesh.triangles.len() as u32).map(|t| mesh.bounds(t)).collect();
        let start = Instant::now();
        let bvh = render::accel::Bvh::build(&bounds);
        figure(&format!("heavy BVH build {} triangles", bvh.len()), start.elapsed().as_secs_f64() * 1e3, "ms");
    }
    bench_scene("heavy", &scene_file, None);
}
