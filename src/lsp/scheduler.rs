//! Diagnostics off the main loop: a small pool of workers checks
//! documents, at most one check of a document at a time, so a document
//! whose check is slow (a huge text, a scene reading a large mesh) holds
//! one worker and never the diagnostics of the others.
//!
//! Each document has a slot: the latest work asked for it (newer work
//! replaces older work not yet started), the cancellation flag of its
//! running check, and a generation that every open, change, save and
//! close advances. A change cancels the running check
//! (`tsl::check_source_cancellable` stops at its next phase), and a
//! result is published only while its generation is the slot's, under
//! the slot's lock: the diagnostics of a stale version are never
//! published, nor any after a close.

use super::diagnostics;
use super::documents::Workspace;
use crate::LoadOptions;
use crate::scene::SceneDesc;
use crossbeam_channel::Sender;
use lsp_server::{Message, Notification};
use lsp_types::notification::Notification as _;
use lsp_types::{Diagnostic, DiagnosticSeverity, PublishDiagnosticsParams, Url, notification};
use std::collections::{HashMap, VecDeque};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::SystemTime;

/// How many documents are checked at once: one slow document (or two)
/// leaves a worker for the others. Each check is single-threaded.
pub const DIAGNOSTICS_WORKERS: usize = 3;

/// What to publish for a version of a document.
pub enum Work {
    /// Its text, to be checked as `tslc check` would.
    Check(String),
    /// These diagnostics as they are: none for a prelude file, why a
    /// document over the size bound is not checked.
    Publish(Vec<Diagnostic>),
}

struct Job {
    generation: u64,
    version: i32,
    work: Work,
}

/// The scene of a document's last check and when that check started:
/// its meshes and environment image are reused while their files are
/// unchanged (a 1M-triangle mesh takes seconds to read). Texture images
/// are decoded again: the texture manager's cache cannot tell a file
/// that changed.
type LastScene = (SceneDesc, SystemTime);

#[derive(Default)]
struct Slot {
    /// Work asked for before this generation is stale.
    generation: u64,
    pending: Option<Job>,
    /// Whether the document is in the queue.
    queued: bool,
    /// The cancellation flag of its running check.
    running: Option<Arc<AtomicBool>>,
    last_scene: Option<LastScene>,
}

#[derive(Default)]
struct State {
    slots: HashMap<Url, Slot>,
    /// Documents with pending work, oldest first.
    queue: VecDeque<Url>,
    next_generation: u64,
    stopping: bool,
}

impl State {
    /// Starts a new generation of a document's slot: work asked before is
    /// dropped, or cancelled if running.
    fn advance(&mut self, uri: &Url) -> (u64, &mut Slot) {
        self.next_generation += 1;
        let generation = self.next_generation;
        let slot = self.slots.entry(uri.clone()).or_default();
        slot.generation = generation;
        slot.pending = None;
        if let Some(running) = &slot.running {
            running.store(true, Ordering::Relaxed);
        }
        (generation, slot)
    }

    /// The oldest pending work of a document not being checked, marked
    /// as running.
    fn take_runnable(&mut self) -> Option<(Url, Job, Arc<AtomicBool>, Option<LastScene>)> {
        let slots = &mut self.slots;
        // Documents closed or superseded since they were queued leave.
        self.queue.retain(|uri| match slots.get_mut(uri) {
            Some(slot) if slot.pending.is_some() => true,
            Some(slot) => {
                slot.queued = false;
                false
            }
            None => false,
        });
        let k = self.queue.iter().position(|uri| slots.get(uri).is_some_and(|s| s.running.is_none()))?;
        let uri = self.queue.remove(k)?;
        let slot = slots.get_mut(&uri)?;
        let job = slot.pending.take()?;
        let cancel = Arc::new(AtomicBool::new(false));
        slot.queued = false;
        slot.running = Some(cancel.clone());
        Some((uri, job, cancel, slot.last_scene.take()))
    }
}

struct Shared {
    state: Mutex<State>,
    wake: Condvar,
    sender: Sender<Message>,
    workspace: Arc<Workspace>,
    options: LoadOptions,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn publish(&self, uri: Url, diagnostics: Vec<Diagnostic>, version: Option<i32>) {
        let params = PublishDiagnosticsParams { uri, diagnostics, version };
        let _ = self.sender.send(Notification::new(notification::PublishDiagnostics::METHOD.into(), params).into());
    }
}

/// The pool of diagnostics workers and the documents' slots.
pub struct Scheduler {
    shared: Arc<Shared>,
    workers: Vec<JoinHandle<()>>,
}

impl Scheduler {
    pub fn new(sender: Sender<Message>, workspace: Arc<Workspace>, options: LoadOptions) -> Scheduler {
        let shared = Arc::new(Shared { state: Mutex::default(), wake: Condvar::new(), sender, workspace, options });
        let workers = (0..DIAGNOSTICS_WORKERS)
            .filter_map(|k| {
                let shared = shared.clone();
                std::thread::Builder::new()
                    .name(format!("tslc-lsp-diagnostics-{k}"))
                    .stack_size(64 << 20)
                    .spawn(move || work(&shared))
                    .ok()
            })
            .collect();
        Scheduler { shared, workers }
    }

