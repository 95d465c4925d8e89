//! Joining the parts of one image (farm tiles, crop windows) into the full
//! frame. Parts must agree on everything that made them (their metadata,
//! the tile aside), must not overlap, and must cover every pixel; a tile
//! that is missing is named by its `--tile` number, so a farm can rerun
//! just that task. The result does not depend on the order of the inputs.
//!
//! Invariant: nothing is allocated by what a file claims before the claim
//! is checked. Every part's header is read and checked first (its windows,
//! tiles, channels and blocks by `exr_read`, each part's samples within the
//! film bound and the frame within the image bounds; here the tile
//! numbers, the overlap and the cover, on windows alone); only then is the
//! frame allocated and the parts' pixels read into it one part at a time.

use super::metadata::{AttributeValue, Metadata, PER_PART, meaning};
use super::{ExrHeader, NO_OBJECT, RenderedImage, read_exr_header, read_exr_with_metadata};
use crate::diag::printable;
use std::path::{Path, PathBuf};

/// Joins tiles or crops of one image (EXR files) into the full frame,
/// with the metadata they share. They must share the frame size, AOVs and
/// metadata (every attribute but [`PER_PART`]'s), must not overlap, and
/// must cover every pixel. Errors name the files and the attribute at
/// fault; missing tiles are named by number (`missing tiles 7 and 12 of
/// 16: rerun with --array=7,12`). Text from the files in errors is
/// escaped ([`printable`]).
pub fn merge(inputs: &[PathBuf]) -> Result<(RenderedImage, Metadata), String> {
    merge_parts(inputs).map_err(|e| printable(&e).into_owned())
}

/// Where a part goes, from its header: the window in the frame and its
/// tile number, `(tsl:tile, tsl:tiles)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Placement {
    x0: u32,
    y0: u32,
    width: u32,
    height: u32,
    tile: Option<(i32, i32)>,
}

impl Placement {
    fn contains(&self, x: u32, y: u32) -> bool {
        (self.x0..self.x0 + self.width).contains(&x) && (self.y0..self.y0 + self.height).contains(&y)
    }
}

/// The layers beside color a part has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Layers {
    albedo: bool,
    normal: bool,
    depth: bool,
    object: bool,
}

impl Layers {
    /// The layers of a header's channels (a triple only when whole).
    fn of(header: &ExrHeader) -> Layers {
        let has = |name: &str| header.channels.iter().any(|c| c == name);
        Layers {
            albedo: ["albedo.R", "albedo.G", "albedo.B"].iter().all(|c| has(c)),
            normal: ["normal.X", "normal.Y", "normal.Z"].iter().all(|c| has(c)),
            depth: has("Z"),
            object: has("object"),
        }
    }

    fn of_image(image: &RenderedImage) -> Layers {
        Layers {
            albedo: image.albedo.is_some(),
            normal: image.normal.is_some(),
            depth: image.depth.is_some(),
            object: image.object.is_some(),
        }
    }
}

fn merge_parts(inputs: &[PathBuf]) -> Result<(RenderedImage, Metadata), String> {
    let first_path = inputs.first().ok_or("nothing to merge")?;
    let first = read_exr_header(first_path)?;
    let (fw, fh) = (first.full_width, first.full_height);
    let layers = Layers::of(&first);
    // Headers one at a time, each checked against the first; only the
    // first's metadata is kept, less the per-part attributes that differ.
    let mut placements = Vec::with_capacity(inputs.len());
    let mut metadata = first.metadata.clone();
    for (k, path) in inputs.iter().enumerate() {
        let read;
        let header = if k == 0 {
            &first
        } else {
            read = read_exr_header(path)?;
            &read
        };
        placements.push(placement(path, header, first_path, &first)?);
        for name in PER_PART {
            if header.metadata.get(name) != first.metadata.get(name) {
                metadata.attributes.remove(*name);
            }
        }
    }
    metadata.attributes.remove("tsl:tile");
    metadata.attributes.remove("tsl:tiles");
    check_tiles(inputs, &placements, (fw, fh))?;
    check_cover(inputs, &placements, (fw, fh))?;
    // The frame is within the image bounds (its header was checked): at
    // most 2^27 pixels, 5.5 GiB with every AOV layer.
    let mut out = frame(fw, fh, layers);
    for (path, at) in inputs.iter().zip(&placements) {
        let (part, _) = read_exr_with_metadata(path)?;
        // Its header was read on its own: the file may have changed since.
        let window = (part.x0, part.y0, part.width, part.height, part.full_width, part.full_height);
        if window != (at.x0, at.y0, at.width, at.height, fw, fh) || Layers::of_image(&part) != layers {
            return Err(format!("{} changed while it was merged", path.display()));
        }
        copy_into(&mut out, &part);
    }
    Ok((out, metadata))
}

