//! Span-free equality of two syntax trees, for the formatter's verifier:
//! every node's kind, names, literal values, operators, list lengths and
//! expression depths (so parentheses, which add depth but no node) must
//! agree; spans may differ. The first difference is returned at the first
//! tree's span and described for a person ("the array ... would have 2
//! elements instead of 5").
//!
//! Every struct of the first tree is destructured without `..` and every
//! enum matched without a wildcard, so a field or variant added to the AST
//! does not compile until it is compared here.

use crate::diag::Span;
use crate::syntax::ast::*;

/// Where the second tree differs from the first, and how.
#[derive(Debug)]
pub(super) struct Difference {
    /// In the first tree's source.
    pub span: Span,
    /// What differs, as a noun phrase: "the array".
    pub subject: String,
    /// How, as a verb phrase: "would have 2 elements instead of 5".
    pub change: String,
}

type Same = Result<(), Difference>;

fn differ(span: Span, subject: impl Into<String>, change: impl Into<String>) -> Same {
    Err(Difference { span, subject: subject.into(), change: change.into() })
}

fn became(span: Span, subject: String, other: String) -> Same {
    differ(span, subject, format!("would become {other}"))
}

/// Whether two files have the same tree, spans aside.
pub(super) fn same_file(a: &SourceFile, b: &SourceFile) -> Same {
    let SourceFile { items } = a;
    let whole = match (items.first(), items.last()) {
        (Some(f), Some(l)) => item_span(f).to(item_span(l)),
        _ => Span::default(),
    };
    same_list(items, &b.items, whole, || "the file".into(), "item", same_item)
}

/// Equal lengths, then equal elements. The subject (of the parent, for a
/// difference in length) is only written when there is a difference:
/// formatting that verifies allocates no message.
fn same_list<T>(
    a: &[T],
    b: &[T],
    parent: Span,
    subject: impl FnOnce() -> String,
    noun: &str,
    same: impl Fn(&T, &T) -> Same,
) -> Same {
    if a.len() != b.len() {
        return differ(parent, subject(), format!("would have {} instead of {}", count(b.len(), noun), a.len()));
    }
    a.iter().zip(b).try_for_each(|(x, y)| same(x, y))
}

fn count(n: usize, noun: &str) -> String {
    match (n, noun.strip_suffix('y')) {
        (1, _) => format!("1 {noun}"),
        (_, Some(stem)) => format!("{n} {stem}ies"),
        _ => format!("{n} {noun}s"),
    }
}

fn same_option<T>(
    a: &Option<T>,
    b: &Option<T>,
    span: Span,
    subject: impl FnOnce() -> String,
    what: &str,
    same: impl FnOnce(&T, &T) -> Same,
) -> Same {
    match (a, b) {
        (Some(x), Some(y)) => same(x, y),
        (None, None) => Ok(()),
        (Some(_), None) => differ(span, subject(), format!("would lose its {what}")),
        (None, Some(_)) => differ(span, subject(), format!("would gain a {what}")),
    }
}

fn same_ident(a: &Ident, b: &Ident) -> Same {
    let Ident { name, span } = a;
    if *name != b.name {
        return differ(*span, format!("the name `{name}`"), format!("would become `{}`", b.name));
    }
    Ok(())
}

// ---------------------------------------------------------------- items

fn item_span(item: &Item) -> Span {
    match item {
        Item::Import { span, .. } => *span,
        Item::Function(f) => f.span,
        Item::Material(m) => m.span,
        Item::MaterialTree(m) => m.span,
        Item::Const(c) => c.span,
        Item::Scene(s) => s.span,
    }
}

fn item_noun(item: &Item) -> String {
    match item {
        Item::Import { path, .. } => format!("the import of {}", quote(path)),
        Item::Function(f) => format!("the function `{}`", f.name.name),
        Item::Material(m) => format!("the material `{}`", m.name.name),
        Item::MaterialTree(m) => format!("the material `{}`", m.name.name),
        Item::Const(c) => format!("the constant `{}`", c.name.name),
        Item::Scene(_) => "the scene".to_string(),
    }
}

