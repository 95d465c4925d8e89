//! The builtin functions: type constructors, elementwise math, geometry,
//! noise, colors and their conversions, transforms, and the value forms of
//! `mix`, `blend` and `select`.

use super::*;

impl<'p> Lowerer<'p> {
    pub(super) fn construct(
        &mut self,
        b: &mut Builder,
        fr: &mut Frame<'p>,
        ctx: &Ctx,
        base: ast::BaseType,
        args: &'p [ast::Arg],
        e: &'p Expr,
    ) -> Val<'p> {
        use ast::BaseType as B;
        if base == B::Normal
            && args.is_empty()
            && let Some(inst) = fr.material.clone()
        {
            let im = Method::Normal.interface();
            return Val::Lanes(self.instance_method(b, &inst, im, &[], ctx));
        }
        let vals: Vec<(Val<'p>, Ty)> =
            args.iter().map(|a| (self.expr(b, fr, ctx, &a.value), self.ty_of(&a.value))).collect();
        match base {
            B::Int => {
                let (v, t) = only_arg(vals);
                let x = self.scalar(b, v);
                Val::Lanes(vec![if t == Ty::Int { x } else { b.un(UnOp::FToI, x) }])
            }
            B::Float => {
                let (v, t) = only_arg(vals);
                Val::Lanes(self.float_lanes(b, v, &t, 1))
            }
            B::Matrix if vals.is_empty() => Val::Lanes(identity(b)),
            B::BsdfSample => {
                // bsdf_sample(wi, weight, pdf): not a delta lobe.
                let mut parts = Vec::new();
                for ((v, t), want) in vals.into_iter().zip([Ty::Vector, Ty::Color, Ty::Float]) {
                    let n = self.lanes_of(&want);
                    parts.push(self.float_lanes(b, v, &t, n));
                }
                let zero = b.f(0.0);
                let [wi, weight, pdf] = <[Vec<Value>; 3]>::try_from(parts).unwrap_or_default();
                let layout = SampleLayout { lanes: self.lanes };
                Val::Lanes(layout.assemble(&wi, &weight, pdf.first().copied().unwrap_or(zero), zero))
            }
            B::Matrix if vals.len() == 1 => {
                let (v, t) = only_arg(vals);
                let s = self.float_lanes(b, v, &t, 1)[0];
                Val::Lanes(diag(b, [s, s, s]))
            }
            _ => {
                let n = self.lanes_of(&self.ty_of(e));
                let mut lanes = Vec::new();
                for (v, t) in vals {
                    lanes.extend(self.float_lanes(b, v, &t, 1));
                }
                if lanes.len() == 1 && n > 1 {
                    lanes = vec![lanes[0]; n];
                }
                Val::Lanes(lanes)
            }
        }
    }

