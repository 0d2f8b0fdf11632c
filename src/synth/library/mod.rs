//! Texture library features and ranking ([references: welsman-dinelle §4.1, §4.3]).
//!
//! Per sample, [`features`] computes once (callers cache the serialisable [`Features`] per
//! file):
//! - a sparse joint RGB histogram with `bins³` bins (32³ in the thesis), integer counts,
//!   bin = 8-bit code >> 3 for 32 bins; grey images count on the diagonal;
//! - the DFT of the grey intensity at an analysis size `n × n` (`n` a power of two; other
//!   sizes are box-resampled when `resample` is set, else refused), normalised by `1/n²`
//!   (Eq. 4.3) so `F(0,0)` is the mean intensity;
//! - the radial profile of `|F|` (rotation-robust Fourier feature) and the Chandra
//!   orientation estimate (angle of maximum spectral amplitude along rays, its value and
//!   how peaked the angular distribution is).
//!
//! [`rank`] computes, per enabled [`Axis`], the raw distance of the query to every library
//! entry (Eq. 4.2 colour L1; Eq. 4.4 Fourier L1 in one of four [`FourierMode`]s), rescales
//! each axis by the largest distance of this query ("per query max", faithful) or by a
//! library-independent bound (`Fixed`), and combines them as `sqrt(Σ d̂²)` (Eq. 4.5).
//! [`select`] draws candidates ([references: welsman-dinelle §4.1]): randomness ρ = 0 gives the k nearest in order,
//! ρ = 1 uniform sampling, in between weights `exp(−d̂/τ)` with `τ = ρ/(1−ρ)`, drawn
//! without replacement by inverse CDF from a seeded generator. [`range_query`] is the
//! thesis's first-version query.

mod error;
mod features;
mod query;

pub use features::{
    box_resample, dft, dft_image, features, grey, orientation, DftPart, FeatureParams, Features, Orientation,
};
pub use query::{
    colour_distance, fourier_distance, query, range_query, rank, select, Axis, FourierMode, HistogramNorm, Normalise,
    QueryParams, Ranked,
};

pub use error::LibraryError;

#[cfg(test)]
mod tests;
