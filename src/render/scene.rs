//! Building a renderable [`Scene`] from a compiled program's `scene { ... }`
//! block: property values are evaluated (they are constants: the checker
//! keeps shading globals out of them), shapes and meshes are made, every
//! object's material is compiled, lights (the environment among them) are
//! gathered and weighed by power, and the BVH is built.
//!
//! Every failure here (a missing mesh, a degenerate camera, a zero-size
//! image) is an [`Error`] pointing at the property that caused it.

use super::camera::Camera;
use super::environment::{Environment, EnvironmentMap, EnvironmentSource};
use super::geometry::{Geometry, ObjectGeometry};
use super::light::{Light, LightKind, LightSampler};
use super::mesh::Mesh;
use super::shape::{Shape, ShapeKind};
use super::{Mat4, Vec3};
use crate::check::{SymbolKind, Ty};
use crate::diag::{Diagnostic, Span};
use crate::image_io;
use crate::syntax::ast::{Expr, ExprKind, Item, SceneBlock, SceneEntry, SceneProp};
use crate::{Color, ColorModel, Error, Material, Program};
use std::path::{Path, PathBuf};

/// Which light-transport algorithm renders the image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IntegratorKind {
    /// The second paper's renderer: direct light, perfect reflection and
    /// refraction, recursively.
    Whitted,
    /// Unidirectional Monte Carlo path tracing with next-event estimation
    /// and multiple importance sampling.
    Path,
}

impl IntegratorKind {
    pub fn parse(name: &str) -> Option<IntegratorKind> {
        match name {
            "whitted" => Some(IntegratorKind::Whitted),
            "path" => Some(IntegratorKind::Path),
            _ => None,
        }
    }
}

/// How the path tracer chooses lights for next-event estimation. (Whitted
/// always sums every light.)
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LightSampling {
    /// Every light, one sample each, at every vertex: exact summation, cost
    /// growing with the number of lights.
    All,
    /// One light per vertex, chosen in proportion to its power
    /// ([`Light::power`]): the cost of one light however many there are.
    Power,
}

impl LightSampling {
    pub fn parse(name: &str) -> Option<LightSampling> {
        match name {
            "all" => Some(LightSampling::All),
            "power" => Some(LightSampling::Power),
            _ => None,
        }
    }
}

/// Which ways of finding the light of area lights and the environment the
/// path tracer combines. Each alone is unbiased, so all three agree in
/// expectation; tests compare them. Not part of the scene language.
#[doc(hidden)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Strategy {
    /// Light sampling and material sampling, weighted by the power
    /// heuristic.
    Mis,
    /// Material sampling only: light is found when a path hits it.
    Material,
    /// Light sampling only: paths that hit a light after a non-delta
    /// bounce count only where light sampling cannot reach.
    Light,
}

/// Render settings: the scene's `render { }` block, then overrides.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// Path segments from the camera (Mitsuba's `max_depth`; for Whitted,
    /// POV-Ray's `max_trace_level`: the camera ray has depth 1).
    pub max_depth: u32,
    pub seed: u64,
    pub integrator: IntegratorKind,
    pub light_sampling: LightSampling,
    #[doc(hidden)]
    pub strategy: Strategy,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            width: 640,
            height: 480,
            spp: 16,
            max_depth: 8,
            seed: 0,
            integrator: IntegratorKind::Path,
            light_sampling: LightSampling::Power,
            strategy: Strategy::Mis,
        }
    }
}

/// Settings given outside the scene file (the command line), which win.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Overrides {
    pub resolution: Option<(u32, u32)>,
    pub spp: Option<u32>,
    pub max_depth: Option<u32>,
    pub seed: Option<u64>,
    pub integrator: Option<IntegratorKind>,
    pub light_sampling: Option<LightSampling>,
}

/// Scenes with more delta lights than this shade them one call each.
pub const MAX_SUMMED_LIGHTS: usize = 8;

