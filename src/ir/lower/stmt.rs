//! Functions and statements: inlining a call (with its memo), bodies with
//! early returns, declarations, assignments to variables, members and
//! elements, `if`, bounded loops, `break` and `continue`.

use super::*;

impl<'p> Lowerer<'p> {
    /// The type the checker gave `e`: every expression of a program that
    /// checked without errors has one, and none is `Ty::Error`.
    pub(super) fn ty_of(&self, e: &Expr) -> Ty {
        let known = self.constant_types.and_then(|types| types.get(&e.span));
        let known = known.or_else(|| self.types.borrow().get(&e.span).copied());
        let found = known.or_else(|| {
            let ty = self.program.expr_types.get(&e.span)?;
            self.types.borrow_mut().insert(e.span, ty);
            Some(ty)
        });
        match found {
            Some(ty) => {
                if *ty == Ty::Error {
                    ruled_out!("an expression of type error at {:?}", e.span);
                }
                ty.clone()
            }
            None => {
                ruled_out!("an expression the checker did not type at {:?}", e.span);
                Ty::Error
            }
        }
    }

    pub(super) fn error(&mut self, span: Span, msg: impl Into<String>) {
        self.diags.push(Diagnostic::error(span, msg));
    }

    /// The lanes of a plain value.
    pub(super) fn lanes(&mut self, b: &mut Builder, v: Val<'p>, ty: &Ty) -> Vec<Value> {
        match v {
            Val::Lanes(l) => l,
            other => {
                ruled_out!("{other:?} where a `{ty}` is expected");
                b.zeros(self.lanes_of(ty))
            }
        }
    }

    /// Converts `v` of type `from` to `to` (int → float; triples are alike).
    pub(super) fn coerce(&mut self, b: &mut Builder, v: Val<'p>, from: &Ty, to: &Ty) -> Val<'p> {
        match (from, to, v) {
            (Ty::Int, Ty::Float, Val::Lanes(l)) => Val::Lanes(vec![b.un(UnOp::IToF, l[0])]),
            (Ty::Array(fe, _), Ty::Array(te, _), Val::Array(ArrayVal::Elems(es)))
                if **fe == Ty::Int && **te == Ty::Float =>
            {
                Val::Array(ArrayVal::Elems(es.into_iter().map(|e| vec![b.un(UnOp::IToF, e[0])]).collect()))
            }
            (_, _, v) => v,
        }
    }

    pub(super) fn expr_as(&mut self, b: &mut Builder, fr: &mut Frame<'p>, ctx: &Ctx, e: &'p Expr, to: &Ty) -> Val<'p> {
        let v = self.expr(b, fr, ctx, e);
        let from = self.ty_of(e);
        self.coerce(b, v, &from, to)
    }

