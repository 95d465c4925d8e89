//! Exceptions: a [`tsl::Error`] becomes `tsl.CompileError` (or
//! `tsl.ParameterError` for a value an instance refuses), whose `str` is
//! the rustc-style text and whose `.diagnostics` lists each diagnostic's
//! file, line, column and message.

use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::PyList;

pyo3::create_exception!(
    tsl,
    Error,
    PyException,
    "Base class of TSL's errors: `str(e)` is the rustc-style text, `e.diagnostics` the list of `Diagnostic`s."
);
pyo3::create_exception!(tsl, CompileError, Error, "A program that does not compile, or a name it does not define.");
pyo3::create_exception!(
    tsl,
    ParameterError,
    Error,
    "A value a shader instance refuses: an unknown parameter, a wrong type, a string outside the options."
);

/// One diagnostic of an error: where it points and what it says.
#[pyclass(module = "tsl", frozen, get_all)]
pub struct Diagnostic {
    /// The file as the program was given it (`None`: no source text).
    pub file: Option<String>,
    /// 1-based line (0 without a file).
    pub line: usize,
    /// 1-based column, in characters (0 without a file).
    pub column: usize,
    pub message: String,
    /// `"error"` or `"warning"`.
    pub severity: &'static str,
}

#[pymethods]
impl Diagnostic {
    fn __repr__(&self) -> String {
        match &self.file {
            Some(file) => {
                format!("<Diagnostic {file}:{}:{}: {}: {}>", self.line, self.column, self.severity, self.message)
            }
            None => format!("<Diagnostic {}: {}>", self.severity, self.message),
        }
    }

    fn __str__(&self) -> String {
        match &self.file {
            Some(file) => format!("{file}:{}:{}: {}: {}", self.line, self.column, self.severity, self.message),
            None => format!("{}: {}", self.severity, self.message),
        }
    }
}

/// Which exception a [`tsl::Error`] raises.
#[derive(Clone, Copy)]
pub enum Kind {
    Compile,
    Parameter,
}

/// The exception for `error`, its diagnostics attached.
pub fn raise(py: Python<'_>, error: &tsl::Error, kind: Kind) -> PyErr {
    let text = error.to_string();
    let err = match kind {
        Kind::Compile => CompileError::new_err(text.trim_end().to_string()),
        Kind::Parameter => ParameterError::new_err(text.trim_end().to_string()),
    };
    let diagnostics: Vec<Diagnostic> = error
        .diagnostics
        .iter()
        .map(|d| {
            let (file, line, column) = match error.location(d) {
                Some((file, line, column)) => (Some(file.to_string()), line, column),
                None => (None, 0, 0),
            };
            let severity = if d.is_error() { "error" } else { "warning" };
            Diagnostic { file, line, column, message: d.message.clone(), severity }
        })
        .collect();
    let attached = PyList::new(py, diagnostics).and_then(|list| err.value(py).setattr("diagnostics", list));
    match attached {
        Ok(()) => err,
        Err(e) => e,
    }
}

/// [`raise`] as `tsl.CompileError`, for `map_err`.
pub fn compile_error(error: tsl::Error) -> PyErr {
    Python::attach(|py| raise(py, &error, Kind::Compile))
}

/// [`raise`] as `tsl.ParameterError`, for `map_err`.
pub fn parameter_error(error: tsl::Error) -> PyErr {
    Python::attach(|py| raise(py, &error, Kind::Parameter))
}
