//! The types of a shader's parameters and the typed values a host gives
//! them (or reads back as defaults), with the TSL text each value is
//! written as when an instance is specialised.

use super::Color;
use super::shader::Instance;
use crate::check::Ty;
use crate::color::ColorModel;
use std::fmt;

/// The type of a shader parameter: TSL's parameter types, as an enum a
/// host can match on (arrays are [`ParamInfo::array_len`](super::ParamInfo::array_len)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ParamType {
    Float,
    Int,
    Bool,
    Color,
    Vector,
    Point,
    Normal,
    Vec2,
    Matrix,
    /// A sampled direction (`bsdf_sample`): hosts cannot set one.
    BsdfSample,
    String,
    Material,
}

impl ParamType {
    /// The TSL keyword: `float`, `color`, ...
    pub fn keyword(self) -> &'static str {
        match self {
            ParamType::Float => "float",
            ParamType::Int => "int",
            ParamType::Bool => "bool",
            ParamType::Color => "color",
            ParamType::Vector => "vector",
            ParamType::Point => "point",
            ParamType::Normal => "normal",
            ParamType::Vec2 => "vec2",
            ParamType::Matrix => "matrix",
            ParamType::BsdfSample => "bsdf_sample",
            ParamType::String => "string",
            ParamType::Material => "material",
        }
    }

    /// The parameter type of a checked type and its array length; `None`
    /// for types a parameter cannot have.
    pub(super) fn of(ty: &Ty) -> Option<(ParamType, Option<u32>)> {
        let base = |t: &Ty| {
            Some(match t {
                Ty::Float => ParamType::Float,
                Ty::Int => ParamType::Int,
                Ty::Bool => ParamType::Bool,
                Ty::Color => ParamType::Color,
                Ty::Vector => ParamType::Vector,
                Ty::Point => ParamType::Point,
                Ty::Normal => ParamType::Normal,
                Ty::Vec2 => ParamType::Vec2,
                Ty::Matrix => ParamType::Matrix,
                Ty::BsdfSample => ParamType::BsdfSample,
                Ty::String => ParamType::String,
                Ty::Material => ParamType::Material,
                Ty::Void | Ty::Array(..) | Ty::Error => return None,
            })
        };
        match ty {
            Ty::Array(element, n) => Some((base(element)?, Some(*n))),
            t => Some((base(t)?, None)),
        }
    }
}

impl fmt::Display for ParamType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.keyword())
    }
}

/// A typed parameter value: what a host sets on an [`Instance`] and what
/// a parameter's evaluated default is. Build one with `into()` from `f32`,
/// `i32`, `bool`, `[f32; 3]` (a vector, point or normal, or an RGB color),
/// `[f32; 2]`, [`Color`], `&str` or an [`Instance`] (for `material`
/// parameters).
///
/// A `color` parameter takes RGB (`[f32; 3]`, converted into the program's
/// model as `rgb(...)` in source is) or a [`Color`] of the program's own
/// model, whose lanes are used as they are, by
/// [`Instance::specialise`](super::Instance::specialise) and
/// [`Instance::bind`](super::Instance::bind) alike (a spectral host passes
/// its spectra; [`Program::rgb`](super::Program::rgb) makes the same lanes
/// as the `rgb(...)` literal). A `Color` of another model is an error.
///
/// ```
/// use tsl::{ColorModel, Compiler, ShadingGlobals};
/// let model = ColorModel::Spectral { samples: 8 };
/// let p = Compiler::new().color_model(model).source("m.tsl", "material m = lambert;").compile()?;
/// let ramp: Vec<f32> = (0..8).map(|i| 0.1 * i as f32).collect();
/// let kd = tsl::Color::from_lanes(model, &ramp);
/// let mut lambert = p.shader("lambert")?.instance();
/// lambert.set("kd", kd)?;
/// let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ng: [0.0, 0.0, 1.0], ..Default::default() };
/// let (flat, up) = (tsl::Color::from_lanes(model, &[1.0; 8]), [0.0, 0.0, 1.0]);
/// for m in [lambert.specialise()?, lambert.bind()?] {
///     let f = m.reflection(&g, up, &flat, up);
///     assert!((f.lanes()[7] / f.lanes()[1] - 7.0).abs() < 1e-4, "the lanes given: {f:?}");
/// }
/// // A color of another model is refused.
/// assert!(lambert.set("kd", tsl::Color::black(ColorModel::Rgb)).is_err());
/// # Ok::<(), tsl::Error>(())
/// ```
// A color holds MAX_SAMPLES lanes inline; values are few (one per
// parameter) and a boxed color would make every host unbox it.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
pub enum ParamValue {
    Float(f32),
    Int(i32),
    Bool(bool),
    /// A vector, point or normal; for a `color` parameter, linear sRGB.
    Triple([f32; 3]),
    Vec2([f32; 2]),
    /// A color in the program's color model.
    Color(Color),
    /// The twelve words of a TSL matrix (an affine transform), in the
    /// order compiled code stores them.
    Matrix([f32; 12]),
    String(String),
    Material(Box<Instance>),
}

