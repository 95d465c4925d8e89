//! A scene's content hash: what a render farm compares to know that images
//! came from the same scene. It covers everything that makes the picture
//! and nothing about where the files are: the text of the program's own
//! source files (the root and its imports, in load order; the prelude is
//! tslc's version), every texture's decoded texels (a UDIM tile's file
//! bytes: its pixels are read only when a lookup needs them), and the meshes and
//! environment image the scene read. BLAKE3 (256 bits, printed as 64 hex
//! digits): five times faster than SHA3 over float texels, which matters at
//! the start of every render of a scene with large textures.

use super::{EnvironmentImage, EnvironmentSourceDesc, MeshData, SceneDesc, ShapeDesc};
use crate::check::Program;
use crate::diag::Span;
use crate::texture::{MipMap, TextureImage, UdimTile};
use std::path::Path;

/// One file a program and its scene were made from, and what was read
/// from it ([`input_files`]).
#[derive(Debug, Clone, Copy)]
pub struct InputFile<'a> {
    /// The file as the program names it (the root source as given, an
    /// import or image as found next to the file naming it); `None` for a
    /// mesh made from arrays.
    pub path: Option<&'a Path>,
    /// Where the program names it: a `texture` call's file literal, a
    /// mesh's `file` or the environment's image property; `None` for the
    /// source files.
    pub span: Option<Span>,
    pub content: InputContent<'a>,
}

