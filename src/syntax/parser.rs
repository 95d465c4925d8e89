//! Parser glue: runs the lalrpop parser over the logos tokens and turns every
//! lexer and grammar error into a located [`Diagnostic`].
//!
//! Invariant: parsing never fails as a whole. It returns the items it could
//! read plus diagnostics; lalrpop's error recovery resumes at the next item or
//! statement so that one typo does not hide the errors after it.

use crate::diag::{Diagnostic, FileId, Span};
use crate::syntax::ast::{self, MAX_NESTING, SourceFile, TooDeep};
use crate::syntax::lexer::{Lexer, SpannedLexError, Tok};
use lalrpop_util::{ErrorRecovery, ParseError};

lalrpop_util::lalrpop_mod!(
    #[allow(clippy::all, clippy::pedantic, clippy::panic, unused_parens, unused_imports, dead_code)]
    grammar,
    "/tsl.rs"
);

/// An error raised from inside a grammar action.
#[derive(Debug, Clone, PartialEq)]
pub enum SyntaxError {
    TooDeep(Span),
}

pub(crate) fn deep(e: TooDeep) -> ParseError<usize, Tok, SyntaxError> {
    ParseError::User { error: SyntaxError::TooDeep(e.0) }
}

/// Builds an expression node from a grammar action.
pub(crate) fn node(
    file: FileId,
    l: usize,
    r: usize,
    kind: ast::ExprKind,
) -> Result<ast::Expr, ParseError<usize, Tok, SyntaxError>> {
    ast::Expr::new(kind, Span::new(file, l, r)).map_err(deep)
}

/// Parses one source file.
pub fn parse(file: FileId, src: &str) -> (SourceFile, Vec<Diagnostic>) {
    let mut diags = Vec::new();
    // Lexer errors are reported and the bad bytes skipped, so the parser sees
    // the rest of the file.
    let mut lex_errors: Vec<SpannedLexError> = Vec::new();
    let tokens: Vec<(usize, Tok, usize)> = Lexer::new(src)
        .filter_map(|t| match t {
            Ok(t) => Some(t),
            Err(e) => {
                lex_errors.push(e);
                None
            }
        })
        .collect();
    for e in &lex_errors {
        let span = Span::new(file, e.span.start, e.span.end);
        let mut d = Diagnostic::error(span, e.error.to_string());
        if let Some(c) = src.get(e.span.clone()).and_then(|s| s.chars().next())
            && e.error == crate::syntax::lexer::LexError::UnexpectedChar
        {
            d = Diagnostic::error(span, format!("unexpected character `{}`", c.escape_debug()));
        }
        diags.push(d);
    }

    let mut recovered: Vec<ErrorRecovery<usize, Tok, SyntaxError>> = Vec::new();
    let end = src.len();
    let result =
        grammar::SourceFileParser::new().parse(file, &mut recovered, tokens.into_iter().map(Ok::<_, SyntaxError>));
    for r in recovered {
        diags.push(parse_error(file, end, r.error));
    }
    let ast = match result {
        Ok(ast) => ast,
        Err(e) => {
            diags.push(parse_error(file, end, e));
            SourceFile::default()
        }
    };
    (ast, diags)
}

fn parse_error(file: FileId, eof: usize, e: ParseError<usize, Tok, SyntaxError>) -> Diagnostic {
    match e {
        ParseError::InvalidToken { location } => {
            Diagnostic::error(Span::new(file, location, location + 1), "invalid token")
        }
        ParseError::UnrecognizedEof { location, expected } => {
            let at = location.min(eof);
            Diagnostic::error(Span::new(file, at, at), "unexpected end of file").with_primary(expected_list(&expected))
        }
        ParseError::UnrecognizedToken { token: (l, tok, r), expected } => {
            let mut d = Diagnostic::error(Span::new(file, l, r), format!("unexpected {tok}"))
                .with_primary(expected_list(&expected));
            if let Some(help) = token_help(&tok, &expected) {
                d = d.with_help(help);
            }
            d
        }
        ParseError::ExtraToken { token: (l, tok, r) } => {
            Diagnostic::error(Span::new(file, l, r), format!("unexpected {tok} after the end of the file"))
        }
        ParseError::User { error: SyntaxError::TooDeep(span) } => {
            Diagnostic::error(span, format!("nesting deeper than {MAX_NESTING} levels"))
                .with_help("split the expression or block into smaller functions or local variables")
        }
    }
}

/// "expected one of ..." from lalrpop's terminal names.
fn expected_list(expected: &[String]) -> String {
    let names: Vec<String> = expected.iter().map(|e| e.trim_matches('"').to_string()).collect();
    match names.len() {
        0 => String::new(),
        1 => format!("expected {}", names[0]),
        n if n <= 8 => format!("expected one of: {}", names.join(", ")),
        _ => "expected an item, statement or expression".to_string(),
    }
}

fn token_help(tok: &Tok, expected: &[String]) -> Option<String> {
    let wants = |t: &str| expected.iter().any(|e| e == &format!("\"{t}\""));
    if wants(";") {
        return Some("statements and declarations end with `;`".into());
    }
    if matches!(tok, Tok::Material) {
        return Some("a function that builds a material tree is written `material name(params) = expr;`".into());
    }
    None
}
