//! Analytic shapes: sphere, infinite plane, quad, disk, box and cylinder.
//! Each is kept in its own frame (as written in the scene, before the
//! object's transforms); rays are moved into that frame to be intersected
//! (their direction is not renormalised, so `t` is shared with the world
//! ray) and the surface record is moved back.
//!
//! Conventions (world y up). `dPdu x dPdv` points along the outward
//! geometric normal for every shape; `Pl` is the hit point in the shape's
//! frame minus its anchor (sphere and disk centre, plane point, quad
//! corner, cylinder base; the box's own coordinates).
//! - sphere: `u = phi / 2 pi`, phi measured about +y from +x toward -z;
//!   `v = 0` at the bottom pole (-y), 1 at the top.
//! - plane: tangents `s, t` with `s x t = n`; for `n = +y`, `s = +x` and
//!   `t = -z`; `u, v` are distances along them divided by `tile` (not
//!   wrapped).
//! - quad: `(u, v)` are the parallelogram's own coordinates in [0, 1].
//! - disk: `u = phi / 2 pi` in the plane's `(s, t)`, `v = 1 - r / radius`.
//! - box: faces 0..5 are -x, +x, -y, +y, -z, +z; `(u, v)` run across each
//!   face in [0, 1], upright and unmirrored seen from outside.
//! - cylinder: `u = phi / 2 pi` about the axis, `v` the height fraction on
//!   the side (face 0); caps are faces 1 (bottom) and 2 (top), polar.

use super::sampling::{self, Frame};
use super::{Mat4, Ray, Vec3};
use glam::Mat3A as Mat3;
use glam::Vec3Swizzles;
use std::f32::consts::{PI, TAU};

/// A ray hit before shading, in world space unless noted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceHit {
    pub t: f32,
    pub p: Vec3,
    /// Object space: see the module documentation.
    pub pl: Vec3,
    /// Unit geometric normal on the shape's outward side (not turned
    /// toward the ray).
    pub ng: Vec3,
    /// Unit shading normal (the same as `ng` for analytic shapes).
    pub n: Vec3,
    pub u: f32,
    pub v: f32,
    pub dpdu: Vec3,
    pub dpdv: Vec3,
    pub face: i32,
}

/// Shapes as written in the scene are plain data of the scene description.
pub use crate::scene::ShapeKind;

/// A shape placed in the world.
#[derive(Debug, Clone)]
pub struct Shape {
    kind: ShapeKind,
    /// How the shape is placed; `None` when its transform is exactly the
    /// identity (most objects of a generated scene: a shape was 320 bytes
    /// with its matrices, about a third of a million-sphere render).
    placement: Option<Box<Placement>>,
    /// For planes and disks: the tangent frame of the normal; for
    /// cylinders: the frame of the axis. Unit normals and axes.
    frame: Frame,
    /// Whether the transform equals the identity (as numbers: `-0` is
    /// `0`); rays and normals are then not transformed.
    identity: bool,
    /// An untransformed plane whose normal and tangents come through
    /// `surface_at`'s normalisation and degenerate check unchanged (a
    /// floor's do): its record skips that work, the most hits of a small
    /// scene.
    plain_plane: bool,
    /// For quads: `edge1 x edge2` and one over its squared length.
    quad_n: Vec3,
    quad_inv_n2: f32,
    /// An untransformed quad whose unit normal (`frame.n`) comes through
    /// `surface_at`'s normalisation unchanged (an axis-aligned one's does):
    /// its hits' normal is `frame.n`, with no normalisation a hit.
    exact_quad_normal: bool,
}

/// A transformed shape's matrices.
#[derive(Debug, Clone)]
struct Placement {
    to_world: Mat4,
    to_object: Mat4,
    /// Transforms normals: the inverse transpose of the linear part.
    normal_matrix: Mat3,
    /// For quads and boxes: each face's world normal as `surface_at`'s
    /// general path computes it (a matrix and a normalisation for a normal
    /// that is the same at every hit of the face); a quad's is the first.
    face_normals: Option<Box<[Vec3; 6]>>,
}

/// A padded world box around a shape whose own test is costly (a transformed
/// shape moves each ray into its frame first; a cylinder solves a
/// quadratic and two caps): most rays of a small scene miss it, and
/// [`Cull::misses`] rejects them before that work. The padding covers the
/// rounding of the exact test, so no ray it hits is ever rejected.
#[derive(Debug, Clone, Copy)]
pub struct Cull {
    lo: Vec3,
    hi: Vec3,
    /// Extra padding per unit of the ray origin's largest coordinate: the
    /// exact test's transform of the origin rounds in proportion to it.
    slack: f32,
}

