//! Sampling in the material interface: the defaults of `sample` and `pdf`
//! for materials that define neither, and how texture-tree nodes compose
//! sampling so that any tree stays an unbiased estimator (docs/language.md,
//! "Sampling").
//!
//! A `bsdf_sample` value is `5 + lanes` words: `wi` (3), `weight` (the
//! color model's lanes), `pdf`, and `delta` as 0 or 1 ([`SampleLayout`]).
//!
//! The rule every node keeps: a sample's weight is the node's own
//! `f · cos / pdf` at the sampled direction, with the node's own pdf. So a
//! mixture picks a child with the probability of its weight and then
//! evaluates every child at the direction drawn (Mitsuba's `blendbsdf` keeps
//! the child's weight; the mixture's pdf is what MIS needs). A delta sample
//! is the chosen child's alone: no other child has a density there.

use super::*;

/// `cos θ ≥ DELTA_CONE` counts as a delta direction: the stdlib's delta
/// lobes answer within it, so smooth samples there are not the smooth part.
const DELTA_CONE: f32 = 0.9999;

/// The largest f32 below 1: remapped random numbers stay in [0, 1).
pub(super) const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// The parts of a `bsdf_sample` value.
pub(super) struct Sample {
    pub(super) wi: Vec<Value>,
    pub(super) weight: Vec<Value>,
    pub(super) pdf: Value,
    /// 1.0 for a delta lobe, else 0.0.
    pub(super) delta: Value,
}

impl Sample {
    pub(super) fn split(lanes: &[Value], model_lanes: usize) -> Sample {
        let layout = SampleLayout { lanes: model_lanes };
        Sample {
            wi: lanes[SampleLayout::WI].to_vec(),
            weight: lanes[layout.weight()].to_vec(),
            pdf: lanes[layout.pdf()],
            delta: lanes[layout.delta()],
        }
    }

    pub(super) fn lanes(&self) -> Vec<Value> {
        SampleLayout { lanes: self.weight.len() }.assemble(&self.wi, &self.weight, self.pdf, self.delta)
    }
}

/// The perfect directions of a material that defines them, with what the
/// default sampling derives from them (as the path tracer did before
/// materials could sample themselves).
struct DeltaLobes {
    /// `reflection_dir(wo)` and `refraction_dir(wo, eta)`.
    dirs: [Vec<Value>; 2],
    /// Responses to unit light along them.
    weights: [Vec<Value>; 2],
    /// The mean of each weight (0 where there is no direction).
    means: [Value; 2],
    /// Their sum.
    total: Value,
    /// The probability of the smooth (cosine-sampled) part: the mean of
    /// `diffuse()`, clamped to [0.05, 1], against the delta weights.
    p_smooth: Value,
}

impl Builder {
    pub(super) fn mean(&mut self, lanes: &[Value]) -> Value {
        let w = vec![1.0 / lanes.len().max(1) as f32; lanes.len()];
        self.weighted(&w, lanes)
    }

    pub(super) fn select_lanes(&mut self, cond: Value, a: &[Value], b: &[Value]) -> Vec<Value> {
        a.iter().zip(b).map(|(x, y)| self.select(cond, *x, *y)).collect()
    }

    /// `x / y`, or 0 where `y` is not positive.
    pub(super) fn safe_div(&mut self, x: Value, y: Value) -> Value {
        let zero = self.f(0.0);
        let positive = self.flt(zero, y);
        let q = self.fdiv(x, y);
        self.select(positive, q, zero)
    }

    /// A cosine-distributed direction about the unit normal `n` for the
    /// random point `u`, and its cosine with `n` (pdf = cosine / π).
    fn cosine_about(&mut self, n: &[Value], u: &[Value]) -> (Vec<Value>, Value) {
        let r = self.un(UnOp::Sqrt, u[0]);
        let tau = self.f(std::f32::consts::TAU);
        let phi = self.fmul(tau, u[1]);
        let (c, s) = (self.call("tsl_cos", vec![phi]), self.call("tsl_sin", vec![phi]));
        let x = self.fmul(r, c);
        let y = self.fmul(r, s);
        let one = self.f(1.0);
        let zero = self.f(0.0);
        let z2 = self.fsub(one, u[0]);
        let z2 = self.fmax(z2, zero);
        let z = self.un(UnOp::Sqrt, z2);
        let (t, bt) = self.tangent_frame(n);
        let wi = (0..3)
            .map(|k| {
                let a = self.fmul(x, t[k]);
                let b = self.fmul(y, bt[k]);
                let c = self.fmul(z, n[k]);
                let ab = self.fadd(a, b);
                self.fadd(ab, c)
            })
            .collect();
        (wi, z)
    }

