//! TSL: an embeddable shading language for texture trees and generic
//! materials.
//!
//! The front end turns source text into a [`Checked`] program, in stages
//! that each read only what the ones before made ([`check_source`] and
//! [`check_file`] run them): [`load`] reads the root file, its imports and
//! the prelude (the standard library), [`syntax`] parses each into a
//! spanned AST, [`check`] resolves names and types against the generic
//! color and material interface (no I/O), the images stage loads the
//! images `texture` calls name through a [`texture::TextureManager`], and
//! [`scene`] describes the `scene { }` block as checked plain data. Every
//! stage returns diagnostics as data ([`diag::Diagnostic`]); nothing here
//! prints or panics on bad input. A [`Compiler`] then lowers and compiles
//! the checked program into a [`Program`] of native functions.
//!
//! ```
//! let src = r#"
//!     float rings(float scale = 8) { return fract(length(vec2(Pl.x, Pl.z)) * scale); }
//!     material wood = mix(rings(), phong(kd: rgb(0.6, 0.4, 0.2)), phong(kd: rgb(0.35, 0.2, 0.08)));
//! "#;
//! let checked = tsl::check_source("wood.tsl", src, &tsl::LoadOptions::default());
//! assert!(checked.is_ok(), "{}", checked.render_diagnostics());
//! ```
#![cfg_attr(not(test), warn(clippy::panic, clippy::print_stdout, clippy::print_stderr, clippy::todo))]

mod api;
pub mod check;
pub mod color;
pub mod diag;
mod driver;
pub mod files;
pub mod format;
pub mod globals;
pub mod image_io;
pub mod input_file;
pub mod interp;
pub mod ir;
pub mod jit;
pub mod load;
pub mod lsp;
pub mod render;
pub mod runtime;
pub mod scene;
pub mod syntax;
#[cfg(test)]
mod test_support;
pub mod texture;

pub use api::{
    Backend, BsdfSample, Color, Compiler, DeltaLobe, DeltaLobes, Error, EvalPdf, Function, HitCalls, HitMaterial,
    Lanes, MAX_BOUND_COMBINATIONS, MAX_DEBUG_DIAGNOSTICS, Material, MaterialFacts, MaterialSource, PATH_METHODS,
    PreparedHit, Program, SampledDir, Surface, SurfaceOptions, SurfaceRecord, TslParams, TslType, TypedFunction,
    WHITTED_METHODS, worth_preparing,
};
pub use api::{Instance, ParamInfo, ParamType, ParamValue, Shader};
pub use color::ColorModel;
pub use driver::{Checked, check_file, check_source, check_source_cancellable, check_source_reusing};
pub use globals::ShadingGlobals;
pub use load::LoadOptions;