impl Cull {
    /// Whether the ray surely misses the shape within `(t_min, t_max)`;
    /// `inv_dir` is `ray.dir.recip()`.
    #[inline(always)]
    pub fn misses(&self, ray: &Ray, inv_dir: Vec3, t_min: f32, t_max: f32) -> bool {
        let pad = Vec3::splat(self.slack * ray.origin.abs().max_element());
        let a = (self.lo - pad - ray.origin) * inv_dir;
        let b = (self.hi + pad - ray.origin) * inv_dir;
        let near = a.min(b);
        let far = a.max(b);
        // The slabs' entry max(near) is past their exit min(far) when some
        // near exceeds some far: compared lane by lane, without the scalar
        // chains of f32::max. A NaN compares false, so never rejects.
        let apart = near.cmpgt(far.yzx()) | near.cmpgt(far.zxy());
        (apart | far.cmple(Vec3::splat(t_min)) | near.cmpge(Vec3::splat(t_max))).any()
    }
}

/// A shape's intersection test, [`Shape::tester`].
pub type Tester = fn(&Shape, &Ray, f32, f32) -> Option<f32>;

/// For [`Shape::intersect_in_frame`]: every kind.
const ANY_KIND: u8 = u8::MAX;

/// The kinds' numbers for [`Shape::intersect_in_frame`].
fn kind_number(kind: &ShapeKind) -> u8 {
    match kind {
        ShapeKind::Sphere { .. } => 0,
        ShapeKind::Plane { .. } => 1,
        ShapeKind::Quad { .. } => 2,
        ShapeKind::Disk { .. } => 3,
        ShapeKind::Box { .. } => 4,
        ShapeKind::Cylinder { .. } => 5,
    }
}

/// The `to_world` of a shape without placement.
static IDENTITY: Mat4 = Mat4::IDENTITY;

/// Tangents `s, t` of a unit normal with `s x t = n`: `s` is +x made
/// perpendicular to `n` (or +z when `n` is near the x axis).
fn plane_frame(n: Vec3) -> Frame {
    let helper = if n.x.abs() > 0.9 { Vec3::Z } else { Vec3::X };
    let s = (helper - helper.dot(n) * n).normalize();
    Frame { s, t: n.cross(s), n }
}

impl Shape {
    /// Checks the shape's numbers and places it with `to_world` (an affine
    /// map).
    pub fn new(kind: ShapeKind, to_world: Mat4) -> Result<Shape, String> {
        if let Some(e) = crate::scene::shape_transform_error(&to_world) {
            return Err(e.into());
        }
        // The scene description checks shapes with the same rules.
        let kind = kind.validated().map_err(|e| e.message)?;
        let frame = match kind {
            ShapeKind::Sphere { .. } | ShapeKind::Box { .. } => Frame::new(Vec3::Y),
            ShapeKind::Plane { normal, .. } | ShapeKind::Disk { normal, .. } => plane_frame(normal),
            ShapeKind::Quad { edge1, edge2, .. } => plane_frame(edge1.cross(edge2).normalize()),
            ShapeKind::Cylinder { axis, .. } => plane_frame(axis),
        };
        let linear = Mat3::from_mat4(to_world);
        let exactly_identity = to_world.to_cols_array().map(f32::to_bits) == IDENTITY.to_cols_array().map(f32::to_bits);
        let placement = (!exactly_identity).then(|| {
            Box::new(Placement {
                to_world,
                to_object: to_world.inverse(),
                normal_matrix: linear.inverse().transpose(),
                face_normals: None,
            })
        });
        let quad_n = match kind {
            ShapeKind::Quad { edge1, edge2, .. } => edge1.cross(edge2),
            _ => Vec3::Z,
        };
        let identity = to_world == Mat4::IDENTITY;
        let plain_plane = match kind {
            ShapeKind::Plane { normal, tile, .. } if identity => {
                let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                bits(normal.normalize_or(Vec3::Y)) == bits(normal)
                    && !degenerate_tangents(frame.s * tile, frame.t * tile, normal)
            }
            _ => false,
        };
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        let exact_quad_normal =
            matches!(kind, ShapeKind::Quad { .. }) && identity && bits(frame.n.normalize_or(Vec3::Y)) == bits(frame.n);
        let mut shape = Shape {
            quad_n,
            quad_inv_n2: 1.0 / quad_n.length_squared(),
            kind,
            placement,
            frame,
            identity,
            plain_plane,
            exact_quad_normal,
        };
        let normals = shape.placed_face_normals();
        if let Some(p) = shape.placement.as_mut() {
            p.face_normals = normals.map(Box::new);
        }
        Ok(shape)
    }

