//! Keeping the folders `tslc watch` reads from watched while they are
//! deleted, moved and created again (a `git checkout`, a script that
//! regenerates a folder).
//!
//! A watch follows a directory, not its path (inotify watches an inode):
//! once the directory is deleted the watch is gone, and once it is moved
//! the watch reports under the old name. So every wanted directory is
//! looked at again after each batch of events and every [`RECHECK`]: one
//! that is missing is waited for through a watch on its nearest existing
//! ancestor, and one that appeared, vanished or was replaced (another
//! device, inode or birth time, or events that removed or renamed it) is
//! watched again and reported, since its files may have changed unseen.

use notify_debouncer_full::notify::event::{EventKind, ModifyKind};
use notify_debouncer_full::notify::{RecommendedWatcher, RecursiveMode};
use notify_debouncer_full::{Debouncer, RecommendedCache};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

/// How often the wanted directories are looked at when no event comes (a
/// directory above them moved away gives no event in them).
pub const RECHECK: Duration = Duration::from_secs(1);

/// The most times one look sets watches before it settles (each round
/// goes one level deeper into directories being created meanwhile).
const MAX_ROUNDS: usize = 32;

pub type Watcher = Debouncer<RecommendedWatcher, RecommendedCache>;

/// Which directory a path names right now.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
struct DirId {
    device: u64,
    inode: u64,
    /// Inode numbers are reused at once on some file systems.
    born: Option<SystemTime>,
}

#[cfg(unix)]
fn identity(dir: &Path) -> Option<DirId> {
    use std::os::unix::fs::MetadataExt;
    let meta = std::fs::metadata(dir).ok().filter(|m| m.is_dir())?;
    Some(DirId { device: meta.dev(), inode: meta.ino(), born: meta.created().ok() })
}

/// Without inode numbers, a directory is told apart by its birth time.
#[cfg(not(unix))]
fn identity(dir: &Path) -> Option<DirId> {
    let meta = std::fs::metadata(dir).ok().filter(|m| m.is_dir())?;
    Some(DirId { device: 0, inode: 0, born: meta.created().ok() })
}

/// `dir`, or its nearest ancestor that exists.
fn nearest_existing(dir: &Path) -> &Path {
    let mut at = dir;
    while identity(at).is_none() {
        match at.parent() {
            Some(parent) => at = parent,
            None => break,
        }
    }
    at
}

/// The directories watched for one `tslc watch`.
#[derive(Default)]
pub struct WatchedDirs {
    /// Each directory watched, and the one its path named when the watch was set.
    armed: HashMap<PathBuf, Option<DirId>>,
    /// Each wanted directory, and the one its path named at the last look
    /// (`None`: missing).
    seen: HashMap<PathBuf, Option<DirId>>,
    /// Directories that events removed or renamed since the last look.
    suspect: HashSet<PathBuf>,
    /// Directories that could not be watched (said once).
    failed: HashSet<PathBuf>,
}

impl WatchedDirs {
    /// Notes an event: one that removes or renames a watched directory, or
    /// a directory above it, makes it suspect until the next look.
    pub fn note(&mut self, kind: &EventKind, path: &Path) {
        if matches!(kind, EventKind::Remove(_) | EventKind::Modify(ModifyKind::Name(_))) {
            let under = self.armed.keys().chain(self.seen.keys()).filter(|d| d.starts_with(path));
            let under: Vec<PathBuf> = under.cloned().collect();
            self.suspect.extend(under);
        }
    }

    /// Watches each of `wanted` or, while it is missing, its nearest
    /// existing ancestor, and stops watching the rest. Returns the wanted
    /// directories that appeared, vanished or were replaced since the last
    /// look (none the first time one is wanted).
    pub fn arm(&mut self, watcher: &mut Watcher, wanted: &HashSet<PathBuf>) -> Vec<PathBuf> {
        let suspect = std::mem::take(&mut self.suspect);
        for round in 0..MAX_ROUNDS {
            let targets: HashMap<PathBuf, Option<DirId>> = wanted
                .iter()
                .map(|dir| {
                    let at = nearest_existing(dir);
                    (at.to_path_buf(), identity(at))
                })
                .collect();
            let stale: Vec<PathBuf> = self
                .armed
                .iter()
                .filter(|(dir, id)| targets.get(*dir) != Some(id) || (round == 0 && suspect.contains(*dir)))
                .map(|(dir, _)| dir.clone())
                .collect();
            for dir in stale {
                // Fails when the watcher already dropped it (the directory went).
                let _ = watcher.unwatch(&dir);
                self.armed.remove(&dir);
            }
            let mut added = false;
            for (dir, id) in targets {
                if self.armed.contains_key(&dir) {
                    continue;
                }
                match watcher.watch(&dir, RecursiveMode::NonRecursive) {
                    Ok(()) => {
                        self.failed.remove(&dir);
                        self.armed.insert(dir, id);
                        added = true;
                    }
                    Err(e) => {
                        if self.failed.insert(dir.clone()) {
                            eprintln!("warning: cannot watch {}: {e}", dir.display());
                        }
                    }
                }
            }
            // A directory may have appeared before its ancestor's watch was
            // set, unseen: look again until nothing new is watched.
            if !added {
                break;
            }
        }
        let mut changed = Vec::new();
        for dir in wanted {
            let now = identity(dir);
            if let Some(before) = self.seen.insert(dir.clone(), now)
                && (before != now || suspect.contains(dir))
            {
                changed.push(dir.clone());
            }
        }
        self.seen.retain(|dir, _| wanted.contains(dir));
        changed.sort();
        changed
    }
}
