//! Images as RGBA float texels and their mip-map pyramids. Decoding files
//! is `crate::image_io`'s.

use crate::image_io::{self, Encoding, NonFiniteTexels};
use std::path::Path;
use std::sync::OnceLock;

/// One level of a pyramid: `width` x `height` RGBA texels, row by row,
/// the first row at the top of the picture.
#[derive(Debug, Clone, PartialEq)]
pub struct Level {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[f32; 4]>,
}

impl Level {
    /// Reads an image file at full resolution, without a pyramid, and
    /// whether it has an alpha channel.
    pub fn load(path: &Path, encoding: Encoding) -> Result<(Level, bool), String> {
        let p = image_io::read_picture(path, encoding)?;
        Ok((Level { width: p.width, height: p.height, texels: p.texels }, p.has_alpha))
    }

    pub fn texel(&self, x: u32, y: u32) -> [f32; 4] {
        self.texels[(y * self.width + x) as usize]
    }

    /// The mean of every channel over the level.
    pub fn mean(&self) -> [f64; 4] {
        let mut sum = [0.0f64; 4];
        for t in &self.texels {
            for c in 0..4 {
                sum[c] += f64::from(t[c]);
            }
        }
        sum.map(|s| s / self.texels.len() as f64)
    }
}

/// An image and its mip-map levels, each half the size of the one before
/// (rounded down, at least 1), down to 1 x 1.
#[derive(Debug, Clone, PartialEq)]
pub struct MipMap {
    /// Where the image came from, for messages and `tslc emit`.
    pub name: String,
    /// Whether the file had an alpha channel (alpha is 1 otherwise).
    pub has_alpha: bool,
    pub levels: Vec<Level>,
    /// The base level's values that were not numbers (NaN or infinite),
    /// replaced by 0 before the pyramid was made, so none reaches a
    /// level above or a lookup.
    pub non_finite: Option<NonFiniteTexels>,
    /// The Jakob–Hanika spectra of every level's texels, made on first use
    /// by a spectral model ([`MipMap::spectra`]).
    spectra: OnceLock<Vec<Vec<[f32; 4]>>>,
}

impl MipMap {
    /// Builds the pyramid of a level-0 image, its values that are not
    /// numbers replaced by 0 first ([`MipMap::non_finite`] says which).
    pub fn new(name: impl Into<String>, mut base: Level, has_alpha: bool) -> MipMap {
        let non_finite = image_io::replace_non_finite(&mut base.texels, base.width);
        let mut levels = vec![base];
        while let Some(last) = levels.last() {
            if last.width == 1 && last.height == 1 {
                break;
            }
            let next = downsample(last);
            levels.push(next);
        }
        MipMap { name: name.into(), has_alpha, levels, non_finite, spectra: OnceLock::new() }
    }

    pub fn width(&self) -> u32 {
        self.levels[0].width
    }

    pub fn height(&self) -> u32 {
        self.levels[0].height
    }

    /// Per level, per texel, the Jakob–Hanika spectrum of its RGB
    /// (`[c0, c1, c2, scale]` of [`crate::color::jakob_hanika::upsample`]),
    /// converted once, on the first call, for the spectral models' lookups
    /// (Mitsuba 3's bitmap texture does the same at load). Each level is
    /// converted from its own box-filtered RGB. The pyramid then takes
    /// twice the memory; RGB rendering never makes it.
    pub fn spectra(&self) -> &[Vec<[f32; 4]>] {
        use rayon::prelude::*;
        self.spectra.get_or_init(|| {
            let convert = |t: &[f32; 4]| {
                let s = crate::color::jakob_hanika::upsample([t[0], t[1], t[2]]);
                let [c0, c1, c2] = s.coefficients;
                [c0, c1, c2, s.scale]
            };
            self.levels.iter().map(|l| l.texels.par_iter().map(convert).collect()).collect()
        })
    }

    /// Reads an image file: PNG, JPEG, Radiance HDR or OpenEXR.
    pub fn load(path: &Path, encoding: Encoding) -> Result<MipMap, String> {
        let (base, has_alpha) = Level::load(path, encoding)?;
        Ok(MipMap::new(path.display().to_string(), base, has_alpha))
    }
}