    pub(super) fn builtin(
        &mut self,
        b: &mut Builder,
        fr: &mut Frame<'p>,
        ctx: &Ctx,
        f: BuiltinFn,
        args: &'p [ast::Arg],
        e: &'p Expr,
    ) -> Val<'p> {
        use BuiltinFn::*;
        let ty = self.ty_of(e);
        let spec = f.builtin();
        let bound = bind_builtin_args(spec, args);
        if matches!(f, Texture | TextureFloat | TextureVector) {
            return self.texture(b, fr, ctx, spec, &bound, e);
        }
        if f == Triplanar {
            return self.triplanar(b, fr, ctx, &bound, &ty);
        }
        let mut vals: Vec<Option<(Val<'p>, Ty)>> = Vec::new();
        for a in &bound {
            vals.push(a.map(|a| (self.expr(b, fr, ctx, a), self.ty_of(a))));
        }
        let n = self.lanes_of(&ty);
        // Float lanes of argument k, broadcast to the result width.
        // `arg` reads required parameters only (optional ones, such as
        // `spline`, are read with their defaults below).
        let mut arg = |me: &mut Self, b: &mut Builder, k: usize, width: usize| -> Vec<Value> {
            match vals.get_mut(k).and_then(Option::take) {
                Some((v, t)) => me.float_lanes(b, v, &t, width),
                None => {
                    ruled_out!("`{}` without its argument {}", spec.name, spec.params.get(k).map_or("?", |p| p.name));
                    b.zeros(width)
                }
            }
        };
        let unary_native = |b: &mut Builder, native: &'static str, x: Vec<Value>| -> Val<'p> {
            Val::Lanes(x.into_iter().map(|v| b.call(native, vec![v])).collect())
        };

        match f {
            Abs if ty == Ty::Int => {
                let x = self.scalar_arg(b, &bound, 0, fr, ctx);
                let neg = b.un(UnOp::INeg, x);
                let zero = b.i(0);
                let lt = b.bin(BinOp::ILt, x, zero);
                Val::Lanes(vec![b.select(lt, neg, x)])
            }
            Abs => Val::Lanes(arg(self, b, 0, n).into_iter().map(|x| b.un(UnOp::FAbs, x)).collect()),
            Sign => {
                let x = arg(self, b, 0, n);
                let (zero, one, minus) = (b.f(0.0), b.f(1.0), b.f(-1.0));
                Val::Lanes(
                    x.into_iter()
                        .map(|v| {
                            let pos = b.flt(zero, v);
                            let neg = b.flt(v, zero);
                            let s = b.select(neg, minus, zero);
                            b.select(pos, one, s)
                        })
                        .collect(),
                )
            }
            Floor => Val::Lanes(arg(self, b, 0, n).into_iter().map(|x| b.un(UnOp::Floor, x)).collect()),
            Ceil => Val::Lanes(arg(self, b, 0, n).into_iter().map(|x| b.un(UnOp::Ceil, x)).collect()),
            Fract => Val::Lanes(
                arg(self, b, 0, n)
                    .into_iter()
                    .map(|x| {
                        let f = b.un(UnOp::Floor, x);
                        b.fsub(x, f)
                    })
                    .collect(),
            ),
            Sqrt => Val::Lanes(arg(self, b, 0, n).into_iter().map(|x| b.un(UnOp::Sqrt, x)).collect()),
            Round | Exp | Log | Sin | Cos | Tan | Asin | Acos | Atan => {
                let x = arg(self, b, 0, n);
                unary_native(b, unary_native_name(f), x)
            }
            Radians | Degrees => {
                let k = b.f(if f == Radians { std::f32::consts::PI / 180.0 } else { 180.0 / std::f32::consts::PI });
                Val::Lanes(arg(self, b, 0, n).into_iter().map(|x| b.fmul(x, k)).collect())
            }
            Atan2 => {
                let (y, x) = (arg(self, b, 0, 1)[0], arg(self, b, 1, 1)[0]);
                Val::Lanes(vec![b.call("tsl_atan2", vec![y, x])])
            }
            Pow => {
                let x = arg(self, b, 0, n);
                let p = arg(self, b, 1, 1)[0];
                Val::Lanes(x.into_iter().map(|v| b.call("tsl_pow", vec![v, p])).collect())
            }
            Min | Max if ty == Ty::Int => {
                let x = self.scalar_arg(b, &bound, 0, fr, ctx);
                let y = self.scalar_arg(b, &bound, 1, fr, ctx);
                let lt = b.bin(BinOp::ILt, x, y);
                Val::Lanes(vec![if f == Min { b.select(lt, x, y) } else { b.select(lt, y, x) }])
            }
            Min | Max => {
                let x = arg(self, b, 0, n);
                let y = arg(self, b, 1, n);
                let op = if f == Min { BinOp::FMin } else { BinOp::FMax };
                Val::Lanes(b.map2(op, &x, &y))
            }
            Clamp if ty == Ty::Int => {
                let x = self.scalar_arg(b, &bound, 0, fr, ctx);
                let lo = self.scalar_arg(b, &bound, 1, fr, ctx);
                let hi = self.scalar_arg(b, &bound, 2, fr, ctx);
                let below = b.bin(BinOp::ILt, x, lo);
                let x = b.select(below, lo, x);
                let above = b.bin(BinOp::ILt, hi, x);
                Val::Lanes(vec![b.select(above, hi, x)])
            }
            Mod if ty == Ty::Int => {
                // Floored modulo: ((a % b) + b) % b, zero for b == 0.
                let x = self.scalar_arg(b, &bound, 0, fr, ctx);
                let y = self.scalar_arg(b, &bound, 1, fr, ctx);
                let r = b.bin(BinOp::IRem, x, y);
                let r = b.bin(BinOp::IAdd, r, y);
                Val::Lanes(vec![b.bin(BinOp::IRem, r, y)])
            }
            Clamp => {
                let x = arg(self, b, 0, n);
                let lo = arg(self, b, 1, n);
                let hi = arg(self, b, 2, n);
                Val::Lanes((0..n).map(|k| b.clamp(x[k], lo[k], hi[k])).collect())
            }
            Mod => {
                let x = arg(self, b, 0, n);
                let y = arg(self, b, 1, n);
                Val::Lanes(
                    (0..n)
                        .map(|k| {
                            let d = b.fdiv(x[k], y[k]);
                            let f = b.un(UnOp::Floor, d);
                            let m = b.fmul(y[k], f);
                            b.fsub(x[k], m)
                        })
                        .collect(),
                )
            }
            Step => {
                let edge = arg(self, b, 0, n);
                let x = arg(self, b, 1, n);
                let (zero, one) = (b.f(0.0), b.f(1.0));
                Val::Lanes(
                    (0..n)
                        .map(|k| {
                            let below = b.flt(x[k], edge[k]);
                            b.select(below, zero, one)
                        })
                        .collect(),
                )
            }
            Smoothstep => {
                let e0 = arg(self, b, 0, n);
                let e1 = arg(self, b, 1, n);
                let x = arg(self, b, 2, n);
                let (zero, one, two, three) = (b.f(0.0), b.f(1.0), b.f(2.0), b.f(3.0));
                Val::Lanes(
                    (0..n)
                        .map(|k| {
                            let num = b.fsub(x[k], e0[k]);
                            let den = b.fsub(e1[k], e0[k]);
                            let t = b.fdiv(num, den);
                            let t = b.clamp(t, zero, one);
                            let tt = b.fmul(t, t);
                            let two_t = b.fmul(two, t);
                            let s = b.fsub(three, two_t);
                            b.fmul(tt, s)
                        })
                        .collect(),
                )
            }
            Dot => {
                let w = self.lanes_of(&self.arg_ty(&bound, 0));
                let x = arg(self, b, 0, w);
                let y = arg(self, b, 1, w);
                Val::Lanes(vec![b.dot(&x, &y)])
            }
            Cross => {
                let x = arg(self, b, 0, 3);
                let y = arg(self, b, 1, 3);
                Val::Lanes(b.cross(&x, &y))
            }
            Length | Normalize => {
                let w = self.lanes_of(&self.arg_ty(&bound, 0));
                let x = arg(self, b, 0, w);
                Val::Lanes(if f == Length { vec![b.length(&x)] } else { b.normalize(&x) })
            }
            Distance => {
                let w = self.lanes_of(&self.arg_ty(&bound, 0));
                let x = arg(self, b, 0, w);
                let y = arg(self, b, 1, w);
                let d = b.map2(BinOp::FSub, &x, &y);
                Val::Lanes(vec![b.length(&d)])
            }
            Reflect => {
                let i = arg(self, b, 0, 3);
                let nrm = arg(self, b, 1, 3);
                let d = b.dot(&nrm, &i);
                let two = b.f(2.0);
                let k = b.fmul(two, d);
                let s = b.scale(&nrm, k);
                Val::Lanes(b.map2(BinOp::FSub, &i, &s))
            }
            Refract => {
                let i = arg(self, b, 0, 3);
                let nrm = arg(self, b, 1, 3);
                let eta = arg(self, b, 2, 1)[0];
                Val::Lanes(refract(b, &i, &nrm, eta))
            }
            RoughTransmittance => {
                let cos_theta = arg(self, b, 0, 1)[0];
                let alpha = arg(self, b, 1, 1)[0];
                let eta = arg(self, b, 2, 1)[0];
                let ggx = self.scalar_arg(b, &bound, 3, fr, ctx);
                Val::Lanes(vec![rough_transmittance(b, cos_theta, alpha, eta, ggx)])
            }
            RoughInternalReflectance => {
                let alpha = arg(self, b, 0, 1)[0];
                let eta = arg(self, b, 1, 1)[0];
                let ggx = self.scalar_arg(b, &bound, 2, fr, ctx);
                let (one, zero) = (b.f(1.0), b.f(0.0));
                let ggx = b.select(ggx, one, zero);
                // Constant arguments fold: the native runs at compile time.
                Val::Lanes(vec![b.call("tsl_rough_internal_reflectance", vec![alpha, eta, ggx])])
            }
            Faceforward => {
                let nrm = arg(self, b, 0, 3);
                let i = arg(self, b, 1, 3);
                let d = b.dot(&nrm, &i);
                let zero = b.f(0.0);
                let facing = b.flt(d, zero);
                Val::Lanes(
                    nrm.iter()
                        .map(|x| {
                            let neg = b.un(UnOp::FNeg, *x);
                            b.select(facing, *x, neg)
                        })
                        .collect(),
                )
            }
            Noise => {
                let w = self.lanes_of(&self.arg_ty(&bound, 0));
                let p = arg(self, b, 0, w);
                let key = MemoKey::Noise(p.clone());
                if let Some(v) = b.lookup(&key) {
                    return Val::Lanes(v);
                }
                if b.noise_budget == 0 {
                    return Val::Lanes(vec![b.call(native_name(f, w), p)]);
                }
                b.noise_budget -= 1;
                let v = noise::noise(b, &p);
                b.remember(key, &[v]);
                Val::Lanes(vec![v])
            }
            Cellnoise => {
                let w = self.lanes_of(&self.arg_ty(&bound, 0));
                let p = arg(self, b, 0, w);
                let native = native_name(f, w);
                Val::Lanes(vec![b.call(native, p)])
            }
            Pnoise => {
                let w = self.lanes_of(&self.arg_ty(&bound, 0));
                let mut p = arg(self, b, 0, w);
                p.extend(arg(self, b, 1, w));
                Val::Lanes(vec![b.call(native_name(f, w), p)])
            }
            Rgb => {
                let (r, g, bl) = (arg(self, b, 0, 1)[0], arg(self, b, 1, 1)[0], arg(self, b, 2, 1)[0]);
                Val::Lanes(self.rgb_to_lanes(b, [r, g, bl]))
            }
            Hsv => {
                let (h, s, v) = (arg(self, b, 0, 1)[0], arg(self, b, 1, 1)[0], arg(self, b, 2, 1)[0]);
                let rgb = hsv_to_rgb(b, h, s, v);
                Val::Lanes(self.rgb_to_lanes(b, rgb))
            }
            Xyz => {
                let xyz = [arg(self, b, 0, 1)[0], arg(self, b, 1, 1)[0], arg(self, b, 2, 1)[0]];
                let rgb = xyz_rows_to_rgb(b, xyz);
                Val::Lanes(self.rgb_to_lanes(b, rgb))
            }
            Gray => {
                let x = arg(self, b, 0, 1)[0];
                Val::Lanes(vec![x; self.lanes])
            }
            Black => Val::Lanes(b.zeros(self.lanes)),
            Spectrum => self.spectrum(b, &mut vals, &bound),
            DeltaSample => {
                // A delta lobe: pdf 0 (no density), the flag set.
                let mut lanes = arg(self, b, 0, 3);
                lanes.extend(arg(self, b, 1, self.lanes));
                lanes.push(b.f(0.0));
                lanes.push(b.f(1.0));
                Val::Lanes(lanes)
            }
            NoSample => Val::Lanes(b.zeros(n)),
            Brightness => {
                let c = arg(self, b, 0, self.lanes);
                Val::Lanes(vec![self.brightness_of(b, &c)])
            }
            ToRgb | ToXyz => {
                let c = arg(self, b, 0, self.lanes);
                Val::Lanes(self.color_rows(b, &c, f == ToXyz))
            }
            Translate => {
                let v = arg(self, b, 0, 3);
                let mut m = identity(b);
                m[3] = v[0];
                m[7] = v[1];
                m[11] = v[2];
                Val::Lanes(m)
            }
            Rotate => {
                let deg = arg(self, b, 0, 1)[0];
                let axis = arg(self, b, 1, 3);
                Val::Lanes(rotation(b, deg, &axis))
            }
            Scale => {
                let (v, t) = vals[0].take().unwrap_or_else(|| {
                    ruled_out!("`scale` without its argument");
                    (Val::Unit, Ty::Float)
                });
                let s = self.float_lanes(b, v, &t, 3);
                Val::Lanes(diag(b, [s[0], s[1], s[2]]))
            }
            Inverse => {
                let m = arg(self, b, 0, 12);
                Val::Lanes(mat_inverse(b, &m))
            }
            TransformPoint | TransformVector => {
                let m = arg(self, b, 0, 12);
                let p = arg(self, b, 1, 3);
                Val::Lanes(transform_point(b, &m, &p, f == TransformPoint))
            }
            TransformNormal => {
                let m = arg(self, b, 0, 12);
                let nrm = arg(self, b, 1, 3);
                let inv = mat_inverse(b, &m);
                // Normals go through the inverse transpose.
                let t: Vec<Value> = (0..3)
                    .map(|r| {
                        let row: Vec<Value> = (0..3).map(|c| inv[c * 4 + r]).collect();
                        b.dot(&row, &nrm)
                    })
                    .collect();
                Val::Lanes(t)
            }
            Mix => {
                let t = arg(self, b, 0, 1)[0];
                let x = arg(self, b, 1, n);
                let y = arg(self, b, 2, n);
                Val::Lanes(b.lerp(t, &x, &y))
            }
            Blend => {
                let t = arg(self, b, 0, 1)[0];
                let spline = match vals.get_mut(2).and_then(Option::take) {
                    Some((v, _)) => self.scalar(b, v),
                    None => b.b(false),
                };
                let items = match vals.get_mut(1).and_then(Option::take) {
                    Some((Val::Array(a), Ty::Array(e, _))) => {
                        let lanes = self.lanes_of(&e);
                        let elems = self.array_elems(b, &a, lanes);
                        if *e == Ty::Int {
                            elems.into_iter().map(|l| vec![b.un(UnOp::IToF, l[0])]).collect()
                        } else {
                            elems
                        }
                    }
                    other => {
                        ruled_out!("`blend` of {other:?}");
                        Vec::new()
                    }
                };
                let w = blend_weights(b, t, spline, items.len());
                let mut acc = b.zeros(n);
                for (wk, item) in w.iter().zip(&items) {
                    let s = b.scale(item, *wk);
                    acc = b.map2(BinOp::FAdd, &acc, &s);
                }
                Val::Lanes(acc)
            }
            Select => {
                let i = self.scalar_arg(b, &bound, 0, fr, ctx);
                let items = match vals.get_mut(1).and_then(Option::take) {
                    Some((Val::Array(a), Ty::Array(e, _))) => {
                        let lanes = self.lanes_of(&e);
                        self.array_elems(b, &a, lanes)
                    }
                    other => {
                        ruled_out!("`select` of {other:?}");
                        Vec::new()
                    }
                };
                if items.is_empty() {
                    // Arrays have at least one element.
                    ruled_out!("`select` of no items");
                    return Val::Lanes(b.zeros(n));
                }
                let i = self.clamp_index(b, i, items.len() as i32);
                let mut acc = items[0].clone();
                for (k, item) in items.iter().enumerate().skip(1) {
                    let kv = b.i(k as i32);
                    let hit = b.bin(BinOp::IEq, i, kv);
                    acc = acc.iter().zip(item).map(|(a, x)| b.select(hit, *x, *a)).collect();
                }
                Val::Lanes(acc)
            }
            // Only over materials: lowered by `tree_node`, never here (and
            // the texture calls and `triplanar` above).
            Texture | TextureFloat | TextureVector | Triplanar | Bump | NormalMap | Transform | Layer => {
                ruled_out!("`{}` reached the value builtins", f.name());
                Val::Lanes(b.zeros(n))
            }
        }
    }

