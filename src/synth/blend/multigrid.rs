//! Geometric multigrid for the masked Poisson problem, standalone (V-cycles) or as the
//! preconditioner of conjugate gradients (MGPCG).
//!
//! The unknowns are the *free* cells of a `w × h` grid; every other cell is fixed and its
//! value already moved into the right-hand side, so on each level the operator is
//! `(L u)_p = deg_p u_p − Σ_{q ∈ N_p} u_q` with `u = 0` on fixed cells. `N_p` is the
//! 4-neighbourhood, wrapped on a torus (`periodic`) or clipped at the grid edge (then
//! `deg_p` counts the neighbours that exist: Neumann at the image border).
//!
//! Design, after McAdams, Sifakis & Teran (2010), "A parallel multigrid Poisson solver for
//! fluids simulation on large grids":
//! - cell-centred coarsening by 2 × 2; a coarse cell is free only when all its children are
//!   free ("Dirichlet dominant"). The digest (003 §7) suggests the opposite rule ("free if any
//!   child is free"); both are offered ([`Coarsening`]), and the Dirichlet-dominant one is the
//!   default because it keeps every coarse operator non-singular (a level with a fixed cell
//!   has no constant null space) and measured fewer iterations on the disc benchmark.
//! - prolongation: cell-centred bilinear (weights 3/4, 1/4 per axis), restricted to free
//!   cells; restriction is its exact transpose, so the V-cycle is a symmetric operator.
//! - red-black Gauss–Seidel smoothing, pre-smoothing red→black, post-smoothing black→red in
//!   reversed traversal order (the adjoint), which keeps the preconditioner SPD for CG.
//! - coarse operator: the same 5-point stencil rediscretised on the coarse mask.
//! - coarsest level (min side ≤ 8): conjugate gradients in f64 to 1e-12.
//!
//! Storage is f32 on full-size planes (zero on fixed cells) with per-row runs of free cells,
//! so every loop touches free cells only. Reductions are accumulated in f64 over fixed
//! blocks of rows and summed in block order; a red (black) half-sweep only reads black
//! (red) cells, so rows can be updated in parallel without changing any value. Together this
//! makes the result bit-identical for any number of rayon threads. The one case where a
//! colour couples to itself across the wrap (periodic with odd height) is swept sequentially.

use rayon::prelude::*;

/// How coarse cells inherit the free/fixed label of their 2 × 2 children.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize)]
pub enum Coarsening {
    /// Free only when every child is free (McAdams et al. 2010). Default.
    #[default]
    AllChildren,
    /// Free when any child is free (digest 003 §7).
    AnyChild,
}

/// Cells per reduction block (rows are grouped so that a block holds about this many
/// cells). Fixed, so reductions do not depend on the thread count.
const BLOCK_CELLS: usize = 16 * 1024;
/// Levels with fewer free cells than this are processed on the calling thread.
const PARALLEL_MIN: usize = 32 * 1024;
/// Coarsening stops once the shorter side is at most this.
const COARSEST_SIDE: usize = 8;

#[derive(Clone, Copy)]
struct SyncPtr(*mut f32);
// SAFETY: the pointer is only dereferenced under the red-black access discipline described
// at `Level::sweep` (no two threads write the same cell or read a cell being written).
unsafe impl Send for SyncPtr {}
unsafe impl Sync for SyncPtr {}

impl SyncPtr {
    #[inline(always)]
    fn get(self) -> *mut f32 {
        self.0
    }
}

/// One grid level: its free cells as runs per row.
pub(crate) struct Level {
    pub w: usize,
    pub h: usize,
    pub periodic: bool,
    pub free: Vec<u8>,
    row_start: Vec<usize>,
    runs: Vec<(usize, usize)>,
    /// Rows that hold at least one free cell.
    rows: Vec<usize>,
    pub count: usize,
    /// Rows may be swept concurrently (false only for periodic levels with odd height).
    parallel_safe: bool,
    rows_per_block: usize,
    /// Rows per block of a fused parallel sweep.
    sweep_rows: usize,
}

