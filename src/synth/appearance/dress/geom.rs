//! Plane geometry of the dressing: areas, ear-clipping triangulation, affine texture maps,
//! simple-polygon checks ([references: frasson §4.2.3]).

use crate::synth::appearance::types::Point;

/// A map from target positions to texture positions: `uv = [a[0]·(x, y, 1), a[1]·(x, y, 1)]`.
pub type Affine = [[f64; 3]; 2];

#[inline]
pub fn apply(a: &Affine, p: Point) -> Point {
    [a[0][0] * p[0] + a[0][1] * p[1] + a[0][2], a[1][0] * p[0] + a[1][1] * p[1] + a[1][2]]
}

#[inline]
pub fn sub(a: Point, b: Point) -> Point {
    [a[0] - b[0], a[1] - b[1]]
}

#[inline]
pub fn add(a: Point, b: Point) -> Point {
    [a[0] + b[0], a[1] + b[1]]
}

#[inline]
pub fn mul(a: Point, s: f64) -> Point {
    [a[0] * s, a[1] * s]
}

#[inline]
pub fn dot(a: Point, b: Point) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// `a × b` (z of the 3-D cross product).
#[inline]
pub fn cross(a: Point, b: Point) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// `v` turned by +90° in raw coordinates (from +x towards +y): the "left" normal of the
/// y-up reading, the side that faces the next branch in increasing angle.
#[inline]
pub fn perp(v: Point) -> Point {
    [-v[1], v[0]]
}

#[inline]
pub fn lerp(a: Point, b: Point, t: f64) -> Point {
    [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t]
}

#[inline]
pub fn norm(a: Point) -> f64 {
    a[0].hypot(a[1])
}

/// `(b − o) × (c − o)`: positive when `o, b, c` turn by increasing angle.
#[inline]
pub fn orient(o: Point, b: Point, c: Point) -> f64 {
    cross(sub(b, o), sub(c, o))
}

/// Shoelace area on raw coordinates (positive for the mesh's region orientation).
pub fn signed_area(poly: &[Point]) -> f64 {
    let n = poly.len();
    (0..n).map(|i| cross(poly[i], poly[(i + 1) % n])).sum::<f64>() * 0.5
}

/// Ear-clipping triangulation of a simple polygon (either orientation; concave allowed).
/// Triangles come out with the polygon's orientation; collinear vertices are dropped without a
/// triangle. If no ear is found (a non-simple input), the rest is closed as a fan.
pub fn triangulate(poly: &[Point]) -> Vec<[usize; 3]> {
    let n = poly.len();
    if n < 3 {
        return Vec::new();
    }
    let sign = if signed_area(poly) >= 0.0 { 1.0 } else { -1.0 };
    let scale = poly.iter().fold(0.0f64, |m, p| m.max(p[0].abs()).max(p[1].abs())).max(1.0);
    let eps = 1e-12 * scale * scale;
    let mut idx: Vec<usize> = (0..n).collect();
    let mut out = Vec::with_capacity(n - 2);
    while idx.len() > 3 {
        let m = idx.len();
        let mut clipped = false;
        for k in 0..m {
            let (a, b, c) = (idx[(k + m - 1) % m], idx[k], idx[(k + 1) % m]);
            let turn = sign * orient(poly[a], poly[b], poly[c]);
            if turn.abs() <= eps {
                // Collinear (or a repeated point): drop it, no area is lost.
                idx.remove(k);
                clipped = true;
                break;
            }
            if turn < 0.0 {
                continue;
            }
            let blocked = idx.iter().any(|&o| {
                if o == a || o == b || o == c {
                    return false;
                }
                let p = poly[o];
                if p == poly[a] || p == poly[b] || p == poly[c] {
                    return false;
                }
                sign * orient(poly[a], poly[b], p) >= 0.0
                    && sign * orient(poly[b], poly[c], p) >= 0.0
                    && sign * orient(poly[c], poly[a], p) >= 0.0
            });
            if !blocked {
                out.push([a, b, c]);
                idx.remove(k);
                clipped = true;
                break;
            }
        }
        if !clipped {
            for k in 1..idx.len() - 1 {
                out.push([idx[0], idx[k], idx[k + 1]]);
            }
            return out;
        }
    }
    if idx.len() == 3 && (sign * orient(poly[idx[0]], poly[idx[1]], poly[idx[2]])).abs() > eps {
        out.push([idx[0], idx[1], idx[2]]);
    }
    out
}

/// The affine map taking the triangle `pos` onto `uv`, `None` when `pos` is degenerate.
pub fn affine_from_triangle(pos: [Point; 3], uv: [Point; 3]) -> Option<Affine> {
    let e1 = sub(pos[1], pos[0]);
    let e2 = sub(pos[2], pos[0]);
    let det = cross(e1, e2);
    if det.abs() < 1e-12 {
        return None;
    }
    let f1 = sub(uv[1], uv[0]);
    let f2 = sub(uv[2], uv[0]);
    // [f1 f2] = L [e1 e2]  →  L = [f1 f2] [e1 e2]^-1.
    let inv = [[e2[1] / det, -e2[0] / det], [-e1[1] / det, e1[0] / det]];
    let mut a = [[0.0; 3]; 2];
    for r in 0..2 {
        let (g1, g2) = (f1[r], f2[r]);
        a[r][0] = g1 * inv[0][0] + g2 * inv[1][0];
        a[r][1] = g1 * inv[0][1] + g2 * inv[1][1];
        a[r][2] = uv[0][r] - a[r][0] * pos[0][0] - a[r][1] * pos[0][1];
    }
    Some(a)
}

/// Whether segments `ab` and `cd` cross at a point interior to both (touching ends do not).
pub fn segments_cross(a: Point, b: Point, c: Point, d: Point) -> bool {
    let d1 = orient(a, b, c);
    let d2 = orient(a, b, d);
    let d3 = orient(c, d, a);
    let d4 = orient(c, d, b);
    ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
}

/// No two non-adjacent sides of the closed polygon cross, and no side has zero length.
pub fn is_simple(poly: &[Point]) -> bool {
    let n = poly.len();
    if n < 3 {
        return false;
    }
    for i in 0..n {
        if poly[i] == poly[(i + 1) % n] {
            return false;
        }
    }
    for i in 0..n {
        for j in i + 2..n {
            if i == 0 && j == n - 1 {
                continue;
            }
            if segments_cross(poly[i], poly[(i + 1) % n], poly[j], poly[(j + 1) % n]) {
                return false;
            }
        }
    }
    true
}

/// Every fan triangle `(center, poly[k], poly[k+1])` turns positively: the polygon is
/// star-shaped from `center` in increasing angle, so its fan is a valid triangulation.
pub fn fan_is_valid(center: Point, poly: &[Point]) -> bool {
    let n = poly.len();
    let turns: f64 = (0..n)
        .map(|k| {
            let (a, b) = (sub(poly[k], center), sub(poly[(k + 1) % n], center));
            cross(a, b).atan2(dot(a, b))
        })
        .sum();
    (0..n).all(|k| orient(center, poly[k], poly[(k + 1) % n]) > 1e-12) && (turns - std::f64::consts::TAU).abs() < 1e-6
}
