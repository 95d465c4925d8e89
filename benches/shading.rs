//! `cargo bench --bench shading`: how fast compiled materials shade.
//!
//! Prints `name: value unit` lines:
//! - marble and wood, 1M shading points: JIT vs interpreter vs the same
//!   shader hand-written in Rust (calling the same noise natives);
//!   goals: JIT ≥ 20× the interpreter, within 1.3× of hand-written Rust;
//! - compile time, source to callable code, for the stdlib and each example;
//!   goal: under 50 ms;
//! - spectral (16 samples) vs RGB cost of the same material;
//! - texture lookups (bilinear, trilinear) and noise evaluations per
//!   second, called from JIT code; goal: trilinear under 50 ns;
//! - batches: a material's `reflection` over 64K points in one batch
//!   (`Material::at_batch`) vs a surface per point; goal: no slower.
//!
//! Ratios are measured in one run, interleaved, so machine noise affects
//! both sides alike.

use std::f32::consts::PI;
use std::hint::black_box;
use std::time::{Duration, Instant};
use tsl::noise::noise3;
use tsl::{Backend, ColorModel, Compiler, Material, Program, ShadingGlobals};

const SOURCE: &str = r#"
float marble_fbm(point p) {
    float sum = 0;
    float amp = 0.5;
    point q = p;
    for o in 0..6 {
        sum += amp * noise(q);
        q = q * 2.03;
        amp *= 0.5;
    }
    return sum;
}

// Marble: fBm noise, a color spline, Phong.
material marble(color ks = gray(0.25), float ns = 40) {
    color reflection(vector wi, color light, vector wo) {
        float t = 0.5 + 0.5 * sin(Pl.x * 4 + 6 * marble_fbm(Pl * 2));
        color kd = blend(t, [rgb(0.9, 0.9, 0.85), rgb(0.55, 0.5, 0.5), rgb(0.2, 0.2, 0.25), rgb(0.9, 0.88, 0.8)], spline: true);
        float cos_i = dot(N, wi);
        if cos_i <= 0 {
            return black();
        }
        vector r = reflect(-wi, N);
        float lobe = pow(max(dot(r, wo), 0), ns) * (ns + 2) / (2 * PI);
        return light * (kd / PI + ks * lobe) * cos_i;
    }
}

float rings() { return fract(length(vec2(Pl.x, Pl.z)) * 8 + 0.3 * noise(Pl * 2)); }

// Wood: a texture tree, two Phong materials mixed by a ring generator.
material wood = mix(rings(), phong(kd: rgb(0.6, 0.4, 0.2)), phong(kd: rgb(0.35, 0.2, 0.08)));
"#;

// ---------------------------------------------------------------- hand-written Rust

type V3 = [f32; 3];

fn dot(a: V3, b: V3) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn reflect(i: V3, n: V3) -> V3 {
    let d = 2.0 * dot(n, i);
    [i[0] - d * n[0], i[1] - d * n[1], i[2] - d * n[2]]
}

fn marble_fbm(p: V3) -> f32 {
    let (mut sum, mut amp, mut q) = (0.0, 0.5, p);
    for _ in 0..6 {
        sum += amp * noise3(q[0], q[1], q[2]);
        q = [q[0] * 2.03, q[1] * 2.03, q[2] * 2.03];
        amp *= 0.5;
    }
    sum
}

fn spline(t: f32, knots: &[[f32; 3]; 4]) -> [f32; 3] {
    let x = t.clamp(0.0, 1.0) * 3.0;
    let seg = x.floor().min(2.0);
    let f = x - seg;
    let s = seg as i32;
    let (f2, f3) = (f * f, f * f * f);
    let w = [
        0.5 * (-f3 + 2.0 * f2 - f),
        0.5 * (3.0 * f3 - 5.0 * f2 + 2.0),
        0.5 * (-3.0 * f3 + 4.0 * f2 + f),
        0.5 * (f3 - f2),
    ];
    let mut c = [0.0; 3];
    for (j, wj) in w.iter().enumerate() {
        let k = (s + j as i32 - 1).clamp(0, 3) as usize;
        for ch in 0..3 {
            c[ch] += wj * knots[k][ch];
        }
    }
    c
}

