//! UDIM tile sets: one texture made of many images, one per unit square of
//! (u, v), named by a pattern such as `"wood.<UDIM>.png"` (MaterialX's
//! `<UDIM>` token, Mari's numbering).
//!
//! Tile `1001 + u_tile + 10 * v_tile` covers u in `[u_tile, u_tile + 1)`
//! and v in `[v_tile, v_tile + 1)`, for `u_tile` in 0..10: u in [0, 1) is
//! tile 1001, u in [1, 2) tile 1002, v in [1, 2) adds 10 (1011). Opening a
//! set ([`UdimSet::open`]) lists the pattern's directory once and records
//! the tiles present, reading no pixels; a tile's pixels are read and
//! mip-mapped on its first lookup (once, whichever thread asks first), so a
//! set of hundreds of 8K tiles costs only the tiles a render sees.
//!
//! Invariant: a lookup never fails. Outside the tile grid, in a tile the
//! set does not have, or in a tile whose file cannot be read, it is
//! transparent black; a failed read is remembered in its tile
//! ([`UdimSet::failures`]), and the renderer reports it as an error after
//! the render (`render::render`).

use super::TextureManager;
use super::mipmap::MipMap;
use super::sampler::Lookup;
use crate::image_io::Encoding;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

/// The token a texture path names a tile set with: `"wood.<UDIM>.png"`.
pub const UDIM_TOKEN: &str = "<UDIM>";

/// The number of the tile at u in [0, 1), v in [0, 1).
pub const FIRST_UDIM_TILE: u32 = 1001;

/// The highest tile number: a tile number has four digits, so a set has
/// ten tiles a row (u in [0, 10)) and at most 900 rows (v in [0, 900); the
/// last row ends at u = 9, tile 9999).
/// Files whose number is outside `FIRST_UDIM_TILE..=LAST_UDIM_TILE`
/// (`wood.0999.png`, `wood.1000.png`) have no place on the grid: they are
/// left out of the set, with a warning.
pub const LAST_UDIM_TILE: u32 = 9999;

/// Tiles per row of the grid: u runs over [0, 10).
pub const UDIM_ROW: u32 = 10;

/// Whether a texture path names a tile set rather than one image.
///
/// ```
/// assert!(tsl::texture::is_udim_pattern("wood.<UDIM>.png"));
/// assert!(!tsl::texture::is_udim_pattern("wood.1001.png"));
/// ```
pub fn is_udim_pattern(path: &str) -> bool {
    path.contains(UDIM_TOKEN)
}

/// The tile that (s, t) falls in, or `None` outside the grid (u outside
/// [0, 10), v below 0 or past the last row).
///
/// ```
/// use tsl::texture::udim_tile_at;
/// assert_eq!(udim_tile_at(0.5, 0.5), Some(1001));
/// assert_eq!(udim_tile_at(1.5, 0.5), Some(1002));
/// assert_eq!(udim_tile_at(0.5, 1.5), Some(1011));
/// assert_eq!(udim_tile_at(10.5, 0.5), None);
/// ```
pub fn udim_tile_at(s: f32, t: f32) -> Option<u32> {
    let rows = (LAST_UDIM_TILE - FIRST_UDIM_TILE).div_ceil(UDIM_ROW);
    let (u, v) = (s.floor(), t.floor());
    // Also false for NaN.
    if !((0.0..UDIM_ROW as f32).contains(&u) && (0.0..rows as f32).contains(&v)) {
        return None;
    }
    Some(FIRST_UDIM_TILE + u as u32 + UDIM_ROW * v as u32).filter(|&n| n <= LAST_UDIM_TILE)
}

/// A tile set's path split around its token: `dir/prefix<UDIM>suffix`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UdimPattern {
    /// The directory part as written (empty for none).
    pub dir: PathBuf,
    pub prefix: String,
    pub suffix: String,
}

