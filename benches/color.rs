//! `cargo bench --bench color`: what each color model costs, relative to
//! RGB (issue 16).
//!
//! - Render time per sample of `cornell` (path traced) and `procedural`
//!   (Whitted) in every model, on one thread, each model rendered five
//!   times interleaved with the others; medians and their ratio to RGB.
//!   Goal: hero sampling at most 1.3x RGB.
//! - RGB upsampling of values known only at run time (what a texel costs):
//!   `rgb(r, g, b)` of varying numbers, compiled, called a million times in
//!   `spectral16` (Jakob–Hanika's table lookup) and `smits16` (Smits'
//!   basis); medians of five and their ratio. Goal: Jakob–Hanika no slower
//!   than Smits by more than 10%.
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
    let calls = 1_000_000u32;
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

fn main() {
    let only = std::env::args().skip(1).find(|a| !a.starts_with('-'));
    let part = |name: &str| only.as_deref().is_none_or(|o| name.contains(o));
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
