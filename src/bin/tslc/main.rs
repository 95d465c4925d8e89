//! `tslc`, the TSL command-line compiler.
//!
//! Renders the library's diagnostics for people (rustc style, coloured on a
//! terminal) or as JSON lines for editors and CI. Diagnostics go to stderr;
//! requested data (JSON messages) to stdout.
//! Exit codes: 0 clean, 1 errors (or warnings under `-W error`), 2 usage.
//! `render`, `merge` and `make-mesh` live in `render.rs`; `query` in
//! `query.rs`; `watch` in `watch.rs` (its web page in `serve.rs`).

mod info;
mod query;
mod render;
mod serve;
mod view;
mod watch;

use clap::{Parser, Subcommand, ValueEnum};
use std::io::{IsTerminal, Read, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use tsl::diag::{self, Colors, Severity};
use tsl::{Checked, LoadOptions};

#[derive(Parser)]
#[command(name = "tslc", version, about = "The TSL shading language compiler")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Parse and type-check TSL files; exit 0 when clean.
    Check(CheckArgs),
    /// Print a compilation stage of a file: the checked AST, the IR, or the
    /// Cranelift IR of every compiled function.
    Emit(EmitArgs),
    /// Render a scene file to an image (.png or .exr).
    Render(render::RenderArgs),
    /// Join tiles rendered with `render --tile I/N` into one image.
    Merge(render::MergeArgs),
    /// List the material templates of a file (or one by name) with their
    /// parameters: types, defaults, doc comments and options (`--json` for
    /// tools), as `oslquery` does.
    Query(query::QueryArgs),
    /// Print what an EXR says about itself: frame, window, channels and
    /// the render settings, scene hash and tile it was made with.
    Info(info::InfoArgs),
    /// Show one layer of a rendered EXR (radiance, albedo, normal, depth,
    /// object): drawn in the terminal, or written as a PNG with `-o`.
    View(view::ViewArgs),
    /// Write a generated mesh that an example scene needs (`heavy`).
    MakeMesh(render::MakeMeshArgs),
    /// Format TSL files in the canonical style (docs/fmt.md), in place;
    /// `-` or no file formats standard input to standard output.
    Fmt(FmtArgs),
    /// Re-check and re-render a scene whenever it, a file it imports or an
    /// image it reads changes, refining the image while nothing changes.
    Watch(watch::WatchArgs),
    /// Run the language server (LSP over standard input and output) for
    /// editors: diagnostics, hover, completion, definitions, formatting.
    Lsp(LspArgs),
}

#[derive(clap::Args)]
struct LspArgs {
    /// Add a directory to the import search path (after the client's
    /// `importPaths` initialization option).
    #[arg(short = 'I', value_name = "DIR")]
    include: Vec<PathBuf>,
    /// Accepted for clients that pass it: stdio is the only transport.
    #[arg(long)]
    stdio: bool,
}

#[derive(clap::Args)]
struct FmtArgs {
    /// Files or directories (searched for `.tsl` files); `-` is standard input.
    files: Vec<PathBuf>,
    /// Change nothing: print a diff and exit 1 when a file would change.
    #[arg(long)]
    check: bool,
    /// The file name to report for standard input.
    #[arg(long, value_name = "PATH")]
    stdin_path: Option<String>,
}

