//! The checked scene description: the `scene { }` block as plain data.
//!
//! [`describe`] runs right after checking. It evaluates every property
//! value (they are constants for a frame: the checker keeps the per-point
//! shading globals out of them; [`describe_frame`] gives `frame` and
//! `time` their values), checks what the checker's schema cannot see (non-finite numbers,
//! a camera looking at its own position, `up` along the view, degenerate
//! shapes and transforms, spot cones), reads the files the scene names (OBJ
//! meshes, environment images) and reports every problem at once as a
//! diagnostic at the property at fault. What comes out is a [`SceneDesc`]:
//! camera, render settings, environment, lights and objects, each property
//! typed and with its span, materials as [`MaterialRef`] handles into the
//! checked program.
//!
//! Architecture invariant: this is the only reader of the scene's syntax.
//! `render` builds cameras, shapes, the BVH and lights from a `SceneDesc`
//! alone and never imports `syntax`; a description without errors is one
//! `render` can build (only render-time settings, such as a zero image
//! size given on the command line, can still fail there).

mod content;
mod describe;
mod lean;
mod mesh;
mod shape;

pub use crate::check::MaterialRef;
pub use content::{InputContent, InputFile, content_hash, input_files};
pub use describe::{describe, describe_frame, description_model};
pub use lean::{drop_object_syntax, forgettable_spans};
pub use mesh::{MAX_MESH_BYTES, MAX_MESH_LINE_BYTES, MeshData};
pub use shape::{ShapeError, ShapeKind, Transform, affine_rows, compose, mesh_transform_error, shape_transform_error};

use crate::color::ColorModel;
use crate::diag::Span;
use crate::syntax::ast;
use std::sync::Arc;

/// Vectors and matrices of the description are glam's, as the renderer's.
pub type Vec3 = glam::Vec3A;
pub type Mat4 = glam::Mat4;

/// A value and where it is written: the property's value, or, for a
/// default the scene did not write, the block it belongs to.
#[derive(Debug, Clone, PartialEq)]
pub struct Prop<T> {
    pub value: T,
    pub span: Span,
}

impl<T> Prop<T> {
    pub fn new(value: T, span: Span) -> Prop<T> {
        Prop { value, span }
    }
}

/// A color in the description's color model: its lanes (3 for RGB).
pub type Lanes = Vec<f32>;

/// The `scene { }` block, checked.
#[derive(Debug, Clone)]
pub struct SceneDesc {
    /// The color model the colors were evaluated in.
    pub model: ColorModel,
    /// The `scene` keyword.
    pub span: Span,
    pub camera: CameraDesc,
    pub render: RenderDesc,
    /// `light environment { }` or `background`; `None` for black.
    pub environment: Option<EnvironmentDesc>,
    /// Point, spot and directional lights, in scene order.
    pub lights: Vec<LightDesc>,
    /// What rays can hit, in scene order: `object` blocks, and the surfaces
    /// of area lights (`light rect`, `light sphere`).
    pub objects: Vec<ObjectDesc>,
    /// The frame its values were evaluated at.
    pub frame: Frame,
}

/// The most a frame number may be from 0 (`--frame`, `--frames`).
pub const MAX_FRAME: i32 = 1_000_000;
/// Frames per second when neither the render block nor the command line
/// says (`time = frame / fps`).
pub const DEFAULT_FPS: f32 = 24.0;

/// Which frame of an animation to describe: the values of the shading
/// globals `frame` and `time` in scene values and shaders.
///
/// ```
/// let request = tsl::scene::FrameRequest { frame: 48, fps: Some(24.0) };
/// assert_eq!(request.frame, 48);
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FrameRequest {
    /// The frame number, at most [`MAX_FRAME`] from 0.
    pub frame: i32,
    /// Frames per second given outside the scene (`tslc render --fps`):
    /// then `time = frame / fps` whatever the render block says.
    pub fps: Option<f32>,
}

/// The frame a description is of.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Frame {
    pub number: i32,
    /// Seconds: `frame / fps` (the command line's, else the render block's
    /// `fps`, else [`DEFAULT_FPS`]), or the render block's `time` mapping.
    pub time: f32,
}

/// The camera, its defaults filled in (`up` +y, `fov` 45 degrees across
/// the width, `aperture` 0: a pinhole).
#[derive(Debug, Clone, PartialEq)]
pub struct CameraDesc {
    /// The `camera` block.
    pub span: Span,
    pub from: Prop<Vec3>,
    pub to: Prop<Vec3>,
    pub up: Prop<Vec3>,
    /// Degrees, in (0, 180).
    pub fov: Prop<f32>,
    /// The lens radius; 0 for a pinhole.
    pub aperture: Prop<f32>,
    /// The distance in focus; `None` for the distance from `from` to `to`.
    pub focus: Option<Prop<f32>>,
}

// The image bounds are image_io's: merge and info check files against them.
pub use crate::image_io::{MAX_IMAGE_SIDE, MAX_PIXELS};
/// The most samples per pixel (`spp`, `--spp`).
pub const MAX_SPP: u32 = 1 << 20;
/// The longest path (`max_depth`, `--max-depth`).
pub const MAX_DEPTH: u32 = 1024;

