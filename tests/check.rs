//! Data-driven checker tests.
//!
//! - every `tests/check/ok/**/*.tsl`, `stdlib/*.tsl` and `examples/*.tsl`
//!   checks clean (no errors, no warnings);
//! - every `tests/check/err/*.tsl` has its expected diagnostics beside it in
//!   a `.stderr` file. Bless changes with `UPDATE_EXPECT=1 cargo test --test check`.

mod common;

use std::path::{Path, PathBuf};
use tsl::LoadOptions;

fn tsl_files(dir: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut dirs = vec![PathBuf::from(dir)];
    while let Some(d) = dirs.pop() {
        for entry in std::fs::read_dir(&d).unwrap_or_else(|e| panic!("{}: {e}", d.display())) {
            let path = entry.unwrap().path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "tsl") {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

fn assert_clean(dir: &str) {
    let files = tsl_files(dir);
    assert!(!files.is_empty(), "no .tsl files in {dir}");
    let mut failures = String::new();
    for f in &files {
        let checked = tsl::check_file(f, &LoadOptions::default());
        // The heavy example's mesh is generated (`tslc make-mesh heavy`),
        // not stored; checking reads it, so without it the one error is
        // that it is missing.
        let generated = Path::new("examples/gen/heavy.obj");
        if f == Path::new("examples/heavy.tsl") && !generated.exists() {
            let text = checked.render_diagnostics();
            assert!(
                checked.diagnostics.len() == 1 && text.contains("cannot open the mesh examples/gen/heavy.obj"),
                "{text}"
            );
            continue;
        }
        if !checked.diagnostics.is_empty() {
            failures.push_str(&checked.render_diagnostics());
        }
    }
    assert!(failures.is_empty(), "expected no diagnostics:\n{failures}");
}

#[test]
fn ok_fixtures_check_clean() {
    assert_clean("tests/check/ok");
}

#[test]
fn stdlib_checks_clean() {
    assert_clean("stdlib");
}

#[test]
fn examples_check_clean() {
    assert_clean("examples");
}

#[test]
fn err_fixtures_match_their_snapshots() {
    let files = tsl_files("tests/check/err");
    for f in &files {
        let checked = tsl::check_file(f, &LoadOptions::default());
        assert!(!checked.is_ok() || !checked.diagnostics.is_empty(), "{} produced no diagnostics", f.display());
        let expected = Path::new(env!("CARGO_MANIFEST_DIR")).join(f.with_extension("stderr"));
        expect_test::expect_file![expected].assert_eq(&checked.render_diagnostics());
    }
    assert!(files.len() >= 40, "only {} error fixtures; the issue asks for at least 40", files.len());
}
