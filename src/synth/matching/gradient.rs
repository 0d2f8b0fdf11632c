//! Bounded conjugate-gradient descent, the thesis's second local search "in unforgiving cases"
//! ([references: bourque §4.4]): Polak–Ribière directions (β clamped at zero, so a bad
//! direction restarts as steepest descent) from finite-difference gradients, each line search
//! a bracketing search along the direction (never past the wall of the unit cube) refined by
//! Brent's method.
//!
//! Renders cannot be differentiated, so the gradient costs `2n` renders with central
//! differences (`n` with forward ones, beside the loss at the point, which the line search
//! already holds). A coordinate on a wall is differenced one-sidedly, a coordinate whose step
//! snaps back onto the point (a whole-number parameter) has no derivative and is left to the
//! matcher's whole-number sweep, and a direction component pushing out of a wall is dropped.
//!
//! Hand-written for the same reasons as the simplex (bounds, snapping, one iteration cap, the
//! trace the tests read); `argmin`'s CG expects analytic gradients and unbounded line searches.

use serde::{Deserialize, Serialize};

use super::simplex::{into_box, LocalResult};

/// How a derivative is estimated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Differences {
    /// `(f(x + h) − f(x)) / h`: `n` renders per gradient.
    Forward,
    /// `(f(x + h) − f(x − h)) / 2h`: `2n` renders per gradient.
    Central,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GradientConfig {
    /// Finite-difference step, in unit-cube coordinates.
    pub step: f64,
    pub differences: Differences,
    /// Conjugate-gradient iterations (one line search each).
    pub max_iterations: usize,
    /// Loss evaluations of one line search.
    pub line_evaluations: usize,
    /// Relative change of the loss over one iteration that ends the search.
    pub ftol: f64,
}

impl Default for GradientConfig {
    fn default() -> Self {
        GradientConfig {
            step: 1e-3,
            differences: Differences::Central,
            max_iterations: 30,
            line_evaluations: 20,
            ftol: 1e-6,
        }
    }
}

/// The finite-difference gradient of `loss` at `x` (whose loss is `fx`), and the renders it
/// took. `eval` clamps and snaps the points it is given.
pub(super) fn gradient(
    eval: &mut impl FnMut(&mut Vec<f64>) -> f64,
    x: &[f64],
    fx: f64,
    cfg: &GradientConfig,
) -> (Vec<f64>, usize) {
    let mut g = vec![0.0; x.len()];
    let mut renders = 0;
    for i in 0..x.len() {
        let mut probe = |offset: f64| -> Option<(f64, f64)> {
            let mut p = x.to_vec();
            p[i] = (x[i] + offset).clamp(0.0, 1.0);
            let f = eval(&mut p);
            renders += 1;
            let moved = p[i] - x[i];
            (moved != 0.0).then_some((f, moved))
        };
        let h = cfg.step;
        g[i] = match cfg.differences {
            Differences::Central if x[i] - h >= 0.0 && x[i] + h <= 1.0 => match (probe(h), probe(-h)) {
                (Some((fp, dp)), Some((fm, dm))) => (fp - fm) / (dp - dm),
                _ => 0.0,
            },
            // Forward differences, or a central difference that would leave the cube.
            _ => {
                let offset = if x[i] + h <= 1.0 { h } else { -h };
                probe(offset).map_or(0.0, |(f, moved)| (f - fx) / moved)
            }
        };
    }
    (g, renders)
}

/// The largest `t ≥ 0` with `x + t·d` in the unit cube.
fn reach(x: &[f64], d: &[f64]) -> f64 {
    x.iter()
        .zip(d)
        .map(|(&c, &v)| {
            if v > 0.0 {
                (1.0 - c) / v
            } else if v < 0.0 {
                -c / v
            } else {
                f64::INFINITY
            }
        })
        .fold(f64::INFINITY, f64::min)
}