impl Level {
    pub fn new(w: usize, h: usize, periodic: bool, free: Vec<u8>) -> Level {
        let mut row_start = Vec::with_capacity(h + 1);
        let mut runs = Vec::new();
        let mut rows = Vec::new();
        let mut count = 0;
        for y in 0..h {
            row_start.push(runs.len());
            let row = &free[y * w..(y + 1) * w];
            let mut x = 0;
            while x < w {
                if row[x] != 0 {
                    let s = x;
                    while x < w && row[x] != 0 {
                        x += 1;
                    }
                    runs.push((s, x));
                    count += x - s;
                } else {
                    x += 1;
                }
            }
            if runs.len() > row_start[y] {
                rows.push(y);
            }
        }
        row_start.push(runs.len());
        let parallel_safe = !(periodic && h % 2 == 1);
        let sweep_rows = (h / 16).clamp(8, 64);
        Level {
            w,
            h,
            periodic,
            free,
            row_start,
            runs,
            rows,
            count,
            parallel_safe,
            rows_per_block: blocks(w),
            sweep_rows,
        }
    }

    #[inline]
    pub fn row_runs(&self, y: usize) -> &[(usize, usize)] {
        &self.runs[self.row_start[y]..self.row_start[y + 1]]
    }

    /// Row offsets of the rows above and below `y` (None past a non-periodic edge).
    #[inline]
    fn vert(&self, y: usize) -> (Option<usize>, Option<usize>) {
        let up = if y > 0 {
            Some((y - 1) * self.w)
        } else if self.periodic {
            Some((self.h - 1) * self.w)
        } else {
            None
        };
        let dn = if y + 1 < self.h {
            Some((y + 1) * self.w)
        } else if self.periodic {
            Some(0)
        } else {
            None
        };
        (up, dn)
    }

    /// Neighbour sum and degree of cell `x` of the row at offset `row`, any position.
    #[inline(always)]
    unsafe fn nb_generic(
        &self,
        u: *const f32,
        row: usize,
        x: usize,
        up: Option<usize>,
        dn: Option<usize>,
    ) -> (f32, f32) {
        let w = self.w;
        let mut s = 0.0f32;
        let mut d = 0.0f32;
        if x > 0 {
            s += *u.add(row + x - 1);
            d += 1.0;
        } else if self.periodic {
            s += *u.add(row + w - 1);
            d += 1.0;
        }
        if x + 1 < w {
            s += *u.add(row + x + 1);
            d += 1.0;
        } else if self.periodic {
            s += *u.add(row);
            d += 1.0;
        }
        if let Some(o) = up {
            s += *u.add(o + x);
            d += 1.0;
        }
        if let Some(o) = dn {
            s += *u.add(o + x);
            d += 1.0;
        }
        (s, d)
    }

    /// Gauss–Seidel update of the cells of colour `colour` ((x + y) mod 2) in row `y`.
    /// With `zero_init` the other colour is taken as zero (first sweep from a zero guess),
    /// so nothing needs clearing beforehand.
    ///
    /// # Safety
    /// `u` and `b` point to `w·h` values; no other thread writes cells this call reads.
    #[inline(always)]
    unsafe fn smooth_row(&self, u: *mut f32, b: *const f32, y: usize, colour: usize, reverse: bool, zero_init: bool) {
        let w = self.w;
        let row = y * w;
        let (up, dn) = self.vert(y);
        let fast_rows = up.is_some() && dn.is_some();
        let runs = self.row_runs(y);
        let generic = |x: usize| {
            let (s, d) = self.nb_generic(u, row, x, up, dn);
            let s = if zero_init { 0.0 } else { s };
            *u.add(row + x) = (*b.add(row + x) + s) / d;
        };
        let do_run = |x0: usize, x1: usize| {
            // First and last cell of the colour in [x0, x1).
            let first = x0 + ((colour + y + x0) & 1);
            if first >= x1 {
                return;
            }
            let last = first + (x1 - 1 - first) / 2 * 2;
            if !fast_rows {
                if reverse {
                    let mut x = last as isize;
                    while x >= first as isize {
                        generic(x as usize);
                        x -= 2;
                    }
                } else {
                    let mut x = first;
                    while x <= last {
                        generic(x);
                        x += 2;
                    }
                }
                return;
            }
            let (uo, do_) = (up.unwrap_unchecked(), dn.unwrap_unchecked());
            // Interior cells [lo, hi] (same colour) use the 4-neighbour fast path.
            let lo = if first == 0 { 2 } else { first };
            let hi = if last == w - 1 { last as isize - 2 } else { last as isize };
            let interior = |x: usize| {
                let i = row + x;
                if zero_init {
                    *u.add(i) = *b.add(i) * 0.25;
                } else {
                    let s = *u.add(i - 1) + *u.add(i + 1) + *u.add(uo + x) + *u.add(do_ + x);
                    *u.add(i) = (*b.add(i) + s) * 0.25;
                }
            };
            if reverse {
                if last == w - 1 {
                    generic(last);
                }
                let mut x = hi;
                while x >= lo as isize {
                    interior(x as usize);
                    x -= 2;
                }
                if first == 0 {
                    generic(0);
                }
            } else {
                if first == 0 {
                    generic(0);
                }
                let mut x = lo;
                while x as isize <= hi {
                    interior(x);
                    x += 2;
                }
                if last == w - 1 {
                    generic(last);
                }
            }
        };
        if reverse {
            for &(x0, x1) in runs.iter().rev() {
                do_run(x0, x1);
            }
        } else {
            for &(x0, x1) in runs {
                do_run(x0, x1);
            }
        }
    }

