//! Open documents (bounded in size), and where files are: the workspace's
//! import directories and the prelude's files on disk.

use super::line_index::LineIndex;
use crate::load::{LoadOptions, PRELUDE};
use lsp_types::{Position, Range, TextDocumentContentChangeEvent, Url};
use std::path::{Path, PathBuf};

/// The largest document the server keeps and checks: the largest source
/// `tslc check` reads ([`crate::load::MAX_SOURCE_BYTES`], 256 MiB). An
/// open or edit that makes a document larger leaves it empty and marked
/// too large (one diagnostic says so; requests get no answers) until a
/// whole-text change brings it back within the bound, so edits cannot
/// grow a document without bound.
pub const MAX_DOCUMENT_BYTES: usize = crate::load::MAX_SOURCE_BYTES as usize;

/// A text document the client has open.
#[derive(Debug, Clone)]
pub struct Document {
    pub text: String,
    pub version: i32,
    pub index: LineIndex,
    /// The size the text would have, when over [`MAX_DOCUMENT_BYTES`]
    /// (the text is then empty).
    pub too_large: Option<usize>,
}

impl Document {
    pub fn new(text: String, version: i32) -> Document {
        let mut doc = Document { text: String::new(), version, index: LineIndex::default(), too_large: None };
        doc.set_text(text, MAX_DOCUMENT_BYTES);
        doc.index = LineIndex::new(&doc.text);
        doc
    }

    /// Applies the client's changes in order: whole-text replacements and
    /// range edits (incremental sync).
    pub fn apply(&mut self, changes: Vec<TextDocumentContentChangeEvent>, version: i32) {
        self.apply_within(changes, version, MAX_DOCUMENT_BYTES);
    }

    /// [`Document::apply`] with a bound of `max` bytes. The line index is
    /// built once per range edit, and once after whole-text changes.
    fn apply_within(&mut self, changes: Vec<TextDocumentContentChangeEvent>, version: i32, max: usize) {
        let mut indexed = true;
        for change in changes {
            match change.range {
                None => {
                    self.set_text(change.text, max);
                    indexed = false;
                    continue;
                }
                // The text is unknown: an edit of it means nothing.
                Some(_) if self.too_large.is_some() => continue,
                Some(range) => {
                    if !indexed {
                        self.index = LineIndex::new(&self.text);
                    }
                    let start = self.index.offset(&self.text, range.start);
                    let end = self.index.offset(&self.text, range.end).max(start);
                    let size = self.text.len() - (end - start) + change.text.len();
                    if size > max {
                        self.too_large = Some(size);
                        self.text = String::new();
                    } else {
                        self.text.replace_range(start..end, &change.text);
                    }
                    indexed = false;
                }
            }
        }
        if !indexed {
            self.index = LineIndex::new(&self.text);
        }
        self.version = version;
    }

    /// Sets the whole text (not indexed yet), or marks the document too
    /// large.
    fn set_text(&mut self, text: String, max: usize) {
        (self.text, self.too_large) = if text.len() > max { (String::new(), Some(text.len())) } else { (text, None) };
    }

    pub fn offset(&self, pos: Position) -> usize {
        self.index.offset(&self.text, pos)
    }

    pub fn range(&self, start: usize, end: usize) -> Range {
        self.index.range(&self.text, start, end)
    }
}

/// The server's settings: the workspace folders and the import search
/// directories (`importPaths` of the initialization options, relative ones
/// taken from the first folder), and the prelude's files on disk.
#[derive(Debug, Clone, Default)]
pub struct Workspace {
    pub roots: Vec<PathBuf>,
    pub import_paths: Vec<PathBuf>,
    /// Where the prelude's text is written, so that definitions in it can
    /// be shown: `None` when no cache directory could be written.
    pub prelude_dir: Option<PathBuf>,
}

impl Workspace {
    pub fn new(roots: Vec<PathBuf>, import_paths: &[PathBuf]) -> Workspace {
        let base = roots.first().cloned().or_else(|| std::env::current_dir().ok()).unwrap_or_default();
        let import_paths =
            import_paths.iter().map(|p| if p.is_absolute() { p.clone() } else { base.join(p) }).collect();
        Workspace { roots, import_paths, prelude_dir: write_prelude() }
    }

    /// How programs of this workspace load: the import directories, then
    /// the workspace folders.
    pub fn load_options(&self) -> LoadOptions {
        let mut import_paths = self.import_paths.clone();
        import_paths.extend(self.roots.iter().cloned());
        LoadOptions { import_paths, ..LoadOptions::default() }
    }

    /// The name a document is loaded under: its path for a file (which
    /// anchors relative imports), else the URI itself.
    pub fn source_name(uri: &Url) -> String {
        match uri.to_file_path() {
            Ok(path) => path.display().to_string(),
            Err(()) => uri.to_string(),
        }
    }

