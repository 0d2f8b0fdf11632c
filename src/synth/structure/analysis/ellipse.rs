//! Ellipse fit by principal component analysis ([references: frasson §3.4], V2).
//!
//! The covariance is normalised (`Σ = (1/Σw) Σ w_i p'_i p'_iᵀ`) and mapped to semi-axes by
//! `a = 2√λ1`, `b = 2√λ2`: a filled ellipse with semi-axes `a, b` has variance `a²/4` along
//! its major axis, so the fit of an elliptical region returns that ellipse (area `πab`).
//! `θ = ½ atan2(2Σxy, Σxx − Σyy)` reduced into `[0, π)`, measured from +x towards +y in the
//! raw (y-down) coordinates; `a ≥ b > 0`.
//!
//! Two modes: exact polygon moments by Green's theorem (the default, resolution-free) and
//! pixel moments over a label raster (the thesis's way: all pixels of the region, pixel
//! centres at `(i + 0.5, j + 0.5)`, optionally weighted).

use crate::synth::structure::types::{Ellipse, Labels, Point, NO_REGION};
use std::f64::consts::PI;

/// Area, centroid and normalised covariance `[Σxx, Σxy, Σyy]` of a region.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Moments {
    pub area: f64,
    pub centroid: Point,
    pub cov: [f64; 3],
}

/// Raw polygon integrals relative to a reference point: `A, ∫x, ∫y, ∫x², ∫xy, ∫y²`.
fn ring_integrals(ring: &[Point], o: Point, acc: &mut [f64; 6]) {
    let n = ring.len();
    for i in 0..n {
        let (x0, y0) = (ring[i][0] - o[0], ring[i][1] - o[1]);
        let j = if i + 1 == n { 0 } else { i + 1 };
        let (x1, y1) = (ring[j][0] - o[0], ring[j][1] - o[1]);
        let c = x0 * y1 - x1 * y0;
        acc[0] += c / 2.0;
        acc[1] += (x0 + x1) * c / 6.0;
        acc[2] += (y0 + y1) * c / 6.0;
        acc[3] += (x0 * x0 + x0 * x1 + x1 * x1) * c / 12.0;
        acc[4] += (x0 * y1 + 2.0 * x0 * y0 + 2.0 * x1 * y1 + x1 * y0) * c / 24.0;
        acc[5] += (y0 * y0 + y0 * y1 + y1 * y1) * c / 12.0;
    }
}

/// Moments of a region bounded by `rings` (outer boundary and holes with opposite
/// orientations, as [`crate::synth::structure::mesh::faces::Faces::rings`] returns them). Either global orientation
/// works. `None` if the area is zero.
pub fn rings_moments(rings: &[Vec<Point>]) -> Option<Moments> {
    let first = rings.iter().find(|r| !r.is_empty())?;
    // A reference point inside the bounding box keeps the sums well conditioned.
    let mut o = [0.0, 0.0];
    for p in first {
        o[0] += p[0];
        o[1] += p[1];
    }
    o = [o[0] / first.len() as f64, o[1] / first.len() as f64];
    let mut acc = [0.0; 6];
    for r in rings {
        ring_integrals(r, o, &mut acc);
    }
    let a = acc[0];
    if a == 0.0 || !a.is_finite() {
        return None;
    }
    let (cx, cy) = (acc[1] / a, acc[2] / a);
    let cov = [acc[3] / a - cx * cx, acc[4] / a - cx * cy, acc[5] / a - cy * cy];
    Some(Moments { area: a.abs(), centroid: [cx + o[0], cy + o[1]], cov })
}

/// Moments of a simple polygon (either orientation).
pub fn polygon_moments(poly: &[Point]) -> Option<Moments> {
    rings_moments(std::slice::from_ref(&poly.to_vec()))
}

/// Eigenvalues `λ1 ≥ λ2` of the covariance `[Σxx, Σxy, Σyy]` and the major-axis angle in
/// `[0, π)`.
pub fn eigen(cov: [f64; 3]) -> (f64, f64, f64) {
    let [sxx, sxy, syy] = cov;
    let mean = 0.5 * (sxx + syy);
    let d = (0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy).sqrt();
    let mut theta = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    if theta < 0.0 {
        theta += PI;
    }
    if theta >= PI {
        theta -= PI;
    }
    (mean + d, mean - d, theta)
}

