//! The level operator `L` and the lane-wise reductions and vector updates of conjugate
//! gradients, each summed per row in a fixed order so results do not depend on threads.

use rayon::prelude::*;

use super::level::{Level, SyncPtr};
use crate::synth::blend::lanes::Lanes;

/// Cells per f32 partial sum in dot products (then accumulated in f64).
const DOT_CHUNK: usize = 64;
/// Most lanes of a [`Lanes`] type.
pub(crate) const MAX_LANES: usize = 4;
/// Per-lane f64 results (lanes past `V::N` are zero).
pub(crate) type Sums = [f64; MAX_LANES];
/// Per-row results of one parallel task: (row, sums).
pub(super) type RowSums = Vec<(usize, Sums)>;

impl Level {
    /// `Σ a·b` over the free cells of row `y`, per lane.
    ///
    /// # Safety
    /// `a` and `b` point to `w·h` cells; nobody writes row `y` meanwhile.
    #[inline]
    pub(super) unsafe fn row_dot_raw<V: Lanes>(&self, a: *const V, b: *const V, y: usize) -> Sums {
        let mut acc = [0.0; MAX_LANES];
        let row = y * self.w;
        for &(x0, x1) in self.row_runs(y) {
            let sa = std::slice::from_raw_parts(a.add(row + x0), x1 - x0);
            let sb = std::slice::from_raw_parts(b.add(row + x0), x1 - x0);
            add_lanes(&mut acc, dot_run(sa, sb));
        }
        acc
    }

    /// `out = b − L u` (or `out = L u` when `b` is None) on the free cells of row `y`.
    #[inline(always)]
    pub(super) fn op_row<V: Lanes>(&self, u: &[V], b: Option<&[V]>, out_row: &mut [V], y: usize) {
        assert!(u.len() >= self.w * self.h && b.is_none_or(|b| b.len() >= self.w * self.h));
        // SAFETY: the planes hold w·h cells and are borrowed for the call.
        unsafe { self.op_row_ptr(u.as_ptr(), b.map(|b| b.as_ptr()), out_row, y) }
    }

    /// [`Level::op_row`] on raw planes: reads rows y − 1, y, y + 1 of `u` and row y of `b`.
    ///
    /// # Safety
    /// `u` and `b` point to `w·h` cells; nobody writes the rows read meanwhile.
    #[inline(always)]
    unsafe fn op_row_ptr<V: Lanes>(&self, u: *const V, b: Option<*const V>, out_row: &mut [V], y: usize) {
        let w = self.w;
        let row = y * w;
        let (up, dn) = self.vert(y);
        let gen = |x: usize, out_row: &mut [V]| {
            let (s, d) = self.nb_generic(u, row, x, up, dn);
            let lu = V::splat(d) * *u.add(row + x) - s;
            out_row[x] = match b {
                Some(b) => *b.add(row + x) - lu,
                None => lu,
            };
        };
        for &(x0, x1) in self.row_runs(y) {
            let (Some(uo), Some(dno)) = (up, dn) else {
                for x in x0..x1 {
                    gen(x, out_row);
                }
                continue;
            };
            let mut xs = x0;
            let mut xe = x1;
            if xs == 0 {
                gen(0, out_row);
                xs = 1;
            }
            let last_generic = xe == w && xe > xs;
            if last_generic {
                xe -= 1;
            }
            if xe > xs {
                let n = xe - xs;
                let l = std::slice::from_raw_parts(u.add(row + xs - 1), n + 2);
                let (c, r) = (&l[1..n + 1], &l[2..n + 2]);
                let t = std::slice::from_raw_parts(u.add(uo + xs), n);
                let d = std::slice::from_raw_parts(u.add(dno + xs), n);
                let o = &mut out_row[xs..xe];
                let four = V::splat(4.0);
                match b {
                    Some(b) => {
                        let bb = std::slice::from_raw_parts(b.add(row + xs), n);
                        for i in 0..n {
                            o[i] = bb[i] - (four * c[i] - (l[i] + r[i] + t[i] + d[i]));
                        }
                    }
                    None => {
                        for i in 0..n {
                            o[i] = four * c[i] - (l[i] + r[i] + t[i] + d[i]);
                        }
                    }
                }
            }
            if last_generic {
                gen(w - 1, out_row);
            }
        }
    }

    /// `body(y)` for every row, in parallel tasks on large levels; the per-row results in
    /// row order.
    fn per_row<V: Lanes, R: Send>(&self, body: impl Fn(usize, &mut Vec<V>) -> R + Sync) -> Vec<R> {
        let nblocks = self.h.div_ceil(self.rows_per_block);
        let block = |bi: usize| {
            let mut tmp = vec![V::default(); self.w];
            self.block_rows(bi).map(|y| body(y, &mut tmp)).collect::<Vec<R>>()
        };
        let parts: Vec<Vec<R>> = if self.parallel::<V>() {
            (0..nblocks).into_par_iter().map(block).collect()
        } else {
            (0..nblocks).map(block).collect()
        };
        parts.into_iter().flatten().collect()
    }

