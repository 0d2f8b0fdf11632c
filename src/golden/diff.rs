//! A picture of where an output departs from its golden image.

use rayon::prelude::*;

use super::compare::sample_diff;
use super::Tolerance;
use crate::raster::{check_layout, color::REC709, Image};

/// Brightness of the grayscale golden image drawn underneath, low enough that the
/// coloured markers stand out.
const BACKGROUND: f32 = 0.3;
/// Error at which a failing pixel turns fully magenta (smaller errors are redder).
const FULL_SCALE: f32 = 0.5;
/// How strongly within-tolerance differences are tinted yellow.
const YELLOW_MIX: f32 = 0.35;

/// Builds a 3-channel RGB image visualising the difference between `actual` and
/// `golden`:
///
/// * background: the golden image as dim grayscale (0–0.3), so the markers can be
///   located in the picture;
/// * pixels beyond `tol.max_abs`: bright red, shading to magenta as the error grows
///   towards 0.5;
/// * pixels that differ but are within tolerance: a faint yellow tint;
/// * identical pixels: the plain background.
///
/// Images of different sizes are drawn on a canvas of the larger width and height with
/// their top-left corners aligned; pixels present in only one image are solid magenta.
/// With different channel counts only the common channels are compared.
pub fn diff_image(actual: &Image, golden: &Image, tol: &Tolerance) -> Image {
    let limit = if tol.max_abs.is_nan() { 0.0 } else { tol.max_abs };
    // Malformed images (data length inconsistent with the header) draw as absent.
    let usable = |img: &Image| check_layout(img).is_ok();
    let (aw, ah) = if usable(actual) { (actual.width, actual.height) } else { (0, 0) };
    let (gw, gh) = if usable(golden) { (golden.width, golden.height) } else { (0, 0) };
    let (w, h) = (aw.max(gw), ah.max(gh));
    let common = actual.channels.min(golden.channels);

    let mut out = Image::new(w, h, 3);
    let n = w * h;
    if n == 0 {
        return out;
    }
    let (r_plane, rest) = out.data.split_at_mut(n);
    let (g_plane, b_plane) = rest.split_at_mut(n);
    r_plane.par_chunks_mut(w).zip(g_plane.par_chunks_mut(w)).zip(b_plane.par_chunks_mut(w)).enumerate().for_each(
        |(y, ((r, g), b))| {
            for x in 0..w {
                let in_a = x < aw && y < ah;
                let in_g = x < gw && y < gh;
                let rgb = if in_a && in_g {
                    let bg = BACKGROUND * gray(golden, x, y);
                    let err = (0..common)
                        .map(|c| sample_diff(actual.get(x, y, c), golden.get(x, y, c)))
                        .fold(0.0f32, f32::max);
                    if err > limit {
                        [1.0, 0.0, (err / FULL_SCALE).min(1.0)]
                    } else if err > 0.0 {
                        let keep = 1.0 - YELLOW_MIX;
                        [keep * bg + YELLOW_MIX, keep * bg + YELLOW_MIX, keep * bg]
                    } else {
                        [bg, bg, bg]
                    }
                } else if in_a || in_g {
                    [1.0, 0.0, 1.0]
                } else {
                    [0.0, 0.0, 0.0]
                };
                [r[x], g[x], b[x]] = rgb;
            }
        },
    );
    out
}

/// Display gray level of a pixel in `[0, 1]`: Rec. 709 luma of the first three
/// channels, or channel 0 for gray images; NaN counts as black.
pub(super) fn gray(img: &Image, x: usize, y: usize) -> f32 {
    let v = match img.channels {
        0 => 0.0,
        1 | 2 => img.get(x, y, 0),
        _ => (0..3).map(|c| REC709[c] * img.get(x, y, c)).sum(),
    };
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn px(img: &Image, x: usize, y: usize) -> [f32; 3] {
        [img.get(x, y, 0), img.get(x, y, 1), img.get(x, y, 2)]
    }

    #[test]
    fn marks_failing_and_tolerated_pixels() {
        let golden = Image::filled(4, 3, 1, 1.0);
        let mut out = golden.clone();
        out.set(1, 1, 0, 0.9); // failing under max_abs 0.05, small error: red
        out.set(2, 1, 0, 0.0); // failing, large error: magenta
        out.set(3, 2, 0, 0.98); // within tolerance: yellow tint
        let d = diff_image(&out, &golden, &Tolerance::new(0.05, 0.0));
        assert_eq!((d.width, d.height, d.channels), (4, 3, 3));
        assert_eq!(px(&d, 0, 0), [0.3, 0.3, 0.3]);
        let red = px(&d, 1, 1);
        assert_eq!(red[..2], [1.0, 0.0]);
        assert!(red[2] < 0.3, "{red:?}");
        assert_eq!(px(&d, 2, 1), [1.0, 0.0, 1.0]);
        let yellow = px(&d, 3, 2);
        assert!(yellow[0] == yellow[1] && yellow[0] > yellow[2] + 0.3, "{yellow:?}");
        assert!(yellow[0] < 1.0);
    }

    #[test]
    fn rgb_golden_background_is_dim_luma() {
        let golden = Image::from_fn(2, 1, 3, |x, _, c| if x == 0 { [1.0, 0.0, 0.0][c] } else { 1.0 });
        let d = diff_image(&golden, &golden, &Tolerance::default());
        assert!((d.get(0, 0, 0) - 0.3 * 0.2126).abs() < 1e-6);
        assert!((d.get(1, 0, 1) - 0.3).abs() < 1e-6);
    }

    #[test]
    fn size_mismatch_uses_max_canvas() {
        let golden = Image::filled(4, 2, 3, 0.5);
        let out = Image::filled(3, 5, 3, 0.5);
        let d = diff_image(&out, &golden, &Tolerance::default());
        assert_eq!((d.width, d.height), (4, 5));
        assert_eq!(d.get(0, 0, 1), d.get(0, 0, 0)); // overlap, identical: gray
        assert_eq!(px(&d, 3, 0), [1.0, 0.0, 1.0]); // golden only
        assert_eq!(px(&d, 0, 4), [1.0, 0.0, 1.0]); // output only
        assert_eq!(px(&d, 3, 4), [0.0, 0.0, 0.0]); // neither
    }

    #[test]
    fn channel_mismatch_compares_common_channels() {
        let golden = Image::filled(2, 2, 3, 0.5);
        let mut out = Image::filled(2, 2, 4, 0.5);
        out.set(1, 0, 2, 0.0);
        let d = diff_image(&out, &golden, &Tolerance::default());
        assert_eq!(d.get(1, 0, 0), 1.0);
        assert_eq!(d.get(0, 0, 0), d.get(0, 0, 2));
    }

    #[test]
    fn malformed_and_empty_inputs_do_not_panic() {
        let broken = Image { width: 3, height: 3, channels: 1, data: vec![0.0; 2] };
        let d = diff_image(&broken, &Image::filled(2, 2, 1, 1.0), &Tolerance::default());
        assert_eq!((d.width, d.height), (2, 2));
        assert_eq!(px(&d, 0, 0), [1.0, 0.0, 1.0]);
        assert_eq!(diff_image(&Image::new(0, 0, 3), &Image::new(0, 0, 3), &Tolerance::default()), Image::new(0, 0, 3));
    }
}
