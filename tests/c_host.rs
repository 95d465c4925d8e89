//! The C and C++ hosts (`examples/c/host.c`, `examples/c/host.cpp`) and
//! the 8-thread C test (`tests/c/threads.c`), built with the system's C
//! and C++ compilers against the `cdylib` cargo built beside this test
//! and `include/tsl.h`, run, and checked: every float they print is the
//! bits the Rust API gives for the same calls.

use std::path::{Path, PathBuf};
use std::process::Command;
use tsl::{ColorModel, Column, Compiler, ParamType, ShadingBatch, ShadingGlobals, SurfaceRecord};

const WOOD: &str = "float rings(float scale = 8) { return fract(length(vec2(Pl.x, Pl.z)) * scale); }\n\
    material wood = mix(rings(), lambert(kd: rgb(0.6, 0.4, 0.2)), lambert(kd: rgb(0.35, 0.2, 0.08)));\n";

/// The folder holding this test binary, `libtsl.so` and `libtsl.a`
/// (target/debug/deps).
fn lib_dir() -> PathBuf {
    std::env::current_exe().expect("the test binary's path").parent().expect("its folder").to_path_buf()
}

/// The compiler in `var` (`CC`, `CXX`) or `default`, when it runs.
fn compiler(var: &str, default: &str) -> Option<String> {
    let cc = std::env::var(var).unwrap_or_else(|_| default.to_string());
    let runs = Command::new(&cc).arg("--version").output().is_ok_and(|o| o.status.success());
    runs.then_some(cc)
}

/// Builds `source` with `cc` and `flags` against the library, runs the
/// program and returns its standard output; panics with the compiler's or
/// the program's messages on failure.
fn build_and_run(cc: &str, flags: &[&str], source: &str, name: &str) -> String {
    build_and_run_with(cc, flags, source, name, &[], Link::Shared)
}

/// Which of the library's two C forms a program links.
#[derive(Clone, Copy)]
enum Link {
    /// `libtsl.so`, found at run time through the rpath.
    Shared,
    /// `libtsl.a` and the system libraries Rust's std needs.
    Static,
}

/// [`build_and_run`] with arguments for the program and a choice of
/// library.
fn build_and_run_with(cc: &str, flags: &[&str], source: &str, name: &str, args: &[&Path], link: Link) -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let lib = lib_dir();
    assert!(lib.join("libtsl.so").exists(), "no libtsl.so in {}", lib.display());
    let dir = tempfile::tempdir().expect("a temporary folder");
    let exe = dir.path().join(name);
    let libraries: Vec<String> = match link {
        Link::Shared => vec![format!("-L{}", lib.display()), "-ltsl".into(), format!("-Wl,-rpath,{}", lib.display())],
        Link::Static => {
            vec![lib.join("libtsl.a").display().to_string(), "-lpthread".into(), "-ldl".into(), "-lm".into()]
        }
    };
    let output = Command::new(cc)
        .args(flags)
        .arg("-Wall")
        .arg("-Wextra")
        .arg("-Werror")
        .arg("-pedantic")
        .arg(format!("-I{}", root.join("include").display()))
        .arg(root.join(source))
        .args(libraries)
        .arg("-o")
        .arg(&exe)
        .output()
        .expect("the compiler runs");
    assert!(output.status.success(), "{cc} {source} failed:\n{}", String::from_utf8_lossy(&output.stderr));
    let run = Command::new(&exe).args(args).output().expect("the host runs");
    assert!(
        run.status.success(),
        "{source} failed:\n{}{}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
    String::from_utf8(run.stdout).expect("UTF-8 output")
}

/// Fails at the first line where `got` differs from `want`.
fn assert_same_lines(got: &str, want: &str) {
    let line = got.lines().zip(want.lines()).position(|(a, b)| a != b);
    if let Some(i) = line {
        panic!(
            "line {} differs:\n  got:  {}\n  want: {}",
            i + 1,
            got.lines().nth(i).unwrap_or(""),
            want.lines().nth(i).unwrap_or("")
        );
    }
    assert_eq!(got.lines().count(), want.lines().count(), "got:\n{got}");
    assert_eq!(got, want);
}

fn floats(label: &str, xs: &[f32]) -> String {
    let mut s = label.to_string();
    for x in xs {
        s += &format!(" {:08x}", x.to_bits());
    }
    s + "\n"
}

/// What the C++ host leaves out of the C host's output.
#[derive(Clone, Copy, PartialEq)]
enum Host {
    C,
    Cpp,
}

