pub mod graph;
pub mod lang;
pub mod raster;
