//! Hit groups: the methods a renderer calls at one hit, lowered into one
//! combined function and split into a per-hit `prepare` and the methods
//! (`ir::split`). Lowering them together is what lets the split find one
//! texture tree to hoist: the memo and value numbering of one builder
//! already share the generators, lookups and normals every method reads.

use super::*;
use crate::ir::split::{self, Part, Split};

/// Noise sites expanded inline in a hit group (a function's default is
/// four): its `prepare` holds a whole tree's generators, a `select` of
/// several trees more (texture_tree's cube has 44), and runs once per hit.
/// Inline noise is f32 arithmetic, the native's f64 (within 1e-6). All
/// 44 inline made texture_tree's path tracing 6% faster than 16 did, for
/// 10 ms more scene build; 64 bounds a group's code at about 10,000
/// operations of noise.
pub const HIT_NOISE_INLINE_SITES: u32 = 64;

/// How many more times a hit group may lower its methods for the cases of
/// `mix` nodes at the root (two per node: t = 0 and t = 1): texture_tree's
/// cube, a `select` over three such mixes, takes six.
pub const HIT_MIX_COPIES: usize = 8;

/// A method of a hit group. Every one reads the hit inputs `wo` and `eta`
/// where the interface method takes them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum HitMethod {
    /// An interface method (`reflection`, `sample`, `emission`, ...).
    Interface(Method),
    /// `f · cos` for unit light from `wi` and the material's pdf
    /// (as [`Program::eval_pdf`](crate::Program::eval_pdf) compiles it
    /// alone): argument `wi`.
    EvalPdf,
    /// Both perfect directions and their weights (as
    /// [`Program::delta_lobes`](crate::Program::delta_lobes) compiles them alone).
    DeltaLobes,
    /// `reflection` summed over this many lights (as
    /// [`Program::reflection_sums`](crate::Program::reflection_sums) compiles it alone):
    /// arguments `wi_1, light_1, ...`.
    ReflectionSum(usize),
}

/// One material's hit group: `prepare`, and one function per method.
#[derive(Debug, Clone)]
pub struct HitGroup {
    /// Every method in one function, before the split: arguments
    /// `[wo, eta | each method's own]`, results each method's in turn.
    pub combined: Function,
    pub split: Split,
    /// One per method of `split.methods`, in order.
    pub entries: Vec<HitEntry>,
}

/// A method of a hit group: its own arguments (after the hit record) and
/// its result.
#[derive(Debug, Clone)]
pub struct HitEntry {
    pub method: HitMethod,
    pub params: Vec<(String, Ty)>,
    pub ret: Ty,
}

/// The hit inputs every method of a group shares: `prepare`'s arguments.
pub fn hit_inputs() -> Vec<(String, Ty)> {
    vec![("wo".into(), Ty::Vector), ("eta".into(), Ty::Color)]
}

/// Lowers one hit group per material expression, named `NAME.hit`.
pub fn lower_hit_groups(
    program: &Program,
    model: ColorModel,
    materials: &[(String, &Expr)],
    methods: &[HitMethod],
) -> (Vec<HitGroup>, Vec<Diagnostic>) {
    lower_hit_groups_with(program, model, materials, methods, true)
}

/// [`lower_hit_groups`], with the cases of root `mix` nodes
/// ([`HIT_MIX_COPIES`]) only when `mix_choices`: they save a long render
/// about a tenth of a textured tree's time, but lower its methods up to
/// three times, which a quick preview's scene build would pay for more.
pub fn lower_hit_groups_with(
    program: &Program,
    model: ColorModel,
    materials: &[(String, &Expr)],
    methods: &[HitMethod],
    mix_choices: bool,
) -> (Vec<HitGroup>, Vec<Diagnostic>) {
    let mut lw = Lowerer::new(program, model);
    let copies = if mix_choices { HIT_MIX_COPIES } else { 0 };
    let groups = materials.iter().map(|(name, expr)| lw.hit_group(name, Mat::of_root(expr), methods, copies)).collect();
    (groups, lw.diags)
}

