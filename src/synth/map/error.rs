//! The error type of the map builders: invalid parameters a scene author can fix.

use std::fmt;

/// A map parameter was invalid. Messages are written for scene authors, not developers.
#[derive(Clone, Debug, PartialEq)]
pub enum MapError {
    /// The output would have no pixels (or too many to address).
    BadSize { width: usize, height: usize },
    /// A numeric parameter was outside its valid range (or not a finite number).
    Invalid { name: &'static str, value: f64, expected: &'static str },
    /// A polygon needs at least three points.
    TooFewPoints { got: usize },
    /// Two maps that must be combined pixel by pixel have different sizes or channel counts.
    SizeMismatch { left: [usize; 3], right: [usize; 3] },
    /// A channel index beyond the image's channels, or an image with too few channels.
    Channel { wanted: usize, channels: usize },
}

impl fmt::Display for MapError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MapError::BadSize { width, height } => {
                write!(f, "map size {width}x{height} is invalid: both sides must be at least 1")
            }
            MapError::Invalid { name, value, expected } => {
                write!(f, "invalid {name} = {value}: expected {expected}")
            }
            MapError::TooFewPoints { got } => {
                write!(f, "a polygon needs at least 3 points, got {got}")
            }
            MapError::SizeMismatch { left, right } => write!(
                f,
                "cannot combine a {}x{}x{} map with a {}x{}x{} map: sizes must match \
                 (channel counts may differ only if one side has 1 channel)",
                left[0], left[1], left[2], right[0], right[1], right[2]
            ),
            MapError::Channel { wanted, channels } => {
                write!(f, "channel {wanted} requested but the image has {channels} channel(s)")
            }
        }
    }
}

impl std::error::Error for MapError {}

/// Rejects empty outputs and sizes whose pixel count overflows.
pub(super) fn check_size(width: usize, height: usize, channels: usize) -> Result<(), MapError> {
    let fits = width.checked_mul(height).and_then(|n| n.checked_mul(channels)).is_some();
    if width == 0 || height == 0 || !fits {
        return Err(MapError::BadSize { width, height });
    }
    Ok(())
}

/// Requires `value > 0` and finite. Written as a negated comparison so NaN is rejected.
pub(super) fn check_positive(name: &'static str, value: f32) -> Result<(), MapError> {
    if !(value > 0.0 && value.is_finite()) {
        return Err(invalid(name, value, "a finite number > 0"));
    }
    Ok(())
}

/// Requires a finite number.
pub(super) fn check_finite(name: &'static str, value: f32) -> Result<(), MapError> {
    if !value.is_finite() {
        return Err(invalid(name, value, "a finite number"));
    }
    Ok(())
}

/// Requires both coordinates of a point to be finite.
pub(super) fn check_point(name: &'static str, p: [f32; 2]) -> Result<(), MapError> {
    check_finite(name, p[0])?;
    check_finite(name, p[1])
}

pub(super) fn invalid(name: &'static str, value: f32, expected: &'static str) -> MapError {
    MapError::Invalid { name, value: f64::from(value), expected }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_the_parameter() {
        let e = invalid("radius", -1.0, "a finite number > 0");
        assert_eq!(e.to_string(), "invalid radius = -1: expected a finite number > 0");
        assert!(MapError::TooFewPoints { got: 2 }.to_string().contains("got 2"));
        assert!(check_positive("r", f32::NAN).is_err());
        assert!(check_size(0, 5, 1).is_err());
        assert!(check_size(usize::MAX, 2, 1).is_err());
        assert!(check_size(3, 5, 1).is_ok());
    }
}
