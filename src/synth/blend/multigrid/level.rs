//! One grid level: its free cells as runs per row, the boundary band, and the row helpers and
//! shared raw pointer that the smoothing, transfer and CG kernels of the other files build on.

use rayon::prelude::*;

use crate::synth::blend::lanes::Lanes;

/// Rows are grouped into parallel tasks of about this many cells.
const BLOCK_CELLS: usize = 16 * 1024;
/// Levels with fewer free cells × lanes than this are processed on the calling thread.
pub(super) const PARALLEL_MIN: usize = 32 * 1024;
/// Boundary smoothing (McAdams et al. 2010): after the pre-smoothing and before the
/// post-smoothing, `BAND_SWEEPS` extra red-black sweeps on the free cells within Chebyshev
/// distance `BAND_RADIUS` of a fixed cell, where the coarse correction is least accurate.
/// Cheap (a thin band) and it cut the CG iterations on the half-image disc from 8 to 5.
const BAND_RADIUS: u8 = 4;
pub(super) const BAND_SWEEPS: usize = 6;
/// Levels of more than `BAND_SMALL` free cells whose band holds more than
/// 1/`BAND_MAX_SHARE` of them skip it (a mask of thin shapes would be all band).
const BAND_MAX_SHARE: usize = 4;
const BAND_SMALL: usize = 16 * 1024;

/// A raw pointer shared between the threads of a red-black sweep.
pub(super) struct SyncPtr<T>(pub(super) *mut T);
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
    pub(super) fn get(self) -> *mut T {
        self.0
    }
}

/// One grid level: its free cells as runs per row.
pub(crate) struct Level {
    pub w: usize,
    pub h: usize,
    pub periodic: bool,
    pub free: Vec<u8>,
    pub(super) row_start: Vec<usize>,
    pub(super) runs: Vec<(usize, usize)>,
    /// Rows that hold at least one free cell.
    pub(super) rows: Vec<usize>,
    pub count: usize,
    /// Rows may be swept concurrently (false only for periodic levels with odd height).
    pub(super) parallel_safe: bool,
    /// Rows per parallel task of row-local loops.
    pub(super) rows_per_block: usize,
    /// `prefix[y]`: free cells in rows before `y`.
    pub(super) prefix: Vec<usize>,
    /// Boundary smoothing (see [`BAND_RADIUS`]): the band's free cells, the band widened by
    /// one cell (prolonged ahead of the band sweeps), and the free cells outside that.
    pub(super) band: Option<Band>,
}

/// Free cells near fixed cells, as runs per row.
pub(super) struct Band {
    pub(super) band: Runs,
    pub(super) wide: Runs,
    pub(super) rest: Runs,
}

/// Runs of cells per row.
pub(super) struct Runs {
    pub(super) start: Vec<usize>,
    pub(super) runs: Vec<(usize, usize)>,
    /// Rows with at least one run.
    pub(super) rows: Vec<usize>,
    pub(super) count: usize,
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
    pub(super) fn row(&self, y: usize) -> &[(usize, usize)] {
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
    pub(super) fn row_empty(&self, y: usize) -> bool {
        self.row_start[y] == self.row_start[y + 1]
    }

    /// Whether loops over this level with `L` lanes are worth running in parallel.
    #[inline]
    pub(super) fn parallel<V: Lanes>(&self) -> bool {
        self.count * V::N >= PARALLEL_MIN
    }

    /// Row offsets of the rows above and below `y` (None past a non-periodic edge).
    #[inline]
    pub(super) fn vert(&self, y: usize) -> (Option<usize>, Option<usize>) {
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
    pub(super) unsafe fn nb_generic<V: Lanes>(
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
    pub(super) fn zero_lane<V: Lanes>(&self, u: &mut [V], k: usize) {
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
    pub(super) fn block_rows(&self, bi: usize) -> std::ops::Range<usize> {
        bi * self.rows_per_block..((bi + 1) * self.rows_per_block).min(self.h)
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

/// Cell `i` of a line of `len` cells: wrapped on a torus, `None` past a rim.
#[inline]
pub(crate) fn wrap_or_skip(i: isize, len: usize, periodic: bool) -> Option<usize> {
    if periodic {
        Some(i.rem_euclid(len as isize) as usize)
    } else {
        usize::try_from(i).ok().filter(|&i| i < len)
    }
}