impl<'p> Lowerer<'p> {
    fn hit_group(&mut self, name: &str, mat: Mat<'p>, methods: &[HitMethod], copies: usize) -> HitGroup {
        let diags = self.diags.len();
        let mut choices = MixChoices { copies, conds: Vec::new() };
        let group = self.hit_group_with(name, mat.clone(), methods, &mut choices);
        if choices.conds.is_empty() || costly_under(&group.combined.body, &choices.conds) {
            return group;
        }
        // The chosen children compute no texture or noise: the cases would
        // only add code (and a branch per call).
        self.diags.truncate(diags);
        self.hit_group_with(name, mat, methods, &mut MixChoices { copies: 0, conds: Vec::new() })
    }

    fn hit_group_with(
        &mut self,
        name: &str,
        mat: Mat<'p>,
        methods: &[HitMethod],
        choices: &mut MixChoices,
    ) -> HitGroup {
        let mut b = Builder::new(&format!("{name}.hit"));
        let inputs = self.method_args(&mut b, &hit_inputs());
        let (wo, eta) = (inputs[0].clone(), inputs[1].clone());
        let hit_words = b.func.params.len() as u32;
        b.hoist_above_per_call(hit_words);
        b.noise_budget = HIT_NOISE_INLINE_SITES;
        let ctx = self.root_ctx();
        // Every method's own arguments first: they are parameters, read
        // wherever the methods are lowered.
        let mut lowered = Vec::new();
        for &method in methods {
            let first_param = b.func.params.len() as u32;
            let (own, args) = match method {
                HitMethod::Interface(m) => {
                    let im = m.interface();
                    let own: Vec<(String, Ty)> = im
                        .params
                        .iter()
                        .filter(|(n, _)| !matches!(*n, "wo" | "eta"))
                        .map(|(n, t)| (n.to_string(), t.clone()))
                        .collect();
                    let args = self.method_args(&mut b, &own);
                    (own, args)
                }
                HitMethod::EvalPdf => {
                    let own = vec![("wi".to_string(), Ty::Vector)];
                    let args = self.method_args(&mut b, &own);
                    (own, args)
                }
                HitMethod::DeltaLobes => (Vec::new(), Vec::new()),
                HitMethod::ReflectionSum(lights) => {
                    let mut own = Vec::new();
                    for k in 0..lights {
                        own.push((format!("wi{k}"), Ty::Vector));
                        own.push((format!("light{k}"), Ty::Color));
                    }
                    let args = self.method_args(&mut b, &own);
                    (own, args)
                }
            };
            lowered.push(HitCall { method, own, args, params: first_param..b.func.params.len() as u32 });
        }
        // A `select` at the root (a box with a material per face) lowers
        // every method under one branch per child: each method's own
        // choice folds there, so the child's generators are lowered once,
        // not once per method in sibling branches. So does a `mix` at a
        // weight of 0 or 1 (a checker of two materials): `sample` then
        // draws no lobe between the children, so `prepare` computes only
        // the chosen child's generators.
        let results = self.under_choices(&mut b, &mat, &ctx, choices, &mut |me, b| {
            me.hit_methods(b, &mat, &lowered, &wo, &eta, &ctx)
        });
        let mut parts = Vec::new();
        let mut entries = Vec::new();
        let mut outputs: Vec<(Scalar, Value)> = Vec::new();
        let mut results = results.into_iter();
        for call in lowered {
            let first_result = outputs.len() as u32;
            let ret = self.hit_ret(call.method);
            for t in self.hit_words_of(call.method, &ret) {
                let v = results.next().unwrap_or_else(|| b.f(0.0));
                outputs.push((t, v));
            }
            parts.push(Part {
                name: format!("{name}.hit.{}", method_name(call.method)),
                params: call.params,
                results: first_result..outputs.len() as u32,
            });
            entries.push(HitEntry { method: call.method, params: call.own, ret });
        }
        b.func.results = outputs.iter().map(|(t, _)| *t).collect();
        for (k, (_, v)) in outputs.iter().enumerate() {
            b.push(Inst::Output(k as u32, *v));
        }
        let combined = self.finish_entry(b, mat.expr.span, "this material");
        HitGroup { split: split::split(&combined, hit_words, &parts), combined, entries }
    }