    /// One red-black sweep: every cell of colour `first`, then every cell of the other
    /// colour (`reverse` walks rows and cells backwards, the adjoint order). With `zero_init`
    /// `u` is treated as zero on entry.
    ///
    /// On levels where rows can run concurrently the two half-sweeps are fused into one
    /// pass: each block of rows updates `first` on row y and the other colour on row y − 1
    /// as it goes, leaving its first and last row's second colour to a short second phase
    /// (their `first`-colour neighbours live in the adjacent blocks). Every cell receives
    /// exactly the update of the unfused sweep, so values do not depend on the blocking.
    pub fn sweep(&self, u: &mut [f32], b: &[f32], first: usize, reverse: bool, zero_init: bool) {
        let second = 1 - first;
        let mut zero_init = zero_init;
        if zero_init && self.periodic && (self.w % 2 == 1 || self.h % 2 == 1) {
            // Across an odd wrap a colour has neighbours of its own colour: clear instead.
            self.zero(u);
            zero_init = false;
        }
        let up = SyncPtr(u.as_mut_ptr());
        let bp = b.as_ptr() as usize;
        let h = self.h;
        if self.parallel_safe && self.count >= PARALLEL_MIN {
            let rpb = self.sweep_rows;
            let nblocks = h.div_ceil(rpb);
            (0..nblocks).into_par_iter().for_each(|k| {
                let (y0, y1) = (k * rpb, ((k + 1) * rpb).min(h));
                for y in y0..y1 {
                    // SAFETY: see the doc comment above: a
                    // colour update reads only the other colour, and a block's phase-1
                    // second-colour rows have all their first-colour neighbours inside
                    // the block.
                    unsafe {
                        self.smooth_row(up.get(), bp as *const f32, y, first, reverse, zero_init);
                        if y >= y0 + 2 {
                            self.smooth_row(up.get(), bp as *const f32, y - 1, second, reverse, false);
                        }
                    }
                }
            });
            (0..nblocks).into_par_iter().for_each(|k| {
                let (y0, y1) = (k * rpb, ((k + 1) * rpb).min(h));
                // SAFETY: as above; second-phase rows are at least a block apart.
                unsafe {
                    self.smooth_row(up.get(), bp as *const f32, y0, second, reverse, false);
                    if y1 - 1 > y0 {
                        self.smooth_row(up.get(), bp as *const f32, y1 - 1, second, reverse, false);
                    }
                }
            });
            return;
        }
        for (colour, zi) in [(first, zero_init), (second, false)] {
            // SAFETY: single-threaded; indices are inside the planes.
            unsafe {
                if reverse {
                    for &y in self.rows.iter().rev() {
                        self.smooth_row(up.0, bp as *const f32, y, colour, reverse, zi);
                    }
                } else {
                    for &y in &self.rows {
                        self.smooth_row(up.0, bp as *const f32, y, colour, reverse, zi);
                    }
                }
            }
        }
    }

