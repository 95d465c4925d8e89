//! Light sources: point, spot and directional lights (delta lights, given
//! by intensity or irradiance), area lights: emissive objects of every
//! bounded shape (spheres and cylinders only under similarity transforms),
//! and the environment. Other emissive objects (an emissive infinite plane,
//! a stretched sphere) still glow; rays find them by chance only.
//! [`LightSampler`] picks one light in proportion to its power.
//!
//! Invariant: a [`LightSample`]'s `pdf` and [`Light::pdf`] are densities per
//! unit solid angle at the shaded point, so the path tracer can weigh
//! light and material sampling against each other; the probability of
//! choosing the light is not in them (the caller multiplies it in).

use super::environment::Environment;
use super::geometry::{Geometry, ObjectGeometry};
use super::sampling::{self, Distribution1D};
use super::shape::{ShapeKind, SurfaceHit};
use super::{Ray, Vec3};
use crate::Color;

pub struct Light {
    pub kind: LightKind,
}

pub enum LightKind {
    /// Radiant intensity in W/sr, exact inverse-square falloff.
    Point { at: Vec3, intensity: Color },
    /// A point light limited to a cone around `axis`, fading smoothly from
    /// `cos_inner` to `cos_outer`.
    Spot { at: Vec3, axis: Vec3, intensity: Color, cos_outer: f32, cos_inner: f32 },
    /// Parallel light travelling along `dir` with this irradiance.
    Directional { dir: Vec3, irradiance: Color },
    /// An emissive object; meshes pick triangles by area. `uv`: whether
    /// its material reads u, v or the tangents, which a sampled point's
    /// record then holds (see [`super::shape::Shape::surface_at`]).
    Area { object: u32, sampler: AreaSampler, uv: bool },
    /// The scene's environment, when it is not black.
    Environment(Box<Environment>),
}

pub enum AreaSampler {
    /// Quads and disks: uniform over the area (an affine map keeps a
    /// planar shape's uniform density uniform).
    Planar { area: f32 },
    /// A sphere under a similarity transform: by the solid angle it
    /// subtends (uniform area from inside it).
    Sphere { center: Vec3, radius: f32 },
    /// Triangles chosen in proportion to their area.
    Mesh { triangles: Distribution1D, area: f32 },
}

/// Light arriving at a point from a sampled light.
pub enum LightSample {
    /// From a delta light: `wi` toward it (unit), the distance to it
    /// (infinite for directional lights), and the factor that turns the
    /// light's intensity into radiance-times-solid-angle at the point
    /// (`1/d^2` times the spot's falloff).
    Delta { wi: Vec3, distance: f32, scale: f32 },
    /// A point on an emitting surface: its surface record (the caller asks
    /// the material for the emission toward `-wi`), the direction and
    /// distance to it, and the pdf per unit solid angle.
    Surface { wi: Vec3, distance: f32, pdf: f32, surface: SurfaceHit, tri: u32 },
    /// A direction toward the environment (unit; the light comes from
    /// infinitely far) and its pdf per unit solid angle.
    Environment { wi: Vec3, pdf: f32 },
}

impl Light {
    /// An area light for emissive object `object`, when its shape can be
    /// sampled; `uv` as in [`LightKind::Area`].
    pub fn area(geometry: &Geometry, object: u32, uv: bool) -> Option<Light> {
        let sampler = match &geometry.objects[object as usize] {
            ObjectGeometry::Shape(s) => match s.kind() {
                // Planar pieces stay uniform under any affine map.
                ShapeKind::Quad { .. } | ShapeKind::Disk { .. } | ShapeKind::Box { .. } => {
                    AreaSampler::Planar { area: s.area() }
                }
                ShapeKind::Cylinder { .. } if is_similarity(&s.to_world()) => AreaSampler::Planar { area: s.area() },
                ShapeKind::Sphere { center, radius } => {
                    let m = s.to_world();
                    if !is_similarity(&m) {
                        return None;
                    }
                    let scale = m.transform_vector3a(Vec3::X).length();
                    AreaSampler::Sphere { center: m.transform_point3a(*center), radius: radius * scale }
                }
                _ => return None,
            },
            ObjectGeometry::Mesh(m) => {
                let areas: Vec<f32> = (0..m.triangles.len() as u32).map(|t| m.triangle_area(t)).collect();
                let area = areas.iter().sum();
                AreaSampler::Mesh { triangles: Distribution1D::new(&areas)?, area }
            }
        };
        Some(Light { kind: LightKind::Area { object, sampler, uv } })
    }

