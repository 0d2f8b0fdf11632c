//! Plain data shared by structure analysis and synthesis ([references: frasson §3.4]).
//!
//! Conventions: pixel units, `f64` geometry, y pointing down, pixel `(i, j)` has its centre
//! at `(i + 0.5, j + 0.5)`. Angles are radians measured from +x towards +y (the same
//! convention as orientation maps).

use serde::{Deserialize, Serialize};

pub type Point = [f64; 2];

/// An ellipse with semi-axes `a ≥ b > 0` and major-axis angle `theta ∈ [0, π)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ellipse {
    pub center: Point,
    pub a: f64,
    pub b: f64,
    pub theta: f64,
}

/// A hand-drawn (or generated) planar straight-line graph: the structure sample.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Subdivision {
    pub vertices: Vec<Point>,
    pub edges: Vec<[usize; 2]>,
}

/// The value of an unlabelled pixel in a `Labels` raster.
pub const NO_REGION: u32 = u32::MAX;

/// A label raster: one region id per pixel, row-major.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Labels {
    pub width: usize,
    pub height: usize,
    pub data: Vec<u32>,
}

impl Labels {
    pub fn new(width: usize, height: usize) -> Self {
        Labels { width, height, data: vec![NO_REGION; width * height] }
    }

    #[inline]
    pub fn get(&self, x: usize, y: usize) -> u32 {
        self.data[y * self.width + x]
    }
}

/// A polygon mesh tiling (part of) the plane: shared vertices, one vertex cycle per region.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Mesh {
    pub vertices: Vec<Point>,
    /// Each region's boundary as a cycle of vertex indices with positive shoelace area on
    /// the raw coordinates: counter-clockwise in a y-up frame ([references: frasson §3.4]), which looks
    /// clockwise on screen because y points down.
    pub regions: Vec<Vec<usize>>,
}

/// Rounds `v` to a multiple of `step`: the one rounding of structure numbers into output
/// bytes (files, messages, reports), so equal values always print alike.
pub(crate) fn round_to(v: f64, step: f64) -> f64 {
    let r = (v / step).round() * step;
    // Re-round through the decimal grid so that 0.30000000000000004 prints as 0.3.
    let digits = (-step.log10()).round().max(0.0) as i32;
    let s = 10f64.powi(digits);
    let r = (r * s).round() / s;
    if r == 0.0 {
        0.0
    } else {
        r
    }
}