    /// Two unit tangents completing the unit normal `n` to a right-handed
    /// frame (Duff et al. 2017, branchless).
    fn tangent_frame(&mut self, n: &[Value]) -> (Vec<Value>, Vec<Value>) {
        let (zero, one, minus) = (self.f(0.0), self.f(1.0), self.f(-1.0));
        let below = self.flt(n[2], zero);
        let sign = self.select(below, minus, one);
        let denom = self.fadd(sign, n[2]);
        let a = self.fdiv(minus, denom);
        let xy = self.fmul(n[0], n[1]);
        let bxy = self.fmul(xy, a);
        let xx = self.fmul(n[0], n[0]);
        let xxa = self.fmul(xx, a);
        let sxxa = self.fmul(sign, xxa);
        let t0 = self.fadd(one, sxxa);
        let t1 = self.fmul(sign, bxy);
        let sx = self.fmul(sign, n[0]);
        let t2 = self.un(UnOp::FNeg, sx);
        let yy = self.fmul(n[1], n[1]);
        let yya = self.fmul(yy, a);
        let b1 = self.fadd(sign, yya);
        let b2 = self.un(UnOp::FNeg, n[1]);
        (vec![t0, t1, t2], vec![bxy, b1, b2])
    }
}

impl<'p> Lowerer<'p> {
    fn ones(&self, b: &mut Builder) -> Vec<Value> {
        let one = b.f(1.0);
        vec![one; self.lanes]
    }

    /// The words of "no sample" (the path ends): all zero.
    pub(super) fn no_sample(&self, b: &mut Builder) -> Vec<Value> {
        b.zeros(5 + self.lanes)
    }

    /// `normal()` of the instance, unit and turned toward `wo`; the shading
    /// normal `N` when `normal()` is degenerate.
    fn sampling_normal(&mut self, b: &mut Builder, inst: &Rc<Instance<'p>>, wo: &[Value], ctx: &Ctx) -> Vec<Value> {
        let own = self.instance_method(b, inst, Method::Normal.interface(), &[], ctx);
        let own = b.normalize(&own);
        let n = self.shading_global(b, ctx, "N");
        let zero = b.f(0.0);
        let len2 = b.dot(&own, &own);
        let degenerate = b.feq(len2, zero);
        let n = b.select_lanes(degenerate, &n, &own);
        let facing = b.dot(&n, wo);
        let away = b.flt(facing, zero);
        (0..3)
            .map(|k| {
                let neg = b.un(UnOp::FNeg, n[k]);
                b.select(away, neg, n[k])
            })
            .collect()
    }

