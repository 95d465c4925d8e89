//! `scene { }` blocks read by hand: a generated scene of a million objects
//! is nearly all scene block, and lalrpop's state machine spent three
//! quarters of `tslc check` on it (23,000 instructions per sphere).
//!
//! Invariant: this is a shortcut that never changes a result. It accepts a
//! file only when the file has no lexer or syntax error, and then builds
//! the tree the grammar builds: the text around scene blocks goes through
//! the lalrpop parser (a file is a sequence of items, so the items of its
//! parts in order are the file's items), a property value that is not a
//! literal, a name or a tuple of literals and names goes through the
//! grammar's `Expr` parser, and every node is made by the same
//! constructors (`Expr::new`) as in the grammar's actions. Anything else
//! (an error, an unexpected token) gives `None`, and the caller parses the
//! whole file with lalrpop, which words the diagnostics.

use super::parser::{SyntaxError, grammar};
use crate::diag::{FileId, Span};
use crate::syntax::ast::{Expr, ExprKind, Ident, Item, Scene, SceneBlock, SceneEntry, SceneProp, SourceFile, UnaryOp};
use crate::syntax::lexer::{Lexer, Tok};

type Token = (usize, Tok, usize);

/// The file's tree if it has a scene block and no error at all; `None`
/// otherwise (the caller then parses it with lalrpop).
///
/// The file is lexed once: the tokens between scene blocks stream into
/// the lalrpop parser as they are read, and a `scene` keyword outside any
/// braces ends that stream.
pub(super) fn parse(file: FileId, src: &str) -> Option<SourceFile> {
    if !src.contains("scene") {
        return None;
    }
    let mut tokens = Tokens { lexer: Lexer::new(src), ahead: Vec::new(), failed: false };
    let mut items = Vec::new();
    while let Some(scene_start) = items_until_scene(file, &mut tokens, &mut items)? {
        let scene = scene(file, scene_start, &mut tokens)?;
        items.push(Item::Scene(scene));
    }
    // A file that only names `scene` (in a comment, say) was read whole by
    // lalrpop: its tree is the grammar's too.
    (!tokens.failed).then_some(SourceFile { items })
}

/// Parses the items up to the next `scene` keyword outside braces, or to
/// the end, with the lalrpop parser, appending them to `items`. The
/// `scene` keyword's start, or `Some(None)` at the end; `None` on any error.
fn items_until_scene(file: FileId, tokens: &mut Tokens<'_>, items: &mut Vec<Item>) -> Option<Option<usize>> {
    match tokens.peek(0) {
        None => return (!tokens.failed).then_some(None),
        Some(Tok::Scene) => return tokens.take().map(|(l, _, _)| Some(l)),
        Some(_) => {}
    }
    let mut depth = 0i64;
    let mut scene_start = None;
    let stream = std::iter::from_fn(|| {
        let t = tokens.next()??;
        match t.1 {
            Tok::LBrace => depth += 1,
            Tok::RBrace => depth -= 1,
            Tok::Scene if depth == 0 => {
                scene_start = Some(t.0);
                return None;
            }
            _ => {}
        }
        Some(Ok::<_, SyntaxError>(t))
    })
    // The parser never reads past the end it was given.
    .fuse();
    let mut recovered = Vec::new();
    let parsed = grammar::SourceFileParser::new().parse(file, &mut recovered, stream).ok()?;
    if !recovered.is_empty() || tokens.failed {
        return None;
    }
    items.extend(parsed.items);
    Some(scene_start)
}

/// The lexer with a few tokens of lookahead.
struct Tokens<'s> {
    lexer: Lexer<'s>,
    /// Tokens read ahead, the next last.
    ahead: Vec<Token>,
    /// Whether the lexer met an error.
    failed: bool,
}

