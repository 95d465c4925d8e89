//! Builtin functions: their parameter names and typing rules.
//!
//! Most builtins are generic over a family of types (`abs` works on float,
//! vec2 and triples; `mix` on those, colors and materials), so each has a
//! typing rule rather than one signature.

use super::ty::Ty;
use crate::syntax::ast::Expr;

/// A builtin's parameters; a trailing `?` marks an optional one.
pub struct Builtin {
    pub name: &'static str,
    pub params: &'static [&'static str],
    /// Shown in "expected" messages.
    pub synopsis: &'static str,
}

impl Builtin {
    /// The argument bound to parameter `param`, with `bound` in the order
    /// of [`Builtin::params`]: call sites name parameters, not positions.
    pub fn arg<'e>(&self, bound: &[Option<&'e Expr>], param: &str) -> Option<&'e Expr> {
        let k = self.params.iter().position(|p| p.trim_end_matches('?') == param)?;
        bound.get(k).copied().flatten()
    }
}

const fn b(name: &'static str, params: &'static [&'static str], synopsis: &'static str) -> Builtin {
    Builtin { name, params, synopsis }
}

/// Elementwise unary math over float, vec2 and triples.
const UNARY_MATH: &[&str] = &[
    "abs", "sign", "floor", "ceil", "fract", "round", "sqrt", "exp", "log", "sin", "cos", "tan", "asin", "acos",
    "atan", "radians", "degrees",
];

/// The unary math that also applies to a color, lane by lane (each
/// wavelength sample, or each RGB channel): a lane-wise function never
/// names a lane, so the representation stays hidden. `min`, `max` and
/// `clamp` of colors are lane-wise too.
const COLOR_MATH: &[&str] = &["abs", "sqrt", "exp", "log"];

pub const BUILTINS: &[Builtin] = &[
    b("abs", &["x"], "abs(T x) -> T, T a float, vec2, triple or color"),
    b("sign", &["x"], "sign(T x) -> T"),
    b("floor", &["x"], "floor(T x) -> T"),
    b("ceil", &["x"], "ceil(T x) -> T"),
    b("fract", &["x"], "fract(T x) -> T"),
    b("round", &["x"], "round(T x) -> T"),
    b("sqrt", &["x"], "sqrt(T x) -> T, T a float, vec2, triple or color"),
    b("exp", &["x"], "exp(T x) -> T, T a float, vec2, triple or color"),
    b("log", &["x"], "log(T x) -> T, T a float, vec2, triple or color"),
    b("sin", &["x"], "sin(T x) -> T"),
    b("cos", &["x"], "cos(T x) -> T"),
    b("tan", &["x"], "tan(T x) -> T"),
    b("asin", &["x"], "asin(T x) -> T"),
    b("acos", &["x"], "acos(T x) -> T"),
    b("atan", &["x"], "atan(T x) -> T"),
    b("radians", &["degrees"], "radians(T degrees) -> T"),
    b("degrees", &["radians"], "degrees(T radians) -> T"),
    b("atan2", &["y", "x"], "atan2(float y, float x) -> float"),
    b("pow", &["x", "e"], "pow(float x, float e) -> float | pow(color c, float e) -> color"),
    b("min", &["a", "b"], "min(T a, T|float b) -> T | min(color a, color b) -> color"),
    b("max", &["a", "b"], "max(T a, T|float b) -> T | max(color a, color b) -> color"),
    b("mod", &["a", "b"], "mod(T a, T|float b) -> T"),
    b(
        "clamp",
        &["x", "lo", "hi"],
        "clamp(T x, T|float lo, T|float hi) -> T | clamp(color x, color lo, color hi) -> color",
    ),
    b("step", &["edge", "x"], "step(T|float edge, T x) -> T"),
    b("smoothstep", &["e0", "e1", "x"], "smoothstep(T|float e0, T|float e1, T x) -> T"),
    b("dot", &["a", "b"], "dot(vector a, vector b) -> float"),
    b("cross", &["a", "b"], "cross(vector a, vector b) -> vector"),
    b("length", &["v"], "length(vector v) -> float"),
    b("distance", &["a", "b"], "distance(point a, point b) -> float"),
    b("normalize", &["v"], "normalize(vector v) -> vector"),
    b("reflect", &["i", "n"], "reflect(vector i, normal n) -> vector"),
    b("refract", &["i", "n", "eta"], "refract(vector i, normal n, float eta) -> vector"),
    b("faceforward", &["n", "i"], "faceforward(normal n, vector i) -> normal"),
    b("noise", &["p"], "noise(float|vec2|point p) -> float in [-1, 1]"),
    b("pnoise", &["p", "period"], "pnoise(T p, T period) -> float in [-1, 1]"),
    b("cellnoise", &["p"], "cellnoise(float|vec2|point p) -> float in [0, 1)"),
    b("rgb", &["r", "g", "b"], "rgb(float r, float g, float b) -> color"),
    b("hsv", &["h", "s", "v"], "hsv(float h, float s, float v) -> color"),
    b("xyz", &["x", "y", "z"], "xyz(float x, float y, float z) -> color"),
    b("gray", &["value"], "gray(float value) -> color"),
    b("black", &[], "black() -> color"),
    b("spectrum", &["samples"], "spectrum(vec2[n] samples) -> color, samples as (nm, value)"),
    b("brightness", &["c"], "brightness(color c) -> float"),
    b("to_rgb", &["c"], "to_rgb(color c) -> vector"),
    b("to_xyz", &["c"], "to_xyz(color c) -> vector"),
    b("delta_sample", &["wi", "weight"], "delta_sample(vector wi, color weight) -> bsdf_sample"),
    b("no_sample", &[], "no_sample() -> bsdf_sample"),
    b("translate", &["offset"], "translate(vector offset) -> matrix"),
    b("rotate", &["degrees", "axis"], "rotate(float degrees, vector axis) -> matrix"),
    b("inverse", &["m"], "inverse(matrix m) -> matrix"),
    b("transform_point", &["m", "p"], "transform_point(matrix m, point p) -> point"),
    b("transform_vector", &["m", "v"], "transform_vector(matrix m, vector v) -> vector"),
    b("transform_normal", &["m", "n"], "transform_normal(matrix m, normal n) -> normal"),
    b(
        "texture",
        &["file", "st?", "filter?", "wrap?", "swrap?", "twrap?", "colorspace?", "dx?", "dy?"],
        "texture(string file, vec2 st = (u, v), string filter, string wrap, ..., vec2 dx, vec2 dy) -> color",
    ),
    b(
        "texture_float",
        &["file", "st?", "channel?", "filter?", "wrap?", "swrap?", "twrap?", "dx?", "dy?"],
        "texture_float(string file, vec2 st = (u, v), int channel = 0, string filter, ...) -> float",
    ),
    // Texture-tree nodes and their scalar/color forms.
    b("mix", &["t", "a", "b", "only?"], "mix(float t, T a, T b) -> T, T a float, vec2, triple, color or material"),
    b("blend", &["t", "items", "spline?"], "blend(float t, T[n] items, bool spline = false) -> T"),
    b("select", &["index", "items"], "select(int index, T[n] items) -> T"),
    b("bump", &["height", "amount", "m"], "bump(float height, float amount, material m) -> material"),
    b("scale", &["c", "m?"], "scale(color c, material m) -> material | scale(vector|float s) -> matrix"),
    b("transform", &["xform", "m"], "transform(matrix xform, material m) -> material"),
];

pub fn builtin(name: &str) -> Option<&'static Builtin> {
    BUILTINS.iter().find(|b| b.name == name)
}

