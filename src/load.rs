//! Loading a program: the root source, everything it imports, and the
//! prelude (the standard library in `stdlib/`, embedded in the binary).
//!
//! The front end's source files are read here, and images are looked for
//! here (`find_file`; the images stage after checking loads them through
//! the texture manager, and `crate::scene` reads the scene's meshes and
//! environment images). This module knows nothing of checking. Every failure (a
//! missing or unreadable file, a directory, a FIFO or device, a file over
//! [`MAX_SOURCE_BYTES`], invalid UTF-8, an empty file, an import cycle)
//! becomes a located diagnostic; loading itself never fails.

use crate::diag::{Diagnostic, FileId, SourceMap, Span};
use crate::syntax::{self, ast};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The standard library, compiled into every program as its prelude.
pub const PRELUDE: &[(&str, &str)] = &[
    ("stdlib/math.tsl", include_str!("../stdlib/math.tsl")),
    ("stdlib/sampling.tsl", include_str!("../stdlib/sampling.tsl")),
    ("stdlib/metals.tsl", include_str!("../stdlib/metals.tsl")),
    ("stdlib/materials.tsl", include_str!("../stdlib/materials.tsl")),
    ("stdlib/physical.tsl", include_str!("../stdlib/physical.tsl")),
    ("stdlib/openpbr.tsl", include_str!("../stdlib/openpbr.tsl")),
    ("stdlib/openpbr_layers.tsl", include_str!("../stdlib/openpbr_layers.tsl")),
    ("stdlib/generators.tsl", include_str!("../stdlib/generators.tsl")),
    ("stdlib/texturing.tsl", include_str!("../stdlib/texturing.tsl")),
];

/// Where imports are searched and whether the prelude is loaded.
#[derive(Debug, Clone)]
pub struct LoadOptions {
    /// Directories searched (after the importing file's own) for `import`.
    pub import_paths: Vec<PathBuf>,
    pub prelude: bool,
    /// Where images named by `texture` calls are loaded and cached.
    pub textures: std::sync::Arc<crate::texture::TextureManager>,
    /// For a one-shot tool (`tslc check`, `tslc render`): once the program
    /// checks clean, forget the types and resolutions of the scene values
    /// nothing reads again ([`crate::scene::forgettable_spans`]). Editors
    /// hover over them: off by default.
    pub lean: bool,
    /// The color model the scene description's colors are evaluated in
    /// ([`crate::Checked::scene`]): a compiler for another model describes
    /// the scene again, so a one-shot spectral render asks for its own.
    pub color_model: crate::ColorModel,
}

impl Default for LoadOptions {
    fn default() -> Self {
        LoadOptions {
            import_paths: Vec::new(),
            prelude: true,
            textures: crate::texture::TextureManager::global(),
            lean: false,
            color_model: crate::ColorModel::Rgb,
        }
    }
}

/// One parsed source file of a program.
#[derive(Debug, Clone)]
pub struct Module {
    pub file: FileId,
    /// Shared: every program holds the same prelude trees.
    pub ast: Arc<ast::SourceFile>,
    pub is_prelude: bool,
}

/// A loaded program: its sources and parsed modules, prelude first.
#[derive(Debug, Clone, Default)]
pub struct Loaded {
    pub sources: SourceMap,
    pub modules: Vec<Module>,
}

/// Loads a program whose root source text is given (from a file, standard
/// input or a host). `name` is shown in diagnostics and, when it is a path,
/// anchors relative imports.
pub fn load_source(name: &str, text: &str, options: &LoadOptions) -> (Loaded, Vec<Diagnostic>) {
    load_text(name, text.to_string(), options)
}

/// [`load_source`] keeping `text` as the program's copy of it.
fn load_text(name: &str, text: String, options: &LoadOptions) -> (Loaded, Vec<Diagnostic>) {
    let mut loader = Loader { loaded: Loaded::default(), diags: Vec::new(), by_path: HashMap::new(), options };
    if options.prelude {
        for (k, (name, text)) in PRELUDE.iter().enumerate() {
            let file = loader.loaded.sources.add(*name, *text);
            let (ast, diags) = match parsed_prelude().get(k) {
                Some(parsed) if file == FileId(k as u32) => parsed.clone(),
                _ => {
                    let (ast, diags) = syntax::parse(file, text);
                    (Arc::new(ast), diags)
                }
            };
            loader.diags.extend(diags);
            loader.loaded.modules.push(Module { file, ast, is_prelude: true });
        }
    }
    let root = loader.add_text(name, text, Path::new(name).canonicalize().ok());
    loader.resolve_imports(root);
    (loader.loaded, loader.diags)
}

