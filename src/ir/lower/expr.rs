//! Expressions and operators: names and globals, calls (user functions,
//! materials, builtins), members and indices, unary and binary operators
//! over lanes, and the matrix arithmetic they need.

use super::*;

impl<'p> Lowerer<'p> {
    pub(super) fn symbol(&self, fr_prelude: bool, name: &str) -> Option<Symbol> {
        let table = if fr_prelude { &self.program.prelude_symbols } else { &self.program.symbols };
        table.get(name).copied()
    }

    pub(super) fn global(&mut self, b: &mut Builder, ctx: &Ctx, name: &str) -> Option<Vec<Value>> {
        if let Some(v) = ctx.overrides.get(name) {
            return Some(v.clone());
        }
        let (word, ty) = globals::word_of(name)?;
        let scalar = Self::scalar_of(&ty);
        Some((0..self.lanes_of(&ty) as u32).map(|k| b.global(word + k, scalar)).collect())
    }

    /// A shading global that lowering itself names (`N`, `u`, `dudx`, ...)
    /// in the coordinate context `ctx`.
    pub(super) fn shading_global(&mut self, b: &mut Builder, ctx: &Ctx, name: &str) -> Vec<Value> {
        self.global(b, ctx, name).unwrap_or_else(|| {
            debug_assert!(false, "lowering names `{name}`, which is not a shading global");
            b.zeros(3)
        })
    }

