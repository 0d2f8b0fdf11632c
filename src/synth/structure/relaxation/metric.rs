//! The elliptic (anisotropic) metric of [references: frasson §3.5.1] and its Manhattan / Chebyshev
//! variants ([references: frasson §3.7.2], "metric map").
//!
//! For an ellipse with centre `c`, semi-axes `a ≥ b` and major-axis angle `θ` (from +x towards
//! +y, y down), let `(u, v) = R(−θ)(p − c)`. Then
//!
//! * elliptic:  `d = sqrt((u/a)² + (v/b)²)` — equal to the thesis's `‖p − c‖ / r(α)` with the
//!   polar radius `r(α)² = b² / (1 − e² cos² α)`, `α` measured from the major axis;
//! * Manhattan: `d = |u/a| + |v/b|` (diamond-shaped unit ball aligned with the ellipse axes,
//!   Lloyd under it turns cells into squares at 45° to the ellipse axes: F19 test);
//! * Chebyshev: `d = max(|u/a|, |v/b|)` (rectangular unit ball circumscribing the ellipse).
//!
//! All three are `1` on the boundary of their unit ball, `0` at the centre, positively
//! homogeneous in `p − c`, and scale exactly by `1/k` when both axes are multiplied by `k`
//! (bit-exactly for powers of two), so a global scale never changes a partition.

use serde::{Deserialize, Serialize};

use crate::synth::structure::types::{Ellipse, Point};

/// Which norm of `(u/a, v/b)` measures the distance to a generator.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MetricKind {
    /// `sqrt((u/a)² + (v/b)²)` (the thesis's metric).
    #[default]
    Elliptic,
    /// `|u/a| + |v/b|`.
    Manhattan,
    /// `max(|u/a|, |v/b|)`.
    Chebyshev,
}

impl MetricKind {
    /// The norm of the normalised offset `(s, t) = (u/a, v/b)`.
    #[inline(always)]
    pub fn norm(self, s: f64, t: f64) -> f64 {
        // `+ 0.0` turns a possible −0 into +0 so keys compare correctly as raw bits.
        match self {
            MetricKind::Elliptic => (s * s + t * t).sqrt() + 0.0,
            MetricKind::Manhattan => s.abs() + t.abs(),
            MetricKind::Chebyshev => s.abs().max(t.abs()),
        }
    }

    /// Constants `(lo, hi)` with `lo·‖(s,t)‖₂ ≤ norm(s,t) ≤ hi·‖(s,t)‖₂`.
    #[inline]
    pub fn euclid_bounds(self) -> (f64, f64) {
        match self {
            MetricKind::Elliptic => (1.0, 1.0),
            MetricKind::Manhattan => (1.0, std::f64::consts::SQRT_2),
            MetricKind::Chebyshev => (std::f64::consts::FRAC_1_SQRT_2, 1.0),
        }
    }
}

/// An ellipse prepared for fast distance evaluation: `(u/a, v/b) = M (p − c)`.
///
/// `M = [[cos θ / a, sin θ / a], [−sin θ / b, cos θ / b]]`. Each entry is one correctly rounded
/// division, so multiplying `a` and `b` by a power of two scales every entry, and therefore
/// every distance, exactly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EllipseFrame {
    pub cx: f64,
    pub cy: f64,
    pub m: [f64; 4],
    /// `1/a` and `1/b`, for Euclidean bounds (`‖p−c‖/a ≤ d_elliptic ≤ ‖p−c‖/b`).
    pub inv_a: f64,
    pub inv_b: f64,
}

impl EllipseFrame {
    pub fn new(e: &Ellipse) -> Self {
        let (s, c) = e.theta.sin_cos();
        EllipseFrame {
            cx: e.center[0],
            cy: e.center[1],
            m: [c / e.a, s / e.a, -s / e.b, c / e.b],
            inv_a: 1.0 / e.a,
            inv_b: 1.0 / e.b,
        }
    }

