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

/// A method of a hit group. Every one reads the hit inputs `wo` and `eta`
/// where the interface method takes them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum HitMethod {
    /// An interface method by name (`reflection`, `sample`, `emission`, ...).
    Interface(&'static str),
    /// `f · cos` for unit light from `wi` and the material's pdf
    /// (see [`lower_eval_pdf`]): argument `wi`.
    EvalPdf,
    /// Both perfect directions and their weights (see [`lower_delta_lobes`]).
    DeltaLobes,
    /// `reflection` summed over this many lights (see [`lower_reflection_sums`]):
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
    let mut lw = Lowerer::new(program, model);
    let groups = materials.iter().map(|(name, expr)| lw.hit_group(name, Mat::of_root(expr), methods)).collect();
    (groups, lw.diags)
}

impl<'p> Lowerer<'p> {
    fn hit_group(&mut self, name: &str, mat: Mat<'p>, methods: &[HitMethod]) -> HitGroup {
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
                    let Some(im) = interface_method(m) else { continue };
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
        // not once per method in sibling branches.
        let choice = self.root_select(&mut b, &mat, &ctx);
        let results = match &choice {
            Some(hits) => {
                self.under_choice(&mut b, hits, &mut |me, b| me.hit_methods(b, &mat, &lowered, &wo, &eta, &ctx))
            }
            None => self.hit_methods(&mut b, &mat, &lowered, &wo, &eta, &ctx),
        };
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
        let combined = b.finish();
        HitGroup { split: split::split(&combined, hit_words, &parts), combined, entries }
    }

    /// The result type of a method in a group.
    fn hit_ret(&self, method: HitMethod) -> Ty {
        match method {
            HitMethod::Interface(m) => interface_method(m).map_or(Ty::Float, |im| im.ret.clone()),
            HitMethod::EvalPdf => Ty::Array(Box::new(Ty::Float), self.lanes as u32 + 1),
            // Both directions and their responses.
            HitMethod::DeltaLobes => Ty::Array(Box::new(Ty::Float), 6 + 2 * self.lanes as u32),
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
                    let Some(im) = interface_method(m) else { continue };
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

    /// The conditions of a `select` at the root of `mat` (named or not),
    /// `hits[k]` true for child k; `None` for any other root.
    fn root_select(&mut self, b: &mut Builder, mat: &Mat<'p>, ctx: &Ctx) -> Option<Vec<Value>> {
        match &mat.expr.kind {
            ExprKind::Name(n) => {
                if let Some(Val::Material(m)) = mat.env.get(n.as_str()) {
                    let m = m.clone();
                    return self.root_select(b, &m, ctx);
                }
                let sym = self.symbol(mat.in_prelude, n)?;
                let Item::MaterialTree(t) = self.item(sym) else { return None };
                let m = Mat { expr: &t.body, env: Rc::new(HashMap::default()), in_prelude: self.is_prelude(sym) };
                self.root_select(b, &m, ctx)
            }
            ExprKind::Call { callee, args: call_args } => {
                if self.program.resolutions.get(&callee.span).is_some() {
                    return None;
                }
                let node = self.program.builtin_calls.get(&callee.span).and_then(|f| f.tree_node())?;
                if node != TreeNode::Select {
                    return None;
                }
                let (index, items) = self.select_parts(mat, call_args);
                let index = index?;
                if items.len() < 2 {
                    return None;
                }
                // As `tree_node` computes it: the same values, numbered once.
                let i = self.node_scalar(b, mat, index, ctx);
                let i = self.clamp_index(b, i, items.len() as i32);
                // Each method's choice only when it is point-only (it is
                // for every index a checked program can give, but a
                // per-call one would not fold).
                if b.is_per_call(i) {
                    return None;
                }
                Some(
                    (0..items.len() - 1)
                        .map(|k| {
                            let kv = b.i(k as i32);
                            b.bin(BinOp::IEq, i, kv)
                        })
                        .collect(),
                )
            }
            _ => None,
        }
    }

    /// `lower` under the chain of branches `hits` (as `select_child`
    /// makes), with each branch's outcome known inside it.
    fn under_choice(
        &mut self,
        b: &mut Builder,
        hits: &[Value],
        lower: &mut dyn FnMut(&mut Self, &mut Builder) -> Vec<Value>,
    ) -> Vec<Value> {
        let Some((&hit, rest)) = hits.split_first() else { return lower(self, b) };
        let mut then_vals = Vec::new();
        let mut then_body = b.nested_under(&[hit], |b| {
            b.facts.push((hit, true));
            then_vals = lower(self, b);
            b.facts.pop();
        });
        let vars: Vec<Var> = then_vals.iter().map(|v| b.var(b.ty(*v))).collect();
        then_body.extend(vars.iter().zip(&then_vals).map(|(var, v)| Inst::Set(*var, *v)));
        let else_body = b.nested_under(&[hit], |b| {
            b.facts.push((hit, false));
            let vals = self.under_choice(b, rest, lower);
            b.facts.pop();
            for (var, v) in vars.iter().zip(&vals) {
                b.push(Inst::Set(*var, *v));
            }
        });
        b.push(Inst::If { cond: hit, then_body, else_body });
        vars.iter().map(|v| b.get(*v)).collect()
    }
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
        HitMethod::Interface(m) => m.to_string(),
        HitMethod::EvalPdf => "eval_pdf".into(),
        HitMethod::DeltaLobes => "delta_lobes".into(),
        HitMethod::ReflectionSum(k) => format!("reflection_sum{k}"),
    }
}