    pub(super) fn scalar_arg(
        &mut self,
        b: &mut Builder,
        bound: &[Option<&'p Expr>],
        k: usize,
        fr: &mut Frame<'p>,
        ctx: &Ctx,
    ) -> Value {
        match bound.get(k).copied().flatten() {
            Some(e) => {
                let v = self.expr(b, fr, ctx, e);
                self.scalar(b, v)
            }
            None => {
                ruled_out!("a required argument omitted");
                b.i(0)
            }
        }
    }

    /// The type of argument `k`, which is required.
    pub(super) fn arg_ty(&self, bound: &[Option<&'p Expr>], k: usize) -> Ty {
        match bound.get(k).copied().flatten() {
            Some(e) => self.ty_of(e),
            None => {
                ruled_out!("a required argument omitted");
                Ty::Float
            }
        }
    }

    /// `spectrum([(nm, value), ...])`: wavelengths must be constants; values
    /// may vary. Each lane is a fixed weighting of the values.
    pub(super) fn spectrum(
        &mut self,
        b: &mut Builder,
        vals: &mut [Option<(Val<'p>, Ty)>],
        bound: &[Option<&'p Expr>],
    ) -> Val<'p> {
        let Some((Val::Array(a), _)) = vals.first_mut().and_then(Option::take) else {
            ruled_out!("`spectrum` of something other than an array");
            return Val::Lanes(b.zeros(self.lanes));
        };
        let elems = self.array_elems(b, &a, 2);
        let mut wavelengths = Vec::new();
        for e in &elems {
            match b.fconst(e[0]) {
                Some(nm) => wavelengths.push(nm),
                None => {
                    let span = bound.first().copied().flatten().map(|e| e.span).unwrap_or_default();
                    self.error(span, "spectrum wavelengths must be constants");
                    return Val::Lanes(b.zeros(self.lanes));
                }
            }
        }
        let values: Vec<Value> = elems.iter().map(|e| e[1]).collect();
        if self.absolute_spectra {
            // Scene values are evaluated in binned models only (hero
            // renders tabulate them at 64 bins).
            let w = color::emission_resample_weights(self.model, &wavelengths);
            return Val::Lanes(w.iter().map(|row| b.weighted(row, &values)).collect());
        }
        if self.model == ColorModel::Hero {
            return Val::Lanes(self.hero_curve(b, &wavelengths, &values));
        }
        let w = color::resample_weights(self.model, &wavelengths);
        Val::Lanes(w.iter().map(|row| b.weighted(row, &values)).collect())
    }
}

/// The one argument of a constructor that takes exactly one.
fn only_arg<'p>(vals: Vec<(Val<'p>, Ty)>) -> (Val<'p>, Ty) {
    if vals.len() != 1 {
        ruled_out!("a one-argument constructor given {}", vals.len());
    }
    vals.into_iter().next().unwrap_or((Val::Unit, Ty::Float))
}

/// The native computing an elementwise builtin that Cranelift has no
/// instruction for.
pub(super) fn unary_native_name(f: BuiltinFn) -> &'static str {
    match f {
        BuiltinFn::Exp => "tsl_exp",
        BuiltinFn::Log => "tsl_log",
        BuiltinFn::Sin => "tsl_sin",
        BuiltinFn::Cos => "tsl_cos",
        BuiltinFn::Tan => "tsl_tan",
        BuiltinFn::Asin => "tsl_asin",
        BuiltinFn::Acos => "tsl_acos",
        BuiltinFn::Atan => "tsl_atan",
        _ => "tsl_round",
    }
}

/// The native of a noise function of a `width`-lane point.
pub(super) fn native_name(f: BuiltinFn, width: usize) -> &'static str {
    match (f, width) {
        (BuiltinFn::Noise, 1) => "tsl_noise1",
        (BuiltinFn::Noise, 2) => "tsl_noise2",
        (BuiltinFn::Noise, _) => "tsl_noise3",
        (BuiltinFn::Pnoise, 1) => "tsl_pnoise1",
        (BuiltinFn::Pnoise, 2) => "tsl_pnoise2",
        (BuiltinFn::Pnoise, _) => "tsl_pnoise3",
        (_, 1) => "tsl_cellnoise1",
        (_, 2) => "tsl_cellnoise2",
        _ => "tsl_cellnoise3",
    }
}

