//! Stanford PLY meshes (ASCII, binary little and big endian) through the
//! `ply-rs-bw` parser: the `vertex` element's `x`, `y`, `z`, optional
//! normals (`nx`, `ny`, `nz`) and texture coordinates (`u`, `v`, or `s`,
//! `t`, or `texture_u`, `texture_v`), and the `face` element's
//! `vertex_indices` (or `vertex_index`) lists, polygons fanned into
//! triangles. Other elements and properties are read past.
//!
//! Bounds: the file is at most [`MAX_MESH_BYTES`] (a regular file), the
//! header's lines at most [`MAX_MESH_LINE_BYTES`], and no element count
//! may claim more elements than the file has bytes, checked before the
//! payload is read.

use super::{MAX_MESH_BYTES, MAX_MESH_LINE_BYTES, MeshData, Vec3};
use crate::diag::printable;
use crate::input_file::{self, BoundedText, TextLimit, size_in_words};
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{Encoding, Property, PropertyAccess, PropertyAccessResult};
use std::path::Path;

/// A `vertex` element as read.
#[derive(Default)]
struct Vertex {
    p: [f32; 3],
    n: [Option<f32>; 3],
    uv: [Option<f32>; 2],
}

/// A `face` element as read: its vertex indices.
#[derive(Default)]
struct Face {
    indices: Vec<i64>,
}

