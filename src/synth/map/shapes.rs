//! Scalar maps from geometry: constants, gradients and anti-aliased masks.

use super::error::{check_finite, check_point, check_positive, check_size, MapError};
use super::render::{rows_map, scalar_map};
use crate::raster::Image;

/// Vertical sub-scanlines per pixel row for the ellipse and polygon masks. Horizontal
/// coverage along each sub-scanline is exact, so edges get `SUBLINES` levels of vertical
/// anti-aliasing and continuous horizontal anti-aliasing.
const SUBLINES: usize = 16;

/// A map with the same value everywhere.
pub fn constant(width: usize, height: usize, value: f32) -> Result<Image, MapError> {
    check_size(width, height, 1)?;
    check_finite("value", value)?;
    Ok(Image::filled(width, height, 1, value))
}

/// A linear ramp: 0 at `from`, 1 at `to`, the pixel centre projected onto the segment and
/// clamped, so the ramp is flat beyond both ends.
pub fn linear(width: usize, height: usize, from: [f32; 2], to: [f32; 2]) -> Result<Image, MapError> {
    check_size(width, height, 1)?;
    check_point("from", from)?;
    check_point("to", to)?;
    let d = [to[0] - from[0], to[1] - from[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    check_positive("gradient length (distance from `from` to `to`)", len2)?;
    Ok(scalar_map(width, height, |x, y| {
        let t = ((x - from[0]) * d[0] + (y - from[1]) * d[1]) / len2;
        t.clamp(0.0, 1.0)
    }))
}

/// Distance from `center` divided by `radius`, clamped to `[0, 1]`: 0 at the centre, 1 at
/// and beyond the radius.
pub fn radial(width: usize, height: usize, center: [f32; 2], radius: f32) -> Result<Image, MapError> {
    check_size(width, height, 1)?;
    check_point("center", center)?;
    check_positive("radius", radius)?;
    Ok(scalar_map(width, height, |x, y| ((x - center[0]).hypot(y - center[1]) / radius).min(1.0)))
}

/// An axis-aligned rectangle mask with `at` its top-left corner, 1 inside and 0 outside.
///
/// Coverage is computed analytically (overlap length in x times overlap in y), so the
/// mask's sum equals the rectangle's area inside the image up to rounding.
pub fn rect(width: usize, height: usize, at: [f32; 2], size: [f32; 2]) -> Result<Image, MapError> {
    check_size(width, height, 1)?;
    check_point("at", at)?;
    check_positive("rect width", size[0])?;
    check_positive("rect height", size[1])?;
    let (x1, y1) = (at[0] + size[0], at[1] + size[1]);
    Ok(rows_map(width, height, |y, row| {
        let cov_y = overlap(y as f32, at[1], y1);
        for (x, v) in row.iter_mut().enumerate() {
            *v = cov_y * overlap(x as f32, at[0], x1);
        }
    }))
}

/// Length of the overlap between the pixel interval `[p, p + 1]` and `[lo, hi]`.
fn overlap(p: f32, lo: f32, hi: f32) -> f32 {
    ((p + 1.0).min(hi) - p.max(lo)).max(0.0)
}

/// A filled ellipse mask with semi-axes `radii`, rotated by `angle_rad` (from +x towards
/// +y, i.e. clockwise on screen since y points down).
pub fn ellipse(
    width: usize,
    height: usize,
    center: [f32; 2],
    radii: [f32; 2],
    angle_rad: f32,
) -> Result<Image, MapError> {
    check_size(width, height, 1)?;
    check_point("center", center)?;
    check_positive("ellipse x radius", radii[0])?;
    check_positive("ellipse y radius", radii[1])?;
    check_finite("angle", angle_rad)?;
    let (s, c) = angle_rad.sin_cos();
    let (ia2, ib2) = (1.0 / (radii[0] * radii[0]), 1.0 / (radii[1] * radii[1]));
    // Points (dx, dy) relative to the centre are inside when, in the ellipse's own frame
    // u = dx c + dy s, v = -dx s + dy c, (u/a)^2 + (v/b)^2 <= 1. On a scanline dy is fixed,
    // leaving a quadratic qa dx^2 + qb dx + qc <= 0 whose roots bound the inside span.
    let qa = c * c * ia2 + s * s * ib2;
    let cross = 2.0 * c * s * (ia2 - ib2);
    let tail = s * s * ia2 + c * c * ib2;
    Ok(span_mask(width, height, |sy, spans| {
        let dy = sy - center[1];
        let (qb, qc) = (cross * dy, tail * dy * dy - 1.0);
        let disc = qb * qb - 4.0 * qa * qc;
        if disc > 0.0 {
            let root = disc.sqrt();
            let x0 = center[0] + (-qb - root) / (2.0 * qa);
            let x1 = center[0] + (-qb + root) / (2.0 * qa);
            spans.push([x0, x1]);
        }
    }))
}

/// A polygon mask filled with the even-odd rule (self-intersections and nested loops
/// cut holes). The polygon is closed implicitly from the last point back to the first.
pub fn polygon(width: usize, height: usize, points: &[[f32; 2]]) -> Result<Image, MapError> {
    check_size(width, height, 1)?;
    if points.len() < 3 {
        return Err(MapError::TooFewPoints { got: points.len() });
    }
    for &p in points {
        check_point("polygon point", p)?;
    }
    Ok(span_mask(width, height, |sy, spans| polygon_spans(points, sy, spans)))
}

/// Appends the even-odd inside spans of the polygon on the horizontal line `y = sy`.
fn polygon_spans(points: &[[f32; 2]], sy: f32, spans: &mut Vec<[f32; 2]>) {
    let mut crossings: Vec<f32> = Vec::new();
    let prev = points.iter().cycle().skip(points.len() - 1);
    for (&a, &b) in prev.zip(points) {
        // Half-open test: a vertex exactly on the line counts for one of its two edges
        // only, so the crossing count stays even.
        if (a[1] <= sy) != (b[1] <= sy) {
            crossings.push(a[0] + (sy - a[1]) * (b[0] - a[0]) / (b[1] - a[1]));
        }
    }
    crossings.sort_unstable_by(f32::total_cmp);
    spans.extend(crossings.chunks_exact(2).map(|pair| [pair[0], pair[1]]));
}

/// Rasterises a shape given as horizontal inside spans per sub-scanline.
///
/// `spans_at(sy, spans)` appends the `[x0, x1]` intervals inside the shape on the line
/// `y = sy`. Each row averages `SUBLINES` sub-scanlines; along a sub-scanline a span adds
/// its exact overlap with each pixel.
fn span_mask(width: usize, height: usize, spans_at: impl Fn(f32, &mut Vec<[f32; 2]>) + Sync) -> Image {
    let weight = 1.0 / SUBLINES as f32;
    rows_map(width, height, |y, row| {
        let mut spans = Vec::new();
        for k in 0..SUBLINES {
            spans.clear();
            spans_at(y as f32 + (k as f32 + 0.5) * weight, &mut spans);
            for &[x0, x1] in &spans {
                add_span(row, x0, x1, weight);
            }
        }
    })
}

/// Adds `weight` times the overlap of `[x0, x1]` with each pixel `[x, x + 1]` of `row`.
fn add_span(row: &mut [f32], x0: f32, x1: f32, weight: f32) {
    let w = row.len() as f32;
    let (x0, x1) = (x0.clamp(0.0, w), x1.clamp(0.0, w));
    if x1 <= x0 {
        return;
    }
    let first = x0 as usize;
    let last = (x1.ceil() as usize).min(row.len());
    for (i, v) in row.iter_mut().enumerate().take(last).skip(first) {
        *v += weight * overlap(i as f32, x0, x1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    fn sum(img: &Image) -> f64 {
        img.data.iter().map(|&v| f64::from(v)).sum()
    }

    fn in_unit_range(img: &Image) -> bool {
        img.data.iter().all(|v| (0.0..=1.0 + 1e-6).contains(v))
    }

    #[test]
    fn constant_fills() {
        let img = constant(4, 3, 0.25).unwrap();
        assert_eq!((img.width, img.height, img.channels), (4, 3, 1));
        assert!(img.data.iter().all(|&v| v == 0.25));
        assert!(constant(0, 3, 0.0).is_err());
        assert!(constant(3, 3, f32::NAN).is_err());
    }

    #[test]
    fn linear_hits_endpoints_and_clamps() {
        // Endpoints on pixel centres: (0.5, 0.5) and (9.5, 0.5).
        let img = linear(10, 2, [0.5, 0.5], [9.5, 0.5]).unwrap();
        assert_eq!(img.get(0, 0, 0), 0.0);
        assert_eq!(img.get(9, 1, 0), 1.0);
        assert!((img.get(3, 0, 0) - 3.0 / 9.0).abs() < 1e-6);
        // Diagonal ramp: perpendicular offsets do not change the value.
        let d = linear(8, 8, [0.0, 0.0], [8.0, 8.0]).unwrap();
        assert!((d.get(2, 5, 0) - d.get(5, 2, 0)).abs() < 1e-6);
        // Beyond the ends the ramp is flat.
        let c = linear(20, 1, [5.5, 0.5], [10.5, 0.5]).unwrap();
        assert_eq!(c.get(0, 0, 0), 0.0);
        assert_eq!(c.get(19, 0, 0), 1.0);
        assert!(linear(4, 4, [1.0, 1.0], [1.0, 1.0]).is_err());
    }

    #[test]
    fn radial_is_zero_at_centre_and_one_outside() {
        let img = radial(64, 64, [32.5, 32.5], 20.0).unwrap();
        assert_eq!(img.get(32, 32, 0), 0.0);
        assert!((img.get(42, 32, 0) - 0.5).abs() < 1e-6);
        assert_eq!(img.get(0, 0, 0), 1.0);
        assert!(in_unit_range(&img));
        assert!(radial(8, 8, [0.0, 0.0], 0.0).is_err());
        assert!(radial(8, 8, [0.0, 0.0], -1.0).is_err());
    }

    #[test]
    fn rect_area_is_exact() {
        let img = rect(100, 80, [10.3, 20.7], [50.0, 30.0]).unwrap();
        assert!((sum(&img) - 1500.0).abs() < 1.0, "{}", sum(&img));
        assert_eq!(img.get(30, 35, 0), 1.0);
        assert_eq!(img.get(5, 5, 0), 0.0);
        // Partial coverage at the fractional left edge: pixel 10 covers [10.3, 11].
        assert!((img.get(10, 35, 0) - 0.7).abs() < 1e-5);
        assert!(in_unit_range(&img));
        // Clipped by the image border: only the inside part counts.
        let clipped = rect(20, 20, [-5.0, -5.0], [10.0, 10.0]).unwrap();
        assert!((sum(&clipped) - 25.0).abs() < 1e-3);
        assert!(rect(10, 10, [0.0, 0.0], [0.0, 5.0]).is_err());
    }

    #[test]
    fn ellipse_area_matches_pi_a_b() {
        for angle in [0.0, 0.4, PI / 2.0, 2.5] {
            let img = ellipse(128, 128, [63.7, 64.2], [40.0, 17.0], angle).unwrap();
            let area = f64::from(PI * 40.0 * 17.0);
            assert!((sum(&img) - area).abs() / area < 0.01, "angle {angle}: {}", sum(&img));
            assert!(in_unit_range(&img));
            assert_eq!(img.get(63, 64, 0), 1.0);
            assert_eq!(img.get(0, 0, 0), 0.0);
        }
        assert!(ellipse(8, 8, [4.0, 4.0], [1.0, -1.0], 0.0).is_err());
    }

    #[test]
    fn ellipse_rotation_turns_the_long_axis() {
        // Rotated by 90 degrees the long axis runs along y.
        let img = ellipse(64, 64, [32.0, 32.0], [25.0, 5.0], PI / 2.0).unwrap();
        assert_eq!(img.get(32, 52, 0), 1.0);
        assert_eq!(img.get(52, 32, 0), 0.0);
    }

    #[test]
    fn polygon_concave_area_and_notch() {
        // An L shape: 40x40 square minus its 20x20 top-right quadrant. Area 1200.
        let l = [[10.0, 10.0], [30.0, 10.0], [30.0, 30.0], [50.0, 30.0], [50.0, 50.0], [10.0, 50.0]];
        let img = polygon(64, 64, &l).unwrap();
        assert!((sum(&img) - 1200.0).abs() < 1.0, "{}", sum(&img));
        assert_eq!(img.get(20, 20, 0), 1.0);
        assert_eq!(img.get(40, 20, 0), 0.0); // inside the notch
        assert_eq!(img.get(40, 40, 0), 1.0);
        assert!(in_unit_range(&img));
    }

    #[test]
    fn polygon_slanted_area() {
        // A triangle with slanted edges: area = 0.5 * 50 * 40 = 1000.
        let img = polygon(64, 64, &[[5.3, 7.1], [55.3, 7.1], [20.3, 47.1]]).unwrap();
        assert!((sum(&img) - 1000.0).abs() < 2.0, "{}", sum(&img));
    }

    #[test]
    fn polygon_even_odd_leaves_star_centre_empty() {
        // A pentagram: the central pentagon is crossed twice and so is outside.
        let pts: Vec<[f32; 2]> = (0..5)
            .map(|i| {
                let a = -PI / 2.0 + i as f32 * 4.0 * PI / 5.0;
                [50.0 + 40.0 * a.cos(), 50.0 + 40.0 * a.sin()]
            })
            .collect();
        let img = polygon(100, 100, &pts).unwrap();
        assert_eq!(img.get(50, 50, 0), 0.0);
        assert_eq!(img.get(50, 15, 0), 1.0); // inside the top point
        assert!(in_unit_range(&img));
    }

    #[test]
    fn polygon_rejects_bad_input() {
        assert_eq!(polygon(8, 8, &[[0.0, 0.0], [1.0, 1.0]]), Err(MapError::TooFewPoints { got: 2 }));
        assert!(polygon(8, 8, &[[0.0, 0.0], [1.0, f32::NAN], [2.0, 0.0]]).is_err());
        // Degenerate (collinear) polygons are valid and empty.
        let flat = polygon(8, 8, &[[0.0, 2.0], [4.0, 2.0], [8.0, 2.0]]).unwrap();
        assert_eq!(sum(&flat), 0.0);
    }
}