pub(super) fn identity(b: &mut Builder) -> Vec<Value> {
    let one = b.f(1.0);
    diag(b, [one, one, one])
}

pub(super) fn diag(b: &mut Builder, d: [Value; 3]) -> Vec<Value> {
    let zero = b.f(0.0);
    let mut m = vec![zero; 12];
    m[0] = d[0];
    m[5] = d[1];
    m[10] = d[2];
    m
}

/// Rodrigues' rotation by `deg` degrees about `axis`.
pub(super) fn rotation(b: &mut Builder, deg: Value, axis: &[Value]) -> Vec<Value> {
    let a = b.normalize(axis);
    let k = b.f(std::f32::consts::PI / 180.0);
    let rad = b.fmul(deg, k);
    let (s, c) = (b.call("tsl_sin", vec![rad]), b.call("tsl_cos", vec![rad]));
    let one = b.f(1.0);
    let t = b.fsub(one, c);
    let zero = b.f(0.0);
    let mut m = vec![zero; 12];
    for r in 0..3 {
        for col in 0..3 {
            let aa = b.fmul(a[r], a[col]);
            let mut v = b.fmul(t, aa);
            if r == col {
                v = b.fadd(v, c);
            } else {
                // The cross-product term: +/- sin times the third axis component.
                let third = 3 - r - col;
                let sign = if (r + 1) % 3 == col { -1.0 } else { 1.0 };
                let sv = b.f(sign);
                let term = b.fmul(s, a[third]);
                let term = b.fmul(sv, term);
                v = b.fadd(v, term);
            }
            m[r * 4 + col] = v;
        }
    }
    m
}

