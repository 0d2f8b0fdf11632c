//! A photometric stack: registered images of one surface, one distant light each.
//!
//! Planes are f64. The thesis's tolerances (a relit 3I image within 1e-9 of an exact
//! Lambertian truth) are below f32 rounding (6e-8 relative), and the 36 × 1 Mpx stack (288 MB)
//! still fits comfortably; the maps that go on to quilting are narrowed to f32 only then.

use crate::synth::relight::error::RelightError;
use crate::synth::relight::light::Light;

/// Rec. 709 luminance weights for linear RGB; the luminance a colour stack is fitted on.
pub const LUMA_WEIGHTS: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// `n` registered monochrome images (row-major planes of `width × height`) and their lights,
/// plus, for colour captures, a per-pixel chromaticity (three planes: R, G, B over luminance).
#[derive(Clone, Debug, PartialEq)]
pub struct PhotoStack {
    pub width: usize,
    pub height: usize,
    pub images: Vec<Vec<f64>>,
    pub lights: Vec<Light>,
    /// Planar R, G, B chromaticity (`3 · width · height`), or `None` for a mono capture.
    pub chroma: Option<Vec<f64>>,
}

fn check_finite(index: usize, plane: &[f64], width: usize) -> Result<(), RelightError> {
    match plane.iter().position(|v| !v.is_finite()) {
        Some(j) => Err(RelightError::NonFinite { index, x: j % width, y: j / width, value: plane[j] }),
        None => Ok(()),
    }
}

fn check_lights(images: usize, lights: &[Light]) -> Result<(), RelightError> {
    if images == 0 {
        return Err(RelightError::NoImages);
    }
    if lights.len() != images {
        return Err(RelightError::LightCount { images, lights: lights.len() });
    }
    for (index, l) in lights.iter().enumerate() {
        if !(l.tilt_deg.is_finite() && l.slant_deg.is_finite() && (0.0..=90.0).contains(&l.slant_deg)) {
            return Err(RelightError::BadLight { index, slant_deg: l.slant_deg });
        }
    }
    Ok(())
}

impl PhotoStack {
    /// A mono stack, validated: at least one image, every image `width · height` finite values,
    /// one light per image with a slant in 0°–90°.
    pub fn new(width: usize, height: usize, images: Vec<Vec<f64>>, lights: Vec<Light>) -> Result<Self, RelightError> {
        check_lights(images.len(), &lights)?;
        if width == 0 || height == 0 {
            return Err(RelightError::EmptyImages { width, height });
        }
        for (index, img) in images.iter().enumerate() {
            if img.len() != width * height {
                return Err(RelightError::ImageSize {
                    index,
                    got: img.len(),
                    expected: width * height,
                    width,
                    height,
                    channels: 1,
                });
            }
            check_finite(index, img, width)?;
        }
        Ok(PhotoStack { width, height, images, lights, chroma: None })
    }

    /// A colour stack from planar linear RGB images (`3 · width · height` each): the luminance
    /// planes are what representations fit, and the chromaticity is `Σ_k RGB_k / Σ_k Y_k`, the
    /// mean of `RGB/Y` weighted by `Y` (so dark, noisy views count little). A pixel dark in
    /// every view gets grey chromaticity `(1, 1, 1)`.
    pub fn from_rgb(
        width: usize,
        height: usize,
        images: &[Vec<f64>],
        lights: Vec<Light>,
    ) -> Result<Self, RelightError> {
        check_lights(images.len(), &lights)?;
        if width == 0 || height == 0 {
            return Err(RelightError::EmptyImages { width, height });
        }
        let m = width * height;
        let mut sums = vec![0.0; 3 * m];
        let mut ysum = vec![0.0; m];
        let mut lum = Vec::with_capacity(images.len());
        for (index, img) in images.iter().enumerate() {
            if img.len() != 3 * m {
                return Err(RelightError::ImageSize {
                    index,
                    got: img.len(),
                    expected: 3 * m,
                    width,
                    height,
                    channels: 3,
                });
            }
            check_finite(index, img, width)?;
            let y: Vec<f64> = (0..m)
                .map(|j| LUMA_WEIGHTS[0] * img[j] + LUMA_WEIGHTS[1] * img[m + j] + LUMA_WEIGHTS[2] * img[2 * m + j])
                .collect();
            for j in 0..m {
                ysum[j] += y[j];
                for c in 0..3 {
                    sums[c * m + j] += img[c * m + j];
                }
            }
            lum.push(y);
        }
        let mut chroma = vec![1.0; 3 * m];
        for j in 0..m {
            if ysum[j] > 0.0 {
                for c in 0..3 {
                    chroma[c * m + j] = sums[c * m + j] / ysum[j];
                }
            }
        }
        Ok(PhotoStack { width, height, images: lum, lights, chroma: Some(chroma) })
    }