    /// The world normals of a transformed quad's face (in the first entry)
    /// or a transformed box's six, each through [`Shape::world_normal`] as
    /// a hit computes it.
    fn placed_face_normals(&self) -> Option<[Vec3; 6]> {
        if self.identity {
            return None;
        }
        match self.kind {
            ShapeKind::Quad { .. } => Some([self.world_normal(self.frame.n); 6]),
            ShapeKind::Box { .. } => Some(std::array::from_fn(|face| self.world_normal(box_face_normal(face)))),
            _ => None,
        }
    }

    /// The world normal of face `face` when it is known without work: an
    /// untransformed box's (unit axes come through normalisation
    /// unchanged), an exact quad's, a transformed quad's or box's kept one.
    #[inline(always)]
    fn flat_normal(&self, face: i32) -> Option<Vec3> {
        match self.kind {
            ShapeKind::Box { .. } if self.identity => Some(box_face_normal(face as usize)),
            ShapeKind::Quad { .. } if self.exact_quad_normal => Some(self.frame.n),
            _ => self.placement.as_ref()?.face_normals.as_ref().map(|n| n[face as usize]),
        }
    }

    /// The unit world normal of the object-space normal `n`.
    #[inline(always)]
    fn world_normal(&self, n: Vec3) -> Vec3 {
        match &self.placement {
            Some(p) if !self.identity => (p.normal_matrix * n).normalize_or(Vec3::Y),
            _ => n.normalize_or(Vec3::Y),
        }
    }

    pub fn kind(&self) -> &ShapeKind {
        &self.kind
    }

    /// The map into the shape's frame, `None` when the shape is not
    /// transformed (as its own intersection test decides).
    pub fn to_object(&self) -> Option<&Mat4> {
        self.placement.as_ref().filter(|_| !self.identity).map(|p| &p.to_object)
    }

    /// For quads: `edge1 x edge2` and one over its squared length.
    pub fn quad_normal(&self) -> (Vec3, f32) {
        (self.quad_n, self.quad_inv_n2)
    }

    pub fn to_world(&self) -> Mat4 {
        *self.world()
    }

    fn world(&self) -> &Mat4 {
        self.placement.as_ref().map_or(&IDENTITY, |p| &p.to_world)
    }

    /// The ray in the shape's frame (for a shape that is transformed).
    fn local_ray(&self, ray: &Ray) -> Ray {
        match &self.placement {
            Some(p) => Ray::new(p.to_object.transform_point3a(ray.origin), p.to_object.transform_vector3a(ray.dir)),
            None => *ray,
        }
    }

    /// The ray in the shape's own frame: `ray` itself when the shape is
    /// untransformed (reading back a fresh copy stalls on store
    /// forwarding), else its transform, kept in `slot`.
    #[inline]
    fn in_frame<'a>(&self, ray: &'a Ray, slot: &'a mut Option<Ray>) -> &'a Ray {
        if self.identity { ray } else { slot.insert(self.local_ray(ray)) }
    }

    /// Whether the shape has [`Self::bounds`]: all but the infinite plane.
    /// Cheaper than asking for them.
    pub fn is_bounded(&self) -> bool {
        !matches!(self.kind, ShapeKind::Plane { .. })
    }

