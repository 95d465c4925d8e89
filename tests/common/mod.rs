//! What the differential tests share: a reproducible random generator,
//! random shading points, and the tolerance by which the JIT and the
//! interpreter must agree.

#![allow(dead_code)] // each test binary uses its own part

use tsl::ShadingGlobals;
use tsl::check::Ty;

/// The message of a scene from `src` that must not render: the compile
/// error (checking describes the scene and finds most problems), or, for
/// what only building it shows, `Scene::build`'s.
pub fn build_error(src: &str) -> String {
    let program = match tsl::Compiler::new().source("bad.tsl", src).compile() {
        Ok(program) => program,
        Err(e) => return e.to_string(),
    };
    match tsl::render::Scene::build(&program, &tsl::render::Overrides::default()) {
        Ok(_) => panic!("the scene built"),
        Err(e) => e.to_string(),
    }
}

/// Runs `tslc` with `args` (no standard input), capturing its output.
pub fn tslc(args: &[&str]) -> std::process::Output {
    use std::process::{Command, Stdio};
    Command::new(env!("CARGO_BIN_EXE_tslc"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .output()
        .expect("tslc runs")
}

/// What a `tslc` run wrote to stderr.
pub fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A fresh, empty directory for one test, unique to this process.
pub fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("tsl-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[path = "../../src/test_support/random.rs"]
mod random;
// Each test binary uses some of these.
#[allow(unused_imports)]
pub use random::{Rng, shading_point};

/// Whether two result words agree: exactly, or within 1e-5 relative for
/// floats (both NaN counts as agreeing).
pub fn close(a: u32, b: u32, ty: tsl::WordType) -> bool {
    if a == b {
        return true;
    }
    if ty != tsl::WordType::F32 {
        return false;
    }
    let (x, y) = (f32::from_bits(a), f32::from_bits(b));
    (x.is_nan() && y.is_nan()) || (x - y).abs() <= 1e-5 * x.abs().max(y.abs()).max(1.0)
}

/// Token texts from which random streams are built.
pub const TOKENS: &[&str] = &[
    "float",
    "int",
    "bool",
    "color",
    "vector",
    "point",
    "normal",
    "vec2",
    "uv",
    "matrix",
    "string",
    "void",
    "material",
    "scene",
    "import",
    "const",
    "if",
    "else",
    "for",
    "in",
    "while",
    "break",
    "continue",
    "return",
    "true",
    "false",
    "(",
    ")",
    "{",
    "}",
    "[",
    "]",
    ",",
    ";",
    ":",
    "?",
    ".",
    "..",
    "=",
    "+=",
    "-=",
    "*=",
    "/=",
    "+",
    "-",
    "*",
    "/",
    "%",
    "!",
    "==",
    "!=",
    "<",
    "<=",
    ">",
    ">=",
    "&&",
    "||",
    "x",
    "P",
    "N",
    "u",
    "mix",
    "phong",
    "rgb",
    "noise",
    "f",
    "1",
    "2.5",
    "\"a.tsl\"",
    "camera",
    "object",
    "light",
    "sphere",
];

/// Random argument words for an entry's parameters.
pub fn args(rng: &mut Rng, params: &[(String, Ty)], model: tsl::ColorModel) -> Vec<u32> {
    let mut words = Vec::new();
    for (_, ty) in params {
        match ty {
            Ty::Float => words.push(rng.float().to_bits()),
            Ty::Int => words.push(rng.int() as u32),
            Ty::Bool => words.push((rng.next() % 2) as u32),
            Ty::Vec2 => words.extend([rng.float().to_bits(), rng.float().to_bits()]),
            Ty::Vector | Ty::Point | Ty::Normal => words.extend(rng.unit().map(f32::to_bits)),
            Ty::Color => words.extend((0..model.lanes()).map(|_| rng.range(0.0, 2.0).to_bits())),
            Ty::Matrix => words.extend((0..12).map(|_| rng.range(-1.0, 1.0).to_bits())),
            _ => {}
        }
    }
    words
}

/// A user's material template with a colour, a string option and a material
/// parameter: what the shader and run-time binding tests instantiate.
pub const CAR_PAINT: &str = r#"
material car_paint(
    color base = rgb(0.5, 0.02, 0.02),
    string finish = "gloss" in ("gloss", "satin"),
    material under = lambert,
) = mix(0.3, rough_plastic(diffuse_reflectance: base, alpha: finish == "gloss" ? 0.05 : 0.3), under);
"#;
