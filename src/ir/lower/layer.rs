//! `layer(top, base)`: one material over another, the base weighted by what
//! the top lets through (MaterialX 1.39's `layer` with albedo scaling,
//! OpenPBR's coat), and the default `albedo` of a material that defines
//! none, which the node needs of its top.
//!
//! The model is MaterialX's, one-sided: `f = f_top + (1 - E_top(wo)) f_base`,
//! with `E_top(wo)` the top's directional albedo toward the viewer
//! (`albedo(wo)`, clamped to [0, 1] per lane). A top that absorbs nothing
//! over a white lambert base then reflects all the light (the white furnace
//! gives exactly 1); the reciprocal form `(1 - E(wi)) (1 - E(wo)) f_base`
//! loses the top's average albedo unless divided by a table of it, which a
//! user's top cannot give. The price is an `f` that is not symmetric in
//! `wi` and `wo`, which a path tracer that evaluates with `wo` toward the
//! eye (TSL's, and MaterialX's renderers) does not see.
//!
//! Sampling is a mixture, as `mix`'s (docs/language.md, "How nodes
//! sample"): the top with probability `P = ē / (ē + t̄ h)`, `ē` and `t̄`
//! the means of `E_top(wo)` and `1 - E_top(wo)`, `h` the base's
//! `diffuse()` clamped to [0.05, 1] (the hint default sampling takes; the
//! base's own albedo could be a 64-sample estimate); the pdf is `P pdf_top + (1 - P) pdf_base`, and a smooth
//! sample's weight is the node's own `f · cos / pdf`. A delta sample is the
//! chosen child's alone: the top's divided by `P` (none when it goes
//! through the surface: what the top transmits is the base's part), the
//! base's times `(1 - E_top(wo)) / (1 - P)`.

use super::sampling::{ONE_MINUS_EPSILON, Sample};
use super::*;

/// How many fixed points the default `albedo` averages the material's own
/// `sample` over: a rank-1 lattice (Roberts' R3 sequence) in the lobe and
/// direction numbers, in one loop, so the sampling code is inlined once.
pub const ALBEDO_SAMPLES: i32 = 64;

/// Roberts' R3 sequence: `fract(0.5 + k a)` with `a = (1/g, 1/g², 1/g³)`,
/// `g` the real root of `x⁴ = x + 1`; low discrepancy in three dimensions
/// for any number of points.
const R3: [f32; 3] = [0.819_172_5, 0.671_043_5, 0.549_700_5];