    /// The URI of a loaded source: a prelude file (`stdlib/x.tsl`) is
    /// shown from the prelude directory, any other by its path.
    pub fn uri_of(&self, name: &str, is_prelude: bool) -> Option<Url> {
        if is_prelude {
            return Url::from_file_path(self.prelude_dir.as_ref()?.join(name)).ok();
        }
        let path = Path::new(name);
        if path.is_absolute() {
            return Url::from_file_path(path).ok();
        }
        Url::parse(name).ok().or_else(|| Url::from_file_path(std::env::current_dir().ok()?.join(path)).ok())
    }

    /// The prelude file (`stdlib/x.tsl`) a document is, when it is one of
    /// the files written to the prelude directory.
    pub fn prelude_name(&self, uri: &Url) -> Option<&'static str> {
        let path = uri.to_file_path().ok()?;
        let dir = self.prelude_dir.as_ref()?;
        PRELUDE.iter().map(|(name, _)| *name).find(|name| dir.join(name) == path)
    }
}

/// Writes the prelude (embedded in the binary) to a cache directory named
/// by a hash of its text, so each version has its own, read by editors
/// when a definition is in the standard library (as rust-analyzer shows
/// the sysroot). `$XDG_CACHE_HOME`, else `~/.cache`, else the temporary
/// directory.
fn write_prelude() -> Option<PathBuf> {
    use std::hash::{Hash, Hasher};
    let mut hasher = std::collections::hash_map::DefaultHasher::new();
    PRELUDE.hash(&mut hasher);
    let cache = std::env::var_os("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .filter(|p| p.is_absolute())
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))
        .unwrap_or_else(std::env::temp_dir);
    let dir = cache.join("tslc").join(format!("prelude-{:016x}", hasher.finish()));
    for (name, text) in PRELUDE {
        let path = dir.join(name);
        if std::fs::read_to_string(&path).ok().as_deref() == Some(*text) {
            continue;
        }
        std::fs::create_dir_all(path.parent()?).ok()?;
        // Written beside and renamed, so a reader never sees half a file;
        // read-only, since editing it would change nothing.
        let temporary = path.with_extension(format!("tsl.{}", std::process::id()));
        std::fs::write(&temporary, text).ok()?;
        let mut permissions = std::fs::metadata(&temporary).ok()?.permissions();
        permissions.set_readonly(true);
        std::fs::set_permissions(&temporary, permissions).ok()?;
        std::fs::rename(&temporary, &path).ok()?;
    }
    Some(dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn incremental_edits_apply_in_order() {
        let mut doc = Document::new("float f() { return 1; }\n".into(), 1);
        let edit = |l0, c0, l1, c1, text: &str| TextDocumentContentChangeEvent {
            range: Some(Range::new(Position::new(l0, c0), Position::new(l1, c1))),
            range_length: None,
            text: text.into(),
        };
        doc.apply(vec![edit(0, 19, 0, 20, "2"), edit(0, 6, 0, 7, "g"), edit(1, 0, 1, 0, "// end\n")], 2);
        assert_eq!(doc.text, "float g() { return 2; }\n// end\n");
        assert_eq!(doc.version, 2);
        doc.apply(vec![edit(5, 0, 0, 0, "x")], 3);
        assert!(doc.text.ends_with('x'), "a range past the end inserts at the end, never panics");
    }

    #[test]
    fn documents_over_the_bound_are_refused_and_recover() {
        let whole = |text: &str| TextDocumentContentChangeEvent { range: None, range_length: None, text: text.into() };
        let insert = |text: &str| TextDocumentContentChangeEvent {
            range: Some(Range::new(Position::new(0, 0), Position::new(0, 0))),
            range_length: None,
            text: text.into(),
        };
        let mut doc = Document::new(String::new(), 1);
        // Growing by edits stops at the bound: the text is dropped, not kept.
        for (k, piece) in ["abcd", "efgh", "ijkl"].into_iter().enumerate() {
            doc.apply_within(vec![insert(piece)], k as i32 + 2, 10);
        }
        assert_eq!((doc.text.as_str(), doc.too_large), ("", Some(12)));
        doc.apply_within(vec![insert("x")], 5, 10);
        assert_eq!((doc.text.as_str(), doc.too_large), ("", Some(12)), "an edit of an unknown text is ignored");
        // A whole text over the bound, then one within it.
        doc.apply_within(vec![whole("0123456789ab")], 6, 10);
        assert_eq!((doc.text.as_str(), doc.too_large), ("", Some(12)));
        doc.apply_within(vec![whole("0123"), insert("x")], 7, 10);
        assert_eq!((doc.text.as_str(), doc.too_large, doc.version), ("x0123", None, 7));
        assert_eq!(doc.offset(Position::new(0, 9)), 5, "the index follows the text");
    }
}
