//! The scene language: syntax, schemas, resolution, diagnostics and formatting.
pub mod ast;
pub mod diag;
pub mod fmt;
pub mod ir;
pub mod parse;
pub mod resolve;
pub mod schema;
pub mod source;

pub use diag::{Diagnostic, Diagnostics};
pub use ir::{Decl, Props, Scene, Val};
pub use resolve::{compile, normalize, Loader, Options};
pub use schema::KindSpec;
