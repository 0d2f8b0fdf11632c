//! Step 5 of polygonisation: Douglas–Peucker simplification of the chains, and the check
//! that finds chains whose simplified geometry crosses another or flips a ring.

use super::cracks::{chain_area2_int, Chain, CrackGrid, RegionRings};
use crate::synth::structure::types::Point;

/// Douglas–Peucker of a raw chain with fixed ends; a closed chain is split at the corner
/// farthest from its anchor. Tolerance 0 keeps exactly the turning corners.
pub(super) fn simplify_chain(grid: &CrackGrid, raw: &[u32], tol: f64) -> Vec<u32> {
    let pts: Vec<[f64; 2]> = raw
        .iter()
        .map(|&c| {
            let (x, y) = grid.corner_xy(c);
            [x as f64, y as f64]
        })
        .collect();
    let n = pts.len();
    let mut keep = vec![false; n];
    keep[0] = true;
    keep[n - 1] = true;
    if raw[0] == raw[n - 1] {
        // Closed: split at the farthest corner, and keep a third corner far from both so the
        // ring cannot collapse.
        let far = (1..n - 1)
            .max_by(|&i, &j| dist2(pts[0], pts[i]).total_cmp(&dist2(pts[0], pts[j])).then(j.cmp(&i)))
            .unwrap_or(0);
        keep[far] = true;
        let third = (1..n - 1).filter(|&i| i != far).max_by(|&i, &j| {
            seg_dist(pts[i], pts[0], pts[far]).total_cmp(&seg_dist(pts[j], pts[0], pts[far])).then(j.cmp(&i))
        });
        if let Some(t) = third {
            keep[t] = true;
        }
        let mut marks: Vec<usize> = (0..n).filter(|&i| keep[i]).collect();
        marks.sort_unstable();
        for win in marks.windows(2) {
            dp(&pts, win[0], win[1], tol, &mut keep);
        }
    } else {
        dp(&pts, 0, n - 1, tol, &mut keep);
    }
    (0..n).filter(|&i| keep[i]).map(|i| raw[i]).collect()
}

pub(super) fn dp(pts: &[[f64; 2]], i0: usize, i1: usize, tol: f64, keep: &mut [bool]) {
    let mut stack = vec![(i0, i1)];
    while let Some((a, b)) = stack.pop() {
        if b <= a + 1 {
            continue;
        }
        let mut best = (-1.0, 0);
        for i in a + 1..b {
            let d = seg_dist(pts[i], pts[a], pts[b]);
            if d > best.0 {
                best = (d, i);
            }
        }
        // With tol = 0 keep only real turns (collinear corners have distance 0).
        if best.0 > tol || (tol == 0.0 && best.0 > 0.0) {
            keep[best.1] = true;
            stack.push((a, best.1));
            stack.push((best.1, b));
        }
    }
}

#[inline]
pub(super) fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

/// Distance from `p` to segment `[a, b]`.
pub(super) fn seg_dist(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
    let l2 = ex * ex + ey * ey;
    let t = if l2 > 0.0 { (((p[0] - a[0]) * ex + (p[1] - a[1]) * ey) / l2).clamp(0.0, 1.0) } else { 0.0 };
    ((p[0] - a[0] - t * ex).powi(2) + (p[1] - a[1] - t * ey).powi(2)).sqrt()
}

#[inline]
pub(super) fn orient(a: Point, b: Point, c: Point) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

#[inline]
pub(super) fn on_segment(p: Point, a: Point, b: Point) -> bool {
    p[0] >= a[0].min(b[0]) && p[0] <= a[0].max(b[0]) && p[1] >= a[1].min(b[1]) && p[1] <= a[1].max(b[1])
}