    /// The result type of a method in a group.
    fn hit_ret(&self, method: HitMethod) -> Ty {
        match method {
            HitMethod::Interface(m) => m.interface().ret.clone(),
            HitMethod::EvalPdf => Ty::Array(Box::new(Ty::Float), EvalPdfLayout { lanes: self.lanes }.words() as u32),
            HitMethod::DeltaLobes => {
                Ty::Array(Box::new(Ty::Float), DeltaLobesLayout { lanes: self.lanes }.words() as u32)
            }
            HitMethod::ReflectionSum(_) => Ty::Color,
        }
    }

    /// The result words of a method: floats for the arrays hosts read.
    fn hit_words_of(&self, method: HitMethod, ret: &Ty) -> Vec<Scalar> {
        match method {
            HitMethod::Interface(_) | HitMethod::ReflectionSum(_) => self.words(ret),
            HitMethod::EvalPdf | HitMethod::DeltaLobes => match ret {
                Ty::Array(_, n) => vec![Scalar::F32; *n as usize],
                _ => Vec::new(),
            },
        }
    }

    /// Every method of a group lowered on `mat` in turn: their results,
    /// one list.
    fn hit_methods(
        &mut self,
        b: &mut Builder,
        mat: &Mat<'p>,
        calls: &[HitCall],
        wo: &[Value],
        eta: &[Value],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let mut out = Vec::new();
        for call in calls {
            let words = self.hit_words_of(call.method, &self.hit_ret(call.method)).len();
            let mut result = match call.method {
                HitMethod::Interface(m) => {
                    let im = m.interface();
                    let mut own_args = call.args.iter();
                    let args: Vec<Vec<Value>> = im
                        .params
                        .iter()
                        .map(|(n, _)| match *n {
                            "wo" => wo.to_vec(),
                            "eta" => eta.to_vec(),
                            _ => own_args.next().cloned().unwrap_or_default(),
                        })
                        .collect();
                    self.mat_method(b, mat, im, &args, ctx)
                }
                HitMethod::EvalPdf => {
                    let wi = call.args.first().cloned().unwrap_or_default();
                    self.eval_pdf(b, mat, &wi, wo, eta, ctx)
                }
                HitMethod::DeltaLobes => self.delta_lobes(b, mat, wo, eta, ctx),
                HitMethod::ReflectionSum(_) => self.reflection_sum(b, mat, &call.args, wo, ctx),
            };
            // The declared words, whatever lowering gave (never different
            // once checked).
            result.resize_with(words, || b.f(0.0));
            out.extend(result);
        }
        out
    }