    /// The delta lobes of an instance that defines `reflection_dir` or
    /// `refraction_dir`; `None` for every other (then sampling is cosine only).
    fn delta_lobes_of(
        &mut self,
        b: &mut Builder,
        inst: &Rc<Instance<'p>>,
        wo: &[Value],
        eta: &[Value],
        ctx: &Ctx,
    ) -> Option<DeltaLobes> {
        let defines = |name: &str| inst.def.methods.iter().any(|m| m.name.name == name);
        if !defines("reflection_dir") && !defines("refraction_dir") {
            return None;
        }
        let ones = self.ones(b);
        let zero = b.f(0.0);
        let dr = self.instance_method(b, inst, Method::ReflectionDir.interface(), &[wo.to_vec()], ctx);
        let dt = self.instance_method(b, inst, Method::RefractionDir.interface(), &[wo.to_vec(), eta.to_vec()], ctx);
        let mut weights = [Vec::new(), Vec::new()];
        let mut means = [zero, zero];
        for (k, dir) in [&dr, &dt].into_iter().enumerate() {
            let len2 = b.dot(dir, dir);
            let present = b.flt(zero, len2);
            let zeros = b.zeros(self.lanes);
            let w = b.branch(
                self,
                present,
                &vec![Scalar::F32; self.lanes],
                |b, me| {
                    if k == 0 {
                        me.instance_method(
                            b,
                            inst,
                            Method::Reflection.interface(),
                            &[dir.clone(), ones.clone(), wo.to_vec()],
                            ctx,
                        )
                    } else {
                        let args = [dir.clone(), ones.clone(), eta.to_vec(), wo.to_vec()];
                        me.instance_method(b, inst, Method::Refraction.interface(), &args, ctx)
                    }
                },
                |_, _| zeros,
            );
            let mean = b.mean(&w);
            let mean = b.fmax(mean, zero);
            means[k] = b.select(present, mean, zero);
            weights[k] = w;
        }
        let total = b.fadd(means[0], means[1]);
        let diffuse = self.instance_method(b, inst, Method::Diffuse.interface(), &[], ctx);
        let hint = b.mean(&diffuse);
        let (lo, one) = (b.f(0.05), b.f(1.0));
        let hint = b.clamp(hint, lo, one);
        let sum = b.fadd(hint, total);
        let share = b.fdiv(hint, sum);
        let any = b.flt(zero, total);
        let p_smooth = b.select(any, share, one);
        Some(DeltaLobes { dirs: [dr, dt], weights, means, total, p_smooth })
    }

    /// The default `sample(wo, eta, u1, u2)` of a material instance.
    pub(super) fn default_sample(
        &mut self,
        b: &mut Builder,
        inst: &Rc<Instance<'p>>,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let (wo, eta, u1, u2) = (&args[0], &args[1], args[2][0], &args[3]);
        let n = self.sampling_normal(b, inst, wo, ctx);
        let lobes = self.delta_lobes_of(b, inst, wo, eta, ctx);
        let tys = self.words(&Ty::BsdfSample);
        let smooth = |b: &mut Builder, me: &mut Self, lobes: Option<&DeltaLobes>| -> Vec<Value> {
            let (wi, cos) = b.cosine_about(&n, u2);
            let inv_pi = b.f(std::f32::consts::FRAC_1_PI);
            let mut pdf = b.fmul(cos, inv_pi);
            let mut ok = {
                let zero = b.f(0.0);
                b.flt(zero, pdf)
            };
            if let Some(l) = lobes {
                pdf = b.fmul(pdf, l.p_smooth);
                let cone = b.f(DELTA_CONE);
                for dir in &l.dirs {
                    let c = b.dot(&wi, dir);
                    let inside = b.bin(BinOp::FLe, cone, c);
                    let outside = b.not(inside);
                    ok = b.and(ok, outside);
                }
            }
            let f = me.eval_instance(b, inst, &wi, wo, eta, ctx);
            let weight: Vec<Value> = f.iter().map(|x| b.safe_div(*x, pdf)).collect();
            let zero = b.f(0.0);
            let sample = Sample { wi, weight, pdf, delta: zero }.lanes();
            let none = me.no_sample(b);
            b.select_lanes(ok, &sample, &none)
        };
        let Some(lobes) = lobes else { return smooth(b, self, None) };
        let is_smooth = b.flt(u1, lobes.p_smooth);
        b.branch(
            self,
            is_smooth,
            &tys,
            |b, me| smooth(b, me, Some(&lobes)),
            |b, _| {
                // Pick a delta lobe in proportion to its mean weight.
                let one = b.f(1.0);
                let rest = b.fsub(one, lobes.p_smooth);
                let shifted = b.fsub(u1, lobes.p_smooth);
                let scaled = b.safe_div(shifted, rest);
                let pick = b.fmul(scaled, lobes.total);
                let reflect = b.flt(pick, lobes.means[0]);
                let dir = b.select_lanes(reflect, &lobes.dirs[0], &lobes.dirs[1]);
                let w = b.select_lanes(reflect, &lobes.weights[0], &lobes.weights[1]);
                let mean = b.select(reflect, lobes.means[0], lobes.means[1]);
                let share = b.safe_div(mean, lobes.total);
                let p = b.fmul(share, rest);
                let weight = w.iter().map(|x| b.safe_div(*x, p)).collect();
                let (zero, flag) = (b.f(0.0), b.f(1.0));
                Sample { wi: dir, weight, pdf: zero, delta: flag }.lanes()
            },
        )
    }

