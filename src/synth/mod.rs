//! The algorithms: pure functions on plain data. No file I/O, no cache, no graph.
pub mod map;
pub mod quilt;
pub mod rng;
pub mod structure;
pub mod surface;
