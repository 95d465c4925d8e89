//! `tsl::format`: formatting never changes what a program means or drops a
//! comment, and is idempotent, tested as rustfmt and gofmt are: every
//! repository `.tsl` file, the same files with a comment in every token
//! gap, fixed programs with a comment in each gap in turn, and generated
//! programs (proptest) with comments in random gaps. Each output is
//! compared with its input by this file's own oracle (the AST's debug
//! form without spans, the tokens' spelling, the comments' texts), apart
//! from the verifier inside `format_source`.

#[path = "random_programs/generator.rs"]
mod generator;
#[path = "format/syntax_programs.rs"]
mod syntax_programs;

use proptest::prelude::*;
use proptest::test_runner::Config;
use std::path::{Path, PathBuf};
use tsl::diag::FileId;
use tsl::syntax::lexer::{Tok, tokenize};

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            files(&p, out);
        } else if p.extension().is_some_and(|x| x == "tsl") {
            out.push(p);
        }
    }
}

// ------------------------------------------------------------ the oracle

/// The Debug form of the AST with every `start: N, end: M` erased
/// (depths, which count parentheses, stay).
fn ast_without_spans(src: &str) -> String {
    let (ast, diags) = tsl::syntax::parse(FileId(0), src);
    assert!(diags.is_empty(), "{diags:?}\n{src}");
    let s = format!("{ast:?}");
    let mut out = String::new();
    let mut rest = s.as_str();
    while let Some(i) = rest.find("start: ") {
        out.push_str(&rest[..i]);
        let after = &rest[i..];
        let end = after.find('}').unwrap();
        rest = &after[end..];
    }
    out.push_str(rest);
    out
}

/// The tokens as written, without the trailing commas the style adds
/// and drops.
fn spelled_tokens(src: &str) -> Vec<String> {
    let toks: Vec<(usize, Tok, usize)> = tokenize(src).into_iter().map(Result::unwrap).collect();
    (0..toks.len())
        .filter(|&i| !(toks[i].1 == Tok::Comma && matches!(toks.get(i + 1), Some((_, Tok::RParen | Tok::RBracket, _)))))
        .map(|i| src[toks[i].0..toks[i].2].to_string())
        .collect()
}

/// Every comment, in order, with the white space at the ends of its lines
/// dropped (fmt removes trailing spaces everywhere, `docs/fmt.md`).
fn comment_texts(src: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut prev = 0;
    let ends = tokenize(src).into_iter().map(|t| t.unwrap()).map(|t| (t.0, t.2));
    for (start, end) in ends.chain([(src.len(), src.len())]) {
        let mut gap = &src[prev..start];
        while let Some(i) = gap.find('/') {
            let rest = &gap[i..];
            let len = if rest.starts_with("//") {
                rest.find('\n').unwrap_or(rest.len())
            } else {
                rest.find("*/").unwrap() + 2
            };
            let text: Vec<&str> = rest[..len].split('\n').map(str::trim_end).collect();
            out.push(text.join("\n"));
            gap = &rest[len..];
        }
        prev = end;
    }
    out
}

/// Formats `src`, which must be accepted, and checks the output against
/// the input with this file's oracle, and that formatting it again
/// changes nothing.
#[track_caller]
fn formats_faithfully(src: &str) -> String {
    let once =
        tsl::format::format_source(src).unwrap_or_else(|d| panic!("refused: {}\n--- input:\n{src}", d[0].message));
    let twice = tsl::format::format_source(&once)
        .unwrap_or_else(|d| panic!("output refused: {}\n--- output:\n{once}", d[0].message));
    assert_eq!(twice, once, "not idempotent\n--- input:\n{src}");
    assert_eq!(
        ast_without_spans(&once),
        ast_without_spans(src),
        "the AST changed\n--- input:\n{src}\n--- output:\n{once}"
    );
    assert_eq!(
        spelled_tokens(&once),
        spelled_tokens(src),
        "the tokens changed\n--- input:\n{src}\n--- output:\n{once}"
    );
    assert_eq!(
        comment_texts(&once),
        comment_texts(src),
        "the comments changed\n--- input:\n{src}\n--- output:\n{once}"
    );
    once
}

// ------------------------------------------------------------ comments in gaps

