//! Tests that read the IR itself (operation counts, tables, function
//! shapes): they live in the crate because `ir` is not public API.

mod bounded;
mod deep_chain;
mod lowering;
mod scene_constants;
