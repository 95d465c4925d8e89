//! The generic material interface (the second paper's `GMaterial`) and the
//! shading globals every generator and method can read.

use super::ty::Ty;

/// One method of the generic material interface.
#[derive(Debug, Clone)]
pub struct InterfaceMethod {
    pub name: &'static str,
    pub ret: Ty,
    pub params: &'static [(&'static str, Ty)],
    /// What a material that omits the method does, in TSL terms.
    pub default: &'static str,
}

/// The interface: the paper's eleven methods in the order of its Figure 3,
/// then the two that let a material importance-sample itself (pbrt's
/// `Sample_f` and `PDF`, Mitsuba's `sample` and `pdf`), then the
/// directional albedo a `layer` node weighs what lies beneath by
/// (MaterialX's albedo scaling).
pub const INTERFACE: &[InterfaceMethod] = &[
    InterfaceMethod {
        name: "reflection",
        ret: Ty::Color,
        params: &[("wi", Ty::Vector), ("light", Ty::Color), ("wo", Ty::Vector)],
        default: "black()",
    },
    InterfaceMethod {
        name: "refraction",
        ret: Ty::Color,
        params: &[("wi", Ty::Vector), ("light", Ty::Color), ("eta", Ty::Color), ("wo", Ty::Vector)],
        default: "black()",
    },
    InterfaceMethod { name: "refraction_index", ret: Ty::Color, params: &[], default: "gray(1)" },
    InterfaceMethod {
        name: "reflection_dir",
        ret: Ty::Vector,
        params: &[("wo", Ty::Vector)],
        default: "vector(0) (no mirror reflection)",
    },
    InterfaceMethod {
        name: "refraction_dir",
        ret: Ty::Vector,
        params: &[("wo", Ty::Vector), ("eta", Ty::Color)],
        default: "vector(0) (no refraction)",
    },
    InterfaceMethod { name: "emission", ret: Ty::Color, params: &[("wo", Ty::Vector)], default: "black()" },
    InterfaceMethod { name: "ambient", ret: Ty::Color, params: &[("light", Ty::Color)], default: "light * diffuse()" },
    InterfaceMethod {
        name: "absorption",
        ret: Ty::Color,
        params: &[("light", Ty::Color), ("distance", Ty::Float)],
        default: "light (nothing is absorbed)",
    },
    InterfaceMethod { name: "normal", ret: Ty::Normal, params: &[], default: "N" },
    InterfaceMethod { name: "diffuse", ret: Ty::Color, params: &[], default: "black()" },
    InterfaceMethod { name: "opaque", ret: Ty::Bool, params: &[], default: "true" },
    InterfaceMethod {
        name: "sample",
        ret: Ty::BsdfSample,
        params: &[("wo", Ty::Vector), ("eta", Ty::Color), ("u1", Ty::Float), ("u2", Ty::Vec2)],
        default: "a cosine-distributed direction about normal(), or a delta direction of reflection_dir/refraction_dir, chosen by their weights",
    },
    InterfaceMethod {
        name: "pdf",
        ret: Ty::Float,
        params: &[("wi", Ty::Vector), ("wo", Ty::Vector), ("eta", Ty::Color)],
        default: "the solid-angle density of the default sample",
    },
    InterfaceMethod {
        name: "albedo",
        ret: Ty::Color,
        params: &[("wo", Ty::Vector)],
        default: "estimated from the material's own sample at ALBEDO_SAMPLES fixed points",
    },
];

/// An interface method by name in Rust: the index of its row in
/// [`INTERFACE`] (`Method::Sample as usize`), so hosts, lowering and the
/// renderer never count positions. Its order is checked against
/// `INTERFACE` at compile time (below), so inserting a method in one and
/// not the other does not build.
///
/// ```
/// use tsl::check::{INTERFACE, Method};
/// assert_eq!(Method::Sample.name(), "sample");
/// assert_eq!(Method::Sample.interface().signature(), INTERFACE[Method::Sample as usize].signature());
/// assert_eq!(Method::from_name("pdf"), Some(Method::Pdf));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Method {
    Reflection,
    Refraction,
    RefractionIndex,
    ReflectionDir,
    RefractionDir,
    Emission,
    Ambient,
    Absorption,
    Normal,
    Diffuse,
    Opaque,
    Sample,
    Pdf,
    Albedo,
}

impl Method {
    /// Every method, in the order of [`INTERFACE`].
    pub const ALL: [Method; 14] = [
        Method::Reflection,
        Method::Refraction,
        Method::RefractionIndex,
        Method::ReflectionDir,
        Method::RefractionDir,
        Method::Emission,
        Method::Ambient,
        Method::Absorption,
        Method::Normal,
        Method::Diffuse,
        Method::Opaque,
        Method::Sample,
        Method::Pdf,
        Method::Albedo,
    ];