    /// The world bounding box; `None` for the infinite plane.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let (lo, hi) = match self.kind {
            ShapeKind::Sphere { center, radius } => (center - Vec3::splat(radius), center + Vec3::splat(radius)),
            ShapeKind::Plane { .. } => return None,
            ShapeKind::Quad { corner, edge1, edge2 } => {
                let pts = [corner, corner + edge1, corner + edge2, corner + edge1 + edge2];
                (pts.iter().fold(pts[0], |a, b| a.min(*b)), pts.iter().fold(pts[0], |a, b| a.max(*b)))
            }
            ShapeKind::Disk { center, normal, radius } => {
                let e = radius * (Vec3::ONE - normal * normal).max(Vec3::ZERO).powf(0.5);
                (center - e, center + e)
            }
            ShapeKind::Box { min, max } => (min, max),
            ShapeKind::Cylinder { base, axis, radius, height } => {
                let e = radius * (Vec3::ONE - axis * axis).max(Vec3::ZERO).powf(0.5);
                let top = base + axis * height;
                (base.min(top) - e, base.max(top) + e)
            }
        };
        // A little slack so rays grazing a flat shape are not culled.
        let pad = 1e-5 * (1.0 + lo.abs().max(hi.abs()).max_element());
        let (lo, hi) = (lo - Vec3::splat(pad), hi + Vec3::splat(pad));
        let mut wlo = Vec3::splat(f32::INFINITY);
        let mut whi = Vec3::splat(f32::NEG_INFINITY);
        for k in 0..8 {
            let c = Vec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            let w = self.world().transform_point3a(c);
            wlo = wlo.min(w);
            whi = whi.max(w);
        }
        Some((wlo, whi))
    }

    /// A [`Cull`] for a shape worth one: transformed and bounded, or a
    /// cylinder, disk or quad (a division and more before their miss).
    pub fn cull(&self) -> Option<Cull> {
        if self.identity && matches!(self.kind, ShapeKind::Sphere { .. } | ShapeKind::Box { .. }) {
            return None;
        }
        let (lo, hi) = self.bounds()?;
        // The exact test's rounding grows with the transform's condition
        // number (in the Frobenius norm, an upper bound), squared: once
        // for the ray's transform, once for `to_object` being a rounded
        // inverse. 1e-5 is about 170 float epsilons.
        let m = self.world();
        let linear = Mat3::from_mat4(*m);
        let norm = |a: Mat3| (a.x_axis.length_squared() + a.y_axis.length_squared() + a.z_axis.length_squared()).sqrt();
        let cond = norm(linear) * norm(linear.inverse());
        let slack = 1e-5 * cond * cond;
        let size = 1.0 + lo.abs().max(hi.abs()).max_element() + m.w_axis.abs().max_element();
        let pad = Vec3::splat(slack * size);
        let cull = Cull { lo: lo - pad, hi: hi + pad, slack };
        (cull.lo.is_finite() && cull.hi.is_finite() && slack.is_finite()).then_some(cull)
    }

    /// The nearest `t` in `(t_min, t_max)` where the ray meets the shape.
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<f32> {
        let mut slot = None;
        let r = self.in_frame(ray, &mut slot);
        self.intersect_in_frame::<ANY_KIND>(r, t_min, t_max)
    }

    /// [`Shape::intersect`] for a ray already in the shape's frame. `K`
    /// is [`ANY_KIND`] or the kind's number, which leaves only its arm.
    #[inline(always)]
    fn intersect_in_frame<const K: u8>(&self, r: &Ray, t_min: f32, t_max: f32) -> Option<f32> {
        let ok = |t: f32| t > t_min && t < t_max;
        let is = |kind: u8| K == ANY_KIND || K == kind;
        debug_assert!(is(kind_number(&self.kind)));
        match self.kind {
            ShapeKind::Sphere { center, radius } if is(0) => {
                let (t0, t1) = sphere_roots(r, center, radius)?;
                nearer(t0, t1, ok)
            }
            ShapeKind::Plane { point, normal, .. } if is(1) => plane_t(r, point, normal).filter(|t| ok(*t)),
            ShapeKind::Quad { corner, edge1, edge2 } if is(2) => {
                let n = self.quad_n;
                let t = plane_t(r, corner, n).filter(|t| ok(*t))?;
                let (s, q) = quad_coords(r.at(t) - corner, edge1, edge2, n, self.quad_inv_n2);
                ((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&q)).then_some(t)
            }
            ShapeKind::Disk { center, normal, radius } if is(3) => {
                let t = plane_t(r, center, normal).filter(|t| ok(*t))?;
                ((r.at(t) - center).length_squared() <= radius * radius).then_some(t)
            }
            ShapeKind::Box { min, max } if is(4) => {
                let (t0, t1) = slabs(r, min, max)?;
                nearer(t0, t1, ok)
            }
            ShapeKind::Cylinder { base, radius, height, .. } if is(5) => {
                self.cylinder_t(r, base, radius, height, t_min, t_max)
            }
            // Another kind than `K`: not reached (see `tester`).
            _ => None,
        }
    }

    /// The cylinder's arm of [`Shape::intersect`], out of line: long, and
    /// rare in the specialised tests.
    #[inline(never)]
    fn cylinder_t(&self, r: &Ray, base: Vec3, radius: f32, height: f32, t_min: f32, t_max: f32) -> Option<f32> {
        self.cylinder_hits(r, base, radius, height)
            .into_iter()
            .flatten()
            .filter(|(t, _)| *t > t_min && *t < t_max)
            .map(|(t, _)| t)
            .reduce(f32::min)
    }

    /// [`Shape::intersect`] specialised to this shape's kind and whether it
    /// is transformed: for a small scene's list of shapes, where matching
    /// the kind and the placement again for every ray costs as much as a
    /// sphere's test.
    pub fn tester(&self) -> Tester {
        fn test<const K: u8, const MOVED: bool>(s: &Shape, ray: &Ray, t_min: f32, t_max: f32) -> Option<f32> {
            if MOVED {
                s.intersect_in_frame::<K>(&s.local_ray(ray), t_min, t_max)
            } else {
                s.intersect_in_frame::<K>(ray, t_min, t_max)
            }
        }
        // `identity` is what `in_frame` tests.
        match (kind_number(&self.kind), self.identity) {
            (0, true) => test::<0, false>,
            (0, false) => test::<0, true>,
            (1, true) => test::<1, false>,
            (1, false) => test::<1, true>,
            (2, true) => test::<2, false>,
            (2, false) => test::<2, true>,
            (3, true) => test::<3, false>,
            (3, false) => test::<3, true>,
            (4, true) => test::<4, false>,
            (4, false) => test::<4, true>,
            (_, true) => test::<5, false>,
            (_, false) => test::<5, true>,
        }
    }

    /// The candidate hits of a cylinder: side (both roots) and caps, with
    /// their face numbers.
    fn cylinder_hits(&self, r: &Ray, base: Vec3, radius: f32, height: f32) -> [Option<(f32, i32)>; 4] {
        let o = self.frame.to_local(r.origin - base);
        let d = self.frame.to_local(r.dir);
        let mut out = [None; 4];
        // Side: x^2 + y^2 = r^2 with 0 <= z <= h.
        let a = d.x * d.x + d.y * d.y;
        if a > 0.0 {
            let b = o.x * d.x + o.y * d.y;
            let c = o.x * o.x + o.y * o.y - radius * radius;
            // The stable form: the discriminant from the closest approach.
            let fx = o.x - b / a * d.x;
            let fy = o.y - b / a * d.y;
            let disc = radius * radius - (fx * fx + fy * fy);
            if disc >= 0.0 {
                let q = -b - (a * disc).sqrt().copysign(b);
                for (k, t) in [c / q, q / a].into_iter().enumerate() {
                    let z = o.z + t * d.z;
                    if t.is_finite() && (0.0..=height).contains(&z) {
                        out[k] = Some((t, 0));
                    }
                }
            }
        }
        if d.z != 0.0 {
            for (k, (z, face)) in [(0.0, 1), (height, 2)].into_iter().enumerate() {
                let t = (z - o.z) / d.z;
                let (x, y) = (o.x + t * d.x, o.y + t * d.y);
                if x * x + y * y <= radius * radius {
                    out[2 + k] = Some((t, face));
                }
            }
        }
        out
    }

    /// The surface record at a `t` returned by [`Shape::intersect`].
    pub fn surface(&self, ray: &Ray, t: f32) -> SurfaceHit {
        self.surface_at(ray, t, true)
    }

    /// [`Shape::surface`]; without `uv`, a sphere's and a quad's `u`, `v`
    /// and every shape's tangents may be left out (zero): they cost
    /// trigonometry, divisions and matrices that a material reading none of
    /// them need not pay.
    pub fn surface_at(&self, ray: &Ray, t: f32, uv: bool) -> SurfaceHit {
        let mut slot = None;
        let r = self.in_frame(ray, &mut slot);
        let p = r.at(t);
        let (pl, n, u, v, dpdu, dpdv, face) = match self.kind {
            ShapeKind::Sphere { center, .. } if !uv => {
                // The normal is normalised below.
                let q = p - center;
                (q, q, 0.0, 0.0, Vec3::ZERO, Vec3::ZERO, 0)
            }
            ShapeKind::Sphere { center, radius } => {
                let q = p - center;
                let n = q / radius;
                let cos_theta = n.y.clamp(-1.0, 1.0);
                let theta = cos_theta.acos();
                let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
                let phi = (-q.z).atan2(q.x).rem_euclid(TAU);
                // cos and sin of phi straight from the point (no sin_cos).
                let rho = (q.x * q.x + q.z * q.z).sqrt();
                let (sp, cp) = if rho > 0.0 { (-q.z / rho, q.x / rho) } else { (0.0, 1.0) };
                let dpdu = TAU * radius * Vec3::new(-sin_theta * sp, 0.0, -sin_theta * cp);
                let dpdv = -PI * radius * Vec3::new(cos_theta * cp, -sin_theta, -cos_theta * sp);
                (q, n, phi / TAU, 1.0 - theta / PI, dpdu, dpdv, 0)
            }
            ShapeKind::Plane { point, normal, tile } => {
                let q = p - point;
                let f = self.frame;
                let (u, v, dpdu, dpdv) = (q.dot(f.s) / tile, q.dot(f.t) / tile, f.s * tile, f.t * tile);
                if self.plain_plane {
                    // What the general path below gives (`r` is `ray`).
                    let (dpdu, dpdv) = if uv { (dpdu, dpdv) } else { (Vec3::ZERO, Vec3::ZERO) };
                    return SurfaceHit { t, p, pl: q, ng: normal, n: normal, u, v, dpdu, dpdv, face: 0 };
                }
                (q, normal, u, v, dpdu, dpdv, 0)
            }
            ShapeKind::Quad { corner, edge1, edge2 } => {
                let q = p - corner;
                let (s, tt) = if uv { quad_coords(q, edge1, edge2, self.quad_n, self.quad_inv_n2) } else { (0.0, 0.0) };
                // `frame.n` is `edge1 x edge2` normalised.
                (q, self.frame.n, s, tt, edge1, edge2, 0)
            }
            ShapeKind::Disk { center, normal, radius } => {
                let q = p - center;
                let (u, v, dpdu, dpdv) = polar(q, self.frame, radius);
                (q, normal, u, v, dpdu, dpdv, 0)
            }
            ShapeKind::Box { min, max } => box_surface(p, min, max),
            ShapeKind::Cylinder { base, axis, radius, height } => {
                let f = self.frame;
                let q = p - base;
                let local = f.to_local(q);
                let face = self
                    .cylinder_hits(r, base, radius, height)
                    .into_iter()
                    .flatten()
                    .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()))
                    .map_or(0, |h| h.1);
                match face {
                    0 => {
                        let phi = local.y.atan2(local.x).rem_euclid(TAU);
                        let (sp, cp) = phi.sin_cos();
                        let n = (cp * f.s + sp * f.t).normalize();
                        let dpdu = TAU * radius * (-sp * f.s + cp * f.t);
                        (q, n, phi / TAU, (local.z / height).clamp(0.0, 1.0), dpdu, axis * height, 0)
                    }
                    1 => {
                        // The bottom cap faces -axis: flip the disk's v so
                        // dPdu x dPdv still points outward.
                        let (u, v, dpdu, dpdv) = polar(q, f, radius);
                        (q, -axis, u, 1.0 - v, dpdu, -dpdv, 1)
                    }
                    _ => {
                        let (u, v, dpdu, dpdv) = polar(q - axis * height, f, radius);
                        (q, axis, u, v, dpdu, dpdv, 2)
                    }
                }
            }
        };
        let ng = self.flat_normal(face).unwrap_or_else(|| self.world_normal(n));
        // Tangents only when asked for: a placed shape's cost two matrices.
        let (mut dpdu, mut dpdv) = match &self.placement {
            Some(p) if uv && !self.identity => {
                (p.to_world.transform_vector3a(dpdu), p.to_world.transform_vector3a(dpdv))
            }
            _ if uv => (dpdu, dpdv),
            _ => (Vec3::ZERO, Vec3::ZERO),
        };
        // Degenerate parametrisations (sphere poles, disk centres): any
        // tangent frame of the normal, so shaders never see a zero vector.
        if uv && degenerate_tangents(dpdu, dpdv, ng) {
            let f = Frame::new(ng);
            dpdu = f.s;
            dpdv = f.t;
        }
        SurfaceHit { t, p: ray.at(t), pl, ng, n: ng, u, v, dpdu, dpdv, face }
    }

    /// World-space area (exact for planar shapes under any affine map,
    /// and for the rest under a similarity transform).
    pub fn area(&self) -> f32 {
        let m = |v: Vec3| self.world().transform_vector3a(v);
        // The scale factor of a similarity transform.
        let similarity = m(Vec3::X).length();
        match self.kind {
            ShapeKind::Sphere { radius, .. } => 4.0 * PI * (radius * similarity) * (radius * similarity),
            ShapeKind::Plane { .. } => f32::INFINITY,
            ShapeKind::Quad { edge1, edge2, .. } => m(edge1).cross(m(edge2)).length(),
            ShapeKind::Disk { radius, .. } => PI * radius * radius * m(self.frame.s).cross(m(self.frame.t)).length(),
            ShapeKind::Box { min, max } => {
                let e = max - min;
                let (x, y, z) = (m(Vec3::X * e.x), m(Vec3::Y * e.y), m(Vec3::Z * e.z));
                2.0 * (x.cross(y).length() + y.cross(z).length() + z.cross(x).length())
            }
            ShapeKind::Cylinder { radius, height, .. } => {
                let s2 = similarity * similarity;
                (TAU * radius * height + 2.0 * PI * radius * radius) * s2
            }
        }
    }

    /// A point uniformly distributed over the shape's area (world space):
    /// exact for quads, disks and boxes under any affine map, and for
    /// spheres and cylinders under a similarity transform. The infinite
    /// plane gives its point.
    pub fn sample_area(&self, u: [f32; 2]) -> Vec3 {
        let m = |v: Vec3| self.world().transform_vector3a(v);
        let local = match self.kind {
            ShapeKind::Box { min, max } => {
                // A face in proportion to its world area, then uniform on it.
                let e = max - min;
                let (x, y, z) = (m(Vec3::X * e.x), m(Vec3::Y * e.y), m(Vec3::Z * e.z));
                let areas = [y.cross(z).length(), z.cross(x).length(), x.cross(y).length()];
                let total = 2.0 * (areas[0] + areas[1] + areas[2]);
                let mut pick = u[0] * total;
                let mut face = 5;
                for k in 0..6 {
                    if pick < areas[k / 2] || k == 5 {
                        face = k;
                        break;
                    }
                    pick -= areas[k / 2];
                }
                let s = (pick / areas[face / 2]).clamp(0.0, 1.0);
                let axis = face / 2;
                let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
                let mut p = min;
                p[axis] = if face % 2 == 0 { min[axis] } else { max[axis] };
                p[a] = min[a] + e[a] * s;
                p[b] = min[b] + e[b] * u[1];
                p
            }
            ShapeKind::Cylinder { base, axis, radius, height } => {
                let (side, cap) = (TAU * radius * height, PI * radius * radius);
                let pick = u[0] * (side + 2.0 * cap);
                let f = self.frame;
                if pick < side {
                    let phi = TAU * (pick / side);
                    base + radius * (phi.cos() * f.s + phi.sin() * f.t) + axis * (height * u[1])
                } else {
                    let top = pick >= side + cap;
                    let s = ((pick - side - if top { cap } else { 0.0 }) / cap).clamp(0.0, 1.0);
                    let [x, y] = sampling::square_to_uniform_disk_concentric([s, u[1]]);
                    base + radius * (x * f.s + y * f.t) + if top { axis * height } else { Vec3::ZERO }
                }
            }
            ShapeKind::Quad { corner, edge1, edge2 } => corner + u[0] * edge1 + u[1] * edge2,
            ShapeKind::Disk { center, radius, .. } => {
                let [x, y] = sampling::square_to_uniform_disk_concentric(u);
                center + radius * (x * self.frame.s + y * self.frame.t)
            }
            ShapeKind::Sphere { center, radius } => center + radius * sampling::square_to_uniform_sphere(u),
            ShapeKind::Plane { point, .. } => point,
        };
        self.world().transform_point3a(local)
    }
}

