//! Turning-function shape distance ([references: arkin]; [references: frasson §3.5.4], V12).
//!
//! `Θ(s)` maps normalised arc length `s ∈ [0, 1)` (perimeter scaled to 1) to the tangent
//! angle; it steps by the turning angle at each vertex (left turns in the y-up sense
//! positive; polygons are taken with positive signed area in raw coordinates and reversed
//! otherwise) and is extended by `Θ(s + 1) = Θ(s) + total turning` (`2π` for a simple
//! polygon).
//!
//! `d(A, B) = min_{t, θ} ( ∫_0^1 (Θ_A(s + t) − Θ_B(s) + θ)² ds )^½`. For a fixed start shift
//! `t`, with `f(s) = Θ_A(s + t) − Θ_B(s)` and `F = ∫f`, the best rotation is `θ* = −F` and
//! `d²(t) = ∫(f − F)²`. Between *critical events* (a breakpoint of `A` meeting one of `B`,
//! `t = a_i − b_j mod 1`) `d²(t)` is concave, so its minimum is at an event: we evaluate all
//! `m·n` events, `O(mn(m + n))` in total.
//!
//! Rotation-forbidden mode: `Θ` keeps absolute tangent angles (the first step is the
//! direction of the first edge) and `θ` may only be a multiple of `2π`:
//! `d²(t) = ∫(f − F)² + (F + 2πk)²` with `k = round(−F / 2π)`.
//!
//! Breakpoints closer than [`SNAP`] are treated as equal and steps shorter than it are
//! ignored, so floating-point noise in arc lengths (rotated, rescaled or re-started copies of
//! a polygon) does not leave slivers that the square root would amplify.

use crate::synth::structure::mesh::faces::signed_area;
use crate::synth::structure::types::Point;
use std::f64::consts::{PI, TAU};

/// Breakpoints (in normalised arc length) closer than this are one breakpoint.
pub const SNAP: f64 = 1e-12;

/// The turning function of a polygon: step `i` covers `[starts[i], starts[i + 1])` (the
/// last one ends at 1) with tangent angle `angles[i]`.
#[derive(Clone, Debug, PartialEq)]
pub struct TurningFunction {
    pub starts: Vec<f64>,
    pub angles: Vec<f64>,
    /// `Θ(s + 1) − Θ(s)`.
    pub total: f64,
    /// `Â_k` for `k = 1..=`[`HARMONICS`] (real, imaginary): the Fourier coefficients of the
    /// periodic part `Θ(s) − total·s`, which are `(1 / 2πik) Σ_j τ_j e^{−2πik s_j}` with `τ_j`
    /// the turn at breakpoint `s_j` (the turn at 0 included). They give lower bounds of the
    /// distance that prune the search ([`best_match_bounded`]).
    pub spectrum: Vec<[f64; 2]>,
    /// `Â_k e^{2πik s_i}` for every breakpoint `s_i` (row `i`, [`HARMONICS`] entries): the
    /// spectrum of `Θ(· + s_i)`, so that the spectral bound of the critical event
    /// `t = a_i − b_j` is the squared distance between row `i` of `A` and row `j` of `B`.
    pub phased: Vec<[f64; 2]>,
}

/// Fourier harmonics kept in [`TurningFunction::spectrum`].
pub const HARMONICS: usize = 24;

/// The spectrum of a turning function (see [`TurningFunction::spectrum`]).
fn spectrum(starts: &[f64], angles: &[f64], total: f64) -> Vec<[f64; 2]> {
    let m = starts.len();
    let mut acc = vec![[0.0f64; 2]; HARMONICS];
    for j in 0..m {
        let tau = if j == 0 { total - (angles[m - 1] - angles[0]) } else { angles[j] - angles[j - 1] };
        // e^{−2πi s_j}, raised to the power k by repeated products.
        let (sn, cs) = (-TAU * starts[j]).sin_cos();
        let mut z = [1.0f64, 0.0];
        for a in acc.iter_mut() {
            z = [z[0] * cs - z[1] * sn, z[0] * sn + z[1] * cs];
            a[0] += tau * z[0];
            a[1] += tau * z[1];
        }
    }
    // Divide by 2πik: (x + iy) / (iω) = (y − ix) / ω.
    acc.iter()
        .enumerate()
        .map(|(k, a)| {
            let w = TAU * (k + 1) as f64;
            [a[1] / w, -a[0] / w]
        })
        .collect()
}

