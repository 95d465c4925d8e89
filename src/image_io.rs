//! Reading and writing pictures, for every part of the crate that needs
//! them: image files decoded to linear RGBA floats (PNG, JPEG, Radiance HDR,
//! OpenEXR; textures and environment maps both read them here), rendered
//! images out (PNG, 8-bit sRGB; or OpenEXR, linear float with optional AOV
//! layers), tiles back in and merged, and the windows of crops and farm
//! tiles.
//!
//! Architecture invariant: this is a leaf. It imports neither `texture`
//! nor `render` (both import it), so image decoding has one home and no
//! module cycle runs through it; it writes through `files`, another leaf.
//!
//! Invariants: a write is atomic (`crate::files::atomic_write`: a
//! temporary created exclusively under an unpredictable name in the
//! target's directory, synced, then renamed over the target), so a crash
//! or Ctrl-C never leaves a truncated or clobbered image, and a link
//! planted beside the output never redirects the write; an EXR keeps its
//! window's place in the full frame (display window = the full image, data
//! window = the pixels rendered), so `merge` can put tiles back together;
//! a file read is opened as a regular file (`crate::input_file`) and an
//! EXR's header claims are checked before anything is allocated by them
//! (`exr_read`), so a small file cannot ask for gigabytes.
//!
//! EXR channels: `R`, `G`, `B` (linear radiance); with AOVs also
//! `albedo.R`, `albedo.G`, `albedo.B`, `normal.X`, `normal.Y`, `normal.Z`
//! (world space) and `Z` (distance from the camera; infinite where a ray
//! left the scene), the names OpenImageDenoise front ends and Blender read,
//! and `object`: the index of the object the pixel centre's camera ray hits
//! first (scene order of `object`, `light rect` and `light sphere` blocks,
//! from 0; [`NO_OBJECT`] where it leaves the scene), a whole number stored
//! as float so any EXR reader takes it, for masks that compare images
//! object by object.

mod exr_planes;
mod exr_read;
mod layers;
mod merge;
mod metadata;
mod non_finite;

pub use exr_read::{
    ExrHeader, MAX_EXR_BLOCK_BYTES, MAX_EXR_CHANNELS, MAX_EXR_HEADER_BYTES, MAX_EXR_PARTS, read_exr, read_exr_header,
    read_exr_with_metadata,
};
pub use layers::{LayerName, layer_rgb8};
pub use merge::{array_spec, merge};
pub use metadata::{ATTRIBUTES, AttributeValue, Metadata, PER_PART, SOFTWARE, meaning};
pub use non_finite::{NonFiniteTexels, replace_non_finite};

use crate::files;
use exr::prelude::{self as exrp, WritableImage};
use exr_planes::Plane;
use exr_read::{ExrBounds, ExrLayer};
use std::path::{Path, PathBuf};

/// How the stored values of an image become linear values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Encoding {
    /// Decode the sRGB transfer curve: 8- and 16-bit color pictures
    /// (PNG, JPEG) hold display-referred values. Alpha stays linear.
    Srgb,
    /// The values as stored (for 8-bit files, `value / 255`): HDR and EXR
    /// images, and data such as height maps and masks.
    Raw,
}

/// A decoded picture: `width` x `height` RGBA texels, row by row, the
/// first row at the top.
#[derive(Debug, Clone, PartialEq)]
pub struct Picture {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[f32; 4]>,
    /// Whether the file had an alpha channel (alpha is 1 otherwise).
    pub has_alpha: bool,
}

/// The largest edge of a picture read (a texture or an environment
/// image): bigger pictures would take gigabytes.
pub const MAX_IMAGE_SIZE: u32 = 16384;

/// The largest image side rendered, in pixels (`width`, `height`,
/// `--res`), and of the frames `merge` joins and `info` reads.
pub const MAX_IMAGE_SIDE: u32 = 65536;
/// The most pixels an image may have: 2^27 (134 million, such as
/// 16384 x 8192; the film alone then takes 1.6 GB).
pub const MAX_PIXELS: u64 = 1 << 27;

/// The most memory the pixels of one image may take (4 GiB), checked
/// before they are allocated: a render's film (`render::film_bytes`;
/// beyond it, render in tiles and `merge` them) and the samples of an EXR
/// part read.
pub const FILM_BUDGET_BYTES: u64 = 4 << 30;

