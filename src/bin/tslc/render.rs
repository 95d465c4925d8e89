//! `tslc render`, `tslc merge` and `tslc make-mesh`: the renderer's command
//! line. Progress goes to stderr: a bar on a terminal, plain lines when
//! piped (render-farm managers parse them), nothing with `--quiet`.

use std::borrow::Cow;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Mutex;
use std::time::Instant;
use tsl::image_io;
use tsl::render::{self, IntegratorKind, LightSampling, Overrides, RenderOptions, Scene};
use tsl::scene::FrameRequest;

#[derive(clap::Args)]
pub struct RenderArgs {
    /// The scene file (a .tsl file with a `scene { ... }` block).
    scene: PathBuf,
    /// The image to write: .png (8-bit sRGB) or .exr (linear float).
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    output: PathBuf,
    /// Samples per pixel, 1 to 1048576 (overrides the scene's `spp`).
    #[arg(long, allow_negative_numbers = true, value_parser = parse_spp)]
    spp: Option<u32>,
    #[command(flatten)]
    options: SceneOptions,
    /// Render only a window: `x0,x1,y0,y1` as fractions of the image in
    /// [0, 1] (as pbrt's --cropwindow) or as pixel numbers.
    #[arg(long, value_name = "x0,x1,y0,y1")]
    crop: Option<String>,
    /// Render only tile I of N (0-based; bands of rows) for a render farm;
    /// join the tiles with `tslc merge`. Needs an .exr output.
    #[arg(long, value_name = "I/N", value_parser = parse_tile)]
    tile: Option<(u32, u32)>,
    /// Also write albedo, normal and depth layers (EXR only).
    #[arg(long)]
    aov: bool,
    /// Render frame N of an animation: shaders and scene values read it as
    /// `frame`, and its time as `time`. A `#` run in the output's file name
    /// becomes the frame number (`-o out/shot.####.exr`).
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = parse_frame, conflicts_with = "frames")]
    frame: Option<i32>,
    /// Render frames A to B, both included, one image each; the output's
    /// file name must have a `#` run for the frame number.
    #[arg(long, value_name = "A..B", allow_negative_numbers = true, value_parser = parse_frames)]
    frames: Option<(i32, i32)>,
    /// Frames per second: a frame's time is `frame / fps` (overrides the
    /// scene's `fps` and `time`; default 24).
    #[arg(long, value_name = "FPS", value_parser = parse_fps)]
    fps: Option<f32>,
    /// No progress and no summary.
    #[arg(short, long)]
    quiet: bool,
}

/// The options `tslc render` and `tslc watch` share: the scene settings they
/// override, the color model, threads and the import path.
#[derive(clap::Args)]
pub struct SceneOptions {
    /// Image size, e.g. `640x480` (overrides the scene's width and height).
    #[arg(long, value_name = "WxH", value_parser = parse_resolution)]
    pub(crate) res: Option<(u32, u32)>,
    /// Worker threads, at most 1024 (default: one per core).
    #[arg(long, default_value_t = 0, allow_negative_numbers = true, value_parser = parse_threads)]
    pub(crate) threads: usize,
    /// The integrator (overrides the scene's `integrator`).
    #[arg(long, value_parser = parse_integrator)]
    pub(crate) integrator: Option<IntegratorKind>,
    /// How the path tracer picks lights at each vertex: `all` samples
    /// every light, `power` one chosen by power (overrides the scene's
    /// `light_sampling`).
    #[arg(long, value_name = "all|power", value_parser = parse_light_sampling)]
    pub(crate) light_sampling: Option<LightSampling>,
    /// The color model (default `rgb`). `rgb`: linear sRGB (the cost unit). `spectral` or
    /// `hero`: four wavelengths drawn per camera sample (hero wavelength
    /// sampling, as Mitsuba 3 and pbrt-v4 render spectrally): unbiased,
    /// converges to the exact spectral integral (Cornell walls within 1% of
    /// Mitsuba, saturated colours within 0.06% of RGB), dispersion works,
    /// colour noise at few samples; about 1.1-1.2x the time of `rgb`.
    /// `spectralN`: N fixed bins of 380-780 nm, noise-free; saturated colours
    /// off by up to 1.2% at 16 bins, 0.05% at 64 (quadrature). RGB is
    /// upsampled by Jakob-Hanika, lights are D65-based. `smitsN`: the bins
    /// with Smits' upsampling and white E (the old model). Costs and
    /// accuracy: the guide (docs/book), "Colour models".
    #[arg(long = "color-model", value_name = "MODEL", value_parser = parse_color)]
    pub(crate) color_model: Option<tsl::ColorModel>,
    /// When to colour diagnostics: auto, always or never (as cargo and
    /// rustc). A color model here, the old spelling of `--color-model`, is
    /// taken with a warning.
    #[arg(long, value_name = "WHEN", value_parser = crate::parse_color_or_model)]
    pub(crate) color: Option<crate::ColorOrModel>,
    /// The random seed, a whole number from 0 (overrides the scene's `seed`).
    #[arg(long, allow_negative_numbers = true, value_parser = parse_seed)]
    pub(crate) seed: Option<u64>,
    /// Maximum path depth, 1 to 1024 (overrides the scene's `max_depth`).
    #[arg(long, allow_negative_numbers = true, value_parser = parse_depth)]
    pub(crate) max_depth: Option<u32>,
    /// Add a directory to the import search path.
    #[arg(short = 'I', value_name = "DIR")]
    pub(crate) include: Vec<PathBuf>,
}

