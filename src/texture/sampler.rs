//! Filtered lookups in a mip-mapped image: address modes, nearest,
//! bilinear and trilinear filtering, and the native the generated code calls.

use super::mipmap::{Level, MipMap};
use super::udim::UdimSet;
use crate::runtime::floor_to_i64;
use std::sync::Arc;

/// What a lookup outside [0, 1) sees, per axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Wrap {
    /// The image tiles the plane (OSL's "periodic").
    Repeat,
    /// Every other tile is mirrored, so tiles meet without seams: the first
    /// paper's reversal tiling.
    Mirror,
    /// The edge texels extend outward.
    Clamp,
    /// Transparent black outside the image.
    Black,
}

impl Wrap {
    /// The names shaders use; `periodic` is OSL's word for `repeat`.
    pub fn from_name(name: &str) -> Option<Wrap> {
        Some(match name {
            "repeat" | "periodic" => Wrap::Repeat,
            "mirror" => Wrap::Mirror,
            "clamp" => Wrap::Clamp,
            "black" => Wrap::Black,
            _ => return None,
        })
    }

    pub const NAMES: &'static [&'static str] = &["repeat", "periodic", "mirror", "clamp", "black"];

    /// The texel of integer coordinate `i` on an axis of `n` texels, or
    /// `None` where the image is black.
    #[inline]
    fn index(self, i: i64, n: u32) -> Option<u32> {
        let n = i64::from(n);
        if (0..n).contains(&i) {
            // Inside the image every mode agrees (and needs no division).
            return Some(i as u32);
        }
        let k = match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m >= n { 2 * n - 1 - m } else { m }
            }
            Wrap::Clamp => i.clamp(0, n - 1),
            Wrap::Black => {
                if !(0..n).contains(&i) {
                    return None;
                }
                i
            }
        };
        Some(k as u32)
    }
}

/// How texels are combined.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Filter {
    /// The nearest texel of the full-resolution image.
    Nearest,
    /// Bilinear interpolation of the full-resolution image.
    Bilinear,
    /// Bilinear in the two mip-map levels whose texels match the pixel
    /// footprint, blended linearly between them.
    Trilinear,
}

impl Filter {
    pub fn from_name(name: &str) -> Option<Filter> {
        Some(match name {
            "nearest" | "closest" => Filter::Nearest,
            "bilinear" | "linear" => Filter::Bilinear,
            "trilinear" | "mipmap" => Filter::Trilinear,
            _ => return None,
        })
    }

    pub const NAMES: &'static [&'static str] = &["nearest", "closest", "bilinear", "linear", "trilinear", "mipmap"];
}

/// What a texture call reads: one image, or a UDIM tile set whose tile
/// each lookup picks by its coordinates.
#[derive(Debug, Clone)]
pub enum TextureImage {
    Single(Arc<MipMap>),
    Udim(Arc<UdimSet>),
}

impl TextureImage {
    /// The file (or the tile set's pattern) as found, for messages.
    pub fn name(&self) -> &str {
        match self {
            TextureImage::Single(image) => &image.name,
            TextureImage::Udim(set) => &set.name,
        }
    }
}

/// An image with the filter and address modes of one kind of lookup.
#[derive(Debug)]
pub struct Sampler {
    pub image: TextureImage,
    pub filter: Filter,
    /// Address modes along s and t.
    pub wrap: [Wrap; 2],
    /// `None`: lookups return RGBA ([`Sampler::sample`]). Otherwise lookups
    /// return the filtered Jakob–Hanika spectra of the texels at these
    /// wavelengths ([`Sampler::sample_spectrum`]).
    pub spectral: Option<SpectralLanes>,
}

/// The wavelengths a spectral lookup evaluates its texels' spectra at, as
/// `t = (λ − 380) / 400`.
#[derive(Debug, Clone, PartialEq)]
pub enum SpectralLanes {
    /// Fixed lanes (a binned model's bin centres).
    Fixed(Vec<f32>),
    /// The four hero lanes, given with each lookup.
    Hero,
}

/// Texture coordinates and their change to the next pixel in x and y.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Lookup {
    pub s: f32,
    pub t: f32,
    pub dsdx: f32,
    pub dtdx: f32,
    pub dsdy: f32,
    pub dtdy: f32,
}