/// What the hosts print, from the Rust API's same calls.
fn expected(host: Host) -> String {
    let mut out = String::new();
    let err = Compiler::new().source("bad.tsl", "material m = lamberd;").compile().expect_err("a compile error");
    out += "bad status 1\n";
    for line in format!("{err:?}").trim_start_matches("Error [\"").trim_end_matches("\"]").split("\", \"") {
        out += &format!("diagnostic {}\n", line.replacen(": error: ", ": ", 1));
    }

    let program = Compiler::new().color_model(ColorModel::Rgb).source("wood.tsl", WOOD).compile().expect("compiles");
    out += "lanes 3\n";
    let metal = program.shader("rough_conductor").expect("rough_conductor");
    let types = [
        ParamType::Float,
        ParamType::Int,
        ParamType::Bool,
        ParamType::Color,
        ParamType::Vector,
        ParamType::Point,
        ParamType::Normal,
        ParamType::Vec2,
        ParamType::Matrix,
        ParamType::BsdfSample,
        ParamType::String,
        ParamType::Material,
    ];
    if host == Host::C {
        for p in metal.params() {
            let ty = types.iter().position(|t| *t == p.ty).expect("a known type");
            out += &format!(
                "param {} type {ty} default {} doc {}",
                p.name,
                p.default_source.as_deref().unwrap_or(""),
                p.doc.as_deref().unwrap_or("")
            );
            for o in &p.options {
                out += &format!(" option {o}");
            }
            if let Some(tsl::ParamValue::Float(x)) = p.default {
                out += &format!(" value {:08x}", x.to_bits());
            }
            out += "\n";
        }
        let err = metal.instance().set("alpah", 0.2).expect_err("a misspelt name");
        assert!(err.to_string().contains("did you mean `alpha`?"), "{err}");
        out += "set alpah: status 1, did you mean alpha\n";
    }
    let mut gold = metal.instance();
    gold.set("distribution", "ggx").expect("ggx");
    let mut bind = |alpha: f32| gold.set("alpha", alpha).expect("alpha").bind().expect("binds");
    let golds = [bind(0.2), bind(0.05)];
    let wood = program.material("wood").expect("wood");

    let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ng: [0.0, 0.0, 1.0], pl: [0.1, 0.0, 0.0], ..Default::default() };
    let (wo, wi) = ([0.0, 0.6, 0.8], [0.0, -0.6, 0.8]);
    let eta = program.rgb(1.0, 1.0, 1.0);
    let mut record = SurfaceRecord::new();
    out += &floats("wood reflection", wood.at(&g, wo, &eta, &mut record).reflection(wi, &eta).lanes());
    for (k, m) in golds.iter().enumerate() {
        let s = m.at(&g, wo, &eta, &mut record).sample(0.5, [0.3, 0.7]);
        out += &format!("gold{k} sample");
        out += &floats(" wi", &s.wi);
        out += &floats("  weight", s.weight.lanes());
        out += &floats("  pdf", &[s.pdf]);
        let e = m.at(&g, wo, &eta, &mut record).eval_pdf(wi);
        out += &format!("gold{k} eval_pdf");
        out += &floats(" value", e.value.lanes());
        out += &floats("  pdf", &[e.pdf]);
    }
    if host == Host::C {
        out += &floats("gold0 albedo", golds[0].at(&g, wo, &eta, &mut record).albedo().lanes());
    }

    const POINTS: usize = 8;
    let pl: Vec<[f32; 3]> = (0..POINTS).map(|i| [0.05 * i as f32, 0.0, 0.02 * i as f32]).collect();
    let u1: Vec<f32> = (0..POINTS).map(|i| i as f32 / POINTS as f32).collect();
    let u2: Vec<f32> = (0..POINTS).map(|i| 1.0 - i as f32 / POINTS as f32).collect();
    let mut points = ShadingBatch::with_base(POINTS, g);
    points.set_vectors("Pl", &pl).expect("Pl");
    let eta_columns = Column::uniforms(eta.lanes());
    let reflection = wood
        .at_batch(&points, Column::uniform_vector(wo), &eta_columns)
        .and_then(|mut s| s.reflection(Column::uniform_vector(wi), &eta_columns))
        .expect("a batch");
    for i in 0..POINTS {
        out += &floats(&format!("batch wood reflection {i}"), reflection.get(i));
    }
    if host == Host::C {
        let samples = golds[0]
            .at_batch(&points, Column::uniform_vector(wo), &eta_columns)
            .and_then(|mut s| s.sample(Column::uniform(0.5), [Column::floats(&u1), Column::floats(&u2)]))
            .expect("a batch");
        for i in 0..POINTS {
            out += &format!("batch gold0 sample {i}");
            out += &floats(" wi", &samples.wi[i]);
            out += &floats("  weight", samples.weight.get(i));
            out += &floats("  pdf", &[samples.pdf[i]]);
        }
        let albedo = wood
            .at_batch(&points, Column::uniform_vector(wo), &eta_columns)
            .and_then(|mut s| s.albedo())
            .expect("a batch");
        for i in 0..POINTS {
            out += &floats(&format!("batch wood albedo {i}"), albedo.get(i));
        }
    }
    out + "done\n"
}

