//! The C ABI: opaque handles over the embedding API for C and C++ hosts,
//! declared to them by `include/tsl.h` (generated from these files by
//! cbindgen; `tests/c_header.rs` fails when the checked-in header is stale).
//!
//! Invariants every function here keeps:
//! - No panic crosses the boundary: each body runs inside
//!   [`std::panic::catch_unwind`] ([`guard`]) and a panic becomes
//!   `TslStatus::TSL_PANIC` with its message in the error handle.
//! - Bad input is an error status, never undefined behaviour we could
//!   check: null pointers, strings that are not UTF-8, color buffers of the
//!   wrong number of lanes. (Dangling pointers and short buffers cannot be
//!   checked; the header states what each pointer must point at.)
//! - Strings in are a pointer and a byte length, never assumed
//!   NUL-terminated; strings out are `TslStr`s owned by the handle they
//!   came from, valid until it is freed.
//!
//! This module is, with `jit`, the only place of `unsafe` code: reading
//! the caller's pointers. Each block says why it is sound.

// Every function taking a pointer is `unsafe` for Rust callers: the
// caller vouches for what it points at. Each checks null before reading,
// and the header (this module's docs) states what each pointer must point
// at; a `# Safety` section per function would repeat it.
#![allow(clippy::missing_safety_doc)]

mod batch;
mod error;
mod instance;
mod program;
mod render;
mod surface;

pub use batch::*;
pub use error::*;
pub use instance::*;
pub use program::*;
pub use render::*;
pub use surface::*;

use crate::Error;
use std::ffi::c_char;
use std::panic::{AssertUnwindSafe, catch_unwind};

/// What a call returned. Every function that can fail returns one and, on
/// failure, fills its `error` out-parameter (when it is not null) with a
/// new `TslError` the caller frees with `tsl_error_free`.
#[repr(C)]
#[allow(non_camel_case_types)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TslStatus {
    /// Success; `*error` is left untouched.
    TSL_OK = 0,
    /// The program or a value was wrong (a compile error, an unknown
    /// shader or parameter, a value of the wrong type, a bad scene): the
    /// error's diagnostics say where.
    TSL_ERROR = 1,
    /// An argument broke the call's contract: a null pointer, a string
    /// that is not UTF-8, a buffer of the wrong length.
    TSL_INVALID_ARGUMENT = 2,
    /// A render stopped because its progress callback returned false.
    TSL_CANCELLED = 3,
    /// A bug in TSL, caught before it could unwind into the caller; the
    /// error's message is the panic's. Please report it.
    TSL_PANIC = 4,
}

/// A UTF-8 string owned by a TSL handle: `len` bytes at `ptr`, not
/// NUL-terminated (print it with `printf("%.*s", (int)s.len, s.ptr)`).
/// Valid until the handle it came from is freed. An absent string is
/// `{NULL, 0}`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct TslStr {
    pub ptr: *const c_char,
    pub len: usize,
}

impl TslStr {
    pub(crate) const NONE: TslStr = TslStr { ptr: std::ptr::null(), len: 0 };

    pub(crate) fn of(s: &str) -> TslStr {
        TslStr { ptr: s.as_ptr().cast(), len: s.len() }
    }

    pub(crate) fn of_option(s: Option<&str>) -> TslStr {
        s.map_or(TslStr::NONE, TslStr::of)
    }
}

/// Why a call failed, before it becomes a `TslError`.
pub(crate) enum Failure {
    /// A `tsl::Error`: `TslStatus::TSL_ERROR`.
    Tsl(Error),
    /// `TslStatus::TSL_INVALID_ARGUMENT`.
    Invalid(String),
    /// `TslStatus::TSL_CANCELLED`.
    Cancelled(String),
}

impl From<Error> for Failure {
    fn from(e: Error) -> Failure {
        Failure::Tsl(e)
    }
}

pub(crate) type Outcome<T = ()> = Result<T, Failure>;

pub(crate) fn invalid<T>(message: impl Into<String>) -> Outcome<T> {
    Err(Failure::Invalid(message.into()))
}

/// Runs `body` with panics caught; a failure (or panic) becomes its status
/// and, when `error` is not null, a new error handle in `*error`.
pub(crate) fn guard(error: *mut *mut TslError, body: impl FnOnce() -> Outcome) -> TslStatus {
    let (status, e) = match catch_unwind(AssertUnwindSafe(body)) {
        Ok(Ok(())) => return TslStatus::TSL_OK,
        Ok(Err(Failure::Tsl(e))) => (TslStatus::TSL_ERROR, e),
        Ok(Err(Failure::Invalid(m))) => (TslStatus::TSL_INVALID_ARGUMENT, Error::plain(m)),
        Ok(Err(Failure::Cancelled(m))) => (TslStatus::TSL_CANCELLED, Error::plain(m)),
        Err(payload) => {
            (TslStatus::TSL_PANIC, Error::plain(format!("internal error (a bug in TSL): {}", panic_message(&*payload))))
        }
    };
    if !error.is_null() {
        // SAFETY: the caller gives either null (checked above) or a
        // pointer to a writable `TslError *`.
        unsafe { *error = TslError::new_raw(status, e) };
    }
    status
}

