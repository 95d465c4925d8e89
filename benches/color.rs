//! `cargo bench --bench color`: what each color model costs, relative to
//! RGB (issue 16).
//!
//! - Render time per sample of `cornell` (path traced) and `procedural`
//!   (Whitted) in every model, on one thread, each model rendered five
//!   times interleaved with the others; medians and their ratio to RGB.
//!   Goal: hero sampling at most 1.3x RGB.
//! - A texel: `texture(...)` of a 512 x 512 image of random colors at
//!   random coordinates (bilinear), compiled, called a million times in
//!   `rgb`, `spectral16` (texels converted to Jakob–Hanika spectra at load,
//!   blended per lookup), `hero` and `smits16` (Smits' basis applied to the
//!   filtered RGB); medians of five and the ratio to Smits. Goal:
//!   Jakob–Hanika no slower than Smits by more than 10%. On a busy
//!   machine, count instructions instead: `TSL_BENCH_MODEL=spectral16
//!   TSL_BENCH_CALLS=20000 valgrind --tool=callgrind
//!   --toggle-collect='*call_words*' target/release/deps/color-… texel`.
//! - RGB upsampling of values known only at run time (procedural colors):
//!   `rgb(r, g, b)` of varying numbers in `spectral16` (Jakob–Hanika's
//!   coefficient table looked up in the code) and `smits16`.
//!
//! Each figure is a `name: value unit` line.

use std::time::Instant;
use tsl::render::{self, Overrides, RenderOptions, Scene};
use tsl::{Backend, ColorModel, Compiler, ShadingGlobals};

const MODELS: [ColorModel; 6] = [
    ColorModel::Rgb,
    ColorModel::Hero,
    ColorModel::Spectral { samples: 16 },
    ColorModel::Spectral { samples: 64 },
    ColorModel::Smits { samples: 16 },
    ColorModel::Smits { samples: 64 },
];

fn median(mut xs: Vec<f64>) -> f64 {
    xs.sort_by(f64::total_cmp);
    xs[xs.len() / 2]
}

fn bench_scene(name: &str, res: (u32, u32), spp: u32) {
    let file = format!("examples/{name}.tsl");
    let scenes: Vec<Scene> = MODELS
        .iter()
        .map(|&model| {
            let program = Compiler::new().color_model(model).file(&file).compile().expect("compiles");
            let overrides = Overrides { resolution: Some(res), spp: Some(spp), ..Default::default() };
            Scene::build(&program, &overrides).expect("builds")
        })
        .collect();
    let options = RenderOptions { threads: 1, ..Default::default() };
    let mut times = vec![Vec::new(); MODELS.len()];
    for _ in 0..5 {
        for (scene, t) in scenes.iter().zip(&mut times) {
            let (_, stats) = render::render(scene, &options).expect("renders");
            t.push(stats.seconds);
        }
    }
    let rgb = median(times[0].clone());
    for (model, t) in MODELS.iter().zip(times) {
        let m = median(t);
        println!("{name} {}x{} {spp}spp {}: {:.3} s, {:.2} x rgb", res.0, res.1, model.name(), m, m / rgb);
    }
}

fn bench_upsampling() {
    let source = "color up(float r, float g, float b) { return rgb(r, g, b); }";
    let models = [ColorModel::Spectral { samples: 16 }, ColorModel::Smits { samples: 16 }];
    let functions: Vec<_> = models
        .iter()
        .map(|&m| {
            let p = Compiler::new().color_model(m).source("up.tsl", source).compile().expect("compiles");
            (p.clone(), p.function("up").expect("entry"))
        })
        .collect();
    let g = ShadingGlobals::default();
    let mut out = [0u32; 64];
    let calls = std::env::var("TSL_BENCH_CALLS").ok().and_then(|n| n.parse().ok()).unwrap_or(1_000_000u32);
    let mut times = vec![Vec::new(); models.len()];
    for _ in 0..5 {
        for ((_, f), t) in functions.iter().zip(&mut times) {
            let start = Instant::now();
            let mut state = 12345u32;
            for _ in 0..calls {
                // Texel-like values: a cheap hash to three numbers in [0, 1).
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                let rgb = [state >> 8, (state >> 16) ^ state, state.rotate_left(11)]
                    .map(|x| ((x & 0xffff) as f32 / 65536.0).to_bits());
                f.call_words(Backend::Jit, &g, &rgb, &mut out).expect("call");
            }
            t.push(start.elapsed().as_secs_f64() / f64::from(calls) * 1e9);
        }
    }
    let ns: Vec<f64> = times.into_iter().map(median).collect();
    for (model, t) in models.iter().zip(&ns) {
        println!("rgb upsampling of a run-time value, {}: {t:.1} ns", model.name());
    }
    println!("rgb upsampling jakob-hanika / smits (16 lanes): {:.2} x", ns[0] / ns[1]);
}

