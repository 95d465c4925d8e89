//! `tsl.Material` and `tsl.Instance`: a material's surface calls over numpy
//! arrays of points (`reflection`, `sample`, `pdf`, `emission`, `albedo`), one batch
//! per chunk of points across cores with the GIL released. An instance is
//! a material whose parameters are set at run time (`set` binds the new
//! values; nothing is compiled again).

use crate::arrays::{Held, Input, Kind, Words, columns, hold, points, triple};
use crate::colors;
use crate::errors::{compile_error, parameter_error};
use crate::points::{Globals, Tangents, hold_globals, run_chunks};
use crate::values;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::PyDict;

use tsl::SurfaceBatch;

/// A material of a program: its surface calls over arrays of points.
#[pyclass(module = "tsl", subclass)]
pub struct Material {
    pub(crate) program: tsl::Program,
    pub(crate) material: tsl::Material,
    pub(crate) name: String,
}

/// One surface call, by what it reads.
#[derive(Clone, Copy)]
enum Call {
    Reflection,
    Sample,
    Pdf,
    EvalPdf,
    Emission,
    Albedo,
}

/// The arrays of a call, held for its length.
struct CallArgs<'py> {
    /// The call's own arguments, in its order.
    own: Vec<Held<'py>>,
    light: Option<Held<'py>>,
    eta: Option<Held<'py>>,
    globals: Vec<Held<'py>>,
}

impl Material {
    /// Runs `call` over the points, the GIL released; the result streams
    /// (RGB colors as 3 floats a point) and the number of points. The
    /// material is borrowed only to clone its handles (cheap), so another
    /// thread may `set` an instance's values meanwhile: this call shades
    /// with the values it started with.
    fn run(slf: &Bound<'_, Self>, call: Call, args: CallArgs<'_>) -> PyResult<(Vec<Vec<f32>>, usize)> {
        let py = slf.py();
        let (program, material) = {
            let this = slf.borrow();
            (this.program.clone(), this.material.clone())
        };
        let own: Vec<Words> = args.own.iter().map(Held::view).collect::<PyResult<_>>()?;
        let light = args.light.as_ref().map(Held::view).transpose()?;
        let eta = args.eta.as_ref().map(Held::view).transpose()?;
        let given: Vec<Words> = args.globals.iter().map(Held::view).collect::<PyResult<_>>()?;
        let all: Vec<&Words> = own.iter().chain(&light).chain(&eta).chain(&given).collect();
        let n = points(&all)?;
        let (program, material) = (&program, &material);
        let model = program.color_model();
        let lanes = model.lanes();
        let out = py.detach(|| {
            let tangents = Tangents::new(&given, n);
            let globals = Globals::new(&given, &tangents);
            // White light by default.
            let light_rgb = light.as_ref().map_or([Input::Same(1.0); 3].to_vec(), |w| w.inputs.clone());
            let light_points = light.as_ref().and_then(|w| w.points);
            let upsampled = colors::upsample(program, &light_rgb, light_points);
            let light_lanes = colors::lanes(model, &light_rgb, light_points, &upsampled);
            let eta_lane = eta.as_ref().map_or(Input::Same(1.0), |w| w.inputs[0]);
            let streams = match call {
                Call::Sample => 4,
                Call::EvalPdf => 2,
                _ => 1,
            };
            run_chunks(n, streams, |range| {
                let batch = globals.batch(range)?;
                let eta_columns = vec![eta_lane.column(range); lanes];
                let wo = match call {
                    Call::Reflection | Call::Pdf | Call::EvalPdf => &own[1],
                    Call::Sample | Call::Emission | Call::Albedo => &own[0],
                };
                let mut surface: SurfaceBatch = material.at_batch(&batch, triple(&wo.inputs, range), &eta_columns)?;
                Ok(match call {
                    Call::Reflection => {
                        let c = surface.reflection(triple(&own[0].inputs, range), &columns(&light_lanes, range))?;
                        vec![colors::to_rgb(model, lanes, &c.values)]
                    }
                    Call::Emission => vec![colors::to_rgb(model, lanes, &surface.emission()?.values)],
                    Call::Albedo => vec![colors::to_rgb(model, lanes, &surface.albedo()?.values)],
                    Call::Pdf => vec![surface.pdf(triple(&own[0].inputs, range))?],
                    Call::EvalPdf => {
                        let e = surface.eval_pdf(triple(&own[0].inputs, range))?;
                        vec![colors::to_rgb(model, lanes, &e.value.values), e.pdf]
                    }
                    Call::Sample => {
                        let u2 = [own[2].inputs[0].column(range), own[2].inputs[1].column(range)];
                        let s = surface.sample(own[1].inputs[0].column(range), u2)?;
                        vec![
                            s.wi.as_flattened().to_vec(),
                            colors::to_rgb(model, lanes, &s.weight.values),
                            s.pdf,
                            s.delta.iter().map(|&d| if d { 1.0 } else { 0.0 }).collect(),
                        ]
                    }
                })
            })
        });
        Ok((out.map_err(compile_error)?, n))
    }

