//! The block grid: block positions along each axis (spread evenly on a torus), and the waves
//! of blocks with disjoint footprints that may be computed in parallel.

#[cfg(test)]
use super::trace::RASTER_ORDER;

/// Block positions along one axis and whether blocks wrap (torus).
pub(super) struct Axis {
    pub(super) pos: Vec<usize>,
    pub(super) size: usize,
    pub(super) wrap: bool,
}

impl Axis {
    pub(super) fn new(size: usize, block: usize, overlap: usize, wrap: bool) -> Axis {
        let step = block - overlap;
        let pos = if wrap {
            // Spread n = ceil(size/step) blocks evenly: spacings differ by at most 1, overlaps ≥ O.
            let n = size.div_ceil(step);
            (0..n).map(|i| i * size / n).collect()
        } else {
            let n = 1 + size.saturating_sub(block).div_ceil(step);
            (0..n).map(|i| i * step).collect()
        };
        Axis { pos, size, wrap }
    }

    /// Extent of block `i` inside the output (clipped unless wrapping).
    pub(super) fn extent(&self, i: usize, block: usize) -> usize {
        if self.wrap {
            block
        } else {
            block.min(self.size - self.pos[i])
        }
    }

    pub(super) fn at(&self, i: usize, d: usize) -> usize {
        let v = self.pos[i] + d;
        if self.wrap {
            v % self.size
        } else {
            v
        }
    }

    /// Overlap widths with the previous block and (torus, last block) with block 0 after wrapping.
    pub(super) fn overlaps(&self, i: usize, block: usize) -> (usize, usize) {
        let before = if i > 0 { (self.pos[i - 1] + block).saturating_sub(self.pos[i]) } else { 0 };
        let after =
            if self.wrap && i + 1 == self.pos.len() { (self.pos[i] + block).saturating_sub(self.size) } else { 0 };
        (before, after)
    }
}

/// Groups the block grid into waves: a block's wave is one more than that of every earlier (raster
/// order) block whose footprint overlaps its own. Blocks of one wave have disjoint footprints, so
/// computing them in parallel and pasting them in raster order gives exactly the raster-order result.
pub(super) fn waves(ax: &Axis, ay: &Axis, b: usize) -> Vec<Vec<(usize, usize)>> {
    let (nbx, nby) = (ax.pos.len(), ay.pos.len());
    #[cfg(test)]
    if RASTER_ORDER.with(std::cell::Cell::get) {
        return (0..nby).flat_map(|j| (0..nbx).map(move |i| vec![(i, j)])).collect();
    }
    // Footprint intervals overlap, on the circle when the axis wraps.
    let overlaps = |a: &Axis, i: usize, k: usize| -> bool {
        let (l1, h1) = (a.pos[i] as i64, (a.pos[i] + a.extent(i, b)) as i64);
        let (l2, h2) = (a.pos[k] as i64, (a.pos[k] + a.extent(k, b)) as i64);
        let n = a.size as i64;
        let shifts: &[i64] = if a.wrap { &[-n, 0, n] } else { &[0] };
        shifts.iter().any(|&s| l1 < h2 + s && l2 + s < h1)
    };
    let mut level = vec![0usize; nbx * nby];
    let mut out: Vec<Vec<(usize, usize)>> = Vec::new();
    for j in 0..nby {
        for i in 0..nbx {
            let mut lv = 0;
            for jj in 0..=j {
                if !overlaps(ay, j, jj) {
                    continue;
                }
                for ii in 0..nbx {
                    if (jj, ii) >= (j, i) {
                        break;
                    }
                    if overlaps(ax, i, ii) {
                        lv = lv.max(level[jj * nbx + ii] + 1);
                    }
                }
            }
            level[j * nbx + i] = lv;
            if out.len() <= lv {
                out.resize(lv + 1, Vec::new());
            }
            out[lv].push((i, j));
        }
    }
    out
}
