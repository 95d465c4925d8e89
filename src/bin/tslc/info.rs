//! `tslc info`: what an EXR written by `tslc render` or `tslc merge` says
//! about itself (the frame and window, the channels, and the metadata of
//! `image_io::Metadata`), for people or, with `--json`, for farm scripts.
//!
//! Invariant: no control character from a file reaches the terminal. The
//! header's strings (and file names) are written with their control
//! characters escaped (`diag::printable`, as diagnostics show a file's
//! text); JSON escapes C0 itself, and DEL, C1 (U+009B is CSI to some
//! terminals) and the bidirectional overrides are escaped as `\uXXXX`.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use tsl::diag::printable;
use tsl::image_io::{self, ExrHeader};

#[derive(clap::Args)]
pub struct InfoArgs {
    /// EXR files (as written by `tslc render` and `tslc merge`).
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// One JSON object per file on stdout, its attributes under
    /// `attributes` (numbers as numbers).
    #[arg(long)]
    json: bool,
}

pub fn info(args: InfoArgs) -> ExitCode {
    let mut failed = false;
    let mut out = std::io::stdout().lock();
    for path in &args.files {
        let header = match image_io::read_exr_header(path) {
            Ok(h) => h,
            Err(e) => {
                // Already escaped: the error quotes the file.
                eprintln!("error: {e}");
                failed = true;
                continue;
            }
        };
        let name = path.display().to_string();
        // A closed stdout (piped into `head`) is not our error.
        let _ = if args.json {
            writeln!(out, "{}", escape_json_controls(&json(&name, &header).to_string()))
        } else {
            write!(out, "{}", human(&name, &header))
        };
    }
    if failed { ExitCode::from(1) } else { ExitCode::SUCCESS }
}

fn json(name: &str, h: &ExrHeader) -> serde_json::Value {
    let attributes: serde_json::Map<String, serde_json::Value> =
        h.metadata.attributes.iter().map(|(k, v)| (k.clone(), attribute_json(k, v))).collect();
    serde_json::json!({
        "file": name,
        "resolution": [h.full_width, h.full_height],
        "window": { "x": h.x0, "y": h.y0, "width": h.width, "height": h.height },
        "channels": h.channels,
        "compression": h.compression,
        "attributes": attributes,
    })
}

/// An attribute's JSON value: numbers as numbers, the seed too (an EXR
/// holds it as text, having no 64-bit integers; JSON numbers are exact
/// integers here, though JavaScript reads those above 2^53 inexactly).
fn attribute_json(name: &str, value: &tsl::render::image_io::AttributeValue) -> serde_json::Value {
    match value {
        tsl::render::image_io::AttributeValue::Text(text) if name == "tsl:seed" => {
            text.parse::<u64>().map_or_else(|_| text.clone().into(), Into::into)
        }
        _ => value.to_json(),
    }
}

/// Compact JSON with every character a terminal must not see raw (DEL,
/// C1, the bidirectional overrides: `diag::escape_char`'s rule) escaped
/// too: serde_json escapes only C0. Outside strings JSON text is ASCII, so
/// every such character is inside a string, where `\uXXXX` is the same
/// character.
pub fn escape_json_controls(json: &str) -> String {
    let mut out = String::with_capacity(json.len());
    for c in json.chars() {
        if tsl::diag::escape_char(c) != c {
            out.push_str(&format!("\\u{:04x}", c as u32));
        } else {
            out.push(c);
        }
    }
    out
}

fn human(name: &str, h: &ExrHeader) -> String {
    let mut rows: Vec<(String, String)> = vec![
        ("resolution".into(), format!("{}x{}", h.full_width, h.full_height)),
        (
            "window".into(),
            format!(
                "x {}..{}, y {}..{} ({}x{} pixels{})",
                h.x0,
                h.x0 + h.width as i32,
                h.y0,
                h.y0 + h.height as i32,
                h.width,
                h.height,
                if (h.x0, h.y0, h.width, h.height) == (0, 0, h.full_width, h.full_height) { ", all" } else { "" }
            ),
        ),
        ("channels".into(), printable(&h.channels.join(", ")).into_owned()),
        ("compression".into(), h.compression.clone()),
    ];
    for (key, value) in h.metadata.ordered() {
        let meaning = image_io::meaning(key).map(|m| format!("  ({m})")).unwrap_or_default();
        rows.push((printable(key).into_owned(), format!("{}{meaning}", printable(&value.to_string()))));
    }
    if !h.metadata.is_tsl() {
        rows.push(("".into(), "no tsl:* attributes: not written by tslc".into()));
    }
    let width = rows.iter().map(|(k, _)| k.chars().count()).max().unwrap_or(0);
    let mut text = format!("{}\n", printable(name));
    for (k, v) in rows {
        text.push_str(&format!("  {k:width$}  {v}\n"));
    }
    text
}