impl SceneOptions {
    /// The color model asked for: `--color-model`, else a model given as
    /// `--color` (warned of once, by [`SceneOptions::warn_old_spellings`]), else RGB.
    pub(crate) fn color_model(&self) -> tsl::ColorModel {
        match (self.color_model, &self.color) {
            (Some(m), _) => m,
            (None, Some(crate::ColorOrModel::Model(m, _))) => *m,
            _ => tsl::ColorModel::Rgb,
        }
    }

    /// When to colour diagnostics.
    pub(crate) fn colors(&self) -> tsl::diag::Colors {
        match self.color {
            Some(crate::ColorOrModel::When(when)) => when.colors(),
            _ => crate::ColorChoice::Auto.colors(),
        }
    }

    /// Warns of a color model given as `--color`.
    pub(crate) fn warn_old_spellings(&self) {
        if let Some(crate::ColorOrModel::Model(_, model)) = &self.color {
            let ignored = if self.color_model.is_some() { " (ignored: `--color-model` is given)" } else { "" };
            eprintln!(
                "warning: `--color {model}` is the old spelling of `--color-model {model}`{ignored}; `--color` is when to colour diagnostics (auto, always, never)"
            );
        }
    }
}

#[derive(clap::Args)]
pub struct MergeArgs {
    /// Tiles or crops of one image, as written by `tslc render --tile` (EXR).
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// The joined image (.exr or .png).
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    output: PathBuf,
}

#[derive(clap::Args)]
pub struct MakeMeshArgs {
    /// Which mesh: `heavy` (the 999,698-triangle height field of the
    /// benchmark scene `heavy`).
    #[arg(value_parser = ["heavy"])]
    which: String,
    /// Where to write the OBJ file.
    #[arg(short = 'o', long = "output", default_value = "examples/gen/heavy.obj")]
    output: PathBuf,
}

pub(crate) fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("`{s}` is not a resolution: write WIDTHxHEIGHT, e.g. 640x480");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let (w, h) = (w.trim().parse::<u32>().map_err(|_| bad())?, h.trim().parse::<u32>().map_err(|_| bad())?);
    let side = tsl::scene::MAX_IMAGE_SIDE;
    if w == 0 || h == 0 || w > side || h > side {
        return Err(format!("the resolution {w}x{h} must be between 1x1 and {side}x{side}"));
    }
    if u64::from(w) * u64::from(h) > tsl::scene::MAX_PIXELS {
        return Err(format!("{w}x{h} is more than the {} pixels an image may have", tsl::scene::MAX_PIXELS));
    }
    Ok((w, h))
}

/// A whole number in `lo..=hi`, for the option `what`.
fn whole(s: &str, what: &str, lo: u64, hi: u64) -> Result<u64, String> {
    let bad = || format!("{what} must be a whole number from {lo} to {hi}, found `{s}`");
    let x: i128 = s.trim().parse().map_err(|_| bad())?;
    if x < i128::from(lo) || x > i128::from(hi) {
        return Err(bad());
    }
    Ok(x as u64)
}

pub(crate) fn parse_spp(s: &str) -> Result<u32, String> {
    whole(s, "samples per pixel", 1, u64::from(tsl::scene::MAX_SPP)).map(|x| x as u32)
}

