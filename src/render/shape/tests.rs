use super::*;

/// Numbers in [0, 1) from a fixed seed (xorshift64).
fn uniform(mut state: u64) -> impl FnMut() -> f32 {
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn shape(kind: ShapeKind) -> Shape {
    Shape::new(kind, Mat4::IDENTITY).unwrap()
}

fn hit(s: &Shape, o: Vec3, d: Vec3) -> Option<SurfaceHit> {
    let r = Ray::new(o, d);
    s.intersect(&r, 1e-4, f32::INFINITY).map(|t| s.surface(&r, t))
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-4 * (1.0 + b.length())
}

/// dPdu x dPdv along the outward normal, and the normal unit length.
fn consistent(h: &SurfaceHit) {
    assert!((h.ng.length() - 1.0).abs() < 1e-4, "{h:?}");
    assert!(h.dpdu.cross(h.dpdv).dot(h.ng) > 0.0, "{h:?}");
    assert!((0.0..=1.0).contains(&h.u) || h.face >= 0, "{h:?}");
}

#[test]
fn sphere_from_outside_inside_tangent_and_missing() {
    let s = shape(ShapeKind::Sphere { center: Vec3::new(0.0, 1.0, 0.0), radius: 1.0 });
    let h = hit(&s, Vec3::new(0.0, 1.0, 5.0), Vec3::NEG_Z).unwrap();
    assert!((h.t - 4.0).abs() < 1e-5 && close(h.ng, Vec3::Z) && close(h.pl, Vec3::Z));
    consistent(&h);
    // From the centre outward: the far side, normal still outward.
    let h = hit(&s, Vec3::new(0.0, 1.0, 0.0), Vec3::X).unwrap();
    assert!((h.t - 1.0).abs() < 1e-5 && close(h.ng, Vec3::X));
    assert_eq!(h.u, 0.0);
    assert!((h.v - 0.5).abs() < 1e-5);
    assert!(hit(&s, Vec3::new(0.0, 3.0, 5.0), Vec3::NEG_Z).is_none(), "passes above");
    let grazing = hit(&s, Vec3::new(1.0, 1.0, 5.0), Vec3::NEG_Z);
    assert!(grazing.is_none_or(|h| (h.p.x - 1.0).abs() < 1e-3));
    // Poles: v = 0 at the bottom, 1 at the top, tangents still valid.
    let top = hit(&s, Vec3::new(0.0, 5.0, 0.0), Vec3::NEG_Y).unwrap();
    assert!((top.v - 1.0).abs() < 1e-5);
    consistent(&top);
    let bottom = hit(&s, Vec3::new(0.0, -5.0, 0.0), Vec3::Y).unwrap();
    assert!(bottom.v.abs() < 1e-5);
    // u grows from +x toward -z.
    let a = hit(&s, Vec3::new(5.0, 1.0, -0.1), Vec3::NEG_X).unwrap();
    assert!(a.u > 0.0 && a.u < 0.05, "{}", a.u);
}

#[test]
fn random_rays_hit_the_surface_they_report() {
    let mut next = uniform(0x1234_5678_9abc_def0);
    let m = Mat4::from_translation(glam::Vec3::new(0.5, -0.2, 0.3))
        * Mat4::from_rotation_y(0.7)
        * Mat4::from_rotation_x(-0.4)
        * Mat4::from_scale(glam::Vec3::new(1.5, 0.7, 1.2));
    let kinds = [
        ShapeKind::Sphere { center: Vec3::new(0.1, 0.2, -0.3), radius: 0.8 },
        ShapeKind::Quad {
            corner: Vec3::new(-1.0, 0.0, -1.0),
            edge1: Vec3::new(2.0, 0.2, 0.0),
            edge2: Vec3::new(0.0, 0.3, 2.0),
        },
        ShapeKind::Disk { center: Vec3::ZERO, normal: Vec3::new(0.3, 1.0, 0.2), radius: 1.0 },
        ShapeKind::Box { min: Vec3::new(-1.0, -0.5, -0.7), max: Vec3::new(0.8, 0.5, 0.9) },
        ShapeKind::Cylinder {
            base: Vec3::new(0.0, -0.5, 0.0),
            axis: Vec3::new(0.2, 1.0, 0.1),
            radius: 0.6,
            height: 1.2,
        },
        ShapeKind::Plane { point: Vec3::ZERO, normal: Vec3::new(0.1, 1.0, -0.2), tile: 0.5 },
    ];
    for kind in kinds {
        for transform in [Mat4::IDENTITY, m] {
            let s = Shape::new(kind, transform).unwrap();
            let bounds = s.bounds();
            assert_eq!(bounds.is_some(), s.is_bounded(), "{kind:?}");
            let mut hits = 0;
            for _ in 0..2000 {
                let o = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 8.0;
                let target = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 2.0;
                let r = Ray::new(o, target - o);
                let Some(t) = s.intersect(&r, 1e-4, f32::INFINITY) else { continue };
                hits += 1;
                let h = s.surface(&r, t);
                assert!(h.p.is_finite() && h.ng.is_finite() && h.dpdu.is_finite() && h.u.is_finite());
                consistent(&h);
                // The point is on the shape: a ray from just off the
                // surface along the normal, backward, hits it again.
                let back = Ray::new(h.p + h.ng * 1e-2, -h.ng);
                let tb = s.intersect(&back, 0.0, 1.0).expect("the reported point is on the surface");
                assert!((tb - 1e-2).abs() < 2e-3, "{kind:?}: {tb}");
                if let Some((lo, hi)) = bounds {
                    assert!(h.p.cmpge(lo - 1e-3).all() && h.p.cmple(hi + 1e-3).all(), "{kind:?} outside bounds");
                }
                // Pl maps back to P.
                let anchor = match kind {
                    ShapeKind::Sphere { center, .. } | ShapeKind::Disk { center, .. } => center,
                    ShapeKind::Quad { corner, .. } => corner,
                    ShapeKind::Plane { point, .. } => point,
                    ShapeKind::Cylinder { base, .. } => base,
                    ShapeKind::Box { .. } => Vec3::ZERO,
                };
                assert!(close(transform.transform_point3a(h.pl + anchor), h.p), "{kind:?}");
            }
            assert!(hits > 50, "{kind:?}: only {hits} hits");
        }
    }
}

/// `Shape::tester` gives `Shape::intersect`'s bits, and `Cull` never
/// rejects a ray that hits: for every kind, untransformed and under
/// rotations, a badly conditioned scale and a far translation, with
/// rays from far away, parallel to the axes, and grazing the shape.
#[test]
fn specialised_tests_and_culls_agree_with_intersect() {
    let mut next = uniform(0x9e37_79b9_7f4a_7c15);
    let transforms = [
        Mat4::IDENTITY,
        Mat4::from_rotation_y(30f32.to_radians()),
        Mat4::from_translation(glam::Vec3::new(0.5, -0.2, 0.3))
            * Mat4::from_rotation_y(0.7)
            * Mat4::from_rotation_x(-0.4)
            * Mat4::from_scale(glam::Vec3::new(1.5, 0.7, 1.2)),
        Mat4::from_rotation_z(0.3) * Mat4::from_scale(glam::Vec3::new(1.0, 0.01, 1.0)),
        Mat4::from_translation(glam::Vec3::new(1000.0, -300.0, 20.0)) * Mat4::from_rotation_x(1.1),
    ];
    let kinds = [
        ShapeKind::Sphere { center: Vec3::new(0.1, 0.2, -0.3), radius: 0.8 },
        ShapeKind::Quad { corner: Vec3::new(-1.0, 0.0, -1.0), edge1: Vec3::X * 2.0, edge2: Vec3::Z * 2.0 },
        ShapeKind::Disk { center: Vec3::ZERO, normal: Vec3::new(0.3, 1.0, 0.2).normalize(), radius: 1.0 },
        ShapeKind::Box { min: Vec3::new(-2.5, 0.0, -0.5), max: Vec3::new(-0.5, 2.0, 1.5) },
        ShapeKind::Cylinder { base: Vec3::new(0.0, -0.5, 0.0), axis: Vec3::Y, radius: 0.6, height: 1.2 },
        ShapeKind::Plane { point: Vec3::ZERO, normal: Vec3::Y, tile: 0.5 },
    ];
    for kind in kinds {
        for transform in transforms {
            let s = Shape::new(kind, transform).unwrap();
            let test = s.tester();
            let cull = s.cull();
            assert_eq!(
                cull.is_some(),
                s.is_bounded() && (transform != Mat4::IDENTITY || matches!(kind_number(&kind), 2 | 3 | 5))
            );
            let (mut hits, mut culled) = (0, 0);
            for k in 0..20000 {
                // A point on the surface, nudged by a hair or more.
                let nudge = [0.0, 1e-7, 1e-5, 1e-3, 0.1][k % 5];
                let on = s.sample_area([next(), next()]);
                let target = on + (Vec3::new(next(), next(), next()) - 0.5) * nudge * (1.0 + on.abs().max_element());
                let far = if k % 7 == 0 { 1000.0 } else { 1.0 };
                let mut o = on + (Vec3::new(next(), next(), next()) - 0.5) * 8.0 * far;
                // Now and then parallel to one or two axes.
                if k % 3 == 0 {
                    o.x = target.x;
                }
                if k % 9 == 0 {
                    o.z = target.z;
                }
                let r = Ray::new(o, target - o);
                let t_min = if k % 2 == 0 { 0.0 } else { 1e-4 };
                let t_max = if k % 4 < 2 { f32::INFINITY } else { 0.5 + next() };
                let exact = s.intersect(&r, t_min, t_max);
                assert_eq!(
                    test(&s, &r, t_min, t_max).map(f32::to_bits),
                    exact.map(f32::to_bits),
                    "{kind:?} {transform:?} {r:?}"
                );
                hits += exact.is_some() as u32;
                if cull.is_some_and(|c| c.misses(&r, r.dir.recip(), t_min, t_max)) {
                    culled += 1;
                    assert_eq!(exact, None, "{kind:?} {transform:?} culled {r:?} {t_min} {t_max}");
                }
            }
            assert!(hits > 2000, "{kind:?}: {hits} hits");
            assert!(cull.is_none() || culled > 200, "{kind:?}: {culled} culled");
        }
    }
}

/// A plain plane's short cut in `surface_at` gives the general path's
/// record, bit for bit.
#[test]
fn plain_planes_give_the_general_record() {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let normals = [Vec3::Y, Vec3::NEG_Z, Vec3::X, Vec3::new(0.1, 1.0, -0.2).normalize(), Vec3::new(-0.0, 1.0, 0.0)];
    let mut plain = 0;
    for normal in normals {
        for tile in [1.0, 0.37, 4.0] {
            let s = shape(ShapeKind::Plane { point: Vec3::new(0.3, -0.2, 0.1), normal, tile });
            plain += s.plain_plane as u32;
            let general = Shape { plain_plane: false, ..s.clone() };
            for k in 0..500 {
                let o = (Vec3::new(next(), next(), next()) - 0.5) * 20.0;
                let r = Ray::new(o, Vec3::new(next(), next(), next()) - 0.5);
                let Some(t) = s.intersect(&r, 1e-4, f32::INFINITY) else { continue };
                let uv = k % 2 == 0;
                let (a, b) = (s.surface_at(&r, t, uv), general.surface_at(&r, t, uv));
                assert_eq!(format!("{a:?}"), format!("{b:?}"));
            }
        }
    }
    assert!(plain >= 9, "{plain} plain planes");
}

/// Without `uv` a record leaves out only what `surface_at` says it may:
/// position, normals and face are the full record's bits (a sphere's normal
/// within an ulp), for every kind
/// under several transforms; and the normals that quads and boxes keep per
/// face are those of their world tangents.
#[test]
fn records_without_uv_keep_the_geometry() {
    let mut next = uniform(0x51_7cc1_b727_220a);
    let transforms = [
        Mat4::IDENTITY,
        Mat4::from_rotation_y(-17f32.to_radians()) * Mat4::from_scale(glam::Vec3::new(0.3, 0.61, 0.3)),
        Mat4::from_translation(glam::Vec3::new(0.5, -0.2, 0.3))
            * Mat4::from_rotation_y(0.7)
            * Mat4::from_rotation_x(-0.4)
            * Mat4::from_scale(glam::Vec3::new(1.5, 0.7, 1.2)),
    ];
    let kinds = [
        ShapeKind::Sphere { center: Vec3::new(0.1, 0.2, -0.3), radius: 0.8 },
        ShapeKind::Quad { corner: Vec3::new(-1.0, 0.0, -1.0), edge1: Vec3::new(2.0, 0.1, 0.0), edge2: Vec3::Z * 2.0 },
        ShapeKind::Disk { center: Vec3::ZERO, normal: Vec3::new(0.3, 1.0, 0.2).normalize(), radius: 1.0 },
        ShapeKind::Box { min: Vec3::new(-2.5, 0.0, -0.5), max: Vec3::new(-0.5, 2.0, 1.5) },
        ShapeKind::Cylinder { base: Vec3::new(0.0, -0.5, 0.0), axis: Vec3::Y, radius: 0.6, height: 1.2 },
        ShapeKind::Plane { point: Vec3::ZERO, normal: Vec3::Y, tile: 0.5 },
    ];
    let bits = |v: Vec3| v.to_array().map(f32::to_bits);
    for kind in kinds {
        for transform in transforms {
            let s = Shape::new(kind, transform).unwrap();
            let mut faces = [false; 6];
            for _ in 0..2000 {
                let on = s.sample_area([next(), next()]);
                let o = on + (Vec3::new(next(), next(), next()) - 0.5) * 8.0;
                let r = Ray::new(o, on - o);
                let Some(t) = s.intersect(&r, 1e-4, f32::INFINITY) else { continue };
                let (full, lean) = (s.surface_at(&r, t, true), s.surface_at(&r, t, false));
                assert_eq!(
                    (full.t.to_bits(), bits(full.p), bits(full.pl)),
                    (lean.t.to_bits(), bits(lean.p), bits(lean.pl))
                );
                if let ShapeKind::Sphere { .. } = kind {
                    // Its lean normal normalises the centre offset itself
                    // rather than divided by the radius: an ulp apart.
                    assert!(close(full.ng, lean.ng) && full.face == lean.face, "{full:?} {lean:?}");
                } else {
                    assert_eq!(
                        (bits(full.ng), bits(full.n), full.face),
                        (bits(lean.ng), bits(lean.n), lean.face),
                        "{kind:?}"
                    );
                }
                if matches!(kind, ShapeKind::Quad { .. } | ShapeKind::Box { .. }) {
                    faces[full.face as usize] = true;
                    assert!(close(full.ng, full.dpdu.cross(full.dpdv).normalize()), "{kind:?} {full:?}");
                }
            }
            let expected = match kind {
                ShapeKind::Box { .. } => 6,
                ShapeKind::Quad { .. } => 1,
                _ => 0,
            };
            assert_eq!(faces.iter().filter(|f| **f).count(), expected, "{kind:?}");
        }
    }
}

#[test]
fn box_faces_are_numbered_and_facing_out() {
    let s = shape(ShapeKind::Box { min: Vec3::splat(-1.0), max: Vec3::splat(1.0) });
    let cases = [
        (Vec3::new(-5.0, 0.1, 0.2), Vec3::X, 0, Vec3::NEG_X),
        (Vec3::new(5.0, 0.1, 0.2), Vec3::NEG_X, 1, Vec3::X),
        (Vec3::new(0.1, -5.0, 0.2), Vec3::Y, 2, Vec3::NEG_Y),
        (Vec3::new(0.1, 5.0, 0.2), Vec3::NEG_Y, 3, Vec3::Y),
        (Vec3::new(0.1, 0.2, -5.0), Vec3::Z, 4, Vec3::NEG_Z),
        (Vec3::new(0.1, 0.2, 5.0), Vec3::NEG_Z, 5, Vec3::Z),
    ];
    for (o, d, face, n) in cases {
        let h = hit(&s, o, d).unwrap();
        assert_eq!(h.face, face);
        assert!(close(h.ng, n));
        assert!((h.t - 4.0).abs() < 1e-5);
        consistent(&h);
    }
    // From inside: the exit face.
    let h = hit(&s, Vec3::ZERO, Vec3::Y).unwrap();
    assert_eq!(h.face, 3);
    // Seen from +z, u grows to the right (+x) and v upward (+y).
    let a = hit(&s, Vec3::new(-0.5, -0.5, 5.0), Vec3::NEG_Z).unwrap();
    let b = hit(&s, Vec3::new(0.5, 0.5, 5.0), Vec3::NEG_Z).unwrap();
    assert!(b.u > a.u && b.v > a.v);
    // Scaled and rotated.
    let m = Mat4::from_rotation_y(0.5) * Mat4::from_scale(glam::Vec3::splat(2.0));
    let t = Shape::new(ShapeKind::Box { min: Vec3::splat(-1.0), max: Vec3::splat(1.0) }, m).unwrap();
    let h = hit(&t, Vec3::new(0.0, 10.0, 0.0), Vec3::NEG_Y).unwrap();
    assert!((h.t - 8.0).abs() < 1e-4 && close(h.ng, Vec3::Y) && close(h.pl, Vec3::new(0.0, 1.0, 0.0)));
}

#[test]
fn planes_quads_and_disks() {
    let p = shape(ShapeKind::Plane { point: Vec3::ZERO, normal: Vec3::Y, tile: 2.0 });
    assert!(hit(&p, Vec3::new(0.0, 1.0, 0.0), Vec3::X).is_none(), "parallel");
    let h = hit(&p, Vec3::new(3.0, 1.0, -4.0), Vec3::NEG_Y).unwrap();
    assert!((h.u - 1.5).abs() < 1e-5 && (h.v - 2.0).abs() < 1e-5, "u along +x, v along -z, per tile");
    assert!(p.bounds().is_none() && !p.is_bounded());
    let q = shape(ShapeKind::Quad {
        corner: Vec3::new(-1.0, 0.0, 1.0),
        edge1: Vec3::new(2.0, 0.0, 0.0),
        edge2: Vec3::new(0.0, 0.0, -2.0),
    });
    let h = hit(&q, Vec3::new(0.5, 1.0, 0.0), Vec3::NEG_Y).unwrap();
    assert!(close(h.ng, Vec3::Y) && (h.u - 0.75).abs() < 1e-5 && (h.v - 0.5).abs() < 1e-5);
    assert!(hit(&q, Vec3::new(1.5, 1.0, 0.0), Vec3::NEG_Y).is_none(), "outside");
    assert!((q.area() - 4.0).abs() < 1e-5);
    let d = shape(ShapeKind::Disk { center: Vec3::ZERO, normal: Vec3::Z, radius: 1.0 });
    assert!(hit(&d, Vec3::new(0.9, 0.0, 1.0), Vec3::NEG_Z).is_some());
    assert!(hit(&d, Vec3::new(0.8, 0.8, 1.0), Vec3::NEG_Z).is_none());
    assert!(hit(&d, Vec3::new(0.0, 0.0, 1.0), Vec3::X).is_none(), "parallel");
    let centre = hit(&d, Vec3::new(0.0, 0.0, 1.0), Vec3::NEG_Z).unwrap();
    assert!((centre.v - 1.0).abs() < 1e-5);
    consistent(&centre);
    assert!((d.area() - PI).abs() < 1e-5);
}

#[test]
fn cylinder_side_and_caps() {
    let c = shape(ShapeKind::Cylinder { base: Vec3::ZERO, axis: Vec3::Y, radius: 1.0, height: 2.0 });
    let side = hit(&c, Vec3::new(5.0, 1.0, 0.0), Vec3::NEG_X).unwrap();
    assert!((side.t - 4.0).abs() < 1e-5 && side.face == 0 && close(side.ng, Vec3::X) && (side.v - 0.5).abs() < 1e-5);
    let top = hit(&c, Vec3::new(0.3, 5.0, 0.2), Vec3::NEG_Y).unwrap();
    assert!(top.face == 2 && close(top.ng, Vec3::Y) && (top.t - 3.0).abs() < 1e-5);
    let bottom = hit(&c, Vec3::new(0.3, -5.0, 0.2), Vec3::Y).unwrap();
    assert!(bottom.face == 1 && close(bottom.ng, Vec3::NEG_Y));
    for h in [side, top, bottom] {
        consistent(&h);
    }
    assert!(hit(&c, Vec3::new(5.0, 2.5, 0.0), Vec3::NEG_X).is_none(), "above the top");
    let inside = hit(&c, Vec3::new(0.0, 1.0, 0.0), Vec3::Z).unwrap();
    assert!((inside.t - 1.0).abs() < 1e-5);
}

#[test]
fn degenerate_shapes_are_errors() {
    let e = |k: ShapeKind| Shape::new(k, Mat4::IDENTITY).unwrap_err();
    assert!(e(ShapeKind::Sphere { center: Vec3::ZERO, radius: 0.0 }).contains("positive"));
    assert!(e(ShapeKind::Sphere { center: Vec3::new(f32::NAN, 0.0, 0.0), radius: 1.0 }).contains("finite"));
    assert!(e(ShapeKind::Plane { point: Vec3::ZERO, normal: Vec3::ZERO, tile: 1.0 }).contains("zero"));
    assert!(e(ShapeKind::Quad { corner: Vec3::ZERO, edge1: Vec3::X, edge2: Vec3::X * 2.0 }).contains("parallel"));
    assert!(e(ShapeKind::Box { min: Vec3::ONE, max: Vec3::ZERO }).contains("exceed"));
    assert!(e(ShapeKind::Cylinder { base: Vec3::ZERO, axis: Vec3::Y, radius: 1.0, height: -1.0 }).contains("positive"));
    let singular = Shape::new(
        ShapeKind::Sphere { center: Vec3::ZERO, radius: 1.0 },
        Mat4::from_scale(glam::Vec3::new(1.0, 0.0, 1.0)),
    );
    assert!(singular.unwrap_err().contains("singular"));
}

#[test]
fn area_sampling_lands_on_the_shape() {
    let m = Mat4::from_translation(glam::Vec3::new(1.0, 2.0, 3.0))
        * Mat4::from_rotation_z(0.3)
        * Mat4::from_scale(glam::Vec3::splat(2.0));
    let sphere = Shape::new(ShapeKind::Sphere { center: Vec3::ZERO, radius: 0.5 }, m).unwrap();
    assert!((sphere.area() - 4.0 * PI).abs() < 1e-4);
    let quad = Shape::new(ShapeKind::Quad { corner: Vec3::ZERO, edge1: Vec3::X, edge2: Vec3::Y }, m).unwrap();
    assert!((quad.area() - 4.0).abs() < 1e-4);
    // Boxes and cylinders: every sample on the surface, and the faces
    // hit in proportion to their areas.
    let boxy = Shape::new(ShapeKind::Box { min: Vec3::ZERO, max: Vec3::new(1.0, 2.0, 3.0) }, m).unwrap();
    let cyl = Shape::new(ShapeKind::Cylinder { base: Vec3::ZERO, axis: Vec3::Y, radius: 1.0, height: 2.0 }, m).unwrap();
    let mut faces = [0usize; 6];
    let mut cyl_faces = [0usize; 3];
    let n = 100;
    for i in 0..n {
        for j in 0..n {
            let u = sampling::Sampler::new(1, i, j, 0).next_2d();
            for (s, counts) in [(&boxy, &mut faces[..]), (&cyl, &mut cyl_faces[..])] {
                let p = s.sample_area(u);
                let c = s.bounds().map(|(lo, hi)| (lo + hi) * 0.5).unwrap();
                let r = Ray::new(c + (p - c) * 3.0, (c - p) * 3.0);
                let t = s.intersect(&r, 0.0, 1.0).expect("the sample is on the surface");
                let h = s.surface(&r, t);
                assert!((h.p - p).length() < 1e-3 * (1.0 + p.length()), "{p} vs {}", h.p);
                counts[h.face as usize] += 1;
            }
        }
    }
    // World areas (uniform scale 2): faces 2*3, 2*3, 1*3, 1*3, 1*2, 1*2 times 4.
    let expected = [6.0, 6.0, 3.0, 3.0, 2.0, 2.0].map(|a| a / 22.0 * (n * n) as f32);
    for k in 0..6 {
        assert!((faces[k] as f32 - expected[k]).abs() < 0.08 * expected[k], "{faces:?}");
    }
    let (side, cap) = (TAU * 2.0, PI);
    let total = side + 2.0 * cap;
    assert!((cyl_faces[0] as f32 / (n * n) as f32 - side / total).abs() < 0.02, "{cyl_faces:?}");
    assert!((boxy.area() - 4.0 * 22.0).abs() < 1e-3);
    for k in 0..100 {
        let u = [(k % 10) as f32 / 10.0 + 0.05, (k / 10) as f32 / 10.0 + 0.05];
        let p = sphere.sample_area(u);
        assert!(((p - Vec3::new(1.0, 2.0, 3.0)).length() - 1.0).abs() < 1e-4);
        let q = m.inverse().transform_point3a(quad.sample_area(u));
        assert!(q.z.abs() < 1e-5 && (0.0..=1.0).contains(&q.x) && (0.0..=1.0).contains(&q.y));
    }
}

/// A shape stays small: a million-sphere scene keeps a million of them
/// (what only some shapes need goes behind a pointer, as `Placement`).
#[test]
fn shapes_stay_small() {
    assert!(std::mem::size_of::<Shape>() <= 144, "{} bytes", std::mem::size_of::<Shape>());
}