fn marble_rust(g: &ShadingGlobals, wi: V3, light: [f32; 3], wo: V3) -> [f32; 3] {
    let pl = g.pl;
    let t = 0.5 + 0.5 * (pl[0] * 4.0 + 6.0 * marble_fbm([pl[0] * 2.0, pl[1] * 2.0, pl[2] * 2.0])).sin();
    let kd = spline(t, &[[0.9, 0.9, 0.85], [0.55, 0.5, 0.5], [0.2, 0.2, 0.25], [0.9, 0.88, 0.8]]);
    let cos_i = dot(g.n, wi);
    if cos_i <= 0.0 {
        return [0.0; 3];
    }
    let r = reflect([-wi[0], -wi[1], -wi[2]], g.n);
    let (ks, ns) = (0.25, 40.0);
    let lobe = dot(r, wo).max(0.0).powf(ns) * (ns + 2.0) / (2.0 * PI);
    let mut out = [0.0; 3];
    for c in 0..3 {
        out[c] = light[c] * (kd[c] / PI + ks * lobe) * cos_i;
    }
    out
}

fn phong_rust(g: &ShadingGlobals, kd: [f32; 3], wi: V3, light: [f32; 3], wo: V3) -> [f32; 3] {
    let mut n = g.n;
    if dot(n, [-wo[0], -wo[1], -wo[2]]) >= 0.0 {
        n = [-n[0], -n[1], -n[2]];
    }
    let cos_i = dot(n, wi);
    if cos_i <= 0.0 {
        return [0.0; 3];
    }
    let r = reflect([-wi[0], -wi[1], -wi[2]], n);
    let ns = 32.0;
    let lobe = dot(r, wo).max(0.0).powf(ns) * (ns + 2.0) / (2.0 * PI);
    let mut out = [0.0; 3];
    for c in 0..3 {
        out[c] = light[c] * (kd[c] / PI + 0.2 * lobe) * cos_i;
    }
    out
}

fn wood_rust(g: &ShadingGlobals, wi: V3, light: [f32; 3], wo: V3) -> [f32; 3] {
    let pl = g.pl;
    let len = (pl[0] * pl[0] + pl[2] * pl[2]).sqrt();
    let x = len * 8.0 + 0.3 * noise3(pl[0] * 2.0, pl[1] * 2.0, pl[2] * 2.0);
    let t = x - x.floor();
    let a = if t != 1.0 { phong_rust(g, [0.6, 0.4, 0.2], wi, light, wo) } else { [0.0; 3] };
    let b = if t != 0.0 { phong_rust(g, [0.35, 0.2, 0.08], wi, light, wo) } else { [0.0; 3] };
    [a[0] * (1.0 - t) + b[0] * t, a[1] * (1.0 - t) + b[1] * t, a[2] * (1.0 - t) + b[2] * t]
}

// ---------------------------------------------------------------- harness

/// Shading points on a sphere seen from +z: normals toward the viewer.
fn points(n: usize) -> Vec<ShadingGlobals> {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..n)
        .map(|_| {
            let (x, y) = (next() * 2.0 - 1.0, next() * 2.0 - 1.0);
            let z = (1.0 - (x * x + y * y).min(1.0)).sqrt();
            let p = [x, y, z];
            ShadingGlobals { p, pl: p, n: p, ng: p, u: next(), v: next(), ..Default::default() }
        })
        .collect()
}

const WI: V3 = [-0.48, 0.6, 0.64];
const WO: V3 = [0.0, 0.0, 1.0];

fn time(reps: usize, pts: &[ShadingGlobals], mut f: impl FnMut(&ShadingGlobals) -> f32) -> Duration {
    let start = Instant::now();
    let mut acc = 0.0;
    for _ in 0..reps {
        for g in pts {
            acc += f(g);
        }
    }
    black_box(acc);
    start.elapsed()
}

