//! Texture measures shared by tests, matching, library search and `tessera compare A B`
//! (the two metrics of [references: bourque §4.5], with tessera's choices).
//!
//! Every function but [`power_similarity`] (a similarity in `[0, 1]`, as matching uses it) is a
//! *distance*: 0 for identical inputs, larger for less similar ones.
//! Images are compared as given (no colour-space conversion); the grey-level measures use
//! Rec. 709 luma of channels 0–2 (channel 0 of 1- and 2-channel images), and expect values
//! roughly in `[0, 1]` where a fixed range matters (pyramid histograms, colour bins).
//!
//! - [`power_similarity`] of two [`power_feature`]s: Bourque's 2-D power-spectrum similarity
//!   `S_F` (Eq. 4.10), orientation-sensitive, for square images of one size (matching).
//! - [`spectrum_distance`]: radially averaged power spectrum, log-power difference weighted
//!   towards low frequencies (size- and rotation-robust).
//! - [`pyramid_distance`]: Laplacian-pyramid level histograms (Bourque eq. 4.11 as a
//!   distance in `[0, 1]`).
//! - [`colour_distance`]: joint colour histogram, total variation in `[0, 1]`.
//! - [`patch_similarity`]: bidirectional patch similarity: coherence (output → sample) and
//!   completeness (sample → output), mean nearest-neighbour RMS patch distance.
//!
//! All results are bit-identical for any rayon thread count.

mod histogram;
mod luma;
mod patches;
mod power;
mod pyramid;
mod spectrum;

use serde::{Deserialize, Serialize};

use crate::raster::Image;

pub use histogram::{colour_distance, colour_histogram, HistogramParams};
pub use patches::{nearest_patch_distance, patch_similarity, PatchParams, PatchSimilarity};
pub use power::{
    power_feature, power_similarity, Calibration, PowerError, PowerFeature, PowerParams, MIN_SIDE as POWER_MIN_SIDE,
};
pub use pyramid::{
    laplacian_pyramid, pyramid_distance, pyramid_feature, pyramid_feature_distance, reconstruct, PyramidFeature,
    PyramidLevel, PyramidParams,
};
pub use spectrum::{radial_power_spectrum, spectrum_distance, SpectrumParams};

/// All measures of `output` against `sample`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    /// [`spectrum_distance`], in natural-log power units.
    pub spectrum: f64,
    /// [`pyramid_distance`], in `[0, 1]`.
    pub pyramid: f64,
    /// [`colour_distance`], in `[0, 1]`.
    pub colour: f64,
    /// Mean RMS distance from each output patch to its nearest sample patch.
    pub coherence: f64,
    /// Mean RMS distance from each sample patch to its nearest output patch.
    pub completeness: f64,
}

/// Parameters of every measure [`compare_with`] computes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CompareParams {
    pub spectrum: SpectrumParams,
    pub pyramid: PyramidParams,
    pub colour: HistogramParams,
    pub patches: PatchParams,
}

/// [`compare_with`] at default parameters.
pub fn compare(output: &Image, sample: &Image) -> Comparison {
    compare_with(output, sample, &CompareParams::default())
}

/// Computes every measure of `output` against `sample` (sizes may differ).
pub fn compare_with(output: &Image, sample: &Image, params: &CompareParams) -> Comparison {
    let ps = patch_similarity(output, sample, &params.patches);
    Comparison {
        spectrum: spectrum_distance(output, sample, &params.spectrum),
        pyramid: pyramid_distance(output, sample, &params.pyramid),
        colour: colour_distance(output, sample, &params.colour),
        coherence: ps.coherence,
        completeness: ps.completeness,
    }
}

#[cfg(test)]
mod tests;
