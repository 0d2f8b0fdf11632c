//! One V-cycle with a zero initial guess, the preconditioner of the iterations in `driver`:
//! smoothing down, residual restriction, the exact coarsest solve, and correction back up.

use rayon::prelude::*;

use super::hierarchy::Hierarchy;
use super::ops::Sums;
use super::smooth::Stage;
use super::transfer::{coarse_span, restrict_x, ProlongSrc};
use crate::synth::blend::lanes::Lanes;

/// Buffers for V-cycles on one hierarchy. Level 0's `x` and `b` are the preconditioner's
/// output and input.
pub(crate) struct Workspace<V: Lanes> {
    pub x: Vec<Vec<V>>,
    pub b: Vec<Vec<V>>,
}

/// Smoothing sweeps per V-cycle side.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CycleParams {
    pub pre: usize,
    pub post: usize,
}

/// Coarse rows per parallel task of the restriction.
const TRANSFER_ROWS: usize = 32;
/// Fine rows whose x-restricted residual a restriction task keeps.
const RESTRICT_CACHE: usize = 6;

/// Computes the residual `b − L u` of level k and restricts it into `out` (level k+1's
/// right-hand side, written on free coarse cells only), without storing the fine residual:
/// each task of coarse rows computes the residual rows it needs (on free cells), restricts
/// them along x (over the coarse span of their free cells) and keeps the last few (rows
/// shared by neighbouring coarse rows are computed once per task). Every coarse value is the
/// same fixed-order sum whatever the blocking.
fn residual_restrict<V: Lanes>(hier: &Hierarchy, k: usize, u: &[V], b: &[V], out: &mut [V]) {
    let (f, c) = (&hier.levels[k], &hier.levels[k + 1]);
    let t = &hier.transfers[k];
    let (wf, wc) = (f.w, c.w);
    let body = |j0: usize, oc: &mut [V]| {
        // Zero outside the free cells of the row being processed.
        let mut res = vec![V::default(); wf];
        // (fine row, x-restricted residual, span); zero outside the span.
        let mut cache: Vec<(usize, Vec<V>, (usize, usize))> = Vec::with_capacity(RESTRICT_CACHE);
        for (dj, orow) in oc.chunks_mut(wc).enumerate() {
            let j = j0 + dj;
            if c.row_empty(j) {
                continue;
            }
            let entries = t.y.restr_of(j);
            for &(y, _) in entries {
                if cache.iter().any(|e| e.0 == y) {
                    continue;
                }
                let (mut xr, old) = if cache.len() >= RESTRICT_CACHE {
                    let e = cache.remove(0);
                    (e.1, e.2)
                } else {
                    (vec![V::default(); wc], (0, 0))
                };
                xr[old.0..old.1].fill(V::default());
                let runs = f.row_runs(y);
                let span = match (runs.first(), runs.last()) {
                    (Some(&(x0, _)), Some(&(_, x1))) => {
                        f.op_row(u, Some(b), &mut res, y);
                        let span = coarse_span(x0, x1, wf, wc);
                        restrict_x(&t.x, &res, &mut xr, span);
                        for &(a, e) in runs {
                            res[a..e].fill(V::default());
                        }
                        span
                    }
                    _ => (0, 0),
                };
                cache.push((y, xr, span));
            }
            for &(x0, x1) in c.row_runs(j) {
                let o = &mut orow[x0..x1];
                o.fill(V::default());
                for &(y, wgt) in entries {
                    let xr = &cache.iter().find(|e| e.0 == y).expect("cached row").1;
                    let wv = V::splat(wgt);
                    for (ov, xv) in o.iter_mut().zip(&xr[x0..x1]) {
                        *ov = *ov + wv * *xv;
                    }
                }
            }
        }
    };
    if f.parallel::<V>() {
        out.par_chunks_mut(wc * TRANSFER_ROWS).enumerate().for_each(|(k, oc)| body(k * TRANSFER_ROWS, oc));
    } else {
        body(0, out);
    }
}