impl Sampler {
    /// The filtered RGBA value at `(s, t)`. `s` runs left to right and `t`
    /// bottom to top over the picture, one tile per unit; texel centres
    /// sit at half-integers of `s * width` and `t * height`. Non-finite
    /// coordinates give black. A tile set's lookup reads the tile `(s, t)`
    /// falls in at the coordinates' fractions, the address modes applying
    /// at that tile's edges ([`UdimSet::lookup`]; transparent black where
    /// there is no tile).
    pub fn sample(&self, q: &Lookup) -> [f32; 4] {
        if !(q.s.is_finite() && q.t.is_finite()) {
            return [0.0; 4];
        }
        match &self.image {
            TextureImage::Single(image) => self.sample_image(image, q),
            TextureImage::Udim(set) => set.lookup(q).map_or([0.0; 4], |(image, q)| self.sample_image(image, &q)),
        }
    }

    fn sample_image(&self, image: &MipMap, q: &Lookup) -> [f32; 4] {
        let levels = &image.levels;
        match self.filter {
            Filter::Nearest => self.nearest(&levels[0], q.s, q.t),
            Filter::Bilinear => self.bilinear(&levels[0], q.s, q.t),
            Filter::Trilinear => {
                let (lo, f) = Self::mip_levels(image, q);
                let a = self.bilinear(&levels[lo], q.s, q.t);
                if f == 0.0 {
                    return a;
                }
                let b = self.bilinear(&levels[lo + 1], q.s, q.t);
                std::array::from_fn(|c| a[c] + f * (b[c] - a[c]))
            }
        }
    }

    /// The level a trilinear lookup starts at and the weight of the next
    /// one (0: that level alone).
    fn mip_levels(image: &MipMap, q: &Lookup) -> (usize, f32) {
        let levels = &image.levels;
        let (w, h) = (levels[0].width as f32, levels[0].height as f32);
        let width = (q.dsdx.abs() * w).max(q.dtdx.abs() * h).max(q.dsdy.abs() * w).max(q.dtdy.abs() * h);
        // NaN and tiny footprints select the finest level.
        let level = if width > 1.0 { fast_log2(width) } else { 0.0 };
        let last = (levels.len() - 1) as f32;
        if level >= last {
            return (levels.len() - 1, 0.0);
        }
        let lo = level.floor();
        (lo as usize, level - lo)
    }

    /// The filtered spectrum at `(s, t)` into `out`, one lane per
    /// wavelength of [`Sampler::spectral`] (`hero`: the hero lanes' `t`),
    /// the rest of `out` zeroed. The same filter as [`Sampler::sample`],
    /// but it blends the texels' spectra ([`MipMap::spectra`]) evaluated at
    /// the lanes, not their RGB: a texel costs a few multiplies and a
    /// square root per lane, never a lookup in the coefficient table.
    pub fn sample_spectrum(&self, q: &Lookup, hero: &[f32; 4], out: &mut [f32]) {
        out.fill(0.0);
        let ts: &[f32] = match &self.spectral {
            Some(SpectralLanes::Fixed(ts)) => ts,
            Some(SpectralLanes::Hero) => hero,
            None => return,
        };
        let lanes = ts.len().min(out.len());
        let (ts, out) = (&ts[..lanes], &mut out[..lanes]);
        if !(q.s.is_finite() && q.t.is_finite()) {
            return;
        }
        let (image, q) = match &self.image {
            TextureImage::Single(image) => (&**image, *q),
            TextureImage::Udim(set) => match set.lookup(q) {
                Some(found) => found,
                None => return,
            },
        };
        let spectra = image.spectra();
        match self.filter {
            Filter::Nearest => {
                let level = &image.levels[0];
                let (x, y) = Self::texel_coords(level, q.s, q.t);
                let (x, y) = (floor_to_i64(x), floor_to_i64(y));
                if let (Some(x), Some(y)) = (self.wrap[0].index(x, level.width), self.wrap[1].index(y, level.height)) {
                    let texel = spectra[0][(y * level.width + x) as usize];
                    add_spectra(&[texel], complement_weight(texel[3], 1.0), ts, out);
                }
            }
            Filter::Bilinear => self.bilinear_spectrum(&image.levels[0], &spectra[0], &q, 1.0, ts, out),
            Filter::Trilinear => {
                let (lo, f) = Self::mip_levels(image, &q);
                self.bilinear_spectrum(&image.levels[lo], &spectra[lo], &q, 1.0 - f, ts, out);
                if f != 0.0 {
                    self.bilinear_spectrum(&image.levels[lo + 1], &spectra[lo + 1], &q, f, ts, out);
                }
            }
        }
    }