impl UdimPattern {
    /// Splits `path`; the error says what is wrong with where the token is.
    ///
    /// ```
    /// let p = tsl::texture::UdimPattern::parse("maps/wood.<UDIM>.png").unwrap();
    /// assert_eq!((p.prefix.as_str(), p.suffix.as_str()), ("wood.", ".png"));
    /// assert_eq!(p.file_name(1002), "wood.1002.png");
    /// assert!(tsl::texture::UdimPattern::parse("<UDIM>/wood.png").is_err());
    /// ```
    pub fn parse(path: &str) -> Result<UdimPattern, String> {
        let path = Path::new(path);
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        let Some((prefix, suffix)) = name.split_once(UDIM_TOKEN) else {
            return Err(format!("the `{UDIM_TOKEN}` token must be in the file name, not in a directory"));
        };
        if suffix.contains(UDIM_TOKEN) || path.parent().is_some_and(|d| d.to_string_lossy().contains(UDIM_TOKEN)) {
            return Err(format!("a tile set's path has one `{UDIM_TOKEN}` token"));
        }
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Ok(UdimPattern { dir, prefix: prefix.to_string(), suffix: suffix.to_string() })
    }

    /// The file name of tile `number`.
    pub fn file_name(&self, number: u32) -> String {
        format!("{}{number:04}{}", self.prefix, self.suffix)
    }

    /// The tile number a file name gives, if it matches the pattern (four
    /// digits in place of the token), whether or not the grid has it.
    pub fn number_of(&self, name: &str) -> Option<u32> {
        let digits = name.strip_prefix(&self.prefix)?.strip_suffix(&self.suffix)?;
        if digits.len() != 4 || !digits.bytes().all(|c| c.is_ascii_digit()) {
            return None;
        }
        digits.parse().ok()
    }
}

/// One tile of a set: its number, its file, and its pyramid once read.
#[derive(Debug)]
pub struct UdimTile {
    pub number: u32,
    pub path: PathBuf,
    /// The pyramid or why it could not be read, set on the first lookup.
    image: OnceLock<Result<Arc<MipMap>, String>>,
}

impl UdimTile {
    /// The pyramid, if the first lookup has read it.
    pub fn loaded(&self) -> Option<&Arc<MipMap>> {
        self.image.get().and_then(|r| r.as_ref().ok())
    }
}

/// The tiles of one pattern in one directory, decoded with one encoding.
#[derive(Debug)]
pub struct UdimSet {
    /// The pattern joined to the directory it was found in, for messages.
    pub name: String,
    pub encoding: Encoding,
    /// By number, ascending.
    pub tiles: Vec<UdimTile>,
    /// Files matching the pattern whose number is not on the grid
    /// (`wood.0999.png`): left out.
    pub off_grid: Vec<PathBuf>,
    /// Tiles are read through it, so a tile shares its pyramid with any
    /// other program naming the same file.
    textures: Arc<TextureManager>,
    /// Whether some tile failed to load (checked once per render tile, so
    /// an atomic flag rather than a scan of the tiles).
    failed: AtomicBool,
}