impl Tokens<'_> {
    /// The next token: `Some(None)` at the end, `None` on a lexer error.
    fn next(&mut self) -> Option<Option<Token>> {
        if let Some(t) = self.ahead.pop() {
            return Some(Some(t));
        }
        match self.lexer.next() {
            None => Some(None),
            Some(Ok(t)) => Some(Some(t)),
            Some(Err(_)) => {
                self.failed = true;
                None
            }
        }
    }

    /// The next token, which must be there.
    fn take(&mut self) -> Option<Token> {
        self.next()?
    }

    /// The `n`th token ahead (0 is the next), left in place.
    fn peek(&mut self, n: usize) -> Option<&Tok> {
        while self.ahead.len() <= n {
            match self.lexer.next()? {
                Ok(t) => self.ahead.insert(0, t),
                Err(_) => {
                    self.failed = true;
                    return None;
                }
            }
        }
        self.ahead.get(self.ahead.len() - 1 - n).map(|t| &t.1)
    }
}

/// The scene block whose `scene` keyword starts at `l`.
fn scene(file: FileId, l: usize, tokens: &mut Tokens<'_>) -> Option<Scene> {
    let (_, Tok::LBrace, _) = tokens.take()? else { return None };
    let mut entries = Vec::new();
    // One buffer for every property value's tokens, one for a block's
    // properties.
    let mut value = Vec::new();
    let mut read = Vec::new();
    loop {
        let (nl, tok, nr) = tokens.take()?;
        if tok == Tok::RBrace {
            // Grown by doubling: up to half of it spare.
            entries.shrink_to_fit();
            return Some(Scene { entries, span: Span::new(file, l, nr) });
        }
        let name = scene_name(file, nl, tok, nr, tokens)?;
        let kind_follows = matches!(tokens.peek(1), Some(Tok::LBrace)) && is_scene_name(tokens.peek(0)?);
        if kind_follows || matches!(tokens.peek(0), Some(Tok::LBrace)) {
            let kind = match kind_follows {
                true => {
                    let (kl, k, kr) = tokens.take()?;
                    Some(scene_name(file, kl, k, kr, tokens)?)
                }
                false => None,
            };
            let (_, Tok::LBrace, _) = tokens.take()? else { return None };
            let r = loop {
                let (pl, tok, pr) = tokens.take()?;
                if tok == Tok::RBrace {
                    break pr;
                }
                let name = scene_name(file, pl, tok, pr, tokens)?;
                read.push(prop(file, name, tokens, &mut value)?);
            };
            // Exactly as long (a vector grown by pushes holds 4 for 3).
            let mut props = Vec::with_capacity(read.len());
            props.append(&mut read);
            let span = Span::new(file, nl, r);
            entries.push(SceneEntry::Block(SceneBlock { keyword: name, kind, props, span }));
        } else {
            entries.push(SceneEntry::Prop(prop(file, name, tokens, &mut value)?));
        }
    }
}

fn is_scene_name(tok: &Tok) -> bool {
    matches!(tok, Tok::Ident(_) | Tok::KwPoint | Tok::Material | Tok::KwNormal | Tok::KwColor)
}

/// The grammar's `SceneName`: an identifier or one of the keywords a scene
/// uses as a word.
fn scene_name(file: FileId, l: usize, tok: Tok, r: usize, tokens: &mut Tokens<'_>) -> Option<Ident> {
    let name = match tok {
        Tok::Ident(name) => name,
        Tok::KwPoint => tokens.lexer.intern("point"),
        Tok::Material => tokens.lexer.intern("material"),
        Tok::KwNormal => tokens.lexer.intern("normal"),
        Tok::KwColor => tokens.lexer.intern("color"),
        _ => return None,
    };
    Some(Ident { name, span: Span::new(file, l, r) })
}