    pub(super) fn expr(&mut self, b: &mut Builder, fr: &mut Frame<'p>, ctx: &Ctx, e: &'p Expr) -> Val<'p> {
        if self.stopped(b) {
            // Past the bound lowering stops inlining (the entry is
            // reported): values become zeros, materials stay expressions.
            let ty = self.ty_of(e);
            let holds_material =
                |t: &Ty| matches!(t, Ty::Material) || matches!(t, Ty::Array(el, _) if **el == Ty::Material);
            if !holds_material(&ty) && ty != Ty::Void {
                return self.zero_value(b, &ty);
            }
        }
        crate::syntax::ast::with_stack(|| self.expr_unguarded(b, fr, ctx, e))
    }

    fn expr_unguarded(&mut self, b: &mut Builder, fr: &mut Frame<'p>, ctx: &Ctx, e: &'p Expr) -> Val<'p> {
        let ty = self.ty_of(e);
        match &e.kind {
            ExprKind::Int(i) => Val::Lanes(vec![b.i(*i)]),
            ExprKind::Float(x) => Val::Lanes(vec![b.f(*x as f32)]),
            ExprKind::Bool(x) => Val::Lanes(vec![b.b(*x)]),
            ExprKind::Str(s) => Val::Str(Rc::from(s.as_str())),
            ExprKind::Name(n) => self.name(b, fr, ctx, n, e),
            ExprKind::Call { callee, args } => self.call(b, fr, ctx, callee, args, e),
            ExprKind::Construct { ty: base, args, .. } => self.construct(b, fr, ctx, *base, args, e),
            ExprKind::Member { base, field } => {
                let base_ty = self.ty_of(base);
                let range = self.field_lanes(&base_ty, &field.name);
                let v = self.expr(b, fr, ctx, base);
                match v {
                    Val::Lanes(l) if Self::is_flag_field(&base_ty, &field.name) && range.end <= l.len() => {
                        let zero = b.f(0.0);
                        Val::Lanes(vec![b.flt(zero, l[range.start])])
                    }
                    Val::Lanes(l) if range.end <= l.len() => Val::Lanes(l[range].to_vec()),
                    other => {
                        ruled_out!("`.{}` of {other:?}, a `{base_ty}`", field.name);
                        self.zero_value(b, &ty)
                    }
                }
            }
            ExprKind::Index { base, index } => {
                let i = self.expr(b, fr, ctx, index);
                let i = self.scalar(b, i);
                let base_ty = self.ty_of(base);
                let v = self.expr(b, fr, ctx, base);
                self.index(b, v, &base_ty, i)
            }
            ExprKind::Unary { op, operand } => {
                let v = self.expr(b, fr, ctx, operand);
                let lanes = self.lanes(b, v, &ty);
                let out = match (op, &ty) {
                    (UnaryOp::Not, _) => lanes.iter().map(|x| b.not(*x)).collect(),
                    (UnaryOp::Neg, Ty::Int) => lanes.iter().map(|x| b.un(UnOp::INeg, *x)).collect(),
                    (UnaryOp::Neg, _) => lanes.iter().map(|x| b.un(UnOp::FNeg, *x)).collect(),
                };
                Val::Lanes(out)
            }
            ExprKind::Binary { op, lhs, rhs } => {
                let (lt, rt) = (self.ty_of(lhs), self.ty_of(rhs));
                let l = self.expr(b, fr, ctx, lhs);
                let r = self.expr(b, fr, ctx, rhs);
                self.binary(b, *op, l, &lt, r, &rt, &ty)
            }
            ExprKind::Ternary { cond, then_expr, else_expr } => {
                let c = self.expr(b, fr, ctx, cond);
                let c = self.scalar(b, c);
                if ty == Ty::Material {
                    return Val::Material(Mat { expr: e, env: self.mat_env(fr), in_prelude: fr.in_prelude });
                }
                // Both sides are pure: evaluate both and select lane by lane.
                let a = self.expr_as(b, fr, ctx, then_expr, &ty);
                let z = self.expr_as(b, fr, ctx, else_expr, &ty);
                match (a, z) {
                    (Val::Lanes(a), Val::Lanes(z)) => {
                        Val::Lanes(a.iter().zip(&z).map(|(x, y)| b.select(c, *x, *y)).collect())
                    }
                    // Arrays select element by element, lane by lane.
                    (Val::Array(a), Val::Array(z)) => {
                        let lanes = match &ty {
                            Ty::Array(elem, _) => self.lanes_of(elem),
                            other => {
                                ruled_out!("arrays chosen as a `{other}`");
                                1
                            }
                        };
                        let (xs, ys) = (self.array_elems(b, &a, lanes), self.array_elems(b, &z, lanes));
                        let elems = xs
                            .iter()
                            .zip(&ys)
                            .map(|(x, y)| x.iter().zip(y).map(|(p, q)| b.select(c, *p, *q)).collect())
                            .collect();
                        Val::Array(ArrayVal::Elems(elems))
                    }
                    (a, z) => {
                        ruled_out!("a choice between {a:?} and {z:?}");
                        a
                    }
                }
            }
            ExprKind::Array(items) => {
                // An array of materials is no value: tree nodes read the
                // literal's items (`material_items`), and a template binds
                // them to its `material[N]` parameter (`material_binding`).
                if ty == Ty::Material || matches!(&ty, Ty::Array(e, _) if **e == Ty::Material) {
                    return Val::Unit;
                }
                let elem_ty = match &ty {
                    Ty::Array(e, _) => (**e).clone(),
                    _ => Ty::Float,
                };
                let elems = items
                    .iter()
                    .map(|it| {
                        let v = self.expr_as(b, fr, ctx, it, &elem_ty);
                        self.lanes(b, v, &elem_ty)
                    })
                    .collect();
                Val::Array(ArrayVal::Elems(elems))
            }
            ExprKind::Tuple(items) => {
                let lanes = items
                    .iter()
                    .map(|it| {
                        let v = self.expr_as(b, fr, ctx, it, &Ty::Float);
                        self.scalar(b, v)
                    })
                    .collect();
                Val::Lanes(lanes)
            }
        }
    }

    /// The template bindings visible from the current frame (materials and
    /// values bound by a template call).
    pub(super) fn mat_env(&self, fr: &Frame<'p>) -> Rc<HashMap<String, Val<'p>>> {
        let mut env = HashMap::default();
        for scope in &fr.scopes {
            for (k, v) in scope {
                if let Binding::Val(v) = v {
                    env.insert(k.clone(), v.clone());
                }
            }
        }
        Rc::new(env)
    }

    pub(super) fn index(&mut self, b: &mut Builder, v: Val<'p>, base_ty: &Ty, i: Value) -> Val<'p> {
        match v {
            Val::Array(a) => {
                let Ty::Array(elem, len) = base_ty else {
                    ruled_out!("an array value of type `{base_ty}` indexed");
                    return Val::Unit;
                };
                let lanes = self.lanes_of(elem);
                if let Some(Const::I(k)) = b.konst(i) {
                    let k = crate::ir::semantics::clamp_index(k, *len as usize) as u32;
                    return Val::Lanes(self.array_elem_const(b, &a, k, lanes));
                }
                let a = match a {
                    ArrayVal::Elems(_) => self.materialize(b, a, base_ty),
                    ir => ir,
                };
                let ArrayVal::Ir { arrays, .. } = a else {
                    ruled_out!("an array that `materialize` left as elements");
                    return Val::Unit;
                };
                Val::Lanes(
                    arrays
                        .iter()
                        .map(|arr| {
                            let ty = b.func.arrays[arr.0 as usize].0;
                            b.def(ty, Op::Load { array: *arr, index: i })
                        })
                        .collect(),
                )
            }
            Val::Lanes(l) => {
                let i = self.clamp_index(b, i, l.len() as i32);
                let mut acc = l[0];
                for (k, x) in l.iter().enumerate().skip(1) {
                    let kv = b.i(k as i32);
                    let hit = b.bin(BinOp::IEq, i, kv);
                    acc = b.select(hit, *x, acc);
                }
                Val::Lanes(vec![acc])
            }
            other => {
                ruled_out!("{other:?} indexed");
                other
            }
        }
    }

    pub(super) fn name(&mut self, b: &mut Builder, fr: &mut Frame<'p>, ctx: &Ctx, n: &str, e: &'p Expr) -> Val<'p> {
        if let Some(binding) = self.lookup(fr, n).cloned() {
            return match binding {
                Binding::Val(v) => v,
                Binding::Vars(vars) => Val::Lanes(vars.iter().map(|v| b.get(*v)).collect()),
            };
        }
        if let Some(g) = self.global(b, ctx, n) {
            return Val::Lanes(g);
        }
        match self.symbol(fr.in_prelude, n) {
            Some(sym) if sym.kind == SymbolKind::Const => self.constant(b, sym),
            Some(_) => Val::Material(Mat { expr: e, env: self.mat_env(fr), in_prelude: fr.in_prelude }),
            None => {
                ruled_out!("the name `{n}` resolves to nothing");
                Val::Unit
            }
        }
    }

    pub(super) fn call(
        &mut self,
        b: &mut Builder,
        fr: &mut Frame<'p>,
        ctx: &Ctx,
        callee: &'p ast::Ident,
        args: &'p [ast::Arg],
        e: &'p Expr,
    ) -> Val<'p> {
        let name = callee.name.as_str();
        // A sibling method inside a material.
        if let (Some(inst), Some(im)) = (fr.material.clone(), interface_method(name)) {
            let params: Vec<(&str, Ty)> = im.params.iter().map(|(n, t)| (*n, t.clone())).collect();
            let bound = bind_args(&params, args);
            let mut lanes = Vec::new();
            for ((_, ty), a) in params.iter().zip(bound) {
                let v = match a {
                    Some(a) => self.expr_as(b, fr, ctx, a, ty),
                    None => self.zero_value(b, ty),
                };
                lanes.push(self.lanes(b, v, ty));
            }
            return Val::Lanes(self.instance_method(b, &inst, im, &lanes, ctx));
        }
        if let Some(sym) = self.program.resolutions.get(&callee.span).copied() {
            return match self.item(sym) {
                Item::Function(f) => {
                    let params: Vec<(&str, Ty)> =
                        f.params.iter().map(|p| (p.name.name.as_str(), Ty::from_ast(&p.ty))).collect();
                    let bound = bind_args(&params, args);
                    let mut vals = Vec::new();
                    for (p, a) in f.params.iter().zip(bound) {
                        let ty = Ty::from_ast(&p.ty);
                        let v = match a {
                            Some(a) => self.expr_as(b, fr, ctx, a, &ty),
                            None => match &p.default {
                                // Defaults are evaluated in the callee's scope.
                                Some(d) => {
                                    let mut dfr = self.new_frame(self.is_prelude(sym), HashSet::default());
                                    self.expr_as(b, &mut dfr, ctx, d, &ty)
                                }
                                None => self.zero_value(b, &ty),
                            },
                        };
                        vals.push(v);
                    }
                    self.inline_function(b, sym, f, vals, ctx)
                }
                _ => Val::Material(Mat { expr: e, env: self.mat_env(fr), in_prelude: fr.in_prelude }),
            };
        }
        let Some(f) = self.program.builtin_calls.get(&callee.span).copied() else {
            ruled_out!("the call of `{name}` resolved to nothing");
            return Val::Unit;
        };
        if f.tree_node().is_some() && self.ty_of(e) == Ty::Material {
            return Val::Material(Mat { expr: e, env: self.mat_env(fr), in_prelude: fr.in_prelude });
        }
        self.builtin(b, fr, ctx, f, args, e)
    }
}