fn same_item(a: &Item, b: &Item) -> Same {
    let other = || became(item_span(a), item_noun(a), item_noun(b));
    match a {
        Item::Import { path, span } => {
            let Item::Import { path: other_path, .. } = b else { return other() };
            if path != other_path {
                return became(*span, item_noun(a), item_noun(b));
            }
            Ok(())
        }
        Item::Function(f) => {
            let Item::Function(g) = b else { return other() };
            same_function(f, g)
        }
        Item::Material(m) => {
            let Item::Material(n) = b else { return other() };
            let MaterialDef { name, params, methods, span } = m;
            let subject = || item_noun(a);
            same_ident(name, &n.name)?;
            same_list(params, &n.params, *span, subject, "parameter", same_param)?;
            same_list(methods, &n.methods, *span, subject, "method", same_function)
        }
        Item::MaterialTree(m) => {
            let Item::MaterialTree(n) = b else { return other() };
            let MaterialTree { name, params, body, span } = m;
            same_ident(name, &n.name)?;
            let subject = || item_noun(a);
            same_option(params, &n.params, *span, subject, "parameter list", |x, y| {
                same_list(x, y, *span, subject, "parameter", same_param)
            })?;
            same_expr(body, &n.body)
        }
        Item::Const(c) => {
            let Item::Const(d) = b else { return other() };
            let ConstDef { ty, name, value, span: _ } = c;
            same_type(ty, &d.ty)?;
            same_ident(name, &d.name)?;
            same_expr(value, &d.value)
        }
        Item::Scene(s) => {
            let Item::Scene(t) = b else { return other() };
            let Scene { entries, span } = s;
            same_list(entries, &t.entries, *span, || "the scene".into(), "entry", same_scene_entry)
        }
    }
}

fn same_function(a: &Function, b: &Function) -> Same {
    let Function { ret, name, params, body, span } = a;
    same_type(ret, &b.ret)?;
    same_ident(name, &b.name)?;
    let subject = || format!("the function `{}`", name.name);
    same_list(params, &b.params, *span, subject, "parameter", same_param)?;
    same_block(body, &b.body)
}

fn same_param(a: &Param, b: &Param) -> Same {
    let Param { ty, name, default, options, span } = a;
    same_type(ty, &b.ty)?;
    same_ident(name, &b.name)?;
    let subject = || format!("the parameter `{}`", name.name);
    same_option(default, &b.default, *span, subject, "default value", same_expr)?;
    same_option(options, &b.options, *span, subject, "options", same_options)
}

fn same_options(a: &ParamOptions, b: &ParamOptions) -> Same {
    let ParamOptions { values, span } = a;
    if !values.iter().map(|(v, _)| v).eq(b.values.iter().map(|(v, _)| v)) {
        return became(*span, format!("the options ({})", a.listed()), format!("({})", b.listed()));
    }
    Ok(())
}

fn same_type(a: &TypeExpr, b: &TypeExpr) -> Same {
    let TypeExpr { base, array_len, span } = a;
    let show = |t: &TypeExpr| match t.array_len {
        Some((n, _)) => format!("{}[{n}]", t.base.keyword()),
        None => t.base.keyword().to_string(),
    };
    if *base != b.base || array_len.map(|l| l.0) != b.array_len.map(|l| l.0) {
        return differ(*span, format!("the type `{}`", show(a)), format!("would become `{}`", show(b)));
    }
    Ok(())
}

fn same_scene_entry(a: &SceneEntry, b: &SceneEntry) -> Same {
    match (a, b) {
        (SceneEntry::Block(x), SceneEntry::Block(y)) => {
            let SceneBlock { keyword, kind, props, span } = x;
            let subject = || format!("the scene block `{}`", keyword.name);
            same_ident(keyword, &y.keyword)?;
            same_option(kind, &y.kind, *span, subject, "kind", same_ident)?;
            same_list(props, &y.props, *span, subject, "property", same_scene_prop)
        }
        (SceneEntry::Prop(x), SceneEntry::Prop(y)) => same_scene_prop(x, y),
        (SceneEntry::Block(x), SceneEntry::Prop(y)) => differ(
            x.span,
            format!("the scene block `{}`", x.keyword.name),
            format!("would become the property `{}`", y.name.name),
        ),
        (SceneEntry::Prop(x), SceneEntry::Block(y)) => differ(
            x.span,
            format!("the property `{}`", x.name.name),
            format!("would become the scene block `{}`", y.keyword.name),
        ),
    }
}

fn same_scene_prop(a: &SceneProp, b: &SceneProp) -> Same {
    let SceneProp { name, value, span } = a;
    same_ident(name, &b.name)?;
    same_option(value, &b.value, *span, || format!("the property `{}`", name.name), "value", same_expr)
}

// ---------------------------------------------------------------- statements

/// A block's and a statement's depths follow from their children's, so
/// only expressions' depths (which count parentheses) are compared.
fn same_block(a: &Block, b: &Block) -> Same {
    let Block { stmts, span, depth: _ } = a;
    same_list(stmts, &b.stmts, *span, || "the block".into(), "statement", same_stmt)
}

