//! Reading OpenEXR files: the header first, bounded, and every size it
//! claims checked against the documented bounds before the exr crate
//! allocates a pixel, then the pixels of the first part.
//!
//! Why: the crate reads headers in bounded steps, but then trusts them. It
//! allocates every channel of the data window before it reads a block (a
//! 160 KB file claiming a 20000 x 20000 window asks for gigabytes), and a
//! block's buffer of the size the block claims, up to the tile's size. So
//! the header is read from a reader that fails past
//! [`MAX_EXR_HEADER_BYTES`], and [`check_claims`] refuses windows, frames,
//! tiles, channels, parts and offset tables beyond the bounds before the
//! same open file (no second open that another file could answer) is
//! handed on for its pixels.

use super::metadata::Metadata;
use super::{FILM_BUDGET_BYTES, MAX_IMAGE_FILE_BYTES, MAX_IMAGE_SIDE, MAX_IMAGE_SIZE, MAX_PIXELS, RenderedImage};
use crate::diag::printable;
use crate::input_file::{self, size_in_words};
use exr::prelude::{self as exrp, FlatSamples, ReadChannels, ReadLayers};
use std::borrow::Cow;
use std::fs::File;
use std::io::{self, BufReader, Read, Seek, SeekFrom};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// The most bytes of headers read from an EXR file (16 MiB): TSL's are
/// about a kilobyte, and a preview image in another tool's header a few
/// hundred. A header that has not ended by then is refused.
pub const MAX_EXR_HEADER_BYTES: u64 = 16 << 20;
/// The most parts (headers) an EXR file may have: compositors write tens.
pub const MAX_EXR_PARTS: usize = 256;
/// The most channels a part may have (TSL writes 3, or 11 with AOVs).
pub const MAX_EXR_CHANNELS: usize = 1024;
/// The most one block of pixels (a tile, or a run of scan lines) may take
/// decoded (256 MiB): the crate allocates a block's buffer at the size the
/// block claims, up to this.
pub const MAX_EXR_BLOCK_BYTES: u64 = 256 << 20;

/// An EXR file's header: the frame, the window, the channels and the
/// metadata, read without the pixels (for `tslc info` and `tslc merge`),
/// its claims checked against the bounds of rendered images.
#[derive(Debug, Clone, PartialEq)]
pub struct ExrHeader {
    /// The display window's size: the full image.
    pub full_width: u32,
    pub full_height: u32,
    /// The data window: the pixels the file holds, in the full image.
    pub x0: i32,
    pub y0: i32,
    pub width: u32,
    pub height: u32,
    pub channels: Vec<String>,
    pub compression: String,
    pub metadata: Metadata,
}

/// What an EXR's claims are checked against.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct ExrBounds {
    /// The longest side of the data window (and display window, with
    /// `frame`).
    max_side: u32,
    max_pixels: u64,
    /// Whether the display window is used (merging places parts in it).
    frame: bool,
}

impl ExrBounds {
    /// Renders, their parts and what `merge` makes of them: the scene's
    /// image bounds, the display window included.
    pub(super) const RENDERED: ExrBounds = ExrBounds { max_side: MAX_IMAGE_SIDE, max_pixels: MAX_PIXELS, frame: true };
    /// Textures and environment images: [`MAX_IMAGE_SIZE`] a side; the
    /// display window is not used.
    pub(super) const PICTURE: ExrBounds =
        ExrBounds { max_side: MAX_IMAGE_SIZE, max_pixels: MAX_IMAGE_SIZE as u64 * MAX_IMAGE_SIZE as u64, frame: false };
}

/// Reads the header of an EXR file (its first part), without the pixels.
/// Its claims must be within the bounds of a rendered image. Errors name
/// the file; text from the file in them is escaped ([`printable`]).
pub fn read_exr_header(path: &Path) -> Result<ExrHeader, String> {
    let fail = |e: String| format!("cannot read {}: {}", printable(&path.display().to_string()), printable(&e));
    let (mut source, len) = HeaderBound::open(path).map_err(fail)?;
    let meta = exr::meta::MetaData::read_from_buffered(&mut source, false).map_err(|e| fail(source.explain(&e)))?;
    check_claims(&meta, source.position(), len, ExrBounds::RENDERED).map_err(fail)?;
    let header = meta.headers.first().ok_or_else(|| fail("it has no header".into()))?;
    let frame = header.shared_attributes.display_window;
    let pos = header.own_attributes.layer_position;
    Ok(ExrHeader {
        full_width: frame.size.0 as u32,
        full_height: frame.size.1 as u32,
        x0: pos.0 - frame.position.0,
        y0: pos.1 - frame.position.1,
        width: header.layer_size.0 as u32,
        height: header.layer_size.1 as u32,
        channels: header.channels.list.iter().map(|c| c.name.to_string()).collect(),
        compression: format!("{:?}", header.compression),
        metadata: Metadata::from_exr(&header.own_attributes, &header.shared_attributes),
    })
}

