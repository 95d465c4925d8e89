//! numpy arrays in: each argument read in place as [`tsl::Column`]s (a
//! float32 array, C-contiguous or strided, is never copied; another dtype
//! is converted to float32 once), its shape checked against what the
//! argument is (`(N, 3)` or `(3,)` for a vector, `(N,)` or a scalar for a
//! number), and the number of points agreed between arguments.

use numpy::{PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use std::ops::Range;
use tsl::Column;

/// What one argument holds at each point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// `width` floats: `(N,)` or a scalar for 1, `(N, width)` or
    /// `(width,)` for more.
    Floats(usize),
    /// One int (`face`, `frame`): its bits are passed as they are.
    Int,
}

impl Kind {
    pub fn width(self) -> usize {
        match self {
            Kind::Floats(w) => w,
            Kind::Int => 1,
        }
    }
}

/// An argument's array, borrowed from Python for the call.
pub struct Held<'py> {
    pub name: String,
    pub kind: Kind,
    array: PyReadonlyArrayDyn<'py, f32>,
}

/// Converts `value` (an array, a sequence, a number) for argument `name`:
/// float32 (ints: int32, viewed as float32 words), readable in place.
pub fn hold<'py>(py: Python<'py>, name: &str, kind: Kind, value: &Bound<'py, PyAny>) -> PyResult<Held<'py>> {
    let np = py.import("numpy")?;
    let dtype = if kind == Kind::Int { "int32" } else { "float32" };
    let converted = np
        .call_method1("asarray", (value, dtype))
        .map_err(|e| PyTypeError::new_err(format!("`{name}` is not an array of numbers: {e}")))?;
    let converted = if kind == Kind::Int { converted.call_method1("view", ("float32",))? } else { converted };
    let mut array = converted.cast_into::<PyArrayDyn<f32>>().map_err(PyErr::from)?;
    if !readable_in_place(&array) {
        array = np.call_method1("ascontiguousarray", (array,))?.cast_into::<PyArrayDyn<f32>>().map_err(PyErr::from)?;
    }
    Ok(Held { name: name.to_string(), kind, array: array.readonly() })
}

/// Whether [`Held::view`] can read the array where it is: non-negative
/// strides, multiples of a float, and an aligned start.
fn readable_in_place(array: &Bound<'_, PyArrayDyn<f32>>) -> bool {
    let aligned = (array.data() as usize).is_multiple_of(std::mem::align_of::<f32>());
    aligned && array.strides().iter().all(|&s| s >= 0 && s % 4 == 0)
}

/// One word of every point: a stretch of an array read with a stride (in
/// floats), or one value for all points.
#[derive(Debug, Clone, Copy)]
pub enum Input<'a> {
    Strided { values: &'a [f32], first: usize, stride: usize },
    Same(f32),
}

impl<'a> Input<'a> {
    /// The column of the points in `range`.
    pub fn column(&self, range: &Range<usize>) -> Column<'a> {
        match *self {
            Input::Same(x) => Column::uniform(x),
            Input::Strided { values, first, stride } => Column::strided(values, first + range.start * stride, stride),
        }
    }

    /// The value at point `i`.
    pub fn get(&self, i: usize) -> f32 {
        match *self {
            Input::Same(x) => x,
            Input::Strided { values, first, stride } => values[first + i * stride],
        }
    }
}

/// The columns of `inputs` for the points in `range`.
pub fn columns<'a>(inputs: &[Input<'a>], range: &Range<usize>) -> Vec<Column<'a>> {
    inputs.iter().map(|i| i.column(range)).collect()
}

/// The three columns of a vector's `inputs` for the points in `range`.
pub fn triple<'a>(inputs: &[Input<'a>], range: &Range<usize>) -> [Column<'a>; 3] {
    [0, 1, 2].map(|k| inputs[k].column(range))
}

/// An argument's words: one [`Input`] per word, and how many points it
/// gives (`None`: one value for all).
pub struct Words<'a> {
    pub name: &'a str,
    pub inputs: Vec<Input<'a>>,
    pub points: Option<usize>,
}

impl Held<'_> {
    /// The argument's words, after checking its shape.
    pub fn view(&self) -> PyResult<Words<'_>> {
        let width = self.kind.width();
        let shape = self.array.shape();
        let per_point = match (width, shape) {
            (1, []) | (1, [_]) => shape.len() == 1,
            (w, [k]) if *k == w => false,
            (w, [_, k]) if *k == w => true,
            _ => {
                let want =
                    if width == 1 { "(N,) or a scalar".to_string() } else { format!("(N, {width}) or ({width},)") };
                return Err(PyValueError::new_err(format!(
                    "`{}` must have shape {want}, not {}",
                    self.name,
                    shape_text(shape)
                )));
            }
        };
        let words = |inputs, points| Words { name: &self.name, inputs, points };
        if !per_point {
            let view = self.array.as_array();
            let values: Vec<Input> = view.iter().map(|&x| Input::Same(x)).collect();
            return Ok(words(values, None));
        }
        let n = shape[0];
        let strides: Vec<usize> = self.array.strides().iter().map(|&s| s as usize / 4).collect();
        let values = self.in_place();
        let inputs = (0..width)
            .map(|k| match (n, strides.get(1)) {
                (0, _) => Input::Strided { values: &[], first: 0, stride: 1 },
                (_, Some(&field)) => Input::Strided { values, first: k * field, stride: strides[0] },
                (_, None) => Input::Strided { values, first: 0, stride: strides[0] },
            })
            .collect();
        Ok(words(inputs, Some(n)))
    }

    /// The floats from the array's first element to its last, as they lie
    /// in its buffer (strided views included).
    fn in_place(&self) -> &[f32] {
        if let Ok(values) = self.array.as_slice() {
            return values;
        }
        let shape = self.array.shape();
        if shape.contains(&0) {
            return &[];
        }
        let span = 1 + shape
            .iter()
            .zip(self.array.strides())
            .map(|(&len, &stride)| (len - 1) * (stride as usize / 4))
            .sum::<usize>();
        // SAFETY: `hold` made the array's strides non-negative multiples of
        // 4 bytes and its start aligned (`readable_in_place`), so every
        // element lies in the `span` floats from its first one, inside the
        // buffer the view was cut from; the readonly borrow keeps the
        // array alive and unborrowed mutably by Rust for `&self`'s life.
        // Columns read only the elements themselves.
        unsafe { std::slice::from_raw_parts(self.array.data(), span) }
    }
}

/// `(4, 2)` as numpy prints a shape.
fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!("({})", shape.iter().map(usize::to_string).collect::<Vec<_>>().join(", ")),
    }
}

/// The number of points of a call: what every per-point argument agrees
/// on (1 when every argument is one value for all).
pub fn points(args: &[&Words<'_>]) -> PyResult<usize> {
    let mut first: Option<(&str, usize)> = None;
    for w in args {
        let Some(n) = w.points else { continue };
        match first {
            None => first = Some((w.name, n)),
            Some((name, m)) if m != n => {
                return Err(PyValueError::new_err(format!(
                    "`{}` has {n} points and `{name}` has {m}: give every array the same N (or one value for all)",
                    w.name
                )));
            }
            Some(_) => {}
        }
    }
    Ok(first.map_or(1, |(_, n)| n))
}
