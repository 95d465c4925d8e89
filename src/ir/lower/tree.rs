//! Texture-tree nodes: `mix`, `blend`, `select`, `bump`, `normal_map`,
//! `scale`, `transform` and `layer` (in `lower::layer`), and the
//! coordinate contexts `bump`, `normal_map` and `transform` give their
//! subtrees.

use super::*;

impl<'p> Lowerer<'p> {
    /// The texture-tree nodes.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn tree_node(
        &mut self,
        b: &mut Builder,
        mat: &Mat<'p>,
        node: TreeNode,
        call_args: &'p [ast::Arg],
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let spec = node.builtin();
        // A method no child defines is the default whatever the weights:
        // the weights (often noise) need not be computed at all.
        if matches!(node, TreeNode::Mix | TreeNode::Blend | TreeNode::Select) && self.uses_default(mat, im, 0) {
            if let Some(v) = self.plain_default(b, im, args, ctx) {
                return v;
            }
            // The default ambient, light * diffuse(), is linear: blending the
            // children's is the node's own, from the node's diffuse.
            if im.name == "ambient" {
                let d = self.mat_method(b, mat, Method::Diffuse.interface(), &[], ctx);
                return b.map2(BinOp::FMul, &args[0], &d);
            }
        }
        let bound = bind_builtin_args(spec, call_args);
        let child = |k: usize| {
            bound.get(k).copied().flatten().map(|e| Mat { expr: e, env: mat.env.clone(), in_prelude: mat.in_prelude })
        };
        let mut fr = self.env_frame(&mat.env, mat.in_prelude);
        // A required float argument.
        let mut scalar = |me: &mut Self, b: &mut Builder, k: usize, ctx: &Ctx| -> Value {
            match bound.get(k).copied().flatten() {
                Some(e) => {
                    let v = me.expr_as(b, &mut fr, ctx, e, &Ty::Float);
                    me.scalar(b, v)
                }
                None => {
                    ruled_out!("`{}` without its argument {}", spec.name, spec.params.get(k).map_or("?", |p| p.name));
                    b.f(0.0)
                }
            }
        };
        // What a node without a required child gives (never, once checked).
        let missing = |me: &mut Self, b: &mut Builder| -> Vec<Value> {
            ruled_out!("`{}` without a material child", spec.name);
            me.typed_zeros(b, &im.ret)
        };
        match node {
            TreeNode::Mix => {
                let (Some(a), Some(c)) = (child(1), child(2)) else { return missing(self, b) };
                if let Some(ExprKind::Str(only)) = bound.get(3).copied().flatten().map(|e| &e.kind) {
                    // A partial blend samples as its first child.
                    if im.name == "sample" {
                        return self.sample_as_first(b, mat, &a, args, ctx);
                    }
                    if im.name == "pdf" || only != im.name {
                        return self.mat_method(b, &a, im, args, ctx);
                    }
                }
                let t = match bound.first().copied().flatten() {
                    Some(e) => self.node_float(b, mat, e, ctx),
                    None => scalar(self, b, 0, ctx),
                };
                if matches!(im.name, "sample" | "pdf") {
                    let one = b.f(1.0);
                    let weights = [b.fsub(one, t), t];
                    // Under a hit group's choice at t = 0 or 1 (`lower::hit`);
                    // elsewhere nothing is known (and nothing is defined).
                    let mut unused = [false; 2];
                    if !b.facts.is_empty() {
                        let zero = b.f(0.0);
                        for (k, w) in [one, zero].into_iter().enumerate() {
                            unused[k] = b.known(&Op::Binary(BinOp::FEq, t, w)) == Some(true);
                        }
                    }
                    let items = [a, c];
                    return if im.name == "sample" {
                        self.sample_mixture(b, mat, &weights, &unused, &items, args, ctx)
                    } else {
                        self.pdf_mixture(b, &weights, &unused, &items, args, ctx)
                    };
                }
                self.mix_children(b, t, &a, &c, im, args, ctx)
            }
            TreeNode::Blend => {
                let t = scalar(self, b, 0, ctx);
                let spline = match bound.get(2).copied().flatten() {
                    Some(e) => self.node_scalar(b, mat, e, ctx),
                    None => b.b(false),
                };
                let items = self.material_items(bound.get(1).copied().flatten(), mat);
                let w = blend_weights(b, t, spline, items.len());
                match im.name {
                    "sample" => self.sample_mixture(b, mat, &w, &[], &items, args, ctx),
                    "pdf" => self.pdf_mixture(b, &w, &[], &items, args, ctx),
                    _ => self.weighted_children(b, &w, &items, im, args, ctx),
                }
            }
            TreeNode::Select => {
                let (index, items) = self.select_parts(mat, call_args);
                let i = match index {
                    Some(e) => self.node_scalar(b, mat, e, ctx),
                    None => {
                        ruled_out!("`select` without its index");
                        b.i(0)
                    }
                };
                self.select_clamped(b, i, &items, im, args, ctx)
            }
            TreeNode::Bump => {
                let Some(m) = child(2) else { return missing(self, b) };
                let amount = scalar(self, b, 1, ctx);
                let Some(height) = bound.first().copied().flatten() else { return missing(self, b) };
                let shadowing = match bound.get(3).copied().flatten() {
                    Some(e) => self.node_scalar(b, mat, e, ctx),
                    None => b.b(true),
                };
                let bumped = self.bump_ctx(b, height, mat, amount, ctx);
                let inner = self.mat_method(b, &m, im, args, &bumped);
                self.shadowed(b, inner, im, args, shadowing, ctx, &bumped)
            }
            TreeNode::NormalMap => {
                let Some(m) = child(1) else { return missing(self, b) };
                let Some(encoded) = bound.first().copied().flatten() else { return missing(self, b) };
                let strength = match bound.get(2).copied().flatten() {
                    Some(e) => self.node_float(b, mat, e, ctx),
                    None => b.f(1.0),
                };
                let convention = match bound.get(3).copied().flatten().map(|e| &e.kind) {
                    Some(ExprKind::Str(name)) => NormalMapConvention::from_name(name),
                    _ => None,
                };
                let shadowing = match bound.get(4).copied().flatten() {
                    Some(e) => self.node_scalar(b, mat, e, ctx),
                    None => b.b(true),
                };
                let mut fr = self.env_frame(&mat.env, mat.in_prelude);
                let v = self.expr_as(b, &mut fr, ctx, encoded, &Ty::Vector);
                let encoded = self.lanes(b, v, &Ty::Vector);
                let convention = convention.unwrap_or(NormalMapConvention::OpenGl);
                let (mapped, tilted) = self.normal_map_ctx(b, &encoded, strength, convention, ctx);
                let inner = self.mat_method(b, &m, im, args, &mapped);
                let shadowed = b.and(tilted, shadowing);
                self.shadowed(b, inner, im, args, shadowed, ctx, &mapped)
            }
            TreeNode::Scale => {
                let Some(m) = child(1) else { return missing(self, b) };
                let inner = self.mat_method(b, &m, im, args, ctx);
                if !matches!(im.name, "reflection" | "refraction" | "emission" | "ambient" | "diffuse" | "sample") {
                    return inner;
                }
                // Black stays black, whatever the weight (even a NaN): the
                // weight is not evaluated, so a scaled lambert stays
                // non-emissive.
                if im.name != "sample" && inner.iter().all(|v| b.fconst(*v) == Some(0.0)) {
                    return inner;
                }
                let c = match bound.first().copied().flatten() {
                    Some(e) => {
                        let mut fr = self.env_frame(&mat.env, mat.in_prelude);
                        let v = self.expr(b, &mut fr, ctx, e);
                        self.lanes(b, v, &Ty::Color)
                    }
                    None => {
                        ruled_out!("`scale` without its color");
                        return inner;
                    }
                };
                if im.name == "sample" {
                    return self.scale_sample(b, &inner, &c);
                }
                b.map2(BinOp::FMul, &inner, &c)
            }
            TreeNode::Transform => {
                let Some(m) = child(1) else { return missing(self, b) };
                let xf = match bound.first().copied().flatten() {
                    Some(e) => {
                        let mut fr = self.env_frame(&mat.env, mat.in_prelude);
                        let v = self.expr(b, &mut fr, ctx, e);
                        self.lanes(b, v, &Ty::Matrix)
                    }
                    None => {
                        ruled_out!("`transform` without its matrix");
                        identity(b)
                    }
                };
                let moved = self.transform_ctx(b, &xf, ctx);
                self.mat_method(b, &m, im, args, &moved)
            }
            TreeNode::Layer => {
                let (Some(top), Some(base)) = (child(0), child(1)) else { return missing(self, b) };
                self.layer_node(b, mat, &top, &base, im, args, ctx)
            }
        }
    }

    /// The index expression of `select(index, [children])` (`None` without
    /// one) and its children, as [`Self::tree_node`] and the hit groups'
    /// root `select` (`lower::hit`) both read them.
    pub(super) fn select_parts(&self, mat: &Mat<'p>, call_args: &'p [ast::Arg]) -> (Option<&'p Expr>, Vec<Mat<'p>>) {
        let bound = bind_builtin_args(TreeNode::Select.builtin(), call_args);
        (bound.first().copied().flatten(), self.material_items(bound.get(1).copied().flatten(), mat))
    }

    /// A node's float argument `e`, evaluated where the node is written.
    pub(super) fn node_scalar(&mut self, b: &mut Builder, mat: &Mat<'p>, e: &'p Expr, ctx: &Ctx) -> Value {
        let mut fr = self.env_frame(&mat.env, mat.in_prelude);
        let v = self.expr(b, &mut fr, ctx, e);
        self.scalar(b, v)
    }

    /// `mix`'s weight `e`, as a float, evaluated where the node is written
    /// (the hit groups' root choice computes it as [`Self::tree_node`] does).
    pub(super) fn node_float(&mut self, b: &mut Builder, mat: &Mat<'p>, e: &'p Expr, ctx: &Ctx) -> Value {
        let mut fr = self.env_frame(&mat.env, mat.in_prelude);
        let v = self.expr_as(b, &mut fr, ctx, e, &Ty::Float);
        self.scalar(b, v)
    }

    pub(super) fn material_items(&self, e: Option<&'p Expr>, mat: &Mat<'p>) -> Vec<Mat<'p>> {
        match e.map(|e| &e.kind) {
            Some(ExprKind::Array(items)) => {
                items.iter().map(|it| Mat { expr: it, env: mat.env.clone(), in_prelude: mat.in_prelude }).collect()
            }
            // A `material[N]` template parameter.
            Some(ExprKind::Name(n)) => match mat.env.get(n.as_str()) {
                Some(Val::Materials(items)) => items.clone(),
                _ => Vec::new(),
            },
            _ => Vec::new(),
        }
    }

    /// `mix`: at t = 0 only `a` runs, at t = 1 only `b`; between, every
    /// result blends linearly (normals are renormalised; a blend is opaque
    /// when both children are).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn mix_children(
        &mut self,
        b: &mut Builder,
        t: Value,
        a: &Mat<'p>,
        c: &Mat<'p>,
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        if self.same_material(a, c) {
            // `mix(t, m, m)` is `m` whatever `t` (normals renormalised, as
            // a blend's are): lowered once, so a tree that mixes the
            // previous tree with itself at every level stays linear.
            let v = self.mat_method(b, a, im, args, ctx);
            return if im.name == "normal" { b.normalize(&v) } else { v };
        }
        let (zero, one) = (b.f(0.0), b.f(1.0));
        let is_zero = b.feq(t, zero);
        let is_one = b.feq(t, one);
        let need_a = b.not(is_one);
        let need_c = b.not(is_zero);
        if im.ret == Ty::Bool {
            // A child left out counts as true. Said explicitly: `guarded`
            // may return a child's value unguarded when it needs no code
            // (a constant), so its `otherwise` only skips work.
            let yes = b.b(true);
            let oa = b.guarded(self, need_a, vec![yes], |b, me| me.mat_method(b, a, im, args, ctx));
            let oc = b.guarded(self, need_c, vec![yes], |b, me| me.mat_method(b, c, im, args, ctx));
            let (oa, oc) = (b.bin(BinOp::Or, is_one, oa[0]), b.bin(BinOp::Or, is_zero, oc[0]));
            return vec![b.and(oa, oc)];
        }
        let n = self.lanes_of(&im.ret);
        let zeros = b.zeros(n);
        let va = b.guarded(self, need_a, zeros.clone(), |b, me| me.mat_method(b, a, im, args, ctx));
        let vc = b.guarded(self, need_c, zeros, |b, me| me.mat_method(b, c, im, args, ctx));
        if va == vc {
            // Both children agree (typically the same constant): no blend.
            return va;
        }
        let blended = b.lerp(t, &va, &vc);
        if im.name == "normal" { b.normalize(&blended) } else { blended }
    }

    /// `blend`: Σ w_k child_k, evaluating only children with nonzero weight.
    pub(super) fn weighted_children(
        &mut self,
        b: &mut Builder,
        w: &[Value],
        items: &[Mat<'p>],
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let zero = b.f(0.0);
        // Children that are the same material are lowered once, when any
        // of their weights is nonzero.
        let groups = self.material_groups(items);
        let used = |b: &mut Builder, group: &[usize]| -> Value {
            let mut used = None;
            for k in group {
                let zero_weight = b.feq(w[*k], zero);
                let nonzero = b.not(zero_weight);
                used = Some(match used {
                    None => nonzero,
                    Some(u) => b.bin(BinOp::Or, u, nonzero),
                });
            }
            used.unwrap_or_else(|| b.b(false))
        };
        if im.ret == Ty::Bool {
            let mut acc = b.b(true);
            for group in &groups {
                let used = used(b, group);
                let yes = b.b(true);
                let item = &items[group[0]];
                let o = b.guarded(self, used, vec![yes], |b, me| me.mat_method(b, item, im, args, ctx));
                // Unused children count as true (see `mix_children`).
                let unused = b.not(used);
                let o = b.bin(BinOp::Or, unused, o[0]);
                acc = b.and(acc, o);
            }
            return vec![acc];
        }
        let n = self.lanes_of(&im.ret);
        let mut results = vec![Vec::new(); items.len()];
        for group in &groups {
            let used = used(b, group);
            let zeros = b.zeros(n);
            let item = &items[group[0]];
            let v = b.guarded(self, used, zeros, |b, me| me.mat_method(b, item, im, args, ctx));
            for k in group {
                results[*k] = v.clone();
            }
        }
        if results.windows(2).all(|r| r[0] == r[1]) {
            // All children agree: the weights (which sum to one) change nothing.
            return results.pop().unwrap_or_else(|| b.zeros(n));
        }
        let mut acc = b.zeros(n);
        for (wk, v) in w.iter().zip(&results) {
            let s = b.scale(v, *wk);
            acc = b.map2(BinOp::FAdd, &acc, &s);
        }
        if im.name == "normal" { b.normalize(&acc) } else { acc }
    }

    /// `items[i]`, `i` clamped into the list: `select`, and an element of
    /// a `material[N]` parameter.
    pub(super) fn select_clamped(
        &mut self,
        b: &mut Builder,
        i: Value,
        items: &[Mat<'p>],
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        if items.is_empty() {
            ruled_out!("a choice among no materials");
            return self.typed_zeros(b, &im.ret);
        }
        let i = self.clamp_index(b, i, items.len() as i32);
        let groups = self.material_groups(items);
        if groups.len() < items.len() {
            // Children that are the same material: one branch for them all.
            return self.select_group(b, i, items, &groups, im, args, ctx);
        }
        self.select_child(b, i, items, 0, im, args, ctx)
    }

    /// [`Self::select_child`] over groups of children that are the same
    /// material: the first group holding index `i`, else a later one.
    #[allow(clippy::too_many_arguments)]
    fn select_group(
        &mut self,
        b: &mut Builder,
        i: Value,
        items: &[Mat<'p>],
        groups: &[Vec<usize>],
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let Some((group, rest)) = groups.split_first() else { return self.typed_zeros(b, &im.ret) };
        let item = &items[group[0]];
        if rest.is_empty() {
            return self.mat_method(b, item, im, args, ctx);
        }
        let mut hit = None;
        for k in group {
            let kv = b.i(*k as i32);
            let is_k = b.bin(BinOp::IEq, i, kv);
            hit = Some(match hit {
                None => is_k,
                Some(h) => b.bin(BinOp::Or, h, is_k),
            });
        }
        let hit = hit.unwrap_or_else(|| b.b(false));
        let tys = self.words(&im.ret);
        b.branch(
            self,
            hit,
            &tys,
            |b, me| me.mat_method(b, item, im, args, ctx),
            |b, me| me.select_group(b, i, items, rest, im, args, ctx),
        )
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) fn select_child(
        &mut self,
        b: &mut Builder,
        i: Value,
        items: &[Mat<'p>],
        k: usize,
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        if k + 1 == items.len() {
            return self.mat_method(b, &items[k], im, args, ctx);
        }
        let kv = b.i(k as i32);
        let hit = b.bin(BinOp::IEq, i, kv);
        let tys = self.words(&im.ret);
        b.branch(
            self,
            hit,
            &tys,
            |b, me| me.mat_method(b, &items[k], im, args, ctx),
            |b, me| me.select_child(b, i, items, k + 1, im, args, ctx),
        )
    }

    /// `ctx` with some globals replaced. Equal changes of one context get
    /// one id (see [`Builder::contexts`]).
    pub(super) fn with_overrides(
        &mut self,
        b: &mut Builder,
        ctx: &Ctx,
        changes: Vec<(&'static str, Vec<Value>)>,
    ) -> Ctx {
        let key = (ctx.id, changes);
        let id = match b.contexts.get(&key) {
            Some(id) => *id,
            None => {
                let id = self.id();
                b.contexts.insert(key.clone(), id);
                id
            }
        };
        let mut map = (*ctx.overrides).clone();
        map.extend(key.1);
        Ctx { id, overrides: Rc::new(map) }
    }

    /// `transform`: the subtree sees P, Pl, (u, v) and the tangents mapped.
    pub(super) fn transform_ctx(&mut self, b: &mut Builder, m: &[Value], ctx: &Ctx) -> Ctx {
        let mut changes = Vec::new();
        for name in ["P", "Pl"] {
            let p = self.shading_global(b, ctx, name);
            changes.push((name, transform_point(b, m, &p, true)));
        }
        for name in ["dPdu", "dPdv"] {
            let d = self.shading_global(b, ctx, name);
            changes.push((name, transform_point(b, m, &d, false)));
        }
        let u = self.shading_global(b, ctx, "u");
        let v = self.shading_global(b, ctx, "v");
        let zero = b.f(0.0);
        let uv = transform_point(b, m, &[u[0], v[0], zero], true);
        changes.push(("u", vec![uv[0]]));
        changes.push(("v", vec![uv[1]]));
        self.with_overrides(b, ctx, changes)
    }

    /// `bump`: the normal tilted by the gradient of `height` along the
    /// tangents, estimated by forward differences; the subtree sees it as N.
    pub(super) fn bump_ctx(
        &mut self,
        b: &mut Builder,
        height: &'p Expr,
        mat: &Mat<'p>,
        amount: Value,
        ctx: &Ctx,
    ) -> Ctx {
        let h_at = |me: &mut Self, b: &mut Builder, c: &Ctx| -> Value {
            let mut fr = me.env_frame(&mat.env, mat.in_prelude);
            let v = me.expr_as(b, &mut fr, c, height, &Ty::Float);
            me.scalar(b, v)
        };
        let g = |me: &mut Self, b: &mut Builder, name: &str| me.shading_global(b, ctx, name);
        let (p, pl, u, v) = (g(self, b, "P"), g(self, b, "Pl"), g(self, b, "u"), g(self, b, "v"));
        let (dpdu, dpdv, n) = (g(self, b, "dPdu"), g(self, b, "dPdv"), g(self, b, "N"));
        let delta = b.f(BUMP_DELTA);
        let h0 = h_at(self, b, ctx);
        let mut gradient = Vec::new();
        for (tangent, param, pname) in [(&dpdu, &u, "u"), (&dpdv, &v, "v")] {
            let step = b.scale(tangent, delta);
            let moved_p = b.map2(BinOp::FAdd, &p, &step);
            let moved_pl = b.map2(BinOp::FAdd, &pl, &step);
            let moved_param = b.fadd(param[0], delta);
            let shifted =
                self.with_overrides(b, ctx, vec![("P", moved_p), ("Pl", moved_pl), (pname, vec![moved_param])]);
            let h = h_at(self, b, &shifted);
            let dh = b.fsub(h, h0);
            gradient.push(b.fdiv(dh, delta));
        }
        // dp/du' = dPdu + amount dh/du N (likewise v); N' = their cross product.
        let ku = b.fmul(amount, gradient[0]);
        let kv = b.fmul(amount, gradient[1]);
        let nu = b.scale(&n, ku);
        let nv = b.scale(&n, kv);
        let du = b.map2(BinOp::FAdd, &dpdu, &nu);
        let dv = b.map2(BinOp::FAdd, &dpdv, &nv);
        let c = b.cross(&du, &dv);
        let c = b.normalize(&c);
        // Keep the side of the original normal; fall back to it when the
        // tangents are degenerate.
        let zero = b.f(0.0);
        let facing = b.dot(&c, &n);
        let flip = b.flt(facing, zero);
        let len = b.dot(&c, &c);
        let degenerate = b.feq(len, zero);
        let new_n: Vec<Value> = (0..3)
            .map(|k| {
                let neg = b.un(UnOp::FNeg, c[k]);
                let oriented = b.select(flip, neg, c[k]);
                b.select(degenerate, n[k], oriented)
            })
            .collect();
        self.with_overrides(b, ctx, vec![("N", new_n)])
    }
}

impl<'p> Lowerer<'p> {
    /// `inner`, the result of method `im` of a child that sees the normal of
    /// `perturbed` instead of `ctx`'s, weighed where `shadowed` by the
    /// bump-terminator shadowing of the light's direction
    /// ([`bump_shadowing`]), as Mitsuba 3's `bumpmap` and `normalmap` do:
    /// `reflection` and `refraction` by their `wi`, `sample` by the `wi` it
    /// draws; every other method as it is.
    #[allow(clippy::too_many_arguments)]
    fn shadowed(
        &mut self,
        b: &mut Builder,
        inner: Vec<Value>,
        im: &InterfaceMethod,
        args: &[Vec<Value>],
        shadowed: Value,
        ctx: &Ctx,
        perturbed: &Ctx,
    ) -> Vec<Value> {
        if !matches!(im.name, "reflection" | "refraction" | "sample") {
            return inner;
        }
        let n = self.shading_global(b, ctx, "N");
        let perturbed_n = self.shading_global(b, perturbed, "N");
        let shadowing = |_: &mut Self, b: &mut Builder, wi: &[Value]| {
            let g = bump_shadowing(b, &n, &perturbed_n, wi);
            let one = b.f(1.0);
            b.select(shadowed, g, one)
        };
        if im.name == "sample" {
            return self.weigh_sample(b, &inner, shadowing);
        }
        let g = shadowing(self, b, &args[0]);
        b.scale(&inner, g)
    }
}

impl<'p> Lowerer<'p> {
    /// `normal_map`: the stored normal `encoded` (in [0, 1]³) decoded to
    /// `2c - 1`, green negated for DirectX, its tangent components times
    /// `strength` and `z` kept above the surface, taken to world space in
    /// the frame (s, t, N) of Mitsuba's `normalmap`: `s` is `dPdu` made
    /// orthogonal to `N` (Gram-Schmidt), `t = N x s` turned to `dPdv`'s side
    /// (a mirrored layout keeps green along +v). The subtree sees the unit
    /// result as N; a flat texel, a zero or a NaN result keeps N. Also
    /// returns whether N was tilted.
    pub(super) fn normal_map_ctx(
        &mut self,
        b: &mut Builder,
        encoded: &[Value],
        strength: Value,
        convention: NormalMapConvention,
        ctx: &Ctx,
    ) -> (Ctx, Value) {
        let (zero, one, two) = (b.f(0.0), b.f(1.0), b.f(2.0));
        let decoded: Vec<Value> = encoded
            .iter()
            .map(|c| {
                let twice = b.fmul(*c, two);
                b.fsub(twice, one)
            })
            .collect();
        let x = b.fmul(decoded[0], strength);
        let y = b.fmul(decoded[1], strength);
        let y = match convention {
            NormalMapConvention::OpenGl => y,
            NormalMapConvention::DirectX => b.un(UnOp::FNeg, y),
        };
        let z = b.fmax(decoded[2], zero);
        let g = |me: &mut Self, b: &mut Builder, name: &str| me.shading_global(b, ctx, name);
        let (dpdu, dpdv, n) = (g(self, b, "dPdu"), g(self, b, "dPdv"), g(self, b, "N"));
        let along_n = b.dot(&n, &dpdu);
        let n_part = b.scale(&n, along_n);
        let s = b.map2(BinOp::FSub, &dpdu, &n_part);
        let s = b.normalize(&s);
        let t = b.cross(&n, &s);
        let t_side = b.dot(&t, &dpdv);
        let mirrored = b.flt(t_side, zero);
        let t: Vec<Value> = t
            .iter()
            .map(|tk| {
                let neg = b.un(UnOp::FNeg, *tk);
                b.select(mirrored, neg, *tk)
            })
            .collect();
        let xs = b.scale(&s, x);
        let yt = b.scale(&t, y);
        let zn = b.scale(&n, z);
        let w = b.map2(BinOp::FAdd, &xs, &yt);
        let w = b.map2(BinOp::FAdd, &w, &zn);
        let len2 = b.dot(&w, &w);
        let nonzero = b.flt(zero, len2);
        // No tangential part (a flat texel, strength 0): N itself, bit for
        // bit, rather than N renormalised.
        let (flat_x, flat_y) = (b.feq(x, zero), b.feq(y, zero));
        let flat = b.and(flat_x, flat_y);
        let tilted = b.not(flat);
        let keep_tilt = b.and(nonzero, tilted);
        let unit = b.normalize(&w);
        let new_n: Vec<Value> = (0..3).map(|k| b.select(keep_tilt, unit[k], n[k])).collect();
        (self.with_overrides(b, ctx, vec![("N", new_n)]), keep_tilt)
    }
}

/// The shadowing of a tilted shading normal (Conty Estevez, Lecocq and
/// Stein, "A Microfacet-Based Shadowing Function to Solve the Bump
/// Terminator Problem", Ray Tracing Gems 2019, as Mitsuba 3's `normalmap`
/// and Cycles apply it): the light from `wi` reaching a surface whose
/// normal `n` was turned to `mapped` is weighted by
/// `2 / (1 + sqrt(1 + a² tan²θ))`, `a² = min(tan²(n, mapped) / 8, 1)` and
/// θ the angle of `wi` from `n`, so light grazing the unmapped surface
/// fades instead of ending at a hard terminator. 1 when `mapped` is `n`.
fn bump_shadowing(b: &mut Builder, n: &[Value], mapped: &[Value], wi: &[Value]) -> Value {
    let (zero, one) = (b.f(0.0), b.f(1.0));
    // tan² of the turn; at 90 degrees (a zero cosine) it is infinite and
    // a² below is 1.
    let cos_d = b.dot(n, mapped);
    let cos2_d = b.fmul(cos_d, cos_d);
    let sin2_d = b.fsub(one, cos2_d);
    let sin2_d = b.fmax(sin2_d, zero);
    let tan2_d = b.fdiv(sin2_d, cos2_d);
    let eighth = b.f(0.125);
    let alpha2 = b.fmul(eighth, tan2_d);
    let alpha2 = b.fmax(alpha2, zero);
    let alpha2 = b.fmin(alpha2, one);
    let len2 = b.dot(wi, wi);
    let cos_i = b.dot(n, wi);
    // wi need not be unit: tan²θ = (|wi|² - (n·wi)²) / (n·wi)².
    let cos2_i = b.fmul(cos_i, cos_i);
    let sin2_i = b.fsub(len2, cos2_i);
    let sin2_i = b.fmax(sin2_i, zero);
    let spread = b.fmul(alpha2, sin2_i);
    // alpha2 tan²θ without dividing by a zero cosine: at 90° the light is
    // fully shadowed (unless the normal did not turn).
    let grazing = b.feq(cos2_i, zero);
    let spread = b.fdiv(spread, cos2_i);
    let root_arg = b.fadd(one, spread);
    let root = b.un(UnOp::Sqrt, root_arg);
    let denom = b.fadd(one, root);
    let two = b.f(2.0);
    let g = b.fdiv(two, denom);
    let flat = b.feq(alpha2, zero);
    let g = b.select(grazing, zero, g);
    b.select(flat, one, g)
}

/// The step of the forward differences in `bump`, in (u, v) units.
pub const BUMP_DELTA: f32 = 1.0 / 1024.0;

pub(super) fn empty_def() -> &'static ast::MaterialDef {
    static EMPTY: std::sync::OnceLock<ast::MaterialDef> = std::sync::OnceLock::new();
    EMPTY.get_or_init(|| ast::MaterialDef {
        name: ast::Ident { name: ast::Name::default(), span: Span::default() },
        params: Vec::new(),
        methods: Vec::new(),
        span: Span::default(),
    })
}