/// The comments the tests insert, by kind: line, block, a block of
/// several lines (its inner lines indented, with trailing spaces), and
/// ones whose text looks like code or other comments.
fn comment(kind: usize, n: usize) -> String {
    match kind % 5 {
        0 => format!(" // c{n}\n"),
        1 => format!(" /* c{n} */ "),
        2 => format!(" /* c{n}\n      second line   \n   */ "),
        3 => format!(" // c{n} ) ] }} , ; /* not a block\n"),
        _ => format!(" /* c{n} // not a line /* not nested */ "),
    }
}

/// The number of gaps between the tokens of `src` (one before the first
/// token, one after the last).
fn gaps(src: &str) -> usize {
    tokenize(src).len() + 1
}

/// `src` with `comment` text inserted in the chosen gaps (`(gap, kind)`),
/// each just before the token that ends the gap, or at the end of the file.
fn with_comments(src: &str, chosen: &[(usize, usize)]) -> String {
    let starts: Vec<usize> = tokenize(src).into_iter().map(|t| t.unwrap().0).chain([src.len()]).collect();
    let mut chosen = chosen.to_vec();
    chosen.sort_by_key(|c| c.0);
    let mut out = String::new();
    let mut at = 0;
    for (n, (gap, kind)) in chosen.into_iter().enumerate() {
        let pos = starts[gap.min(starts.len() - 1)];
        out.push_str(&src[at..pos]);
        out.push_str(&comment(kind, n));
        at = pos;
    }
    out.push_str(&src[at..]);
    out
}

// ------------------------------------------------------------ repository files

/// Every `.tsl` file of the repository that parses.
fn repository_sources() -> Vec<(PathBuf, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut all = Vec::new();
    for d in ["stdlib", "examples", "tests", "editors"] {
        if root.join(d).is_dir() {
            files(&root.join(d), &mut all);
        }
    }
    all.sort();
    all.into_iter()
        .filter_map(|f| {
            let src = std::fs::read_to_string(&f).ok()?;
            let (_, diags) = tsl::syntax::parse(FileId(0), &src);
            (!diags.iter().any(|d| d.is_error())).then_some((f, src))
        })
        .collect()
}

#[test]
fn repository_files_format_to_a_fixed_point_with_the_same_ast_and_comments() {
    let sources = repository_sources();
    // stdlib, examples, tests/check/ok and the error fixtures that parse.
    assert!(sources.len() > 150, "only {} files", sources.len());
    for dir in ["stdlib/", "examples/techniques/", "tests/check/ok/", "tests/check/err/", "tests/lower/"] {
        assert!(sources.iter().any(|(f, _)| f.to_string_lossy().contains(dir)), "no file of {dir}");
    }
    for (f, src) in &sources {
        let out = std::panic::catch_unwind(|| formats_faithfully(src));
        assert!(out.is_ok(), "{}", f.display());
    }
}

#[test]
fn repository_files_with_a_comment_in_every_gap_keep_them_all() {
    for (f, src) in repository_sources() {
        // Line comments everywhere, then every kind in turn.
        for pass in 0..2 {
            let chosen: Vec<(usize, usize)> = (0..gaps(&src)).map(|g| (g, pass * g)).collect();
            let commented = with_comments(&src, &chosen);
            let out = std::panic::catch_unwind(|| formats_faithfully(&commented));
            assert!(out.is_ok(), "{} with comments in every gap (pass {pass})", f.display());
        }
    }
}

// ------------------------------------------------------------ fixed programs, every gap