fn best_of(runs: usize, mut f: impl FnMut() -> Duration) -> Duration {
    (0..runs).map(|_| f()).min().unwrap_or_default()
}

fn ns_per_point(d: Duration, n: usize) -> f64 {
    d.as_secs_f64() * 1e9 / n as f64
}

fn program(model: ColorModel) -> Program {
    Compiler::new().color_model(model).source("bench.tsl", SOURCE).compile().expect("the benchmark program compiles")
}

fn bench_material(name: &str, m: &Material, p: &Program, rust: fn(&ShadingGlobals, V3, [f32; 3], V3) -> [f32; 3]) {
    let pts = points(1 << 16);
    let reps = 16; // 1M points in all
    let light = p.rgb(1.0, 1.0, 1.0);
    // The hand-written shader must compute what the TSL one does.
    for g in pts.iter().take(64) {
        let a = m.reflection(g, WI, &light, WO).lanes().to_vec();
        let b = rust(g, WI, [1.0; 3], WO);
        for c in 0..3 {
            assert!((a[c] - b[c]).abs() <= 1e-4 * a[c].abs().max(1.0), "{name}: jit {a:?} vs rust {b:?}");
        }
    }
    let f = p.function(&format!("{name}.reflection")).expect("compiled");
    let mut args: Vec<u32> = Vec::new();
    args.extend(WI.map(f32::to_bits));
    args.extend([1.0f32; 3].map(f32::to_bits));
    args.extend(WO.map(f32::to_bits));
    let mut out = [0u32; 3];
    let mut jit = Duration::MAX;
    let mut into = Duration::MAX;
    let mut raw = Duration::MAX;
    let mut hand = Duration::MAX;
    for _ in 0..5 {
        jit = jit.min(time(reps, &pts, |g| m.reflection(g, WI, &light, WO).lanes()[0]));
        let mut buf = [0.0f32; 3];
        into = into.min(time(reps, &pts, |g| {
            m.reflection_into(g, WI, &[1.0; 3], WO, &mut buf);
            buf[0]
        }));
        raw = raw.min(time(reps, &pts, |g| {
            let _ = f.call_words(Backend::Jit, g, &args, &mut out);
            f32::from_bits(out[0])
        }));
        hand = hand.min(time(reps, &pts, |g| rust(g, WI, [1.0; 3], WO)[0]));
    }
    let interp_pts = &pts[..1 << 14];
    let interp = best_of(5, || {
        time(1, interp_pts, |g| {
            let _ = f.call_words(Backend::Interpreter, g, &args, &mut out);
            f32::from_bits(out[0])
        })
    });
    let n = pts.len() * reps;
    let (jit_ns, raw_ns, hand_ns) = (ns_per_point(jit, n), ns_per_point(raw, n), ns_per_point(hand, n));
    let into_ns = ns_per_point(into, n);
    let interp_ns = ns_per_point(interp, interp_pts.len());
    println!("{name} jit (Material::reflection): {jit_ns:.1} ns/point");
    println!("{name} jit (Material::reflection_into): {into_ns:.1} ns/point");
    println!("{name} jit (raw call): {raw_ns:.1} ns/point");
    println!("{name} hand-written rust: {hand_ns:.1} ns/point");
    println!("{name} interpreter: {interp_ns:.1} ns/point");
    println!("{name} jit/native: {:.2} x", into_ns / hand_ns);
    println!("{name} jit (Color by value)/native: {:.2} x", jit_ns / hand_ns);
    // Both back ends through the same entry (`Function::call_words`).
    println!("{name} interpreter/jit: {:.1} x", interp_ns / raw_ns);
}

