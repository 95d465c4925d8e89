//! From the checked program's `scene { }` block to a [`SceneDesc`]: every
//! property evaluated (lowered on its own with `ir::lower::lower_value` and
//! run by the interpreter), checked against what rendering needs, and
//! every file the scene names read. Problems are diagnostics at the
//! property at fault; all of them are reported, not only the first.

use super::{
    AreaEmission, CameraDesc, DEFAULT_FPS, EnvironmentDesc, EnvironmentImage, EnvironmentSourceDesc, Frame,
    FrameRequest, IntegratorKind, Lanes, LightColor, LightDesc, LightSampling, MAX_DEPTH, MAX_FRAME, MAX_IMAGE_SIDE,
    MAX_PIXELS, MAX_SPP, MaterialDesc, MaterialRef, MeshData, ObjectDesc, Prop, RenderDesc, SceneDesc, ShapeDesc,
    Surface, Transform, Vec3, affine_rows, compose, mesh_transform_error, shape_transform_error,
};
use crate::check::{Program, SymbolKind, Ty};
use crate::color::ColorModel;
use crate::diag::{Diagnostic, Span};
use crate::globals::ShadingGlobals;
use crate::syntax::ast::{Expr, ExprKind, Scene, SceneBlock, SceneEntry, SceneProp, UnaryOp};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The model a scene's colors are evaluated in for a render in `model`
/// ([`SceneDesc::model`]). A hero render's wavelengths change per camera
/// sample: its scene colors are tabulated at the 64 bin centres and
/// interpolated when drawn.
pub fn description_model(model: ColorModel) -> ColorModel {
    if model == ColorModel::Hero { ColorModel::Spectral { samples: crate::color::MAX_SAMPLES } } else { model }
}

/// Describes the program's scene (the first `scene { }` block of the root
/// program and its imports) with colors in `model`. Files already read for
/// `reuse` (a description of the same program in another color model) are
/// not read again. `None` when the program has no scene or the scene has
/// errors; the diagnostics say which.
///
/// The program should check without errors: values are evaluated, and an
/// ill-typed one would only add noise.
pub fn describe(
    program: &Program,
    model: ColorModel,
    reuse: Option<&SceneDesc>,
) -> (Option<SceneDesc>, Vec<Diagnostic>) {
    describe_frame(program, model, reuse, &FrameRequest::default())
}

/// [`describe`] at one frame of an animation: `frame` and `time` read in
/// scene values take the frame's values. A frame number beyond
/// [`MAX_FRAME`] or an `fps` that is not a positive number is an error at
/// the scene.
pub fn describe_frame(
    program: &Program,
    model: ColorModel,
    reuse: Option<&SceneDesc>,
    request: &FrameRequest,
) -> (Option<SceneDesc>, Vec<Diagnostic>) {
    let Some((module, item, scene)) = super::root_scene(program) else { return (None, Vec::new()) };
    let file = program.loaded.modules[module].file;
    let model = description_model(model);
    let dir = Path::new(program.loaded.sources.name(file)).parent().map(Path::to_path_buf).unwrap_or_default();
    let globals = ShadingGlobals { frame: request.frame, ..ShadingGlobals::default() }.words();
    let values = crate::ir::lower::ValueLowerer::new(program, model);
    let mut d = Describer { program, model, module, item, dir, reuse, globals, diags: Vec::new(), named: None, values };
    let desc = d.scene(scene, request);
    let failed = d.diags.iter().any(Diagnostic::is_error);
    (desc.filter(|_| !failed), d.diags)
}

struct Describer<'a> {
    program: &'a Program,
    model: ColorModel,
    /// Where the scene is: module and item.
    module: usize,
    item: usize,
    /// The directory relative file names are resolved against: the one of
    /// the file that holds the scene.
    dir: PathBuf,
    reuse: Option<&'a SceneDesc>,
    /// The shading globals values are evaluated with: zero but for the
    /// frame globals.
    globals: [u32; crate::globals::GLOBAL_WORDS as usize],
    diags: Vec<Diagnostic>,
    /// The last object material found to be a plain material name.
    named: Option<Arc<str>>,
    /// Lowers the values, each constant once for them all.
    values: crate::ir::lower::ValueLowerer<'a>,
}