/// Solves the coarsest level by conjugate gradients in f64 (to 1e-12 relative), lane by
/// lane.
fn coarsest_solve<V: Lanes>(hier: &Hierarchy, b: &[V], x: &mut [V]) {
    let lv = hier.levels.last().unwrap();
    let n = hier.coarse_cells.len();
    if n == 0 {
        return;
    }
    let w = lv.w;
    let apply = |u: &[f64], out: &mut [f64]| {
        for (k, &cell) in hier.coarse_cells.iter().enumerate() {
            let (cx, cy) = (cell % w, cell / w);
            let mut s = 0.0;
            let mut d = 0.0;
            let mut add = |xx: isize, yy: isize| {
                let (xx, yy) = if lv.periodic {
                    (xx.rem_euclid(w as isize) as usize, yy.rem_euclid(lv.h as isize) as usize)
                } else if xx < 0 || yy < 0 || xx >= w as isize || yy >= lv.h as isize {
                    return;
                } else {
                    (xx as usize, yy as usize)
                };
                d += 1.0;
                let j = hier.coarse_index[yy * w + xx];
                if j != usize::MAX {
                    s += u[j];
                }
            };
            let (xi, yi) = (cx as isize, cy as isize);
            add(xi - 1, yi);
            add(xi + 1, yi);
            add(xi, yi - 1);
            add(xi, yi + 1);
            out[k] = d * u[k] - s;
        }
    };
    let mut u = vec![0.0f64; n];
    let mut r = vec![0.0f64; n];
    let mut p = vec![0.0f64; n];
    let mut q = vec![0.0f64; n];
    for lane in 0..V::N {
        for (ri, &c) in r.iter_mut().zip(&hier.coarse_cells) {
            *ri = b[c].get(lane) as f64;
        }
        let bn = r.iter().map(|v| v * v).sum::<f64>().sqrt();
        u.fill(0.0);
        if bn > 0.0 {
            p.copy_from_slice(&r);
            let mut rr: f64 = r.iter().map(|v| v * v).sum();
            for _ in 0..(10 * n + 100) {
                if rr.sqrt() <= 1e-12 * bn {
                    break;
                }
                apply(&p, &mut q);
                let pq: f64 = p.iter().zip(&q).map(|(a, b)| a * b).sum();
                if pq <= 0.0 {
                    break;
                }
                let alpha = rr / pq;
                for i in 0..n {
                    u[i] += alpha * p[i];
                    r[i] -= alpha * q[i];
                }
                let rr_new: f64 = r.iter().map(|v| v * v).sum();
                let beta = rr_new / rr;
                rr = rr_new;
                for i in 0..n {
                    p[i] = r[i] + beta * p[i];
                }
            }
        }
        for (k, &c) in hier.coarse_cells.iter().enumerate() {
            x[c].set(lane, u[k] as f32);
        }
    }
}

/// Applies one V-cycle with zero initial guess: `ws.x[0] ≈ L⁻¹ ws.b[0]` (lane-wise). With
/// `want_dot`, also returns `ws.b[0] · ws.x[0]` per lane when the finest level was smoothed
/// (taken during the last sweep; None otherwise).
pub(crate) fn vcycle<V: Lanes>(
    hier: &Hierarchy,
    ws: &mut Workspace<V>,
    cp: CycleParams,
    want_dot: bool,
) -> Option<Sums> {
    let nl = hier.levels.len();
    let pre: Vec<Stage> = (0..cp.pre)
        .flat_map(|s| [Stage::Smooth { colour: 0, zero_init: s == 0 }, Stage::Smooth { colour: 1, zero_init: false }])
        .collect();
    let post: Vec<Stage> = std::iter::once(Stage::Prolong)
        .chain((0..cp.post).flat_map(|_| {
            [Stage::Smooth { colour: 1, zero_init: false }, Stage::Smooth { colour: 0, zero_init: false }]
        }))
        .collect();
    for k in 0..nl - 1 {
        let lv = &hier.levels[k];
        lv.run_stages(&mut ws.x[k], &ws.b[k], &pre, None, false, false);
        lv.band_smooth(&mut ws.x[k], &ws.b[k], 0);
        let (lo, hi) = ws.b.split_at_mut(k + 1);
        residual_restrict(hier, k, &ws.x[k], &lo[k], &mut hi[0]);
    }
    {
        let k = nl - 1;
        coarsest_solve(hier, &ws.b[k], &mut ws.x[k]);
    }
    let mut dot = None;
    for k in (0..nl - 1).rev() {
        let lv = &hier.levels[k];
        let (lo, hi) = ws.x.split_at_mut(k + 1);
        let pro = ProlongSrc { t: &hier.transfers[k], e: &hi[0], wc: hier.levels[k + 1].w };
        lv.prolong_band(&mut lo[k], &pro);
        lv.band_smooth(&mut lo[k], &ws.b[k], 1);
        dot = lv.run_stages(&mut lo[k], &ws.b[k], &post, Some(&pro), false, want_dot && k == 0);
    }
    dot
}
