//! Target surfaces. A plane is a rectangle of pixels with an occupancy mask saying where
//! detail may go (1) and where it may not (0).

use crate::raster::Image;

#[derive(Clone, Debug, PartialEq)]
pub struct Plane {
    /// One channel, in [0, 1].
    pub occupancy: Image,
}

impl Plane {
    pub fn full(width: usize, height: usize) -> Self {
        Plane { occupancy: Image::filled(width, height, 1, 1.0) }
    }

    pub fn width(&self) -> usize {
        self.occupancy.width
    }

    pub fn height(&self) -> usize {
        self.occupancy.height
    }
}