/// Programs holding every form of the grammar, to put a comment in each
/// gap of in turn.
const EVERY_FORM: [&str; 3] = [
    r#"import "lib/util.tsl";
const float[5] W = [0.1, 0.2, 0.3, 0.4, 0.5,];
const color S = spectrum([(400.0, 0.1), (500.0, 0.5), (600.0, 0.9)]);
const vector V = (1, -2, 3);
const float T = (1.5,);
const vec2 U = uv(0.5, 0.25);
float f(float x, int n = 3, vector d = vector(0.5, 1, -2),) {
    float[4] a = [x, x * 2, -x, (x + 1) / 2];
    float y;
    y += a[n % 4] * d.x;
    if x < 0 && !(n == 2) { return -x; } else if x > 1 { y = 1; } else { y = 0; }
    for i in 0..n { if i == 2 { break; } continue; }
    while false {}
    { y -= 1; }
    return x > 0 ? y : f(x: -x, n: n + 1,);
}"#,
    r#"material m(color kd = rgb(0.5, 0.5, 0.5), float k = 0.5) {
    color reflection(vector wi, color light, vector wo) { return kd * light * k; }
    normal normal() { return N; }
}
material t(material a, material b) = mix(0.5, a, b,);
material w = blend(noise(), [m(kd: rgb(1, 0, 0)), m(), mirror, glass, t(m, m)], spline: true);
material v = blend(noise(), [0.1, 0.2, 0.3, 0.4, 0.5]);"#,
    r#"scene {
    camera { from (0, 1, -4); to (0, 1, 0); fov 40; }
    light point { position (0, 4, 0); intensity 10; }
    object sphere { center (0, 1, 0); radius 1; material w; }
    render { spp 16; }
    background rgb(0, 0, 0);
    flag;
}"#,
];

#[test]
fn a_comment_in_each_gap_in_turn_survives_with_the_program() {
    for src in EVERY_FORM {
        for gap in 0..gaps(src) {
            // A line comment, and a block comment of one or more lines.
            formats_faithfully(&with_comments(src, &[(gap, 0)]));
            formats_faithfully(&with_comments(src, &[(gap, 1 + gap % 2)]));
        }
        // And at the very end, without a line end.
        formats_faithfully(&format!("{src}\n// the end"));
        formats_faithfully(&format!("{src} /* the end */"));
    }
}

#[test]
fn comments_in_every_gap_at_once_survive_with_the_program() {
    for src in EVERY_FORM {
        for kind in 0..5 {
            let chosen: Vec<(usize, usize)> = (0..gaps(src)).map(|g| (g, kind)).collect();
            formats_faithfully(&with_comments(src, &chosen));
        }
        let mixed: Vec<(usize, usize)> = (0..gaps(src)).map(|g| (g, g * 7 % 5)).collect();
        formats_faithfully(&with_comments(src, &mixed));
        // Windows line ends: written as `\n`, the comments the same.
        formats_faithfully(&with_comments(src, &mixed).replace('\n', "\r\n"));
    }
}

// ------------------------------------------------------------ generated programs

/// `cases` unless `PROPTEST_CASES` says otherwise (for longer campaigns).
fn config(cases: u32) -> Config {
    let cases = std::env::var("PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(cases);
    Config { cases, failure_persistence: None, ..Config::default() }
}

/// Up to `n` comments in random gaps (`(index, kind)`; the index is
/// reduced to a gap of the program).
fn random_comments(n: usize) -> impl Strategy<Value = Vec<(proptest::sample::Index, usize)>> {
    proptest::collection::vec((any::<proptest::sample::Index>(), 0..5usize), 0..n)
}

fn place(src: &str, comments: &[(proptest::sample::Index, usize)]) -> String {
    let n = gaps(src);
    let chosen: Vec<(usize, usize)> = comments.iter().map(|(i, k)| (i.index(n), *k)).collect();
    with_comments(src, &chosen)
}

proptest! {
    #![proptest_config(config(16))]

    /// The random programs of `tests/random_programs.rs` (well typed:
    /// helpers, materials, texture trees), with comments in random gaps.
    #[test]
    fn generated_typed_programs_with_comments_format_faithfully(
        program in generator::program(),
        comments in random_comments(24),
    ) {
        formats_faithfully(&place(&program.0, &comments));
    }
}

proptest! {
    #![proptest_config(config(96))]

    /// Programs of every syntactic form (scene blocks, data arrays, named
    /// arguments, trailing commas, parentheses), with comments in random
    /// gaps.
    #[test]
    fn generated_syntax_with_comments_formats_faithfully(
        program in syntax_programs::program(),
        comments in random_comments(16),
    ) {
        formats_faithfully(&place(&program, &comments));
    }
}

/// The repository's own `.tsl` files, formatted. Not the error fixtures of
/// `tests/check/err/` (their expected diagnostics carry line and column) nor
/// `tests/data/fuzz/` (they do not parse).
const FORMATTED_DIRS: [&str; 5] = ["stdlib", "examples", "tests/check/ok", "tests/lower", "tests/data/regressions"];

#[test]
fn repository_files_are_formatted() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut all = Vec::new();
    for d in FORMATTED_DIRS {
        files(&root.join(d), &mut all);
    }
    let unformatted: Vec<String> = all
        .iter()
        .filter(|f| {
            let src = std::fs::read_to_string(f).unwrap();
            tsl::format::format_source(&src).map_or(true, |out| out != src)
        })
        .map(|f| f.strip_prefix(root).unwrap_or(f).display().to_string())
        .collect();
    assert!(
        unformatted.is_empty(),
        "not formatted (run `cargo run -- fmt {}`): {}",
        FORMATTED_DIRS.join(" "),
        unformatted.join(", ")
    );
}

