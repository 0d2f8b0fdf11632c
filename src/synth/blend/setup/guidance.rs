//! The guidance field (target differences per right and down edge) for each selector, mode
//! and seam rule, with the sources' value range that the fused binary case computes alongside.

use rayon::prelude::*;

use super::grid::{ChanSel, Graph};
use crate::synth::blend::lanes::Pooled;
use crate::synth::blend::params::{BlendParams, Mode, Seam, WrapGuidance};

/// `max − min` over the sources' values (1 when they are constant): the scale that
/// `Solver::max_tol` is relative to.
pub(super) fn value_range(srcs: &[&[f32]]) -> f64 {
    let (lo, hi) = srcs
        .par_iter()
        .flat_map(|s| s.par_chunks(1 << 16))
        .map(chunk_range)
        .reduce(|| (f32::MAX, f32::MIN), |a, b| (a.0.min(b.0), a.1.max(b.1)));
    range_of(lo, hi)
}

/// `hi − lo`, or 1 when that is not positive.
fn range_of(lo: f32, hi: f32) -> f64 {
    let r = (hi - lo) as f64;
    if r > 0.0 {
        r
    } else {
        1.0
    }
}

/// Exact (min, max) of `c` (eight running extremes, so it vectorises; any order gives the
/// same result).
fn chunk_range(c: &[f32]) -> (f32, f32) {
    let (mut lo, mut hi) = ([f32::MAX; 8], [f32::MIN; 8]);
    let q = c.chunks_exact(8);
    for &v in q.remainder() {
        lo[0] = if v < lo[0] { v } else { lo[0] };
        hi[0] = if v > hi[0] { v } else { hi[0] };
    }
    for q in q {
        for k in 0..8 {
            lo[k] = if q[k] < lo[k] { q[k] } else { lo[k] };
            hi[k] = if q[k] > hi[k] { q[k] } else { hi[k] };
        }
    }
    (lo.iter().fold(f32::MAX, |a, &b| a.min(b)), hi.iter().fold(f32::MIN, |a, &b| a.max(b)))
}

/// Guidance differences: `tx[p]` is the target of `f(right(p)) − f(p)`, `ty[p]` of
/// `f(down(p)) − f(p)` (unused where the edge does not exist).
pub(super) fn guidance(g: &Graph, srcs: &[&[f32]], sel: &ChanSel<'_>, params: &BlendParams) -> (Vec<f32>, Vec<f32>) {
    let mixed = params.mode == Mode::Mixed;
    match sel {
        ChanSel::Labels(l) if srcs.len() == 2 && !mixed && params.seam == Seam::Insert => {
            binary_insert_guidance(g, srcs[0], srcs[1], l, params.wrap_guidance == WrapGuidance::Zero)
        }
        ChanSel::Labels(l) => {
            let d = |s: usize, p: usize, q: usize| srcs[s][q] - srcs[s][p];
            if mixed {
                fill_guidance(g, params, |p, q| {
                    let (lp, lq) = (l[p] as usize, l[q] as usize);
                    let mut best = d(lp, p, q);
                    for s in [lq, 0] {
                        let v = d(s, p, q);
                        if v.abs() > best.abs() {
                            best = v;
                        }
                    }
                    best
                })
            } else {
                match params.seam {
                    Seam::Insert => fill_guidance(g, params, |p, q| d(l[p].max(l[q]) as usize, p, q)),
                    Seam::Average => {
                        fill_guidance(g, params, |p, q| 0.5 * (d(l[p] as usize, p, q) + d(l[q] as usize, p, q)))
                    }
                    Seam::Zero => {
                        fill_guidance(g, params, |p, q| if l[p] == l[q] { d(l[p] as usize, p, q) } else { 0.0 })
                    }
                }
            }
        }
        ChanSel::Weights(m) => {
            let (a, b) = (srcs[0], srcs[1]);
            let insert = params.seam == Seam::Insert;
            let weight = |p: usize, q: usize| if insert { m[p].max(m[q]) } else { 0.5 * (m[p] + m[q]) };
            if mixed {
                fill_guidance(g, params, |p, q| {
                    let (da, db) = (a[q] - a[p], b[q] - b[p]);
                    if weight(p, q) > 0.0 && db.abs() >= da.abs() {
                        db
                    } else {
                        da
                    }
                })
            } else {
                fill_guidance(g, params, |p, q| {
                    let wgt = weight(p, q);
                    (1.0 - wgt) * (a[q] - a[p]) + wgt * (b[q] - b[p])
                })
            }
        }
    }
}

/// Two sources, labels 0/1, insert seams (the thesis's case): the edge takes source 1's
/// difference when either end is labelled 1.
fn binary_insert_guidance(g: &Graph, a: &[f32], b: &[f32], l: &[u32], zero_wrap: bool) -> (Vec<f32>, Vec<f32>) {
    let w = g.w;
    let mut tx = vec![0.0f32; w * g.h];
    let mut ty = vec![0.0f32; w * g.h];
    tx.par_chunks_mut(w)
        .zip(ty.par_chunks_mut(w))
        .enumerate()
        .with_min_len(8)
        .for_each(|(y, (rx, ry))| binary_insert_row(g, a, b, l, zero_wrap, y, rx, ry));
    (tx, ty)
}

