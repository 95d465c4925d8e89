//! `cargo bench --bench color_convert`: nanoseconds per call of
//! `Color::to_rgb` and `Color::brightness` in each color model (issue 30:
//! under 0.1 µs in every model; 16.8 µs before the weights were cached,
//! when each call integrated the CIE table again).
//!
//! As criterion does: one warm-up call, then the number of calls that
//! takes about 20 ms is found by doubling, and seven samples of that many
//! calls are timed; the median and the fastest sample are printed, one
//! `name: value unit` line per model and call. `cargo bench --bench
//! color_convert -- brightness` runs the lines whose name contains
//! `brightness` only.

use std::hint::black_box;
use std::time::{Duration, Instant};
use tsl::{Color, ColorModel};

const MODELS: [ColorModel; 8] = [
    ColorModel::Rgb,
    ColorModel::Hero,
    ColorModel::Spectral { samples: 4 },
    ColorModel::Spectral { samples: 16 },
    ColorModel::Spectral { samples: 64 },
    ColorModel::Smits { samples: 4 },
    ColorModel::Smits { samples: 16 },
    ColorModel::Smits { samples: 64 },
];

/// The time one sample should take.
const SAMPLE_TIME: Duration = Duration::from_millis(20);
const SAMPLES: usize = 7;

/// (median, fastest) nanoseconds per call of `f`.
fn time_per_call(mut f: impl FnMut()) -> (f64, f64) {
    f();
    let mut calls = 1u64;
    loop {
        let start = Instant::now();
        (0..calls).for_each(|_| f());
        if start.elapsed() >= SAMPLE_TIME || calls >= 1 << 30 {
            break;
        }
        calls *= 2;
    }
    let mut ns: Vec<f64> = (0..SAMPLES)
        .map(|_| {
            let start = Instant::now();
            (0..calls).for_each(|_| f());
            start.elapsed().as_secs_f64() * 1e9 / calls as f64
        })
        .collect();
    ns.sort_by(f64::total_cmp);
    (ns[SAMPLES / 2], ns[0])
}

/// A color of the model with lanes that vary (a spectrum, or an RGB triple).
fn sample_color(model: ColorModel) -> Color {
    let lanes: Vec<f32> = (0..model.lanes()).map(|i| 0.2 + 0.6 * ((i as f32 * 0.37).sin() * 0.5 + 0.5)).collect();
    Color::from_lanes(model, &lanes)
}

fn main() {
    let only = std::env::args().skip(1).find(|a| !a.starts_with('-'));
    let wanted = |name: &str| only.as_deref().is_none_or(|o| name.contains(o));
    for model in MODELS {
        let color = sample_color(model);
        let name = format!("to_rgb {}", model.name());
        if wanted(&name) {
            let (median, fastest) = time_per_call(|| {
                black_box(black_box(&color).to_rgb());
            });
            println!("{name}: {median:.1} ns (fastest sample {fastest:.1} ns)");
        }
        let name = format!("brightness {}", model.name());
        if wanted(&name) {
            let (median, fastest) = time_per_call(|| {
                black_box(black_box(&color).brightness());
            });
            println!("{name}: {median:.1} ns (fastest sample {fastest:.1} ns)");
        }
    }
}
