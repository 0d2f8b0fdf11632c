//! tessera: a compiler for example-driven surface detail.
//!
//! `lang` turns scene text into a typed scene; `kinds` plans it into a `graph` of cached
//! stages; `synth` holds the algorithms as pure functions; `raster` the pixels; `golden`
//! the comparisons; `project` ties them into the commands the CLI offers.
//!
//! The library API is what the `tessera` binary calls: open the repository a directory
//! belongs to, build a scene (every stage cached under the project's cache directory),
//! then write its outputs, all at once or not at all.
//!
//! ```
//! use tessera::project::Project;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let dir = tempfile::tempdir()?;
//! std::fs::write(
//!     dir.path().join("ramp.tess"),
//!     r#"
//!     scene { size = 64 x 32 }
//!     map ramp { from = linear(from = [0, 0], to = [scene.width, 0]) }
//!     output "ramp.png" { from = ramp }
//!     "#,
//! )?;
//!
//! let mut project = Project::open(dir.path())?;
//! project.progress = false;
//! let built = project.build(&dir.path().join("ramp.tess"))?;
//! assert_eq!(built.name, "ramp");
//! for (output, bytes) in &built.outputs {
//!     println!("{}: {} bytes", output.name, bytes.0.len());
//! }
//!
//! let written = project.emit(&built)?;
//! assert!(written.iter().all(|e| e.path.exists()));
//! assert!(dir.path().join("out/ramp/ramp.png").exists());
//! # Ok(())
//! # }
//! ```
pub mod golden;
pub mod graph;
pub mod kinds;
pub mod lang;
pub mod project;
pub mod raster;
pub mod synth;
