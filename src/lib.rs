//! tessera: a compiler for example-driven surface detail.
//!
//! `lang` turns scene text into a typed scene; `kinds` plans it into a `graph` of cached
//! stages; `synth` holds the algorithms as pure functions; `raster` the pixels; `golden`
//! the comparisons; `project` ties them into the commands the CLI offers.
pub mod golden;
pub mod graph;
pub mod kinds;
pub mod lang;
pub mod project;
pub mod raster;
pub mod synth;