/// A typing failure: which argument is at fault (if one is) and why.
#[derive(Debug)]
pub struct ArgError {
    pub arg: Option<usize>,
    pub message: String,
    pub help: Option<String>,
}

fn err(arg: usize, message: String) -> ArgError {
    ArgError { arg: Some(arg), message, help: None }
}

fn color_component_help() -> String {
    "a color hides its representation (RGB or spectral samples): use brightness(c) or to_rgb(c) to get numbers out"
        .into()
}

/// The result of elementwise arithmetic between `a` and `b`, where a float
/// may stand on either side of a vec2 or triple.
pub fn elementwise(a: &Ty, b: &Ty) -> Option<Ty> {
    let norm = |t: &Ty| if t.is_triple() { Ty::Vector } else { t.clone() };
    match (a, b) {
        (Ty::Error, _) | (_, Ty::Error) => Some(Ty::Error),
        (Ty::Int, Ty::Int) => Some(Ty::Int),
        (x, y) if x.is_numeric() && y.is_numeric() => Some(Ty::Float),
        (x, y) if x.is_numeric() && y.is_float_like() => Some(norm(y)),
        (x, y) if x.is_float_like() && y.is_numeric() => Some(norm(x)),
        (x, y) if x.is_triple() && y.is_triple() => Some(Ty::Vector),
        (Ty::Vec2, Ty::Vec2) => Some(Ty::Vec2),
        _ => None,
    }
}

/// "`float`" or "`vector` or `float`": what may accompany a `t` argument.
fn same_or_float(t: &Ty) -> String {
    if *t == Ty::Float { "`float`".into() } else { format!("`{t}` or `float`") }
}