/// Where the part at `path` goes, once its header agrees with the
/// first's: the frame, the AOV layers and the metadata (but
/// [`PER_PART`]'s), and a window with color inside the frame.
fn placement(path: &Path, header: &ExrHeader, first_path: &Path, first: &ExrHeader) -> Result<Placement, String> {
    let shown = path.display();
    let (fw, fh) = (first.full_width, first.full_height);
    if (header.full_width, header.full_height) != (fw, fh) {
        return Err(format!(
            "{shown} is a part of a {}x{} image, but {} is of a {fw}x{fh} one",
            header.full_width,
            header.full_height,
            first_path.display()
        ));
    }
    if Layers::of(header) != Layers::of(first) {
        return Err(format!("{shown} and {} differ in their AOV layers", first_path.display()));
    }
    if let Some((name, this, other)) = disagreement(&header.metadata, &first.metadata) {
        let what = meaning(&name).map(|m| format!(" ({m})")).unwrap_or_default();
        return Err(format!(
            "{shown} was rendered with {name}{what} {this}, but {} with {other}: the parts of one image must \
             come from the same scene, settings and frame",
            first_path.display()
        ));
    }
    let cannot = |why: &str| format!("cannot read {shown}: {why}");
    if !["R", "G", "B"].iter().all(|c| header.channels.iter().any(|h| h == c)) {
        return Err(cannot("it has no R, G and B channels"));
    }
    if header.x0 < 0 || header.y0 < 0 {
        return Err(cannot("its data window starts outside its display window"));
    }
    let (x0, y0) = (header.x0 as u32, header.y0 as u32);
    if header.width == 0
        || header.height == 0
        || u64::from(x0) + u64::from(header.width) > u64::from(fw)
        || u64::from(y0) + u64::from(header.height) > u64::from(fh)
    {
        return Err(cannot("its data window lies outside its display window"));
    }
    let tile = header.metadata.int("tsl:tile").zip(header.metadata.int("tsl:tiles"));
    Ok(Placement { x0, y0, width: header.width, height: header.height, tile })
}

/// The first attribute (by name) on which `meta` and `first` differ,
/// leaving out those that differ between parts: its name and both values
/// in words.
fn disagreement(meta: &Metadata, first: &Metadata) -> Option<(String, String, String)> {
    let names = meta.attributes.keys().chain(first.attributes.keys()).filter(|n| !PER_PART.contains(&n.as_str()));
    let mut names: Vec<&String> = names.collect();
    names.sort();
    names.dedup();
    let show =
        |v: Option<&AttributeValue>| v.map_or_else(|| "none (no such attribute)".to_string(), |v| format!("`{v}`"));
    let name = names.into_iter().find(|n| meta.get(n) != first.get(n))?;
    Some((name.clone(), show(meta.get(name)), show(first.get(name))))
}

/// Tiles (parts with `tsl:tile` and `tsl:tiles`): a count a frame `fh`
/// rows high can be cut into (as `--tile` cuts it), each number once, and
/// every number there.
fn check_tiles(inputs: &[PathBuf], placements: &[Placement], (fw, fh): (u32, u32)) -> Result<(), String> {
    let tiles: Option<Vec<(i32, i32)>> = placements.iter().map(|p| p.tile).collect();
    let Some(tiles) = tiles else { return Ok(()) };
    // The counts agree: `tsl:tiles` was compared with the others.
    let count = tiles[0].1;
    if count < 1 || i64::from(count) > i64::from(fh) {
        return Err(format!(
            "{} says it is one of {count} tiles, but the {fw}x{fh} image is cut into 1 to {fh} tiles (--tile I/N \
             cuts it into bands of whole rows)",
            inputs[0].display()
        ));
    }
    let mut owner: Vec<Option<usize>> = vec![None; count as usize];
    for (k, &(index, _)) in tiles.iter().enumerate() {
        let slot = usize::try_from(index).ok().and_then(|i| owner.get_mut(i));
        let Some(slot) = slot else {
            return Err(format!("{} says it is tile {index} of {count}, which does not exist", inputs[k].display()));
        };
        if let Some(other) = *slot {
            return Err(format!(
                "tile {index} of {count} is given twice: {} and {}",
                inputs[other].display(),
                inputs[k].display()
            ));
        }
        *slot = Some(k);
    }
    let missing: Vec<u32> = (0..count as u32).filter(|&i| owner[i as usize].is_none()).collect();
    if missing.is_empty() {
        return Ok(());
    }
    let commands = if missing.len() <= 4 {
        missing.iter().map(|i| format!("--tile {i}/{count}")).collect::<Vec<_>>().join(", ")
    } else {
        format!("--tile I/{count} for each")
    };
    Err(format!(
        "missing tile{} {} of {count}: rerun with --array={} ({commands})",
        if missing.len() == 1 { "" } else { "s" },
        in_words(&missing),
        array_spec(&missing),
    ))
}

