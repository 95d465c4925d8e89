//! The printer: walks the syntax tree for structure and takes the text of
//! every token from the source, in order, through a cursor over the lexed
//! tokens; so literals keep their spelling and the parentheses the author
//! wrote are kept. Each comment is flushed before the first token that
//! follows it, with two exceptions at separators (`,` and `;`): a line
//! comment before one is printed after it (it ends its line, so the
//! separator would else start the next one), and the comments around a
//! list's trailing comma, which the style drops or adds, are printed after
//! the last element whether the comma is or not.
//!
//! The printer never panics on a tree and tokens that disagree (a bug): it
//! prints what it has, and the verifier (`verify.rs`) refuses the output.

use super::doc::{Doc, text};
use super::lexed::{Comment, Lexed};
use crate::syntax::ast::*;
use crate::syntax::lexer::Tok;

/// The layout document of a parsed file.
pub(super) fn print(src: &str, lexed: &Lexed, ast: &SourceFile) -> Doc {
    let mut p = Printer { src, tokens: &lexed.tokens, ti: 0, comments: &lexed.comments, ci: 0, line_ended: false };
    p.file(ast)
}

/// A separator (`,` or `;`) and the comments before it: those printed
/// before it and those printed after it.
struct Separator {
    before: Vec<Doc>,
    token: Doc,
    after: Vec<Doc>,
}

struct Printer<'s> {
    src: &'s str,
    tokens: &'s [(usize, Tok, usize)],
    /// The next token to print.
    ti: usize,
    comments: &'s [Comment],
    /// The next comment to print.
    ci: usize,
    /// A line comment written before the last token is printed after it:
    /// no comment after the token is on its line.
    line_ended: bool,
}