// ------------------------------------------------------------ `tslc fmt`

fn tslc_fmt(args: &[&str], stdin: &str) -> std::process::Output {
    use std::io::Write;
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_tslc"))
        .arg("fmt")
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(stdin.as_bytes()).unwrap();
    child.wait_with_output().unwrap()
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tslc-fmt-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    dir
}

const UGLY: &str = "float f(float x){return x*2;}\n";
const PRETTY: &str = "float f(float x) {\n    return x * 2;\n}\n";

#[test]
fn fmt_rewrites_files_and_directories_in_place() {
    let dir = scratch("in-place");
    std::fs::write(dir.join("a.tsl"), UGLY).unwrap();
    std::fs::write(dir.join("sub/b.tsl"), UGLY).unwrap();
    std::fs::write(dir.join("sub/notes.txt"), UGLY).unwrap();
    let o = tslc_fmt(&[dir.to_str().unwrap()], "");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read_to_string(dir.join("a.tsl")).unwrap(), PRETTY);
    assert_eq!(std::fs::read_to_string(dir.join("sub/b.tsl")).unwrap(), PRETTY);
    assert_eq!(std::fs::read_to_string(dir.join("sub/notes.txt")).unwrap(), UGLY, "only .tsl files");
    // No temporary is left beside them.
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2);
    // A file that does not parse is reported where it breaks and left as it is.
    std::fs::write(dir.join("bad.tsl"), "float f( {").unwrap();
    let o = tslc_fmt(&[dir.join("bad.tsl").to_str().unwrap()], "");
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("bad.tsl:1:"), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read_to_string(dir.join("bad.tsl")).unwrap(), "float f( {");
}

#[test]
fn fmt_check_prints_a_unified_diff_exits_1_and_changes_nothing() {
    let dir = scratch("check");
    let file = dir.join("a.tsl");
    std::fs::write(&file, format!("// keep\n{UGLY}const int N = 3;\n")).unwrap();
    let o = tslc_fmt(&["--check", file.to_str().unwrap()], "");
    assert_eq!(o.status.code(), Some(1));
    let diff = String::from_utf8_lossy(&o.stdout);
    let name = file.display().to_string();
    let expected = format!(
        "--- {name}\n+++ {name} (formatted)\n@@ -1,3 +1,5 @@\n // keep\n-float f(float x){{return x*2;}}\n\
         +float f(float x) {{\n+    return x * 2;\n+}}\n const int N = 3;\n"
    );
    assert_eq!(diff, expected);
    assert!(std::fs::read_to_string(&file).unwrap().contains("{return x*2;}"));
    // Formatted: silent, exit 0.
    std::fs::write(&file, PRETTY).unwrap();
    let o = tslc_fmt(&["--check", file.to_str().unwrap()], "");
    assert!(o.status.success() && o.stdout.is_empty());
}

#[test]
fn fmt_reads_standard_input_and_writes_standard_output() {
    let o = tslc_fmt(&["-"], UGLY);
    assert!(o.status.success());
    assert_eq!(String::from_utf8_lossy(&o.stdout), PRETTY);
    let o = tslc_fmt(&[], UGLY);
    assert_eq!(String::from_utf8_lossy(&o.stdout), PRETTY, "no file is standard input");
    let o = tslc_fmt(&["--check", "-"], UGLY);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stdout).starts_with("--- <stdin>\n"));
    let o = tslc_fmt(&["-", "--stdin-path", "shaders/m.tsl"], "float f( {");
    assert_eq!(o.status.code(), Some(1));
    assert!(o.stdout.is_empty());
    assert!(String::from_utf8_lossy(&o.stderr).contains("shaders/m.tsl:1:"));
}
