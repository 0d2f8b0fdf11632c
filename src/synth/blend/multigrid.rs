//! Geometric multigrid for the masked Poisson problem, standalone (V-cycles) or as the
//! preconditioner of conjugate gradients (MGPCG), solving the channels of one blend (which
//! share the free-cell pattern) together.
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
//!   free ("Dirichlet dominant"). [references: welsman-dinelle §4.2] has the opposite rule ("free if any
//!   child is free"); both are offered ([`Coarsening`]), and the Dirichlet-dominant one is the
//!   default because it keeps every coarse operator non-singular (a level with a fixed cell
//!   has no constant null space) and measured fewer iterations on the disc benchmark.
//! - prolongation: cell-centred bilinear (weights 3/4, 1/4 per axis), restricted to free
//!   cells; restriction is its exact transpose, so the V-cycle is a symmetric operator.
//! - red-black Gauss–Seidel smoothing, pre-smoothing red→black, post-smoothing black→red
//!   (the adjoint; the order inside one colour does not matter, as a colour only reads the
//!   other one), which keeps the preconditioner SPD for CG.
//! - boundary smoothing (also McAdams et al.): the free cells within a few cells of a fixed
//!   one get extra red-black sweeps after the pre-smoothing and before the post-smoothing
//!   (in the adjoint order), where the rediscretised coarse correction is least accurate.
//!   The band is thin, so this is cheap, and it cut the CG iterations on the half-image disc
//!   from 8 to 5 (see [`BAND_RADIUS`]).
//! - coarse operator: the same 5-point stencil rediscretised on the coarse mask.
//! - coarsest level (min side ≤ 8): conjugate gradients in f64 to 1e-12.
//!
//! Lanes: storage is f32 on full-size planes (zero on fixed cells) of [`Lanes`] cells, one
//! lane per channel (`f32` for one channel, four SSE lanes otherwise), so one pass over
//! memory serves every channel and each level is traversed once. Lanes never mix: each lane
//! sees exactly the operations (and rounding) of a one-lane solve, with its own CG scalars
//! and its own stopping test; a lane that has stopped keeps its values (step length 0).
//!
//! Memory traffic: the solve is bandwidth-bound, so passes are fused. All half-sweeps of one
//! smoothing phase (and, after the coarse correction, the prolongation) run as one
//! *wavefront* over the rows (row y gets stage k while row y + 1 gets stage k − 1), so u and
//! b stream through the cache once per phase instead of once per half-sweep; the CG residual
//! · preconditioned residual product is taken as rows receive their last post-smoothing
//! update; `L p` is recomputed where needed instead of stored. The solver's planes come from
//! a small scratch pool (`lanes::Pool`): first-touch page faults of fresh planes cost more
//! than several V-cycles.
//!
//! Determinism: every reduction is summed per row, in a fixed order, then over rows in row
//! order; a red (black) half-sweep only reads black (red) cells, so rows can be updated in
//! parallel without changing any value. A parallel wavefront runs in blocks of rows:
//! each block first does the stage/row pairs whose inputs lie inside the block (stage k
//! skips k rows at either end), then the pairs near each block boundary are done in stage
//! order. Every cell receives exactly the update of the unfused, sequential sweep, so the
//! result is bit-identical for any number of rayon threads and any blocking. The one case
//! where a colour couples to itself across the wrap (periodic with odd height) is swept
//! sequentially, one half-sweep at a time.

use rayon::prelude::*;

use super::lanes::{par_copy, Lanes, Pooled};

/// How coarse cells inherit the free/fixed label of their 2 × 2 children.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize)]
pub enum Coarsening {
    /// Free only when every child is free (McAdams et al. 2010). Default.
    #[default]
    AllChildren,
    /// Free when any child is free (the alternative of [references: welsman-dinelle §4.2]).
    AnyChild,
}