pub(super) fn refract(b: &mut Builder, i: &[Value], n: &[Value], eta: Value) -> Vec<Value> {
    let d = b.dot(n, i);
    let one = b.f(1.0);
    let dd = b.fmul(d, d);
    let sin2 = b.fsub(one, dd);
    let ee = b.fmul(eta, eta);
    let e_sin2 = b.fmul(ee, sin2);
    let k = b.fsub(one, e_sin2);
    let zero = b.f(0.0);
    let tir = b.flt(k, zero);
    let root = b.un(UnOp::Sqrt, k);
    let ed = b.fmul(eta, d);
    let coef = b.fadd(ed, root);
    (0..3)
        .map(|c| {
            let a = b.fmul(eta, i[c]);
            let m = b.fmul(coef, n[c]);
            let r = b.fsub(a, m);
            b.select(tir, zero, r)
        })
        .collect()
}

/// HSV (all in [0, 1]) to RGB, the standard six-sector formula.
pub(super) fn hsv_to_rgb(b: &mut Builder, h: Value, s: Value, v: Value) -> [Value; 3] {
    let six = b.f(6.0);
    let one = b.f(1.0);
    let hf = b.un(UnOp::Floor, h);
    let h = b.fsub(h, hf);
    let h6 = b.fmul(h, six);
    let sector = b.un(UnOp::Floor, h6);
    let f = b.fsub(h6, sector);
    let one_s = b.fsub(one, s);
    let p = b.fmul(v, one_s);
    let sf = b.fmul(s, f);
    let one_sf = b.fsub(one, sf);
    let q = b.fmul(v, one_sf);
    let one_f = b.fsub(one, f);
    let s1f = b.fmul(s, one_f);
    let one_s1f = b.fsub(one, s1f);
    let t = b.fmul(v, one_s1f);
    let table = [[v, t, p], [q, v, p], [p, v, t], [p, q, v], [t, p, v], [v, p, q]];
    let mut out = table[5];
    for (k, row) in table.iter().enumerate().take(5).rev() {
        let kv = b.f(k as f32);
        let hit = b.feq(sector, kv);
        for c in 0..3 {
            out[c] = b.select(hit, row[c], out[c]);
        }
    }
    out
}

