//! A source as the formatter sees it: its tokens with their byte spans, and
//! the comments in the gaps between them. The printer takes every token's
//! text and every comment from here; the verifier lexes the printed text
//! the same way and compares.

use crate::syntax::lexer::{Lexer, Tok};

/// A comment between two tokens.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Comment {
    /// Byte offsets of the comment's text (a line comment without its line
    /// end or the spaces before it).
    pub start: usize,
    pub end: usize,
    /// `// ...` rather than `/* ... */`.
    pub line: bool,
}

impl Comment {
    pub fn text<'s>(&self, src: &'s str) -> &'s str {
        &src[self.start..self.end]
    }
}

/// The tokens and comments of one source.
pub(super) struct Lexed {
    pub tokens: Vec<(usize, Tok, usize)>,
    pub comments: Vec<Comment>,
}

/// Lexes `src`; `None` when a token does not lex (the parser reports it).
pub(super) fn lex(src: &str) -> Option<Lexed> {
    let mut tokens = Vec::new();
    for t in Lexer::new(src) {
        tokens.push(t.ok()?);
    }
    let comments = scan_comments(src, &tokens);
    Some(Lexed { tokens, comments })
}

/// Comments are what lies between tokens besides whitespace (the lexer
/// skips exactly these two forms; block comments do not nest).
fn scan_comments(src: &str, tokens: &[(usize, Tok, usize)]) -> Vec<Comment> {
    let mut out = Vec::new();
    let mut prev = 0;
    let gaps = tokens.iter().map(|t| (t.0, t.2)).chain(std::iter::once((src.len(), src.len())));
    for (start, end) in gaps {
        let gap = &src[prev..start];
        let mut i = 0;
        while i < gap.len() {
            let rest = &gap[i..];
            if rest.starts_with("//") {
                let len = rest.find('\n').unwrap_or(rest.len());
                let text_len = rest[..len].trim_end().len();
                out.push(Comment { start: prev + i, end: prev + i + text_len, line: true });
                i += len;
            } else if let Some(body) = rest.strip_prefix("/*") {
                let len = body.find("*/").map_or(rest.len(), |e| e + 4);
                out.push(Comment { start: prev + i, end: prev + i + len, line: false });
                i += len;
            } else {
                i += rest.chars().next().map_or(1, char::len_utf8);
            }
        }
        prev = end;
    }
    out
}