impl UdimSet {
    /// The tiles of `pattern` in `dir` (the pattern's own directory part
    /// already joined to it), or `None` when none exists there (the
    /// directory too may not exist). Reads the directory's names only.
    pub fn open(
        dir: &Path,
        pattern: &UdimPattern,
        encoding: Encoding,
        textures: Arc<TextureManager>,
    ) -> Result<Option<UdimSet>, String> {
        // An empty directory (a source in the current one) lists `.`, but
        // tiles are named as the source's other files are: `wood.1001.png`.
        let listed = if dir.as_os_str().is_empty() { Path::new(".") } else { dir };
        let entries = match std::fs::read_dir(listed) {
            Ok(entries) => entries,
            Err(e) if matches!(e.kind(), std::io::ErrorKind::NotFound | std::io::ErrorKind::NotADirectory) => {
                return Ok(None);
            }
            Err(e) => return Err(format!("cannot list `{}`: {}", dir.display(), crate::input_file::reason(&e))),
        };
        let (mut tiles, mut off_grid) = (Vec::new(), Vec::new());
        for entry in entries {
            let entry = entry.map_err(|e| format!("cannot list `{}`: {}", dir.display(), e))?;
            let name = entry.file_name();
            let Some(number) = name.to_str().and_then(|n| pattern.number_of(n)) else { continue };
            let path = dir.join(&name);
            if (FIRST_UDIM_TILE..=LAST_UDIM_TILE).contains(&number) {
                tiles.push(UdimTile { number, path, image: OnceLock::new() });
            } else {
                off_grid.push(path);
            }
        }
        if tiles.is_empty() {
            return Ok(None);
        }
        tiles.sort_by_key(|t| t.number);
        off_grid.sort();
        let name = dir.join(format!("{}{UDIM_TOKEN}{}", pattern.prefix, pattern.suffix)).display().to_string();
        Ok(Some(UdimSet { name, encoding, tiles, off_grid, textures, failed: AtomicBool::new(false) }))
    }

    /// The tile numbered `number`, if the set has it.
    pub fn tile(&self, number: u32) -> Option<&UdimTile> {
        self.tiles.binary_search_by_key(&number, |t| t.number).ok().map(|k| &self.tiles[k])
    }

    /// The pyramid of the tile that `q` falls in and the lookup moved into
    /// that tile's unit square (the footprint unchanged: a tile spans one
    /// unit, as a single image does). `None` outside the grid, in a missing
    /// tile, or in one that failed to load. Reads the tile on first use.
    pub fn lookup(&self, q: &Lookup) -> Option<(&MipMap, Lookup)> {
        let number = udim_tile_at(q.s, q.t)?;
        let tile = self.tile(number)?;
        let image = tile.image.get_or_init(|| {
            let loaded = self.textures.load(&tile.path, self.encoding);
            if loaded.is_err() {
                self.failed.store(true, Ordering::Relaxed);
            }
            loaded
        });
        let image = image.as_ref().ok()?;
        Some((image, Lookup { s: q.s - q.s.floor(), t: q.t - q.t.floor(), ..*q }))
    }

    /// Whether some tile has failed to load.
    pub fn has_failed(&self) -> bool {
        self.failed.load(Ordering::Relaxed)
    }

    /// The tiles that failed to load and why, by number.
    pub fn failures(&self) -> Vec<(&UdimTile, &str)> {
        self.tiles.iter().filter_map(|t| Some((t, t.image.get()?.as_ref().err()?.as_str()))).collect()
    }

