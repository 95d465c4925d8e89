//! Joining the parts of one image (farm tiles, crop windows) into the full
//! frame. Parts must agree on everything that made them (their metadata,
//! the tile aside), must not overlap, and must cover every pixel; a tile
//! that is missing is named by its `--tile` number, so a farm can rerun
//! just that task. The result does not depend on the order of the inputs.

use super::metadata::{AttributeValue, Metadata, PER_PART, meaning};
use super::{NO_OBJECT, RenderedImage, read_exr_with_metadata};
use std::path::PathBuf;

/// Joins tiles or crops of one image (EXR files) into the full frame,
/// with the metadata they share. They must share the frame size, AOVs and
/// metadata (every attribute but [`PER_PART`]'s), must not overlap, and
/// must cover every pixel. Errors name the files and the attribute at
/// fault; missing tiles are named by number (`missing tiles 7 and 12 of
/// 16: rerun with --array=7,12`).
pub fn merge(inputs: &[PathBuf]) -> Result<(RenderedImage, Metadata), String> {
    let first_path = inputs.first().ok_or("nothing to merge")?;
    let parts: Vec<(RenderedImage, Metadata)> =
        inputs.iter().map(|p| read_exr_with_metadata(p)).collect::<Result<_, _>>()?;
    let (first, first_meta) = &parts[0];
    let (fw, fh) = (first.full_width, first.full_height);
    for (k, (part, meta)) in parts.iter().enumerate() {
        let path = inputs[k].display();
        if (part.full_width, part.full_height) != (fw, fh) {
            return Err(format!(
                "{path} is a part of a {}x{} image, but {} is of a {fw}x{fh} one",
                part.full_width,
                part.full_height,
                first_path.display()
            ));
        }
        if part.albedo.is_some() != first.albedo.is_some()
            || part.normal.is_some() != first.normal.is_some()
            || part.depth.is_some() != first.depth.is_some()
            || part.object.is_some() != first.object.is_some()
        {
            return Err(format!("{path} and {} differ in their AOV layers", first_path.display()));
        }
        if let Some((name, this, other)) = disagreement(meta, first_meta) {
            let what = meaning(&name).map(|m| format!(" ({m})")).unwrap_or_default();
            return Err(format!(
                "{path} was rendered with {name}{what} {this}, but {} with {other}: the parts of one image must \
                 come from the same scene, settings and frame",
                first_path.display()
            ));
        }
    }
    check_tiles(inputs, &parts)?;
    let out = place(inputs, &parts)?;
    // What every part shares: the per-part attributes only where all agree.
    let mut metadata = first_meta.clone();
    for name in PER_PART {
        if parts.iter().any(|(_, m)| m.get(name) != first_meta.get(name)) {
            metadata.attributes.remove(*name);
        }
    }
    metadata.attributes.remove("tsl:tile");
    metadata.attributes.remove("tsl:tiles");
    Ok((out, metadata))
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

/// Tiles (parts with `tsl:tile` and `tsl:tiles`): each number once, and
/// every number there.
fn check_tiles(inputs: &[PathBuf], parts: &[(RenderedImage, Metadata)]) -> Result<(), String> {
    let tiles: Option<Vec<(i32, i32)>> =
        parts.iter().map(|(_, m)| Some((m.int("tsl:tile")?, m.int("tsl:tiles")?))).collect();
    let Some(tiles) = tiles else { return Ok(()) };
    // The counts agree: `tsl:tiles` was compared with the others.
    let count = tiles[0].1;
    let mut owner: Vec<Option<usize>> = vec![None; usize::try_from(count).unwrap_or(0)];
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

/// Puts every part's pixels in the full frame; an overlap or a pixel no
/// part covers is an error.
fn place(inputs: &[PathBuf], parts: &[(RenderedImage, Metadata)]) -> Result<RenderedImage, String> {
    let first = &parts[0].0;
    let (fw, fh) = (first.full_width, first.full_height);
    let n = fw as usize * fh as usize;
    let mut out = RenderedImage {
        full_width: fw,
        full_height: fh,
        x0: 0,
        y0: 0,
        width: fw,
        height: fh,
        color: vec![[0.0; 3]; n],
        albedo: first.albedo.as_ref().map(|_| vec![[0.0; 3]; n]),
        normal: first.normal.as_ref().map(|_| vec![[0.0; 3]; n]),
        depth: first.depth.as_ref().map(|_| vec![0.0; n]),
        object: first.object.as_ref().map(|_| vec![NO_OBJECT; n]),
    };
    let mut owner: Vec<Option<usize>> = vec![None; n];
    for (k, (part, _)) in parts.iter().enumerate() {
        for y in 0..part.height {
            for x in 0..part.width {
                let src = (y * part.width + x) as usize;
                let dst = ((part.y0 + y) * fw + part.x0 + x) as usize;
                if let Some(other) = owner[dst] {
                    return Err(format!(
                        "{} and {} overlap at pixel ({}, {})",
                        inputs[k].display(),
                        inputs[other].display(),
                        part.x0 + x,
                        part.y0 + y
                    ));
                }
                owner[dst] = Some(k);
                out.color[dst] = part.color[src];
                if let (Some(a), Some(pa)) = (&mut out.albedo, &part.albedo) {
                    a[dst] = pa[src];
                }
                if let (Some(a), Some(pa)) = (&mut out.normal, &part.normal) {
                    a[dst] = pa[src];
                }
                if let (Some(a), Some(pa)) = (&mut out.depth, &part.depth) {
                    a[dst] = pa[src];
                }
                if let (Some(a), Some(pa)) = (&mut out.object, &part.object) {
                    a[dst] = pa[src];
                }
            }
        }
    }
    if let Some(missing) = owner.iter().position(Option::is_none) {
        let rows: Vec<u32> = (0..fh).filter(|y| (0..fw).any(|x| owner[(y * fw + x) as usize].is_none())).collect();
        return Err(format!(
            "the parts do not cover the {fw}x{fh} image: pixel ({}, {}) is missing, in {} row{} from {} to {}",
            missing as u32 % fw,
            missing as u32 / fw,
            rows.len(),
            if rows.len() == 1 { "" } else { "s" },
            rows[0],
            rows[rows.len() - 1]
        ));
    }
    Ok(out)
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
}
