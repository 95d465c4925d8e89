//! `tsl.Program` (what `tsl.compile` returns), `tsl.Shader` and its
//! `tsl.Parameter`s, and `tsl.Generator`: a program's generators called
//! over arrays of points.

use crate::arrays::{Held, Input, Kind, Words, hold, points};
use crate::colors;
use crate::errors::compile_error;
use crate::points::{Globals, Tangents, hold_globals, run_chunks};
use crate::shading::{Instance, Material};
use crate::values;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use tsl::check::{SymbolKind, Ty};
use tsl::{Backend, ColorModel, Column, Layout};

/// A compiled TSL program: its materials, shaders (material templates)
/// and generators. Each is compiled on first use.
#[pyclass(module = "tsl", frozen)]
pub struct Program {
    pub(crate) program: tsl::Program,
}

#[pymethods]
impl Program {
    /// The names of the program's own materials and material templates
    /// (not the prelude's), in definition order.
    #[getter]
    fn materials(&self) -> Vec<String> {
        let checked = self.program.checked();
        let mut own: Vec<(&String, &tsl::check::Symbol)> = checked
            .symbols
            .iter()
            .filter(|(_, s)| matches!(s.kind, SymbolKind::Material | SymbolKind::MaterialTree))
            .filter(|(_, s)| !checked.loaded.modules[s.module].is_prelude)
            .collect();
        own.sort_by_key(|(_, s)| (s.module, s.item));
        own.into_iter().map(|(n, _)| n.clone()).collect()
    }

    /// The color model: `"rgb"`, `"hero"`, `"spectral16"`, ...
    #[getter]
    fn color_model(&self) -> String {
        color_model_name(self.program.color_model())
    }

    /// How many functions the program has compiled so far: unchanged by
    /// binding an instance's values (`Instance.set`).
    #[getter]
    fn compiled_functions(&self) -> usize {
        self.program.compiled_functions()
    }

    /// The material template `name` (a prelude one such as
    /// `rough_conductor`, or the program's own); `tsl.CompileError` with a
    /// did-you-mean for a name that is not one.
    fn shader(&self, name: &str) -> PyResult<Shader> {
        Ok(Shader { shader: self.program.shader(name).map_err(compile_error)? })
    }

    /// Every material template the program can call, the prelude's
    /// included.
    #[getter]
    fn shaders(&self) -> Vec<Shader> {
        self.program.shaders().into_iter().map(|shader| Shader { shader }).collect()
    }

    /// The material `name` (a material defined in the program, or a
    /// template whose parameters all have defaults), compiled on first use.
    fn material(&self, py: Python<'_>, name: &str) -> PyResult<Material> {
        let material = py.detach(|| self.program.material(name)).map_err(compile_error)?;
        Ok(Material { program: self.program.clone(), material, name: name.to_string() })
    }

    /// The generator (a function of plain values) `name`, callable over
    /// arrays of points.
    fn generator(&self, py: Python<'_>, name: &str) -> PyResult<Generator> {
        let found = py.detach(|| self.program.try_function(name)).map_err(compile_error)?;
        let Some(function) = found.filter(|f| !f.name().contains('.')) else {
            return Err(compile_error_text(format!("the program has no generator named `{name}`")));
        };
        for (param, ty) in function.params() {
            if param_kind(ty, self.program.color_model()).is_none() {
                return Err(PyTypeError::new_err(format!(
                    "`{name}` takes `{param}` as a {ty}, which Python cannot pass"
                )));
            }
        }
        if !matches!(
            function.result_type(),
            Ty::Float | Ty::Int | Ty::Bool | Ty::Color | Ty::Vector | Ty::Point | Ty::Normal | Ty::Vec2
        ) {
            return Err(PyTypeError::new_err(format!(
                "`{name}` returns a {}, which Python cannot take (float, int, bool, color, vector, point, normal, vec2)",
                function.result_type()
            )));
        }
        Ok(Generator { program: self.program.clone(), function })
    }

    fn __repr__(&self) -> String {
        format!("<tsl.Program {} materials, color model {}>", self.materials().len(), self.color_model())
    }
}

/// A `CompileError` with a message only.
fn compile_error_text(message: String) -> PyErr {
    crate::errors::CompileError::new_err(message)
}

/// How the CLI's `--color` names `model`.
pub fn color_model_name(model: ColorModel) -> String {
    match model {
        ColorModel::Rgb => "rgb".into(),
        ColorModel::Hero => "hero".into(),
        ColorModel::Spectral { samples } => format!("spectral{samples}"),
        ColorModel::Smits { samples } => format!("smits{samples}"),
    }
}