/// One object: its geometry and material.
pub struct Object {
    pub material: Material,
    /// `reflection` summed over all the scene's delta lights (point, spot,
    /// directional, in scene order) in one call; see
    /// `ir::lower::lower_reflection_sums`.
    pub reflection_sum: Option<crate::Function>,
    /// For an object that reflects or refracts: both perfect directions
    /// and their weights in one call (`ir::lower::lower_delta_lobes`).
    pub delta_lobes: Option<crate::Function>,
    /// For the path tracer: `f · cos` and `pdf` of a light direction in one
    /// call (`ir::lower::lower_eval_pdf`); absent for area lights given as
    /// `light rect` or `light sphere`, whose emitter reflects nothing.
    pub eval_pdf: Option<crate::Function>,
    /// The material's `sample` entry, called with the tracer's own buffers.
    pub sample: crate::Function,
    /// Multiplies the material's emission (area lights given as `light rect`
    /// or `light sphere` use the stdlib `emitter` scaled to their radiance,
    /// as pbrt's area lights take a `scale`).
    pub emission_scale: Option<Color>,
    /// The material may emit: its `emission` is not the default black.
    pub emissive: bool,
    /// `opaque()` is the constant `true`: shadow rays need not ask.
    pub always_opaque: bool,
    /// `reflection_dir` / `refraction_dir` are not the default zero.
    pub reflects: bool,
    pub refracts: bool,
    /// Light may cross the surface: it refracts, or is not always opaque
    /// (a rough dielectric has no perfect direction but lets paths through).
    pub transmits: bool,
    /// Some method reads the pixel footprint (dPdx, ..., dvdy).
    pub reads_footprint: bool,
    /// `absorption` is the identity: nothing to call along rays inside.
    pub clear: bool,
    /// `refraction_index` when it is a constant, so it is not called.
    pub constant_ior: Option<Vec<f32>>,
    /// Some method reads u, v, dPdu or dPdv (or the footprint, which
    /// needs them).
    pub reads_uv: bool,
    /// Where the object is defined, for messages.
    pub span: Span,
}

/// A scene ready to render.
pub struct Scene {
    pub camera: Camera,
    pub settings: Settings,
    pub objects: Vec<Object>,
    pub geometry: Geometry,
    /// Delta lights in scene order, then area lights, then the
    /// environment (when it is not black).
    pub lights: Vec<Light>,
    /// The area light of each object, if it is one.
    pub light_of_object: Vec<Option<usize>>,
    /// The light that is the environment; without one, rays that leave
    /// the scene see black.
    pub environment_light: Option<usize>,
    /// Chooses lights by power (for [`LightSampling::Power`]).
    pub light_sampler: LightSampler,
    pub model: ColorModel,
    /// Seconds spent loading meshes and building the BVH.
    pub build_seconds: f64,
}

impl Scene {
    /// The environment, when it is not black.
    pub fn environment(&self) -> Option<&Environment> {
        match &self.lights.get(self.environment_light?)?.kind {
            LightKind::Environment(env) => Some(env),
            _ => None,
        }
    }

    /// The probability that next-event estimation picks light `k`: 1 when
    /// every light is sampled.
    pub fn light_pmf(&self, k: usize) -> f32 {
        match self.settings.light_sampling {
            LightSampling::All => 1.0,
            LightSampling::Power => self.light_sampler.pmf(k),
        }
    }

    /// Builds the scene of a compiled program. Relative file names (meshes,
    /// environment images) are resolved against the directory of the file
    /// that holds the scene.
    pub fn build(program: &Program, overrides: &Overrides) -> Result<Scene, Error> {
        let start = std::time::Instant::now();
        let scene = Builder::new(program)?.build(overrides)?;
        Ok(Scene { build_seconds: start.elapsed().as_secs_f64(), ..scene })
    }
}

struct Builder<'a> {
    program: &'a Program,
    scene: &'a crate::syntax::ast::Scene,
    /// The directory relative file names are resolved against.
    dir: PathBuf,
    model: ColorModel,
}

fn find<'b>(props: &'b [SceneProp], name: &str) -> Option<&'b SceneProp> {
    props.iter().find(|p| p.name.name == name)
}

fn f32s(words: &[u32]) -> Vec<f32> {
    words.iter().map(|w| f32::from_bits(*w)).collect()
}

