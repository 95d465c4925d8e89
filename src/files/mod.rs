//! The files tslc creates beside a user's: the temporary an output is
//! written to before it replaces its target, the probe that checks an
//! output can be written before any work starts, and the replacement of a
//! formatted source file ([`replace_source`]). File identity, for "is this
//! output one of the inputs?", is here too ([`FileIdentity`]).
//!
//! Invariants. Every file created here has a name nobody can predict
//! (`.NAME.tmp-` and [`TEMPORARY_RANDOM_CHARS`] random letters and digits)
//! and is created exclusively (`O_CREAT | O_EXCL`: creation fails rather
//! than follow a link planted at that name), so another user of a shared,
//! group-writable folder cannot redirect a write into a file of their
//! choosing. A target is replaced whole (written, synced, renamed over
//! it), so a crash or a signal leaves the old file or the new one, never a
//! mix; the temporary being written is registered, so the SIGINT/SIGTERM
//! handler can remove it ([`remove_temporaries`]). Writers get the open
//! file, never the temporary's path: nothing opens that name a second time.
//!
//! Architecture invariant: a leaf, like `image_io` (which writes through
//! it); it knows nothing of images, sources or scenes.

mod identity;
mod replace;

pub use identity::FileIdentity;
pub use replace::{Replaced, replace_source};

use std::ffi::OsString;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use tempfile::NamedTempFile;

/// How many random letters and digits a temporary's name has: 62^12, about
/// 3 x 10^21 names, so guessing the next one is hopeless (and a guess would
/// only make the exclusive creation fail and retry, never redirect it).
pub const TEMPORARY_RANDOM_CHARS: usize = 12;

/// The mode a new output is created with, before the umask: what
/// `File::create` gives (0666 less the umask), so an image in a shared
/// folder is as readable to the group as any file the user makes there.
#[cfg(unix)]
const OUTPUT_MODE: u32 = 0o666;

/// Creates the directory `target` is to be written into, and those above
/// it, when they do not exist (as `mkdir -p`): `-o out/shot.exr` makes
/// `out/`. An error names the directory and `target`.
pub fn create_directory_of(target: &Path) -> Result<(), String> {
    match target.parent() {
        Some(dir) if !dir.as_os_str().is_empty() && !dir.is_dir() => std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create the directory {} for {}: {e}", dir.display(), target.display())),
        _ => Ok(()),
    }
}

/// The directory `target` is written into; an error naming `target` when
/// it does not exist.
pub fn directory_of(target: &Path) -> Result<PathBuf, String> {
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(format!("cannot write {}: the directory {} does not exist", target.display(), dir.display()));
    }
    Ok(dir)
}

/// The start of the name of every temporary made for `target`:
/// `.NAME.tmp-`.
fn temporary_prefix(target: &Path) -> OsString {
    let mut prefix = OsString::from(".");
    prefix.push(target.file_name().unwrap_or_default());
    prefix.push(".tmp-");
    prefix
}

/// Whether `candidate` is a temporary made for `target` by this module:
/// in the same directory, named `.NAME.tmp-` and the random part. For a
/// file watcher that must not take tslc's own writes for a change.
pub fn is_temporary_for(target: &Path, candidate: &Path) -> bool {
    let (Some(name), Some(dir)) = (candidate.file_name(), candidate.parent()) else { return false };
    let prefix = temporary_prefix(target);
    let Some(random) = name.as_encoded_bytes().strip_prefix(prefix.as_encoded_bytes()) else { return false };
    let target_dir = target.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let same_dir =
        dir == target_dir || (dir.canonicalize().ok()).is_some_and(|d| target_dir.canonicalize().is_ok_and(|t| t == d));
    same_dir && random.len() == TEMPORARY_RANDOM_CHARS && random.iter().all(u8::is_ascii_alphanumeric)
}