/// The rows of [`TurningFunction::phased`].
fn phased(starts: &[f64], spectrum: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut out = Vec::with_capacity(starts.len() * spectrum.len());
    for &s in starts {
        let (sn, cs) = (TAU * s).sin_cos();
        let mut z = [1.0f64, 0.0];
        for x in spectrum {
            z = [z[0] * cs - z[1] * sn, z[0] * sn + z[1] * cs];
            out.push([x[0] * z[0] - x[1] * z[1], x[0] * z[1] + x[1] * z[0]]);
        }
    }
    out
}

/// `2 Σ_k |Â_k e^{2πikt} − B̂_k|²` for `t = a_i − b_j`, from rows `i` and `j` of the phased
/// spectra (both sides multiplied by `e^{2πik b_j}`, which keeps the moduli): a lower bound
/// of `d(t)²` (Parseval's identity on the periodic parts, truncated to the kept harmonics;
/// the rotation removes the mean).
fn spectral_bound_at(pa: &[[f64; 2]], pb: &[[f64; 2]]) -> f64 {
    let mut sum = 0.0;
    for (x, y) in pa.iter().zip(pb) {
        let (re, im) = (x[0] - y[0], x[1] - y[1]);
        sum += re * re + im * im;
    }
    2.0 * sum
}

/// `2 Σ_k (|Â_k| − |B̂_k|)²`: a lower bound of `d(t)²` for every `t`.
fn spectral_bound(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
    let mut sum = 0.0;
    for (x, y) in a.iter().zip(b) {
        let d = x[0].hypot(x[1]) - y[0].hypot(y[1]);
        sum += d * d;
    }
    2.0 * sum
}

/// Whether the spectral bounds apply to the pair: both totals equal (to rounding), so that
/// `Θ_A(s + t) − Θ_B(s)` is periodic up to a constant.
fn spectra_comparable(a: &TurningFunction, b: &TurningFunction) -> bool {
    (a.total - b.total).abs() <= 1e-9
        && a.spectrum.len() == HARMONICS
        && b.spectrum.len() == HARMONICS
        && a.phased.len() == a.starts.len() * HARMONICS
        && b.phased.len() == b.starts.len() * HARMONICS
}

/// Whether a lower bound `lb` of a squared distance rules out distances up to `bound`,
/// with room for rounding and for the steps shorter than [`SNAP`] that the exact evaluation
/// ignores.
pub fn bound_exceeds(lb: f64, bound: f64) -> bool {
    lb > bound * bound * (1.0 + 1e-6) + 1e-7
}

/// A lower bound of the square of the best match's distance (`0` when none is known).
pub fn distance_lower_bound_sq(a: &TurningFunction, b: &TurningFunction) -> f64 {
    if spectra_comparable(a, b) {
        spectral_bound(&a.spectrum, &b.spectrum)
    } else {
        0.0
    }
}

impl TurningFunction {
    /// `Θ(s)` for `s ∈ [0, 1)` (other `s` use the periodic extension).
    pub fn eval(&self, s: f64) -> f64 {
        let k = s.floor();
        let s0 = s - k;
        let i = self.starts.partition_point(|&x| x <= s0).saturating_sub(1);
        self.angles[i] + k * self.total
    }
}