/// The prelude parsed once per process. Its text is fixed and it is
/// always the first files of a program (`FileId(0)`, `FileId(1)`, ...), so
/// every program gets the same trees: cloning them costs a fraction of
/// parsing (which was two thirds of checking a small file, and of every
/// keystroke's analysis in `tslc lsp`).
fn parsed_prelude() -> &'static [(Arc<ast::SourceFile>, Vec<Diagnostic>)] {
    static PARSED: std::sync::OnceLock<Vec<(Arc<ast::SourceFile>, Vec<Diagnostic>)>> = std::sync::OnceLock::new();
    PARSED.get_or_init(|| {
        PRELUDE
            .iter()
            .enumerate()
            .map(|(k, (_, text))| {
                let (ast, diags) = syntax::parse(FileId(k as u32), text);
                (Arc::new(ast), diags)
            })
            .collect()
    })
}

/// Loads a program from a file on disk.
pub fn load_file(path: &Path, options: &LoadOptions) -> (Loaded, Vec<Diagnostic>) {
    match read_source(path) {
        Ok(text) => load_text(&path.display().to_string(), text, options),
        Err(ReadError { message, bad_utf8_at }) => {
            // The diagnostic needs a file to point into: the readable prefix.
            let mut loaded = Loaded::default();
            let shown = match bad_utf8_at {
                Some(_) => read_capped(path).map(|b| String::from_utf8_lossy(&b).into_owned()).unwrap_or_default(),
                None => String::new(),
            };
            let file = loaded.sources.add(path.display().to_string(), shown);
            let at = bad_utf8_at.unwrap_or(0);
            (loaded, vec![Diagnostic::error(Span::new(file, at, at), message)])
        }
    }
}

/// The largest source file read (256 MiB; a scene of a million spheres
/// written out is about 80 MB): a runaway generator's output stops here
/// instead of at the end of memory (and `/dev/zero` or a FIFO is refused
/// before a byte is read: [`crate::input_file::open_regular`]). `tslc check`, `tslc fmt` and
/// standard input share it.
pub const MAX_SOURCE_BYTES: u64 = 256 << 20;

/// Why a source could not be read: too large (refused before reading),
/// or the reason in words (not found, a FIFO, a device, ...).
enum CappedError {
    TooLarge,
    Unreadable(String),
}

/// At most one byte more than [`MAX_SOURCE_BYTES`] of the regular file
/// `path` (opened by [`crate::input_file::open_regular`], so a FIFO or a
/// device is refused without blocking); a file whose size is already over
/// the bound is refused without reading it.
fn read_capped(path: &Path) -> Result<Vec<u8>, CappedError> {
    use std::io::Read;
    let (file, len) = crate::input_file::open_regular(path).map_err(CappedError::Unreadable)?;
    if len > MAX_SOURCE_BYTES {
        return Err(CappedError::TooLarge);
    }
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(MAX_SOURCE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| CappedError::Unreadable(crate::input_file::reason(&e)))?;
    Ok(bytes)
}

/// Reads a source file exactly as `tslc check` reads one (a directory or
/// a special file refused, at most [`MAX_SOURCE_BYTES`], UTF-8), for tools
/// such as `tslc fmt`. The error says what is wrong, naming `path`.
pub fn read_source_file(path: &Path) -> Result<String, String> {
    read_source(path).map_err(|e| e.message)
}

struct ReadError {
    message: String,
    bad_utf8_at: Option<usize>,
}

fn read_source(path: &Path) -> Result<String, ReadError> {
    let plain = |message: String| ReadError { message, bad_utf8_at: None };
    if path.is_dir() {
        return Err(plain(format!("`{}` is a directory, not a .tsl file", path.display())));
    }
    let too_large = || {
        plain(format!(
            "`{}` is larger than {} MiB, the most a source file may be",
            path.display(),
            MAX_SOURCE_BYTES >> 20
        ))
    };
    let bytes = read_capped(path).map_err(|e| match e {
        CappedError::TooLarge => too_large(),
        CappedError::Unreadable(why) => plain(format!("cannot read `{}`: {why}", path.display())),
    })?;
    if bytes.len() as u64 > MAX_SOURCE_BYTES {
        return Err(too_large());
    }
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        ReadError {
            message: format!("`{}` is not valid UTF-8 (bad byte at offset {at})", path.display()),
            bad_utf8_at: Some(at),
        }
    })
}

struct Loader<'o> {
    loaded: Loaded,
    diags: Vec<Diagnostic>,
    /// Canonical path to module index, so each file is loaded once.
    by_path: HashMap<PathBuf, usize>,
    options: &'o LoadOptions,
}

