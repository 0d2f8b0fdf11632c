//! Structure from example ([references: frasson §3]): analysis of a drawn subdivision,
//! anisotropic Lloyd synthesis steered by control maps, polygonisation, shape optimisation.
//!
//! The folders follow the pipeline, and each one's shipped code imports only folders before it
//! (tests may use any):
//! `mesh` (edges ⇄ faces, labels → mesh) → `analysis` (a sample's ellipses and statistics)
//! → `relaxation` (metric, control maps, Voronoi, Lloyd) → `generation` (ellipses to relax,
//! edits) → `shapes` (stage 2: closest-shape correction). The top-level files are what they
//! all share: the plain data (`types`), the file format, validation and its errors, and the
//! views (`render`). `fixtures` (seeded stand-in samples) is test code, compiled only for
//! tests or with the `fixtures` feature, never into the shipped library.
pub mod analysis;
mod error;
#[cfg(any(test, feature = "fixtures"))]
pub mod fixtures;
pub mod format;
pub mod generation;
pub mod mesh;
pub mod regionmaps;
pub mod relaxation;
pub mod render;
pub mod shapes;
mod types;
pub mod validate;

pub use error::{StructureError, VERTEX_EPS};
pub use format::{parse_structure, to_json};
pub use types::*;