/// The ellipse of a centroid and covariance (`a = 2√λ1`, `b = 2√λ2`). `None` if the
/// covariance is degenerate (`λ2 ≤ 0`) or not finite.
pub fn ellipse_from_cov(centroid: Point, cov: [f64; 3]) -> Option<Ellipse> {
    let (l1, l2, theta) = eigen(cov);
    if !(l2 > 0.0 && l1.is_finite()) {
        return None;
    }
    Some(Ellipse { center: centroid, a: 2.0 * l1.sqrt(), b: 2.0 * l2.sqrt(), theta })
}

/// `λ1 / λ2` of a covariance (∞ when degenerate). Below 1.02 the angle is unstable
/// ([references: frasson §3.4]); orientation tests skip such regions.
pub fn anisotropy(cov: [f64; 3]) -> f64 {
    let (l1, l2, _) = eigen(cov);
    if l2 > 0.0 {
        l1 / l2
    } else {
        f64::INFINITY
    }
}

/// Ellipse fit of a polygon by exact moments.
pub fn fit_polygon(poly: &[Point]) -> Option<Ellipse> {
    let m = polygon_moments(poly)?;
    ellipse_from_cov(m.centroid, m.cov)
}

/// Ellipse fit of a region with holes by exact moments.
pub fn fit_rings(rings: &[Vec<Point>]) -> Option<Ellipse> {
    let m = rings_moments(rings)?;
    ellipse_from_cov(m.centroid, m.cov)
}

/// Weighted centroid `C = Σ w_i p_i / Σ w_i` (`weights = None`: all 1). `None` if the total
/// weight is not positive.
pub fn weighted_centroid(points: &[Point], weights: Option<&[f64]>) -> Option<Point> {
    let mut sw = 0.0;
    let mut s = [0.0, 0.0];
    for (i, p) in points.iter().enumerate() {
        let w = weights.map_or(1.0, |w| w[i]);
        sw += w;
        s[0] += w * p[0];
        s[1] += w * p[1];
    }
    (sw > 0.0).then(|| [s[0] / sw, s[1] / sw])
}

/// Weighted centroid and normalised weighted covariance of a point set (two passes).
pub fn point_moments(points: &[Point], weights: Option<&[f64]>) -> Option<Moments> {
    let c = weighted_centroid(points, weights)?;
    let mut sw = 0.0;
    let mut cov = [0.0; 3];
    for (i, p) in points.iter().enumerate() {
        let w = weights.map_or(1.0, |w| w[i]);
        let (dx, dy) = (p[0] - c[0], p[1] - c[1]);
        sw += w;
        cov[0] += w * dx * dx;
        cov[1] += w * dx * dy;
        cov[2] += w * dy * dy;
    }
    Some(Moments { area: points.len() as f64, centroid: c, cov: [cov[0] / sw, cov[1] / sw, cov[2] / sw] })
}

/// Ellipse fit of a (weighted) point set, e.g. the pixel centres of a region.
pub fn fit_points(points: &[Point], weights: Option<&[f64]>) -> Option<Ellipse> {
    let m = point_moments(points, weights)?;
    ellipse_from_cov(m.centroid, m.cov)
}

/// The pixel-mode fit of one label.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelFit {
    pub label: u32,
    pub pixels: usize,
    pub weight: f64,
    /// Weighted centroid and covariance (`area` is the pixel count).
    pub moments: Moments,
    pub ellipse: Option<Ellipse>,
}