    /// Holds the call's arrays: `own` by name and kind, then `light`,
    /// `eta` and the globals.
    fn hold_args<'py>(
        py: Python<'py>,
        own: &[(&str, Kind, &Bound<'py, PyAny>)],
        light: Option<&Bound<'py, PyAny>>,
        eta: Option<&Bound<'py, PyAny>>,
        globals: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<CallArgs<'py>> {
        Ok(CallArgs {
            own: own.iter().map(|(name, kind, v)| hold(py, name, *kind, v)).collect::<PyResult<_>>()?,
            light: light.filter(|l| !l.is_none()).map(|l| hold(py, "light", Kind::Floats(3), l)).transpose()?,
            eta: eta.filter(|e| !e.is_none()).map(|e| hold(py, "eta", Kind::Floats(1), e)).transpose()?,
            globals: hold_globals(py, globals, &[])?,
        })
    }
}

/// What `eval_pdf` returns: `(N, 3)` RGB values and `(N,)` pdfs.
type ValueAndPdf<'py> = (Bound<'py, PyArray2<f32>>, Bound<'py, PyArray1<f32>>);

/// An `(n, width)` float32 array of `values`.
fn matrix<'py>(py: Python<'py>, values: Vec<f32>, n: usize, width: usize) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let array = Array2::from_shape_vec((n, width), values)
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
    Ok(array.into_pyarray(py))
}

