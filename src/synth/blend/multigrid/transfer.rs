//! Transfer between a level and the next coarser one: the cell-centred bilinear prolongation
//! and the per-axis tables whose transpose is the restriction.

use rayon::prelude::*;

use super::level::{Level, SyncPtr, PARALLEL_MIN};
use crate::synth::blend::lanes::Lanes;

/// The coarse correction a [`Stage::Prolong`] adds.
pub(super) struct ProlongSrc<'a, V> {
    pub(super) t: &'a Transfer,
    pub(super) e: &'a [V],
    pub(super) wc: usize,
}

impl Level {
    /// Adds the prolongation of the coarse correction `src` to the cells `runs` of row `y`:
    /// the two coarse rows are mixed (3/4, 1/4) into `v`, then each cell mixes its two
    /// coarse columns.
    ///
    /// # Safety
    /// `u` points to `w·h` cells; no other thread accesses row `y`; `v` holds `src.wc`
    /// cells.
    #[inline]
    pub(super) unsafe fn prolong_row<V: Lanes>(
        &self,
        src: &ProlongSrc<'_, V>,
        y: usize,
        runs: &[(usize, usize)],
        u: *mut V,
        v: &mut [V],
    ) {
        let (wf, wc, t) = (self.w, src.wc, src.t);
        let [(j0, w0), (j1, w1)] = t.y.prol[y];
        let (e0, e1) = (&src.e[j0 * wc..(j0 + 1) * wc], &src.e[j1 * wc..(j1 + 1) * wc]);
        let (w0, w1) = (V::splat(w0), V::splat(w1));
        let even = wf == 2 * wc && wc >= 3;
        let (q1, q3) = (V::splat(0.25), V::splat(0.75));
        let row = y * wf;
        let add = |x: usize, val: V| *u.add(row + x) = *u.add(row + x) + val;
        for &(a, b) in runs {
            // The coarse rows mixed over the run's coarse span.
            let (clo, chi) = coarse_span(a, b, wf, wc);
            for i in clo..chi {
                v[i] = w0 * e0[i] + w1 * e1[i];
            }
            let v = &*v;
            let table = |x: usize| {
                let [(c0, a0), (c1, a1)] = t.x.prol[x];
                V::splat(a0) * v[c0] + V::splat(a1) * v[c1]
            };
            // Cells [lo, hi) take the even-size fast path: even x = 2c mixes coarse columns
            // c and c − 1, odd x = 2c + 1 mixes c and c + 1.
            let (lo, hi) = if even { (a.max(2), b.min(wf - 2)) } else { (b, b) };
            let mut x = a;
            while x < b && x < lo {
                add(x, table(x));
                x += 1;
            }
            if x < hi && x % 2 == 1 {
                let c = x / 2;
                add(x, q3 * v[c] + q1 * v[c + 1]);
                x += 1;
            }
            while x + 1 < hi {
                let c = x / 2;
                let m = q3 * v[c];
                add(x, m + q1 * v[c - 1]);
                add(x + 1, m + q1 * v[c + 1]);
                x += 2;
            }
            if x < hi {
                let c = x / 2;
                add(x, q3 * v[c] + q1 * v[c - 1]);
                x += 1;
            }
            while x < b {
                add(x, table(x));
                x += 1;
            }
        }
    }

    /// Adds the prolongation of `src` on the widened band (the rest of the free cells get
    /// theirs in the post-smoothing wavefront).
    pub(super) fn prolong_band<V: Lanes>(&self, u: &mut [V], src: &ProlongSrc<'_, V>) {
        let Some(bd) = &self.band else {
            return;
        };
        let up = SyncPtr(u.as_mut_ptr());
        let parallel = bd.wide.count * V::N >= PARALLEL_MIN;
        let row = |v: &mut Vec<V>, &y: &usize| {
            // SAFETY: each row is written by one task; e is only read.
            unsafe { self.prolong_row(src, y, bd.wide.row(y), up.get(), v) }
        };
        if parallel {
            bd.wide.rows.par_iter().with_min_len(16).for_each_init(|| vec![V::default(); src.wc], row);
        } else {
            let mut v = vec![V::default(); src.wc];
            bd.wide.rows.iter().for_each(|y| row(&mut v, y));
        }
    }
}

/// The coarse columns `[lo, hi)` that the fine columns `[x0, x1)` exchange values with
/// under prolongation and restriction (all of them when the span touches the image edge,
/// where the transfer wraps or clamps).
#[inline]
pub(super) fn coarse_span(x0: usize, x1: usize, wf: usize, wc: usize) -> (usize, usize) {
    if x0 == 0 || x1 == wf {
        (0, wc)
    } else {
        ((x0 / 2).saturating_sub(1), ((x1 - 1) / 2 + 2).min(wc))
    }
}

/// One-dimensional transfer between a fine axis of `n` cells and a coarse one of `nc`.
pub(super) struct Transfer1 {
    /// For each fine index: two (coarse index, weight) sources; weight 0 means unused.
    prol: Vec<[(usize, f32); 2]>,
    /// Transpose: for each coarse index, its (fine index, weight) entries.
    restr_start: Vec<usize>,
    restr: Vec<(usize, f32)>,
}

impl Transfer1 {
    pub(super) fn new(n: usize, nc: usize, periodic: bool) -> Transfer1 {
        let mut prol = Vec::with_capacity(n);
        for x in 0..n {
            let c0 = x / 2;
            let c1 = if x % 2 == 1 { c0 as isize + 1 } else { c0 as isize - 1 };
            let c1 = if periodic { c1.rem_euclid(nc as isize) as usize } else { c1.clamp(0, nc as isize - 1) as usize };
            if c1 == c0 {
                prol.push([(c0, 1.0), (c0, 0.0)]);
            } else {
                prol.push([(c0, 0.75), (c1, 0.25)]);
            }
        }
        let mut lists: Vec<Vec<(usize, f32)>> = vec![Vec::new(); nc];
        for (x, src) in prol.iter().enumerate() {
            for &(c, wgt) in src {
                if wgt != 0.0 {
                    lists[c].push((x, wgt));
                }
            }
        }
        let mut restr_start = Vec::with_capacity(nc + 1);
        let mut restr = Vec::new();
        for l in lists {
            restr_start.push(restr.len());
            restr.extend(l);
        }
        restr_start.push(restr.len());
        Transfer1 { prol, restr_start, restr }
    }

    #[inline]
    pub(super) fn restr_of(&self, c: usize) -> &[(usize, f32)] {
        &self.restr[self.restr_start[c]..self.restr_start[c + 1]]
    }
}

pub(super) struct Transfer {
    pub(super) x: Transfer1,
    pub(super) y: Transfer1,
}

/// Restriction along x of one fine row `src` into the coarse cells `[lo, hi)` of `dst`.
#[inline]
pub(super) fn restrict_x<V: Lanes>(t: &Transfer1, src: &[V], dst: &mut [V], (lo, hi): (usize, usize)) {
    let nc = dst.len();
    let even = src.len() == 2 * nc && nc >= 3;
    let list = |i: usize| {
        let mut s = V::default();
        for &(x, wgt) in t.restr_of(i) {
            s = s + V::splat(wgt) * src[x];
        }
        s
    };
    let (q1, q3) = (V::splat(0.25), V::splat(0.75));
    for i in lo..hi {
        dst[i] = if even && i >= 1 && i + 1 < nc {
            q1 * (src[2 * i - 1] + src[2 * i + 2]) + q3 * (src[2 * i] + src[2 * i + 1])
        } else {
            list(i)
        };
    }
}