/// The words of a number or a tuple of numbers, written out, as lowering
/// and the interpreter would compute them (`as f32` of the literal, the
/// negation exact): a scene of a million spheres lowers no value.
fn literal_words(e: &Expr, ty: &Ty) -> Option<Words> {
    fn number(e: &Expr) -> Option<f32> {
        match &e.kind {
            ExprKind::Int(i) => Some(*i as f32),
            ExprKind::Float(x) => Some(*x as f32),
            ExprKind::Unary { op: UnaryOp::Neg, operand } => number(operand).map(|x| -x),
            _ => None,
        }
    }
    match (ty, &e.kind) {
        (Ty::Float, _) => Some(smallvec::smallvec![number(e)?.to_bits()]),
        (Ty::Vector | Ty::Point | Ty::Normal, ExprKind::Tuple(items)) if items.len() == 3 => {
            items.iter().map(|item| number(item).map(f32::to_bits)).collect()
        }
        _ => None,
    }
}

/// A value's words: a vector's three without allocating.
type Words = smallvec::SmallVec<[u32; 4]>;

fn find<'b>(props: &'b [SceneProp], name: &str) -> Option<&'b SceneProp> {
    props.iter().find(|p| p.name.name == name)
}

/// A value, or its default written at the block's span.
fn or_default<T>(given: Option<Option<Prop<T>>>, default: T, span: Span) -> Option<Prop<T>> {
    given.unwrap_or(Some(Prop::new(default, span)))
}

impl<'a> Describer<'a> {
    fn error(&mut self, span: Span, message: impl Into<String>) {
        self.diags.push(Diagnostic::error(span, message));
    }

    // ---------------------------------------------------------- values