/// The `BsdfSample` named tuple type (made once per interpreter).
pub fn sample_type(py: Python<'_>) -> PyResult<&Bound<'_, PyAny>> {
    static TYPE: PyOnceLock<Py<PyAny>> = PyOnceLock::new();
    TYPE.get_or_try_init(py, || {
        let namedtuple = py.import("collections")?.getattr("namedtuple")?;
        let kwargs = PyDict::new(py);
        kwargs.set_item("module", "tsl")?;
        Ok(namedtuple.call(("BsdfSample", ["wi", "weight", "pdf", "delta"]), Some(&kwargs))?.unbind())
    })
    .map(|t| t.bind(py))
}

#[pymethods]
impl Material {
    /// The material's name (an instance's: its shader's).
    #[getter]
    fn name(&self) -> &str {
        &self.name
    }

    /// Light reflected toward `wo` from light `light` arriving from `wi`,
    /// at every point: `(N, 3)` float32 linear RGB (a spectral program's
    /// colors are converted to RGB point by point; `light` is RGB, white by
    /// default, upsampled as the program upsamples RGB).
    ///
    /// `wi`, `wo`: `(N, 3)` unit vectors (or one `(3,)` for all points);
    /// `eta`: the relative index of refraction outside, `(N,)` or a scalar
    /// (1 by default); `**globals`: the shading globals by name (`P`, `N`,
    /// `u`, `v`, `dPdu`, `face`, ...), `(N, 3)` / `(N,)` or one value for
    /// all. `N` defaults to `(0, 0, 1)`, `Ng` to `N`, `Pl` to `P`,
    /// `dPdu`/`dPdv` to a tangent frame around `N`, the rest to 0.
    #[pyo3(signature = (wi, wo, light=None, *, eta=None, **globals))]
    fn reflection<'py>(
        slf: &Bound<'py, Self>,
        py: Python<'py>,
        wi: &Bound<'py, PyAny>,
        wo: &Bound<'py, PyAny>,
        light: Option<&Bound<'py, PyAny>>,
        eta: Option<&Bound<'py, PyAny>>,
        globals: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let own = [("wi", Kind::Floats(3), wi), ("wo", Kind::Floats(3), wo)];
        let args = Self::hold_args(py, &own, light, eta, globals)?;
        let (mut out, n) = Self::run(slf, Call::Reflection, args)?;
        matrix(py, out.swap_remove(0), n, 3)
    }

    /// Samples a direction at every point: `u1` (`(N,)`) picks the lobe,
    /// `u2` (`(N, 2)`) the direction in it, as Mitsuba's `sample1` and
    /// `sample2`. Returns `BsdfSample(wi, weight, pdf, delta)`: `(N, 3)`
    /// directions, `(N, 3)` RGB weights (reflection × cosine / pdf),
    /// `(N,)` pdfs and `(N,)` bools (a delta lobe). Other arguments as
    /// `reflection`.
    #[pyo3(signature = (wo, u1, u2, *, eta=None, **globals))]
    fn sample<'py>(
        slf: &Bound<'py, Self>,
        py: Python<'py>,
        wo: &Bound<'py, PyAny>,
        u1: &Bound<'py, PyAny>,
        u2: &Bound<'py, PyAny>,
        eta: Option<&Bound<'py, PyAny>>,
        globals: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let own = [("wo", Kind::Floats(3), wo), ("u1", Kind::Floats(1), u1), ("u2", Kind::Floats(2), u2)];
        let args = Self::hold_args(py, &own, None, eta, globals)?;
        let (out, n) = Self::run(slf, Call::Sample, args)?;
        let [wi, weight, pdf, delta]: [Vec<f32>; 4] =
            out.try_into().map_err(|_| pyo3::exceptions::PyRuntimeError::new_err("a sample has four parts"))?;
        let delta: Vec<bool> = delta.iter().map(|&d| d != 0.0).collect();
        let fields = (
            matrix(py, wi, n, 3)?,
            matrix(py, weight, n, 3)?,
            PyArray1::from_vec(py, pdf),
            PyArray1::from_vec(py, delta),
        );
        sample_type(py)?.call1(fields)
    }

    /// The solid-angle density of `sample` choosing `wi` at every point:
    /// `(N,)` float32. Arguments as `reflection`.
    #[pyo3(signature = (wi, wo, *, eta=None, **globals))]
    fn pdf<'py>(
        slf: &Bound<'py, Self>,
        py: Python<'py>,
        wi: &Bound<'py, PyAny>,
        wo: &Bound<'py, PyAny>,
        eta: Option<&Bound<'py, PyAny>>,
        globals: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let own = [("wi", Kind::Floats(3), wi), ("wo", Kind::Floats(3), wo)];
        let args = Self::hold_args(py, &own, None, eta, globals)?;
        let (mut out, _) = Self::run(slf, Call::Pdf, args)?;
        Ok(PyArray1::from_vec(py, out.swap_remove(0)))
    }

    /// `reflection` of white light and `pdf` in one call, as a renderer's
    /// light sample needs them (one pass over the texture tree): `(value,
    /// pdf)`, `(N, 3)` float32 linear RGB and `(N,)`; where `wi` crosses the
    /// surface, `value` is the refraction instead. Arguments as `pdf`.
    #[pyo3(signature = (wi, wo, *, eta=None, **globals))]
    fn eval_pdf<'py>(
        slf: &Bound<'py, Self>,
        py: Python<'py>,
        wi: &Bound<'py, PyAny>,
        wo: &Bound<'py, PyAny>,
        eta: Option<&Bound<'py, PyAny>>,
        globals: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<ValueAndPdf<'py>> {
        let own = [("wi", Kind::Floats(3), wi), ("wo", Kind::Floats(3), wo)];
        let args = Self::hold_args(py, &own, None, eta, globals)?;
        let (out, n) = Self::run(slf, Call::EvalPdf, args)?;
        let [value, pdf]: [Vec<f32>; 2] =
            out.try_into().map_err(|_| pyo3::exceptions::PyRuntimeError::new_err("eval_pdf has two parts"))?;
        Ok((matrix(py, value, n, 3)?, PyArray1::from_vec(py, pdf)))
    }

    /// Light emitted toward `wo` at every point: `(N, 3)` float32 linear
    /// RGB. Arguments as `reflection`.
    #[pyo3(signature = (wo, *, eta=None, **globals))]
    fn emission<'py>(
        slf: &Bound<'py, Self>,
        py: Python<'py>,
        wo: &Bound<'py, PyAny>,
        eta: Option<&Bound<'py, PyAny>>,
        globals: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let own = [("wo", Kind::Floats(3), wo)];
        let args = Self::hold_args(py, &own, None, eta, globals)?;
        let (mut out, n) = Self::run(slf, Call::Emission, args)?;
        matrix(py, out.swap_remove(0), n, 3)
    }

    /// The fraction of light from `wo` reflected at every point (the
    /// directional albedo: what a `layer` above would not let through):
    /// `(N, 3)` float32 linear RGB. Arguments as `emission`.
    #[pyo3(signature = (wo, *, eta=None, **globals))]
    fn albedo<'py>(
        slf: &Bound<'py, Self>,
        py: Python<'py>,
        wo: &Bound<'py, PyAny>,
        eta: Option<&Bound<'py, PyAny>>,
        globals: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let own = [("wo", Kind::Floats(3), wo)];
        let args = Self::hold_args(py, &own, None, eta, globals)?;
        let (mut out, n) = Self::run(slf, Call::Albedo, args)?;
        matrix(py, out.swap_remove(0), n, 3)
    }

    fn __repr__(&self) -> String {
        format!("<tsl.Material {}>", self.name)
    }
}

