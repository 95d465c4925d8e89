//! TSL from Python: the extension module `tsl._tsl`, which the package
//! `tsl` (python/tsl/) re-exports. Compile a program (`tsl.compile`),
//! describe its shaders, make instances whose parameters are set at run
//! time, shade numpy arrays of points with the GIL released and the
//! points split across cores, and render scene files (`tsl.render`).
//!
//! Every call goes through the library's public API (`tsl::Compiler`,
//! `Shader`, `Instance::bind`, `Material::at_batch`, `Function::call_batch`,
//! the renderer), so results are the Rust API's bits.

mod arrays;
mod colors;
mod errors;
mod points;
mod program;
mod render;
mod shading;
mod values;

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::PathBuf;

/// Compiles a TSL program from a file (`path`) or from text (`source`;
/// `name` is the file name its errors show), in the color model
/// `color_model` (`"rgb"`, `"spectral"`/`"hero"`, `"spectral16"`,
/// `"smits16"`, as the CLI's `--color`); `include` adds directories to
/// the import search path (the CLI's `-I`). Errors raise `tsl.CompileError`,
/// whose `str` is the rustc-style text and whose `.diagnostics` lists
/// `file`, `line`, `column` and `message`. The GIL is released.
#[pyfunction]
#[pyo3(signature = (path=None, source=None, color_model="rgb", name="<source>", include=Vec::new()))]
fn compile(
    py: Python<'_>,
    path: Option<PathBuf>,
    source: Option<&str>,
    color_model: &str,
    name: &str,
    include: Vec<PathBuf>,
) -> PyResult<program::Program> {
    let model = tsl::ColorModel::parse(color_model).ok_or_else(|| {
        PyValueError::new_err(format!(
            "`{color_model}` is not a color model: use rgb, spectral (= hero), spectralN or smitsN with N in 1..=64"
        ))
    })?;
    let compiler = include.into_iter().fold(tsl::Compiler::new().color_model(model), |c, dir| c.import_path(dir));
    let compiler = match (path, source) {
        (Some(path), None) => compiler.file(path),
        (None, Some(text)) => compiler.source(name, text),
        _ => return Err(PyValueError::new_err("give one of `path` and `source`")),
    };
    let program = py.detach(|| compiler.compile()).map_err(errors::compile_error)?;
    Ok(program::Program { program })
}

#[pymodule]
fn _tsl(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_function(wrap_pyfunction!(compile, m)?)?;
    m.add_function(wrap_pyfunction!(render::render, m)?)?;
    m.add_function(wrap_pyfunction!(render::read_exr, m)?)?;
    m.add_class::<program::Program>()?;
    m.add_class::<program::Shader>()?;
    m.add_class::<program::Parameter>()?;
    m.add_class::<program::Generator>()?;
    m.add_class::<shading::Material>()?;
    m.add_class::<shading::Instance>()?;
    m.add_class::<errors::Diagnostic>()?;
    m.add("BsdfSample", shading::sample_type(py)?)?;
    m.add("Error", py.get_type::<errors::Error>())?;
    m.add("CompileError", py.get_type::<errors::CompileError>())?;
    m.add("ParameterError", py.get_type::<errors::ParameterError>())?;
    Ok(())
}