fn scalar(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(x) => f64::from(x),
        Property::UChar(x) => f64::from(x),
        Property::Short(x) => f64::from(x),
        Property::UShort(x) => f64::from(x),
        Property::Int(x) => f64::from(x),
        Property::UInt(x) => f64::from(x),
        Property::Float(x) => f64::from(x),
        Property::Double(x) => x,
        _ => return None,
    })
}

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Vertex::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let Some(x) = scalar(&property) else { return PropertyAccessResult::Ignored };
        let x = x as f32;
        match name {
            "x" => self.p[0] = x,
            "y" => self.p[1] = x,
            "z" => self.p[2] = x,
            "nx" => self.n[0] = Some(x),
            "ny" => self.n[1] = Some(x),
            "nz" => self.n[2] = Some(x),
            "u" | "s" | "texture_u" | "texture_s" => self.uv[0] = Some(x),
            "v" | "t" | "texture_v" | "texture_t" => self.uv[1] = Some(x),
            _ => return PropertyAccessResult::Ignored,
        }
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for Face {
    fn new() -> Self {
        Face::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        if name != "vertex_indices" && name != "vertex_index" {
            return PropertyAccessResult::Ignored;
        }
        self.indices = match property {
            Property::ListChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListInt(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUInt(v) => v.into_iter().map(i64::from).collect(),
            _ => return PropertyAccessResult::UnsupportedType,
        };
        PropertyAccessResult::Set
    }
}

/// Reads a PLY mesh; errors name the file as `path` spells it.
pub(super) fn load_ply(path: &Path) -> Result<MeshData, String> {
    let (file, len) = input_file::open_bounded(path, MAX_MESH_BYTES, "a mesh")
        .map_err(|e| format!("cannot open the mesh {}: {e}", path.display()))?;
    let name = path.display();
    let mut reader = Reader::new(std::io::BufReader::new(BoundedText::new(file, MAX_MESH_BYTES, MAX_MESH_LINE_BYTES)));
    let explain = |reader: &Reader<std::io::BufReader<BoundedText<std::fs::File>>>, e: &dyn std::fmt::Display| {
        match reader.get_ref().get_ref().limit() {
            Some(TextLimit::Line(line)) => format!(
                "the mesh {name}: header line {line} is longer than {}, the most a line of a mesh may be",
                size_in_words(MAX_MESH_LINE_BYTES)
            ),
            Some(TextLimit::Size) => {
                format!("the mesh {name} is larger than {}, the most a mesh may be", size_in_words(MAX_MESH_BYTES))
            }
            // The parser's first line says where and what; the rest quotes
            // the file at length.
            None => {
                let text = e.to_string();
                format!("cannot read the mesh {name}: {}", printable(text.lines().next().unwrap_or_default()))
            }
        }
    };
    let header = Parser::<Vertex>::new().read_header(&mut reader).map_err(|e| explain(&reader, &e))?;
    if header.encoding != Encoding::Ascii {
        // The payload is binary: lines mean nothing there.
        reader.get_mut().get_mut().end_lines();
    }
    for element in header.elements.values() {
        if element.count as u64 > len {
            return Err(format!(
                "the mesh {name} claims {} `{}` elements, more than its {len} bytes could hold",
                element.count, element.name
            ));
        }
    }
    let (mut vertices, mut faces) = (Vec::new(), Vec::new());
    for element in header.elements.values() {
        match element.name.as_str() {
            "vertex" => {
                vertices = Parser::<Vertex>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(|e| explain(&reader, &e))?;
            }
            "face" => {
                faces = Parser::<Face>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(|e| explain(&reader, &e))?;
            }
            // Read past elements that are neither (edges, materials, ...).
            _ => {
                Parser::<Face>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(|e| explain(&reader, &e))?;
            }
        }
    }
    mesh_of(path, &vertices, &faces)
}

/// The mesh of the vertices and faces read: normals and uvs when every
/// vertex has them; polygons fanned into triangles.
fn mesh_of(path: &Path, vertices: &[Vertex], faces: &[Face]) -> Result<MeshData, String> {
    let name = path.display();
    let positions = vertices.iter().map(|v| Vec3::from(v.p)).collect();
    let normals = vertices
        .iter()
        .map(|v| Some(Vec3::new(v.n[0]?, v.n[1]?, v.n[2]?)))
        .collect::<Option<Vec<Vec3>>>()
        .filter(|n| !n.is_empty());
    let uvs = vertices.iter().map(|v| Some([v.uv[0]?, v.uv[1]?])).collect::<Option<Vec<_>>>().filter(|t| !t.is_empty());
    let mut triangles = Vec::new();
    for (k, face) in faces.iter().enumerate() {
        let index = |i: i64| {
            u32::try_from(i).ok().filter(|i| (*i as usize) < vertices.len()).ok_or_else(|| {
                format!("the mesh {name}: face {} refers to vertex {i}, and it has {} vertices", k + 1, vertices.len())
            })
        };
        if let [first, rest @ ..] = face.indices.as_slice() {
            let first = index(*first)?;
            for pair in rest.windows(2) {
                triangles.push([first, index(pair[0])?, index(pair[1])?]);
            }
        }
    }
    let mesh = MeshData::new(positions, normals, uvs, triangles).map_err(|e| format!("the mesh {name}: {e}"))?;
    Ok(MeshData { path: path.to_path_buf(), ..mesh })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::temp_dir;

    const QUAD_HEADER: &str = "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
        property float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\n\
        element face 1\nproperty list uchar int vertex_indices\nend_header\n";

    /// The quad's vertices (position, normal, uv) and its one face.
    fn quad() -> (Vec<[f32; 8]>, Vec<i32>) {
        let v = |x: f32, y: f32| [x, y, 0.0, 0.0, 0.0, 1.0, x, y];
        (vec![v(0.0, 0.0), v(1.0, 0.0), v(1.0, 1.0), v(0.0, 1.0)], vec![0, 1, 2, 3])
    }

    fn binary(big_endian: bool) -> Vec<u8> {
        binary_of(big_endian, quad())
    }

    fn binary_of(big_endian: bool, (vertices, face): (Vec<[f32; 8]>, Vec<i32>)) -> Vec<u8> {
        let format = if big_endian { "binary_big_endian" } else { "binary_little_endian" };
        let mut bytes = format!("ply\nformat {format} 1.0\ncomment made by hand\n{QUAD_HEADER}").into_bytes();
        for x in vertices.iter().flatten() {
            bytes.extend(if big_endian { x.to_be_bytes() } else { x.to_le_bytes() });
        }
        bytes.push(4);
        for i in face {
            bytes.extend(if big_endian { i.to_be_bytes() } else { i.to_le_bytes() });
        }
        bytes
    }

    fn ascii() -> String {
        let (vertices, face) = quad();
        let mut text = format!("ply\nformat ascii 1.0\n{QUAD_HEADER}");
        for v in vertices {
            text += &v.map(|x| x.to_string()).join(" ");
            text += "\n";
        }
        text += &format!("4 {}\n", face.iter().map(|i| i.to_string()).collect::<Vec<_>>().join(" "));
        text
    }

    #[test]
    fn ascii_and_binary_ply_meshes_read_the_same() {
        let dir = temp_dir("ply-formats");
        let mut meshes = Vec::new();
        for (name, bytes) in [("a.ply", ascii().into_bytes()), ("le.ply", binary(false)), ("be.ply", binary(true))] {
            let path = dir.join(name);
            std::fs::write(&path, bytes).unwrap();
            let m = MeshData::load(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(m.path, path);
            meshes.push(MeshData { path: std::path::PathBuf::new(), ..m });
        }
        let m = &meshes[0];
        // The quad fanned into two triangles, with its normals and uvs.
        assert_eq!(m.triangles, [[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.positions[2], Vec3::new(1.0, 1.0, 0.0));
        assert_eq!(m.normals.as_ref().unwrap()[3], Vec3::Z);
        assert_eq!(m.uvs.as_ref().unwrap()[1], [1.0, 0.0]);
        assert!(meshes.iter().all(|x| x == m), "the three encodings differ");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn bad_ply_files_are_clear_errors() {
        let dir = temp_dir("ply-bad");
        let load = |name: &str, bytes: &[u8]| {
            let path = dir.join(name);
            std::fs::write(&path, bytes).unwrap();
            MeshData::load(&path).unwrap_err()
        };
        let quad = ascii();
        // A header claiming more vertices than the file has bytes.
        let e = load("lie.ply", quad.replace("element vertex 4", "element vertex 4000000000").as_bytes());
        assert!(e.contains("claims 4000000000 `vertex` elements") && e.contains("lie.ply"), "{e}");
        // Fewer vertices than the header says.
        let e = load("short.ply", quad.replace("element vertex 4", "element vertex 9").as_bytes());
        assert!(e.contains("cannot read the mesh") && e.contains("short.ply"), "{e}");
        let e = load("index.ply", quad.replace("4 0 1 2 3", "4 0 1 2 7").as_bytes());
        assert!(e.contains("face 1 refers to vertex 7, and it has 4 vertices"), "{e}");
        let e = load("points.ply", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n");
        assert!(e.contains("no triangles"), "{e}");
        let (mut vertices, face) = super::tests::quad();
        vertices[1][2] = f32::NAN;
        let e = load("nan.ply", &binary_of(false, (vertices, face)));
        assert!(e.contains("vertex 2") && e.contains("NaN"), "{e}");
        let e = load("word.ply", quad.replacen("1 0 0 0 0 1 1 0", "1 0 zero 0 0 1 1 0", 1).as_bytes());
        assert!(e.contains("word.ply: Line 16: Couldn't read element line.") && !e.contains('\n'), "{e}");
        let e = load("garbage.ply", b"not a ply file at all\n");
        assert!(e.contains("cannot read the mesh") && e.contains("garbage.ply"), "{e}");
        let mut long = b"ply\nformat ascii 1.0\ncomment ".to_vec();
        long.extend(std::iter::repeat_n(b'x', (MAX_MESH_LINE_BYTES + 10) as usize));
        let e = load("long.ply", &long);
        assert!(e.contains("header line 3 is longer than"), "{e}");
        let e = load("mesh.stl", b"solid x\n");
        assert!(e.contains("Wavefront .obj or Stanford .ply"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