    /// The default `pdf(wi, wo, eta)`: the density of [`Self::default_sample`].
    pub(super) fn default_pdf(
        &mut self,
        b: &mut Builder,
        inst: &Rc<Instance<'p>>,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let (wi, wo, eta) = (&args[0], &args[1], &args[2]);
        let n = self.sampling_normal(b, inst, wo, ctx);
        let c = b.dot(&n, wi);
        let zero = b.f(0.0);
        let c = b.fmax(c, zero);
        let inv_pi = b.f(std::f32::consts::FRAC_1_PI);
        let pdf = b.fmul(c, inv_pi);
        match self.delta_lobes_of(b, inst, wo, eta, ctx) {
            Some(l) => vec![b.fmul(pdf, l.p_smooth)],
            None => vec![pdf],
        }
    }

    /// `f · cos` of a material expression toward `wo` for unit light from
    /// `wi`: `reflection` when both are on the side of the geometric normal,
    /// `refraction` when they are on opposite sides.
    pub(super) fn eval_at(
        &mut self,
        b: &mut Builder,
        mat: &Mat<'p>,
        wi: &[Value],
        wo: &[Value],
        eta: &[Value],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let ones = self.ones(b);
        let same = self.same_side(b, wi, wo, ctx);
        let reflection = Method::Reflection.interface();
        if self.uses_default(mat, Method::Refraction.interface(), 0) {
            let f = self.mat_method(b, mat, reflection, &[wi.to_vec(), ones, wo.to_vec()], ctx);
            let zeros = b.zeros(self.lanes);
            return b.select_lanes(same, &f, &zeros);
        }
        let tys = vec![Scalar::F32; self.lanes];
        b.branch(
            self,
            same,
            &tys,
            |b, me| me.mat_method(b, mat, reflection, &[wi.to_vec(), ones.clone(), wo.to_vec()], ctx),
            |b, me| {
                let args = [wi.to_vec(), ones.clone(), eta.to_vec(), wo.to_vec()];
                me.mat_method(b, mat, Method::Refraction.interface(), &args, ctx)
            },
        )
    }

    /// [`Self::eval_at`] for one material instance.
    fn eval_instance(
        &mut self,
        b: &mut Builder,
        inst: &Rc<Instance<'p>>,
        wi: &[Value],
        wo: &[Value],
        eta: &[Value],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let ones = self.ones(b);
        let same = self.same_side(b, wi, wo, ctx);
        let f = self.instance_method(
            b,
            inst,
            Method::Reflection.interface(),
            &[wi.to_vec(), ones.clone(), wo.to_vec()],
            ctx,
        );
        if !inst.def.methods.iter().any(|m| m.name.name == "refraction") {
            let zeros = b.zeros(self.lanes);
            return b.select_lanes(same, &f, &zeros);
        }
        let t = self.instance_method(
            b,
            inst,
            Method::Refraction.interface(),
            &[wi.to_vec(), ones, eta.to_vec(), wo.to_vec()],
            ctx,
        );
        b.select_lanes(same, &f, &t)
    }

    /// Whether `wi` and `wo` are on the same side of the geometric normal.
    pub(super) fn same_side(&mut self, b: &mut Builder, wi: &[Value], wo: &[Value], ctx: &Ctx) -> Value {
        let ng = self.shading_global(b, ctx, "Ng");
        let (ci, co) = (b.dot(wi, &ng), b.dot(wo, &ng));
        let side = b.fmul(ci, co);
        let zero = b.f(0.0);
        b.flt(zero, side)
    }

    /// The probability of choosing each child of a weighted node:
    /// `|w_k| / Σ |w_j|` (spline weights can be negative).
    fn selection(&self, b: &mut Builder, weights: &[Value]) -> Vec<Value> {
        let abs: Vec<Value> = weights.iter().map(|w| b.un(UnOp::FAbs, *w)).collect();
        let mut total = b.f(0.0);
        for a in &abs {
            total = b.fadd(total, *a);
        }
        abs.iter().map(|a| b.safe_div(*a, total)).collect()
    }

