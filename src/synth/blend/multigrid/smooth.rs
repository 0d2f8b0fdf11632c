//! Red-black Gauss–Seidel smoothing: one row's half-sweep, and the fused wavefront that runs a
//! whole smoothing phase (with the prolongation ahead of it) in one pass over the rows.

use rayon::prelude::*;

use super::level::{wrap_or_skip, Level, SyncPtr, BAND_SWEEPS, PARALLEL_MIN};
use super::ops::{sum_rows, RowSums, Sums, MAX_LANES};
use super::transfer::ProlongSrc;
use crate::synth::blend::lanes::Lanes;

/// One step of a fused smoothing phase, applied row by row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Stage {
    /// `u += P e` on the row's free cells (the coarser level's correction).
    Prolong,
    /// Gauss–Seidel on the row's cells of colour `colour` ((x + y) mod 2); with
    /// `zero_init` the other colour is read as zero.
    Smooth { colour: usize, zero_init: bool },
}

impl Level {
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

    /// Boundary smoothing: [`BAND_SWEEPS`] red-black sweeps on the band, each colour
    /// `first` then the other (nothing without a band).
    pub(super) fn band_smooth<V: Lanes>(&self, u: &mut [V], b: &[V], first: usize) {
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
    pub(super) fn run_stages<V: Lanes>(
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
}
