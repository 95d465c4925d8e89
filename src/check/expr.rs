//! Checking expressions: names, operators, constructors, members,
//! indexing, arrays and tuples, and the typing rules of operators.

use super::*;

impl<'a> Checker<'a> {
    pub(super) fn expect_ty(&mut self, e: &Expr, found: &Ty, want: &Ty, what: &str) {
        if found.converts_to(want) {
            return;
        }
        let mut d = Diagnostic::error(e.span, format!("mismatched types: expected `{want}`, found `{found}`"))
            .with_primary(format!("{what} must be `{want}`"));
        if *want == Ty::Color && found.is_numeric() {
            d = d.with_help("a number is not a color: write gray(x) for a uniform color, or rgb(r, g, b)");
        } else if *found == Ty::Color && (want.is_numeric() || want.is_triple()) {
            d = d.with_help(
                "a color hides its representation (RGB or spectral samples): convert explicitly with brightness(c) or to_rgb(c)",
            );
        } else if *want == Ty::Int && *found == Ty::Float {
            d = d.with_help("convert explicitly with int(x), which truncates");
        }
        self.error(d);
    }

    /// Types an expression, recording the result. `expected` guides tuples
    /// and array literals and is otherwise only a hint.
    pub(super) fn expr(&mut self, e: &Expr, expected: Option<&Ty>) -> Ty {
        // Opened before the expressions inside, so entries come in span order.
        let slot = self.expr_types.open(e.span);
        let ty = crate::syntax::ast::with_stack(|| self.expr_inner(e, expected));
        self.expr_types.set(slot, &ty);
        ty
    }

    pub(super) fn expr_inner(&mut self, e: &Expr, expected: Option<&Ty>) -> Ty {
        match &e.kind {
            ExprKind::Int(_) => Ty::Int,
            ExprKind::Float(_) => Ty::Float,
            ExprKind::Bool(_) => Ty::Bool,
            ExprKind::Str(_) => Ty::String,
            ExprKind::Name(name) => self.name(name, e.span),
            ExprKind::Call { callee, args } => self.call(callee, args, e.span),
            ExprKind::Construct { ty, ty_span, args } => self.construct(*ty, *ty_span, args, e.span),
            ExprKind::Member { base, field } => self.member(base, field),
            ExprKind::Index { base, index } => self.index(base, index),
            ExprKind::Unary { op, operand } => {
                let t = self.expr(operand, None);
                match (op, &t) {
                    (_, Ty::Error) => Ty::Error,
                    (UnaryOp::Neg, t) if t.is_numeric() || t.is_float_like() => {
                        if t.is_triple() {
                            Ty::Vector
                        } else {
                            t.clone()
                        }
                    }
                    (UnaryOp::Not, Ty::Bool) => Ty::Bool,
                    // Lane-wise, like `c1 - c2`: see `color_arith`.
                    (UnaryOp::Neg, Ty::Color) => Ty::Color,
                    (op, t) => {
                        let sym = if *op == UnaryOp::Neg { "-" } else { "!" };
                        self.error(Diagnostic::error(e.span, format!("cannot apply unary `{sym}` to `{t}`")));
                        Ty::Error
                    }
                }
            }
            ExprKind::Binary { op, lhs, rhs } => {
                let l = self.expr(lhs, None);
                let r = self.expr(rhs, None);
                if l == Ty::String && r == Ty::String {
                    for side in [lhs, rhs] {
                        let known = match &side.kind {
                            ExprKind::Str(_) => true,
                            ExprKind::Name(n) => self.lookup_local(n).is_some_and(|l| l.kind == LocalKind::Param),
                            _ => false,
                        };
                        if !known {
                            self.error(
                                Diagnostic::error(side.span, "only string literals and `string` parameters can be compared")
                                    .with_help("a string is an option chosen when the shader is compiled: compare a parameter with a literal, `mode == \"ggx\"`"),
                            );
                            return Ty::Error;
                        }
                    }
                    self.record_string_option(lhs, rhs);
                }
                match binary_type(*op, &l, &r) {
                    Ok(t) => t,
                    Err((message, help)) => {
                        let mut d = Diagnostic::error(e.span, message)
                            .with_label(lhs.span, format!("`{l}`"))
                            .with_label(rhs.span, format!("`{r}`"));
                        if let Some(h) = help {
                            d = d.with_help(h);
                        }
                        self.error(d);
                        Ty::Error
                    }
                }
            }
            ExprKind::Ternary { cond, then_expr, else_expr } => {
                self.condition(cond, "the condition of `?:`");
                let a = self.expr(then_expr, expected);
                let b = self.expr(else_expr, expected);
                match unify(&a, &b) {
                    Some(Ty::String) => {
                        self.error(
                            Diagnostic::error(e.span, "a string cannot be chosen while shading")
                                .with_help("strings are file names and options fixed when the shader is compiled; choose between the values they select instead"),
                        );
                        Ty::Error
                    }
                    // Texture trees take their children's lists as written.
                    Some(Ty::Array(elem, _)) if *elem == Ty::Material => {
                        self.error(
                            Diagnostic::error(e.span, "a list of materials cannot be chosen with `?:`")
                                .with_help("choose each element instead: `[c ? a : b, c ? d : e]`"),
                        );
                        Ty::Error
                    }
                    Some(t) => t,
                    None => {
                        self.error(
                            Diagnostic::error(
                                e.span,
                                format!("the branches of `?:` have different types: `{a}` and `{b}`"),
                            )
                            .with_label(then_expr.span, format!("`{a}`"))
                            .with_label(else_expr.span, format!("`{b}`")),
                        );
                        Ty::Error
                    }
                }
            }
            ExprKind::Array(items) => self.array(items, e.span, expected),
            ExprKind::Tuple(items) => self.tuple(items, e.span, expected),
        }
    }

