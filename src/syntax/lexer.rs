//! The logos lexer. Every token carries its byte span; the parser consumes the
//! tokens through [`Lexer`], an iterator in the shape lalrpop's external-lexer
//! interface expects.
//!
//! Invariant: lexing never fails as a whole. A byte sequence that forms no
//! token becomes a [`LexError`] for that span and lexing continues after it.

use crate::syntax::ast::{Name, Names};
use logos::Logos;
use std::fmt;
use std::ops::Range;

/// What went wrong in a token that could not be lexed.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum LexError {
    /// A character that starts no token.
    #[default]
    UnexpectedChar,
    /// A `/* ...` comment that never ends.
    UnterminatedComment,
    /// A `"...` string that never ends on its line.
    UnterminatedString,
    /// A number that does not fit its type.
    BadNumber,
    /// A word with letters beyond ASCII (`café`): identifiers are ASCII.
    NonAsciiIdent,
}

impl fmt::Display for LexError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LexError::UnexpectedChar => "unexpected character",
            LexError::UnterminatedComment => "unterminated block comment",
            LexError::UnterminatedString => "unterminated string literal",
            LexError::BadNumber => "number literal out of range",
            LexError::NonAsciiIdent => "identifiers are ASCII letters, digits and `_`",
        })
    }
}

fn block_comment(lex: &mut logos::Lexer<'_, Tok>) -> logos::FilterResult<(), LexError> {
    // `/*` has been consumed; comments do not nest, as in C and OSL.
    match lex.remainder().find("*/") {
        Some(end) => {
            lex.bump(end + 2);
            logos::FilterResult::Skip
        }
        None => {
            lex.bump(lex.remainder().len());
            logos::FilterResult::Error(LexError::UnterminatedComment)
        }
    }
}

fn string_body(lex: &mut logos::Lexer<'_, Tok>) -> Result<String, LexError> {
    let s = lex.slice();
    if s.len() < 2 || !s.ends_with('"') {
        return Err(LexError::UnterminatedString);
    }
    Ok(s[1..s.len() - 1].to_string())
}

fn non_ascii_ident(_: &mut logos::Lexer<'_, Tok>) -> Result<Name, LexError> {
    Err(LexError::NonAsciiIdent)
}

fn int_value(lex: &mut logos::Lexer<'_, Tok>) -> Result<i32, LexError> {
    lex.slice().parse().map_err(|_| LexError::BadNumber)
}

fn float_value(lex: &mut logos::Lexer<'_, Tok>) -> Result<f64, LexError> {
    let v: f64 = lex.slice().parse().map_err(|_| LexError::BadNumber)?;
    if v.is_finite() { Ok(v) } else { Err(LexError::BadNumber) }
}

/// A TSL token.
#[derive(Logos, Debug, Clone, PartialEq)]
#[logos(error = LexError)]
#[logos(extras = Names)]
#[logos(skip r"[ \t\r\n\f]+")]
#[logos(skip(r"//[^\n]*", allow_greedy = true))]
pub enum Tok {
    #[token("/*", block_comment)]
    BlockComment,

    #[regex(r"[0-9]+", int_value, priority = 3)]
    Int(i32),
    // `1.` is not a float, so that `0..8` lexes as a range.
    #[regex(r"([0-9]+\.[0-9]+|\.[0-9]+)([eE][+-]?[0-9]+)?", float_value)]
    #[regex(r"[0-9]+[eE][+-]?[0-9]+", float_value)]
    Float(f64),
    // A string runs to the closing quote on the same line; escapes are not
    // needed for file names.
    #[regex(r#""[^"\n]*"?"#, string_body)]
    Str(String),
    #[regex(r"[A-Za-z_][A-Za-z0-9_]*", |lex| lex.extras.intern(lex.slice()), priority = 3)]
    // A word with other letters is one error, not one per character (the
    // longer match wins over the ASCII rule).
    #[regex(r"[\p{XID_Start}_][\p{XID_Continue}]*", non_ascii_ident, priority = 1)]
    Ident(Name),