    fn expr<'p>(&mut self, p: &'p SceneProp) -> Option<&'p Expr> {
        if p.value.is_none() {
            self.error(p.span, format!("`{}` needs a value", p.name.name));
        }
        p.value.as_ref()
    }

    /// The value's words, converted to `ty`.
    fn words(&mut self, e: &Expr, ty: &Ty) -> Option<Words> {
        self.value_words(e, ty, false)
    }

    /// [`Self::words`]; `emission`: a light's value, whose `spectrum(...)`
    /// curves are absolute (see `lower_value`).
    fn value_words(&mut self, e: &Expr, ty: &Ty, emission: bool) -> Option<Words> {
        if let Some(words) = literal_words(e, ty) {
            return Some(words);
        }
        let (f, diags) = self.values.lower("value", e, ty, emission);
        if !diags.is_empty() {
            self.diags.extend(diags);
            return None;
        }
        let mut out = Words::from_elem(0, f.results.len());
        crate::interp::run(&f, &self.globals, &[], &mut out);
        Some(out)
    }

    fn float(&mut self, p: &SceneProp) -> Option<Prop<f32>> {
        let e = self.expr(p)?;
        let x = f32::from_bits(*self.words(e, &Ty::Float)?.first()?);
        if !x.is_finite() {
            self.error(e.span, format!("`{}` is not a finite number: {x}", p.name.name));
            return None;
        }
        Some(Prop::new(x, e.span))
    }

    fn positive(&mut self, p: &SceneProp) -> Option<Prop<f32>> {
        let x = self.float(p)?;
        if x.value <= 0.0 {
            self.error(x.span, format!("`{}` must be positive, found {}", p.name.name, x.value));
            return None;
        }
        Some(x)
    }

    /// A whole number in `1..=max`.
    fn count(&mut self, p: &SceneProp, max: u32) -> Option<Prop<u32>> {
        let e = self.expr(p)?;
        let x = *self.words(e, &Ty::Int)?.first()? as i32;
        if x <= 0 {
            self.error(e.span, format!("`{}` must be positive, found {x}", p.name.name));
            return None;
        }
        if x as u32 > max {
            self.error(e.span, format!("`{}` must be at most {max}, found {x}", p.name.name));
            return None;
        }
        Some(Prop::new(x as u32, e.span))
    }

    fn vec3(&mut self, p: &SceneProp) -> Option<Prop<Vec3>> {
        let e = self.expr(p)?;
        let w = self.words(e, &Ty::Vector)?;
        let [x, y, z] = w[..] else { return None };
        let v = Vec3::new(f32::from_bits(x), f32::from_bits(y), f32::from_bits(z));
        if !v.is_finite() {
            self.error(e.span, format!("`{}` is not finite: {v}", p.name.name));
            return None;
        }
        Some(Prop::new(v, e.span))
    }

    /// A light's or emitter's color (every color of a scene is one): RGB is
    /// D65-based, `spectrum(...)` curves absolute spectral power.
    fn color(&mut self, p: &SceneProp) -> Option<Prop<Lanes>> {
        let e = self.expr(p)?;
        let lanes: Lanes = self
            .value_words(e, &Ty::Color, true)?
            .iter()
            .take(self.model.lanes())
            .map(|w| f32::from_bits(*w))
            .collect();
        if lanes.iter().any(|x| !x.is_finite() || *x < 0.0) {
            self.error(e.span, format!("`{}` must be finite and not negative, found {lanes:?}", p.name.name));
            return None;
        }
        Some(Prop::new(lanes, e.span))
    }

    fn string<'p>(&mut self, p: &'p SceneProp) -> Option<Prop<&'p str>> {
        let e = self.expr(p)?;
        match &e.kind {
            ExprKind::Str(s) => Some(Prop::new(s.as_str(), e.span)),
            _ => {
                self.error(e.span, format!("`{}` takes a string literal here", p.name.name));
                None
            }
        }
    }

    /// A file name, resolved against the scene's directory.
    fn path(&mut self, p: &SceneProp) -> Option<Prop<PathBuf>> {
        let name = self.string(p)?;
        let path = Path::new(name.value);
        let path = if path.is_absolute() { path.to_path_buf() } else { self.dir.join(path) };
        Some(Prop::new(path, name.span))
    }

    /// A required property, evaluated by `f`; missing is an error at the block.
    fn need<T>(
        &mut self,
        b: &SceneBlock,
        name: &str,
        f: impl FnOnce(&mut Self, &SceneProp) -> Option<Prop<T>>,
    ) -> Option<Prop<T>> {
        match find(&b.props, name) {
            Some(p) => f(self, p),
            None => {
                self.error(b.span, format!("this block is missing `{name}`"));
                None
            }
        }
    }

    /// An optional property: `None` when absent, `Some(None)` when invalid.
    fn get<T>(
        &mut self,
        b: &SceneBlock,
        name: &str,
        f: impl FnOnce(&mut Self, &SceneProp) -> Option<Prop<T>>,
    ) -> Option<Option<Prop<T>>> {
        find(&b.props, name).map(|p| f(self, p))
    }

    // ---------------------------------------------------------- blocks

    fn scene(&mut self, scene: &Scene, request: &FrameRequest) -> Option<SceneDesc> {
        let blocks = || {
            scene.entries.iter().enumerate().filter_map(|(k, e)| match e {
                SceneEntry::Block(b) => Some((k, b)),
                SceneEntry::Prop(_) => None,
            })
        };
        let keyword = Span { end: scene.span.start + 5, ..scene.span };
        // The render settings first: they say what `time` is.
        let mut render = Some(RenderDesc::default());
        for (_, b) in blocks().filter(|(_, b)| b.keyword.name == "render") {
            if !self.render(b, render.as_mut()) {
                render = None;
            }
        }
        let frame = self.frame(keyword, request, render.as_ref());
        let camera = match blocks().find(|(_, b)| b.keyword.name == "camera") {
            Some((_, b)) => self.camera(b),
            None => {
                self.error(keyword, "the scene has no camera");
                None
            }
        };
        let environment = self.environment(scene);
        let mut lights = Some(Vec::new());
        // Exactly as many (at most the area lights more): a million
        // objects grown by pushes held 1.6 million on average.
        let count = blocks().filter(|(_, b)| matches!(b.keyword.name.as_str(), "object" | "light")).count();
        let mut objects = Some(Vec::with_capacity(count));
        for (entry, b) in blocks() {
            let kind = b.kind.as_ref().map_or("", |k| k.name.as_str());
            match (b.keyword.name.as_str(), kind) {
                ("object", _) => {
                    let object = self.object(entry, b, kind);
                    push(&mut objects, object);
                }
                ("light", "point" | "spot" | "directional") => {
                    let light = self.light(b, kind);
                    push(&mut lights, light);
                }
                ("light", "rect" | "sphere") => {
                    let object = self.area_light(b, kind);
                    push(&mut objects, object);
                }
                _ => {}
            }
        }
        Some(SceneDesc {
            model: self.model,
            span: keyword,
            camera: camera?,
            render: render?,
            environment: environment?,
            lights: lights?,
            objects: objects?,
            frame: frame?,
        })
    }

    /// The frame described, its time found from the request and the
    /// render settings; the frame globals are set for every value after.
    fn frame(&mut self, scene: Span, request: &FrameRequest, render: Option<&RenderDesc>) -> Option<Frame> {
        let number = request.frame;
        if number.unsigned_abs() > MAX_FRAME as u32 {
            self.error(scene, format!("frame {number} is out of range: frames go from -{MAX_FRAME} to {MAX_FRAME}"));
            return None;
        }
        let time = match (request.fps, render?) {
            (Some(fps), _) if !(fps.is_finite() && fps > 0.0) => {
                self.error(scene, format!("the frame rate must be a positive number, found {fps}"));
                return None;
            }
            (Some(fps), _) => number as f32 / fps,
            (None, RenderDesc { time: Some(time), .. }) => time.value,
            (None, r) => number as f32 / r.fps.as_ref().map_or(DEFAULT_FPS, |f| f.value),
        };
        self.globals = ShadingGlobals { frame: number, time, ..ShadingGlobals::default() }.words();
        Some(Frame { number, time })
    }

    fn camera(&mut self, b: &SceneBlock) -> Option<CameraDesc> {
        let from = self.need(b, "from", Self::vec3);
        let to = self.need(b, "to", Self::vec3);
        let up = self.get(b, "up", Self::vec3);
        let fov = self.get(b, "fov", Self::positive);
        let aperture = self.get(b, "aperture", Self::float);
        let focus = self.get(b, "focus", Self::positive);
        let (up_given, up) = (up.is_some(), or_default(up, Vec3::Y, b.span));
        let fov = or_default(fov, 45.0, b.span);
        let aperture = or_default(aperture, 0.0, b.span);
        let mut ok = true;
        if let Some(fov) = &fov
            && !(fov.value > 0.0 && fov.value < 180.0)
        {
            self.error(fov.span, format!("the field of view must be between 0 and 180 degrees, found {}", fov.value));
            ok = false;
        }
        if let Some(a) = &aperture
            && !(a.value >= 0.0 && a.value.is_finite())
        {
            self.error(a.span, format!("the aperture must be zero or positive, found {}", a.value));
            ok = false;
        }
        let focus = match focus {
            Some(Some(f)) => Some(Some(f)),
            Some(None) => None,
            None => Some(None),
        };
        let (from, to, up, fov, aperture, focus) = (from?, to?, up?, fov?, aperture?, focus?);
        let forward = (to.value - from.value).normalize_or_zero();
        if forward == Vec3::ZERO {
            self.diags.push(
                Diagnostic::error(to.span, "the camera looks from a point to itself: `from` and `to` must differ")
                    .with_label(from.span, "`from` is here"),
            );
            return None;
        }
        let right = forward.cross(up.value).normalize_or_zero();
        if right == Vec3::ZERO || !right.is_finite() {
            let message = "the camera's `up` is parallel to its view direction (or zero)";
            self.diags.push(if up_given {
                Diagnostic::error(up.span, message).with_label(to.span, "the camera looks toward `to`")
            } else {
                Diagnostic::error(to.span, message)
                    .with_primary("the camera looks straight up or down, and `up` is (0, 1, 0) by default")
                    .with_help("give an `up` across the view, such as `up (0, 0, 1);`")
            });
            return None;
        }
        if focus.is_none() {
            let distance = (to.value - from.value).length();
            if !(distance > 0.0 && distance.is_finite()) {
                self.error(to.span, format!("the focus distance must be positive, found {distance}"));
                return None;
            }
        }
        if !ok {
            return None;
        }
        Some(CameraDesc { span: b.span, from, to, up, fov, aperture, focus })
    }

    /// Adds a `render { }` block's settings to `out`; false on an error.
    fn render(&mut self, b: &SceneBlock, out: Option<&mut RenderDesc>) -> bool {
        let mut s = RenderDesc::default();
        let mut ok = true;
        for p in &b.props {
            let name = p.name.name.as_str();
            let valid = match name {
                "width" => self.count(p, MAX_IMAGE_SIDE).map(|x| s.width = Some(x)),
                "height" => self.count(p, MAX_IMAGE_SIDE).map(|x| s.height = Some(x)),
                "spp" => self.count(p, MAX_SPP).map(|x| s.spp = Some(x)),
                "max_depth" => self.count(p, MAX_DEPTH).map(|x| s.max_depth = Some(x)),
                "seed" => self.expr(p).and_then(|e| {
                    let w = *self.words(e, &Ty::Int)?.first()?;
                    s.seed = Some(Prop::new(u64::from(w), e.span));
                    Some(())
                }),
                "integrator" => self.string(p).and_then(|v| match IntegratorKind::parse(v.value) {
                    Some(k) => {
                        s.integrator = Some(Prop::new(k, v.span));
                        Some(())
                    }
                    None => {
                        self.error(p.span, format!("unknown integrator \"{}\": use \"whitted\" or \"path\"", v.value));
                        None
                    }
                }),
                "light_sampling" => self.string(p).and_then(|v| match LightSampling::parse(v.value) {
                    Some(k) => {
                        s.light_sampling = Some(Prop::new(k, v.span));
                        Some(())
                    }
                    None => {
                        self.error(p.span, format!("unknown light_sampling \"{}\": use \"all\" or \"power\"", v.value));
                        None
                    }
                }),
                "fps" => self.positive(p).map(|x| s.fps = Some(x)),
                "time" => self.float(p).map(|x| s.time = Some(x)),
                _ => Some(()),
            };
            ok &= valid.is_some();
        }
        if let (Some(w), Some(h)) = (&s.width, &s.height)
            && u64::from(w.value) * u64::from(h.value) > MAX_PIXELS
        {
            let message = format!("{}x{} is more than the {MAX_PIXELS} pixels an image may have", w.value, h.value);
            self.error(h.span, message);
            ok = false;
        }
        if let Some(out) = out {
            // Later blocks override earlier ones (the checker allows one).
            let RenderDesc { width, height, spp, max_depth, seed, integrator, light_sampling, fps, time } = s;
            out.fps = fps.or(out.fps.take());
            out.time = time.or(out.time.take());
            out.width = width.or(out.width.take());
            out.height = height.or(out.height.take());
            out.spp = spp.or(out.spp.take());
            out.max_depth = max_depth.or(out.max_depth.take());
            out.seed = seed.or(out.seed.take());
            out.integrator = integrator.or(out.integrator.take());
            out.light_sampling = light_sampling.or(out.light_sampling.take());
        }
        ok
    }

    /// The `light environment { }` block or the top-level `background`
    /// (the checker allows one of them). `Some(None)` without either;
    /// `None` on an error.
    fn environment(&mut self, scene: &Scene) -> Option<Option<EnvironmentDesc>> {
        let entry = scene.entries.iter().find(|e| match e {
            SceneEntry::Prop(p) => p.name.name == "background",
            SceneEntry::Block(b) => {
                b.keyword.name == "light" && b.kind.as_ref().is_some_and(|k| k.name == "environment")
            }
        });
        match entry {
            None => Some(None),
            Some(SceneEntry::Prop(p)) => {
                let source = self.environment_source(p)?;
                Some(Some(EnvironmentDesc {
                    span: p.span,
                    source,
                    scale: Prop::new(1.0, p.span),
                    rotate: Prop::new(Vec3::ZERO, p.span),
                }))
            }
            Some(SceneEntry::Block(b)) => {
                let source = match (find(&b.props, "file"), find(&b.props, "radiance")) {
                    (Some(p), _) | (None, Some(p)) => self.environment_source(p),
                    (None, None) => {
                        self.error(b.span, "an environment needs `file` or `radiance`");
                        None
                    }
                };
                let scale = match self.get(b, "scale", Self::float) {
                    Some(Some(x)) if x.value < 0.0 => {
                        self.error(x.span, format!("`scale` must not be negative, found {}", x.value));
                        None
                    }
                    given => or_default(given, 1.0, b.span),
                };
                let rotate = self.get(b, "rotate", Self::vec3);
                let rotate = or_default(rotate, Vec3::ZERO, b.span);
                Some(Some(EnvironmentDesc { span: b.span, source: source?, scale: scale?, rotate: rotate? }))
            }
        }
    }

    /// A color, or a string naming a lat-long image (read here, so a
    /// missing or unreadable file is an error at its literal).
    fn environment_source(&mut self, p: &SceneProp) -> Option<EnvironmentSourceDesc> {
        if !matches!(self.expr(p)?.kind, ExprKind::Str(_)) {
            return Some(EnvironmentSourceDesc::Constant(self.color(p)?));
        }
        let path = self.path(p)?;
        let reused = self.reuse.and_then(|r| match &r.environment.as_ref()?.source {
            EnvironmentSourceDesc::Image(image) if image.value.path == path.value => Some(image.value.clone()),
            _ => None,
        });
        let image = match reused {
            Some(image) => image,
            None => match crate::image_io::load_environment(&path.value) {
                Ok(image) => {
                    if let Some(replaced) = image.non_finite {
                        let what = format!("the environment image {}", path.value.display());
                        self.diags.push(Diagnostic::warning(path.span, replaced.warning(&what)));
                    }
                    let (width, height, rgb) = (image.width, image.height, image.rgb);
                    Arc::new(EnvironmentImage { path: path.value, width, height, rgb })
                }
                Err(m) => {
                    self.error(path.span, m);
                    return None;
                }
            },
        };
        Some(EnvironmentSourceDesc::Image(Prop::new(image, path.span)))
    }

    fn light(&mut self, b: &SceneBlock, kind: &str) -> Option<LightDesc> {
        if kind == "directional" {
            let direction = self.need(b, "direction", Self::vec3);
            let irradiance = self.need(b, "irradiance", Self::color);
            let direction = direction?;
            let unit = direction.value.normalize_or_zero();
            if unit == Vec3::ZERO {
                self.error(direction.span, "a directional light needs a non-zero `direction`");
                return None;
            }
            return Some(LightDesc::Directional {
                span: b.span,
                direction: Prop::new(unit, direction.span),
                irradiance: irradiance?,
            });
        }
        let at = self.need(b, "at", Self::vec3);
        let intensity = match (find(&b.props, "intensity"), find(&b.props, "power")) {
            (Some(p), _) => self.color(p).map(|color| LightColor { color, from_power: false }),
            (None, Some(p)) => self.color(p).map(|color| LightColor { color, from_power: true }),
            (None, None) => {
                self.error(b.span, "this light needs `intensity` or `power`");
                None
            }
        };
        if kind == "point" {
            return Some(LightDesc::Point { span: b.span, at: at?, intensity: intensity? });
        }
        let to = self.need(b, "to", Self::vec3);
        let cone = self.get(b, "cone", Self::positive);
        let cone = or_default(cone, 30.0, b.span);
        let falloff = self.get(b, "falloff", Self::float);
        let falloff = or_default(falloff, 5.0, b.span);
        let (at, to, intensity, cone, falloff) = (at?, to?, intensity?, cone?, falloff?);
        let axis = (to.value - at.value).normalize_or_zero();
        let mut ok = true;
        if axis == Vec3::ZERO {
            self.diags.push(
                Diagnostic::error(to.span, "a spot light must point somewhere: `at` and `to` are the same point")
                    .with_label(at.span, "`at` is here"),
            );
            ok = false;
        }
        let (c, f) = (cone.value, falloff.value);
        if c >= 180.0 || f < 0.0 || f > c {
            let span = if c >= 180.0 { cone.span } else { falloff.span };
            self.error(
                span,
                format!("a spot light needs 0 < cone < 180 and 0 <= falloff <= cone, found cone {c}, falloff {f}"),
            );
            ok = false;
        }
        ok.then(|| LightDesc::Spot { span: b.span, at, axis: Prop::new(axis, to.span), intensity, cone, falloff })
    }

    fn area_light(&mut self, b: &SceneBlock, kind: &str) -> Option<ObjectDesc> {
        let shape = self.shape(b, if kind == "rect" { "quad" } else { kind });
        let emission = match (find(&b.props, "radiance"), find(&b.props, "power")) {
            (Some(p), _) => self.color(p).map(AreaEmission::Radiance),
            (None, Some(p)) => self.color(p).map(AreaEmission::Power),
            (None, None) => {
                self.error(b.span, "an area light needs `radiance` or `power`");
                None
            }
        };
        let shape = shape?;
        self.check_shape(&shape, &[], b.span)?;
        Some(ObjectDesc { span: b.span, shape, transforms: Vec::new(), surface: Surface::Emitter(emission?) })
    }

    fn object(&mut self, entry: usize, b: &SceneBlock, kind: &str) -> Option<ObjectDesc> {
        let transforms = self.transforms(b);
        let shape = if kind == "mesh" {
            self.need(b, "file", Self::mesh).map(|file| ShapeDesc::Mesh { file })
        } else {
            self.shape(b, kind)
        };
        let material = match b.props.iter().position(|p| p.name.name == "material") {
            Some(prop) => self.material(&b.props[prop], entry, prop),
            None => {
                self.error(b.span, "this object is missing `material`");
                None
            }
        };
        let (shape, transforms) = (shape?, transforms?);
        self.check_shape(&shape, &transforms, b.span)?;
        Some(ObjectDesc { span: b.span, shape, transforms, surface: Surface::Material(material?) })
    }

    /// A mesh file, read (or reused from the description being reused).
    fn mesh(&mut self, p: &SceneProp) -> Option<Prop<Arc<MeshData>>> {
        let path = self.path(p)?;
        let reused = self.reuse.and_then(|r| {
            r.objects.iter().find_map(|o| match &o.shape {
                ShapeDesc::Mesh { file } if file.value.path == path.value => Some(file.value.clone()),
                _ => None,
            })
        });
        if let Some(mesh) = reused {
            return Some(Prop::new(mesh, path.span));
        }
        match MeshData::load(&path.value) {
            Ok(mesh) => Some(Prop::new(Arc::new(mesh), path.span)),
            Err(m) => {
                self.error(path.span, m);
                None
            }
        }
    }

    fn material(&mut self, p: &SceneProp, entry: usize, prop: usize) -> Option<MaterialDesc> {
        let e = self.expr(p)?;
        // A bare name of a material: its entries are compiled once however
        // many objects use it.
        let name = match &e.kind {
            // Objects of a generated scene name one material after another.
            ExprKind::Name(n) if self.named.as_deref() == Some(n.as_str()) => self.named.clone(),
            ExprKind::Name(n) => {
                let found = self
                    .program
                    .symbols
                    .get(n.as_str())
                    .filter(|s| matches!(s.kind, SymbolKind::Material | SymbolKind::MaterialTree))
                    .map(|_| Arc::<str>::from(n.as_str()));
                self.named.clone_from(&found);
                found
            }
            _ => None,
        };
        let material = MaterialRef::SceneValue {
            module: self.module as u32,
            item: self.item as u32,
            entry: entry as u32,
            prop: prop as u32,
        };
        Some(MaterialDesc { material, name, span: e.span })
    }

    /// An analytic shape's properties (area lights: `rect` as a quad, and
    /// `sphere`).
    fn shape(&mut self, b: &SceneBlock, kind: &str) -> Option<ShapeDesc> {
        Some(match kind {
            "sphere" => {
                let center = self.need(b, "center", Self::vec3);
                let radius = self.need(b, "radius", Self::positive);
                ShapeDesc::Sphere { center: center?, radius: radius? }
            }
            "plane" => {
                let point = self.need(b, "point", Self::vec3);
                let normal = self.need(b, "normal", Self::vec3);
                let tile = self.get(b, "tile", Self::positive);
                let tile = or_default(tile, 1.0, b.span);
                ShapeDesc::Plane { point: point?, normal: normal?, tile: tile? }
            }
            "quad" => {
                let corner = self.need(b, "corner", Self::vec3);
                let edge1 = self.need(b, "edge1", Self::vec3);
                let edge2 = self.need(b, "edge2", Self::vec3);
                ShapeDesc::Quad { corner: corner?, edge1: edge1?, edge2: edge2? }
            }
            "disk" => {
                let center = self.need(b, "center", Self::vec3);
                let normal = self.need(b, "normal", Self::vec3);
                let radius = self.need(b, "radius", Self::positive);
                ShapeDesc::Disk { center: center?, normal: normal?, radius: radius? }
            }
            "box" => {
                let min = self.need(b, "min", Self::vec3);
                let max = self.need(b, "max", Self::vec3);
                ShapeDesc::Box { min: min?, max: max? }
            }
            "cylinder" => {
                let base = self.need(b, "base", Self::vec3);
                let axis = self.get(b, "axis", Self::vec3);
                let axis = or_default(axis, Vec3::Y, b.span);
                let radius = self.need(b, "radius", Self::positive);
                let height = self.need(b, "height", Self::positive);
                ShapeDesc::Cylinder { base: base?, axis: axis?, radius: radius?, height: height? }
            }
            // Unknown kinds were reported by the checker.
            _ => return None,
        })
    }

    /// An object's transforms, in the order written.
    fn transforms(&mut self, b: &SceneBlock) -> Option<Vec<Prop<Transform>>> {
        let mut out = Some(Vec::new());
        for p in &b.props {
            let step = match p.name.name.as_str() {
                "translate" => self.vec3(p).map(|v| Prop::new(Transform::Translate(v.value), v.span)),
                "rotate" => self.vec3(p).map(|v| Prop::new(Transform::Rotate(v.value), v.span)),
                "scale" => {
                    let triple =
                        p.value.as_ref().and_then(|e| self.program.expr_types.get(&e.span)).is_some_and(Ty::is_triple);
                    if triple {
                        self.vec3(p).map(|v| Prop::new(Transform::Scale(v.value), v.span))
                    } else {
                        self.float(p).map(|x| Prop::new(Transform::Scale(Vec3::splat(x.value)), x.span))
                    }
                }
                "transform" => self.expr(p).and_then(|e| {
                    let w: Vec<f32> = self.words(e, &Ty::Matrix)?.iter().map(|w| f32::from_bits(*w)).collect();
                    (w.len() == 12).then(|| Prop::new(Transform::Matrix(affine_rows(&w)), e.span))
                }),
                _ => continue,
            };
            push(&mut out, step);
        }
        out
    }

    /// Checks that the transforms can place the shape and that its numbers
    /// make a shape; an error points at the property at fault.
    fn check_shape(&mut self, shape: &ShapeDesc, transforms: &[Prop<Transform>], block: Span) -> Option<()> {
        let mesh = matches!(shape, ShapeDesc::Mesh { .. });
        let error_of = |m: &super::Mat4| if mesh { mesh_transform_error(m) } else { shape_transform_error(m) };
        let to_world = compose(transforms.iter().map(|t| &t.value));
        if let Some(message) = error_of(&to_world) {
            // Blame the step from which on every partial composition fails.
            let mut m = super::Mat4::IDENTITY;
            let mut blame = transforms.first().map_or(block, |t| t.span);
            let mut failing = false;
            for t in transforms {
                m = t.value.matrix() * m;
                let fails = error_of(&m).is_some();
                if fails && !failing {
                    blame = t.span;
                }
                failing = fails;
            }
            self.error(blame, message);
            return None;
        }
        if let Some(kind) = shape.kind()
            && let Err(e) = kind.validated()
        {
            let span = shape.span_of(e.property).unwrap_or(block);
            self.error(span, e.message);
            return None;
        }
        Some(())
    }
}

