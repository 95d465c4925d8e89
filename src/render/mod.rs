//! The built-in ray tracer: scenes from the `scene { ... }` block, shapes,
//! the BVH, lights, the Whitted and path-tracing integrators, and image
//! output. It talks to materials only through the generic material
//! interface ([`crate::Material`]).
//!
//! ```no_run
//! use tsl::render::{self, Overrides, RenderOptions, Scene};
//! let program = tsl::Compiler::new().file("examples/cornell.tsl").compile()?;
//! let scene = Scene::build(&program, &Overrides { spp: Some(4), ..Default::default() })?;
//! let (image, stats) = render::render(&scene, &RenderOptions::default())?;
//! tsl::image_io::write_image("cornell.exr".as_ref(), &image)?;
//! println!("{} samples in {:.2} s", stats.samples, stats.seconds);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Invariant: every random number is a pure function of (seed, frame,
//! pixel, sample index, dimension), so an image does not depend on the
//! number of threads, the tiling, the window rendered, or the other frames
//! rendered by the same command.

pub mod accel;
pub mod camera;
pub mod chi2;
pub mod environment;
pub mod geometry;
pub mod heightfield;
pub mod integrator;
pub mod light;
pub mod mesh;
pub mod packed;
pub mod sampling;
pub mod scene;
pub mod shape;
pub mod spectrum;
pub mod wavelengths;

pub use glam::Mat4;
/// The renderer's vectors are glam's 16-byte SIMD vectors: arithmetic is one
/// instruction per operation, and a vector is always loaded and stored
/// whole, so a load never straddles two smaller stores (which stalls).
pub type Vec3 = glam::Vec3A;
/// Image output lives in the crate's leaf module [`crate::image_io`]
/// (textures read pictures there too); it is re-exported here, where
/// renderers look for it.
pub use crate::image_io;
pub use crate::image_io::{NO_OBJECT, RenderedImage};
pub use integrator::{Counters, camera_hit};
pub use scene::{IntegratorKind, LightSampling, Overrides, Scene, Settings};

use integrator::{Aov, Tracer};
use rayon::prelude::*;
use sampling::Sampler;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// A ray `origin + t * dir`. `dir` need not be unit length; every `t` is in
/// units of `dir`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Ray {
        Ray { origin, dir }
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }
}

/// The most worker threads a render may ask for.
pub const MAX_THREADS: usize = 1024;

// The most memory a render's film may take (4 GiB), checked before it is
// allocated; beyond it, render in tiles. Merging and reading images share it.
pub use crate::image_io::FILM_BUDGET_BYTES;

/// What the film of a `width` x `height` window takes at its peak: the
/// finished tiles and the image they are copied into, color (and AOVs).
pub fn film_bytes(width: u32, height: u32, aov: bool) -> u64 {
    let per_pixel =
        std::mem::size_of::<[f32; 3]>() + if aov { std::mem::size_of::<Aov>() + std::mem::size_of::<i32>() } else { 0 };
    2 * u64::from(width) * u64::from(height) * per_pixel as u64
}

/// How one render runs (what is not part of the scene).
#[derive(Default)]
pub struct RenderOptions<'a> {
    /// Worker threads; 0 means one per core. At most [`MAX_THREADS`], and
    /// never more than the image has tiles.
    pub threads: usize,
    /// The pixels to render, `(x0, y0, width, height)`; `None` for all.
    pub window: Option<(u32, u32, u32, u32)>,
    /// Also produce albedo, normal, depth and object-index layers.
    pub aov: bool,
    /// Called from worker threads as pixels finish: (pixels done, total).
    pub progress: Option<&'a (dyn Fn(u64, u64) + Sync)>,
    /// The samples to take at each pixel, as indices into its sample
    /// sequence; `None` for `0..spp`. A progressive renderer takes
    /// successive ranges and averages the images by their lengths: the
    /// result is the image of the whole range (up to rounding), since each
    /// sample depends only on (seed, pixel, index).
    pub samples: Option<Range<u32>>,
    /// Set from another thread to stop the render: workers look at it
    /// before each tile and each row, and the render returns
    /// `Err(`[`CANCELLED`]`)`.
    pub cancel: Option<&'a AtomicBool>,
}

/// The error of a render stopped through [`RenderOptions::cancel`].
pub const CANCELLED: &str = "the render was cancelled";

