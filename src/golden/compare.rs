//! Numeric comparison of an output against its golden image.

use std::fmt;

use rayon::prelude::*;

use crate::raster::{check_layout, Image};

/// How different an output may be from its golden image and still pass.
///
/// A pixel fails when any channel differs by more than `max_abs` (in the images' own
/// units, `[0, 1]` for PNG-sourced data); the comparison passes when the fraction of
/// failing pixels is at most `max_fraction`. The default is an exact match, which is
/// what a deterministic pipeline should produce on one platform; loosen it per golden
/// when outputs legitimately vary (e.g. across floating-point libraries).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tolerance {
    pub max_abs: f32,
    pub max_fraction: f32,
}

impl Tolerance {
    /// No difference allowed at all.
    pub const EXACT: Tolerance = Tolerance { max_abs: 0.0, max_fraction: 0.0 };

    pub fn new(max_abs: f32, max_fraction: f32) -> Self {
        Tolerance { max_abs, max_fraction }
    }

    /// NaN limits would make every test vacuous or every pixel fail; treat them as 0.
    fn sanitized(&self) -> (f32, f32) {
        let clean = |v: f32| if v.is_nan() { 0.0 } else { v };
        (clean(self.max_abs), clean(self.max_fraction))
    }
}

/// The outcome of [`compare`].
///
/// Statistics are over all samples (pixels × channels). When `mismatch` is set the
/// images could not be compared: `pass` is false, `failing_pixels == total_pixels`
/// (the golden's pixel count) and the error statistics are infinite.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    /// Largest absolute difference of any sample (infinite if a NaN/∞ differs).
    pub max_abs: f32,
    pub mean_abs: f32,
    pub rmse: f32,
    /// Pixels with at least one channel beyond the tolerance.
    pub failing_pixels: usize,
    pub total_pixels: usize,
    pub pass: bool,
    /// Why the images are incomparable (size or channel count), if they are.
    pub mismatch: Option<String>,
}

impl fmt::Display for Comparison {
    /// One line for the CLI, e.g.
    /// `FAIL: 12 of 4096 pixels (0.293%) beyond tolerance; max |Δ| 0.2, mean 0.0004, RMSE 0.003`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let verdict = if self.pass { "pass" } else { "FAIL" };
        if let Some(why) = &self.mismatch {
            return write!(f, "{verdict}: {why}");
        }
        let pct =
            if self.total_pixels == 0 { 0.0 } else { 100.0 * self.failing_pixels as f64 / self.total_pixels as f64 };
        write!(
            f,
            "{verdict}: {} of {} pixels ({pct:.3}%) beyond tolerance; max |Δ| {}, mean {}, RMSE {}",
            self.failing_pixels, self.total_pixels, self.max_abs, self.mean_abs, self.rmse
        )
    }
}

/// Absolute difference of two samples, treating equal values (including equal
/// infinities and NaN vs NaN) as 0 and any other non-finite difference as ∞, so a NaN
/// appearing in an output is always noticed.
pub(crate) fn sample_diff(a: f32, b: f32) -> f32 {
    if a == b || (a.is_nan() && b.is_nan()) {
        0.0
    } else {
        let d = (a - b).abs();
        if d.is_nan() {
            f32::INFINITY
        } else {
            d
        }
    }
}

/// Describes why two images cannot be compared pixel by pixel, if they cannot.
pub(crate) fn mismatch(actual: &Image, golden: &Image) -> Option<String> {
    if let Err(e) = check_layout(actual) {
        return Some(format!("output image is malformed: {e}"));
    }
    if let Err(e) = check_layout(golden) {
        return Some(format!("golden image is malformed: {e}"));
    }
    if !actual.same_size(golden) {
        return Some(format!(
            "size differs: output is {}x{}, golden is {}x{}",
            actual.width, actual.height, golden.width, golden.height
        ));
    }
    if actual.channels != golden.channels {
        return Some(format!("channel count differs: output has {}, golden has {}", actual.channels, golden.channels));
    }
    None
}

/// Per-row partial results, combined in row order so the totals do not depend on how
/// rayon split the work.
#[derive(Clone, Copy, Default)]
struct RowStats {
    max_abs: f32,
    sum_abs: f64,
    sum_sq: f64,
    failing: usize,
}

