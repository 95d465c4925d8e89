//! `tslc fmt`: prints a parsed file in the one canonical style (see
//! `docs/fmt.md`), keeping every comment.
//!
//! The printer walks the AST for structure and takes the text of every token
//! from the source, in order, through a cursor over the lexed tokens; so
//! literals keep their spelling, parentheses the author wrote are kept (the
//! AST, depth included, is unchanged), and each comment is flushed before
//! the first token that follows it. Layout goes through a small Wadler-style
//! document: a group (an argument or parameter list) is printed on one line
//! when it fits in [`WIDTH`] columns, otherwise one element per line.

use crate::diag::{Diagnostic, FileId};
use crate::syntax::ast::*;
use crate::syntax::lexer::{Lexer, Tok};

/// The line width the printer aims for.
pub const WIDTH: usize = 100;
const INDENT: usize = 4;

/// Formats one source file, or returns its lexer and parser diagnostics
/// (against `FileId(0)`) when it does not parse.
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
    let mut tokens = Vec::new();
    for t in Lexer::new(src) {
        match t {
            Ok((s, tok, e)) => tokens.push((s, tok, e)),
            Err(_) => return Err(diags),
        }
    }
    let comments = scan_comments(src, &tokens);
    let mut p = Printer { src, tokens, ti: 0, comments, ci: 0 };
    let doc = p.file(&ast);
    let mut out = render(&doc);
    // Trailing spaces never survive, and the file ends with one newline.
    let mut lines: Vec<&str> = out.lines().map(str::trim_end).collect();
    while lines.last().is_some_and(|l| l.is_empty()) {
        lines.pop();
    }
    out = lines.join("\n");
    if !out.is_empty() {
        out.push('\n');
    }
    Ok(out)
}

#[derive(Debug, Clone)]
struct Comment {
    start: usize,
    end: usize,
    line: bool,
}

/// Comments are what lies between tokens besides whitespace.
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

// ---------------------------------------------------------------- documents

#[derive(Debug, Clone)]
enum Doc {
    Text(String),
    /// A space on one line, a newline when the group breaks.
    Line,
    /// Nothing on one line, a newline when the group breaks.
    SoftLine,
    /// Always a newline; the groups around it break.
    HardLine,
    /// An empty line (a kept blank line).
    Blank,
    /// Printed only when the group breaks (a trailing comma).
    IfBreak(&'static str),
    /// In a broken group, a space when the element after it (and a comma)
    /// still fits on the line, else a newline: rows of data filled like
    /// text. A space in a flat group.
    FillLine,
    /// Forces the enclosing groups to break, prints nothing.
    BreakParent,
    /// A comment: a space before unless at a line start or after an opening
    /// bracket.
    Comment(String),
    Indent(Vec<Doc>),
    Group(Vec<Doc>),
    Concat(Vec<Doc>),
}

fn text(s: &str) -> Doc {
    Doc::Text(s.to_string())
}

fn render(doc: &Doc) -> String {
    let mut out = String::new();
    let mut stack: Vec<(usize, bool, &Doc)> = vec![(0, false, doc)];
    let mut col = 0usize;
    let mut pending_indent: Option<usize> = None;
    while let Some((ind, flat, d)) = stack.pop() {
        let put = |out: &mut String, s: &str, col: &mut usize, pending_indent: &mut Option<usize>| {
            if let Some(i) = pending_indent.take() {
                out.push_str(&" ".repeat(i));
                *col = i;
            }
            out.push_str(s);
            match s.rfind('\n') {
                Some(n) => *col = s[n + 1..].chars().count(),
                None => *col += s.chars().count(),
            }
        };
        match d {
            Doc::Text(s) => put(&mut out, s, &mut col, &mut pending_indent),
            Doc::Comment(s) => {
                let at_start = pending_indent.is_some() || out.is_empty() || out.ends_with('\n');
                if !at_start && !out.ends_with([' ', '(', '[']) {
                    put(&mut out, " ", &mut col, &mut pending_indent);
                }
                put(&mut out, s, &mut col, &mut pending_indent);
            }
            Doc::Line | Doc::SoftLine if flat => {
                if matches!(d, Doc::Line) {
                    put(&mut out, " ", &mut col, &mut pending_indent);
                }
            }
            Doc::FillLine => {
                let next = stack.last().map(|x| x.2);
                let room = WIDTH as isize - col as isize - 2;
                if flat || next.is_some_and(|n| fits(room, n, &[])) {
                    put(&mut out, " ", &mut col, &mut pending_indent);
                } else {
                    out.push('\n');
                    col = 0;
                    pending_indent = Some(ind);
                }
            }
            Doc::Line | Doc::SoftLine | Doc::HardLine => {
                out.push('\n');
                col = 0;
                pending_indent = Some(ind);
            }
            Doc::Blank => {
                out.push('\n');
                out.push('\n');
                col = 0;
                pending_indent = Some(ind);
            }
            Doc::IfBreak(s) => {
                if !flat {
                    put(&mut out, s, &mut col, &mut pending_indent);
                }
            }
            Doc::BreakParent => {}
            Doc::Indent(ds) => stack.extend(ds.iter().rev().map(|x| (ind + INDENT, flat, x))),
            Doc::Concat(ds) => stack.extend(ds.iter().rev().map(|x| (ind, flat, x))),
            Doc::Group(ds) => {
                let here = if pending_indent.is_some() { ind } else { col };
                let flat = flat || fits(WIDTH.saturating_sub(here) as isize, d, &stack);
                stack.extend(ds.iter().rev().map(|x| (ind, flat, x)));
            }
        }
    }
    out
}

/// Whether `group` fits flat in `room` columns, with what follows it up to
/// the next line break. A comment after the group does not count: it stays
/// at the end of its line wherever the group breaks (as in rustfmt).
fn fits(mut room: isize, group: &Doc, rest: &[(usize, bool, &Doc)]) -> bool {
    // (flat, doc, whether it follows the group)
    let mut local: Vec<(bool, &Doc, bool)> = vec![(true, group, false)];
    let mut rest_i = rest.len();
    loop {
        let (flat, d, after) = match local.pop() {
            Some(x) => x,
            None => {
                if rest_i == 0 {
                    return true;
                }
                rest_i -= 1;
                (rest[rest_i].1, rest[rest_i].2, true)
            }
        };
        match d {
            Doc::Comment(_) if after => return true,
            Doc::Text(s) | Doc::Comment(s) => {
                if s.contains('\n') {
                    return !flat;
                }
                room -= s.chars().count() as isize + isize::from(matches!(d, Doc::Comment(_)));
            }
            Doc::Line | Doc::FillLine if flat => room -= 1,
            Doc::SoftLine if flat => {}
            Doc::Line | Doc::SoftLine | Doc::FillLine => return true,
            Doc::HardLine | Doc::Blank | Doc::BreakParent => return !flat,
            Doc::IfBreak(s) => {
                if !flat {
                    room -= s.len() as isize;
                }
            }
            Doc::Indent(ds) | Doc::Concat(ds) | Doc::Group(ds) => {
                local.extend(ds.iter().rev().map(|x| (flat, x, after)))
            }
        }
        if room < 0 {
            return false;
        }
    }
}

// ---------------------------------------------------------------- printer

struct Printer<'s> {
    src: &'s str,
    tokens: Vec<(usize, Tok, usize)>,
    ti: usize,
    comments: Vec<Comment>,
    ci: usize,
}