    /// The point-only choice at the root of `mat`, through names,
    /// templates and `scale`: `select`'s index, or (when `mix`) `mix`'s
    /// weight at 0 or 1.
    fn root_choice(&mut self, b: &mut Builder, mat: &Mat<'p>, ctx: &Ctx, mix: bool) -> Option<RootChoice<'p>> {
        match &mat.expr.kind {
            ExprKind::Name(n) => {
                if let Some(Val::Material(m)) = mat.env.get(n.as_str()) {
                    let m = m.clone();
                    return self.root_choice(b, &m, ctx, mix);
                }
                let sym = self.symbol(mat.in_prelude, n)?;
                let Item::MaterialTree(t) = self.item(sym) else { return None };
                let m = Mat { expr: &t.body, env: Rc::new(HashMap::default()), in_prelude: self.is_prelude(sym) };
                self.root_choice(b, &m, ctx, mix)
            }
            ExprKind::Call { callee, args: call_args } => {
                if let Some(sym) = self.program.resolutions.get(&callee.span).copied() {
                    // A template: its body with its parameters bound, as
                    // `mat_method` binds them (the same values, numbered once).
                    let Item::MaterialTree(t) = self.item(sym) else { return None };
                    let env = self.template_env(b, t, call_args, mat, ctx);
                    let m = Mat { expr: &t.body, env, in_prelude: self.is_prelude(sym) };
                    return self.root_choice(b, &m, ctx, mix);
                }
                let node = self.program.builtin_calls.get(&callee.span).and_then(|f| f.tree_node())?;
                let bound = bind_builtin_args(node.builtin(), call_args);
                let child = |k: usize| {
                    bound.get(k).copied().flatten().map(|e| Mat {
                        expr: e,
                        env: mat.env.clone(),
                        in_prelude: mat.in_prelude,
                    })
                };
                match node {
                    TreeNode::Select => self.root_select(b, mat, call_args, ctx),
                    TreeNode::Scale => self.root_choice(b, &child(1)?, ctx, mix),
                    // Not a partial blend (`only:`), which samples as `a`.
                    TreeNode::Mix if mix && bound.get(3).copied().flatten().is_none() => {
                        let (a, c) = (child(1)?, child(2)?);
                        // `mix(t, m, m)` is `m` at every weight: no choice.
                        if self.same_material(&a, &c) {
                            return None;
                        }
                        // As `tree_node` computes it: the same values, numbered once.
                        let t = self.node_float(b, mat, bound.first().copied().flatten()?, ctx);
                        if b.is_per_call(t) {
                            return None;
                        }
                        let (zero, one) = (b.f(0.0), b.f(1.0));
                        let (is_zero, is_one) = (b.feq(t, zero), b.feq(t, one));
                        Some(RootChoice::Mix { is_zero, is_one, a, c })
                    }
                    _ => None,
                }
            }
            _ => None,
        }
    }

    /// The choice of a `select` (`call_args`) at the root.
    fn root_select(
        &mut self,
        b: &mut Builder,
        mat: &Mat<'p>,
        call_args: &'p [ast::Arg],
        ctx: &Ctx,
    ) -> Option<RootChoice<'p>> {
        let (index, items) = self.select_parts(mat, call_args);
        let index = index?;
        if items.len() < 2 {
            return None;
        }
        // As `tree_node` computes it: the same values, numbered once.
        let i = self.node_scalar(b, mat, index, ctx);
        let i = self.clamp_index(b, i, items.len() as i32);
        // Each method's choice only when it is point-only (it is for every
        // index a checked program can give, but a per-call one would not
        // fold).
        if b.is_per_call(i) {
            return None;
        }
        let hits = (0..items.len() - 1)
            .map(|k| {
                let kv = b.i(k as i32);
                b.bin(BinOp::IEq, i, kv)
            })
            .collect();
        Some(RootChoice::Select { hits, items })
    }

    /// `lower` under the root choice of `mat` and, inside each branch, the
    /// chosen child's own (each branch's outcome known inside it, so each
    /// method's own branch on it folds). `choices.copies` bounds how many more
    /// times a `mix`'s three cases may lower the methods again.
    fn under_choices(
        &mut self,
        b: &mut Builder,
        mat: &Mat<'p>,
        ctx: &Ctx,
        choices: &mut MixChoices,
        lower: &mut LowerMethods<'_, 'p>,
    ) -> Vec<Value> {
        match self.root_choice(b, mat, ctx, choices.copies >= 2) {
            None => lower(self, b),
            Some(RootChoice::Select { hits, items }) => {
                let cases: Vec<Case<'p>> = hits
                    .iter()
                    .zip(&items)
                    .map(|(h, m)| Case { cond: *h, facts: vec![(*h, true)], next: Some(m.clone()) })
                    .collect();
                self.under_cases(b, &cases, items.last(), ctx, choices, lower)
            }
            Some(RootChoice::Mix { is_zero, is_one, a, c }) if choices.copies >= 2 => {
                choices.copies -= 2;
                choices.conds.extend([is_zero, is_one]);
                let cases = [
                    Case { cond: is_zero, facts: vec![(is_zero, true), (is_one, false)], next: Some(a) },
                    Case { cond: is_one, facts: vec![(is_one, true)], next: Some(c) },
                ];
                // Between (or at a NaN), both children, as without the choice.
                self.under_cases(b, &cases, None, ctx, choices, lower)
            }
            Some(RootChoice::Mix { .. }) => lower(self, b),
        }
    }