/// Numbers as a Slurm `--array` list: ascending, runs as ranges
/// (`3-5,7,12`).
pub fn array_spec(numbers: &[u32]) -> String {
    runs(numbers)
        .iter()
        .map(|&(a, b)| if a == b { a.to_string() } else { format!("{a}-{b}") })
        .collect::<Vec<_>>()
        .join(",")
}

/// Ascending numbers as runs `(first, last)`.
fn runs(numbers: &[u32]) -> Vec<(u32, u32)> {
    let mut out: Vec<(u32, u32)> = Vec::new();
    for &n in numbers {
        match out.last_mut() {
            Some((_, last)) if *last + 1 == n => *last = n,
            _ => out.push((n, n)),
        }
    }
    out
}

/// `7`, `7 and 12`, `3-5, 7 and 12`.
fn in_words(numbers: &[u32]) -> String {
    let items: Vec<String> = runs(numbers)
        .iter()
        .flat_map(|&(a, b)| match b - a {
            0 => vec![a.to_string()],
            1 => vec![a.to_string(), b.to_string()],
            _ => vec![format!("{a}-{b}")],
        })
        .collect();
    match items.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} and {last}", rest.join(", ")),
        _ => items.join(""),
    }
}

/// The windows must not overlap and must cover the frame: checked on the
/// windows alone, with a bit a pixel (16 MiB for the largest frame).
fn check_cover(inputs: &[PathBuf], placements: &[Placement], (fw, fh): (u32, u32)) -> Result<(), String> {
    let mut cover = Coverage::new(fw, fh);
    for (k, p) in placements.iter().enumerate() {
        let (x0, x1) = (p.x0, p.x0 + p.width);
        for y in p.y0..p.y0 + p.height {
            if let Some(x) = cover.first(y, x0, x1, true) {
                let other = placements[..k].iter().position(|q| q.contains(x, y)).unwrap_or(k);
                return Err(format!(
                    "{} and {} overlap at pixel ({x}, {y})",
                    inputs[k].display(),
                    inputs[other].display()
                ));
            }
            cover.set(y, x0, x1);
        }
    }
    let gaps: Vec<(u32, u32)> = (0..fh).filter_map(|y| Some((cover.first(y, 0, fw, false)?, y))).collect();
    let (Some(&(x, y)), Some(&(_, last))) = (gaps.first(), gaps.last()) else { return Ok(()) };
    Err(format!(
        "the parts do not cover the {fw}x{fh} image: pixel ({x}, {y}) is missing, in {} row{} from {y} to {last}",
        gaps.len(),
        if gaps.len() == 1 { "" } else { "s" },
    ))
}

/// Which pixels of a frame a part covers: a bit each, row by row.
struct Coverage {
    width: u64,
    bits: Vec<u64>,
}

impl Coverage {
    fn new(width: u32, height: u32) -> Coverage {
        let n = u64::from(width) * u64::from(height);
        Coverage { width: u64::from(width), bits: vec![0; n.div_ceil(64) as usize] }
    }

    /// The first pixel of row `y` in `x0..x1` that is covered (`covered`)
    /// or not.
    fn first(&self, y: u32, x0: u32, x1: u32, covered: bool) -> Option<u32> {
        let row = u64::from(y) * self.width;
        let (mut i, end) = (row + u64::from(x0), row + u64::from(x1));
        while i < end {
            let (word, mask, span) = Self::word_mask(i, end);
            let bits = if covered { self.bits[word] } else { !self.bits[word] } & mask;
            if bits != 0 {
                return Some((word as u64 * 64 + u64::from(bits.trailing_zeros()) - row) as u32);
            }
            i += span;
        }
        None
    }

