//! Building a renderable [`Scene`] from a compiled program's scene
//! description ([`crate::scene::SceneDesc`], made when the program was
//! checked): shapes and meshes are placed, every object's material is
//! compiled, lights (the environment among them) are gathered and weighed
//! by power, and the BVH is built.
//!
//! Architecture invariant: nothing here reads syntax. The description has
//! every value evaluated and checked and every file read; what can still
//! fail here are settings given outside the scene (a zero image size on
//! the command line), as an [`Error`].

use super::Vec3;
use super::camera::Camera;
use super::environment::{Environment, EnvironmentMap, EnvironmentSource};
use super::geometry::{Blocks, Geometry, ObjectGeometry};
use super::light::{Light, LightKind, LightSampler};
use super::mesh::Mesh;
use super::shape::Shape;
use crate::diag::{Diagnostic, Span};
use crate::scene::{
    AreaEmission, EnvironmentDesc, EnvironmentSourceDesc, Frame, LightColor, LightDesc, MaterialRef, ObjectDesc,
    SceneDesc, ShapeDesc, Surface,
};
use crate::{Color, ColorModel, Error, Material, Program};
use std::borrow::Cow;
use std::collections::HashMap;
use std::sync::Arc;

pub use crate::scene::{IntegratorKind, LightSampling};

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
    /// The frame rendered: its number and time, which shaders read as
    /// `frame` and `time`. The number enters the seed (see [`Settings::frame_seed`]).
    pub frame: Frame,
    #[doc(hidden)]
    pub strategy: Strategy,
}

impl Settings {
    /// The seed of the frame's random numbers: `seed` itself at frame 0,
    /// and for other frames `seed` mixed with the frame number, so each
    /// frame of an animation has its own noise, and a frame is the same
    /// bits whether rendered alone or in a sequence.
    pub fn frame_seed(&self) -> u64 {
        match self.frame.number {
            0 => self.seed,
            n => self.seed ^ super::sampling::mix64(u64::from(n as u32) | 1 << 32),
        }
    }
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
            frame: Frame::default(),
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
    /// Compiles each method on its own instead of splitting materials into
    /// a per-hit stage and per-direction calls (`ir::split`): the code
    /// before the split, kept for `cargo bench --bench render`.
    #[doc(hidden)]
    pub unsplit: bool,
    /// Whether the hit groups' large functions get Cranelift's optimising
    /// tier ([`crate::Compiler::optimize_large`]); `None` decides by the
    /// image's sample count ([`OPTIMIZE_FROM_SAMPLES`]).
    pub optimize_code: Option<bool>,
}

/// Renders of at least this many camera samples (width x height x spp)
/// compile their hit groups with the optimising tier: it costs a deep
/// texture tree a few tenths of a second more to compile and renders it
/// about 1.3x faster, which pays from about a second of rendering on.
/// Previews stay quick to start.
pub const OPTIMIZE_FROM_SAMPLES: u64 = 1 << 19;

/// The number of delta lights when a reflection sum shades them (2 to
/// [`MAX_SUMMED_LIGHTS`]), else `None`.
fn summed_lights(lights: &[Light]) -> Option<usize> {
    let count = lights.iter().filter(|l| l.is_delta()).count();
    (2..=MAX_SUMMED_LIGHTS).contains(&count).then_some(count)
}

/// Objects that only reflect may have their delta lights summed.
fn takes_reflection_sum(o: &Object) -> bool {
    !o.reflects && !o.refracts
}

/// Scenes with more delta lights than this shade them one call each.
pub const MAX_SUMMED_LIGHTS: usize = 8;

/// An object's material compiled for prepared hits, with the methods the
/// integrators call looked up once ([`crate::HitMaterial::method_index`]).
#[derive(Debug, Clone)]
pub struct PreparedMaterial {
    pub material: crate::HitMaterial,
    pub sample: Option<usize>,
    pub eval_pdf: Option<usize>,
    pub delta_lobes: Option<usize>,
    pub reflection: Option<usize>,
}