    /// `frame` or `time`, where the body may read them.
    fn frame_global(&mut self, name: &str, span: Span, ty: Ty) -> Ty {
        let allowed = match self.body.frame_globals {
            FrameGlobals::Both => true,
            FrameGlobals::FrameOnly => name == "frame",
            FrameGlobals::Neither => false,
        };
        if allowed {
            if let (Some(node), Some(global)) = (&self.body.node, FRAME_GLOBALS.iter().find(|g| **g == name)) {
                self.reads_frame.entry((*node, *global)).or_insert((span, *global));
            }
            return ty;
        }
        let refused = match self.body.frame_globals {
            FrameGlobals::Both => return ty,
            FrameGlobals::FrameOnly => Diagnostic::error(span, "the `time` mapping cannot read `time`")
                .with_help("it defines `time`: compute it from `frame`, e.g. `time frame / 24.0;`"),
            FrameGlobals::Neither => Diagnostic::error(span, format!("`{name}` cannot be used in render settings"))
                .with_help(
                    "render settings hold for every frame of an animation; only the `time` mapping reads `frame`",
                ),
        };
        self.error(refused);
        Ty::Error
    }

    pub(super) fn name(&mut self, name: &str, span: Span) -> Ty {
        if let Some(local) = self.lookup_local(name) {
            local.used = true;
            let (ty, declared) = (local.ty.clone(), local.span);
            self.local_uses.insert(span, declared);
            return ty;
        }
        if let Some(t) = interface::global(name) {
            if interface::is_frame_global(name) {
                return self.frame_global(name, span, t);
            }
            if !self.body.globals_allowed {
                let help = if self.body.context == "the scene" {
                    "scene values are fixed for a frame (they may read `frame` and `time`); only a `material` may vary over the surface"
                } else {
                    "constants are fixed for a frame (they may read `frame` and `time`); use a function to compute a value per shading point"
                };
                self.error(
                    Diagnostic::error(
                        span,
                        format!("the shading global `{name}` cannot be used in {}", self.body.context),
                    )
                    .with_help(help),
                );
                return Ty::Error;
            }
            if let Some(node) = &self.body.node {
                self.reads_globals.entry(*node).or_insert(span);
            }
            return t;
        }
        if let Some(sym) = self.symbol(name) {
            self.use_item(sym, span);
            return match sym.kind {
                SymbolKind::Const => self.const_type(sym),
                SymbolKind::MaterialTree | SymbolKind::Material => {
                    let needs_args = match self.item(sym) {
                        Item::MaterialTree(t) => t.params.as_ref().map(|ps| required_params(ps)).unwrap_or_default(),
                        Item::Material(d) => required_params(&d.params),
                        _ => Vec::new(),
                    };
                    if !needs_args.is_empty() {
                        self.error(
                            Diagnostic::error(span, format!("`{name}` needs arguments: {}", needs_args.join(", ")))
                                .with_help(format!("call it: `{name}(...)`")),
                        );
                        return Ty::Error;
                    }
                    self.material_value(span)
                }
                SymbolKind::Function => {
                    self.error(
                        Diagnostic::error(span, format!("`{name}` is a function, not a value"))
                            .with_help(format!("call it: `{name}()`")),
                    );
                    Ty::Error
                }
            };
        }
        if builtin(name).is_some() {
            self.error(
                Diagnostic::error(span, format!("`{name}` is a builtin function, not a value"))
                    .with_help(format!("call it: `{name}(...)`")),
            );
            return Ty::Error;
        }
        self.unknown(name, span, "value");
        Ty::Error
    }

