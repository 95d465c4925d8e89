//! All the scene's surfaces behind one query interface: analytic shapes and
//! mesh triangles in a BVH, unbounded shapes (infinite planes) tested
//! beside it. Hits name the object (and triangle) they found; the full
//! surface record is computed only for the hit that is shaded.

use super::accel::Bvh;
use super::mesh::Mesh;
use super::packed::{self, Group};
use super::shape::{Cull, Shape, SurfaceHit, Tester};
use super::{Ray, Vec3};
use glam::Vec4;

/// A growable array kept in blocks of [`Blocks::BLOCK`] elements (72 KB of
/// shapes), below the size from which the allocator maps an allocation on
/// its own: a large scene's shapes then take the memory that its dropped
/// syntax left free (`Compiler::lean`), where one array of a million
/// shapes would be 144 MB more at the render's peak.
pub struct Blocks<T> {
    blocks: Vec<Vec<T>>,
    len: usize,
}

impl<T> Default for Blocks<T> {
    fn default() -> Self {
        Blocks { blocks: Vec::new(), len: 0 }
    }
}

impl<T> Blocks<T> {
    const SHIFT: u32 = 9;
    pub const BLOCK: usize = 1 << Self::SHIFT;

    pub fn push(&mut self, x: T) {
        if self.len.is_multiple_of(Self::BLOCK) {
            self.blocks.push(Vec::with_capacity(Self::BLOCK));
        }
        if let Some(block) = self.blocks.last_mut() {
            block.push(x);
        }
        self.len += 1;
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    pub fn iter(&self) -> impl Iterator<Item = &T> {
        self.blocks.iter().flatten()
    }
}

impl<T> std::ops::Index<usize> for Blocks<T> {
    type Output = T;

    #[inline]
    fn index(&self, k: usize) -> &T {
        &self.blocks[k >> Self::SHIFT][k & (Self::BLOCK - 1)]
    }
}

/// The geometry of one object.
pub enum ObjectGeometry {
    Shape(Shape),
    /// Boxed: a mesh is 160 bytes, most objects are shapes.
    Mesh(Box<Mesh>),
}

/// A primitive of the BVH: an analytic shape, or one triangle of a mesh.
#[derive(Debug, Clone, Copy)]
struct Prim {
    object: u32,
    /// The triangle of a mesh; unused for shapes.
    tri: u32,
}

/// The nearest hit of a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    pub object: u32,
    pub tri: u32,
    pub t: f32,
}

pub struct Geometry {
    pub objects: Blocks<ObjectGeometry>,
    prims: Vec<Prim>,
    unbounded: Vec<u32>,
    bvh: Bvh,
    /// With few primitives, testing them all beats traversing a tree:
    /// then this holds every primitive, in groups tested together and
    /// one by one.
    small: Option<Small>,
}

/// Every primitive of a small scene: quads, spheres and boxes in
/// [`Group`]s of [`packed::LANES`], the rest one by one (bounded ones first,
/// then the unbounded shapes).
struct Small {
    groups: Vec<Group>,
    rest: Vec<Linear>,
    /// How many of `rest` are bounded.
    rest_bounded: usize,
}

/// A primitive of the linear list, a shape with a copy of itself: testing
/// it then reads no block of objects and matches no kind of geometry
/// (a tenth of a small scene's ray cost).
struct Linear {
    prim: Prim,
    shape: Option<Shape>,
    /// The shape's test specialised to it.
    test: Tester,
    /// For shapes with a costly test: a box that rejects most rays cheaply.
    cull: Option<Cull>,
}

/// At most this many tests of bounded primitives (a [`Group`] of shapes
/// tested together counts one) are made for a ray without the BVH.
const LINEAR_MAX: usize = 4;