    /// The normalised offset `(u/a, v/b)` of `(x, y)`.
    #[inline(always)]
    pub fn normalized(&self, x: f64, y: f64) -> (f64, f64) {
        let dx = x - self.cx;
        let dy = y - self.cy;
        (self.m[0] * dx + self.m[1] * dy, self.m[2] * dx + self.m[3] * dy)
    }

    /// The distance of `(x, y)` under `kind`.
    #[inline(always)]
    pub fn distance(&self, kind: MetricKind, x: f64, y: f64) -> f64 {
        let (s, t) = self.normalized(x, y);
        kind.norm(s, t)
    }
}

/// The closed-form elliptic distance `sqrt((u/a)² + (v/b)²)`.
pub fn elliptic_distance(e: &Ellipse, p: Point) -> f64 {
    EllipseFrame::new(e).distance(MetricKind::Elliptic, p[0], p[1])
}

/// The distance from `p` to ellipse generator `e` under `kind`.
pub fn distance(e: &Ellipse, kind: MetricKind, p: Point) -> f64 {
    EllipseFrame::new(e).distance(kind, p[0], p[1])
}

/// The thesis's polar radius `r(α) = sqrt(b² / (1 − e² cos² α))`, `e² = 1 − b²/a²`, with `α`
/// measured from the major axis.
pub fn polar_radius(a: f64, b: f64, alpha: f64) -> f64 {
    let e2 = 1.0 - (b * b) / (a * a);
    let c = alpha.cos();
    (b * b / (1.0 - e2 * c * c)).sqrt()
}

/// The thesis's form `‖p − c‖ / r(α)` of the elliptic distance (corrected, [references: frasson §3.5.1]: `α`
/// is measured from the ellipse's major axis). Slower than [`elliptic_distance`]; kept as a
/// reference for tests.
pub fn polar_distance(e: &Ellipse, p: Point) -> f64 {
    let dx = p[0] - e.center[0];
    let dy = p[1] - e.center[1];
    let r = dx.hypot(dy);
    if r == 0.0 {
        return 0.0;
    }
    let alpha = dy.atan2(dx) - e.theta;
    r / polar_radius(e.a, e.b, alpha)
}

/// Euclidean distance from `p` to the segment `[p0, p1]` (the Fig. 3.5 segment generators).
#[inline]
pub fn segment_distance(p0: Point, p1: Point, x: f64, y: f64) -> f64 {
    let ex = p1[0] - p0[0];
    let ey = p1[1] - p0[1];
    let wx = x - p0[0];
    let wy = y - p0[1];
    let len2 = ex * ex + ey * ey;
    let t = if len2 > 0.0 { ((wx * ex + wy * ey) / len2).clamp(0.0, 1.0) } else { 0.0 };
    let dx = wx - t * ex;
    let dy = wy - t * ey;
    (dx * dx + dy * dy).sqrt() + 0.0
}

/// Normalises an axial angle into `[0, π)`.
pub fn wrap_axial(theta: f64) -> f64 {
    let pi = std::f64::consts::PI;
    let mut t = theta % pi;
    if t < 0.0 {
        t += pi;
    }
    if t >= pi {
        t -= pi;
    }
    t
}