pub(crate) fn parse_depth(s: &str) -> Result<u32, String> {
    whole(s, "the maximum depth", 1, u64::from(tsl::scene::MAX_DEPTH)).map(|x| x as u32)
}

pub(crate) fn parse_threads(s: &str) -> Result<usize, String> {
    whole(s, "the thread count", 0, render::MAX_THREADS as u64).map(|x| x as usize)
}

pub(crate) fn parse_seed(s: &str) -> Result<u64, String> {
    whole(s, "the seed", 0, u64::MAX)
}

pub(crate) fn parse_integrator(s: &str) -> Result<IntegratorKind, String> {
    IntegratorKind::parse(s).ok_or_else(|| format!("`{s}` is not an integrator: use whitted or path"))
}

pub(crate) fn parse_light_sampling(s: &str) -> Result<LightSampling, String> {
    LightSampling::parse(s).ok_or_else(|| format!("`{s}` is not a light sampling: use all or power"))
}

pub(crate) fn parse_color(s: &str) -> Result<tsl::ColorModel, String> {
    tsl::ColorModel::parse(s).ok_or_else(|| {
        format!("`{s}` is not a color model: use rgb, spectral (= hero), spectralN or smitsN with N in 1..=64")
    })
}

fn parse_tile(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("`{s}` is not a tile: write I/N with 0 <= I < N, e.g. 3/8");
    let (i, n) = s.split_once('/').ok_or_else(bad)?;
    let (i, n) = (i.trim().parse::<u32>().map_err(|_| bad())?, n.trim().parse::<u32>().map_err(|_| bad())?);
    if n == 0 || i >= n {
        return Err(bad());
    }
    Ok((i, n))
}

fn parse_frame(s: &str) -> Result<i32, String> {
    let max = tsl::scene::MAX_FRAME;
    let x: i64 = s.trim().parse().map_err(|_| format!("a frame must be a whole number, found `{s}`"))?;
    if x.unsigned_abs() > max as u64 {
        return Err(format!("frame {x} is out of range: frames go from -{max} to {max}"));
    }
    Ok(x as i32)
}

/// `A..B` (both included, as frame ranges on farms are), or one frame `N`.
fn parse_frames(s: &str) -> Result<(i32, i32), String> {
    let Some((a, b)) = s.split_once("..") else {
        let n = parse_frame(s)?;
        return Ok((n, n));
    };
    let (a, b) = (parse_frame(a)?, parse_frame(b)?);
    if b < a {
        return Err(format!("the frame range `{s}` is empty: write A..B with A <= B (both are rendered)"));
    }
    Ok((a, b))
}

fn parse_fps(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(x) if x.is_finite() && x > 0.0 && x <= 1e6 => Ok(x),
        _ => Err(format!("frames per second must be a positive number up to 1000000, found `{s}`")),
    }
}

pub(crate) fn fail(message: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {message}");
    ExitCode::from(1)
}