/// What a render did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RenderStats {
    pub seconds: f64,
    /// Camera samples taken.
    pub samples: u64,
    pub rays: Counters,
    /// Samples whose radiance was NaN or infinite, dropped (counted as black).
    pub dropped_samples: u64,
    /// With AOVs, samples whose albedo or normal was NaN or infinite,
    /// dropped from those layers (counted as 0) as radiance samples are.
    pub dropped_aov_samples: u64,
    pub threads: usize,
}

impl RenderStats {
    pub fn total_rays(&self) -> u64 {
        self.rays.camera_rays + self.rays.secondary_rays + self.rays.shadow_rays
    }
}

/// What made an image of `scene`, for its EXR header: the software and
/// TSL's version, the scene's content hash (from
/// [`crate::scene::content_hash`]), the render settings and color model,
/// the frame, and the tile (`(index, count)`) when it is one. `tslc merge`
/// refuses parts that disagree on any of it but the tile.
pub fn image_metadata(scene: &Scene, content_hash: &str, tile: Option<(u32, u32)>) -> image_io::Metadata {
    let s = &scene.settings;
    let version = env!("CARGO_PKG_VERSION");
    let mut m = image_io::Metadata::default();
    m.set_text(image_io::SOFTWARE, format!("tslc {version}"))
        .set_text("tsl:version", version)
        .set_text("tsl:sceneHash", content_hash)
        .set_int("tsl:spp", s.spp as i32)
        .set_text("tsl:seed", s.seed.to_string())
        .set_int("tsl:maxDepth", s.max_depth as i32)
        .set_text(
            "tsl:integrator",
            match s.integrator {
                IntegratorKind::Whitted => "whitted",
                IntegratorKind::Path => "path",
            },
        )
        .set_text(
            "tsl:lightSampling",
            match s.light_sampling {
                LightSampling::All => "all",
                LightSampling::Power => "power",
            },
        )
        .set_text("tsl:colorModel", scene.model.name())
        .set_int("tsl:frame", s.frame.number)
        .set_float("tsl:time", s.frame.time);
    if let Some((index, count)) = tile {
        m.set_int("tsl:tile", index as i32).set_int("tsl:tiles", count as i32);
    }
    m
}

/// Mixed into the seed of the stream that draws hero wavelengths.
const HERO_STREAM: u64 = 0x6865_726f_5f77_6c31;

/// Tiles are this many pixels square.
const TILE: u32 = 16;

/// Renders `scene` (or a window of it) into linear RGB.
pub fn render(scene: &Scene, options: &RenderOptions) -> Result<(RenderedImage, RenderStats), String> {
    // Radiance lanes rounded up to a capacity the integrators are built for.
    match scene.model.lanes() {
        0..=3 => render_lanes::<3>(scene, options),
        4 => render_lanes::<4>(scene, options),
        5..=8 => render_lanes::<8>(scene, options),
        9..=16 => render_lanes::<16>(scene, options),
        17..=32 => render_lanes::<32>(scene, options),
        _ => render_lanes::<{ crate::color::MAX_SAMPLES }>(scene, options),
    }
}

/// One finished tile.
struct TileOut {
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
    color: Vec<[f32; 3]>,
    aov: Vec<Aov>,
    /// Per pixel with AOVs: the object the pixel centre's ray hits first.
    object: Vec<i32>,
    counters: Counters,
    dropped: u64,
    dropped_aov: u64,
}

