//! Procedural maps: density, masks and orientation fields as [`Image`]s in pixel units.
//!
//! Maps steer synthesis (where detail goes, how dense, which way it flows), so they are
//! plain images the rest of the pipeline already understands. Conventions shared by every
//! builder:
//!
//! - Builders take the output `width, height` and return `Result<Image, MapError>`;
//!   invalid parameters are errors, never panics.
//! - Pixel `(x, y)` is sampled at its centre `(x + 0.5, y + 0.5)`; y points down.
//! - Scalar maps have 1 channel. Orientation fields have 2 channels holding a unit vector
//!   `(cos θ, sin θ)`, θ measured from +x towards +y.
//! - Output is bit-identical for the same inputs whatever rayon's thread count: pixels are
//!   computed independently (parallel over rows), with no cross-thread float reductions.
//!
//! [`Image`]: crate::raster::Image

mod convert;
mod error;
mod fields;
mod noise;
mod ops;
mod render;
mod shapes;

pub use convert::{from_image_scalar, from_image_vector, ChannelSel};
pub use error::MapError;
pub use fields::{linear_orientation, radial_orientation, RadialMode};
pub use noise::{gradient_noise, noise, value_noise, NoiseKind, NoiseParams, MAX_OCTAVES, MAX_PERSISTENCE};
pub use ops::{blur, combine, invert, remap, threshold, CombineOp, MAX_SIGMA};
pub use shapes::{constant, ellipse, linear, polygon, radial, rect};
