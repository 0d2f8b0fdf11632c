//! Golden-file comparison: decides whether a rendered output matches its reference and
//! draws a picture of where it does not. Pure functions on [`Image`]s; the CLI's `check`
//! command does the file handling.
//!
//! [`Image`]: crate::raster::Image
mod compare;
mod diff;

pub use compare::{compare, Comparison, Tolerance};
pub use diff::diff_image;

mod lines;
pub use lines::{is_line_art, two_colour_diff, Marks, ADDED, CHANGED, REMOVED};

mod text;
pub use text::{compare_text, TextComparison};

mod mesh;
pub use mesh::mesh_difference;