/// A property after its name: its value, if any, and `;`.
fn prop(file: FileId, name: Ident, tokens: &mut Tokens<'_>, value: &mut Vec<Token>) -> Option<SceneProp> {
    value.clear();
    let r = loop {
        let t = tokens.take()?;
        match t.1 {
            Tok::Semi => break t.2,
            // An expression has no braces: the block is not well formed.
            Tok::LBrace | Tok::RBrace => return None,
            _ => value.push(t),
        }
    };
    let span = Span::new(file, name.span.start as usize, r);
    let value = match value.is_empty() {
        true => None,
        false => Some(expr(file, value)?),
    };
    Some(SceneProp { name, value, span })
}

/// The expression of `tokens`: most values of a generated scene by hand,
/// the rest by the grammar's `Expr` parser.
fn expr(file: FileId, tokens: &mut Vec<Token>) -> Option<Expr> {
    if is_simple(tokens) {
        return simple(file, tokens);
    }
    let mut recovered = Vec::new();
    let e = grammar::ExprParser::new().parse(file, &mut recovered, tokens.drain(..).map(Ok::<_, SyntaxError>)).ok()?;
    recovered.is_empty().then_some(e)
}

/// Whether `tokens` are an operand (see [`is_operand`]) or a tuple of at
/// least two operands without a trailing comma.
fn is_simple(tokens: &[Token]) -> bool {
    match tokens {
        [(_, Tok::LParen, _), inner @ .., (_, Tok::RParen, _)] => {
            inner.split(|t| t.1 == Tok::Comma).count() >= 2 && inner.split(|t| t.1 == Tok::Comma).all(is_operand)
        }
        _ => is_operand(tokens),
    }
}

/// A literal, a negated number or a name.
fn is_operand(tokens: &[Token]) -> bool {
    match tokens {
        [(_, t, _)] => {
            matches!(t, Tok::Int(_) | Tok::Float(_) | Tok::Str(_) | Tok::Ident(_) | Tok::True | Tok::False)
        }
        [(_, Tok::Minus, _), (_, Tok::Int(_) | Tok::Float(_), _)] => true,
        _ => false,
    }
}

/// The tree of tokens [`is_simple`] accepts, as the grammar builds it.
fn simple(file: FileId, tokens: &mut [Token]) -> Option<Expr> {
    if let [(l, Tok::LParen, _), inner @ .., (_, Tok::RParen, r)] = tokens {
        let (l, r) = (*l, *r);
        let mut items = Vec::with_capacity(inner.split(|t| t.1 == Tok::Comma).count());
        for item in inner.split_mut(|t| t.1 == Tok::Comma) {
            items.push(operand(file, item)?);
        }
        return node(file, l, r, ExprKind::Tuple(items));
    }
    operand(file, tokens)
}

fn operand(file: FileId, tokens: &mut [Token]) -> Option<Expr> {
    let literal = |t: &mut Tok| match std::mem::replace(t, Tok::Semi) {
        Tok::Int(v) => Some(ExprKind::Int(v)),
        Tok::Float(v) => Some(ExprKind::Float(v)),
        Tok::Str(s) => Some(ExprKind::Str(s)),
        Tok::Ident(name) => Some(ExprKind::Name(name)),
        Tok::True => Some(ExprKind::Bool(true)),
        Tok::False => Some(ExprKind::Bool(false)),
        _ => None,
    };
    match tokens {
        [(l, t, r)] => node(file, *l, *r, literal(t)?),
        [(l, Tok::Minus, _), (nl, t, r)] => {
            let operand = node(file, *nl, *r, literal(t)?)?;
            node(file, *l, *r, ExprKind::Unary { op: UnaryOp::Neg, operand: Box::new(operand) })
        }
        _ => None,
    }
}

