//! `tsl.render`: a scene file rendered as `tslc render` renders it (the
//! same library calls: check, compile, build the scene, render), to a
//! numpy array instead of a file, and `tsl.read_exr` to read an image back.

use crate::errors::compile_error;
use numpy::IntoPyArray;
use numpy::ndarray::{Array2, Array3};
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use tsl::image_io::RenderedImage;
use tsl::render::{IntegratorKind, Overrides, RenderOptions, Scene};

/// Renders the scene file `path` (a `.tsl` file with a `scene { ... }`
/// block) and returns a `(height, width, 3)` float32 array of linear
/// radiance: the same bits `tslc render` writes to an EXR with the same
/// settings. `spp`, `res` (`(width, height)`), `seed` and `integrator`
/// (`"path"` or `"whitted"`) override the scene's; `color` is the color
/// model as the CLI's `--color` (`"rgb"`, `"spectral"`/`"hero"`,
/// `"spectral16"`, `"smits16"`). With `aov=True` the result is
/// `(image, layers)`, `layers` a dict of `albedo` and `normal`
/// (`(height, width, 3)`), `depth` (`(height, width)`) and `object`
/// (int32, -1 for none). `include` adds directories to the import search
/// path (the CLI's `-I`). `progress`, a callable, is called as
/// `progress(pixels_done, pixels_total)` as the render goes (from the
/// calling thread; an exception it raises stops the render and is
/// raised). The GIL is released; Ctrl-C stops the render
/// (`KeyboardInterrupt`).
#[pyfunction]
#[pyo3(signature = (path, spp=None, res=None, seed=None, integrator=None, color=None, aov=false, include=Vec::new(), progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn render<'py>(
    py: Python<'py>,
    path: PathBuf,
    spp: Option<u32>,
    res: Option<(u32, u32)>,
    seed: Option<u64>,
    integrator: Option<&str>,
    color: Option<&str>,
    aov: bool,
    include: Vec<PathBuf>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let model = match color {
        None => tsl::ColorModel::Rgb,
        Some(name) => tsl::ColorModel::parse(name).ok_or_else(|| {
            PyValueError::new_err(format!(
                "`{name}` is not a color model: use rgb, spectral (= hero), spectralN or smitsN with N in 1..=64"
            ))
        })?,
    };
    let integrator = integrator
        .map(|name| {
            IntegratorKind::parse(name)
                .ok_or_else(|| PyValueError::new_err(format!("`{name}` is not an integrator: use whitted or path")))
        })
        .transpose()?;
    if spp.is_some_and(|s| s == 0 || s > tsl::scene::MAX_SPP) {
        return Err(PyValueError::new_err(format!("spp must be from 1 to {}", tsl::scene::MAX_SPP)));
    }
    if let Some((w, h)) = res {
        let side = tsl::scene::MAX_IMAGE_SIDE;
        if w == 0 || h == 0 || w > side || h > side || u64::from(w) * u64::from(h) > tsl::scene::MAX_PIXELS {
            return Err(PyValueError::new_err(format!("the resolution {w}x{h} is not between 1x1 and {side}x{side}")));
        }
    }
    let overrides = Overrides { resolution: res, spp, seed, integrator, ..Default::default() };
    let cancel = AtomicBool::new(false);
    let done = Progress::default();
    // An exception from `progress`, raised once the render has stopped.
    let mut raised: Option<PyErr> = None;
    // The render runs on its own thread; this one (Python's main thread,
    // where signal handlers run) looks for Ctrl-C and reports progress
    // between waits.
    let image = py.detach(|| {
        std::thread::scope(|scope| {
            let worker = scope.spawn(|| render_file(&path, &include, model, &overrides, aov, &cancel, &done));
            let mut reported = (0, 0);
            let mut report = || {
                Python::attach(|py| {
                    if py.check_signals().is_err() {
                        cancel.store(true, Ordering::Relaxed);
                    }
                    let now = (done.pixels.load(Ordering::Relaxed), done.total.load(Ordering::Relaxed));
                    if let Some(callback) = progress.as_ref().filter(|_| now != reported && raised.is_none()) {
                        reported = now;
                        if let Err(e) = callback.call1(py, now) {
                            raised = Some(e);
                            cancel.store(true, Ordering::Relaxed);
                        }
                    }
                })
            };
            while !worker.is_finished() {
                std::thread::sleep(std::time::Duration::from_millis(50));
                report();
            }
            // The last report (the render may end between two looks).
            report();
            worker.join().unwrap_or_else(|_| Err(Failure::Render("the render panicked".into())))
        })
    });
    if let Some(e) = raised {
        return Err(e);
    }
    let image = match image {
        Ok(image) => image,
        Err(Failure::Compile(e)) => return Err(compile_error(e)),
        Err(Failure::Render(message)) if message == tsl::render::CANCELLED => {
            return Err(PyKeyboardInterrupt::new_err("the render was cancelled"));
        }
        Err(Failure::Render(message)) => return Err(PyRuntimeError::new_err(message)),
    };
    image_to_python(py, &image, aov)
}

