//! What matching compares: a metric's feature of an image, computed once per render
//! ([references: bourque §4.5]), and the similarity of two features; and the [`Probe`] that
//! renders a point of a shader's search space on the canonical plane and takes its feature.

use serde::{Deserialize, Serialize};

use super::catalogue::Oracle;
use super::space::Space;
use crate::raster::resample::{crop, resize, Filter};
use crate::raster::Image;
use crate::synth::metrics::{
    power_feature, power_similarity, pyramid_feature, pyramid_feature_distance, PowerFeature, PowerParams,
    PyramidFeature, PyramidParams, POWER_MIN_SIDE,
};
use crate::synth::shader;

/// A similarity metric and its options.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Metric {
    /// The 2-D power spectrum `S_F` (Eq. 4.10): orientation-sensitive, blind to position.
    Power(PowerParams),
    /// Laplacian-pyramid histograms `S_L = 1 − D` (Eq. 4.11): blind to position and to turns
    /// by quarter turns.
    Pyramid(PyramidParams),
}

impl Default for Metric {
    fn default() -> Self {
        Metric::Power(PowerParams::default())
    }
}

/// One image's feature under a metric.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Feature {
    Power(PowerFeature),
    Pyramid(PyramidFeature),
}

/// The smallest canonical side any metric compares.
pub const MIN_SIDE: usize = POWER_MIN_SIDE;

/// The feature of a square image at least [`MIN_SIDE`] wide.
pub fn feature(img: &Image, metric: &Metric) -> Feature {
    match metric {
        Metric::Power(p) => {
            Feature::Power(power_feature(img, p).expect("matching renders square images of MIN_SIDE or more"))
        }
        Metric::Pyramid(p) => Feature::Pyramid(pyramid_feature(img, p)),
    }
}

/// The raw similarity of two features in `[0, 1]`; 0 for features of different metrics,
/// options or sizes (they do not compare), and for any that is not a number (a NaN would
/// otherwise calibrate to a perfect score).
pub fn similarity(a: &Feature, b: &Feature) -> f64 {
    let s = match (a, b) {
        (Feature::Power(a), Feature::Power(b)) => power_similarity(a, b).unwrap_or(0.0),
        (Feature::Pyramid(a), Feature::Pyramid(b)) => pyramid_feature_distance(a, b).map_or(0.0, |d| 1.0 - d),
        _ => 0.0,
    };
    if s.is_nan() {
        0.0
    } else {
        s
    }
}

/// How much there is to see in a render: the length of its weighted power spectrum (0 for a
/// flat image, whatever its colour); 1 under metrics that do not measure it.
pub fn energy(f: &Feature) -> f64 {
    match f {
        Feature::Power(p) => p.weighted.iter().map(|&v| (v as f64).powi(2)).sum::<f64>().sqrt(),
        Feature::Pyramid(_) => 1.0,
    }
}

/// Why a target cannot be compared.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("the target is {0} x {1}: matching needs at least {MIN_SIDE} x {MIN_SIDE} pixels")]
pub struct TargetTooSmall(pub usize, pub usize);

/// A target as matching compares it: its centred square, resampled to `side × side`, clamped
/// to `[0, 1]` as every render is (an HDR target's highlights would otherwise outweigh the
/// whole spectrum, and huge values overflow it).
pub fn canonical(img: &Image, side: usize) -> Result<Image, TargetTooSmall> {
    let s = img.width.min(img.height);
    if s < MIN_SIDE {
        return Err(TargetTooSmall(img.width, img.height));
    }
    let mut square =
        crop(img, (img.width - s) / 2, (img.height - s) / 2, s, s).expect("the square is inside the image");
    for v in &mut square.data {
        *v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    }
    Ok(if s == side { square } else { resize(&square, side, side, Filter::Bilinear) })
}

/// Renders points of a search space at `side × side` over the unit square and takes their
/// features.
pub struct Probe<'a> {
    pub space: &'a Space,
    pub seed: u64,
    pub side: usize,
    pub metric: Metric,
}

impl Probe<'_> {
    pub fn render(&self, x: &[f64]) -> Image {
        shader::render_square(self.space.shader, &self.space.values(x), self.seed, self.side)
            .expect("a space's values are valid and the side is positive")
    }
}

impl Oracle for Probe<'_> {
    type Feature = Feature;

    fn dim(&self) -> usize {
        self.space.dim()
    }

    fn snap(&self, x: &mut [f64]) {
        self.space.snap(x);
    }

    fn feature(&self, x: &[f64]) -> Feature {
        feature(&self.render(x), &self.metric)
    }

    fn similarity(&self, a: &Feature, b: &Feature) -> f64 {
        similarity(a, b)
    }
}