pub fn render(args: RenderArgs) -> ExitCode {
    let start = Instant::now();
    args.options.warn_old_spellings();
    let frames: Vec<i32> = match (args.frame, args.frames) {
        (Some(n), _) => vec![n],
        (None, Some((a, b))) => (a..=b).collect(),
        (None, None) => vec![0],
    };
    if frames.len() > 1 && !image_io::has_frame_pattern(&args.output) {
        return fail(format!(
            "--frames renders {} images: put a run of `#` in the output's file name for the frame number, \
             e.g. -o out/shot.####.exr",
            frames.len()
        ));
    }
    // Everything about the output is checked before any work starts (every
    // frame is written to the same directory, made if missing).
    let first = image_io::frame_path(&args.output, frames[0]);
    if let Err(e) = image_io::prepare_output(&first) {
        return fail(e);
    }
    let is_exr = args.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if args.tile.is_some() && !is_exr {
        return fail("a tile must be written as .exr, so that `tslc merge` can place it");
    }
    if args.aov && !is_exr {
        return fail("--aov needs an .exr output (PNG has no layers)");
    }
    if args.crop.is_some() && args.tile.is_some() {
        return fail("--crop and --tile cannot be combined");
    }
    // One frame described once: the scene's syntax can go once described.
    let lean = args.frame.is_none() && args.frames.is_none() && args.fps.is_none();
    let options = tsl::LoadOptions {
        import_paths: args.options.include.clone(),
        color_model: args.options.color_model(),
        lean,
        ..tsl::LoadOptions::default()
    };
    // Checked first so its warnings (a texel that is not a number, say)
    // are shown as `tslc check` shows them, as cargo shows a build's.
    let checked = tsl::check_file(&args.scene, &options);
    let warnings: Vec<_> = checked.diagnostics.iter().filter(|d| !d.is_error()).cloned().collect();
    if checked.is_ok() && !warnings.is_empty() {
        eprint!("{}", tsl::diag::render_text(&checked.program.loaded.sources, &warnings, args.options.colors()));
    }
    let mut compiler = tsl::Compiler::new().color_model(args.options.color_model()).lean(lean);
    for dir in &args.options.include {
        compiler = compiler.import_path(dir);
    }
    let mut program = match compiler.compile_checked(checked) {
        Ok(p) => p,
        Err(e) => {
            eprint!("{e}");
            return ExitCode::from(1);
        }
    };
    // Nothing the scene was made from may be written over (every frame's
    // output; the files a scene reads are the same for every frame).
    let outputs = frames.iter().map(|&f| image_io::frame_path(&args.output, f));
    if let Err(e) = refuse_overwriting_inputs(outputs, program.checked(), program.scene(), args.options.colors()) {
        eprint!("{e}");
        return ExitCode::from(1);
    }
    // One frame, described once: the scene builder is given the
    // description, and frees its objects once placed.
    if lean && program.scene().is_some() {
        let content_hash = tsl::scene::content_hash(program.checked(), program.scene());
        let compiled = start.elapsed().as_secs_f64();
        let desc = program.take_scene().map(Cow::Owned);
        let code = render_frame(&args, &program, desc, None, true, compiled, &content_hash);
        // As below: the process ends next.
        std::mem::forget(program);
        return code;
    }
    // Every frame's scene is checked before the first is rendered; the
    // first frame's description is kept for its render.
    let request = |frame| FrameRequest { frame, fps: args.fps };
    // The frame the program was described at is used as it is, not copied
    // (a scene of a million objects).
    let described = |frame: i32| args.fps.is_none() && program.scene().is_some_and(|d| d.frame.number == frame);
    let mut first = None;
    for &frame in frames.iter().filter(|f| !described(**f)) {
        match program.scene_at(&request(frame)) {
            Ok(desc) => {
                first.get_or_insert(desc);
            }
            Err(e) => {
                eprint!("{e}");
                return ExitCode::from(1);
            }
        }
    }
    // The same for every frame: the frame is recorded apart.
    let content_hash = tsl::scene::content_hash(program.checked(), program.scene());
    let compiled = start.elapsed().as_secs_f64();
    for (k, &frame) in frames.iter().enumerate() {
        let owned = match (described(frame), k, first.take()) {
            (true, _, _) => None,
            (false, 0, Some(desc)) => desc,
            _ => match program.scene_at(&request(frame)) {
                Ok(desc) => desc,
                Err(e) => {
                    eprint!("{e}");
                    return ExitCode::from(1);
                }
            },
        };
        let desc = if described(frame) { program.scene() } else { owned.as_ref() };
        let animated = args.frame.is_some() || args.frames.is_some();
        let first = k == 0;
        let code = render_frame(
            &args,
            &program,
            desc.map(Cow::Borrowed),
            animated.then_some(frame),
            first,
            compiled,
            &content_hash,
        );
        if code != ExitCode::SUCCESS {
            return code;
        }
    }
    // The process ends next: freeing a large program's trees one by one
    // would only cost time.
    std::mem::forget(program);
    ExitCode::SUCCESS
}