/// What the `render { }` block sets; `None` where it says nothing, so the
/// renderer's defaults (and command-line overrides) apply.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RenderDesc {
    pub width: Option<Prop<u32>>,
    pub height: Option<Prop<u32>>,
    pub spp: Option<Prop<u32>>,
    pub max_depth: Option<Prop<u32>>,
    pub seed: Option<Prop<u64>>,
    pub integrator: Option<Prop<IntegratorKind>>,
    pub light_sampling: Option<Prop<LightSampling>>,
    /// Frames per second: a frame's time is `frame / fps`.
    pub fps: Option<Prop<f32>>,
    /// The `time` mapping's value at the frame described.
    pub time: Option<Prop<f32>>,
}

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
    /// One light per vertex, chosen in proportion to its power: the cost of
    /// one light however many there are.
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

/// The environment: light from infinitely far away.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvironmentDesc {
    /// The `light environment` block or the `background` property.
    pub span: Span,
    pub source: EnvironmentSourceDesc,
    /// Not negative; 1 for `background`.
    pub scale: Prop<f32>,
    /// Degrees about x, then y, then z; zero for `background`.
    pub rotate: Prop<Vec3>,
}

#[derive(Debug, Clone, PartialEq)]
pub enum EnvironmentSourceDesc {
    /// The same radiance from every direction.
    Constant(Prop<Lanes>),
    /// A lat-long image, read when the scene was described.
    Image(Prop<Arc<EnvironmentImage>>),
}

/// A lat-long environment image as linear RGB, row by row, +y at the top.
#[derive(Clone, PartialEq)]
pub struct EnvironmentImage {
    /// The file, as the scene's directory and the property spell it.
    pub path: std::path::PathBuf,
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<[f32; 3]>,
}

impl std::fmt::Debug for EnvironmentImage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EnvironmentImage")
            .field("path", &self.path)
            .field("width", &self.width)
            .field("height", &self.height)
            .finish()
    }
}

/// A light's strength: as written, or as a power to be divided by the
/// solid angle it shines into (the renderer knows which).
#[derive(Debug, Clone, PartialEq)]
pub struct LightColor {
    pub color: Prop<Lanes>,
    /// `power` (W) was given rather than `intensity` (W/sr).
    pub from_power: bool,
}

/// A point, spot or directional light.
#[derive(Debug, Clone, PartialEq)]
pub enum LightDesc {
    Point {
        span: Span,
        at: Prop<Vec3>,
        intensity: LightColor,
    },
    Spot {
        span: Span,
        at: Prop<Vec3>,
        /// Unit, from `at` toward `to`.
        axis: Prop<Vec3>,
        intensity: LightColor,
        /// The half angle of the cone, degrees, in (0, 180).
        cone: Prop<f32>,
        /// The width of the smooth edge, degrees, in [0, cone].
        falloff: Prop<f32>,
    },
    Directional {
        span: Span,
        /// Unit: the direction the light travels.
        direction: Prop<Vec3>,
        irradiance: Prop<Lanes>,
    },
}

/// An object: a shape, how it is placed, and what it is made of.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectDesc {
    /// The block.
    pub span: Span,
    pub shape: ShapeDesc,
    /// In the order written (area lights have none).
    pub transforms: Vec<Prop<Transform>>,
    pub surface: Surface,
}

impl ObjectDesc {
    /// The object's transforms composed: object to world.
    pub fn to_world(&self) -> Mat4 {
        compose(self.transforms.iter().map(|t| &t.value))
    }
}

/// A shape in its own frame, each number with its property's span.
#[derive(Debug, Clone, PartialEq)]
pub enum ShapeDesc {
    Sphere {
        center: Prop<Vec3>,
        radius: Prop<f32>,
    },
    Plane {
        point: Prop<Vec3>,
        normal: Prop<Vec3>,
        tile: Prop<f32>,
    },
    /// `object quad`, and the surface of `light rect`.
    Quad {
        corner: Prop<Vec3>,
        edge1: Prop<Vec3>,
        edge2: Prop<Vec3>,
    },
    Disk {
        center: Prop<Vec3>,
        normal: Prop<Vec3>,
        radius: Prop<f32>,
    },
    Box {
        min: Prop<Vec3>,
        max: Prop<Vec3>,
    },
    Cylinder {
        base: Prop<Vec3>,
        axis: Prop<Vec3>,
        radius: Prop<f32>,
        height: Prop<f32>,
    },
    /// A triangle mesh read from its file when the scene was described.
    Mesh {
        file: Prop<Arc<MeshData>>,
    },
}

