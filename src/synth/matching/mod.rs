//! Procedural texture matching by example ([references: bourque §4]): given a target image,
//! find the library shader and the parameters that reproduce it.
//!
//! ```text
//! shader + search space ─► catalogue (adaptive random sampling; cached per shader)
//! target ─► feature ─► screen (small subsets) ─► scan (whole catalogues) ─► seeds
//!        ─► bounded simplex (or gradient) per seed (fresh renders) ─► integer sweep ─► match record
//! ```
//!
//! - [`space`]: which parameters a search moves, normalised to the unit cube;
//! - [`probe`]: the metric's features and similarity, and renders of a space's points;
//! - [`catalogue`]: Eqs. 4.2–4.5, generic over what it samples;
//! - [`simplex`]: the bounded Nelder–Mead;
//! - [`gradient`]: bounded conjugate gradients on finite differences, the alternative;
//! - [`search`]: screening, scan, refinement and the residual status;
//! - [`path`], [`jump`], [`transform`](mod@transform): transformations between textures
//!   ([references: bourque §ch5]): p-norm paths over catalogue graphs, jump points between
//!   shaders, midpoint subdivision and frame times.

pub mod catalogue;
pub mod gradient;
pub mod jump;
pub mod path;
pub mod probe;
pub mod search;
pub mod simplex;
pub mod space;
pub mod transform;

pub use catalogue::{build as build_catalogue, Catalogue, CatalogueConfig, Oracle, Pruning};
pub use gradient::{descend, Differences, GradientConfig};
pub use jump::{jump_points, JumpConfig, JumpPoint, JumpSet};
pub use probe::{canonical, feature, similarity, Feature, Metric, Probe, TargetTooSmall};
pub use search::{match_target, Candidate, MatchConfig, MatchError, MatchRecord, Optimiser, Status};
pub use simplex::{minimise, LocalResult, SimplexConfig};
pub use space::{AxisOverride, Space, SpaceError};
pub use transform::{transform, Frame, Key, Link, TransformConfig, TransformError, Transformation};

#[cfg(test)]
mod tests;
#[cfg(test)]
mod transform_tests;
