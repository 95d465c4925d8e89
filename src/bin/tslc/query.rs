//! `tslc query`: the material templates of a file and their parameters
//! (types, defaults, doc comments, options), as `oslquery` lists a
//! shader's: for people, or with `--json` one object per shader for tools.
//!
//! Invariant: no control character from a file reaches the terminal (doc
//! comments and defaults are the file's text): the human listing escapes
//! them (`diag::printable`), the JSON as `info --json` does.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use tsl::diag::printable;
use tsl::{ParamInfo, ParamValue, Shader};

#[derive(clap::Args)]
pub struct QueryArgs {
    /// The TSL file whose templates to list.
    file: PathBuf,
    /// One template by name (the prelude's too: `rough_conductor`);
    /// without it, every template the file and its imports define.
    name: Option<String>,
    /// Without NAME, list the standard library's templates as well.
    #[arg(long)]
    prelude: bool,
    /// One JSON object per template on stdout.
    #[arg(long)]
    json: bool,
    /// The color model defaults are evaluated in: `rgb`, `spectral`,
    /// `spectralN` or `smitsN`.
    #[arg(long, default_value = "rgb", value_parser = super::parse_color_model)]
    color_model: tsl::ColorModel,
    /// Add a directory to the import search path.
    #[arg(short = 'I', value_name = "DIR")]
    include: Vec<PathBuf>,
}

pub fn query(args: QueryArgs) -> ExitCode {
    // Nothing is compiled: a program compiles each material on first use.
    let mut compiler = tsl::Compiler::new().color_model(args.color_model).file(&args.file).lean(true);
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
    let shaders = match &args.name {
        Some(name) => match program.shader(name) {
            Ok(s) => vec![s],
            Err(e) => {
                eprint!("{e}");
                return ExitCode::from(1);
            }
        },
        None => program.shaders().into_iter().filter(|s| args.prelude || !s.in_prelude()).collect(),
    };
    if shaders.is_empty() {
        let file = args.file.display();
        eprintln!("note: {file} defines no material template (`--prelude` lists the standard library's)");
    }
    let mut out = std::io::stdout().lock();
    for (k, shader) in shaders.iter().enumerate() {
        // A closed stdout (piped into `head`) is not our error.
        let _ = if args.json {
            writeln!(out, "{}", super::info::escape_json_controls(&json(shader).to_string()))
        } else {
            let gap = if k > 0 { "\n" } else { "" };
            write!(out, "{gap}{}", human(shader))
        };
    }
    ExitCode::SUCCESS
}

/// `material NAME`, its doc, then each parameter's declaration with its
/// doc indented under it.
fn human(shader: &Shader) -> String {
    let mut text = format!("material {}\n", shader.name());
    if let Some(doc) = shader.doc() {
        text.push_str(&indented(doc, 4));
    }
    for p in shader.params() {
        text.push_str(&format!("    {}\n", printable(&declaration(p))));
        if let Some(doc) = &p.doc {
            text.push_str(&indented(doc, 8));
        }
    }
    text
}

/// `string distribution = "beckmann" in ("beckmann", "ggx")`, with the
/// evaluated default after it when it reads otherwise (`gray(1)` is
/// `rgb(1, 1, 1)`).
fn declaration(p: &ParamInfo) -> String {
    let mut text = format!("{} {}", p.type_text(), p.name);
    if let Some(source) = &p.default_source {
        text.push_str(&format!(" = {source}"));
        if let Some(value) = p.default.as_ref().map(ToString::to_string).filter(|v| v != source) {
            text.push_str(&format!("  (= {value})"));
        }
    } else {
        text.push_str("  (required)");
    }
    if !p.options.is_empty() {
        let options: Vec<String> = p.options.iter().map(|o| format!("\"{o}\"")).collect();
        text.push_str(&format!(" in ({})", options.join(", ")));
    }
    text
}

fn indented(doc: &str, by: usize) -> String {
    doc.lines().map(|l| format!("{:by$}{}\n", "", printable(l))).collect()
}

fn json(shader: &Shader) -> serde_json::Value {
    let params: Vec<serde_json::Value> = shader
        .params()
        .iter()
        .map(|p| {
            serde_json::json!({
                "name": p.name,
                "type": p.ty.keyword(),
                "array_len": p.array_len,
                "required": p.required(),
                "default_source": p.default_source,
                "default": p.default.as_ref().map(value_json),
                "doc": p.doc,
                "options": p.options,
            })
        })
        .collect();
    serde_json::json!({
        "name": shader.name(),
        "doc": shader.doc(),
        "prelude": shader.in_prelude(),
        "params": params,
    })
}

/// A default as JSON: numbers, booleans and strings as themselves; triples,
/// colors (their lanes in the chosen model) and matrices as arrays.
fn value_json(v: &ParamValue) -> serde_json::Value {
    match v {
        ParamValue::Float(x) => serde_json::json!(x),
        ParamValue::Int(i) => serde_json::json!(i),
        ParamValue::Bool(b) => serde_json::json!(b),
        ParamValue::Triple(t) => serde_json::json!(t),
        ParamValue::Vec2(t) => serde_json::json!(t),
        ParamValue::Color(c) => serde_json::json!(c.lanes()),
        ParamValue::Matrix(m) => serde_json::json!(m),
        ParamValue::String(s) => serde_json::json!(s),
        ParamValue::Material(m) => serde_json::json!(m.source()),
    }
}
