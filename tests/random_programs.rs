//! Random well-typed TSL programs: the JIT and the reference interpreter
//! agree on every entry point.
//!
//! A typed expression generator (a proptest strategy producing source text
//! for a target type) builds whole programs: constants, helper functions
//! with locals, `if`/`else`, bounded `for` loops with `break` and
//! `continue`, early returns, compound assignment and arrays indexed
//! dynamically; materials implementing interface methods; and texture trees
//! over them (`mix`, `blend`, `select`, `bump`, `normal_map`, `scale`, `transform`,
//! templates, `?:`). Every program must compile in the RGB and a spectral
//! color model, and every entry point must give the same words on both back
//! ends at a set of random (and a few extreme) shading points and arguments.
//! Every entry point's batch form (the JIT's four-lane vector code) must
//! give, point by point, what the interpreter gives at that point.
//! Each helper also has a wrapper calling it with constant arguments, which
//! lowering specialises: the wrapper must give what the helper computes
//! from the same values at run time.
//!
//! A failure prints the whole program; `PROPTEST_CASES=500 cargo test --test
//! random_programs` runs a longer campaign. Minimal reproducers of bugs
//! found this way live in `tests/regressions.rs`.

#[path = "random_programs/generator.rs"]
mod generator;

use generator::{Source, program};
use proptest::prelude::*;
use proptest::test_runner::Config;
use tsl::{Backend, ColorModel, Column, Compiler, Layout, Program, ShadingBatch, ShadingGlobals};

// ---------------------------------------------------------------- running both back ends

mod common;
use common::{Rng, args, close};

const POINTS: usize = 50;

fn globals(rng: &mut Rng, point: usize) -> ShadingGlobals {
    // A few degenerate points first: everything zero, and huge coordinates.
    match point {
        0 => ShadingGlobals::default(),
        1 => ShadingGlobals { p: [1e30, -1e30, 3e38], pl: [5e29, -5e29, 1.5e38], ..common::shading_point(rng) },
        _ => common::shading_point(rng),
    }
}

/// Entries defined by the generated program (not the prelude's).
fn own(name: &str) -> bool {
    ["g_", "w_", "m0.", "m1.", "tree0.", "tree1."].iter().any(|p| name.starts_with(p))
}

/// Compares both back ends on every entry of the program; returns how many
/// entries were compared.
/// Batches are compared for one entry point in this many (each compiles
/// vector code of its own: all of them would take minutes).
const BATCH_STRIDE: usize = 32;

/// Compares both back ends on every entry point, and the batch form of
/// entries `batch_offset`, `batch_offset + BATCH_STRIDE`, ...
fn compare(program: &Program, seed: u64, batch_offset: usize) -> Result<usize, String> {
    let mut rng = Rng(seed);
    let mut checked = 0;
    for (k, entry) in program.functions().iter().filter(|e| own(e.name())).enumerate() {
        let f = program.function(entry.name()).ok_or(format!("entry `{}` is not compiled", entry.name()))?;
        let results = f.result_types();
        let mut out_jit = vec![0u32; results.len()];
        let mut out_int = vec![0u32; results.len()];
        for point in 0..POINTS {
            let g = globals(&mut rng, point);
            let a = args(&mut rng, entry.params(), program.color_model());
            f.call_words(Backend::Jit, &g, &a, &mut out_jit)?;
            f.call_words(Backend::Interpreter, &g, &a, &mut out_int)?;
            for (k, ty) in results.iter().enumerate() {
                if !close(out_jit[k], out_int[k], *ty) {
                    return Err(format!(
                        "{} ({}) word {k} ({ty:?}) at point {point}: jit {:#x} ({:?}) vs interpreter {:#x} ({:?})\nglobals {g:?}\nargs {a:?}",
                        entry.name(),
                        program.color_model().name(),
                        out_jit[k],
                        f32::from_bits(out_jit[k]),
                        out_int[k],
                        f32::from_bits(out_int[k]),
                    ));
                }
            }
        }
        if k % BATCH_STRIDE == batch_offset % BATCH_STRIDE {
            compare_batch(program, &f, entry, &mut rng)?;
        }
        checked += 1;
    }
    Ok(checked)
}

/// The JIT's batch entry (four points a vector) against the interpreter
/// point by point, every global and argument varying from point to point.
fn compare_batch(program: &Program, f: &tsl::Function, entry: &tsl::Function, rng: &mut Rng) -> Result<(), String> {
    let points: Vec<ShadingGlobals> = (0..POINTS).map(|i| globals(rng, i)).collect();
    let args: Vec<Vec<u32>> = (0..POINTS).map(|_| args(rng, entry.params(), program.color_model())).collect();
    // Word `w` of every point, for each globals word and argument word.
    let by_word = |words: &dyn Fn(usize) -> Vec<u32>, count: usize| -> Vec<Vec<u32>> {
        (0..count).map(|w| (0..POINTS).map(|i| words(i)[w]).collect()).collect()
    };
    let global_words = by_word(&|i| points[i].words().to_vec(), tsl::globals::GLOBAL_WORDS as usize);
    let arg_words = by_word(&|i| args[i].clone(), f.arg_words());
    let mut batch = ShadingBatch::with_base(POINTS, points[0]);
    for (name, _, _) in tsl::check::GLOBALS {
        let (first, ty) = tsl::globals::word_of(name).expect("a global's words");
        let n = if ty.is_triple() { 3 } else { 1 };
        let columns: Vec<Column> = (0..n).map(|k| Column::words(&global_words[first as usize + k])).collect();
        batch.set(name, &columns).map_err(|e| e.to_string())?;
    }
    let columns: Vec<Column> = arg_words.iter().map(|w| Column::words(w)).collect();
    let results = f.result_types();
    let mut out = vec![0u32; POINTS * results.len()];
    f.call_batch(Backend::Jit, &batch, &columns, &mut out, Layout::WordMajor).map_err(|e| e.to_string())?;
    let mut want = vec![0u32; results.len()];
    for (i, a) in args.iter().enumerate() {
        let g = batch.point(i);
        f.call_words(Backend::Interpreter, &g, a, &mut want)?;
        for (k, ty) in results.iter().enumerate() {
            let got = out[k * POINTS + i];
            if !close(got, want[k], *ty) {
                return Err(format!(
                    "{} ({}) word {k} ({ty:?}) at point {i}: jit batch {got:#x} ({:?}) vs interpreter {:#x} ({:?})\nglobals {g:?}\nargs {a:?}",
                    entry.name(),
                    program.color_model().name(),
                    f32::from_bits(got),
                    want[k],
                    f32::from_bits(want[k]),
                ));
            }
        }
    }
    Ok(())
}