fn main() {
    // `cargo bench --bench shading -- lookups` runs one part: materials,
    // spectral, lookups or compile.
    let only: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with('-')).collect();
    let part = |name: &str| only.is_empty() || only.iter().any(|o| o == name);
    let rgb = program(ColorModel::Rgb);
    if part("materials") {
        for (name, rust) in [("marble", marble_rust as fn(&_, _, _, _) -> _), ("wood", wood_rust)] {
            let m = rgb.material(name).expect("material exists");
            bench_material(name, &m, &rgb, rust);
        }
    }
    if part("spectral") {
        bench_spectral(&rgb);
    }
    if part("lookups") {
        bench_lookups();
    }
    if part("batch") {
        bench_batch(&rgb);
    }
    if part("compile") {
        // Other words filter the compiled sources by name:
        // `-- compile texture_tree`.
        let parts = ["materials", "spectral", "lookups", "batch", "compile"];
        let names: Vec<&str> = only.iter().map(String::as_str).filter(|o| !parts.contains(o)).collect();
        bench_compile(&names);
    }
}

/// One batch call over all points vs a surface per point: the same
/// `reflection` of the same material at the same points.
fn bench_batch(rgb: &Program) {
    let pts = points(1 << 16);
    let p: Vec<[f32; 3]> = pts.iter().map(|g| g.p).collect();
    let uv: [Vec<f32>; 2] = [pts.iter().map(|g| g.u).collect(), pts.iter().map(|g| g.v).collect()];
    let mut batch = tsl::ShadingBatch::new(pts.len());
    for name in ["P", "Pl", "N", "Ng"] {
        batch.set_vectors(name, &p).expect("a global");
    }
    batch.set_floats("u", &uv[0]).expect("a global").set_floats("v", &uv[1]).expect("a global");
    let ones = tsl::Column::uniforms(&[1.0; 3]);
    for name in ["marble", "wood"] {
        let m = rgb.material(name).expect("material exists");
        let light = rgb.rgb(1.0, 1.0, 1.0);
        let mut record = tsl::SurfaceRecord::new();
        let (mut per_point, mut batched) = (Duration::MAX, Duration::MAX);
        for _ in 0..5 {
            per_point =
                per_point.min(time(1, &pts, |g| m.at(g, WO, &light, &mut record).reflection(WI, &light).lanes()[0]));
            let start = Instant::now();
            let mut surfaces = m.at_batch(&batch, tsl::Column::uniform_vector(WO), &ones).unwrap();
            let out = surfaces.reflection(tsl::Column::uniform_vector(WI), &ones).unwrap();
            black_box(out);
            batched = batched.min(start.elapsed());
        }
        let (a, b) = (ns_per_point(per_point, pts.len()), ns_per_point(batched, pts.len()));
        println!("{name} reflection, a surface per point: {a:.1} ns/point");
        println!("{name} reflection, one batch: {b:.1} ns/point");
        println!("{name} batch/per-point: {:.2} x", b / a);
        // The issue's figure: how many times faster the batched JIT
        // (four lanes a vector) shades a point than the scalar JIT.
        println!("{name} batched/scalar: {:.2} x", a / b);
    }
}

/// Spectral vs RGB, same material, same points.
fn bench_spectral(rgb: &Program) {
    let spectral = program(ColorModel::Spectral { samples: 16 });
    let pts = points(1 << 16);
    for name in ["marble", "wood"] {
        let (mr, ms) = (rgb.material(name).unwrap(), spectral.material(name).unwrap());
        let (lr, ls) = (rgb.rgb(1.0, 1.0, 1.0), spectral.rgb(1.0, 1.0, 1.0));
        let mut t_rgb = Duration::MAX;
        let mut t_spec = Duration::MAX;
        for _ in 0..5 {
            t_rgb = t_rgb.min(time(4, &pts, |g| mr.reflection(g, WI, &lr, WO).lanes()[0]));
            t_spec = t_spec.min(time(4, &pts, |g| ms.reflection(g, WI, &ls, WO).lanes()[0]));
        }
        println!("{name} spectral16/rgb: {:.2} x", t_spec.as_secs_f64() / t_rgb.as_secs_f64());
    }
}