/// A material template: its name, documentation and parameters.
#[pyclass(module = "tsl", frozen)]
pub struct Shader {
    shader: tsl::Shader,
}

#[pymethods]
impl Shader {
    #[getter]
    fn name(&self) -> &str {
        self.shader.name()
    }

    /// The `///` comment above the template.
    #[getter]
    fn doc(&self) -> Option<&str> {
        self.shader.doc()
    }

    /// The parameters, in declaration order.
    #[getter]
    fn parameters(&self, py: Python<'_>) -> PyResult<Vec<Parameter>> {
        self.shader.params().iter().map(|p| Parameter::new(py, p)).collect()
    }

    /// An instance with `values` set by name (`alpha=0.3, eta=(0.2, 0.9,
    /// 1.1)`), bound: it shades at once, and `set` changes values without
    /// compiling.
    #[pyo3(signature = (**values))]
    fn instance(&self, py: Python<'_>, values: Option<&Bound<'_, PyDict>>) -> PyResult<Py<Instance>> {
        Instance::create(py, &self.shader, values)
    }

    fn __repr__(&self) -> String {
        let params: Vec<String> =
            self.shader.params().iter().map(|p| format!("{} {}", p.type_text(), p.name)).collect();
        format!("<tsl.Shader {}({})>", self.shader.name(), params.join(", "))
    }
}

/// One parameter of a shader.
#[pyclass(module = "tsl", frozen, get_all)]
pub struct Parameter {
    pub name: String,
    /// The type as TSL writes it: `float`, `color`, `string`, `color[4]`.
    pub r#type: String,
    /// The default evaluated (a float, int, bool, str, or a tuple; a
    /// spectral color as RGB); `None` when required or not one constant.
    pub default: Py<PyAny>,
    /// The default as written (`gray(0.5)`); `None` when required.
    pub default_source: Option<String>,
    /// The `///` comment above the declaration.
    pub doc: Option<String>,
    /// The values a `string` parameter accepts (empty: any).
    pub options: Vec<String>,
    /// Whether an instance must give it a value.
    pub required: bool,
}

impl Parameter {
    fn new(py: Python<'_>, p: &tsl::ParamInfo) -> PyResult<Parameter> {
        let default = match &p.default {
            Some(v) => values::to_python(py, v)?.unbind(),
            None => py.None(),
        };
        Ok(Parameter {
            name: p.name.clone(),
            r#type: p.type_text(),
            default,
            default_source: p.default_source.clone(),
            doc: p.doc.clone(),
            options: p.options.clone(),
            required: p.required(),
        })
    }
}

#[pymethods]
impl Parameter {
    fn __repr__(&self, py: Python<'_>) -> String {
        let default = self.default.bind(py).repr().map(|r| r.to_string()).unwrap_or_default();
        format!("<tsl.Parameter {} {} = {default}>", self.r#type, self.name)
    }
}

/// How many words a generator's parameter of type `ty` takes from Python,
/// and as what; `None` for a type Python cannot pass.
fn param_kind(ty: &Ty, model: ColorModel) -> Option<(Kind, usize)> {
    Some(match ty {
        Ty::Float => (Kind::Floats(1), 1),
        Ty::Int | Ty::Bool => (Kind::Int, 1),
        Ty::Vector | Ty::Point | Ty::Normal => (Kind::Floats(3), 3),
        Ty::Vec2 => (Kind::Floats(2), 2),
        Ty::Color => (Kind::Floats(3), model.lanes()),
        _ => return None,
    })
}

/// A generator of a program (a function of plain values: a texture, a
/// noise), called over arrays of points: `gen(scale=8.0, P=points)`.
#[pyclass(module = "tsl", frozen)]
pub struct Generator {
    program: tsl::Program,
    function: tsl::Function,
}

#[pymethods]
impl Generator {
    #[getter]
    fn name(&self) -> &str {
        self.function.name()
    }

    /// The parameters as `(name, type)` pairs.
    #[getter]
    fn parameters(&self) -> Vec<(String, String)> {
        self.function.params().iter().map(|(n, t)| (n.clone(), t.to_string())).collect()
    }

    /// The result type (`float`, `color`, ...).
    #[getter]
    fn result_type(&self) -> String {
        self.function.result_type().to_string()
    }