impl Printer<'_> {
    fn next_start(&self) -> usize {
        self.tokens.get(self.ti).map_or(self.src.len(), |t| t.0)
    }

    fn prev_end(&self) -> usize {
        self.ti.checked_sub(1).map_or(0, |i| self.tokens[i].2)
    }

    fn comment_text(&self, c: &Comment) -> String {
        self.src[c.start..c.end].to_string()
    }

    fn newlines(&self, from: usize, to: usize) -> usize {
        self.src[from.min(to)..to].matches('\n').count()
    }

    /// Comments before the next token, inline: each line comment ends its line.
    fn flush(&mut self) -> Vec<Doc> {
        let mut out = Vec::new();
        let next = self.next_start();
        while self.ci < self.comments.len() && self.comments[self.ci].start < next {
            let c = self.comments[self.ci].clone();
            out.push(Doc::Comment(self.comment_text(&c)));
            if c.line {
                out.push(Doc::HardLine);
            }
            self.ci += 1;
        }
        out
    }

    /// The comments on the same line as the last token, after it.
    fn trailing(&mut self) -> Vec<Doc> {
        let mut out = Vec::new();
        let next = self.next_start();
        let mut at = self.prev_end();
        while self.ci < self.comments.len() && self.comments[self.ci].start < next {
            let c = self.comments[self.ci].clone();
            if self.newlines(at, c.start) > 0 {
                break;
            }
            out.push(Doc::Comment(self.comment_text(&c)));
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
            let c = self.comments[self.ci].clone();
            out.push(Doc::Comment(self.comment_text(&c)));
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

    /// The next token, with the comments before it.
    fn tok(&mut self) -> Doc {
        let mut out = self.flush();
        let (s, _, e) = &self.tokens[self.ti];
        out.push(Doc::Text(self.src[*s..*e].to_string()));
        self.ti += 1;
        Doc::Concat(out)
    }

    /// Skips the next token (a trailing comma the style drops or puts
    /// back itself), keeping the comments before it.
    fn skip(&mut self) -> Vec<Doc> {
        let out = self.flush();
        self.ti += 1;
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
                if self.is_next(&Tok::Comma) {
                    let comma = self.tok();
                    if always_comma {
                        inner.push(comma);
                    }
                } else if always_comma {
                    inner.push(text(","));
                }
                if !always_comma {
                    inner.push(Doc::IfBreak(","));
                }
                inner.extend(self.trailing());
            }
        }
        let next = self.next_start();
        if self.ci < self.comments.len() && self.comments[self.ci].start < next {
            inner.push(Doc::HardLine);
            let mut lead = self.leading();
            lead.pop();
            inner.extend(lead);
            inner.push(Doc::BreakParent);
        }
        let close = self.tok();
        if n == 0 && inner.len() == 1 {
            return Doc::Concat(vec![open, close]);
        }
        Doc::Group(vec![open, Doc::Indent(inner), Doc::SoftLine, close])
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
                if self.is_next(&Tok::Comma) {
                    inner.extend(self.skip());
                }
                inner.push(Doc::IfBreak(","));
                inner.extend(self.trailing());
            }
        }
        let next = self.next_start();
        if self.ci < self.comments.len() && self.comments[self.ci].start < next {
            inner.push(Doc::HardLine);
            let mut lead = self.leading();
            lead.pop();
            inner.extend(lead);
            inner.push(Doc::BreakParent);
        }
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
                out.extend(self.skip());
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
            debug_assert_eq!(self.tokens[self.ti].1, Tok::LParen);
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

#[cfg(test)]
mod tests;