    /// A material value where one appears; outside material trees that is
    /// an error.
    pub(super) fn material_value(&mut self, span: Span) -> Ty {
        if self.body.materials_allowed {
            Ty::Material
        } else {
            self.error(
                Diagnostic::error(span, format!("a material cannot be used in {}", self.body.context))
                    .with_help("build texture trees at the top level: `material name = mix(...);`"),
            );
            Ty::Error
        }
    }

    pub(super) fn item(&self, sym: Symbol) -> &'a Item {
        &self.loaded.modules[sym.module].ast.items[sym.item]
    }

    pub(super) fn const_type(&mut self, sym: Symbol) -> Ty {
        match self.item(sym) {
            Item::Const(c) => Ty::from_ast(&c.ty),
            _ => Ty::Error,
        }
    }

    /// Reports an unknown name with the closest known one.
    pub(super) fn unknown(&mut self, name: &str, span: Span, what: &str) {
        let mut candidates: Vec<&str> = Vec::new();
        for scope in &self.body.scopes {
            candidates.extend(scope.iter().map(|l| l.name.as_str()));
        }
        if self.body.globals_allowed {
            candidates.extend(GLOBALS.iter().map(|g| g.0));
        } else {
            candidates.extend(interface::FRAME_GLOBALS);
        }
        let table = if self.in_prelude { self.prelude_symbols } else { self.symbols };
        candidates.extend(table.keys().map(String::as_str));
        if what == "function" {
            candidates.extend(BUILTINS.iter().map(|b| b.name));
            if let Some((_, _)) = &self.body.material {
                candidates.extend(INTERFACE.iter().map(|m| m.name));
            }
        }
        let mut d = Diagnostic::error(span, format!("cannot find {what} `{name}` in this scope"));
        if let Some(s) = did_you_mean(name, candidates) {
            d = d.with_help(format!("did you mean `{s}`?"));
        } else if interface_method(name).is_some() {
            d = d.with_help("interface methods can be called only inside a material definition");
        }
        self.error(d);
    }

    pub(super) fn construct(&mut self, ty: BaseType, ty_span: Span, args: &[Arg], span: Span) -> Ty {
        // Inside a material, `normal()` is the interface method, not a constructor.
        if ty == BaseType::Normal && args.is_empty() && self.body.material.is_some() {
            let callee = Ident { name: "normal".into(), span: ty_span };
            return self.call(&callee, args, span);
        }
        for a in args {
            if let Some(n) = &a.name {
                self.error(Diagnostic::error(n.span, "type constructors take positional arguments only"));
            }
        }
        let tys: Vec<Ty> = args.iter().map(|a| self.expr(&a.value, None)).collect();
        if ty == BaseType::BsdfSample {
            return self.construct_sample(args, &tys, span);
        }
        let result = Ty::from_base(ty);
        let (counts, elem): (&[usize], Ty) = match ty {
            BaseType::Color => {
                self.error(
                    Diagnostic::error(ty_span, "colors have no component constructor")
                        .with_help("a color hides its representation: build one with rgb(r, g, b), hsv(h, s, v), xyz(x, y, z), gray(v), black() or spectrum([...])"),
                );
                return Ty::Error;
            }
            BaseType::Vector | BaseType::Point | BaseType::Normal => (&[1, 3], Ty::Float),
            BaseType::Vec2 => (&[1, 2], Ty::Float),
            BaseType::Float | BaseType::Int => (&[1], Ty::Float),
            BaseType::Matrix => (&[0, 1, 12], Ty::Float),
            _ => (&[], Ty::Error),
        };
        if !counts.contains(&tys.len()) {
            let want: Vec<String> = counts.iter().map(|c| c.to_string()).collect();
            self.error(
                Diagnostic::error(span, format!("`{}(...)` takes {} arguments, found {}", ty.keyword(), want.join(" or "), tys.len()))
                    .with_help(match ty {
                        BaseType::Matrix => "matrix() is the identity, matrix(s) scales, matrix(12 floats) gives the three rows of an affine transform",
                        BaseType::Vec2 => "vec2(s) repeats s; vec2(a, b) sets both",
                        _ => "vector(s) repeats s; vector(x, y, z) sets each",
                    }),
            );
            return Ty::Error;
        }
        for (a, t) in args.iter().zip(&tys) {
            let ok = if matches!(ty, BaseType::Float | BaseType::Int) {
                t.is_numeric() || t.is_error()
            } else {
                t.converts_to(&elem)
            };
            if !ok {
                let mut d = Diagnostic::error(a.value.span, format!("expected a number, found `{t}`"));
                if *t == Ty::Color {
                    d = d.with_help("a color has no components: use to_rgb(c) for an explicit conversion");
                }
                self.error(d);
                return Ty::Error;
            }
        }
        result
    }

    /// `bsdf_sample(vector wi, color weight, float pdf)`: a direction drawn
    /// from a density (see `delta_sample` for delta lobes).
    pub(super) fn construct_sample(&mut self, args: &[Arg], tys: &[Ty], span: Span) -> Ty {
        const SIGNATURE: &str = "bsdf_sample(vector wi, color weight, float pdf)";
        if tys.len() != 3 {
            self.error(
                Diagnostic::error(span, format!("`bsdf_sample(...)` takes 3 arguments, found {}", tys.len()))
                    .with_note(format!("expected {SIGNATURE}"))
                    .with_help("a delta lobe's sample is delta_sample(wi, weight); no sample at all is no_sample()"),
            );
            return Ty::Error;
        }
        for (k, want) in [Ty::Vector, Ty::Color, Ty::Float].iter().enumerate() {
            if !tys[k].converts_to(want) {
                let mut d = Diagnostic::error(args[k].value.span, format!("expected `{want}`, found `{}`", tys[k]))
                    .with_note(format!("expected {SIGNATURE}"));
                if *want == Ty::Color && tys[k].is_numeric() {
                    d = d.with_help("a number is not a color: write gray(x) for a uniform color");
                }
                self.error(d);
                return Ty::Error;
            }
        }
        Ty::BsdfSample
    }

    pub(super) fn member(&mut self, base: &Expr, field: &Ident) -> Ty {
        let t = self.expr(base, None);
        let fields: &[&str] = match &t {
            Ty::Error => return Ty::Error,
            t if t.is_triple() => &["x", "y", "z"],
            Ty::Vec2 => &["x", "y"],
            Ty::BsdfSample => {
                if let Some((_, ty)) = SAMPLE_FIELDS.iter().find(|(n, _)| *n == field.name) {
                    return ty.clone();
                }
                &["wi", "weight", "pdf", "delta"]
            }
            Ty::Color => {
                self.error(
                    Diagnostic::error(field.span, format!("cannot read component `{}` of a color", field.name))
                        .with_label(base.span, "this is a `color`")
                        .with_help("a color hides its representation (RGB or N spectral samples), so shaders run unchanged in both renderers: use brightness(c) for a scalar or to_rgb(c) for an explicit conversion"),
                );
                return Ty::Error;
            }
            _ => &[],
        };
        if fields.contains(&field.name.as_str()) {
            return Ty::Float;
        }
        let mut d = Diagnostic::error(field.span, format!("`{t}` has no field `{}`", field.name));
        if !fields.is_empty() {
            d = d.with_help(format!("the fields of `{t}` are {}", fields.join(", ")));
        }
        self.error(d);
        Ty::Error
    }

    pub(super) fn index(&mut self, base: &Expr, index: &Expr) -> Ty {
        let t = self.expr(base, None);
        let i = self.expr(index, Some(&Ty::Int));
        if !i.is_error() && i != Ty::Int {
            self.error(
                Diagnostic::error(index.span, format!("an index must be `int`, found `{i}`"))
                    .with_help("convert with int(x)"),
            );
        }
        let (elem, len) = match &t {
            Ty::Error => return Ty::Error,
            Ty::Array(e, n) => ((**e).clone(), *n),
            t if t.is_triple() => (Ty::Float, 3),
            Ty::Vec2 => (Ty::Float, 2),
            Ty::Color => {
                self.error(
                    Diagnostic::error(index.span, "cannot index a color")
                        .with_label(base.span, "this is a `color`")
                        .with_help("a color hides its representation (RGB or N spectral samples): use brightness(c) or to_rgb(c)"),
                );
                return Ty::Error;
            }
            t => {
                self.error(Diagnostic::error(base.span, format!("`{t}` cannot be indexed")));
                return Ty::Error;
            }
        };
        if let Some(k) = const_int(index)
            && (k < 0 || k >= i64::from(len))
        {
            self.error(
                Diagnostic::error(index.span, format!("index {k} is out of bounds"))
                    .with_label(base.span, format!("this has {len} elements")),
            );
        }
        elem
    }

    pub(super) fn array(&mut self, items: &[Expr], span: Span, expected: Option<&Ty>) -> Ty {
        let mut wrong_len = false;
        let want_elem = match expected {
            Some(Ty::Array(e, n)) => {
                if items.len() != *n as usize {
                    self.error(Diagnostic::error(
                        span,
                        format!("expected an array of {n} items, found {}", items.len()),
                    ));
                    wrong_len = true;
                }
                Some((**e).clone())
            }
            _ => None,
        };
        if items.is_empty() {
            if want_elem.is_none() {
                self.error(Diagnostic::error(span, "cannot infer the type of an empty array"));
            }
            return Ty::Error;
        }
        if items.len() > MAX_ARRAY_LEN as usize {
            self.error(Diagnostic::error(span, format!("an array has at most {MAX_ARRAY_LEN} items")));
            return Ty::Error;
        }
        let mut elem: Option<Ty> = None;
        for item in items {
            let t = self.expr(item, want_elem.as_ref());
            elem = match elem {
                None => Some(t),
                Some(prev) => match unify(&prev, &t) {
                    Some(u) => Some(u),
                    None => {
                        self.error(Diagnostic::error(
                            item.span,
                            format!("array items must share one type: expected `{prev}`, found `{t}`"),
                        ));
                        Some(Ty::Error)
                    }
                },
            };
        }
        let elem = elem.unwrap_or(Ty::Error);
        if elem == Ty::Material && !self.body.materials_allowed {
            return self.material_value(span);
        }
        if let Ty::Array(..) = elem {
            self.error(Diagnostic::error(span, "arrays of arrays are not supported"));
            return Ty::Error;
        }
        if wrong_len {
            return Ty::Error;
        }
        Ty::Array(Box::new(elem), items.len() as u32)
    }

    pub(super) fn tuple(&mut self, items: &[Expr], span: Span, expected: Option<&Ty>) -> Ty {
        let result = match (expected, items.len()) {
            (Some(t), 3) if t.is_triple() => t.clone(),
            (Some(Ty::Vec2), 2) => Ty::Vec2,
            (_, 3) => Ty::Vector,
            (_, 2) => Ty::Vec2,
            (_, n) => {
                self.error(
                    Diagnostic::error(span, format!("a tuple of {n} values has no type"))
                        .with_help("tuples of two numbers are vec2, of three numbers vector/point/normal"),
                );
                self.untyped_exprs(items);
                return Ty::Error;
            }
        };
        for item in items {
            let t = self.expr(item, Some(&Ty::Float));
            if !t.converts_to(&Ty::Float) {
                self.error(Diagnostic::error(item.span, format!("tuple items must be numbers, found `{t}`")));
            }
        }
        result
    }

    pub(super) fn untyped_exprs(&mut self, items: &[Expr]) {
        for item in items {
            self.expr(item, None);
        }
    }
}

