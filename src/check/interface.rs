//! The generic material interface (the second paper's `GMaterial`) and the
//! shading globals every generator and method can read.

use super::ty::Ty;

/// One method of the generic material interface.
#[derive(Debug, Clone, Copy)]
pub struct InterfaceMethod {
    pub name: &'static str,
    pub ret: Ty2,
    pub params: &'static [(&'static str, Ty2)],
    /// What a material that omits the method does, in TSL terms.
    pub default: &'static str,
}

/// A `Ty` that can live in a `static` table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ty2 {
    Float,
    Int,
    Bool,
    Color,
    Vector,
    Point,
    Normal,
    Vec2,
}

impl Ty2 {
    pub fn ty(self) -> Ty {
        match self {
            Ty2::Float => Ty::Float,
            Ty2::Int => Ty::Int,
            Ty2::Bool => Ty::Bool,
            Ty2::Color => Ty::Color,
            Ty2::Vector => Ty::Vector,
            Ty2::Point => Ty::Point,
            Ty2::Normal => Ty::Normal,
            Ty2::Vec2 => Ty::Vec2,
        }
    }
}

/// The interface, in the order of the paper's Figure 3.
pub const INTERFACE: &[InterfaceMethod] = &[
    InterfaceMethod {
        name: "reflection",
        ret: Ty2::Color,
        params: &[("wi", Ty2::Vector), ("light", Ty2::Color), ("wo", Ty2::Vector)],
        default: "black()",
    },
    InterfaceMethod {
        name: "refraction",
        ret: Ty2::Color,
        params: &[("wi", Ty2::Vector), ("light", Ty2::Color), ("eta", Ty2::Color), ("wo", Ty2::Vector)],
        default: "black()",
    },
    InterfaceMethod { name: "refraction_index", ret: Ty2::Color, params: &[], default: "gray(1)" },
    InterfaceMethod {
        name: "reflection_dir",
        ret: Ty2::Vector,
        params: &[("wo", Ty2::Vector)],
        default: "vector(0) (no mirror reflection)",
    },
    InterfaceMethod {
        name: "refraction_dir",
        ret: Ty2::Vector,
        params: &[("wo", Ty2::Vector), ("eta", Ty2::Color)],
        default: "vector(0) (no refraction)",
    },
    InterfaceMethod { name: "emission", ret: Ty2::Color, params: &[("wo", Ty2::Vector)], default: "black()" },
    InterfaceMethod {
        name: "ambient",
        ret: Ty2::Color,
        params: &[("light", Ty2::Color)],
        default: "light * diffuse()",
    },
    InterfaceMethod {
        name: "absorption",
        ret: Ty2::Color,
        params: &[("light", Ty2::Color), ("distance", Ty2::Float)],
        default: "light (nothing is absorbed)",
    },
    InterfaceMethod { name: "normal", ret: Ty2::Normal, params: &[], default: "N" },
    InterfaceMethod { name: "diffuse", ret: Ty2::Color, params: &[], default: "black()" },
    InterfaceMethod { name: "opaque", ret: Ty2::Bool, params: &[], default: "true" },
];

pub fn interface_method(name: &str) -> Option<&'static InterfaceMethod> {
    INTERFACE.iter().find(|m| m.name == name)
}

impl InterfaceMethod {
    /// The signature as it would be written in TSL.
    pub fn signature(&self) -> String {
        let params: Vec<String> = self.params.iter().map(|(n, t)| format!("{} {n}", t.ty())).collect();
        format!("{} {}({})", self.ret.ty(), self.name, params.join(", "))
    }
}

/// The read-only shading globals: the surface-point record.
pub const GLOBALS: &[(&str, Ty2, &str)] = &[
    ("P", Ty2::Point, "hit point, world space"),
    ("Pl", Ty2::Point, "hit point, object space"),
    ("N", Ty2::Normal, "shading normal"),
    ("Ng", Ty2::Normal, "geometric normal"),
    ("u", Ty2::Float, "surface parameter u"),
    ("v", Ty2::Float, "surface parameter v"),
    ("dPdu", Ty2::Vector, "tangent along u"),
    ("dPdv", Ty2::Vector, "tangent along v"),
    ("face", Ty2::Int, "surface number"),
    ("t", Ty2::Float, "ray length"),
    ("dPdx", Ty2::Vector, "change of P to the next pixel in x"),
    ("dPdy", Ty2::Vector, "change of P to the next pixel in y"),
    ("dudx", Ty2::Float, "change of u to the next pixel in x"),
    ("dudy", Ty2::Float, "change of u to the next pixel in y"),
    ("dvdx", Ty2::Float, "change of v to the next pixel in x"),
    ("dvdy", Ty2::Float, "change of v to the next pixel in y"),
];

pub fn global(name: &str) -> Option<Ty> {
    GLOBALS.iter().find(|g| g.0 == name).map(|g| g.1.ty())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signatures_read_like_tsl() {
        assert_eq!(
            interface_method("reflection").unwrap().signature(),
            "color reflection(vector wi, color light, vector wo)"
        );
        assert_eq!(INTERFACE.len(), 11, "the paper's eleven methods");
    }
}
