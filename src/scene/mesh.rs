//! Triangle meshes as read from Wavefront OBJ files (tobj) and Stanford PLY
//! files (`ply`), in the mesh's own frame, before any object transform.
//!
//! Invariant: a `MeshData` holds only finite numbers, at least one
//! triangle, and in-range indices (checked when it is made), so whatever
//! places it in the world never meets NaN input.

mod ply;

use super::Vec3;
use crate::input_file::{self, BoundedText, TextLimit, size_in_words};
use std::path::{Path, PathBuf};

/// The largest mesh file read (1 GiB: a Wavefront OBJ of some ten million
/// triangles with normals and texture coordinates; `tslc make-mesh
/// heavy`'s million is 104 MB).
pub const MAX_MESH_BYTES: u64 = 1 << 30;
/// The longest line of a mesh file (1 MiB: a face of some 100,000
/// vertices), so a file that never ends a line is refused at that length.
pub const MAX_MESH_LINE_BYTES: u64 = 1 << 20;

/// A mesh in its own frame. Triangles are counter-clockwise seen from
/// their front.
#[derive(Clone, PartialEq)]
pub struct MeshData {
    /// The file it was read from (empty for a mesh made from arrays).
    pub path: PathBuf,
    pub positions: Vec<Vec3>,
    /// Vertex normals, when the file has them for every vertex.
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<[f32; 2]>>,
    pub triangles: Vec<[u32; 3]>,
}

impl std::fmt::Debug for MeshData {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // A mesh may have millions of vertices: its size, not its numbers.
        f.debug_struct("MeshData")
            .field("path", &self.path)
            .field("vertices", &self.positions.len())
            .field("triangles", &self.triangles.len())
            .field("normals", &self.normals.is_some())
            .field("uvs", &self.uvs.is_some())
            .finish()
    }
}

impl MeshData {
    /// Loads a mesh file by its extension: `.obj` ([`MeshData::load_obj`])
    /// or `.ply` (ASCII or binary, with normals and texture coordinates when
    /// every vertex has them). Another extension is an error naming the
    /// formats read.
    pub fn load(path: &Path) -> Result<MeshData, String> {
        let extension = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        match extension.as_deref() {
            Some("obj") => MeshData::load_obj(path),
            Some("ply") => ply::load_ply(path),
            _ => Err(format!(
                "the mesh {}: not a mesh format TSL reads (Wavefront .obj or Stanford .ply, by the file's extension)",
                path.display()
            )),
        }
    }

