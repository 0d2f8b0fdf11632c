//! Why features or a query could not be computed: one error type for both halves of the
//! library, in its own module so that neither half imports the module gathering them.

use std::fmt;

/// Why features or a query could not be computed.
#[derive(Clone, Debug, PartialEq)]
pub enum LibraryError {
    /// The image has no pixels or no channels.
    Empty,
    /// The DFT needs a square power-of-two image and resampling is off.
    NotPowerOfTwo { width: usize, height: usize },
    /// A parameter is out of range.
    BadParameter { name: &'static str, reason: String },
    /// Two feature sets were computed with different settings and cannot be compared.
    Incompatible { what: &'static str, left: usize, right: usize },
}

impl fmt::Display for LibraryError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LibraryError::Empty => write!(f, "the image is empty"),
            LibraryError::NotPowerOfTwo { width, height } => write!(
                f,
                "the Fourier feature needs a square power-of-two image, got {width}x{height} (enable resampling)"
            ),
            LibraryError::BadParameter { name, reason } => write!(f, "invalid `{name}`: {reason}"),
            LibraryError::Incompatible { what, left, right } => {
                write!(f, "features differ in {what} ({left} vs {right}); recompute them with the same settings")
            }
        }
    }
}

impl std::error::Error for LibraryError {}