impl ShapeDesc {
    /// The analytic shape's numbers; `None` for a mesh.
    pub fn kind(&self) -> Option<ShapeKind> {
        Some(match self {
            ShapeDesc::Sphere { center, radius } => ShapeKind::Sphere { center: center.value, radius: radius.value },
            ShapeDesc::Plane { point, normal, tile } => {
                ShapeKind::Plane { point: point.value, normal: normal.value, tile: tile.value }
            }
            ShapeDesc::Quad { corner, edge1, edge2 } => {
                ShapeKind::Quad { corner: corner.value, edge1: edge1.value, edge2: edge2.value }
            }
            ShapeDesc::Disk { center, normal, radius } => {
                ShapeKind::Disk { center: center.value, normal: normal.value, radius: radius.value }
            }
            ShapeDesc::Box { min, max } => ShapeKind::Box { min: min.value, max: max.value },
            ShapeDesc::Cylinder { base, axis, radius, height } => {
                ShapeKind::Cylinder { base: base.value, axis: axis.value, radius: radius.value, height: height.value }
            }
            ShapeDesc::Mesh { .. } => return None,
        })
    }

    /// The span of the shape's property `name`, for messages.
    fn span_of(&self, name: &str) -> Option<Span> {
        let span = match (self, name) {
            (ShapeDesc::Sphere { center, .. } | ShapeDesc::Disk { center, .. }, "center") => center.span,
            (ShapeDesc::Sphere { radius, .. } | ShapeDesc::Disk { radius, .. }, "radius") => radius.span,
            (ShapeDesc::Cylinder { radius, .. }, "radius") => radius.span,
            (ShapeDesc::Plane { point, .. }, "point") => point.span,
            (ShapeDesc::Plane { normal, .. } | ShapeDesc::Disk { normal, .. }, "normal") => normal.span,
            (ShapeDesc::Plane { tile, .. }, "tile") => tile.span,
            (ShapeDesc::Quad { corner, .. }, "corner") => corner.span,
            (ShapeDesc::Quad { edge1, .. }, "edge1") => edge1.span,
            (ShapeDesc::Quad { edge2, .. }, "edge2") => edge2.span,
            (ShapeDesc::Box { min, .. }, "min") => min.span,
            (ShapeDesc::Box { max, .. }, "max") => max.span,
            (ShapeDesc::Cylinder { base, .. }, "base") => base.span,
            (ShapeDesc::Cylinder { axis, .. }, "axis") => axis.span,
            (ShapeDesc::Cylinder { height, .. }, "height") => height.span,
            _ => return None,
        };
        Some(span)
    }
}

/// What an object's surface is.
#[derive(Debug, Clone, PartialEq)]
pub enum Surface {
    /// The `material` property of an `object` block.
    Material(MaterialDesc),
    /// An area light's surface: the stdlib `emitter`, scaled to the light's
    /// radiance (given, or from its power over its area).
    Emitter(AreaEmission),
}

/// An object's material: where it is written and, when it is the plain
/// name of a material of the program, that name (its compiled entries are
/// then shared by every object that names it).
#[derive(Debug, Clone, PartialEq)]
pub struct MaterialDesc {
    pub material: MaterialRef,
    /// Shared by the objects that name one material.
    pub name: Option<Arc<str>>,
    pub span: Span,
}

/// An area light's strength.
#[derive(Debug, Clone, PartialEq)]
pub enum AreaEmission {
    /// `radiance` (W/(m² sr)).
    Radiance(Prop<Lanes>),
    /// `power` (W), spread over the surface.
    Power(Prop<Lanes>),
}

/// The scene a program renders: the first `scene { }` block of the root
/// program and its imports (not the prelude), with its module and item.
pub(crate) fn root_scene(program: &crate::check::Program) -> Option<(usize, usize, &ast::Scene)> {
    program.loaded.modules.iter().enumerate().filter(|(_, m)| !m.is_prelude).find_map(|(m, module)| {
        module.ast.items.iter().enumerate().find_map(|(i, item)| match item {
            ast::Item::Scene(scene) => Some((m, i, scene)),
            _ => None,
        })
    })
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    /// The layering the description exists for, checked on the sources:
    /// `render` reads no syntax, `texture` does not reach into `render`, and
    /// `image_io` is a leaf.
    #[test]
    fn render_reads_no_syntax_and_image_io_is_a_leaf() {
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
        let rules: [(&str, &[&str]); 4] = [
            ("render", &["crate::syntax", "syntax::"]),
            ("texture", &["crate::render"]),
            ("image_io.rs", &["crate::render", "crate::texture", "crate::scene"]),
            ("image_io", &["crate::render", "crate::texture", "crate::scene"]),
        ];
        for (place, forbidden) in rules {
            let path = src.join(place);
            // Every file under `place`, subdirectories included.
            let (mut pending, mut files) = (vec![path], Vec::new());
            while let Some(p) = pending.pop() {
                if p.is_dir() {
                    pending.extend(std::fs::read_dir(&p).unwrap().map(|e| e.unwrap().path()));
                } else {
                    files.push(p);
                }
            }
            for file in files {
                let text = std::fs::read_to_string(&file).unwrap();
                for f in forbidden {
                    assert!(!text.contains(f), "{} mentions `{f}`", file.display());
                }
            }
        }
    }
}