/// Float-family type of a numeric-or-vector argument, with ints as floats.
fn genf(t: &Ty) -> Option<Ty> {
    match t {
        Ty::Int | Ty::Float => Some(Ty::Float),
        Ty::Error => Some(Ty::Error),
        t if t.is_float_like() => Some(t.clone()),
        _ => None,
    }
}

fn expect(args: &[Option<Ty>], i: usize, want: &Ty) -> Result<(), ArgError> {
    match &args[i] {
        Some(t) if !t.converts_to(want) => {
            let mut e = err(i, format!("expected `{want}`, found `{t}`"));
            if *want == Ty::Color && t.is_numeric() {
                e.help = Some("a number is not a color: write gray(x) for a uniform color, or rgb(r, g, b)".into());
            } else if t == &Ty::Color {
                e.help = Some(color_component_help());
            }
            Err(e)
        }
        _ => Ok(()),
    }
}

fn arg(args: &[Option<Ty>], i: usize) -> Ty {
    args.get(i).cloned().flatten().unwrap_or(Ty::Error)
}

/// The element type of an array argument.
fn array_elem(args: &[Option<Ty>], i: usize, what: &str) -> Result<Ty, ArgError> {
    match arg(args, i) {
        Ty::Array(e, n) if n > 0 => Ok(*e),
        Ty::Array(_, _) => Err(err(i, format!("{what} needs at least one item"))),
        Ty::Error => Ok(Ty::Error),
        t => Err(err(i, format!("expected an array such as `[a, b, c]`, found `{t}`"))),
    }
}