/// The helpers that have constant-argument wrappers.
const HELPERS: [&str; 6] = ["g_bool", "g_int", "g_matrix", "g_vector", "g_color", "g_float"];

/// Lowering specialises a helper called with constants (`w_x()`); the result
/// must be the one the helper computes from the same values at run time.
fn compare_folded(program: &Program) -> Result<(), String> {
    let mut rng = Rng(0x5EED);
    let model = program.color_model();
    // a = 0.75, n = 2, d = (0.25, -1, 2), c = its default rgb(0.2, 0.5, 0.9), flag = false.
    let mut words = vec![0.75f32.to_bits(), 2, 0.25f32.to_bits(), (-1.0f32).to_bits(), 2.0f32.to_bits()];
    words.extend(program.rgb(0.2, 0.5, 0.9).lanes().iter().map(|x| x.to_bits()));
    words.push(0);
    for name in HELPERS {
        let wrapper = name.replacen("g_", "w_", 1);
        let g = program.function(name).ok_or(format!("no entry `{name}`"))?;
        let w = program.function(&wrapper).ok_or(format!("no entry `{wrapper}`"))?;
        let results = g.result_types();
        let mut out_g = vec![0u32; results.len()];
        let mut out_w = vec![0u32; results.len()];
        for point in 0..10 {
            let globals = globals(&mut rng, point);
            for backend in [Backend::Jit, Backend::Interpreter] {
                g.call_words(backend, &globals, &words, &mut out_g)?;
                w.call_words(backend, &globals, &[], &mut out_w)?;
                for (k, ty) in results.iter().enumerate() {
                    if !close(out_g[k], out_w[k], *ty) {
                        return Err(format!(
                            "{wrapper}() ({}, {backend:?}) word {k} ({ty:?}) at point {point}: constant-specialised {:#x} ({:?}) vs {name} at run time {:#x} ({:?})\nglobals {globals:?}",
                            model.name(),
                            out_w[k],
                            f32::from_bits(out_w[k]),
                            out_g[k],
                            f32::from_bits(out_g[k]),
                        ));
                    }
                }
            }
        }
    }
    Ok(())
}

const MODELS: [ColorModel; 2] = [ColorModel::Rgb, ColorModel::Spectral { samples: 16 }];

fn check_program(src: &Source) -> Result<(), TestCaseError> {
    for (m, model) in MODELS.into_iter().enumerate() {
        let program = Compiler::new()
            .color_model(model)
            .eager(true)
            .source("random.tsl", &src.0)
            .compile()
            .map_err(|e| TestCaseError::fail(format!("{} does not compile:\n{e}", model.name())))?;
        // Which entries' batches are compared varies with the program.
        let batch_offset = src.0.len() + m * BATCH_STRIDE / 2;
        let n = compare(&program, 0x9E37_79B9_7F4A_7C15, batch_offset).map_err(TestCaseError::fail)?;
        // 6 helpers (g_arr takes an array, so it is no entry), their 6
        // wrappers, and every interface method of m0, m1, tree0, tree1.
        prop_assert_eq!(n, 2 * 6 + 4 * tsl::check::INTERFACE.len());
        compare_folded(&program).map_err(TestCaseError::fail)?;
    }
    Ok(())
}

/// `cases` unless `PROPTEST_CASES` says otherwise (for longer campaigns);
/// shrinking is bounded because every step compiles a program twice.
fn config(cases: u32) -> Config {
    let cases = std::env::var("PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(cases);
    Config { cases, failure_persistence: None, max_shrink_iters: 1000, max_shrink_time: 120_000, ..Config::default() }
}

proptest! {
    #![proptest_config(config(32))]

    /// Two tests of 32 cases each, so the two halves run in parallel.
    #[test]
    fn random_programs_agree_a(src in program()) {
        check_program(&src)?;
    }

    #[test]
    fn random_programs_agree_b(src in program()) {
        check_program(&src)?;
    }
}

/// The generator's output always checks clean (a generator bug otherwise),
/// over many more cases than the back ends are compared on: checking is cheap.
#[test]
fn generated_programs_check_clean() {
    let mut runner = proptest::test_runner::TestRunner::new(config(64));
    runner
        .run(&program(), |src| {
            let checked = tsl::check_source("random.tsl", &src.0, &tsl::LoadOptions::default());
            prop_assert!(checked.is_ok(), "{}\n{}", src.0, checked.render_diagnostics());
            Ok(())
        })
        .unwrap();
}
