//! Replacing the text of a source file the user keeps (`tslc fmt`), the
//! way careful editors save.
//!
//! A symbolic link is followed to the file it names, and that file is
//! replaced (the link stays a link, as vim and Emacs leave it). The new
//! text goes into a temporary beside the target, which gets the old file's
//! permission bits, owner and group, is synced, and is renamed over it.
//!
//! Two cases cannot be done that way without changing the file, and are
//! written in place instead, as vim's `backupcopy=auto` and gofmt do: the
//! old file's owner or group cannot be given to a new file (it belongs to
//! another user, in a shared folder we may write to; only root may give a
//! file away), or it has other hard links (a rename would split them).
//! Writing in place keeps the inode, so owner, group, mode and links stay;
//! a backup copy of the old text is made beside the file first and removed
//! once the new text is whole. A failed write puts the old text back; if
//! even that fails, the error names the backup, which is kept. A new file
//! never silently gets another owner.

use super::{FileIdentity, Temporary, reason};
use std::fs::{File, Metadata};
use std::io::{Seek, Write};
use std::path::Path;

/// How [`replace_source`] replaced a file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Replaced {
    /// A new file with the old one's mode, owner and group was renamed over
    /// it (atomic).
    Renamed,
    /// The file was rewritten in place, keeping its inode: its owner could
    /// not be given to a new file, or it has other hard links.
    InPlace,
}

/// Replaces the contents of the file `path` names (through any symbolic
/// links), which held `old`, by `new`, keeping its mode, owner, group and
/// hard links (module docs). Errors name `path`.
pub fn replace_source(path: &Path, old: &[u8], new: &[u8]) -> Result<Replaced, String> {
    let fail = |why: String| format!("cannot write {}: {why}", path.display());
    let target = std::fs::canonicalize(path).map_err(|e| fail(reason(&e)))?;
    let before = std::fs::metadata(&target).map_err(|e| fail(reason(&e)))?;
    if !before.is_file() {
        return Err(fail("it is not a regular file".into()));
    }
    let dir = target.parent().unwrap_or(Path::new("/"));
    if has_other_links(&before) {
        return in_place(path, &target, &before, old, new);
    }
    let mut tmp = Temporary::create(dir, &target, 0o600).map_err(|e| fail(reason(&e)))?;
    tmp.file().write_all(new).map_err(|e| fail(reason(&e)))?;
    match keep_owner_and_mode(tmp.file(), &before) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied => {
            drop(tmp);
            return in_place(path, &target, &before, old, new);
        }
        Err(e) => return Err(fail(reason(&e))),
    }
    tmp.file().sync_all().map_err(|e| fail(reason(&e)))?;
    tmp.persist(&target).map_err(|e| fail(reason(&e)))?;
    Ok(Replaced::Renamed)
}

#[cfg(unix)]
fn has_other_links(metadata: &Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    metadata.nlink() > 1
}

#[cfg(not(unix))]
fn has_other_links(_metadata: &Metadata) -> bool {
    false
}

/// Gives `file` the owner, group and permission bits of `before` (owner
/// and group first: changing them clears the set-id bits). Fails with
/// `PermissionDenied` when the process may not give it that owner or group.
#[cfg(unix)]
fn keep_owner_and_mode(file: &File, before: &Metadata) -> std::io::Result<()> {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    let now = file.metadata()?;
    let uid = (now.uid() != before.uid()).then_some(before.uid());
    let gid = (now.gid() != before.gid()).then_some(before.gid());
    if uid.is_some() || gid.is_some() {
        std::os::unix::fs::fchown(file, uid, gid)?;
    }
    file.set_permissions(std::fs::Permissions::from_mode(before.mode() & 0o7777))
}

#[cfg(not(unix))]
fn keep_owner_and_mode(file: &File, before: &Metadata) -> std::io::Result<()> {
    file.set_permissions(before.permissions())
}

/// Writes `new` over the file `target` in place (module docs), after a
/// backup of `old` beside it. `before`: the file's metadata, to make sure
/// the file opened is the one examined.
pub(super) fn in_place(
    path: &Path,
    target: &Path,
    before: &Metadata,
    old: &[u8],
    new: &[u8],
) -> Result<Replaced, String> {
    let fail = |why: String| format!("cannot write {}: {why}", path.display());
    let dir = target.parent().unwrap_or(Path::new("/"));
    let mut backup_name = std::ffi::OsString::from(".");
    backup_name.push(target.file_name().unwrap_or_default());
    backup_name.push(".backup-");
    // Not a registered temporary: a signal during the write below must not
    // remove the only whole copy of the text.
    let mut backup = tempfile::Builder::new()
        .prefix(&backup_name)
        .rand_bytes(super::TEMPORARY_RANDOM_CHARS)
        .tempfile_in(dir)
        .map_err(|e| fail(format!("cannot make a backup beside it: {}", reason(&e))))?;
    backup
        .write_all(old)
        .and_then(|()| backup.as_file().sync_all())
        .map_err(|e| fail(format!("cannot make a backup beside it: {}", reason(&e))))?;
    let mut file = std::fs::OpenOptions::new().write(true).open(target).map_err(|e| fail(reason(&e)))?;
    let expected = super::identity::of_metadata(target, before);
    if FileIdentity::of_open(&file).is_some_and(|id| Some(id) != expected) {
        return Err(fail("it was replaced while being formatted; nothing was written".into()));
    }
    match overwrite(&mut file, new) {
        Ok(()) => Ok(Replaced::InPlace),
        Err(e) => match overwrite(&mut file, old) {
            Ok(()) => Err(fail(reason(&e))),
            Err(_) => {
                let kept = backup.keep().map(|(_, p)| p.display().to_string()).unwrap_or_default();
                Err(fail(format!("{}; its old text is kept in {kept}", reason(&e))))
            }
        },
    }
}

/// `bytes` as the whole content of `file`, synced.
fn overwrite(file: &mut File, bytes: &[u8]) -> std::io::Result<()> {
    file.rewind()?;
    file.write_all(bytes)?;
    file.set_len(bytes.len() as u64)?;
    file.sync_all()
}
