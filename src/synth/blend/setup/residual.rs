//! The residual of the normal equations in f64 on the free pixels (per row, summed in a fixed
//! order), which both sets and checks the stopping bounds of the masked solves.

use rayon::prelude::*;

use super::grid::Graph;
use super::guidance::div;
use crate::synth::blend::lanes::Lanes;
use crate::synth::blend::multigrid::Level;

/// Rows per reduction block in this file's f64 sums (fixed: thread-count independent).
const ROWS_PER_BLOCK: usize = 16;

pub(super) fn relative(rn: f64, bnorm: f64) -> f64 {
    if bnorm > 0.0 {
        rn / bnorm
    } else {
        rn
    }
}

/// Sums over free pixels returned by [`residual`].
#[derive(Clone, Copy, Default)]
pub(super) struct ResidualSums {
    /// `Σ r²` with `r_p = Σ_q (f_q − f_p) − Σ_q t(p→q)`.
    pub(super) rr: f64,
    /// `max |r|`.
    pub(super) rmax: f64,
    /// `Σ b²` with `b_p = Σ_{q fixed} f_q − Σ_q t(p→q)` (the normal equations' right-hand
    /// side, fixed values taken from `f`).
    pub(super) bb: f64,
}

/// Residual of the normal equations on the free pixels (runs of `lv`) of row `y`, in f64;
/// optionally stored (as f32) in `out_row` (the row's slice of a plane). With `WITH_B` the
/// right-hand side's `Σ b²` is summed too (else `bb` is 0). Interior pixels use a
/// branch-free stencil; the image border goes through the graph's neighbour functions.
#[allow(clippy::too_many_arguments)]
#[inline]
fn residual_row<const WITH_B: bool>(
    g: &Graph,
    lv: &Level,
    f: &[f32],
    free: &[u8],
    tx: &[f32],
    ty: &[f32],
    y: usize,
    mut out_row: Option<&mut [f32]>,
) -> ResidualSums {
    let w = g.w;
    let mut acc = ResidualSums::default();
    let generic = |x: usize| -> (f64, f64) {
        let p = y * w + x;
        let fp = f[p] as f64;
        let mut lap = 0.0f64;
        let mut fixed = 0.0f64;
        for q in [g.left(x, y), g.right(x, y), g.up(x, y), g.down(x, y)].into_iter().flatten() {
            lap += f[q] as f64 - fp;
            if free[q] == 0 {
                fixed += f[q] as f64;
            }
        }
        let dv = div(g, tx, ty, x, y);
        (lap - dv, fixed - dv)
    };
    let push = |x: usize, r: f64, b: f64, acc: &mut ResidualSums, out_row: &mut Option<&mut [f32]>| {
        acc.rr += r * r;
        let ra = r.abs();
        acc.rmax = if ra > acc.rmax { ra } else { acc.rmax };
        if WITH_B {
            acc.bb += b * b;
        }
        if let Some(o) = out_row.as_deref_mut() {
            o[x] = r as f32;
        }
    };
    let interior_row = g.periodic || (y > 0 && y + 1 < g.h);
    let (up, dn) = if interior_row { (((y + g.h - 1) % g.h) * w, ((y + 1) % g.h) * w) } else { (0, 0) };
    let row = y * w;
    for &(x0, x1) in lv.row_runs(y) {
        if !interior_row {
            for x in x0..x1 {
                let (r, b) = generic(x);
                push(x, r, b, &mut acc, &mut out_row);
            }
            continue;
        }
        let mut xs = x0;
        let mut xe = x1;
        if xs == 0 {
            let (r, b) = generic(0);
            push(0, r, b, &mut acc, &mut out_row);
            xs = 1;
        }
        let last = xe == w && xe > xs;
        if last {
            xe -= 1;
        }
        if xe > xs {
            let n = xe - xs;
            let (fc, fl, frt) =
                (&f[row + xs..row + xe], &f[row + xs - 1..row + xe - 1], &f[row + xs + 1..row + xe + 1]);
            let (fu, fd) = (&f[up + xs..up + xe], &f[dn + xs..dn + xe]);
            let (txc, txl) = (&tx[row + xs..row + xe], &tx[row + xs - 1..row + xe - 1]);
            let (tyc, tyu) = (&ty[row + xs..row + xe], &ty[up + xs..up + xe]);
            let (frl, frr) = (&free[row + xs - 1..row + xe - 1], &free[row + xs + 1..row + xe + 1]);
            let (fru, frd) = (&free[up + xs..up + xe], &free[dn + xs..dn + xe]);
            let (fc, fl, frt, fu, fd) = (&fc[..n], &fl[..n], &frt[..n], &fu[..n], &fd[..n]);
            let (txc, txl, tyc, tyu) = (&txc[..n], &txl[..n], &tyc[..n], &tyu[..n]);
            let (frl, frr, fru, frd) = (&frl[..n], &frr[..n], &fru[..n], &frd[..n]);
            // Residual and right-hand side of pixel i of the run.
            macro_rules! cell {
                ($i:expr) => {{
                    let i = $i;
                    let nb = [fl[i] as f64, frt[i] as f64, fu[i] as f64, fd[i] as f64];
                    let lap = -4.0 * fc[i] as f64 + nb[0] + nb[1] + nb[2] + nb[3];
                    let dv = txc[i] as f64 - txl[i] as f64 + tyc[i] as f64 - tyu[i] as f64;
                    let b = if WITH_B {
                        let fr = [frl[i], frr[i], fru[i], frd[i]];
                        let mut fixed = 0.0f64;
                        for k in 0..4 {
                            fixed += if fr[k] == 0 { nb[k] } else { 0.0 };
                        }
                        fixed - dv
                    } else {
                        0.0
                    };
                    (lap - dv, b)
                }};
            }
            // Two interleaved accumulators (pixels of even and odd offset), then combined.
            let (mut rr0, mut rr1, mut bb0, mut bb1, mut m0, mut m1) =
                (0.0f64, 0.0f64, 0.0f64, 0.0f64, acc.rmax, acc.rmax);
            let mut o = out_row.as_deref_mut().map(|o| &mut o[xs..xe]);
            let mut i = 0;
            while i + 1 < n {
                let (r0, b0) = cell!(i);
                let (r1, b1) = cell!(i + 1);
                rr0 += r0 * r0;
                rr1 += r1 * r1;
                bb0 += b0 * b0;
                bb1 += b1 * b1;
                let (a0, a1) = (r0.abs(), r1.abs());
                m0 = if a0 > m0 { a0 } else { m0 };
                m1 = if a1 > m1 { a1 } else { m1 };
                if let Some(o) = o.as_deref_mut() {
                    o[i] = r0 as f32;
                    o[i + 1] = r1 as f32;
                }
                i += 2;
            }
            if i < n {
                let (r0, b0) = cell!(i);
                rr0 += r0 * r0;
                bb0 += b0 * b0;
                let a0 = r0.abs();
                m0 = if a0 > m0 { a0 } else { m0 };
                if let Some(o) = o {
                    o[i] = r0 as f32;
                }
            }
            acc.rr += rr0 + rr1;
            if WITH_B {
                acc.bb += bb0 + bb1;
            }
            acc.rmax = m0.max(m1);
        }
        if last {
            let (r, b) = generic(w - 1);
            push(w - 1, r, b, &mut acc, &mut out_row);
        }
    }
    acc
}

