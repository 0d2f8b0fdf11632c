//! Orientation fields: 2-channel maps holding a unit vector `(cos θ, sin θ)` per pixel.
//!
//! Angles are measured from +x towards +y. Because image y points down, a positive angle
//! turns clockwise on screen.

use super::error::{check_finite, check_point, check_size, MapError};
use super::render::{unit_or_x, vector_map};
use crate::raster::Image;

/// How a [`radial_orientation`] field relates to the direction from its centre.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RadialMode {
    /// Pointing away from the centre.
    Radial,
    /// Perpendicular to [`RadialMode::Radial`], circling the centre counter-clockwise as
    /// seen on screen: right of the centre the field points up, i.e. `(0, -1)`.
    Tangential,
}

/// The same direction everywhere: `(cos angle_rad, sin angle_rad)`.
pub fn linear_orientation(width: usize, height: usize, angle_rad: f32) -> Result<Image, MapError> {
    check_size(width, height, 2)?;
    check_finite("angle", angle_rad)?;
    let (s, c) = angle_rad.sin_cos();
    Ok(vector_map(width, height, |_, _| [c, s]))
}

/// Directions relative to `center`, radial or tangential. At the exact centre, where the
/// direction is undefined, the field is `(1, 0)`.
pub fn radial_orientation(width: usize, height: usize, center: [f32; 2], mode: RadialMode) -> Result<Image, MapError> {
    check_size(width, height, 2)?;
    check_point("center", center)?;
    Ok(vector_map(width, height, |x, y| {
        let (dx, dy) = (x - center[0], y - center[1]);
        if dx == 0.0 && dy == 0.0 {
            return [1.0, 0.0];
        }
        let [rx, ry] = unit_or_x(dx, dy);
        match mode {
            RadialMode::Radial => [rx, ry],
            // Rotating by -90 degrees in the y-down frame is counter-clockwise on screen.
            RadialMode::Tangential => [ry, -rx],
        }
    }))
}

#[cfg(test)]
pub(super) fn assert_unit_field(img: &Image) {
    assert_eq!(img.channels, 2);
    let n = img.plane_len();
    for i in 0..n {
        let (x, y) = (img.data[i], img.data[n + i]);
        assert!((x.hypot(y) - 1.0).abs() < 1e-5, "pixel {i}: ({x}, {y})");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_orientation_is_constant_unit() {
        let img = linear_orientation(5, 4, std::f32::consts::FRAC_PI_2).unwrap();
        assert_unit_field(&img);
        assert!(img.get(2, 2, 0).abs() < 1e-6);
        assert_eq!(img.get(2, 2, 1), 1.0);
        assert!(linear_orientation(5, 4, f32::INFINITY).is_err());
    }

    #[test]
    fn radial_points_away_from_centre() {
        let img = radial_orientation(9, 9, [4.5, 4.5], RadialMode::Radial).unwrap();
        assert_unit_field(&img);
        // Exact centre falls back to (1, 0).
        assert_eq!((img.get(4, 4, 0), img.get(4, 4, 1)), (1.0, 0.0));
        // Right of the centre: +x. Below (y down): +y.
        assert_eq!((img.get(8, 4, 0), img.get(8, 4, 1)), (1.0, 0.0));
        assert_eq!((img.get(4, 8, 0), img.get(4, 8, 1)), (0.0, 1.0));
        let (dx, dy) = (img.get(0, 0, 0), img.get(0, 0, 1));
        assert!(dx < 0.0 && dy < 0.0);
    }

    #[test]
    fn tangential_turns_counter_clockwise_on_screen() {
        let img = radial_orientation(9, 9, [4.5, 4.5], RadialMode::Tangential).unwrap();
        assert_unit_field(&img);
        assert_eq!((img.get(4, 4, 0), img.get(4, 4, 1)), (1.0, 0.0));
        // Right of centre: up. Above centre: left. Left: down. Below: right.
        assert_eq!((img.get(8, 4, 0), img.get(8, 4, 1)), (0.0, -1.0));
        assert_eq!((img.get(4, 0, 0), img.get(4, 0, 1)), (-1.0, 0.0));
        assert_eq!((img.get(0, 4, 0), img.get(0, 4, 1)), (0.0, 1.0));
        assert_eq!((img.get(4, 8, 0), img.get(4, 8, 1)), (1.0, 0.0));
    }
}