/// The turning function of a polygon (vertex list, implicitly closed). Zero-length edges
/// are skipped and collinear steps merged. `None` for fewer than 3 distinct vertices or a
/// zero perimeter.
pub fn turning_function(poly: &[Point]) -> Option<TurningFunction> {
    let mut pts: Vec<Point> = Vec::with_capacity(poly.len());
    for &p in poly {
        if pts.last() != Some(&p) {
            pts.push(p);
        }
    }
    while pts.len() > 1 && pts.first() == pts.last() {
        pts.pop();
    }
    if pts.len() < 3 {
        return None;
    }
    if signed_area(&pts) < 0.0 {
        pts.reverse();
    }
    let n = pts.len();
    let dirs: Vec<Point> = (0..n).map(|i| [pts[(i + 1) % n][0] - pts[i][0], pts[(i + 1) % n][1] - pts[i][1]]).collect();
    let lens: Vec<f64> = dirs.iter().map(|d| (d[0] * d[0] + d[1] * d[1]).sqrt()).collect();
    let perim: f64 = lens.iter().sum();
    if !(perim > 0.0 && perim.is_finite()) {
        return None;
    }
    let turn = |a: Point, b: Point| (a[0] * b[1] - a[1] * b[0]).atan2(a[0] * b[0] + a[1] * b[1]);
    let mut starts = vec![0.0];
    let mut angles = vec![dirs[0][1].atan2(dirs[0][0])];
    let mut s = lens[0];
    for i in 1..n {
        let t = turn(dirs[i - 1], dirs[i]);
        let cur = *angles.last().unwrap() + t;
        if t.abs() > 1e-12 {
            starts.push(s / perim);
            angles.push(cur);
        } else {
            *angles.last_mut().unwrap() = cur;
        }
        s += lens[i];
    }
    let total = angles.last().unwrap() + turn(dirs[n - 1], dirs[0]) - angles[0];
    let spectrum = spectrum(&starts, &angles, total);
    let phased = phased(&starts, &spectrum);
    Some(TurningFunction { starts, angles, total, spectrum, phased })
}

/// The result of matching `A` onto `B`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TurningMatch {
    pub distance: f64,
    /// The start shift `t ∈ [0, 1)` of `A` (normalised arc length).
    pub shift: f64,
    /// The rotation to apply to `A` (radians, increasing `atan2(dy, dx)` of raw coordinates)
    /// to best align it with `B`; a multiple of `2π` (so no rotation) in rotation-forbidden
    /// mode.
    pub rotation: f64,
}

/// `d(t)` and the best rotation for one start shift `t`.
pub fn distance_at(a: &TurningFunction, b: &TurningFunction, t: f64, allow_rotation: bool) -> (f64, f64) {
    distance_at_bounded(a, b, t, allow_rotation, f64::INFINITY).expect("an infinite bound never prunes")
}

/// Slack of the pruning tests: a value is pruned only when its lower bound exceeds the bound
/// by more than this (relative and absolute), far above the rounding of the sums, so that a
/// value equal to the bound (a tie) is always computed in full.
const PRUNE_SLACK: f64 = 1e-9;

