//! Structure from example (Frasson ch. 3; digest 004 §2): analysis of a drawn subdivision,
//! anisotropic Lloyd synthesis steered by control maps, polygonisation, shape optimisation.
pub mod render;
mod types;
pub use types::*;
