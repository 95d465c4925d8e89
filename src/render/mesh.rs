//! Triangle meshes: the scene's checked [`MeshData`] (read from OBJ files
//! by `crate::scene`) moved to world space once, and intersected triangle
//! by triangle.
//!
//! Invariant: a `Mesh` holds only finite numbers and in-range indices
//! (its `MeshData` was checked when it was made, and the transform is
//! checked here), so intersection never meets NaN input. Triangles are
//! counter-clockwise seen from their front: `ng = normalize((v1 - v0) x
//! (v2 - v0))`.

use super::sampling::Frame;
use super::shape::SurfaceHit;
use super::{Mat4, Ray, Vec3};
use crate::scene::{MeshData, mesh_transform_error};
use std::path::Path;

#[derive(Debug, Clone)]
pub struct Mesh {
    /// World-space positions.
    pub positions: Vec<Vec3>,
    /// World-space unit vertex normals, when the file has them.
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<[f32; 2]>>,
    pub triangles: Vec<[u32; 3]>,
    /// World to object space, for `Pl`.
    to_object: Mat4,
}

impl Mesh {
    /// Loads a mesh file, `.obj` or `.ply` (see [`MeshData::load`]), and
    /// places it with `to_world`.
    pub fn load(path: &Path, to_world: Mat4) -> Result<Mesh, String> {
        Mesh::from_data(&MeshData::load(path)?, to_world).map_err(|e| format!("the mesh {}: {e}", path.display()))
    }

    /// A mesh from arrays in object space; checks every number and index.
    pub fn from_parts(
        positions: Vec<Vec3>,
        normals: Option<Vec<Vec3>>,
        uvs: Option<Vec<[f32; 2]>>,
        triangles: Vec<[u32; 3]>,
        to_world: Mat4,
    ) -> Result<Mesh, String> {
        Mesh::from_data(&MeshData::new(positions, normals, uvs, triangles)?, to_world)
    }

    /// A checked mesh moved to world space by `to_world`, which must be
    /// finite and invertible.
    pub fn from_data(data: &MeshData, to_world: Mat4) -> Result<Mesh, String> {
        if let Some(e) = mesh_transform_error(&to_world) {
            return Err(e.into());
        }
        let positions: Vec<Vec3> = data.positions.iter().map(|p| to_world.transform_point3a(*p)).collect();
        let normal_matrix = glam::Mat3A::from_mat4(to_world).inverse().transpose();
        let normals =
            data.normals.as_ref().map(|n| n.iter().map(|v| (normal_matrix * *v).normalize_or_zero()).collect());
        Ok(Mesh {
            positions,
            normals,
            uvs: data.uvs.clone(),
            triangles: data.triangles.clone(),
            to_object: to_world.inverse(),
        })
    }

    fn vertices(&self, tri: u32) -> [Vec3; 3] {
        self.triangles[tri as usize].map(|i| self.positions[i as usize])
    }

    pub fn bounds(&self, tri: u32) -> (Vec3, Vec3) {
        let [a, b, c] = self.vertices(tri);
        (a.min(b).min(c), a.max(b).max(c))
    }

    pub fn triangle_area(&self, tri: u32) -> f32 {
        let [a, b, c] = self.vertices(tri);
        0.5 * (b - a).cross(c - a).length()
    }