    /// Samples light arriving at `x`; `u` is a 2D random number, `u3` a
    /// third for meshes. `None` when the sample carries no light.
    pub fn sample(&self, geometry: &Geometry, x: Vec3, u: [f32; 2], u3: f32) -> Option<LightSample> {
        match &self.kind {
            LightKind::Point { at, .. } => {
                let d = *at - x;
                let d2 = d.length_squared();
                (d2 > 0.0).then(|| LightSample::Delta { wi: d / d2.sqrt(), distance: d2.sqrt(), scale: 1.0 / d2 })
            }
            LightKind::Spot { at, axis, cos_outer, cos_inner, .. } => {
                let d = *at - x;
                let d2 = d.length_squared();
                if d2 <= 0.0 {
                    return None;
                }
                let wi = d / d2.sqrt();
                let cos = (-wi).dot(*axis);
                let falloff = smoothstep(*cos_outer, *cos_inner, cos);
                (falloff > 0.0).then(|| LightSample::Delta { wi, distance: d2.sqrt(), scale: falloff / d2 })
            }
            LightKind::Directional { dir, .. } => {
                Some(LightSample::Delta { wi: -*dir, distance: f32::INFINITY, scale: 1.0 })
            }
            LightKind::Environment(env) => env.sample(u).map(|(wi, pdf)| LightSample::Environment { wi, pdf }),
            LightKind::Area { object, sampler, uv } => {
                let ObjectGeometry::Shape(shape) = &geometry.objects[*object as usize] else {
                    let ObjectGeometry::Mesh(mesh) = &geometry.objects[*object as usize] else { unreachable!() };
                    let AreaSampler::Mesh { triangles, area } = sampler else { return None };
                    let (tri, _) = triangles.sample(u3);
                    let tri = tri as u32;
                    let (b1, b2) = sampling::square_to_uniform_triangle(u);
                    let [v0, v1, v2] = mesh.triangles[tri as usize].map(|i| mesh.positions[i as usize]);
                    let y = v0 * (1.0 - b1 - b2) + v1 * b1 + v2 * b2;
                    let ray = Ray::new(x, y - x);
                    let surface = mesh.surface(tri, &ray, 1.0, b1, b2);
                    return surface_sample(x, surface, 1.0 / area, tri);
                };
                match sampler {
                    AreaSampler::Planar { area } => {
                        let y = shape.sample_area(u);
                        let surface = shape.surface_at(&Ray::new(x, y - x), 1.0, *uv);
                        surface_sample(x, surface, 1.0 / area, 0)
                    }
                    AreaSampler::Sphere { center, radius } => {
                        if (x - *center).length_squared() <= radius * radius {
                            let y = shape.sample_area(u);
                            let surface = shape.surface_at(&Ray::new(x, y - x), 1.0, *uv);
                            return surface_sample(x, surface, 1.0 / shape.area(), 0);
                        }
                        let (wi, pdf) = sampling::sample_sphere_solid_angle(*center, *radius, x, u)?;
                        let ray = Ray::new(x, wi);
                        let t = shape.intersect(&ray, 0.0, f32::INFINITY)?;
                        let surface = shape.surface_at(&ray, t, *uv);
                        Some(LightSample::Surface { wi, distance: t, pdf, surface, tri: 0 })
                    }
                    AreaSampler::Mesh { .. } => None,
                }
            }
        }
    }

    /// The solid-angle pdf with which [`Light::sample`] picks the point
    /// `surface` (on this light) seen from `x`; 0 for delta lights.
    pub fn pdf(&self, x: Vec3, surface: &SurfaceHit) -> f32 {
        let LightKind::Area { sampler, .. } = &self.kind else { return 0.0 };
        let area_pdf = |pdf_area: f32| {
            let d = surface.p - x;
            let d2 = d.length_squared();
            let cos = surface.ng.dot(d / d2.sqrt()).abs();
            if cos <= 0.0 { 0.0 } else { pdf_area * d2 / cos }
        };
        match sampler {
            AreaSampler::Planar { area } => area_pdf(1.0 / area),
            AreaSampler::Mesh { area, .. } => area_pdf(1.0 / area),
            AreaSampler::Sphere { center, radius } => {
                if (x - *center).length_squared() <= radius * radius {
                    area_pdf(1.0 / (4.0 * std::f32::consts::PI * radius * radius))
                } else {
                    sampling::sphere_solid_angle_pdf(*center, *radius, x)
                }
            }
        }
    }

    /// The emitting object of an area light.
    pub fn object(&self) -> Option<u32> {
        match self.kind {
            LightKind::Area { object, .. } => Some(object),
            _ => None,
        }
    }

    /// Whether the light sits at a point or in one direction (point,
    /// spot, directional): no ray finds it by chance.
    pub fn is_delta(&self) -> bool {
        matches!(self.kind, LightKind::Point { .. } | LightKind::Spot { .. } | LightKind::Directional { .. })
    }