/// Both roots of a ray and a sphere, nearest first (Ray Tracing Gems,
/// chapter 7: the discriminant from the point of closest approach keeps
/// precision for far and small spheres).
fn sphere_roots(r: &Ray, center: Vec3, radius: f32) -> Option<(f32, f32)> {
    let f = r.origin - center;
    let a = r.dir.length_squared();
    if a == 0.0 {
        return None;
    }
    // Most rays miss: reject them without a division. |f x d|^2 / a is the
    // squared distance of closest approach; the margin leaves rays within
    // rounding of the silhouette to the exact test below.
    let r2 = radius * radius;
    if f.cross(r.dir).length_squared() > r2 * a * (1.0 + 1e-3) {
        return None;
    }
    let b = -f.dot(r.dir);
    let l = f + (b / a) * r.dir;
    let disc = radius * radius - l.length_squared();
    if disc < 0.0 {
        return None;
    }
    let c = f.length_squared() - radius * radius;
    let q = b + (a * disc).sqrt().copysign(b);
    if q == 0.0 {
        // The origin is on the sphere and the ray is tangent to it.
        return Some((0.0, 0.0));
    }
    let (t0, t1) = (c / q, q / a);
    Some(if t0 <= t1 { (t0, t1) } else { (t1, t0) })
}