/// What was read from an [`InputFile`].
#[derive(Debug, Clone, Copy)]
pub enum InputContent<'a> {
    /// The root source file's text.
    Source(&'a str),
    /// An imported file's text.
    Import(&'a str),
    Texture(&'a MipMap),
    /// A tile of a UDIM set (its file is hashed, not its pixels).
    UdimTile(&'a UdimTile),
    Mesh(&'a MeshData),
    Environment(&'a EnvironmentImage),
}

impl InputContent<'_> {
    /// What the file is to the scene, in words: "the source", "an
    /// imported file", "a texture", "a mesh", "the environment image".
    pub fn role(&self) -> &'static str {
        match self {
            InputContent::Source(_) => "the source",
            InputContent::Import(_) => "an imported file",
            InputContent::Texture(_) => "a texture",
            InputContent::UdimTile(_) => "a UDIM tile",
            InputContent::Mesh(_) => "a mesh",
            InputContent::Environment(_) => "the environment image",
        }
    }
}

/// Every file `program` and its described scene were made from, in a fixed
/// order: the root source, its imports in load order, the textures that
/// loaded, the meshes, the environment image. The content hash covers
/// exactly these, and `tslc render` refuses to write over any of them.
pub fn input_files<'a>(program: &'a Program, scene: Option<&'a SceneDesc>) -> Vec<InputFile<'a>> {
    let loaded = &program.loaded;
    let mut inputs: Vec<InputFile<'a>> = Vec::new();
    for (k, module) in loaded.modules.iter().filter(|m| !m.is_prelude).enumerate() {
        let text = loaded.sources.text(module.file);
        let content = if k == 0 { InputContent::Source(text) } else { InputContent::Import(text) };
        inputs.push(InputFile { path: Some(Path::new(loaded.sources.name(module.file))), span: None, content });
    }
    for image in &program.images {
        match &image.image {
            Some(TextureImage::Single(texture)) => {
                let path = Some(Path::new(texture.name.as_str()));
                inputs.push(InputFile { path, span: Some(image.span), content: InputContent::Texture(texture) });
            }
            Some(TextureImage::Udim(set)) => {
                for tile in &set.tiles {
                    let path = Some(tile.path.as_path());
                    inputs.push(InputFile { path, span: Some(image.span), content: InputContent::UdimTile(tile) });
                }
            }
            None => {}
        }
    }
    let Some(scene) = scene else { return inputs };
    for object in &scene.objects {
        if let ShapeDesc::Mesh { file } = &object.shape {
            let mesh = &*file.value;
            let path = Some(mesh.path.as_path()).filter(|p| !p.as_os_str().is_empty());
            inputs.push(InputFile { path, span: Some(file.span), content: InputContent::Mesh(mesh) });
        }
    }
    if let Some(EnvironmentSourceDesc::Image(image)) = scene.environment.as_ref().map(|e| &e.source) {
        let path = Some(image.value.path.as_path());
        inputs.push(InputFile { path, span: Some(image.span), content: InputContent::Environment(&image.value) });
    }
    inputs
}

/// The content hash of `program` and its described scene, as hex digits:
/// the contents of its [`input_files`]. Every frame of an animation has
/// the same hash (the frame is recorded apart).
///
/// ```
/// let a = tsl::check_source("a.tsl", "float f() { return 1; }", &Default::default());
/// let b = tsl::check_source("b.tsl", "float f() { return 2; }", &Default::default());
/// let hash = |c: &tsl::Checked| tsl::scene::content_hash(&c.program, c.scene.as_ref());
/// assert_eq!(hash(&a).len(), 64);
/// assert_ne!(hash(&a), hash(&b));
/// ```
pub fn content_hash(program: &Program, scene: Option<&SceneDesc>) -> String {
    let mut h = Pieces(blake3::Hasher::new());
    h.bytes("tsl-scene-content-2", &[]);
    for input in input_files(program, scene) {
        match input.content {
            InputContent::Source(text) | InputContent::Import(text) => h.bytes("source", text.as_bytes()),
            InputContent::Texture(image) => {
                let Some(level) = image.levels.first() else { continue };
                h.bytes("texture", &[level.width.to_le_bytes(), level.height.to_le_bytes()].concat());
                h.floats("texels", level.texels.as_flattened());
            }
            InputContent::UdimTile(tile) => {
                h.bytes("udim-tile", &tile.number.to_le_bytes());
                h.file(&tile.path);
            }
            InputContent::Mesh(mesh) => {
                let positions: Vec<f32> = mesh.positions.iter().flat_map(|p| p.to_array()).collect();
                h.floats("mesh", &positions);
                let normals: Vec<f32> = mesh.normals.iter().flatten().flat_map(|n| n.to_array()).collect();
                h.floats("normals", &normals);
                let uvs: Vec<f32> = mesh.uvs.iter().flatten().flatten().copied().collect();
                h.floats("uvs", &uvs);
                let indices: Vec<u8> = mesh.triangles.iter().flatten().flat_map(|i| i.to_le_bytes()).collect();
                h.bytes("triangles", &indices);
            }
            InputContent::Environment(image) => {
                h.bytes("environment", &[image.width.to_le_bytes(), image.height.to_le_bytes()].concat());
                h.floats("texels", image.rgb.as_flattened());
            }
        }
    }
    h.0.finalize().to_hex().to_string()
}

/// The hasher, fed tagged and sized pieces so that no two inputs hash
/// alike.
struct Pieces(blake3::Hasher);

impl Pieces {
    fn bytes(&mut self, tag: &str, bytes: &[u8]) {
        self.0.update(tag.as_bytes());
        self.0.update(&(bytes.len() as u64).to_le_bytes());
        self.0.update(bytes);
    }

    /// The bytes of the file at `path`, streamed; one that cannot be read
    /// hashes as its error (the render that follows reports it).
    fn file(&mut self, path: &Path) {
        let mut file = blake3::Hasher::new();
        let read = crate::input_file::open_regular(path)
            .and_then(|(f, _)| file.update_reader(f).map(|_| ()).map_err(|e| e.to_string()));
        match read {
            Ok(()) => self.bytes("file", file.finalize().as_bytes()),
            Err(e) => self.bytes("unreadable", e.as_bytes()),
        }
    }

    /// `xs` as little-endian bytes, streamed through a small buffer.
    fn floats(&mut self, tag: &str, xs: &[f32]) {
        self.0.update(tag.as_bytes());
        self.0.update(&(4 * xs.len() as u64).to_le_bytes());
        let mut buffer = [0u8; 4096];
        for chunk in xs.chunks(buffer.len() / 4) {
            for (out, x) in buffer.chunks_exact_mut(4).zip(chunk) {
                out.copy_from_slice(&x.to_le_bytes());
            }
            self.0.update(&buffer[..4 * chunk.len()]);
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::test_support::temp_dir;

    /// The hash of `scene.tsl` in `dir`, which looks up `t.png` and reads
    /// `m.obj`.
    fn hash_in(dir: &std::path::Path, texel: u8, z: f32) -> String {
        image::save_buffer(dir.join("t.png"), &[texel, 0, 0], 1, 1, image::ColorType::Rgb8).unwrap();
        std::fs::write(dir.join("m.obj"), format!("v 0 0 {z}\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")).unwrap();
        let src = r#"material m = lambert(kd: texture("t.png"));
            scene {
                camera { from (0, 0, 5); to (0, 0, 0); }
                object mesh { file "m.obj"; material m; }
            }"#;
        std::fs::write(dir.join("scene.tsl"), src).unwrap();
        let checked = crate::check_file(&dir.join("scene.tsl"), &crate::LoadOptions::default());
        assert!(checked.is_ok(), "{}", checked.render_diagnostics());
        super::content_hash(&checked.program, checked.scene.as_ref())
    }

    #[test]
    fn the_hash_follows_textures_and_meshes_not_where_the_files_are() {
        let (a, b) = (temp_dir("hash-a"), temp_dir("hash-b"));
        let base = hash_in(&a, 10, 0.0);
        assert_eq!(base, hash_in(&b, 10, 0.0), "the same files elsewhere");
        assert_ne!(base, hash_in(&b, 11, 0.0), "another texel");
        assert_ne!(base, hash_in(&b, 10, 0.5), "another vertex");
        let _ = std::fs::remove_dir_all(&a);
        let _ = std::fs::remove_dir_all(&b);
    }
}