impl Loader<'_> {
    fn add_text(&mut self, name: &str, text: String, canonical: Option<PathBuf>) -> usize {
        // The source map keeps the text; parsing reads that copy.
        let file = self.loaded.sources.add(name, text);
        let text = self.loaded.sources.text(file);
        if text.trim().is_empty() {
            self.diags.push(
                Diagnostic::error(Span::new(file, 0, 0), "the file is empty")
                    .with_help("a .tsl file holds functions, materials, material trees or a scene"),
            );
        }
        let (ast, diags) = syntax::parse(file, text);
        self.diags.extend(diags);
        self.loaded.modules.push(Module { file, ast: Arc::new(ast), is_prelude: false });
        let index = self.loaded.modules.len() - 1;
        if let Some(p) = canonical {
            self.by_path.insert(p, index);
        }
        index
    }

    /// Loads every import reachable from `root`, breadth first, and reports
    /// import cycles. Iterative, so long import chains cannot overflow.
    fn resolve_imports(&mut self, root: usize) {
        let mut edges: Vec<(usize, usize, Span)> = Vec::new();
        let mut queue = vec![root];
        while let Some(index) = queue.pop() {
            let module = &self.loaded.modules[index];
            let file = module.file;
            let imports: Vec<(String, Span)> = module
                .ast
                .items
                .iter()
                .filter_map(|i| match i {
                    ast::Item::Import { path, span } => Some((path.clone(), *span)),
                    _ => None,
                })
                .collect();
            let base = Path::new(self.loaded.sources.name(file)).parent().map(Path::to_path_buf);
            for (path, span) in imports {
                let Some(found) = find_file(base.as_deref(), &path, &self.options.import_paths) else {
                    let searched = searched(base.as_deref(), &self.options.import_paths);
                    self.diags.push(
                        Diagnostic::error(span, format!("cannot find imported file `{path}`"))
                            .with_help(format!("searched {searched}; add a directory with -I")),
                    );
                    continue;
                };
                let canonical = found.canonicalize().unwrap_or_else(|_| found.clone());
                let target = match self.by_path.get(&canonical) {
                    Some(&t) => t,
                    None => match read_source(&found) {
                        Ok(text) => {
                            let t = self.add_text(&found.display().to_string(), text, Some(canonical));
                            queue.push(t);
                            t
                        }
                        Err(e) => {
                            self.diags.push(Diagnostic::error(span, e.message));
                            continue;
                        }
                    },
                };
                edges.push((index, target, span));
            }
        }
        self.report_cycles(&edges);
    }

    /// Finds cycles in the import graph with an iterative depth-first search
    /// and reports each once, at the import that closes it.
    fn report_cycles(&mut self, edges: &[(usize, usize, Span)]) {
        let n = self.loaded.modules.len();
        let mut out: Vec<Vec<(usize, Span)>> = vec![Vec::new(); n];
        for &(from, to, span) in edges {
            out[from].push((to, span));
        }
        // 0 = unvisited, 1 = on the stack, 2 = done.
        let mut state = vec![0u8; n];
        for start in 0..n {
            if state[start] != 0 {
                continue;
            }
            let mut stack: Vec<(usize, usize)> = vec![(start, 0)];
            state[start] = 1;
            while let Some(&mut (node, ref mut next)) = stack.last_mut() {
                if let Some(&(to, span)) = out[node].get(*next) {
                    *next += 1;
                    match state[to] {
                        0 => {
                            state[to] = 1;
                            stack.push((to, 0));
                        }
                        1 => {
                            let pos = stack.iter().position(|&(m, _)| m == to).unwrap_or(0);
                            let mut names: Vec<&str> = stack[pos..]
                                .iter()
                                .map(|&(m, _)| self.loaded.sources.name(self.loaded.modules[m].file))
                                .collect();
                            names.push(self.loaded.sources.name(self.loaded.modules[to].file));
                            self.diags.push(
                                Diagnostic::error(span, "import cycle")
                                    .with_primary("this import closes the cycle")
                                    .with_note(format!("cycle: {}", names.join(" -> ")))
                                    .with_help("move what both files need into a third file that both import"),
                            );
                        }
                        _ => {}
                    }
                } else {
                    state[node] = 2;
                    stack.pop();
                }
            }
        }
    }
}

/// `path` as given when absolute, else the first of `base` and then the
/// search directories holding it (the current directory when there is no
/// base).
pub(crate) fn find_file(base: Option<&Path>, path: &str, search: &[PathBuf]) -> Option<PathBuf> {
    find_where(base, path, search, |p| p.is_file())
}

/// [`find_file`]'s search order with another test of a place: the first
/// of `path` itself (absolute), under `base`, under each of `search`, or
/// as given (without a base) that passes `found`.
pub(crate) fn find_where(
    base: Option<&Path>,
    path: &str,
    search: &[PathBuf],
    mut found: impl FnMut(&Path) -> bool,
) -> Option<PathBuf> {
    let direct = Path::new(path);
    if direct.is_absolute() {
        return found(direct).then(|| direct.to_path_buf());
    }
    base.into_iter()
        .chain(search.iter().map(PathBuf::as_path))
        .map(|dir| dir.join(path))
        .find(|p| found(p))
        .or_else(|| (base.is_none() && found(direct)).then(|| direct.to_path_buf()))
}

/// The directories `find_file` searched, for a message.
pub(crate) fn searched(base: Option<&Path>, search: &[PathBuf]) -> String {
    let mut dirs: Vec<String> = base.iter().map(|b| format!("`{}`", display_dir(b))).collect();
    dirs.extend(search.iter().map(|d| format!("`{}`", display_dir(d))));
    if dirs.is_empty() { "the current directory".into() } else { dirs.join(", ") }
}

fn display_dir(p: &Path) -> String {
    if p.as_os_str().is_empty() { ".".into() } else { p.display().to_string() }
}
