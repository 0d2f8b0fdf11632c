//! Colour measures of appearance ([references: frasson §4.1.2]): sRGB-encoded pixels to CIELAB
//! (D65, through linear light, in `f64`), means and the CIE76 colour difference.

use super::types::Lab;
use crate::raster::color::{linear_rgb_to_lab, srgb_to_linear};
use crate::raster::Image;

/// CIELAB of one sRGB-encoded RGB pixel (values in `[0, 1]`).
pub fn lab_of_srgb(rgb: [f32; 3]) -> Lab {
    let l = linear_rgb_to_lab([srgb_to_linear(rgb[0]), srgb_to_linear(rgb[1]), srgb_to_linear(rgb[2])]);
    [l[0] as f64, l[1] as f64, l[2] as f64]
}

/// CIELAB of pixel `(x, y)` of an RGB(A) sRGB-encoded image.
pub fn lab_at(img: &Image, x: usize, y: usize) -> Lab {
    let n = img.plane_len();
    let i = y * img.width + x;
    lab_of_srgb([img.data[i], img.data[n + i], img.data[2 * n + i]])
}

/// The whole image in CIELAB, one `Lab` per pixel, row-major.
pub fn lab_image(img: &Image) -> Vec<Lab> {
    let n = img.plane_len();
    (0..n).map(|i| lab_of_srgb([img.data[i], img.data[n + i], img.data[2 * n + i]])).collect()
}

/// CIE76 colour difference: the Euclidean distance in CIELAB.
pub fn delta_e(a: Lab, b: Lab) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Mean of CIELAB values (`[0, 0, 0]` for none), summed in order.
pub fn mean_lab(values: impl IntoIterator<Item = Lab>) -> Lab {
    let (mut s, mut n) = ([0.0f64; 3], 0usize);
    for v in values {
        for c in 0..3 {
            s[c] += v[c];
        }
        n += 1;
    }
    if n == 0 {
        return [0.0; 3];
    }
    [s[0] / n as f64, s[1] / n as f64, s[2] / n as f64]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// F20: the reference values of CIELAB from sRGB (D65).
    #[test]
    fn f20_reference_values() {
        let cases: [([f32; 3], Lab, f64); 4] = [
            ([1.0, 1.0, 1.0], [100.0, 0.0, 0.0], 0.01),
            ([1.0, 0.0, 0.0], [53.24, 80.09, 67.20], 0.05),
            ([0.0, 1.0, 0.0], [87.73, -86.18, 83.18], 0.05),
            ([0.0, 0.0, 1.0], [32.30, 79.19, -107.86], 0.05),
        ];
        for (rgb, want, tol) in cases {
            let got = lab_of_srgb(rgb);
            for c in 0..3 {
                assert!((got[c] - want[c]).abs() <= tol, "{rgb:?}: {got:?} vs {want:?}");
            }
        }
    }

    #[test]
    fn delta_e_is_euclidean() {
        assert_eq!(delta_e([50.0, 0.0, 0.0], [53.0, 4.0, 0.0]), 5.0);
        assert_eq!(mean_lab([[1.0, 2.0, 3.0], [3.0, 4.0, 5.0]]), [2.0, 3.0, 4.0]);
        assert_eq!(mean_lab(std::iter::empty()), [0.0; 3]);
    }
}
