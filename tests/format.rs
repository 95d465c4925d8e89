//! `tsl::format`: every repository `.tsl` file formats to a fixed point with
//! the same AST (spans aside) and all its comments, in order.

use std::path::{Path, PathBuf};
use tsl::diag::FileId;

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

/// The Debug form of the AST with every `start: N, end: M` erased.
fn ast_without_spans(src: &str) -> String {
    let (ast, diags) = tsl::syntax::parse(FileId(0), src);
    assert!(diags.is_empty());
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

fn comments(src: &str) -> Vec<String> {
    let toks = tsl::syntax::lexer::tokenize(src);
    let mut out = Vec::new();
    let mut prev = 0;
    for (s, _, e) in
        toks.into_iter().flatten().chain(std::iter::once((src.len(), tsl::syntax::lexer::Tok::Semi, src.len())))
    {
        let gap = src[prev..s].trim();
        if !gap.is_empty() {
            out.extend(gap.split_whitespace().map(str::to_string));
        }
        prev = e;
    }
    out
}

#[test]
fn repository_files_format_to_a_fixed_point_with_the_same_ast_and_comments() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut all = Vec::new();
    for d in ["stdlib", "examples", "tests/check/ok"] {
        files(&root.join(d), &mut all);
    }
    assert!(all.len() > 20);
    for f in all {
        let src = std::fs::read_to_string(&f).unwrap();
        let once = tsl::format::format_source(&src).unwrap_or_else(|_| panic!("{} does not parse", f.display()));
        let twice = tsl::format::format_source(&once).unwrap();
        assert_eq!(twice, once, "{} is not a fixed point", f.display());
        assert_eq!(ast_without_spans(&once), ast_without_spans(&src), "{}: the AST changed", f.display());
        assert_eq!(comments(&once), comments(&src), "{}: comments changed", f.display());
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