    /// `out = b − L u` (or `out = L u` when `b` is None) on free cells of row `y`; returns
    /// the row's contributions to `(Σ out·dot, Σ out²)` where `dot` is an optional vector.
    #[inline(always)]
    fn op_row(&self, u: &[f32], b: Option<&[f32]>, out_row: &mut [f32], y: usize) {
        let w = self.w;
        let row = y * w;
        let (up, dn) = self.vert(y);
        let fast = up.is_some() && dn.is_some();
        for &(x0, x1) in self.row_runs(y) {
            let mut xs = x0;
            let mut xe = x1;
            let gen = |x: usize, out_row: &mut [f32]| {
                // SAFETY: indices are inside the plane.
                let (s, d) = unsafe { self.nb_generic(u.as_ptr(), row, x, up, dn) };
                let lu = d * u[row + x] - s;
                out_row[x] = match b {
                    Some(b) => b[row + x] - lu,
                    None => lu,
                };
            };
            if !fast {
                for x in xs..xe {
                    gen(x, out_row);
                }
                continue;
            }
            if xs == 0 {
                gen(0, out_row);
                xs = 1;
            }
            let last_generic = xe == w && xe > xs;
            if last_generic {
                xe -= 1;
            }
            if xe > xs {
                let (uo, do_) = (up.unwrap(), dn.unwrap());
                let c = &u[row + xs..row + xe];
                let l = &u[row + xs - 1..row + xe - 1];
                let r = &u[row + xs + 1..row + xe + 1];
                let t = &u[uo + xs..uo + xe];
                let d = &u[do_ + xs..do_ + xe];
                let o = &mut out_row[xs..xe];
                match b {
                    Some(b) => {
                        let bb = &b[row + xs..row + xe];
                        for i in 0..o.len() {
                            o[i] = bb[i] - (4.0 * c[i] - (l[i] + r[i] + t[i] + d[i]));
                        }
                    }
                    None => {
                        for i in 0..o.len() {
                            o[i] = 4.0 * c[i] - (l[i] + r[i] + t[i] + d[i]);
                        }
                    }
                }
            }
            if last_generic {
                gen(w - 1, out_row);
            }
        }
    }

    /// Runs `body(y, rows_of_a, rows_of_b)` over fixed blocks of rows of two planes (in
    /// parallel on large levels) and returns the per-block results in block order.
    fn blocks2<R: Send>(
        &self,
        a: &mut [f32],
        b: &mut [f32],
        body: impl Fn(usize, &mut [f32], &mut [f32]) -> R + Sync,
    ) -> Vec<R> {
        let step = self.w * self.rows_per_block;
        let rpb = self.rows_per_block;
        if self.count >= PARALLEL_MIN {
            a.par_chunks_mut(step)
                .zip(b.par_chunks_mut(step))
                .enumerate()
                .map(|(k, (x, y))| body(k * rpb, x, y))
                .collect()
        } else {
            a.chunks_mut(step).zip(b.chunks_mut(step)).enumerate().map(|(k, (x, y))| body(k * rpb, x, y)).collect()
        }
    }

    /// Sets free cells of `u` to zero (fixed cells are zero by construction).
    pub fn zero(&self, u: &mut [f32]) {
        let w = self.w;
        for &y in &self.rows {
            for &(x0, x1) in self.row_runs(y) {
                u[y * w + x0..y * w + x1].fill(0.0);
            }
        }
    }

    /// `q = L p` on free cells; returns `p·q` (f64, fixed order).
    pub fn apply_dot(&self, p: &[f32], q: &mut [f32]) -> f64 {
        let w = self.w;
        let rpb = self.rows_per_block;
        let body = |k: usize, qc: &mut [f32]| -> f64 {
            let y0 = k * rpb;
            let mut acc = 0.0;
            for (dy, qrow) in qc.chunks_mut(w).enumerate() {
                let y = y0 + dy;
                if self.row_start[y] == self.row_start[y + 1] {
                    continue;
                }
                self.op_row(p, None, qrow, y);
                for &(x0, x1) in self.row_runs(y) {
                    acc += dot_run(&p[y * w + x0..y * w + x1], &qrow[x0..x1]);
                }
            }
            acc
        };
        let parts: Vec<f64> = if self.count >= PARALLEL_MIN {
            q.par_chunks_mut(w * rpb).enumerate().map(|(k, c)| body(k, c)).collect()
        } else {
            q.chunks_mut(w * rpb).enumerate().map(|(k, c)| body(k, c)).collect()
        };
        parts.iter().sum()
    }

