//! Noise by example [references: lagae §7]: a photo of an isotropic stochastic texture fitted
//! with multiresolution wavelet noise (band weights, PCA colour, inverse-CDF curves) and
//! evaluated procedurally anywhere; and, for textures that are not such noise, histogram-
//! preserving tiling and blending of the photo itself.
//!
//! - `tile`: Cook–DeRose wavelet-noise tiles, 2-D and 3-D, and their quadratic B-spline.
//! - `spectrum`: band powers (eq. 10), the weight estimators (eq. 9, NNLS), the isotropy check.
//! - `marginal`: Gaussianisation, Φ, the monotone inverse-CDF curve.
//! - `colour`: PCA colour with its sign convention, and its morph.
//! - `params`: the analysis and the parameter file; `eval`: evaluation; `slice`: the solid
//!   weights that give a planar slice the 2-D texture's band powers.
//! - `tiling`: histogram-preserving tiling and blending (Heitz & Neyret 2018; hex tiles).

pub mod colour;
pub mod eval;
pub mod marginal;
pub mod params;
pub mod slice;
pub mod spectrum;
pub mod tile;
pub mod tiling;

#[cfg(test)]
mod tests;

/// The variance of one 2-D wavelet-noise band the paper gives (eq. 8); every tile is scaled to it.
pub const SIGMA_N2: f64 = 0.265;

/// Why a texture could not be fitted, read or evaluated.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NoiseError {
    #[error(transparent)]
    Tile(#[from] tile::TileError),
    #[error(transparent)]
    Spectrum(#[from] spectrum::SpectrumError),
    #[error(transparent)]
    Marginal(#[from] marginal::MarginalError),
    #[error(transparent)]
    Colour(#[from] colour::ColourError),
    #[error("{0}")]
    Sample(String),
    #[error("{0}")]
    Options(String),
    #[error("{0}")]
    Mask(String),
    #[error("the parameter file: {0}")]
    File(String),
    #[error("cannot morph: {0}")]
    Morph(String),
    #[error("{pixels} pixels is more than one render makes ({limit})")]
    TooLarge { pixels: u64, limit: u64 },
}