/// Rows are grouped into parallel tasks of about this many cells.
const BLOCK_CELLS: usize = 16 * 1024;
/// Levels with fewer free cells × lanes than this are processed on the calling thread.
const PARALLEL_MIN: usize = 32 * 1024;
/// Coarsening stops once the shorter side is at most this.
const COARSEST_SIDE: usize = 8;
/// Cells per f32 partial sum in dot products (then accumulated in f64).
const DOT_CHUNK: usize = 64;
/// Boundary smoothing (McAdams et al. 2010): after the pre-smoothing and before the
/// post-smoothing, `BAND_SWEEPS` extra red-black sweeps on the free cells within Chebyshev
/// distance `BAND_RADIUS` of a fixed cell, where the coarse correction is least accurate.
/// Cheap (a thin band) and it cut the CG iterations on the half-image disc from 8 to 5.
const BAND_RADIUS: u8 = 4;
const BAND_SWEEPS: usize = 6;
/// Levels of more than `BAND_SMALL` free cells whose band holds more than
/// 1/`BAND_MAX_SHARE` of them skip it (a mask of thin shapes would be all band).
const BAND_MAX_SHARE: usize = 4;
const BAND_SMALL: usize = 16 * 1024;
/// Most lanes of a [`Lanes`] type.
pub(crate) const MAX_LANES: usize = 4;
/// Per-lane f64 results (lanes past `V::N` are zero).
pub(crate) type Sums = [f64; MAX_LANES];
/// Per-row results of one parallel task: (row, sums).
type RowSums = Vec<(usize, Sums)>;

/// A raw pointer shared between the threads of a red-black sweep.
struct SyncPtr<T>(*mut T);
impl<T> Clone for SyncPtr<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for SyncPtr<T> {}
// SAFETY: the pointer is only dereferenced under the access discipline described at
// `Level::run_stages` and `Level::update_direction` (no two threads write the same cell or
// read a cell being written).
unsafe impl<T> Send for SyncPtr<T> {}
unsafe impl<T> Sync for SyncPtr<T> {}

impl<T> SyncPtr<T> {
    #[inline(always)]
    fn get(self) -> *mut T {
        self.0
    }
}

/// One step of a fused smoothing phase, applied row by row.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Stage {
    /// `u += P e` on the row's free cells (the coarser level's correction).
    Prolong,
    /// Gauss–Seidel on the row's cells of colour `colour` ((x + y) mod 2); with
    /// `zero_init` the other colour is read as zero.
    Smooth { colour: usize, zero_init: bool },
}

/// The coarse correction a [`Stage::Prolong`] adds.
struct ProlongSrc<'a, V> {
    t: &'a Transfer,
    e: &'a [V],
    wc: usize,
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
    /// Rows per parallel task of row-local loops.
    rows_per_block: usize,
    /// `prefix[y]`: free cells in rows before `y`.
    prefix: Vec<usize>,
    /// Boundary smoothing (see [`BAND_RADIUS`]): the band's free cells, the band widened by
    /// one cell (prolonged ahead of the band sweeps), and the free cells outside that.
    band: Option<Band>,
}

/// Free cells near fixed cells, as runs per row.
struct Band {
    band: Runs,
    wide: Runs,
    rest: Runs,
}

/// Runs of cells per row.
struct Runs {
    start: Vec<usize>,
    runs: Vec<(usize, usize)>,
    /// Rows with at least one run.
    rows: Vec<usize>,
    count: usize,
}

impl Runs {
    /// The runs of cells where `mask` is non-zero (rows scanned in parallel).
    fn from_mask(w: usize, h: usize, mask: &[u8]) -> Runs {
        Runs::from_rows(h, |y, runs| {
            let row = &mask[y * w..(y + 1) * w];
            let mut x = 0;
            while let Some(s) = row[x..].iter().position(|&v| v != 0) {
                let s = x + s;
                let e = row[s..].iter().position(|&v| v == 0).map_or(w, |e| s + e);
                runs.push((s, e));
                x = e;
                if x >= w {
                    break;
                }
            }
        })
    }