    pub(super) fn new_frame(&self, in_prelude: bool, assigned: HashSet<String>) -> Frame<'p> {
        Frame { scopes: vec![HashMap::default()], ret: None, loops: Vec::new(), material: None, assigned, in_prelude }
    }

    /// Binds a name in the innermost scope: as a value when it is never
    /// assigned (so it folds), else in variables.
    pub(super) fn bind(&mut self, b: &mut Builder, fr: &mut Frame<'p>, name: &str, v: Val<'p>, ty: &Ty) {
        let binding = if fr.assigned.contains(name) {
            match v {
                Val::Lanes(lanes) => {
                    let vars: Vec<Var> = lanes
                        .iter()
                        .map(|x| {
                            let var = b.var(b.ty(*x));
                            b.push(Inst::Set(var, *x));
                            var
                        })
                        .collect();
                    Binding::Vars(vars)
                }
                Val::Array(a) => Binding::Val(Val::Array(self.materialize(b, a, ty))),
                other => Binding::Val(other),
            }
        } else {
            Binding::Val(v)
        };
        if let Some(scope) = fr.scopes.last_mut() {
            scope.insert(name.to_string(), binding);
        }
    }

    /// Copies an array into fresh IR arrays (arrays have value semantics).
    pub(super) fn materialize(&mut self, b: &mut Builder, a: ArrayVal, ty: &Ty) -> ArrayVal {
        let Ty::Array(elem, len) = ty else {
            ruled_out!("an array of type `{ty}`");
            return a;
        };
        let lanes = self.lanes_of(elem);
        let scalar = Self::scalar_of(elem);
        let arrays: Vec<ArrayId> = (0..lanes)
            .map(|_| {
                b.func.arrays.push((scalar, *len));
                ArrayId(b.func.arrays.len() as u32 - 1)
            })
            .collect();
        for k in 0..*len {
            let elem_vals = self.array_elem_const(b, &a, k, lanes);
            let idx = b.i(k as i32);
            for (lane, arr) in arrays.iter().enumerate() {
                b.push(Inst::Store { array: *arr, index: idx, value: elem_vals[lane] });
            }
        }
        ArrayVal::Ir { arrays, len: *len }
    }

    pub(super) fn array_elem_const(&mut self, b: &mut Builder, a: &ArrayVal, k: u32, lanes: usize) -> Vec<Value> {
        match a {
            ArrayVal::Elems(es) => es.get(k as usize).cloned().unwrap_or_else(|| {
                ruled_out!("element {k} of an array of {}", es.len());
                b.zeros(lanes)
            }),
            ArrayVal::Ir { arrays, .. } => {
                let idx = b.i(k as i32);
                arrays
                    .iter()
                    .map(|arr| {
                        let ty = b.func.arrays[arr.0 as usize].0;
                        b.def(ty, Op::Load { array: *arr, index: idx })
                    })
                    .collect()
            }
        }
    }

    pub(super) fn array_elems(&mut self, b: &mut Builder, a: &ArrayVal, lanes: usize) -> Vec<Vec<Value>> {
        let len = match a {
            ArrayVal::Elems(es) => es.len() as u32,
            ArrayVal::Ir { len, .. } => *len,
        };
        (0..len).map(|k| self.array_elem_const(b, a, k, lanes)).collect()
    }

    /// Inlines a call of a user function, reusing an earlier identical call.
    pub(super) fn inline_function(
        &mut self,
        b: &mut Builder,
        sym: Symbol,
        f: &'p ast::Function,
        args: Vec<Val<'p>>,
        ctx: &Ctx,
    ) -> Val<'p> {
        let plain_args: Option<Vec<Value>> = args
            .iter()
            .map(|a| match a {
                Val::Lanes(l) => Some(l.clone()),
                _ => None,
            })
            .collect::<Option<Vec<_>>>()
            .map(|v| v.concat());
        let key = plain_args.map(|args| MemoKey::Call { item: (sym.module, sym.item), ctx: ctx.id, args });
        if let Some(key) = &key
            && let Some(v) = b.lookup(key)
        {
            return Val::Lanes(v);
        }
        // In a hit group, a call with point-only inputs under a per-call
        // condition is lowered above it (`ir::hoist`), for the other methods.
        if let Some(MemoKey::Call { args: words, .. }) = &key
            && b.hoisting.is_some()
        {
            let inputs: Vec<Value> = words.iter().chain(ctx.overrides.values().flatten()).copied().collect();
            return b.hoisted(&inputs, |b| self.inline_body(b, (sym, f), args, ctx, key));
        }
        self.inline_body(b, (sym, f), args, ctx, key)
    }

    /// The body of `callee` inlined with `args`, remembered under `key`.
    fn inline_body(
        &mut self,
        b: &mut Builder,
        (sym, f): (Symbol, &'p ast::Function),
        args: Vec<Val<'p>>,
        ctx: &Ctx,
        key: Option<MemoKey>,
    ) -> Val<'p> {
        let ret = Ty::from_ast(&f.ret);
        let mut fr = self.new_frame(self.is_prelude(sym), assigned_names(&f.body));
        for (p, a) in f.params.iter().zip(args) {
            let ty = Ty::from_ast(&p.ty);
            self.bind(b, &mut fr, &p.name.name, a, &ty);
        }
        let result = self.body_with_return(b, &mut fr, ctx, &f.body, &ret);
        if let (Some(key), Val::Lanes(l)) = (key, &result) {
            b.remember(key, l);
        }
        result
    }

    /// Lowers a function or method body and returns its result. A body whose
    /// only `return` is its last statement needs no result variables.
    pub(super) fn body_with_return(
        &mut self,
        b: &mut Builder,
        fr: &mut Frame<'p>,
        ctx: &Ctx,
        body: &'p ast::Block,
        ret: &Ty,
    ) -> Val<'p> {
        let returns = count_returns(&body.stmts);
        if let Some(Stmt { kind: StmtKind::Return(value), .. }) = body.stmts.last()
            && returns == 1
        {
            for s in &body.stmts[..body.stmts.len() - 1] {
                if self.stmt(b, fr, ctx, s) {
                    break;
                }
            }
            return match value {
                Some(e) => self.expr_as(b, fr, ctx, e, ret),
                None => Val::Unit,
            };
        }
        if *ret == Ty::Void {
            return Val::Unit;
        }
        let label = b.label();
        let vars: Vec<Var> = self.words(ret).into_iter().map(|s| b.var(s)).collect();
        // Result variables start at zero: every path returns (checked), so
        // this only keeps unreachable paths defined.
        for v in &vars {
            let zero = match b.func.vars[v.0 as usize] {
                Scalar::F32 => b.f(0.0),
                Scalar::I32 => b.i(0),
                Scalar::Bool => b.b(false),
            };
            b.push(Inst::Set(*v, zero));
        }
        fr.ret = Some((label, vars.clone(), ret.clone()));
        let (prefix, inner) = b.block_body(|b| {
            for s in &body.stmts {
                if self.stmt(b, fr, ctx, s) {
                    break;
                }
            }
        });
        for inst in prefix {
            b.push(inst);
        }
        b.push(Inst::Block { label, body: inner });
        let lanes = vars.iter().map(|v| b.get(*v)).collect();
        Val::Lanes(lanes)
    }

    pub(super) fn lookup<'f>(&self, fr: &'f Frame<'p>, name: &str) -> Option<&'f Binding<'p>> {
        fr.scopes.iter().rev().find_map(|s| s.get(name))
    }

    /// Lowers a statement; returns true when control never falls through.
    pub(super) fn stmt(&mut self, b: &mut Builder, fr: &mut Frame<'p>, ctx: &Ctx, s: &'p Stmt) -> bool {
        match &s.kind {
            StmtKind::Let { ty, name, init } => {
                let ty = Ty::from_ast(ty);
                let v = match init {
                    Some(e) => self.expr_as(b, fr, ctx, e, &ty),
                    None => self.zero_value(b, &ty),
                };
                self.bind(b, fr, &name.name, v, &ty);
                false
            }
            StmtKind::Assign { target, op, value } => {
                self.assign(b, fr, ctx, target, *op, value);
                false
            }
            // Functions are pure: an expression statement does nothing.
            StmtKind::Expr(_) => false,
            StmtKind::If { cond, then_block, else_branch } => {
                let c = self.expr(b, fr, ctx, cond);
                let c = self.scalar(b, c);
                match b.konst(c) {
                    Some(Const::B(true)) => return self.block(b, fr, ctx, then_block),
                    Some(Const::B(false)) => {
                        return match else_branch {
                            Some(e) => self.stmt(b, fr, ctx, e),
                            None => false,
                        };
                    }
                    _ => {}
                }
                let mut then_ends = false;
                let then_body = b.nested_under(&[c], |b| then_ends = self.block(b, fr, ctx, then_block));
                let mut else_ends = false;
                let else_body = b.nested_under(&[c], |b| {
                    if let Some(e) = else_branch {
                        else_ends = self.stmt(b, fr, ctx, e);
                    }
                });
                b.push(Inst::If { cond: c, then_body, else_body });
                then_ends && else_ends
            }
            StmtKind::For { var, start, end, body } => {
                let lo = self.expr(b, fr, ctx, start);
                let lo = self.scalar(b, lo);
                let hi = self.expr(b, fr, ctx, end);
                let hi = self.scalar(b, hi);
                let label = b.label();
                let counter = b.var(Scalar::I32);
                b.note_loop_counter(counter, [lo, hi]);
                fr.loops.push(label);
                let inner = b.nested_under(&[lo, hi], |b| {
                    fr.scopes.push(HashMap::default());
                    let i = b.get(counter);
                    if let Some(scope) = fr.scopes.last_mut() {
                        scope.insert(var.name.to_string(), Binding::Val(Val::Lanes(vec![i])));
                    }
                    self.block(b, fr, ctx, body);
                    fr.scopes.pop();
                });
                fr.loops.pop();
                b.push(Inst::Loop { label, counter, start: lo, end: hi, body: inner });
                false
            }
            StmtKind::While { .. } => {
                ruled_out!("a `while` loop (parsed only to be refused)");
                false
            }
            StmtKind::Break | StmtKind::Continue => {
                match fr.loops.last() {
                    Some(l) => {
                        b.push(if matches!(s.kind, StmtKind::Break) { Inst::Break(*l) } else { Inst::Continue(*l) })
                    }
                    None => ruled_out!("`break` or `continue` outside a loop"),
                }
                true
            }
            StmtKind::Return(value) => {
                if let Some((label, vars, ret_ty)) = fr.ret.clone() {
                    if let Some(e) = value {
                        let v = self.expr_as(b, fr, ctx, e, &ret_ty);
                        let lanes = self.lanes(b, v, &ret_ty);
                        for (var, x) in vars.iter().zip(lanes) {
                            b.push(Inst::Set(*var, x));
                        }
                    }
                    b.push(Inst::Break(label));
                } else {
                    // A body whose one return is its last statement lowers
                    // it itself (`body_with_return`); void bodies are not
                    // lowered (a call's statements have no effects).
                    ruled_out!("a `return` with nowhere to go");
                }
                true
            }
            StmtKind::Block(block) => self.block(b, fr, ctx, block),
        }
    }

    pub(super) fn block(&mut self, b: &mut Builder, fr: &mut Frame<'p>, ctx: &Ctx, block: &'p ast::Block) -> bool {
        fr.scopes.push(HashMap::default());
        let mut ends = false;
        for s in &block.stmts {
            if self.stmt(b, fr, ctx, s) {
                ends = true;
                break;
            }
        }
        fr.scopes.pop();
        ends
    }

    pub(super) fn zero_value(&mut self, b: &mut Builder, ty: &Ty) -> Val<'p> {
        match ty {
            Ty::Array(e, n) => {
                let lanes = self.lanes_of(e);
                let z = self.zero_lanes(b, e, lanes);
                Val::Array(ArrayVal::Elems(vec![z; *n as usize]))
            }
            Ty::String => Val::Str(Rc::from("")),
            t => {
                let n = self.lanes_of(t);
                Val::Lanes(self.zero_lanes(b, t, n))
            }
        }
    }

    /// Zero in every lane of a `ty` (false for a bool, 0 for an int): a
    /// fallback that keeps the IR well typed.
    pub(super) fn typed_zeros(&mut self, b: &mut Builder, ty: &Ty) -> Vec<Value> {
        let n = self.lanes_of(ty);
        self.zero_lanes(b, ty, n)
    }

    pub(super) fn zero_lanes(&mut self, b: &mut Builder, ty: &Ty, n: usize) -> Vec<Value> {
        let z = match ty {
            Ty::Int => b.i(0),
            Ty::Bool => b.b(false),
            _ => b.f(0.0),
        };
        vec![z; n]
    }

    pub(super) fn scalar(&mut self, b: &mut Builder, v: Val<'p>) -> Value {
        match v {
            Val::Lanes(l) if !l.is_empty() => l[0],
            other => {
                ruled_out!("{other:?} where a scalar is expected");
                b.f(0.0)
            }
        }
    }

    pub(super) fn assign(
        &mut self,
        b: &mut Builder,
        fr: &mut Frame<'p>,
        ctx: &Ctx,
        target: &'p Expr,
        op: AssignOp,
        value: &'p Expr,
    ) {
        let target_ty = self.ty_of(target);
        let new = match op.binary() {
            None => self.expr_as(b, fr, ctx, value, &target_ty),
            Some(bop) => {
                let old = self.expr(b, fr, ctx, target);
                let value_ty = self.ty_of(value);
                let v = self.expr(b, fr, ctx, value);
                self.binary(b, bop, old, &target_ty, v, &value_ty, &target_ty)
            }
        };
        let new_lanes = match new {
            Val::Lanes(l) => l,
            Val::Array(a) => {
                // Whole-array assignment: copy element by element.
                // (An assigned array is bound to IR arrays: see `bind`.)
                if let ExprKind::Name(n) = &target.kind
                    && let Some(Binding::Val(Val::Array(ArrayVal::Ir { arrays, .. }))) = self.lookup(fr, n).cloned()
                {
                    let lanes = arrays.len();
                    for (k, elem) in self.array_elems(b, &a, lanes).into_iter().enumerate() {
                        let idx = b.i(k as i32);
                        for (arr, v) in arrays.iter().zip(elem) {
                            b.push(Inst::Store { array: *arr, index: idx, value: v });
                        }
                    }
                } else {
                    ruled_out!("an array assigned to something other than an array variable");
                }
                return;
            }
            other => {
                ruled_out!("{other:?} assigned");
                return;
            }
        };
        self.store(b, fr, ctx, target, new_lanes);
    }

    /// Writes lanes into an assignable place.
    pub(super) fn store(
        &mut self,
        b: &mut Builder,
        fr: &mut Frame<'p>,
        ctx: &Ctx,
        target: &'p Expr,
        lanes: Vec<Value>,
    ) {
        match &target.kind {
            ExprKind::Name(n) => match self.lookup(fr, n).cloned() {
                // Every name a body assigns is bound to variables (`bind`).
                Some(Binding::Vars(vars)) => {
                    for (var, v) in vars.iter().zip(lanes) {
                        b.push(Inst::Set(*var, v));
                    }
                }
                _ => ruled_out!("an assignment to `{n}`, which has no variables"),
            },
            ExprKind::Member { base, field } => {
                let base_ty = self.ty_of(base);
                let range = self.field_lanes(&base_ty, &field.name);
                let mut lanes = lanes;
                if Self::is_flag_field(&base_ty, &field.name) && !lanes.is_empty() {
                    let (one, zero) = (b.f(1.0), b.f(0.0));
                    lanes = vec![b.select(lanes[0], one, zero)];
                }
                let old = self.expr(b, fr, ctx, base);
                if let Val::Lanes(mut l) = old
                    && range.end <= l.len()
                    && lanes.len() == range.len()
                {
                    l[range].copy_from_slice(&lanes);
                    self.store(b, fr, ctx, base, l);
                } else {
                    ruled_out!("an assignment to `.{}` of a `{base_ty}`", field.name);
                }
            }
            ExprKind::Index { base, index } => {
                let i = self.expr(b, fr, ctx, index);
                let i = self.scalar(b, i);
                match self.expr(b, fr, ctx, base) {
                    Val::Array(ArrayVal::Ir { arrays, .. }) => {
                        for (arr, v) in arrays.iter().zip(lanes) {
                            b.push(Inst::Store { array: *arr, index: i, value: v });
                        }
                    }
                    Val::Lanes(old) if !lanes.is_empty() => {
                        // A vector lane chosen at run time.
                        let n = old.len() as i32;
                        let i = self.clamp_index(b, i, n);
                        let new: Vec<Value> = old
                            .iter()
                            .enumerate()
                            .map(|(k, x)| {
                                let kv = b.i(k as i32);
                                let hit = b.bin(BinOp::IEq, i, kv);
                                b.select(hit, lanes[0], *x)
                            })
                            .collect();
                        self.store(b, fr, ctx, base, new);
                    }
                    other => ruled_out!("an element of {other:?} assigned"),
                }
            }
            _ => ruled_out!("an assignment to an expression that is not a place"),
        }
    }

    /// `i` clamped into `0..n` in IR, for lanes and tree children chosen
    /// at run time: what [`semantics::clamp_index`] gives an array index.
    pub(super) fn clamp_index(&mut self, b: &mut Builder, i: Value, n: i32) -> Value {
        let zero = b.i(0);
        let last = b.i(n - 1);
        let below = b.bin(BinOp::ILt, i, zero);
        let i = b.select(below, zero, i);
        let above = b.bin(BinOp::ILt, last, i);
        b.select(above, last, i)
    }
}

