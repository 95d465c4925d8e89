//! Parser glue: runs the lalrpop parser over the logos tokens and turns every
//! lexer and grammar error into a located [`Diagnostic`].
//!
//! Invariant: parsing never fails as a whole. It returns the items it could
//! read plus diagnostics; lalrpop's error recovery resumes at the next item or
//! statement so that one typo does not hide the errors after it.

use crate::diag::{Diagnostic, FileId, Span};
use crate::syntax::ast::{self, MAX_NESTING, SourceFile, TooDeep};
use crate::syntax::lexer::{LexError, Lexer, SpannedLexError, Tok};
use lalrpop_util::{ErrorRecovery, ParseError};

lalrpop_util::lalrpop_mod!(
    #[allow(clippy::all, clippy::pedantic, clippy::panic, unused_parens, unused_imports, dead_code)]
    pub(crate) grammar,
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

/// A chain of binary operations as the grammar reads it, `a + b * c ...`,
/// built into the tree the precedence tiers give (operator-precedence
/// parsing): an operator first builds what binds at least as tightly on its
/// left, and the end of the chain builds the rest. Nodes are built in the
/// order the tiers' reductions built them, so the first node nested too
/// deeply is the one reported.
pub(crate) struct Chain {
    pending: Pending,
    /// The last operand and its extent (parentheses included, which its
    /// span leaves out).
    last: ast::Expr,
    start: u32,
    end: u32,
}

/// Left operands waiting for their right side: where each starts, and the
/// operator after it. Precedence rises from bottom to top.
pub(crate) struct Pending(Vec<(ast::Expr, u32, ast::BinaryOp)>);

impl Chain {
    pub(crate) fn new(e: ast::Expr, l: usize, r: usize) -> Chain {
        Pending(Vec::new()).operand(e, l, r)
    }

    /// Adds the operator after the chain so far.
    pub(crate) fn operator(
        self,
        op: ast::BinaryOp,
        file: FileId,
    ) -> Result<Pending, ParseError<usize, Tok, SyntaxError>> {
        let Chain { mut pending, last, start, end } = self;
        let (mut rhs, mut start) = (last, start);
        while pending.0.last().is_some_and(|top| top.2.precedence() >= op.precedence()) {
            let Some((lhs, lhs_start, top)) = pending.0.pop() else { break };
            rhs = binary(file, lhs, top, rhs, lhs_start, end)?;
            start = lhs_start;
        }
        pending.0.push((rhs, start, op));
        Ok(pending)
    }

    /// The tree of the whole chain.
    pub(crate) fn finish(self, file: FileId) -> Result<ast::Expr, ParseError<usize, Tok, SyntaxError>> {
        let Chain { mut pending, last, end, .. } = self;
        let mut rhs = last;
        while let Some((lhs, start, op)) = pending.0.pop() {
            rhs = binary(file, lhs, op, rhs, start, end)?;
        }
        Ok(rhs)
    }
}

impl Pending {
    pub(crate) fn operand(self, e: ast::Expr, l: usize, r: usize) -> Chain {
        Chain { pending: self, last: e, start: l as u32, end: r as u32 }
    }
}

fn binary(
    file: FileId,
    lhs: ast::Expr,
    op: ast::BinaryOp,
    rhs: ast::Expr,
    start: u32,
    end: u32,
) -> Result<ast::Expr, ParseError<usize, Tok, SyntaxError>> {
    let kind = ast::ExprKind::Binary { op, lhs: Box::new(lhs), rhs: Box::new(rhs) };
    node(file, start as usize, end as usize, kind)
}

/// The most syntax errors reported for one file, before one more
/// diagnostic counting the rest: with it, the bound of every file's
/// diagnostics ([`MAX_DIAGNOSTICS_PER_FILE`](crate::diag::MAX_DIAGNOSTICS_PER_FILE)),
/// applied while parsing so a broken file of thousands of lines does not
/// collect thousands of errors first.
pub const MAX_SYNTAX_ERRORS: usize = crate::diag::MAX_DIAGNOSTICS_PER_FILE - 1;

/// Parses one source file.
pub fn parse(file: FileId, src: &str) -> (SourceFile, Vec<Diagnostic>) {
    // Scene blocks by hand when the file has one and no error: the same tree.
    if let Some(ast) = super::scene_block::parse(file, src) {
        return (ast, Vec::new());
    }
    parse_with_lalrpop(file, src)
}

/// [`parse`] by the lalrpop parser alone, which words every error.
pub(crate) fn parse_with_lalrpop(file: FileId, src: &str) -> (SourceFile, Vec<Diagnostic>) {
    let mut diags = Vec::new();
    // Lexer errors are reported and lexing goes on. A bad string or number
    // still becomes a token, so the parser does not report it a second time.
    let mut lex_errors: Vec<SpannedLexError> = Vec::new();
    // Tokens stream into the parser: a 86 MB scene is never a token vector.
    let mut recovered: Vec<ErrorRecovery<usize, Tok, SyntaxError>> = Vec::new();
    let result = grammar::SourceFileParser::new().parse(
        file,
        &mut recovered,
        tokens(src, &mut lex_errors).map(Ok::<_, SyntaxError>),
    );
    // An unterminated comment or string swallows the rest of the file or
    // line; the end of file that follows is no news.
    let swallowed =
        lex_errors.iter().any(|e| matches!(e.error, LexError::UnterminatedComment | LexError::UnterminatedString));
    for e in &lex_errors {
        let span = Span::new(file, e.span.start, e.span.end);
        let d = match src.get(e.span.clone()).and_then(|s| s.chars().next()) {
            Some(c) if e.error == LexError::UnexpectedChar => {
                Diagnostic::error(span, format!("unexpected character `{}`", c.escape_debug()))
            }
            _ if e.error == LexError::NonAsciiIdent => {
                let word = src.get(e.span.clone()).unwrap_or("");
                Diagnostic::error(span, format!("`{word}` is not an identifier: {}", e.error)).with_help(
                    "rename it with ASCII letters: identifiers are `[A-Za-z_][A-Za-z0-9_]*`, as in OSL and C",
                )
            }
            _ => Diagnostic::error(span, e.error.to_string()),
        };
        diags.push(d);
    }

    let mut errors: Vec<ParseError<usize, Tok, SyntaxError>> = recovered.into_iter().map(|r| r.error).collect();
    let ast = match result {
        Ok(ast) => ast,
        Err(e) => {
            errors.push(e);
            SourceFile::default()
        }
    };
    if errors.is_empty() {
        return (ast, diags);
    }
    // Only a file with syntax errors needs the tokens again, to word them.
    let spans: Vec<(usize, usize)> = tokens(src, &mut Vec::new()).map(|t| (t.0, t.2)).collect();
    let context = ErrorContext { file, eof: src.len(), unclosed: unclosed_braces(src), spans };
    for e in errors {
        if swallowed && matches!(e, ParseError::UnrecognizedEof { .. }) {
            continue;
        }
        diags.push(context.diagnostic(e));
    }
    if diags.len() > MAX_SYNTAX_ERRORS {
        let more = diags.len() - MAX_SYNTAX_ERRORS;
        let at = diags[MAX_SYNTAX_ERRORS].span;
        diags.truncate(MAX_SYNTAX_ERRORS);
        diags.push(
            Diagnostic::error(Span { end: at.start, ..at }, format!("{more} more syntax errors not shown"))
                .with_note("past the first errors, most are echoes of one mistake: fix those first"),
        );
    }
    (ast, diags)
}

/// What a parse error message needs besides the error.
struct ErrorContext {
    file: FileId,
    eof: usize,
    /// Byte ranges of the tokens, in order.
    spans: Vec<(usize, usize)>,
    /// Where `{` were opened and never closed.
    unclosed: Vec<usize>,
}

/// The tokens of `src`, lexer errors pushed to `errors` as they are met. A
/// bad string or number still becomes a token, so the parser does not
/// report it a second time.
fn tokens<'s>(src: &'s str, errors: &'s mut Vec<SpannedLexError>) -> impl Iterator<Item = (usize, Tok, usize)> + 's {
    Lexer::new(src).filter_map(move |t| match t {
        Ok(t) => Some(t),
        Err(e) => {
            let stand_in = match e.error {
                LexError::UnterminatedString => {
                    Some(Tok::Str(src.get(e.span.start + 1..e.span.end).unwrap_or("").to_string()))
                }
                LexError::BadNumber => Some(Tok::Float(0.0)),
                // Parsed as the identifier it means, so nothing else is reported.
                LexError::NonAsciiIdent => Some(Tok::Ident(src.get(e.span.clone()).unwrap_or("").into())),
                LexError::UnexpectedChar | LexError::UnterminatedComment => None,
            };
            let token = stand_in.map(|t| (e.span.start, t, e.span.end));
            errors.push(e);
            token
        }
    })
}

fn unclosed_braces(src: &str) -> Vec<usize> {
    let mut open = Vec::new();
    for (start, tok, _) in tokens(src, &mut Vec::new()) {
        match tok {
            Tok::LBrace => open.push(start),
            Tok::RBrace => {
                open.pop();
            }
            _ => {}
        }
    }
    open
}

/// What the parser was looking for, in words.
#[derive(Debug, PartialEq)]
enum Wanted {
    Semicolon,
    Expression,
    Statement,
    Item,
    MaterialMethod,
    Tokens(String),
}

fn wanted(expected: &[String]) -> Wanted {
    let wants = |t: &str| expected.iter().any(|e| e.trim_matches('"') == t);
    // After a complete expression an operator could also follow, but `;` is
    // what is missing.
    if wants(";") && !wants("identifier") {
        return Wanted::Semicolon;
    }
    if wants("scene") && wants("material") {
        return Wanted::Item;
    }
    if wants("return") {
        return Wanted::Statement;
    }
    if wants("}") && wants("float") && !wants("identifier") {
        return Wanted::MaterialMethod;
    }
    if wants("identifier") && wants("(") && wants("int literal") {
        return Wanted::Expression;
    }
    let names: Vec<String> = expected.iter().map(|e| format!("`{}`", e.trim_matches('"'))).collect();
    Wanted::Tokens(match names.len() {
        0 => "something else".to_string(),
        1 => names[0].clone(),
        _ => format!("one of {}", names.join(", ")),
    })
}

impl ErrorContext {
    fn span(&self, start: usize, end: usize) -> Span {
        Span::new(self.file, start.min(self.eof), end.min(self.eof))
    }

    /// The token before the one starting at `at`.
    fn previous_token(&self, at: usize) -> Option<(usize, usize)> {
        let i = self.spans.partition_point(|&(s, _)| s < at);
        i.checked_sub(1).map(|i| self.spans[i])
    }

    fn diagnostic(&self, e: ParseError<usize, Tok, SyntaxError>) -> Diagnostic {
        match e {
            ParseError::InvalidToken { location } => {
                Diagnostic::error(self.span(location, location + 1), "invalid token")
            }
            ParseError::UnrecognizedEof { location, expected } => {
                let at = self.span(location, location);
                match (wanted(&expected), self.unclosed.last()) {
                    (_, Some(&open)) => Diagnostic::error(at, "unexpected end of file: expected `}`")
                        .with_label(self.span(open, open + 1), "this `{` is never closed"),
                    (Wanted::Semicolon, None) => self.missing_semicolon(location, "the end of the file".into()),
                    (w, None) => Diagnostic::error(at, format!("unexpected end of file: expected {}", describe(&w))),
                }
            }
            ParseError::UnrecognizedToken { token: (l, tok, r), expected } => {
                let w = wanted(&expected);
                if w == Wanted::Semicolon {
                    return self.missing_semicolon(l, tok.to_string());
                }
                let mut d = Diagnostic::error(self.span(l, r), format!("expected {}, found {tok}", describe(&w)));
                if w == Wanted::MaterialMethod {
                    d = d.with_help(
                        "a material body holds interface methods such as `color diffuse() { return kd; }`; \
                         a material built from an expression is written `material name(params) = expr;`",
                    );
                } else if matches!(tok, Tok::Material) && w == Wanted::Statement {
                    d = d.with_help("materials are defined at the top level, outside functions");
                }
                d
            }
            ParseError::ExtraToken { token: (l, tok, r) } => {
                Diagnostic::error(self.span(l, r), format!("unexpected {tok} after the end of the file"))
            }
            ParseError::User { error: SyntaxError::TooDeep(span) } => {
                // Point at where the over-deep construct starts, not over all of it.
                let start = Span { end: span.start + 1, ..span };
                Diagnostic::error(start, format!("nested deeper than {MAX_NESTING} levels"))
                    .with_note("each parenthesis, call, index, block and right operand adds a level; a chain `a + b + c + ...` is one level")
                    .with_help("split it into smaller functions or local variables")
            }
        }
    }

    /// rustc style: point just after the token that should be followed by `;`.
    fn missing_semicolon(&self, next_start: usize, found: String) -> Diagnostic {
        match self.previous_token(next_start) {
            Some((s, e)) => Diagnostic::error(self.span(e, e), format!("expected `;`, found {found}"))
                .with_label(self.span(s, e), "add `;` after this")
                .with_help("statements and declarations end with `;`"),
            None => Diagnostic::error(self.span(next_start, next_start), format!("expected `;`, found {found}")),
        }
    }
}

fn describe(w: &Wanted) -> String {
    match w {
        Wanted::Semicolon => "`;`".into(),
        Wanted::Expression => "an expression".into(),
        Wanted::Statement => "a statement or `}`".into(),
        Wanted::Item => "a function, material, constant, `import` or `scene`".into(),
        Wanted::MaterialMethod => "an interface method or `}`".into(),
        Wanted::Tokens(t) => t.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::syntax::ast::{BinaryOp, Expr, ExprKind};

    const OPS: [(&str, BinaryOp); 13] = [
        ("||", BinaryOp::Or),
        ("&&", BinaryOp::And),
        ("==", BinaryOp::Eq),
        ("!=", BinaryOp::Ne),
        ("<", BinaryOp::Lt),
        ("<=", BinaryOp::Le),
        (">", BinaryOp::Gt),
        (">=", BinaryOp::Ge),
        ("+", BinaryOp::Add),
        ("-", BinaryOp::Sub),
        ("*", BinaryOp::Mul),
        ("/", BinaryOp::Div),
        ("%", BinaryOp::Rem),
    ];

    /// The tree with every node parenthesised and spanned: `(a + b)@0..5`.
    fn shape(e: &Expr, src: &str) -> String {
        let at = format!("@{}..{}", e.span.start, e.span.end);
        match &e.kind {
            ExprKind::Binary { op, lhs, rhs } => {
                format!("({} {} {}){at}", shape(lhs, src), op.symbol(), shape(rhs, src))
            }
            ExprKind::Unary { operand, .. } => format!("(-{}){at}", shape(operand, src)),
            _ => format!("{}{at}", &src[e.span.start as usize..e.span.end as usize]),
        }
    }

    fn parsed(src: &str) -> String {
        let mut errors = Vec::new();
        let tokens = tokens(src, &mut Vec::new()).map(Ok::<_, SyntaxError>).collect::<Vec<_>>();
        let e = grammar::ExprParser::new().parse(FileId(0), &mut errors, tokens).unwrap();
        assert!(errors.is_empty());
        shape(&e, src)
    }

    /// The precedence tiers as a reference: recursive descent over the
    /// atoms `x0 op x1 op ...` (one character each, one space around each
    /// operator), giving the tree and spans the tiers' grammar gave.
    fn tiers(atoms: &[usize], ops: &[(&str, BinaryOp)]) -> String {
        fn level(tier: u8, lo: usize, hi: usize, atoms: &[usize], ops: &[(&str, BinaryOp)], src: &str) -> String {
            if tier > 5 {
                let a = atoms[lo];
                return format!("{}@{a}..{}", &src[a..a + 1], a + 1);
            }
            // The last operator of this tier splits the range (left-associative).
            match (lo..hi).rev().find(|&k| ops[k].1.precedence() == tier) {
                Some(k) => format!(
                    "({} {} {})@{}..{}",
                    level(tier, lo, k, atoms, ops, src),
                    ops[k].0,
                    level(tier + 1, k + 1, hi, atoms, ops, src),
                    atoms[lo],
                    atoms[hi] + 1
                ),
                None => level(tier + 1, lo, hi, atoms, ops, src),
            }
        }
        let src = source(ops);
        level(0, 0, ops.len(), atoms, ops, &src)
    }

    fn source(ops: &[(&str, BinaryOp)]) -> String {
        let mut src = "a".to_string();
        for (k, (sym, _)) in ops.iter().enumerate() {
            src += &format!(" {sym} {}", (b'b' + k as u8) as char);
        }
        src
    }

    #[test]
    fn chains_build_the_trees_and_spans_of_the_precedence_tiers() {
        // Every sequence of four operators: 28,561 chains of five operands.
        for n in 0..OPS.len().pow(4) {
            let ops: Vec<(&str, BinaryOp)> = (0..4).map(|k| OPS[n / OPS.len().pow(k) % OPS.len()]).collect();
            let src = source(&ops);
            let atoms: Vec<usize> = src.char_indices().filter(|c| c.1.is_ascii_lowercase()).map(|c| c.0).collect();
            assert_eq!(parsed(&src), tiers(&atoms, &ops), "{src}");
        }
    }

    #[test]
    fn prefix_postfix_parentheses_and_the_ternary() {
        assert_eq!(parsed("-a * b"), "((-a@1..2)@0..2 * b@5..6)@0..6");
        assert_eq!(parsed("(a + b) * c"), "((a@1..2 + b@5..6)@1..6 * c@10..11)@0..11");
        assert_eq!(parsed("a - -b - c"), "((a@0..1 - (-b@5..6)@4..6)@0..6 - c@9..10)@0..10");
        let ternary = parsed("a < b ? c + d : e");
        assert_eq!(ternary, "a < b ? c + d : e@0..17");
        let mut errors = Vec::new();
        let tokens = tokens("a < b ? c : d ? e : f", &mut Vec::new()).map(Ok::<_, SyntaxError>).collect::<Vec<_>>();
        let e = grammar::ExprParser::new().parse(FileId(0), &mut errors, tokens).unwrap();
        let ExprKind::Ternary { cond, else_expr, .. } = &e.kind else { panic!("{e:?}") };
        assert!(matches!(cond.kind, ExprKind::Binary { op: BinaryOp::Lt, .. }));
        assert!(matches!(else_expr.kind, ExprKind::Ternary { .. }), "right-associative");
    }
}