/// [`bind_args`] for a call of the builtin `spec`: its parameters' names
/// are all that binding needs.
pub(super) fn bind_builtin_args<'a>(spec: &crate::check::Builtin, args: &'a [ast::Arg]) -> Vec<Option<&'a Expr>> {
    let params: Vec<(&str, Ty)> = spec.params.iter().map(|p| (p.name, Ty::Error)).collect();
    bind_args(&params, args)
}

/// Matches call arguments to parameters by position and name.
pub(super) fn bind_args<'a>(params: &[(&str, Ty)], args: &'a [ast::Arg]) -> Vec<Option<&'a Expr>> {
    let mut bound: Vec<Option<&Expr>> = vec![None; params.len()];
    for (k, a) in args.iter().enumerate() {
        let slot = match &a.name {
            Some(n) => params.iter().position(|(p, _)| *p == n.name),
            None => Some(k),
        };
        if let Some(s) = slot.filter(|s| *s < bound.len()) {
            bound[s] = Some(&a.value);
        }
    }
    bound
}

// ---------------------------------------------------------------- operators

impl<'p> Lowerer<'p> {
    /// Lanes of `v` (of type `t`) as floats, broadcast to `n` lanes.
    pub(super) fn float_lanes(&mut self, b: &mut Builder, v: Val<'p>, t: &Ty, n: usize) -> Vec<Value> {
        let lanes = self.lanes(b, v, t);
        let lanes: Vec<Value> =
            if *t == Ty::Int { lanes.iter().map(|x| b.un(UnOp::IToF, *x)).collect() } else { lanes };
        if lanes.len() == 1 && n > 1 { vec![lanes[0]; n] } else { lanes }
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) fn binary(
        &mut self,
        b: &mut Builder,
        op: BinaryOp,
        l: Val<'p>,
        lt: &Ty,
        r: Val<'p>,
        rt: &Ty,
        ty: &Ty,
    ) -> Val<'p> {
        use BinaryOp::*;
        match op {
            And | Or => {
                let (x, y) = (self.scalar(b, l), self.scalar(b, r));
                Val::Lanes(vec![b.bin(if op == And { BinOp::And } else { BinOp::Or }, x, y)])
            }
            Lt | Le | Gt | Ge => {
                let ints = *lt == Ty::Int && *rt == Ty::Int;
                let (mut x, mut y) = if ints {
                    (self.scalar(b, l), self.scalar(b, r))
                } else {
                    (self.float_lanes(b, l, lt, 1)[0], self.float_lanes(b, r, rt, 1)[0])
                };
                if matches!(op, Gt | Ge) {
                    std::mem::swap(&mut x, &mut y);
                }
                let bop = match (ints, matches!(op, Lt | Gt)) {
                    (true, true) => BinOp::ILt,
                    (true, false) => BinOp::ILe,
                    (false, true) => BinOp::FLt,
                    (false, false) => BinOp::FLe,
                };
                Val::Lanes(vec![b.bin(bop, x, y)])
            }
            Eq | Ne => {
                let eq = if let (Val::Str(x), Val::Str(y)) = (&l, &r) {
                    // Options are known when the item is compiled.
                    b.b(x == y)
                } else if *lt == Ty::Bool {
                    let (x, y) = (self.scalar(b, l), self.scalar(b, r));
                    b.bin(BinOp::BEq, x, y)
                } else if *lt == Ty::Int && *rt == Ty::Int {
                    let (x, y) = (self.scalar(b, l), self.scalar(b, r));
                    b.bin(BinOp::IEq, x, y)
                } else {
                    let n = self.lanes_of(lt).max(self.lanes_of(rt));
                    let x = self.float_lanes(b, l, lt, n);
                    let y = self.float_lanes(b, r, rt, n);
                    let mut acc = b.b(true);
                    for (p, q) in x.iter().zip(&y) {
                        let e = b.feq(*p, *q);
                        acc = b.and(acc, e);
                    }
                    acc
                };
                Val::Lanes(vec![if op == Ne { b.not(eq) } else { eq }])
            }
            Add | Sub | Mul | Div | Rem => {
                if *ty == Ty::Int {
                    let (x, y) = (self.scalar(b, l), self.scalar(b, r));
                    let bop = match op {
                        Add => BinOp::IAdd,
                        Sub => BinOp::ISub,
                        Mul => BinOp::IMul,
                        Div => BinOp::IDiv,
                        _ => BinOp::IRem,
                    };
                    return Val::Lanes(vec![b.bin(bop, x, y)]);
                }
                if *ty == Ty::Matrix {
                    let (x, y) = (self.lanes(b, l, lt), self.lanes(b, r, rt));
                    return Val::Lanes(mat_mul(b, &x, &y));
                }
                let n = self.lanes_of(ty);
                let x = self.float_lanes(b, l, lt, n);
                let y = self.float_lanes(b, r, rt, n);
                let out = x
                    .iter()
                    .zip(&y)
                    .map(|(p, q)| match op {
                        Add => b.fadd(*p, *q),
                        Sub => b.fsub(*p, *q),
                        Mul => b.fmul(*p, *q),
                        Div => b.fdiv(*p, *q),
                        // Float `%` truncates like C's fmod: a - b trunc(a / b).
                        _ => {
                            let d = b.fdiv(*p, *q);
                            let t = b.un(UnOp::Trunc, d);
                            let m = b.fmul(*q, t);
                            b.fsub(*p, m)
                        }
                    })
                    .collect();
                Val::Lanes(out)
            }
        }
    }
}