    /// Calls the generator at every point. Arguments by position or by
    /// parameter name: `(N,)` or a scalar for numbers (ints and bools
    /// too), `(N, 3)` or `(3,)` for vectors and colors (RGB), `(N, 2)` or
    /// `(2,)` for vec2s; other keywords are shading globals, as for
    /// `Material.reflection`. Returns `(N,)` for a float (float32), int
    /// (int32) or bool, `(N, 3)` float32 for vectors and colors (linear
    /// RGB; a spectral program's colors converted point by point), `(N,
    /// 2)` for a vec2.
    #[pyo3(signature = (*args, **kwargs))]
    fn __call__<'py>(
        &self,
        py: Python<'py>,
        args: &Bound<'py, PyTuple>,
        kwargs: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let params = self.function.params();
        let model = self.program.color_model();
        if args.len() > params.len() {
            return Err(PyTypeError::new_err(format!(
                "`{}` takes {} arguments, not {}",
                self.function.name(),
                params.len(),
                args.len()
            )));
        }
        let mut held: Vec<Held> = Vec::new();
        for (k, (name, ty)) in params.iter().enumerate() {
            let by_name = kwargs.map(|kw| kw.get_item(name)).transpose()?.flatten();
            let value = match (args.get_item(k).ok(), by_name) {
                (Some(_), Some(_)) => {
                    return Err(PyTypeError::new_err(format!("`{name}` given by position and by name")));
                }
                (Some(v), None) | (None, Some(v)) => v,
                (None, None) => {
                    return Err(PyTypeError::new_err(format!(
                        "`{}` needs its argument `{name}`",
                        self.function.name()
                    )));
                }
            };
            let (kind, _) = param_kind(ty, model).ok_or_else(|| PyTypeError::new_err(format!("`{name}` is a {ty}")))?;
            // A bool is passed as an int word, 0 or 1.
            held.push(hold(py, name, kind, &value)?);
        }
        let names: Vec<&str> = params.iter().map(|(n, _)| n.as_str()).collect();
        let globals = hold_globals(py, kwargs, &names)?;
        let own: Vec<Words> = held.iter().map(Held::view).collect::<PyResult<_>>()?;
        let given: Vec<Words> = globals.iter().map(Held::view).collect::<PyResult<_>>()?;
        let all: Vec<&Words> = own.iter().chain(&given).collect();
        let n = points(&all)?;
        let (function, program) = (&self.function, &self.program);
        let lanes = model.lanes();
        let words = function.result_types().len();
        let result = py.detach(|| {
            let tangents = Tangents::new(&given, n);
            let globals = Globals::new(&given, &tangents);
            // Color arguments as the model's lanes.
            let upsampled: Vec<Vec<f32>> = params
                .iter()
                .zip(&own)
                .map(|((_, ty), w)| match ty {
                    Ty::Color => colors::upsample(program, &w.inputs, w.points),
                    _ => Vec::new(),
                })
                .collect();
            let inputs: Vec<Input> = params
                .iter()
                .zip(&own)
                .zip(&upsampled)
                .flat_map(|(((_, ty), w), up)| match ty {
                    Ty::Color => colors::lanes(model, &w.inputs, w.points, up),
                    _ => w.inputs.clone(),
                })
                .collect();
            run_chunks(n, 1, |range| {
                let batch = globals.batch(range)?;
                let columns: Vec<Column> = inputs.iter().map(|i| i.column(range)).collect();
                let mut out = vec![0u32; range.len() * words];
                function.call_batch(Backend::Jit, &batch, &columns, &mut out, Layout::PointMajor)?;
                Ok(vec![out.into_iter().map(f32::from_bits).collect()])
            })
        });
        let values = result.map_err(compile_error)?.swap_remove(0);
        let array = |width: usize, values: Vec<f32>| -> PyResult<Bound<'py, PyAny>> {
            let a = Array2::from_shape_vec((n, width), values).map_err(|e| PyValueError::new_err(e.to_string()))?;
            Ok(a.into_pyarray(py).into_any())
        };
        match function.result_type() {
            Ty::Float => Ok(PyArray1::from_vec(py, values).into_any()),
            Ty::Int => Ok(PyArray1::from_vec(py, values.iter().map(|x| x.to_bits() as i32).collect()).into_any()),
            Ty::Bool => Ok(PyArray1::from_vec(py, values.iter().map(|x| x.to_bits() != 0).collect()).into_any()),
            Ty::Color => array(3, colors::to_rgb(model, lanes, &values)),
            Ty::Vec2 => array(2, values),
            _ => array(3, values),
        }
    }

    fn __repr__(&self) -> String {
        let params: Vec<String> = self.function.params().iter().map(|(n, t)| format!("{t} {n}")).collect();
        format!("<tsl.Generator {} {}({})>", self.function.result_type(), self.function.name(), params.join(", "))
    }
}
