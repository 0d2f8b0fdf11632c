//! Raster foundation: planar images, colour spaces, resampling and file I/O.
//!
//! Everything here is pure: codecs work on byte slices and return byte vectors, because
//! the caller reads and writes files through its own content-hashing layer.
pub mod codec;
pub mod color;
mod error;
mod image;
pub mod io;
pub mod resample;

pub(crate) use error::check_layout;
pub use error::RasterError;
pub use image::Image;
pub use io::{decode, encode_exr, encode_png};
pub use resample::{crop, resize, sample, Edge, Filter};