/// Do two segments conflict? Segments sharing one endpoint conflict only if they overlap
/// along a line; identical segments conflict; otherwise any contact is a conflict.
/// (Coordinates are small dyadic rationals, so the orientation tests are exact.)
pub(super) fn segments_conflict(a0: Point, a1: Point, b0: Point, b1: Point) -> bool {
    let shared = [(a0 == b0), (a0 == b1), (a1 == b0), (a1 == b1)];
    let nshared = shared.iter().filter(|&&s| s).count();
    if nshared >= 2 {
        return true;
    }
    if nshared == 1 {
        let (p, qa, qb) = if shared[0] {
            (a0, a1, b1)
        } else if shared[1] {
            (a0, a1, b0)
        } else if shared[2] {
            (a1, a0, b1)
        } else {
            (a1, a0, b0)
        };
        let collinear = orient(p, qa, qb) == 0.0;
        let same_dir = (qa[0] - p[0]) * (qb[0] - p[0]) + (qa[1] - p[1]) * (qb[1] - p[1]) > 0.0;
        return collinear && same_dir;
    }
    let o1 = orient(a0, a1, b0);
    let o2 = orient(a0, a1, b1);
    let o3 = orient(b0, b1, a0);
    let o4 = orient(b0, b1, a1);
    if ((o1 > 0.0 && o2 < 0.0) || (o1 < 0.0 && o2 > 0.0)) && ((o3 > 0.0 && o4 < 0.0) || (o3 < 0.0 && o4 > 0.0)) {
        return true;
    }
    (o1 == 0.0 && on_segment(b0, a0, a1))
        || (o2 == 0.0 && on_segment(b1, a0, a1))
        || (o3 == 0.0 && on_segment(a0, b0, b1))
        || (o4 == 0.0 && on_segment(a1, b0, b1))
}

/// Chains whose simplified geometry conflicts with another chain (or itself) or flips a ring.
pub(super) fn invalid_chains(grid: &CrackGrid, chains: &[Chain], rings: &RegionRings) -> Vec<usize> {
    let xy = |c: u32| {
        let (x, y) = grid.corner_xy(c);
        [x as f64, y as f64]
    };
    // Segments with owner chain and index.
    let mut segs: Vec<(usize, usize, Point, Point)> = Vec::new();
    for (ci, c) in chains.iter().enumerate() {
        for (k, p) in c.pts.windows(2).enumerate() {
            segs.push((ci, k, xy(p[0]), xy(p[1])));
        }
    }
    let mut bad = vec![false; chains.len()];
    let cell = 16.0;
    let gw = (grid.w as f64 / cell).ceil() as usize + 1;
    let gh = (grid.h as f64 / cell).ceil() as usize + 1;
    let mut buckets: Vec<Vec<usize>> = vec![Vec::new(); gw * gh];
    for (si, s) in segs.iter().enumerate() {
        let x0 = (s.2[0].min(s.3[0]) / cell) as usize;
        let x1 = (s.2[0].max(s.3[0]) / cell) as usize;
        let y0 = (s.2[1].min(s.3[1]) / cell) as usize;
        let y1 = (s.2[1].max(s.3[1]) / cell) as usize;
        for gy in y0..=y1.min(gh - 1) {
            for gx in x0..=x1.min(gw - 1) {
                buckets[gy * gw + gx].push(si);
            }
        }
    }
    for b in &buckets {
        for (ii, &i) in b.iter().enumerate() {
            for &j in &b[ii + 1..] {
                let (si, sj) = (&segs[i], &segs[j]);
                if si.0 == sj.0 {
                    let n = chains[si.0].pts.len() - 1;
                    let adjacent = si.1.abs_diff(sj.1) == 1
                        || (chains[si.0].raw[0] == *chains[si.0].raw.last().unwrap() && si.1.abs_diff(sj.1) == n - 1);
                    if adjacent {
                        // Consecutive segments: only a fold-back is a conflict.
                        if segments_conflict(si.2, si.3, sj.2, sj.3) {
                            bad[si.0] = true;
                        }
                        continue;
                    }
                }
                if segments_conflict(si.2, si.3, sj.2, sj.3) {
                    bad[si.0] = true;
                    bad[sj.0] = true;
                }
            }
        }
    }
    // Ring orientation: outer rings positive, holes negative, all non-degenerate.
    for (_, rs) in &rings.regions {
        for (k, ring) in rs.iter().enumerate() {
            let a2: i64 = ring.iter().map(|&(ci, rev)| chain_area2_int(grid, &chains[ci].pts, rev)).sum();
            let ok = if k == 0 { a2 > 0 } else { a2 < 0 };
            if !ok {
                for &(ci, _) in ring {
                    bad[ci] = true;
                }
            }
        }
    }
    (0..chains.len()).filter(|&i| bad[i] && chains[i].level < 4).collect()
}
