//! Builtin functions: their parameter names and typing rules.
//!
//! Most builtins are generic over a family of types (`abs` works on float,
//! vec2 and triples; `mix` on those, colors and materials), so each has a
//! typing rule rather than one signature.

use super::ty::Ty;
use crate::syntax::ast::Expr;

/// Every builtin function, in the order of [`BUILTINS`]. The checker
/// records which one each call resolved to, and the typing rules and the
/// lowering match on it exhaustively: a builtin added here without either
/// does not compile.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BuiltinFn {
    Abs,
    Sign,
    Floor,
    Ceil,
    Fract,
    Round,
    Sqrt,
    Exp,
    Log,
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Radians,
    Degrees,
    Atan2,
    Pow,
    Min,
    Max,
    Mod,
    Clamp,
    Step,
    Smoothstep,
    Dot,
    Cross,
    Length,
    Distance,
    Normalize,
    Reflect,
    Refract,
    Faceforward,
    RoughTransmittance,
    RoughInternalReflectance,
    Noise,
    Pnoise,
    Cellnoise,
    Rgb,
    Hsv,
    Xyz,
    Gray,
    Black,
    Spectrum,
    Brightness,
    ToRgb,
    ToXyz,
    DeltaSample,
    NoSample,
    Translate,
    Rotate,
    Inverse,
    TransformPoint,
    TransformVector,
    TransformNormal,
    Texture,
    TextureFloat,
    TextureVector,
    Triplanar,
    Mix,
    Blend,
    Select,
    Bump,
    NormalMap,
    Scale,
    Transform,
    Layer,
}

impl BuiltinFn {
    /// The builtin's table entry.
    pub fn builtin(self) -> &'static Builtin {
        &BUILTINS[self as usize]
    }

    pub fn name(self) -> &'static str {
        self.builtin().name
    }

    /// The texture-tree node this builtin is when its arguments are
    /// materials.
    pub fn tree_node(self) -> Option<TreeNode> {
        Some(match self {
            BuiltinFn::Mix => TreeNode::Mix,
            BuiltinFn::Blend => TreeNode::Blend,
            BuiltinFn::Select => TreeNode::Select,
            BuiltinFn::Bump => TreeNode::Bump,
            BuiltinFn::NormalMap => TreeNode::NormalMap,
            BuiltinFn::Scale => TreeNode::Scale,
            BuiltinFn::Transform => TreeNode::Transform,
            BuiltinFn::Layer => TreeNode::Layer,
            _ => return None,
        })
    }
}

/// The texture-tree nodes (docs/language.md section 10).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TreeNode {
    Mix,
    Blend,
    Select,
    Bump,
    NormalMap,
    Scale,
    Transform,
    Layer,
}

impl TreeNode {
    /// The builtin the node is written as, with its parameters.
    pub fn builtin(self) -> &'static Builtin {
        match self {
            TreeNode::Mix => BuiltinFn::Mix,
            TreeNode::Blend => BuiltinFn::Blend,
            TreeNode::Select => BuiltinFn::Select,
            TreeNode::Bump => BuiltinFn::Bump,
            TreeNode::NormalMap => BuiltinFn::NormalMap,
            TreeNode::Scale => BuiltinFn::Scale,
            TreeNode::Transform => BuiltinFn::Transform,
            TreeNode::Layer => BuiltinFn::Layer,
        }
        .builtin()
    }
}

/// How a normal map's green channel points (`normal_map`'s
/// `convention:`): OpenGL (and MaterialX, Mitsuba, Blender) store +v as
/// green up, DirectX (and Unreal, 3ds Max) as green down.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NormalMapConvention {
    OpenGl,
    DirectX,
}

impl NormalMapConvention {
    /// The names `convention:` accepts, in the order of the variants.
    pub const NAMES: &'static [&'static str] = &["opengl", "directx"];

    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "opengl" => Some(Self::OpenGl),
            "directx" => Some(Self::DirectX),
            _ => None,
        }
    }
}

/// A builtin's parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BuiltinParam {
    pub name: &'static str,
    /// What the builtin does when the argument is left out, in words for
    /// signatures and hovers (`"(u, v)"`, `"\"repeat\""`); `None` when the
    /// argument is required. Lowering implements each default.
    pub default: Option<&'static str>,
}