    /// Adds `weight` times the bilinear blend of the spectra of `level` at
    /// the lookup to `out`.
    fn bilinear_spectrum(
        &self,
        level: &Level,
        spectra: &[[f32; 4]],
        q: &Lookup,
        weight: f32,
        ts: &[f32],
        out: &mut [f32],
    ) {
        let (x, y) = Self::texel_coords(level, q.s, q.t);
        let ((x0, fx), (y0, fy)) = (floor_fract(x - 0.5), floor_fract(y - 0.5));
        let (sx, sy) = (self.wrap[0], self.wrap[1]);
        let xs = [(sx.index(x0, level.width), 1.0 - fx), (sx.index(x0.saturating_add(1), level.width), fx)];
        let ys = [(sy.index(y0, level.height), 1.0 - fy), (sy.index(y0.saturating_add(1), level.height), fy)];
        // Texels outside the image (`Wrap::Black`) weigh 0.
        let mut taps = [[0.0f32; 4]; 4];
        let mut weights = [0.0f32; 4];
        for (k, ((x, wx), (y, wy))) in
            [(xs[0], ys[0]), (xs[1], ys[0]), (xs[0], ys[1]), (xs[1], ys[1])].into_iter().enumerate()
        {
            if let (Some(x), Some(y)) = (x, y) {
                taps[k] = spectra[(y * level.width + x) as usize];
                weights[k] = weight * wx * wy;
                taps[k][3] *= weights[k];
            }
        }
        // After the loop, over whole arrays, it vectorises: 28 instructions
        // per lookup fewer than summing it in the loop (callgrind).
        let offset = (0..4).map(|k| complement_weight(taps[k][3], weights[k])).fold(0.0, |a, b| a + b);
        add_spectra(&taps, offset, ts, out);
    }

    #[inline]
    fn texel(&self, level: &Level, x: i64, y: i64) -> [f32; 4] {
        match (self.wrap[0].index(x, level.width), self.wrap[1].index(y, level.height)) {
            (Some(x), Some(y)) => level.texel(x, y),
            _ => [0.0; 4],
        }
    }

    /// The words a lookup writes: 4 (RGBA) or one per spectral lane.
    pub fn spectral_lanes(&self) -> usize {
        match &self.spectral {
            None | Some(SpectralLanes::Hero) => 4,
            Some(SpectralLanes::Fixed(ts)) => ts.len(),
        }
    }

    /// Continuous texel coordinates: x right, y down from the top row.
    #[inline]
    fn texel_coords(level: &Level, s: f32, t: f32) -> (f64, f64) {
        (f64::from(s) * f64::from(level.width), (1.0 - f64::from(t)) * f64::from(level.height))
    }

    fn nearest(&self, level: &Level, s: f32, t: f32) -> [f32; 4] {
        let (x, y) = Self::texel_coords(level, s, t);
        self.texel(level, floor_to_i64(x), floor_to_i64(y))
    }

    fn bilinear(&self, level: &Level, s: f32, t: f32) -> [f32; 4] {
        let (x, y) = Self::texel_coords(level, s, t);
        let (x, y) = (x - 0.5, y - 0.5);
        let ((x0, fx), (y0, fy)) = (floor_fract(x), floor_fract(y));
        let (x1, y1) = (x0.saturating_add(1), y0.saturating_add(1));
        let (sx, sy) = (self.wrap[0], self.wrap[1]);
        let (ix0, ix1) = (sx.index(x0, level.width), sx.index(x1, level.width));
        let (iy0, iy1) = (sy.index(y0, level.height), sy.index(y1, level.height));
        let fetch = |x: Option<u32>, y: Option<u32>| match (x, y) {
            (Some(x), Some(y)) => level.texel(x, y),
            _ => [0.0; 4],
        };
        let (a, b) = (fetch(ix0, iy0), fetch(ix1, iy0));
        let (c, d) = (fetch(ix0, iy1), fetch(ix1, iy1));
        std::array::from_fn(|k| {
            let top = a[k] + fx * (b[k] - a[k]);
            let bottom = c[k] + fx * (d[k] - c[k]);
            top + fy * (bottom - top)
        })
    }
}

