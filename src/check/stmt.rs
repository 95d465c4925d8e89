//! Checking statements: scopes and locals, assignments, `return`, and
//! the conditions and bounds of `if` and `for`.

use super::expr::binary_type;
use super::*;

impl<'a> Checker<'a> {
    pub(super) fn push_scope(&mut self) {
        self.body.scopes.push(Vec::new());
    }

    pub(super) fn end_scope(&mut self) {
        let Some(scope) = self.body.scopes.pop() else {
            return;
        };
        for l in scope {
            if l.kind == LocalKind::Var && !l.used && !l.name.starts_with('_') {
                self.error(
                    Diagnostic::warning(l.span, format!("unused variable `{}`", l.name))
                        .with_help(format!("remove it, or name it `_{}` if that is intended", l.name)),
                );
            }
        }
    }

    pub(super) fn declare(&mut self, local: Local) {
        let Some(scope) = self.body.scopes.last_mut() else {
            return;
        };
        if let Some(prev) = scope.iter().find(|l| l.name == local.name) {
            let prev_span = prev.span;
            self.error(
                Diagnostic::error(local.span, format!("`{}` is already declared in this scope", local.name))
                    .with_label(prev_span, "previous declaration"),
            );
            return;
        }
        scope.push(local);
    }

    /// Parameters are never reported unused: interface methods often ignore some.
    pub(super) fn declare_param(&mut self, name: &Ident, ty: Ty) {
        self.declare(Local { name: name.name.to_string(), ty, span: name.span, kind: LocalKind::Param, used: true });
    }

    pub(super) fn lookup_local(&mut self, name: &str) -> Option<&mut Local> {
        self.body.scopes.iter_mut().rev().flat_map(|s| s.iter_mut().rev()).find(|l| l.name == name)
    }

    pub(super) fn edge(&mut self, from: Node, to: Node, span: Span) {
        self.graph.entry(from).or_default().add(to, span);
    }

    /// Records that the current body uses a global item.
    pub(super) fn use_item(&mut self, sym: Symbol, span: Span) {
        self.resolutions.insert(span, sym);
        if let Some(from) = self.body.node {
            self.edge(from, Node::Item((sym.module, sym.item)), span);
        }
    }

    // ------------------------------------------------------------ statements

    pub(super) fn block_in_scope(&mut self, b: &Block) {
        for s in &b.stmts {
            self.stmt(s);
        }
    }

    pub(super) fn block(&mut self, b: &Block) {
        self.push_scope();
        self.block_in_scope(b);
        self.end_scope();
    }

