//! TSL: an embeddable shading language for texture trees and generic materials.
#![cfg_attr(not(test), warn(clippy::panic, clippy::print_stdout, clippy::print_stderr, clippy::todo))]

pub mod diag;
pub mod syntax;
