//! Bad input never panics, hangs or overflows the stack: it gets a located
//! diagnostic. Property tests feed arbitrary text and random token streams
//! through the whole front end.

use proptest::prelude::*;
use tsl::LoadOptions;

mod common;
use common::TOKENS;

fn check(src: &str) -> tsl::Checked {
    tsl::check_source("input.tsl", src, &LoadOptions::default())
}

/// Asserts the source is rejected with a nesting diagnostic.
fn assert_too_deep(src: &str) {
    let checked = check(src);
    let text = checked.render_diagnostics();
    assert!(text.contains("nested deeper than 256 levels"), "{}", &text[..text.len().min(2000)]);
    assert!(text.contains("input.tsl:1:"), "the error is located: {}", &text[..text.len().min(2000)]);
}

const DEEP: usize = 100_000;

#[test]
fn parentheses_nested_100000_deep() {
    assert_too_deep(&format!("float f() {{ return {}1{}; }}", "(".repeat(DEEP), ")".repeat(DEEP)));
}

#[test]
fn unary_chain_100000_long() {
    assert_too_deep(&format!("float f() {{ return {}1; }}", "- ".repeat(DEEP)));
}

// `binary_chain_100000_long_is_not_nesting` lowers and interprets the IR
// directly, so it lives in the crate: src/ir/tests/deep_chain.rs.

#[test]
fn blocks_nested_100000_deep() {
    assert_too_deep(&format!("float f() {{ {} return 1; {} }}", "{".repeat(DEEP), "}".repeat(DEEP)));
}

#[test]
fn else_if_chain_100000_long() {
    assert_too_deep(&format!(
        "float f(int i) {{ if i == 0 {{ return 0; }}{} return 1; }}",
        " else if i == 1 { return 1; }".repeat(DEEP)
    ));
}

#[test]
fn ternary_and_member_chains() {
    assert_too_deep(&format!("float f() {{ return {}1; }}", "true ? 1 : ".repeat(DEEP)));
    assert_too_deep(&format!("float f() {{ return P{}; }}", ".x".repeat(DEEP)));
    assert_too_deep(&format!("float f() {{ return {}1{}; }}", "[".repeat(DEEP), "]".repeat(DEEP)));
}

/// Just inside the limit, every pass runs in a default 2 MiB test thread.
#[test]
fn nesting_at_the_limit_is_accepted() {
    let depth = 250;
    let sources = [
        format!("float f(float x) {{ return {}x{}; }}", "(".repeat(depth), ")".repeat(depth)),
        format!("float f(float x) {{ return {}x; }}", "-".repeat(depth)),
        format!("float f(float x) {{ return x{}; }}", " + x".repeat(depth)),
        // Each level is a parenthesis and an addition: two levels.
        format!("float f(float x) {{ return {}x{}; }}", "(x + ".repeat(depth / 2), ")".repeat(depth / 2)),
        format!("float f() {{ {} return 1; {} }}", "{".repeat(depth), "}".repeat(depth)),
    ];
    for src in sources {
        let checked = check(&src);
        assert!(checked.is_ok(), "{}", checked.render_diagnostics());
    }
}

#[test]
fn ten_megabytes_of_garbage() {
    // Deterministic pseudo-random printable bytes and token fragments.
    let pieces = ["{", "}", "(", ")", "float", "x", "=", ";", "material", "$", "\"", "/*", "1.5", "+", "scene", "\n"];
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut src = String::with_capacity(10 << 20);
    while src.len() < 10 << 20 {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        src.push_str(pieces[(state % pieces.len() as u64) as usize]);
        src.push(' ');
    }
    let checked = check(&src);
    assert!(!checked.is_ok());
    assert!(checked.diagnostics.iter().all(|d| d.span.end as usize <= src.len()));
}

#[test]
fn invalid_utf8_file_is_a_located_error() {
    let dir = std::env::temp_dir().join(format!("tsl-utf8-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.tsl");
    std::fs::write(&path, b"float f() { return 1; }\n// caf\xe9\n").unwrap();
    let checked = tsl::check_file(&path, &LoadOptions::default());
    let text = checked.render_diagnostics();
    assert!(text.contains("not valid UTF-8"), "{text}");
    assert!(text.contains("bad.tsl:2:"), "located on the bad line: {text}");
    std::fs::remove_dir_all(&dir).ok();
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_text_never_panics(src in "\\PC{0,400}") {
        let checked = check(&src);
        for d in &checked.diagnostics {
            prop_assert!(d.span.start <= d.span.end);
        }
    }

    /// Arbitrary bytes, including invalid UTF-8, through the file loader.
    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let dir = std::env::temp_dir().join(format!("tsl-bytes-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("fuzz.tsl");
        std::fs::write(&path, &bytes).unwrap();
        let checked = tsl::check_file(&path, &LoadOptions::default());
        let _ = checked.render_diagnostics();
        prop_assert!(checked.is_ok() || !checked.diagnostics.is_empty());
    }

    #[test]
    fn random_token_streams_never_panic(tokens in proptest::collection::vec(0..TOKENS.len(), 0..120)) {
        let src: Vec<&str> = tokens.iter().map(|&i| TOKENS[i]).collect();
        let _ = check(&src.join(" "));
    }

    /// Streams that start as a valid function body reach the checker.
    #[test]
    fn random_bodies_never_panic(tokens in proptest::collection::vec(0..TOKENS.len(), 0..40)) {
        let body: Vec<&str> = tokens.iter().map(|&i| TOKENS[i]).collect();
        let _ = check(&format!("float f(float x) {{ {} ; return x; }}", body.join(" ")));
        let _ = check(&format!("material m = mix({}, mirror, lambert);", body.join(" ")));
    }
}

/// Found by the fuzzer (scripts/fuzz.sh): one stray token in a 4,000-item
/// array literal gave 2,687 syntax errors, each printing the 12 KB line,
/// and `tslc check` took seconds. Past `MAX_SYNTAX_ERRORS`, a count.
#[test]
fn a_cascade_of_syntax_errors_is_cut_short() {
    let src = std::fs::read_to_string("tests/data/fuzz/syntax_cascade.tsl").unwrap();
    let checked = check(&src);
    let errors = checked.diagnostics.iter().filter(|d| d.is_error()).count();
    assert_eq!(errors, tsl::syntax::parser::MAX_SYNTAX_ERRORS + 1);
    let text = checked.render_diagnostics();
    assert!(text.contains("more syntax errors not shown"), "{}", &text[text.len().saturating_sub(2000)..]);
}
