//! The texture manager: images loaded once per file, mip-mapped at load,
//! shared by every program and thread that uses them, and the filtered
//! lookups behind the `texture` builtins.
//!
//! A program names its images with string literals (`texture("wood.png",
//! st)`); the front end resolves each path relative to the file that
//! contains the call and loads it through a [`TextureManager`] while
//! checking, so a missing or corrupt image is a located error before any
//! code runs. Lowering turns each call into an IR texture instruction that
//! holds its [`Sampler`] (the image with a filter and address modes); both
//! back ends call [`sampler::tsl_texture`] with it.
//!
//! ```
//! use tsl::texture::{Encoding, Level, MipMap};
//! let base = Level { width: 2, height: 2, texels: vec![[1.0, 0.0, 0.0, 1.0]; 4] };
//! let image = MipMap::new("red", base, false);
//! assert_eq!(image.levels.len(), 2);
//! # let _ = Encoding::Srgb;
//! ```

mod mipmap;
mod sampler;
mod udim;

// Decoding lives in the leaf `image_io`, which the renderer shares.
pub use crate::image_io::{Encoding, MAX_IMAGE_SIZE, srgb_to_linear};
pub use mipmap::{Level, MipMap};
pub use sampler::{Filter, Lookup, Sampler, SpectralLanes, TextureImage, Wrap, tsl_texture, tsl_texture_spectrum};
pub use udim::{
    FIRST_UDIM_TILE, LAST_UDIM_TILE, UDIM_ROW, UDIM_TOKEN, UdimPattern, UdimSet, UdimTile, is_udim_pattern,
    udim_tile_at,
};

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock, Weak};

/// Loads images once per (file, encoding) and hands out shared pyramids.
///
/// The cache holds weak references: an image lives while some program
/// uses it and is read again after the last one is dropped. Hosts that
/// compile many programs share one manager (the default is process-wide,
/// [`TextureManager::global`]) so each image is decoded once.
#[derive(Debug, Default)]
pub struct TextureManager {
    cache: Mutex<HashMap<(PathBuf, Encoding), Weak<MipMap>>>,
}

impl TextureManager {
    pub fn new() -> TextureManager {
        TextureManager::default()
    }

    /// The process-wide manager that programs use unless given another.
    pub fn global() -> Arc<TextureManager> {
        static GLOBAL: OnceLock<Arc<TextureManager>> = OnceLock::new();
        GLOBAL.get_or_init(|| Arc::new(TextureManager::new())).clone()
    }

    /// The image at `path`, decoded with `encoding`, from the cache or
    /// from the file. The error says what is wrong in words.
    pub fn load(&self, path: &Path, encoding: Encoding) -> Result<Arc<MipMap>, String> {
        let key_path = std::fs::canonicalize(path).map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => "no such file".to_string(),
            _ => e.to_string(),
        })?;
        if key_path.is_dir() {
            return Err("it is a directory, not an image".into());
        }
        let key = (key_path, encoding);
        if let Some(image) = self.lock().get(&key).and_then(Weak::upgrade) {
            return Ok(image);
        }
        // Decode outside the lock: other images load meanwhile. Two threads
        // asking for one new image may both decode it; either result is kept.
        let image = Arc::new(MipMap::load(&key.0, encoding)?);
        let mut cache = self.lock();
        cache.retain(|_, w| w.strong_count() > 0);
        cache.insert(key, Arc::downgrade(&image));
        Ok(image)
    }

    /// How many images are alive in the cache.
    pub fn loaded(&self) -> usize {
        self.lock().values().filter(|w| w.strong_count() > 0).count()
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<(PathBuf, Encoding), Weak<MipMap>>> {
        // A panic while holding the lock cannot leave the map inconsistent.
        self.cache.lock().unwrap_or_else(|e| e.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::temp_dir;

    #[test]
    fn loads_once_and_frees_when_unused() {
        let dir = temp_dir("cache");
        let path = dir.join("a.png");
        image::RgbImage::from_pixel(4, 2, image::Rgb([255, 128, 0])).save(&path).unwrap();
        let m = TextureManager::new();
        let a = m.load(&path, Encoding::Srgb).unwrap();
        let b = m.load(&dir.join(".").join("a.png"), Encoding::Srgb).unwrap();
        assert!(Arc::ptr_eq(&a, &b), "one path, one image");
        let raw = m.load(&path, Encoding::Raw).unwrap();
        assert!(!Arc::ptr_eq(&a, &raw));
        assert_eq!(raw.levels[0].texels[0][1], 128.0 / 255.0);
        assert!((a.levels[0].texels[0][1] - srgb_to_linear(128.0 / 255.0)).abs() < 1e-6);
        assert_eq!(a.levels[0].texels[0][3], 1.0);
        assert!(!a.has_alpha);
        assert_eq!(m.loaded(), 2);
        drop((a, b, raw));
        assert_eq!(m.loaded(), 0);
    }

    #[test]
    fn bad_files_are_errors_not_panics() {
        let dir = temp_dir("bad");
        let m = TextureManager::new();
        assert_eq!(m.load(&dir.join("none.png"), Encoding::Srgb).unwrap_err(), "no such file");
        std::fs::write(dir.join("junk.png"), b"not a png at all").unwrap();
        assert!(m.load(&dir.join("junk.png"), Encoding::Srgb).is_err());
        std::fs::write(dir.join("junk.exr"), b"\x76\x2f\x31\x01 truncated").unwrap();
        assert!(m.load(&dir.join("junk.exr"), Encoding::Raw).is_err());
        std::fs::write(dir.join("picture.bmp"), b"BM").unwrap();
        assert!(m.load(&dir.join("picture.bmp"), Encoding::Srgb).unwrap_err().contains("not an image format"));
        assert!(m.load(&dir, Encoding::Srgb).unwrap_err().contains("directory"));
        // A PNG cut in half.
        let path = dir.join("cut.png");
        image::RgbImage::from_pixel(64, 64, image::Rgb([1, 2, 3])).save(&path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
        assert!(m.load(&path, Encoding::Srgb).is_err());
    }

    #[test]
    fn reads_alpha_hdr_and_exr() {
        let dir = temp_dir("formats");
        let png = dir.join("alpha.png");
        image::RgbaImage::from_pixel(2, 2, image::Rgba([255, 255, 255, 51])).save(&png).unwrap();
        let m = TextureManager::new();
        let a = m.load(&png, Encoding::Srgb).unwrap();
        assert!(a.has_alpha);
        assert!((a.levels[0].texels[0][3] - 0.2).abs() < 1e-6);
        let exr = dir.join("linear.exr");
        let level = Level { width: 2, height: 1, texels: vec![[0.25, 2.0, 8.0, 1.0], [0.5, 0.5, 0.5, 1.0]] };
        let rgb = vec![[0.25, 2.0, 8.0], [0.5, 0.5, 0.5]];
        let image = crate::image_io::RenderedImage {
            full_width: 2,
            full_height: 1,
            x0: 0,
            y0: 0,
            width: 2,
            height: 1,
            color: rgb,
            albedo: None,
            normal: None,
            depth: None,
            object: None,
        };
        crate::image_io::write_image(&exr, &image).unwrap();
        let e = m.load(&exr, Encoding::Srgb).unwrap();
        assert_eq!(e.levels[0].texels, level.texels, "EXR is linear whatever the encoding asked");
    }
}