    /// A document changed: the work asked for it before is stale and its
    /// running check is cancelled (its new text is submitted later, once
    /// the typing pauses).
    pub fn supersede(&self, uri: &Url) {
        self.shared.lock().advance(uri);
    }

    /// Asks for `work` on `version` of a document, in place of any older.
    pub fn submit(&self, uri: &Url, version: i32, work: Work) {
        let mut state = self.shared.lock();
        let (generation, slot) = state.advance(uri);
        slot.pending = Some(Job { generation, version, work });
        if !std::mem::replace(&mut slot.queued, true) {
            state.queue.push_back(uri.clone());
        }
        drop(state);
        self.shared.wake.notify_one();
    }

    /// A document closed: its work is cancelled and its diagnostics
    /// cleared.
    pub fn close(&self, uri: &Url) {
        let mut state = self.shared.lock();
        state.advance(uri);
        state.slots.remove(uri);
        // Under the lock, so no worker publishes after it.
        self.shared.publish(uri.clone(), Vec::new(), None);
    }

    /// Stops the workers, cancelling their checks.
    pub fn stop(&mut self) {
        let mut state = self.shared.lock();
        state.stopping = true;
        for slot in state.slots.values() {
            if let Some(running) = &slot.running {
                running.store(true, Ordering::Relaxed);
            }
        }
        drop(state);
        self.shared.wake.notify_all();
        for worker in self.workers.drain(..) {
            let _ = worker.join();
        }
    }
}

impl Drop for Scheduler {
    fn drop(&mut self) {
        self.stop();
    }
}

/// A worker: takes the oldest runnable work, does it outside the lock,
/// and publishes the result if it is still the document's latest.
fn work(shared: &Shared) {
    loop {
        let (uri, job, cancel, last_scene) = {
            let mut state = shared.lock();
            loop {
                if state.stopping {
                    return;
                }
                if let Some(found) = state.take_runnable() {
                    break found;
                }
                state = shared.wake.wait(state).unwrap_or_else(PoisonError::into_inner);
            }
        };
        let (diagnostics, scene) = match job.work {
            Work::Publish(diagnostics) => (Some(diagnostics), None),
            Work::Check(text) => {
                let previous = last_scene.as_ref().filter(|(scene, at)| unchanged_scene(scene, *at)).map(|s| &s.0);
                match check(shared, &uri, &text, previous, &cancel) {
                    Some((diagnostics, scene)) => (Some(diagnostics), scene),
                    None => (None, None),
                }
            }
        };
        let mut state = shared.lock();
        // The slot is this check's unless the document was closed (and
        // maybe opened again) meanwhile.
        let mine = state.slots.get_mut(&uri).filter(|s| s.running.as_ref().is_some_and(|r| Arc::ptr_eq(r, &cancel)));
        if let Some(slot) = mine {
            slot.running = None;
            // The last scene described stays while the text has errors:
            // its files are reused once it is fixed.
            slot.last_scene = scene.or(last_scene);
            if let Some(diagnostics) = diagnostics.filter(|_| slot.generation == job.generation) {
                shared.publish(uri, diagnostics, Some(job.version));
            }
        }
        drop(state);
        // Work of this document may wait for this check to end.
        shared.wake.notify_all();
    }
}

/// The diagnostics of a text and the scene it describes, or `None` when
/// the check was cancelled. A panic is reported as a diagnostic.
fn check(
    shared: &Shared,
    uri: &Url,
    text: &str,
    previous: Option<&SceneDesc>,
    cancel: &AtomicBool,
) -> Option<(Vec<Diagnostic>, Option<LastScene>)> {
    let name = Workspace::source_name(uri);
    let run = || {
        let started = SystemTime::now();
        let cancelled = || cancel.load(Ordering::Relaxed);
        let checked = crate::check_source_cancellable(&name, text, &shared.options, previous, &cancelled)?;
        let shown = diagnostics::diagnostics(&shared.workspace, &checked, text);
        Some((shown, checked.scene.map(|scene| (scene, started))))
    };
    catch_unwind(AssertUnwindSafe(run)).unwrap_or_else(|panic| {
        let message = format!("internal error in tslc (please report it): {}", super::panic_message(&*panic));
        let diagnostic = Diagnostic {
            message,
            severity: Some(DiagnosticSeverity::ERROR),
            source: Some("tslc".into()),
            ..Diagnostic::default()
        };
        Some((vec![diagnostic], None))
    })
}

/// Whether a scene's mesh and environment files have not been modified
/// since `started`.
fn unchanged_scene(scene: &SceneDesc, started: SystemTime) -> bool {
    let meshes = scene.objects.iter().filter_map(|o| match &o.shape {
        crate::scene::ShapeDesc::Mesh { file } => Some(file.value.path.clone()),
        _ => None,
    });
    let environment = scene.environment.iter().filter_map(|e| match &e.source {
        crate::scene::EnvironmentSourceDesc::Image(image) => Some(image.value.path.clone()),
        crate::scene::EnvironmentSourceDesc::Constant(_) => None,
    });
    let unchanged =
        |path: std::path::PathBuf| std::fs::metadata(path).and_then(|m| m.modified()).is_ok_and(|t| t < started);
    meshes.chain(environment).all(unchanged)
}
