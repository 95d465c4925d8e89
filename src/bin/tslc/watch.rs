//! `tslc watch`: live preview of a scene while its files are edited.
//!
//! Each build checks the scene (printing diagnostics as `tslc check` does),
//! compiles it and renders it in passes: 1 sample per pixel, then passes
//! that double the samples taken, each averaged into the image and written
//! atomically, until the scene's `spp` (or `--spp`). A change to the scene,
//! a file it imports, or an image or mesh it reads cancels the pass in
//! progress (the renderer looks at a flag before each tile and row) and
//! starts a new build. A build that fails keeps the last good image.
//!
//! Files are watched through their directories (editors often save by
//! writing a new file and renaming it over the old one, which a watch on the
//! file itself would lose), and events are debounced. An event counts when
//! its path is one of the files the build read (`inputs`), compared whole:
//! never by file name, so the output and its temporaries are ignored and an
//! input named like the output in another folder is not. A directory that
//! is deleted and created again is watched again (`dirs`).

mod dirs;
mod inputs;

use crate::render::{SceneOptions, fail, parse_spp};
use crate::serve::Live;
use dirs::{RECHECK, WatchedDirs, Watcher};
use inputs::{Inputs, inputs_of};
use notify_debouncer_full::notify::event::{AccessKind, AccessMode, EventKind};
use notify_debouncer_full::{DebounceEventResult, new_debouncer};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};
use tsl::LoadOptions;
use tsl::image_io::{self, RenderedImage};
use tsl::render::{self, Overrides, RenderOptions, Scene};
use tsl::texture::TextureManager;

/// File events closer together than this are one change (an editor's save
/// is often a write, a rename and a change of attributes).
const DEBOUNCE: Duration = Duration::from_millis(100);

/// The files a broken build may be waiting for besides its known inputs (a
/// mesh or environment image of a scene that did not check): any with
/// these extensions appearing or changing in an input's directory starts a
/// new build, unless it is in the output's directory with the output's
/// extension (what the image writer's temporaries look like).
const SOURCE_EXTENSIONS: [&str; 7] = ["tsl", "obj", "png", "jpg", "jpeg", "hdr", "exr"];

#[derive(clap::Args)]
pub struct WatchArgs {
    /// The scene file (a .tsl file with a `scene { ... }` block).
    scene: PathBuf,
    /// The image to keep up to date: .png (8-bit sRGB) or .exr (linear float).
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    output: PathBuf,
    /// Refine up to this many samples per pixel, 1 to 1048576 (default:
    /// the scene's `spp`). Passes take 1, 1, 2, 4, ... samples.
    #[arg(long, allow_negative_numbers = true, value_parser = parse_spp)]
    spp: Option<u32>,
    #[command(flatten)]
    options: SceneOptions,
    /// Also serve a page showing the image as it refines and the
    /// diagnostics, e.g. `127.0.0.1:8000` (port 0 picks a free port). It
    /// answers only requests addressed to it by IP address and port (or
    /// `localhost:PORT` over loopback), never by another host name, so
    /// other web pages cannot read it; bound to `0.0.0.0`, by whichever
    /// address of this machine the browser connected to.
    #[arg(long, value_name = "ADDR:PORT")]
    serve: Option<SocketAddr>,
}

