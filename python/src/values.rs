//! Parameter values between Python and TSL: what `shader.instance(**values)`
//! accepts (numbers, bools, strings, 2- and 3-sequences, instances) and
//! how a parameter's default reads back (`float`, `tuple`, `str`, ...).

use crate::shading::Instance;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyFloat, PyInt, PyString, PyTuple};
use tsl::{ColorModel, ParamValue};

/// The TSL value of the Python `value` given for parameter `name`: a bool,
/// an int, a float (numpy scalars included), a str, a sequence of two or
/// three numbers (vec2; vector, point, normal or RGB color), or a
/// `tsl.Instance` for a `material` parameter. Whether it suits the
/// parameter's type is the instance's check.
pub fn from_python(name: &str, value: &Bound<'_, PyAny>) -> PyResult<ParamValue> {
    if value.is_instance_of::<PyBool>() {
        return Ok(ParamValue::Bool(value.extract()?));
    }
    // numpy's integer scalars are not `int`s, but have `__index__`.
    if value.is_instance_of::<PyInt>() || value.hasattr("__index__")? && !value.hasattr("__len__")? {
        let Ok(i) = value.extract::<i32>() else {
            return Err(PyTypeError::new_err(format!("`{name}` = {value} does not fit a TSL int (32 bits)")));
        };
        return Ok(ParamValue::Int(i));
    }
    if value.is_instance_of::<PyString>() {
        return Ok(ParamValue::String(value.extract()?));
    }
    if let Ok(instance) = value.cast::<Instance>() {
        return Ok(ParamValue::from(instance.borrow().tsl_instance()));
    }
    if value.is_instance_of::<PyFloat>() || value.hasattr("__float__")? && !value.hasattr("__len__")? {
        return Ok(ParamValue::Float(value.extract::<f64>()? as f32));
    }
    if let Ok(v) = value.extract::<Vec<f64>>() {
        let v: Vec<f32> = v.into_iter().map(|x| x as f32).collect();
        match v[..] {
            [x, y] => return Ok(ParamValue::Vec2([x, y])),
            [x, y, z] => return Ok(ParamValue::Triple([x, y, z])),
            _ => {}
        }
    }
    Err(PyTypeError::new_err(format!(
        "`{name}` = {value}: give a number, a bool, a str, a sequence of 2 or 3 numbers, or a tsl.Instance"
    )))
}

/// A parameter's value as Python: a float, int, bool or str, a tuple for
/// vectors and colors (a spectral color as its RGB), `None` for what has no
/// plain Python value (a material).
pub fn to_python<'py>(py: Python<'py>, value: &ParamValue) -> PyResult<Bound<'py, PyAny>> {
    Ok(match value {
        ParamValue::Float(x) => x.into_pyobject(py)?.into_any(),
        ParamValue::Int(i) => i.into_pyobject(py)?.into_any(),
        ParamValue::Bool(b) => PyBool::new(py, *b).to_owned().into_any(),
        ParamValue::Triple(t) => PyTuple::new(py, t)?.into_any(),
        ParamValue::Vec2(v) => PyTuple::new(py, v)?.into_any(),
        ParamValue::Color(c) if c.model() == ColorModel::Rgb => PyTuple::new(py, c.lanes())?.into_any(),
        ParamValue::Color(c) => PyTuple::new(py, c.to_rgb())?.into_any(),
        ParamValue::Matrix(m) => PyTuple::new(py, m)?.into_any(),
        ParamValue::String(s) => s.into_pyobject(py)?.into_any(),
        ParamValue::Material(_) => py.None().into_bound(py),
    })
}