    /// How many tiles have been read (successfully or not).
    pub fn tiles_read(&self) -> usize {
        self.tiles.iter().filter(|t| t.image.get().is_some()).count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::temp_dir;

    fn tile_png(path: &Path, rgb: [u8; 3]) {
        image::RgbImage::from_pixel(4, 4, image::Rgb(rgb)).save(path).unwrap();
    }

    #[test]
    fn tile_numbers_follow_mari() {
        assert_eq!(udim_tile_at(0.0, 0.0), Some(1001));
        assert_eq!(udim_tile_at(0.999, 0.999), Some(1001));
        assert_eq!(udim_tile_at(1.0, 0.0), Some(1002));
        assert_eq!(udim_tile_at(9.5, 0.0), Some(1010));
        assert_eq!(udim_tile_at(0.0, 1.0), Some(1011));
        assert_eq!(udim_tile_at(2.5, 3.5), Some(1033));
        assert_eq!(udim_tile_at(9.9, 898.5), Some(9990));
        assert_eq!(udim_tile_at(8.5, 899.5), Some(LAST_UDIM_TILE));
        for (s, t) in
            [(9.5, 899.5), (-0.1, 0.5), (10.0, 0.5), (0.5, -0.01), (0.5, 900.0), (f32::NAN, 0.5), (0.5, f32::INFINITY)]
        {
            assert_eq!(udim_tile_at(s, t), None, "({s}, {t})");
        }
    }

    #[test]
    fn patterns_split_around_one_token_in_the_file_name() {
        let p = UdimPattern::parse("wood.<UDIM>.png").unwrap();
        assert_eq!(p, UdimPattern { dir: PathBuf::new(), prefix: "wood.".into(), suffix: ".png".into() });
        assert_eq!(p.number_of("wood.1011.png"), Some(1011));
        assert_eq!(p.number_of("wood.0999.png"), Some(999));
        for other in ["wood.101.png", "wood.10011.png", "wood.10a1.png", "wood.1001.png.bak", "oak.1001.png"] {
            assert_eq!(p.number_of(other), None, "{other}");
        }
        assert!(UdimPattern::parse("<UDIM>/wood.png").unwrap_err().contains("file name"));
        assert!(UdimPattern::parse("a.<UDIM>.<UDIM>.png").unwrap_err().contains("one"));
        assert_eq!(UdimPattern::parse("maps/<UDIM>.exr").unwrap().dir, PathBuf::from("maps"));
    }

    #[test]
    fn opening_lists_tiles_and_reads_no_pixels() {
        let dir = temp_dir("udim-open");
        for (n, rgb) in [(1001, [255, 0, 0]), (1002, [0, 255, 0]), (1011, [0, 0, 255])] {
            tile_png(&dir.join(format!("wood.{n}.png")), rgb);
        }
        // Off the grid, or not matching: left out.
        tile_png(&dir.join("wood.0999.png"), [9, 9, 9]);
        std::fs::write(dir.join("wood.1003.png.bak"), b"x").unwrap();
        // Corrupt, and never looked up: no error.
        std::fs::write(dir.join("wood.1021.png"), b"not a png").unwrap();
        let pattern = UdimPattern::parse("wood.<UDIM>.png").unwrap();
        let textures = Arc::new(TextureManager::new());
        let set = UdimSet::open(&dir, &pattern, Encoding::Raw, textures.clone()).unwrap().unwrap();
        let numbers: Vec<u32> = set.tiles.iter().map(|t| t.number).collect();
        assert_eq!(numbers, [1001, 1002, 1011, 1021]);
        assert_eq!(set.off_grid, [dir.join("wood.0999.png")]);
        assert_eq!((set.tiles_read(), textures.loaded()), (0, 0), "opening reads no pixels");
        let at = |s: f32, t: f32| {
            let (image, q) = set.lookup(&Lookup { s, t, ..Lookup::default() })?;
            Some((image.levels[0].texels[0], q.s, q.t))
        };
        let (red, s, t) = at(0.25, 0.75).unwrap();
        assert_eq!((red, s, t), ([1.0, 0.0, 0.0, 1.0], 0.25, 0.75));
        assert_eq!(at(1.25, 0.5).unwrap().0, [0.0, 1.0, 0.0, 1.0]);
        let (blue, s, t) = at(0.5, 1.25).unwrap();
        assert_eq!((blue, s, t), ([0.0, 0.0, 1.0, 1.0], 0.5, 0.25));
        assert_eq!((set.tiles_read(), textures.loaded()), (3, 3), "only the tiles looked up are read");
        assert!(at(2.5, 0.5).is_none(), "no tile 1003");
        assert!(at(-0.5, 0.5).is_none(), "off the grid");
        assert!(!set.has_failed());
        assert!(at(0.5, 2.5).is_none(), "tile 1021 cannot be read");
        assert!(set.has_failed());
        let failures = set.failures();
        assert_eq!(failures.len(), 1);
        assert_eq!(failures[0].0.number, 1021);
        // Another pattern, or a directory that is not there: no set.
        let other = UdimPattern::parse("oak.<UDIM>.png").unwrap();
        assert!(UdimSet::open(&dir, &other, Encoding::Raw, textures.clone()).unwrap().is_none());
        assert!(UdimSet::open(&dir.join("none"), &pattern, Encoding::Raw, textures).unwrap().is_none());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