    /// The method's name in TSL (`reflection_dir`).
    pub const fn name(self) -> &'static str {
        match self {
            Method::Reflection => "reflection",
            Method::Refraction => "refraction",
            Method::RefractionIndex => "refraction_index",
            Method::ReflectionDir => "reflection_dir",
            Method::RefractionDir => "refraction_dir",
            Method::Emission => "emission",
            Method::Ambient => "ambient",
            Method::Absorption => "absorption",
            Method::Normal => "normal",
            Method::Diffuse => "diffuse",
            Method::Opaque => "opaque",
            Method::Sample => "sample",
            Method::Pdf => "pdf",
            Method::Albedo => "albedo",
        }
    }

    /// Its signature and default: its row of [`INTERFACE`].
    pub fn interface(self) -> &'static InterfaceMethod {
        &INTERFACE[self as usize]
    }

    /// The method named `name`, if the interface has one.
    pub fn from_name(name: &str) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.name() == name)
    }
}

/// `Method` and `INTERFACE` agree row by row: checked when the crate
/// builds, so the enum cannot drift from the table.
const _: () = {
    const fn same(a: &str, b: &str) -> bool {
        let (a, b) = (a.as_bytes(), b.as_bytes());
        if a.len() != b.len() {
            return false;
        }
        let mut k = 0;
        while k < a.len() {
            if a[k] != b[k] {
                return false;
            }
            k += 1;
        }
        true
    }
    assert!(Method::ALL.len() == INTERFACE.len(), "one Method per INTERFACE row");
    let mut k = 0;
    while k < INTERFACE.len() {
        assert!(Method::ALL[k] as usize == k, "Method::ALL is in declaration order");
        assert!(same(Method::ALL[k].name(), INTERFACE[k].name), "Method and INTERFACE in the same order");
        k += 1;
    }
};

pub fn interface_method(name: &str) -> Option<&'static InterfaceMethod> {
    INTERFACE.iter().find(|m| m.name == name)
}

impl InterfaceMethod {
    /// The signature as it would be written in TSL.
    pub fn signature(&self) -> String {
        let params: Vec<String> = self.params.iter().map(|(n, t)| format!("{t} {n}")).collect();
        format!("{} {}({})", self.ret, self.name, params.join(", "))
    }
}

/// The read-only shading globals: the surface-point record, then the
/// frame's number and time.
pub const GLOBALS: &[(&str, Ty, &str)] = &[
    ("P", Ty::Point, "hit point, world space"),
    ("Pl", Ty::Point, "hit point, object space"),
    ("N", Ty::Normal, "shading normal"),
    ("Ng", Ty::Normal, "geometric normal"),
    ("u", Ty::Float, "surface parameter u"),
    ("v", Ty::Float, "surface parameter v"),
    ("dPdu", Ty::Vector, "tangent along u"),
    ("dPdv", Ty::Vector, "tangent along v"),
    ("face", Ty::Int, "surface number"),
    ("t", Ty::Float, "ray length"),
    ("dPdx", Ty::Vector, "change of P to the next pixel in x"),
    ("dPdy", Ty::Vector, "change of P to the next pixel in y"),
    ("dudx", Ty::Float, "change of u to the next pixel in x"),
    ("dudy", Ty::Float, "change of u to the next pixel in y"),
    ("dvdx", Ty::Float, "change of v to the next pixel in x"),
    ("dvdy", Ty::Float, "change of v to the next pixel in y"),
    ("frame", Ty::Int, "the frame being rendered (0 unless the render asks for one)"),
    ("time", Ty::Float, "the frame's time in seconds (frame / fps, or the render block's `time`)"),
];

/// The globals that are the same at every point of a frame: besides
/// shading code, constants and scene values may read them.
pub const FRAME_GLOBALS: &[&str] = &["frame", "time"];

/// Whether `name` is a global that is fixed for a whole frame.
pub fn is_frame_global(name: &str) -> bool {
    FRAME_GLOBALS.contains(&name)
}

pub fn global(name: &str) -> Option<Ty> {
    GLOBALS.iter().find(|g| g.0 == name).map(|g| g.1.clone())
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
        assert_eq!(INTERFACE.len(), 14, "the paper's eleven methods, sample, pdf and albedo");
        assert_eq!(interface_method("albedo").unwrap().signature(), "color albedo(vector wo)");
        assert_eq!(
            interface_method("sample").unwrap().signature(),
            "bsdf_sample sample(vector wo, color eta, float u1, vec2 u2)"
        );
    }
}