impl PreparedMaterial {
    fn new(material: crate::HitMaterial) -> PreparedMaterial {
        use crate::ir::lower::HitMethod;
        let at = |m| material.method_index(m);
        PreparedMaterial {
            sample: at(HitMethod::Interface(crate::check::Method::Sample)),
            eval_pdf: at(HitMethod::EvalPdf),
            delta_lobes: at(HitMethod::DeltaLobes),
            reflection: at(HitMethod::Interface(crate::check::Method::Reflection)),
            material,
        }
    }
}

/// An object's surface: its material and what its code shows, shared by
/// the objects that name one material.
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
    /// For the path tracer: the material's hit group (`sample`,
    /// `eval_pdf`, the delta lobes) split into a per-hit stage and
    /// per-direction calls, used instead of `sample`, `eval_pdf` and
    /// `delta_lobes`.
    pub hit: Option<PreparedMaterial>,
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
    /// Where the first object with this surface is defined, for messages.
    pub span: Span,
}

/// A scene ready to render.
pub struct Scene {
    pub camera: Camera,
    pub settings: Settings,
    /// The objects' surfaces, each once: objects naming one material
    /// share one ([`Scene::object`]).
    pub objects: Vec<Object>,
    /// The index in `objects` of each object's surface, by object (as the
    /// geometry numbers them).
    pub surface_of_object: Vec<u32>,
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
    /// Seconds spent placing shapes and meshes, compiling object materials
    /// and building the BVH (meshes are read when the program is compiled).
    pub build_seconds: f64,
}

impl Scene {
    /// The surface of object `k` (as the geometry numbers objects).
    pub fn object(&self, k: u32) -> &Object {
        &self.objects[self.surface_of_object[k as usize] as usize]
    }

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

    /// Builds the scene of a compiled program from its description
    /// ([`Program::scene`]), which checking has validated and whose files
    /// it has read.
    pub fn build(program: &Program, overrides: &Overrides) -> Result<Scene, Error> {
        Scene::build_from(program, program.scene(), overrides)
    }

    /// Builds a scene from a description of `program`'s scene, such as one
    /// frame of an animation ([`Program::scene_at`]).
    pub fn build_from(program: &Program, desc: Option<&SceneDesc>, overrides: &Overrides) -> Result<Scene, Error> {
        let start = std::time::Instant::now();
        let Some(desc) = desc else {
            // Said at the top of the user's file.
            let root = program.checked().loaded.modules.iter().find(|m| !m.is_prelude).map(|m| m.file);
            let message = "the program has no `scene { ... }` block to render";
            return Err(match root {
                Some(file) => {
                    program.error(crate::diag::Diagnostic::error(crate::diag::Span::new(file, 0, 0), message))
                }
                None => Error::plain(message.into()),
            });
        };
        let scene =
            Builder { program, desc, model: program.color_model() }.build(overrides, Cow::Borrowed(&desc.objects))?;
        Ok(Scene { build_seconds: start.elapsed().as_secs_f64(), ..scene })
    }

    /// [`Scene::build_from`] given the description ([`Program::take_scene`]):
    /// its objects are dropped once placed, before the BVH is built (a
    /// million spheres' description is 200 MB).
    pub fn build_owned(program: &Program, mut desc: SceneDesc, overrides: &Overrides) -> Result<Scene, Error> {
        let start = std::time::Instant::now();
        let objects = std::mem::take(&mut desc.objects);
        let scene =
            Builder { program, desc: &desc, model: program.color_model() }.build(overrides, Cow::Owned(objects))?;
        Ok(Scene { build_seconds: start.elapsed().as_secs_f64(), ..scene })
    }
}

struct Builder<'a> {
    program: &'a Program,
    desc: &'a SceneDesc,
    model: ColorModel,
}

impl<'a> Builder<'a> {
    fn error(&self, span: Span, message: impl Into<String>) -> Error {
        self.program.error(Diagnostic::error(span, message))
    }