/// Returns `e` with `a ≥ b` (swapping the axes and turning `θ` by 90° if needed) and
/// `θ ∈ [0, π)`.
pub fn canonical(mut e: Ellipse) -> Ellipse {
    if e.b > e.a {
        std::mem::swap(&mut e.a, &mut e.b);
        e.theta += std::f64::consts::FRAC_PI_2;
    }
    e.theta = wrap_axial(e.theta);
    e
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn ell(cx: f64, cy: f64, a: f64, b: f64, theta: f64) -> Ellipse {
        Ellipse { center: [cx, cy], a, b, theta }
    }

    /// F6: `d = 1 ± 1e-12` on 360 boundary points, `0` at the centre.
    #[test]
    fn f6_unit_on_boundary_zero_at_centre() {
        for e in [ell(10.0, -3.0, 7.0, 2.5, 0.7), ell(0.0, 0.0, 3.0, 3.0, 0.0), ell(100.5, 40.25, 40.0, 15.0, 2.9)] {
            let (s, c) = e.theta.sin_cos();
            let mut worst: f64 = 0.0;
            for k in 0..360 {
                let t = k as f64 * PI / 180.0;
                let (u, v) = (e.a * t.cos(), e.b * t.sin());
                let p = [e.center[0] + c * u - s * v, e.center[1] + s * u + c * v];
                worst = worst.max((elliptic_distance(&e, p) - 1.0).abs());
            }
            assert!(worst < 1e-12, "worst |d-1| = {worst}");
            assert_eq!(elliptic_distance(&e, e.center), 0.0);
            assert_eq!(distance(&e, MetricKind::Manhattan, e.center), 0.0);
            assert_eq!(distance(&e, MetricKind::Chebyshev, e.center), 0.0);
        }
    }

    /// Manhattan and Chebyshev are 1 on the diamond / rectangle with vertices on the axes.
    #[test]
    fn variants_unit_balls() {
        let e = ell(5.0, 6.0, 8.0, 3.0, 0.4);
        let (s, c) = e.theta.sin_cos();
        let to_xy = |u: f64, v: f64| [e.center[0] + c * u - s * v, e.center[1] + s * u + c * v];
        for k in 0..=100 {
            let f = k as f64 / 100.0;
            // Diamond edge between (a,0) and (0,b).
            let p = to_xy(e.a * f, e.b * (1.0 - f));
            assert!((distance(&e, MetricKind::Manhattan, p) - 1.0).abs() < 1e-12);
            // Rectangle edge u = a, v ∈ [−b, b].
            let p = to_xy(e.a, e.b * (2.0 * f - 1.0));
            assert!((distance(&e, MetricKind::Chebyshev, p) - 1.0).abs() < 1e-12);
        }
    }

    /// F6: the closed form equals the polar formula to 1e-12.
    #[test]
    fn f6_closed_form_equals_polar() {
        let mut rng = crate::synth::rng::Rng::new(6);
        let mut worst: f64 = 0.0;
        for _ in 0..2000 {
            let b = rng.range(0.5, 30.0);
            let a = b * rng.range(1.0, 5.0);
            let e = ell(rng.range(-50.0, 50.0), rng.range(-50.0, 50.0), a, b, rng.range(0.0, PI));
            let p = [rng.range(-100.0, 100.0), rng.range(-100.0, 100.0)];
            let d1 = elliptic_distance(&e, p);
            let d2 = polar_distance(&e, p);
            worst = worst.max((d1 - d2).abs() / d1.max(1.0));
        }
        assert!(worst < 1e-12, "worst relative difference {worst}");
    }

    #[test]
    fn scaling_by_powers_of_two_is_exact() {
        let e = ell(3.3, 4.4, 9.1, 2.7, 1.1);
        let mut e2 = e;
        e2.a *= 2.0;
        e2.b *= 2.0;
        for kind in [MetricKind::Elliptic, MetricKind::Manhattan, MetricKind::Chebyshev] {
            for p in [[0.5, 0.5], [17.5, 3.5], [-40.5, 22.5]] {
                assert_eq!(distance(&e, kind, p), 2.0 * distance(&e2, kind, p));
            }
        }
    }

    #[test]
    fn canonical_and_wrap() {
        let e = canonical(ell(0.0, 0.0, 2.0, 5.0, 0.3));
        assert_eq!((e.a, e.b), (5.0, 2.0));
        assert!((e.theta - (0.3 + PI / 2.0)).abs() < 1e-15);
        assert!((wrap_axial(-0.1) - (PI - 0.1)).abs() < 1e-15);
        assert!((wrap_axial(7.0) - (7.0 - 2.0 * PI)).abs() < 1e-12);
        let p = [3.0, 4.0];
        assert!((segment_distance([0.0, 0.0], [10.0, 0.0], p[0], p[1]) - 4.0).abs() < 1e-15);
        assert!((segment_distance([0.0, 0.0], [0.0, 0.0], p[0], p[1]) - 5.0).abs() < 1e-15);
    }
}