pub(super) fn xyz_rows_to_rgb(b: &mut Builder, xyz: [Value; 3]) -> [Value; 3] {
    // Columns of the XYZ → linear sRGB matrix, taken from the color module.
    let cols = [
        color::xyz_to_linear_srgb([1.0, 0.0, 0.0]),
        color::xyz_to_linear_srgb([0.0, 1.0, 0.0]),
        color::xyz_to_linear_srgb([0.0, 0.0, 1.0]),
    ];
    let mut out = [Value(0); 3];
    for (r, o) in out.iter_mut().enumerate() {
        let w = [cols[0][r], cols[1][r], cols[2][r]];
        *o = b.weighted(&w, &xyz);
    }
    out
}

/// Smits (1999): how much of each of the seven basis spectra (white, cyan,
/// magenta, yellow, red, green, blue) to add for an RGB triple. The same
/// case analysis as `color::smits_coefficients`, as selects.
pub(super) fn smits_coefficients(b: &mut Builder, rgb: [Value; 3]) -> Vec<Value> {
    let [r, g, bl] = rgb;
    let zero = b.f(0.0);
    let mut coef = vec![zero; 7];
    // Case: red is smallest → white r, then cyan and blue/green.
    let c_r = {
        let rg = b.bin(BinOp::FLe, r, g);
        let rb = b.bin(BinOp::FLe, r, bl);
        b.and(rg, rb)
    };
    let c_g = {
        let gr = b.bin(BinOp::FLe, g, r);
        let gb = b.bin(BinOp::FLe, g, bl);
        b.and(gr, gb)
    };
    // Otherwise blue is smallest.
    let cases = [
        // (smallest, a, b, white, two-channel basis index, a-only, b-only)
        (r, g, bl, 1usize, 5usize, 6usize),
        (g, r, bl, 2, 4, 6),
        (bl, r, g, 3, 4, 5),
    ];
    let mut per_case: Vec<Vec<Value>> = Vec::new();
    for (min, a, c, pair, a_only, c_only) in cases {
        let mut k = vec![zero; 7];
        k[0] = min;
        let a_le_c = b.bin(BinOp::FLe, a, c);
        let da = b.fsub(a, min);
        let dc = b.fsub(c, min);
        let ca = b.fsub(c, a);
        let ac = b.fsub(a, c);
        // The pair colour takes the smaller excess; the remainder goes to the
        // single-channel basis of the larger channel.
        k[pair] = b.select(a_le_c, da, dc);
        k[c_only] = b.select(a_le_c, ca, zero);
        k[a_only] = b.select(a_le_c, zero, ac);
        per_case.push(k);
    }
    for i in 0..7 {
        let gb = b.select(c_g, per_case[1][i], per_case[2][i]);
        coef[i] = b.select(c_r, per_case[0][i], gb);
    }
    coef
}

