//! Rendering a program's `scene { }` block with the built-in ray tracer
//! into a caller-owned float buffer, with a progress callback that can
//! cancel.

use super::{TslError, TslProgram, TslStatus, guard, handle, invalid, put, slice_out, write};
use crate::render::{self, IntegratorKind, Overrides, RenderOptions, Scene};
use std::ffi::c_void;
use std::sync::atomic::{AtomicBool, Ordering};

/// `TslRenderSettings::integrator`: which integrator renders.
#[repr(C)]
#[allow(non_camel_case_types)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TslIntegrator {
    /// The scene's own choice.
    TSL_INTEGRATOR_SCENE = 0,
    /// Whitted ray tracing.
    TSL_INTEGRATOR_WHITTED = 1,
    /// Path tracing.
    TSL_INTEGRATOR_PATH = 2,
}

/// Overrides of the scene's `render { }` settings, as `tslc render`'s
/// options; a zero field keeps the scene's value.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct TslRenderSettings {
    /// `--res WxH` (both or neither).
    pub width: u32,
    pub height: u32,
    /// `--spp`.
    pub spp: u32,
    /// `--max-depth`.
    pub max_depth: u32,
    /// `--seed`, when `override_seed` is true.
    pub seed: u64,
    pub override_seed: bool,
    /// A `TslIntegrator`: `TSL_INTEGRATOR_SCENE`, `_WHITTED` or `_PATH`.
    pub integrator: u32,
}

/// A scene ready to render: the program's scene block built (objects,
/// lights, BVH) with the settings applied. Immutable; renders of one scene
/// may run on several threads at once.
pub struct TslScene {
    scene: Scene,
}

/// Called from the render's worker threads (several at once: it must be
/// thread-safe) as pixels finish, with the pixels done and the total;
/// returning false cancels the render, which then returns
/// `TSL_CANCELLED`.
pub type TslProgressFn = Option<extern "C" fn(user_data: *mut c_void, done: u64, total: u64) -> bool>;

/// Builds the scene of `program` (compiled from a file or string with a
/// `scene { }` block) with `settings` (null: the scene's own) into `*out`;
/// free it with `tsl_scene_free`. A program without a scene, or a bad
/// scene, is `TSL_ERROR`.
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_scene_new(
    program: *const TslProgram,
    settings: *const TslRenderSettings,
    out: *mut *mut TslScene,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let program = &handle(program, "program")?.program;
        let mut overrides = Overrides::default();
        // SAFETY: null or a readable `TslRenderSettings` (the header's
        // contract).
        if let Some(s) = unsafe { settings.as_ref() } {
            let some = |n: u32| (n != 0).then_some(n);
            overrides.resolution = match (s.width, s.height) {
                (0, 0) => None,
                (0, _) | (_, 0) => return invalid("give both `width` and `height`, or neither"),
                (w, h) => Some((w, h)),
            };
            overrides.spp = some(s.spp);
            overrides.max_depth = some(s.max_depth);
            overrides.seed = s.override_seed.then_some(s.seed);
            overrides.integrator = match s.integrator {
                n if n == TslIntegrator::TSL_INTEGRATOR_SCENE as u32 => None,
                n if n == TslIntegrator::TSL_INTEGRATOR_WHITTED as u32 => Some(IntegratorKind::Whitted),
                n if n == TslIntegrator::TSL_INTEGRATOR_PATH as u32 => Some(IntegratorKind::Path),
                n => return invalid(format!("{n} is not a TSL_INTEGRATOR_ value")),
            };
        }
        if program.scene().is_none() {
            return Err(crate::Error::plain("the program has no `scene { }` block to render".into()).into());
        }
        let scene = Scene::build(program, &overrides)?;
        put(out, TslScene { scene }, "out")
    })
}

/// Frees a scene (null is ignored).
/// Threads: not while another call uses the handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_scene_free(scene: *mut TslScene) {
    super::free(scene);
}

/// The image's width and height in pixels, into `*width` and `*height`.
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_scene_size(
    scene: *const TslScene,
    width: *mut u32,
    height: *mut u32,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let s = &handle(scene, "scene")?.scene.settings;
        write(width, s.width, "width")?;
        write(height, s.height, "height")
    })
}

/// Thread-safe holder of the caller's progress callback and its data.
struct Progress {
    callback: extern "C" fn(*mut c_void, u64, u64) -> bool,
    user_data: *mut c_void,
    cancel: AtomicBool,
}

// SAFETY: the header requires the callback to be callable from several
// threads at once with the caller's `user_data`; TSL only passes it back.
unsafe impl Sync for Progress {}

/// Renders `scene` into `out`: `len` floats, which must be
/// `width * height * 3` (`tsl_scene_size`): linear RGB radiance, rows top to bottom, the
/// bits `tslc render` writes to an EXR with the same settings. `threads`
/// 0 uses every core. `progress` (may be null) is called as pixels finish;
/// its returning false cancels the render (`TSL_CANCELLED`, `out`
/// unchanged). Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_scene_render(
    scene: *const TslScene,
    threads: u32,
    out: *mut f32,
    len: usize,
    progress: TslProgressFn,
    user_data: *mut c_void,
    error: *mut *mut TslError,
) -> TslStatus {
    guard(error, || {
        let scene = &handle(scene, "scene")?.scene;
        let pixels = scene.settings.width as usize * scene.settings.height as usize;
        if len != pixels * 3 {
            return invalid(format!(
                "the image is {}x{}: `out` must hold {} floats, not {len}",
                scene.settings.width,
                scene.settings.height,
                pixels * 3
            ));
        }
        let out = slice_out(out, len, "out")?;
        let progress = progress.map(|callback| Progress { callback, user_data, cancel: AtomicBool::new(false) });
        let report = |done: u64, total: u64| {
            if let Some(p) = &progress
                && !(p.callback)(p.user_data, done, total)
            {
                p.cancel.store(true, Ordering::Relaxed);
            }
        };
        let options = RenderOptions {
            threads: threads as usize,
            progress: progress.as_ref().map(|_| &report as &(dyn Fn(u64, u64) + Sync)),
            cancel: progress.as_ref().map(|p| &p.cancel),
            ..Default::default()
        };
        match render::render(scene, &options) {
            Ok((image, _)) => {
                out.copy_from_slice(image.color.as_flattened());
                Ok(())
            }
            Err(e) if e == render::CANCELLED => Err(super::Failure::Cancelled(e)),
            Err(e) => Err(crate::Error::plain(e).into()),
        }
    })
}
