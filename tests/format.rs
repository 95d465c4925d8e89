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
