//! `cargo bench --bench render`: how fast the renderer renders the example
//! scenes at their specified settings (../shared/scenes/*/spec.md).
//!
//! Prints `name: value unit` lines: for each scene, the scene build time
//! (compile, meshes, BVH), the render time on one thread and on all, and
//! rays per second; for `heavy`, the BVH build of its 999,698 triangles
//! (the mesh is generated into `target/bench-gen/` first). Whole-process
//! comparisons with POV-Ray and Mitsuba are in `scripts/compare-peers.sh`.

use std::path::Path;
use std::time::Instant;
use tsl::render::{self, Overrides, RenderOptions, Scene};

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

fn main() {
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
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
