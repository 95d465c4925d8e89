//! [`Error`]: what compiling or describing a program can fail with, and
//! its two faces, the diagnostics rendered for people (`Display`) and a
//! short list of messages and locations for logs and `?` in `main`
//! (`Debug`).

use crate::diag::{Colors, Diagnostic, SourceMap, render_text};
use std::fmt;

/// A compile error: the diagnostics and the sources they point into.
///
/// `Display` renders every diagnostic as rustc does (the source line
/// quoted, carets, help). `Debug`, which `fn main() -> Result<_, Error>`
/// prints on `?`, is one line per diagnostic, `file:line:col: error:
/// message`, and never the sources (a program's prelude is about 120 KB):
///
/// ```
/// let err = tsl::Compiler::new().source("m.tsl", "material m = lamberd;").compile().unwrap_err();
/// let debug = format!("{err:?}");
/// assert!(debug.contains("m.tsl:1:14: error: "), "{debug}");
/// assert!(debug.len() < 200, "{debug}");
/// ```
#[derive(Clone)]
pub struct Error {
    pub diagnostics: Vec<Diagnostic>,
    /// The program's sources, which the diagnostics point into.
    pub(crate) sources: SourceMap,
}

/// The most diagnostics an [`Error`]'s `Debug` lists; past them it counts
/// the rest (`Display` shows up to
/// [`MAX_DIAGNOSTICS_PER_FILE`](crate::diag::MAX_DIAGNOSTICS_PER_FILE) per
/// file).
pub const MAX_DEBUG_DIAGNOSTICS: usize = 10;

impl Error {
    pub(crate) fn plain(message: String) -> Error {
        let mut sources = SourceMap::new();
        let file = sources.add(crate::diag::UNLOCATED, "");
        Error { diagnostics: vec![Diagnostic::error(crate::diag::Span::new(file, 0, 0), message)], sources }
    }
}

impl Error {
    /// Where `d` (one of [`Error::diagnostics`]) points: the file's name as
    /// the program was given it, and the 1-based line and column (in
    /// characters); `None` for an error about no source text. Hosts that
    /// show errors their own way (a Python exception's fields, a C
    /// struct) read it field by field.
    ///
    /// ```
    /// let err = tsl::Compiler::new().source("m.tsl", "material m = lamberd;").compile().unwrap_err();
    /// assert_eq!(err.location(&err.diagnostics[0]), Some(("m.tsl", 1, 14)));
    /// ```
    pub fn location(&self, d: &Diagnostic) -> Option<(&str, usize, usize)> {
        let name = self.sources.name(d.span.file);
        if name == crate::diag::UNLOCATED && self.sources.text(d.span.file).is_empty() {
            return None;
        }
        let (line, col) = self.sources.line_col(d.span.file, d.span.start);
        Some((name, line, col))
    }

    /// `file:line:col: error: message` (without a location for an error
    /// about no source text), control characters escaped by `Debug`.
    fn located_message(&self, d: &Diagnostic) -> String {
        let severity = if d.is_error() { "error" } else { "warning" };
        match self.location(d) {
            Some((name, line, col)) => format!("{name}:{line}:{col}: {severity}: {}", d.message),
            None => format!("{severity}: {}", d.message),
        }
    }
}

impl fmt::Debug for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("Error ")?;
        let mut list = f.debug_list();
        for d in self.diagnostics.iter().take(MAX_DEBUG_DIAGNOSTICS) {
            list.entry(&self.located_message(d));
        }
        let more = self.diagnostics.len().saturating_sub(MAX_DEBUG_DIAGNOSTICS);
        if more > 0 {
            list.entry(&format_args!("... {more} more"));
        }
        list.finish()
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&render_text(&self.sources, &self.diagnostics, Colors::Never))
    }
}

impl std::error::Error for Error {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Compiler;

    /// Two errors in a program that also loads the whole prelude.
    const BAD: &str = "material m = lamberd;\nfloat f() { return undefined_name; }\n";

    fn bad_program() -> Error {
        Compiler::new().source("bad.tsl", BAD).compile().expect_err("the program has errors")
    }

    #[test]
    fn debug_lists_locations_and_messages_without_sources() {
        let err = bad_program();
        assert_eq!(err.diagnostics.len(), 2);
        let debug = format!("{err:?}");
        expect_test::expect![[r#"Error ["bad.tsl:1:14: error: cannot find value `lamberd` in this scope", "bad.tsl:2:20: error: cannot find value `undefined_name` in this scope"]"#]]
            .assert_eq(&debug);
        // The prelude is in the sources: `Display` would quote none of it
        // here, `Debug` used to print all of it.
        let sources: usize =
            (0..err.sources.len()).map(|i| err.sources.text(crate::diag::FileId(i as u32)).len()).sum();
        assert!(sources > 50_000, "the prelude is {sources} bytes");
        assert!(format!("{err:#?}").len() < 300);
    }

    #[test]
    fn display_renders_diagnostics_as_before() {
        expect_test::expect![[r#"
            error: cannot find value `lamberd` in this scope
              ┌─ bad.tsl:1:14
              │
            1 │ material m = lamberd;
              │              ^^^^^^^
              │
              = help: did you mean `lambert`?

            error: cannot find value `undefined_name` in this scope
              ┌─ bad.tsl:2:20
              │
            2 │ float f() { return undefined_name; }
              │                    ^^^^^^^^^^^^^^

        "#]]
        .assert_eq(&bad_program().to_string());
    }

    #[test]
    fn debug_counts_diagnostics_past_its_bound() {
        let source: String =
            (0..MAX_DEBUG_DIAGNOSTICS + 5).map(|i| format!("float f{i}() {{ return nope; }}\n")).collect();
        let err = Compiler::new().source("many.tsl", &source).compile().expect_err("errors");
        let debug = format!("{err:?}");
        assert_eq!(debug.matches("cannot find value `nope`").count(), MAX_DEBUG_DIAGNOSTICS, "{debug}");
        assert!(debug.contains("many.tsl:10:"), "{debug}");
        assert!(debug.ends_with(", ... 5 more]"), "{debug}");
    }

    #[test]
    fn debug_of_an_unlocated_error_is_its_message() {
        let err = Compiler::new().compile().expect_err("no source");
        assert_eq!(format!("{err:?}"), r#"Error ["error: no source given to the compiler"]"#);
        assert_eq!(err.to_string(), "error: no source given to the compiler\n");
    }
}
