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
use crate::texture::{LAST_UDIM_TILE, TextureImage, UDIM_TOKEN, UdimSet, udim_tile_at};
use crate::{Color, ColorModel, Error, HitCalls, Material, MaterialSource, Program, SurfaceOptions};
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

/// Scenes with more delta lights than this shade them one call each.
pub const MAX_SUMMED_LIGHTS: usize = 8;

/// An object's surface: its compiled material (which the integrators call
/// only through its [`Surface`](crate::Surface)), shared by the objects
/// that name one material.
pub struct Object {
    pub material: Material,
    /// Multiplies the material's emission (area lights given as `light rect`
    /// or `light sphere` use the stdlib `emitter` scaled to their radiance,
    /// as pbrt's area lights take a `scale`).
    pub emission_scale: Option<Color>,
    /// Where the first object with this surface is defined, for messages.
    pub span: Span,
}

impl Object {
    /// The surface may emit: its material's `emission` is not the default
    /// black, and its scale (if any) is not black.
    pub fn emissive(&self) -> bool {
        self.material.facts().may_emit
            && self.emission_scale.as_ref().is_none_or(|c: &Color| c.lanes().iter().any(|x| *x > 0.0))
    }
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
    /// The program's UDIM tile sets, whose tiles load during the render: a
    /// tile that fails to load makes [`super::render`] an error.
    pub tile_sets: Vec<Arc<UdimSet>>,
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
        let mut objects: Vec<(usize, Option<Color>, Span)> = Vec::new();
        // What each distinct material is, compiled together below.
        let mut sources: Vec<MaterialSource> = Vec::new();
        let mut source_of: HashMap<MaterialRef, usize> = HashMap::new();
        let mut emitter: Option<usize> = None;
        // Each named material is looked up once.
        let mut by_name: HashMap<Arc<str>, u32> = HashMap::new();
        let mut has_emitters = false;
        let count = descs.len();
        let mut surface_of_object: Vec<u32> = Vec::with_capacity(count);
        // Per mesh object with texture coordinates, when the program has
        // tile sets: its surface, its file's span and path, the tiles its uv cover.
        let has_tile_sets =
            self.program.checked().images.iter().any(|i| matches!(i.image, Some(TextureImage::Udim(_))));
        let mut mesh_tiles: Vec<(u32, Span, std::path::PathBuf, Vec<u32>)> = Vec::new();
        for o in descs.iter() {
            let to_world = o.to_world();
            if has_tile_sets && let (ShapeDesc::Mesh { file }, Surface::Material(m)) = (&o.shape, &o.surface) {
                let surface = m.name.as_ref().and_then(|n| by_name.get(&**n).copied()).unwrap_or(objects.len() as u32);
                let tiles = udim_tiles_of(&file.value);
                if !tiles.is_empty() {
                    mesh_tiles.push((surface, file.span, file.value.path.clone(), tiles));
                }
            }
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
                Surface::Material(m) => {
                    if let Some(name) = &m.name {
                        if let Some(&shared) = by_name.get(&**name) {
                            surface_of_object.push(shared);
                            geometry.push(placed);
                            continue;
                        }
                        by_name.insert(name.clone(), surface);
                    }
                    let source = *source_of.entry(m.material).or_insert_with(|| {
                        sources.push(MaterialSource::Ref(m.material));
                        sources.len() - 1
                    });
                    objects.push((source, None, o.span));
                }
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
                    has_emitters = true;
                    let source = *emitter.get_or_insert_with(|| {
                        sources.push(MaterialSource::Named("emitter".into()));
                        sources.len() - 1
                    });
                    objects.push((source, Some(radiance), o.span));
                }
            }
            surface_of_object.push(surface);
            geometry.push(placed);
        }
        drop(descs);
        // Whitted shades an object that neither reflects nor refracts under
        // 2 to MAX_SUMMED_LIGHTS delta lights (and no other light) with one
        // reflection sum: one evaluation per hit already, no hit group.
        let summed = summed_lights(&lights);
        let summed_alone =
            settings.integrator == IntegratorKind::Whitted && summed == Some(lights.len()) && !has_emitters;
        let samples = u64::from(settings.width) * u64::from(settings.height) * u64::from(settings.spp);
        let options = SurfaceOptions {
            hit_calls: (!overrides.unsplit).then_some(match settings.integrator {
                IntegratorKind::Path => HitCalls::Path,
                IntegratorKind::Whitted => HitCalls::Whitted,
            }),
            // Summed delta lights serve the integrators that sample every light.
            summed_lights: summed.filter(|_| {
                settings.integrator == IntegratorKind::Whitted || settings.light_sampling == LightSampling::All
            }),
            sums_instead_of_groups: summed_alone,
            optimize_large: overrides.optimize_code.unwrap_or(samples >= OPTIMIZE_FROM_SAMPLES),
        };
        let materials = self.program.compile_surfaces(&sources, &options)?;
        for (surface, span, path, tiles) in &mesh_tiles {
            let material = &materials[objects[*surface as usize].0];
            for set in material.udim_sets_at_uv() {
                if let Some(&missing) = tiles.iter().find(|&&n| set.tile(n).is_none()) {
                    let have: Vec<String> = set.tiles.iter().map(|t| t.number.to_string()).collect();
                    let tile_file = set.name.replace(UDIM_TOKEN, &format!("{missing:04}"));
                    return Err(self.program.error(
                        Diagnostic::error(
                            *span,
                            format!(
                                "the mesh `{}` has texture coordinates in UDIM tile {missing}, which `{}` does not have",
                                path.display(),
                                set.name
                            ),
                        )
                        .with_help(format!("the set has tiles {}; add `{tile_file}`", have.join(", "))),
                    ));
                }
            }
        }
        let tile_sets: Vec<Arc<UdimSet>> = (self.program.checked().images.iter())
            .filter_map(|i| match &i.image {
                Some(TextureImage::Udim(set)) => Some(set.clone()),
                _ => None,
            })
            .collect();
        let objects: Vec<Object> = objects
            .into_iter()
            .map(|(source, emission_scale, span)| Object { material: materials[source].clone(), emission_scale, span })
            .collect();
        let geometry = Geometry::new(geometry);
        for (k, &surface) in surface_of_object.iter().enumerate() {
            let object = &objects[surface as usize];
            if object.emissive()
                && let Some(light) = Light::area(&geometry, k as u32, object.material.facts().reads_uv())
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
            tile_sets,
        })
    }
}