    /// The light's power (W, mean over the color lanes), for choosing
    /// lights in proportion to it, as pbrt-v4's `Phi`: point `4 pi I`; spot
    /// `I` times the cone's solid angle (the smooth edge counted as half);
    /// directional `E pi r²` and the environment `pi r² ∫ L dω`, the light
    /// crossing the scene's cross-section (`scene_radius` r); area `L pi A`,
    /// one side, with `area_radiance` the mean radiance `L` the caller
    /// estimated from the material.
    pub fn power(&self, scene_radius: f32, area_radiance: f32) -> f32 {
        let mean = |c: &Color| c.lanes().iter().sum::<f32>() / c.lanes().len().max(1) as f32;
        let pi = std::f32::consts::PI;
        let power = match &self.kind {
            LightKind::Point { intensity, .. } => 4.0 * pi * mean(intensity),
            LightKind::Spot { intensity, cos_outer, cos_inner, .. } => {
                mean(intensity) * std::f32::consts::TAU * (1.0 - 0.5 * (cos_inner + cos_outer))
            }
            LightKind::Directional { irradiance, .. } => mean(irradiance) * pi * scene_radius * scene_radius,
            LightKind::Area { sampler, .. } => {
                let area = match sampler {
                    AreaSampler::Planar { area } | AreaSampler::Mesh { area, .. } => *area,
                    AreaSampler::Sphere { radius, .. } => 4.0 * pi * radius * radius,
                };
                area_radiance * pi * area
            }
            LightKind::Environment(env) => env.power(scene_radius),
        };
        if power.is_finite() && power > 0.0 { power } else { 0.0 }
    }

    /// A point uniformly distributed over an area light's surface (`u3`
    /// picks a mesh's triangle), with the triangle; `None` for other
    /// lights. For estimating the light's emission.
    pub fn area_point(&self, geometry: &Geometry, u: [f32; 2], u3: f32) -> Option<(SurfaceHit, u32)> {
        let LightKind::Area { object, sampler, .. } = &self.kind else { return None };
        // Any ray through the point gives its surface record; this one
        // comes from one unit away along y.
        let ray_to = |y: Vec3| Ray::new(y + Vec3::Y, -Vec3::Y);
        match (&geometry.objects[*object as usize], sampler) {
            (ObjectGeometry::Mesh(mesh), AreaSampler::Mesh { triangles, .. }) => {
                let tri = triangles.sample(u3).0 as u32;
                let (b1, b2) = sampling::square_to_uniform_triangle(u);
                let [v0, v1, v2] = mesh.triangles[tri as usize].map(|i| mesh.positions[i as usize]);
                let y = v0 * (1.0 - b1 - b2) + v1 * b1 + v2 * b2;
                Some((mesh.surface(tri, &ray_to(y), 1.0, b1, b2), tri))
            }
            (ObjectGeometry::Shape(shape), _) => Some((shape.surface(&ray_to(shape.sample_area(u)), 1.0), 0)),
            _ => None,
        }
    }
}

/// Chooses one light for next-event estimation in proportion to its power
/// (pbrt-v4's `PowerLightSampler`). Lights of zero power are never chosen.
#[derive(Debug, Clone, Default)]
pub struct LightSampler {
    /// `None` when no light has power.
    distribution: Option<Distribution1D>,
}

impl LightSampler {
    /// A sampler over lights of these powers (see [`Light::power`]).
    pub fn new(powers: &[f32]) -> LightSampler {
        LightSampler { distribution: Distribution1D::new(powers) }
    }

    /// The light that `u` picks, its probability, and `u` remapped to a
    /// fresh uniform number (with one light, `u` itself).
    pub fn sample(&self, u: f32) -> Option<(usize, f32, f32)> {
        let distribution = self.distribution.as_ref()?;
        // One light is the common case: no search, the same numbers.
        if distribution.len() == 1 {
            return Some((0, 1.0, u));
        }
        let (k, pmf, rest) = distribution.sample_remapped(u);
        (pmf > 0.0).then_some((k, pmf, rest))
    }

    /// The probability of choosing light `k`.
    pub fn pmf(&self, k: usize) -> f32 {
        self.distribution.as_ref().map_or(0.0, |d| d.pmf(k))
    }
}

/// Whether `m` scales all directions alike (rotations, translations and a
/// uniform scale), which keeps spheres spheres.
fn is_similarity(m: &glam::Mat4) -> bool {
    let (x, y, z) = (m.transform_vector3a(Vec3::X), m.transform_vector3a(Vec3::Y), m.transform_vector3a(Vec3::Z));
    let s = x.length();
    let tol = 1e-4 * s;
    (y.length() - s).abs() <= tol
        && (z.length() - s).abs() <= tol
        && x.dot(y).abs() <= tol * s
        && y.dot(z).abs() <= tol * s
}

/// Converts an area-density sample at `surface` to solid angle at `x`.
fn surface_sample(x: Vec3, surface: SurfaceHit, pdf_area: f32, tri: u32) -> Option<LightSample> {
    let d = surface.p - x;
    let d2 = d.length_squared();
    if d2 <= 0.0 || !d2.is_finite() {
        return None;
    }
    let distance = d2.sqrt();
    let wi = d / distance;
    let cos = surface.ng.dot(wi).abs();
    if cos <= 1e-7 {
        return None;
    }
    Some(LightSample::Surface { wi, distance, pdf: pdf_area * d2 / cos, surface, tri })
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    if e1 <= e0 {
        return if x >= e0 { 1.0 } else { 0.0 };
    }
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}
