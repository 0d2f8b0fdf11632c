//! Structure from example ([references: frasson §3]): analysis of a drawn subdivision,
//! anisotropic Lloyd synthesis steered by control maps, polygonisation, shape optimisation.
pub mod associate;
pub mod controls;
pub mod edits;
pub mod ellipse;
pub mod faces;
pub mod format;
pub mod labels_import;
pub mod lloyd;
pub mod metric;
pub mod optimize;
pub mod polygonize;
pub mod render;
pub mod report;
pub mod sample;
pub mod standins;
pub mod stats;
pub mod synthesis;
pub mod turning;
mod types;
pub mod validate;
pub mod voronoi;

pub use format::{parse_structure, to_json, StructureError};
pub use types::*;