/// Interpolation weights of `n` knots at `t` in [0, 1]: piecewise linear,
/// or uniform Catmull-Rom with the end knots repeated.
pub(super) fn blend_weights(b: &mut Builder, t: Value, spline: Value, n: usize) -> Vec<Value> {
    if n == 0 {
        return Vec::new();
    }
    if n == 1 {
        return vec![b.f(1.0)];
    }
    let (zero, one) = (b.f(0.0), b.f(1.0));
    let t = b.clamp(t, zero, one);
    let span = b.f((n - 1) as f32);
    let x = b.fmul(t, span);
    let max_seg = b.f((n - 2) as f32);
    let fl = b.un(UnOp::Floor, x);
    let seg = b.fmin(fl, max_seg);
    let f = b.fsub(x, seg);
    let seg_i = b.un(UnOp::FToI, seg);
    // Catmull-Rom basis for knots seg-1 .. seg+2.
    let half = b.f(0.5);
    let f2 = b.fmul(f, f);
    let f3 = b.fmul(f2, f);
    let poly = |b: &mut Builder, c3: f32, c2: f32, c1: f32, c0: f32| {
        let (a3, a2, a1, a0) = (b.f(c3), b.f(c2), b.f(c1), b.f(c0));
        let t3 = b.fmul(a3, f3);
        let t2 = b.fmul(a2, f2);
        let t1 = b.fmul(a1, f);
        let s = b.fadd(t3, t2);
        let s = b.fadd(s, t1);
        let s = b.fadd(s, a0);
        b.fmul(half, s)
    };
    let basis = [
        poly(b, -1.0, 2.0, -1.0, 0.0),
        poly(b, 3.0, -5.0, 0.0, 2.0),
        poly(b, -3.0, 4.0, 1.0, 0.0),
        poly(b, 1.0, -1.0, 0.0, 0.0),
    ];
    let one_f = b.fsub(one, f);
    let last = (n - 1) as i32;
    (0..n)
        .map(|k| {
            let kv = b.i(k as i32);
            // Linear: the two knots around t.
            let at_seg = b.bin(BinOp::IEq, seg_i, kv);
            let next = b.i(1);
            let seg1 = b.bin(BinOp::IAdd, seg_i, next);
            let at_next = b.bin(BinOp::IEq, seg1, kv);
            let w_seg = b.select(at_seg, one_f, zero);
            let w_next = b.select(at_next, f, zero);
            let linear = b.fadd(w_seg, w_next);
            // Spline: knots seg-1 .. seg+2, indices clamped to the ends.
            let mut spl = zero;
            for (j, bj) in basis.iter().enumerate() {
                let off = b.i(j as i32 - 1);
                let idx = b.bin(BinOp::IAdd, seg_i, off);
                let lo = b.i(0);
                let hi = b.i(last);
                let below = b.bin(BinOp::ILt, idx, lo);
                let idx = b.select(below, lo, idx);
                let above = b.bin(BinOp::ILt, hi, idx);
                let idx = b.select(above, hi, idx);
                let hit = b.bin(BinOp::IEq, idx, kv);
                let term = b.select(hit, *bj, zero);
                spl = b.fadd(spl, term);
            }
            b.select(spline, spl, linear)
        })
        .collect()
}

