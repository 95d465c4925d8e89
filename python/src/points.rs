//! A call's shading points: the globals given by name (`P`, `N`, `u`, ...)
//! as numpy arrays, the rest set as a renderer sets them from `P` and `N`
//! (`Ng` = `N`, `Pl` = `P`, `dPdu`/`dPdv` a tangent frame around `N`), and
//! the run of a call over the points in chunks across cores.

use crate::arrays::{Held, Input, Kind, Words, hold};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;
use std::ops::Range;
use tsl::check::Ty;
use tsl::render::sampling::Frame;
use tsl::{ShadingBatch, ShadingGlobals};

/// Points per chunk a core runs at once: large enough that a chunk's
/// fixed cost (its batch setup, one native call) vanishes, small enough to
/// keep both cores busy on modest arrays.
const CHUNK: usize = 4096;

/// The normal of a point when the call gives none.
const DEFAULT_N: [f32; 3] = [0.0, 0.0, 1.0];

/// Holds each keyword argument as a shading global (an unknown name is a
/// `TypeError` with a did-you-mean), except the names in `skip`.
pub fn hold_globals<'py>(
    py: Python<'py>,
    kwargs: Option<&Bound<'py, PyDict>>,
    skip: &[&str],
) -> PyResult<Vec<Held<'py>>> {
    let mut held = Vec::new();
    let Some(kwargs) = kwargs else { return Ok(held) };
    for (key, value) in kwargs.iter() {
        let name: String = key.extract()?;
        if skip.contains(&name.as_str()) {
            continue;
        }
        let Some((_, ty)) = tsl::globals::word_of(&name) else {
            let names = tsl::check::GLOBALS.iter().map(|g| g.0);
            let hint = match tsl::diag::did_you_mean(&name, names.clone()) {
                Some(s) => format!("did you mean `{s}`?"),
                None => format!("the globals are {}", names.collect::<Vec<_>>().join(", ")),
            };
            return Err(PyTypeError::new_err(format!(
                "unexpected keyword argument `{name}`: not a shading global; {hint}"
            )));
        };
        let kind = match ty {
            Ty::Int => Kind::Int,
            t if t.is_triple() => Kind::Floats(3),
            _ => Kind::Floats(1),
        };
        held.push(hold(py, &name, kind, &value)?);
    }
    Ok(held)
}

/// Each global's words, the given ones and those derived from them.
pub struct Globals<'a> {
    by_name: Vec<(&'a str, Vec<Input<'a>>)>,
}

/// `dPdu` and `dPdv` around each point's normal, when the call gives no
/// tangents (`Frame::new`, as a mesh without uvs has them).
pub struct Tangents {
    s: Vec<f32>,
    t: Vec<f32>,
    per_point: bool,
}

impl Tangents {
    /// The frames around `N` at `n` points (one frame when `N` is one
    /// value for all); empty when the call gives its own tangents.
    pub fn new(given: &[Words<'_>], n: usize) -> Tangents {
        let find = |name: &str| given.iter().find(|w| w.name == name);
        if find("dPdu").is_some() || find("dPdv").is_some() {
            return Tangents { s: Vec::new(), t: Vec::new(), per_point: false };
        }
        let normal = find("N");
        let per_point = normal.is_some_and(|w| w.points.is_some());
        let count = if per_point { n } else { 1 };
        let (mut s, mut t) = (Vec::with_capacity(3 * count), Vec::with_capacity(3 * count));
        for i in 0..count {
            let nv = match normal {
                Some(w) => [0, 1, 2].map(|k| w.inputs[k].get(i)),
                None => DEFAULT_N,
            };
            let f = Frame::new(tsl::render::Vec3::from(nv));
            s.extend_from_slice(&f.s.to_array());
            t.extend_from_slice(&f.t.to_array());
        }
        Tangents { s, t, per_point }
    }

    fn inputs<'a>(&self, values: &'a [f32]) -> Vec<Input<'a>> {
        (0..3)
            .map(|k| match self.per_point {
                true => Input::Strided { values, first: k, stride: 3 },
                false => Input::Same(values[k]),
            })
            .collect()
    }
}

impl<'a> Globals<'a> {
    /// The globals `given`, with `N` (default `(0, 0, 1)`), `Ng` (= `N`),
    /// `Pl` (= `P`) and the tangents (`tangents`) when not given.
    pub fn new(given: &'a [Words<'a>], tangents: &'a Tangents) -> Globals<'a> {
        let mut by_name: Vec<(&'a str, Vec<Input<'a>>)> = given.iter().map(|w| (w.name, w.inputs.clone())).collect();
        let has = |by_name: &[(&str, Vec<Input>)], name: &str| by_name.iter().any(|(n, _)| *n == name);
        if !has(&by_name, "N") {
            by_name.push(("N", DEFAULT_N.map(Input::Same).to_vec()));
        }
        let copy = |by_name: &mut Vec<(&'a str, Vec<Input<'a>>)>, to: &'a str, from: &str| {
            if !has(by_name, to)
                && let Some((_, inputs)) = by_name.iter().find(|(n, _)| *n == from)
            {
                let inputs = inputs.clone();
                by_name.push((to, inputs));
            }
        };
        copy(&mut by_name, "Ng", "N");
        copy(&mut by_name, "Pl", "P");
        if !tangents.s.is_empty() {
            by_name.push(("dPdu", tangents.inputs(&tangents.s)));
            by_name.push(("dPdv", tangents.inputs(&tangents.t)));
        }
        Globals { by_name }
    }

    /// The points in `range` as a batch.
    pub fn batch(&self, range: &Range<usize>) -> Result<ShadingBatch<'a>, tsl::Error> {
        let mut batch = ShadingBatch::with_base(range.len(), ShadingGlobals::default());
        for (name, inputs) in &self.by_name {
            let columns: Vec<tsl::Column> = inputs.iter().map(|i| i.column(range)).collect();
            batch.set(name, &columns)?;
        }
        Ok(batch)
    }
}

/// Runs `f` over the `n` points in chunks across cores, concatenating the
/// `streams` float arrays each chunk returns in point order: the results
/// do not depend on the chunking (each point's result is its own).
pub fn run_chunks<F>(n: usize, streams: usize, f: F) -> Result<Vec<Vec<f32>>, tsl::Error>
where
    F: Fn(&Range<usize>) -> Result<Vec<Vec<f32>>, tsl::Error> + Sync,
{
    let ranges: Vec<Range<usize>> = (0..n).step_by(CHUNK).map(|s| s..(s + CHUNK).min(n)).collect();
    let parts: Vec<Vec<Vec<f32>>> = ranges.par_iter().map(&f).collect::<Result<_, _>>()?;
    let mut out: Vec<Vec<f32>> = vec![Vec::new(); streams];
    for part in parts {
        for (o, p) in out.iter_mut().zip(part) {
            o.extend_from_slice(&p);
        }
    }
    Ok(out)
}