impl ParamValue {
    /// What the value is, for messages: "a float", "a color".
    pub fn describe(&self) -> &'static str {
        match self {
            ParamValue::Float(_) => "a float",
            ParamValue::Int(_) => "an int",
            ParamValue::Bool(_) => "a bool",
            ParamValue::Triple(_) => "a triple ([f32; 3])",
            ParamValue::Vec2(_) => "a vec2 ([f32; 2])",
            ParamValue::Color(_) => "a color",
            ParamValue::Matrix(_) => "a matrix",
            ParamValue::String(_) => "a string",
            ParamValue::Material(_) => "a material instance",
        }
    }

    /// Decodes the result words of a parameter's default, lowered as a
    /// value of type `ty` (f32 bits, i32, bool as 0/1, color lanes).
    pub(super) fn from_words(ty: ParamType, words: &[u32], model: ColorModel) -> Option<ParamValue> {
        let floats: Vec<f32> = words.iter().map(|w| f32::from_bits(*w)).collect();
        let want = match ty {
            ParamType::Float | ParamType::Int | ParamType::Bool => 1,
            ParamType::Vector | ParamType::Point | ParamType::Normal => 3,
            ParamType::Vec2 => 2,
            ParamType::Matrix => 12,
            ParamType::Color => model.lanes(),
            ParamType::BsdfSample | ParamType::String | ParamType::Material => return None,
        };
        if words.len() != want {
            return None;
        }
        Some(match ty {
            ParamType::Float => ParamValue::Float(floats[0]),
            ParamType::Int => ParamValue::Int(words[0] as i32),
            ParamType::Bool => ParamValue::Bool(words[0] != 0),
            ParamType::Vector | ParamType::Point | ParamType::Normal => {
                ParamValue::Triple([floats[0], floats[1], floats[2]])
            }
            ParamType::Vec2 => ParamValue::Vec2([floats[0], floats[1]]),
            ParamType::Matrix => ParamValue::Matrix(floats.try_into().ok()?),
            ParamType::Color => ParamValue::Color(Color::from_lanes(model, &floats)),
            ParamType::BsdfSample | ParamType::String | ParamType::Material => return None,
        })
    }

    /// The value as TSL source text for a parameter of type `ty` (which
    /// the value was checked against), exactly: a float is written with
    /// the digits of its f64 widening, which the lexer reads back to the
    /// same f64 and lowering rounds to the same f32. `None` for a value
    /// TSL cannot write (a spectral color's lanes; see [`Instance::set`]).
    pub(super) fn source(&self, ty: ParamType) -> Option<String> {
        Some(match self {
            ParamValue::Color(c) if c.model() != ColorModel::Rgb => return None,
            ParamValue::Matrix(_) => return None,
            _ => self.call_text(ty),
        })
    }

    /// The value's text in an instance's call: [`ParamValue::source`], or
    /// for a spectral color, which TSL cannot write, `rgb(...)` of its
    /// [`Color::to_rgb`]: a stand-in that the instance's code replaces by
    /// the lanes themselves ([`Instance::specialise`], [`Instance::bind`]).
    pub(super) fn call_text(&self, ty: ParamType) -> String {
        let float = |x: f32| format!("{:?}", f64::from(x));
        let floats = |xs: &[f32]| xs.iter().map(|x| float(*x)).collect::<Vec<_>>().join(", ");
        match self {
            ParamValue::Float(x) => float(*x),
            // The lexer reads digits as a positive i32, and i32::MIN has none.
            ParamValue::Int(i32::MIN) => "(-2147483647 - 1)".into(),
            ParamValue::Int(i) => i.to_string(),
            ParamValue::Bool(b) => b.to_string(),
            ParamValue::Triple(t) if ty == ParamType::Color => format!("rgb({})", floats(t)),
            ParamValue::Triple(t) => format!("{}({})", ty.keyword(), floats(t)),
            ParamValue::Vec2(v) => format!("vec2({})", floats(v)),
            ParamValue::Color(c) if c.model() == ColorModel::Rgb => format!("rgb({})", floats(c.lanes())),
            ParamValue::Color(c) => format!("rgb({})", floats(&c.to_rgb())),
            // Matrices are set in source only (`Instance::set` refuses them).
            ParamValue::Matrix(_) => String::new(),
            ParamValue::String(s) => format!("\"{s}\""),
            ParamValue::Material(instance) => instance.source(),
        }
    }
}