    /// `if cases[0].cond { next } else if cases[1].cond { ... } else { last }`,
    /// where `next` and `last` are lowered under their own choices (`None`:
    /// `lower` directly).
    fn under_cases(
        &mut self,
        b: &mut Builder,
        cases: &[Case<'p>],
        last: Option<&Mat<'p>>,
        ctx: &Ctx,
        choices: &mut MixChoices,
        lower: &mut LowerMethods<'_, 'p>,
    ) -> Vec<Value> {
        let mut next = |me: &mut Self, b: &mut Builder, m: Option<&Mat<'p>>, choices: &mut MixChoices| match m {
            Some(m) => me.under_choices(b, m, ctx, choices, lower),
            None => lower(me, b),
        };
        let Some((case, rest)) = cases.split_first() else { return next(self, b, last, choices) };
        let depth = b.facts.len();
        match b.konst(case.cond) {
            Some(Const::B(false)) => return self.under_cases(b, rest, last, ctx, choices, lower),
            Some(Const::B(true)) => {
                b.facts.extend(&case.facts);
                let vals = next(self, b, case.next.as_ref(), choices);
                b.facts.truncate(depth);
                return vals;
            }
            _ => {}
        }
        let mut then_vals = Vec::new();
        let mut then_body = b.nested_under(&[case.cond], |b| {
            b.facts.extend(&case.facts);
            then_vals = next(self, b, case.next.as_ref(), choices);
            b.facts.truncate(depth);
        });
        let vars: Vec<Var> = then_vals.iter().map(|v| b.var(b.ty(*v))).collect();
        then_body.extend(vars.iter().zip(&then_vals).map(|(var, v)| Inst::Set(*var, *v)));
        let else_body = b.nested_under(&[case.cond], |b| {
            b.facts.push((case.cond, false));
            let vals = self.under_cases(b, rest, last, ctx, choices, lower);
            b.facts.truncate(depth);
            for (var, v) in vars.iter().zip(&vals) {
                b.push(Inst::Set(*var, *v));
            }
        });
        b.push(Inst::If { cond: case.cond, then_body, else_body });
        vars.iter().map(|v| b.get(*v)).collect()
    }
}

/// The `mix` cases of a hit group: how many more lowerings they may take,
/// and the conditions of those made (t == 0, t == 1).
struct MixChoices {
    copies: usize,
    conds: Vec<Value>,
}

/// Whether a branch taken on one of `conds` looks up a texture or
/// evaluates noise ([`Inst::is_costly`], as `api::prepared::worth_preparing`).
fn costly_under(body: &[Inst], conds: &[Value]) -> bool {
    body.iter().any(|inst| match inst {
        Inst::If { cond, then_body, else_body } => {
            (conds.contains(cond) && crate::ir::has_costly(then_body))
                || costly_under(then_body, conds)
                || costly_under(else_body, conds)
        }
        Inst::Block { body, .. } | Inst::Loop { body, .. } => costly_under(body, conds),
        _ => false,
    })
}

/// Lowers every method of a hit group on its material.
type LowerMethods<'a, 'p> = dyn FnMut(&mut Lowerer<'p>, &mut Builder) -> Vec<Value> + 'a;

/// A point-only choice at the root of a material (see `under_choices`).
enum RootChoice<'p> {
    /// `select`: `hits[k]` is true for child k, the last child otherwise.
    Select { hits: Vec<Value>, items: Vec<Mat<'p>> },
    /// `mix` at t = 0 (only `a`) and t = 1 (only `c`).
    Mix { is_zero: Value, is_one: Value, a: Mat<'p>, c: Mat<'p> },
}

/// A branch of a root choice: its condition, what is known inside it, and
/// the child chosen (`None`: no single one).
struct Case<'p> {
    cond: Value,
    facts: Vec<(Value, bool)>,
    next: Option<Mat<'p>>,
}

/// A method of a group with its own parameters, read once.
struct HitCall {
    method: HitMethod,
    own: Vec<(String, Ty)>,
    args: Vec<Vec<Value>>,
    params: std::ops::Range<u32>,
}

/// The name of a method's function in a group (`NAME.hit.sample`).
pub fn method_name(method: HitMethod) -> String {
    match method {
        HitMethod::Interface(m) => m.name().to_string(),
        HitMethod::EvalPdf => "eval_pdf".into(),
        HitMethod::DeltaLobes => "delta_lobes".into(),
        HitMethod::ReflectionSum(k) => format!("reflection_sum{k}"),
    }
}