impl BuiltinParam {
    pub fn optional(&self) -> bool {
        self.default.is_some()
    }
}

const fn req(name: &'static str) -> BuiltinParam {
    BuiltinParam { name, default: None }
}

const fn opt(name: &'static str, default: &'static str) -> BuiltinParam {
    BuiltinParam { name, default: Some(default) }
}

/// A builtin function: its parameters and what "expected" messages show.
pub struct Builtin {
    pub func: BuiltinFn,
    pub name: &'static str,
    pub params: &'static [BuiltinParam],
    /// Shown in "expected" messages.
    pub synopsis: &'static str,
}

impl Builtin {
    /// The argument bound to parameter `param`, with `bound` in the order
    /// of [`Builtin::params`]: call sites name parameters, not positions.
    pub fn arg<'e>(&self, bound: &[Option<&'e Expr>], param: &str) -> Option<&'e Expr> {
        let k = self.params.iter().position(|p| p.name == param)?;
        bound.get(k).copied().flatten()
    }
}

const fn b(func: BuiltinFn, name: &'static str, params: &'static [BuiltinParam], synopsis: &'static str) -> Builtin {
    Builtin { func, name, params, synopsis }
}

pub const BUILTINS: &[Builtin] = &[
    b(BuiltinFn::Abs, "abs", &[req("x")], "abs(T x) -> T, T a float, vec2, triple or color"),
    b(BuiltinFn::Sign, "sign", &[req("x")], "sign(T x) -> T"),
    b(BuiltinFn::Floor, "floor", &[req("x")], "floor(T x) -> T"),
    b(BuiltinFn::Ceil, "ceil", &[req("x")], "ceil(T x) -> T"),
    b(BuiltinFn::Fract, "fract", &[req("x")], "fract(T x) -> T"),
    b(BuiltinFn::Round, "round", &[req("x")], "round(T x) -> T"),
    b(BuiltinFn::Sqrt, "sqrt", &[req("x")], "sqrt(T x) -> T, T a float, vec2, triple or color"),
    b(BuiltinFn::Exp, "exp", &[req("x")], "exp(T x) -> T, T a float, vec2, triple or color"),
    b(BuiltinFn::Log, "log", &[req("x")], "log(T x) -> T, T a float, vec2, triple or color"),
    b(BuiltinFn::Sin, "sin", &[req("x")], "sin(T x) -> T"),
    b(BuiltinFn::Cos, "cos", &[req("x")], "cos(T x) -> T"),
    b(BuiltinFn::Tan, "tan", &[req("x")], "tan(T x) -> T"),
    b(BuiltinFn::Asin, "asin", &[req("x")], "asin(T x) -> T"),
    b(BuiltinFn::Acos, "acos", &[req("x")], "acos(T x) -> T"),
    b(BuiltinFn::Atan, "atan", &[req("x")], "atan(T x) -> T"),
    b(BuiltinFn::Radians, "radians", &[req("degrees")], "radians(T degrees) -> T"),
    b(BuiltinFn::Degrees, "degrees", &[req("radians")], "degrees(T radians) -> T"),
    b(BuiltinFn::Atan2, "atan2", &[req("y"), req("x")], "atan2(float y, float x) -> float"),
    b(BuiltinFn::Pow, "pow", &[req("x"), req("e")], "pow(float x, float e) -> float | pow(color c, float e) -> color"),
    b(BuiltinFn::Min, "min", &[req("a"), req("b")], "min(T a, T|float b) -> T | min(color a, color b) -> color"),
    b(BuiltinFn::Max, "max", &[req("a"), req("b")], "max(T a, T|float b) -> T | max(color a, color b) -> color"),
    b(BuiltinFn::Mod, "mod", &[req("a"), req("b")], "mod(T a, T|float b) -> T"),
    b(
        BuiltinFn::Clamp,
        "clamp",
        &[req("x"), req("lo"), req("hi")],
        "clamp(T x, T|float lo, T|float hi) -> T | clamp(color x, color lo, color hi) -> color",
    ),
    b(BuiltinFn::Step, "step", &[req("edge"), req("x")], "step(T|float edge, T x) -> T"),
    b(
        BuiltinFn::Smoothstep,
        "smoothstep",
        &[req("e0"), req("e1"), req("x")],
        "smoothstep(T|float e0, T|float e1, T x) -> T",
    ),
    b(BuiltinFn::Dot, "dot", &[req("a"), req("b")], "dot(vector a, vector b) -> float"),
    b(BuiltinFn::Cross, "cross", &[req("a"), req("b")], "cross(vector a, vector b) -> vector"),
    b(BuiltinFn::Length, "length", &[req("v")], "length(vector v) -> float"),
    b(BuiltinFn::Distance, "distance", &[req("a"), req("b")], "distance(point a, point b) -> float"),
    b(BuiltinFn::Normalize, "normalize", &[req("v")], "normalize(vector v) -> vector"),
    b(BuiltinFn::Reflect, "reflect", &[req("i"), req("n")], "reflect(vector i, normal n) -> vector"),
    b(
        BuiltinFn::Refract,
        "refract",
        &[req("i"), req("n"), req("eta")],
        "refract(vector i, normal n, float eta) -> vector",
    ),
    b(BuiltinFn::Faceforward, "faceforward", &[req("n"), req("i")], "faceforward(normal n, vector i) -> normal"),
    b(
        BuiltinFn::RoughTransmittance,
        "rough_transmittance",
        &[req("cos_theta"), req("alpha"), req("eta"), req("ggx")],
        "rough_transmittance(float cos_theta, float alpha, float eta, bool ggx) -> float",
    ),
    b(
        BuiltinFn::RoughInternalReflectance,
        "rough_internal_reflectance",
        &[req("alpha"), req("eta"), req("ggx")],
        "rough_internal_reflectance(float alpha, float eta, bool ggx) -> float",
    ),
    b(BuiltinFn::Noise, "noise", &[req("p")], "noise(float|vec2|point p) -> float in [-1, 1]"),
    b(BuiltinFn::Pnoise, "pnoise", &[req("p"), req("period")], "pnoise(T p, T period) -> float in [-1, 1]"),
    b(BuiltinFn::Cellnoise, "cellnoise", &[req("p")], "cellnoise(float|vec2|point p) -> float in [0, 1)"),
    b(BuiltinFn::Rgb, "rgb", &[req("r"), req("g"), req("b")], "rgb(float r, float g, float b) -> color"),
    b(BuiltinFn::Hsv, "hsv", &[req("h"), req("s"), req("v")], "hsv(float h, float s, float v) -> color"),
    b(BuiltinFn::Xyz, "xyz", &[req("x"), req("y"), req("z")], "xyz(float x, float y, float z) -> color"),
    b(BuiltinFn::Gray, "gray", &[req("value")], "gray(float value) -> color"),
    b(BuiltinFn::Black, "black", &[], "black() -> color"),
    b(BuiltinFn::Spectrum, "spectrum", &[req("samples")], "spectrum(vec2[n] samples) -> color, samples as (nm, value)"),
    b(BuiltinFn::Brightness, "brightness", &[req("c")], "brightness(color c) -> float"),
    b(BuiltinFn::ToRgb, "to_rgb", &[req("c")], "to_rgb(color c) -> vector"),
    b(BuiltinFn::ToXyz, "to_xyz", &[req("c")], "to_xyz(color c) -> vector"),
    b(
        BuiltinFn::DeltaSample,
        "delta_sample",
        &[req("wi"), req("weight")],
        "delta_sample(vector wi, color weight) -> bsdf_sample",
    ),
    b(BuiltinFn::NoSample, "no_sample", &[], "no_sample() -> bsdf_sample"),
    b(BuiltinFn::Translate, "translate", &[req("offset")], "translate(vector offset) -> matrix"),
    b(BuiltinFn::Rotate, "rotate", &[req("degrees"), req("axis")], "rotate(float degrees, vector axis) -> matrix"),
    b(BuiltinFn::Inverse, "inverse", &[req("m")], "inverse(matrix m) -> matrix"),
    b(
        BuiltinFn::TransformPoint,
        "transform_point",
        &[req("m"), req("p")],
        "transform_point(matrix m, point p) -> point",
    ),
    b(
        BuiltinFn::TransformVector,
        "transform_vector",
        &[req("m"), req("v")],
        "transform_vector(matrix m, vector v) -> vector",
    ),
    b(
        BuiltinFn::TransformNormal,
        "transform_normal",
        &[req("m"), req("n")],
        "transform_normal(matrix m, normal n) -> normal",
    ),
    b(
        BuiltinFn::Texture,
        "texture",
        &[
            req("file"),
            opt("st", "(u, v)"),
            opt("filter", "\"trilinear\""),
            opt("wrap", "\"repeat\""),
            opt("swrap", "the wrap: value"),
            opt("twrap", "the wrap: value"),
            opt("colorspace", "\"srgb\""),
            opt("dx", "st at the next pixel in x, less st"),
            opt("dy", "st at the next pixel in y, less st"),
        ],
        "texture(string file, vec2 st = (u, v), string filter, string wrap, ..., vec2 dx, vec2 dy) -> color",
    ),
    b(
        BuiltinFn::TextureFloat,
        "texture_float",
        &[
            req("file"),
            opt("st", "(u, v)"),
            opt("channel", "0"),
            opt("filter", "\"trilinear\""),
            opt("wrap", "\"repeat\""),
            opt("swrap", "the wrap: value"),
            opt("twrap", "the wrap: value"),
            opt("dx", "st at the next pixel in x, less st"),
            opt("dy", "st at the next pixel in y, less st"),
        ],
        "texture_float(string file, vec2 st = (u, v), int channel = 0, string filter, ...) -> float",
    ),
    b(
        BuiltinFn::TextureVector,
        "texture_vector",
        &[
            req("file"),
            opt("st", "(u, v)"),
            opt("filter", "\"trilinear\""),
            opt("wrap", "\"repeat\""),
            opt("swrap", "the wrap: value"),
            opt("twrap", "the wrap: value"),
            opt("dx", "st at the next pixel in x, less st"),
            opt("dy", "st at the next pixel in y, less st"),
        ],
        "texture_vector(string file, vec2 st = (u, v), string filter, ...) -> vector",
    ),
    b(
        BuiltinFn::Triplanar,
        "triplanar",
        &[req("value"), opt("sharpness", "4")],
        "triplanar(T value, float sharpness = 4) -> T, T a float, vec2, triple or color",
    ),
    b(
        BuiltinFn::Mix,
        "mix",
        &[req("t"), req("a"), req("b"), opt("only", "every method")],
        "mix(float t, T a, T b) -> T, T a float, vec2, triple, color or material",
    ),
    b(
        BuiltinFn::Blend,
        "blend",
        &[req("t"), req("items"), opt("spline", "false")],
        "blend(float t, T[n] items, bool spline = false) -> T",
    ),
    b(BuiltinFn::Select, "select", &[req("index"), req("items")], "select(int index, T[n] items) -> T"),
    b(
        BuiltinFn::Bump,
        "bump",
        &[req("height"), req("amount"), req("m"), opt("shadowing", "true")],
        "bump(float height, float amount, material m, bool shadowing = true) -> material",
    ),
    b(
        BuiltinFn::NormalMap,
        "normal_map",
        &[req("map"), req("m"), opt("strength", "1"), opt("convention", "\"opengl\""), opt("shadowing", "true")],
        "normal_map(vector map, material m, float strength = 1, string convention = \"opengl\", bool shadowing = true) -> material",
    ),
    b(
        BuiltinFn::Scale,
        "scale",
        &[req("c"), opt("m", "none: scale(s) is a matrix")],
        "scale(color c, material m) -> material | scale(vector|float s) -> matrix",
    ),
    b(BuiltinFn::Transform, "transform", &[req("xform"), req("m")], "transform(matrix xform, material m) -> material"),
    b(BuiltinFn::Layer, "layer", &[req("top"), req("base")], "layer(material top, material base) -> material"),
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
pub fn type_builtin(f: BuiltinFn, args: &[Option<Ty>]) -> Result<Ty, ArgError> {
    use BuiltinFn::*;
    let name = f.name();
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
    match f {
        // Lane-wise on colors: a lane-wise function never names a lane, so
        // the representation stays hidden (docs/language.md section 3).
        Abs | Sqrt | Exp | Log if a0 == Ty::Color => Ok(Ty::Color),
        Abs | Sign | Floor | Ceil | Fract | Round | Sqrt | Exp | Log | Sin | Cos | Tan | Asin | Acos | Atan
        | Radians | Degrees => unary("a float, vec2 or vector"),
        Atan2 => {
            expect(args, 0, &Ty::Float)?;
            expect(args, 1, &Ty::Float)?;
            Ok(Ty::Float)
        }
        Pow => {
            expect(args, 1, &Ty::Float)?;
            if a0 == Ty::Color { Ok(Ty::Color) } else { unary("a float, vec2, vector or color") }
        }
        Min | Max | Clamp if a0 == Ty::Color => {
            for i in 1..args.len() {
                expect(args, i, &Ty::Color)?;
            }
            Ok(Ty::Color)
        }
        Min | Max | Mod | Clamp => {
            let t = unary("a float, vec2 or vector")?;
            for i in 1..args.len() {
                let ai = arg(args, i);
                if !(ai.converts_to(&t) || ai.is_numeric()) {
                    return Err(err(i, format!("expected {}, found `{ai}`", same_or_float(&t))));
                }
            }
            Ok(if a0 == Ty::Int && args[1..].iter().all(|x| x.as_ref() == Some(&Ty::Int)) { Ty::Int } else { t })
        }
        Step | Smoothstep => {
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
        Dot | Distance => {
            let t = if a0 == Ty::Vec2 { Ty::Vec2 } else { Ty::Vector };
            expect(args, 0, &t)?;
            expect(args, 1, &t)?;
            Ok(Ty::Float)
        }
        Length => {
            let t = if a0 == Ty::Vec2 { Ty::Vec2 } else { Ty::Vector };
            expect(args, 0, &t)?;
            Ok(Ty::Float)
        }
        Normalize => {
            let t = if a0 == Ty::Vec2 { Ty::Vec2 } else { Ty::Vector };
            expect(args, 0, &t)?;
            Ok(t)
        }
        Cross | Reflect => {
            expect(args, 0, &Ty::Vector)?;
            expect(args, 1, &Ty::Vector)?;
            Ok(Ty::Vector)
        }
        Refract => {
            expect(args, 0, &Ty::Vector)?;
            expect(args, 1, &Ty::Vector)?;
            expect(args, 2, &Ty::Float)?;
            Ok(Ty::Vector)
        }
        Faceforward => {
            expect(args, 0, &Ty::Vector)?;
            expect(args, 1, &Ty::Vector)?;
            Ok(Ty::Normal)
        }
        RoughTransmittance | RoughInternalReflectance => {
            let floats = args.len() - 1;
            for i in 0..floats {
                expect(args, i, &Ty::Float)?;
            }
            expect(args, floats, &Ty::Bool)?;
            Ok(Ty::Float)
        }
        Noise | Cellnoise => {
            unary("a float, vec2 or point")?;
            Ok(Ty::Float)
        }
        Pnoise => {
            let t = unary("a float, vec2 or point")?;
            let a1 = arg(args, 1);
            if !(a1.converts_to(&t) || (t != Ty::Float && a1.is_numeric())) {
                return Err(err(1, format!("the period must be `{t}` like the point, found `{a1}`")));
            }
            Ok(Ty::Float)
        }
        Rgb | Hsv | Xyz => {
            for i in 0..3 {
                expect(args, i, &Ty::Float)?;
            }
            Ok(Ty::Color)
        }
        Gray => {
            expect(args, 0, &Ty::Float)?;
            Ok(Ty::Color)
        }
        Black => Ok(Ty::Color),
        Spectrum => {
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
        Brightness | ToRgb | ToXyz => {
            expect(args, 0, &Ty::Color)?;
            Ok(if f == Brightness { Ty::Float } else { Ty::Vector })
        }
        DeltaSample => {
            expect(args, 0, &Ty::Vector)?;
            expect(args, 1, &Ty::Color)?;
            Ok(Ty::BsdfSample)
        }
        NoSample => Ok(Ty::BsdfSample),
        Translate => {
            expect(args, 0, &Ty::Vector)?;
            Ok(Ty::Matrix)
        }
        Rotate => {
            expect(args, 0, &Ty::Float)?;
            expect(args, 1, &Ty::Vector)?;
            Ok(Ty::Matrix)
        }
        Inverse => {
            expect(args, 0, &Ty::Matrix)?;
            Ok(Ty::Matrix)
        }
        TransformPoint | TransformVector | TransformNormal => {
            expect(args, 0, &Ty::Matrix)?;
            expect(args, 1, &Ty::Vector)?;
            Ok(match f {
                TransformPoint => Ty::Point,
                TransformVector => Ty::Vector,
                _ => Ty::Normal,
            })
        }
        Texture | TextureFloat | TextureVector => {
            for (i, want) in texture_param_types(f).iter().enumerate() {
                if args.get(i).is_some_and(|a| a.is_some()) {
                    expect(args, i, want)?;
                }
            }
            Ok(match f {
                Texture => Ty::Color,
                TextureFloat => Ty::Float,
                _ => Ty::Vector,
            })
        }
        Triplanar => {
            if args.get(1).is_some_and(|a| a.is_some()) {
                expect(args, 1, &Ty::Float)?;
            }
            match a0 {
                Ty::Color => Ok(Ty::Color),
                _ => unary("a float, vec2, vector or color"),
            }
        }
        Mix => {
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
        Blend => {
            expect(args, 0, &Ty::Float)?;
            let e = array_elem(args, 1, "`blend`")?;
            if !(e.is_float_like() || matches!(e, Ty::Int | Ty::Color | Ty::Material | Ty::Error)) {
                return Err(err(1, format!("`blend` cannot interpolate `{e}`")));
            }
            expect(args, 2, &Ty::Bool)?;
            Ok(if e == Ty::Int { Ty::Float } else { e })
        }
        Select => {
            expect(args, 0, &Ty::Int).map_err(|mut e| {
                e.help = Some("the index is an int such as `face`; convert a float with int(x)".into());
                e
            })?;
            array_elem(args, 1, "`select`")
        }
        Bump => {
            expect(args, 0, &Ty::Float)?;
            expect(args, 1, &Ty::Float)?;
            expect(args, 2, &Ty::Material)?;
            if args.get(3).is_some_and(|a| a.is_some()) {
                expect(args, 3, &Ty::Bool)?;
            }
            Ok(Ty::Material)
        }
        NormalMap => {
            if a0 == Ty::Color {
                return Err(ArgError {
                    arg: Some(0),
                    message: "a normal map is data, not a color: expected `vector`, found `color`".into(),
                    help: Some(
                        "read the image with texture_vector(\"normal.png\"), which returns its stored values \
                         (no sRGB decoding, no spectral upsampling)"
                            .into(),
                    ),
                });
            }
            expect(args, 0, &Ty::Vector)?;
            expect(args, 1, &Ty::Material)?;
            if args.get(2).is_some_and(|a| a.is_some()) {
                expect(args, 2, &Ty::Float)?;
            }
            if args.get(3).is_some_and(|a| a.is_some()) {
                expect(args, 3, &Ty::String)?;
            }
            if args.get(4).is_some_and(|a| a.is_some()) {
                expect(args, 4, &Ty::Bool)?;
            }
            Ok(Ty::Material)
        }
        Scale => {
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
        Transform => {
            expect(args, 0, &Ty::Matrix)?;
            expect(args, 1, &Ty::Material)?;
            Ok(Ty::Material)
        }
        Layer => {
            for k in 0..2 {
                expect(args, k, &Ty::Material).map_err(|mut e| {
                    e.help = Some(
                        "layer(top, base) puts one material over another, e.g. a coat over a base; \
                         to blend by a weight, write mix(t, a, b)"
                            .into(),
                    );
                    e
                })?;
            }
            Ok(Ty::Material)
        }
    }
}

/// The parameter types of `texture`, `texture_float` and
/// `texture_vector`, in the order of their [`BUILTINS`] entries.
pub fn texture_param_types(f: BuiltinFn) -> Vec<Ty> {
    use Ty::{Int, String as S, Vec2};
    match f {
        BuiltinFn::Texture => vec![S, Vec2, S, S, S, S, S, Vec2, Vec2],
        BuiltinFn::TextureFloat => vec![S, Vec2, Int, S, S, S, S, Vec2, Vec2],
        _ => vec![S, Vec2, S, S, S, S, Vec2, Vec2],
    }
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
        type_builtin(builtin(name).expect("a builtin").func, &args)
    }

    #[test]
    fn the_table_is_in_the_order_of_the_enum() {
        for (k, b) in BUILTINS.iter().enumerate() {
            assert_eq!(b.func as usize, k, "`{}` is out of place", b.name);
            assert_eq!(b.func.name(), b.name);
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