/// Shortest text that reads back as the same value: `0.1`, `rgb(0.5, 0.02, 0.02)`.
impl fmt::Display for ParamValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let list = |xs: &[f32]| xs.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", ");
        match self {
            ParamValue::Float(x) => write!(f, "{x}"),
            ParamValue::Int(i) => write!(f, "{i}"),
            ParamValue::Bool(b) => write!(f, "{b}"),
            ParamValue::Triple(t) => write!(f, "({})", list(t)),
            ParamValue::Vec2(v) => write!(f, "({})", list(v)),
            ParamValue::Color(c) if c.model() == ColorModel::Rgb => write!(f, "rgb({})", list(c.lanes())),
            ParamValue::Color(c) => write!(f, "[{}]", list(c.lanes())),
            ParamValue::Matrix(m) => write!(f, "[{}]", list(m)),
            ParamValue::String(s) => write!(f, "\"{s}\""),
            ParamValue::Material(instance) => f.write_str(&instance.source()),
        }
    }
}

impl From<f32> for ParamValue {
    fn from(x: f32) -> Self {
        ParamValue::Float(x)
    }
}

impl From<i32> for ParamValue {
    fn from(i: i32) -> Self {
        ParamValue::Int(i)
    }
}

impl From<bool> for ParamValue {
    fn from(b: bool) -> Self {
        ParamValue::Bool(b)
    }
}

impl From<[f32; 3]> for ParamValue {
    fn from(t: [f32; 3]) -> Self {
        ParamValue::Triple(t)
    }
}

impl From<[f32; 2]> for ParamValue {
    fn from(v: [f32; 2]) -> Self {
        ParamValue::Vec2(v)
    }
}

impl From<Color> for ParamValue {
    fn from(c: Color) -> Self {
        ParamValue::Color(c)
    }
}

impl From<&str> for ParamValue {
    fn from(s: &str) -> Self {
        ParamValue::String(s.to_string())
    }
}

impl From<String> for ParamValue {
    fn from(s: String) -> Self {
        ParamValue::String(s)
    }
}

impl From<Instance> for ParamValue {
    fn from(instance: Instance) -> Self {
        ParamValue::Material(Box::new(instance))
    }
}

impl From<&Instance> for ParamValue {
    fn from(instance: &Instance) -> Self {
        ParamValue::Material(Box::new(instance.clone()))
    }
}