/// Start of the row below row `y` whose edge to `y` carries guidance: the next row, on a
/// torus the first row after the last (unless the wrap carries none), else none.
fn below(g: &Graph, y: usize, zero_wrap: bool) -> Option<usize> {
    if y + 1 < g.h {
        Some((y + 1) * g.w)
    } else if g.periodic && !zero_wrap {
        Some(0)
    } else {
        None
    }
}

/// Row `y` of [`binary_insert_guidance`], every value of `rx` and `ry` written. Row slices
/// and a branch-free select keep the loops vectorisable.
#[allow(clippy::too_many_arguments)]
#[inline]
fn binary_insert_row(
    g: &Graph,
    a: &[f32],
    b: &[f32],
    l: &[u32],
    zero_wrap: bool,
    y: usize,
    rx: &mut [f32],
    ry: &mut [f32],
) {
    let w = g.w;
    let pick = |lp: u32, lq: u32, da: f32, db: f32| if (lp | lq) != 0 { db } else { da };
    let row = y * w;
    let (ar, br, lr) = (&a[row..row + w], &b[row..row + w], &l[row..row + w]);
    for x in 0..w - 1 {
        rx[x] = pick(lr[x], lr[x + 1], ar[x + 1] - ar[x], br[x + 1] - br[x]);
    }
    rx[w - 1] =
        if g.periodic && !zero_wrap { pick(lr[w - 1], lr[0], ar[0] - ar[w - 1], br[0] - br[w - 1]) } else { 0.0 };
    match below(g, y, zero_wrap) {
        Some(nr) => {
            let (an, bn, ln) = (&a[nr..nr + w], &b[nr..nr + w], &l[nr..nr + w]);
            for x in 0..w {
                ry[x] = pick(lr[x], ln[x], an[x] - ar[x], bn[x] - br[x]);
            }
        }
        None => ry.fill(0.0),
    }
}

/// [`binary_insert_guidance`] fused with the composite (written into `f`) and the sources'
/// value range ([`value_range`]), in one pass over the sources.
pub(super) fn binary_insert_prep(
    g: &Graph,
    a: &[f32],
    b: &[f32],
    l: &[u32],
    zero_wrap: bool,
    f: &mut [f32],
) -> (Vec<f32>, Vec<f32>, f64) {
    let (w, h) = (g.w, g.h);
    // Scratch planes (every value is written below).
    let mut tx = f32::pool().take(w * h);
    let mut ty = f32::pool().take(w * h);
    let (lo, hi) = tx
        .par_chunks_mut(w)
        .zip(ty.par_chunks_mut(w))
        .zip(f.par_chunks_mut(w))
        .enumerate()
        .with_min_len(8)
        .map(|(y, ((rx, ry), fr))| {
            let row = y * w;
            let (ar, br, lr) = (&a[row..row + w], &b[row..row + w], &l[row..row + w]);
            for x in 0..w {
                fr[x] = if lr[x] != 0 { br[x] } else { ar[x] };
            }
            binary_insert_row(g, a, b, l, zero_wrap, y, rx, ry);
            let (l0, h0) = chunk_range(ar);
            let (l1, h1) = chunk_range(br);
            (l0.min(l1), h0.max(h1))
        })
        .reduce(|| (f32::MAX, f32::MIN), |p, q| (p.0.min(q.0), p.1.max(q.1)));
    (tx, ty, range_of(lo, hi))
}

/// Evaluates `target(p, q)` on every right and down edge of the graph (monomorphised per
/// selector variant, so the inner loops carry no dispatch).
fn fill_guidance(g: &Graph, params: &BlendParams, target: impl Fn(usize, usize) -> f32 + Sync) -> (Vec<f32>, Vec<f32>) {
    let (w, h) = (g.w, g.h);
    let zero_wrap = params.wrap_guidance == WrapGuidance::Zero;
    let mut tx = vec![0.0f32; w * h];
    let mut ty = vec![0.0f32; w * h];
    tx.par_chunks_mut(w).zip(ty.par_chunks_mut(w)).enumerate().with_min_len(8).for_each(|(y, (rx, ry))| {
        let row = y * w;
        for (x, v) in rx.iter_mut().enumerate().take(w.saturating_sub(1)) {
            *v = target(row + x, row + x + 1);
        }
        if g.periodic {
            rx[w - 1] = if zero_wrap { 0.0 } else { target(row + w - 1, row) };
        }
        if let Some(nr) = below(g, y, zero_wrap) {
            for (x, v) in ry.iter_mut().enumerate() {
                *v = target(row + x, nr + x);
            }
        }
    });
    (tx, ty)
}

/// `Σ_q t(p→q)` over the existing edges of p: the divergence of the guidance (so the
/// normal equations read `L f = −div` on the whole graph).
#[inline]
pub(super) fn div(g: &Graph, tx: &[f32], ty: &[f32], x: usize, y: usize) -> f64 {
    let p = y * g.w + x;
    let mut s = 0.0f64;
    if g.right(x, y).is_some() {
        s += tx[p] as f64;
    }
    if let Some(q) = g.left(x, y) {
        s -= tx[q] as f64;
    }
    if g.down(x, y).is_some() {
        s += ty[p] as f64;
    }
    if let Some(q) = g.up(x, y) {
        s -= ty[q] as f64;
    }
    s
}