fn stmt_noun(s: &Stmt) -> String {
    match &s.kind {
        StmtKind::Let { name, .. } => format!("the declaration of `{}`", name.name),
        StmtKind::Assign { op, .. } => format!("the assignment `{}`", assign_symbol(*op)),
        StmtKind::Expr(_) => "the expression statement".to_string(),
        StmtKind::If { .. } => "the `if` statement".to_string(),
        StmtKind::For { .. } => "the `for` loop".to_string(),
        StmtKind::While { .. } => "the `while` loop".to_string(),
        StmtKind::Break => "the `break`".to_string(),
        StmtKind::Continue => "the `continue`".to_string(),
        StmtKind::Return(_) => "the `return`".to_string(),
        StmtKind::Block(_) => "the block".to_string(),
    }
}

fn assign_symbol(op: AssignOp) -> &'static str {
    match op {
        AssignOp::Set => "=",
        AssignOp::Add => "+=",
        AssignOp::Sub => "-=",
        AssignOp::Mul => "*=",
        AssignOp::Div => "/=",
    }
}

fn same_stmt(a: &Stmt, b: &Stmt) -> Same {
    with_stack(|| same_stmt_unguarded(a, b))
}

fn same_stmt_unguarded(a: &Stmt, b: &Stmt) -> Same {
    let Stmt { kind, span, depth: _ } = a;
    let span = *span;
    let other = || became(span, stmt_noun(a), stmt_noun(b));
    match kind {
        StmtKind::Let { ty, name, init } => {
            let StmtKind::Let { ty: ty2, name: name2, init: init2 } = &b.kind else { return other() };
            same_type(ty, ty2)?;
            same_ident(name, name2)?;
            same_option(init, init2, span, || stmt_noun(a), "initial value", same_expr)
        }
        StmtKind::Assign { target, op, value } => {
            let StmtKind::Assign { target: target2, op: op2, value: value2 } = &b.kind else { return other() };
            if op != op2 {
                return other();
            }
            same_expr(target, target2)?;
            same_expr(value, value2)
        }
        StmtKind::Expr(e) => {
            let StmtKind::Expr(e2) = &b.kind else { return other() };
            same_expr(e, e2)
        }
        StmtKind::If { cond, then_block, else_branch } => {
            let StmtKind::If { cond: cond2, then_block: then2, else_branch: else2 } = &b.kind else { return other() };
            same_expr(cond, cond2)?;
            same_block(then_block, then2)?;
            same_option(else_branch, else2, span, || stmt_noun(a), "`else` branch", |x, y| same_stmt(x, y))
        }
        StmtKind::For { var, start, end, body } => {
            let StmtKind::For { var: var2, start: start2, end: end2, body: body2 } = &b.kind else { return other() };
            same_ident(var, var2)?;
            same_expr(start, start2)?;
            same_expr(end, end2)?;
            same_block(body, body2)
        }
        StmtKind::While { cond, body } => {
            let StmtKind::While { cond: cond2, body: body2 } = &b.kind else { return other() };
            same_expr(cond, cond2)?;
            same_block(body, body2)
        }
        StmtKind::Break => {
            if matches!(b.kind, StmtKind::Break) {
                Ok(())
            } else {
                other()
            }
        }
        StmtKind::Continue => {
            if matches!(b.kind, StmtKind::Continue) {
                Ok(())
            } else {
                other()
            }
        }
        StmtKind::Return(e) => {
            let StmtKind::Return(e2) = &b.kind else { return other() };
            same_option(e, e2, span, || stmt_noun(a), "value", same_expr)
        }
        StmtKind::Block(block) => {
            let StmtKind::Block(block2) = &b.kind else { return other() };
            same_block(block, block2)
        }
    }
}

// ---------------------------------------------------------------- expressions

fn expr_noun(e: &Expr) -> String {
    match &e.kind {
        ExprKind::Int(v) => format!("the literal `{v}`"),
        ExprKind::Float(v) => format!("the literal `{v}`"),
        ExprKind::Bool(v) => format!("the literal `{v}`"),
        ExprKind::Str(s) => format!("the string {}", quote(s)),
        ExprKind::Name(n) => format!("the name `{n}`"),
        ExprKind::Call { callee, .. } => format!("the call of `{}`", callee.name),
        ExprKind::Construct { ty, .. } => format!("the call of `{}`", ty.keyword()),
        ExprKind::Member { field, .. } => format!("the member `.{}`", field.name),
        ExprKind::Index { .. } => "the indexing".to_string(),
        ExprKind::Unary { op: UnaryOp::Neg, .. } => "the negation".to_string(),
        ExprKind::Unary { op: UnaryOp::Not, .. } => "the `!` operation".to_string(),
        ExprKind::Binary { op, .. } => format!("the `{}` operation", op.symbol()),
        ExprKind::Ternary { .. } => "the conditional".to_string(),
        ExprKind::Array(_) => "the array".to_string(),
        ExprKind::Tuple(_) => "the tuple".to_string(),
    }
}