/// The largest image file read (8 GiB: a 16384 x 16384 RGBA float EXR
/// stored uncompressed is 4 GiB).
pub const MAX_IMAGE_FILE_BYTES: u64 = 8 << 30;

/// Reads an image file at full resolution: PNG, JPEG, Radiance HDR or
/// OpenEXR, chosen by extension. The error says what is wrong in words.
pub fn read_picture(path: &Path, encoding: Encoding) -> Result<Picture, String> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
    let srgb = encoding == Encoding::Srgb;
    match ext.as_str() {
        "exr" => read_exr_picture(path),
        "hdr" => read_with_image_crate(path, false),
        "png" | "jpg" | "jpeg" => read_with_image_crate(path, srgb),
        _ => Err(format!("`{}` is not an image format TSL reads (PNG, JPEG, Radiance HDR, OpenEXR)", path.display())),
    }
}

fn check_size(width: u32, height: u32) -> Result<(), String> {
    if width == 0 || height == 0 {
        return Err("the image is empty".into());
    }
    if width > MAX_IMAGE_SIZE || height > MAX_IMAGE_SIZE {
        return Err(format!("the image is {width} x {height}; at most {MAX_IMAGE_SIZE} pixels a side are accepted"));
    }
    Ok(())
}

/// `srgb`: decode the sRGB curve from the color channels (alpha stays
/// linear).
fn read_with_image_crate(path: &Path, srgb: bool) -> Result<Picture, String> {
    let (file, _) = crate::input_file::open_bounded(path, MAX_IMAGE_FILE_BYTES, "an image file")?;
    // As `ImageReader::open`: the format the extension names, unless the
    // contents say otherwise.
    let mut reader = image::ImageReader::new(std::io::BufReader::new(file));
    if let Ok(format) = image::ImageFormat::from_path(path) {
        reader.set_format(format);
    }
    let mut reader = reader.with_guessed_format().map_err(|e| e.to_string())?;
    // Refuse oversized pictures before decoding them.
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIZE);
    limits.max_image_height = Some(MAX_IMAGE_SIZE);
    reader.limits(limits);
    let decoded = reader.decode().map_err(|e| e.to_string())?;
    let (width, height) = (decoded.width(), decoded.height());
    check_size(width, height)?;
    let has_alpha = decoded.color().has_alpha();
    // (Gray pictures convert through another path in the image crate, one
    // ulp away on some values: they keep it.)
    let eight_bit = matches!(decoded, image::DynamicImage::ImageRgb8(_) | image::DynamicImage::ImageRgba8(_));
    let texels = if eight_bit {
        // Each channel value through a table of the 256 values: the same
        // numbers as converting every texel (`into_rgba32f`'s k / 255, then
        // the curve), without a `powf` per channel.
        let unit: [f32; 256] = std::array::from_fn(|k| f32::from(k as u8) / 255.0);
        let color = unit.map(|v| if srgb { srgb_to_linear(v) } else { v });
        let rgba = decoded.into_rgba8();
        rgba.pixels()
            .map(|p| {
                let [r, g, b, a] = p.0.map(usize::from);
                [color[r], color[g], color[b], unit[a]]
            })
            .collect()
    } else {
        let mut texels: Vec<[f32; 4]> = decoded.into_rgba32f().pixels().map(|p| p.0).collect();
        if srgb {
            for t in &mut texels {
                for c in &mut t[..3] {
                    *c = srgb_to_linear(*c);
                }
            }
        }
        texels
    };
    Ok(Picture { width, height, texels, has_alpha })
}

fn read_exr_picture(path: &Path) -> Result<Picture, String> {
    let layer = ExrLayer::read(path, ExrBounds::PICTURE)?;
    let (width, height) = (layer.width as u32, layer.height as u32);
    check_size(width, height)?;
    let channels = ["R", "G", "B", "Y", "A"].map(|name| layer.channel(name));
    let [r, g, b, y, a] = channels.each_ref().map(Option::as_deref);
    let (r, g, b) = match (r, g, b, y) {
        (Some(r), Some(g), Some(b), _) => (r, g, b),
        (_, _, _, Some(y)) => (y, y, y),
        _ => return Err("it has neither R, G, B nor Y channels".into()),
    };
    let texels = (0..r.len()).map(|k| [r[k], g[k], b[k], a.map_or(1.0, |a| a[k])]).collect();
    Ok(Picture { width, height, texels, has_alpha: a.is_some() })
}