/// Temporaries being written, for [`remove_temporaries`].
static TEMPORARIES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Removes the temporary file of every write in progress: for a signal
/// handler, just before the process exits (`tslc` installs one for SIGINT
/// and SIGTERM), so an interrupted write leaves neither a truncated target
/// (writes are atomic) nor litter.
pub fn remove_temporaries() {
    if let Ok(mut pending) = TEMPORARIES.lock() {
        for tmp in pending.drain(..) {
            let _ = std::fs::remove_file(&tmp);
        }
    }
}

/// A new, empty temporary beside a target, created exclusively under an
/// unpredictable name and registered for [`remove_temporaries`] until
/// dropped (which removes it) or persisted.
struct Temporary {
    file: NamedTempFile,
    _registered: Registration,
}

/// A temporary's place in [`TEMPORARIES`], given up when dropped.
struct Registration(PathBuf);

impl Drop for Registration {
    fn drop(&mut self) {
        if let Ok(mut pending) = TEMPORARIES.lock() {
            pending.retain(|p| *p != self.0);
        }
    }
}

impl Temporary {
    /// In `dir`, named for `target`; `mode`: the permission bits it is
    /// created with, before the umask (unix only).
    fn create(dir: &Path, target: &Path, #[cfg_attr(not(unix), allow(unused))] mode: u32) -> std::io::Result<Self> {
        let prefix = temporary_prefix(target);
        let mut builder = tempfile::Builder::new();
        builder.prefix(&prefix).rand_bytes(TEMPORARY_RANDOM_CHARS);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            builder.permissions(std::fs::Permissions::from_mode(mode));
        }
        let file = builder.tempfile_in(dir)?;
        let path = file.path().to_path_buf();
        if let Ok(mut pending) = TEMPORARIES.lock() {
            pending.push(path.clone());
        }
        Ok(Temporary { file, _registered: Registration(path) })
    }

    fn file(&mut self) -> &mut File {
        self.file.as_file_mut()
    }

    /// Renames the temporary over `target`.
    fn persist(self, target: &Path) -> std::io::Result<()> {
        self.file.persist(target).map(drop).map_err(|e| e.error)
    }
}

/// An I/O error in words, without the temporary's path (which the user
/// never named: messages name their path instead).
fn reason(e: &std::io::Error) -> String {
    match e.raw_os_error() {
        Some(code) => std::io::Error::from_raw_os_error(code).to_string(),
        None => e.kind().to_string(),
    }
}

/// Whether a file can be created beside `target`, checked before any work:
/// its directory exists and a probe (a temporary, as [`atomic_write`]
/// makes) can be created there and is removed at once. Errors name
/// `target`.
pub fn check_writable(target: &Path) -> Result<(), String> {
    let dir = directory_of(target)?;
    Temporary::create(&dir, target, 0o600)
        .map(drop)
        .map_err(|e| format!("cannot write {}: {}", target.display(), reason(&e)))
}

/// Writes `target` atomically: `write` fills a new temporary beside it
/// (given the open file; a reason on failure), which is synced and renamed
/// over `target`. On failure the temporary is removed and `target` is
/// untouched; the error names `target`. A symbolic link at `target` is
/// replaced, not followed. A new file's mode is 0666 less the umask, as
/// for any file the user creates.
pub fn atomic_write(target: &Path, write: impl FnOnce(&mut File) -> Result<(), String>) -> Result<(), String> {
    let fail = |why: String| format!("cannot write {}: {why}", target.display());
    let dir = directory_of(target)?;
    #[cfg(unix)]
    let mode = OUTPUT_MODE;
    #[cfg(not(unix))]
    let mode = 0;
    let mut tmp = Temporary::create(&dir, target, mode).map_err(|e| fail(reason(&e)))?;
    write(tmp.file()).map_err(fail)?;
    tmp.file().sync_all().map_err(|e| fail(reason(&e)))?;
    tmp.persist(target).map_err(|e| fail(reason(&e)))
}

#[cfg(test)]
mod tests;