/// The type of `l op r`, or a message and help line.
pub(super) fn binary_type(op: BinaryOp, l: &Ty, r: &Ty) -> Result<Ty, (String, Option<String>)> {
    use BinaryOp::*;
    if l.is_error() || r.is_error() {
        return Ok(if matches!(op, Eq | Ne | Lt | Le | Gt | Ge | And | Or) { Ty::Bool } else { Ty::Error });
    }
    let sym = op.symbol();
    let plain = |m: String| Err((m, None));
    let color_help = "a color hides its representation (RGB or spectral samples)";
    match op {
        And | Or => {
            if *l == Ty::Bool && *r == Ty::Bool {
                Ok(Ty::Bool)
            } else {
                Err((
                    format!("`{sym}` needs two `bool`s, found `{l}` and `{r}`"),
                    Some("compare numbers explicitly, e.g. `x != 0`".into()),
                ))
            }
        }
        Lt | Le | Gt | Ge => {
            if l.is_numeric() && r.is_numeric() {
                Ok(Ty::Bool)
            } else if *l == Ty::Color || *r == Ty::Color {
                Err((
                    format!("colors cannot be ordered with `{sym}`"),
                    Some(format!("{color_help}: compare brightness(a) {sym} brightness(b)")),
                ))
            } else {
                plain(format!("cannot compare `{l}` {sym} `{r}`"))
            }
        }
        Eq | Ne => {
            if (l.is_numeric() && r.is_numeric()) || (*l == Ty::Bool && *r == Ty::Bool) {
                Ok(Ty::Bool)
            } else if *l == Ty::String && *r == Ty::String {
                // Both are literals or string parameters, known when the
                // item is compiled: the comparison folds to a constant.
                Ok(Ty::Bool)
            } else if *l == Ty::Color || *r == Ty::Color {
                Err((
                    format!("colors cannot be compared with `{sym}`"),
                    Some(format!("{color_help}: compare brightness(a) and brightness(b)")),
                ))
            } else if elementwise(l, r).is_some() && l.is_float_like() && r.is_float_like() {
                Ok(Ty::Bool)
            } else {
                plain(format!("cannot compare `{l}` {sym} `{r}`"))
            }
        }
        Add | Sub | Mul | Div | Rem => {
            if *l == Ty::Color || *r == Ty::Color {
                return color_arith(op, l, r);
            }
            if *l == Ty::Matrix || *r == Ty::Matrix {
                return if op == Mul && l == r {
                    Ok(Ty::Matrix)
                } else {
                    Err((
                        format!("cannot apply `{sym}` to `{l}` and `{r}`"),
                        Some("matrices compose with `*`; apply one with transform_point, transform_vector or transform_normal".into()),
                    ))
                };
            }
            match elementwise(l, r) {
                Some(t) => Ok(t),
                None => {
                    let help = (*l == Ty::Material || *r == Ty::Material)
                        .then(|| "combine materials with texture-tree nodes: mix, blend, select, scale".to_string());
                    Err((format!("cannot apply `{sym}` to `{l}` and `{r}`"), help))
                }
            }
        }
    }
}