/// Renders and writes one frame (`None`: a render that asked for no frame).
fn render_frame(
    args: &RenderArgs,
    program: &tsl::Program,
    desc: Option<Cow<'_, tsl::scene::SceneDesc>>,
    frame: Option<i32>,
    first: bool,
    compiled: f64,
    content_hash: &str,
) -> ExitCode {
    let overrides = Overrides {
        resolution: args.options.res,
        spp: args.spp,
        max_depth: args.options.max_depth,
        seed: args.options.seed,
        integrator: args.options.integrator,
        light_sampling: args.options.light_sampling,
        ..Default::default()
    };
    let built = match desc {
        Some(Cow::Owned(desc)) => Scene::build_owned(program, desc, &overrides),
        desc => Scene::build_from(program, desc.as_deref(), &overrides),
    };
    let scene = match built {
        Ok(s) => s,
        Err(e) => {
            eprint!("{e}");
            return ExitCode::from(1);
        }
    };
    if scene.lights.is_empty() && !args.quiet && first {
        eprintln!(
            "warning: the scene has no light (no `light` block, emitting object or environment): \
             its surfaces will render black"
        );
    }
    let (w, h) = (scene.settings.width, scene.settings.height);
    // Both at once was refused before compiling.
    let window = match (&args.crop, args.tile) {
        (Some(c), _) => image_io::parse_crop(c, w, h).map(Some),
        (None, Some((i, n))) => image_io::tile_window(w, h, i, n).map(Some),
        (None, None) => Ok(None),
    };
    let window = match window {
        Ok(window) => window,
        Err(e) => return fail(e),
    };
    let progress = Progress::new(args.quiet);
    let report = |done: u64, total: u64| progress.update(done, total);
    let options = RenderOptions {
        threads: args.options.threads,
        window,
        aov: args.aov,
        progress: if args.quiet { None } else { Some(&report) },
        ..Default::default()
    };
    let (image, stats) = match render::render(&scene, &options) {
        Ok(r) => r,
        Err(e) => return fail(e),
    };
    progress.finish();
    let output = image_io::frame_path(&args.output, frame.unwrap_or(0));
    let mut metadata = render::image_metadata(&scene, content_hash, args.tile);
    metadata.set_text("tsl:scene", args.scene.display().to_string());
    if let Err(e) = image_io::write_image_with(&output, &image, &metadata) {
        return fail(e);
    }
    if !args.quiet {
        let secs = stats.seconds.max(1e-9);
        let what = match frame {
            Some(n) => format!("frame {n} (time {:.4} s) ", scene.settings.frame.time),
            None => String::new(),
        };
        eprintln!(
            "rendered {what}{}x{} ({}x{} pixels) at {} spp with {} in {:.2} s on {} thread{} \
             (compile {:.2} s, scene {:.2} s)",
            w,
            h,
            image.width,
            image.height,
            scene.settings.spp,
            match scene.settings.integrator {
                IntegratorKind::Whitted => "whitted",
                IntegratorKind::Path => "path",
            },
            stats.seconds,
            stats.threads,
            if stats.threads == 1 { "" } else { "s" },
            if first { compiled } else { 0.0 },
            scene.build_seconds,
        );
        eprintln!(
            "{:.3} M samples/s, {:.3} M rays/s ({} camera, {} secondary, {} shadow), peak memory {}",
            stats.samples as f64 / secs / 1e6,
            stats.total_rays() as f64 / secs / 1e6,
            stats.rays.camera_rays,
            stats.rays.secondary_rays,
            stats.rays.shadow_rays,
            peak_memory(),
        );
        if stats.dropped_samples > 0 {
            eprintln!("warning: {} samples were NaN or infinite and were dropped", stats.dropped_samples);
        }
        if stats.dropped_aov_samples > 0 {
            eprintln!(
                "warning: {} AOV samples (albedo or normal) were NaN or infinite and were dropped",
                stats.dropped_aov_samples
            );
        }
        eprintln!("wrote {}", output.display());
    }
    ExitCode::SUCCESS
}

/// Refuses, before any rendering, to write an output that is one of the
/// files `program` and its `scene` were made from (`scene::input_files`:
/// the source, its imports, textures, meshes, the environment image): the
/// render would overwrite its own input. Files are compared by identity
/// (device and inode, `tsl::files::FileIdentity`), so a hard link, a
/// symbolic link or another spelling of an input's path counts. The error
/// (rendered as a diagnostic, ready to print) names the output and the
/// input, at the place the scene names it when it has one.
pub(crate) fn refuse_overwriting_inputs(
    outputs: impl IntoIterator<Item = PathBuf>,
    program: &tsl::check::Program,
    scene: Option<&tsl::scene::SceneDesc>,
    colors: tsl::diag::Colors,
) -> Result<(), String> {
    use tsl::files::FileIdentity;
    let inputs = tsl::scene::input_files(program, scene);
    let mut by_identity = std::collections::HashMap::new();
    for input in &inputs {
        for id in input.path.map(FileIdentity::all_of).unwrap_or_default() {
            by_identity.entry(id).or_insert(input);
        }
    }
    for output in outputs {
        let Some(input) = FileIdentity::all_of(&output).iter().find_map(|id| by_identity.get(id)) else { continue };
        let name = input.path.map(|p| p.display().to_string()).unwrap_or_default();
        let message = format!(
            "cannot write {}: it is {} of this scene, `{name}`; rendering would overwrite it",
            output.display(),
            input.content.role()
        );
        let help = "write the image to another file";
        return Err(match input.span {
            Some(span) => {
                let d = tsl::diag::Diagnostic::error(span, message).with_primary("read from here").with_help(help);
                tsl::diag::render_text(&program.loaded.sources, &[d], colors)
            }
            None => format!("error: {message}\n  = help: {help}\n"),
        });
    }
    Ok(())
}

