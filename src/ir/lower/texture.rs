//! Texture calls: the sampler a call names and the footprint of its
//! coordinates, found by evaluating them again at the neighbouring pixels;
//! and `triplanar`, which evaluates a value three times with (u, v) taken
//! from the point's position along the three axes.

use super::*;

impl<'p> Lowerer<'p> {
    /// `texture(file, st, ...)`, `texture_float(file, st, channel, ...)`
    /// and `texture_vector(file, st, ...)` (the stored RGB as a vector).
    /// The footprint is `dx`/`dy` when given; else `st` is evaluated again at
    /// the neighbouring pixels (the globals moved by their derivatives), so
    /// any expression of the globals gets its true change per pixel. When
    /// that shows no change (`st` is a local or a parameter computed
    /// earlier), the footprint of (u, v) stands in.
    pub(super) fn texture(
        &mut self,
        b: &mut Builder,
        fr: &mut Frame<'p>,
        ctx: &Ctx,
        spec: &crate::check::Builtin,
        bound: &[Option<&'p Expr>],
        e: &'p Expr,
    ) -> Val<'p> {
        let color = spec.func == BuiltinFn::Texture;
        let width = match spec.func {
            BuiltinFn::Texture => self.lanes,
            BuiltinFn::TextureVector => 3,
            _ => 1,
        };
        let st_arg = spec.arg(bound, "st");
        // Jakob–Hanika models look texels' spectra up, converted at load.
        let spectral = color && matches!(self.model, ColorModel::Spectral { .. } | ColorModel::Hero);
        let Some(sampler) = self.sampler(e.span, spectral) else {
            self.error(e.span, "internal error: this texture call has no loaded image");
            return Val::Lanes(b.zeros(width));
        };
        let eval_st = |me: &mut Self, b: &mut Builder, fr: &mut Frame<'p>, c: &Ctx| -> Vec<Value> {
            match st_arg {
                Some(st) => {
                    let v = me.expr_as(b, fr, c, st, &Ty::Vec2);
                    me.lanes(b, v, &Ty::Vec2)
                }
                None => {
                    let u = me.shading_global(b, c, "u");
                    let v = me.shading_global(b, c, "v");
                    vec![u[0], v[0]]
                }
            }
        };
        let st = eval_st(self, b, fr, ctx);
        let uv_footprint = |me: &mut Self, b: &mut Builder, axis: &str| -> Vec<Value> {
            let du = me.shading_global(b, ctx, &format!("dud{axis}"));
            let dv = me.shading_global(b, ctx, &format!("dvd{axis}"));
            vec![du[0], dv[0]]
        };
        let mut derivs = Vec::new();
        for (param, axis) in [("dx", "x"), ("dy", "y")] {
            let d = match spec.arg(bound, param) {
                Some(d) => {
                    let v = self.expr_as(b, fr, ctx, d, &Ty::Vec2);
                    self.lanes(b, v, &Ty::Vec2)
                }
                None if st_arg.is_none() => uv_footprint(self, b, axis),
                None => {
                    let shifted = self.pixel_neighbour(b, ctx, axis);
                    let moved = eval_st(self, b, fr, &shifted);
                    if moved == st { uv_footprint(self, b, axis) } else { b.map2(BinOp::FSub, &moved, &st) }
                }
            };
            derivs.push(d);
        }
        let mut coords = vec![st[0], st[1], derivs[0][0], derivs[0][1], derivs[1][0], derivs[1][1]];
        if spectral {
            if self.model == ColorModel::Hero {
                coords.extend(super::spectral::hero_normalised_wavelengths(b));
            } else {
                coords.extend([b.f(0.0); 4]);
            }
            return Val::Lanes(b.texture(&sampler, coords));
        }
        let rgba = b.texture(&sampler, coords);
        if color {
            return Val::Lanes(self.rgb_to_lanes(b, [rgba[0], rgba[1], rgba[2]]));
        }
        if spec.func == BuiltinFn::TextureVector {
            return Val::Lanes(rgba[..3].to_vec());
        }
        let channel = match spec.arg(bound, "channel") {
            Some(c) => {
                let v = self.expr(b, fr, ctx, c);
                self.scalar(b, v)
            }
            None => b.i(0),
        };
        self.index(b, Val::Lanes(rgba.to_vec()), &Ty::Float, channel)
    }

    /// `triplanar(value, sharpness)`: `value` evaluated with (u, v) (and
    /// their footprint) replaced by the world position projected along x,
    /// y and z, blended by `|N_axis|^sharpness`, normalised. Each
    /// projection reads its picture upright and unmirrored from outside:
    /// along x, (-sign(Nx) Pz, Py); along y, (Px, -sign(Ny) Pz); along z,
    /// (sign(Nz) Px, Py).
    pub(super) fn triplanar(
        &mut self,
        b: &mut Builder,
        fr: &mut Frame<'p>,
        ctx: &Ctx,
        bound: &[Option<&'p Expr>],
        ty: &Ty,
    ) -> Val<'p> {
        let width = self.lanes_of(ty);
        let Some(value) = bound.first().copied().flatten() else {
            ruled_out!("`triplanar` without its value");
            return Val::Lanes(b.zeros(width));
        };
        let sharpness = match bound.get(1).copied().flatten() {
            Some(s) => {
                let v = self.expr_as(b, fr, ctx, s, &Ty::Float);
                self.scalar(b, v)
            }
            None => b.f(TRIPLANAR_SHARPNESS),
        };
        // A negative exponent would make an axis the normal does not face
        // weigh infinitely.
        let no_exponent = b.f(0.0);
        let sharpness = b.fmax(sharpness, no_exponent);
        let g = |me: &mut Self, b: &mut Builder, name: &str| me.shading_global(b, ctx, name);
        let (p, n, dpdx, dpdy) = (g(self, b, "P"), g(self, b, "N"), g(self, b, "dPdx"), g(self, b, "dPdy"));
        let (zero, one) = (b.f(0.0), b.f(1.0));
        let minus_one = b.f(-1.0);
        // Per projection: the axis; the axis u is read from, its sign, and
        // whether it turns with the side N faces; likewise v.
        let planes = [
            (0, (2, -1.0, true), (1, 1.0, false)),
            (1, (0, 1.0, false), (2, -1.0, true)),
            (2, (0, 1.0, true), (1, 1.0, false)),
        ];
        let mut weights = Vec::new();
        let mut values = Vec::new();
        for (axis, (u_axis, u_sign, u_turns), (v_axis, v_sign, v_turns)) in planes {
            let below = b.flt(n[axis], zero);
            let side = b.select(below, minus_one, one);
            let project = |b: &mut Builder, x: &[Value], k: usize, sign: f32, turns: bool| -> Value {
                let s = b.f(sign);
                let x = b.fmul(x[k], s);
                if turns { b.fmul(x, side) } else { x }
            };
            let u = project(b, &p, u_axis, u_sign, u_turns);
            let v = project(b, &p, v_axis, v_sign, v_turns);
            let mut changes = vec![("u", vec![u]), ("v", vec![v])];
            for (d, axis_name) in [(&dpdx, "x"), (&dpdy, "y")] {
                let du = project(b, d, u_axis, u_sign, u_turns);
                let dv = project(b, d, v_axis, v_sign, v_turns);
                changes.push((if axis_name == "x" { "dudx" } else { "dudy" }, vec![du]));
                changes.push((if axis_name == "x" { "dvdx" } else { "dvdy" }, vec![dv]));
            }
            let projected = self.with_overrides(b, ctx, changes);
            let v = self.expr_as(b, fr, &projected, value, ty);
            values.push(self.lanes(b, v, ty));
            let along = b.un(UnOp::FAbs, n[axis]);
            weights.push(b.call("tsl_pow", vec![along, sharpness]));
        }
        // Normalised weights; a zero or NaN normal weighs the three alike.
        let sum = b.fadd(weights[0], weights[1]);
        let sum = b.fadd(sum, weights[2]);
        let usable = b.flt(zero, sum);
        let third = b.f(1.0 / 3.0);
        let inv = b.fdiv(one, sum);
        let mut acc = b.zeros(width);
        for (w, v) in weights.iter().zip(&values) {
            let share = b.fmul(*w, inv);
            let share = b.select(usable, share, third);
            let term = b.scale(v, share);
            acc = b.map2(BinOp::FAdd, &acc, &term);
        }
        Val::Lanes(acc)
    }

    /// The sampler of the texture call at `span`, made once per image,
    /// filter, address modes and kind (RGBA, or `spectral`: the texels'
    /// spectra at the model's lanes).
    pub(super) fn sampler(&mut self, span: Span, spectral: bool) -> Option<Arc<Sampler>> {
        let call = *self.program.texture_calls.get(&span)?;
        let image = self.program.images.get(call.image)?.image.clone()?;
        let lanes = spectral.then(|| match self.model {
            ColorModel::Hero => SpectralLanes::Hero,
            model => {
                SpectralLanes::Fixed(model.wavelengths().iter().map(|&l| super::spectral::normalised(l)).collect())
            }
        });
        Some(
            self.samplers
                .entry((call, spectral))
                .or_insert_with(|| Arc::new(Sampler { image, filter: call.filter, wrap: call.wrap, spectral: lanes }))
                .clone(),
        )
    }

    /// The coordinate context of the next pixel in `axis` ("x" or "y"):
    /// P and Pl moved by dP/d`axis`, u and v by their derivatives.
    pub(super) fn pixel_neighbour(&mut self, b: &mut Builder, ctx: &Ctx, axis: &str) -> Ctx {
        let g = |me: &mut Self, b: &mut Builder, name: &str| me.shading_global(b, ctx, name);
        let dp = g(self, b, &format!("dPd{axis}"));
        let mut changes = Vec::new();
        for name in ["P", "Pl"] {
            let p = g(self, b, name);
            changes.push((name, b.map2(BinOp::FAdd, &p, &dp)));
        }
        for name in ["u", "v"] {
            let x = g(self, b, name);
            let d = g(self, b, &format!("d{name}d{axis}"));
            changes.push((name, vec![b.fadd(x[0], d[0])]));
        }
        self.with_overrides(b, ctx, changes)
    }
}

/// `triplanar`'s default sharpness: the exponent of the normal's components
/// in the blend weights (1 blends widely, large values give hard seams).
pub const TRIPLANAR_SHARPNESS: f32 = 4.0;