/// The sRGB transfer curve, decoded.
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.040_45 { v / 12.92 } else { ((v + 0.055) / 1.055).powf(2.4) }
}

/// The `object` layer's value where a pixel's ray hits nothing.
pub const NO_OBJECT: i32 = -1;

/// A rendered image, or a window of one: pixels `[x0, x0 + width) x
/// [y0, y0 + height)` of a `full_width x full_height` frame, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderedImage {
    pub full_width: u32,
    pub full_height: u32,
    pub x0: u32,
    pub y0: u32,
    pub width: u32,
    pub height: u32,
    /// Linear RGB.
    pub color: Vec<[f32; 3]>,
    pub albedo: Option<Vec<[f32; 3]>>,
    pub normal: Option<Vec<[f32; 3]>>,
    pub depth: Option<Vec<f32>>,
    /// The object index per pixel ([`NO_OBJECT`] for none).
    pub object: Option<Vec<i32>>,
}

impl RenderedImage {
    fn check(&self) -> Result<(), String> {
        let n = self.width as usize * self.height as usize;
        if self.width == 0 || self.height == 0 {
            return Err("the image is empty".into());
        }
        if self.x0 + self.width > self.full_width || self.y0 + self.height > self.full_height {
            return Err("the image window lies outside its frame".into());
        }
        let aov_ok = self.albedo.as_ref().is_none_or(|a| a.len() == n)
            && self.normal.as_ref().is_none_or(|a| a.len() == n)
            && self.depth.as_ref().is_none_or(|a| a.len() == n)
            && self.object.as_ref().is_none_or(|a| a.len() == n);
        if self.color.len() != n || !aov_ok {
            return Err(format!("the pixel buffers do not hold {}x{} pixels", self.width, self.height));
        }
        Ok(())
    }
}

/// The sRGB transfer curve of a linear value, clamped to [0, 1] and
/// rounded to 8 bits.
pub fn srgb_encode(linear: f32) -> u8 {
    let x = if linear.is_nan() { 0.0 } else { linear.clamp(0.0, 1.0) };
    let v = if x <= 0.003_130_8 { 12.92 * x } else { 1.055 * x.powf(1.0 / 2.4) - 0.055 };
    (v * 255.0 + 0.5).floor().clamp(0.0, 255.0) as u8
}

enum Format {
    Png,
    Exr,
}

fn format_of(path: &Path) -> Result<Format, String> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("png") => Ok(Format::Png),
        Some("exr") => Ok(Format::Exr),
        _ => Err(format!("cannot write {}: the file name must end in .png or .exr", path.display())),
    }
}

/// Whether an image can be written to `path`, checked before rendering:
/// a known extension, an existing directory, not a directory itself, and
/// permission to create a file beside it (a probe is created, exclusively
/// under an unpredictable name, and removed: `files::check_writable`).
/// Errors name `path`.
pub fn check_output(path: &Path) -> Result<(), String> {
    format_of(path)?;
    files::directory_of(path)?;
    if path.is_dir() {
        return Err(format!("cannot write {}: it is a directory", path.display()));
    }
    files::check_writable(path)
}

/// [`check_output`] after making the output's missing directories (as
/// `mkdir -p`); a wrong extension is refused before any directory is made.
pub fn prepare_output(path: &Path) -> Result<(), String> {
    format_of(path)?;
    files::create_directory_of(path)?;
    check_output(path)
}

/// Writes the image, choosing the format by extension (`.png` or `.exr`).
/// A PNG holds just the window's pixels; an EXR keeps the window's place
/// in the full frame.
pub fn write_image(path: &Path, image: &RenderedImage) -> Result<(), String> {
    write_image_with(path, image, &Metadata::default())
}

/// [`write_image`], with `metadata` in an EXR's header (a PNG has none).
/// The same image and metadata are the same bytes. The write is atomic
/// (`files::atomic_write`).
pub fn write_image_with(path: &Path, image: &RenderedImage, metadata: &Metadata) -> Result<(), String> {
    let format = format_of(path)?;
    image.check().map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    files::atomic_write(path, |file| match format {
        Format::Png => write_png(file, image),
        Format::Exr => write_exr(file, image, metadata),
    })
}