/// Names assigned anywhere in a block (so they need variables).
pub(super) fn assigned_names(block: &ast::Block) -> HashSet<String> {
    let mut out = HashSet::default();
    let mut stack: Vec<&Stmt> = block.stmts.iter().collect();
    while let Some(s) = stack.pop() {
        match &s.kind {
            StmtKind::Assign { target, .. } => {
                let mut t = target;
                loop {
                    match &t.kind {
                        ExprKind::Member { base, .. } | ExprKind::Index { base, .. } => t = base,
                        ExprKind::Name(n) => {
                            out.insert(n.to_string());
                            break;
                        }
                        _ => break,
                    }
                }
            }
            StmtKind::If { then_block, else_branch, .. } => {
                stack.extend(then_block.stmts.iter());
                if let Some(e) = else_branch {
                    stack.push(e);
                }
            }
            StmtKind::For { body, .. } | StmtKind::While { body, .. } => stack.extend(body.stmts.iter()),
            StmtKind::Block(b) => stack.extend(b.stmts.iter()),
            _ => {}
        }
    }
    out
}

pub(super) fn count_returns(stmts: &[Stmt]) -> usize {
    let mut n = 0;
    let mut stack: Vec<&Stmt> = stmts.iter().collect();
    while let Some(s) = stack.pop() {
        match &s.kind {
            StmtKind::Return(_) => n += 1,
            StmtKind::If { then_block, else_branch, .. } => {
                stack.extend(then_block.stmts.iter());
                if let Some(e) = else_branch {
                    stack.push(e);
                }
            }
            StmtKind::For { body, .. } | StmtKind::While { body, .. } => stack.extend(body.stmts.iter()),
            StmtKind::Block(b) => stack.extend(b.stmts.iter()),
            _ => {}
        }
    }
    n
}
