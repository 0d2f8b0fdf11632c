//! Operations on maps: invert, threshold, blur, remap and combine.
//!
//! By the convention of this module a 2-channel image is an orientation field (unit
//! vectors); every other channel count holds independent scalar planes.

use rayon::prelude::*;

use super::error::{check_finite, check_size, invalid, MapError};
use super::render::{map_values, normalize_field};
use crate::raster::Image;

/// Largest blur sigma accepted. The kernel has `2 * ceil(3 sigma) + 1` taps, so this keeps
/// an absurd sigma from exhausting memory or time instead of failing cleanly.
pub const MAX_SIGMA: f32 = 10_000.0;

/// How [`combine`] merges two maps, value by value (`a` is the left map).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CombineOp {
    /// `a * b`: masks a map by another.
    Multiply,
    /// `a + b`, not clamped (follow with [`remap`] to clamp).
    Add,
    /// `a - b`, not clamped.
    Subtract,
    /// `min(a, b)`: intersection of masks.
    Min,
    /// `max(a, b)`: union of masks.
    Max,
    /// `a * (1 - t) + b * t`.
    Mix(f32),
    /// `1 - (1 - a)(1 - b)`: a union that brightens without exceeding 1 for inputs in
    /// `[0, 1]`.
    Screen,
}

impl CombineOp {
    fn apply(self, a: f32, b: f32) -> f32 {
        match self {
            CombineOp::Multiply => a * b,
            CombineOp::Add => a + b,
            CombineOp::Subtract => a - b,
            CombineOp::Min => a.min(b),
            CombineOp::Max => a.max(b),
            CombineOp::Mix(t) => a * (1.0 - t) + b * t,
            CombineOp::Screen => 1.0 - (1.0 - a) * (1.0 - b),
        }
    }
}

/// `1 - v` on scalar maps; the opposite vector on 2-channel orientation fields.
pub fn invert(img: &Image) -> Image {
    if img.channels == 2 {
        map_values(img, |v| -v)
    } else {
        map_values(img, |v| 1.0 - v)
    }
}

/// 1 where `v >= t`, else 0 (per value, so every channel is thresholded on its own).
pub fn threshold(img: &Image, t: f32) -> Image {
    map_values(img, |v| if v >= t { 1.0 } else { 0.0 })
}

/// Linear remap of `[from[0], from[1]]` onto `[to[0], to[1]]`, clamped to the `to` range.
/// Either range may be reversed (e.g. `to = [1, 0]` inverts while remapping).
pub fn remap(img: &Image, from: [f32; 2], to: [f32; 2]) -> Result<Image, MapError> {
    for v in from.iter().chain(&to) {
        check_finite("remap bound", *v)?;
    }
    let span = from[1] - from[0];
    if span == 0.0 {
        return Err(invalid("remap source range width", span, "two different `from` values"));
    }
    let (lo, hi) = (to[0].min(to[1]), to[0].max(to[1]));
    Ok(map_values(img, |v| {
        let t = (v - from[0]) / span;
        (to[0] + t * (to[1] - to[0])).clamp(lo, hi)
    }))
}

/// Separable Gaussian blur, kernel radius `ceil(3 sigma)`, clamp-to-edge. `sigma == 0` is
/// the identity. 2-channel orientation fields are blurred as vectors and renormalised.
pub fn blur(img: &Image, sigma_px: f32) -> Result<Image, MapError> {
    if !(0.0..=MAX_SIGMA).contains(&sigma_px) {
        return Err(invalid("blur sigma", sigma_px, "a number from 0 to 10000 (pixels)"));
    }
    if sigma_px == 0.0 || img.width == 0 || img.height == 0 {
        return Ok(img.clone());
    }
    let kernel = gaussian_kernel(sigma_px);
    let mut out = img.clone();
    for c in 0..img.channels {
        let blurred = blur_plane(img.plane(c), img.width, &kernel);
        out.plane_mut(c).copy_from_slice(&blurred);
    }
    if out.channels == 2 {
        normalize_field(&mut out);
    }
    Ok(out)
}

/// Normalised Gaussian weights for offsets `-r..=r`, `r = ceil(3 sigma)`.
fn gaussian_kernel(sigma: f32) -> Vec<f32> {
    let r = (3.0 * sigma).ceil() as i64;
    let inv = 1.0 / (2.0 * f64::from(sigma) * f64::from(sigma));
    let raw: Vec<f64> = (-r..=r).map(|i| (-((i * i) as f64) * inv).exp()).collect();
    let total: f64 = raw.iter().sum();
    raw.iter().map(|w| (w / total) as f32).collect()
}

