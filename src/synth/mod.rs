//! The algorithms: pure functions on plain data. No file I/O, no cache, no graph.
pub mod appearance;
pub mod blend;
pub mod fft;
pub mod library;
pub mod map;
pub mod matching;
pub mod mesh;
pub mod metrics;
pub mod noise;
pub mod progress;
pub mod quilt;
pub mod relief;
pub mod relight;
pub mod render;
pub mod rng;
pub mod shader;
pub mod structure;
pub mod surface;

pub use progress::Progress;