impl<'p> Lowerer<'p> {
    /// Method `im` of `layer(top, base)` (the node `node`).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn layer_node(
        &mut self,
        b: &mut Builder,
        node: &Mat<'p>,
        top: &Mat<'p>,
        base: &Mat<'p>,
        im: &'static InterfaceMethod,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        match im.name {
            // The body beneath the top: its interior, its refraction, its
            // normal (the surface the top follows).
            "refraction_index" | "refraction_dir" | "absorption" | "opaque" | "normal" => {
                self.mat_method(b, base, im, args, ctx)
            }
            "reflection" | "emission" | "albedo" | "refraction" | "diffuse" | "ambient" => {
                let below = self.mat_method(b, base, im, args, ctx);
                let black_below = below.iter().all(|v| b.fconst(*v) == Some(0.0));
                let wo = match im.name {
                    "reflection" => args[2].clone(),
                    "refraction" => args[3].clone(),
                    "emission" | "albedo" => args[0].clone(),
                    // No direction: the top's albedo head-on.
                    _ => self.shading_global(b, ctx, "N"),
                };
                // The top's own transmission is what reaches the base.
                let above =
                    if im.name == "refraction" { b.zeros(self.lanes) } else { self.mat_method(b, top, im, args, ctx) };
                if black_below {
                    return above;
                }
                let through = self.transmitted(b, top, &wo, ctx);
                let below = b.map2(BinOp::FMul, &through, &below);
                b.map2(BinOp::FAdd, &above, &below)
            }
            "reflection_dir" => {
                let below = self.mat_method(b, base, im, args, ctx);
                if self.uses_default(top, im, 0) {
                    return below;
                }
                let above = self.mat_method(b, top, im, args, ctx);
                let len2 = b.dot(&above, &above);
                let zero = b.f(0.0);
                let present = b.flt(zero, len2);
                b.select_lanes(present, &above, &below)
            }
            "sample" => self.sample_layer(b, node, top, base, args, ctx),
            "pdf" => {
                let (p, _) = self.layer_choice(b, top, base, &args[1], ctx);
                let (zero, one) = (b.f(0.0), b.f(1.0));
                let pdf = Method::Pdf.interface();
                let top_used = b.flt(zero, p);
                let above = b.guarded(self, top_used, vec![zero], |b, me| me.mat_method(b, top, pdf, args, ctx));
                let base_used = b.flt(p, one);
                let below = b.guarded(self, base_used, vec![zero], |b, me| me.mat_method(b, base, pdf, args, ctx));
                let q = b.fsub(one, p);
                let above = b.fmul(p, above[0]);
                let below = b.fmul(q, below[0]);
                vec![b.fadd(above, below)]
            }
            other => {
                ruled_out!("`layer` has no rule for the method `{other}`");
                self.typed_zeros(b, &im.ret)
            }
        }
    }

    /// `1 - E_top(wo)` per lane, `E_top` the top's albedo clamped to [0, 1].
    fn transmitted(&mut self, b: &mut Builder, top: &Mat<'p>, wo: &[Value], ctx: &Ctx) -> Vec<Value> {
        let e = self.mat_method(b, top, Method::Albedo.interface(), &[wo.to_vec()], ctx);
        let (zero, one) = (b.f(0.0), b.f(1.0));
        e.iter()
            .map(|x| {
                let x = b.fmax(*x, zero);
                let x = b.fmin(x, one);
                b.fsub(one, x)
            })
            .collect()
    }

    /// The probability of sampling the top, and `1 - E_top(wo)`.
    fn layer_choice(
        &mut self,
        b: &mut Builder,
        top: &Mat<'p>,
        base: &Mat<'p>,
        wo: &[Value],
        ctx: &Ctx,
    ) -> (Value, Vec<Value>) {
        let through = self.transmitted(b, top, wo, ctx);
        let one = b.f(1.0);
        let t_mean = b.mean(&through);
        let e_mean = b.fsub(one, t_mean);
        // The base's diffuse() as the hint, as default sampling takes it:
        // its albedo might be an estimate of 64 samples.
        let hint = self.mat_method(b, base, Method::Diffuse.interface(), &[], ctx);
        let hint = b.mean(&hint);
        let lo = b.f(0.05);
        let hint = b.clamp(hint, lo, one);
        let below = b.fmul(t_mean, hint);
        let total = b.fadd(e_mean, below);
        (b.safe_div(e_mean, total), through)
    }

    /// `sample` of `layer(top, base)`: see the module's documentation.
    fn sample_layer(
        &mut self,
        b: &mut Builder,
        node: &Mat<'p>,
        top: &Mat<'p>,
        base: &Mat<'p>,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let (wo, eta, u1, u2) = (&args[0], &args[1], args[2][0], &args[3]);
        let (p, through) = self.layer_choice(b, top, base, wo, ctx);
        let (zero, one, below_one) = (b.f(0.0), b.f(1.0), b.f(ONE_MINUS_EPSILON));
        let q = b.fsub(one, p);
        let pick_top = b.flt(u1, p);
        let tys = self.words(&Ty::BsdfSample);
        let outermost = !std::mem::replace(&mut self.direction_only, true);
        let chosen = b.branch(
            self,
            pick_top,
            &tys,
            |b, me| {
                let u = b.safe_div(u1, p);
                let u = b.clamp(u, zero, below_one);
                let child_args = [wo.clone(), eta.clone(), vec![u], u2.clone()];
                me.mat_method(b, top, Method::Sample.interface(), &child_args, ctx)
            },
            |b, me| {
                let shifted = b.fsub(u1, p);
                let u = b.safe_div(shifted, q);
                let u = b.clamp(u, zero, below_one);
                let child_args = [wo.clone(), eta.clone(), vec![u], u2.clone()];
                me.mat_method(b, base, Method::Sample.interface(), &child_args, ctx)
            },
        );
        self.direction_only = !outermost;
        let s = Sample::split(&chosen, self.lanes);
        let is_delta = b.flt(zero, s.delta);
        // A delta lobe is the chosen child's alone.
        let top_weight: Vec<Value> = s.weight.iter().map(|w| b.safe_div(*w, p)).collect();
        let base_weight: Vec<Value> = s
            .weight
            .iter()
            .zip(&through)
            .map(|(w, t)| {
                let wt = b.fmul(*w, *t);
                b.safe_div(wt, q)
            })
            .collect();
        let delta_weight = b.select_lanes(pick_top, &top_weight, &base_weight);
        let weight = b.select_lanes(is_delta, &delta_weight, &s.weight);
        // The top's delta transmission is not the layer's: the base is.
        let same = self.same_side(b, &s.wi, wo, ctx);
        let through_top = b.not(same);
        let top_delta = b.and(pick_top, is_delta);
        let dropped = b.and(top_delta, through_top);
        let none = self.no_sample(b);
        let chosen = Sample { weight, ..s };
        if !outermost {
            let lanes = chosen.lanes();
            return b.select_lanes(dropped, &none, &lanes);
        }
        let result = self.weigh_by_node(b, node, chosen, is_delta, args, ctx);
        b.select_lanes(dropped, &none, &result)
    }

    /// The default `albedo(wo)` of a material instance: the mean weight of
    /// its own `sample(wo, eta, u1, u2)` over [`ALBEDO_SAMPLES`] fixed
    /// points, counting the directions on `wo`'s side of `Ng` (reflection
    /// only), `eta` its `refraction_index()` seen from `wo`. Unbiased for
    /// random points, so within a few percent for smooth lobes; a lobe
    /// chosen with a small probability (a smooth coat's Fresnel
    /// reflection) is hit by few points, which is why such materials
    /// define `albedo` themselves.
    pub(super) fn default_albedo(
        &mut self,
        b: &mut Builder,
        inst: &Rc<Instance<'p>>,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let wo = &args[0];
        let index = self.instance_method(b, inst, Method::RefractionIndex.interface(), &[], ctx);
        let ng = self.shading_global(b, ctx, "Ng");
        let (zero, half, one) = (b.f(0.0), b.f(0.5), b.f(1.0));
        let facing = b.dot(wo, &ng);
        let inside = b.flt(facing, zero);
        let eta: Vec<Value> = index
            .iter()
            .map(|x| {
                let inverse = b.fdiv(one, *x);
                b.select(inside, inverse, *x)
            })
            .collect();
        let sums: Vec<Var> = (0..self.lanes).map(|_| b.var(Scalar::F32)).collect();
        for sum in &sums {
            b.push(Inst::Set(*sum, zero));
        }
        let (lo, hi) = (b.i(0), b.i(ALBEDO_SAMPLES));
        let label = b.label();
        let counter = b.var(Scalar::I32);
        b.note_loop_counter(counter, [lo, hi]);
        let body = b.nested_under(&[lo, hi], |b| {
            let k = b.get(counter);
            let k = b.un(UnOp::IToF, k);
            let point: Vec<Value> = R3
                .iter()
                .map(|a| {
                    let a = b.f(*a);
                    let x = b.fmul(k, a);
                    let x = b.fadd(x, half);
                    let whole = b.un(UnOp::Floor, x);
                    b.fsub(x, whole)
                })
                .collect();
            let sample_args = [wo.clone(), eta.clone(), vec![point[0]], vec![point[1], point[2]]];
            let s = self.instance_method(b, inst, Method::Sample.interface(), &sample_args, ctx);
            let s = Sample::split(&s, self.lanes);
            let same = self.same_side(b, &s.wi, wo, ctx);
            for (sum, w) in sums.iter().zip(&s.weight) {
                let counted = b.select(same, *w, zero);
                let old = b.get(*sum);
                let new = b.fadd(old, counted);
                b.push(Inst::Set(*sum, new));
            }
        });
        b.push(Inst::Loop { label, counter, start: lo, end: hi, body });
        let scale = b.f(1.0 / ALBEDO_SAMPLES as f32);
        sums.iter()
            .map(|sum| {
                let total = b.get(*sum);
                b.fmul(total, scale)
            })
            .collect()
    }
}
