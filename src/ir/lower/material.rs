//! Materials and their methods: instances bound to their parameters, a
//! method's own body or the interface default, templates, and whether a
//! method is the default throughout a tree.

use super::*;

impl<'p> Lowerer<'p> {
    /// Binds a material definition's parameters: given arguments (lowered in
    /// the tree's context) or defaults.
    pub(super) fn instance_from_def(
        &mut self,
        b: &mut Builder,
        sym: Symbol,
        args: &'p [ast::Arg],
        ctx: &Ctx,
        env: &Rc<HashMap<String, Val<'p>>>,
        env_prelude: bool,
    ) -> Rc<Instance<'p>> {
        let Item::Material(def) = self.item(sym) else {
            ruled_out!("an instance of an item that is not a material definition");
            return Rc::new(Instance { id: 0, def: empty_def(), params: Vec::new(), in_prelude: false });
        };
        let params: Vec<(&str, Ty)> = def.params.iter().map(|p| (p.name.name.as_str(), Ty::from_ast(&p.ty))).collect();
        let bound = bind_args(&params, args);
        let mut values = Vec::new();
        for (p, a) in def.params.iter().zip(bound) {
            let ty = Ty::from_ast(&p.ty);
            let v = match a {
                Some(a) => {
                    let mut fr = self.env_frame(env, env_prelude);
                    self.expr_as(b, &mut fr, ctx, a, &ty)
                }
                None => match &p.default {
                    Some(d) => {
                        let mut fr = self.new_frame(self.is_prelude(sym), HashSet::default());
                        self.expr_as(b, &mut fr, ctx, d, &ty)
                    }
                    None => {
                        ruled_out!(
                            "the parameter `{}` of `{}` has no argument and no default",
                            p.name.name,
                            def.name.name
                        );
                        self.zero_value(b, &ty)
                    }
                },
            };
            values.push((p.name.name.to_string(), v));
        }
        let id = self.id();
        Rc::new(Instance { id, def, params: values, in_prelude: self.is_prelude(sym) })
    }

    /// A frame whose only scope is a template environment.
    pub(super) fn env_frame(&self, env: &Rc<HashMap<String, Val<'p>>>, in_prelude: bool) -> Frame<'p> {
        let mut fr = self.new_frame(in_prelude, HashSet::default());
        fr.scopes[0] = env.iter().map(|(k, v)| (k.clone(), Binding::Val(v.clone()))).collect();
        fr
    }

    /// One interface method of a material instance: its own body, or the
    /// documented default.
    pub(super) fn instance_method(
        &mut self,
        b: &mut Builder,
        inst: &Rc<Instance<'p>>,
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let key = MemoKey::Method { instance: inst.id, method: im.name, ctx: ctx.id, args: args.concat() };
        if let Some(v) = b.lookup(&key) {
            return v;
        }
        let result = match inst.def.methods.iter().find(|m| m.name.name == im.name) {
            Some(m) => {
                let mut fr = self.new_frame(inst.in_prelude, assigned_names(&m.body));
                fr.material = Some(inst.clone());
                // The method's own copy of the parameters: variables for
                // those it assigns (`bind`).
                for ((name, v), p) in inst.params.iter().zip(&inst.def.params) {
                    let ty = Ty::from_ast(&p.ty);
                    self.bind(b, &mut fr, name, v.clone(), &ty);
                }
                fr.scopes.push(HashMap::default());
                for (p, a) in m.params.iter().zip(args) {
                    let ty = Ty::from_ast(&p.ty);
                    self.bind(b, &mut fr, &p.name.name, Val::Lanes(a.clone()), &ty);
                }
                let v = self.body_with_return(b, &mut fr, ctx, &m.body, &im.ret);
                self.lanes(b, v, &im.ret)
            }
            None => self.default_method(b, inst, im, args, ctx),
        };
        b.remember(key, &result);
        result
    }

    pub(super) fn default_method(
        &mut self,
        b: &mut Builder,
        inst: &Rc<Instance<'p>>,
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        match im.name {
            "refraction_index" => {
                let one = b.f(1.0);
                vec![one; self.lanes]
            }
            "ambient" => {
                let diffuse = Method::Diffuse.interface();
                let d = self.instance_method(b, inst, diffuse, &[], ctx);
                b.map2(BinOp::FMul, &args[0], &d)
            }
            "absorption" => args[0].clone(),
            "normal" => self.shading_global(b, ctx, "N"),
            "opaque" => vec![b.b(true)],
            "sample" => self.default_sample(b, inst, args, ctx),
            "pdf" => self.default_pdf(b, inst, args, ctx),
            "albedo" => self.default_albedo(b, inst, args, ctx),
            // Black, or no direction.
            "reflection" | "refraction" | "reflection_dir" | "refraction_dir" | "emission" | "diffuse" => {
                b.zeros(self.lanes_of(&im.ret))
            }
            other => {
                ruled_out!("no default for the interface method `{other}`");
                self.typed_zeros(b, &im.ret)
            }
        }
    }

    /// One interface method of a material expression (a texture tree).
    pub(super) fn mat_method(
        &mut self,
        b: &mut Builder,
        mat: &Mat<'p>,
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        if self.stopped(b) {
            return self.typed_zeros(b, &im.ret);
        }
        let e = mat.expr;
        match &e.kind {
            ExprKind::Name(n) => {
                if let Some(Val::Material(m)) = mat.env.get(n.as_str()) {
                    let m = m.clone();
                    return self.mat_method(b, &m, im, args, ctx);
                }
                match self.symbol(mat.in_prelude, n) {
                    Some(sym) => match self.item(sym) {
                        Item::MaterialTree(t) => {
                            let m = Mat {
                                expr: &t.body,
                                env: Rc::new(HashMap::default()),
                                in_prelude: self.is_prelude(sym),
                            };
                            self.mat_method(b, &m, im, args, ctx)
                        }
                        Item::Material(_) => {
                            let inst = self.instance_from_def(b, sym, &[], ctx, &mat.env, mat.in_prelude);
                            self.instance_method(b, &inst, im, args, ctx)
                        }
                        _ => {
                            ruled_out!("the material `{n}` names an item that is no material");
                            self.typed_zeros(b, &im.ret)
                        }
                    },
                    None => {
                        ruled_out!("the material `{n}` resolves to nothing");
                        self.typed_zeros(b, &im.ret)
                    }
                }
            }
            ExprKind::Ternary { cond, then_expr, else_expr } => {
                let (m1, m2) = (
                    Mat { expr: then_expr, env: mat.env.clone(), in_prelude: mat.in_prelude },
                    Mat { expr: else_expr, env: mat.env.clone(), in_prelude: mat.in_prelude },
                );
                if self.same_material(&m1, &m2) {
                    return self.mat_method(b, &m1, im, args, ctx);
                }
                let mut fr = self.env_frame(&mat.env, mat.in_prelude);
                let c = self.expr(b, &mut fr, ctx, cond);
                let c = self.scalar(b, c);
                let tys = self.words(&im.ret);
                b.branch(
                    self,
                    c,
                    &tys,
                    |b, me| me.mat_method(b, &m1, im, args, ctx),
                    |b, me| me.mat_method(b, &m2, im, args, ctx),
                )
            }
            ExprKind::Call { callee, args: call_args } => {
                if let Some(sym) = self.program.resolutions.get(&callee.span).copied() {
                    return match self.item(sym) {
                        Item::Material(def) => {
                            let mut inst = self.instance_from_def(b, sym, call_args, ctx, &mat.env, mat.in_prelude);
                            if let Some(read) = self.instance_block_values(b, e.span, &def.params) {
                                let mut params = inst.params.clone();
                                for (k, v) in read {
                                    params[k].1 = v;
                                }
                                inst = Rc::new(Instance { params, ..*inst });
                            }
                            self.instance_method(b, &inst, im, args, ctx)
                        }
                        Item::MaterialTree(t) => {
                            let mut env = self.template_env(b, t, call_args, mat, ctx);
                            let params = t.params.as_deref().unwrap_or(&[]);
                            if let Some(read) = self.instance_block_values(b, e.span, params) {
                                let mut bound = (*env).clone();
                                for (k, v) in read {
                                    bound.insert(params[k].name.name.to_string(), v);
                                }
                                env = Rc::new(bound);
                            }
                            let m = Mat { expr: &t.body, env, in_prelude: self.is_prelude(sym) };
                            self.mat_method(b, &m, im, args, ctx)
                        }
                        _ => {
                            ruled_out!("`{}` is called as a material but is none", callee.name);
                            self.typed_zeros(b, &im.ret)
                        }
                    };
                }
                match self.program.builtin_calls.get(&callee.span).and_then(|f| f.tree_node()) {
                    Some(node) => self.tree_node(b, mat, node, call_args, im, args, ctx),
                    None => {
                        ruled_out!("`{}` is a material but no tree node", callee.name);
                        self.typed_zeros(b, &im.ret)
                    }
                }
            }
            // `ms[i]` of a `material[N]` parameter (`i` clamped, as `select`).
            ExprKind::Index { base, index } => {
                let items = self.material_items(Some(base), mat);
                let mut fr = self.env_frame(&mat.env, mat.in_prelude);
                let i = self.expr(b, &mut fr, ctx, index);
                let i = self.scalar(b, i);
                self.select_clamped(b, i, &items, im, args, ctx)
            }
            _ => {
                ruled_out!("a material expression of an unexpected form");
                self.typed_zeros(b, &im.ret)
            }
        }
    }

    /// When `at` is the run-time-bound instance's call: its value
    /// parameters read from the instance parameter block, by parameter
    /// index (see [`InstanceBlock`]).
    fn instance_block_values(
        &mut self,
        b: &mut Builder,
        at: Span,
        params: &[ast::Param],
    ) -> Option<Vec<(usize, Val<'p>)>> {
        let block = self.instance_block.as_ref().filter(|block| block.root == at)?;
        let (offsets, constants) = (block.offsets.clone(), block.constants.clone());
        let mut read = Vec::new();
        for (k, (p, first)) in params.iter().zip(offsets).enumerate() {
            let Some(first) = first else { continue };
            // Known words are constants (the API writes every one; a
            // missing word is 0, never a read of a block the code has not).
            let word = |b: &mut Builder, i: u32, ty: Scalar| match &constants {
                Some(c) => {
                    let w = c.get((first + i) as usize).copied().unwrap_or(0);
                    match ty {
                        Scalar::F32 => b.f(f32::from_bits(w)),
                        Scalar::I32 => b.i(w as i32),
                        Scalar::Bool => b.b(w != 0),
                    }
                }
                None => b.def(ty, Op::InstanceWord(first + i)),
            };
            let ty = Ty::from_ast(&p.ty);
            if ty == Ty::Color && self.model == ColorModel::Hero {
                // Hero lanes are at the hit's wavelengths: the block holds
                // RGB, upsampled here as a run-time `rgb(...)` is.
                let rgb = [0, 1, 2].map(|i| word(b, i, Scalar::F32));
                let lanes = self.rgb_to_lanes(b, rgb);
                read.push((k, Val::Lanes(lanes)));
                continue;
            }
            let lanes = (0..).zip(self.words(&ty)).map(|(i, ty)| word(b, i, ty)).collect();
            read.push((k, Val::Lanes(lanes)));
        }
        Some(read)
    }

    /// Binds a template's parameters: materials stay expressions, values
    /// are lowered now.
    pub(super) fn template_env(
        &mut self,
        b: &mut Builder,
        t: &'p ast::MaterialTree,
        call_args: &'p [ast::Arg],
        mat: &Mat<'p>,
        ctx: &Ctx,
    ) -> Rc<HashMap<String, Val<'p>>> {
        let params = t.params.as_deref().unwrap_or(&[]);
        let typed: Vec<(&str, Ty)> = params.iter().map(|p| (p.name.name.as_str(), Ty::from_ast(&p.ty))).collect();
        let bound = bind_args(&typed, call_args);
        let mut env = HashMap::default();
        for (p, a) in params.iter().zip(bound) {
            let ty = Ty::from_ast(&p.ty);
            let (expr, source_env, prelude) = match (a, &p.default) {
                (Some(a), _) => (a, mat.env.clone(), mat.in_prelude),
                (None, Some(d)) => (d, Rc::new(HashMap::default()), mat.in_prelude),
                (None, None) => continue,
            };
            let v = match self.material_binding(&ty, Mat { expr, env: source_env.clone(), in_prelude: prelude }) {
                Some(v) => v,
                None => {
                    let mut fr = self.env_frame(&source_env, prelude);
                    self.expr_as(b, &mut fr, ctx, expr, &ty)
                }
            };
            env.insert(p.name.name.to_string(), v);
        }
        Rc::new(env)
    }

    /// The binding of a template parameter of type `ty` that holds
    /// materials: the material `m`, or the items of the `material[N]`
    /// argument `m` (an array literal or such a parameter passed on).
    /// `None` for a value parameter.
    fn material_binding(&self, ty: &Ty, m: Mat<'p>) -> Option<Val<'p>> {
        match ty {
            Ty::Material => Some(Val::Material(m)),
            Ty::Array(elem, _) if **elem == Ty::Material => Some(Val::Materials(self.material_items(Some(m.expr), &m))),
            _ => None,
        }
    }

    /// Whether method `im` of the material expression is the interface
    /// default everywhere in its tree (no leaf defines it and no node
    /// changes it). Conservative: `false` when unsure.
    ///
    /// Each named tree is analysed once per method (`default_methods`), and
    /// a node's children that are the same material once: a tree that
    /// uses the previous tree twice at every level costs its depth, not
    /// 2^depth.
    pub(super) fn uses_default(&self, mat: &Mat<'p>, im: &'static InterfaceMethod, depth: u32) -> bool {
        if depth > 64 {
            return false;
        }
        if let Some(id) = self.mat_identity(mat) {
            let key = (id, im.name);
            if let Some(known) = self.default_methods.borrow().get(&key) {
                return *known;
            }
            let found = self.uses_default_uncached(mat, im, depth);
            self.default_methods.borrow_mut().insert(key, found);
            return found;
        }
        self.uses_default_uncached(mat, im, depth)
    }

    fn uses_default_uncached(&self, mat: &Mat<'p>, im: &'static InterfaceMethod, depth: u32) -> bool {
        let defines = |def: &ast::MaterialDef| def.methods.iter().any(|m| m.name.name == im.name);
        match &mat.expr.kind {
            ExprKind::Name(n) => {
                if let Some(Val::Material(m)) = mat.env.get(n.as_str()) {
                    return self.uses_default(m, im, depth + 1);
                }
                match self.symbol(mat.in_prelude, n) {
                    Some(sym) => match self.item(sym) {
                        Item::MaterialTree(t) if t.params.is_none() => {
                            let m = Mat {
                                expr: &t.body,
                                env: Rc::new(HashMap::default()),
                                in_prelude: self.is_prelude(sym),
                            };
                            self.uses_default(&m, im, depth + 1)
                        }
                        Item::Material(def) => !defines(def),
                        _ => false,
                    },
                    None => false,
                }
            }
            ExprKind::Index { base, .. } => {
                let items = self.material_items(Some(base), mat);
                !items.is_empty() && self.distinct(&items).iter().all(|m| self.uses_default(m, im, depth + 1))
            }
            ExprKind::Ternary { then_expr, else_expr, .. } => [then_expr, else_expr].iter().all(|e| {
                self.uses_default(&Mat { expr: e, env: mat.env.clone(), in_prelude: mat.in_prelude }, im, depth + 1)
            }),
            ExprKind::Call { callee, args: call_args } => {
                if let Some(sym) = self.program.resolutions.get(&callee.span).copied() {
                    return match self.item(sym) {
                        Item::Material(def) => !defines(def),
                        Item::MaterialTree(t) => {
                            // A template: its body, with its material
                            // parameters bound to the call's arguments.
                            let params = t.params.as_deref().unwrap_or(&[]);
                            let typed: Vec<(&str, Ty)> =
                                params.iter().map(|p| (p.name.name.as_str(), Ty::from_ast(&p.ty))).collect();
                            let mut env = HashMap::default();
                            for (p, a) in params.iter().zip(bind_args(&typed, call_args)) {
                                let bound = match (a, &p.default) {
                                    (Some(a), _) => Mat { expr: a, env: mat.env.clone(), in_prelude: mat.in_prelude },
                                    (None, Some(d)) => Mat {
                                        expr: d,
                                        env: Rc::new(HashMap::default()),
                                        in_prelude: self.is_prelude(sym),
                                    },
                                    (None, None) => continue,
                                };
                                if let Some(v) = self.material_binding(&Ty::from_ast(&p.ty), bound) {
                                    env.insert(p.name.name.to_string(), v);
                                }
                            }
                            let body = Mat { expr: &t.body, env: Rc::new(env), in_prelude: self.is_prelude(sym) };
                            self.uses_default(&body, im, depth + 1)
                        }
                        _ => false,
                    };
                }
                // Only values (`spline:`, `strength:`, `convention:`,
                // `shadowing:`) may be named; a named material child, or
                // `only:` (which changes where a method comes from), is not
                // analysed.
                let value_option = |n: &str| matches!(n, "spline" | "strength" | "convention" | "shadowing");
                if call_args.iter().any(|a| a.name.as_ref().is_some_and(|n| !value_option(&n.name))) {
                    return false;
                }
                let positional: Vec<&'p ast::Arg> = call_args.iter().filter(|a| a.name.is_none()).collect();
                let child = |k: usize| {
                    positional.get(k).map(|a| Mat { expr: &a.value, env: mat.env.clone(), in_prelude: mat.in_prelude })
                };
                let all = |items: Vec<Mat<'p>>| {
                    !items.is_empty() && self.distinct(&items).iter().all(|m| self.uses_default(m, im, depth + 1))
                };
                let Some(node) = self.program.builtin_calls.get(&callee.span).and_then(|f| f.tree_node()) else {
                    return false;
                };
                match node {
                    TreeNode::Mix => all([child(1), child(2)].into_iter().flatten().collect()),
                    TreeNode::Blend | TreeNode::Select => all(self.material_items(child(1).map(|m| m.expr), mat)),
                    // bump and normal_map change the normal; transform moves the point.
                    TreeNode::Bump => im.name != "normal" && all(child(2).into_iter().collect()),
                    TreeNode::NormalMap => im.name != "normal" && all(child(1).into_iter().collect()),
                    TreeNode::Transform => all(child(1).into_iter().collect()),
                    // scale keeps a black default black.
                    TreeNode::Scale => {
                        matches!(
                            im.name,
                            "reflection"
                                | "refraction"
                                | "emission"
                                | "diffuse"
                                | "reflection_dir"
                                | "refraction_dir"
                                | "normal"
                                | "opaque"
                        ) && all(child(1).into_iter().collect())
                    }
                    // The body's methods are the base's; the light's are both children's.
                    TreeNode::Layer => match im.name {
                        "refraction" | "refraction_index" | "refraction_dir" | "absorption" | "opaque" | "normal" => {
                            all(child(1).into_iter().collect())
                        }
                        "reflection" | "emission" | "diffuse" | "reflection_dir" => {
                            all([child(0), child(1)].into_iter().flatten().collect())
                        }
                        _ => false,
                    },
                }
            }
            _ => false,
        }
    }

    /// The material a material expression names when it is a plain name
    /// (of a material definition or a tree without parameters, directly or
    /// through template parameters): two children with the same identity
    /// are the same material in the same place, lowered once.
    pub(super) fn mat_identity(&self, mat: &Mat<'p>) -> Option<MatId> {
        let mut mat = mat;
        loop {
            let ExprKind::Name(n) = &mat.expr.kind else { return None };
            if let Some(bound) = mat.env.get(n.as_str()) {
                let Val::Material(inner) = bound else { return None };
                mat = inner;
                continue;
            }
            let sym = self.symbol(mat.in_prelude, n)?;
            return match self.item(sym) {
                Item::Material(_) => Some((sym.module, sym.item)),
                Item::MaterialTree(t) if t.params.is_none() => Some((sym.module, sym.item)),
                _ => None,
            };
        }
    }

    /// Whether `a` and `b` are the same material ([`Self::mat_identity`]).
    pub(super) fn same_material(&self, a: &Mat<'p>, b: &Mat<'p>) -> bool {
        self.mat_identity(a).is_some_and(|id| self.mat_identity(b) == Some(id))
    }

    /// `items` with repeats of the same material left out.
    pub(super) fn distinct(&self, items: &[Mat<'p>]) -> Vec<Mat<'p>> {
        let groups = self.material_groups(items);
        groups.iter().map(|g| items[g[0]].clone()).collect()
    }

    /// The indices of `items`, grouped by material: each group holds the
    /// children that are the same material ([`Self::mat_identity`]), in
    /// order of first appearance; a child without an identity is alone.
    pub(super) fn material_groups(&self, items: &[Mat<'p>]) -> Vec<Vec<usize>> {
        let mut groups: Vec<(Option<MatId>, Vec<usize>)> = Vec::new();
        for (k, item) in items.iter().enumerate() {
            let id = self.mat_identity(item);
            match groups.iter_mut().find(|(g, _)| id.is_some() && *g == id) {
                Some((_, members)) => members.push(k),
                None => groups.push((id, vec![k])),
            }
        }
        groups.into_iter().map(|(_, members)| members).collect()
    }

    /// The interface default of a method that needs no material to compute
    /// (every default but `ambient`, which reads `diffuse`).
    pub(super) fn plain_default(
        &mut self,
        b: &mut Builder,
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Option<Vec<Value>> {
        Some(match im.name {
            "refraction_index" => {
                let one = b.f(1.0);
                vec![one; self.lanes]
            }
            "absorption" => args[0].clone(),
            "normal" => self.shading_global(b, ctx, "N"),
            "opaque" => vec![b.b(true)],
            // These read the material's other methods.
            "ambient" | "sample" | "pdf" | "albedo" => return None,
            // Black, or no direction.
            "reflection" | "refraction" | "reflection_dir" | "refraction_dir" | "emission" | "diffuse" => {
                b.zeros(self.lanes_of(&im.ret))
            }
            other => {
                ruled_out!("no default for the interface method `{other}`");
                self.typed_zeros(b, &im.ret)
            }
        })
    }
}