/// The constant a texel of spectrum scale `scale` adds with filter weight
/// `weight`: a negative scale is a complement, `1 − |scale| · sigmoid`
/// ([`crate::color::jakob_hanika::Sigmoid`]), whose 1 counts `weight`.
#[inline]
fn complement_weight(scale: f32, weight: f32) -> f32 {
    if scale < 0.0 { weight } else { 0.0 }
}

/// Adds `offset` plus the spectra `[c0, c1, c2, scale]` at each `t` to
/// `out`: `offset + Σ scale · sigmoid(c0 t² + c1 t + c2)`, with the
/// arithmetic of the compiled per-lookup conversion
/// (`ir::lower::spectral`), so both agree. The taps are a fixed number, so
/// the loop over lanes vectorises with every tap unrolled in it.
#[inline]
fn add_spectra<const K: usize>(taps: &[[f32; 4]; K], offset: f32, ts: &[f32], out: &mut [f32]) {
    // scale · sigmoid(x) = hs + hs · x / √(x² + 1) with hs = scale / 2.
    let hs: [f32; K] = std::array::from_fn(|k| 0.5 * taps[k][3]);
    let base: f32 = offset + hs.iter().sum::<f32>();
    for (o, &t) in out.iter_mut().zip(ts) {
        let mut acc = base;
        for k in 0..K {
            let [c0, c1, c2, _] = taps[k];
            let x = (c0 * t + c1) * t + c2;
            acc += hs[k] * (x / (x * x + 1.0).sqrt());
        }
        *o += acc;
    }
}

/// `floor(x)` and the fraction `x - floor(x)` in [0, 1]; beyond 2^52 every
/// `f64` is an integer, so the fraction is 0 (and the floor saturates).
#[inline]
fn floor_fract(x: f64) -> (i64, f32) {
    let i = floor_to_i64(x);
    let f = if x.abs() < 4_503_599_627_370_496.0 { (x - i as f64) as f32 } else { 0.0 };
    (i, f)
}

/// log2 of a finite `x > 0` to within 0.01: the exponent plus a quadratic
/// in the mantissa, continuous and increasing, which is all choosing and
/// blending mip-map levels needs (and cheaper than a libm call).
#[inline]
fn fast_log2(x: f32) -> f32 {
    let bits = x.to_bits();
    let exponent = ((bits >> 23) & 0xff) as i32 - 127;
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000) - 1.0;
    exponent as f32 + m * (1.346_6 - 0.346_6 * m)
}

/// The native behind `texture()`: writes the RGBA value of `sampler` at
/// the lookup into `out[0..4]`.
///
/// # Safety
/// `sampler` points to a live [`Sampler`] and `out` to four writable
/// floats. Generated code passes a sampler its program keeps alive and a
/// stack slot of its own.
pub unsafe extern "C" fn tsl_texture(
    sampler: *const Sampler,
    s: f32,
    t: f32,
    dsdx: f32,
    dtdx: f32,
    dsdy: f32,
    dtdy: f32,
    out: *mut f32,
) {
    // SAFETY: guaranteed by the caller, as documented above.
    let (sampler, out) = unsafe { (&*sampler, std::slice::from_raw_parts_mut(out, 4)) };
    out.copy_from_slice(&sampler.sample(&Lookup { s, t, dsdx, dtdx, dsdy, dtdy }));
}

