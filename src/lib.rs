//! TSL: an embeddable shading language for texture trees and generic
//! materials.
//!
//! The front end turns source text into a checked [`check::Program`]:
//! [`load`] reads the root file, its imports and the prelude (the standard
//! library), [`syntax`] parses each into a spanned AST, and [`check`] resolves
//! names and types against the generic color and material interface, and
//! [`scene`] describes the `scene { }` block as checked plain data. Every
//! stage returns diagnostics as data ([`diag::Diagnostic`]); nothing here
//! prints or panics on bad input.
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
    Backend, BsdfSample, Color, Compiler, Error, Function, HitMaterial, MAX_DEBUG_DIAGNOSTICS, Material, PATH_METHODS,
    PreparedHit, Program, SampledDir, WHITTED_METHODS, worth_preparing,
};
pub use color::ColorModel;
pub use globals::ShadingGlobals;
pub use load::LoadOptions;

use diag::{Colors, Diagnostic, Severity};
use std::path::Path;

/// The result of checking a program: the checked program, its scene
/// described (colors in RGB), and every diagnostic, sorted by file and
/// position.
#[derive(Debug, Clone)]
pub struct Checked {
    pub program: check::Program,
    /// The program's `scene { }` block as plain data; `None` without a
    /// scene, or when it (or the rest of the program) has errors.
    pub scene: Option<scene::SceneDesc>,
    pub diagnostics: Vec<Diagnostic>,
}

impl Checked {
    /// True when there are no errors (warnings allowed).
    pub fn is_ok(&self) -> bool {
        !self.diagnostics.iter().any(Diagnostic::is_error)
    }

    pub fn count(&self, severity: Severity) -> usize {
        self.diagnostics.iter().filter(|d| d.severity == severity).count()
    }

    /// The diagnostics as rustc-style text without colours.
    pub fn render_diagnostics(&self) -> String {
        diag::render_text(&self.program.loaded.sources, &self.diagnostics, Colors::Never)
    }
}

/// Loads and checks a program from source text.
pub fn check_source(name: &str, text: &str, options: &LoadOptions) -> Checked {
    check_source_reusing(name, text, options, None)
}

/// [`check_source`], taking the meshes and environment images the scene
/// names from `previous` (an earlier description of the program, whose
/// files have not changed since) instead of reading them again: an
/// editor checks a scene at every pause in typing.
pub fn check_source_reusing(
    name: &str,
    text: &str,
    options: &LoadOptions,
    previous: Option<&scene::SceneDesc>,
) -> Checked {
    let (loaded, diags) = load::load_source(name, text, options);
    finish(loaded, diags, options, previous, &|| false)
}

/// [`check_source_reusing`] that stops between its phases (loading,
/// checking, reading images, describing the scene) once `cancelled()` is
/// true, and then gives `None`: the language server cancels the check of
/// a text that an edit has replaced.
pub fn check_source_cancellable(
    name: &str,
    text: &str,
    options: &LoadOptions,
    previous: Option<&scene::SceneDesc>,
    cancelled: &dyn Fn() -> bool,
) -> Option<Checked> {
    let (loaded, diags) = load::load_source(name, text, options);
    let checked = finish(loaded, diags, options, previous, cancelled);
    (!cancelled()).then_some(checked)
}

/// Loads and checks a program from a file.
pub fn check_file(path: &Path, options: &LoadOptions) -> Checked {
    let (loaded, diags) = load::load_file(path, options);
    finish(loaded, diags, options, None, &|| false)
}

fn finish(
    loaded: load::Loaded,
    mut diagnostics: Vec<Diagnostic>,
    options: &LoadOptions,
    previous: Option<&scene::SceneDesc>,
    cancelled: &dyn Fn() -> bool,
) -> Checked {
    // Type checking a file that did not parse would only add noise.
    let parsed = !diagnostics.iter().any(Diagnostic::is_error);
    let (program, scene) = if parsed && !cancelled() {
        let (mut program, more) = check::check(loaded);
        diagnostics.extend(more);
        if !cancelled() {
            diagnostics.extend(load::load_images(&mut program, options));
        }
        // The scene's values are evaluated, which needs a well-typed
        // program; its files are read once here.
        let scene = if cancelled() || diagnostics.iter().any(Diagnostic::is_error) {
            None
        } else {
            if options.lean {
                let spans = scene::forgettable_spans(&program);
                program.forget_exprs(&spans);
            }
            let (scene, more) = scene::describe(&program, options.color_model, previous);
            diagnostics.extend(more);
            scene
        };
        (program, scene)
    } else {
        (check::Program { loaded, ..Default::default() }, None)
    };
    diagnostics.sort_by_key(|d| (d.span.file, d.span.start, d.span.end));
    diagnostics.dedup();
    Checked { program, scene, diagnostics }
}