/// The first layer of an EXR file: its channels by name, its size, and
/// where it sits in the display window.
pub(super) struct ExrLayer {
    pub width: usize,
    pub height: usize,
    pub display_size: (usize, usize),
    /// The data window's position relative to the display window's.
    pub offset: (i32, i32),
    channels: Vec<(String, FlatSamples)>,
    pub metadata: Metadata,
}

impl ExrLayer {
    /// Reads the first layer at its largest resolution, once its header's
    /// claims are within `bounds`. The error does not name the file.
    pub(super) fn read(path: &Path, bounds: ExrBounds) -> Result<ExrLayer, String> {
        let (source, len) = HeaderBound::open(path)?;
        let limit = source.limit.clone();
        let chunks = exr::block::reader::Reader::read_from_buffered(source, false).map_err(|e| limit.explain(&e))?;
        check_claims(chunks.meta_data(), limit.position(), len, bounds)?;
        // The header is read and checked: the pixels may follow.
        limit.lift();
        let image = exrp::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .from_chunks(chunks)
            .map_err(|e| limit.explain(&e))?;
        let layer = image.layer_data;
        let frame = image.attributes.display_window;
        let pos = layer.attributes.layer_position;
        Ok(ExrLayer {
            width: layer.size.0,
            height: layer.size.1,
            display_size: (frame.size.0, frame.size.1),
            offset: (pos.0 - frame.position.0, pos.1 - frame.position.1),
            metadata: Metadata::from_exr(&layer.attributes, &image.attributes),
            channels: layer.channel_data.list.into_iter().map(|c| (c.name.to_string(), c.sample_data)).collect(),
        })
    }

    /// The samples of channel `name`, row by row, as floats (borrowed
    /// when the file holds 32-bit floats).
    pub(super) fn channel(&self, name: &str) -> Option<Cow<'_, [f32]>> {
        let (_, samples) = self.channels.iter().find(|(n, _)| n == name)?;
        Some(match samples {
            FlatSamples::F32(values) => Cow::Borrowed(values.as_slice()),
            other => Cow::Owned(other.values_as_f32().collect()),
        })
    }
}

/// Checks what every part of the file claims against `bounds` and the
/// file's own length (`len`; its headers took `header_bytes`), before the
/// crate allocates anything by those claims. The error quotes the claim.
fn check_claims(meta: &exr::meta::MetaData, header_bytes: u64, len: u64, bounds: ExrBounds) -> Result<(), String> {
    let parts = meta.headers.len();
    if parts > MAX_EXR_PARTS {
        return Err(format!("it has {parts} parts; at most {MAX_EXR_PARTS} are read"));
    }
    let mut chunks = 0u64;
    for (k, header) in meta.headers.iter().enumerate() {
        let it = if parts == 1 { "it".to_string() } else { format!("its part {k}") };
        let channels = header.channels.list.len();
        if channels > MAX_EXR_CHANNELS {
            return Err(format!("{it} claims {channels} channels; a part may have at most {MAX_EXR_CHANNELS}"));
        }
        let (w, h) = (header.layer_size.0 as u64, header.layer_size.1 as u64);
        check_window(&it, "data window", w, h, bounds)?;
        if bounds.frame {
            let frame = header.shared_attributes.display_window.size;
            check_window(&it, "display window (the full frame)", frame.0 as u64, frame.1 as u64, bounds)?;
        }
        let per_pixel = header.channels.bytes_per_pixel as u64;
        let decoded = w * h * per_pixel;
        if decoded > FILM_BUDGET_BYTES {
            return Err(format!(
                "{it} claims a {w} x {h} data window of {channels} channels, which would take {} decoded, more \
                 than the {} an image may take",
                size_in_words(decoded),
                size_in_words(FILM_BUDGET_BYTES)
            ));
        }
        let (block, shape) = match header.blocks {
            exr::meta::BlockDescription::Tiles(tiles) => {
                let (tw, th) = (tiles.tile_size.0 as u64, tiles.tile_size.1 as u64);
                (tw.saturating_mul(th).saturating_mul(per_pixel), format!("{tw} x {th} tiles"))
            }
            exr::meta::BlockDescription::ScanLines => {
                let lines = header.compression.scan_lines_per_block() as u64;
                (w * lines * per_pixel, format!("blocks of {lines} scan lines {w} pixels wide"))
            }
        };
        if block > MAX_EXR_BLOCK_BYTES {
            return Err(format!(
                "{it} claims {shape} of {per_pixel} bytes a pixel, {} a block; a block may take at most {}",
                size_in_words(block),
                size_in_words(MAX_EXR_BLOCK_BYTES)
            ));
        }
        chunks += header.chunk_count as u64;
    }
    // Each block has an 8-byte entry in the offset table after the headers.
    let table = chunks.saturating_mul(8);
    if header_bytes.saturating_add(table) > len.saturating_add(1) {
        return Err(format!(
            "it claims {chunks} blocks of pixels, but at {len} bytes the file is too short for even their offset \
             table ({table} bytes): it is cut short or its header is wrong"
        ));
    }
    Ok(())
}