pub fn merge(args: MergeArgs) -> ExitCode {
    if let Err(e) = image_io::prepare_output(&args.output) {
        return fail(e);
    }
    let output = tsl::files::FileIdentity::all_of(&args.output);
    if let Some(tile) =
        args.inputs.iter().find(|t| tsl::files::FileIdentity::all_of(t).iter().any(|id| output.contains(id)))
    {
        return fail(format!(
            "cannot write {}: it is the input tile {}; merging would overwrite it",
            args.output.display(),
            tile.display()
        ));
    }
    let (image, metadata) = match image_io::merge(&args.inputs) {
        Ok(i) => i,
        Err(e) => return fail(e),
    };
    if let Err(e) = image_io::write_image_with(&args.output, &image, &metadata) {
        return fail(e);
    }
    eprintln!("merged {} files into {}", args.inputs.len(), args.output.display());
    ExitCode::SUCCESS
}

pub fn make_mesh(args: MakeMeshArgs) -> ExitCode {
    let start = Instant::now();
    if let Some(dir) = args.output.parent().filter(|d| !d.as_os_str().is_empty())
        && let Err(e) = std::fs::create_dir_all(dir)
    {
        return fail(format!("cannot create {}: {e}", dir.display()));
    }
    // Written beside the target and renamed, like images.
    let written = tsl::files::atomic_write(&args.output, |file| {
        let mut w = std::io::BufWriter::new(file);
        render::heightfield::write_heavy_obj(&mut w)
            .and_then(|()| std::io::Write::flush(&mut w))
            .map_err(|e| e.to_string())
    });
    if let Err(e) = written {
        return fail(e);
    }
    eprintln!("wrote {} in {:.1} s", args.output.display(), start.elapsed().as_secs_f64());
    ExitCode::SUCCESS
}

/// Peak resident memory of this process (Linux), for the summary.
fn peak_memory() -> String {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().strip_suffix("kB"))
        .and_then(|kb| kb.trim().parse::<f64>().ok())
        .map_or_else(|| "unknown".into(), |kb| format!("{:.1} MB", kb / 1024.0))
}

/// Progress on stderr: an indicatif bar on a terminal, else a plain line
/// every 5% (`progress: 35% 12.1 s elapsed, 22.4 s left`).
struct Progress {
    bar: Option<indicatif::ProgressBar>,
    plain: bool,
    start: Instant,
    /// The last percentage printed as a plain line.
    last: Mutex<u64>,
}

impl Progress {
    fn new(quiet: bool) -> Progress {
        let terminal = std::io::stderr().is_terminal();
        let bar = (!quiet && terminal).then(|| {
            let bar = indicatif::ProgressBar::new(0);
            let style = indicatif::ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {wide_bar} {percent:>3}% eta {eta_precise}",
            );
            if let Ok(style) = style {
                bar.set_style(style);
            }
            bar
        });
        Progress { bar, plain: !quiet && !terminal, start: Instant::now(), last: Mutex::new(0) }
    }

    fn update(&self, done: u64, total: u64) {
        if let Some(bar) = &self.bar {
            bar.set_length(total);
            bar.set_position(done);
        } else if self.plain && total > 0 {
            let percent = done * 100 / total;
            let Ok(mut last) = self.last.lock() else { return };
            if percent >= *last + 5 || (done == total && *last < 100) {
                *last = percent;
                let elapsed = self.start.elapsed().as_secs_f64();
                let left = if done > 0 { elapsed * (total - done) as f64 / done as f64 } else { 0.0 };
                eprintln!("progress: {percent}% {elapsed:.1} s elapsed, {left:.1} s left");
            }
        }
    }

    fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}