    /// Runs from `row(y, runs)`, which pushes row y's runs in order (rows in parallel).
    fn from_rows(h: usize, row: impl Fn(usize, &mut Vec<(usize, usize)>) + Sync) -> Runs {
        let per_row: Vec<Vec<(usize, usize)>> = (0..h)
            .into_par_iter()
            .with_min_len(16)
            .map(|y| {
                let mut runs = Vec::new();
                row(y, &mut runs);
                runs
            })
            .collect();
        let mut start = Vec::with_capacity(h + 1);
        let (mut runs, mut rows, mut count) = (Vec::new(), Vec::new(), 0);
        for (y, r) in per_row.into_iter().enumerate() {
            start.push(runs.len());
            if !r.is_empty() {
                rows.push(y);
            }
            count += r.iter().map(|&(a, b)| b - a).sum::<usize>();
            runs.extend(r);
        }
        start.push(runs.len());
        Runs { start, runs, rows, count }
    }

    /// The parts of this level's runs where `keep(dist)` holds.
    fn filter(free: &Level, dist: &[u8], keep: impl Fn(u8) -> bool + Sync) -> Runs {
        let w = free.w;
        Runs::from_rows(free.h, |y, runs| {
            for &(a, b) in free.row_runs(y) {
                let d = &dist[y * w..(y + 1) * w];
                let mut x = a;
                while x < b {
                    if keep(d[x]) {
                        let s = x;
                        while x < b && keep(d[x]) {
                            x += 1;
                        }
                        runs.push((s, x));
                    } else {
                        x += 1;
                    }
                }
            }
        })
    }

    #[inline]
    fn row(&self, y: usize) -> &[(usize, usize)] {
        &self.runs[self.start[y]..self.start[y + 1]]
    }
}