    // Keywords.
    #[token("import")]
    Import,
    #[token("material")]
    Material,
    #[token("scene")]
    Scene,
    #[token("const")]
    Const,
    #[token("if")]
    If,
    #[token("else")]
    Else,
    #[token("for")]
    For,
    #[token("in")]
    In,
    #[token("while")]
    While,
    #[token("break")]
    Break,
    #[token("continue")]
    Continue,
    #[token("return")]
    Return,
    #[token("true")]
    True,
    #[token("false")]
    False,
    #[token("float")]
    KwFloat,
    #[token("int")]
    KwInt,
    #[token("bool")]
    KwBool,
    #[token("color")]
    KwColor,
    #[token("vector")]
    KwVector,
    #[token("point")]
    KwPoint,
    #[token("normal")]
    KwNormal,
    #[token("vec2")]
    KwVec2,
    #[token("uv")]
    KwUv,
    #[token("matrix")]
    KwMatrix,
    #[token("bsdf_sample")]
    KwBsdfSample,
    #[token("string")]
    KwString,
    #[token("void")]
    KwVoid,

    // Punctuation.
    #[token("(")]
    LParen,
    #[token(")")]
    RParen,
    #[token("{")]
    LBrace,
    #[token("}")]
    RBrace,
    #[token("[")]
    LBracket,
    #[token("]")]
    RBracket,
    #[token(",")]
    Comma,
    #[token(";")]
    Semi,
    #[token(":")]
    Colon,
    #[token("?")]
    Question,
    #[token(".")]
    Dot,
    #[token("..")]
    DotDot,
    #[token("=")]
    Assign,
    #[token("+=")]
    PlusAssign,
    #[token("-=")]
    MinusAssign,
    #[token("*=")]
    StarAssign,
    #[token("/=")]
    SlashAssign,
    #[token("+")]
    Plus,
    #[token("-")]
    Minus,
    #[token("*")]
    Star,
    #[token("/")]
    Slash,
    #[token("%")]
    Percent,
    #[token("!")]
    Not,
    #[token("==")]
    EqEq,
    #[token("!=")]
    NotEq,
    #[token("<")]
    Lt,
    #[token("<=")]
    Le,
    #[token(">")]
    Gt,
    #[token(">=")]
    Ge,
    #[token("&&")]
    AndAnd,
    #[token("||")]
    OrOr,
}

impl fmt::Display for Tok {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Tok::Int(v) => write!(f, "`{v}`"),
            Tok::Float(v) => write!(f, "`{v}`"),
            Tok::Str(s) => write!(f, "\"{s}\""),
            Tok::Ident(s) => write!(f, "`{s}`"),
            other => write!(f, "`{}`", other.text()),
        }
    }
}

impl Tok {
    /// The source text of a fixed token (keywords and punctuation).
    pub fn text(&self) -> &'static str {
        match self {
            Tok::BlockComment => "/*",
            Tok::Int(_) => "integer",
            Tok::Float(_) => "number",
            Tok::Str(_) => "string",
            Tok::Ident(_) => "identifier",
            Tok::Import => "import",
            Tok::Material => "material",
            Tok::Scene => "scene",
            Tok::Const => "const",
            Tok::If => "if",
            Tok::Else => "else",
            Tok::For => "for",
            Tok::In => "in",
            Tok::While => "while",
            Tok::Break => "break",
            Tok::Continue => "continue",
            Tok::Return => "return",
            Tok::True => "true",
            Tok::False => "false",
            Tok::KwFloat => "float",
            Tok::KwInt => "int",
            Tok::KwBool => "bool",
            Tok::KwColor => "color",
            Tok::KwVector => "vector",
            Tok::KwPoint => "point",
            Tok::KwNormal => "normal",
            Tok::KwVec2 => "vec2",
            Tok::KwUv => "uv",
            Tok::KwMatrix => "matrix",
            Tok::KwBsdfSample => "bsdf_sample",
            Tok::KwString => "string",
            Tok::KwVoid => "void",
            Tok::LParen => "(",
            Tok::RParen => ")",
            Tok::LBrace => "{",
            Tok::RBrace => "}",
            Tok::LBracket => "[",
            Tok::RBracket => "]",
            Tok::Comma => ",",
            Tok::Semi => ";",
            Tok::Colon => ":",
            Tok::Question => "?",
            Tok::Dot => ".",
            Tok::DotDot => "..",
            Tok::Assign => "=",
            Tok::PlusAssign => "+=",
            Tok::MinusAssign => "-=",
            Tok::StarAssign => "*=",
            Tok::SlashAssign => "/=",
            Tok::Plus => "+",
            Tok::Minus => "-",
            Tok::Star => "*",
            Tok::Slash => "/",
            Tok::Percent => "%",
            Tok::Not => "!",
            Tok::EqEq => "==",
            Tok::NotEq => "!=",
            Tok::Lt => "<",
            Tok::Le => "<=",
            Tok::Gt => ">",
            Tok::Ge => ">=",
            Tok::AndAnd => "&&",
            Tok::OrOr => "||",
        }
    }
}

