//! The BVH: obvhs's compressed wide BVH (CWBVH, built by PLOC) over the
//! bounds of arbitrary primitives. Callers keep their primitives and test
//! them in callbacks; ids passed to callbacks are indices into the bounds
//! the BVH was built from.
//!
//! Invariant: primitives with non-finite or inverted bounds are left out
//! (they can never be hit); an empty BVH misses every ray.

use super::{Ray, Vec3};
use obvhs::aabb::Aabb;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh;
use obvhs::ploc::PlocBuilder;
use obvhs::ray::{Ray as BvhRay, RayHit};

pub struct Bvh {
    tree: Option<CwBvh>,
    /// BVH leaf order → the caller's primitive id.
    ids: Vec<u32>,
    len: usize,
}

struct Bounds(Aabb);

impl obvhs::Boundable for Bounds {
    fn aabb(&self) -> Aabb {
        self.0
    }
}

impl Bvh {
    /// Builds over `(min, max)` bounds; primitive `k` is the `k`th.
    pub fn build(bounds: impl IntoIterator<Item = (Vec3, Vec3)>) -> Bvh {
        let bounds = bounds.into_iter();
        let mut kept = Vec::with_capacity(bounds.size_hint().0);
        let mut ids = Vec::with_capacity(bounds.size_hint().0);
        for (k, (lo, hi)) in bounds.enumerate() {
            if lo.is_finite() && hi.is_finite() && lo.cmple(hi).all() {
                kept.push(Bounds(Aabb::new(lo, hi)));
                ids.push(k as u32);
            }
        }
        if kept.is_empty() {
            return Bvh { tree: None, ids, len: 0 };
        }
        // obvhs's `build_cwbvh` with `fast_build` (PLOC with a short search
        // and reinsertion; a million primitives in a fraction of a second
        // on two cores, tracing within a few percent of the slower
        // presets), written out to free the bounds before the conversion
        // to the wide BVH, the peak of a large scene's memory.
        let params = obvhs::BvhBuildParams::fast_build();
        let mut bvh2 = PlocBuilder::with_capacity(kept.len()).build(
            params.ploc_search_distance,
            &kept,
            (0..kept.len() as u32).collect(),
            params.sort_precision,
            params.search_depth_threshold,
        );
        let len = kept.len();
        drop(kept);
        ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None);
        let tree = bvh2_to_cwbvh(&bvh2, params.max_prims_per_leaf.clamp(1, 3), true, false);
        drop(bvh2);
        let ids = tree.primitive_indices.iter().map(|&i| ids[i as usize]).collect();
        Bvh { tree: Some(tree), ids, len }
    }

    /// Primitives in the BVH.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    fn bvh_ray(ray: &Ray, t_min: f32, t_max: f32) -> BvhRay {
        BvhRay::new(ray.origin, ray.dir, t_min, t_max)
    }

    /// The nearest primitive: `intersect(id, ray, t_max)` returns a hit `t`
    /// in `(t_min, t_max)` or `None`; `t_max` shrinks as hits are found.
    // Always inline, as `any`: the traversal belongs in the caller's loop
    // (out of line, cornell traced 6% more instructions).
    #[inline(always)]
    pub fn closest(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        mut intersect: impl FnMut(u32, &Ray, f32) -> Option<f32>,
    ) -> Option<(u32, f32)> {
        let tree = self.tree.as_ref()?;
        let mut hit = RayHit::none();
        let found = tree.ray_traverse(Self::bvh_ray(ray, t_min, t_max), &mut hit, |r, leaf| {
            let id = self.ids[leaf];
            intersect(id, ray, r.tmax).filter(|t| *t > t_min && *t < r.tmax).unwrap_or(f32::INFINITY)
        });
        found.then(|| (self.ids[hit.primitive_id as usize], hit.t))
    }

    /// True as soon as `occludes(id, ray, t_max)` says a primitive blocks
    /// the ray within `(t_min, t_max)`.
    #[inline(always)]
    pub fn any(&self, ray: &Ray, t_min: f32, t_max: f32, mut occludes: impl FnMut(u32, &Ray, f32) -> bool) -> bool {
        let Some(tree) = self.tree.as_ref() else { return false };
        !tree.ray_traverse_miss(Self::bvh_ray(ray, t_min, t_max), |r, leaf| {
            if occludes(self.ids[leaf], ray, r.tmax) { 0.0f32.max(t_min) } else { f32::INFINITY }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
        fn vec(&mut self, scale: f32) -> Vec3 {
            Vec3::new(self.next() - 0.5, self.next() - 0.5, self.next() - 0.5) * scale
        }
    }

    fn sphere_t(c: Vec3, r: f32, ray: &Ray, t_min: f32, t_max: f32) -> Option<f32> {
        let oc = ray.origin - c;
        let a = ray.dir.length_squared();
        let b = oc.dot(ray.dir);
        let disc = b * b - a * (oc.length_squared() - r * r);
        if disc < 0.0 {
            return None;
        }
        let s = disc.sqrt();
        [(-b - s) / a, (-b + s) / a].into_iter().find(|t| *t > t_min && *t < t_max)
    }

    #[test]
    fn agrees_with_brute_force() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let spheres: Vec<(Vec3, f32)> = (0..500).map(|_| (rng.vec(20.0), 0.1 + rng.next() * 0.6)).collect();
        let bounds: Vec<(Vec3, Vec3)> = spheres.iter().map(|(c, r)| (*c - *r, *c + *r)).collect();
        let bvh = Bvh::build(bounds);
        assert_eq!(bvh.len(), 500);
        let mut hits = 0;
        for k in 0..2000 {
            let ray = Ray::new(rng.vec(30.0), rng.vec(2.0));
            let (t_min, t_max) = if k % 3 == 0 { (0.5, 3.0) } else { (0.0, f32::INFINITY) };
            let brute = spheres
                .iter()
                .enumerate()
                .filter_map(|(i, (c, r))| sphere_t(*c, *r, &ray, t_min, t_max).map(|t| (i as u32, t)))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            let got = bvh.closest(&ray, t_min, t_max, |id, ray, tmax| {
                let (c, r) = spheres[id as usize];
                sphere_t(c, r, ray, t_min, tmax)
            });
            assert_eq!(got.map(|h| h.0), brute.map(|h| h.0), "ray {k}");
            if let (Some(a), Some(b)) = (got, brute) {
                assert_eq!(a.1, b.1);
                hits += 1;
            }
            let any = bvh.any(&ray, t_min, t_max, |id, ray, tmax| {
                let (c, r) = spheres[id as usize];
                sphere_t(c, r, ray, t_min, tmax).is_some()
            });
            assert_eq!(any, brute.is_some(), "ray {k}");
            // A callback that lets everything through ("holes") never occludes.
            assert!(!bvh.any(&ray, t_min, t_max, |_, _, _| false));
        }
        assert!(hits > 100, "{hits}");
    }

    #[test]
    fn holes_are_skipped_by_closest_hits() {
        // Two boxes on the z axis; the nearer one says "no hit".
        let bounds = [
            (Vec3::new(-1.0, -1.0, 1.0), Vec3::new(1.0, 1.0, 2.0)),
            (Vec3::new(-1.0, -1.0, 5.0), Vec3::new(1.0, 1.0, 6.0)),
        ];
        let bvh = Bvh::build(bounds);
        let ray = Ray::new(Vec3::ZERO, Vec3::Z);
        let got = bvh.closest(&ray, 0.0, f32::INFINITY, |id, _, _| (id == 1).then_some(5.0));
        assert_eq!(got, Some((1, 5.0)));
        let got = bvh.closest(&ray, 0.0, f32::INFINITY, |id, _, _| Some(if id == 0 { 1.0 } else { 5.0 }));
        assert_eq!(got, Some((0, 1.0)));
        assert!(!bvh.any(&ray, 0.0, 4.0, |id, _, _| id == 1), "t_max stops before the far box");
    }

    #[test]
    fn empty_single_and_bad_bounds() {
        let ray = Ray::new(Vec3::ZERO, Vec3::Z);
        let empty = Bvh::build([]);
        assert!(empty.is_empty());
        assert_eq!(empty.closest(&ray, 0.0, f32::INFINITY, |_, _, _| Some(1.0)), None);
        assert!(!empty.any(&ray, 0.0, f32::INFINITY, |_, _, _| true));
        let one = Bvh::build([(Vec3::splat(-1.0), Vec3::splat(1.0))]);
        assert_eq!(one.closest(&ray, 0.0, f32::INFINITY, |_, _, _| Some(1.0)), Some((0, 1.0)));
        let bad = Bvh::build([
            (Vec3::splat(f32::NAN), Vec3::ONE),
            (Vec3::ONE, Vec3::ZERO),
            (Vec3::splat(-1.0), Vec3::splat(1.0)),
        ]);
        assert_eq!(bad.len(), 1);
        assert_eq!(bad.closest(&ray, 0.0, f32::INFINITY, |id, _, _| Some(id as f32)), Some((2, 2.0)));
    }
}