impl Geometry {
    pub fn new(objects: Blocks<ObjectGeometry>) -> Geometry {
        let count = objects
            .iter()
            .map(|o| match o {
                ObjectGeometry::Shape(_) => 1,
                ObjectGeometry::Mesh(m) => m.triangles.len(),
            })
            .sum();
        let mut prims = Vec::with_capacity(count);
        let mut unbounded = Vec::new();
        for (k, o) in objects.iter().enumerate() {
            let object = k as u32;
            match o {
                ObjectGeometry::Shape(s) if !s.is_bounded() => unbounded.push(object),
                ObjectGeometry::Shape(_) => prims.push(Prim { object, tri: 0 }),
                ObjectGeometry::Mesh(m) => prims.extend((0..m.triangles.len() as u32).map(|tri| Prim { object, tri })),
            }
        }
        let small = Self::small(&objects, &prims, &unbounded);
        // The bounds go straight into the BVH builder, not through a list
        // of their own (24 bytes a primitive at the peak of a large scene).
        let bounds = prims.iter().map(|p| match &objects[p.object as usize] {
            // Unbounded shapes are not primitives.
            ObjectGeometry::Shape(s) => s.bounds().unwrap_or((Vec3::NAN, Vec3::NAN)),
            ObjectGeometry::Mesh(m) => m.bounds(p.tri),
        });
        let bvh = if small.is_some() { Bvh::build([]) } else { Bvh::build(bounds) };
        Geometry { objects, prims, unbounded, bvh, small }
    }

    /// The scene's primitives as a [`Small`] list, when they need at most
    /// [`LINEAR_MAX`] tests.
    fn small(objects: &Blocks<ObjectGeometry>, prims: &[Prim], unbounded: &[u32]) -> Option<Small> {
        if prims.len() > LINEAR_MAX * packed::LANES {
            return None;
        }
        let shape = |object: u32| match &objects[object as usize] {
            ObjectGeometry::Shape(s) => Some(s),
            ObjectGeometry::Mesh(_) => None,
        };
        let (groups, loose) = packed::pack(prims.iter().filter_map(|p| Some((p.object, shape(p.object)?))));
        let triangles = prims.iter().filter(|p| shape(p.object).is_none());
        let bounded: Vec<Prim> =
            loose.iter().map(|&object| Prim { object, tri: 0 }).chain(triangles.copied()).collect();
        if groups.len() + bounded.len() > LINEAR_MAX {
            return None;
        }
        let rest_bounded = bounded.len();
        let all = bounded.into_iter().chain(unbounded.iter().map(|&object| Prim { object, tri: 0 }));
        let rest = all
            .map(|prim| {
                let shape = shape(prim.object).cloned();
                let cull = shape.as_ref().and_then(Shape::cull);
                let test = shape.as_ref().map_or(Shape::intersect as Tester, Shape::tester);
                Linear { prim, shape, test, cull }
            })
            .collect();
        Some(Small { groups, rest, rest_bounded })
    }

    /// Whether rays test every primitive, without the BVH (a scene with
    /// few primitives, see [`LINEAR_MAX`]).
    pub fn tests_every_primitive(&self) -> bool {
        self.small.is_some()
    }

    /// Primitives in the BVH (shapes and triangles).
    pub fn primitive_count(&self) -> usize {
        self.prims.len()
    }

    /// [`Geometry::test`] of a primitive of the linear list; `inv_dir` is
    /// `ray.dir.recip()`.
    #[inline(always)]
    fn test_linear(&self, l: &Linear, ray: &Ray, inv_dir: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        if l.cull.is_some_and(|c| c.misses(ray, inv_dir, t_min, t_max)) {
            return None;
        }
        match &l.shape {
            Some(s) => (l.test)(s, ray, t_min, t_max),
            None => self.test(l.prim, ray, t_min, t_max),
        }
    }

    fn test(&self, prim: Prim, ray: &Ray, t_min: f32, t_max: f32) -> Option<f32> {
        match &self.objects[prim.object as usize] {
            ObjectGeometry::Shape(s) => s.intersect(ray, t_min, t_max),
            ObjectGeometry::Mesh(m) => m.intersect(prim.tri, ray, t_min, t_max).map(|h| h.0),
        }
    }

