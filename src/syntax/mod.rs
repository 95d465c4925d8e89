//! Text to syntax tree: the logos lexer, the lalrpop parser and the spanned
//! AST. Knows nothing of types.

pub mod ast;
pub mod lexer;
pub mod parser;
mod scene_block;

pub use parser::parse;