#[test]
fn c_host_prints_the_bits_of_the_rust_api() {
    let Some(cc) = compiler("CC", "cc") else {
        eprintln!("skipped: no C compiler (`cc` or $CC) runs here");
        return;
    };
    let output = build_and_run(&cc, &["-std=c99"], "examples/c/host.c", "host");
    assert_same_lines(&output, &expected(Host::C));
}

#[test]
fn c_host_linked_with_the_static_library_prints_the_same() {
    let Some(cc) = compiler("CC", "cc") else {
        eprintln!("skipped: no C compiler (`cc` or $CC) runs here");
        return;
    };
    let output = build_and_run_with(&cc, &["-std=c99"], "examples/c/host.c", "host_static", &[], Link::Static);
    assert_same_lines(&output, &expected(Host::C));
}

#[test]
fn cpp_host_prints_the_bits_of_the_rust_api() {
    let Some(cxx) = compiler("CXX", "c++") else {
        eprintln!("skipped: no C++ compiler (`c++` or $CXX) runs here");
        return;
    };
    let output = build_and_run(&cxx, &["-std=c++17"], "examples/c/host.cpp", "host_cpp");
    assert_same_lines(&output, &expected(Host::Cpp));
}

#[test]
fn one_program_shades_the_same_bits_from_eight_c_threads() {
    let Some(cc) = compiler("CC", "cc") else {
        eprintln!("skipped: no C compiler (`cc` or $CC) runs here");
        return;
    };
    let output = build_and_run(&cc, &["-std=c99", "-pthread"], "tests/c/threads.c", "threads");
    assert_eq!(output, "threads: 8 threads x 1024 results agree\n");
}

#[test]
fn c_render_into_a_buffer_gives_the_bits_of_tslc_render_and_cancels() {
    let Some(cc) = compiler("CC", "cc") else {
        eprintln!("skipped: no C compiler (`cc` or $CC) runs here");
        return;
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene_path = root.join("examples/cornell.tsl");
    let output =
        build_and_run_with(&cc, &["-std=c99", "-pthread"], "tests/c/render.c", "render", &[&scene_path], Link::Shared);

    // The same settings through `tslc render` to an EXR.
    let dir = tempfile::tempdir().expect("a temporary folder");
    let exr = dir.path().join("cornell.exr");
    let tslc = Command::new(env!("CARGO_BIN_EXE_tslc"))
        .arg("render")
        .arg(&scene_path)
        .args(["--res", "24x18", "--spp", "4", "--seed", "7", "--integrator", "path", "--quiet", "-o"])
        .arg(&exr)
        .output()
        .expect("tslc runs");
    assert!(tslc.status.success(), "{}", String::from_utf8_lossy(&tslc.stderr));
    let image = tsl::image_io::read_exr(&exr).expect("tslc's EXR reads");
    assert_eq!((image.width, image.height), (24, 18));

    let mut want = "size 24x18\nshort buffer: status 2\nprogress complete\n".to_string();
    let words: Vec<String> = image.color.as_flattened().iter().map(|x| format!("{:08x}", x.to_bits())).collect();
    for row in words.chunks(8) {
        want += &row.join(" ");
        want += "\n";
    }
    want += "cancelled: status 3, error: the render was cancelled\n";
    assert_same_lines(&output, &want);
}

/// AddressSanitizer (with LeakSanitizer) and UBSan over the C programs:
/// no invalid access, no undefined behaviour on the C side, and no leak
/// once every handle is freed (Rust's allocations go through the same
/// intercepted malloc). `scripts/c-sanitize.sh` runs them under valgrind.
#[test]
fn c_programs_are_clean_under_address_sanitizer() {
    const SANITIZE: [&str; 4] = ["-g", "-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-pthread"];
    let Some(cc) = compiler("CC", "cc") else {
        eprintln!("skipped: no C compiler (`cc` or $CC) runs here");
        return;
    };
    let dir = tempfile::tempdir().expect("a temporary folder");
    let probe = dir.path().join("probe.c");
    std::fs::write(&probe, "int main(void) { return 0; }\n").expect("writes");
    let links =
        Command::new(&cc).args(SANITIZE).arg(&probe).arg("-o").arg(dir.path().join("probe")).output().expect("cc runs");
    if !links.status.success() {
        eprintln!("skipped: {cc} cannot link with -fsanitize=address,undefined (no libasan/libubsan)");
        return;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = root.join("examples/cornell.tsl");
    let flags = [&["-std=c99"][..], &SANITIZE[..]].concat();
    let host = build_and_run_with(&cc, &flags, "examples/c/host.c", "host_asan", &[], Link::Shared);
    assert_same_lines(&host, &expected(Host::C));
    let threads = build_and_run_with(&cc, &flags, "tests/c/threads.c", "threads_asan", &[], Link::Shared);
    assert!(threads.starts_with("threads: 8 threads"), "{threads}");
    let render = build_and_run_with(&cc, &flags, "tests/c/render.c", "render_asan", &[&scene], Link::Shared);
    assert!(render.starts_with("size 24x18\n") && render.contains("cancelled: status 3"), "{render}");
}