#[derive(clap::Args)]
struct EmitArgs {
    /// The file to compile.
    file: PathBuf,
    /// What to print.
    #[arg(long, value_enum, default_value_t = EmitKind::Ir)]
    emit: EmitKind,
    /// The color model: `rgb`, `spectral` (= `hero`), `spectralN` (e.g. `spectral16`) or `smitsN`.
    #[arg(long, default_value = "rgb", value_parser = parse_color_model)]
    color_model: tsl::ColorModel,
    /// Only functions whose name starts with this (e.g. `wood.` or `rings`).
    #[arg(long, value_name = "PREFIX")]
    only: Option<String>,
    /// Add a directory to the import search path.
    #[arg(short = 'I', value_name = "DIR")]
    include: Vec<PathBuf>,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum EmitKind {
    Ast,
    Ir,
    /// Each material's hit group for the path tracer, split: `prepare`
    /// and the methods reading its record (`hit[k]`).
    Hit,
    Clif,
}

fn parse_color_model(s: &str) -> Result<tsl::ColorModel, String> {
    tsl::ColorModel::parse(s).ok_or_else(|| {
        format!("`{s}` is not a color model: use rgb, spectral (= hero), spectralN or smitsN with N in 1..=64")
    })
}

#[derive(clap::Args)]
struct CheckArgs {
    /// Files to check; `-` reads standard input.
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// When to colour diagnostics.
    #[arg(long, value_name = "WHEN", default_value = "auto", value_parser = parse_color_choice)]
    color: ColorChoice,
    /// How to print diagnostics.
    #[arg(long, value_enum, default_value_t = MessageFormat::Human)]
    message_format: MessageFormat,
    /// The file name to report for standard input (also anchors its imports).
    #[arg(long, value_name = "PATH")]
    stdin_path: Option<String>,
    /// Add a directory to the import search path.
    #[arg(short = 'I', value_name = "DIR")]
    include: Vec<PathBuf>,
    /// `-W error` turns warnings into a failure.
    #[arg(short = 'W', value_name = "LEVEL", value_enum)]
    warnings: Option<WarningLevel>,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum ColorChoice {
    Auto,
    Always,
    Never,
}

impl ColorChoice {
    fn colors(self) -> Colors {
        match self {
            ColorChoice::Always => Colors::Always,
            ColorChoice::Never => Colors::Never,
            ColorChoice::Auto => stderr_colors(),
        }
    }
}

/// `--color` of `render` and `watch`: when to colour diagnostics, or (the
/// old spelling) a color model.
#[derive(Clone, Debug)]
enum ColorOrModel {
    When(ColorChoice),
    /// The model, and how the user spelled it.
    Model(tsl::ColorModel, String),
}

fn parse_color_or_model(s: &str) -> Result<ColorOrModel, String> {
    match ColorChoice::from_str(s, false) {
        Ok(when) => Ok(ColorOrModel::When(when)),
        Err(_) => tsl::ColorModel::parse(s)
            .map(|m| ColorOrModel::Model(m, s.to_string()))
            .ok_or_else(|| format!("`{s}` is not auto, always or never (nor a color model, for `--color-model`)")),
    }
}

/// `--color` of `check`: when to colour diagnostics; a color model gets a
/// message saying where a model goes.
fn parse_color_choice(s: &str) -> Result<ColorChoice, String> {
    ColorChoice::from_str(s, false).map_err(|_| match tsl::ColorModel::parse(s) {
        Some(_) => format!(
            "`{s}` is a color model, and `--color` is when to colour diagnostics (auto, always or never); checking needs no model (`tslc render --color-model {s}` renders in it)"
        ),
        None => format!("`{s}` is not auto, always or never"),
    })
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum MessageFormat {
    Human,
    Json,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum WarningLevel {
    Error,
}

fn lsp(args: LspArgs) -> ExitCode {
    let _ = args.stdio;
    match tsl::lsp::run_stdio(args.include) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // Interrupted (SIGINT, SIGTERM): the image being written, if any, is
    // left as it was (writes are atomic) and its temporary is removed.
    let _ = ctrlc::set_handler(|| {
        tsl::files::remove_temporaries();
        std::process::exit(130);
    });
    // Checking recurses over the (depth-limited) syntax tree; a generous
    // stack keeps that safe for every accepted input.
    let worker = std::thread::Builder::new().stack_size(64 << 20).spawn(move || match cli.command {
        Command::Check(args) => check(args),
        Command::Emit(args) => emit(args),
        Command::Render(args) => render::render(args),
        Command::Merge(args) => render::merge(args),
        Command::Info(args) => info::info(args),
        Command::View(args) => view::view(args),
        Command::Query(args) => query::query(args),
        Command::MakeMesh(args) => render::make_mesh(args),
        Command::Fmt(args) => fmt(args),
        Command::Watch(args) => watch::watch(args),
        Command::Lsp(args) => lsp(args),
    });
    match worker.map(|w| w.join()) {
        Ok(Ok(code)) => code,
        _ => {
            eprintln!("error: internal compiler error (this is a bug in tslc; please report it)");
            ExitCode::from(101)
        }
    }
}

fn check(args: CheckArgs) -> ExitCode {
    let options = LoadOptions { import_paths: args.include.clone(), lean: true, ..LoadOptions::default() };
    let colors = args.color.colors();
    let mut failed = false;
    let mut stdin_used = false;
    for (k, file) in args.files.iter().enumerate() {
        let checked = if file.as_os_str() == "-" {
            if stdin_used {
                eprintln!("error: standard input (`-`) can be checked only once");
                return ExitCode::from(2);
            }
            stdin_used = true;
            let mut text = String::new();
            let name = args.stdin_path.clone().unwrap_or_else(|| "<stdin>".into());
            let max = tsl::load::MAX_SOURCE_BYTES;
            if let Err(e) = std::io::stdin().take(max + 1).read_to_string(&mut text) {
                eprintln!("error: cannot read standard input: {e}");
                failed = true;
                continue;
            }
            if text.len() as u64 > max {
                eprintln!("error: standard input is larger than {} MiB, the most a source file may be", max >> 20);
                failed = true;
                continue;
            }
            tsl::check_source(&name, &text, &options)
        } else {
            tsl::check_file(file, &options)
        };
        failed |= report(&checked, &args, colors);
        if k + 1 == args.files.len() {
            // The process ends next: freeing a large program's trees one
            // by one would only cost time (rustc does the same).
            std::mem::forget(checked);
        }
    }
    if failed { ExitCode::from(1) } else { ExitCode::SUCCESS }
}

fn emit(args: EmitArgs) -> ExitCode {
    let wanted = |name: &str| args.only.as_deref().is_none_or(|p| name.starts_with(p));
    let mut out = std::io::stdout().lock();
    if args.emit == EmitKind::Ast {
        let options = LoadOptions { import_paths: args.include.clone(), ..LoadOptions::default() };
        let checked = tsl::check_file(&args.file, &options);
        if !checked.is_ok() {
            eprint!("{}", checked.render_diagnostics());
            return ExitCode::from(1);
        }
        for module in checked.program.loaded.modules.iter().filter(|m| !m.is_prelude) {
            let _ = writeln!(out, "// {}", checked.program.loaded.sources.name(module.file));
            let _ = writeln!(out, "{:#?}", module.ast);
        }
        return ExitCode::SUCCESS;
    }
    let mut compiler = tsl::Compiler::new()
        .color_model(args.color_model)
        .file(&args.file)
        .eager(true)
        .keep_clif(args.emit == EmitKind::Clif);
    for dir in &args.include {
        compiler = compiler.import_path(dir);
    }
    let program = match compiler.compile() {
        Ok(p) => p,
        Err(e) => {
            eprint!("{e}");
            return ExitCode::from(1);
        }
    };
    match args.emit {
        EmitKind::Ir => {
            for f in program.functions().iter().filter(|f| wanted(f.name())) {
                let _ = writeln!(out, "{}", f.ir_text());
            }
        }
        EmitKind::Hit => {
            let names = root_materials(&program);
            let names: Vec<&str> = names.iter().map(String::as_str).filter(|n| wanted(n)).collect();
            match program.hit_materials(&names, tsl::PATH_METHODS) {
                Ok(hits) => {
                    for (name, hit) in names.iter().zip(&hits) {
                        let worth = hit.worth_preparing();
                        let _ = writeln!(
                            out,
                            "// {name}: a {}-word hit record; the renderer {} it",
                            hit.record_words(),
                            if worth { "prepares" } else { "calls each method on its own for" }
                        );
                        let _ = writeln!(out, "{}", hit.prepare_function().ir_text());
                        for m in tsl::PATH_METHODS {
                            if let Some(f) = hit.method_function(*m) {
                                let _ = writeln!(out, "{}", f.ir_text());
                            }
                        }
                    }
                }
                Err(e) => {
                    eprint!("{e}");
                    return ExitCode::from(1);
                }
            }
        }
        _ => {
            for (name, text) in program.clif().iter().filter(|(n, _)| wanted(n)) {
                let _ = writeln!(out, "; {name}\n{text}");
            }
        }
    }
    ExitCode::SUCCESS
}

/// The materials of the root file without parameters, in source order.
fn root_materials(program: &tsl::Program) -> Vec<String> {
    let checked = program.checked();
    let mut names: Vec<((usize, usize), String)> = checked
        .symbols
        .iter()
        .filter(|(_, s)| !checked.loaded.modules[s.module].is_prelude)
        .filter(|(_, s)| match &checked.loaded.modules[s.module].ast.items[s.item] {
            tsl::syntax::ast::Item::MaterialTree(t) => t.params.is_none(),
            tsl::syntax::ast::Item::Material(d) => d.params.iter().all(|p| p.default.is_some()),
            _ => false,
        })
        .map(|(n, s)| ((s.module, s.item), n.clone()))
        .collect();
    names.sort();
    names.into_iter().map(|(_, n)| n).collect()
}

/// Prints the diagnostics of one file; returns whether it failed.
fn report(checked: &Checked, args: &CheckArgs, colors: Colors) -> bool {
    let sources = &checked.program.loaded.sources;
    match args.message_format {
        MessageFormat::Json => {
            let mut out = std::io::stdout().lock();
            for line in diag::json_lines(sources, &checked.diagnostics) {
                // A closed stdout (e.g. piped into `head`) is not our error.
                let _ = writeln!(out, "{line}");
            }
        }
        MessageFormat::Human => {
            let _ = std::io::stderr().lock().write_all(human_report(checked, colors).as_bytes());
        }
    }
    let warnings_fail = args.warnings == Some(WarningLevel::Error) && checked.count(Severity::Warning) > 0;
    !checked.is_ok() || warnings_fail
}

/// Writes to standard output; a closed one (piped into `head`) is not our
/// error, and is not a panic as `print!` makes it.
fn write_stdout(text: &str) {
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
}

/// Colours on a terminal, unless `NO_COLOR` is set.
fn stderr_colors() -> Colors {
    if std::io::stderr().is_terminal() && std::env::var_os("NO_COLOR").is_none() {
        Colors::Always
    } else {
        Colors::Never
    }
}

/// The diagnostics of one file as `tslc check` prints them, with the
/// closing count of errors and warnings.
fn human_report(checked: &Checked, colors: Colors) -> String {
    let mut text = diag::render_text(&checked.program.loaded.sources, &checked.diagnostics, colors);
    let (errors, warnings) = (checked.count(Severity::Error), checked.count(Severity::Warning));
    if errors > 0 {
        let also = if warnings > 0 { format!("; {warnings} warning{} emitted", s(warnings)) } else { String::new() };
        text += &format!("error: could not check due to {errors} error{}{also}\n", s(errors));
    } else if warnings > 0 {
        text += &format!("warning: {warnings} warning{} emitted\n", s(warnings));
    }
    text
}

fn s(n: usize) -> &'static str {
    if n == 1 { "" } else { "s" }
}

/// The files `tslc fmt` formats for the paths it was given, each once
/// (by identity, so a file named twice, or named and found in a walk, is
/// formatted once), in order. A path named on the command line is
/// followed through symbolic links: a directory is walked, anything else
/// is formatted. A walk goes into real subdirectories only and takes the
/// regular files ending in `.tsl`; it does not follow symbolic links, to
/// directories or to files (as gofmt and rustfmt walk), so a loop of links
/// cannot make it run forever. A directory that cannot be read is an error
/// (in the second list), not a silent skip.
fn tsl_files(paths: &[PathBuf]) -> (Vec<PathBuf>, Vec<String>) {
    let mut found = Vec::new();
    let mut errors = Vec::new();
    for path in paths {
        if std::fs::metadata(path).is_ok_and(|m| m.is_dir()) {
            walk_tsl_files(path, &mut found, &mut errors);
        } else {
            found.push(path.clone());
        }
    }
    let mut seen = std::collections::HashSet::new();
    found.retain(|p| tsl::files::FileIdentity::of(p).is_none_or(|id| seen.insert(id)));
    (found, errors)
}

fn walk_tsl_files(dir: &std::path::Path, out: &mut Vec<PathBuf>, errors: &mut Vec<String>) {
    let entries = match std::fs::read_dir(dir) {
        Ok(entries) => entries,
        Err(e) => {
            errors.push(format!("cannot read the directory {}: {e}", dir.display()));
            return;
        }
    };
    let mut children = Vec::new();
    for entry in entries {
        match entry.and_then(|e| Ok((e.path(), e.file_type()?))) {
            Ok(child) => children.push(child),
            Err(e) => errors.push(format!("cannot read the directory {}: {e}", dir.display())),
        }
    }
    children.sort_by(|a, b| a.0.cmp(&b.0));
    // `file_type` is the entry's own (a link is a link, never its target).
    for (path, kind) in children {
        if kind.is_dir() {
            walk_tsl_files(&path, out, errors);
        } else if kind.is_file() && path.extension().is_some_and(|x| x == "tsl") {
            out.push(path);
        }
    }
}

/// A unified diff (as `diff -u` and `git diff` print it, 3 lines of
/// context) from `old` to its formatted text.
fn line_diff(name: &str, old: &str, new: &str) -> String {
    similar::TextDiff::from_lines(old, new)
        .unified_diff()
        .context_radius(3)
        .header(name, &format!("{name} (formatted)"))
        .to_string()
}

fn fmt(args: FmtArgs) -> ExitCode {
    let mut failed = false;
    let report = |name: &str, text: &str, diags: &[diag::Diagnostic]| {
        let mut sources = diag::SourceMap::new();
        sources.add(name, text);
        eprint!("{}", diag::render_text(&sources, diags, Colors::Never));
    };
    if args.files.is_empty() || args.files.iter().any(|f| f.as_os_str() == "-") {
        let name = args.stdin_path.clone().unwrap_or_else(|| "<stdin>".into());
        let mut text = String::new();
        let max = tsl::load::MAX_SOURCE_BYTES;
        if let Err(e) = std::io::stdin().take(max + 1).read_to_string(&mut text) {
            eprintln!("error: cannot read standard input: {e}");
            return ExitCode::from(1);
        }
        if text.len() as u64 > max {
            eprintln!("error: standard input is larger than {} MiB, the most a source file may be", max >> 20);
            return ExitCode::from(1);
        }
        return match tsl::format::format_source(&text) {
            Ok(out) if args.check => {
                if out == text {
                    ExitCode::SUCCESS
                } else {
                    write_stdout(&line_diff(&name, &text, &out));
                    ExitCode::from(1)
                }
            }
            Ok(out) => {
                write_stdout(&out);
                ExitCode::SUCCESS
            }
            Err(d) => {
                report(&name, &text, &d);
                ExitCode::from(1)
            }
        };
    }
    let (files, walk_errors) = tsl_files(&args.files);
    for e in &walk_errors {
        eprintln!("error: {e}");
        failed = true;
    }
    for path in files {
        let name = path.display().to_string();
        // As `tslc check` reads a source: bounded, special files refused.
        let text = match tsl::load::read_source_file(&path) {
            Ok(t) => t,
            Err(e) => {
                eprintln!("error: {e}");
                failed = true;
                continue;
            }
        };
        match tsl::format::format_source(&text) {
            Ok(out) if out == text => {}
            Ok(out) if args.check => {
                write_stdout(&line_diff(&name, &text, &out));
                failed = true;
            }
            Ok(out) => {
                // Through a link to its target, keeping mode, owner and
                // group (`tsl::files::replace_source`, docs/fmt.md).
                if let Err(e) = tsl::files::replace_source(&path, text.as_bytes(), out.as_bytes()) {
                    eprintln!("error: {e}");
                    failed = true;
                }
            }
            Err(d) => {
                report(&name, &text, &d);
                failed = true;
            }
        }
    }
    if failed { ExitCode::from(1) } else { ExitCode::SUCCESS }
}
