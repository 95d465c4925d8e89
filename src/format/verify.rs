//! The formatter checks its own output before anyone writes it: the printed
//! text is lexed and parsed again and must be the same program, with the
//! same comments, as the input. Three comparisons, each reported at the
//! input's location:
//!
//! - the syntax trees, spans ignored (`same_tree.rs`): the same items,
//!   statements, expressions, names, values, operators and parentheses;
//! - the tokens' spelling, in order (`1.50` stays `1.50`, `uv` stays `uv`),
//!   except the trailing commas of lists, which the style adds or drops;
//! - the comments, in order, each the same kind (`//` or `/* */`) with the
//!   same text, except white space at the end of each of its lines (the
//!   printer removes trailing spaces everywhere, and writes `\n` line
//!   ends). This is what `docs/fmt.md` calls "the same comment".

use super::lexed::{self, Comment, Lexed};
use super::same_tree::{self, Difference, escaped, quote};
use crate::diag::{Diagnostic, FileId, Span};
use crate::syntax::ast::SourceFile;
use crate::syntax::lexer::{Tok, tokenize};

/// Checks that `out`, the formatting of `src` (lexed and parsed as
/// `lexed` and `ast`), is the same program with the same comments; else a
/// diagnostic saying formatting was refused and what would change (one, as
/// `format_source` returns it).
pub(super) fn same_program(src: &str, lexed: &Lexed, ast: &SourceFile, out: &str) -> Result<(), Vec<Diagnostic>> {
    let located = |d: Difference| refused(src, d, "it would change the program");
    let (out_ast, diags) = crate::syntax::parse(FileId(0), out);
    let broken = diags.iter().find(|d| d.is_error());
    let out_lexed = lexed::lex(out);
    let (Some(out_lexed), None) = (out_lexed, broken) else {
        // A printer bug broke the text: say where, in the input's terms.
        let (at, why) = match broken {
            Some(d) => (d.span.start as usize, d.message.clone()),
            None => (out.len(), "a token would not lex".to_string()),
        };
        let span = input_span_near(lexed, out, at);
        let what = format!("its output would not parse ({why})");
        return Err(refused(src, Difference { span, subject: "the text".into(), change: String::new() }, &what));
    };
    same_tree::same_file(ast, &out_ast).map_err(located)?;
    same_spelling(src, lexed, out, &out_lexed).map_err(located)?;
    same_comments(src, lexed, out, &out_lexed).map_err(|d| refused(src, d, "it would lose or change a comment"))
}

/// How every refusal's message starts ([`super::is_refusal`]).
pub(super) const REFUSED: &str = "formatting refused";

/// The diagnostic: "formatting refused because it would change the
/// program: the array at 2:5 would have 1 element instead of 5".
fn refused(src: &str, d: Difference, because: &str) -> Vec<Diagnostic> {
    let (line, col) = line_col(src, d.span.start as usize);
    let what = if d.change.is_empty() {
        format!("near {line}:{col}")
    } else {
        format!("{} at {line}:{col} {}", d.subject, d.change)
    };
    vec![
        Diagnostic::error(d.span, format!("{REFUSED} because {because}: {what}"))
            .with_primary(if d.change.is_empty() { "here".to_string() } else { d.change })
            .with_help(
                "`tslc fmt` checks that what it prints is the same program with the same comments; \
                 this formatting is not, so nothing was written. This is a bug in the formatter: \
                 please report it with this file.",
            ),
    ]
}

/// The 1-based line and column (in characters) of a byte offset.
fn line_col(src: &str, offset: usize) -> (usize, usize) {
    let before = &src[..offset.min(src.len())];
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    (before.matches('\n').count() + 1, before[line_start..].chars().count() + 1)
}

/// Whether token `i` of `tokens` is a trailing comma (before `)` or `]`),
/// which the style may add or drop.
fn trailing_comma(tokens: &[(usize, Tok, usize)], i: usize) -> bool {
    tokens[i].1 == Tok::Comma && matches!(tokens.get(i + 1), Some((_, Tok::RParen | Tok::RBracket, _)))
}

/// The tokens that must be printed, spelled as written: all but the
/// trailing commas.
fn kept(tokens: &[(usize, Tok, usize)]) -> impl Iterator<Item = (usize, usize)> + '_ {
    (0..tokens.len()).filter(|&i| !trailing_comma(tokens, i)).map(|i| (tokens[i].0, tokens[i].2))
}

fn same_spelling(src: &str, lexed: &Lexed, out: &str, out_lexed: &Lexed) -> Result<(), Difference> {
    let mut theirs = kept(&out_lexed.tokens);
    for (s, e) in kept(&lexed.tokens) {
        let change = match theirs.next() {
            Some((t, u)) if out[t..u] == src[s..e] => continue,
            Some((t, u)) => format!("would become `{}`", escaped(&out[t..u])),
            None => "would be lost".into(),
        };
        let span = Span::new(FileId(0), s, e);
        return Err(Difference { span, subject: format!("`{}`", escaped(&src[s..e])), change });
    }
    match theirs.next() {
        Some((t, u)) => {
            let span = Span::new(FileId(0), src.len(), src.len());
            Err(Difference {
                span,
                subject: "the end of the file".into(),
                change: format!("would gain `{}`", escaped(&out[t..u])),
            })
        }
        None => Ok(()),
    }
}

/// Whether two comments' texts are the same but for the white space at
/// the end of each line.
fn same_text(a: &str, b: &str) -> bool {
    a.split('\n').map(str::trim_end).eq(b.split('\n').map(str::trim_end))
}

fn same_comments(src: &str, lexed: &Lexed, out: &str, out_lexed: &Lexed) -> Result<(), Difference> {
    let ours = &lexed.comments;
    let theirs = &out_lexed.comments;
    let same = |a: &Comment, b: &Comment| a.line == b.line && same_text(a.text(src), b.text(out));
    let Some(k) = (0..ours.len().max(theirs.len())).find(|&k| match (ours.get(k), theirs.get(k)) {
        (Some(a), Some(b)) => !same(a, b),
        _ => true,
    }) else {
        return Ok(());
    };
    match (ours.get(k), theirs.get(k)) {
        (Some(a), b) => {
            let span = Span::new(FileId(0), a.start, a.end);
            let change = match b {
                Some(b) if theirs.len() >= ours.len() => format!("would become {}", quote(b.text(out))),
                _ => "would be lost".to_string(),
            };
            Err(Difference { span, subject: "the comment".into(), change })
        }
        (None, b) => {
            let at = b.map_or(out.len(), |b| b.start);
            let span = input_span_near(lexed, out, at);
            let text = b.map_or(String::new(), |b| quote(b.text(out)));
            Err(Difference { span, subject: "the text".into(), change: format!("would gain the comment {text}") })
        }
    }
}

/// The input's place for a byte offset of the output: the input token
/// that corresponds to the first output token at or after it (counting
/// tokens, commas aside, since the style adds and drops some).
fn input_span_near(lexed: &Lexed, out: &str, at: usize) -> Span {
    let before = tokenize(out).iter().flatten().filter(|t| t.0 < at && t.1 != Tok::Comma).count();
    let token = lexed.tokens.iter().filter(|t| t.1 != Tok::Comma).nth(before);
    match token {
        Some(&(s, _, e)) => Span::new(FileId(0), s, e),
        None => {
            let end = lexed.tokens.last().map_or(0, |t| t.2);
            Span::new(FileId(0), end, end)
        }
    }
}