/// The UDIM tiles a mesh's texture coordinates lie in, ascending: the
/// tile of each triangle's uv centroid (a triangle whose corners sit on a
/// tile's edge, as uv shells laid out in a tile do, belongs to that tile).
fn udim_tiles_of(mesh: &crate::scene::MeshData) -> Vec<u32> {
    let Some(uvs) = &mesh.uvs else { return Vec::new() };
    let mut seen = vec![false; (LAST_UDIM_TILE + 1) as usize];
    for tri in &mesh.triangles {
        let [a, b, c] = tri.map(|i| uvs.get(i as usize).copied().unwrap_or_default());
        let centroid = [(a[0] + b[0] + c[0]) / 3.0, (a[1] + b[1] + c[1]) / 3.0];
        if let Some(tile) = udim_tile_at(centroid[0], centroid[1]) {
            seen[tile as usize] = true;
        }
    }
    (0..=LAST_UDIM_TILE).filter(|&n| seen[n as usize]).collect()
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
    let mut record = crate::SurfaceRecord::new();
    let mut sum = 0.0f64;
    for probe in 0..EMISSION_PROBES {
        // Fixed numbers, so the powers (and the image) are reproducible.
        let mut u = super::sampling::Sampler::new(0x11c4, probe, k as u32, 0);
        let (uv, u3) = (u.next_2d(), u.next_1d());
        let Some((surface, _)) = light.area_point(geometry, uv, u3) else { continue };
        let g = super::integrator::globals_of(&surface, 0.0, frame);
        let ones = Color::from_lanes(object.material.color_model(), &vec![1.0; lanes]);
        let emitted = object.material.at(&g, surface.n.to_array(), &ones, &mut record).emission();
        out.copy_from_slice(&emitted.lanes()[..lanes]);
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
    /// The renderer reaches compiled code only through the embedding API's
    /// surface: no module of `render` imports lowering.
    #[test]
    fn render_does_not_import_lowering() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/render");
        let mut files = vec![dir.clone()];
        let mut checked = 0;
        while let Some(path) = files.pop() {
            if path.is_dir() {
                files.extend(std::fs::read_dir(&path).unwrap().map(|e| e.unwrap().path()));
            } else if path.extension().is_some_and(|e| e == "rs") {
                let text = std::fs::read_to_string(&path).unwrap();
                // Spelled in pieces, so this file does not name them itself.
                for needle in [["ir::", "lower"], ["Hit", "Method"], ["call_", "words"], ["Hit", "Material"]] {
                    let needle = needle.concat();
                    assert!(!text.contains(&needle), "{} names `{needle}`", path.display());
                }
                checked += 1;
            }
        }
        assert!(checked > 10, "{checked} files");
    }
}
