//! The files one build of `tslc watch` read or looked for, each named by
//! one path so that a file event is matched to it exactly (never by file
//! name alone: an image in another folder may share the output's name).
//!
//! That path, a file's *key*, is its directory's path made absolute with
//! the longest part that exists resolved (`canonicalize`) and the rest
//! normalised by hand, joined to its own name. The same file has the same
//! key whether it exists now or not, so a missing import, or a file in a
//! folder that was deleted, is still recognised when it comes back; and it
//! is the path the watcher reports, since directories are watched by key.

use std::collections::HashSet;
use std::path::{Component, Path, PathBuf};
use tsl::Checked;
use tsl::scene::{EnvironmentSourceDesc, ShapeDesc};
use tsl::syntax::ast;
use tsl::texture::TextureImage;

/// The files one build read: a change to any of them starts a new build.
#[derive(Default)]
pub struct Inputs {
    /// Each file's key (and, for a symbolic link, its target's too).
    pub files: HashSet<PathBuf>,
    /// The directories of the files: the ones to watch.
    pub dirs: HashSet<PathBuf>,
}

impl Inputs {
    fn add(&mut self, path: &Path) {
        let file = key(path);
        // A symbolic link: a change to its target is a change too.
        if let Ok(target) = path.canonicalize()
            && target != file
        {
            self.insert(target);
        }
        self.insert(file);
    }

    fn insert(&mut self, file: PathBuf) {
        if let Some(dir) = file.parent() {
            self.dirs.insert(dir.to_path_buf());
        }
        self.files.insert(file);
    }
}

/// The path events name `path` by: see the module's documentation.
pub fn key(path: &Path) -> PathBuf {
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    match (absolute.parent(), absolute.file_name()) {
        (Some(dir), Some(name)) => directory_key(dir).join(name),
        _ => absolute,
    }
}

/// `dir` with its longest existing ancestor resolved and the components
/// after it (which do not exist yet) normalised lexically.
fn directory_key(dir: &Path) -> PathBuf {
    let mut missing = Vec::new();
    let mut existing = dir;
    loop {
        if let Ok(resolved) = existing.canonicalize() {
            let mut key = resolved;
            for component in missing.iter().rev() {
                match component {
                    Component::ParentDir => {
                        key.pop();
                    }
                    Component::Normal(name) => key.push(name),
                    _ => {}
                }
            }
            return key;
        }
        match (existing.parent(), existing.components().next_back()) {
            (Some(parent), Some(last)) => {
                missing.push(last);
                existing = parent;
            }
            _ => return dir.to_path_buf(),
        }
    }
}

/// Every place a file named `written` in a file in `base` is looked for, in
/// the order the front end looks (next to the file, then each `-I`
/// directory): a file appearing at any of them may change what is read.
fn lookup_places(base: &Path, written: &str, import_paths: &[PathBuf]) -> Vec<PathBuf> {
    let direct = Path::new(written);
    if direct.is_absolute() {
        return vec![direct.to_path_buf()];
    }
    std::iter::once(base).chain(import_paths.iter().map(PathBuf::as_path)).map(|dir| dir.join(written)).collect()
}

/// The scene, its imports, the images its `texture` calls read (each at
/// every place it is looked for, found or not), its meshes and its
/// environment image.
pub fn inputs_of(scene: &Path, checked: &Checked, import_paths: &[PathBuf]) -> Inputs {
    let mut inputs = Inputs::default();
    inputs.add(scene);
    let program = &checked.program;
    let sources = &program.loaded.sources;
    let base_of = |file| Path::new(sources.name(file)).parent().unwrap_or(Path::new("")).to_path_buf();
    for module in program.loaded.modules.iter().filter(|m| !m.is_prelude) {
        inputs.add(Path::new(sources.name(module.file)));
        let base = base_of(module.file);
        for item in &module.ast.items {
            if let ast::Item::Import { path, .. } = item {
                for place in lookup_places(&base, path, import_paths) {
                    inputs.add(&place);
                }
            }
        }
    }
    for image in &program.images {
        match &image.image {
            Some(TextureImage::Single(loaded)) => inputs.add(Path::new(&loaded.name)),
            // The tiles found; a tile added later is seen at the next check.
            Some(TextureImage::Udim(set)) => set.tiles.iter().for_each(|t| inputs.add(&t.path)),
            None => {}
        }
        for place in lookup_places(&base_of(image.span.file), &image.path, import_paths) {
            inputs.add(&place);
        }
    }
    if let Some(desc) = &checked.scene {
        for object in &desc.objects {
            if let ShapeDesc::Mesh { file } = &object.shape {
                inputs.add(&file.value.path);
            }
        }
        if let Some(EnvironmentSourceDesc::Image(image)) = desc.environment.as_ref().map(|e| &e.source) {
            inputs.add(&image.value.path);
        }
    }
    inputs
}

#[cfg(test)]
mod tests {
    use super::key;
    use std::path::Path;

    #[test]
    fn a_key_is_the_same_whether_the_file_exists_or_not() {
        let dir = std::env::temp_dir().join(format!("tslc-watch-keys-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let resolved = {
            std::fs::create_dir_all(dir.join("a/b")).unwrap();
            std::fs::write(dir.join("a/b/scene.tsl"), "").unwrap();
            key(&dir.join("a/./b/../b/scene.tsl"))
        };
        assert_eq!(resolved, dir.canonicalize().unwrap().join("a/b/scene.tsl"));
        std::fs::remove_dir_all(dir.join("a")).unwrap();
        assert_eq!(key(&dir.join("a/b/scene.tsl")), resolved, "the folder deleted");
        assert_eq!(key(&dir.join("a/c/../b/scene.tsl")), resolved, "`..` in the missing part");
        assert_eq!(key(Path::new("/")), Path::new("/"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
