//! Golden IR: every `tests/lower/X.tsl` is lowered for the RGB color
//! model and the functions it names are printed into `tests/lower/X.ir`,
//! which must match byte for byte. The IR printer names tables and shading
//! globals rather than printing addresses, and lowering is deterministic,
//! so the text is the same on every run and machine.
//!
//! A fixture names what to print on a line `// emit: NAME ...` (entry
//! points such as `shade` or `m.diffuse`); without one, every entry of the
//! program is printed. Images are found in `examples/textures`.
//!
//! After a deliberate change to lowering, review the diff and bless it with
//! `UPDATE_EXPECT=1 cargo test --test lower_golden`.

use std::path::{Path, PathBuf};

/// The fixtures, sorted so failures come in a stable order.
fn fixtures() -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = std::fs::read_dir("tests/lower")
        .expect("tests/lower exists")
        .map(|e| e.expect("a readable directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "tsl"))
        .collect();
    out.sort();
    out
}

/// The names on the fixture's `// emit:` lines.
fn emitted_names(source: &str) -> Vec<String> {
    source
        .lines()
        .filter_map(|l| l.trim().strip_prefix("// emit:"))
        .flat_map(|names| names.split_whitespace().map(str::to_string))
        .collect()
}

/// The golden text of one fixture: a header, then each function.
fn lower(path: &Path) -> String {
    let source = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let program = tsl::Compiler::new()
        .eager(true)
        .file(path)
        .import_path("examples/textures")
        .compile()
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let names = emitted_names(&source);
    let functions: Vec<tsl::Function> = if names.is_empty() {
        program.functions()
    } else {
        names
            .iter()
            .map(|n| program.function(n).unwrap_or_else(|| panic!("{}: no entry point `{n}`", path.display())))
            .collect()
    };
    // Images print by the path they were loaded from, which is absolute:
    // the golden files hold it relative to the repository.
    let root = format!("{}/", env!("CARGO_MANIFEST_DIR"));
    let file = path.file_name().unwrap_or_default().to_string_lossy();
    let mut text = format!("// The IR of {file} (RGB). Bless: UPDATE_EXPECT=1 cargo test --test lower_golden\n");
    for f in functions {
        text.push('\n');
        text.push_str(&f.ir_text().replace(&root, ""));
    }
    text
}

#[test]
fn lowered_fixtures_match_their_golden_ir() {
    let files = fixtures();
    assert!(files.len() >= 10, "only {} fixtures in tests/lower", files.len());
    let mut failed = Vec::new();
    for tsl_file in &files {
        let text = lower(tsl_file);
        let golden = Path::new(env!("CARGO_MANIFEST_DIR")).join(tsl_file.with_extension("ir"));
        // expect-test prints the expected text, the actual text and their
        // diff, names the file, and rewrites it under UPDATE_EXPECT=1.
        let checked = std::panic::catch_unwind(|| expect_test::expect_file![&golden].assert_eq(&text));
        if checked.is_err() {
            failed.push(golden.display().to_string());
        }
    }
    assert!(
        failed.is_empty(),
        "the lowered IR differs from {} golden file(s) (diffs above): {}\n\
         if the change is intended, rerun with UPDATE_EXPECT=1 cargo test --test lower_golden",
        failed.len(),
        failed.join(", ")
    );
}