    /// A color of the scene description. A hero render's are tabulated at
    /// the 64 bin centres (see `scene::describe`), interpolated per sample.
    fn color(&self, lanes: &[f32]) -> Color {
        let model = match self.model {
            ColorModel::Hero => ColorModel::Spectral { samples: crate::color::MAX_SAMPLES },
            model => model,
        };
        Color::from_lanes(model, lanes)
    }

    fn settings(&self, overrides: &Overrides) -> Result<Settings, Error> {
        let r = &self.desc.render;
        let d = Settings::default();
        let mut s = Settings {
            width: r.width.as_ref().map_or(d.width, |p| p.value),
            height: r.height.as_ref().map_or(d.height, |p| p.value),
            spp: r.spp.as_ref().map_or(d.spp, |p| p.value),
            max_depth: r.max_depth.as_ref().map_or(d.max_depth, |p| p.value),
            seed: r.seed.as_ref().map_or(d.seed, |p| p.value),
            integrator: r.integrator.as_ref().map_or(d.integrator, |p| p.value),
            light_sampling: r.light_sampling.as_ref().map_or(d.light_sampling, |p| p.value),
            frame: self.desc.frame,
            strategy: d.strategy,
        };
        if let Some((w, h)) = overrides.resolution {
            (s.width, s.height) = (w, h);
        }
        s.spp = overrides.spp.unwrap_or(s.spp);
        s.max_depth = overrides.max_depth.unwrap_or(s.max_depth);
        s.seed = overrides.seed.unwrap_or(s.seed);
        s.integrator = overrides.integrator.unwrap_or(s.integrator);
        s.light_sampling = overrides.light_sampling.unwrap_or(s.light_sampling);
        // Overrides (the scene's own values were checked with their spans).
        use crate::scene::{MAX_DEPTH, MAX_IMAGE_SIDE, MAX_PIXELS, MAX_SPP};
        let sides = 1..=MAX_IMAGE_SIDE;
        if !sides.contains(&s.width) || !sides.contains(&s.height) {
            return Err(Error::plain(format!(
                "the image size {}x{} must be between 1x1 and {MAX_IMAGE_SIDE}x{MAX_IMAGE_SIDE}",
                s.width, s.height
            )));
        }
        if u64::from(s.width) * u64::from(s.height) > MAX_PIXELS {
            return Err(Error::plain(format!(
                "{}x{} is more than the {MAX_PIXELS} pixels an image may have",
                s.width, s.height
            )));
        }
        if !(1..=MAX_SPP).contains(&s.spp) {
            return Err(Error::plain(format!("samples per pixel must be in 1..={MAX_SPP}, found {}", s.spp)));
        }
        if !(1..=MAX_DEPTH).contains(&s.max_depth) {
            return Err(Error::plain(format!("the maximum depth must be in 1..={MAX_DEPTH}, found {}", s.max_depth)));
        }
        Ok(s)
    }

    fn camera(&self, settings: &Settings) -> Result<Camera, Error> {
        let c = &self.desc.camera;
        let focus = c.focus.as_ref().map(|p| p.value);
        Camera::new(
            c.from.value,
            c.to.value,
            c.up.value,
            c.fov.value,
            (settings.width, settings.height),
            c.aperture.value,
            focus,
        )
        .map_err(|m| self.error(c.span, m))
    }

    /// The scene's environment: black without one.
    fn environment(&self) -> Environment {
        let Some(EnvironmentDesc { source, scale, rotate, .. }) = &self.desc.environment else {
            let black = self.color(&[]).lanes().to_vec();
            return Environment::new(EnvironmentSource::Constant(black), 1.0, Vec3::ZERO);
        };
        let source = match source {
            EnvironmentSourceDesc::Constant(c) => EnvironmentSource::Constant(self.color(&c.value).lanes().to_vec()),
            // Hero renders upsample at each lookup, at the sample's wavelengths.
            EnvironmentSourceDesc::Image(image) if self.model == ColorModel::Hero => {
                let image = &image.value;
                let texels = image.rgb.iter().flatten().copied().collect();
                EnvironmentSource::Image(EnvironmentMap { width: image.width, height: image.height, lanes: 3, texels })
            }
            EnvironmentSourceDesc::Image(image) => {
                let image = &image.value;
                let lanes = self.model.lanes();
                let mut texels = Vec::with_capacity(image.rgb.len() * lanes);
                for t in &image.rgb {
                    texels.extend(crate::color::rgb_to_lanes(self.model, *t));
                }
                EnvironmentSource::Image(EnvironmentMap { width: image.width, height: image.height, lanes, texels })
            }
        };
        Environment::new(source, scale.value, rotate.value)
    }