/// Pixel-mode ellipse fit of every label of a raster (`NO_REGION` skipped), sorted by label.
/// Pixel centres are at `(i + 0.5, j + 0.5)`. With `weights` (one per pixel, row-major),
/// the centroid and covariance are weighted; pixels of weight 0 count in `pixels` only.
pub fn fit_labels(labels: &Labels, weights: Option<&[f32]>) -> Vec<PixelFit> {
    let (w, h) = (labels.width, labels.height);
    assert_eq!(labels.data.len(), w * h, "label raster size");
    if let Some(wt) = weights {
        assert_eq!(wt.len(), w * h, "weight raster size");
    }
    // Dense index of the labels present.
    let mut ids: Vec<u32> = labels.data.iter().copied().filter(|&l| l != NO_REGION).collect();
    ids.sort_unstable();
    ids.dedup();
    let slot = |l: u32| ids.binary_search(&l).ok();
    let n = ids.len();
    // Pass 1: counts, weights, weighted sums (relative to the image centre).
    let o = [w as f64 / 2.0, h as f64 / 2.0];
    let mut acc = vec![[0.0f64; 3]; n];
    let mut count = vec![0usize; n];
    let mut idx = vec![usize::MAX; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let Some(s) = slot(labels.data[i]) else { continue };
            idx[i] = s;
            let wt = weights.map_or(1.0, |wt| wt[i] as f64);
            let (px, py) = (x as f64 + 0.5 - o[0], y as f64 + 0.5 - o[1]);
            count[s] += 1;
            acc[s][0] += wt;
            acc[s][1] += wt * px;
            acc[s][2] += wt * py;
        }
    }
    let cent: Vec<Point> =
        acc.iter().map(|a| if a[0] > 0.0 { [a[1] / a[0], a[2] / a[0]] } else { [f64::NAN, f64::NAN] }).collect();
    // Pass 2: central second moments.
    let mut cov = vec![[0.0f64; 3]; n];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let s = idx[i];
            if s == usize::MAX {
                continue;
            }
            let wt = weights.map_or(1.0, |wt| wt[i] as f64);
            let (dx, dy) = (x as f64 + 0.5 - o[0] - cent[s][0], y as f64 + 0.5 - o[1] - cent[s][1]);
            cov[s][0] += wt * dx * dx;
            cov[s][1] += wt * dx * dy;
            cov[s][2] += wt * dy * dy;
        }
    }
    (0..n)
        .map(|s| {
            let sw = acc[s][0];
            let centroid = [cent[s][0] + o[0], cent[s][1] + o[1]];
            let c = if sw > 0.0 { [cov[s][0] / sw, cov[s][1] / sw, cov[s][2] / sw] } else { [0.0; 3] };
            let moments = Moments { area: count[s] as f64, centroid, cov: c };
            let ellipse = if sw > 0.0 { ellipse_from_cov(centroid, c) } else { None };
            PixelFit { label: ids[s], pixels: count[s], weight: sw, moments, ellipse }
        })
        .collect()
}

/// Points of an ellipse polygon with `n` vertices (positive signed area in raw coordinates).
pub fn ellipse_polygon(e: &Ellipse, n: usize) -> Vec<Point> {
    let (c, s) = (e.theta.cos(), e.theta.sin());
    (0..n)
        .map(|k| {
            let t = 2.0 * PI * k as f64 / n as f64;
            let (u, v) = (e.a * t.cos(), e.b * t.sin());
            [e.center[0] + u * c - v * s, e.center[1] + u * s + v * c]
        })
        .collect()
}

