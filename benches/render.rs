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
//! code before the split) and split, alternately, three times each; the
//! medians, their ratio, both scene builds, and the noise sites run per
//! path vertex (static: a site in a loop counts once).

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

/// Noise sites in `f`: native calls plus inline expansions, which read
/// their gradient table at each corner of the lattice cell (2, 4 or 8).
fn noise_sites(f: &tsl::ir::Function) -> usize {
    let (mut calls, mut corners) = (0, 0.0);
    tsl::ir::for_each_op(&f.body, &mut |op| match op {
        tsl::ir::Op::Call { native, .. } if native.contains("noise") => calls += 1,
        tsl::ir::Op::Table { table, .. } => {
            corners += match tsl::runtime::table_name(table) {
                Some("grad1") => 0.5,
                Some("grad2.x") => 0.25,
                Some("grad3.x") => 0.125,
                _ => 0.0,
            }
        }
        _ => {}
    });
    calls + corners as usize
}

fn bench_split(name: &str, file: &Path) {
    let Ok(program) = tsl::Compiler::new().file(file).compile() else { return };
    let overrides = |unsplit| Overrides {
        resolution: Some((160, 120)),
        spp: Some(4),
        integrator: Some(IntegratorKind::Path),
        unsplit,
        ..Default::default()
    };
    let mut builds = [0.0; 2];
    let mut scenes = Vec::new();
    for (k, unsplit) in [true, false].into_iter().enumerate() {
        let start = Instant::now();
        match Scene::build(&program, &overrides(unsplit)) {
            Ok(s) => scenes.push(s),
            Err(e) => {
                eprintln!("{e}");
                return;
            }
        }
        builds[k] = start.elapsed().as_secs_f64() * 1e3;
    }
    let mut times = [Vec::new(), Vec::new()];
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
    let (before, after) = (median(&mut times[0]), median(&mut times[1]));
    let label = format!("{name} path 160x120 4spp");
    figure(&format!("{label} scene build per method"), builds[0], "ms");
    figure(&format!("{label} scene build split"), builds[1], "ms");
    figure(&format!("{label} render per method"), before, "s");
    figure(&format!("{label} render split"), after, "s");
    figure(&format!("{label} split speed-up"), before / after, "x");
    let prepared = scenes[1].objects.iter().filter(|o| o.hit.is_some()).count();
    figure(&format!("{label} objects prepared (of {})", scenes[1].objects.len()), prepared as f64, "");
    // Per vertex: sample, eval_pdf and the delta lobes, on their own or
    // after prepare (the first object with a texture counts).
    for (unsplit, scene) in [true, false].into_iter().zip(&scenes) {
        let sites: Option<usize> = scene
            .objects
            .iter()
            .map(|o| match (&o.hit, unsplit) {
                (Some(h), false) => {
                    let methods = [tsl::ir::lower::HitMethod::Interface("sample"), tsl::ir::lower::HitMethod::EvalPdf];
                    noise_sites(h.prepare_function().ir())
                        + methods
                            .iter()
                            .filter_map(|m| h.method_function(*m))
                            .map(|f| noise_sites(f.ir()))
                            .sum::<usize>()
                }
                _ => {
                    noise_sites(o.sample.ir())
                        + o.eval_pdf.as_ref().map_or(0, |f| noise_sites(f.ir()))
                        + o.delta_lobes.as_ref().map_or(0, |f| noise_sites(f.ir()))
                }
            })
            .max();
        let which = if unsplit { "per method" } else { "split" };
        figure(
            &format!("{label} noise sites per vertex {which} (most textured object)"),
            sites.unwrap_or(0) as f64,
            "",
        );
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