    /// `pdf` of a weighted node (`mix`, `blend`): the mixture of the
    /// children's pdfs by their selection probabilities. `unused[k]`: child
    /// k's weight is known to be 0 here (a hit group lowers its methods
    /// under `mix`'s t = 0 and t = 1, `lower::hit`), so it is not computed.
    pub(super) fn pdf_mixture(
        &mut self,
        b: &mut Builder,
        weights: &[Value],
        unused: &[bool],
        items: &[Mat<'p>],
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let sel = self.selection(b, weights);
        let zero = b.f(0.0);
        let mut pdf = zero;
        // Children that are the same material: one pdf for them all.
        for group in self.material_groups(items) {
            let mut used = None;
            for k in group.iter().filter(|k| !unused.get(**k).copied().unwrap_or(false)) {
                let positive = b.flt(zero, sel[*k]);
                used = Some(match used {
                    None => positive,
                    Some(u) => b.bin(BinOp::Or, u, positive),
                });
            }
            // What the guard gives at a weight of 0.
            let child = match used {
                None => vec![zero],
                Some(used) => {
                    let item = &items[group[0]];
                    b.guarded(self, used, vec![zero], |b, me| {
                        me.mat_method(b, item, Method::Pdf.interface(), args, ctx)
                    })
                }
            };
            for k in group {
                let term = b.fmul(sel[k], child[0]);
                pdf = b.fadd(pdf, term);
            }
        }
        vec![pdf]
    }

    /// `sample` of a weighted node (`node`): one child drawn with its
    /// selection probability (the lobe number `uc` remapped), then the
    /// node's own weight and pdf at the direction it gave. Inside another
    /// mixture only the choice is made: the outermost mixture evaluates the
    /// whole tree once at the final direction, so a chain of n mixtures
    /// costs O(n), not O(n²). When all children but one are `unused`
    /// (weight known to be 0, see [`Self::pdf_mixture`]), that one is
    /// sampled without the choice, which would pick it with the same
    /// lobe number: the same bits, and no other child's code.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn sample_mixture(
        &mut self,
        b: &mut Builder,
        node: &Mat<'p>,
        weights: &[Value],
        unused: &[bool],
        items: &[Mat<'p>],
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        if items.is_empty() {
            return self.no_sample(b);
        }
        let sel = self.selection(b, weights);
        let mut starts = Vec::with_capacity(items.len());
        let mut acc = b.f(0.0);
        for p in &sel {
            starts.push(acc);
            acc = b.fadd(acc, *p);
        }
        let live: Vec<usize> = (0..items.len()).filter(|k| !unused.get(*k).copied().unwrap_or(false)).collect();
        let only = (live.len() == 1).then(|| live[0]);
        let outermost = !std::mem::replace(&mut self.direction_only, true);
        let groups = self.material_groups(items);
        let chosen = if only.is_none() && groups.len() < items.len() {
            self.sample_group(b, &groups, weights, &sel, &starts, items, args, ctx)
        } else {
            self.sample_child(b, 0, only, weights, &sel, &starts, items, args, ctx)
        };
        self.direction_only = !outermost;
        let lanes = self.lanes;
        let s = Sample::split(&chosen, lanes);
        let ratio = chosen[5 + lanes];
        let zero = b.f(0.0);
        let is_delta = b.flt(zero, s.delta);
        // A delta lobe is the chosen child's alone: its weight times w_k / p_k.
        let delta_weight: Vec<Value> = s.weight.iter().map(|w| b.fmul(*w, ratio)).collect();
        let weight = b.select_lanes(is_delta, &delta_weight, &s.weight);
        let chosen = Sample { weight, ..s };
        if !outermost {
            return chosen.lanes();
        }
        self.weigh_by_node(b, node, chosen, is_delta, args, ctx)
    }

    /// What the outermost of nested mixtures (or layers) returns for the
    /// sample a child drew: a delta lobe's `chosen` as it is; any other
    /// direction weighed by the whole node's `f · cos / pdf`, so the weight
    /// agrees with the node's own `pdf` (MIS); nothing when that pdf is 0.
    pub(super) fn weigh_by_node(
        &mut self,
        b: &mut Builder,
        node: &Mat<'p>,
        chosen: Sample,
        is_delta: Value,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let zero = b.f(0.0);
        let not_delta = b.not(is_delta);
        let has_pdf = b.flt(zero, chosen.pdf);
        let smooth = b.and(not_delta, has_pdf);
        let tys = self.words(&Ty::BsdfSample);
        let (wo, eta) = (&args[0], &args[1]);
        let wi = chosen.wi.clone();
        let mixed = b.branch(
            self,
            smooth,
            &tys,
            |b, me| {
                let f = me.eval_at(b, node, &wi, wo, eta, ctx);
                let pdf =
                    me.mat_method(b, node, Method::Pdf.interface(), &[wi.clone(), wo.clone(), eta.clone()], ctx)[0];
                let weight = f.iter().map(|x| b.safe_div(*x, pdf)).collect();
                let flag = b.f(0.0);
                Sample { wi: wi.clone(), weight, pdf, delta: flag }.lanes()
            },
            |b, me| me.no_sample(b),
        );
        let chosen = chosen.lanes();
        b.select_lanes(is_delta, &chosen, &mixed)
    }

    /// Samples child `k` when the lobe number falls in its share, else a
    /// later one (child `only`, when given, without the test); returns the
    /// child's sample words and `w_k / p_k`.
    #[allow(clippy::too_many_arguments)]
    fn sample_child(
        &mut self,
        b: &mut Builder,
        k: usize,
        only: Option<usize>,
        weights: &[Value],
        sel: &[Value],
        starts: &[Value],
        items: &[Mat<'p>],
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let uc = args[2][0];
        let here = |b: &mut Builder, me: &mut Self| -> Vec<Value> {
            let offset = b.fsub(uc, starts[k]);
            let remapped = b.safe_div(offset, sel[k]);
            let (zero, top) = (b.f(0.0), b.f(ONE_MINUS_EPSILON));
            let remapped = b.clamp(remapped, zero, top);
            let child_args = [args[0].clone(), args[1].clone(), vec![remapped], args[3].clone()];
            let mut s = me.mat_method(b, &items[k], Method::Sample.interface(), &child_args, ctx);
            s.push(b.safe_div(weights[k], sel[k]));
            s
        };
        if k + 1 == items.len() || only == Some(k) {
            return here(b, self);
        }
        if only.is_some() {
            return self.sample_child(b, k + 1, only, weights, sel, starts, items, args, ctx);
        }
        let end = b.fadd(starts[k], sel[k]);
        let inside = b.flt(uc, end);
        let mut tys = self.words(&Ty::BsdfSample);
        tys.push(Scalar::F32);
        b.branch(self, inside, &tys, here, |b, me| {
            me.sample_child(b, k + 1, None, weights, sel, starts, items, args, ctx)
        })
    }

    /// [`Self::sample_child`] for children of which some are the same
    /// material: the child is chosen as the branches there choose it (the
    /// first whose share holds the lobe number, else the last), and each
    /// group of equal children is sampled once, with the remapped lobe
    /// number and `w_k / p_k` of the member chosen. The same bits as
    /// sampling each child in its own branch, but `mix(t, m, m)` samples
    /// `m` once, so a tree that mixes the previous one with itself at
    /// every level samples in linear code.
    #[allow(clippy::too_many_arguments)]
    fn sample_group(
        &mut self,
        b: &mut Builder,
        groups: &[Vec<usize>],
        weights: &[Value],
        sel: &[Value],
        starts: &[Value],
        items: &[Mat<'p>],
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let uc = args[2][0];
        let n = items.len();
        // Which child the lobe number picks, and what that child is given.
        let mut taken = Vec::with_capacity(n);
        let mut none_before = b.b(true);
        for k in 0..n {
            if k + 1 == n {
                taken.push(none_before);
                break;
            }
            let end = b.fadd(starts[k], sel[k]);
            let inside = b.flt(uc, end);
            taken.push(b.and(none_before, inside));
            let outside = b.not(inside);
            none_before = b.and(none_before, outside);
        }
        let (zero, top) = (b.f(0.0), b.f(ONE_MINUS_EPSILON));
        let mut picks = Vec::with_capacity(groups.len());
        for group in groups {
            let mut pick: Option<(Value, Value, Value)> = None;
            for &k in group {
                let offset = b.fsub(uc, starts[k]);
                let remapped = b.safe_div(offset, sel[k]);
                let remapped = b.clamp(remapped, zero, top);
                let ratio = b.safe_div(weights[k], sel[k]);
                pick = Some(match pick {
                    None => (taken[k], remapped, ratio),
                    Some((in_group, r, q)) => (
                        b.bin(BinOp::Or, in_group, taken[k]),
                        b.select(taken[k], remapped, r),
                        b.select(taken[k], ratio, q),
                    ),
                });
            }
            picks.push(pick.unwrap_or((zero, zero, zero)));
        }
        self.sample_picked(b, groups, &picks, items, args, ctx)
    }

    /// Samples the first group whose flag in `picks` is set (the last
    /// group without a test), with its remapped lobe number; returns the
    /// sample words and the group's `w_k / p_k`.
    fn sample_picked(
        &mut self,
        b: &mut Builder,
        groups: &[Vec<usize>],
        picks: &[(Value, Value, Value)],
        items: &[Mat<'p>],
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let here = |b: &mut Builder, me: &mut Self| -> Vec<Value> {
            let (_, remapped, ratio) = picks[0];
            let child_args = [args[0].clone(), args[1].clone(), vec![remapped], args[3].clone()];
            let mut s = me.mat_method(b, &items[groups[0][0]], Method::Sample.interface(), &child_args, ctx);
            s.push(ratio);
            s
        };
        if groups.len() == 1 {
            return here(b, self);
        }
        let mut tys = self.words(&Ty::BsdfSample);
        tys.push(Scalar::F32);
        b.branch(self, picks[0].0, &tys, here, |b, me| me.sample_picked(b, &groups[1..], &picks[1..], items, args, ctx))
    }

    /// `sample` of `mix(t, a, b, only: ...)`: the node samples as `a` does,
    /// with the weight recomputed from the node's own `f` (which `only`
    /// may have blended).
    pub(super) fn sample_as_first(
        &mut self,
        b: &mut Builder,
        node: &Mat<'p>,
        first: &Mat<'p>,
        args: &[Vec<Value>],
        ctx: &Ctx,
    ) -> Vec<Value> {
        let s = self.mat_method(b, first, Method::Sample.interface(), args, ctx);
        if self.direction_only {
            return s;
        }
        let s = Sample::split(&s, self.lanes);
        let zero = b.f(0.0);
        let is_delta = b.flt(zero, s.delta);
        let not_delta = b.not(is_delta);
        let has_pdf = b.flt(zero, s.pdf);
        let smooth = b.and(not_delta, has_pdf);
        let own = self.eval_at(b, node, &s.wi, &args[0], &args[1], ctx);
        let own: Vec<Value> = own.iter().map(|x| b.safe_div(*x, s.pdf)).collect();
        let weight = b.select_lanes(smooth, &own, &s.weight);
        Sample { weight, ..s }.lanes()
    }

    /// `sample` of a node that weighs its child's light by a factor of
    /// the light's direction (`normal_map`'s shadowing): the child's
    /// sample with its weight times the factor at the direction drawn.
    pub(super) fn weigh_sample(
        &mut self,
        b: &mut Builder,
        sample: &[Value],
        factor: impl FnOnce(&mut Self, &mut Builder, &[Value]) -> Value,
    ) -> Vec<Value> {
        let mut s = Sample::split(sample, self.lanes);
        let f = factor(self, b, &s.wi);
        s.weight = b.scale(&s.weight, f);
        s.lanes()
    }

    /// `sample` of `scale(c, m)`: m's sample with its weight times `c`.
    pub(super) fn scale_sample(&self, b: &mut Builder, sample: &[Value], c: &[Value]) -> Vec<Value> {
        let mut s = Sample::split(sample, self.lanes);
        s.weight = b.map2(BinOp::FMul, &s.weight, c);
        s.lanes()
    }
}
