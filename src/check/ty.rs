//! Checked types and the conversions between them.

use crate::syntax::ast::{BaseType, TypeExpr};
use std::fmt;

/// A checked type.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Ty {
    Float,
    Int,
    Bool,
    /// The generic color: RGB or N spectral samples, chosen at compile time.
    Color,
    Vector,
    Point,
    Normal,
    Vec2,
    Matrix,
    /// A direction sampled by a material: `wi`, its `weight` (a color),
    /// its solid-angle `pdf`, and whether it is a `delta` lobe.
    BsdfSample,
    String,
    /// A material expression (texture tree).
    Material,
    Void,
    Array(Box<Ty>, u32),
    /// The type of an expression that already produced an error; it
    /// converts to everything so one mistake is reported once.
    Error,
}

/// The fields of a [`Ty::BsdfSample`], in the order of its words.
pub const SAMPLE_FIELDS: &[(&str, Ty)] =
    &[("wi", Ty::Vector), ("weight", Ty::Color), ("pdf", Ty::Float), ("delta", Ty::Bool)];

impl Ty {
    pub fn from_base(b: BaseType) -> Ty {
        match b {
            BaseType::Float => Ty::Float,
            BaseType::Int => Ty::Int,
            BaseType::Bool => Ty::Bool,
            BaseType::Color => Ty::Color,
            BaseType::Vector => Ty::Vector,
            BaseType::Point => Ty::Point,
            BaseType::Normal => Ty::Normal,
            BaseType::Vec2 => Ty::Vec2,
            BaseType::Matrix => Ty::Matrix,
            BaseType::BsdfSample => Ty::BsdfSample,
            BaseType::String => Ty::String,
            BaseType::Material => Ty::Material,
            BaseType::Void => Ty::Void,
        }
    }

    pub fn from_ast(t: &TypeExpr) -> Ty {
        let base = Ty::from_base(t.base);
        match t.array_len {
            Some((n, _)) => Ty::Array(Box::new(base), n),
            None => base,
        }
    }

    /// `vector`, `point` and `normal`: three floats, interchangeable.
    pub fn is_triple(&self) -> bool {
        matches!(self, Ty::Vector | Ty::Point | Ty::Normal)
    }

    pub fn is_numeric(&self) -> bool {
        matches!(self, Ty::Float | Ty::Int)
    }

    /// Types that arithmetic works on elementwise: float, vec2, triples.
    pub fn is_float_like(&self) -> bool {
        matches!(self, Ty::Float | Ty::Vec2) || self.is_triple()
    }

    pub fn is_error(&self) -> bool {
        match self {
            Ty::Error => true,
            Ty::Array(e, _) => e.is_error(),
            _ => false,
        }
    }

    /// Whether a value of type `self` may be used where `to` is expected.
    pub fn converts_to(&self, to: &Ty) -> bool {
        match (self, to) {
            (Ty::Error, _) | (_, Ty::Error) => true,
            (a, b) if a == b => true,
            (Ty::Int, Ty::Float) => true,
            (a, b) if a.is_triple() && b.is_triple() => true,
            (Ty::Array(a, n), Ty::Array(b, m)) => n == m && a.converts_to(b),
            _ => false,
        }
    }
}

impl fmt::Display for Ty {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = match self {
            Ty::Float => "float",
            Ty::Int => "int",
            Ty::Bool => "bool",
            Ty::Color => "color",
            Ty::Vector => "vector",
            Ty::Point => "point",
            Ty::Normal => "normal",
            Ty::Vec2 => "vec2",
            Ty::Matrix => "matrix",
            Ty::BsdfSample => "bsdf_sample",
            Ty::String => "string",
            Ty::Material => "material",
            Ty::Void => "void",
            Ty::Error => "{error}",
            Ty::Array(e, n) => return write!(f, "{e}[{n}]"),
        };
        f.write_str(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions() {
        assert!(Ty::Int.converts_to(&Ty::Float));
        assert!(!Ty::Float.converts_to(&Ty::Int));
        assert!(Ty::Point.converts_to(&Ty::Normal));
        assert!(!Ty::Float.converts_to(&Ty::Color), "a float is never implicitly a color");
        assert!(Ty::Array(Box::new(Ty::Int), 3).converts_to(&Ty::Array(Box::new(Ty::Float), 3)));
        assert!(!Ty::Array(Box::new(Ty::Int), 3).converts_to(&Ty::Array(Box::new(Ty::Float), 2)));
        assert_eq!(Ty::Array(Box::new(Ty::Color), 4).to_string(), "color[4]");
    }
}