    fn set(&mut self, y: u32, x0: u32, x1: u32) {
        let row = u64::from(y) * self.width;
        let (mut i, end) = (row + u64::from(x0), row + u64::from(x1));
        while i < end {
            let (word, mask, span) = Self::word_mask(i, end);
            self.bits[word] |= mask;
            i += span;
        }
    }

    /// The word holding bit `i`, the mask of bits `i..end` in it, and how
    /// many bits that is.
    fn word_mask(i: u64, end: u64) -> (usize, u64, u64) {
        let bit = i % 64;
        let span = (64 - bit).min(end - i);
        let ones = if span == 64 { u64::MAX } else { (1u64 << span) - 1 };
        ((i / 64) as usize, ones << bit, span)
    }
}

/// An empty frame: color and `layers`, with [`NO_OBJECT`] everywhere.
fn frame(fw: u32, fh: u32, layers: Layers) -> RenderedImage {
    let n = fw as usize * fh as usize;
    RenderedImage {
        full_width: fw,
        full_height: fh,
        x0: 0,
        y0: 0,
        width: fw,
        height: fh,
        color: vec![[0.0; 3]; n],
        albedo: layers.albedo.then(|| vec![[0.0; 3]; n]),
        normal: layers.normal.then(|| vec![[0.0; 3]; n]),
        depth: layers.depth.then(|| vec![0.0; n]),
        object: layers.object.then(|| vec![NO_OBJECT; n]),
    }
}

/// Copies a part's pixels into its window of `out`, row by row.
fn copy_into(out: &mut RenderedImage, part: &RenderedImage) {
    fn rows<T: Copy>(dst: &mut [T], src: &[T], out_width: usize, part: &RenderedImage) {
        let w = part.width as usize;
        for (y, row) in src.chunks_exact(w).enumerate() {
            let at = (part.y0 as usize + y) * out_width + part.x0 as usize;
            dst[at..at + w].copy_from_slice(row);
        }
    }
    let fw = out.width as usize;
    rows(&mut out.color, &part.color, fw, part);
    if let (Some(a), Some(pa)) = (&mut out.albedo, &part.albedo) {
        rows(a, pa, fw, part);
    }
    if let (Some(a), Some(pa)) = (&mut out.normal, &part.normal) {
        rows(a, pa, fw, part);
    }
    if let (Some(a), Some(pa)) = (&mut out.depth, &part.depth) {
        rows(a, pa, fw, part);
    }
    if let (Some(a), Some(pa)) = (&mut out.object, &part.object) {
        rows(a, pa, fw, part);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_numbers_read_as_words_and_as_slurm_arrays() {
        assert_eq!((in_words(&[7]), array_spec(&[7])), ("7".into(), "7".into()));
        assert_eq!((in_words(&[7, 12]), array_spec(&[7, 12])), ("7 and 12".into(), "7,12".into()));
        assert_eq!(in_words(&[3, 4, 5, 7, 12]), "3-5, 7 and 12");
        assert_eq!(array_spec(&[3, 4, 5, 7, 12]), "3-5,7,12");
        assert_eq!((in_words(&[0, 1]), array_spec(&[0, 1])), ("0 and 1".into(), "0-1".into()));
    }

    #[test]
    fn coverage_finds_the_first_covered_and_uncovered_pixel_of_a_row() {
        // Rows of 150 bits straddle words at every offset.
        let mut c = Coverage::new(150, 3);
        assert_eq!(c.first(1, 0, 150, false), Some(0));
        assert_eq!(c.first(1, 0, 150, true), None);
        c.set(1, 3, 140);
        assert_eq!(c.first(1, 0, 150, true), Some(3));
        assert_eq!(c.first(1, 60, 70, true), Some(60));
        assert_eq!(c.first(1, 140, 150, true), None);
        assert_eq!(c.first(1, 3, 140, false), None);
        assert_eq!(c.first(1, 0, 150, false), Some(0));
        c.set(1, 0, 3);
        assert_eq!(c.first(1, 0, 150, false), Some(140));
        c.set(1, 140, 150);
        assert_eq!(c.first(1, 0, 150, false), None);
        // Neighbouring rows are untouched.
        assert_eq!((c.first(0, 0, 150, true), c.first(2, 0, 150, true)), (None, None));
        let mut full = Coverage::new(64, 2);
        full.set(0, 0, 64);
        assert_eq!((full.first(0, 0, 64, false), full.first(1, 0, 64, true)), (None, None));
    }
}
