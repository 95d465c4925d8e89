//! Checking items: functions, materials and their methods against the
//! interface, material trees, constants, and the types they name.

use super::*;

impl<'a> Checker<'a> {
    pub(super) fn begin(&mut self, node: Node, context: &'static str, globals_allowed: bool, materials_allowed: bool) {
        self.body = Body {
            node: Some(node),
            context,
            globals_allowed,
            materials_allowed,
            scopes: vec![Vec::new()],
            ..Body::default()
        };
    }

    /// Declares parameters in the current scope, checking their types and
    /// defaults.
    pub(super) fn declare_params(&mut self, params: &[Param], what: &str) {
        let mut seen: HashMap<&str, Span> = HashMap::new();
        for p in params {
            let ty = self.resolve_type(&p.ty, what);
            if let Some(default) = &p.default {
                let found = self.expr(default, Some(&ty));
                self.expect_ty(default, &found, &ty, "the default value");
            }
            if let Some(options) = &p.options {
                self.check_declared_options(p, &ty, options);
            }
            if let Some(prev) = seen.insert(&p.name.name, p.name.span) {
                self.error(
                    Diagnostic::error(p.name.span, format!("parameter `{}` is declared twice", p.name.name))
                        .with_label(prev, "first declared here"),
                );
                continue;
            }
            self.declare_param(&p.name, ty);
        }
    }

    pub(super) fn check_function(&mut self, f: &Function) {
        self.begin(Node::Item(self.current), "a function", true, false);
        let ret = self.resolve_type(&f.ret, "a function");
        self.declare_params(&f.params, "a function");
        self.body.ret = Some(ret.clone());
        self.block_in_scope(&f.body);
        self.check_returns(f, &ret);
        self.end_scope();
    }

    pub(super) fn check_returns(&mut self, f: &Function, ret: &Ty) {
        if *ret != Ty::Void && !ret.is_error() && !block_returns(&f.body) {
            let end = Span { start: f.body.span.end.saturating_sub(1), ..f.body.span };
            self.error(
                Diagnostic::error(end, format!("`{}` does not return a value on every path", f.name.name))
                    .with_primary(format!("the end of the body is reachable without a `return` of `{ret}`"))
                    .with_label(f.ret.span, "the declared return type")
                    .with_help("add a `return` at the end of the function"),
            );
        }
    }

    pub(super) fn check_material(&mut self, d: &MaterialDef) {
        let name = d.name.name.clone();
        self.begin(Node::Item(self.current), "a material's parameters", true, false);
        self.declare_params(&d.params, "a material's parameter list");
        let params_scope = self.body.scopes.clone();

        // Which methods the material defines, for sibling calls.
        let mut defined: Vec<&'static str> = Vec::new();
        let mut seen: HashMap<&str, Span> = HashMap::new();
        for m in &d.methods {
            if let Some(prev) = seen.insert(&m.name.name, m.name.span) {
                self.error(
                    Diagnostic::error(m.name.span, format!("method `{}` is defined twice", m.name.name))
                        .with_label(prev, "first defined here"),
                );
            }
            match interface_method(&m.name.name) {
                Some(im) => defined.push(im.name),
                None => {
                    let names = INTERFACE.iter().map(|m| m.name);
                    let mut diag = Diagnostic::error(
                        m.name.span,
                        format!("`{}` is not a method of the material interface", m.name.name),
                    );
                    diag = match did_you_mean(&m.name.name, names) {
                        Some(s) => diag.with_help(format!("did you mean `{s}`?")),
                        None => diag.with_help(format!(
                            "the interface methods are: {}",
                            INTERFACE.iter().map(|m| m.name).collect::<Vec<_>>().join(", ")
                        )),
                    };
                    self.error(diag.with_note("helper functions go outside the material, at the top level"));
                }
            }
        }
        // The item depends on all of its methods; defaults add their own edges.
        let id = self.current;
        let item = Node::Item(id);
        for im in INTERFACE {
            self.edge(item, Node::Method(id, im.name), d.name.span);
        }
        if !defined.contains(&"ambient") {
            self.edge(Node::Method(id, "ambient"), Node::Method(id, "diffuse"), d.name.span);
        }

        for m in &d.methods {
            let Some(im) = interface_method(&m.name.name) else {
                continue;
            };
            self.check_method_signature(m, im);
            self.body = Body {
                scopes: params_scope.clone(),
                material: Some((name.to_string(), defined.clone())),
                context: "a material method",
                globals_allowed: true,
                node: Some(Node::Method(id, im.name)),
                ..Body::default()
            };
            self.push_scope();
            // The body is checked against the signature as written: a wrong
            // signature is one error, not one per `return`.
            for p in &m.params {
                let ty = Ty::from_ast(&p.ty);
                self.declare_param(&p.name, ty);
            }
            let ret = Ty::from_ast(&m.ret);
            self.body.ret = Some(ret.clone());
            self.block_in_scope(&m.body);
            self.check_returns(m, &ret);
            self.end_scope();
            self.end_scope();
        }
    }