    /// A point, spot or directional light.
    fn light(&self, light: &LightDesc) -> LightKind {
        // `intensity` (W/sr), or `power` (W) over the solid angle `solid`.
        let strength = |c: &LightColor, solid: f32| {
            let color = self.color(&c.color.value);
            if c.from_power { scale_color(&color, 1.0 / solid) } else { color }
        };
        match light {
            LightDesc::Point { at, intensity, .. } => {
                LightKind::Point { at: at.value, intensity: strength(intensity, 4.0 * std::f32::consts::PI) }
            }
            LightDesc::Spot { at, axis, intensity, cone, falloff, .. } => {
                let cos_outer = cone.value.to_radians().cos();
                let cos_inner = (cone.value - falloff.value).to_radians().cos();
                // pbrt-v4's spot power: the cone's solid angle, the smooth
                // edge counted as half.
                let solid = std::f32::consts::TAU * (1.0 - 0.5 * (cos_inner + cos_outer));
                LightKind::Spot {
                    at: at.value,
                    axis: axis.value,
                    intensity: strength(intensity, solid),
                    cos_outer,
                    cos_inner,
                }
            }
            LightDesc::Directional { direction, irradiance, .. } => {
                LightKind::Directional { dir: direction.value, irradiance: self.color(&irradiance.value) }
            }
        }
    }