    /// The CG direction update fused with its operator application: `p ← z + β p`,
    /// `q ← L z + β q` (= `L p` by linearity, given `q = L p` on entry); returns `p·q`.
    pub fn update_direction(&self, z: &[f32], beta: f64, p: &mut [f32], q: &mut [f32]) -> f64 {
        let w = self.w;
        let bt = beta as f32;
        let parts = self.blocks2(p, q, |y0, pc, qc| {
            let mut tmp = vec![0.0f32; w];
            let mut acc = 0.0;
            for dy in 0..pc.len() / w {
                let y = y0 + dy;
                if self.row_start[y] == self.row_start[y + 1] {
                    continue;
                }
                self.op_row(z, None, &mut tmp, y);
                for &(x0, x1) in self.row_runs(y) {
                    let (ps, qs) = (&mut pc[dy * w + x0..dy * w + x1], &mut qc[dy * w + x0..dy * w + x1]);
                    let (zs, ls) = (&z[y * w + x0..y * w + x1], &tmp[x0..x1]);
                    for i in 0..ps.len() {
                        ps[i] = zs[i] + bt * ps[i];
                        qs[i] = ls[i] + bt * qs[i];
                    }
                    acc += dot_run(ps, qs);
                }
            }
            acc
        });
        parts.iter().sum()
    }

    /// `Σ a·b` over free cells, in f64, in a fixed block order.
    pub fn dot(&self, a: &[f32], b: &[f32]) -> f64 {
        let w = self.w;
        let rpb = self.rows_per_block;
        let nblocks = self.h.div_ceil(rpb);
        let block = |bi: usize| -> f64 {
            let mut acc = 0.0f64;
            for y in bi * rpb..((bi + 1) * rpb).min(self.h) {
                for &(x0, x1) in self.row_runs(y) {
                    acc += dot_run(&a[y * w + x0..y * w + x1], &b[y * w + x0..y * w + x1]);
                }
            }
            acc
        };
        let parts: Vec<f64> = if self.count >= PARALLEL_MIN {
            (0..nblocks).into_par_iter().map(block).collect()
        } else {
            (0..nblocks).map(block).collect()
        };
        parts.iter().sum()
    }

    /// `u += α p; r −= α q`, returning `(Σ r², max |r|)` (f64, fixed order).
    pub fn cg_update(&self, u: &mut [f32], r: &mut [f32], p: &[f32], q: &[f32], alpha: f64) -> (f64, f64) {
        let w = self.w;
        let a = alpha as f32;
        let parts = self.blocks2(u, r, |y0, uc, rc| {
            let mut acc = 0.0f64;
            let mut mx = 0.0f32;
            for dy in 0..uc.len() / w {
                let y = y0 + dy;
                for &(x0, x1) in self.row_runs(y) {
                    let off = y * w;
                    let (us, rs) = (&mut uc[dy * w + x0..dy * w + x1], &mut rc[dy * w + x0..dy * w + x1]);
                    let (ps, qs) = (&p[off + x0..off + x1], &q[off + x0..off + x1]);
                    for i in 0..us.len() {
                        us[i] += a * ps[i];
                        rs[i] -= a * qs[i];
                        mx = mx.max(rs[i].abs());
                    }
                    acc += dot_run(rs, rs);
                }
            }
            (acc, mx as f64)
        });
        (parts.iter().map(|p| p.0).sum(), parts.iter().fold(0.0, |m, p| m.max(p.1)))
    }
}

fn blocks(w: usize) -> usize {
    (BLOCK_CELLS / w.max(1)).max(1)
}

#[inline]
fn dot_run(a: &[f32], b: &[f32]) -> f64 {
    let mut acc = 0.0f64;
    for (ca, cb) in a.chunks(64).zip(b.chunks(64)) {
        let mut s = 0.0f32;
        for i in 0..ca.len() {
            s += ca[i] * cb[i];
        }
        acc += s as f64;
    }
    acc
}

/// One-dimensional transfer between a fine axis of `n` cells and a coarse one of `nc`.
struct Transfer1 {
    /// For each fine index: two (coarse index, weight) sources; weight 0 means unused.
    prol: Vec<[(usize, f32); 2]>,
    /// Transpose: for each coarse index, its (fine index, weight) entries.
    restr_start: Vec<usize>,
    restr: Vec<(usize, f32)>,
}

