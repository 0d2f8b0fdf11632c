//! The one error type of the raster layer.
//!
//! Messages are written for the person running `tessera`, not for the programmer: they
//! end up verbatim in diagnostics such as "cannot read `rock.exr`: EXR contains 3 NaN or
//! infinite values".

use thiserror::Error;

/// Everything that can go wrong while decoding, encoding or reshaping an [`Image`].
///
/// [`Image`]: crate::raster::Image
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum RasterError {
    /// The bytes start with neither the PNG signature nor the OpenEXR magic number.
    #[error("not a PNG or OpenEXR file")]
    UnknownFormat,

    /// The PNG signature was present but the decoder rejected the rest.
    #[error("corrupt PNG: {0}")]
    CorruptPng(String),

    /// The OpenEXR magic number was present but the decoder rejected the rest.
    #[error("corrupt EXR: {0}")]
    CorruptExr(String),

    /// A well-formed EXR using a feature tessera does not read (deep data, subsampling…).
    #[error("unsupported EXR: {0}")]
    UnsupportedExr(String),

    /// NaN or ±infinity samples: they would poison every later stage, so they are refused
    /// at the door with a count the user can act on.
    #[error("EXR contains {count} NaN or infinite values")]
    NonFinite { count: usize },

    /// Decoding would need more memory than tessera is willing to allocate for one image.
    #[error("image too large: {width}x{height} with {channels} channels exceeds the limit of {limit} samples")]
    TooLarge { width: usize, height: usize, channels: usize, limit: usize },

    /// PNG only has gray, gray+alpha, RGB and RGBA.
    #[error("cannot write {0} channels to PNG")]
    PngChannels(usize),

    /// PNG output is offered in 8 and 16 bits per sample only.
    #[error("cannot write {0}-bit PNG (use 8 or 16)")]
    PngBits(u8),

    /// Neither PNG nor EXR can store an image without pixels or channels.
    #[error("cannot encode an empty image ({width}x{height}, {channels} channels)")]
    Empty { width: usize, height: usize, channels: usize },

    /// `data.len()` disagrees with `width * height * channels` (the fields are public, so
    /// an inconsistent image can be built by hand).
    #[error("image data has {len} values but {width}x{height} with {channels} channels needs {expected}")]
    BadLayout { width: usize, height: usize, channels: usize, len: usize, expected: usize },

    /// The underlying encoder failed (should not happen for a valid image).
    #[error("{format} encoding failed: {message}")]
    Encode { format: &'static str, message: String },

    /// A cached image blob failed validation; callers treat this as a cache miss.
    #[error("corrupt image cache entry: {0}")]
    CorruptCache(String),

    /// An operation that needs colour channels was given too few.
    #[error("{operation} needs at least {needed} channels, the image has {got}")]
    TooFewChannels { operation: &'static str, needed: usize, got: usize },

    /// A crop rectangle reaching outside the image.
    #[error("crop of {w}x{h} at ({x}, {y}) does not fit in the {width}x{height} image")]
    CropOutOfBounds { x: usize, y: usize, w: usize, h: usize, width: usize, height: usize },
}

/// Checks that `img.data` has exactly `width * height * channels` values and returns that
/// count. Encoders call this first so a hand-built, inconsistent image becomes an error
/// instead of an out-of-bounds panic deep inside a codec.
pub(crate) fn check_layout(img: &crate::raster::Image) -> Result<usize, RasterError> {
    let expected = img.width.checked_mul(img.height).and_then(|n| n.checked_mul(img.channels)).unwrap_or(usize::MAX);
    if expected != img.data.len() {
        return Err(RasterError::BadLayout {
            width: img.width,
            height: img.height,
            channels: img.channels,
            len: img.data.len(),
            expected,
        });
    }
    Ok(expected)
}
