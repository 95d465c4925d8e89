//! `TslError`: why a call failed, as the rustc-style text and as
//! diagnostics read field by field (file, line, column, message).

use super::{TslStatus, TslStr, guard_value};
use crate::Error;

/// A failed call's error: made by the library on failure, freed by the
/// caller with `tsl_error_free`. Immutable: readable from any thread.
pub struct TslError {
    status: TslStatus,
    /// The rustc-style text, followed by a NUL byte not counted in its
    /// `TslStr`.
    message: String,
    diagnostics: Vec<DiagnosticText>,
}

struct DiagnosticText {
    /// Empty for a diagnostic about no source text.
    file: String,
    line: u32,
    column: u32,
    message: String,
    is_error: bool,
}

/// One diagnostic of a `TslError`; its strings are owned by the error.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct TslDiagnostic {
    /// The file as the user named it (`{NULL, 0}` for an error about no
    /// source, such as a bad argument).
    pub file: TslStr,
    /// 1-based line and column (characters), 0 when there is no file.
    pub line: u32,
    pub column: u32,
    /// The message alone, without location or severity.
    pub message: TslStr,
    /// An error (true) or a warning.
    pub is_error: bool,
}

impl TslError {
    pub(crate) fn new_raw(status: TslStatus, e: Error) -> *mut TslError {
        let diagnostics = e
            .diagnostics
            .iter()
            .map(|d| {
                let name = e.sources.name(d.span.file);
                let unlocated = name == crate::diag::UNLOCATED && e.sources.text(d.span.file).is_empty();
                let (file, (line, column)) = if unlocated {
                    (String::new(), (0, 0))
                } else {
                    (name.to_string(), e.sources.line_col(d.span.file, d.span.start))
                };
                let clamp = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
                DiagnosticText {
                    file,
                    line: clamp(line),
                    column: clamp(column),
                    message: d.message.clone(),
                    is_error: d.is_error(),
                }
            })
            .collect();
        let mut message = e.to_string();
        message.push('\0');
        Box::into_raw(Box::new(TslError { status, message, diagnostics }))
    }
}

/// Frees an error (null is ignored). Call once per error handle.
/// Threads: not while another call uses the handle.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_error_free(error: *mut TslError) {
    super::free(error);
}

/// The status of the call that made `error` (`TSL_OK` for null).
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_error_status(error: *const TslError) -> TslStatus {
    guard_value(TslStatus::TSL_OK, || super::handle(error, "error").map_or(TslStatus::TSL_OK, |e| e.status))
}

/// The whole error as rustc renders it: each diagnostic as
/// `error: message`, its location `file:line:col`, the source line and
/// carets (UTF-8 box-drawing characters frame them).
/// Owned by `error`; also NUL-terminated (the NUL not counted in `len`).
/// `{NULL, 0}` for a null error.
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_error_message(error: *const TslError) -> TslStr {
    guard_value(TslStr::NONE, || {
        super::handle(error, "error").map_or(TslStr::NONE, |e| TslStr::of(&e.message[..e.message.len() - 1]))
    })
}

/// The number of diagnostics in `error` (0 for null).
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_error_diagnostic_count(error: *const TslError) -> usize {
    guard_value(0, || super::handle(error, "error").map_or(0, |e| e.diagnostics.len()))
}

/// Diagnostic `index` of `error` (below `tsl_error_diagnostic_count`);
/// false, leaving `*out` untouched, for a null argument or an index past
/// the end.
/// Thread-safe.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn tsl_error_diagnostic(error: *const TslError, index: usize, out: *mut TslDiagnostic) -> bool {
    guard_value(false, || {
        let Ok(e) = super::handle(error, "error") else { return false };
        let Some(d) = e.diagnostics.get(index) else { return false };
        let diagnostic = TslDiagnostic {
            file: if d.file.is_empty() { TslStr::NONE } else { TslStr::of(&d.file) },
            line: d.line,
            column: d.column,
            message: TslStr::of(&d.message),
            is_error: d.is_error,
        };
        super::write(out, diagnostic, "out").is_ok()
    })
}