impl Transfer1 {
    fn new(n: usize, nc: usize, periodic: bool) -> Transfer1 {
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
    fn restr_of(&self, c: usize) -> &[(usize, f32)] {
        &self.restr[self.restr_start[c]..self.restr_start[c + 1]]
    }
}

struct Transfer {
    x: Transfer1,
    y: Transfer1,
}

/// The level hierarchy of one free-cell pattern.
pub(crate) struct Hierarchy {
    pub levels: Vec<Level>,
    transfers: Vec<Transfer>,
    /// Compact index of each free cell of the coarsest level (usize::MAX for fixed cells).
    coarse_index: Vec<usize>,
    coarse_cells: Vec<usize>,
}

impl Hierarchy {
    pub fn new(w: usize, h: usize, periodic: bool, free: Vec<u8>, rule: Coarsening) -> Hierarchy {
        let mut levels = vec![Level::new(w, h, periodic, free)];
        let mut transfers = Vec::new();
        loop {
            let f = levels.last().unwrap();
            if f.w.min(f.h) <= COARSEST_SIDE || f.count == 0 {
                break;
            }
            let (wc, hc) = (f.w.div_ceil(2), f.h.div_ceil(2));
            let mut cfree = vec![0u8; wc * hc];
            for j in 0..hc {
                for i in 0..wc {
                    let mut all = true;
                    let mut any = false;
                    for dy in 0..2 {
                        for dx in 0..2 {
                            let (x, y) = (2 * i + dx, 2 * j + dy);
                            if x < f.w && y < f.h {
                                let v = f.free[y * f.w + x] != 0;
                                all &= v;
                                any |= v;
                            }
                        }
                    }
                    let v = match rule {
                        Coarsening::AllChildren => all,
                        Coarsening::AnyChild => any,
                    };
                    cfree[j * wc + i] = v as u8;
                }
            }
            let c = Level::new(wc, hc, periodic, cfree);
            if c.count == 0 {
                break;
            }
            transfers.push(Transfer { x: Transfer1::new(f.w, wc, periodic), y: Transfer1::new(f.h, hc, periodic) });
            levels.push(c);
        }
        let last = levels.last().unwrap();
        let mut coarse_index = vec![usize::MAX; last.w * last.h];
        let mut coarse_cells = Vec::new();
        for (i, &v) in last.free.iter().enumerate() {
            if v != 0 {
                coarse_index[i] = coarse_cells.len();
                coarse_cells.push(i);
            }
        }
        Hierarchy { levels, transfers, coarse_index, coarse_cells }
    }
}

/// Buffers for V-cycles on one hierarchy. Level 0's `x` and `b` are the preconditioner's
/// output and input.
pub(crate) struct Workspace {
    pub x: Vec<Vec<f32>>,
    pub b: Vec<Vec<f32>>,
}

impl Workspace {
    pub fn new(hier: &Hierarchy) -> Workspace {
        let plane = |l: &Level| vec![0.0f32; l.w * l.h];
        Workspace { x: hier.levels.iter().map(plane).collect(), b: hier.levels.iter().map(plane).collect() }
    }
}

/// Smoothing sweeps per V-cycle side.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CycleParams {
    pub pre: usize,
    pub post: usize,
}

/// Coarse rows per parallel block of the transfer operators.
const TRANSFER_ROWS: usize = 8;

/// Restriction along x of one fine row into `dst` (coarse width).
#[inline]
fn restrict_x(t: &Transfer1, src: &[f32], dst: &mut [f32]) {
    let nc = dst.len();
    let even = src.len() == 2 * nc;
    let list = |i: usize| {
        let mut s = 0.0f32;
        for &(x, wgt) in t.restr_of(i) {
            s += wgt * src[x];
        }
        s
    };
    if even && nc >= 3 {
        dst[0] = list(0);
        for i in 1..nc - 1 {
            dst[i] = 0.25 * (src[2 * i - 1] + src[2 * i + 2]) + 0.75 * (src[2 * i] + src[2 * i + 1]);
        }
        dst[nc - 1] = list(nc - 1);
    } else {
        for (i, d) in dst.iter_mut().enumerate() {
            *d = list(i);
        }
    }
}