    /// `Σ a·b` over free cells per lane, in f64 (per row, then in row order).
    pub fn dot<V: Lanes>(&self, a: &[V], b: &[V]) -> Sums {
        let w = self.w;
        let rows = self.per_row::<V, Sums>(|y, _| {
            let mut acc = [0.0f64; MAX_LANES];
            for &(x0, x1) in self.row_runs(y) {
                add_lanes(&mut acc, dot_run(&a[y * w + x0..y * w + x1], &b[y * w + x0..y * w + x1]));
            }
            acc
        });
        sum_rows(&rows)
    }

    /// `Σ p·L p` over free cells per lane (per row, then in row order).
    pub fn dot_lap<V: Lanes>(&self, p: &[V]) -> Sums {
        let w = self.w;
        let rows = self.per_row::<V, Sums>(|y, tmp| {
            let mut acc = [0.0f64; MAX_LANES];
            if !self.row_empty(y) {
                self.op_row(p, None, tmp, y);
                for &(x0, x1) in self.row_runs(y) {
                    add_lanes(&mut acc, dot_run(&p[y * w + x0..y * w + x1], &tmp[x0..x1]));
                }
            }
            acc
        });
        sum_rows(&rows)
    }

    /// `max |a|` over free cells per lane.
    pub fn max_abs<V: Lanes>(&self, a: &[V]) -> Sums {
        let w = self.w;
        let rows = self.per_row::<V, V>(|y, _| {
            let mut mx = V::default();
            for &(x0, x1) in self.row_runs(y) {
                max_abs_run(&mut mx, &a[y * w + x0..y * w + x1]);
            }
            mx
        });
        max_lanes(&rows)
    }

    /// The CG direction update `p ← z + β p` (per lane), returning `p·L p` per lane. Each
    /// task updates its rows of p and takes `p·L p` on the rows whose neighbours it owns as
    /// it goes; the rows at task boundaries follow once every row of p is updated.
    pub fn update_direction<V: Lanes>(&self, z: &[V], beta: Sums, p: &mut [V]) -> Sums {
        let (w, h) = (self.w, self.h);
        let bt = V::from_fn(|k| beta[k] as f32);
        let pp = SyncPtr(p.as_mut_ptr());
        // SAFETY: rows are updated by exactly one task; `p·L p` of a row is only taken once
        // its neighbour rows are updated and by the task that owns them (or after all tasks).
        let update = |y: usize| unsafe {
            for &(x0, x1) in self.row_runs(y) {
                let start = y * w + x0;
                for (i, &zv) in z[start..y * w + x1].iter().enumerate() {
                    let q = pp.get().add(start + i);
                    *q = zv + bt * *q;
                }
            }
        };
        let pq_row = |y: usize, tmp: &mut Vec<V>| -> Sums {
            let mut acc = [0.0f64; MAX_LANES];
            if self.row_empty(y) {
                return acc;
            }
            // SAFETY: rows y − 1, y, y + 1 are no longer written (see above).
            unsafe {
                let ps = pp.get() as *const V;
                self.op_row_ptr(ps, None, tmp, y);
                for &(x0, x1) in self.row_runs(y) {
                    let pr = std::slice::from_raw_parts(ps.add(y * w + x0), x1 - x0);
                    add_lanes(&mut acc, dot_run(pr, &tmp[x0..x1]));
                }
            }
            acc
        };
        // Larger tasks than elsewhere: the boundary rows cost a second pass.
        let rpb = (4 * self.rows_per_block).max(3);
        let nblocks = h.div_ceil(rpb);
        let range = |bi: usize| (bi * rpb, ((bi + 1) * rpb).min(h));
        let block = |bi: usize| {
            let (y0, y1) = range(bi);
            let mut tmp = vec![V::default(); w];
            let mut out = Vec::with_capacity(y1 - y0);
            for y in y0..y1 {
                update(y);
                if y >= y0 + 2 {
                    out.push((y - 1, pq_row(y - 1, &mut tmp)));
                }
            }
            out
        };
        let edge = |bi: usize| {
            let (y0, y1) = range(bi);
            let mut tmp = vec![V::default(); w];
            let mut out = vec![(y0, pq_row(y0, &mut tmp))];
            if y1 - 1 > y0 {
                out.push((y1 - 1, pq_row(y1 - 1, &mut tmp)));
            }
            out
        };
        let (inner, edges): (Vec<RowSums>, Vec<RowSums>) = if self.parallel::<V>() {
            let inner = (0..nblocks).into_par_iter().map(block).collect();
            (inner, (0..nblocks).into_par_iter().map(edge).collect())
        } else {
            let inner = (0..nblocks).map(block).collect();
            (inner, (0..nblocks).map(edge).collect())
        };
        let mut per_row = vec![[0.0; MAX_LANES]; h];
        for (y, s) in inner.into_iter().chain(edges).flatten() {
            per_row[y] = s;
        }
        sum_rows(&per_row)
    }

