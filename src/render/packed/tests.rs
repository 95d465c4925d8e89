use super::*;
use crate::render::Mat4;
use crate::render::geometry::{Blocks, Geometry, ObjectGeometry};
use glam::Quat;

/// Numbers in [0, 1) from a fixed seed (xorshift64).
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

    fn pick(&mut self, n: usize) -> usize {
        ((self.next() * n as f32) as usize).min(n - 1)
    }
}

/// A quad, sphere or box, untransformed or under a random affine map.
fn random_shape(rng: &mut Rng) -> Shape {
    let kind = match rng.pick(3) {
        0 => ShapeKind::Quad { corner: rng.vec(4.0), edge1: rng.vec(3.0), edge2: rng.vec(3.0) },
        1 => ShapeKind::Sphere { center: rng.vec(4.0), radius: 0.1 + rng.next() },
        _ => {
            let (c, e) = (rng.vec(4.0), rng.vec(2.0).abs() + Vec3::splat(0.05));
            ShapeKind::Box { min: c - e, max: c + e }
        }
    };
    let to_world = if rng.next() < 0.5 {
        Mat4::IDENTITY
    } else {
        let axis = rng.vec(1.0).normalize_or(Vec3::Y);
        Mat4::from_scale_rotation_translation(
            (rng.vec(1.0).abs() + Vec3::splat(0.3)).into(),
            Quat::from_axis_angle(axis.into(), rng.next() * 6.0),
            rng.vec(2.0).into(),
        )
    };
    Shape::new(kind, to_world).expect("a valid shape")
}

/// Rays of every sort: random, axis-parallel (zero direction components),
/// from inside the scene, and aimed at a shape's corners and edges, where
/// tests graze.
fn random_ray(rng: &mut Rng, shapes: &[Shape]) -> Ray {
    let spread = if rng.next() < 0.3 { 2.0 } else { 16.0 };
    let origin = rng.vec(spread);
    let dir = match rng.pick(5) {
        0 => [Vec3::X, Vec3::NEG_Y, Vec3::Z, Vec3::new(1.0, 1.0, 0.0)][rng.pick(4)],
        1 => {
            // Through a corner of some shape's bounds.
            let (lo, hi) = shapes[rng.pick(shapes.len())].bounds().unwrap();
            let corner = Vec3::select(rng.vec(1.0).cmpgt(Vec3::ZERO), lo, hi);
            corner - origin
        }
        2 => match *shapes[rng.pick(shapes.len())].kind() {
            // Along a quad's edge or at its far corner.
            ShapeKind::Quad { corner, edge1, edge2 } => {
                corner + edge1 * rng.next() + edge2 * rng.pick(2) as f32 - origin
            }
            _ => rng.vec(2.0),
        },
        3 => {
            // Parallel to a face and starting in its plane: the slabs'
            // 0 * inf, a NaN that the scalar test's f32::max passes over.
            let (lo, hi) = shapes[rng.pick(shapes.len())].bounds().unwrap();
            let axis = rng.pick(3);
            let mut origin = origin;
            origin[axis] = if rng.next() < 0.5 { lo[axis] } else { hi[axis] };
            if let ShapeKind::Box { min, max } = *shapes[rng.pick(shapes.len())].kind() {
                origin[axis] = if rng.next() < 0.5 { min[axis] } else { max[axis] };
            }
            let mut dir = rng.vec(2.0);
            dir[axis] = 0.0;
            return Ray::new(origin, dir);
        }
        _ => rng.vec(2.0),
    };
    Ray::new(origin, dir)
}

/// Whether a group's lane agrees with the scalar test: bit for bit on
/// x86-64 (the same SSE operations), within rounding elsewhere.
fn agrees(packed: Option<f32>, scalar: Option<f32>) -> bool {
    match (packed, scalar) {
        (Some(a), Some(b)) if cfg!(target_arch = "x86_64") => a.to_bits() == b.to_bits(),
        (Some(a), Some(b)) => (a - b).abs() <= 1e-5 * (1.0 + b.abs()),
        (a, b) => a.is_none() == b.is_none(),
    }
}

#[test]
fn groups_match_the_scalar_test_lane_by_lane() {
    let mut rng = Rng(0x2545_f491_4f6c_dd1d);
    let (mut hits, mut misses, mut tests) = (0, 0, 0);
    for _scene in 0..40 {
        let shapes: Vec<Shape> = (0..1 + rng.pick(12)).map(|_| random_shape(&mut rng)).collect();
        let (mut groups, rest) = pack(shapes.iter().enumerate().map(|(k, s)| (k as u32, s)));
        let packed: usize = groups.iter().map(|g| g.live.bitmask().count_ones() as usize).sum();
        assert_eq!(packed + rest.len(), shapes.len());
        // Shapes alone in a group are packed too, to be tested here.
        groups.extend(rest.iter().map(|&k| Group::new(&[(k, &shapes[k as usize])])));
        for _ in 0..400 {
            let ray = random_ray(&mut rng, &shapes);
            let (t_min, t_max) = match rng.pick(4) {
                0 => (0.0, f32::INFINITY),
                1 => (rng.next(), 1.0 + rng.next() * 20.0),
                // Bounds at a hit: both are open.
                _ => {
                    let s = &shapes[rng.pick(shapes.len())];
                    let t = s.intersect(&ray, 0.0, f32::INFINITY).unwrap_or(1.0);
                    if rng.next() < 0.5 { (0.0, t) } else { (t, f32::INFINITY) }
                }
            };
            for group in &groups {
                let (t, hit) = group.hits(&ray, t_min, t_max);
                let hit = hit.bitmask();
                for (lane, &object) in group.objects.iter().enumerate() {
                    if group.live.bitmask() & (1 << lane) == 0 {
                        assert_eq!(hit & (1 << lane), 0, "a padding lane never hits");
                        continue;
                    }
                    let scalar = shapes[object as usize].intersect(&ray, t_min, t_max);
                    let packed = (hit & (1 << lane) != 0).then_some(t[lane]);
                    assert!(
                        agrees(packed, scalar),
                        "{:?} {ray:?} ({t_min}, {t_max}): packed {packed:?}, scalar {scalar:?}",
                        shapes[object as usize]
                    );
                    tests += 1;
                    if scalar.is_some() { hits += 1 } else { misses += 1 }
                }
            }
        }
    }
    assert!(hits > 2_000 && misses > 50_000, "{hits} hits, {misses} misses of {tests}");
}