pub fn watch(args: WatchArgs) -> ExitCode {
    args.options.warn_old_spellings();
    if let Err(e) = image_io::prepare_output(&args.output) {
        return fail(e);
    }
    let live = match args.serve.map(Live::start).transpose() {
        Ok(live) => live,
        Err(e) => return fail(e),
    };
    if let Some(live) = &live {
        eprintln!("watch: serving http://{}/", live.address());
    }
    let mut watching = match Watching::start(&args.output) {
        Ok(w) => w,
        Err(e) => return fail(e),
    };
    loop {
        let started = Instant::now();
        let (scene, inputs) = build(&args, live.as_deref());
        // A folder created again while the build read it: read it again.
        let renewed = watching.arm(&inputs);
        if !renewed.is_empty() {
            report_change(&renewed);
            continue;
        }
        let broken = scene.is_none();
        let changed = match scene {
            Some(scene) => {
                eprintln!(
                    "watch: built in {:.2} s; rendering {}x{} up to {} spp ({} files watched)",
                    started.elapsed().as_secs_f64(),
                    scene.settings.width,
                    scene.settings.height,
                    args.spp.unwrap_or(scene.settings.spp),
                    inputs.files.len(),
                );
                let cancel = AtomicBool::new(false);
                std::thread::scope(|s| {
                    let refining = s.spawn(|| refine(&scene, &args, &cancel, live.as_deref()));
                    let changed = watching.next_change(&inputs, broken);
                    let stopping = Instant::now();
                    cancel.store(true, Ordering::Relaxed);
                    let finished = refining.is_finished();
                    let _ = refining.join();
                    if !finished {
                        eprintln!("watch: the pass in progress stopped in {:.3} s", stopping.elapsed().as_secs_f64());
                    }
                    changed
                })
            }
            None => {
                eprintln!("watch: keeping the last image; waiting for a change");
                watching.next_change(&inputs, broken)
            }
        };
        let Some(changed) = changed else {
            return fail("the file watcher stopped");
        };
        report_change(&changed);
    }
}

fn report_change(paths: &[PathBuf]) {
    let names: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    eprintln!("watch: changed: {}", names.join(", "));
}

/// Checks and compiles the scene and builds it for rendering; `None` (after
/// printing why) when any step fails.
fn build(args: &WatchArgs, live: Option<&Live>) -> (Option<Scene>, Inputs) {
    // A texture manager of its own, so a changed image is read again
    // rather than found in the cache.
    let textures = Arc::new(TextureManager::new());
    let options = LoadOptions { import_paths: args.options.include.clone(), textures, ..Default::default() };
    let checked = tsl::check_file(&args.scene, &options);
    let inputs = inputs_of(&args.scene, &checked, &args.options.include);
    eprint!("{}", crate::human_report(&checked, args.options.colors()));
    if let Some(live) = live {
        live.diagnostics(crate::human_report(&checked, tsl::diag::Colors::Never), !checked.is_ok());
    }
    if !checked.is_ok() {
        return (None, inputs);
    }
    let failed = |message: String| {
        eprint!("{message}");
        if let Some(live) = live {
            live.diagnostics(message, true);
        }
        None
    };
    let (output, scene) = ([args.output.clone()], checked.scene.as_ref());
    if let Err(e) = crate::render::refuse_overwriting_inputs(output, &checked.program, scene, tsl::diag::Colors::Never)
    {
        return (failed(e), inputs);
    }
    let program = match tsl::Compiler::new().color_model(args.options.color_model()).compile_checked(checked) {
        Ok(p) => p,
        Err(e) => return (failed(e.to_string()), inputs),
    };
    let overrides = Overrides {
        resolution: args.options.res,
        max_depth: args.options.max_depth,
        seed: args.options.seed,
        integrator: args.options.integrator,
        light_sampling: args.options.light_sampling,
        ..Default::default()
    };
    match Scene::build(&program, &overrides) {
        Ok(scene) => (Some(scene), inputs),
        Err(e) => (failed(e.to_string()), inputs),
    }
}

/// The watcher's side of the loop: its events, and the directories watched.
struct Watching<'a> {
    changes: Receiver<DebounceEventResult>,
    watcher: Watcher,
    dirs: WatchedDirs,
    output: &'a Path,
}