    pub(super) fn stmt(&mut self, s: &Stmt) {
        match &s.kind {
            StmtKind::Let { ty, name, init } => {
                let ty = self.resolve_type(ty, "a local variable");
                // After a bad type, checking the initialiser or use would
                // only repeat the same mistake.
                let bad_type = ty.is_error();
                if let (Some(init), false) = (init, bad_type) {
                    let found = self.expr(init, Some(&ty));
                    self.expect_ty(init, &found, &ty, "the initial value");
                }
                self.warn_shadowed_global(name);
                let local =
                    Local { name: name.name.to_string(), ty, span: name.span, kind: LocalKind::Var, used: bad_type };
                self.declare(local);
            }
            StmtKind::Assign { target, op, value } => self.assign(target, *op, value),
            StmtKind::Expr(e) => {
                self.expr(e, None);
                self.error(
                    Diagnostic::warning(e.span, "this expression has no effect")
                        .with_help("TSL functions are pure: assign the result to a variable or return it"),
                );
            }
            StmtKind::If { cond, then_block, else_branch } => {
                self.condition(cond, "an `if` condition");
                self.block(then_block);
                if let Some(e) = else_branch {
                    self.stmt(e);
                }
            }
            StmtKind::For { var, start, end, body } => {
                for bound in [start, end] {
                    let t = self.expr(bound, Some(&Ty::Int));
                    if !t.is_error() && t != Ty::Int {
                        self.error(
                            Diagnostic::error(bound.span, format!("loop bounds must be `int`, found `{t}`"))
                                .with_help("convert with int(x)"),
                        );
                    }
                }
                if let (Some(lo), Some(hi)) = (const_int(start), const_int(end))
                    && hi - lo > MAX_LOOP_ITERATIONS
                {
                    self.error(
                        Diagnostic::warning(start.span.to(end.span), format!("this loop would run {} times", hi - lo))
                            .with_note(format!("a loop stops after {MAX_LOOP_ITERATIONS} iterations")),
                    );
                }
                self.push_scope();
                self.warn_shadowed_global(var);
                self.declare(Local {
                    name: var.name.to_string(),
                    ty: Ty::Int,
                    span: var.span,
                    kind: LocalKind::LoopVar,
                    used: true,
                });
                let outer_work = self.body.loop_work;
                self.body.loop_work = outer_work.max(1).saturating_mul(worst_case_trips(start, end));
                if self.body.loop_work > MAX_CALL_ITERATIONS
                    && (const_int(start).is_none() || const_int(end).is_none())
                    && !self.body.loop_warned
                {
                    self.body.loop_warned = true;
                    self.error(
                        Diagnostic::warning(
                            start.span.to(end.span),
                            "a bound that is not a constant lets these loops run past the call's iteration budget",
                        )
                        .with_note(format!(
                            "with this bound, the loops around here can run {} iterations per call; a call stops \
                             every loop after {MAX_CALL_ITERATIONS} in all, and a runaway shader spends them on \
                             every hit",
                            self.body.loop_work
                        ))
                        .with_help("bound it with a constant, for example `for i in 0..min(n, 64)`"),
                    );
                }
                self.body.loops += 1;
                self.block(body);
                self.body.loops -= 1;
                self.body.loop_work = outer_work;
                self.end_scope();
            }
            StmtKind::While { cond, body } => {
                self.error(
                    Diagnostic::error(
                        Span { end: cond.span.end, ..s.span },
                        "`while` loops are not allowed: a shader must not hang its host",
                    )
                    .with_help("loop over a bounded range instead: `for i in 0..n { ... }`"),
                );
                self.condition(cond, "a `while` condition");
                self.body.loops += 1;
                self.block(body);
                self.body.loops -= 1;
            }
            StmtKind::Break | StmtKind::Continue => {
                if self.body.loops == 0 {
                    let what = if matches!(s.kind, StmtKind::Break) { "break" } else { "continue" };
                    self.error(Diagnostic::error(s.span, format!("`{what}` outside of a loop")));
                }
            }
            StmtKind::Return(value) => self.ret(s.span, value.as_ref()),
            StmtKind::Block(b) => self.block(b),
        }
    }

    pub(super) fn warn_shadowed_global(&mut self, name: &Ident) {
        if interface::global(&name.name).is_some() {
            self.error(
                Diagnostic::warning(name.span, format!("`{}` shadows the shading global of the same name", name.name))
                    .with_help("rename the variable to keep the global visible"),
            );
        }
    }

    pub(super) fn condition(&mut self, cond: &Expr, what: &str) {
        let t = self.expr(cond, Some(&Ty::Bool));
        if !t.is_error() && t != Ty::Bool {
            let mut d = Diagnostic::error(cond.span, format!("{what} must be `bool`, found `{t}`"));
            if t.is_numeric() {
                d = d.with_help("numbers are not truth values: compare explicitly, e.g. `x != 0`");
            }
            self.error(d);
        }
    }

    pub(super) fn ret(&mut self, span: Span, value: Option<&Expr>) {
        let Some(want) = self.body.ret.clone() else {
            self.error(Diagnostic::error(span, "`return` outside of a function"));
            return;
        };
        match (value, &want) {
            (None, Ty::Void) => {}
            (None, want) => {
                self.error(Diagnostic::error(span, format!("`return` needs a value of type `{want}`")));
            }
            (Some(v), Ty::Void) => {
                self.expr(v, None);
                self.error(Diagnostic::error(v.span, "a `void` function cannot return a value"));
            }
            (Some(v), want) => {
                let found = self.expr(v, Some(want));
                self.expect_ty(v, &found, want, "the return value");
            }
        }
    }

