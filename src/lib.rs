//! TSL: an embeddable shading language for texture trees and generic
//! materials.
//!
//! A host compiles a program once, asks what its material templates take,
//! makes instances, and at every ray hit gets a [`Surface`] whose methods
//! (`sample`, `eval_pdf`, `reflection`, `emission`, ...) return typed
//! results; generators are typed functions; both run over many points in
//! one call too ([`ShadingBatch`], [`SurfaceBatch`]):
//!
//! ```
//! use tsl::{ColorModel, Compiler, ShadingGlobals, SurfaceRecord};
//!
//! let src = r#"
//!     float rings(float scale = 8) { return fract(length(vec2(Pl.x, Pl.z)) * scale); }
//!     material wood = mix(rings(), lambert(kd: rgb(0.6, 0.4, 0.2)), lambert(kd: rgb(0.35, 0.2, 0.08)));
//! "#;
//! let program = Compiler::new().color_model(ColorModel::Spectral { samples: 16 }).source("wood.tsl", src).compile()?;
//!
//! // What a template takes, as OSL's oslquery tells.
//! let metal = program.shader("rough_conductor")?;
//! let alpha = metal.param("alpha").expect("rough_conductor has an alpha");
//! assert_eq!(alpha.default_source.as_deref(), Some("0.1"));
//!
//! // An instance, its values checked as they are set; a wrong name is an error.
//! let mut gold = metal.instance();
//! gold.set("alpha", 0.2)?.set("distribution", "ggx")?;
//! assert!(metal.instance().set("alpah", 0.2).is_err());
//! let gold = gold.specialise()?;
//!
//! // At a hit: the surface, seen from `wo`, with typed results.
//! let g = ShadingGlobals { n: [0.0, 0.0, 1.0], ng: [0.0, 0.0, 1.0], pl: [0.1, 0.0, 0.0], ..Default::default() };
//! let eta = program.rgb(1.0, 1.0, 1.0);
//! let mut record = SurfaceRecord::new();
//! for material in [program.material("wood")?, gold] {
//!     let mut surface = material.at(&g, [0.0, 0.0, 1.0], &eta, &mut record);
//!     let s = surface.sample(0.5, [0.3, 0.7]);
//!     let e = surface.eval_pdf(s.wi);
//!     assert!(s.pdf > 0.0 && (e.pdf - s.pdf).abs() <= 1e-3 * s.pdf);
//!     assert!(s.weight.to_rgb().iter().all(|c| c.is_finite() && *c >= 0.0));
//! }
//!
//! // A generator, its signature checked once.
//! let rings = program.typed_function::<(f32,), f32>("rings")?;
//! assert!((0.0..1.0).contains(&rings.call(&g, (8.0,))));
//!
//! // Many points in one call: globals and arguments as columns.
//! let pl = [[0.1, 0.0, 0.0], [0.2, 0.0, 0.0], [0.3, 0.0, 0.0f32]];
//! let mut points = tsl::ShadingBatch::with_base(3, g);
//! points.set_vectors("Pl", &pl)?;
//! let values = rings.call_batch_uniform(&points, (8.0,))?;
//! assert_eq!(values[1], rings.call(&points.point(1), (8.0,)));
//! let wo = tsl::Column::uniform_vector([0.0, 0.0, 1.0]);
//! let albedo = program.material("wood")?.at_batch(&points, wo, &tsl::Column::uniforms(eta.lanes()))?.diffuse()?;
//! assert_eq!(albedo.len(), 3);
//! # Ok::<(), tsl::Error>(())
//! ```
//!
//! A host built in the dev profile should optimise this crate and Cranelift
//! anyway (`[profile.dev.package.tsl] opt-level = 3`, and the same for
//! `cranelift-codegen`): unoptimised, compiling a material is about 50x slower.
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
pub mod capi;
pub mod check;
pub mod color;
pub mod diag;
mod driver;
pub mod files;
pub mod format;
pub mod globals;
pub mod image_io;
pub mod input_file;
mod interp;
mod ir;
mod jit;
pub mod load;
pub mod lsp;
pub mod noise;
pub mod render;
mod runtime;
pub mod scene;
pub mod syntax;
#[cfg(test)]
mod test_support;
pub mod texture;

pub use api::{
    Backend, BsdfSample, Color, Compiler, DeltaLobe, DeltaLobes, Error, EvalPdf, Function, HitCalls, HitMaterial,
    HitMethod, Lanes, MAX_BOUND_COMBINATIONS, MAX_DEBUG_DIAGNOSTICS, Material, MaterialFacts, MaterialSource,
    PATH_METHODS, PreparedHit, Program, SampledDir, Surface, SurfaceOptions, SurfaceRecord, TslParams, TslType,
    TypedFunction, WHITTED_METHODS, WordType,
};
pub use api::{
    ColorBatch, Column, DeltaLobesBatch, EvalPdfBatch, Layout, MAX_BATCH_WORDS, SampleBatch, ShadingBatch, SurfaceBatch,
};
pub use api::{Instance, ParamInfo, ParamType, ParamValue, Shader};
pub use color::ColorModel;
pub use driver::{Checked, check_file, check_source, check_source_cancellable, check_source_reusing};
pub use globals::ShadingGlobals;
pub use interp::OpCounts;
pub use load::LoadOptions;

// The user guide's Rust page and the README: their ```rust blocks compile and
// run as doctests (tests/book.rs checks every page with one is listed here).
#[cfg(doctest)]
#[doc = include_str!("../docs/book/src/embedding/rust.md")]
struct GuideEmbeddingRust;
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct Readme;