/// An instance of a shader (a material template) with parameter values
/// set at run time: `shader.instance(alpha=0.3)`, then `set(alpha=0.5)`.
/// Setting values binds them to the compiled shader (microseconds; no
/// compiling); the instance shades as its `Material`.
#[pyclass(module = "tsl", extends = Material)]
pub struct Instance {
    instance: tsl::Instance,
}

impl Instance {
    /// A new instance of `shader` with `values` set, bound.
    pub fn create(py: Python<'_>, shader: &tsl::Shader, values: Option<&Bound<'_, PyDict>>) -> PyResult<Py<Instance>> {
        let mut instance = shader.instance();
        apply(&mut instance, values)?;
        let material = instance.bind().map_err(parameter_error)?;
        let base = Material { program: shader.program().clone(), material, name: shader.name().to_string() };
        Py::new(py, PyClassInitializer::from(base).add_subclass(Instance { instance }))
    }

    pub fn tsl_instance(&self) -> &tsl::Instance {
        &self.instance
    }
}

/// Sets every keyword value on `instance`, all or none.
fn apply(instance: &mut tsl::Instance, values: Option<&Bound<'_, PyDict>>) -> PyResult<()> {
    let Some(values) = values else { return Ok(()) };
    let mut next = instance.clone();
    for (key, value) in values.iter() {
        let name: String = key.extract()?;
        let value = values::from_python(&name, &value)?;
        next.set(&name, value).map_err(parameter_error)?;
    }
    *instance = next;
    Ok(())
}

#[pymethods]
impl Instance {
    /// Sets parameters by name (`alpha=0.5, eta=(0.2, 0.9, 1.1)`),
    /// checked now (`tsl.ParameterError` for an unknown name, a wrong type,
    /// a string outside the options; then nothing changes), and binds them:
    /// no recompiling. Returns the instance.
    #[pyo3(signature = (**values))]
    fn set<'py>(mut slf: PyRefMut<'py, Self>, values: Option<&Bound<'py, PyDict>>) -> PyResult<PyRefMut<'py, Self>> {
        let mut instance = slf.instance.clone();
        apply(&mut instance, values)?;
        let material = instance.bind().map_err(parameter_error)?;
        slf.instance = instance;
        slf.as_super().material = material;
        Ok(slf)
    }

    /// The values set so far, by name (parameters at their defaults are
    /// absent).
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let dict = PyDict::new(py);
        for (p, v) in self.instance.shader().params().iter().zip(self.instance.values()) {
            if let Some(v) = v {
                dict.set_item(&p.name, values::to_python(py, v)?)?;
            }
        }
        Ok(dict)
    }

    /// The instance as the TSL call it stands for: `rough_conductor(alpha: 0.5)`.
    #[getter]
    fn source(&self) -> String {
        self.instance.source()
    }

    /// The instance compiled with its values folded in as constants (a new
    /// compile each call): a `Material` that agrees with the bound one
    /// within float rounding.
    fn specialise(&self, py: Python<'_>) -> PyResult<Material> {
        let material = py.detach(|| self.instance.specialise()).map_err(parameter_error)?;
        let shader = self.instance.shader();
        Ok(Material { program: shader.program().clone(), material, name: self.instance.source() })
    }

    fn __repr__(&self) -> String {
        format!("<tsl.Instance {}>", self.instance.source())
    }
}
