//! `tslc view FILE.exr [--layer NAME] [-o OUT.png]`: one layer of a
//! rendered EXR (radiance or an AOV) as a picture: a PNG with `-o`, else a
//! preview drawn in the terminal (24-bit colour, two pixels a character).

use crate::render::fail;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use tsl::render::image_io::{self, LayerName, RenderedImage};

#[derive(clap::Args)]
pub struct ViewArgs {
    /// An EXR written by `tslc render` (with `--aov` for the AOV layers).
    file: PathBuf,
    /// The layer: color, albedo, normal, depth (or Z) or object.
    #[arg(long, default_value = "color", value_parser = parse_layer)]
    layer: LayerName,
    /// Write the layer as a PNG here instead of drawing it in the terminal.
    #[arg(short, long, value_name = "OUT.png")]
    output: Option<PathBuf>,
    /// Characters across the terminal preview (default: `$COLUMNS`, else 80).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=MAX_PREVIEW_COLUMNS as i64))]
    columns: Option<u32>,
}

/// The widest terminal preview, in characters.
pub const MAX_PREVIEW_COLUMNS: u32 = 1000;

fn parse_layer(s: &str) -> Result<LayerName, String> {
    LayerName::parse(s).ok_or_else(|| format!("`{s}` is not a layer: use color, albedo, normal, depth or object"))
}

pub fn view(args: ViewArgs) -> ExitCode {
    if let Some(out) = &args.output
        && let Err(e) = image_io::prepare_output(out)
    {
        return fail(e);
    }
    let image = match image_io::read_exr(&args.file) {
        Ok(image) => image,
        Err(e) => return fail(e),
    };
    let pixels = match image_io::layer_rgb8(&image, args.layer) {
        Ok(p) => p,
        Err(e) => return fail(format!("{}: {e}", args.file.display())),
    };
    match &args.output {
        Some(out) if out.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) => {
            match image_io::write_png_rgb8(out, image.width, image.height, &pixels) {
                Ok(()) => ExitCode::SUCCESS,
                Err(e) => fail(e),
            }
        }
        Some(out) => fail(format!("cannot write {}: `tslc view` writes .png", out.display())),
        None => {
            let columns = args.columns.unwrap_or_else(terminal_columns);
            // A closed stdout (piped into `head`) is not our error.
            let _ = std::io::stdout().lock().write_all(preview(&image, &pixels, columns).as_bytes());
            ExitCode::SUCCESS
        }
    }
}

fn terminal_columns() -> u32 {
    std::env::var("COLUMNS")
        .ok()
        .and_then(|c| c.parse().ok())
        .filter(|c| (1..=MAX_PREVIEW_COLUMNS).contains(c))
        .unwrap_or(80)
}

/// The picture at most `columns` characters wide, each character two
/// pixels stacked (`▀`, the upper in the foreground colour), nearest
/// sampling; no wider than the image.
fn preview(image: &RenderedImage, pixels: &[[u8; 3]], columns: u32) -> String {
    let (w, h) = (image.width, image.height);
    let cols = columns.min(w).max(1);
    // Terminal cells are about twice as tall as wide: one cell, two rows.
    let rows = (u64::from(h) * u64::from(cols) / u64::from(w)).max(1) as u32;
    let at = |x: u32, y: u32| {
        let (px, py) = (u64::from(x) * u64::from(w) / u64::from(cols), u64::from(y) * u64::from(h) / u64::from(rows));
        pixels[(py * u64::from(w) + px) as usize]
    };
    let mut text = String::new();
    for y in (0..rows).step_by(2) {
        for x in 0..cols {
            let [r, g, b] = at(x, y);
            text += &format!("\x1b[38;2;{r};{g};{b}m");
            if y + 1 < rows {
                let [r, g, b] = at(x, y + 1);
                text += &format!("\x1b[48;2;{r};{g};{b}m");
            }
            text.push('▀');
        }
        text += "\x1b[0m\n";
    }
    text
}