/// The image as a PNG into `file`; the error is the reason.
fn write_png(file: &mut std::fs::File, image: &RenderedImage) -> Result<(), String> {
    use std::io::Write;
    let bytes = encode_png(image)?;
    file.write_all(&bytes).map_err(|e| e.to_string())
}

/// The image's color as an 8-bit sRGB PNG file in memory (what
/// [`write_image`] writes to a `.png`; `tslc watch --serve` sends it).
pub fn encode_png(image: &RenderedImage) -> Result<Vec<u8>, String> {
    let pixels: Vec<[u8; 3]> = image.color.iter().map(|p| p.map(srgb_encode)).collect();
    encode_png_rgb8(image.width, image.height, &pixels)
}

/// 8-bit RGB pixels, row by row, as a PNG file in memory.
pub fn encode_png_rgb8(width: u32, height: u32, pixels: &[[u8; 3]]) -> Result<Vec<u8>, String> {
    use image::ImageEncoder;
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(pixels.as_flattened(), width, height, image::ExtendedColorType::Rgb8)
        .map_err(|e| format!("cannot encode a PNG image: {e}"))?;
    Ok(png)
}

/// 8-bit RGB pixels written to a `.png`, atomically (`files::atomic_write`).
pub fn write_png_rgb8(path: &Path, width: u32, height: u32, pixels: &[[u8; 3]]) -> Result<(), String> {
    let png = encode_png_rgb8(width, height, pixels)?;
    files::atomic_write(path, |file| {
        use std::io::Write;
        file.write_all(&png).map_err(|e| e.to_string())
    })
}

/// The image as an EXR into `file`; the error is the reason.
fn write_exr(file: &mut std::fs::File, image: &RenderedImage, metadata: &Metadata) -> Result<(), String> {
    use exrp::{AnyChannel, AnyChannels, Encoding, Image, ImageAttributes, Layer, LayerAttributes, Vec2};
    // Each channel read from the image in place: no copy of a layer.
    let mut channels: Vec<AnyChannel<Plane<'_>>> =
        ["R", "G", "B"].iter().enumerate().map(|(k, c)| AnyChannel::new(*c, Plane::Lane(&image.color, k))).collect();
    if let Some(a) = &image.albedo {
        for (k, c) in ["R", "G", "B"].iter().enumerate() {
            channels.push(AnyChannel::new(format!("albedo.{c}").as_str(), Plane::Lane(a, k)));
        }
    }
    if let Some(n) = &image.normal {
        for (k, c) in ["X", "Y", "Z"].iter().enumerate() {
            channels.push(AnyChannel::new(format!("normal.{c}").as_str(), Plane::Lane(n, k)));
        }
    }
    if let Some(d) = &image.depth {
        channels.push(AnyChannel::new("Z", Plane::Floats(d)));
    }
    if let Some(o) = &image.object {
        channels.push(AnyChannel::new("object", Plane::Indices(o)));
    }
    let position = Vec2(image.x0 as i32, image.y0 as i32);
    let mut attributes = LayerAttributes::default().with_position(position);
    let (software, other) = metadata.to_exr();
    attributes.software_name = software;
    attributes.other.extend(other);
    // Blocks in increasing order (compressed in parallel, written in
    // order), so the file does not depend on which thread finished first.
    let encoding = Encoding { line_order: exrp::LineOrder::Increasing, ..Encoding::FAST_LOSSLESS };
    let layer = Layer::new(
        (image.width as usize, image.height as usize),
        attributes,
        encoding,
        AnyChannels::sort(channels.into()),
    );
    let frame = exrp::IntegerBounds::from_dimensions((image.full_width as usize, image.full_height as usize));
    let out = Image::new(ImageAttributes::new(frame), layer);
    out.write().to_unbuffered(&mut *file).map_err(|e| e.to_string())?;
    metadata::sort_header_attributes_of(file)
}

/// A lat-long environment image: `width` x `height` linear RGB texels,
/// row by row, the first row at the top.
#[derive(Debug, Clone, PartialEq)]
pub struct LatLong {
    pub width: u32,
    pub height: u32,
    /// Every value finite: what was not is 0 and reported in `non_finite`.
    pub rgb: Vec<[f32; 3]>,
    pub non_finite: Option<NonFiniteTexels>,
}