    /// `descs`: the description's objects (taken out of it when owned).
    fn build(&self, overrides: &Overrides, descs: Cow<'_, [ObjectDesc]>) -> Result<Scene, Error> {
        let settings = self.settings(overrides)?;
        let camera = self.camera(&settings)?;
        let environment = self.environment();
        let mut lights: Vec<Light> = self.desc.lights.iter().map(|l| Light { kind: self.light(l) }).collect();
        let mut geometry = Blocks::default();
        // The distinct surfaces: objects naming one material share one.
        let mut objects = Vec::new();
        // Object materials that are not a plain name compile together.
        let mut pending: Vec<(usize, String, MaterialRef)> = Vec::new();
        // Each surface's material (none for `light rect`/`sphere`).
        let mut materials: Vec<Option<MaterialRef>> = Vec::new();
        // Each named material is looked up (and its code examined) once.
        let mut by_name: HashMap<Arc<str>, u32> = HashMap::new();
        let count = descs.len();
        let mut surface_of_object: Vec<u32> = Vec::with_capacity(count);
        for o in descs.iter() {
            let to_world = o.to_world();
            let placed = match (&o.shape, o.shape.kind()) {
                (ShapeDesc::Mesh { file }, _) => Mesh::from_data(&file.value, to_world)
                    .map(|m| ObjectGeometry::Mesh(Box::new(m)))
                    .map_err(|m| self.error(file.span, m))?,
                (_, Some(kind)) => {
                    ObjectGeometry::Shape(Shape::new(kind, to_world).map_err(|m| self.error(o.span, m))?)
                }
                (_, None) => return Err(self.error(o.span, "internal error: a shape without its numbers")),
            };
            let surface = objects.len() as u32;
            match &o.surface {
                Surface::Material(m) => match &m.name {
                    Some(name) => {
                        if let Some(&shared) = by_name.get(&**name) {
                            surface_of_object.push(shared);
                            geometry.push(placed);
                            continue;
                        }
                        by_name.insert(name.clone(), surface);
                        objects.push((Some(self.program.material(name)?), None, o.span));
                        materials.push(Some(m.material));
                    }
                    None => {
                        pending.push((objects.len(), format!("@object{}", geometry.len()), m.material));
                        objects.push((None, None, o.span));
                        materials.push(Some(m.material));
                    }
                },
                Surface::Emitter(emission) => {
                    let radiance = match (emission, &placed) {
                        (AreaEmission::Radiance(c), _) => self.color(&c.value),
                        (AreaEmission::Power(c), ObjectGeometry::Shape(shape)) => {
                            scale_color(&self.color(&c.value), 1.0 / (std::f32::consts::PI * shape.area()))
                        }
                        (AreaEmission::Power(_), _) => {
                            return Err(self.error(o.span, "internal error: an area light that is a mesh"));
                        }
                    };
                    objects.push((Some(self.program.material("emitter")?), Some(radiance), o.span));
                    materials.push(None);
                }
            }
            surface_of_object.push(surface);
            geometry.push(placed);
        }
        drop(descs);
        if !pending.is_empty() {
            let refs: Vec<(String, MaterialRef)> = pending.iter().map(|(_, n, r)| (n.clone(), *r)).collect();
            let compiled = self.program.compile_material_exprs(&refs)?;
            for ((index, _, _), m) in pending.iter().zip(compiled) {
                objects[*index].0 = Some(m);
            }
        }
        // dPdx .. dvdy are consecutive words of the globals, and so are u,
        // v, dPdu, dPdv; the footprint needs the latter too.
        let ends = |name: &str| {
            crate::globals::word_of(name).map_or((0, 0), |(w, ty)| (w, w + if ty.is_triple() { 3 } else { 1 }))
        };
        let words = |first: &str, last: &str| (!0u64 << ends(first).0) & !(!0u64 << ends(last).1);
        let footprint_words = words("dPdx", "dvdy");
        let uv_words = words("u", "dPdv") | footprint_words;
        // What a material's code shows is found once per material.
        let mut constant_iors: HashMap<MaterialRef, Option<Vec<f32>>> = HashMap::new();
        let mut constant_ior = |material: &Material, shared: Option<MaterialRef>| match shared {
            Some(key) => constant_iors.entry(key).or_insert_with(|| material.constant_refraction_index()).clone(),
            None => material.constant_refraction_index(),
        };
        let mut objects: Vec<Object> = objects
            .into_iter()
            .zip(&materials)
            .filter_map(|((m, scale, span), shared)| {
                let material = m?;
                let emissive =
                    material.may_emit() && scale.as_ref().is_none_or(|c: &Color| c.lanes().iter().any(|x| *x > 0.0));
                Some(Object {
                    hit: None,
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
                    constant_ior: constant_ior(&material, *shared),
                    material,
                    span,
                })
            })
            .collect();
        if !overrides.unsplit {
            // Whitted shades an object that neither reflects nor refracts
            // under 2 to MAX_SUMMED_LIGHTS delta lights (and no other light)
            // with one reflection sum: one evaluation per hit already.
            let summed_alone = settings.integrator == IntegratorKind::Whitted
                && summed_lights(&lights) == Some(lights.len())
                && !objects.iter().any(|o| o.emissive);
            let methods = match settings.integrator {
                IntegratorKind::Path => crate::PATH_METHODS,
                IntegratorKind::Whitted => crate::WHITTED_METHODS,
            };
            let skip = |o: &Object| summed_alone && takes_reflection_sum(o);
            let samples = u64::from(settings.width) * u64::from(settings.height) * u64::from(settings.spp);
            let optimize = overrides.optimize_code.unwrap_or(samples >= OPTIMIZE_FROM_SAMPLES);
            self.hit_groups(&mut objects, &materials, methods, skip, optimize)?;
        }
        // Summed delta lights serve the integrators that sample every light,
        // for objects without a prepared hit (whose eval_pdf per light reads
        // the record: cheaper than evaluating the tree again for the sum).
        if settings.integrator == IntegratorKind::Whitted || settings.light_sampling == LightSampling::All {
            self.reflection_sums(&mut objects, &materials, &lights)?;
        }
        // Objects without a hit group call these on their own.
        self.delta_lobes(&mut objects, &materials)?;
        if settings.integrator == IntegratorKind::Path {
            self.eval_pdfs(&mut objects, &materials)?;
        }
        let geometry = Geometry::new(geometry);
        for (k, &surface) in surface_of_object.iter().enumerate() {
            if objects[surface as usize].emissive
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
        let mut light_of_object = vec![None; surface_of_object.len()];
        for (k, light) in lights.iter().enumerate() {
            if let Some(o) = light.object() {
                light_of_object[o as usize] = Some(k);
            }
        }
        let of_object = |o: u32| &objects[surface_of_object[o as usize] as usize];
        let light_sampler = light_sampler(&lights, of_object, &geometry, self.model.lanes(), settings.frame);
        Ok(Scene {
            camera,
            settings,
            objects,
            surface_of_object,
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
        materials: &[Option<MaterialRef>],
        lights: &[Light],
    ) -> Result<(), Error> {
        let Some(count) = summed_lights(lights) else { return Ok(()) };
        let wanted: Vec<(usize, MaterialRef)> = objects
            .iter()
            .zip(materials)
            .enumerate()
            .filter_map(|(k, (o, m))| (takes_reflection_sum(o) && o.hit.is_none()).then_some((k, (*m)?)))
            .collect();
        for (k, f) in per_material(&wanted, |items| self.program.compile_reflection_sums(items, count))? {
            objects[k].reflection_sum = Some(f);
        }
        Ok(())
    }

    /// Compiles for each object that reflects or refracts its perfect
    /// directions and their weights as one function.
    fn delta_lobes(&self, objects: &mut [Object], materials: &[Option<MaterialRef>]) -> Result<(), Error> {
        let mut wanted = Vec::new();
        for (k, (o, m)) in objects.iter().zip(materials).enumerate() {
            if (!o.reflects && !o.refracts) || o.hit.is_some() {
                continue;
            }
            // Only area lights have no expression, and their emitter has
            // no perfect directions.
            let m = m.ok_or_else(|| self.error(o.span, "internal error: a specular object without a material"))?;
            wanted.push((k, m));
        }
        for (k, f) in per_material(&wanted, |items| self.program.compile_delta_lobes(items))? {
            objects[k].delta_lobes = Some(f);
        }
        Ok(())
    }

    /// Compiles for each textured object with a material (but those `skip`
    /// names) its hit group of `methods`.
    fn hit_groups(
        &self,
        objects: &mut [Object],
        materials: &[Option<MaterialRef>],
        methods: &[crate::ir::lower::HitMethod],
        skip: impl Fn(&Object) -> bool,
        optimize: bool,
    ) -> Result<(), Error> {
        // A tree without lookups or noise in its methods has none in its
        // `prepare` either: not worth lowering a group for.
        let textured = |o: &Object| {
            ["sample", "pdf", "reflection"]
                .iter()
                .filter_map(|m| o.material.method(m))
                .any(|f| crate::worth_preparing(f.ir()))
        };
        // Once per material: objects that share one share its code.
        let mut textured_materials: HashMap<MaterialRef, bool> = HashMap::new();
        let wanted: Vec<(usize, MaterialRef)> = materials
            .iter()
            .enumerate()
            .filter_map(|(k, m)| Some((k, (*m)?)))
            .filter(|(k, m)| {
                let o = &objects[*k];
                !skip(o) && *textured_materials.entry(*m).or_insert_with(|| textured(o))
            })
            .collect();
        for (k, h) in per_material(&wanted, |items| self.program.compile_hit_group_refs(items, methods, optimize))? {
            objects[k].hit = h.map(PreparedMaterial::new);
        }
        Ok(())
    }

    /// Compiles for each object with a material expression `f · cos` and
    /// `pdf` of a light direction as one function.
    fn eval_pdfs(&self, objects: &mut [Object], materials: &[Option<MaterialRef>]) -> Result<(), Error> {
        let wanted: Vec<(usize, MaterialRef)> = materials
            .iter()
            .enumerate()
            .filter(|(k, _)| objects[*k].hit.is_none())
            .filter_map(|(k, m)| Some((k, (*m)?)))
            .collect();
        for (k, f) in per_material(&wanted, |items| self.program.compile_eval_pdf(items))? {
            objects[k].eval_pdf = Some(f);
        }
        Ok(())
    }
}

/// Compiles once per distinct material of the `(object, material)` pairs
/// (each named `@object{k}` after the first object that has it) and gives
/// every object its material's result: a million spheres of one material
/// are one compile.
fn per_material<T: Clone>(
    wanted: &[(usize, MaterialRef)],
    compile: impl FnOnce(&[(String, MaterialRef)]) -> Result<Vec<T>, Error>,
) -> Result<Vec<(usize, T)>, Error> {
    if wanted.is_empty() {
        return Ok(Vec::new());
    }
    let mut slot_of: HashMap<MaterialRef, usize> = HashMap::new();
    let mut items: Vec<(String, MaterialRef)> = Vec::new();
    let slots: Vec<usize> = wanted
        .iter()
        .map(|(k, m)| {
            *slot_of.entry(*m).or_insert_with(|| {
                items.push((format!("@object{k}"), *m));
                items.len() - 1
            })
        })
        .collect();
    let compiled = compile(&items)?;
    Ok(wanted.iter().zip(slots).map(|((k, _), slot)| (*k, compiled[slot].clone())).collect())
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
fn light_sampler<'a>(
    lights: &[Light],
    object: impl Fn(u32) -> &'a Object,
    geometry: &Geometry,
    lanes: usize,
    frame: Frame,
) -> LightSampler {
    let radius = geometry.bounding_sphere().1;
    let mut powers: Vec<f32> = lights
        .iter()
        .enumerate()
        .map(|(k, light)| {
            let radiance = light.object().map_or(0.0, |o| mean_emission(light, k, object(o), geometry, lanes, frame));
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
fn mean_emission(light: &Light, k: usize, object: &Object, geometry: &Geometry, lanes: usize, frame: Frame) -> f32 {
    let scale = object.emission_scale.as_ref().map_or(&[][..], |c| c.lanes());
    let mut out = vec![0.0f32; lanes];
    let mut sum = 0.0f64;
    for probe in 0..EMISSION_PROBES {
        // Fixed numbers, so the powers (and the image) are reproducible.
        let mut u = super::sampling::Sampler::new(0x11c4, probe, k as u32, 0);
        let (uv, u3) = (u.next_2d(), u.next_1d());
        let Some((surface, _)) = light.area_point(geometry, uv, u3) else { continue };
        out.fill(0.0);
        let g = super::integrator::globals_of(&surface, 0.0, frame);
        object.material.emission_into(&g, surface.n.to_array(), &mut out);
        for (c, x) in out.iter().enumerate() {
            let x = x * scale.get(c).copied().unwrap_or(1.0);
            if x.is_finite() && x > 0.0 {
                sum += f64::from(x);
            }
        }
    }
    (sum / f64::from(EMISSION_PROBES) / lanes.max(1) as f64) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn objects_sharing_a_material_share_one_compile() {
        let clay = MaterialRef::TreeBody { module: 0, item: 1 };
        let gold = MaterialRef::TreeBody { module: 0, item: 2 };
        let wanted = [(0, clay), (3, gold), (5, clay), (7, clay), (9, gold)];
        let mut asked = Vec::new();
        let given = per_material(&wanted, |items| {
            asked = items.to_vec();
            Ok(items.iter().map(|(name, _)| name.clone()).collect())
        })
        .unwrap();
        assert_eq!(asked, vec![("@object0".to_string(), clay), ("@object3".to_string(), gold)]);
        let names: Vec<(usize, &str)> = given.iter().map(|(k, n)| (*k, n.as_str())).collect();
        assert_eq!(names, [(0, "@object0"), (3, "@object3"), (5, "@object0"), (7, "@object0"), (9, "@object3")]);
        assert!(per_material(&[], |_| -> Result<Vec<()>, Error> { panic!("nothing to compile") }).unwrap().is_empty());
    }
}
