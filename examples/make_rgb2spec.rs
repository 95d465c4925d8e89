//! Writes `src/color/data/rgb2spec_srgb.bin`, the Jakob–Hanika (2019)
//! coefficient table of the spectral color models: every cell fitted by
//! Gauss–Newton against the CIE 1931 observer, D65 and the sRGB primaries
//! (`tsl::color::jakob_hanika::fit_table`), then prints how well lookups in
//! it round-trip. Run from the repository root:
//!
//! ```sh
//! cargo run --release --example make_rgb2spec                  # about 30 s on two cores
//! cargo run --release --example make_rgb2spec -- OUT.bin [RES]  # elsewhere, another resolution
//! ```
//!
//! The output is deterministic (each column is fitted in its own order),
//! so running it again reproduces the committed file bit for bit.

use tsl::color::jakob_hanika::{self, RES, Table, fit_table};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let out = args.next().unwrap_or_else(|| "src/color/data/rgb2spec_srgb.bin".into());
    let res = match args.next() {
        Some(r) => r.parse()?,
        None => RES,
    };
    let start = std::time::Instant::now();
    let table = fit_table(res);
    std::fs::write(&out, table.to_bytes())?;
    eprintln!("{out}: {res}^3 x 3 cells in {:.1} s", start.elapsed().as_secs_f64());
    report(&table);
    Ok(())
}

/// Where the `i`-th of a set of random colours is put.
type Place = fn([f32; 3], usize) -> [f32; 3];

/// Worst and typical round-trip errors of lookups in `table` (no
/// refinement; `jakob_hanika::upsample` with it) on random reflectances:
/// over all of `[0, 1]³`, near white, and on the cube's faces (a channel at
/// 0 or 1, as 8-bit texels often are).
fn report(table: &Table) {
    let mut state = 1u64;
    let mut uniform = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let sets: [(&str, usize, Place); 3] = [
        ("random RGB in [0, 1]^3", 200_000, |c, _| c),
        ("random RGB in [0.8, 1]^3", 20_000, |c, _| c.map(|x| 0.8 + 0.2 * x)),
        ("random RGB on the faces of [0, 1]^3", 120_000, |mut c, i| {
            c[i % 3] = (i / 3 % 2) as f32;
            c
        }),
    ];
    for (what, count, place) in sets {
        let mut errors: Vec<f64> = (0..count)
            .map(|i| {
                let rgb = place([uniform(), uniform(), uniform()], i);
                let s = jakob_hanika::upsample_in(table, rgb);
                let back = jakob_hanika::reflectance_to_rgb(|l| s.eval64(l));
                (0..3).map(|c| (back[c] - f64::from(rgb[c])).abs()).fold(0.0, f64::max)
            })
            .collect();
        errors.sort_by(f64::total_cmp);
        let q = |p: f64| errors[((errors.len() - 1) as f64 * p) as usize];
        eprintln!("round trips of {count} {what}: median {:.2e}, 99% {:.2e}, worst {:.2e}", q(0.5), q(0.99), q(1.0));
    }
}