/// A lat-long environment image as linear RGB: EXR and Radiance HDR as
/// stored, PNG and JPEG decoded from sRGB. Values that are not numbers
/// are replaced by 0 ([`replace_non_finite`]) and reported in the result.
pub fn load_environment(path: &Path) -> Result<LatLong, String> {
    // The renderer filters the full-resolution image itself: no pyramid.
    let picture = read_picture(path, Encoding::Srgb)
        .map_err(|e| format!("cannot read the environment image {}: {e}", path.display()))?;
    let mut rgb: Vec<[f32; 3]> = picture.texels.iter().map(|t| [t[0], t[1], t[2]]).collect();
    drop(picture.texels);
    let non_finite = replace_non_finite(&mut rgb, picture.width);
    Ok(LatLong { width: picture.width, height: picture.height, rgb, non_finite })
}

/// The window of tile `index` of `count` (0-based): horizontal bands of
/// whole rows, as even as possible, as `(x0, y0, width, height)`.
pub fn tile_window(full_width: u32, full_height: u32, index: u32, count: u32) -> Result<(u32, u32, u32, u32), String> {
    if count == 0 || index >= count {
        return Err(format!("tile {index}/{count}: the index must be at least 0 and below the count"));
    }
    if count > full_height {
        return Err(format!("cannot cut {full_height} rows into {count} tiles: use at most {full_height}"));
    }
    let y0 = (u64::from(full_height) * u64::from(index) / u64::from(count)) as u32;
    let y1 = (u64::from(full_height) * u64::from(index + 1) / u64::from(count)) as u32;
    Ok((0, y0, full_width, y1 - y0))
}

/// Whether an output path has a frame pattern: a run of `#` in its file
/// name (`shot.####.exr`).
pub fn has_frame_pattern(path: &Path) -> bool {
    path.file_name().is_some_and(|n| n.to_string_lossy().contains('#'))
}

/// The output path of frame `frame`: each run of `#` in the file name is
/// replaced by the frame number, zero-padded to the run's length (as
/// Blender and Houdini name frames: `shot.####.exr` gives `shot.0007.exr`,
/// frame -3 `shot.-003.exr`); a path without `#` is returned as is.
pub fn frame_path(path: &Path, frame: i32) -> PathBuf {
    let Some(name) = path.file_name().map(|n| n.to_string_lossy().into_owned()) else { return path.to_path_buf() };
    let mut out = String::with_capacity(name.len() + 8);
    let mut chars = name.chars().peekable();
    while let Some(c) = chars.next() {
        if c != '#' {
            out.push(c);
            continue;
        }
        let mut width = 1;
        while chars.next_if_eq(&'#').is_some() {
            width += 1;
        }
        out.push_str(&format!("{frame:0width$}"));
    }
    path.with_file_name(out)
}