/// The next level: each new texel is the area-weighted mean of the texels
/// it covers (a box filter). Odd sizes split texels fractionally, so every
/// level keeps the mean of the one before exactly (up to rounding).
fn downsample(src: &Level) -> Level {
    let width = (src.width / 2).max(1);
    let height = (src.height / 2).max(1);
    let wx = box_weights(src.width, width);
    let wy = box_weights(src.height, height);
    // Rows first, then columns: the box filter is separable.
    let mut rows = vec![[0.0f32; 4]; (width * src.height) as usize];
    for y in 0..src.height {
        for (x, taps) in wx.iter().enumerate() {
            let mut acc = [0.0f32; 4];
            for &(sx, w) in taps {
                let t = src.texel(sx, y);
                for c in 0..4 {
                    acc[c] += w * t[c];
                }
            }
            rows[(y * width) as usize + x] = acc;
        }
    }
    let mut texels = vec![[0.0f32; 4]; (width * height) as usize];
    for (y, taps) in wy.iter().enumerate() {
        for x in 0..width {
            let mut acc = [0.0f32; 4];
            for &(sy, w) in taps {
                let t = rows[(sy * width + x) as usize];
                for c in 0..4 {
                    acc[c] += w * t[c];
                }
            }
            texels[y * width as usize + x as usize] = acc;
        }
    }
    Level { width, height, texels }
}

/// For each of `to` output texels, the source texels it covers and their
/// weights (summing to 1): output `i` covers `[i, i + 1) * from / to`.
fn box_weights(from: u32, to: u32) -> Vec<Vec<(u32, f32)>> {
    let ratio = f64::from(from) / f64::from(to);
    (0..to)
        .map(|i| {
            let (lo, hi) = (f64::from(i) * ratio, f64::from(i + 1) * ratio);
            let mut taps = Vec::new();
            let mut s = lo.floor() as u32;
            while f64::from(s) < hi && s < from {
                let cover = hi.min(f64::from(s + 1)) - lo.max(f64::from(s));
                if cover > 0.0 {
                    taps.push((s, (cover / ratio) as f32));
                }
                s += 1;
            }
            taps
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn level(width: u32, height: u32, f: impl Fn(u32, u32) -> [f32; 4]) -> Level {
        let texels = (0..height).flat_map(|y| (0..width).map(move |x| (x, y))).map(|(x, y)| f(x, y)).collect();
        Level { width, height, texels }
    }

    #[test]
    fn levels_halve_down_to_one_texel() {
        let m = MipMap::new("t", level(8, 3, |_, _| [1.0; 4]), false);
        let sizes: Vec<(u32, u32)> = m.levels.iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(sizes, vec![(8, 3), (4, 1), (2, 1), (1, 1)]);
    }

    #[test]
    fn every_level_keeps_the_mean() {
        // Power-of-two and odd sizes, with a pattern that is not constant.
        for (w, h) in [(16, 16), (7, 5), (13, 1), (1, 9), (33, 17)] {
            let m =
                MipMap::new("t", level(w, h, |x, y| [x as f32, y as f32, ((x * 7 + y * 3) % 5) as f32, 1.0]), false);
            let mean0 = m.levels[0].mean();
            for l in &m.levels {
                let mean = l.mean();
                for c in 0..4 {
                    assert!(
                        (mean[c] - mean0[c]).abs() < 1e-4,
                        "{w}x{h} level {}x{}: {mean:?} vs {mean0:?}",
                        l.width,
                        l.height
                    );
                }
            }
        }
    }

    #[test]
    fn two_by_two_boxes_average() {
        let m = MipMap::new("t", level(4, 2, |x, y| [(x + 4 * y) as f32, 0.0, 0.0, 1.0]), false);
        // Texels 0 1 2 3 / 4 5 6 7: the boxes average to 2.5 and 4.5.
        assert_eq!(m.levels[1].texels.iter().map(|t| t[0]).collect::<Vec<_>>(), vec![2.5, 4.5]);
        assert_eq!(m.levels[2].texels[0][0], 3.5);
    }

    #[test]
    fn box_weights_cover_each_output_once() {
        for (from, to) in [(5, 2), (7, 3), (2, 1), (9, 4)] {
            let w = box_weights(from, to);
            for taps in &w {
                let sum: f32 = taps.iter().map(|t| t.1).sum();
                assert!((sum - 1.0).abs() < 1e-6);
            }
            let mut per_source = vec![0.0f32; from as usize];
            for taps in &w {
                for &(s, x) in taps {
                    per_source[s as usize] += x;
                }
            }
            for p in per_source {
                assert!((p - to as f32 / from as f32).abs() < 1e-6);
            }
        }
    }
}