fn render_lanes<const N: usize>(
    scene: &Scene,
    options: &RenderOptions,
) -> Result<(RenderedImage, RenderStats), String> {
    let s = &scene.settings;
    let (x0, y0, width, height) = options.window.unwrap_or((0, 0, s.width, s.height));
    if width == 0 || height == 0 || x0 + width > s.width || y0 + height > s.height {
        return Err(format!(
            "the window {width}x{height} at ({x0}, {y0}) is not inside the {}x{} image",
            s.width, s.height
        ));
    }
    let film = film_bytes(width, height, options.aov);
    if film > FILM_BUDGET_BYTES {
        let tiles_needed = film.div_ceil(FILM_BUDGET_BYTES);
        return Err(format!(
            "a {width}x{height} film{} would take {:.1} GB, more than the {} GB budget: render it in \
             parts with --tile I/{tiles_needed} (or more) and join them with `tslc merge`",
            if options.aov { " with AOVs" } else { "" },
            film as f64 / 1e9,
            FILM_BUDGET_BYTES >> 30
        ));
    }
    let mut tiles = Vec::new();
    for ty in (y0..y0 + height).step_by(TILE as usize) {
        for tx in (x0..x0 + width).step_by(TILE as usize) {
            tiles.push((tx, ty, TILE.min(x0 + width - tx), TILE.min(y0 + height - ty)));
        }
    }
    if options.threads > MAX_THREADS {
        return Err(format!("at most {MAX_THREADS} render threads, asked for {}", options.threads));
    }
    // More threads than tiles would only wait.
    let threads = if options.threads == 0 { 0 } else { options.threads.min(tiles.len()) };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| format!("cannot start render threads: {e}"))?;
    let threads = pool.current_num_threads();
    let samples = options.samples.clone().unwrap_or(0..s.spp);
    if samples.is_empty() || samples.end > crate::scene::MAX_SPP {
        return Err(format!("the sample range {samples:?} is empty or beyond {}", crate::scene::MAX_SPP));
    }
    // A UDIM tile that cannot be read stops the render (reported below).
    let tile_failed = || scene.tile_sets.iter().any(|set| set.has_failed());
    let cancelled = || options.cancel.is_some_and(|c| c.load(Ordering::Relaxed)) || tile_failed();
    let total = u64::from(width) * u64::from(height);
    let done = AtomicU64::new(0);
    let start = std::time::Instant::now();
    // A cancelled tile is `None`, which stops the collection.
    let outs: Option<Vec<TileOut>> = pool.install(|| {
        tiles
            .par_iter()
            .map(|&(tx, ty, w, h)| {
                let out = render_tile::<N>(scene, (tx, ty, w, h), &samples, options.aov, &cancelled)?;
                let now = done.fetch_add(u64::from(w * h), Ordering::Relaxed) + u64::from(w * h);
                if let Some(progress) = options.progress {
                    progress(now, total);
                }
                Some(out)
            })
            .collect()
    });
    if let Some(e) = tile_failure(scene) {
        return Err(e);
    }
    let Some(outs) = outs else { return Err(CANCELLED.into()) };
    let mut image = RenderedImage {
        full_width: s.width,
        full_height: s.height,
        x0,
        y0,
        width,
        height,
        color: vec![[0.0; 3]; (width * height) as usize],
        albedo: options.aov.then(|| vec![[0.0; 3]; (width * height) as usize]),
        normal: options.aov.then(|| vec![[0.0; 3]; (width * height) as usize]),
        depth: options.aov.then(|| vec![0.0; (width * height) as usize]),
        object: options.aov.then(|| vec![NO_OBJECT; (width * height) as usize]),
    };
    let mut stats = RenderStats { threads, ..RenderStats::default() };
    for t in outs {
        for j in 0..t.h {
            for i in 0..t.w {
                let src = (j * t.w + i) as usize;
                let dst = ((t.y0 - y0 + j) * width + (t.x0 - x0 + i)) as usize;
                image.color[dst] = t.color[src];
                if let (Some(a), Some(n), Some(d), Some(o)) =
                    (&mut image.albedo, &mut image.normal, &mut image.depth, &mut image.object)
                {
                    a[dst] = t.aov[src].albedo;
                    n[dst] = t.aov[src].normal;
                    d[dst] = t.aov[src].depth;
                    o[dst] = t.object[src];
                }
            }
        }
        stats.rays.camera_rays += t.counters.camera_rays;
        stats.rays.secondary_rays += t.counters.secondary_rays;
        stats.rays.shadow_rays += t.counters.shadow_rays;
        stats.dropped_samples += t.dropped;
        stats.dropped_aov_samples += t.dropped_aov;
    }
    stats.samples = total * u64::from(samples.end - samples.start);
    stats.seconds = start.elapsed().as_secs_f64();
    Ok((image, stats))
}

/// The first UDIM tile of `scene` that failed to load, in words: its file
/// and why.
fn tile_failure(scene: &Scene) -> Option<String> {
    let set = scene.tile_sets.iter().find(|s| s.has_failed())?;
    let (tile, reason) = set.failures().into_iter().next()?;
    Some(format!("cannot read the UDIM tile {} `{}` of `{}`: {reason}", tile.number, tile.path.display(), set.name))
}