/// Appends `item` to `list`, or spoils the list when `item` failed.
fn push<T>(list: &mut Option<Vec<T>>, item: Option<T>) {
    match (list.as_mut(), item) {
        (Some(l), Some(x)) => l.push(x),
        _ => *list = None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Mat4;
    use crate::test_support::temp_dir;

    fn checked(dir: &Path, scene: &str) -> crate::Checked {
        std::fs::write(dir.join("t.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let src = dir.join("s.tsl");
        std::fs::write(&src, scene).unwrap();
        crate::check_file(&src, &crate::LoadOptions::default())
    }

    #[test]
    fn another_color_model_evaluates_colors_again_and_reuses_the_files() {
        let dir = temp_dir("describe-reuse");
        let checked = checked(
            &dir,
            r#"scene {
                camera { from (0, 0, 5); to (0, 0, 0); }
                light point { at (0, 4, 0); intensity rgb(1, 0.5, 0.25); }
                object mesh { file "t.obj"; translate (0, 1, 0); material lambert; }
            }"#,
        );
        let rgb = checked.scene.as_ref().unwrap_or_else(|| panic!("{}", checked.render_diagnostics()));
        let model = ColorModel::Spectral { samples: 8 };
        let (spectral, diags) = describe(&checked.program, model, Some(rgb));
        let spectral = spectral.unwrap();
        assert!(diags.is_empty());
        let intensity = |d: &SceneDesc| match &d.lights[0] {
            LightDesc::Point { intensity, .. } => intensity.color.value.len(),
            _ => 0,
        };
        assert_eq!((intensity(rgb), intensity(&spectral)), (3, 8));
        let mesh = |d: &SceneDesc| match &d.objects[0].shape {
            ShapeDesc::Mesh { file } => file.value.clone(),
            _ => panic!("not a mesh"),
        };
        assert!(Arc::ptr_eq(&mesh(rgb), &mesh(&spectral)), "the mesh was read again");
        assert_eq!(spectral.objects[0].to_world(), Mat4::from_translation(glam::Vec3::Y));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_compiler_for_a_spectral_model_describes_the_scene_once_in_it() {
        // A million-object spectral render holds one description, not an
        // RGB one beside it.
        let src = "scene { camera { from (0, 0, 5); to (0, 0, 0); } light point { at (0, 4, 0); intensity gray(2); } }";
        for model in [ColorModel::Rgb, ColorModel::Spectral { samples: 8 }, ColorModel::Hero] {
            let options = crate::LoadOptions { color_model: model, ..crate::LoadOptions::default() };
            let checked = crate::check_source("s.tsl", src, &options);
            assert_eq!(checked.scene.as_ref().map(|d| d.model), Some(description_model(model)));
            let program = crate::Compiler::new().color_model(model).source("s.tsl", src).compile().unwrap();
            assert_eq!(program.scene().map(|d| d.model), Some(description_model(model)));
        }
        assert_eq!(description_model(ColorModel::Hero), ColorModel::Spectral { samples: crate::color::MAX_SAMPLES });
    }

    #[test]
    fn materials_are_handles_to_what_the_scene_wrote() {
        let dir = temp_dir("describe-materials");
        let checked = checked(
            &dir,
            r#"material red = lambert(kd: rgb(0.8, 0.1, 0.1));
            scene {
                camera { from (0, 0, 5); to (0, 0, 0); }
                object sphere { center (0, 0, 0); radius 1; material red; }
                light rect { corner (0, 2, 0); edge1 (1, 0, 0); edge2 (0, 0, 1); power gray(10); }
                object mesh { file "t.obj"; material mix(0.5, red, mirror); }
            }"#,
        );
        let desc = checked.scene.as_ref().unwrap_or_else(|| panic!("{}", checked.render_diagnostics()));
        let surfaces: Vec<&Surface> = desc.objects.iter().map(|o| &o.surface).collect();
        let [Surface::Material(named), Surface::Emitter(AreaEmission::Power(_)), Surface::Material(written)] =
            surfaces[..]
        else {
            panic!("{surfaces:?}")
        };
        assert_eq!(named.name.as_deref(), Some("red"));
        assert_eq!(written.name, None);
        let expr = checked.program.material_expr(written.material).unwrap();
        assert_eq!(expr.span, written.span);
        assert!(matches!(expr.kind, ExprKind::Call { .. }), "{:?}", expr.kind);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