/// Types a builtin call. `args[i]` is `None` for an omitted optional.
pub fn type_builtin(name: &str, args: &[Option<Ty>]) -> Result<Ty, ArgError> {
    let a0 = arg(args, 0);
    let unary = |want: &str| -> Result<Ty, ArgError> {
        genf(&a0).ok_or_else(|| {
            let mut e = err(0, format!("`{name}` takes {want}, found `{a0}`"));
            if a0 == Ty::Color {
                e.help = Some(color_component_help());
            }
            e
        })
    };
    match name {
        n if COLOR_MATH.contains(&n) && a0 == Ty::Color => Ok(Ty::Color),
        n if UNARY_MATH.contains(&n) => unary("a float, vec2 or vector"),
        "atan2" => {
            expect(args, 0, &Ty::Float)?;
            expect(args, 1, &Ty::Float)?;
            Ok(Ty::Float)
        }
        "pow" => {
            expect(args, 1, &Ty::Float)?;
            if a0 == Ty::Color { Ok(Ty::Color) } else { unary("a float, vec2, vector or color") }
        }
        "min" | "max" | "clamp" if a0 == Ty::Color => {
            for i in 1..args.len() {
                expect(args, i, &Ty::Color)?;
            }
            Ok(Ty::Color)
        }
        "min" | "max" | "mod" | "clamp" => {
            let t = unary("a float, vec2 or vector")?;
            for i in 1..args.len() {
                let ai = arg(args, i);
                if !(ai.converts_to(&t) || ai.is_numeric()) {
                    return Err(err(i, format!("expected {}, found `{ai}`", same_or_float(&t))));
                }
            }
            Ok(if a0 == Ty::Int && args[1..].iter().all(|x| x.as_ref() == Some(&Ty::Int)) { Ty::Int } else { t })
        }
        "step" | "smoothstep" => {
            let last = args.len() - 1;
            let t = genf(&arg(args, last))
                .ok_or_else(|| err(last, format!("expected a float, vec2 or vector, found `{}`", arg(args, last))))?;
            for i in 0..last {
                let ai = arg(args, i);
                if !(ai.converts_to(&t) || ai.is_numeric()) {
                    return Err(err(i, format!("expected {}, found `{ai}`", same_or_float(&t))));
                }
            }
            Ok(t)
        }
        "dot" | "distance" => {
            let t = if a0 == Ty::Vec2 { Ty::Vec2 } else { Ty::Vector };
            expect(args, 0, &t)?;
            expect(args, 1, &t)?;
            Ok(Ty::Float)
        }
        "length" => {
            let t = if a0 == Ty::Vec2 { Ty::Vec2 } else { Ty::Vector };
            expect(args, 0, &t)?;
            Ok(Ty::Float)
        }
        "normalize" => {
            let t = if a0 == Ty::Vec2 { Ty::Vec2 } else { Ty::Vector };
            expect(args, 0, &t)?;
            Ok(t)
        }
        "cross" | "reflect" => {
            expect(args, 0, &Ty::Vector)?;
            expect(args, 1, &Ty::Vector)?;
            Ok(Ty::Vector)
        }
        "refract" => {
            expect(args, 0, &Ty::Vector)?;
            expect(args, 1, &Ty::Vector)?;
            expect(args, 2, &Ty::Float)?;
            Ok(Ty::Vector)
        }
        "faceforward" => {
            expect(args, 0, &Ty::Vector)?;
            expect(args, 1, &Ty::Vector)?;
            Ok(Ty::Normal)
        }
        "noise" | "cellnoise" => {
            unary("a float, vec2 or point")?;
            Ok(Ty::Float)
        }
        "pnoise" => {
            let t = unary("a float, vec2 or point")?;
            let a1 = arg(args, 1);
            if !(a1.converts_to(&t) || (t != Ty::Float && a1.is_numeric())) {
                return Err(err(1, format!("the period must be `{t}` like the point, found `{a1}`")));
            }
            Ok(Ty::Float)
        }
        "rgb" | "hsv" | "xyz" => {
            for i in 0..3 {
                expect(args, i, &Ty::Float)?;
            }
            Ok(Ty::Color)
        }
        "gray" => {
            expect(args, 0, &Ty::Float)?;
            Ok(Ty::Color)
        }
        "black" => Ok(Ty::Color),
        "spectrum" => {
            let e = array_elem(args, 0, "a spectrum")?;
            if !e.converts_to(&Ty::Vec2) {
                return Err(ArgError {
                    arg: Some(0),
                    message: format!("expected samples `(wavelength_nm, value)` as vec2, found `{e}` items"),
                    help: Some("write spectrum([(400, 0.2), (550, 0.5), (700, 0.9)])".into()),
                });
            }
            Ok(Ty::Color)
        }
        "brightness" | "to_rgb" | "to_xyz" => {
            expect(args, 0, &Ty::Color)?;
            Ok(if name == "brightness" { Ty::Float } else { Ty::Vector })
        }
        "delta_sample" => {
            expect(args, 0, &Ty::Vector)?;
            expect(args, 1, &Ty::Color)?;
            Ok(Ty::BsdfSample)
        }
        "no_sample" => Ok(Ty::BsdfSample),
        "translate" => {
            expect(args, 0, &Ty::Vector)?;
            Ok(Ty::Matrix)
        }
        "rotate" => {
            expect(args, 0, &Ty::Float)?;
            expect(args, 1, &Ty::Vector)?;
            Ok(Ty::Matrix)
        }
        "inverse" => {
            expect(args, 0, &Ty::Matrix)?;
            Ok(Ty::Matrix)
        }
        "transform_point" | "transform_vector" | "transform_normal" => {
            expect(args, 0, &Ty::Matrix)?;
            expect(args, 1, &Ty::Vector)?;
            Ok(match name {
                "transform_point" => Ty::Point,
                "transform_vector" => Ty::Vector,
                _ => Ty::Normal,
            })
        }
        "texture" | "texture_float" => {
            let color = name == "texture";
            for (i, want) in texture_param_types(color).iter().enumerate() {
                if args.get(i).is_some_and(|a| a.is_some()) {
                    expect(args, i, want)?;
                }
            }
            Ok(if color { Ty::Color } else { Ty::Float })
        }
        "mix" => {
            expect(args, 0, &Ty::Float)?;
            let (a, b) = (arg(args, 1), arg(args, 2));
            let t =
                unify(&a, &b).ok_or_else(|| err(2, format!("`mix` blends two values of one type: `{a}` and `{b}`")))?;
            let t = if t == Ty::Int { Ty::Float } else { t };
            if !(t.is_float_like() || matches!(t, Ty::Color | Ty::Material | Ty::Error)) {
                return Err(err(1, format!("`mix` cannot blend `{t}`")));
            }
            if args.get(3).is_some_and(|o| o.is_some()) {
                expect(args, 3, &Ty::String)?;
                if !matches!(t, Ty::Material | Ty::Error) {
                    return Err(err(3, "`only:` selects an interface method, so it needs materials".into()));
                }
            }
            Ok(t)
        }
        "blend" => {
            expect(args, 0, &Ty::Float)?;
            let e = array_elem(args, 1, "`blend`")?;
            if !(e.is_float_like() || matches!(e, Ty::Int | Ty::Color | Ty::Material | Ty::Error)) {
                return Err(err(1, format!("`blend` cannot interpolate `{e}`")));
            }
            expect(args, 2, &Ty::Bool)?;
            Ok(if e == Ty::Int { Ty::Float } else { e })
        }
        "select" => {
            expect(args, 0, &Ty::Int).map_err(|mut e| {
                e.help = Some("the index is an int such as `face`; convert a float with int(x)".into());
                e
            })?;
            array_elem(args, 1, "`select`")
        }
        "bump" => {
            expect(args, 0, &Ty::Float)?;
            expect(args, 1, &Ty::Float)?;
            expect(args, 2, &Ty::Material)?;
            Ok(Ty::Material)
        }
        "scale" => {
            if args.get(1).is_some_and(|o| o.is_some()) {
                expect(args, 0, &Ty::Color)?;
                expect(args, 1, &Ty::Material)?;
                Ok(Ty::Material)
            } else if a0.is_numeric() || a0.is_triple() || a0 == Ty::Error {
                Ok(Ty::Matrix)
            } else {
                Err(ArgError {
                    arg: Some(0),
                    message: format!("`scale` takes a color and a material, or a float or vector; found `{a0}`"),
                    help: Some("scale(c, m) weights a material by a color; scale(s) builds a matrix".into()),
                })
            }
        }
        "transform" => {
            expect(args, 0, &Ty::Matrix)?;
            expect(args, 1, &Ty::Material)?;
            Ok(Ty::Material)
        }
        _ => Err(ArgError { arg: None, message: format!("no typing rule for builtin `{name}`"), help: None }),
    }
}

