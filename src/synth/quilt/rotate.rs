//! Pre-rotated copies of a sample for orientation-map quilting.

use std::f64::consts::{FRAC_PI_2, TAU};

use crate::raster::Image;

/// The sample rotated by `angle` radians (θ from +x towards +y, y down) about its centre, with the
/// same size as the input, and the mask of pixels that lie inside the original.
///
/// Output pixel `d` (relative to the centre) shows the input at `R(−θ)·d`, so a feature pointing
/// along +x in the input points along `(cos θ, sin θ)` in the copy. Exact quarter turns of square
/// samples (and angle 0) permute pixels exactly; other angles interpolate bilinearly. The function is
/// deterministic, so gathering another channel through the same angle reproduces the same values.
pub fn rotate_sample(img: &Image, angle: f32) -> (Image, Vec<bool>) {
    let (w, h) = (img.width, img.height);
    let a = f64::from(angle).rem_euclid(TAU);
    let quarter = (a / FRAC_PI_2).round();
    // Angles come as f32: within 1e-6 rad of a quarter turn counts as exact.
    if (a - quarter * FRAC_PI_2).abs() < 1e-6 && (w == h || quarter as i64 % 4 == 0) {
        let q = quarter as i64 % 4;
        let out = Image::from_fn(w, h, img.channels, |x, y, c| {
            let (sx, sy) = match q {
                0 => (x, y),
                1 => (y, w - 1 - x),
                2 => (w - 1 - x, h - 1 - y),
                _ => (h - 1 - y, x),
            };
            img.get(sx, sy, c)
        });
        return (out, vec![true; w * h]);
    }
    let (s, c) = a.sin_cos();
    let (cx, cy) = (w as f64 / 2.0, h as f64 / 2.0);
    let mut out = Image::new(w, h, img.channels);
    let mut valid = vec![false; w * h];
    let plane = w * h;
    for y in 0..h {
        for x in 0..w {
            let (dx, dy) = (x as f64 + 0.5 - cx, y as f64 + 0.5 - cy);
            // R(−θ)·d, then back to continuous coordinates with centres at i + 0.5.
            let fx = cx + c * dx + s * dy - 0.5;
            let fy = cy - s * dx + c * dy - 0.5;
            let eps = 1e-9;
            if fx < -eps || fy < -eps || fx > (w - 1) as f64 + eps || fy > (h - 1) as f64 + eps {
                continue;
            }
            let fx = fx.clamp(0.0, (w - 1) as f64);
            let fy = fy.clamp(0.0, (h - 1) as f64);
            let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
            let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
            let (tx, ty) = (fx - x0 as f64, fy - y0 as f64);
            valid[y * w + x] = true;
            for ch in 0..img.channels {
                let p = &img.data[ch * plane..(ch + 1) * plane];
                let top = f64::from(p[y0 * w + x0]) * (1.0 - tx) + f64::from(p[y0 * w + x1]) * tx;
                let bot = f64::from(p[y1 * w + x0]) * (1.0 - tx) + f64::from(p[y1 * w + x1]) * tx;
                out.data[ch * plane + y * w + x] = (top * (1.0 - ty) + bot * ty) as f32;
            }
        }
    }
    (out, valid)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quarter_turn_maps_x_features_to_y() {
        // A bright column at x = 5 becomes a bright row after a 90° turn.
        let img = Image::from_fn(16, 16, 1, |x, _, _| if x == 5 { 1.0 } else { 0.0 });
        let (r, valid) = rotate_sample(&img, std::f32::consts::FRAC_PI_2);
        assert!(valid.iter().all(|&v| v));
        let row_sums: Vec<f32> = (0..16).map(|y| (0..16).map(|x| r.get(x, y, 0)).sum()).collect();
        assert_eq!(row_sums.iter().filter(|&&s| s == 16.0).count(), 1);
        // Four quarter turns are the identity.
        let mut cur = img.clone();
        for _ in 0..4 {
            cur = rotate_sample(&cur, std::f32::consts::FRAC_PI_2).0;
        }
        assert_eq!(cur, img);
    }

    #[test]
    fn general_angle_keeps_centre_and_marks_corners_invalid() {
        let img = Image::from_fn(33, 33, 2, |x, y, c| (x + 2 * y + c) as f32);
        let (r, valid) = rotate_sample(&img, 0.5);
        assert!(valid[16 * 33 + 16]);
        assert!((r.get(16, 16, 0) - img.get(16, 16, 0)).abs() < 1e-4);
        assert!(!valid[0] && !valid[32] && !valid[32 * 33]);
    }
}
