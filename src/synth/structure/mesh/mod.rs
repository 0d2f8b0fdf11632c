//! Converting between a structure's representations: faces from an edge graph (and back),
//! and a watertight mesh from a label raster.
pub mod faces;
pub mod polygonize;
