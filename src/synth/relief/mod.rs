//! Depth from colour: what relief layers are measured against. The greyscale baseline
//! [references: frasson §5.2] (a grey copy of the texture used as displacement, which gets dark
//! protruding foliage wrong) and the scores the stand-ins' ground truth allows.
//!
//! The synthesis itself is multi-patch quilting (`synth::quilt::quilt_multipatch`).

#[cfg(any(test, feature = "fixtures"))]
pub mod fixtures;
pub mod instanced;

use crate::raster::color::linear_rgb_to_lab;
use crate::raster::Image;

/// The greyscale baseline: CIE lightness `L*/100` of a linear-RGB image, used as depth.
pub fn greyscale_depth(colour: &Image) -> Image {
    Image::from_fn(colour.width, colour.height, 1, |x, y, _| {
        let c = |k: usize| colour.get(x, y, k.min(colour.channels - 1));
        linear_rgb_to_lab([c(0), c(1), c(2)])[0] / 100.0
    })
}

/// The share of the pixels where `select` holds whose depth lies on the stated side of `level`
/// (`above`: `depth > level`, else `depth < level`); `None` when no pixel is selected.
pub fn side_share(depth: &Image, select: impl Fn(usize) -> bool, level: f32, above: bool) -> Option<f64> {
    let (mut n, mut good) = (0usize, 0usize);
    for (i, &d) in depth.plane(0).iter().enumerate() {
        if select(i) {
            n += 1;
            good += usize::from(if above { d > level } else { d < level });
        }
    }
    (n > 0).then(|| good as f64 / n as f64)
}

/// Mean absolute difference of two one-channel images of one size over the pixels where
/// `select` holds (`None` when none is).
pub fn mean_abs_error(a: &Image, b: &Image, select: impl Fn(usize) -> bool) -> Option<f64> {
    let (mut n, mut sum) = (0usize, 0.0f64);
    for (i, (&x, &y)) in a.plane(0).iter().zip(b.plane(0)).enumerate() {
        if select(i) {
            n += 1;
            sum += f64::from((x - y).abs());
        }
    }
    (n > 0).then(|| sum / n as f64)
}

#[cfg(test)]
mod tests;