impl Printer<'_> {
    fn next_start(&self) -> usize {
        self.tokens.get(self.ti).map_or(self.src.len(), |t| t.0)
    }

    fn prev_end(&self) -> usize {
        self.ti.checked_sub(1).map_or(0, |i| self.tokens[i].2)
    }

    fn comment(&self, c: &Comment) -> Doc {
        let text = c.text(self.src).to_string();
        if c.line { Doc::LineComment(text) } else { Doc::Comment(text) }
    }

    fn newlines(&self, from: usize, to: usize) -> usize {
        self.src[from.min(to)..to].matches('\n').count()
    }

    /// Comments before the next token, inline: each line comment ends its line.
    fn flush(&mut self) -> Vec<Doc> {
        let mut out = Vec::new();
        let next = self.next_start();
        while self.ci < self.comments.len() && self.comments[self.ci].start < next {
            let c = self.comments[self.ci];
            out.push(self.comment(&c));
            if c.line {
                out.push(Doc::HardLine);
            }
            self.ci += 1;
        }
        out
    }

    /// The comments before the next token, a separator, that go with it:
    /// the block comments before the first line comment, printed before
    /// the separator, and that line comment, printed after it (it ends its
    /// line, so the separator would else start the next one). The comments
    /// after that line comment are on lines of their own: they stay for
    /// the next token, as if written after the separator.
    fn around_separator(&mut self) -> (Vec<Doc>, Option<Doc>) {
        let mut before = Vec::new();
        let next = self.next_start();
        while self.ci < self.comments.len() && self.comments[self.ci].start < next {
            let c = self.comments[self.ci];
            self.ci += 1;
            if c.line {
                return (before, Some(self.comment(&c)));
            }
            before.push(self.comment(&c));
        }
        (before, None)
    }

    /// The comments on the same line as the last token, after it (none
    /// when a line comment moved after it ends that line).
    fn trailing(&mut self) -> Vec<Doc> {
        let mut out = Vec::new();
        if self.line_ended {
            return out;
        }
        let next = self.next_start();
        let mut at = self.prev_end();
        while self.ci < self.comments.len() && self.comments[self.ci].start < next {
            let c = self.comments[self.ci];
            if self.newlines(at, c.start) > 0 {
                break;
            }
            out.push(self.comment(&c));
            out.push(Doc::BreakParent);
            at = c.end;
            self.ci += 1;
        }
        out
    }

    /// The comments before the next token, each on its own line and
    /// followed by a line break (an empty line where the source has one).
    fn leading(&mut self) -> Vec<Doc> {
        let mut out = Vec::new();
        let next = self.next_start();
        while self.ci < self.comments.len() && self.comments[self.ci].start < next {
            let c = self.comments[self.ci];
            out.push(self.comment(&c));
            self.ci += 1;
            let upto = self.comments.get(self.ci).map_or(next, |n| n.start.min(next));
            let eof = self.ti >= self.tokens.len() && upto == next;
            out.push(if self.newlines(c.end, upto) > 1 && !eof { Doc::Blank } else { Doc::HardLine });
        }
        out
    }

    /// Whether the source has an empty line before the next comment or token.
    fn blank_before(&self) -> bool {
        let next = self.comments.get(self.ci).map_or(self.next_start(), |c| c.start.min(self.next_start()));
        self.newlines(self.prev_end(), next) > 1
    }

    /// The next token, with the comments before it (line comments after
    /// it for a separator).
    fn tok(&mut self) -> Doc {
        if self.is_next(&Tok::Comma) || self.is_next(&Tok::Semi) {
            let Separator { before, token, after } = self.separator();
            return Doc::Concat(before.into_iter().chain([token]).chain(after).collect());
        }
        let mut out = self.flush();
        out.push(self.token_text());
        Doc::Concat(out)
    }

    /// The next token's text, or nothing past the last token (the tree and
    /// the tokens disagree: the verifier refuses what is printed).
    fn token_text(&mut self) -> Doc {
        let Some((s, _, e)) = self.tokens.get(self.ti) else { return Doc::Concat(Vec::new()) };
        self.ti += 1;
        self.line_ended = false;
        Doc::Text(self.src[*s..*e].to_string())
    }

    /// The next token, a separator, and the comments that go with it (see
    /// [`Printer::around_separator`]). The caller prints the comments
    /// whether or not it prints the token (a trailing comma).
    fn separator(&mut self) -> Separator {
        let (before, line_comment) = self.around_separator();
        let token = self.token_text();
        self.line_ended = line_comment.is_some();
        let after = line_comment.map(|c| vec![c, Doc::BreakParent]).unwrap_or_default();
        Separator { before, token, after }
    }

    /// What follows a list's last element: its comma (printed when the
    /// group breaks, or `always`, for a one-element tuple) and the
    /// comments that go with the comma written or not, at the end of the
    /// element's line. So `2 /* two */ ,` and `2, /* two */` print alike,
    /// and a second formatting changes nothing.
    fn last_comma(&mut self, always: bool) -> Vec<Doc> {
        let mut out = vec![if always { text(",") } else { Doc::IfBreak(",") }];
        if self.is_next(&Tok::Comma) {
            let Separator { before, token: _, after } = self.separator();
            for c in before {
                out.extend([c, Doc::BreakParent]);
            }
            out.extend(after);
        }
        out.extend(self.trailing());
        out
    }

    fn is_next(&self, t: &Tok) -> bool {
        self.tokens.get(self.ti).is_some_and(|x| &x.1 == t)
    }

    /// Items, statements, methods or scene entries, one per line (`break_`
    /// is the line break: hard, or a group's `Line`).
    fn lines<T>(
        &mut self,
        items: &[T],
        mut one: impl FnMut(&mut Self, &T) -> Doc,
        top: bool,
        break_: fn() -> Doc,
    ) -> Vec<Doc> {
        let mut out = Vec::new();
        for (i, item) in items.iter().enumerate() {
            if i > 0 || !top {
                out.push(if i > 0 && self.blank_before() { Doc::Blank } else { break_() });
            }
            out.extend(self.leading());
            let item_doc = one(self, item);
            out.push(item_doc);
            out.extend(self.trailing());
        }
        out
    }

    /// `{ lines }` with the comments left before `}` inside.
    fn braced<T>(&mut self, items: &[T], one: impl FnMut(&mut Self, &T) -> Doc) -> Doc {
        self.braced_with(items, one, || Doc::HardLine)
    }

    /// `{ a; b; }` on one line when it fits and holds no line comment or
    /// blank line, else one entry a line (scene blocks).
    fn braced_group<T>(&mut self, items: &[T], one: impl FnMut(&mut Self, &T) -> Doc) -> Doc {
        Doc::Group(vec![self.braced_with(items, one, || Doc::Line)])
    }

    fn braced_with<T>(&mut self, items: &[T], one: impl FnMut(&mut Self, &T) -> Doc, break_: fn() -> Doc) -> Doc {
        let open = self.tok();
        let after_open = self.trailing();
        let mut inner = self.lines(items, one, false, break_);
        let mut rest = Vec::new();
        let next = self.next_start();
        if self.ci < self.comments.len() && self.comments[self.ci].start < next {
            rest.push(if !items.is_empty() && self.blank_before() { Doc::Blank } else { Doc::HardLine });
            rest.extend(self.leading());
        }
        if !rest.is_empty() {
            rest.pop();
        }
        inner.extend(rest);
        let empty = inner.is_empty() && after_open.is_empty();
        let close = self.tok();
        if empty {
            return Doc::Concat(vec![open, close]);
        }
        Doc::Concat(vec![open, Doc::Concat(after_open), Doc::Indent(inner), break_(), close])
    }

    fn file(&mut self, f: &SourceFile) -> Doc {
        let mut out = self.lines(&f.items, Self::item, true, || Doc::HardLine);
        if self.ci < self.comments.len() {
            if !f.items.is_empty() {
                out.push(if self.blank_before() { Doc::Blank } else { Doc::HardLine });
            }
            out.extend(self.leading());
        }
        out.push(Doc::HardLine);
        Doc::Concat(out)
    }

    fn item(&mut self, item: &Item) -> Doc {
        match item {
            Item::Import { .. } => Doc::Concat(vec![self.tok(), text(" "), self.tok(), self.tok()]),
            Item::Function(f) => self.function(f),
            Item::Material(m) => {
                let kw = self.tok();
                let name = self.tok();
                let params = self.params(&m.params);
                let body = self.braced(&m.methods, Self::function);
                Doc::Concat(vec![kw, text(" "), name, params, text(" "), body])
            }
            Item::MaterialTree(m) => {
                let mut out = vec![self.tok(), text(" "), self.tok()];
                if let Some(ps) = &m.params {
                    out.push(self.params(ps));
                }
                out.extend([text(" "), self.tok(), text(" "), self.expr(&m.body), self.tok()]);
                Doc::Concat(out)
            }
            Item::Const(c) => {
                let kw = self.tok();
                let ty = self.ty(&c.ty);
                Doc::Concat(vec![
                    kw,
                    text(" "),
                    ty,
                    text(" "),
                    self.tok(),
                    text(" "),
                    self.tok(),
                    text(" "),
                    self.expr(&c.value),
                    self.tok(),
                ])
            }
            Item::Scene(s) => {
                let kw = self.tok();
                let body = self.braced(&s.entries, |p, e| match e {
                    SceneEntry::Block(b) => {
                        let mut out = vec![p.tok()];
                        if b.kind.is_some() {
                            out.extend([text(" "), p.tok()]);
                        }
                        out.push(text(" "));
                        out.push(p.braced_group(&b.props, Self::prop));
                        Doc::Concat(out)
                    }
                    SceneEntry::Prop(prop) => p.prop(prop),
                });
                Doc::Concat(vec![kw, text(" "), body])
            }
        }
    }

    fn prop(&mut self, p: &SceneProp) -> Doc {
        let mut out = vec![self.tok()];
        if let Some(v) = &p.value {
            out.extend([text(" "), self.expr(v)]);
        }
        out.push(self.tok());
        Doc::Concat(out)
    }

    fn ty(&mut self, t: &TypeExpr) -> Doc {
        let mut out = vec![self.tok()];
        if t.array_len.is_some() {
            out.extend([self.tok(), self.tok(), self.tok()]);
        }
        Doc::Concat(out)
    }

    fn function(&mut self, f: &Function) -> Doc {
        let ret = self.ty(&f.ret);
        let name = self.tok();
        let params = self.params(&f.params);
        let body = self.block(&f.body);
        Doc::Concat(vec![ret, text(" "), name, params, text(" "), body])
    }

    fn params(&mut self, ps: &[Param]) -> Doc {
        self.list(ps, false, |p, param| {
            let mut out = vec![p.ty(&param.ty), text(" "), p.tok()];
            if let Some(d) = &param.default {
                out.extend([text(" "), p.tok(), text(" "), p.expr(d)]);
            }
            if let Some(options) = &param.options {
                // `in ("a", "b")`: the keyword, then the literals as a list.
                out.extend([text(" "), p.tok(), text(" ")]);
                out.push(p.list(&options.values, false, |p, _| p.tok()));
            }
            Doc::Concat(out)
        })
    }

    /// `( a, b )` or `[ ... ]`: on one line when it fits, else one element a
    /// line with a trailing comma. `always_comma` for a one-element tuple.
    fn list<T>(&mut self, items: &[T], always_comma: bool, mut one: impl FnMut(&mut Self, &T) -> Doc) -> Doc {
        let open = self.tok();
        let mut inner = vec![Doc::SoftLine];
        let n = items.len();
        for (i, item) in items.iter().enumerate() {
            inner.push(one(self, item));
            if i + 1 < n {
                inner.push(self.tok());
                inner.extend(self.trailing());
                inner.push(Doc::Line);
            } else {
                inner.extend(self.last_comma(always_comma));
            }
        }
        self.comments_before_close(&mut inner);
        let close = self.tok();
        if n == 0 && inner.len() == 1 {
            return Doc::Concat(vec![open, close]);
        }
        Doc::Group(vec![open, Doc::Indent(inner), Doc::SoftLine, close])
    }

    /// The comments between a list's last element and its closing
    /// bracket, each on a line of its own (which breaks the list).
    fn comments_before_close(&mut self, inner: &mut Vec<Doc>) {
        let next = self.next_start();
        if self.ci < self.comments.len() && self.comments[self.ci].start < next {
            inner.push(Doc::HardLine);
            let mut lead = self.leading();
            lead.pop();
            inner.extend(lead);
            inner.push(Doc::BreakParent);
        }
    }

    /// `[a, b, c]` on one line when it fits, else as many elements a line
    /// as fit, with a trailing comma: for arrays of literals and tuples of
    /// them (measured spectra, spline knots).
    fn filled(&mut self, items: &[Expr]) -> Doc {
        let open = self.tok();
        let mut inner = vec![Doc::SoftLine];
        for (i, item) in items.iter().enumerate() {
            inner.push(self.expr(item));
            if i + 1 < items.len() {
                inner.push(self.tok());
                inner.extend(self.trailing());
                inner.push(Doc::FillLine);
            } else {
                inner.extend(self.last_comma(false));
            }
        }
        self.comments_before_close(&mut inner);
        let close = self.tok();
        Doc::Group(vec![open, Doc::Indent(inner), Doc::SoftLine, close])
    }

    fn block(&mut self, b: &Block) -> Doc {
        self.braced(&b.stmts, Self::stmt)
    }

    fn stmt(&mut self, s: &Stmt) -> Doc {
        match &s.kind {
            StmtKind::Let { ty, init, .. } => {
                let mut out = vec![self.ty(ty), text(" "), self.tok()];
                if let Some(e) = init {
                    out.extend([text(" "), self.tok(), text(" "), self.expr(e)]);
                }
                out.push(self.tok());
                Doc::Concat(out)
            }
            StmtKind::Assign { target, value, .. } => {
                Doc::Concat(vec![self.expr(target), text(" "), self.tok(), text(" "), self.expr(value), self.tok()])
            }
            StmtKind::Expr(e) => Doc::Concat(vec![self.expr(e), self.tok()]),
            StmtKind::If { cond, then_block, else_branch } => {
                let mut out = vec![self.tok(), text(" "), self.expr(cond), text(" "), self.block(then_block)];
                if let Some(e) = else_branch {
                    out.extend([text(" "), self.tok(), text(" "), self.stmt(e)]);
                }
                Doc::Concat(out)
            }
            StmtKind::For { start, end, body, .. } => Doc::Concat(vec![
                self.tok(),
                text(" "),
                self.tok(),
                text(" "),
                self.tok(),
                text(" "),
                self.expr(start),
                self.tok(),
                self.expr(end),
                text(" "),
                self.block(body),
            ]),
            StmtKind::While { cond, body } => {
                Doc::Concat(vec![self.tok(), text(" "), self.expr(cond), text(" "), self.block(body)])
            }
            StmtKind::Break | StmtKind::Continue => Doc::Concat(vec![self.tok(), self.tok()]),
            StmtKind::Return(e) => {
                let mut out = vec![self.tok()];
                if let Some(e) = e {
                    out.extend([text(" "), self.expr(e)]);
                }
                out.push(self.tok());
                Doc::Concat(out)
            }
            StmtKind::Block(b) => self.block(b),
        }
    }

    fn args(&mut self, args: &[Arg]) -> Doc {
        // A sole array argument opens and closes with the call's
        // parentheses: `spectrum([` ... `])`.
        if let [Arg { name: None, value }] = args
            && matches!(value.kind, ExprKind::Array(_))
        {
            let mut out = vec![self.tok(), self.expr(value)];
            if self.is_next(&Tok::Comma) {
                let Separator { before, token: _, after } = self.separator();
                out.extend(before.into_iter().chain(after));
            }
            out.push(self.tok());
            return Doc::Concat(out);
        }
        self.list(args, false, |p, a| {
            let mut out = Vec::new();
            if a.name.is_some() {
                out.extend([p.tok(), p.tok(), text(" ")]);
            }
            out.push(p.expr(&a.value));
            Doc::Concat(out)
        })
    }

    /// A left-leaning chain `a + b - c` printed flat: its document is as
    /// deep as the chain's real nesting, not as long as the chain.
    fn chain(&mut self, e: &Expr) -> Doc {
        let mut nodes = vec![e];
        let mut first = e;
        while let ExprKind::Binary { lhs, .. } = &first.kind {
            // A parenthesized left operand starts after its `(`: it is
            // printed by `expr`, with its parentheses.
            if !matches!(lhs.kind, ExprKind::Binary { .. }) || lhs.span.start != first.span.start {
                break;
            }
            nodes.push(lhs);
            first = lhs;
        }
        let ExprKind::Binary { lhs, .. } = &first.kind else { return Doc::Concat(Vec::new()) };
        let loosest = nodes
            .iter()
            .filter_map(|n| if let ExprKind::Binary { op, .. } = &n.kind { Some(binding(*op)) } else { None })
            .min();
        let first = self.expr(lhs);
        let mut rest = Vec::new();
        for node in nodes.iter().rev() {
            if let ExprKind::Binary { op, rhs, .. } = &node.kind {
                rest.push(if Some(binding(*op)) == loosest { Doc::Line } else { text(" ") });
                rest.extend([self.tok(), text(" "), self.expr(rhs)]);
            }
        }
        Doc::Group(vec![first, Doc::Indent(rest)])
    }

    fn expr(&mut self, e: &Expr) -> Doc {
        crate::syntax::ast::with_stack(|| self.expr_unguarded(e))
    }

    fn expr_unguarded(&mut self, e: &Expr) -> Doc {
        // Parentheses the author wrote lie before the expression's span.
        let mut out = Vec::new();
        let mut parens = 0;
        while self.ti < self.tokens.len() && self.tokens[self.ti].0 < e.span.start as usize {
            out.push(self.tok());
            parens += 1;
        }
        out.push(match &e.kind {
            ExprKind::Int(_) | ExprKind::Float(_) | ExprKind::Bool(_) | ExprKind::Str(_) | ExprKind::Name(_) => {
                self.tok()
            }
            ExprKind::Call { args, .. } | ExprKind::Construct { args, .. } => {
                let callee = self.tok();
                Doc::Concat(vec![callee, self.args(args)])
            }
            ExprKind::Member { base, .. } => Doc::Concat(vec![self.expr(base), self.tok(), self.tok()]),
            ExprKind::Index { base, index } => {
                Doc::Concat(vec![self.expr(base), self.tok(), self.expr(index), self.tok()])
            }
            ExprKind::Unary { operand, .. } => Doc::Concat(vec![self.tok(), self.expr(operand)]),
            ExprKind::Binary { .. } => self.chain(e),
            ExprKind::Ternary { cond, then_expr, else_expr } => {
                let cond = self.expr(cond);
                Doc::Group(vec![
                    cond,
                    Doc::Indent(vec![
                        Doc::Line,
                        self.tok(),
                        text(" "),
                        self.expr(then_expr),
                        Doc::Line,
                        self.tok(),
                        text(" "),
                        self.expr(else_expr),
                    ]),
                ])
            }
            ExprKind::Array(items) if items.len() > 1 && items.iter().all(is_data) => self.filled(items),
            ExprKind::Array(items) => self.list(items, false, Self::expr),
            ExprKind::Tuple(items) => self.list(items, items.len() == 1, Self::expr),
        });
        for _ in 0..parens {
            out.push(self.tok());
        }
        Doc::Concat(out)
    }
}

/// How tightly an operator binds (a chain breaks before its loosest).
fn binding(op: BinaryOp) -> u8 {
    match op {
        BinaryOp::Or => 0,
        BinaryOp::And => 1,
        BinaryOp::Eq | BinaryOp::Ne | BinaryOp::Lt | BinaryOp::Le | BinaryOp::Gt | BinaryOp::Ge => 2,
        BinaryOp::Add | BinaryOp::Sub => 3,
        BinaryOp::Mul | BinaryOp::Div | BinaryOp::Rem => 4,
    }
}

/// A literal, a negated one, or a tuple of them: an element of a data table.
fn is_data(e: &Expr) -> bool {
    match &e.kind {
        ExprKind::Int(_) | ExprKind::Float(_) | ExprKind::Bool(_) | ExprKind::Str(_) => true,
        ExprKind::Unary { operand, .. } => is_data(operand),
        ExprKind::Tuple(items) => items.iter().all(is_data),
        _ => false,
    }
}