/// Nanoseconds per call of `f(args)` over a million calls, medians of five
/// interleaved runs, one per program; `args(k)` gives call `k`'s arguments.
fn time_calls(functions: &[tsl::Function], g: &ShadingGlobals, args: impl Fn(u32) -> [u32; 3]) -> Vec<f64> {
    let mut out = [0u32; 64];
    let calls = std::env::var("TSL_BENCH_CALLS").ok().and_then(|n| n.parse().ok()).unwrap_or(1_000_000u32);
    let mut times = vec![Vec::new(); functions.len()];
    for _ in 0..5 {
        for (f, t) in functions.iter().zip(&mut times) {
            let start = Instant::now();
            for k in 0..calls {
                f.call_words(Backend::Jit, g, &args(k), &mut out).expect("call");
            }
            t.push(start.elapsed().as_secs_f64() / f64::from(calls) * 1e9);
        }
    }
    times.into_iter().map(median).collect()
}

/// A cheap hash of `k` to three numbers in [0, 1), as words.
fn hash3(k: u32) -> [u32; 3] {
    let state = k.wrapping_mul(1_664_525).wrapping_add(1_013_904_223).wrapping_mul(0x9e37_79b9);
    [state >> 8, (state >> 16) ^ state, state.rotate_left(11)].map(|x| ((x & 0xffff) as f32 / 65536.0).to_bits())
}

fn bench_texels() {
    let dir = std::env::temp_dir().join(format!("tsl-bench-color-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("random.png");
    let image = image::RgbImage::from_fn(512, 512, |x, y| {
        let [r, g, b] = hash3(x * 512 + y).map(|w| (f32::from_bits(w) * 255.0) as u8);
        image::Rgb([r, g, b])
    });
    image.save(&path).expect("writes the image");
    let source = format!(
        "color tex(float s, float t) {{ return texture(\"{}\", (s, t), filter: \"bilinear\"); }}",
        path.display()
    );
    let mut models = vec![
        ColorModel::Rgb,
        ColorModel::Spectral { samples: 16 },
        ColorModel::Hero,
        ColorModel::Smits { samples: 16 },
    ];
    // One model alone, for instruction counts under callgrind.
    if let Ok(name) = std::env::var("TSL_BENCH_MODEL") {
        models.retain(|m| m.name() == name);
    }
    let programs: Vec<_> = models
        .iter()
        .map(|&m| Compiler::new().color_model(m).source("tex.tsl", &source).compile().expect("compiles"))
        .collect();
    let functions: Vec<_> = programs.iter().map(|p| p.function("tex").expect("entry")).collect();
    let g = ShadingGlobals::default();
    let ns = time_calls(&functions, &g, hash3);
    for (model, t) in models.iter().zip(&ns) {
        println!("texel lookup (bilinear, random texels), {}: {t:.1} ns", model.name());
    }
    if ns.len() == 4 {
        println!("texel lookup jakob-hanika / smits (16 lanes): {:.2} x", ns[1] / ns[3]);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

fn main() {
    let only = std::env::args().skip(1).find(|a| !a.starts_with('-'));
    let part = |name: &str| only.as_deref().is_none_or(|o| name.contains(o));
    if part("texel") {
        bench_texels();
    }
    if part("upsampling") {
        bench_upsampling();
    }
    if part("cornell") {
        bench_scene("cornell", (128, 128), 16);
    }
    if part("procedural") {
        bench_scene("procedural", (320, 240), 4);
    }
}