/// A crop window `x0,x1,y0,y1`: fractions of the image in [0, 1] (as
/// pbrt's `--cropwindow`; pixels from `floor(x0 W)` to `ceil(x1 W)`) when
/// all four are at most 1, otherwise pixel numbers with `x1`, `y1`
/// exclusive. Returns `(x0, y0, width, height)`.
pub fn parse_crop(spec: &str, full_width: u32, full_height: u32) -> Result<(u32, u32, u32, u32), String> {
    let bad = |why: &str| format!("bad crop window `{spec}`: {why}");
    let values: Vec<f64> = spec
        .split(',')
        .map(|s| s.trim().parse::<f64>().map_err(|_| bad("write four numbers x0,x1,y0,y1")))
        .collect::<Result<_, _>>()?;
    let [x0, x1, y0, y1] = values[..] else { return Err(bad("write four numbers x0,x1,y0,y1")) };
    if values.iter().any(|v| !v.is_finite() || *v < 0.0) {
        return Err(bad("the numbers must be finite and not negative"));
    }
    let (w, h) = (f64::from(full_width), f64::from(full_height));
    let (px0, px1, py0, py1) = if values.iter().all(|v| *v <= 1.0) {
        ((x0 * w).floor(), (x1 * w).ceil(), (y0 * h).floor(), (y1 * h).ceil())
    } else {
        // Pixel numbers: a fraction among them (`0,1.5,0,1`) is a mistake.
        if let Some(v) = values.iter().find(|v| v.fract() != 0.0) {
            return Err(bad(&format!(
                "{v} is neither a fraction in [0, 1] nor a pixel number: write all four as fractions or as whole pixels"
            )));
        }
        (x0, x1, y0, y1)
    };
    if px1 <= px0 || py1 <= py0 {
        return Err(bad("the window is empty (x1 must exceed x0 and y1 exceed y0)"));
    }
    if px1 > w || py1 > h {
        return Err(bad(&format!("the window reaches beyond the {full_width}x{full_height} image")));
    }
    Ok((px0 as u32, py0 as u32, (px1 - px0) as u32, (py1 - py0) as u32))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::temp_dir;

    fn image(full: (u32, u32), window: (u32, u32, u32, u32), aov: bool, seed: f32) -> RenderedImage {
        let (x0, y0, w, h) = window;
        let n = (w * h) as usize;
        let color: Vec<[f32; 3]> = (0..n).map(|k| [k as f32 * 0.25 + seed, -1.5, f32::MAX]).collect();
        RenderedImage {
            full_width: full.0,
            full_height: full.1,
            x0,
            y0,
            width: w,
            height: h,
            color,
            albedo: aov.then(|| vec![[0.5, 0.25, 0.125]; n]),
            normal: aov.then(|| vec![[0.0, 1.0, -0.0]; n]),
            depth: aov.then(|| (0..n).map(|k| if k == 0 { f32::INFINITY } else { k as f32 }).collect()),
            object: aov.then(|| (0..n).map(|k| k as i32 - 1).collect()),
        }
    }

    fn leftovers(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains(".tmp-"))
            .collect()
    }

    #[test]
    fn eight_bit_pictures_decode_as_each_texel_converted_on_its_own() {
        let dir = temp_dir("eight-bit");
        // Every byte value in every channel, in RGBA, RGB and gray.
        let rgba = image::RgbaImage::from_fn(256, 2, |x, y| {
            let k = x as u8;
            image::Rgba([k, k.wrapping_add(85 * y as u8), 255 - k, k.wrapping_mul(7)])
        });
        let gray = image::GrayImage::from_fn(256, 1, |x, _| image::Luma([x as u8]));
        let (a, b, c) = (dir.join("rgba.png"), dir.join("gray.png"), dir.join("rgb.png"));
        rgba.save(&a).unwrap();
        gray.save(&b).unwrap();
        image::DynamicImage::ImageRgba8(rgba).into_rgb8().save(&c).unwrap();
        for path in [a, b, c] {
            let reference: Vec<[f32; 4]> = image::open(&path).unwrap().into_rgba32f().pixels().map(|p| p.0).collect();
            for encoding in [Encoding::Srgb, Encoding::Raw] {
                let picture = read_picture(&path, encoding).unwrap();
                assert_eq!(picture.texels.len(), reference.len());
                for (got, want) in picture.texels.iter().zip(&reference) {
                    let curve = |c: f32| if encoding == Encoding::Srgb { srgb_to_linear(c) } else { c };
                    let want = [curve(want[0]), curve(want[1]), curve(want[2]), want[3]];
                    assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "{} {encoding:?}", path.display());
                }
            }
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn srgb_known_values() {
        assert_eq!(srgb_encode(0.0), 0);
        assert_eq!(srgb_encode(1.0), 255);
        assert_eq!(srgb_encode(7.0), 255);
        assert_eq!(srgb_encode(-1.0), 0);
        assert_eq!(srgb_encode(f32::NAN), 0);
        assert_eq!(srgb_encode(0.5), 188);
        assert_eq!(srgb_encode(0.003_130_8), 10);
        assert!((srgb_to_linear(188.0 / 255.0) - 0.5).abs() < 0.003);
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_to_linear(0.5) - 0.214_041).abs() < 1e-5);
    }

    #[test]
    fn exr_round_trips_bit_exactly_with_window_and_aovs() {
        let dir = temp_dir("roundtrip");
        for aov in [false, true] {
            let img = image((7, 5), (2, 1, 4, 3), aov, 0.1);
            let path = dir.join(format!("a{aov}.exr"));
            write_image(&path, &img).unwrap();
            let back = read_exr(&path).unwrap();
            assert_eq!(
                back.color.iter().map(|p| p.map(f32::to_bits)).collect::<Vec<_>>(),
                img.color.iter().map(|p| p.map(f32::to_bits)).collect::<Vec<_>>()
            );
            assert_eq!(
                (back.full_width, back.full_height, back.x0, back.y0, back.width, back.height),
                (7, 5, 2, 1, 4, 3)
            );
            assert_eq!(back.albedo, img.albedo);
            assert_eq!(
                back.normal.map(|n| n.iter().map(|p| p.map(f32::to_bits)).collect::<Vec<_>>()),
                img.normal.map(|n| n.iter().map(|p| p.map(f32::to_bits)).collect())
            );
            assert_eq!(back.depth, img.depth);
            assert_eq!(back.object, img.object);
        }
        assert!(leftovers(&dir).is_empty());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn png_is_srgb_of_the_window() {
        let dir = temp_dir("png");
        let mut img = image((4, 4), (0, 0, 2, 1), false, 0.0);
        img.color = vec![[0.5, 0.0, 1.0], [0.0031308, 2.0, -1.0]];
        let path = dir.join("x.PNG");
        write_image(&path, &img).unwrap();
        let back = image::open(&path).unwrap().into_rgb8();
        assert_eq!(back.dimensions(), (2, 1));
        assert_eq!(back.get_pixel(0, 0).0, [188, 0, 255]);
        assert_eq!(back.get_pixel(1, 0).0, [10, 255, 0]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn failed_writes_leave_nothing_and_keep_the_old_file() {
        let dir = temp_dir("atomic");
        let missing = dir.join("no/such/dir/out.png");
        let e = write_image(&missing, &image((2, 2), (0, 0, 2, 2), false, 0.0)).unwrap_err();
        assert!(e.contains("does not exist") && e.contains("out.png"), "{e}");
        let path = dir.join("keep.exr");
        std::fs::write(&path, b"precious").unwrap();
        let mut bad = image((2, 2), (0, 0, 2, 2), false, 0.0);
        bad.color.pop();
        assert!(write_image(&path, &bad).unwrap_err().contains("pixel buffers"));
        assert_eq!(std::fs::read(&path).unwrap(), b"precious");
        let e = write_image(&dir.join("x.tiff"), &image((2, 2), (0, 0, 2, 2), false, 0.0)).unwrap_err();
        assert!(e.contains(".png or .exr"), "{e}");
        assert!(leftovers(&dir).is_empty());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn merge_joins_tiles_and_reports_gaps_and_overlaps() {
        let dir = temp_dir("merge");
        let mut paths = Vec::new();
        for i in 0..3 {
            let (x0, y0, w, h) = tile_window(7, 5, i, 3).unwrap();
            let path = dir.join(format!("t{i}.exr"));
            write_image(&path, &image((7, 5), (x0, y0, w, h), true, i as f32)).unwrap();
            paths.push(path);
        }
        let (full, _) = merge(&paths).unwrap();
        assert_eq!((full.width, full.height, full.color.len()), (7, 5, 35));
        // Row 0 comes from tile 0 (seed 0), the last row from tile 2.
        assert_eq!(full.color[0][0], 0.0);
        let (_, y2, _, _) = tile_window(7, 5, 2, 3).unwrap();
        assert_eq!(full.color[(y2 * 7) as usize][0], 2.0);
        let gap = merge(&paths[..2]).unwrap_err();
        assert!(gap.contains("missing"), "{gap}");
        let overlap = merge(&[paths[0].clone(), paths[0].clone(), paths[1].clone(), paths[2].clone()]).unwrap_err();
        assert!(overlap.contains("overlap"), "{overlap}");
        let other = dir.join("other.exr");
        write_image(&other, &image((8, 5), (0, 0, 8, 5), true, 0.0)).unwrap();
        assert!(merge(&[paths[0].clone(), other]).unwrap_err().contains("8x5"));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn metadata_round_trips_and_a_header_is_the_same_bytes_every_time() {
        let dir = temp_dir("metadata");
        let mut meta = Metadata::default();
        meta.set_text(SOFTWARE, "tslc 9.9").set_int("tsl:spp", 64).set_float("tsl:time", 0.5);
        for k in 0..12 {
            meta.set_text(&format!("tsl:extra{k}"), format!("välue {k} ☃"));
        }
        let img = image((6, 4), (0, 1, 6, 2), true, 0.5);
        let bytes: Vec<Vec<u8>> = (0..4)
            .map(|k| {
                let path = dir.join(format!("m{k}.exr"));
                write_image_with(&path, &img, &meta).unwrap();
                std::fs::read(&path).unwrap()
            })
            .collect();
        assert!(bytes.iter().all(|b| *b == bytes[0]), "the same image and metadata gave other bytes");
        let (back, read) = read_exr_with_metadata(&dir.join("m0.exr")).unwrap();
        assert_eq!(back.color, img.color);
        // Text is Latin-1 in EXR: what it cannot hold reads back as `?`.
        meta.attributes.values_mut().for_each(|v| {
            if let AttributeValue::Text(t) = v {
                *t = t.replace('☃', "?");
            }
        });
        assert_eq!(read, meta);
        let header = read_exr_header(&dir.join("m0.exr")).unwrap();
        assert_eq!((header.full_width, header.full_height, header.y0, header.height), (6, 4, 1, 2));
        assert!(header.channels.contains(&"albedo.R".to_string()));
        assert_eq!(header.metadata, meta);
        let mut garbage = b"v/1\x01not an exr".to_vec();
        assert!(metadata::sort_header_attributes(&mut garbage).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn tiles_and_crops() {
        let bands: Vec<_> = (0..4).map(|i| tile_window(10, 10, i, 4).unwrap()).collect();
        assert_eq!(bands, [(0, 0, 10, 2), (0, 2, 10, 3), (0, 5, 10, 2), (0, 7, 10, 3)]);
        assert!(tile_window(10, 10, 4, 4).is_err());
        assert!(tile_window(10, 3, 0, 4).is_err());
        assert_eq!(parse_crop("0.25,0.75,0,0.5", 100, 50).unwrap(), (25, 0, 50, 25));
        assert_eq!(parse_crop("10,20,5,9", 100, 50).unwrap(), (10, 5, 10, 4));
        assert!(parse_crop("0.5,0.5,0,1", 100, 50).unwrap_err().contains("empty"));
        assert!(parse_crop("0,200,0,10", 100, 50).unwrap_err().contains("beyond"));
        assert!(parse_crop("1,2,3", 100, 50).is_err());
        assert!(parse_crop("a,b,c,d", 100, 50).is_err());
        // A fraction among pixel numbers is not one pixel wide: it is refused.
        assert!(parse_crop("0,1.5,0,1", 100, 50).unwrap_err().contains("neither a fraction"));
    }

    #[test]
    fn frame_patterns_take_the_frame_number_padded() {
        let p = |s: &str, f: i32| frame_path(Path::new(s), f).display().to_string();
        assert_eq!(p("out/shot.####.exr", 7), "out/shot.0007.exr");
        assert_eq!(p("out/shot.#.exr", 123), "out/shot.123.exr");
        assert_eq!(p("shot_##_v#.png", 5), "shot_05_v5.png");
        assert_eq!(p("shot.####.exr", -3), "shot.-003.exr");
        assert_eq!(p("dir#/shot.exr", 3), "dir#/shot.exr");
        assert!(has_frame_pattern(Path::new("a/b.##.exr")) && !has_frame_pattern(Path::new("a#/b.exr")));
    }

    #[test]
    fn environment_images_load_linear() {
        let dir = temp_dir("env");
        let png = dir.join("sky.png");
        image::save_buffer(&png, &[188, 0, 255, 255, 255, 255], 2, 1, image::ColorType::Rgb8).unwrap();
        let LatLong { width: w, height: h, rgb: t, non_finite } = load_environment(&png).unwrap();
        assert_eq!((w, h, non_finite), (2, 1, None));
        assert!((t[0][0] - 0.5).abs() < 0.003 && t[0][1] == 0.0 && t[1][2] == 1.0);
        let exr = dir.join("sky.exr");
        write_image(&exr, &image((3, 2), (0, 0, 3, 2), false, 0.0)).unwrap();
        assert_eq!(load_environment(&exr).unwrap().rgb[1][0], 0.25);
        std::fs::write(dir.join("bad.png"), b"not a png").unwrap();
        assert!(load_environment(&dir.join("bad.png")).unwrap_err().contains("bad.png"));
        assert!(load_environment(&dir.join("none.hdr")).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
