//! Text to syntax tree: the logos lexer, the lalrpop parser and the spanned
//! AST. Knows nothing of types.

pub mod ast;
mod doc_comment;
pub mod lexer;
pub mod parser;
mod scene_block;

pub use doc_comment::doc_comment;
pub use parser::parse;