fn same_expr(a: &Expr, b: &Expr) -> Same {
    with_stack(|| {
        let Expr { kind, span, depth } = a;
        same_kind(kind, a, b)?;
        if *depth != b.depth {
            return differ(*span, format!("the parentheses around {}", expr_noun(a)), "would change");
        }
        Ok(())
    })
}

/// `a.kind` (passed apart so that the match below is exhaustive) against
/// `b.kind`.
fn same_kind(kind: &ExprKind, a: &Expr, b: &Expr) -> Same {
    let span = a.span;
    let other = || became(span, expr_noun(a), expr_noun(b));
    let args = |x: &[Arg], y: &[Arg]| same_list(x, y, span, || expr_noun(a), "argument", same_arg);
    let exprs = |x: &[Expr], y: &[Expr]| same_list(x, y, span, || expr_noun(a), "element", same_expr);
    match kind {
        ExprKind::Int(v) => {
            if matches!(b.kind, ExprKind::Int(w) if w == *v) {
                Ok(())
            } else {
                other()
            }
        }
        ExprKind::Float(v) => {
            if matches!(b.kind, ExprKind::Float(w) if w.to_bits() == v.to_bits()) {
                Ok(())
            } else {
                other()
            }
        }
        ExprKind::Bool(v) => {
            if matches!(b.kind, ExprKind::Bool(w) if w == *v) {
                Ok(())
            } else {
                other()
            }
        }
        ExprKind::Str(s) => {
            if matches!(&b.kind, ExprKind::Str(t) if t == s) {
                Ok(())
            } else {
                other()
            }
        }
        ExprKind::Name(n) => {
            if matches!(&b.kind, ExprKind::Name(m) if m == n) {
                Ok(())
            } else {
                other()
            }
        }
        ExprKind::Call { callee, args: xs } => {
            let ExprKind::Call { callee: callee2, args: ys } = &b.kind else { return other() };
            same_ident(callee, callee2)?;
            args(xs, ys)
        }
        ExprKind::Construct { ty, ty_span: _, args: xs } => {
            let ExprKind::Construct { ty: ty2, args: ys, .. } = &b.kind else { return other() };
            if ty != ty2 {
                return other();
            }
            args(xs, ys)
        }
        ExprKind::Member { base, field } => {
            let ExprKind::Member { base: base2, field: field2 } = &b.kind else { return other() };
            same_expr(base, base2)?;
            same_ident(field, field2)
        }
        ExprKind::Index { base, index } => {
            let ExprKind::Index { base: base2, index: index2 } = &b.kind else { return other() };
            same_expr(base, base2)?;
            same_expr(index, index2)
        }
        ExprKind::Unary { op, operand } => {
            let ExprKind::Unary { op: op2, operand: operand2 } = &b.kind else { return other() };
            if op != op2 {
                return other();
            }
            same_expr(operand, operand2)
        }
        ExprKind::Binary { op, lhs, rhs } => {
            let ExprKind::Binary { op: op2, lhs: lhs2, rhs: rhs2 } = &b.kind else { return other() };
            if op != op2 {
                return other();
            }
            same_expr(lhs, lhs2)?;
            same_expr(rhs, rhs2)
        }
        ExprKind::Ternary { cond, then_expr, else_expr } => {
            let ExprKind::Ternary { cond: cond2, then_expr: then2, else_expr: else2 } = &b.kind else {
                return other();
            };
            same_expr(cond, cond2)?;
            same_expr(then_expr, then2)?;
            same_expr(else_expr, else2)
        }
        ExprKind::Array(xs) => {
            let ExprKind::Array(ys) = &b.kind else { return other() };
            exprs(xs, ys)
        }
        ExprKind::Tuple(xs) => {
            let ExprKind::Tuple(ys) = &b.kind else { return other() };
            exprs(xs, ys)
        }
    }
}

fn same_arg(a: &Arg, b: &Arg) -> Same {
    let Arg { name, value } = a;
    let subject = || match name {
        Some(n) => format!("the argument `{}`", n.name),
        None => "the argument".to_string(),
    };
    same_option(name, &b.name, value.span, subject, "name", same_ident)?;
    same_expr(value, &b.value)
}

/// The most characters of the user's text a refusal quotes (a comment
/// or a token); longer text is cut and ends with `…`.
pub const QUOTED_CHARS: usize = 40;

/// Text of the user's file for a message: control characters escaped (no
/// terminal escape sequence from a file reaches the terminal), at most
/// [`QUOTED_CHARS`] characters.
pub(super) fn escaped(s: &str) -> String {
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i == QUOTED_CHARS {
            out.push('…');
            break;
        }
        out.push(crate::diag::escape_char(c));
    }
    out
}

/// A string or comment for a message, in double quotes.
pub(super) fn quote(s: &str) -> String {
    format!("\"{}\"", escaped(s))
}