/// [`distance_at`], giving up (`None`) as soon as `d(t)` is certain to exceed `bound`.
///
/// Over the part `[0, p]` of `[0, 1]` walked so far, `min_θ ∫_0^p (f + θ)² = s₂ − s₁²/p`
/// (`s₁`, `s₂` the partial integrals of `f − f(0)` and its square) can only grow with `p`,
/// and at `p = 1` it is `d(t)²` (rotation allowed) or a lower bound of it (rotation
/// forbidden). When it is not pruned the value returned is bit-identical to the unbounded
/// evaluation: the same sums are formed in the same order.
pub fn distance_at_bounded(
    a: &TurningFunction,
    b: &TurningFunction,
    t: f64,
    allow_rotation: bool,
    bound: f64,
) -> Option<(f64, f64)> {
    let t = t - t.floor();
    let m = a.starts.len();
    // Pruning threshold on `s₂·p − s₁²` (squared distance times p).
    let limit = if bound.is_finite() { bound * bound * (1.0 + PRUNE_SLACK) + PRUNE_SLACK } else { f64::INFINITY };
    // The step of A containing t (snapped: a start within SNAP above t counts as t).
    let i0 = a.starts.partition_point(|&x| x <= t + SNAP).saturating_sub(1);
    // Breakpoints and values of g(s) = Θ_A(s + t) on [0, 1).
    // Step k of g (k = 0..m) is A's step (i0 + k) mod m, shifted by `total` after the wrap.
    let g_end = |k: usize| -> f64 {
        // End of g's k-th step.
        let j = i0 + k + 1;
        if j < m {
            a.starts[j] - t
        } else if j - m < m && j - m <= i0 {
            a.starts[j - m] + 1.0 - t
        } else {
            1.0
        }
    };
    let g_val = |k: usize| -> f64 {
        let j = i0 + k;
        if j < m {
            a.angles[j]
        } else {
            a.angles[j - m] + a.total
        }
    };
    let nb = b.starts.len();
    let b_end = |k: usize| if k + 1 < nb { b.starts[k + 1] } else { 1.0 };
    let (mut kg, mut kb) = (0usize, 0usize);
    let mut pos = 0.0;
    let f0 = g_val(0) - b.angles[0];
    let (mut s1, mut s2) = (0.0, 0.0);
    // g has m + 1 steps at most (the one containing t is split by the wrap).
    while kg <= m && kb < nb {
        let (eg, eb) = (g_end(kg).min(1.0), b_end(kb));
        let end = if (eg - eb).abs() < SNAP { eb } else { eg.min(eb) };
        let len = end - pos;
        if len > SNAP {
            let d = g_val(kg) - b.angles[kb] - f0;
            s1 += d * len;
            s2 += d * d * len;
            if s2 * end - s1 * s1 > limit * end {
                return None;
            }
        }
        if eg <= end + SNAP {
            kg += 1;
        }
        if eb <= end + SNAP {
            kb += 1;
        }
        pos = end;
        if pos >= 1.0 - SNAP {
            break;
        }
    }
    let var = (s2 - s1 * s1).max(0.0);
    let big_f = f0 + s1;
    if allow_rotation {
        Some((var.sqrt(), -big_f))
    } else {
        let k = (-big_f / TAU).round();
        let off = big_f + TAU * k;
        Some(((var + off * off).sqrt(), TAU * k))
    }
}

/// The critical event `t = a_i − b_j mod 1`.
fn event(ai: f64, bj: f64) -> f64 {
    let mut t = ai - bj;
    if t < 0.0 {
        t += 1.0;
    }
    if t >= 1.0 {
        t -= 1.0;
    }
    t
}

/// The best match of `A` onto `B` over all critical events (ties: the first event in
/// `(i, j)` order).
pub fn best_match(a: &TurningFunction, b: &TurningFunction, allow_rotation: bool) -> TurningMatch {
    best_match_bounded(a, b, allow_rotation, f64::INFINITY).expect("an infinite bound never prunes")
}