    pub(super) fn assign(&mut self, target: &Expr, op: AssignOp, value: &Expr) {
        let Some(target_ty) = self.lvalue(target) else {
            self.expr(value, None);
            return;
        };
        let found = self.expr(value, Some(&target_ty));
        match op.binary() {
            None => self.expect_ty(value, &found, &target_ty, "the assigned value"),
            Some(bop) => match binary_type(bop, &target_ty, &found) {
                Ok(result) if result.converts_to(&target_ty) => {}
                Ok(result) => self.error(Diagnostic::error(
                    value.span,
                    format!(
                        "`{target_ty} {}= {found}` gives `{result}`, which cannot be stored in `{target_ty}`",
                        bop.symbol()
                    ),
                )),
                Err((message, help)) => {
                    let mut d = Diagnostic::error(value.span, message);
                    if let Some(h) = help {
                        d = d.with_help(h);
                    }
                    self.error(d);
                }
            },
        }
    }

    /// Checks an assignment target and returns its type.
    pub(super) fn lvalue(&mut self, e: &Expr) -> Option<Ty> {
        match &e.kind {
            ExprKind::Name(name) => {
                if let Some(local) = self.lookup_local(name) {
                    let (kind, ty) = (local.kind.clone(), local.ty.clone());
                    let declared = local.span;
                    self.local_uses.insert(e.span, declared);
                    if kind == LocalKind::LoopVar {
                        self.error(
                            Diagnostic::error(e.span, format!("cannot assign to the loop variable `{name}`"))
                                .with_help("copy it into a local variable first"),
                        );
                        return None;
                    }
                    self.expr_types.insert(e.span, &ty);
                    return Some(ty);
                }
                let (msg, ty) = if let Some(ty) = interface::global(name) {
                    (format!("cannot assign to `{name}`: shading globals are read-only"), ty)
                } else if let Some(sym) = self.symbol(name).filter(|s| s.kind == SymbolKind::Const) {
                    (format!("cannot assign to the constant `{name}`"), self.const_type(sym))
                } else {
                    self.expr(e, None);
                    return None;
                };
                let copy = format!("my_{}", name.to_lowercase());
                self.error(
                    Diagnostic::error(e.span, msg)
                        .with_help(format!("declare a local copy and change that: `{ty} {copy} = {name};`")),
                );
                None
            }
            ExprKind::Member { base, .. } | ExprKind::Index { base, .. } => {
                self.lvalue(base)?;
                let t = self.expr(e, None);
                (!t.is_error()).then_some(t)
            }
            _ => {
                self.expr(e, None);
                self.error(Diagnostic::error(e.span, "this expression cannot be assigned to"));
                None
            }
        }
    }
}

/// The most times `for i in start..end` can run: the difference of constant
/// bounds; `c` for `x..x + c`; where the end is `min(x, c)` (either order)
/// over a constant start, `c - start`; otherwise the per-loop cap.
fn worst_case_trips(start: &Expr, end: &Expr) -> i64 {
    if let ExprKind::Binary { op: BinaryOp::Add, lhs, rhs } = &end.kind
        && let (ExprKind::Name(a), ExprKind::Name(b)) = (&lhs.kind, &start.kind)
        && a == b
        && let Some(c) = const_int(rhs)
    {
        return c.clamp(0, MAX_LOOP_ITERATIONS);
    }
    let upper = const_int(end).or_else(|| match &end.kind {
        ExprKind::Call { callee, args } if callee.name == "min" && args.len() == 2 => {
            args.iter().filter_map(|a| const_int(&a.value)).min()
        }
        _ => None,
    });
    match (const_int(start), upper) {
        (Some(lo), Some(hi)) => (hi - lo).clamp(0, MAX_LOOP_ITERATIONS),
        _ => MAX_LOOP_ITERATIONS,
    }
}