/// The parameter types of `texture` (`color`) and `texture_float`, in the
/// order of their [`BUILTINS`] entries.
pub fn texture_param_types(color: bool) -> [Ty; 9] {
    use Ty::{Int, String as S, Vec2};
    if color { [S, Vec2, S, S, S, S, S, Vec2, Vec2] } else { [S, Vec2, Int, S, S, S, S, Vec2, Vec2] }
}

/// The common type of two branches (`?:`, `mix`, array items).
pub fn unify(a: &Ty, b: &Ty) -> Option<Ty> {
    match (a, b) {
        (Ty::Error, t) | (t, Ty::Error) => Some(t.clone()),
        (x, y) if x == y => Some(x.clone()),
        (x, y) if x.is_numeric() && y.is_numeric() => Some(Ty::Float),
        (x, y) if x.is_triple() && y.is_triple() => Some(Ty::Vector),
        (Ty::Array(x, n), Ty::Array(y, m)) if n == m => unify(x, y).map(|t| Ty::Array(Box::new(t), *n)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ty(name: &str, args: &[Ty]) -> Result<Ty, ArgError> {
        let args: Vec<Option<Ty>> = args.iter().cloned().map(Some).collect();
        type_builtin(name, &args)
    }

    #[test]
    fn every_builtin_has_a_rule() {
        for b in BUILTINS {
            let args: Vec<Option<Ty>> = b.params.iter().map(|_| Some(Ty::Error)).collect();
            if let Err(e) = type_builtin(b.name, &args) {
                assert!(!e.message.starts_with("no typing rule"), "{}", b.name);
            }
        }
    }

    #[test]
    fn generic_rules() {
        assert_eq!(ty("abs", &[Ty::Int]).unwrap(), Ty::Float);
        assert_eq!(ty("floor", &[Ty::Point]).unwrap(), Ty::Point);
        assert_eq!(ty("pow", &[Ty::Color, Ty::Float]).unwrap(), Ty::Color);
        assert!(ty("sin", &[Ty::Color]).unwrap_err().help.is_some());
        assert_eq!(ty("sqrt", &[Ty::Color]).unwrap(), Ty::Color);
        assert_eq!(ty("max", &[Ty::Color, Ty::Color]).unwrap(), Ty::Color);
        assert!(ty("max", &[Ty::Color, Ty::Float]).is_err(), "a number is not a color");
        assert_eq!(ty("mix", &[Ty::Float, Ty::Material, Ty::Material]).unwrap(), Ty::Material);
        assert_eq!(ty("mix", &[Ty::Float, Ty::Int, Ty::Float]).unwrap(), Ty::Float);
        assert!(ty("mix", &[Ty::Float, Ty::Color, Ty::Float]).is_err());
        assert_eq!(ty("scale", &[Ty::Float]).unwrap(), Ty::Matrix);
        assert_eq!(ty("select", &[Ty::Int, Ty::Array(Box::new(Ty::Color), 3)]).unwrap(), Ty::Color);
        assert_eq!(ty("min", &[Ty::Int, Ty::Int]).unwrap(), Ty::Int);
        assert_eq!(elementwise(&Ty::Point, &Ty::Float), Some(Ty::Vector));
        assert_eq!(elementwise(&Ty::Color, &Ty::Float), None);
    }
}
