//! A flat chain is long, not deep (moved from tests/robustness.rs: it reads
//! the lowered IR, which is crate-private).

use crate::LoadOptions;

fn check(src: &str) -> crate::Checked {
    crate::check_source("input.tsl", src, &LoadOptions::default())
}

/// Asserts the source is rejected with a nesting diagnostic (as
/// tests/robustness.rs's helper of the same name).
fn assert_too_deep(src: &str) {
    let checked = check(src);
    let text = checked.render_diagnostics();
    assert!(text.contains("nested deeper than 256 levels"), "{}", &text[..text.len().min(2000)]);
    assert!(text.contains("input.tsl:1:"), "the error is located: {}", &text[..text.len().min(2000)]);
}

const DEEP: usize = 100_000;

/// A flat chain is long, not deep: 100,000 terms check clean, lower, and
/// run in the interpreter, all on a default 2 MiB test thread (the passes
/// grow their stack as they recurse along the chain).
#[test]
fn binary_chain_100000_long_is_not_nesting() {
    let src = format!("float f(float x) {{ return x{}; }}", " - x * 0.5".repeat(DEEP));
    let checked = check(&src);
    assert!(checked.is_ok(), "{}", &checked.render_diagnostics()[..2000.min(checked.render_diagnostics().len())]);
    let (module, _, diags) = crate::ir::lower::lower_entries(&checked.program, crate::ColorModel::Rgb, |_, _| true);
    assert!(diags.is_empty(), "{diags:?}");
    let f = module.function("f").expect("f is lowered");
    let globals = crate::ShadingGlobals::default().words();
    let mut out = [0u32];
    crate::interp::run(f, &globals, &[2.0f32.to_bits()], &mut out);
    // x - x/2 - x/2 - ... : 2 - 100,000 exactly, every step exact in f32.
    assert_eq!(f32::from_bits(out[0]), 2.0 - DEEP as f32);
    // Real nesting inside the chain still counts.
    assert_too_deep(&format!("float f() {{ return 1 + {}1{}; }}", "(".repeat(300), ")".repeat(300)));
    assert_too_deep(&format!("float f() {{ return 1{}; }}", " + (1".repeat(300) + &")".repeat(300)));
}
