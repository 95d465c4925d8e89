//! A small scene's quads, spheres and boxes tested [`LANES`] at a time:
//! shapes of one kind (and either all placed by a transform or none) are
//! packed into groups in structure-of-arrays form, one shape a lane of
//! glam's `Vec4` (SSE on x86-64, NEON on Arm). Each lane repeats the
//! scalar test of [`Shape::intersect`] operation for operation (the same
//! products, sums and comparisons in the same order, without fused
//! multiply-adds), so a group finds the very `t` the scalar test finds.

use super::shape::{Shape, ShapeKind};
use super::{Ray, Vec3};
use glam::{BVec4A, Vec4};

/// Shapes in a group: the lanes of glam's `Vec4`.
pub const LANES: usize = 4;

/// Four 3-vectors, one a lane.
#[derive(Debug, Clone, Copy)]
struct Vec3x4 {
    x: Vec4,
    y: Vec4,
    z: Vec4,
}

impl Vec3x4 {
    fn gather(v: [Vec3; LANES]) -> Vec3x4 {
        Vec3x4 {
            x: Vec4::from_array(v.map(|v| v.x)),
            y: Vec4::from_array(v.map(|v| v.y)),
            z: Vec4::from_array(v.map(|v| v.z)),
        }
    }

    #[inline(always)]
    fn splat(v: Vec3) -> Vec3x4 {
        Vec3x4 { x: Vec4::splat(v.x), y: Vec4::splat(v.y), z: Vec4::splat(v.z) }
    }

    #[inline(always)]
    fn sub(self, o: Vec3x4) -> Vec3x4 {
        Vec3x4 { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }

    /// glam's `Vec3A::dot`: `(x x' + y y') + z z'`.
    #[inline(always)]
    fn dot(self, o: Vec3x4) -> Vec4 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    #[inline(always)]
    fn cross(self, o: Vec3x4) -> Vec3x4 {
        Vec3x4 { x: self.y * o.z - o.y * self.z, y: self.z * o.x - o.z * self.x, z: self.x * o.y - o.x * self.y }
    }

    /// `self + t * d`, as `Ray::at`.
    #[inline(always)]
    fn at(self, t: Vec4, d: Vec3x4) -> Vec3x4 {
        Vec3x4 { x: self.x + t * d.x, y: self.y + t * d.y, z: self.z + t * d.z }
    }
}

/// The affine maps of a group's shapes into their frames, by columns, as
/// glam's `Mat4::transform_point3a` applies them.
#[derive(Debug, Clone, Copy)]
struct Affine3x4 {
    cols: [Vec3x4; 4],
}

impl Affine3x4 {
    #[inline(always)]
    fn vector(&self, v: Vec3) -> Vec3x4 {
        let [a, b, c, _] = &self.cols;
        let lane = |a: Vec4, b: Vec4, c: Vec4| b * Vec4::splat(v.y) + a * Vec4::splat(v.x) + c * Vec4::splat(v.z);
        Vec3x4 { x: lane(a.x, b.x, c.x), y: lane(a.y, b.y, c.y), z: lane(a.z, b.z, c.z) }
    }

    #[inline(always)]
    fn point(&self, p: Vec3) -> Vec3x4 {
        let v = self.vector(p);
        let w = self.cols[3];
        Vec3x4 { x: w.x + v.x, y: w.y + v.y, z: w.z + v.z }
    }
}

/// What a group's lanes hold beside their frames.
#[derive(Debug, Clone, Copy)]
enum Lanes {
    /// `n = edge1 x edge2` and one over its squared length.
    Quad {
        corner: Vec3x4,
        edge1: Vec3x4,
        edge2: Vec3x4,
        n: Vec3x4,
        inv_n2: Vec4,
    },
    Sphere {
        center: Vec3x4,
        radius: Vec4,
    },
    Box {
        min: Vec3x4,
        max: Vec3x4,
    },
}

/// Up to [`LANES`] shapes of one kind, tested together.
#[derive(Debug, Clone)]
pub struct Group {
    lanes: Lanes,
    /// Into each shape's frame, for transformed shapes (all of the group's
    /// or none).
    to_object: Option<Affine3x4>,
    /// The lanes that hold a shape (the rest repeat the last).
    live: BVec4A,
    /// The object of each lane.
    pub objects: [u32; LANES],
}

/// Shapes (with their objects) of one [`group_key`].
type Bucket<'a> = ((u8, bool), Vec<(u32, &'a Shape)>);

