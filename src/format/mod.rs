//! `tslc fmt`: prints a parsed file in the one canonical style (see
//! `docs/fmt.md`), and proves before it answers that the printed text is
//! the same program with the same comments.
//!
//! Invariant: [`format_source`] never returns text that means something
//! else. The printer (`printer.rs`) takes every token's text and every
//! comment from the source and only chooses the white space between them,
//! through a layout document (`doc.rs`); the verifier (`verify.rs`) then
//! lexes and parses the printed text again and compares it with the input:
//! the syntax tree with spans ignored (`same_tree.rs`), every token's
//! spelling, and every comment, in order. When they differ, formatting is
//! refused with a diagnostic at the input's location and nothing is
//! written. The command line (`tslc fmt`, in place, `--check` and standard
//! input) and the language server's formatting all go through
//! [`format_source`], so all get the guarantee.

mod doc;
mod lexed;
mod printer;
mod same_tree;
mod verify;

use crate::diag::{Diagnostic, FileId};
pub use same_tree::QUOTED_CHARS;

/// The line width the printer aims for.
pub const WIDTH: usize = 100;

/// Formats one source file. Returns its lexer and parser diagnostics
/// (against `FileId(0)`) when it does not parse, and a diagnostic saying
/// formatting was refused (naming what would change, at the input's
/// location) when the printed text would not be the same program with the
/// same comments.
///
/// ```
/// let out = tsl::format::format_source("float  f(float x){return x*2;}").unwrap();
/// assert_eq!(out, "float f(float x) {\n    return x * 2;\n}\n");
/// ```
pub fn format_source(src: &str) -> Result<String, Vec<Diagnostic>> {
    let (ast, diags) = crate::syntax::parse(FileId(0), src);
    if diags.iter().any(|d| d.is_error()) {
        return Err(diags);
    }
    let Some(lexed) = lexed::lex(src) else { return Err(diags) };
    let out = print(src, &lexed, &ast);
    // Idempotence (formatting the output changes nothing) is not checked
    // here: it would cost a second whole formatting, and a second pass
    // that moved white space would still keep the program and its
    // comments, which is what the check below guarantees. The tests check
    // it on every repository file and on generated programs.
    verify::same_program(src, &lexed, &ast, &out)?;
    Ok(out)
}

/// Whether `diagnostic` is [`format_source`] refusing a formatting that
/// would change the program (a formatter bug to report), rather than the
/// source's own syntax error. Editors show the first as a failed request:
/// the user asked for a formatting and gets none.
pub fn is_refusal(diagnostic: &Diagnostic) -> bool {
    diagnostic.message.starts_with(verify::REFUSED)
}

/// The printed text, before verification.
fn print(src: &str, lexed: &lexed::Lexed, ast: &crate::syntax::ast::SourceFile) -> String {
    let out = doc::render(&printer::print(src, lexed, ast));
    // Trailing spaces never survive, and the file ends with one newline.
    let mut lines: Vec<&str> = out.lines().map(str::trim_end).collect();
    while lines.last().is_some_and(|l| l.is_empty()) {
        lines.pop();
    }
    let mut out = lines.join("\n");
    if !out.is_empty() {
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests;