impl<'a> Watching<'a> {
    fn start(output: &'a Path) -> Result<Watching<'a>, String> {
        let (events, changes) = std::sync::mpsc::channel::<DebounceEventResult>();
        let watcher = new_debouncer(DEBOUNCE, None, events).map_err(|e| format!("cannot watch files: {e}"))?;
        Ok(Watching { changes, watcher, dirs: WatchedDirs::default(), output })
    }

    /// Watches the directories of `inputs`; returns those that appeared,
    /// vanished or were replaced since the last look.
    fn arm(&mut self, inputs: &Inputs) -> Vec<PathBuf> {
        self.dirs.arm(&mut self.watcher, &inputs.dirs)
    }

    /// Waits for a change to one of `inputs` (while the build is `broken`,
    /// also to a [`SOURCE_EXTENSIONS`] file in their directories), or for
    /// one of their directories to appear, vanish or be replaced; never to
    /// the output image or its temporaries. Reads are not changes: checking
    /// opens every input. `None` when the watcher has stopped.
    fn next_change(&mut self, inputs: &Inputs, broken: bool) -> Option<Vec<PathBuf>> {
        let output = inputs::key(self.output);
        let output_target = self.output.canonicalize().ok();
        let output_dir = output.parent();
        let output_extension = output.extension();
        let relevant = |p: &Path| {
            if *p == output || Some(p) == output_target.as_deref() {
                return false;
            }
            if inputs.files.contains(p) {
                return true;
            }
            let candidate = broken
                && p.extension().is_some_and(|e| SOURCE_EXTENSIONS.iter().any(|x| e.eq_ignore_ascii_case(x)))
                && p.parent().is_some_and(|dir| inputs.dirs.contains(dir));
            let like_ours = p.parent() == output_dir && p.extension() == output_extension;
            candidate && !like_ours
        };
        loop {
            let mut changed: Vec<PathBuf> = match self.changes.recv_timeout(RECHECK) {
                Ok(Ok(events)) => events
                    .into_iter()
                    .filter(|e| match e.event.kind {
                        EventKind::Access(AccessKind::Close(AccessMode::Write)) => true,
                        EventKind::Access(_) => false,
                        _ => true,
                    })
                    .flat_map(|e| {
                        for path in &e.event.paths {
                            self.dirs.note(&e.event.kind, path);
                        }
                        e.event.paths
                    })
                    .filter(|p| relevant(p))
                    .collect(),
                Ok(Err(errors)) => {
                    for e in errors {
                        eprintln!("warning: watching files: {e}");
                    }
                    Vec::new()
                }
                Err(RecvTimeoutError::Timeout) => Vec::new(),
                Err(RecvTimeoutError::Disconnected) => return None,
            };
            changed.extend(self.arm(inputs));
            changed.sort();
            changed.dedup();
            if !changed.is_empty() {
                return Some(changed);
            }
        }
    }
}

/// Renders passes of 1, 1, 2, 4, ... samples per pixel into one running
/// mean, writing the image after each, until the target or `cancel`.
fn refine(scene: &Scene, args: &WatchArgs, cancel: &AtomicBool, live: Option<&Live>) {
    let target = args.spp.unwrap_or(scene.settings.spp);
    let mut image: Option<RenderedImage> = None;
    let mut taken = 0u32;
    while taken < target {
        let pass = taken.max(1).min(target - taken);
        let options = RenderOptions {
            threads: args.options.threads,
            samples: Some(taken..taken + pass),
            cancel: Some(cancel),
            ..Default::default()
        };
        let (part, stats) = match render::render(scene, &options) {
            Ok(r) => r,
            Err(e) if e == render::CANCELLED => {
                eprintln!("watch: cancelled the pass of {pass} spp at {taken}/{target} spp");
                return;
            }
            Err(e) => {
                eprintln!("error: {e}");
                return;
            }
        };
        image = Some(match image {
            None => part,
            Some(mut sum) => {
                // A running mean, weighted by the samples each side took.
                let w = pass as f32 / (taken + pass) as f32;
                for (s, p) in sum.color.iter_mut().zip(&part.color) {
                    for c in 0..3 {
                        s[c] += (p[c] - s[c]) * w;
                    }
                }
                sum
            }
        });
        taken += pass;
        let Some(current) = &image else { return };
        if let Err(e) = image_io::write_image(&args.output, current) {
            eprintln!("error: {e}");
            return;
        }
        eprintln!(
            "watch: {taken}/{target} spp, pass of {pass} in {:.2} s; wrote {}",
            stats.seconds,
            args.output.display()
        );
        if let Some(live) = live {
            match image_io::encode_png(current) {
                Ok(png) => live.image(png, taken, target),
                Err(e) => eprintln!("error: {e}"),
            }
        }
    }
    eprintln!("watch: done; waiting for a change");
}
