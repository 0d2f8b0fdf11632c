//! Raster foundation: planar images, colour spaces, resampling and file I/O.
mod image;
pub use image::Image;
