//! The iterations that drive the V-cycles (conjugate gradients preconditioned by one cycle, or
//! plain cycles), lane by lane with their own stopping tests, and their scratch buffers.

use super::cycle::{vcycle, CycleParams, Workspace};
use super::hierarchy::Hierarchy;
use super::level::Level;
use super::ops::{Sums, MAX_LANES};
use crate::synth::blend::lanes::{par_copy, Pooled};

/// Outcome of an iterative solve of one lane.
#[derive(Clone, Copy, Debug)]
pub(crate) struct IterStats {
    pub iterations: usize,
    /// The recurrence residual met both stopping bounds.
    pub converged: bool,
}

/// Which iteration drives the multigrid cycles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Driver {
    Pcg,
    VCycles,
}

/// Buffers of one solve (taken from and returned to the scratch pool).
pub(crate) struct SolveBuffers<V: Pooled> {
    ws: Workspace<V>,
    p: Vec<V>,
}

impl<V: Pooled> SolveBuffers<V> {
    pub fn new(hier: &Hierarchy) -> SolveBuffers<V> {
        let pool = V::pool();
        let size = |l: &Level| l.w * l.h;
        // x: zero on fixed cells (their values are read as neighbours); free cells are
        // written before they are read. b: read and written on free cells only; level 0's
        // is the caller's residual, swapped in per cycle.
        let x = hier.levels.iter().map(|l| pool.take_zeroed(size(l))).collect();
        let b =
            hier.levels.iter().enumerate().map(|(k, l)| if k == 0 { Vec::new() } else { pool.take(size(l)) }).collect();
        SolveBuffers { ws: Workspace { x, b }, p: Vec::new() }
    }
}

impl<V: Pooled> Drop for SolveBuffers<V> {
    fn drop(&mut self) {
        let pool = V::pool();
        for p in self.ws.x.drain(..).chain(self.ws.b.drain(..)).chain([std::mem::take(&mut self.p)]) {
            pool.give(p);
        }
    }
}

/// When the iterative solve of one lane stops.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Stop {
    /// Bound on `‖b − L u‖₂`.
    pub norm: f64,
    /// Bound on `max |b − L u|`.
    pub max: f64,
    pub max_iter: usize,
}

/// Solves `L u = r` lane-wise on the hierarchy's free cells from `u = 0`. Lane `k <
/// stops.len()` stops when both bounds of `stops[k]` hold or after `stops[k].max_iter`
/// iterations (it keeps its values while other lanes go on); lanes past `stops.len()` must
/// be zero and stay zero. On entry `r` holds the right-hand sides; on exit the final
/// residuals. `u` must be zero on fixed cells.
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve<V: Pooled>(
    hier: &Hierarchy,
    bufs: &mut SolveBuffers<V>,
    r: &mut Vec<V>,
    u: &mut [V],
    stops: &[Stop],
    driver: Driver,
    cp: CycleParams,
    progress: crate::synth::Progress<'_>,
) -> Vec<IterStats> {
    let lv = &hier.levels[0];
    let nl = stops.len().min(V::N);
    let mut stats = vec![IterStats { iterations: 0, converged: false }; nl];
    let done = |k: usize, rr: &Sums, rmax: &Sums| rr[k].sqrt() <= stops[k].norm && rmax[k] <= stops[k].max;
    let (rr, rmax) = (lv.dot(r, r), lv.max_abs(r));
    let mut active = [false; MAX_LANES];
    for k in 0..nl {
        if lv.count == 0 || done(k, &rr, &rmax) {
            stats[k].converged = true;
        } else {
            active[k] = true;
        }
    }
    let max_iter = stops[..nl].iter().map(|s| s.max_iter).max().unwrap_or(0);
    let SolveBuffers { ws, p } = bufs;
    // z = M⁻¹ r into ws.x[0]; with `want_dot`, returns r·z.
    let precondition = |r: &mut Vec<V>, ws: &mut Workspace<V>, want_dot: bool| -> Sums {
        std::mem::swap(&mut ws.b[0], r);
        let dot = vcycle(hier, ws, cp, want_dot);
        std::mem::swap(&mut ws.b[0], r);
        match dot {
            Some(d) => d,
            None if want_dot => lv.dot(r, &ws.x[0]),
            None => [0.0; MAX_LANES],
        }
    };
    // Records iteration `it` for the active lanes and retires the converged ones (and those
    // at their iteration cap). Returns whether any lane is still active.
    let mut retire = |it: usize, rr: &Sums, rmax: &Sums, active: &mut [bool; MAX_LANES]| {
        for k in 0..nl {
            if active[k] {
                stats[k].iterations = it;
                if done(k, rr, rmax) {
                    stats[k].converged = true;
                    active[k] = false;
                } else if it >= stops[k].max_iter {
                    active[k] = false;
                }
            }
        }
        active.iter().any(|&a| a)
    };
    if !active.iter().any(|&a| a) {
        return stats;
    }
    let mut it = 0;
    match driver {
        Driver::VCycles => {
            while it < max_iter {
                precondition(r, ws, false);
                // u += z; r −= L z.
                let alpha = std::array::from_fn(|k| if active[k] { 1.0 } else { 0.0 });
                let (rr, rmax) = lv.cg_update(u, r, &ws.x[0], alpha);
                it += 1;
                progress.report(it, max_iter);
                if !retire(it, &rr, &rmax, &mut active) {
                    break;
                }
            }
        }
        Driver::Pcg => {
            let mut rz = precondition(r, ws, true);
            if p.len() != ws.x[0].len() {
                *p = V::pool().take(ws.x[0].len());
            }
            par_copy(p, &ws.x[0]);
            let mut pq = lv.dot_lap(p);
            while it < max_iter {
                for k in 0..nl {
                    if active[k] && (pq[k] <= 0.0 || !pq[k].is_finite()) {
                        // Breakdown: this lane stops unconverged; clear its direction so the
                        // zero steps below leave it unchanged.
                        active[k] = false;
                        lv.zero_lane(p, k);
                    }
                }
                if !active.iter().any(|&a| a) {
                    break;
                }
                let alpha = std::array::from_fn(|k| if active[k] { rz[k] / pq[k] } else { 0.0 });
                let (rr, rmax) = lv.cg_update(u, r, p, alpha);
                it += 1;
                progress.report(it, max_iter);
                if !retire(it, &rr, &rmax, &mut active) {
                    break;
                }
                let rz_new = precondition(r, ws, true);
                let beta = std::array::from_fn(|k| if active[k] { rz_new[k] / rz[k] } else { 0.0 });
                rz = rz_new;
                pq = lv.update_direction(&ws.x[0], beta, p);
            }
        }
    }
    stats
}