    /// Loads an OBJ file (all its objects and groups together; polygons
    /// triangulated; materials in `.mtl` files are ignored: TSL materials
    /// come from the scene). The error names the file as `path` spells it.
    ///
    /// The file must be a regular file (a FIFO or device is refused, not
    /// waited on or read without end) of at most [`MAX_MESH_BYTES`], with
    /// no line longer than [`MAX_MESH_LINE_BYTES`].
    pub fn load_obj(path: &Path) -> Result<MeshData, String> {
        let (file, _) = input_file::open_bounded(path, MAX_MESH_BYTES, "a mesh")
            .map_err(|e| format!("cannot open the mesh {}: {e}", path.display()))?;
        let bounded = BoundedText::new(file, MAX_MESH_BYTES, MAX_MESH_LINE_BYTES);
        let mut reader = std::io::BufReader::new(bounded);
        let options = tobj::LoadOptions { single_index: true, triangulate: true, ..tobj::LoadOptions::default() };
        let loaded = tobj::load_obj_buf(&mut reader, &options, |_| Err(tobj::LoadError::OpenFileFailed));
        let (models, _) = loaded.map_err(|e| match reader.get_ref().limit() {
            Some(TextLimit::Line(line)) => format!(
                "the mesh {}: line {line} is longer than {}, the most a line of a mesh may be",
                path.display(),
                size_in_words(MAX_MESH_LINE_BYTES)
            ),
            Some(TextLimit::Size) => format!(
                "the mesh {} is larger than {}, the most a mesh may be",
                path.display(),
                size_in_words(MAX_MESH_BYTES)
            ),
            None => format!("cannot read the mesh {}: {e}", path.display()),
        })?;
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        let mut uvs = Vec::new();
        let mut triangles = Vec::new();
        let all_normals = models.iter().all(|m| !m.mesh.normals.is_empty());
        let all_uvs = models.iter().all(|m| !m.mesh.texcoords.is_empty());
        for model in &models {
            let m = &model.mesh;
            let base = positions.len() as u32;
            let count = m.positions.len() / 3;
            positions.extend(m.positions.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])));
            if all_normals {
                normals.extend(m.normals.chunks_exact(3).map(|n| Vec3::new(n[0], n[1], n[2])));
            }
            if all_uvs {
                uvs.extend(m.texcoords.chunks_exact(2).map(|t| [t[0], t[1]]));
            }
            for f in m.indices.chunks_exact(3) {
                if f.iter().any(|i| *i as usize >= count) {
                    return Err(format!(
                        "the mesh {} has a face with vertex index {} but only {count} vertices",
                        path.display(),
                        f.iter().max().copied().unwrap_or(0) + 1
                    ));
                }
                triangles.push([base + f[0], base + f[1], base + f[2]]);
            }
        }
        let mesh = MeshData::new(positions, all_normals.then_some(normals), all_uvs.then_some(uvs), triangles)
            .map_err(|e| format!("the mesh {}: {e}", path.display()))?;
        Ok(MeshData { path: path.to_path_buf(), ..mesh })
    }

    /// A mesh from arrays; checks every number and index.
    pub fn new(
        positions: Vec<Vec3>,
        normals: Option<Vec<Vec3>>,
        uvs: Option<Vec<[f32; 2]>>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<MeshData, String> {
        if triangles.is_empty() {
            return Err("it has no triangles".into());
        }
        if let Some(k) = positions.iter().position(|p| !p.is_finite()) {
            return Err(format!(
                "vertex {} has a position that is not a number (NaN or infinite): {}",
                k + 1,
                positions[k]
            ));
        }
        if let Some(n) = &normals {
            if n.len() != positions.len() {
                return Err(format!("it has {} normals for {} vertices", n.len(), positions.len()));
            }
            if let Some(k) = n.iter().position(|v| !v.is_finite()) {
                return Err(format!("vertex {} has a normal that is not a number (NaN or infinite)", k + 1));
            }
        }
        if let Some(t) = &uvs {
            if t.len() != positions.len() {
                return Err(format!("it has {} texture coordinates for {} vertices", t.len(), positions.len()));
            }
            if let Some(k) = t.iter().position(|v| !v[0].is_finite() || !v[1].is_finite()) {
                return Err(format!("vertex {} has texture coordinates that are not numbers (NaN or infinite)", k + 1));
            }
        }
        if let Some(t) = triangles.iter().find(|t| t.iter().any(|i| *i as usize >= positions.len())) {
            return Err(format!("a triangle {t:?} refers to a vertex beyond the {} there are", positions.len()));
        }
        Ok(MeshData { path: PathBuf::new(), positions, normals, uvs, triangles })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_obj(name: &str, text: &str) -> PathBuf {
        let path = std::env::temp_dir().join(format!("tsl-meshdata-{}-{name}.obj", std::process::id()));
        std::fs::write(&path, text).unwrap();
        path
    }

    #[test]
    fn obj_files_load_with_normals_and_uvs() {
        let path = temp_obj(
            "quad",
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/3/1 4/4/1\n",
        );
        let m = MeshData::load_obj(&path).unwrap();
        let _ = std::fs::remove_file(&path);
        assert_eq!((m.triangles.len(), m.positions.len()), (2, 4));
        assert!(m.normals.is_some() && m.uvs.is_some() && m.path == path);
    }

    #[test]
    fn bad_obj_files_are_clear_errors() {
        let missing = MeshData::load_obj(Path::new("/no/such/dir/mesh.obj")).unwrap_err();
        assert!(missing.contains("cannot open") && missing.contains("mesh.obj"), "{missing}");
        let nan = temp_obj("nan", "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n");
        let e = MeshData::load_obj(&nan).unwrap_err();
        let _ = std::fs::remove_file(&nan);
        assert!(e.contains("vertex 2") && e.contains("NaN"), "{e}");
        let range = temp_obj("range", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
        let e = MeshData::load_obj(&range).unwrap_err();
        let _ = std::fs::remove_file(&range);
        assert!(e.contains("mesh"), "{e}");
        let empty = temp_obj("empty", "# nothing\nv 0 0 0\n");
        let e = MeshData::load_obj(&empty).unwrap_err();
        let _ = std::fs::remove_file(&empty);
        assert!(e.contains("no triangles"), "{e}");
    }
}