    /// The nearest hit with `t` in `(t_min, t_max)`.
    // Inline, so that the hit of a few primitives' loop stays in registers
    // (returned through memory, reading it back stalls).
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        let Some(small) = &self.small else { return self.intersect_bvh(ray, t_min, t_max) };
        let mut best: Option<Hit> = None;
        let mut t_max = t_max;
        for group in &small.groups {
            let (t, hit) = group.hits(ray, t_min, t_max);
            if hit.any() {
                // The nearest lane, the first of equals (as one by one).
                let t = Vec4::select(hit, t, Vec4::INFINITY);
                let nearest = t.min_element();
                let lane = t.cmpeq(Vec4::splat(nearest)).bitmask().trailing_zeros() as usize;
                best = Some(Hit { object: group.objects[lane], tri: 0, t: nearest });
                t_max = nearest;
            }
        }
        let inv_dir = ray.dir.recip();
        for l in &small.rest {
            if let Some(t) = self.test_linear(l, ray, inv_dir, t_min, t_max) {
                best = Some(Hit { object: l.prim.object, tri: l.prim.tri, t });
                t_max = t;
            }
        }
        best
    }

    #[inline(always)]
    fn intersect_bvh(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        let mut best = self
            .bvh
            .closest(ray, t_min, t_max, |id, ray, t_max| self.test(self.prims[id as usize], ray, t_min, t_max))
            .map(|(id, t)| {
                let p = self.prims[id as usize];
                Hit { object: p.object, tri: p.tri, t }
            });
        for &object in &self.unbounded {
            let t_max = best.map_or(t_max, |h| h.t);
            if let Some(t) = self.test(Prim { object, tri: 0 }, ray, t_min, t_max) {
                best = Some(Hit { object, tri: 0, t });
            }
        }
        best
    }

    /// True when something with `t` in `(t_min, t_max)` blocks the ray.
    /// `blocks` decides for each surface found (cutouts let rays through);
    /// it is called for surfaces in no particular order.
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32, mut blocks: impl FnMut(Hit) -> bool) -> bool {
        if let Some(small) = &self.small {
            // Unbounded shapes first, as with the BVH below.
            let (bounded, unbounded) = small.rest.split_at(small.rest_bounded);
            let inv_dir = ray.dir.recip();
            // Plain loops: a chain of iterators costs more than the tests.
            for l in unbounded {
                if let Some(t) = self.test_linear(l, ray, inv_dir, t_min, t_max)
                    && blocks(Hit { object: l.prim.object, tri: l.prim.tri, t })
                {
                    return true;
                }
            }
            for group in &small.groups {
                let (t, hit) = group.hits(ray, t_min, t_max);
                let mut lanes = hit.bitmask();
                while lanes != 0 {
                    let lane = lanes.trailing_zeros() as usize;
                    lanes &= lanes - 1;
                    if blocks(Hit { object: group.objects[lane], tri: 0, t: t[lane] }) {
                        return true;
                    }
                }
            }
            for l in bounded {
                if let Some(t) = self.test_linear(l, ray, inv_dir, t_min, t_max)
                    && blocks(Hit { object: l.prim.object, tri: l.prim.tri, t })
                {
                    return true;
                }
            }
            return false;
        }
        let mut check = |prim: Prim, t_max: f32| match self.test(prim, ray, t_min, t_max) {
            Some(t) => blocks(Hit { object: prim.object, tri: prim.tri, t }),
            None => false,
        };
        if self.unbounded.iter().any(|&object| check(Prim { object, tri: 0 }, t_max)) {
            return true;
        }
        self.bvh.any(ray, t_min, t_max, |id, _, t_max| check(self.prims[id as usize], t_max))
    }

    /// The surface record of a hit found by [`Geometry::intersect`]; `uv`
    /// asks for (u, v) and the tangents (see [`Shape::surface_at`]).
    pub fn surface(&self, ray: &Ray, hit: &Hit, uv: bool) -> SurfaceHit {
        match &self.objects[hit.object as usize] {
            ObjectGeometry::Shape(s) => s.surface_at(ray, hit.t, uv),
            ObjectGeometry::Mesh(m) => {
                // Recompute the barycentrics of the one triangle shaded.
                let (t, b1, b2) =
                    m.intersect(hit.tri, ray, 0.0, f32::INFINITY).unwrap_or((hit.t, 1.0 / 3.0, 1.0 / 3.0));
                m.surface(hit.tri, ray, t, b1, b2)
            }
        }
    }

    /// The scene's bounding sphere (centre, radius) over bounded
    /// primitives, for directional and environment lights.
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for (k, o) in self.objects.iter().enumerate() {
            let _ = k;
            match o {
                ObjectGeometry::Shape(s) => {
                    if let Some((a, b)) = s.bounds() {
                        lo = lo.min(a);
                        hi = hi.max(b);
                    }
                }
                ObjectGeometry::Mesh(m) => {
                    for p in &m.positions {
                        lo = lo.min(*p);
                        hi = hi.max(*p);
                    }
                }
            }
        }
        if lo.x > hi.x {
            return (Vec3::ZERO, 1.0);
        }
        ((lo + hi) * 0.5, ((hi - lo) * 0.5).length().max(1e-3))
    }
}