/// Renders the pixels of one tile `(x0, y0, w, h)`, taking `samples` at
/// each; `None` when `cancelled` (asked before each row).
fn render_tile<const N: usize>(
    scene: &Scene,
    (x0, y0, w, h): (u32, u32, u32, u32),
    samples: &Range<u32>,
    want_aov: bool,
    cancelled: &dyn Fn() -> bool,
) -> Option<TileOut> {
    let s = &scene.settings;
    let seed = s.frame_seed();
    let mut tracer = Tracer::<N>::new(scene, want_aov);
    let lanes = scene.model.lanes();
    let to_rgb = crate::color::to_rgb_weights(scene.model);
    let hero = scene.model == crate::ColorModel::Hero;
    let mut color = Vec::with_capacity((w * h) as usize);
    let mut aovs = Vec::with_capacity(if want_aov { (w * h) as usize } else { 0 });
    let mut objects = Vec::with_capacity(aovs.capacity());
    let (mut dropped, mut dropped_aov) = (0, 0);
    for py in y0..y0 + h {
        if cancelled() {
            return None;
        }
        for px in x0..x0 + w {
            let mut sum = spectrum::Spectrum::<N>::ZERO;
            // Hero samples go to RGB one by one (each has its wavelengths).
            let mut rgb_sum = [0.0f32; 3];
            let hero_phase = Sampler::new(seed ^ HERO_STREAM, px, py, u32::MAX).next_1d();
            let mut aov_sum = Aov::default();
            let mut hits = 0u32;
            for k in samples.clone() {
                let mut sampler = Sampler::new(seed, px, py, k);
                if hero {
                    // Its own stream: the paths' numbers are those of the
                    // other models, so renders compare sample for sample.
                    // Stratified over the pixel's samples, from a random
                    // phase per pixel: each u is uniform, and together they
                    // cover [0, 1) evenly.
                    let jitter = Sampler::new(seed ^ HERO_STREAM, px, py, k).next_1d();
                    // Its `fract`, which below 2 (every sample up to the
                    // scene's spp) is at most one subtraction, not a call
                    // to `truncf`.
                    let u = (k as f32 + jitter) / s.spp as f32 + hero_phase;
                    let u = if u < 1.0 {
                        u
                    } else if u < 2.0 {
                        u - 1.0
                    } else {
                        u.fract()
                    };
                    tracer.hero = Some(wavelengths::HeroSample::draw(u));
                }
                // One sample per pixel looks through the pixel centre, as
                // the benchmark scenes and POV-Ray's -A expect.
                let (jx, jy) = if s.spp == 1 { (0.5, 0.5) } else { sampler.next_2d().into() };
                let lens = sampler.next_2d();
                let ray = scene.camera.ray(px as f32 + jx, py as f32 + jy, lens);
                let (l, aov) = match s.integrator {
                    IntegratorKind::Whitted => tracer.whitted(&ray, &mut sampler),
                    IntegratorKind::Path => tracer.path(&ray, &mut sampler),
                };
                if !l.is_finite() {
                    dropped += 1;
                } else if let Some(h) = &tracer.hero {
                    let rgb = h.to_rgb(&l);
                    for c in 0..3 {
                        rgb_sum[c] += rgb[c];
                    }
                } else {
                    sum += l;
                }
                if want_aov {
                    // One NaN would make the pixel's mean NaN: dropped and
                    // counted, as radiance is.
                    if aov.albedo.iter().chain(&aov.normal).all(|x| x.is_finite()) {
                        for c in 0..3 {
                            aov_sum.albedo[c] += aov.albedo[c];
                            aov_sum.normal[c] += aov.normal[c];
                        }
                    } else {
                        dropped_aov += 1;
                    }
                    if aov.depth.is_finite() {
                        aov_sum.depth += aov.depth;
                        hits += 1;
                    }
                }
            }
            let taken = (samples.end - samples.start) as f32;
            if hero {
                color.push(rgb_sum.map(|c| c / taken));
            } else {
                let mean = sum * (1.0 / taken);
                color.push(crate::color::weighted_rgb(&to_rgb, &mean.0[..lanes]));
            }
            if want_aov {
                aovs.push(Aov {
                    albedo: aov_sum.albedo.map(|x| x / taken),
                    normal: aov_sum.normal.map(|x| x / taken),
                    depth: if hits > 0 { aov_sum.depth / hits as f32 } else { f32::INFINITY },
                });
                objects.push(object_at_centre(scene, px, py));
            }
        }
    }
    Some(TileOut { x0, y0, w, h, color, aov: aovs, object: objects, counters: tracer.counters, dropped, dropped_aov })
}

/// The index (in [`Scene::objects`], scene order) of the first surface the
/// ray through the centre of pixel `(px, py)` and the centre of the lens
/// meets, or [`NO_OBJECT`]. Geometry only: a cutout's holes do not count.
fn object_at_centre(scene: &Scene, px: u32, py: u32) -> i32 {
    let ray = scene.camera.ray(px as f32 + 0.5, py as f32 + 0.5, [0.5, 0.5]);
    scene.geometry.intersect(&ray, 0.0, f32::INFINITY).map_or(NO_OBJECT, |hit| hit.object as i32)
}