/// The generic color interface: `+`, `-`, `*` and `/` between colors (lane
/// by lane, so no component is ever named), `*` and `/` by a float. A
/// number is never a color: `c + 1` is an error (write `gray(1)`).
pub(super) fn color_arith(op: BinaryOp, l: &Ty, r: &Ty) -> Result<Ty, (String, Option<String>)> {
    use BinaryOp::*;
    let (lc, rc) = (*l == Ty::Color, *r == Ty::Color);
    let ok = match op {
        Add | Sub => lc && rc,
        Mul => (lc && (rc || r.is_numeric())) || (l.is_numeric() && rc),
        Div => lc && (rc || r.is_numeric()),
        _ => false,
    };
    if ok {
        return Ok(Ty::Color);
    }
    let sym = op.symbol();
    let help = match op {
        Add | Sub if l.is_numeric() || r.is_numeric() => {
            "a number is not a color: write gray(x) for a uniform color".to_string()
        }
        Div if l.is_numeric() => {
            "a number cannot be divided by a color; divide two colors, or scale by 1 / x".to_string()
        }
        _ => "colors support `+`, `-`, `*` and `/` with colors, and `*` and `/` by a float".to_string(),
    };
    Err((format!("cannot apply `{sym}` to `{l}` and `{r}`"), Some(help)))
}