/// A line search along a direction: `phi(t)` for `t` in `[0, t_max]`, `phi(0) = f0`, at most
/// `evaluations` calls, the first trial at `t0`. The minimum is bracketed first (doubling the
/// trial while it improves, quartering it while it does not), then refined by [`brent`]; the
/// best `(t, phi(t))` seen is returned.
fn line_search(mut phi: impl FnMut(f64) -> f64, t_max: f64, f0: f64, t0: f64, evaluations: usize) -> (f64, f64) {
    let mut left = evaluations.max(2);
    let mut t = t0.clamp(f64::MIN_POSITIVE, t_max);
    let mut ft = phi(t);
    left -= 1;
    let mut best = if ft < f0 { (t, ft) } else { (0.0, f0) };
    let (lo, hi);
    if ft < f0 {
        // Double while it improves, up to the wall.
        let mut prev = 0.0;
        loop {
            if t >= t_max || left <= evaluations / 2 {
                (lo, hi) = (prev, t);
                break;
            }
            let t2 = (2.0 * t).min(t_max);
            let f2 = phi(t2);
            left -= 1;
            if f2 < best.1 {
                best = (t2, f2);
            }
            if f2 >= ft {
                (lo, hi) = (prev, t2);
                break;
            }
            (prev, t, ft) = (t, t2, f2);
        }
    } else {
        // Quarter until it improves.
        loop {
            if left <= evaluations / 2 || t < 1e-12 {
                break;
            }
            let t2 = 0.25 * t;
            let f2 = phi(t2);
            left -= 1;
            if f2 < best.1 {
                best = (t2, f2);
                break;
            }
            t = t2;
        }
        (lo, hi) = (0.0, if best.0 > 0.0 { 4.0 * best.0 } else { t });
    }
    let refined = brent(phi, lo, hi.min(t_max), left);
    if refined.1 < best.1 {
        refined
    } else {
        best
    }
}

/// Brent's minimisation of `phi` on `[a, b]` (golden sections with parabolic steps, as in
/// Forsythe, Malcolm and Moler's `fmin`), at most `evaluations` calls; the best `(t, phi(t))`
/// it evaluated.
fn brent(mut phi: impl FnMut(f64) -> f64, a: f64, b: f64, evaluations: usize) -> (f64, f64) {
    const GOLD: f64 = 0.381_966_011_250_105_1;
    if evaluations == 0 || b <= a {
        return (a, f64::INFINITY);
    }
    let (mut lo, mut hi) = (a, b);
    let mut x = lo + GOLD * (hi - lo);
    let mut fx = phi(x);
    let (mut w, mut fw, mut v, mut fv) = (x, fx, x, fx);
    let (mut d, mut e): (f64, f64) = (0.0, 0.0);
    let mut best = (x, fx);
    let tol = 1e-6 * b.max(1e-12);
    for _ in 1..evaluations {
        let m = 0.5 * (lo + hi);
        if (x - m).abs() <= 2.0 * tol - 0.5 * (hi - lo) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol {
            let r = (x - w) * (fx - fv);
            let q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            let mut q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            if p.abs() < (0.5 * q * e).abs() && p > q * (lo - x) && p < q * (hi - x) {
                e = d;
                d = p / q;
                let u = x + d;
                if u - lo < 2.0 * tol || hi - u < 2.0 * tol {
                    d = if x < m { tol } else { -tol };
                }
                golden = false;
            }
        }
        if golden {
            e = if x < m { hi - x } else { lo - x };
            d = GOLD * e;
        }
        let u = if d.abs() >= tol { x + d } else { x + tol.copysign(d) };
        let fu = phi(u);
        if fu < best.1 {
            best = (u, fu);
        }
        if fu <= fx {
            if u < x {
                hi = x;
            } else {
                lo = x;
            }
            (v, fv, w, fw, x, fx) = (w, fw, x, fx, u, fu);
        } else {
            if u < x {
                lo = u;
            } else {
                hi = u;
            }
            if fu <= fw || w == x {
                (v, fv, w, fw) = (w, fw, u, fu);
            } else if fu <= fv || v == x || v == w {
                (v, fv) = (u, fu);
            }
        }
    }
    best
}

