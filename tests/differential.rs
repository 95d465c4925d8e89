//! Differential tests: the JIT and the reference interpreter agree on every
//! generator and material method of `stdlib/`, `examples/` (and
//! `examples/techniques/`) and
//! `tests/check/ok/`, at 1,000 random shading points each, in the RGB and a
//! spectral color model.

use tsl::check::Ty;
use tsl::{Backend, ColorModel, Compiler, Program, ShadingGlobals};

const POINTS: usize = 1000;

/// Points for `albedo` entries: a default `albedo` runs its material's
/// `sample` 64 times in a loop, so 16 points run the sampling code as
/// often as 1,024 calls of `sample` (at 1,000 points the interpreter's
/// share tripled this file's time).
const ALBEDO_POINTS: usize = 16;

mod common;
use common::{Rng, close};

fn globals(rng: &mut Rng) -> ShadingGlobals {
    common::shading_point(rng)
}

/// Random argument words for a parameter list: unit directions for
/// vectors, colors in [0, 1], small ints.
fn args(rng: &mut Rng, params: &[(String, Ty)], model: ColorModel) -> Vec<u32> {
    let mut words = Vec::new();
    for (name, ty) in params {
        match ty {
            Ty::Float if name == "distance" => words.push(rng.range(0.0, 5.0).to_bits()),
            Ty::Float => words.push(rng.range(-2.0, 2.0).to_bits()),
            Ty::Int => words.push((rng.next() % 8) as u32),
            Ty::Bool => words.push((rng.next() % 2) as u32),
            Ty::Vec2 => words.extend([rng.range(-2.0, 2.0).to_bits(), rng.range(-2.0, 2.0).to_bits()]),
            Ty::Vector | Ty::Point | Ty::Normal => words.extend(rng.unit().map(f32::to_bits)),
            Ty::Color if name == "eta" => words.extend((0..model.lanes()).map(|_| rng.range(1.0, 2.0).to_bits())),
            Ty::Color => words.extend((0..model.lanes()).map(|_| rng.range(0.0, 1.0).to_bits())),
            Ty::Matrix => words.extend((0..12).map(|_| rng.range(-1.0, 1.0).to_bits())),
            _ => {}
        }
    }
    words
}

/// Compares both back ends on every entry whose name passes `keep`.
fn compare(program: &Program, keep: impl Fn(&str) -> bool, seed: u64) -> usize {
    let mut rng = Rng(seed);
    let mut checked = 0;
    for entry in program.functions().iter().filter(|e| keep(e.name())) {
        let f = program.function(entry.name()).expect("every entry is compiled");
        let results = f.result_types();
        let mut out_jit = vec![0u32; results.len()];
        let mut out_int = vec![0u32; results.len()];
        let points = if entry.name().ends_with(".albedo") { ALBEDO_POINTS } else { POINTS };
        for point in 0..points {
            let g = globals(&mut rng);
            let a = args(&mut rng, entry.params(), program.color_model());
            f.call_words(Backend::Jit, &g, &a, &mut out_jit).unwrap();
            f.call_words(Backend::Interpreter, &g, &a, &mut out_int).unwrap();
            for (k, ty) in results.iter().enumerate() {
                assert!(
                    close(out_jit[k], out_int[k], *ty),
                    "{} ({}) word {k} at point {point}: jit {:?} vs interpreter {:?}\nglobals {g:?}\nargs {a:?}",
                    entry.name(),
                    program.color_model().name(),
                    f32::from_bits(out_jit[k]),
                    f32::from_bits(out_int[k]),
                );
            }
        }
        checked += 1;
    }
    checked
}

const MODELS: [ColorModel; 2] = [ColorModel::Rgb, ColorModel::Spectral { samples: 16 }];

#[test]
fn stdlib_agrees() {
    for model in MODELS {
        let program = Compiler::new()
            .color_model(model)
            .eager_prelude(true)
            .source("empty.tsl", "const float UNUSED = 0;")
            .compile()
            .unwrap();
        let n = compare(&program, |_| true, 1);
        assert!(n >= 40, "only {n} stdlib entries were compared");
    }
}

/// Entries defined in the file itself (the prelude is covered above).
fn own_entries(path: &std::path::Path) -> Vec<String> {
    let checked = tsl::check_file(path, &tsl::LoadOptions::default());
    let root = checked.program.loaded.modules.iter().position(|m| !m.is_prelude).unwrap();
    checked.program.symbols.iter().filter(|(_, s)| s.module >= root).map(|(n, _)| n.clone()).collect()
}

fn compare_files(dir: &str) {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "tsl"))
        .collect();
    files.sort();
    for path in files {
        let names = own_entries(&path);
        if names.is_empty() {
            // Nothing of its own to compare (a scene of stdlib materials,
            // such as heavy.tsl, whose generated mesh may be absent).
            continue;
        }
        for model in MODELS {
            let program = Compiler::new()
                .color_model(model)
                .eager(true)
                .file(&path)
                .compile()
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let keep = |entry: &str| names.iter().any(|n| entry == n || entry.starts_with(&format!("{n}.")));
            assert!(compare(&program, keep, 7) > 0, "{}: nothing compared", path.display());
        }
    }
}

#[test]
fn examples_agree() {
    compare_files("examples");
}

#[test]
fn technique_examples_agree() {
    compare_files("examples/techniques");
}

#[test]
fn ok_fixtures_agree() {
    compare_files("tests/check/ok");
}