impl Level {
    pub fn new(w: usize, h: usize, periodic: bool, free: Vec<u8>) -> Level {
        let Runs { start: row_start, runs, rows, count } = Runs::from_mask(w, h, &free);
        let parallel_safe = !(periodic && h % 2 == 1);
        let mut prefix = Vec::with_capacity(h + 1);
        prefix.push(0);
        for y in 0..h {
            let n: usize = runs[row_start[y]..row_start[y + 1]].iter().map(|&(a, b)| b - a).sum();
            prefix.push(prefix[y] + n);
        }
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
            prefix,
            band: None,
        }
        .with_band()
    }

    /// Adds the boundary band when it is small enough to be worth smoothing separately.
    fn with_band(mut self) -> Level {
        // Chebyshev distance to the nearest fixed cell, capped at BAND_RADIUS + 2.
        let dist = chebyshev_distance(&self, BAND_RADIUS + 2);
        let band = Runs::filter(&self, &dist, |d| d <= BAND_RADIUS);
        if band.count == 0 || (band.count * BAND_MAX_SHARE > self.count && self.count > BAND_SMALL) {
            return self;
        }
        let wide = Runs::filter(&self, &dist, |d| d <= BAND_RADIUS + 1);
        let rest = Runs::filter(&self, &dist, |d| d > BAND_RADIUS + 1);
        self.band = Some(Band { band, wide, rest });
        self
    }

    #[inline]
    pub fn row_runs(&self, y: usize) -> &[(usize, usize)] {
        &self.runs[self.row_start[y]..self.row_start[y + 1]]
    }

    #[inline]
    fn row_empty(&self, y: usize) -> bool {
        self.row_start[y] == self.row_start[y + 1]
    }

    /// Whether loops over this level with `L` lanes are worth running in parallel.
    #[inline]
    fn parallel<V: Lanes>(&self) -> bool {
        self.count * V::N >= PARALLEL_MIN
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
    ///
    /// # Safety
    /// `u` points to `w·h` cells.
    #[inline(always)]
    unsafe fn nb_generic<V: Lanes>(
        &self,
        u: *const V,
        row: usize,
        x: usize,
        up: Option<usize>,
        dn: Option<usize>,
    ) -> (V, f32) {
        let w = self.w;
        let mut s = V::default();
        let mut d = 0.0f32;
        let mut add = |i: usize| {
            s = s + *u.add(i);
            d += 1.0;
        };
        if x > 0 {
            add(row + x - 1);
        } else if self.periodic {
            add(row + w - 1);
        }
        if x + 1 < w {
            add(row + x + 1);
        } else if self.periodic {
            add(row);
        }
        if let Some(o) = up {
            add(o + x);
        }
        if let Some(o) = dn {
            add(o + x);
        }
        (s, d)
    }

    /// Gauss–Seidel update of the cells of colour `colour` ((x + y) mod 2) in row `y`.
    /// With `zero_init` the other colour is taken as zero (first sweep from a zero guess),
    /// so nothing needs clearing beforehand.
    ///
    /// # Safety
    /// `u` and `b` point to `w·h` cells; no other thread writes cells this call reads.
    #[inline(always)]
    unsafe fn smooth_row<V: Lanes>(
        &self,
        u: *mut V,
        b: *const V,
        y: usize,
        colour: usize,
        zero_init: bool,
        runs: &[(usize, usize)],
    ) {
        let w = self.w;
        let row = y * w;
        let (up, dn) = self.vert(y);
        let generic = |x: usize| {
            let (s, d) = self.nb_generic(u, row, x, up, dn);
            let s = if zero_init { V::default() } else { s };
            *u.add(row + x) = (*b.add(row + x) + s) / V::splat(d);
        };
        for &(x0, x1) in runs {
            // First and last cell of the colour in [x0, x1).
            let first = x0 + ((colour + y + x0) & 1);
            if first >= x1 {
                continue;
            }
            let last = first + (x1 - 1 - first) / 2 * 2;
            let (Some(uo), Some(dno)) = (up, dn) else {
                let mut x = first;
                while x <= last {
                    generic(x);
                    x += 2;
                }
                continue;
            };
            // Interior cells [lo, hi) (same colour) use the 4-neighbour fast path.
            let lo = if first == 0 {
                generic(0);
                2
            } else {
                first
            };
            let hi = if last == w - 1 { last - 1 } else { last + 1 };
            let mut x = lo;
            let quarter = V::splat(0.25);
            if zero_init {
                while x < hi {
                    *u.add(row + x) = *b.add(row + x) * quarter;
                    x += 2;
                }
            } else {
                while x < hi {
                    let i = row + x;
                    let (l, r, t, d) = (*u.add(i - 1), *u.add(i + 1), *u.add(uo + x), *u.add(dno + x));
                    *u.add(i) = (*b.add(i) + (l + r + t + d)) * quarter;
                    x += 2;
                }
            }
            if last == w - 1 && last >= lo {
                generic(last);
            }
        }
    }

    /// Adds the prolongation of the coarse correction `src` to the cells `runs` of row `y`:
    /// the two coarse rows are mixed (3/4, 1/4) into `v`, then each cell mixes its two
    /// coarse columns.
    ///
    /// # Safety
    /// `u` points to `w·h` cells; no other thread accesses row `y`; `v` holds `src.wc`
    /// cells.
    #[inline]
    unsafe fn prolong_row<V: Lanes>(
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

    /// Boundary smoothing: [`BAND_SWEEPS`] red-black sweeps on the band, each colour
    /// `first` then the other (nothing without a band).
    fn band_smooth<V: Lanes>(&self, u: &mut [V], b: &[V], first: usize) {
        if self.band.is_some() {
            let stages: Vec<Stage> = (0..BAND_SWEEPS)
                .flat_map(|_| {
                    [
                        Stage::Smooth { colour: first, zero_init: false },
                        Stage::Smooth { colour: 1 - first, zero_init: false },
                    ]
                })
                .collect();
            self.run_stages(u, b, &stages, None, true, false);
        }
    }

    /// Adds the prolongation of `src` on the widened band (the rest of the free cells get
    /// theirs in the post-smoothing wavefront).
    fn prolong_band<V: Lanes>(&self, u: &mut [V], src: &ProlongSrc<'_, V>) {
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

    /// `Σ a·b` over the free cells of row `y`, per lane.
    ///
    /// # Safety
    /// `a` and `b` point to `w·h` cells; nobody writes row `y` meanwhile.
    #[inline]
    unsafe fn row_dot_raw<V: Lanes>(&self, a: *const V, b: *const V, y: usize) -> Sums {
        let mut acc = [0.0; MAX_LANES];
        let row = y * self.w;
        for &(x0, x1) in self.row_runs(y) {
            let sa = std::slice::from_raw_parts(a.add(row + x0), x1 - x0);
            let sb = std::slice::from_raw_parts(b.add(row + x0), x1 - x0);
            add_lanes(&mut acc, dot_run(sa, sb));
        }
        acc
    }

    /// Row blocks of about equal free-cell counts for a parallel wavefront of `ns` stages
    /// (first rows, then h), or None when blocks would be too short for the boundary
    /// scheme (fewer than 2·ns rows). The blocking does not change any value.
    fn wave_blocks(&self, ns: usize) -> Option<Vec<usize>> {
        let h = self.h;
        let min_rows = 2 * ns.max(1);
        let want = (4 * rayon::current_num_threads()).min(h / min_rows);
        if want < 2 {
            return None;
        }
        let mut starts = vec![0usize];
        for i in 1..want {
            let target = i * self.count / want;
            let y = self.prefix.partition_point(|&c| c < target).saturating_sub(1);
            let y = y.max(starts[i - 1] + min_rows);
            if y + min_rows > h {
                break;
            }
            starts.push(y);
        }
        starts.push(h);
        (starts.len() > 2).then_some(starts)
    }

    /// Applies `stages` in order to the free cells of every row (with `band`, the smoothing
    /// stages touch the boundary band only): the same values as running each stage over all
    /// rows before the next, but as one wavefront (see the module documentation). With
    /// `want_dot`, returns `Σ b·u` per lane, summed per row after each row's last stage,
    /// then in row order.
    fn run_stages<V: Lanes>(
        &self,
        u: &mut [V],
        b: &[V],
        stages: &[Stage],
        pro: Option<&ProlongSrc<'_, V>>,
        band: bool,
        want_dot: bool,
    ) -> Option<Sums> {
        let (h, ns) = (self.h, stages.len());
        let mut stages = stages.to_vec();
        let zero_init = stages.iter().any(|s| matches!(s, Stage::Smooth { zero_init: true, .. }));
        if zero_init && self.periodic && (self.w % 2 == 1 || self.h % 2 == 1) {
            // Across an odd wrap a colour has neighbours of its own colour: clear instead.
            self.zero(u);
            for s in &mut stages {
                if let Stage::Smooth { zero_init, .. } = s {
                    *zero_init = false;
                }
            }
        }
        let stages = &stages[..];
        let band_runs = if band { self.band.as_ref().map(|bd| &bd.band) } else { None };
        let smooth_runs = |y: usize| band_runs.map_or(self.row_runs(y), |r| r.row(y));
        let active = |y: usize| !smooth_runs(y).is_empty();
        let wc = pro.map_or(0, |p| p.wc);
        let up = SyncPtr(u.as_mut_ptr());
        let bp = SyncPtr(b.as_ptr() as *mut V);
        // Stage k on row y (and the row's dot after the last stage).
        //
        // SAFETY (for callers): the caller guarantees the wavefront discipline: no other
        // thread writes the rows this stage reads or reads the row it writes.
        let apply = |k: usize, y: usize, v: &mut [V], dots: &mut Vec<(usize, Sums)>| unsafe {
            match stages[k] {
                Stage::Prolong => {
                    // Band levels prolong their widened band ahead of the band sweeps.
                    let runs = self.band.as_ref().map_or(self.row_runs(y), |bd| bd.rest.row(y));
                    self.prolong_row(pro.expect("prolongation source"), y, runs, up.get(), v)
                }
                Stage::Smooth { colour, zero_init } => {
                    self.smooth_row(up.get(), bp.get(), y, colour, zero_init, smooth_runs(y))
                }
            }
            if want_dot && k + 1 == ns {
                dots.push((y, self.row_dot_raw(bp.get(), up.get(), y)));
            }
        };
        let cells = band_runs.map_or(self.count, |r| r.count);
        let parallel = cells * V::N >= PARALLEL_MIN;
        // Wavefront blocks; None: stage after stage (rows too few for the boundary scheme,
        // or a colour that meets itself across an odd wrap).
        let starts = if !self.parallel_safe || h < 2 * ns.max(1) {
            None
        } else if parallel {
            Some(self.wave_blocks(ns).unwrap_or_else(|| vec![0, h]))
        } else {
            Some(vec![0, h])
        };
        let mut dots: Vec<(usize, Sums)> = Vec::new();
        match starts {
            None => {
                let mut v = vec![V::default(); wc];
                let rows = band_runs.map_or(&self.rows, |r| &r.rows);
                for k in 0..ns {
                    for &y in rows {
                        apply(k, y, &mut v, &mut dots);
                    }
                }
            }
            Some(starts) => {
                let nb = starts.len() - 1;
                // Phase 1: in each block, stage k on rows [y0 + k, y1 − k), as a wavefront.
                let phase1 = |bi: usize| {
                    let (y0, y1) = (starts[bi], starts[bi + 1]);
                    let mut v = vec![V::default(); wc];
                    let mut dots = Vec::new();
                    for t in y0..y1 + ns {
                        for k in 0..ns.min(t + 1) {
                            let y = t - k;
                            if y >= y0 + k && y + k < y1 && active(y) {
                                apply(k, y, &mut v, &mut dots);
                            }
                        }
                    }
                    dots
                };
                // Phase 2: around each block boundary Y, stage k on rows [Y − k, Y + k),
                // stage by stage (wrapping on a torus; clipped at a non-periodic edge).
                let phase2 = |&yb: &usize| {
                    let mut v = vec![V::default(); wc];
                    let mut dots = Vec::new();
                    for k in 1..ns {
                        for d in -(k as isize)..k as isize {
                            let Some(y) = wrap_or_skip(yb as isize + d, h, self.periodic) else { continue };
                            if active(y) {
                                apply(k, y, &mut v, &mut dots);
                            }
                        }
                    }
                    dots
                };
                let bounds: &[usize] = if self.periodic { &starts[..nb] } else { &starts };
                let (p1, p2): (Vec<RowSums>, Vec<RowSums>) = if parallel && nb > 1 {
                    let p1 = (0..nb).into_par_iter().map(phase1).collect();
                    (p1, bounds.par_iter().map(phase2).collect())
                } else {
                    ((0..nb).map(phase1).collect(), bounds.iter().map(phase2).collect())
                };
                dots = p1.into_iter().chain(p2).flatten().collect();
            }
        }
        want_dot.then(|| {
            let mut per_row = vec![[0.0; MAX_LANES]; h];
            for (y, s) in dots {
                per_row[y] = s;
            }
            sum_rows(&per_row)
        })
    }

    /// `out = b − L u` (or `out = L u` when `b` is None) on the free cells of row `y`.
    #[inline(always)]
    fn op_row<V: Lanes>(&self, u: &[V], b: Option<&[V]>, out_row: &mut [V], y: usize) {
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

    /// Sets free cells of `u` to zero (fixed cells are zero by construction).
    pub fn zero<V: Lanes>(&self, u: &mut [V]) {
        let w = self.w;
        let block = |bi: usize, c: &mut [V]| {
            for (dy, y) in self.block_rows(bi).enumerate() {
                for &(x0, x1) in self.row_runs(y) {
                    c[dy * w + x0..dy * w + x1].fill(V::default());
                }
            }
        };
        let step = w * self.rows_per_block;
        if self.parallel::<V>() {
            u.par_chunks_mut(step).enumerate().for_each(|(bi, c)| block(bi, c));
        } else {
            u.chunks_mut(step).enumerate().for_each(|(bi, c)| block(bi, c));
        }
    }

    /// Sets lane `k` of the free cells of `u` to zero.
    fn zero_lane<V: Lanes>(&self, u: &mut [V], k: usize) {
        let w = self.w;
        for &y in &self.rows {
            for &(x0, x1) in self.row_runs(y) {
                for v in &mut u[y * w + x0..y * w + x1] {
                    v.set(k, 0.0);
                }
            }
        }
    }

    /// Rows of parallel task `bi`.
    #[inline]
    fn block_rows(&self, bi: usize) -> std::ops::Range<usize> {
        bi * self.rows_per_block..((bi + 1) * self.rows_per_block).min(self.h)
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

fn blocks(w: usize) -> usize {
    (BLOCK_CELLS / w.max(1)).max(1)
}

/// Chebyshev distance (capped at `cap`) from each cell to the nearest cell with
/// `free == 0`, wrapping when `periodic`. Separable: the distance along the row (a forward
/// and a backward scan), then the minimum over vertical offsets `d` of
/// `max(row distance at y + d, |d|)`.
fn chebyshev_distance(lv: &Level, cap: u8) -> Vec<u8> {
    let (w, h, periodic) = (lv.w, lv.h, lv.periodic);
    let r = cap as usize;
    let mut rowd = vec![0u8; w * h];
    rowd.par_chunks_mut(w).enumerate().with_min_len(16).for_each(|(y, out)| {
        // Along the row: free runs measure to the fixed cells at their ends (none past a
        // non-periodic edge; through the wrap on a torus).
        let runs = lv.row_runs(y);
        let n = runs.len();
        for (i, &(s, e)) in runs.iter().enumerate() {
            // Free cells between the nearest fixed cell and the run's first (last) cell.
            let left = if s > 0 {
                Some(0)
            } else if !periodic || (n == 1 && e == w) {
                None
            } else {
                Some(runs.last().filter(|&&(_, e2)| e2 == w && i + 1 != n).map_or(0, |&(s2, _)| w - s2))
            };
            let right = if e < w {
                Some(0)
            } else if !periodic || (n == 1 && s == 0) {
                None
            } else {
                Some(runs.first().filter(|&&(s2, _)| s2 == 0 && i != 0).map_or(0, |&(_, e2)| e2))
            };
            for (x, o) in out[s..e].iter_mut().enumerate() {
                let dl = left.map_or(r, |g| x + 1 + g);
                let dr = right.map_or(r, |g| e - s - x + g);
                *o = dl.min(dr).min(r) as u8;
            }
        }
    });
    let mut out = vec![cap; w * h];
    out.par_chunks_mut(w).enumerate().with_min_len(16).for_each(|(y, o)| {
        for d in -(r as isize)..=r as isize {
            let Some(yy) = wrap_or_skip(y as isize + d, h, periodic) else { continue };
            let dd = d.unsigned_abs() as u8;
            for (ov, &av) in o.iter_mut().zip(&rowd[yy * w..(yy + 1) * w]) {
                *ov = (*ov).min(av.max(dd));
            }
        }
    });
    out
}

/// The coarse columns `[lo, hi)` that the fine columns `[x0, x1)` exchange values with
/// under prolongation and restriction (all of them when the span touches the image edge,
/// where the transfer wraps or clamps).
#[inline]
fn coarse_span(x0: usize, x1: usize, wf: usize, wc: usize) -> (usize, usize) {
    if x0 == 0 || x1 == wf {
        (0, wc)
    } else {
        ((x0 / 2).saturating_sub(1), ((x1 - 1) / 2 + 2).min(wc))
    }
}

#[inline(always)]
fn add_lanes(acc: &mut Sums, v: Sums) {
    for k in 0..MAX_LANES {
        acc[k] += v[k];
    }
}

/// Per-row sums added in row order.
fn sum_rows(rows: &[Sums]) -> Sums {
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
            cfree.par_chunks_mut(wc).enumerate().with_min_len(8).for_each(|(j, crow)| {
                for (i, cv) in crow.iter_mut().enumerate() {
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
                    *cv = v as u8;
                }
            });
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

/// Restriction along x of one fine row `src` into the coarse cells `[lo, hi)` of `dst`.
#[inline]
fn restrict_x<V: Lanes>(t: &Transfer1, src: &[V], dst: &mut [V], (lo, hi): (usize, usize)) {
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
pub(crate) fn solve<V: Pooled>(
    hier: &Hierarchy,
    bufs: &mut SolveBuffers<V>,
    r: &mut Vec<V>,
    u: &mut [V],
    stops: &[Stop],
    driver: Driver,
    cp: CycleParams,
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

/// Cell `i` of a line of `len` cells: wrapped on a torus, `None` past a rim.
#[inline]
pub(super) fn wrap_or_skip(i: isize, len: usize, periodic: bool) -> Option<usize> {
    if periodic {
        Some(i.rem_euclid(len as isize) as usize)
    } else {
        usize::try_from(i).ok().filter(|&i| i < len)
    }
}