/// Minimises `loss` over `[0, 1]^n` from `x0` (see the module documentation). `snap` moves a
/// point onto one that may be evaluated; `stop` ends the search when it returns true for the
/// best loss so far.
pub fn descend(
    mut loss: impl FnMut(&[f64]) -> f64,
    snap: impl Fn(&mut [f64]),
    x0: &[f64],
    cfg: &GradientConfig,
    stop: impl Fn(f64) -> bool,
) -> LocalResult {
    let n = x0.len();
    let mut evaluations = 0;
    let mut eval = |x: &mut Vec<f64>| {
        into_box(x, &snap);
        evaluations += 1;
        loss(x)
    };
    let mut x = x0.to_vec();
    let mut f = eval(&mut x);
    let mut trace = Vec::new();
    let mut iterations = 0;
    let mut converged = n == 0;
    let (mut g_old, mut d_old): (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
    let mut g_here: Option<Vec<f64>> = None;
    let mut step_length = 0.05;
    while !converged && iterations < cfg.max_iterations && !stop(f) {
        iterations += 1;
        let g = match g_here.take() {
            Some(g) => g,
            None => gradient(&mut eval, &x, f, cfg).0,
        };
        // Polak–Ribière, clamped at zero.
        let beta = if g_old.is_empty() {
            0.0
        } else {
            let den: f64 = g_old.iter().map(|v| v * v).sum();
            let num: f64 = g.iter().zip(&g_old).map(|(a, b)| a * (a - b)).sum();
            if den > 0.0 {
                (num / den).max(0.0)
            } else {
                0.0
            }
        };
        let mut d: Vec<f64> = (0..n).map(|i| -g[i] + if beta > 0.0 { beta * d_old[i] } else { 0.0 }).collect();
        if d.iter().zip(&g).map(|(a, b)| a * b).sum::<f64>() >= 0.0 {
            d = g.iter().map(|v| -v).collect();
        }
        // Drop what pushes out of a wall.
        for i in 0..n {
            if (x[i] <= 0.0 && d[i] < 0.0) || (x[i] >= 1.0 && d[i] > 0.0) {
                d[i] = 0.0;
            }
        }
        let t_max = reach(&x, &d);
        if !t_max.is_finite() || t_max <= 0.0 {
            converged = true;
            trace.push(f);
            break;
        }
        // The first trial repeats the last step's length (the simplex's initial step at first).
        let norm = d.iter().map(|v| v * v).sum::<f64>().sqrt();
        let t0 = step_length / norm;
        let (t, ft) = line_search(
            |t| {
                let mut p: Vec<f64> = x.iter().zip(&d).map(|(c, v)| c + t * v).collect();
                eval(&mut p)
            },
            t_max,
            f,
            t0,
            cfg.line_evaluations,
        );
        let step_made = t > 0.0 && ft < f;
        if step_made {
            step_length = (t * norm).max(1e-6);
        }
        if step_made {
            let mut p: Vec<f64> = x.iter().zip(&d).map(|(c, v)| c + t * v).collect();
            into_box(&mut p, &snap);
            let small = 2.0 * (f - ft).abs() <= cfg.ftol * (f.abs() + ft.abs()) + 1e-15;
            (x, f) = (p, ft);
            converged = small;
        } else if beta > 0.0 {
            // The conjugate direction did not help: restart from steepest descent.
            g_old.clear();
            g_here = Some(g);
            trace.push(f);
            continue;
        } else {
            converged = true;
        }
        trace.push(f);
        (g_old, d_old) = (g, d);
    }
    LocalResult { x, loss: f, iterations, evaluations, trace, converged }
}