/// Computes the residual `b − L u` of level k and restricts it into `out` (level k+1's
/// right-hand side, written on free coarse cells only), without storing the fine residual:
/// each block of coarse rows computes the residual rows it needs, restricted along x, and
/// keeps the last few in a small cache (rows shared by neighbouring coarse rows are computed
/// once per block). Every coarse value is the same fixed-order sum whatever the blocking.
fn residual_restrict(hier: &Hierarchy, k: usize, u: &[f32], b: &[f32], out: &mut [f32]) {
    let (f, c) = (&hier.levels[k], &hier.levels[k + 1]);
    let t = &hier.transfers[k];
    let (wf, wc) = (f.w, c.w);
    let body = |j0: usize, oc: &mut [f32]| {
        let mut res = vec![0.0f32; wf];
        // (fine row, x-restricted residual) cache.
        let mut cache: Vec<(usize, Vec<f32>)> = Vec::with_capacity(6);
        for (dj, orow) in oc.chunks_mut(wc).enumerate() {
            let j = j0 + dj;
            if c.row_start[j] == c.row_start[j + 1] {
                continue;
            }
            let entries = t.y.restr_of(j);
            for &(y, _) in entries {
                if cache.iter().any(|(cy, _)| *cy == y) {
                    continue;
                }
                let mut xr = if cache.len() >= 6 { cache.remove(0).1 } else { vec![0.0f32; wc] };
                if f.row_start[y] == f.row_start[y + 1] {
                    xr.fill(0.0);
                } else {
                    res.fill(0.0);
                    f.op_row(u, Some(b), &mut res, y);
                    restrict_x(&t.x, &res, &mut xr);
                }
                cache.push((y, xr));
            }
            for &(x0, x1) in c.row_runs(j) {
                let o = &mut orow[x0..x1];
                o.fill(0.0);
                for &(y, wgt) in entries {
                    let xr = &cache.iter().find(|(cy, _)| *cy == y).unwrap().1;
                    for (ov, xv) in o.iter_mut().zip(&xr[x0..x1]) {
                        *ov += wgt * xv;
                    }
                }
            }
        }
    };
    if f.count >= PARALLEL_MIN {
        out.par_chunks_mut(wc * TRANSFER_ROWS).enumerate().for_each(|(k, oc)| body(k * TRANSFER_ROWS, oc));
    } else {
        body(0, out);
    }
}

/// Adds the prolongation of level k+1's `e` to level k's `u` on free fine cells: per fine
/// row, the two coarse rows are mixed (3/4, 1/4), then each cell mixes its two coarse
/// columns.
fn prolong_add(hier: &Hierarchy, k: usize, e: &[f32], u: &mut [f32]) {
    let (f, c) = (&hier.levels[k], &hier.levels[k + 1]);
    let t = &hier.transfers[k];
    let (wf, wc) = (f.w, c.w);
    let even = wf == 2 * wc && wc >= 3;
    let body = |y0: usize, uc: &mut [f32]| {
        let mut v = vec![0.0f32; wc];
        let mut full = vec![0.0f32; wf];
        for (dy, urow) in uc.chunks_mut(wf).enumerate() {
            let y = y0 + dy;
            if f.row_start[y] == f.row_start[y + 1] {
                continue;
            }
            let [(j0, w0), (j1, w1)] = t.y.prol[y];
            let (e0, e1) = (&e[j0 * wc..(j0 + 1) * wc], &e[j1 * wc..(j1 + 1) * wc]);
            for i in 0..wc {
                v[i] = w0 * e0[i] + w1 * e1[i];
            }
            let table = |x: usize| {
                let [(c0, a0), (c1, a1)] = t.x.prol[x];
                a0 * v[c0] + a1 * v[c1]
            };
            if even {
                for x in [0, 1, wf - 2, wf - 1] {
                    full[x] = table(x);
                }
                let (vm, vc, vp) = (&v[0..wc - 2], &v[1..wc - 1], &v[2..wc]);
                for (i, pair) in full[2..wf - 2].chunks_exact_mut(2).enumerate() {
                    pair[0] = 0.75 * vc[i] + 0.25 * vm[i];
                    pair[1] = 0.75 * vc[i] + 0.25 * vp[i];
                }
            } else {
                for (x, o) in full.iter_mut().enumerate() {
                    *o = table(x);
                }
            }
            for &(x0, x1) in f.row_runs(y) {
                for (o, a) in urow[x0..x1].iter_mut().zip(&full[x0..x1]) {
                    *o += *a;
                }
            }
        }
    };
    let step = wf * TRANSFER_ROWS * 2;
    if f.count >= PARALLEL_MIN {
        u.par_chunks_mut(step).enumerate().for_each(|(k, uc)| body(k * TRANSFER_ROWS * 2, uc));
    } else {
        body(0, u);
    }
}

/// Solves the coarsest level by conjugate gradients in f64 (to 1e-12 relative).
fn coarsest_solve(hier: &Hierarchy, b: &[f32], x: &mut [f32]) {
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
    let rhs: Vec<f64> = hier.coarse_cells.iter().map(|&c| b[c] as f64).collect();
    let bn = rhs.iter().map(|v| v * v).sum::<f64>().sqrt();
    let mut u = vec![0.0f64; n];
    if bn > 0.0 {
        let mut r = rhs.clone();
        let mut p = r.clone();
        let mut q = vec![0.0f64; n];
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
        x[c] = u[k] as f32;
    }
}