/// Smallest difference between two axial angles (period π).
pub fn axial_angle_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(PI);
    d.min(PI - d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::rng::Rng;

    #[test]
    fn f2_polygon_fit_of_a_128_gon() {
        let truth = Ellipse { center: [100.0, 70.0], a: 40.0, b: 15.0, theta: 30f64.to_radians() };
        let poly = ellipse_polygon(&truth, 128);
        let e = fit_polygon(&poly).unwrap();
        let da = (e.a - truth.a).abs() / truth.a;
        let db = (e.b - truth.b).abs() / truth.b;
        let dt = axial_angle_diff(e.theta, truth.theta).to_degrees();
        eprintln!("F2 128-gon: |Δa|/a {da:.2e} |Δb|/b {db:.2e} |Δθ| {dt:.2e}°");
        // The inscribed 128-gon is slightly smaller than the ellipse: about 0.03 % per axis.
        assert!(da < 0.005 && db < 0.005 && dt < 0.2, "da {da} db {db} dθ {dt}°");
        assert!(da < 4e-4 && db < 4e-4 && dt < 1e-9, "da {da} db {db} dθ {dt}°");
        assert!((e.center[0] - 100.0).abs() < 1e-9 && (e.center[1] - 70.0).abs() < 1e-9);
        // Reversed orientation gives the same ellipse.
        let mut rev = poly.clone();
        rev.reverse();
        let e2 = fit_polygon(&rev).unwrap();
        assert!((e2.a - e.a).abs() < 1e-9 && (e2.b - e.b).abs() < 1e-9 && (e2.theta - e.theta).abs() < 1e-9);
    }

    #[test]
    fn rectangle_moments_closed_form() {
        // A w×h rectangle has variances w²/12 and h²/12.
        let poly = vec![[10.0, 20.0], [40.0, 20.0], [40.0, 30.0], [10.0, 30.0]];
        let m = polygon_moments(&poly).unwrap();
        assert_eq!(m.area, 300.0);
        assert!((m.centroid[0] - 25.0).abs() < 1e-12 && (m.centroid[1] - 25.0).abs() < 1e-12);
        assert!((m.cov[0] - 75.0).abs() < 1e-9 && m.cov[1].abs() < 1e-9 && (m.cov[2] - 100.0 / 12.0).abs() < 1e-9);
        let e = fit_polygon(&poly).unwrap();
        assert_eq!(e.theta, 0.0);
        // Upright rectangle: θ = π/2.
        let up = vec![[0.0, 0.0], [5.0, 0.0], [5.0, 20.0], [0.0, 20.0]];
        assert!((fit_polygon(&up).unwrap().theta - PI / 2.0).abs() < 1e-12);
    }

    #[test]
    fn holes_subtract() {
        let outer = vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
        let hole = vec![[2.0, 2.0], [2.0, 4.0], [4.0, 4.0], [4.0, 2.0]];
        let m = rings_moments(&[outer, hole]).unwrap();
        assert!((m.area - 96.0).abs() < 1e-12);
        assert!((m.centroid[0] - (500.0 - 12.0) / 96.0).abs() < 1e-12);
    }

    fn raster_ellipse(e: &Ellipse, w: usize, h: usize) -> Labels {
        let mut l = Labels::new(w, h);
        let (c, s) = (e.theta.cos(), e.theta.sin());
        for y in 0..h {
            for x in 0..w {
                let (dx, dy) = (x as f64 + 0.5 - e.center[0], y as f64 + 0.5 - e.center[1]);
                let (u, v) = (dx * c + dy * s, -dx * s + dy * c);
                if (u / e.a).powi(2) + (v / e.b).powi(2) <= 1.0 {
                    l.data[y * w + x] = 7;
                }
            }
        }
        l
    }

    #[test]
    fn f2_raster_fit_agrees_with_polygon_fit() {
        let mut rng = Rng::new(5);
        let mut worst = (0.0f64, 0.0f64);
        for _ in 0..20 {
            let b = rng.range(12.0, 20.0);
            let a = b * rng.range(1.3, 3.0);
            let truth =
                Ellipse { center: [rng.range(60.0, 70.0), rng.range(60.0, 70.0)], a, b, theta: rng.range(0.0, PI) };
            let labels = raster_ellipse(&truth, 140, 140);
            let fits = fit_labels(&labels, None);
            assert_eq!(fits.len(), 1);
            assert!(fits[0].pixels >= 500, "{}", fits[0].pixels);
            let r = fits[0].ellipse.unwrap();
            let p = fit_polygon(&ellipse_polygon(&truth, 256)).unwrap();
            let dax = ((r.a - p.a) / p.a).abs().max(((r.b - p.b) / p.b).abs());
            let dt = axial_angle_diff(r.theta, p.theta).to_degrees();
            worst = (worst.0.max(dax), worst.1.max(dt));
        }
        eprintln!("F2 raster vs polygon (20 ellipses ≥ 500 px): worst axis {:.4} θ {:.4}°", worst.0, worst.1);
        assert!(worst.0 < 0.02 && worst.1 < 1.0, "worst axis {} θ {}°", worst.0, worst.1);
    }

    #[test]
    fn f2_constant_weights_give_the_unweighted_centroid() {
        let truth = Ellipse { center: [50.3, 41.7], a: 30.0, b: 12.0, theta: 1.0 };
        let labels = raster_ellipse(&truth, 100, 90);
        let plain = fit_labels(&labels, None)[0];
        let weights = vec![0.37f32; 100 * 90];
        let weighted = fit_labels(&labels, Some(&weights))[0];
        for k in 0..2 {
            assert!((plain.moments.centroid[k] - weighted.moments.centroid[k]).abs() < 1e-12);
        }
        for k in 0..3 {
            assert!((plain.moments.cov[k] - weighted.moments.cov[k]).abs() < 1e-9);
        }
        // Point-set variant: constant weights equal no weights.
        let pts: Vec<Point> = (0..50).map(|i| [i as f64 * 1.3, (i * i % 17) as f64]).collect();
        let w = vec![2.5; 50];
        let a = weighted_centroid(&pts, None).unwrap();
        let b = weighted_centroid(&pts, Some(&w)).unwrap();
        assert!((a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12);
        // Non-constant weights pull the centroid.
        let ramp: Vec<f32> = (0..100 * 90).map(|i| (i % 100) as f32).collect();
        let pulled = fit_labels(&labels, Some(&ramp))[0];
        assert!(pulled.moments.centroid[0] > plain.moments.centroid[0] + 1.0);
    }

    #[test]
    fn degenerate_inputs() {
        assert!(fit_polygon(&[[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]).is_none());
        assert!(fit_points(&[[0.0, 0.0], [1.0, 0.0]], None).is_none());
        assert!(fit_points(&[], None).is_none());
    }
}