fn node(file: FileId, l: usize, r: usize, kind: ExprKind) -> Option<Expr> {
    Expr::new(kind, Span::new(file, l, r)).ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::syntax::parser::parse_with_lalrpop;

    /// The shortcut gives lalrpop's tree, or declines; it declines every
    /// file with a diagnostic.
    fn agrees(src: &str) -> bool {
        let fast = parse(FileId(3), src);
        let (tree, diags) = parse_with_lalrpop(FileId(3), src);
        match fast {
            Some(fast) => {
                assert!(diags.is_empty(), "accepted a file with errors: {src}\n{diags:?}");
                assert_eq!(fast, tree, "{src}");
                true
            }
            None => false,
        }
    }

    const SCENE: &str = r#"material red = lambert(kd: rgb(0.8, 0.2, 0.2));
// before
scene {
    background rgb(0.1, 0.1, 0.1);
    camera { from (0, 1, -4); to (0, -1.5, 0); fov 40; up (x, -0, 1e3); }
    render { integrator "path"; spp 4; flag; }
    light point { at (0, 5, -5); intensity 3 * rgb(1, 1, 1); }
    light sphere { center (a, b, c); radius 2; radiance color(1); }
    object sphere { center (-1.115, -11.344, 15.240); radius 0.05; material red; }
    object plane { point (0, 0, 0); normal (0, 1, 0); material mix(red, red, 0.5); }
    object quad { corner (1); edge1 (1,); edge2 (1, 2,); material red; scale -2; translate ((1, 2), 3); }
    object box { min -(1, 1, 1); max (true, false, "s"); material m.x; rotate (- -1, 2, 3); }
    object disk { center (0, 0, 0) ; normal point(0, 1, 0); radius 1; material red; }
}
float f() { return 1; }
/* after */ scene { camera { from (0, 0, 1); to (0, 0, 0); } }
"#;

    #[test]
    fn same_tree_as_the_grammar() {
        assert!(agrees(SCENE));
        assert!(agrees("scene { }"));
        assert!(!agrees("float f() { return 1; }"), "no scene: nothing to shortcut");
    }

    #[test]
    fn declines_every_broken_file() {
        // Every prefix, and every file with one character removed.
        for cut in (0..SCENE.len()).filter(|&k| SCENE.is_char_boundary(k)) {
            agrees(&SCENE[..cut]);
            let mut s = SCENE.to_string();
            s.remove(cut);
            agrees(&s);
        }
        for bad in ["scene { object sphere { center (1, 2 3); } }", "scene { x ((1); }", "scene { café 1; }"] {
            assert!(!agrees(bad), "{bad}");
        }
    }

    /// The shortcut lexes a file once: the items between scene blocks are
    /// parsed from the tokens the scan for `scene` reads.
    #[test]
    fn lexes_a_file_once() {
        use crate::syntax::lexer::TOKENS_LEXED;
        let constants: String = (0..50).map(|k| format!("const float c{k} = c{k} * 0.5 + {k};\n")).collect();
        for src in [
            SCENE.to_string(),
            format!("{constants}scene {{ }}"),
            format!("scene {{ camera {{ fov 40; }} }}\n{constants}"),
            format!("{constants}scene {{ camera {{ fov c3 + 1; }} }}\n{constants}/* scene */\n"),
            format!("// not a scene\n{constants}"),
        ] {
            let tokens = Lexer::new(&src).count();
            TOKENS_LEXED.with(|n| n.set(0));
            assert!(agrees(&src), "{src}");
            // `agrees` parses with lalrpop too, which lexes the file once.
            assert_eq!(TOKENS_LEXED.with(std::cell::Cell::get), 2 * tokens, "{src}");
        }
    }

    #[test]
    fn every_file_of_the_repository() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut dirs = vec![root.join("examples"), root.join("tests"), root.join("stdlib")];
        let mut shortcut = 0;
        while let Some(dir) = dirs.pop() {
            for entry in std::fs::read_dir(&dir).unwrap().flatten() {
                let path = entry.path();
                if path.is_dir() {
                    dirs.push(path);
                } else if path.extension().is_some_and(|e| e == "tsl")
                    && let Ok(src) = std::fs::read_to_string(&path)
                {
                    shortcut += usize::from(agrees(&src));
                }
            }
        }
        assert!(shortcut > 20, "only {shortcut} files took the shortcut");
    }
}
