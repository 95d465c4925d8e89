//! The front end's driver: source text to a [`Checked`] program, stage by
//! stage.
//!
//! ```text
//! load ──▶ check ──▶ images ──▶ scene::describe
//! ```
//!
//! [`load`](crate::load) reads the root, its imports and the prelude and
//! parses each; [`check`](crate::check) resolves names and types (no I/O);
//! [`images`] loads the images the checked program's `texture` calls name;
//! [`scene::describe`] evaluates the scene block and reads its meshes and
//! environment images. Each stage only reads what the ones before it made,
//! and no module of a stage imports a later one. A stage that follows an
//! error is skipped (type checking a file that did not parse would only add
//! noise), and every stage returns diagnostics as data.

mod images;

use crate::diag::{self, Colors, Diagnostic, Severity};
use crate::load::{self, LoadOptions};
use crate::{check, scene};
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

    /// The number of diagnostics of one severity.
    pub fn count(&self, severity: Severity) -> usize {
        self.diagnostics.iter().filter(|d| d.severity == severity).count()
    }

    /// The diagnostics as rustc-style text without colours.
    pub fn render_diagnostics(&self) -> String {
        diag::render_text(&self.program.loaded.sources, &self.diagnostics, Colors::Never)
    }
}

/// Loads and checks a program from source text.
///
/// ```
/// let checked = tsl::check_source("m.tsl", "material m = lamberd;", &tsl::LoadOptions::default());
/// assert_eq!(checked.count(tsl::diag::Severity::Error), 1);
/// assert!(checked.render_diagnostics().contains("m.tsl:1:14"));
/// ```
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

/// [`check_source_reusing`] that stops between its stages (loading,
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

/// The stages after loading: check, images, scene.
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
            diagnostics.extend(images::load_images(&mut program, options));
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// The stages depend one way, checked on the sources: loading knows
    /// nothing of checking, and checking nothing of the stages after it
    /// (the images stage and this driver) nor of the texture manager.
    #[test]
    fn stages_depend_one_way() {
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
        let rules: [(&str, &[&str]); 2] = [
            ("load.rs", &["crate::check", "check::", "crate::driver", "images::"]),
            ("check", &["crate::driver", "images::", "load_images", "TextureManager", "crate::check_"]),
        ];
        for (place, forbidden) in rules {
            let path = src.join(place);
            let files: Vec<_> = if path.is_dir() {
                std::fs::read_dir(&path).unwrap().map(|e| e.unwrap().path()).collect()
            } else {
                vec![path]
            };
            assert!(!files.is_empty());
            for file in files {
                let text = std::fs::read_to_string(&file).unwrap();
                for f in forbidden {
                    assert!(!text.contains(f), "{} mentions `{f}`", file.display());
                }
            }
        }
    }

    /// Each stage runs after the one before it, on its output: a syntax
    /// error stops checking, a type error stops the scene's description,
    /// and images are loaded from a checked program.
    #[test]
    fn a_stage_that_follows_an_error_is_skipped() {
        let options = LoadOptions::default();
        let scene = "scene { camera { from (0, 1, -4); to (0, 1, 0); } }";
        let syntax_error = check_source("a.tsl", &format!("float f( {{ return 1; }}\n{scene}"), &options);
        assert!(!syntax_error.is_ok());
        assert!(syntax_error.program.symbols.is_empty(), "checked after a syntax error");
        let type_error = check_source("b.tsl", &format!("float f() {{ return nope; }}\n{scene}"), &options);
        assert_eq!(type_error.count(Severity::Error), 1, "{}", type_error.render_diagnostics());
        assert!(type_error.scene.is_none(), "a scene described after a type error");
        let clean = check_source("c.tsl", &format!("float f() {{ return 1; }}\n{scene}"), &options);
        assert!(clean.is_ok() && clean.scene.is_some(), "{}", clean.render_diagnostics());
        let missing_image =
            check_source("d.tsl", "color c() { return texture(\"no-such.png\", (0.5, 0.5)); }", &options);
        let text = missing_image.render_diagnostics();
        assert!(text.contains("cannot find the image `no-such.png`") && text.contains("d.tsl:1:"), "{text}");
    }

    #[test]
    fn a_cancelled_check_gives_nothing() {
        let options = LoadOptions::default();
        assert!(check_source_cancellable("m.tsl", "material m = lambert;", &options, None, &|| true).is_none());
        let checked = check_source_cancellable("m.tsl", "material m = lambert;", &options, None, &|| false);
        assert!(checked.is_some_and(|c| c.is_ok()));
    }
}