    pub fn len(&self) -> usize {
        self.images.len()
    }

    pub fn is_empty(&self) -> bool {
        self.images.is_empty()
    }

    pub fn pixels(&self) -> usize {
        self.width * self.height
    }

    /// The stack without image `k` (leave-one-out), sharing nothing with `self`.
    pub fn without(&self, k: usize) -> PhotoStack {
        let keep = |i: &usize| *i != k;
        PhotoStack {
            width: self.width,
            height: self.height,
            images: (0..self.len()).filter(keep).map(|i| self.images[i].clone()).collect(),
            lights: (0..self.len()).filter(keep).map(|i| self.lights[i]).collect(),
            chroma: self.chroma.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Dong `item 3` (the part below file decoding): registration and light checks.
    #[test]
    fn a_stack_is_validated() {
        let l = vec![Light::new(0.0, 30.0), Light::new(90.0, 30.0)];
        assert!(PhotoStack::new(2, 2, vec![vec![0.5; 4], vec![0.25; 4]], l.clone()).is_ok());
        assert!(matches!(
            PhotoStack::new(2, 2, vec![vec![0.5; 4], vec![0.25; 6]], l.clone()),
            Err(RelightError::ImageSize { index: 1, got: 6, .. })
        ));
        assert!(matches!(
            PhotoStack::new(2, 2, vec![vec![0.5; 4]], l.clone()),
            Err(RelightError::LightCount { images: 1, lights: 2 })
        ));
        let mut bad = vec![0.5; 4];
        bad[3] = f64::NAN;
        assert!(matches!(
            PhotoStack::new(2, 2, vec![vec![0.5; 4], bad], l.clone()),
            Err(RelightError::NonFinite { index: 1, x: 1, y: 1, .. })
        ));
        assert!(matches!(
            PhotoStack::new(2, 2, vec![vec![0.5; 4]; 2], vec![Light::new(0.0, 30.0), Light::new(0.0, 95.0)]),
            Err(RelightError::BadLight { index: 1, .. })
        ));
        assert_eq!(PhotoStack::new(2, 2, vec![], vec![]), Err(RelightError::NoImages));
    }

    #[test]
    fn colour_stacks_carry_an_intensity_weighted_chromaticity() {
        // One pixel, two views of a surface whose colour is (0.8, 0.4, 0.2) × shading.
        let rgb = [0.8, 0.4, 0.2];
        let y: f64 = (0..3).map(|c| LUMA_WEIGHTS[c] * rgb[c]).sum();
        let imgs: Vec<Vec<f64>> = [1.0, 0.3].iter().map(|s| rgb.iter().map(|c| c * s).collect()).collect();
        let st = PhotoStack::from_rgb(1, 1, &imgs, vec![Light::new(0.0, 30.0), Light::new(90.0, 30.0)]).unwrap();
        let ch = st.chroma.as_ref().unwrap();
        for c in 0..3 {
            assert!((ch[c] - rgb[c] / y).abs() < 1e-12);
        }
        assert!((st.images[1][0] - 0.3 * y).abs() < 1e-12);
    }
}