/// The group a shape belongs in: its kind and whether it is transformed;
/// `None` for kinds tested one by one.
fn group_key(shape: &Shape) -> Option<(u8, bool)> {
    let kind = match shape.kind() {
        ShapeKind::Quad { .. } => 0,
        ShapeKind::Sphere { .. } => 1,
        ShapeKind::Box { .. } => 2,
        _ => return None,
    };
    Some((kind, shape.to_object().is_some()))
}

/// Packs the shapes that groups can test, two or more to a group; returns
/// the groups and the shapes left (their objects).
pub fn pack<'a>(shapes: impl IntoIterator<Item = (u32, &'a Shape)>) -> (Vec<Group>, Vec<u32>) {
    let mut buckets: Vec<Bucket> = Vec::new();
    let mut rest = Vec::new();
    for (object, shape) in shapes {
        let Some(key) = group_key(shape) else {
            rest.push(object);
            continue;
        };
        match buckets.iter_mut().find(|(k, _)| *k == key) {
            Some((_, b)) => b.push((object, shape)),
            None => buckets.push((key, vec![(object, shape)])),
        }
    }
    let mut groups = Vec::new();
    for chunk in buckets.iter().flat_map(|(_, b)| b.chunks(LANES)) {
        // A shape alone is tested alone: its specialised scalar test, with
        // its early outs and culling box, beats four lanes that have none.
        match chunk {
            [(object, _)] => rest.push(*object),
            _ => groups.push(Group::new(chunk)),
        }
    }
    (groups, rest)
}

impl Group {
    /// A group of 1 to [`LANES`] shapes of one [`group_key`].
    fn new(shapes: &[(u32, &Shape)]) -> Group {
        let lane = |k: usize| shapes[k.min(shapes.len() - 1)];
        let live = BVec4A::new(true, shapes.len() > 1, shapes.len() > 2, shapes.len() > 3);
        let objects = std::array::from_fn(|k| lane(k).0);
        let v3 = |f: &dyn Fn(&Shape) -> Vec3| Vec3x4::gather(std::array::from_fn(|k| f(lane(k).1)));
        let f1 = |f: &dyn Fn(&Shape) -> f32| Vec4::from_array(std::array::from_fn(|k| f(lane(k).1)));
        let to_object = shapes[0].1.to_object().is_some().then(|| Affine3x4 {
            cols: std::array::from_fn(|c| {
                v3(&|s| s.to_object().map_or(Vec3::ZERO, |m| Vec3::from(m.col(c).truncate())))
            }),
        });
        let lanes = match shapes[0].1.kind() {
            ShapeKind::Quad { .. } => {
                let part = |s: &Shape, k: usize| match *s.kind() {
                    ShapeKind::Quad { corner, edge1, edge2 } => [corner, edge1, edge2][k],
                    _ => Vec3::ZERO,
                };
                Lanes::Quad {
                    corner: v3(&|s| part(s, 0)),
                    edge1: v3(&|s| part(s, 1)),
                    edge2: v3(&|s| part(s, 2)),
                    n: v3(&|s| s.quad_normal().0),
                    inv_n2: f1(&|s| s.quad_normal().1),
                }
            }
            ShapeKind::Sphere { .. } => {
                let part = |s: &Shape| match *s.kind() {
                    ShapeKind::Sphere { center, radius } => (center, radius),
                    _ => (Vec3::ZERO, 0.0),
                };
                Lanes::Sphere { center: v3(&|s| part(s).0), radius: f1(&|s| part(s).1) }
            }
            _ => {
                let part = |s: &Shape| match *s.kind() {
                    ShapeKind::Box { min, max } => (min, max),
                    _ => (Vec3::ZERO, Vec3::ZERO),
                };
                Lanes::Box { min: v3(&|s| part(s).0), max: v3(&|s| part(s).1) }
            }
        };
        Group { lanes, to_object, live, objects }
    }