/// A lexer error with the byte span it covers.
#[derive(Debug, Clone, PartialEq)]
pub struct SpannedLexError {
    pub error: LexError,
    pub span: Range<usize>,
}

/// The token stream as lalrpop consumes it: `(start, token, end)` triples.
pub struct Lexer<'src> {
    inner: logos::SpannedIter<'src, Tok>,
}

impl<'src> Lexer<'src> {
    pub fn new(src: &'src str) -> Self {
        Lexer { inner: Tok::lexer(src).spanned() }
    }

    /// `s` as a name of this lexer's file (a keyword used as a name).
    pub fn intern(&mut self, s: &str) -> Name {
        self.inner.extras.intern(s)
    }
}

#[cfg(test)]
thread_local! {
    /// The tokens (and errors) lexed on this thread, for tests of how many
    /// times a file is lexed.
    pub(crate) static TOKENS_LEXED: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

impl Iterator for Lexer<'_> {
    type Item = Result<(usize, Tok, usize), SpannedLexError>;

    fn next(&mut self) -> Option<Self::Item> {
        let (tok, span) = self.inner.next()?;
        #[cfg(test)]
        TOKENS_LEXED.with(|n| n.set(n.get() + 1));
        Some(match tok {
            Ok(tok) => Ok((span.start, tok, span.end)),
            Err(error) => Err(SpannedLexError { error, span }),
        })
    }
}

/// Lexes a whole source, for tests and tools: tokens and errors in order.
pub fn tokenize(src: &str) -> Vec<Result<(usize, Tok, usize), SpannedLexError>> {
    Lexer::new(src).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kinds(src: &str) -> Vec<Tok> {
        tokenize(src).into_iter().map(|t| t.unwrap().1).collect()
    }

    #[test]
    fn numbers_and_ranges() {
        assert_eq!(
            kinds("0..8 1.5 .5 2e3"),
            vec![Tok::Int(0), Tok::DotDot, Tok::Int(8), Tok::Float(1.5), Tok::Float(0.5), Tok::Float(2000.0),]
        );
    }

    #[test]
    fn comments_are_skipped() {
        assert_eq!(kinds("a // x\n /* y\n z */ b"), vec![Tok::Ident("a".into()), Tok::Ident("b".into())]);
    }

    #[test]
    fn errors_carry_spans_and_lexing_continues() {
        let toks = tokenize("a $ b");
        assert_eq!(toks.len(), 3);
        assert_eq!(toks[1], Err(SpannedLexError { error: LexError::UnexpectedChar, span: 2..3 }));
        let toks = tokenize("x /* never closed");
        assert!(matches!(&toks[1], Err(e) if e.error == LexError::UnterminatedComment));
        let toks = tokenize("\"abc\nd");
        assert!(matches!(&toks[0], Err(e) if e.error == LexError::UnterminatedString));
        let toks = tokenize("99999999999");
        assert!(matches!(&toks[0], Err(e) if e.error == LexError::BadNumber));
    }

    /// A word with non-ASCII letters is one error over the whole word;
    /// ASCII identifiers are untouched by that rule.
    #[test]
    fn a_non_ascii_word_is_one_error() {
        let toks = tokenize("café x_1 größe");
        assert_eq!(toks[0], Err(SpannedLexError { error: LexError::NonAsciiIdent, span: 0..5 }));
        assert_eq!(toks[1], Ok((6, Tok::Ident("x_1".into()), 9)));
        assert!(matches!(&toks[2], Err(e) if e.error == LexError::NonAsciiIdent && e.span == (10..17)));
        assert_eq!(toks.len(), 3);
    }
}
