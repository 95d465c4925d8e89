//! Open documents, positions as LSP counts them, and where files are: the
//! workspace's import directories and the prelude's files on disk.

use crate::load::{LoadOptions, PRELUDE};
use lsp_types::{Position, Range, TextDocumentContentChangeEvent, Url};
use std::path::{Path, PathBuf};

/// Line starts of a text, to convert byte offsets to LSP positions (lines
/// and UTF-16 code units, the encoding every client supports) and back.
#[derive(Debug, Clone)]
pub struct LineIndex {
    line_starts: Vec<usize>,
}

impl LineIndex {
    pub fn new(text: &str) -> LineIndex {
        let line_starts = std::iter::once(0).chain(text.match_indices('\n').map(|(i, _)| i + 1)).collect();
        LineIndex { line_starts }
    }

    /// The byte offset of a position, clamped into the text: a column past
    /// the end of its line is the line's end, a line past the end the end
    /// of the text (clients send both while edits race).
    pub fn offset(&self, text: &str, pos: Position) -> usize {
        let Some(&start) = self.line_starts.get(pos.line as usize) else {
            return text.len();
        };
        let end = self.line_starts.get(pos.line as usize + 1).map_or(text.len(), |&next| next - 1);
        let line = text.get(start..end.max(start)).unwrap_or("");
        let mut units = 0u32;
        for (i, c) in line.char_indices() {
            if units >= pos.character {
                return start + i;
            }
            units += c.len_utf16() as u32;
        }
        start + line.len()
    }

    /// The position of a byte offset (clamped to the text, and back to a
    /// character boundary).
    pub fn position(&self, text: &str, offset: usize) -> Position {
        let mut offset = offset.min(text.len());
        while !text.is_char_boundary(offset) {
            offset -= 1;
        }
        let line = self.line_starts.partition_point(|&s| s <= offset) - 1;
        let start = self.line_starts[line];
        let character = text[start..offset].chars().map(|c| c.len_utf16() as u32).sum();
        Position { line: line as u32, character }
    }

    pub fn range(&self, text: &str, start: usize, end: usize) -> Range {
        Range { start: self.position(text, start), end: self.position(text, end.max(start)) }
    }
}

/// A text document the client has open.
#[derive(Debug, Clone)]
pub struct Document {
    pub text: String,
    pub version: i32,
    pub index: LineIndex,
}

impl Document {
    pub fn new(text: String, version: i32) -> Document {
        let index = LineIndex::new(&text);
        Document { text, version, index }
    }

    /// Applies the client's changes in order: whole-text replacements and
    /// range edits (incremental sync).
    pub fn apply(&mut self, changes: Vec<TextDocumentContentChangeEvent>, version: i32) {
        for change in changes {
            match change.range {
                None => self.text = change.text,
                Some(range) => {
                    let start = self.index.offset(&self.text, range.start);
                    let end = self.index.offset(&self.text, range.end).max(start);
                    self.text.replace_range(start..end, &change.text);
                }
            }
            self.index = LineIndex::new(&self.text);
        }
        self.version = version;
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
    fn positions_count_utf16_units() {
        let text = "ab\nçd 😀e\n";
        let index = LineIndex::new(text);
        assert_eq!(index.position(text, 3), Position::new(1, 0));
        let e = text.find('e').unwrap();
        // ç and d are one unit each, the space one, the emoji two.
        assert_eq!(index.position(text, e), Position::new(1, 5));
        assert_eq!(index.offset(text, Position::new(1, 5)), e);
        assert_eq!(index.offset(text, Position::new(1, 99)), text.len() - 1, "past the line: its end");
        assert_eq!(index.offset(text, Position::new(9, 0)), text.len(), "past the text: its end");
        assert_eq!(index.position(text, e - 1), Position::new(1, 3), "inside a character: its start");
    }

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
}