/// Whether tangents need replacing: a zero one, or not along `ng`.
#[inline]
fn degenerate_tangents(dpdu: Vec3, dpdv: Vec3, ng: Vec3) -> bool {
    dpdu.length_squared() < 1e-20 || dpdv.length_squared() < 1e-20 || dpdu.cross(dpdv).dot(ng) <= 0.0
}

/// The first of the ordered roots `t0 <= t1` that `ok` accepts.
#[inline]
fn nearer(t0: f32, t1: f32, ok: impl Fn(f32) -> bool) -> Option<f32> {
    if ok(t0) {
        Some(t0)
    } else if ok(t1) {
        Some(t1)
    } else {
        None
    }
}

fn plane_t(r: &Ray, point: Vec3, normal: Vec3) -> Option<f32> {
    let denom = normal.dot(r.dir);
    if denom == 0.0 {
        return None;
    }
    let t = normal.dot(point - r.origin) / denom;
    t.is_finite().then_some(t)
}

/// Coordinates of `w` (in the plane) along a parallelogram's edges.
fn quad_coords(w: Vec3, e1: Vec3, e2: Vec3, n: Vec3, inv_n2: f32) -> (f32, f32) {
    (w.cross(e2).dot(n) * inv_n2, e1.cross(w).dot(n) * inv_n2)
}