impl<'a> Builder<'a> {
    fn new(program: &'a Program) -> Result<Builder<'a>, Error> {
        let checked = program.checked();
        for module in checked.loaded.modules.iter().filter(|m| !m.is_prelude) {
            for item in &module.ast.items {
                if let Item::Scene(scene) = item {
                    let name = checked.loaded.sources.name(module.file);
                    let dir = Path::new(name).parent().map(Path::to_path_buf).unwrap_or_default();
                    return Ok(Builder { program, scene, dir, model: program.color_model() });
                }
            }
        }
        Err(Error::plain("the program has no `scene { ... }` block to render".into()))
    }

    fn error(&self, span: Span, message: impl Into<String>) -> Error {
        self.program.error(Diagnostic::error(span, message))
    }

    fn expr(&self, p: &'a SceneProp) -> Result<&'a Expr, Error> {
        p.value.as_ref().ok_or_else(|| self.error(p.span, format!("`{}` needs a value", p.name.name)))
    }

    fn words(&self, p: &'a SceneProp, ty: &Ty) -> Result<Vec<u32>, Error> {
        self.program.eval_value(self.expr(p)?, ty)
    }

    fn float(&self, p: &'a SceneProp) -> Result<f32, Error> {
        let x = f32::from_bits(self.words(p, &Ty::Float)?[0]);
        if !x.is_finite() {
            return Err(self.error(self.expr(p)?.span, format!("`{}` is not a finite number: {x}", p.name.name)));
        }
        Ok(x)
    }

    fn positive(&self, p: &'a SceneProp) -> Result<f32, Error> {
        let x = self.float(p)?;
        if x <= 0.0 {
            return Err(self.error(self.expr(p)?.span, format!("`{}` must be positive, found {x}", p.name.name)));
        }
        Ok(x)
    }

    fn count(&self, p: &'a SceneProp) -> Result<u32, Error> {
        let x = self.words(p, &Ty::Int)?[0] as i32;
        if x <= 0 {
            return Err(self.error(self.expr(p)?.span, format!("`{}` must be positive, found {x}", p.name.name)));
        }
        Ok(x as u32)
    }

    fn vec3(&self, p: &'a SceneProp) -> Result<Vec3, Error> {
        let v = f32s(&self.words(p, &Ty::Vector)?);
        let v = Vec3::new(v[0], v[1], v[2]);
        if !v.is_finite() {
            return Err(self.error(self.expr(p)?.span, format!("`{}` is not finite: {v}", p.name.name)));
        }
        Ok(v)
    }

    fn color(&self, p: &'a SceneProp) -> Result<Color, Error> {
        let c = Color::from_lanes(self.model, &f32s(&self.words(p, &Ty::Color)?));
        if c.lanes().iter().any(|x| !x.is_finite() || *x < 0.0) {
            return Err(self.error(
                self.expr(p)?.span,
                format!("`{}` must be finite and not negative, found {:?}", p.name.name, c.lanes()),
            ));
        }
        Ok(c)
    }

    fn string(&self, p: &'a SceneProp) -> Result<&'a str, Error> {
        let e = self.expr(p)?;
        match &e.kind {
            ExprKind::Str(s) => Ok(s),
            _ => Err(self.error(e.span, format!("`{}` takes a string literal here", p.name.name))),
        }
    }

    fn path(&self, p: &'a SceneProp) -> Result<PathBuf, Error> {
        let name = self.string(p)?;
        let path = Path::new(name);
        Ok(if path.is_absolute() { path.to_path_buf() } else { self.dir.join(path) })
    }

    /// An object's transforms, composed in the order written.
    fn transform(&self, props: &'a [SceneProp]) -> Result<Mat4, Error> {
        let mut m = Mat4::IDENTITY;
        for p in props {
            let step = match p.name.name.as_str() {
                "translate" => Mat4::from_translation(self.vec3(p)?.into()),
                "rotate" => {
                    let r = self.vec3(p)?;
                    Mat4::from_rotation_z(r.z.to_radians())
                        * Mat4::from_rotation_y(r.y.to_radians())
                        * Mat4::from_rotation_x(r.x.to_radians())
                }
                "scale" => {
                    let e = self.expr(p)?;
                    let ty = self.program.checked().expr_types.get(&e.span).cloned().unwrap_or(Ty::Float);
                    let s = if ty.is_triple() { self.vec3(p)? } else { Vec3::splat(self.float(p)?) };
                    Mat4::from_scale(s.into())
                }
                "transform" => {
                    let w = f32s(&self.words(p, &Ty::Matrix)?);
                    // Three rows of an affine map, row-major.
                    let col = |c: usize| glam::Vec4::new(w[c], w[4 + c], w[8 + c], if c == 3 { 1.0 } else { 0.0 });
                    Mat4::from_cols(col(0), col(1), col(2), col(3))
                }
                _ => continue,
            };
            m = step * m;
        }
        Ok(m)
    }

    fn settings(&self, overrides: &Overrides) -> Result<Settings, Error> {
        let mut s = Settings::default();
        for entry in &self.scene.entries {
            let SceneEntry::Block(b) = entry else { continue };
            if b.keyword.name != "render" {
                continue;
            }
            for p in &b.props {
                match p.name.name.as_str() {
                    "width" => s.width = self.count(p)?,
                    "height" => s.height = self.count(p)?,
                    "spp" => s.spp = self.count(p)?,
                    "max_depth" => s.max_depth = self.count(p)?,
                    "seed" => s.seed = u64::from(self.words(p, &Ty::Int)?[0]),
                    "integrator" => {
                        let name = self.string(p)?;
                        s.integrator = IntegratorKind::parse(name).ok_or_else(|| {
                            self.error(p.span, format!("unknown integrator \"{name}\": use \"whitted\" or \"path\""))
                        })?;
                    }
                    "light_sampling" => {
                        let name = self.string(p)?;
                        s.light_sampling = LightSampling::parse(name).ok_or_else(|| {
                            self.error(p.span, format!("unknown light_sampling \"{name}\": use \"all\" or \"power\""))
                        })?;
                    }
                    _ => {}
                }
            }
        }
        if let Some((w, h)) = overrides.resolution {
            (s.width, s.height) = (w, h);
        }
        s.spp = overrides.spp.unwrap_or(s.spp);
        s.max_depth = overrides.max_depth.unwrap_or(s.max_depth);
        s.seed = overrides.seed.unwrap_or(s.seed);
        s.integrator = overrides.integrator.unwrap_or(s.integrator);
        s.light_sampling = overrides.light_sampling.unwrap_or(s.light_sampling);
        if s.width == 0 || s.height == 0 {
            return Err(Error::plain(format!("the image size must be positive, found {}x{}", s.width, s.height)));
        }
        if s.spp == 0 {
            return Err(Error::plain("samples per pixel must be at least 1".into()));
        }
        Ok(s)
    }

    fn camera(&self, settings: &Settings) -> Result<Camera, Error> {
        let block = self
            .scene
            .entries
            .iter()
            .find_map(|e| match e {
                SceneEntry::Block(b) if b.keyword.name == "camera" => Some(b),
                _ => None,
            })
            .ok_or_else(|| self.error(self.scene.span, "the scene has no camera"))?;
        let get = |name: &str| find(&block.props, name);
        let need =
            |name: &str| get(name).ok_or_else(|| self.error(block.span, format!("the camera is missing `{name}`")));
        let from = self.vec3(need("from")?)?;
        let to = self.vec3(need("to")?)?;
        let up = get("up").map(|p| self.vec3(p)).transpose()?.unwrap_or(Vec3::Y);
        let fov = get("fov").map(|p| self.positive(p)).transpose()?.unwrap_or(45.0);
        let aperture = get("aperture").map(|p| self.float(p)).transpose()?.unwrap_or(0.0);
        let focus = get("focus").map(|p| self.positive(p)).transpose()?;
        Camera::new(from, to, up, fov, (settings.width, settings.height), aperture, focus)
            .map_err(|m| self.error(block.span, m))
    }

    /// The scene's environment: the `light environment { }` block or the
    /// top-level `background`, scale 1 and unturned (the checker allows
    /// one of them; a second is an error here too). Black without either.
    fn environment(&self) -> Result<Environment, Error> {
        // Where each is named, and its block (none for `background`).
        let mut found: Vec<(Span, Option<&'a SceneBlock>)> = Vec::new();
        let mut background = None;
        for entry in &self.scene.entries {
            match entry {
                SceneEntry::Prop(p) if p.name.name == "background" => {
                    found.push((p.name.span, None));
                    background = Some(p);
                }
                SceneEntry::Block(b)
                    if b.keyword.name == "light" && b.kind.as_ref().is_some_and(|k| k.name == "environment") =>
                {
                    found.push((b.keyword.span, Some(b)));
                }
                _ => {}
            }
        }
        match found[..] {
            [] => {
                let black = Color::black(self.model).lanes().to_vec();
                Ok(Environment::new(EnvironmentSource::Constant(black), 1.0, Vec3::ZERO))
            }
            [(_, None)] => match background {
                Some(p) => Ok(Environment::new(self.environment_source(p)?, 1.0, Vec3::ZERO)),
                None => Err(self.error(self.scene.span, "internal error: a background without its property")),
            },
            [(_, Some(b))] => self.environment_block(b),
            [(first, _), (second, _), ..] => Err(self.program.error(
                Diagnostic::error(second, "a scene has one environment").with_label(first, "the first is here"),
            )),
        }
    }

    /// A `light environment { }` block.
    fn environment_block(&self, b: &'a SceneBlock) -> Result<Environment, Error> {
        let source = match (find(&b.props, "file"), find(&b.props, "radiance")) {
            (Some(p), _) | (None, Some(p)) => self.environment_source(p)?,
            (None, None) => return Err(self.error(b.span, "an environment needs `file` or `radiance`")),
        };
        let scale = match find(&b.props, "scale") {
            Some(p) => {
                let x = self.float(p)?;
                if x < 0.0 {
                    return Err(self.error(self.expr(p)?.span, format!("`scale` must not be negative, found {x}")));
                }
                x
            }
            None => 1.0,
        };
        let rotate = find(&b.props, "rotate").map(|p| self.vec3(p)).transpose()?.unwrap_or(Vec3::ZERO);
        Ok(Environment::new(source, scale, rotate))
    }

    /// A color, or a string naming a lat-long image (loaded here, so a
    /// missing or unreadable file is an error at its literal).
    fn environment_source(&self, p: &'a SceneProp) -> Result<EnvironmentSource, Error> {
        let e = self.expr(p)?;
        if !matches!(e.kind, ExprKind::Str(_)) {
            return Ok(EnvironmentSource::Constant(self.color(p)?.lanes().to_vec()));
        }
        let path = self.path(p)?;
        let (width, height, rgb) = image_io::load_environment(&path).map_err(|m| self.error(e.span, m))?;
        let lanes = self.model.lanes();
        let mut texels = Vec::with_capacity(rgb.len() * lanes);
        for t in rgb {
            texels.extend(crate::color::rgb_to_lanes(self.model, t));
        }
        Ok(EnvironmentSource::Image(EnvironmentMap { width, height, lanes, texels }))
    }

    /// The shape of an `object KIND { }` or area `light KIND { }` block.
    fn shape(&self, b: &'a SceneBlock, kind: &str, to_world: Mat4) -> Result<Option<ShapeKind>, Error> {
        let need = |name: &str| {
            find(&b.props, name).ok_or_else(|| self.error(b.span, format!("this block is missing `{name}`")))
        };
        let get = |name: &str| find(&b.props, name);
        let _ = to_world;
        Ok(Some(match kind {
            "sphere" => {
                ShapeKind::Sphere { center: self.vec3(need("center")?)?, radius: self.positive(need("radius")?)? }
            }
            "plane" => ShapeKind::Plane {
                point: self.vec3(need("point")?)?,
                normal: self.vec3(need("normal")?)?,
                tile: get("tile").map(|p| self.positive(p)).transpose()?.unwrap_or(1.0),
            },
            "quad" | "rect" => ShapeKind::Quad {
                corner: self.vec3(need("corner")?)?,
                edge1: self.vec3(need("edge1")?)?,
                edge2: self.vec3(need("edge2")?)?,
            },
            "disk" => ShapeKind::Disk {
                center: self.vec3(need("center")?)?,
                normal: self.vec3(need("normal")?)?,
                radius: self.positive(need("radius")?)?,
            },
            "box" => ShapeKind::Box { min: self.vec3(need("min")?)?, max: self.vec3(need("max")?)? },
            "cylinder" => ShapeKind::Cylinder {
                base: self.vec3(need("base")?)?,
                axis: get("axis").map(|p| self.vec3(p)).transpose()?.unwrap_or(Vec3::Y),
                radius: self.positive(need("radius")?)?,
                height: self.positive(need("height")?)?,
            },
            _ => return Ok(None),
        }))
    }

    fn build(&self, overrides: &Overrides) -> Result<Scene, Error> {
        let settings = self.settings(overrides)?;
        let camera = self.camera(&settings)?;
        let environment = self.environment()?;
        let mut geometry = Vec::new();
        let mut objects = Vec::new();
        let mut lights = Vec::new();
        // Object materials that are not a plain name compile together.
        let mut pending: Vec<(usize, String, &'a Expr)> = Vec::new();
        // Each object's material expression (none for `light rect`/`sphere`).
        let mut material_exprs: Vec<Option<&'a Expr>> = Vec::new();
        for entry in &self.scene.entries {
            let SceneEntry::Block(b) = entry else { continue };
            let kind = b.kind.as_ref().map(|k| k.name.as_str()).unwrap_or("");
            match b.keyword.name.as_str() {
                "object" => {
                    let to_world = self.transform(&b.props)?;
                    let shape = if kind == "mesh" {
                        let p =
                            find(&b.props, "file").ok_or_else(|| self.error(b.span, "this mesh is missing `file`"))?;
                        let path = self.path(p)?;
                        let mesh = Mesh::load_obj(&path, to_world)
                            .map_err(|m| self.error(self.expr(p).map(|e| e.span).unwrap_or(p.span), m))?;
                        ObjectGeometry::Mesh(mesh)
                    } else {
                        let Some(k) = self.shape(b, kind, to_world)? else { continue };
                        ObjectGeometry::Shape(Shape::new(k, to_world).map_err(|m| self.error(b.span, m))?)
                    };
                    let mp = find(&b.props, "material")
                        .ok_or_else(|| self.error(b.span, "this object is missing `material`"))?;
                    let expr = self.expr(mp)?;
                    let material = match self.named_material(expr) {
                        Some(m) => Some(m?),
                        None => {
                            pending.push((objects.len(), format!("@object{}", objects.len()), expr));
                            None
                        }
                    };
                    geometry.push(shape);
                    objects.push((material, None, b.span));
                    material_exprs.push(Some(expr));
                }
                "light" => match kind {
                    "point" | "spot" => {
                        let at = self.vec3(find(&b.props, "at").ok_or_else(|| self.error(b.span, "missing `at`"))?)?;
                        let (intensity, from_power) = self.intensity(b)?;
                        let light = if kind == "point" {
                            let intensity = scale_color(
                                &intensity,
                                if from_power { 1.0 / (4.0 * std::f32::consts::PI) } else { 1.0 },
                            );
                            LightKind::Point { at, intensity }
                        } else {
                            let to =
                                self.vec3(find(&b.props, "to").ok_or_else(|| self.error(b.span, "missing `to`"))?)?;
                            let axis = (to - at).normalize_or_zero();
                            if axis == Vec3::ZERO {
                                return Err(self.error(
                                    b.span,
                                    "a spot light must point somewhere: `at` and `to` are the same point",
                                ));
                            }
                            let cone = find(&b.props, "cone").map(|p| self.positive(p)).transpose()?.unwrap_or(30.0);
                            let falloff = find(&b.props, "falloff").map(|p| self.float(p)).transpose()?.unwrap_or(5.0);
                            if cone >= 180.0 || falloff < 0.0 || falloff > cone {
                                return Err(self.error(b.span, format!("a spot light needs 0 < cone < 180 and 0 <= falloff <= cone, found cone {cone}, falloff {falloff}")));
                            }
                            let cos_outer = cone.to_radians().cos();
                            let cos_inner = (cone - falloff).to_radians().cos();
                            // pbrt-v4's spot power: the cone's solid angle, the
                            // smooth edge counted as half.
                            let solid = std::f32::consts::TAU * (1.0 - 0.5 * (cos_inner + cos_outer));
                            let intensity = scale_color(&intensity, if from_power { 1.0 / solid } else { 1.0 });
                            LightKind::Spot { at, axis, intensity, cos_outer, cos_inner }
                        };
                        lights.push(Light { kind: light });
                    }
                    "directional" => {
                        let d = self.vec3(
                            find(&b.props, "direction").ok_or_else(|| self.error(b.span, "missing `direction`"))?,
                        )?;
                        let dir = d.normalize_or_zero();
                        if dir == Vec3::ZERO {
                            return Err(self.error(b.span, "a directional light needs a non-zero `direction`"));
                        }
                        let irradiance = self.color(
                            find(&b.props, "irradiance").ok_or_else(|| self.error(b.span, "missing `irradiance`"))?,
                        )?;
                        lights.push(Light { kind: LightKind::Directional { dir, irradiance } });
                    }
                    "rect" | "sphere" => {
                        let to_world = Mat4::IDENTITY;
                        let Some(k) = self.shape(b, kind, to_world)? else { continue };
                        let shape = Shape::new(k, to_world).map_err(|m| self.error(b.span, m))?;
                        let area = shape.area();
                        let radiance = match (find(&b.props, "radiance"), find(&b.props, "power")) {
                            (Some(p), _) => self.color(p)?,
                            (None, Some(p)) => scale_color(&self.color(p)?, 1.0 / (std::f32::consts::PI * area)),
                            (None, None) => return Err(self.error(b.span, "an area light needs `radiance` or `power`")),
                        };
                        let emitter = self.program.material("emitter")?;
                        geometry.push(ObjectGeometry::Shape(shape));
                        objects.push((Some(emitter), Some(radiance), b.span));
                        material_exprs.push(None);
                    }
                    _ => {}
                },
                _ => {}
            }
        }
        if !pending.is_empty() {
            let names: Vec<(String, &Expr)> = pending.iter().map(|(_, n, e)| (n.clone(), *e)).collect();
            let compiled = self.program.compile_material_exprs(&names)?;
            for ((index, _, _), m) in pending.iter().zip(compiled) {
                objects[*index].0 = Some(m);
            }
        }
        let objects: Vec<Object> = objects
            .into_iter()
            .filter_map(|(m, scale, span)| {
                let material = m?;
                let emissive =
                    material.may_emit() && scale.as_ref().is_none_or(|c: &Color| c.lanes().iter().any(|x| *x > 0.0));
                // dPdx .. dvdy are the last words of the globals.
                let word = |name: &str| crate::globals::word_of(name).map_or(0, |w| w.0);
                let footprint_words = !0u32 << word("dPdx");
                // u, v, dPdu, dPdv are consecutive, and the footprint needs them.
                let uv_words = (!0u32 << word("u")) & !(!0u32 << (word("dPdv") + 3)) | footprint_words;
                Some(Object {
                    reflection_sum: None,
                    delta_lobes: None,
                    eval_pdf: None,
                    sample: material.sample_entry().clone(),
                    emission_scale: scale,
                    emissive,
                    always_opaque: material.always_opaque(),
                    reflects: material.may_reflect_dir(),
                    refracts: material.may_refract(),
                    transmits: material.may_refract() || !material.always_opaque(),
                    reads_footprint: material.globals_read() & footprint_words != 0,
                    reads_uv: material.globals_read() & uv_words != 0,
                    clear: material.clear(),
                    constant_ior: material.constant_refraction_index(),
                    material,
                    span,
                })
            })
            .collect();
        let mut objects = objects;
        // Summed delta lights serve the integrators that sample every light.
        if settings.integrator == IntegratorKind::Whitted || settings.light_sampling == LightSampling::All {
            self.reflection_sums(&mut objects, &material_exprs, &lights)?;
        }
        self.delta_lobes(&mut objects, &material_exprs)?;
        if settings.integrator == IntegratorKind::Path {
            self.eval_pdfs(&mut objects, &material_exprs)?;
        }
        let geometry = Geometry::new(geometry);
        for (k, o) in objects.iter().enumerate() {
            if o.emissive
                && let Some(light) = Light::area(&geometry, k as u32)
            {
                lights.push(light);
            }
        }
        let mut environment_light = None;
        if !environment.is_black() {
            environment_light = Some(lights.len());
            lights.push(Light { kind: LightKind::Environment(Box::new(environment)) });
        }
        let mut light_of_object = vec![None; objects.len()];
        for (k, light) in lights.iter().enumerate() {
            if let Some(o) = light.object() {
                light_of_object[o as usize] = Some(k);
            }
        }
        let light_sampler = light_sampler(&lights, &objects, &geometry, self.model.lanes());
        Ok(Scene {
            camera,
            settings,
            objects,
            geometry,
            lights,
            light_of_object,
            environment_light,
            light_sampler,
            model: self.model,
            build_seconds: 0.0,
        })
    }

    /// With two or more delta lights, compiles for each object that only
    /// reflects the sum of `reflection` over those lights in one function,
    /// so its texture is evaluated once per hit rather than once per light.
    fn reflection_sums(
        &self,
        objects: &mut [Object],
        exprs: &[Option<&'a Expr>],
        lights: &[Light],
    ) -> Result<(), Error> {
        let count = lights.iter().filter(|l| l.is_delta()).count();
        if !(2..=MAX_SUMMED_LIGHTS).contains(&count) {
            return Ok(());
        }
        let wanted: Vec<(usize, String, &Expr)> = objects
            .iter()
            .zip(exprs)
            .enumerate()
            .filter_map(|(k, (o, e))| (!o.reflects && !o.refracts).then_some((k, format!("@object{k}"), (*e)?)))
            .collect();
        let items: Vec<(String, &Expr)> = wanted.iter().map(|(_, n, e)| (n.clone(), *e)).collect();
        let functions = self.program.compile_reflection_sums(&items, count)?;
        for ((k, _, _), f) in wanted.iter().zip(functions) {
            objects[*k].reflection_sum = Some(f);
        }
        Ok(())
    }

    /// Compiles for each object that reflects or refracts its perfect
    /// directions and their weights as one function.
    fn delta_lobes(&self, objects: &mut [Object], exprs: &[Option<&'a Expr>]) -> Result<(), Error> {
        let mut wanted = Vec::new();
        for (k, (o, e)) in objects.iter().zip(exprs).enumerate() {
            if !o.reflects && !o.refracts {
                continue;
            }
            // Only area lights have no expression, and their emitter has
            // no perfect directions.
            let e = e.ok_or_else(|| self.error(o.span, "internal error: a specular object without a material"))?;
            wanted.push((k, (format!("@object{k}"), e)));
        }
        if wanted.is_empty() {
            return Ok(());
        }
        let items: Vec<(String, &Expr)> = wanted.iter().map(|(_, item)| item.clone()).collect();
        let functions = self.program.compile_delta_lobes(&items)?;
        for ((k, _), f) in wanted.iter().zip(functions) {
            objects[*k].delta_lobes = Some(f);
        }
        Ok(())
    }

    /// Compiles for each object with a material expression `f · cos` and
    /// `pdf` of a light direction as one function.
    fn eval_pdfs(&self, objects: &mut [Object], exprs: &[Option<&'a Expr>]) -> Result<(), Error> {
        let wanted: Vec<(usize, (String, &Expr))> =
            exprs.iter().enumerate().filter_map(|(k, e)| Some((k, (format!("@object{k}"), (*e)?)))).collect();
        if wanted.is_empty() {
            return Ok(());
        }
        let items: Vec<(String, &Expr)> = wanted.iter().map(|(_, item)| item.clone()).collect();
        let functions = self.program.compile_eval_pdf(&items)?;
        for ((k, _), f) in wanted.iter().zip(functions) {
            objects[*k].eval_pdf = Some(f);
        }
        Ok(())
    }

    /// `intensity` (W/sr), or `power` (W) to be divided by the solid angle;
    /// the flag says which was given.
    fn intensity(&self, b: &'a SceneBlock) -> Result<(Color, bool), Error> {
        match (find(&b.props, "intensity"), find(&b.props, "power")) {
            (Some(p), _) => Ok((self.color(p)?, false)),
            (None, Some(p)) => Ok((self.color(p)?, true)),
            (None, None) => Err(self.error(b.span, "this light needs `intensity` or `power`")),
        }
    }

    /// A material written as a bare name of a material without required
    /// parameters: its entries are compiled once however many objects use it.
    fn named_material(&self, e: &Expr) -> Option<Result<Material, Error>> {
        let ExprKind::Name(n) = &e.kind else { return None };
        let sym = self.program.checked().symbols.get(n)?;
        matches!(sym.kind, SymbolKind::Material | SymbolKind::MaterialTree).then(|| self.program.material(n))
    }
}

fn scale_color(c: &Color, s: f32) -> Color {
    c.scaled(s)
}

/// Area lights' radiance is estimated from this many points on each.
const EMISSION_PROBES: u32 = 64;

/// The sampler choosing lights by power. Area lights' radiance comes from
/// their materials, estimated at points spread over the surface; since a
/// textured emitter could be dark at every probe, an area light gets at
/// least a thousandth of the strongest light's power, so it stays
/// sampled (material sampling alone would still find it, unbiased, but
/// noisily).
fn light_sampler(lights: &[Light], objects: &[Object], geometry: &Geometry, lanes: usize) -> LightSampler {
    let radius = geometry.bounding_sphere().1;
    let mut powers: Vec<f32> = lights
        .iter()
        .enumerate()
        .map(|(k, light)| {
            let radiance =
                light.object().map_or(0.0, |o| mean_emission(light, k, &objects[o as usize], geometry, lanes));
            light.power(radius, radiance)
        })
        .collect();
    let strongest = powers.iter().copied().fold(0.0f32, f32::max);
    for (p, light) in powers.iter_mut().zip(lights) {
        if light.object().is_some() {
            *p = p.max(1e-3 * strongest);
        }
    }
    LightSampler::new(&powers)
}

/// The mean radiance (over probes and lanes) area light `light`, number
/// `k`, emits along the normal of its surface, `object`'s.
fn mean_emission(light: &Light, k: usize, object: &Object, geometry: &Geometry, lanes: usize) -> f32 {
    let scale = object.emission_scale.as_ref().map_or(&[][..], |c| c.lanes());
    let mut out = vec![0.0f32; lanes];
    let mut sum = 0.0f64;
    for probe in 0..EMISSION_PROBES {
        // Fixed numbers, so the powers (and the image) are reproducible.
        let mut u = super::sampling::Sampler::new(0x11c4, probe, k as u32, 0);
        let (uv, u3) = (u.next_2d(), u.next_1d());
        let Some((surface, _)) = light.area_point(geometry, uv, u3) else { continue };
        out.fill(0.0);
        object.material.emission_into(&super::integrator::globals_of(&surface, 0.0), surface.n.to_array(), &mut out);
        for (c, x) in out.iter().enumerate() {
            let x = x * scale.get(c).copied().unwrap_or(1.0);
            if x.is_finite() && x > 0.0 {
                sum += f64::from(x);
            }
        }
    }
    (sum / f64::from(EMISSION_PROBES) / lanes.max(1) as f64) as f32
}
