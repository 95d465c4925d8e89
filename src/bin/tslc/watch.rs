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
//! file itself would lose), and events are debounced.

use crate::render::{SceneOptions, fail, parse_spp};
use crate::serve::Live;
use notify_debouncer_full::notify::RecursiveMode;
use notify_debouncer_full::notify::event::{AccessKind, AccessMode, EventKind};
use notify_debouncer_full::{DebounceEventResult, new_debouncer};
use std::collections::HashSet;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};
use tsl::image_io::{self, RenderedImage};
use tsl::render::{self, Overrides, RenderOptions, Scene};
use tsl::scene::{EnvironmentSourceDesc, ShapeDesc};
use tsl::texture::TextureManager;
use tsl::{Checked, LoadOptions};

/// File events closer together than this are one change (an editor's save
/// is often a write, a rename and a change of attributes).
const DEBOUNCE: Duration = Duration::from_millis(100);

/// The files a broken build may be waiting for besides its known inputs (a
/// missing import, image or mesh): any with these extensions appearing or
/// changing in a watched directory starts a new build.
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
    /// diagnostics, e.g. `127.0.0.1:8000` (port 0 picks a free port).
    #[arg(long, value_name = "ADDR:PORT")]
    serve: Option<SocketAddr>,
}

/// The files one build read: a change to any of them starts a new build.
#[derive(Default)]
struct Inputs {
    /// Each file as its watched directory names it (and, for a symbolic
    /// link, its target too).
    files: HashSet<PathBuf>,
    /// The directories watched, canonical.
    dirs: HashSet<PathBuf>,
}

impl Inputs {
    fn add(&mut self, path: &Path) {
        let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
        let (Some(dir), Some(name)) = (absolute.parent(), absolute.file_name()) else { return };
        let Ok(dir) = dir.canonicalize() else { return };
        self.files.insert(dir.join(name));
        if let Ok(target) = absolute.canonicalize() {
            if let Some(target_dir) = target.parent() {
                self.dirs.insert(target_dir.to_path_buf());
            }
            self.files.insert(target);
        }
        self.dirs.insert(dir);
    }
}

/// The scene, its imports, the images its `texture` calls read (or would
/// read, when missing), its meshes and its environment image.
fn inputs_of(scene: &Path, checked: &Checked) -> Inputs {
    let mut inputs = Inputs::default();
    inputs.add(scene);
    let program = &checked.program;
    let sources = &program.loaded.sources;
    for module in program.loaded.modules.iter().filter(|m| !m.is_prelude) {
        inputs.add(Path::new(sources.name(module.file)));
    }
    for image in &program.images {
        match &image.image {
            Some(loaded) => inputs.add(Path::new(&loaded.name)),
            None => {
                let base = Path::new(sources.name(image.span.file)).parent().unwrap_or(Path::new(""));
                inputs.add(&base.join(&image.path));
            }
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

pub fn watch(args: WatchArgs) -> ExitCode {
    if let Err(e) = image_io::check_output(&args.output) {
        return fail(e);
    }
    let live = match args.serve.map(Live::start).transpose() {
        Ok(live) => live,
        Err(e) => return fail(e),
    };
    if let Some(live) = &live {
        eprintln!("watch: serving http://{}/", live.address());
    }
    let (events, changes) = std::sync::mpsc::channel::<DebounceEventResult>();
    let mut debouncer = match new_debouncer(DEBOUNCE, None, events) {
        Ok(d) => d,
        Err(e) => return fail(format!("cannot watch files: {e}")),
    };
    let mut watched: HashSet<PathBuf> = HashSet::new();
    loop {
        let started = Instant::now();
        let (scene, inputs) = build(&args, live.as_deref());
        for dir in inputs.dirs.difference(&watched.clone()) {
            match debouncer.watch(dir, RecursiveMode::NonRecursive) {
                Ok(()) => {
                    watched.insert(dir.clone());
                }
                Err(e) => eprintln!("warning: cannot watch {}: {e}", dir.display()),
            }
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
                    let changed = next_change(&changes, &inputs, broken, &args.output);
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
                next_change(&changes, &inputs, broken, &args.output)
            }
        };
        let Some(changed) = changed else {
            return fail("the file watcher stopped");
        };
        let names: Vec<String> = changed.iter().map(|p| p.display().to_string()).collect();
        eprintln!("watch: changed: {}", names.join(", "));
    }
}

/// Checks and compiles the scene and builds it for rendering; `None` (after
/// printing why) when any step fails.
fn build(args: &WatchArgs, live: Option<&Live>) -> (Option<Scene>, Inputs) {
    // A texture manager of its own, so a changed image is read again
    // rather than found in the cache.
    let textures = Arc::new(TextureManager::new());
    let options = LoadOptions { import_paths: args.options.include.clone(), textures, ..Default::default() };
    let checked = tsl::check_file(&args.scene, &options);
    let inputs = inputs_of(&args.scene, &checked);
    eprint!("{}", crate::human_report(&checked, crate::stderr_colors()));
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
    let program = match tsl::Compiler::new().color_model(args.options.color).compile_checked(checked) {
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

/// Waits for a change to one of `inputs` (while the build is `broken`,
/// also to any file with one of [`SOURCE_EXTENSIONS`] in the watched
/// directories), never to the output image itself. Reads are not changes:
/// checking opens every input. `None` when the watcher has stopped.
fn next_change(
    changes: &Receiver<DebounceEventResult>,
    inputs: &Inputs,
    broken: bool,
    output: &Path,
) -> Option<Vec<PathBuf>> {
    let out_name = output.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let temporary = format!(".{out_name}.tmp-");
    let relevant = |p: &Path| {
        let name = p.file_name().map(|n| n.to_string_lossy()).unwrap_or_default();
        let ours = name == out_name.as_str() || name.starts_with(&temporary);
        let candidate =
            broken && p.extension().is_some_and(|e| SOURCE_EXTENSIONS.iter().any(|x| e.eq_ignore_ascii_case(x)));
        !ours && (inputs.files.contains(p) || candidate)
    };
    loop {
        match changes.recv().ok()? {
            Ok(events) => {
                let mut changed: Vec<PathBuf> = events
                    .into_iter()
                    .filter(|e| match e.event.kind {
                        EventKind::Access(AccessKind::Close(AccessMode::Write)) => true,
                        EventKind::Access(_) => false,
                        _ => true,
                    })
                    .flat_map(|e| e.event.paths.clone())
                    .filter(|p| relevant(p))
                    .collect();
                changed.sort();
                changed.dedup();
                if !changed.is_empty() {
                    return Some(changed);
                }
            }
            Err(errors) => {
                for e in errors {
                    eprintln!("warning: watching files: {e}");
                }
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
