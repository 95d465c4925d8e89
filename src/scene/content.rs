//! A scene's content hash: what a render farm compares to know that images
//! came from the same scene. It covers everything that makes the picture
//! and nothing about where the files are: the text of the program's own
//! source files (the root and its imports, in load order; the prelude is
//! tslc's version), every texture's decoded texels, and the meshes and
//! environment image the scene read. SHA3-256 (the `sha3` crate, already
//! built for lalrpop), printed as 64 hex digits.

use super::{EnvironmentSourceDesc, SceneDesc, ShapeDesc};
use crate::check::Program;
use sha3::{Digest, Sha3_256};

/// The content hash of `program` and its described scene, as hex digits.
/// Every frame of an animation has the same hash (the frame is recorded
/// apart).
///
/// ```
/// let a = tsl::check_source("a.tsl", "float f() { return 1; }", &Default::default());
/// let b = tsl::check_source("b.tsl", "float f() { return 2; }", &Default::default());
/// let hash = |c: &tsl::Checked| tsl::scene::content_hash(&c.program, c.scene.as_ref());
/// assert_eq!(hash(&a).len(), 64);
/// assert_ne!(hash(&a), hash(&b));
/// ```
pub fn content_hash(program: &Program, scene: Option<&SceneDesc>) -> String {
    let mut h = Sha3_256::new();
    // Each piece is tagged and sized, so no two inputs hash alike.
    let mut piece = |tag: &str, bytes: &[u8]| {
        h.update(tag.as_bytes());
        h.update((bytes.len() as u64).to_le_bytes());
        h.update(bytes);
    };
    piece("tsl-scene-content-1", &[]);
    let loaded = &program.loaded;
    for module in loaded.modules.iter().filter(|m| !m.is_prelude) {
        piece("source", loaded.sources.text(module.file).as_bytes());
    }
    let floats = |xs: &mut dyn Iterator<Item = f32>| xs.flat_map(f32::to_le_bytes).collect::<Vec<u8>>();
    for image in program.images.iter().filter_map(|i| i.image.as_ref()) {
        let Some(level) = image.levels.first() else { continue };
        piece("texture", &[level.width.to_le_bytes(), level.height.to_le_bytes()].concat());
        piece("texels", &floats(&mut level.texels.iter().flatten().copied()));
    }
    let Some(scene) = scene else { return hex(&h.finalize()) };
    for object in &scene.objects {
        if let ShapeDesc::Mesh { file } = &object.shape {
            let mesh = &file.value;
            piece("mesh", &floats(&mut mesh.positions.iter().flat_map(|p| p.to_array())));
            piece("normals", &floats(&mut mesh.normals.iter().flatten().flat_map(|n| n.to_array())));
            piece("uvs", &floats(&mut mesh.uvs.iter().flatten().flatten().copied()));
            let indices: Vec<u8> = mesh.triangles.iter().flatten().flat_map(|i| i.to_le_bytes()).collect();
            piece("triangles", &indices);
        }
    }
    if let Some(EnvironmentSourceDesc::Image(image)) = scene.environment.as_ref().map(|e| &e.source) {
        let image = &image.value;
        piece("environment", &[image.width.to_le_bytes(), image.height.to_le_bytes()].concat());
        piece("texels", &floats(&mut image.rgb.iter().flatten().copied()));
    }
    hex(&h.finalize())
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
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