/// Runs `body`, which cannot fail but for a bug, with panics caught: a
/// panic gives `fallback` (accessors: lengths, names).
pub(crate) fn guard_value<T>(fallback: T, body: impl FnOnce() -> T) -> T {
    catch_unwind(AssertUnwindSafe(body)).unwrap_or(fallback)
}

fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "a panic without a message".to_string()
    }
}

/// The string of `len` bytes at `ptr` (null only with `len` 0), checked
/// to be UTF-8; `what` names it in errors.
pub(crate) fn str_arg<'a>(ptr: *const c_char, len: usize, what: &str) -> Outcome<&'a str> {
    let bytes = slice_arg(ptr.cast::<u8>(), len, what)?;
    std::str::from_utf8(bytes).or_else(|e| invalid(format!("`{what}` is not UTF-8: {e}")))
}

/// The `len` values at `ptr` (null only with `len` 0).
pub(crate) fn slice_arg<'a, T>(ptr: *const T, len: usize, what: &str) -> Outcome<&'a [T]> {
    if len == 0 {
        return Ok(&[]);
    }
    if ptr.is_null() {
        return invalid(format!("`{what}` is null with a length of {len}"));
    }
    if len.checked_mul(size_of::<T>()).is_none_or(|b| b > isize::MAX as usize) {
        return invalid(format!("`{what}` has an impossible length of {len}"));
    }
    // SAFETY: non-null, and the caller promises `len` readable values
    // there (the header's contract); the size fits in an isize.
    Ok(unsafe { std::slice::from_raw_parts(ptr, len) })
}

/// The `len` values at `ptr`, writable (null only with `len` 0).
pub(crate) fn slice_out<'a, T>(ptr: *mut T, len: usize, what: &str) -> Outcome<&'a mut [T]> {
    if len == 0 {
        return Ok(&mut []);
    }
    if ptr.is_null() {
        return invalid(format!("`{what}` is null with a length of {len}"));
    }
    if len.checked_mul(size_of::<T>()).is_none_or(|b| b > isize::MAX as usize) {
        return invalid(format!("`{what}` has an impossible length of {len}"));
    }
    // SAFETY: non-null, and the caller promises `len` writable values
    // there that nothing else reads during the call.
    Ok(unsafe { std::slice::from_raw_parts_mut(ptr, len) })
}

/// The handle behind `ptr`, or an error naming `what` when it is null.
pub(crate) fn handle<'a, T>(ptr: *const T, what: &str) -> Outcome<&'a T> {
    // SAFETY: a non-null handle pointer came from this library's
    // `Box::into_raw` and has not been freed (the header's contract).
    unsafe { ptr.as_ref() }.map_or_else(|| invalid(format!("`{what}` is null")), Ok)
}

/// The handle behind `ptr`, mutable.
pub(crate) fn handle_mut<'a, T>(ptr: *mut T, what: &str) -> Outcome<&'a mut T> {
    // SAFETY: as `handle`; the header says a handle written through must
    // not be used from another thread at the same time.
    unsafe { ptr.as_mut() }.map_or_else(|| invalid(format!("`{what}` is null")), Ok)
}

/// Stores a new handle in `*out`.
pub(crate) fn put<T>(out: *mut *mut T, value: T, what: &str) -> Outcome {
    if out.is_null() {
        return invalid(format!("`{what}` is null"));
    }
    // SAFETY: non-null, and the caller gives a writable `T *`.
    unsafe { *out = Box::into_raw(Box::new(value)) };
    Ok(())
}

/// Writes `value` to `*out` (a plain out-parameter).
pub(crate) fn write<T>(out: *mut T, value: T, what: &str) -> Outcome {
    if out.is_null() {
        return invalid(format!("`{what}` is null"));
    }
    // SAFETY: non-null, and the caller gives a writable `T`.
    unsafe { out.write(value) };
    Ok(())
}

/// Frees a handle made by `put` (null is ignored), panics caught.
pub(crate) fn free<T>(ptr: *mut T) {
    if !ptr.is_null() {
        // SAFETY: `ptr` came from `Box::into_raw` in `put` and is freed
        // once (the header's contract).
        let boxed = unsafe { Box::from_raw(ptr) };
        guard_value((), move || drop(boxed));
    }
}

/// The three floats at `ptr`.
pub(crate) fn vec3_arg(ptr: *const f32, what: &str) -> Outcome<[f32; 3]> {
    let s = slice_arg(ptr, 3, what)?;
    Ok([s[0], s[1], s[2]])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_becomes_an_error_status_not_an_unwind() {
        let mut error = std::ptr::null_mut();
        let status = guard(&mut error, || panic!("a bug"));
        assert_eq!(status, TslStatus::TSL_PANIC);
        // SAFETY: the handle `guard` made, freed once.
        unsafe {
            let message = tsl_error_message(error);
            let text = std::str::from_utf8(std::slice::from_raw_parts(message.ptr.cast::<u8>(), message.len));
            assert_eq!(text, Ok("error: internal error (a bug in TSL): a bug\n"));
            tsl_error_free(error);
        }
        assert_eq!(guard_value(7, || panic!("a bug")), 7);
    }
}