/// A window of `w` x `h` pixels within `bounds`.
fn check_window(it: &str, what: &str, w: u64, h: u64, bounds: ExrBounds) -> Result<(), String> {
    if w > u64::from(bounds.max_side) || h > u64::from(bounds.max_side) {
        return Err(format!("{it} claims a {w} x {h} {what}; an image is at most {} pixels a side", bounds.max_side));
    }
    if w * h > bounds.max_pixels {
        return Err(format!(
            "{it} claims a {w} x {h} {what}, {} pixels; an image holds at most {} pixels",
            w * h,
            bounds.max_pixels
        ));
    }
    Ok(())
}

/// The limit a [`HeaderBound`] reads within, shared with its reader once
/// the crate owns it.
#[derive(Debug, Default)]
struct Limit {
    /// Reads past this position fail.
    end: AtomicU64,
    /// The position reached.
    position: AtomicU64,
    /// Whether a read failed at `end`.
    hit: AtomicBool,
}

impl Limit {
    fn lift(&self) {
        self.end.store(u64::MAX, Ordering::Relaxed);
    }

    fn position(&self) -> u64 {
        self.position.load(Ordering::Relaxed)
    }

    /// The crate's error in words; a read stopped at the header bound
    /// says so.
    fn explain(&self, e: &exr::error::Error) -> String {
        if self.hit.load(Ordering::Relaxed) {
            format!(
                "its header does not end within {}, the most read of an EXR header",
                size_in_words(MAX_EXR_HEADER_BYTES)
            )
        } else {
            e.to_string()
        }
    }
}

/// An open EXR file, buffered, whose reads fail past the shared
/// [`Limit`] (at first [`MAX_EXR_HEADER_BYTES`]).
struct HeaderBound {
    inner: BufReader<File>,
    limit: Arc<Limit>,
}

impl HeaderBound {
    /// Opens `path` as a regular file of at most [`MAX_IMAGE_FILE_BYTES`]
    /// ([`input_file::open_bounded`]); also its length.
    fn open(path: &Path) -> Result<(HeaderBound, u64), String> {
        let (file, len) = input_file::open_bounded(path, MAX_IMAGE_FILE_BYTES, "an image file")?;
        let limit = Arc::new(Limit { end: AtomicU64::new(MAX_EXR_HEADER_BYTES), ..Limit::default() });
        Ok((HeaderBound { inner: BufReader::new(file), limit }, len))
    }

    fn position(&self) -> u64 {
        self.limit.position()
    }

    fn explain(&self, e: &exr::error::Error) -> String {
        self.limit.explain(e)
    }
}

impl Read for HeaderBound {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let position = self.limit.position();
        let room = self.limit.end.load(Ordering::Relaxed).saturating_sub(position);
        if room == 0 && !buf.is_empty() {
            self.limit.hit.store(true, Ordering::Relaxed);
            return Err(io::Error::new(io::ErrorKind::InvalidData, "the EXR header is too long"));
        }
        let want = buf.len().min(usize::try_from(room).unwrap_or(usize::MAX));
        let n = self.inner.read(&mut buf[..want])?;
        self.limit.position.store(position + n as u64, Ordering::Relaxed);
        Ok(n)
    }
}

impl Seek for HeaderBound {
    fn seek(&mut self, to: SeekFrom) -> io::Result<u64> {
        let at = self.inner.seek(to)?;
        self.limit.position.store(at, Ordering::Relaxed);
        Ok(at)
    }
}

/// Reads an EXR written by [`super::write_image`] (or any EXR with R, G, B).
pub fn read_exr(path: &Path) -> Result<RenderedImage, String> {
    read_exr_with_metadata(path).map(|(image, _)| image)
}

/// [`read_exr`], and the metadata in the file's header. The header's
/// claims must be within the bounds of a rendered image.
pub fn read_exr_with_metadata(path: &Path) -> Result<(RenderedImage, Metadata), String> {
    let fail = |e: String| format!("cannot read {}: {}", printable(&path.display().to_string()), printable(&e));
    let layer = ExrLayer::read(path, ExrBounds::RENDERED).map_err(fail)?;
    let triple = |names: [&str; 3]| -> Option<Vec<[f32; 3]>> {
        let [a, b, c] = names.map(|n| layer.channel(n));
        let (a, b, c) = (a?, b?, c?);
        Some((0..a.len()).map(|k| [a[k], b[k], c[k]]).collect())
    };
    let color = triple(["R", "G", "B"]).ok_or_else(|| fail("it has no R, G and B channels".into()))?;
    let (x0, y0) = layer.offset;
    if x0 < 0 || y0 < 0 {
        return Err(fail("its data window starts outside its display window".into()));
    }
    let out = RenderedImage {
        full_width: layer.display_size.0 as u32,
        full_height: layer.display_size.1 as u32,
        x0: x0 as u32,
        y0: y0 as u32,
        width: layer.width as u32,
        height: layer.height as u32,
        color,
        albedo: triple(["albedo.R", "albedo.G", "albedo.B"]),
        normal: triple(["normal.X", "normal.Y", "normal.Z"]),
        depth: layer.channel("Z").map(Cow::into_owned),
        object: layer.channel("object").map(|o| o.iter().map(|&k| k as i32).collect()),
    };
    out.check().map_err(fail)?;
    Ok((out, layer.metadata))
}