/// Composes two affine maps given as three rows of four.
pub(super) fn mat_mul(b: &mut Builder, x: &[Value], y: &[Value]) -> Vec<Value> {
    let mut out = Vec::with_capacity(12);
    for r in 0..3 {
        for c in 0..4 {
            let mut acc = b.fmul(x[r * 4], y[c]);
            for k in 1..3 {
                let p = b.fmul(x[r * 4 + k], y[k * 4 + c]);
                acc = b.fadd(acc, p);
            }
            if c == 3 {
                acc = b.fadd(acc, x[r * 4 + 3]);
            }
            out.push(acc);
        }
    }
    out
}

pub(super) fn transform_point(b: &mut Builder, m: &[Value], p: &[Value], translate: bool) -> Vec<Value> {
    (0..3)
        .map(|r| {
            let mut acc = b.fmul(m[r * 4], p[0]);
            for k in 1..3 {
                let t = b.fmul(m[r * 4 + k], p[k]);
                acc = b.fadd(acc, t);
            }
            if translate { b.fadd(acc, m[r * 4 + 3]) } else { acc }
        })
        .collect()
}

/// The inverse of an affine map (the zero map when it is singular).
#[allow(clippy::needless_range_loop)] // row/column index arithmetic reads best as loops
pub(super) fn mat_inverse(b: &mut Builder, m: &[Value]) -> Vec<Value> {
    let a = |r: usize, c: usize| m[r * 4 + c];
    let mut cof = [[Value(0); 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
            let (c1, c2) = ((c + 1) % 3, (c + 2) % 3);
            let p = b.fmul(a(r1, c1), a(r2, c2));
            let q = b.fmul(a(r1, c2), a(r2, c1));
            cof[r][c] = b.fsub(p, q);
        }
    }
    let mut det = b.fmul(a(0, 0), cof[0][0]);
    for c in 1..3 {
        let t = b.fmul(a(0, c), cof[0][c]);
        det = b.fadd(det, t);
    }
    let zero = b.f(0.0);
    let singular = b.feq(det, zero);
    let one = b.f(1.0);
    let inv_det = b.fdiv(one, det);
    let inv_det = b.select(singular, zero, inv_det);
    let mut out = vec![zero; 12];
    for r in 0..3 {
        for c in 0..3 {
            // The inverse is the transposed cofactor matrix over the determinant.
            out[r * 4 + c] = b.fmul(cof[c][r], inv_det);
        }
    }
    let t = [a(0, 3), a(1, 3), a(2, 3)];
    let lin: Vec<Value> = out.clone();
    let moved = transform_point(b, &lin, &t, false);
    for r in 0..3 {
        out[r * 4 + 3] = b.un(UnOp::FNeg, moved[r]);
    }
    out
}