/// [`best_match`] among the matches not worse than `bound`: `None` when every critical event
/// is certain to exceed `bound`; otherwise the match [`best_match`] would return, bit for bit,
/// whenever its distance is at most `bound` (a result above `bound` may also come back).
///
/// Each critical event first gets a spectral lower bound of `d(t)²` (Parseval on the first
/// [`HARMONICS`] Fourier coefficients of the periodic parts of `Θ`); the event with the
/// smallest bound is evaluated first, then the events are visited in `(i, j)` order, each
/// skipped if its bound exceeds the best distance so far, and otherwise evaluated with that
/// distance as its bound ([`distance_at_bounded`]). Every event that could equal the
/// minimum is evaluated exactly, and ties go to the first event in `(i, j)` order, as in
/// the exhaustive loop.
pub fn best_match_bounded(
    a: &TurningFunction,
    b: &TurningFunction,
    allow_rotation: bool,
    bound: f64,
) -> Option<TurningMatch> {
    let mut best = TurningMatch { distance: f64::INFINITY, shift: 0.0, rotation: 0.0 };
    let mut limit = bound;
    if spectra_comparable(a, b) {
        if bound_exceeds(spectral_bound(&a.spectrum, &b.spectrum), limit) {
            return None;
        }
        let nb = b.starts.len();
        let mut lbs: Vec<f64> = Vec::with_capacity(a.starts.len() * nb);
        let mut first = (f64::INFINITY, usize::MAX);
        for pa in a.phased.chunks_exact(HARMONICS) {
            for pb in b.phased.chunks_exact(HARMONICS) {
                let lb = spectral_bound_at(pa, pb);
                if lb < first.0 {
                    first = (lb, lbs.len());
                }
                lbs.push(lb);
            }
        }
        if lbs.iter().all(|lb| lb.is_finite()) {
            if first.1 != usize::MAX && !bound_exceeds(first.0, limit) {
                let t = event(a.starts[first.1 / nb], b.starts[first.1 % nb]);
                if let Some((d, _)) = distance_at_bounded(a, b, t, allow_rotation, limit) {
                    limit = limit.min(d);
                }
            }
            for (index, &lb) in lbs.iter().enumerate() {
                if bound_exceeds(lb, limit) {
                    continue;
                }
                let t = event(a.starts[index / nb], b.starts[index % nb]);
                if let Some((d, rot)) = distance_at_bounded(a, b, t, allow_rotation, limit) {
                    if d < best.distance {
                        best = TurningMatch { distance: d, shift: t, rotation: rot };
                        limit = limit.min(d);
                    }
                }
            }
            return (best.distance < f64::INFINITY || bound == f64::INFINITY).then_some(best);
        }
    }
    for &ai in &a.starts {
        for &bj in &b.starts {
            let t = event(ai, bj);
            if let Some((d, rot)) = distance_at_bounded(a, b, t, allow_rotation, limit) {
                if d < best.distance {
                    best = TurningMatch { distance: d, shift: t, rotation: rot };
                    limit = limit.min(d);
                }
            }
        }
    }
    (best.distance < f64::INFINITY || bound == f64::INFINITY).then_some(best)
}

/// Turning distance between two polygons (`∞` if either is degenerate).
pub fn turning_distance(a: &[Point], b: &[Point], allow_rotation: bool) -> f64 {
    match (turning_function(a), turning_function(b)) {
        (Some(ta), Some(tb)) => best_match(&ta, &tb, allow_rotation).distance,
        _ => f64::INFINITY,
    }
}

/// Rotates points about `c` by `angle` (raw coordinates: increases `atan2(dy, dx)`).
pub fn rotate_about(points: &[Point], c: Point, angle: f64) -> Vec<Point> {
    let (s, co) = angle.sin_cos();
    points
        .iter()
        .map(|p| {
            let (dx, dy) = (p[0] - c[0], p[1] - c[1]);
            [c[0] + dx * co - dy * s, c[1] + dx * s + dy * co]
        })
        .collect()
}