#[test]
fn shapes_are_grouped_by_kind_and_placement() {
    let quad = |x: f32| ShapeKind::Quad { corner: Vec3::new(x, 0.0, 0.0), edge1: Vec3::X, edge2: Vec3::Y };
    let moved = Mat4::from_translation(glam::Vec3::Z);
    let disk = ShapeKind::Disk { center: Vec3::ZERO, normal: Vec3::Y, radius: 1.0 };
    let shapes: Vec<Shape> = [
        (quad(0.0), Mat4::IDENTITY),
        (disk, Mat4::IDENTITY),
        (quad(1.0), moved),
        (quad(2.0), Mat4::IDENTITY),
        (ShapeKind::Sphere { center: Vec3::ZERO, radius: 1.0 }, Mat4::IDENTITY),
        (quad(3.0), Mat4::IDENTITY),
        (quad(4.0), Mat4::IDENTITY),
        (quad(5.0), Mat4::IDENTITY),
    ]
    .into_iter()
    .map(|(kind, m)| Shape::new(kind, m).unwrap())
    .collect();
    let (groups, rest) = pack(shapes.iter().enumerate().map(|(k, s)| (k as u32, s)));
    // Disks are tested one by one, and so is a shape alone in its group:
    // the fifth untransformed quad, the moved quad and the sphere.
    assert_eq!(rest, vec![1, 7, 2, 4]);
    let lanes: Vec<(u32, [u32; LANES])> = groups.iter().map(|g| (g.live.bitmask(), g.objects)).collect();
    assert_eq!(lanes, vec![(0b1111, [0, 3, 5, 6])]);
    let (groups, rest) = pack(shapes[..4].iter().enumerate().map(|(k, s)| (k as u32, s)));
    assert_eq!(rest, vec![1, 2]);
    let lanes: Vec<(u32, [u32; LANES])> = groups.iter().map(|g| (g.live.bitmask(), g.objects)).collect();
    assert_eq!(lanes, vec![(0b0011, [0, 3, 3, 3])], "padding repeats the last shape");
}

/// A small scene through [`Geometry`] (groups and one-by-one tests
/// together) finds what testing every shape finds.
#[test]
fn small_scenes_find_the_nearest_hit_and_every_blocker() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let (mut hits, mut small) = (0, 0);
    for _scene in 0..30 {
        let mut shapes: Vec<Shape> = (0..1 + rng.pick(8)).map(|_| random_shape(&mut rng)).collect();
        // Shapes tested one by one beside the groups.
        if rng.next() < 0.5 {
            let disk = ShapeKind::Disk { center: rng.vec(4.0), normal: rng.vec(1.0), radius: 1.0 };
            shapes.push(Shape::new(disk, Mat4::IDENTITY).unwrap());
        }
        if rng.next() < 0.5 {
            let plane = ShapeKind::Plane { point: rng.vec(8.0), normal: Vec3::Y, tile: 1.0 };
            shapes.push(Shape::new(plane, Mat4::IDENTITY).unwrap());
        }
        let mut objects = Blocks::default();
        for s in &shapes {
            objects.push(ObjectGeometry::Shape(s.clone()));
        }
        let geometry = Geometry::new(objects);
        small += geometry.tests_every_primitive() as usize;
        for _ in 0..300 {
            let ray = random_ray(&mut rng, &shapes[..1]);
            let t_max = if rng.next() < 0.5 { f32::INFINITY } else { rng.next() * 20.0 };
            let all: Vec<(u32, f32)> = shapes
                .iter()
                .enumerate()
                .filter_map(|(k, s)| Some((k as u32, s.intersect(&ray, 0.0, t_max)?)))
                .collect();
            let nearest = all.iter().map(|h| h.1).reduce(f32::min);
            let got = geometry.intersect(&ray, 0.0, t_max);
            assert!(agrees(got.map(|h| h.t), nearest), "{ray:?}: {got:?}, {all:?}");
            if let Some(hit) = got {
                assert!(all.iter().any(|&(k, t)| k == hit.object && agrees(Some(hit.t), Some(t))), "{hit:?} {all:?}");
                hits += 1;
            }
            // `occluded` offers every blocker when none blocks.
            let mut offered = Vec::new();
            let blocked = geometry.occluded(&ray, 0.0, t_max, |h| {
                offered.push(h.object);
                false
            });
            offered.sort_unstable();
            assert!(!blocked);
            assert_eq!(offered, all.iter().map(|h| h.0).collect::<Vec<_>>(), "{ray:?}");
            assert_eq!(geometry.occluded(&ray, 0.0, t_max, |_| true), !all.is_empty());
        }
    }
    assert!(hits > 1000, "{hits}");
    assert!((10..30).contains(&small), "{small} of 30 scenes without the BVH");
}