/// Blurs one plane: a horizontal then a vertical pass, each parallel over output rows.
/// Every output value sums its taps in kernel order, so the result is thread-independent.
fn blur_plane(src: &[f32], width: usize, kernel: &[f32]) -> Vec<f32> {
    let height = src.len() / width;
    let r = (kernel.len() / 2) as isize;
    let clamp = |i: isize, n: usize| i.clamp(0, n as isize - 1) as usize;
    let mut tmp = vec![0.0f32; src.len()];
    tmp.par_chunks_mut(width).zip(src.par_chunks(width)).for_each(|(out, row)| {
        for (x, o) in out.iter_mut().enumerate() {
            let mut acc = 0.0;
            for (k, w) in kernel.iter().enumerate() {
                acc += w * row[clamp(x as isize + k as isize - r, width)];
            }
            *o = acc;
        }
    });
    let mut dst = vec![0.0f32; src.len()];
    dst.par_chunks_mut(width).enumerate().for_each(|(y, out)| {
        for (k, w) in kernel.iter().enumerate() {
            let sy = clamp(y as isize + k as isize - r, height);
            let row = &tmp[sy * width..(sy + 1) * width];
            for (o, v) in out.iter_mut().zip(row) {
                *o += w * v;
            }
        }
    });
    dst
}

