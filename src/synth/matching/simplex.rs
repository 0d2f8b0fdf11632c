//! Bounded downhill simplex (Nelder–Mead, as in Numerical Recipes §10.4, which the thesis
//! follows [references: bourque §4.4]) on the unit cube, minimising a loss (matching minimises
//! `1 − S`).
//!
//! Hand-written rather than taken from `argmin`: the search needs every evaluated point kept
//! inside the box (a shader cannot render outside its ranges; argmin's Nelder–Mead is
//! unbounded), points snapped to whole numbers before they are evaluated, one iteration cap
//! shared by the restarts (the thesis's "under 100 iterations") and the trace of best losses
//! the tests read; the method itself is forty lines.
//!
//! Moves and coefficients are NR's: reflection (−1), expansion (2), one-dimensional
//! contraction (½), shrink toward the best vertex (½). The initial simplex steps each axis by
//! `step` (away from the nearer wall). A run ends when the simplex's losses agree to `ftol`
//! (relative) or at the cap; the search then restarts once from its best point, as the thesis
//! did.

use std::collections::HashMap;

use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimplexConfig {
    /// Initial step along each axis, in unit-cube coordinates.
    pub step: f64,
    /// Relative agreement of the simplex's losses that ends a run.
    pub ftol: f64,
    /// Iterations over all runs together.
    pub max_iterations: usize,
    /// Runs after the first, each from the best point so far.
    pub restarts: usize,
}

impl Default for SimplexConfig {
    fn default() -> Self {
        SimplexConfig { step: 0.05, ftol: 1e-4, max_iterations: 100, restarts: 1 }
    }
}

/// The outcome of a local search ([`minimise`] or [`descend`](super::gradient::descend)).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LocalResult {
    pub x: Vec<f64>,
    pub loss: f64,
    pub iterations: usize,
    pub evaluations: usize,
    /// The best loss after each iteration (never increasing).
    pub trace: Vec<f64>,
    /// The loss stopped improving (rather than the cap or `stop` ending the search).
    pub converged: bool,
}

/// Moves a point a local search wants to evaluate onto one it may: inside the unit cube (NaN
/// to 0), then `snap`ped (whole numbers whole).
pub(super) fn into_box(x: &mut [f64], snap: &impl Fn(&mut [f64])) {
    for c in x.iter_mut() {
        *c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    }
    snap(x);
}

/// Minimises `loss` over `[0, 1]^n` from `x0`. `snap` moves a point onto one that may be
/// evaluated (inside the box, whole numbers whole); `stop` ends the search early when it
/// returns true for the best loss so far.
pub fn minimise(
    mut loss: impl FnMut(&[f64]) -> f64,
    snap: impl Fn(&mut [f64]),
    x0: &[f64],
    cfg: &SimplexConfig,
    stop: impl Fn(f64) -> bool,
) -> LocalResult {
    let n = x0.len();
    let mut evaluations = 0;
    // Snapping maps many of the simplex's points onto one (whole numbers, the box's walls):
    // each distinct point is rendered once.
    let mut seen: HashMap<Vec<u64>, f64> = HashMap::new();
    let mut eval = |x: &mut Vec<f64>| {
        into_box(x, &snap);
        *seen.entry(x.iter().map(|v| v.to_bits()).collect()).or_insert_with(|| {
            evaluations += 1;
            loss(x)
        })
    };
    let mut best_x = x0.to_vec();
    let mut best = eval(&mut best_x);
    let mut trace = Vec::new();
    let mut iterations = 0;
    let mut converged = false;
    if n == 0 || stop(best) {
        return LocalResult { x: best_x, loss: best, iterations, evaluations, trace, converged: n == 0 };
    }
    'runs: for _ in 0..=cfg.restarts {
        let mut pts = vec![best_x.clone()];
        let mut vals = vec![best];
        for i in 0..n {
            let mut x = best_x.clone();
            x[i] += if x[i] + cfg.step <= 1.0 { cfg.step } else { -cfg.step };
            vals.push(eval(&mut x));
            pts.push(x);
        }
        converged = false;
        while iterations < cfg.max_iterations {
            // Order: best first, worst last (ties by position, a fixed order).
            let mut order: Vec<usize> = (0..=n).collect();
            order.sort_by(|&a, &b| vals[a].total_cmp(&vals[b]).then(a.cmp(&b)));
            pts = order.iter().map(|&i| pts[i].clone()).collect();
            vals = order.iter().map(|&i| vals[i]).collect();
            if vals[0] < best {
                best = vals[0];
                best_x = pts[0].clone();
            }
            let (lo, hi) = (vals[0], vals[n]);
            if 2.0 * (hi - lo).abs() <= cfg.ftol * (hi.abs() + lo.abs()) + 1e-12 {
                converged = true;
                break;
            }
            if stop(best) {
                break 'runs;
            }
            iterations += 1;
            let centroid: Vec<f64> = (0..n).map(|j| pts[..n].iter().map(|p| p[j]).sum::<f64>() / n as f64).collect();
            let towards =
                |t: f64| -> Vec<f64> { (0..n).map(|j| centroid[j] + t * (pts[n][j] - centroid[j])).collect() };
            let mut xr = towards(-1.0);
            let fr = eval(&mut xr);
            if fr < vals[0] {
                let mut xe = towards(-2.0);
                let fe = eval(&mut xe);
                (pts[n], vals[n]) = if fe < fr { (xe, fe) } else { (xr, fr) };
            } else if fr < vals[n - 1] {
                (pts[n], vals[n]) = (xr, fr);
            } else {
                let mut xc = towards(0.5);
                let fc = eval(&mut xc);
                if fc < vals[n].min(fr) {
                    (pts[n], vals[n]) = (xc, fc);
                } else if fr < vals[n] {
                    (pts[n], vals[n]) = (xr, fr);
                } else {
                    for i in 1..=n {
                        let mut x: Vec<f64> = (0..n).map(|j| pts[0][j] + 0.5 * (pts[i][j] - pts[0][j])).collect();
                        vals[i] = eval(&mut x);
                        pts[i] = x;
                    }
                }
            }
            let round_best = vals.iter().copied().fold(f64::INFINITY, f64::min);
            if round_best < best {
                let i = vals.iter().position(|&v| v == round_best).expect("present");
                best = round_best;
                best_x = pts[i].clone();
            }
            trace.push(best);
        }
        if iterations >= cfg.max_iterations {
            break;
        }
    }
    LocalResult { x: best_x, loss: best, iterations, evaluations, trace, converged }
}