/// Compile time, source to callable code.
fn bench_compile(names: &[&str]) {
    let mut sources: Vec<(String, String)> = vec![("stdlib".into(), "const float UNUSED = 0;".into())];
    let mut examples: Vec<_> =
        std::fs::read_dir("examples").map(|d| d.filter_map(Result::ok).map(|e| e.path()).collect()).unwrap_or_default();
    examples.retain(|p| p.extension().is_some_and(|e| e == "tsl"));
    examples.sort();
    for p in examples {
        if let Ok(text) = std::fs::read_to_string(&p) {
            sources.push((p.display().to_string(), text));
        }
    }
    sources.retain(|(name, _)| names.is_empty() || names.iter().any(|n| name.contains(n)));
    for (name, text) in &sources {
        // The stdlib line compiles every prelude entry; examples compile
        // their own entries (prelude ones are compiled when first used).
        let eager = name == "stdlib";
        // examples/heavy.tsl reads a generated mesh (`tslc make-mesh heavy`).
        if let Err(e) = Compiler::new().eager(true).eager_prelude(eager).source(name, text).compile() {
            let first = e.to_string().lines().next().unwrap_or_default().to_string();
            println!("compile {name}: skipped ({first})");
            continue;
        }
        let t = best_of(5, || {
            let start = Instant::now();
            let program = Compiler::new()
                .eager(true)
                .eager_prelude(eager)
                .source(name, text)
                .compile()
                .expect("examples compile");
            let elapsed = start.elapsed();
            black_box(program.functions().len());
            elapsed
        });
        let n = Compiler::new()
            .eager(true)
            .eager_prelude(eager)
            .source(name, text)
            .compile()
            .map(|p| p.functions().len())
            .unwrap_or(0);
        println!("compile {name} ({n} entry points): {:.1} ms", t.as_secs_f64() * 1e3);
    }
}

/// Texture lookups and noise, each the whole body of a JIT-compiled
/// function called through `call_words`, over a 1024 x 1024 image with
/// footprints spanning its first mip-map levels.
fn bench_lookups() {
    let dir = std::env::temp_dir().join(format!("tsl-bench-textures-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let img = image::RgbImage::from_fn(1024, 1024, |x, y| image::Rgb([(x ^ y) as u8, (x * 3) as u8, (y * 5) as u8]));
    img.save(dir.join("bench.png")).expect("write the bench image");
    let src = r#"
        color bilinear() { return texture("bench.png", filter: "bilinear"); }
        color trilinear() { return texture("bench.png"); }
        float noise3() { return noise(P); }
        float nothing() { return u; }
    "#;
    let file = dir.join("lookups.tsl");
    std::fs::write(&file, src).expect("write the bench shader");
    let p = Compiler::new().file(&file).compile().expect("the lookup shaders compile");
    // A 256 x 256 pixel window seen in scanline order, as a renderer's
    // tile would see it: each band of 32 rows magnifies the image
    // differently, from 0.25 to 8 texels per pixel.
    let mut pts = Vec::with_capacity(1 << 16);
    for y in 0..256u32 {
        let texels_per_pixel = 0.25 * f32::powi(2.0, (y / 32 % 6) as i32);
        let d = texels_per_pixel / 1024.0;
        for x in 0..256u32 {
            let (u, v) = (0.1 + x as f32 * d, 0.9 - y as f32 * d);
            let p = [u * 40.0, v * 40.0, 1.0];
            pts.push(ShadingGlobals { p, pl: p, u, v, dudx: d, dvdy: d, ..Default::default() });
        }
    }
    let reps = 16;
    let n = pts.len() * reps;
    let call = |name: &str| {
        let f = p.function(name).expect("compiled");
        let mut out = [0u32; 3];
        best_of(5, || {
            time(reps, &pts, |g| {
                let _ = f.call_words(Backend::Jit, g, &[], &mut out);
                f32::from_bits(out[0])
            })
        })
    };
    let base = ns_per_point(call("nothing"), n);
    for name in ["bilinear", "trilinear", "noise3"] {
        let ns = ns_per_point(call(name), n);
        let what = if name == "noise3" { "noise(point)" } else { name };
        println!("{what} lookup: {ns:.1} ns ({:.1} M/s; call overhead {base:.1} ns)", 1e3 / ns);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
