//! Procedural texture matching by example ([references: bourque §4]): given a target image,
//! find the library shader and the parameters that reproduce it.
//!
//! ```text
//! shader + search space ─► catalogue (adaptive random sampling; cached per shader)
//! target ─► feature ─► screen (small subsets) ─► scan (whole catalogues) ─► seeds
//!        ─► bounded simplex per seed (fresh renders) ─► integer sweep ─► match record
//! ```
//!
//! - [`space`]: which parameters a search moves, normalised to the unit cube;
//! - [`probe`]: the metric's features and similarity, and renders of a space's points;
//! - [`catalogue`]: Eqs. 4.2–4.5, generic over what it samples;
//! - [`simplex`]: the bounded Nelder–Mead;
//! - [`search`]: screening, scan, refinement and the residual status.

pub mod catalogue;
pub mod probe;
pub mod search;
pub mod simplex;
pub mod space;

pub use catalogue::{build as build_catalogue, Catalogue, CatalogueConfig, Oracle};
pub use probe::{canonical, feature, similarity, Feature, Metric, Probe, TargetTooSmall};
pub use search::{match_target, Candidate, MatchConfig, MatchError, MatchRecord, Status};
pub use simplex::{minimise, SimplexConfig, SimplexResult};
pub use space::{AxisOverride, Space, SpaceError};

#[cfg(test)]
mod tests;