/// Combines two maps value by value. Sizes must match; channel counts must match too,
/// except that a 1-channel map is applied to every channel of the other.
pub fn combine(a: &Image, b: &Image, op: CombineOp) -> Result<Image, MapError> {
    if let CombineOp::Mix(t) = op {
        check_finite("mix factor", t)?;
    }
    let channels_ok = a.channels == b.channels || a.channels == 1 || b.channels == 1;
    if !a.same_size(b) || !channels_ok || a.channels == 0 || b.channels == 0 {
        let dims = |i: &Image| [i.width, i.height, i.channels];
        return Err(MapError::SizeMismatch { left: dims(a), right: dims(b) });
    }
    check_size(a.width, a.height, 1)?;
    let channels = a.channels.max(b.channels);
    let mut out = Image::new(a.width, a.height, channels);
    let pick = |img: &Image, c: usize| if img.channels == 1 { 0 } else { c };
    for c in 0..channels {
        let (pa, pb) = (a.plane(pick(a, c)), b.plane(pick(b, c)));
        out.plane_mut(c).par_chunks_mut(a.width).zip(pa.par_chunks(a.width).zip(pb.par_chunks(a.width))).for_each(
            |(o, (ra, rb))| {
                for ((o, &va), &vb) in o.iter_mut().zip(ra).zip(rb) {
                    *o = op.apply(va, vb);
                }
            },
        );
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::fields::{assert_unit_field, radial_orientation, RadialMode};
    use super::super::noise::value_noise;
    use super::*;

    fn ramp(w: usize, h: usize) -> Image {
        Image::from_fn(w, h, 1, |x, y, _| (x + y * w) as f32 / (w * h) as f32)
    }

    fn mean(img: &Image) -> f64 {
        img.data.iter().map(|&v| f64::from(v)).sum::<f64>() / img.data.len() as f64
    }

    #[test]
    fn invert_scalar_and_vector() {
        let s = Image::from_fn(2, 1, 1, |x, _, _| x as f32 * 0.25);
        assert_eq!(invert(&s).data, vec![1.0, 0.75]);
        let v = Image::from_fn(1, 1, 2, |_, _, c| if c == 0 { 0.6 } else { -0.8 });
        assert_eq!(invert(&v).data, vec![-0.6, 0.8]);
    }

    #[test]
    fn threshold_is_inclusive() {
        let s = Image::from_fn(3, 1, 1, |x, _, _| [0.2, 0.5, 0.7][x]);
        assert_eq!(threshold(&s, 0.5).data, vec![0.0, 1.0, 1.0]);
    }

    #[test]
    fn remap_is_linear_and_clamped() {
        let s = Image::from_fn(4, 1, 1, |x, _, _| [0.0, 0.25, 0.5, 2.0][x]);
        let r = remap(&s, [0.0, 0.5], [10.0, 20.0]).unwrap();
        assert_eq!(r.data, vec![10.0, 15.0, 20.0, 20.0]);
        let rev = remap(&s, [0.0, 1.0], [1.0, 0.0]).unwrap();
        assert_eq!(rev.data, vec![1.0, 0.75, 0.5, 0.0]);
        let below = remap(&s, [0.5, 1.0], [0.0, 1.0]).unwrap();
        assert_eq!(below.get(0, 0, 0), 0.0);
        assert!(remap(&s, [0.3, 0.3], [0.0, 1.0]).is_err());
        assert!(remap(&s, [0.0, 1.0], [f32::NAN, 1.0]).is_err());
    }

    #[test]
    fn blur_identity_at_zero_and_preserves_constants() {
        let img = ramp(13, 7);
        assert_eq!(blur(&img, 0.0).unwrap(), img);
        let c = Image::filled(20, 15, 1, 0.37);
        let b = blur(&c, 2.5).unwrap();
        assert!(b.data.iter().all(|v| (v - 0.37).abs() < 1e-5));
        assert!(blur(&img, -1.0).is_err());
        assert!(blur(&img, f32::NAN).is_err());
        assert!(blur(&img, 1e9).is_err());
    }

    #[test]
    fn blur_smooths_and_roughly_preserves_mean() {
        let img = value_noise(64, 64, 4, 2.0, 1, 0.5).unwrap();
        let b = blur(&img, 3.0).unwrap();
        assert!((mean(&b) - mean(&img)).abs() < 0.01);
        let var = |i: &Image| {
            let m = mean(i);
            i.data.iter().map(|&v| (f64::from(v) - m).powi(2)).sum::<f64>()
        };
        assert!(var(&b) < 0.5 * var(&img));
        // A single bright pixel spreads symmetrically.
        let mut dot = Image::new(21, 21, 1);
        dot.set(10, 10, 0, 1.0);
        let d = blur(&dot, 1.5).unwrap();
        assert!((d.get(8, 10, 0) - d.get(12, 10, 0)).abs() < 1e-7);
        assert!((d.get(10, 8, 0) - d.get(8, 10, 0)).abs() < 1e-7);
        assert!((d.data.iter().sum::<f32>() - 1.0).abs() < 1e-5);
    }

    #[test]
    fn blur_renormalises_orientation_fields() {
        let f = radial_orientation(16, 16, [8.0, 8.0], RadialMode::Tangential).unwrap();
        let b = blur(&f, 2.0).unwrap();
        assert_unit_field(&b);
    }

    #[test]
    fn blur_is_thread_count_independent() {
        let img = value_noise(61, 47, 4, 3.0, 2, 0.5).unwrap();
        let run = |n| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
            pool.install(|| blur(&img, 2.2).unwrap())
        };
        assert_eq!(run(1), run(2));
    }

    #[test]
    fn combine_ops() {
        let a = Image::filled(2, 2, 1, 0.25);
        let b = Image::filled(2, 2, 1, 0.5);
        let at = |op| combine(&a, &b, op).unwrap().get(1, 1, 0);
        assert_eq!(at(CombineOp::Multiply), 0.125);
        assert_eq!(at(CombineOp::Add), 0.75);
        assert_eq!(at(CombineOp::Subtract), -0.25);
        assert_eq!(at(CombineOp::Min), 0.25);
        assert_eq!(at(CombineOp::Max), 0.5);
        assert_eq!(at(CombineOp::Mix(0.5)), 0.375);
        assert_eq!(at(CombineOp::Screen), 0.625);
    }

    #[test]
    fn combine_broadcasts_one_channel_and_rejects_mismatch() {
        let rgb = Image::filled(3, 2, 3, 0.5);
        let mask = Image::from_fn(3, 2, 1, |x, _, _| x as f32);
        let m = combine(&rgb, &mask, CombineOp::Multiply).unwrap();
        assert_eq!(m.channels, 3);
        assert_eq!(m.get(2, 1, 2), 1.0);
        let small = Image::filled(2, 2, 1, 0.0);
        assert!(matches!(
            combine(&mask, &small, CombineOp::Add),
            Err(MapError::SizeMismatch { left: [3, 2, 1], right: [2, 2, 1] })
        ));
        let two = Image::filled(3, 2, 2, 0.0);
        assert!(combine(&rgb, &two, CombineOp::Add).is_err());
        assert!(combine(&mask, &mask, CombineOp::Mix(f32::NAN)).is_err());
        let empty = Image::new(0, 0, 1);
        assert!(combine(&empty, &empty, CombineOp::Add).is_err());
    }
}
