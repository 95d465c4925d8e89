//! `cargo bench --bench check`: front-end speed on a generated 2,000-line
//! program. Prints `name: value unit` lines so runs can be compared.
//! Goal (issue 2): `tslc check` of 2,000 lines under 20 ms.

use std::fmt::Write;
use std::process::Command;
use std::time::{Duration, Instant};

/// A realistic program: generators with loops and branches, materials that
/// override interface methods, texture trees, a scene. About `lines` lines.
fn program(lines: usize) -> String {
    let mut src = String::new();
    let mut i = 0;
    while src.lines().count() < lines {
        let _ = write!(
            src,
            r#"
// Generator {i}: octaves of noise with a ring pattern.
float gen{i}(point p = Pl, int octaves = 5, float gain = 0.5) {{
    float sum = 0;
    float amp = 1;
    point q = p * {scale};
    for o in 0..octaves {{
        sum += amp * abs(noise(q));
        q = q * 2.0 + vector(0.31, 0.17, 0.9);
        amp *= gain;
        if sum > 4 {{
            break;
        }}
    }}
    float rings = fract(length(vec2(p.x, p.z)) * 8 + sum);
    return rings < 0.5 ? smoothstep(0.0, 0.5, rings) : 1 - smoothstep(0.5, 1.0, rings);
}}

material shiny{i}(color kd = rgb(0.5, 0.4, 0.3), color ks = gray(0.3), float ns = 40) {{
    color reflection(vector wi, color light, vector wo) {{
        vector h = normalize(wi + wo);
        float spec = pow(max(dot(N, h), 0), ns) * (ns + 2) / (2 * PI);
        return light * (kd / PI + ks * spec) * max(dot(N, wi), 0);
    }}
    color diffuse() {{ return kd; }}
    vector reflection_dir(vector wo) {{ return reflect(-wo, N); }}
}}

material tree{i} = bump(gen{i}(), 0.02, mix(gen{i}(octaves: 3), shiny{i}(), shiny{i}(kd: hsv(0.1, 0.5, 0.4))));
"#,
            scale = 1.0 + i as f64 * 0.25
        );
        i += 1;
    }
    src.push_str(
        "scene {\n    camera { from (0, 1, -4); to (0, 1, 0); fov 40; }\n    light point { at (2, 4, -3); intensity rgb(60, 60, 60); }\n    object sphere { center (0, 1, 0); radius 1; material tree0; }\n}\n",
    );
    src
}

fn median(mut xs: Vec<Duration>) -> Duration {
    xs.sort();
    xs[xs.len() / 2]
}

fn time_runs(runs: usize, mut f: impl FnMut()) -> Duration {
    median(
        (0..runs)
            .map(|_| {
                let start = Instant::now();
                f();
                start.elapsed()
            })
            .collect(),
    )
}

fn main() {
    let src = program(2000);
    let lines = src.lines().count();
    let options = tsl::LoadOptions::default();

    let checked = tsl::check_source("bench.tsl", &src, &options);
    assert!(checked.is_ok(), "the benchmark program must check clean:\n{}", checked.render_diagnostics());

    let runs = 30;
    let in_process = time_runs(runs, || {
        std::hint::black_box(tsl::check_source("bench.tsl", &src, &options));
    });
    println!("check {lines} lines, in process: {:.2} ms", in_process.as_secs_f64() * 1e3);

    let dir = std::env::temp_dir().join(format!("tsl-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("bench.tsl");
    std::fs::write(&path, &src).expect("write bench input");
    let tiny = dir.join("tiny.tsl");
    std::fs::write(&tiny, "float f() { return 1; }\n").expect("write tiny input");
    let tslc = env!("CARGO_BIN_EXE_tslc");
    let run = |file: &std::path::Path| {
        let status = Command::new(tslc).arg("check").arg(file).status().expect("run tslc");
        assert!(status.success());
    };
    let whole = time_runs(runs, || run(&path));
    let startup = time_runs(runs, || run(&tiny));
    println!("tslc check {lines} lines, whole process: {:.2} ms", whole.as_secs_f64() * 1e3);
    println!("tslc check 1 line (startup and prelude): {:.2} ms", startup.as_secs_f64() * 1e3);
    println!("tslc check {lines} lines / 20 ms goal: {:.2} x", whole.as_secs_f64() / 0.020);
    std::fs::remove_dir_all(&dir).ok();
}
