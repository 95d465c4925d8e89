//! Which file a path names, as the file system sees it: two paths name
//! the same file when they lead to the same device and inode, whatever
//! the spelling (`a/../b`, a symbolic link, a hard link).

use std::path::Path;

/// A file's identity: its device and inode (on other systems, its
/// canonical path).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct FileIdentity(Inner);

#[cfg(unix)]
type Inner = (u64, u64);
#[cfg(not(unix))]
type Inner = std::path::PathBuf;

impl FileIdentity {
    /// The identity of the file `path` leads to, following symbolic links;
    /// `None` when there is none (or it cannot be reached).
    pub fn of(path: &Path) -> Option<FileIdentity> {
        of_metadata(path, &std::fs::metadata(path).ok()?)
    }

    /// The identity of the directory entry `path` itself: a symbolic link's
    /// own, not its target's.
    pub fn of_entry(path: &Path) -> Option<FileIdentity> {
        of_metadata(path, &std::fs::symlink_metadata(path).ok()?)
    }

    /// Both identities of `path` (the entry's and, for a symbolic link, its
    /// target's), the ones that exist: writing over `path` replaces the
    /// entry, and a writer that follows links changes the target.
    pub fn all_of(path: &Path) -> Vec<FileIdentity> {
        // One call for the common cases (no such file, a plain file).
        let Ok(entry) = std::fs::symlink_metadata(path) else { return Vec::new() };
        let ids = [of_metadata(path, &entry), entry.file_type().is_symlink().then(|| Self::of(path)).flatten()];
        ids.into_iter().flatten().collect()
    }

    /// The identity of an open file (unix only: elsewhere `None`).
    pub fn of_open(file: &std::fs::File) -> Option<FileIdentity> {
        #[cfg(unix)]
        return of_metadata(Path::new(""), &file.metadata().ok()?);
        #[cfg(not(unix))]
        return {
            let _ = file;
            None
        };
    }
}

/// The identity `metadata` (of `path`) gives.
#[cfg(unix)]
pub(super) fn of_metadata(_path: &Path, metadata: &std::fs::Metadata) -> Option<FileIdentity> {
    use std::os::unix::fs::MetadataExt;
    Some(FileIdentity((metadata.dev(), metadata.ino())))
}

/// Without inodes: the canonical path (`metadata` does not hold one).
#[cfg(not(unix))]
pub(super) fn of_metadata(path: &Path, _metadata: &std::fs::Metadata) -> Option<FileIdentity> {
    path.canonicalize().ok().map(FileIdentity)
}