/// Compares `actual` with `golden` under `tol`.
pub fn compare(actual: &Image, golden: &Image, tol: &Tolerance) -> Comparison {
    let total_pixels = golden.plane_len();
    if let Some(why) = mismatch(actual, golden) {
        return Comparison {
            max_abs: f32::INFINITY,
            mean_abs: f32::INFINITY,
            rmse: f32::INFINITY,
            failing_pixels: total_pixels,
            total_pixels,
            pass: false,
            mismatch: Some(why),
        };
    }
    let (limit, max_fraction) = tol.sanitized();
    let (w, h, n) = (golden.width, golden.height, total_pixels);
    let rows: Vec<RowStats> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut s = RowStats::default();
            for x in 0..w {
                let i = y * w + x;
                let mut pixel_max = 0.0f32;
                for c in 0..golden.channels {
                    let d = sample_diff(actual.data[c * n + i], golden.data[c * n + i]);
                    pixel_max = pixel_max.max(d);
                    s.sum_abs += f64::from(d);
                    s.sum_sq += f64::from(d) * f64::from(d);
                }
                s.max_abs = s.max_abs.max(pixel_max);
                if pixel_max > limit {
                    s.failing += 1;
                }
            }
            s
        })
        .collect();
    let t = rows.iter().fold(RowStats::default(), |acc, r| RowStats {
        max_abs: acc.max_abs.max(r.max_abs),
        sum_abs: acc.sum_abs + r.sum_abs,
        sum_sq: acc.sum_sq + r.sum_sq,
        failing: acc.failing + r.failing,
    });
    let samples = (n * golden.channels) as f64;
    let (mean_abs, rmse) =
        if samples > 0.0 { ((t.sum_abs / samples) as f32, (t.sum_sq / samples).sqrt() as f32) } else { (0.0, 0.0) };
    Comparison {
        max_abs: t.max_abs,
        mean_abs,
        rmse,
        failing_pixels: t.failing,
        total_pixels,
        pass: t.failing as f64 <= f64::from(max_fraction) * total_pixels as f64,
        mismatch: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn base() -> Image {
        Image::from_fn(8, 6, 3, |x, y, c| (x + 2 * y + c) as f32 / 20.0)
    }

    #[test]
    fn identical_images_pass_exactly() {
        let c = compare(&base(), &base(), &Tolerance::default());
        assert!(c.pass);
        assert_eq!((c.max_abs, c.mean_abs, c.rmse, c.failing_pixels, c.total_pixels), (0.0, 0.0, 0.0, 0, 48));
        assert_eq!(c.mismatch, None);
    }

    #[test]
    fn one_pixel_beyond_tolerance_fails() {
        let mut out = base();
        out.set(3, 2, 1, out.get(3, 2, 1) + 0.2);
        let c = compare(&out, &base(), &Tolerance::new(0.1, 0.0));
        assert!(!c.pass);
        assert_eq!(c.failing_pixels, 1);
        assert!((c.max_abs - 0.2).abs() < 1e-6);
        assert!((c.mean_abs - 0.2 / 144.0).abs() < 1e-7);
        assert!((c.rmse - (0.04f32 / 144.0).sqrt()).abs() < 1e-6);
        assert!(c.to_string().starts_with("FAIL: 1 of 48 pixels"), "{c}");
        // Allowed as a fraction: 1/48 ≈ 2.1% failing.
        assert!(compare(&out, &base(), &Tolerance::new(0.1, 0.03)).pass);
        assert!(!compare(&out, &base(), &Tolerance::new(0.1, 0.02)).pass);
    }

    #[test]
    fn differences_within_tolerance_pass() {
        let mut out = base();
        out.set(0, 0, 0, out.get(0, 0, 0) + 0.05);
        out.set(7, 5, 2, out.get(7, 5, 2) - 0.1);
        let c = compare(&out, &base(), &Tolerance::new(0.1 + 1e-6, 0.0));
        assert!(c.pass, "{c}");
        assert_eq!(c.failing_pixels, 0);
        assert!(c.max_abs > 0.0);
    }

    #[test]
    fn size_or_channel_mismatch_fails_with_message() {
        let c = compare(&Image::new(4, 6, 3), &base(), &Tolerance::new(1.0, 1.0));
        assert!(!c.pass);
        assert_eq!(c.mismatch.as_deref(), Some("size differs: output is 4x6, golden is 8x6"));
        assert_eq!(c.failing_pixels, 48);
        let c = compare(&Image::new(8, 6, 4), &base(), &Tolerance::new(1.0, 1.0));
        assert_eq!(c.mismatch.as_deref(), Some("channel count differs: output has 4, golden has 3"));
        assert_eq!(c.to_string(), "FAIL: channel count differs: output has 4, golden has 3");
        let broken = Image { width: 8, height: 6, channels: 3, data: vec![0.0; 5] };
        assert!(compare(&broken, &base(), &Tolerance::default()).mismatch.unwrap().contains("malformed"));
    }

    #[test]
    fn nan_in_output_always_fails() {
        let mut out = base();
        out.set(1, 1, 0, f32::NAN);
        let c = compare(&out, &base(), &Tolerance::new(100.0, 0.0));
        assert!(!c.pass);
        assert_eq!(c.max_abs, f32::INFINITY);
        // NaN where the golden also has NaN is a match.
        let mut golden = base();
        golden.set(1, 1, 0, f32::NAN);
        assert!(compare(&out, &golden, &Tolerance::default()).pass);
    }

    #[test]
    fn nan_tolerance_acts_as_exact() {
        let tol = Tolerance::new(f32::NAN, f32::NAN);
        assert!(compare(&base(), &base(), &tol).pass);
        let mut out = base();
        out.set(2, 2, 2, 0.99);
        assert!(!compare(&out, &base(), &tol).pass);
    }

    #[test]
    fn empty_images_compare_equal() {
        let c = compare(&Image::new(0, 0, 3), &Image::new(0, 0, 3), &Tolerance::default());
        assert!(c.pass);
        assert_eq!((c.total_pixels, c.mean_abs), (0, 0.0));
    }
}
