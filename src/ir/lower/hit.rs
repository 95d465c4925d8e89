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
        let mut parts = Vec::new();
        let mut entries = Vec::new();
        let mut outputs: Vec<(Scalar, Value)> = Vec::new();
        for &method in methods {
            let first_param = b.func.params.len() as u32;
            let first_result = outputs.len() as u32;
            let (params, ret) = match method {
                HitMethod::Interface(m) => {
                    let Some(im) = interface_method(m) else { continue };
                    let own: Vec<(String, Ty)> = im
                        .params
                        .iter()
                        .filter(|(n, _)| !matches!(*n, "wo" | "eta"))
                        .map(|(n, t)| (n.to_string(), t.clone()))
                        .collect();
                    let mut own_args = self.method_args(&mut b, &own).into_iter();
                    let args: Vec<Vec<Value>> = im
                        .params
                        .iter()
                        .map(|(n, _)| match *n {
                            "wo" => wo.clone(),
                            "eta" => eta.clone(),
                            _ => own_args.next().unwrap_or_default(),
                        })
                        .collect();
                    let result = self.mat_method(&mut b, &mat, im, &args, &ctx);
                    outputs.extend(self.words(&im.ret).into_iter().zip(result));
                    (own, im.ret.clone())
                }
                HitMethod::EvalPdf => {
                    let own = vec![("wi".to_string(), Ty::Vector)];
                    let wi = self.method_args(&mut b, &own).remove(0);
                    let results = self.eval_pdf(&mut b, &mat, &wi, &wo, &eta, &ctx);
                    (own, self.float_words(&mut outputs, results))
                }
                HitMethod::DeltaLobes => {
                    let lobes = self.delta_lobes(&mut b, &mat, &wo, &eta, &ctx);
                    (Vec::new(), self.float_words(&mut outputs, lobes))
                }
                HitMethod::ReflectionSum(lights) => {
                    let mut own = Vec::new();
                    for k in 0..lights {
                        own.push((format!("wi{k}"), Ty::Vector));
                        own.push((format!("light{k}"), Ty::Color));
                    }
                    let args = self.method_args(&mut b, &own);
                    let sum = self.reflection_sum(&mut b, &mat, &args, &wo, &ctx);
                    outputs.extend(self.words(&Ty::Color).into_iter().zip(sum));
                    (own, Ty::Color)
                }
            };
            parts.push(Part {
                name: format!("{name}.hit.{}", method_name(method)),
                params: first_param..b.func.params.len() as u32,
                results: first_result..outputs.len() as u32,
            });
            entries.push(HitEntry { method, params, ret });
        }
        b.func.results = outputs.iter().map(|(t, _)| *t).collect();
        for (k, (_, v)) in outputs.iter().enumerate() {
            b.push(Inst::Output(k as u32, *v));
        }
        let combined = b.finish();
        HitGroup { split: split::split(&combined, hit_words, &parts), combined, entries }
    }

    /// Appends `results` as float words; the array type hosts read them as.
    fn float_words(&self, outputs: &mut Vec<(Scalar, Value)>, results: Vec<Value>) -> Ty {
        let n = results.len() as u32;
        outputs.extend(results.into_iter().map(|v| (Scalar::F32, v)));
        Ty::Array(Box::new(Ty::Float), n)
    }
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