    /// Each lane's nearest `t` in `(t_min, t_max)`, and which lanes hit;
    /// `t` is meaningless in the others.
    #[inline(always)]
    pub fn hits(&self, ray: &Ray, t_min: f32, t_max: f32) -> (Vec4, BVec4A) {
        let (o, d) = match &self.to_object {
            Some(m) => (m.point(ray.origin), m.vector(ray.dir)),
            None => (Vec3x4::splat(ray.origin), Vec3x4::splat(ray.dir)),
        };
        let (t_min, t_max) = (Vec4::splat(t_min), Vec4::splat(t_max));
        let ok = |t: Vec4| t.cmpgt(t_min) & t.cmplt(t_max);
        let (t, hit) = match &self.lanes {
            Lanes::Quad { corner, edge1, edge2, n, inv_n2 } => {
                // `plane_t`, then the parallelogram's coordinates.
                let denom = n.dot(d);
                let t = n.dot(corner.sub(o)) / denom;
                // Most rays meet no quad's plane within the bounds.
                let planes = denom.cmpne(Vec4::ZERO) & t.is_finite_mask() & ok(t) & self.live;
                if !planes.any() {
                    return (t, planes);
                }
                let w = o.at(t, d).sub(*corner);
                let s = w.cross(*edge2).dot(*n) * *inv_n2;
                let q = edge1.cross(w).dot(*n) * *inv_n2;
                let inside = |x: Vec4| x.cmpge(Vec4::ZERO) & x.cmple(Vec4::ONE);
                (t, planes & inside(s) & inside(q))
            }
            Lanes::Sphere { center, radius } => sphere(o, d, *center, *radius, self.live, ok),
            Lanes::Box { min, max } => {
                // `slabs`: SSE's min and max as glam's, and `f32::max`'s
                // way with NaN across the axes.
                let inv = Vec3x4 { x: d.x.recip(), y: d.y.recip(), z: d.z.recip() };
                let a = min.sub(o);
                let b = max.sub(o);
                let (ax, ay, az) = (a.x * inv.x, a.y * inv.y, a.z * inv.z);
                let (bx, by, bz) = (b.x * inv.x, b.y * inv.y, b.z * inv.z);
                let (nx, ny, nz) = (ax.min(bx), ay.min(by), az.min(bz));
                let (fx, fy, fz) = (ax.max(bx), ay.max(by), az.max(bz));
                let t0 = max_num(max_num(nx, ny), nz);
                let t1 = min_num(min_num(fx, fy), fz);
                let crossed = t0.cmple(t1);
                let (near_ok, far_ok) = (ok(t0), ok(t1));
                (Vec4::select(near_ok, t0, t1), crossed & (near_ok | far_ok))
            }
        };
        (t, hit & self.live)
    }
}

/// `sphere_roots` and `nearer` of the shape module, lane by lane.
#[inline(always)]
fn sphere(
    o: Vec3x4,
    d: Vec3x4,
    center: Vec3x4,
    radius: Vec4,
    live: BVec4A,
    ok: impl Fn(Vec4) -> BVec4A,
) -> (Vec4, BVec4A) {
    let f = o.sub(center);
    let a = d.dot(d);
    let r2 = radius * radius;
    let cross = f.cross(d);
    // Negated comparisons, as the scalar test's early outs: NaN passes.
    let near_line = !cross.dot(cross).cmpgt(r2 * a * Vec4::splat(1.0 + 1e-3)) & a.cmpne(Vec4::ZERO) & live;
    // Most rays pass far from every sphere: no division, no root.
    if !near_line.any() {
        return (a, near_line);
    }
    let b = -f.dot(d);
    let ba = b / a;
    let l = f.at(ba, d);
    let disc = radius * radius - l.dot(l);
    let c = f.dot(f) - radius * radius;
    let q = b + (a * disc).sqrt().copysign(b);
    let (t0, t1) = (c / q, q / a);
    let tangent = q.cmpeq(Vec4::ZERO);
    let (t0, t1) = (Vec4::select(tangent, Vec4::ZERO, t0), Vec4::select(tangent, Vec4::ZERO, t1));
    let swap = t0.cmple(t1);
    let (near, far) = (Vec4::select(swap, t0, t1), Vec4::select(swap, t1, t0));
    let (near_ok, far_ok) = (ok(near), ok(far));
    let roots = near_line & !disc.cmplt(Vec4::ZERO);
    (Vec4::select(near_ok, near, far), roots & (near_ok | far_ok))
}

/// `f32::max` lane by lane as x86-64 computes it: SSE's `max(b, a)`, or
/// `b` where `a` is NaN.
#[inline(always)]
fn max_num(a: Vec4, b: Vec4) -> Vec4 {
    Vec4::select(a.is_nan_mask(), b, b.max(a))
}

/// `f32::min` lane by lane, as [`max_num`].
#[inline(always)]
fn min_num(a: Vec4, b: Vec4) -> Vec4 {
    Vec4::select(a.is_nan_mask(), b, b.min(a))
}

#[cfg(test)]
mod tests;