/// The native behind `texture()` in the Jakob–Hanika spectral models:
/// writes the filtered spectrum of `sampler` (which has
/// [`Sampler::spectral`] lanes) at the lookup into `out[0..lanes]`;
/// `t0..t3` are the hero lanes' normalised wavelengths (ignored by fixed
/// lanes).
///
/// # Safety
/// `sampler` points to a live [`Sampler`] and `out` to `lanes` writable
/// floats, where `lanes` is the number of its fixed lanes, or 4 for hero.
/// Generated code passes a sampler its program keeps alive and an array of
/// its own of that size.
pub unsafe extern "C" fn tsl_texture_spectrum(
    sampler: *const Sampler,
    s: f32,
    t: f32,
    dsdx: f32,
    dtdx: f32,
    dsdy: f32,
    dtdy: f32,
    t0: f32,
    t1: f32,
    t2: f32,
    t3: f32,
    out: *mut f32,
) {
    // SAFETY: guaranteed by the caller, as documented above.
    let sampler = unsafe { &*sampler };
    let lanes = sampler.spectral_lanes();
    // SAFETY: as above.
    let out = unsafe { std::slice::from_raw_parts_mut(out, lanes) };
    sampler.sample_spectrum(&Lookup { s, t, dsdx, dtdx, dsdy, dtdy }, &[t0, t1, t2, t3], out);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4 x 2 image whose red channel numbers its texels 0..8 row by row
    /// from the top, green is 1 on the bottom row.
    fn numbered() -> Arc<MipMap> {
        let texels = (0..8).map(|k| [k as f32, (k / 4) as f32, 0.0, 1.0]).collect();
        Arc::new(MipMap::new("numbered", Level { width: 4, height: 2, texels }, false))
    }

    fn sampler(filter: Filter, wrap: Wrap) -> Sampler {
        Sampler { image: TextureImage::Single(numbered()), filter, wrap: [wrap, wrap], spectral: None }
    }

    fn at(s: &Sampler, x: f32, y: f32) -> [f32; 4] {
        s.sample(&Lookup { s: x, t: y, ..Lookup::default() })
    }

    #[test]
    fn texel_centres_return_texels() {
        let s = sampler(Filter::Bilinear, Wrap::Clamp);
        // Texel (x, y) from the top has its centre at s = (x + 0.5) / 4,
        // t = 1 - (y + 0.5) / 2.
        for k in 0..8u32 {
            let (x, y) = (k % 4, k / 4);
            let v = at(&s, (x as f32 + 0.5) / 4.0, 1.0 - (y as f32 + 0.5) / 2.0);
            assert_eq!(v[0], k as f32);
        }
        let n = sampler(Filter::Nearest, Wrap::Clamp);
        assert_eq!(at(&n, 0.6, 0.9)[0], 2.0);
        assert_eq!(at(&n, 0.6, 0.1)[0], 6.0);
    }

    #[test]
    fn bilinear_between_texels() {
        let s = sampler(Filter::Bilinear, Wrap::Clamp);
        // Halfway between texels 1 and 2 of the top row: 1.5.
        assert!((at(&s, 0.5, 0.75)[0] - 1.5).abs() < 1e-6);
        // A quarter of the way from texel 1 down to texel 5: 1 + 4 / 4.
        assert!((at(&s, 0.375, 0.625)[0] - 2.0).abs() < 1e-6);
        // The middle of the image: the mean of texels 1, 2, 5, 6.
        assert!((at(&s, 0.5, 0.5)[0] - 3.5).abs() < 1e-6);
    }

    #[test]
    fn address_modes() {
        let rep = sampler(Filter::Nearest, Wrap::Repeat);
        assert_eq!(at(&rep, 1.1, 0.9), at(&rep, 0.1, 0.9));
        assert_eq!(at(&rep, -0.9, 0.9), at(&rep, 0.1, 0.9));
        let mir = sampler(Filter::Nearest, Wrap::Mirror);
        // The tile to the right is the image flipped left to right.
        assert_eq!(at(&mir, 1.1, 0.9)[0], 3.0);
        assert_eq!(at(&mir, -0.1, 0.9)[0], 0.0);
        assert_eq!(at(&mir, 1.9, 0.9)[0], 0.0);
        let clamp = sampler(Filter::Nearest, Wrap::Clamp);
        assert_eq!(at(&clamp, 7.0, 0.9)[0], 3.0);
        assert_eq!(at(&clamp, -7.0, -3.0)[0], 4.0);
        let black = sampler(Filter::Nearest, Wrap::Black);
        assert_eq!(at(&black, 1.1, 0.5), [0.0; 4]);
        assert_eq!(at(&black, 0.5, -0.2), [0.0; 4]);
        assert_eq!(at(&black, 0.1, 0.9)[3], 1.0);
    }

    #[test]
    fn mirror_tiling_is_continuous_across_tile_borders() {
        let s = sampler(Filter::Bilinear, Wrap::Mirror);
        for border in [-2.0f32, -1.0, 0.0, 1.0, 2.0, 3.0] {
            for t in [0.1f32, 0.5, 0.8] {
                let (a, b) = (at(&s, border - 1e-4, t), at(&s, border + 1e-4, t));
                assert!((a[0] - b[0]).abs() < 1e-2, "s = {border}, t = {t}: {a:?} vs {b:?}");
                let (a, b) = (at(&s, t, border - 1e-4), at(&s, t, border + 1e-4));
                assert!((a[0] - b[0]).abs() < 1e-2, "t = {border}: {a:?} vs {b:?}");
            }
        }
        // Texel by texel: mirrored tiles repeat the border column, plain
        // repetition jumps from the last column to the first.
        let (m, r) = (sampler(Filter::Nearest, Wrap::Mirror), sampler(Filter::Nearest, Wrap::Repeat));
        assert_eq!(at(&m, 1.0 - 1e-4, 0.75), at(&m, 1.0 + 1e-4, 0.75));
        assert_eq!(at(&r, 1.0 - 1e-4, 0.75)[0] - at(&r, 1.0 + 1e-4, 0.75)[0], 3.0);
    }

    #[test]
    fn trilinear_picks_levels_by_footprint() {
        let s = sampler(Filter::Trilinear, Wrap::Repeat);
        let q = |d: f32| s.sample(&Lookup { s: 0.3, t: 0.7, dsdx: d, dtdx: 0.0, dsdy: 0.0, dtdy: d })[0];
        let b = sampler(Filter::Bilinear, Wrap::Repeat);
        // No footprint, or one under a texel: the full-resolution image.
        assert_eq!(q(0.0), at(&b, 0.3, 0.7)[0]);
        assert_eq!(q(0.1), at(&b, 0.3, 0.7)[0]);
        // A footprint as wide as the image: its mean (3.5) from the last level.
        assert!((q(1.0) - 3.5).abs() < 1e-6);
        assert!((q(100.0) - 3.5).abs() < 1e-6);
        // Between levels the result is between theirs.
        let (l0, l1) = (at(&b, 0.3, 0.7)[0], q(0.5));
        let mid = q(0.35);
        assert!(mid >= l0.min(l1) - 1e-6 && mid <= l0.max(l1) + 1e-6);
        // NaN derivatives are treated as no footprint.
        assert_eq!(q(f32::NAN), at(&b, 0.3, 0.7)[0]);
    }

    #[test]
    fn fast_log2_is_close_continuous_and_increasing() {
        let mut prev = f32::NEG_INFINITY;
        for k in 0..20_000 {
            let x = 1.0 + k as f32 * 0.05;
            let l = fast_log2(x);
            assert!((l - x.log2()).abs() < 0.01, "{x}: {l} vs {}", x.log2());
            assert!(l >= prev, "not increasing at {x}");
            prev = l;
        }
        assert_eq!(fast_log2(2.0), 1.0);
        assert_eq!(fast_log2(1024.0), 10.0);
        assert_eq!(floor_to_i64(-0.5), -1);
        assert_eq!(floor_to_i64(2.0), 2);
        assert_eq!(floor_to_i64(-3.0), -3);
        assert_eq!(floor_to_i64(f64::MAX), i64::MAX);
        assert_eq!(floor_to_i64(f64::MIN), i64::MIN);
    }

    #[test]
    fn odd_inputs_never_panic() {
        for filter in [Filter::Nearest, Filter::Bilinear, Filter::Trilinear] {
            for wrap in [Wrap::Repeat, Wrap::Mirror, Wrap::Clamp, Wrap::Black] {
                let s = sampler(filter, wrap);
                for x in [f32::NAN, f32::INFINITY, -f32::INFINITY, f32::MAX, -f32::MAX, 1e30, -1e-30, 0.0] {
                    let q = Lookup { s: x, t: 0.5, dsdx: x, dtdx: x, dsdy: x, dtdy: x };
                    let v = s.sample(&q);
                    assert!(v.iter().all(|c| c.is_finite()), "{filter:?} {wrap:?} {x}: {v:?}");
                    let q = Lookup { s: 0.5, t: x, ..q };
                    assert!(s.sample(&q).iter().all(|c| c.is_finite()));
                }
            }
        }
    }
}