fn merge_sums(a: ResidualSums, b: ResidualSums) -> ResidualSums {
    ResidualSums { rr: a.rr + b.rr, rmax: a.rmax.max(b.rmax), bb: a.bb + b.bb }
}

/// [`residual_row`] summed over all rows (fixed blocks of rows, merged in order).
pub(super) fn residual<const WITH_B: bool>(
    g: &Graph,
    lv: &Level,
    f: &[f32],
    free: &[u8],
    tx: &[f32],
    ty: &[f32],
) -> ResidualSums {
    let parts: Vec<ResidualSums> = (0..g.h.div_ceil(ROWS_PER_BLOCK))
        .into_par_iter()
        .map(|bi| {
            let mut acc = ResidualSums::default();
            for y in bi * ROWS_PER_BLOCK..((bi + 1) * ROWS_PER_BLOCK).min(g.h) {
                acc = merge_sums(acc, residual_row::<WITH_B>(g, lv, f, free, tx, ty, y, None));
            }
            acc
        })
        .collect();
    parts.into_iter().fold(ResidualSums::default(), merge_sums)
}

/// The residuals of up to `V::N` channels (`chans[k]` = (f, tx, ty) of lane k), with the
/// right-hand side sums, stored interleaved in `out` on free pixels (one pass over `out`).
pub(super) fn residual_lanes<V: Lanes>(
    g: &Graph,
    lv: &Level,
    free: &[u8],
    chans: &[(&[f32], &[f32], &[f32])],
    out: &mut [V],
) -> Vec<ResidualSums> {
    let w = g.w;
    let nc = chans.len();
    let parts: Vec<Vec<ResidualSums>> = out
        .par_chunks_mut(w * ROWS_PER_BLOCK)
        .enumerate()
        .map(|(bi, chunk)| {
            let mut acc = vec![ResidualSums::default(); nc];
            let mut rows = vec![vec![0.0f32; w]; nc];
            for (dy, orow) in chunk.chunks_mut(w).enumerate() {
                let y = bi * ROWS_PER_BLOCK + dy;
                for (k, &(f, tx, ty)) in chans.iter().enumerate() {
                    let sums = residual_row::<true>(g, lv, f, free, tx, ty, y, Some(&mut rows[k]));
                    acc[k] = merge_sums(acc[k], sums);
                }
                for &(x0, x1) in lv.row_runs(y) {
                    for x in x0..x1 {
                        orow[x] = V::from_fn(|k| if k < nc { rows[k][x] } else { 0.0 });
                    }
                }
            }
            acc
        })
        .collect();
    (0..nc).map(|k| parts.iter().fold(ResidualSums::default(), |a, p| merge_sums(a, p[k]))).collect()
}