    /// Möller–Trumbore: `(t, b1, b2)` with `P = (1 - b1 - b2) v0 + b1 v1 +
    /// b2 v2`, for `t` in `(t_min, t_max)`. Degenerate triangles never hit.
    #[inline]
    pub fn intersect(&self, tri: u32, ray: &Ray, t_min: f32, t_max: f32) -> Option<(f32, f32, f32)> {
        let [v0, v1, v2] = self.vertices(tri);
        let e1 = v1 - v0;
        let e2 = v2 - v0;
        let p = ray.dir.cross(e2);
        let det = e1.dot(p);
        if det.abs() < f32::MIN_POSITIVE || !det.is_finite() {
            return None;
        }
        let inv = 1.0 / det;
        let s = ray.origin - v0;
        let b1 = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&b1) {
            return None;
        }
        let q = s.cross(e1);
        let b2 = ray.dir.dot(q) * inv;
        if b2 < 0.0 || b1 + b2 > 1.0 {
            return None;
        }
        let t = e2.dot(q) * inv;
        (t > t_min && t < t_max).then_some((t, b1, b2))
    }

    /// The surface record of a hit found by [`Mesh::intersect`].
    pub fn surface(&self, tri: u32, ray: &Ray, t: f32, b1: f32, b2: f32) -> SurfaceHit {
        let idx = self.triangles[tri as usize];
        let [v0, v1, v2] = self.vertices(tri);
        let b0 = 1.0 - b1 - b2;
        let p = v0 * b0 + v1 * b1 + v2 * b2;
        let cross = (v1 - v0).cross(v2 - v0);
        let ng = cross.normalize_or(Vec3::Y);
        let n = match &self.normals {
            Some(ns) => {
                let [n0, n1, n2] = idx.map(|i| ns[i as usize]);
                (n0 * b0 + n1 * b1 + n2 * b2).normalize_or(ng)
            }
            None => ng,
        };
        let uv = self.uvs.as_ref().map(|t| idx.map(|i| t[i as usize]));
        let (u, v) = match uv {
            Some([a, b, c]) => (a[0] * b0 + b[0] * b1 + c[0] * b2, a[1] * b0 + b[1] * b1 + c[1] * b2),
            None => (b1, b2),
        };
        // dP/du, dP/dv from the uv parametrisation (pbrt's 2x2 solve).
        let [t0, t1, t2] = uv.unwrap_or([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
        let (du02, dv02) = (t0[0] - t2[0], t0[1] - t2[1]);
        let (du12, dv12) = (t1[0] - t2[0], t1[1] - t2[1]);
        let (dp02, dp12) = (v0 - v2, v1 - v2);
        let det = du02 * dv12 - dv02 * du12;
        let mut dpdu = (dv12 * dp02 - dv02 * dp12) / det;
        let mut dpdv = (du02 * dp12 - du12 * dp02) / det;
        if !det.is_finite()
            || det.abs() < 1e-12
            || !dpdu.is_finite()
            || !dpdv.is_finite()
            || dpdu.cross(dpdv).length_squared() == 0.0
        {
            let f = Frame::new(ng);
            dpdu = f.s;
            dpdv = f.t;
        } else if dpdu.cross(dpdv).dot(ng) < 0.0 {
            // A mirrored uv layout: keep dPdu x dPdv along the normal.
            dpdv = -dpdv;
        }
        SurfaceHit {
            t,
            p: if ray.dir == Vec3::ZERO { p } else { ray.at(t) },
            pl: self.to_object.transform_point3a(p),
            ng,
            n,
            u,
            v,
            dpdu,
            dpdv,
            face: 0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one_triangle() -> Mesh {
        Mesh::from_parts(
            vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            None,
            Some(vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]),
            vec![[0, 1, 2]],
            Mat4::IDENTITY,
        )
        .unwrap()
    }

    #[test]
    fn triangle_hits_give_barycentrics_and_a_consistent_frame() {
        let m = one_triangle();
        let r = Ray::new(Vec3::new(0.25, 0.5, 2.0), Vec3::NEG_Z);
        let (t, b1, b2) = m.intersect(0, &r, 0.0, f32::INFINITY).unwrap();
        assert!((t - 2.0).abs() < 1e-6 && (b1 - 0.25).abs() < 1e-6 && (b2 - 0.5).abs() < 1e-6);
        let s = m.surface(0, &r, t, b1, b2);
        assert!((s.ng - Vec3::Z).length() < 1e-6 && (s.u - 0.25).abs() < 1e-6 && (s.v - 0.5).abs() < 1e-6);
        assert!(s.dpdu.cross(s.dpdv).dot(s.ng) > 0.0);
        assert!((s.dpdu - Vec3::X).length() < 1e-6 && (s.dpdv - Vec3::Y).length() < 1e-6);
        // From behind too (both sides are hit), and t limits hold.
        assert!(m.intersect(0, &Ray::new(Vec3::new(0.2, 0.2, -1.0), Vec3::Z), 0.0, 10.0).is_some());
        assert!(m.intersect(0, &r, 0.0, 1.5).is_none());
        // Outside, and exactly on an edge.
        assert!(m.intersect(0, &Ray::new(Vec3::new(0.8, 0.8, 1.0), Vec3::NEG_Z), 0.0, 10.0).is_none());
        assert!(m.intersect(0, &Ray::new(Vec3::new(0.5, 0.0, 1.0), Vec3::NEG_Z), 0.0, 10.0).is_some());
        // Parallel to the plane.
        assert!(m.intersect(0, &Ray::new(Vec3::new(-1.0, 0.2, 0.0), Vec3::X), 0.0, 10.0).is_none());
    }

    #[test]
    fn degenerate_triangles_never_hit() {
        let m = Mesh::from_parts(vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0], None, None, vec![[0, 1, 2]], Mat4::IDENTITY)
            .unwrap();
        for k in 0..50 {
            let r = Ray::new(Vec3::new(k as f32 * 0.04, 0.0, 1.0), Vec3::NEG_Z);
            assert!(m.intersect(0, &r, 0.0, f32::INFINITY).is_none());
        }
        assert_eq!(m.triangle_area(0), 0.0);
    }

    #[test]
    fn transforms_move_vertices_and_normals() {
        let m = Mesh::from_parts(
            vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            Some(vec![Vec3::Z; 3]),
            None,
            vec![[0, 1, 2]],
            Mat4::from_translation(glam::Vec3::new(0.0, 0.0, -3.0))
                * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2),
        )
        .unwrap();
        // Rotated to lie in the xz plane facing +y, moved to z = -3.
        let r = Ray::new(Vec3::new(0.2, 5.0, -3.2), Vec3::NEG_Y);
        let (t, b1, b2) = m.intersect(0, &r, 0.0, f32::INFINITY).unwrap();
        let s = m.surface(0, &r, t, b1, b2);
        assert!((s.n - Vec3::Y).length() < 1e-5 && (s.ng - Vec3::Y).length() < 1e-5);
        assert!((s.pl - Vec3::new(0.2, 0.2, 0.0)).length() < 1e-5, "{}", s.pl);
    }

    fn temp_obj(name: &str, text: &str) -> std::path::PathBuf {
        let path = std::env::temp_dir().join(format!("tsl-mesh-{}-{name}.obj", std::process::id()));
        std::fs::write(&path, text).unwrap();
        path
    }

    #[test]
    fn obj_files_load_with_normals_and_uvs() {
        let path = temp_obj(
            "quad",
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/3/1 4/4/1\n",
        );
        let m = Mesh::load(&path, Mat4::IDENTITY).unwrap();
        let _ = std::fs::remove_file(&path);
        assert_eq!(m.triangles.len(), 2);
        assert!(m.normals.is_some() && m.uvs.is_some());
        let r = Ray::new(Vec3::new(0.7, 0.6, 1.0), Vec3::NEG_Z);
        let hits: Vec<_> = (0..2).filter_map(|k| m.intersect(k, &r, 0.0, 10.0).map(|h| (k, h))).collect();
        let (k, (t, b1, b2)) = hits[0];
        let s = m.surface(k, &r, t, b1, b2);
        assert!((s.u - 0.7).abs() < 1e-5 && (s.v - 0.6).abs() < 1e-5);
    }

    #[test]
    fn bad_obj_files_and_transforms_are_clear_errors() {
        let missing = Mesh::load(Path::new("/no/such/dir/mesh.obj"), Mat4::IDENTITY).unwrap_err();
        assert!(missing.contains("cannot open") && missing.contains("mesh.obj"), "{missing}");
        let e =
            Mesh::from_parts(vec![Vec3::ZERO, Vec3::X, Vec3::Y], None, None, vec![[0, 1, 2]], Mat4::ZERO).unwrap_err();
        assert!(e.contains("singular"), "{e}");
    }
}