    pub(super) fn check_method_signature(&mut self, m: &Function, im: &InterfaceMethod) {
        if let Some(d) = m.params.iter().find_map(|p| p.default.as_ref()) {
            self.error(
                Diagnostic::error(d.span, "interface method parameters cannot have default values")
                    .with_help("the renderer always passes every argument; remove the default"),
            );
            return;
        }
        let ret = Ty::from_ast(&m.ret);
        let params_ok = m.params.len() == im.params.len()
            && m.params
                .iter()
                .zip(im.params)
                .all(|(p, (_, t))| Ty::from_ast(&p.ty) == t.clone() && p.default.is_none());
        if ret != im.ret.clone() || !params_ok {
            let written: Vec<String> =
                m.params.iter().map(|p| format!("{} {}", Ty::from_ast(&p.ty), p.name.name)).collect();
            self.error(
                Diagnostic::error(m.name.span, format!("method `{}` has the wrong signature", im.name))
                    .with_primary(format!("found `{} {}({})`", ret, m.name.name, written.join(", ")))
                    .with_help(format!("the material interface expects `{}`", im.signature()))
                    .with_note("parameter names are free; the types, their order and the return type are fixed"),
            );
        }
    }

    pub(super) fn check_tree(&mut self, t: &MaterialTree) {
        self.begin(Node::Item(self.current), "a material tree", true, true);
        if let Some(params) = &t.params {
            self.declare_params(params, "a material tree");
        }
        let ty = self.expr(&t.body, Some(&Ty::Material));
        self.expect_ty(&t.body, &ty, &Ty::Material, "a material tree");
        self.end_scope();
    }

    pub(super) fn check_const(&mut self, c: &ConstDef) {
        self.begin(Node::Item(self.current), "a constant", false, false);
        let ty = self.resolve_type(&c.ty, "a constant");
        if ty.is_error() {
            return;
        }
        let found = self.expr(&c.value, Some(&ty));
        self.expect_ty(&c.value, &found, &ty, "the constant");
        self.end_scope();
    }

    /// Resolves a written type, refusing materials outside material trees.
    pub(super) fn resolve_type(&mut self, t: &TypeExpr, what: &str) -> Ty {
        if let Some((n, span)) = t.array_len
            && (n == 0 || n > MAX_ARRAY_LEN)
        {
            self.error(Diagnostic::error(span, format!("array length must be between 1 and {MAX_ARRAY_LEN}")));
            return Ty::Error;
        }
        if t.base == BaseType::Material && !self.body.materials_allowed {
            self.error(Diagnostic::error(t.span, format!("`material` values cannot be used in {what}")).with_help(
                "materials are built by material trees: `material name(material a, float s = 1) = mix(s, a, mirror);`",
            ));
            return Ty::Error;
        }
        if t.base == BaseType::Void && t.array_len.is_some() {
            self.error(Diagnostic::error(t.span, "there are no arrays of `void`"));
            return Ty::Error;
        }
        Ty::from_ast(t)
    }
}