/// The image as a `(height, width, 3)` array, and with `layers` a dict of
/// its AOV layers beside it.
fn image_to_python<'py>(py: Python<'py>, image: &RenderedImage, layers: bool) -> PyResult<Bound<'py, PyAny>> {
    let color = pixels(image, &image.color)?.into_pyarray(py).into_any();
    if !layers {
        return Ok(color);
    }
    let dict = PyDict::new(py);
    if let Some(albedo) = &image.albedo {
        dict.set_item("albedo", pixels(image, albedo)?.into_pyarray(py))?;
    }
    if let Some(normal) = &image.normal {
        dict.set_item("normal", pixels(image, normal)?.into_pyarray(py))?;
    }
    if let Some(depth) = &image.depth {
        dict.set_item("depth", plane(image, depth.clone())?.into_pyarray(py))?;
    }
    if let Some(object) = &image.object {
        dict.set_item("object", plane(image, object.clone())?.into_pyarray(py))?;
    }
    Ok((color, dict).into_pyobject(py)?.into_any())
}

/// Reads an EXR image (as `tslc render` writes them) as a `(height,
/// width, 3)` float32 array of its RGB channels; with `aov=True`,
/// `(image, layers)` as `render` gives them (the layers the file has).
#[pyfunction]
#[pyo3(signature = (path, aov=false))]
pub fn read_exr<'py>(py: Python<'py>, path: PathBuf, aov: bool) -> PyResult<Bound<'py, PyAny>> {
    let image = py.detach(|| tsl::image_io::read_exr(&path)).map_err(PyRuntimeError::new_err)?;
    image_to_python(py, &image, aov)
}

/// Pixels rendered so far, of the total, as the renderer reports them.
#[derive(Default)]
struct Progress {
    pixels: AtomicU64,
    total: AtomicU64,
}

/// Why a render did not finish.
enum Failure {
    Compile(tsl::Error),
    Render(String),
}

/// `tslc render`'s steps for one frame: check, compile (lean: one frame),
/// build the scene from its description, render on every core.
fn render_file(
    path: &std::path::Path,
    include: &[PathBuf],
    model: tsl::ColorModel,
    overrides: &Overrides,
    aov: bool,
    cancel: &AtomicBool,
    done: &Progress,
) -> Result<RenderedImage, Failure> {
    let options = tsl::LoadOptions {
        import_paths: include.to_vec(),
        color_model: model,
        lean: true,
        ..tsl::LoadOptions::default()
    };
    let checked = tsl::check_file(path, &options);
    let compiler = tsl::Compiler::new().color_model(model).lean(true);
    let compiler = include.iter().fold(compiler, |c, dir| c.import_path(dir));
    let mut program = compiler.compile_checked(checked).map_err(Failure::Compile)?;
    let scene = match program.take_scene() {
        Some(desc) => Scene::build_owned(&program, desc, overrides),
        None => Scene::build_from(&program, None, overrides),
    }
    .map_err(Failure::Compile)?;
    let report = |pixels: u64, total: u64| {
        done.total.store(total, Ordering::Relaxed);
        done.pixels.fetch_max(pixels, Ordering::Relaxed);
    };
    let options = RenderOptions { aov, progress: Some(&report), cancel: Some(cancel), ..Default::default() };
    let (image, _stats) = tsl::render::render(&scene, &options).map_err(Failure::Render)?;
    Ok(image)
}

/// A `(height, width, 3)` array of an image's pixels.
fn pixels(image: &RenderedImage, values: &[[f32; 3]]) -> PyResult<Array3<f32>> {
    let (w, h) = (image.width as usize, image.height as usize);
    Array3::from_shape_vec((h, w, 3), values.as_flattened().to_vec())
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// A `(height, width)` array of one value per pixel.
fn plane<T>(image: &RenderedImage, values: Vec<T>) -> PyResult<Array2<T>> {
    let (w, h) = (image.width as usize, image.height as usize);
    Array2::from_shape_vec((h, w), values).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}