    /// `u += α p; r −= α L p` per lane (`L p` recomputed from p), returning `(Σ r², max |r|)`
    /// per lane (f64; sums per row, then in row order).
    pub fn cg_update<V: Lanes>(&self, u: &mut [V], r: &mut [V], p: &[V], alpha: Sums) -> (Sums, Sums) {
        let w = self.w;
        let a = V::from_fn(|k| alpha[k] as f32);
        let step = w * self.rows_per_block;
        let block = |bi: usize, uc: &mut [V], rc: &mut [V]| {
            let mut tmp = vec![V::default(); w];
            let mut out = Vec::with_capacity(self.rows_per_block);
            for (dy, y) in self.block_rows(bi).enumerate() {
                let mut acc = [0.0f64; MAX_LANES];
                let mut mx = V::default();
                if !self.row_empty(y) {
                    self.op_row(p, None, &mut tmp, y);
                }
                for &(x0, x1) in self.row_runs(y) {
                    let (us, rs) = (&mut uc[dy * w + x0..dy * w + x1], &mut rc[dy * w + x0..dy * w + x1]);
                    let (ps, qs) = (&p[y * w + x0..y * w + x1], &tmp[x0..x1]);
                    for i in 0..us.len() {
                        us[i] = us[i] + a * ps[i];
                        rs[i] = rs[i] - a * qs[i];
                    }
                    max_abs_run(&mut mx, rs);
                    add_lanes(&mut acc, dot_run(rs, rs));
                }
                out.push((acc, mx));
            }
            out
        };
        let parts: Vec<Vec<(Sums, V)>> = if self.parallel::<V>() {
            u.par_chunks_mut(step)
                .zip(r.par_chunks_mut(step))
                .enumerate()
                .map(|(bi, (uc, rc))| block(bi, uc, rc))
                .collect()
        } else {
            u.chunks_mut(step).zip(r.chunks_mut(step)).enumerate().map(|(bi, (uc, rc))| block(bi, uc, rc)).collect()
        };
        let rows: Vec<(Sums, V)> = parts.into_iter().flatten().collect();
        let sums: Vec<Sums> = rows.iter().map(|p| p.0).collect();
        let maxs: Vec<V> = rows.iter().map(|p| p.1).collect();
        (sum_rows(&sums), max_lanes(&maxs))
    }
}

#[inline(always)]
fn add_lanes(acc: &mut Sums, v: Sums) {
    for k in 0..MAX_LANES {
        acc[k] += v[k];
    }
}

/// Per-row sums added in row order.
pub(super) fn sum_rows(rows: &[Sums]) -> Sums {
    let mut s = [0.0; MAX_LANES];
    for p in rows {
        add_lanes(&mut s, *p);
    }
    s
}

/// Lane-wise maximum of non-negative values, as f64.
fn max_lanes<V: Lanes>(parts: &[V]) -> Sums {
    let mut m = [0.0f64; MAX_LANES];
    for p in parts {
        for (k, mk) in m.iter_mut().enumerate().take(V::N) {
            *mk = mk.max(p.get(k) as f64);
        }
    }
    m
}

/// `mx = max(mx, |a|)` per lane (NaN never wins, as with `f32::max`).
#[inline(always)]
fn max_abs_run<V: Lanes>(mx: &mut V, a: &[V]) {
    for v in a {
        *mx = v.abs().max_into(*mx);
    }
}

/// `Σ a·b` per lane over a run: f32 partial sums over [`DOT_CHUNK`] cells (four
/// interleaved accumulators, combined pairwise), accumulated in f64. The order depends only
/// on the run, not on the lane count.
#[inline]
fn dot_run<V: Lanes>(a: &[V], b: &[V]) -> Sums {
    let mut acc = [0.0f64; MAX_LANES];
    for (ca, cb) in a.chunks(DOT_CHUNK).zip(b.chunks(DOT_CHUNK)) {
        let mut s = [V::default(); 4];
        let (qa, qb) = (ca.chunks_exact(4), cb.chunks_exact(4));
        let (ra, rb) = (qa.remainder(), qb.remainder());
        for (xa, xb) in qa.zip(qb) {
            for j in 0..4 {
                s[j] = s[j] + xa[j] * xb[j];
            }
        }
        for (j, (xa, xb)) in ra.iter().zip(rb).enumerate() {
            s[j] = s[j] + *xa * *xb;
        }
        let t = (s[0] + s[1]) + (s[2] + s[3]);
        for (k, ak) in acc.iter_mut().enumerate().take(V::N) {
            *ak += t.get(k) as f64;
        }
    }
    acc
}