/// Wraps an angle into `(−π, π]`.
pub fn wrap_angle(a: f64) -> f64 {
    let r = a.rem_euclid(TAU);
    if r > PI {
        r - TAU
    } else {
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::rng::Rng;

    fn random_polygon(rng: &mut Rng) -> Vec<Point> {
        // Star-shaped about the origin (angular gaps < π), hence simple with total turning 2π.
        let n = 3 + rng.below(10);
        let step = TAU / n as f64;
        let angs: Vec<f64> = (0..n).map(|k| (k as f64 + rng.range(-0.2, 0.2)) * step).collect();
        angs.iter()
            .map(|&a| {
                let r = rng.range(3.0, 10.0);
                [r * a.cos(), r * a.sin()]
            })
            .collect()
    }

    fn poly_pair(rng: &mut Rng) -> (Vec<Point>, Vec<Point>) {
        loop {
            let a = random_polygon(rng);
            let b = random_polygon(rng);
            if turning_function(&a).is_some() && turning_function(&b).is_some() {
                return (a, b);
            }
        }
    }

    #[test]
    fn f14_identity_and_symmetry() {
        let mut rng = Rng::new(1);
        let mut worst_sym: f64 = 0.0;
        for _ in 0..200 {
            let (a, b) = poly_pair(&mut rng);
            assert!(turning_distance(&a, &a, true) < 1e-12);
            assert!(turning_distance(&a, &a, false) < 1e-12);
            let dab = turning_distance(&a, &b, true);
            let dba = turning_distance(&b, &a, true);
            worst_sym = worst_sym.max((dab - dba).abs());
            let fab = turning_distance(&a, &b, false);
            let fba = turning_distance(&b, &a, false);
            worst_sym = worst_sym.max((fab - fba).abs());
        }
        eprintln!("F14 symmetry: worst |d(A,B) − d(B,A)| = {worst_sym:.2e}");
        assert!(worst_sym < 1e-9, "asymmetry {worst_sym}");
    }

    #[test]
    fn f14_invariances() {
        let mut rng = Rng::new(2);
        let mut worst: f64 = 0.0;
        for _ in 0..200 {
            let (a, b) = poly_pair(&mut rng);
            let d = turning_distance(&a, &b, true);
            let moved: Vec<Point> = a.iter().map(|p| [p[0] + 123.4, p[1] - 56.7]).collect();
            let scaled: Vec<Point> = a.iter().map(|p| [p[0] * 3.7, p[1] * 3.7]).collect();
            let rotated = rotate_about(&a, [1.0, 2.0], 0.83);
            let mut cyc = a.clone();
            cyc.rotate_left(1 + rng.below(a.len() - 1));
            for v in [&moved, &scaled, &rotated, &cyc] {
                worst = worst.max((turning_distance(v, &b, true) - d).abs());
                worst = worst.max(turning_distance(v, &a, true));
            }
            // Rotation-forbidden mode is invariant to everything but rotation.
            let df = turning_distance(&a, &b, false);
            for v in [&moved, &scaled, &cyc] {
                worst = worst.max((turning_distance(v, &b, false) - df).abs());
            }
        }
        eprintln!("F14 invariance: worst deviation {worst:.2e}");
        assert!(worst < 1e-9, "worst deviation {worst}");
    }

    #[test]
    fn f14_triangle_inequality() {
        let mut rng = Rng::new(3);
        let mut worst = f64::NEG_INFINITY;
        for trial in 0..1000 {
            let a = random_polygon(&mut rng);
            let b = random_polygon(&mut rng);
            let c = random_polygon(&mut rng);
            let rot = trial % 2 == 0;
            let (ab, bc, ac) =
                (turning_distance(&a, &b, rot), turning_distance(&b, &c, rot), turning_distance(&a, &c, rot));
            worst = worst.max(ac - (ab + bc));
        }
        eprintln!("F14 triangle inequality: max d(A,C) − d(A,B) − d(B,C) = {worst:.3}");
        assert!(worst <= 1e-9, "violation {worst}");
    }

    fn dense_min(a: &TurningFunction, b: &TurningFunction, rot: bool) -> f64 {
        (0..10_000).map(|k| distance_at(a, b, k as f64 / 10_000.0, rot).0).fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn f14_critical_events_equal_dense_sweep() {
        // Rectilinear polygons with integer sides and perimeter 100 or 200: every breakpoint
        // and every critical event lies on the 1e-4 grid of the dense sweep, so the two
        // minima must agree.
        let polys: Vec<Vec<Point>> = vec![
            vec![[0.0, 0.0], [30.0, 0.0], [30.0, 20.0], [0.0, 20.0]],
            vec![[0.0, 0.0], [20.0, 0.0], [20.0, 10.0], [10.0, 10.0], [10.0, 30.0], [0.0, 30.0]],
            vec![
                [0.0, 0.0],
                [30.0, 0.0],
                [30.0, 30.0],
                [20.0, 30.0],
                [20.0, 10.0],
                [10.0, 10.0],
                [10.0, 30.0],
                [0.0, 30.0],
            ],
            vec![[0.0, 0.0], [45.0, 0.0], [45.0, 5.0], [0.0, 5.0]],
            vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [40.0, 10.0], [40.0, 20.0], [0.0, 20.0]],
        ];
        let mut worst_grid: f64 = 0.0;
        for rot in [true, false] {
            for a in &polys {
                for b in &polys {
                    let (ta, tb) = (turning_function(a).unwrap(), turning_function(b).unwrap());
                    let crit = best_match(&ta, &tb, rot).distance;
                    let dense = dense_min(&ta, &tb, rot);
                    worst_grid = worst_grid.max((crit - dense).abs());
                    assert!((crit - dense).abs() < 1e-6, "crit {crit} dense {dense}");
                }
            }
        }
        // Random polygons: the events are never beaten by the sweep, and the sweep comes
        // within its resolution (step 1e-4 times the slope of d(t)).
        let mut rng = Rng::new(4);
        let mut worst_gap: f64 = 0.0;
        for _ in 0..30 {
            let (a, b) = poly_pair(&mut rng);
            let (ta, tb) = (turning_function(&a).unwrap(), turning_function(&b).unwrap());
            let crit = best_match(&ta, &tb, true).distance;
            let dense = dense_min(&ta, &tb, true);
            assert!(crit <= dense + 1e-12, "crit {crit} dense {dense}");
            worst_gap = worst_gap.max(dense - crit);
        }
        eprintln!("F14 events vs dense sweep: grid-aligned worst {worst_grid:.2e}; random worst gap {worst_gap:.2e}");
        assert!(worst_gap < 1e-2, "{worst_gap}");
    }

    #[test]
    fn f14_rotation_forbidden() {
        let p = vec![[0.0, 0.0], [40.0, 0.0], [40.0, 10.0], [0.0, 10.0]];
        let q = rotate_about(&p, [20.0, 5.0], PI / 2.0);
        assert!(turning_distance(&p, &q, true) < 1e-9);
        let forbidden = turning_distance(&p, &q, false);
        eprintln!("F14 rotation-forbidden d(P, rot90 P) = {forbidden:.4}");
        assert!(forbidden > 0.5, "{forbidden}");
        // A half turn maps a rectangle onto itself.
        let h = rotate_about(&p, [20.0, 5.0], PI);
        assert!(turning_distance(&p, &h, false) < 1e-9);
        // The rotation found re-aligns a rotated copy.
        let (ta, tb) = (turning_function(&q).unwrap(), turning_function(&p).unwrap());
        let m = best_match(&ta, &tb, true);
        assert!(wrap_angle(m.rotation + PI / 2.0).abs() < 1e-9 || wrap_angle(m.rotation - PI / 2.0).abs() < 1e-9);
    }

    #[test]
    fn turning_function_basics() {
        let sq = turning_function(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]).unwrap();
        assert_eq!(sq.starts, vec![0.0, 0.25, 0.5, 0.75]);
        assert!((sq.total - TAU).abs() < 1e-12);
        assert!((sq.eval(0.3) - PI / 2.0).abs() < 1e-12);
        assert!((sq.eval(1.3) - PI / 2.0 - TAU).abs() < 1e-12);
        // Clockwise input is reversed; collinear points are merged.
        let cw = turning_function(&[[0.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 0.5], [1.0, 0.0]]).unwrap();
        assert_eq!(cw.starts.len(), 4);
        assert!((cw.total - TAU).abs() < 1e-12);
        assert!(turning_function(&[[0.0, 0.0], [1.0, 0.0]]).is_none());
    }
}