/// Entry and exit `t` of a ray through an axis-aligned box.
fn slabs(r: &Ray, min: Vec3, max: Vec3) -> Option<(f32, f32)> {
    let inv = r.dir.recip();
    let a = (min - r.origin) * inv;
    let b = (max - r.origin) * inv;
    // min/max ignore the NaN of 0 * inf (origin on a slab, ray parallel).
    let near = a.min(b);
    let far = a.max(b);
    let t0 = near.x.max(near.y).max(near.z);
    let t1 = far.x.min(far.y).min(far.z);
    // A NaN (zero direction) compares false: no hit.
    (t0 <= t1).then_some((t0, t1))
}

/// Polar coordinates of `q` in the plane of `f` (for disks and caps):
/// `u = phi / 2 pi`, `v = 1 - r / radius`, with their tangents.
fn polar(q: Vec3, f: Frame, radius: f32) -> (f32, f32, Vec3, Vec3) {
    let (x, y) = (q.dot(f.s), q.dot(f.t));
    let r = (x * x + y * y).sqrt();
    let phi = y.atan2(x).rem_euclid(TAU);
    let (sp, cp) = phi.sin_cos();
    let dpdu = TAU * r * (-sp * f.s + cp * f.t);
    let dpdv = -radius * (cp * f.s + sp * f.t);
    (phi / TAU, 1.0 - r / radius, dpdu, dpdv)
}