/// `rough_transmittance`: with a constant roughness, index and
/// distribution, the interface's blended table as constant data and a
/// linear interpolation in `cos_theta` (the operations of
/// [`runtime::rough_interface::lerp_transmittance`], so both agree bit for
/// bit); otherwise a call of the native, which blends the same grid nodes
/// at run time.
fn rough_transmittance(b: &mut Builder, cos_theta: Value, alpha: Value, eta: Value, ggx: Value) -> Value {
    use crate::runtime::rough_interface::{ROUGH_INTERFACE_NODES, constant_table};
    let constant = match (b.fconst(alpha), b.fconst(eta), b.konst(ggx)) {
        (Some(alpha), Some(eta), Some(Const::B(ggx))) => constant_table(alpha, eta, ggx),
        _ => None,
    };
    let Some(table) = constant else {
        let (one, zero) = (b.f(1.0), b.f(0.0));
        let ggx = b.select(ggx, one, zero);
        return b.call("tsl_rough_transmittance", vec![cos_theta, alpha, eta, ggx]);
    };
    let table: &'static [u32] = table;
    let (zero, one) = (b.f(0.0), b.f(1.0));
    let c = b.fmax(cos_theta, zero);
    let c = b.fmin(c, one);
    let last = b.f((ROUGH_INTERFACE_NODES - 1) as f32);
    let x = b.fmul(c, last);
    let k = b.un(UnOp::FToI, x);
    let top = b.i(ROUGH_INTERFACE_NODES as i32 - 2);
    let below = b.bin(BinOp::ILt, k, top);
    let k = b.select(below, k, top);
    let kf = b.un(UnOp::IToF, k);
    let w = b.fsub(x, kf);
    let step = b.i(1);
    let k1 = b.bin(BinOp::IAdd, k, step);
    let lo = b.def(Scalar::F32, Op::Table { table, index: k });
    let hi = b.def(Scalar::F32, Op::Table { table, index: k1 });
    let d = b.fsub(hi, lo);
    let dw = b.fmul(d, w);
    b.fadd(lo, dw)
}
