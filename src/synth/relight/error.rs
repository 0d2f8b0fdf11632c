//! The errors of relighting, each naming what the caller should blame.

use thiserror::Error;

/// What went wrong; the kinds layer maps each variant to a diagnostic at the property that set
/// the offending value.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum RelightError {
    #[error("the photometric stack has no images")]
    NoImages,
    #[error("the images are {width}x{height} pixels, but there are none")]
    EmptyImages { width: usize, height: usize },
    #[error("image {index} has {got} values, expected {expected} ({width}x{height}x{channels})")]
    ImageSize { index: usize, got: usize, expected: usize, width: usize, height: usize, channels: usize },
    #[error("{images} images but {lights} lights: every image needs exactly one light")]
    LightCount { images: usize, lights: usize },
    #[error("image {index} has a non-finite value ({value}) at pixel ({x}, {y})")]
    NonFinite { index: usize, x: usize, y: usize, value: f64 },
    #[error("light {index} is not finite or its slant {slant_deg}° is outside 0°–90°")]
    BadLight { index: usize, slant_deg: f64 },
    #[error("{method} needs at least {needed} images, got {got}")]
    TooFewImages { method: &'static str, needed: usize, got: usize },
    #[error(
        "the lights of {method} are coplanar or degenerate (singular values {smallest:.3e} / {largest:.3e}): \
         they do not span three directions"
    )]
    Degenerate { method: &'static str, smallest: f64, largest: f64 },
    #[error(
        "PTM needs lights at two or more slants: at one slant l_x² + l_y² is constant and the six \
         coefficients are not determined (singular values {smallest:.3e} / {largest:.3e})"
    )]
    SingleSlant { smallest: f64, largest: f64 },
    #[error("Eigen-{k} needs k between 1 and the number of images ({n})")]
    EigenRank { k: usize, n: usize },
    #[error("light slant {slant_deg}° is outside the captured slant range {min_deg}°–{max_deg}° of the Eigen grid")]
    SlantOutsideGrid { slant_deg: f64, min_deg: f64, max_deg: f64 },
    #[error("no three lights of the stack are usable for 3I{reason}")]
    NoTriple { reason: &'static str },
    #[error("the maps have {got} channels, the basis needs {expected}")]
    Channels { got: usize, expected: usize },
    #[error("size mismatch: {what} is {got:?}, expected {expected:?}")]
    Size { what: &'static str, got: [usize; 2], expected: [usize; 2] },
    #[error(
        "Eigen's coefficients are interpolated on its light grid, so no per-pixel linear map turns its maps \
         into another frame"
    )]
    NoRotation,
    #[error("the PTM file is malformed: {0}")]
    PtmFile(String),
}