#[allow(clippy::type_complexity)]
fn box_surface(p: Vec3, min: Vec3, max: Vec3) -> (Vec3, Vec3, f32, f32, Vec3, Vec3, i32) {
    let size = max - min;
    let q = (p - min) / size;
    // The face whose plane the point is nearest, relative to the box size.
    let distances = [q.x, 1.0 - q.x, q.y, 1.0 - q.y, q.z, 1.0 - q.z];
    let mut face = 0;
    for k in 1..6 {
        if distances[k] * size[k / 2] < distances[face] * size[face / 2] {
            face = k;
        }
    }
    let (sx, sy, sz) = (size.x, size.y, size.z);
    let (u, v, dpdu, dpdv) = match face {
        0 => (q.z, q.y, Vec3::new(0.0, 0.0, sz), Vec3::new(0.0, sy, 0.0)),
        1 => (1.0 - q.z, q.y, Vec3::new(0.0, 0.0, -sz), Vec3::new(0.0, sy, 0.0)),
        2 => (q.x, q.z, Vec3::new(sx, 0.0, 0.0), Vec3::new(0.0, 0.0, sz)),
        3 => (q.x, 1.0 - q.z, Vec3::new(sx, 0.0, 0.0), Vec3::new(0.0, 0.0, -sz)),
        4 => (1.0 - q.x, q.y, Vec3::new(-sx, 0.0, 0.0), Vec3::new(0.0, sy, 0.0)),
        _ => (q.x, q.y, Vec3::new(sx, 0.0, 0.0), Vec3::new(0.0, sy, 0.0)),
    };
    (p, box_face_normal(face), u.clamp(0.0, 1.0), v.clamp(0.0, 1.0), dpdu, dpdv, face as i32)
}

/// The outward normal of a box's face (numbered as in the module
/// documentation).
fn box_face_normal(face: usize) -> Vec3 {
    [Vec3::NEG_X, Vec3::X, Vec3::NEG_Y, Vec3::Y, Vec3::NEG_Z, Vec3::Z][face.min(5)]
}

#[cfg(test)]
mod tests;