/// Applies one V-cycle with zero initial guess: `ws.x[0] ≈ L⁻¹ ws.b[0]`.
pub(crate) fn vcycle(hier: &Hierarchy, ws: &mut Workspace, cp: CycleParams) {
    let nl = hier.levels.len();
    for k in 0..nl - 1 {
        let lv = &hier.levels[k];
        for s in 0..cp.pre {
            lv.sweep(&mut ws.x[k], &ws.b[k], 0, false, s == 0);
        }
        let (lo, hi) = ws.b.split_at_mut(k + 1);
        residual_restrict(hier, k, &ws.x[k], &lo[k], &mut hi[0]);
    }
    {
        let k = nl - 1;
        coarsest_solve(hier, &ws.b[k], &mut ws.x[k]);
    }
    for k in (0..nl - 1).rev() {
        let lv = &hier.levels[k];
        let (lo, hi) = ws.x.split_at_mut(k + 1);
        prolong_add(hier, k, &hi[0], &mut lo[k]);
        for _ in 0..cp.post {
            lv.sweep(&mut ws.x[k], &ws.b[k], 1, true, false);
        }
    }
}

/// Outcome of an iterative solve.
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

/// Buffers of one solve, reused across channels that share a hierarchy.
pub(crate) struct SolveBuffers {
    ws: Workspace,
    p: Vec<f32>,
    q: Vec<f32>,
}

impl SolveBuffers {
    pub fn new(hier: &Hierarchy) -> SolveBuffers {
        let n = hier.levels[0].w * hier.levels[0].h;
        SolveBuffers { ws: Workspace::new(hier), p: vec![0.0; n], q: vec![0.0; n] }
    }
}

/// When an iterative solve stops.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Stop {
    /// Bound on `‖b − L u‖₂`.
    pub norm: f64,
    /// Bound on `max |b − L u|`.
    pub max: f64,
    pub max_iter: usize,
}

/// Solves `L u = r` on the hierarchy's free cells from `u = 0`, stopping when both bounds of
/// `stop` hold or after `stop.max_iter` iterations. On entry `r` holds the
/// right-hand side; on exit it holds the final residual. `u` must be zero on fixed cells.
pub(crate) fn solve(
    hier: &Hierarchy,
    bufs: &mut SolveBuffers,
    r: &mut Vec<f32>,
    u: &mut [f32],
    stop: Stop,
    driver: Driver,
    cp: CycleParams,
) -> IterStats {
    let lv = &hier.levels[0];
    let rr = lv.dot(r, r);
    let rmax = r.iter().fold(0.0f32, |m, v| m.max(v.abs())) as f64;
    let done = |rr: f64, rmax: f64| rr.sqrt() <= stop.norm && rmax <= stop.max;
    let max_iter = stop.max_iter;
    if done(rr, rmax) || lv.count == 0 {
        return IterStats { iterations: 0, converged: true };
    }
    let SolveBuffers { ws, p, q } = bufs;
    let precondition = |r: &mut Vec<f32>, ws: &mut Workspace| {
        std::mem::swap(&mut ws.b[0], r);
        vcycle(hier, ws, cp);
        std::mem::swap(&mut ws.b[0], r);
    };
    let mut it = 0;
    let mut converged = false;
    match driver {
        Driver::VCycles => {
            while it < max_iter {
                precondition(r, ws);
                // u += z; r −= L z.
                lv.apply_dot(&ws.x[0], q);
                let (rr, rmax) = lv.cg_update(u, r, &ws.x[0], q, 1.0);
                it += 1;
                if done(rr, rmax) {
                    converged = true;
                    break;
                }
            }
        }
        Driver::Pcg => {
            precondition(r, ws);
            p.copy_from_slice(&ws.x[0]);
            let mut rz = lv.dot(r, &ws.x[0]);
            let mut pq = lv.apply_dot(p, q);
            while it < max_iter {
                if pq <= 0.0 || !pq.is_finite() {
                    break;
                }
                let alpha = rz / pq;
                let (rr, rmax) = lv.cg_update(u, r, p, q, alpha);
                it += 1;
                if done(rr, rmax) {
                    converged = true;
                    break;
                }
                precondition(r, ws);
                let rz_new = lv.dot(r, &ws.x[0]);
                let beta = rz_new / rz;
                rz = rz_new;
                pq = lv.update_direction(&ws.x[0], beta, p, q);
            }
        }
    }
    IterStats { iterations: it, converged }
}
