//! Minimum-error boundary cut by dynamic programming ([references: efros-freeman]; [references: dong §5.3.2]).

/// Minimum-cost top-to-bottom path through a `width × height` error strip (row-major): one column per
/// row, consecutive rows' columns differ by at most 1 (8-connected, monotone in y).
///
/// `E(0, c) = e(0, c)`, `E(r, c) = e(r, c) + min(E(r−1, c−1), E(r−1, c), E(r−1, c+1))`, backtracked
/// from the lowest-cost end. Ties go to the lowest column, so the path is deterministic. Returns the
/// path's column per row and its total cost. An empty strip gives an empty path of cost 0.
pub fn min_cut_vertical(err: &[f64], width: usize, height: usize) -> (Vec<usize>, f64) {
    assert_eq!(err.len(), width * height, "error strip size");
    if width == 0 || height == 0 {
        return (Vec::new(), 0.0);
    }
    let mut cost = err[..width].to_vec();
    // from[r * width + c] = column of the predecessor in row r − 1.
    let mut from = vec![0u32; width * height];
    let mut next = vec![0.0; width];
    for r in 1..height {
        for c in 0..width {
            let lo = c.saturating_sub(1);
            let hi = (c + 1).min(width - 1);
            let mut best = lo;
            for k in lo + 1..=hi {
                if cost[k] < cost[best] {
                    best = k;
                }
            }
            next[c] = err[r * width + c] + cost[best];
            from[r * width + c] = best as u32;
        }
        std::mem::swap(&mut cost, &mut next);
    }
    let mut end = 0;
    for c in 1..width {
        if cost[c] < cost[end] {
            end = c;
        }
    }
    let total = cost[end];
    let mut path = vec![0usize; height];
    let mut c = end;
    for r in (0..height).rev() {
        path[r] = c;
        c = from[r * width + c] as usize;
    }
    (path, total)
}

/// Minimum-cost left-to-right path through a `width × height` strip: one row per column (the
/// transpose of [`min_cut_vertical`]).
pub fn min_cut_horizontal(err: &[f64], width: usize, height: usize) -> (Vec<usize>, f64) {
    assert_eq!(err.len(), width * height, "error strip size");
    let mut t = vec![0.0; err.len()];
    for y in 0..height {
        for x in 0..width {
            t[x * height + y] = err[y * width + x];
        }
    }
    min_cut_vertical(&t, height, width)
}

/// Overlap strips of a block, in pixels: `[left, top, right, bottom]` (0 = no overlap on that side).
pub(super) type Sides = [usize; 4];

/// Which pixels of a `bw × bh` block come from the new block: per side with an overlap, a cut through
/// that strip's error; pixels on the old side of any cut keep the existing result (the intersection of
/// the "new" regions, [references: efros-freeman] for the L-shaped case). The path pixel itself is new.
/// `err(x, y)` is the per-pixel error inside the block.
pub(super) fn new_region(bw: usize, bh: usize, sides: Sides, err: impl Fn(usize, usize) -> f64) -> Vec<bool> {
    let mut new = vec![true; bw * bh];
    let [left, top, right, bottom] = sides;
    let (left, right, top, bottom) = (left.min(bw), right.min(bw), top.min(bh), bottom.min(bh));
    if left > 0 {
        let strip: Vec<f64> = (0..bh).flat_map(|y| (0..left).map(move |x| (x, y))).map(|(x, y)| err(x, y)).collect();
        let (path, _) = min_cut_vertical(&strip, left, bh);
        for (y, &p) in path.iter().enumerate() {
            new[y * bw..y * bw + p].fill(false);
        }
    }
    if right > 0 {
        let x0 = bw - right;
        let strip: Vec<f64> =
            (0..bh).flat_map(|y| (0..right).map(move |x| (x0 + x, y))).map(|(x, y)| err(x, y)).collect();
        let (path, _) = min_cut_vertical(&strip, right, bh);
        for (y, &p) in path.iter().enumerate() {
            new[y * bw + x0 + p + 1..(y + 1) * bw].fill(false);
        }
    }
    if top > 0 {
        let strip: Vec<f64> = (0..top).flat_map(|y| (0..bw).map(move |x| (x, y))).map(|(x, y)| err(x, y)).collect();
        let (path, _) = min_cut_horizontal(&strip, bw, top);
        for (x, &p) in path.iter().enumerate() {
            for y in 0..p {
                new[y * bw + x] = false;
            }
        }
    }
    if bottom > 0 {
        let y0 = bh - bottom;
        let strip: Vec<f64> =
            (0..bottom).flat_map(|y| (0..bw).map(move |x| (x, y0 + y))).map(|(x, y)| err(x, y)).collect();
        let (path, _) = min_cut_horizontal(&strip, bw, bottom);
        for (x, &p) in path.iter().enumerate() {
            for y in y0 + p + 1..bh {
                new[y * bw + x] = false;
            }
        }
    }
    new
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::rng::Rng;

    /// Brute force over every 8-connected monotone top-to-bottom path.
    fn brute_vertical(err: &[f64], w: usize, h: usize) -> f64 {
        fn rec(err: &[f64], w: usize, h: usize, r: usize, c: usize) -> f64 {
            let here = err[r * w + c];
            if r + 1 == h {
                return here;
            }
            let lo = c.saturating_sub(1);
            let hi = (c + 1).min(w - 1);
            here + (lo..=hi).map(|k| rec(err, w, h, r + 1, k)).fold(f64::INFINITY, f64::min)
        }
        (0..w).map(|c| rec(err, w, h, 0, c)).fold(f64::INFINITY, f64::min)
    }

    fn path_cost_vertical(err: &[f64], w: usize, path: &[usize]) -> f64 {
        path.iter().enumerate().map(|(r, &c)| err[r * w + c]).sum()
    }

    // Dong checklist item 16: DP cost = brute-force minimum on random 6x4 strips (Frasson F30: 8x8).
    #[test]
    fn dp_cut_equals_brute_force_minimum() {
        let mut rng = Rng::new(16);
        for (w, h) in [(4usize, 6usize), (6, 4), (8, 8), (1, 5), (3, 1)] {
            for _ in 0..50 {
                let err: Vec<f64> = (0..w * h).map(|_| rng.next_f64()).collect();
                let (path, cost) = min_cut_vertical(&err, w, h);
                let brute = brute_vertical(&err, w, h);
                assert!((cost - brute).abs() < 1e-12, "vertical {w}x{h}: {cost} vs {brute}");
                assert!((path_cost_vertical(&err, w, &path) - cost).abs() < 1e-12);
                for r in 1..h {
                    assert!(path[r].abs_diff(path[r - 1]) <= 1, "path not 8-connected: {path:?}");
                }
                // Horizontal = vertical on the transpose.
                let (hpath, hcost) = min_cut_horizontal(&err, w, h);
                let mut t = vec![0.0; w * h];
                for y in 0..h {
                    for x in 0..w {
                        t[x * h + y] = err[y * w + x];
                    }
                }
                assert!((hcost - brute_vertical(&t, h, w)).abs() < 1e-12);
                let hsum: f64 = hpath.iter().enumerate().map(|(x, &y)| err[y * w + x]).sum();
                assert!((hsum - hcost).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn cut_follows_a_zero_error_valley() {
        // A zero column at x = 2 in a 5-wide strip: the cut must run straight down it.
        let (w, h) = (5, 7);
        let err: Vec<f64> = (0..w * h).map(|i| if i % w == 2 { 0.0 } else { 1.0 }).collect();
        let (path, cost) = min_cut_vertical(&err, w, h);
        assert_eq!(path, vec![2; h]);
        assert_eq!(cost, 0.0);
    }

    #[test]
    fn l_shaped_region_is_the_intersection() {
        // Clean valleys (unique minima): column 1 and row 2.
        let (bw, bh) = (6, 6);
        let err = |x: usize, y: usize| {
            if x == 1 && y >= 2 || y == 2 && x >= 1 {
                0.0
            } else {
                1.0 + 0.01 * (x + 3 * y) as f64
            }
        };
        let new = new_region(bw, bh, [3, 0, 0, 0], err);
        for y in 0..bh {
            let first_new = (0..bw).find(|&x| new[y * bw + x]).unwrap();
            assert!((first_new..bw).all(|x| new[y * bw + x]), "row {y} is old then new");
        }
        assert!((2..bh).all(|y| !new[y * bw] && new[y * bw + 1]), "cut follows the column-1 valley");
        // On random errors every side's half-plane comes from its own DP path, and the block's new
        // region is their intersection.
        let mut rng = Rng::new(3);
        let e: Vec<f64> = (0..bw * bh).map(|_| rng.next_f64()).collect();
        let err = |x: usize, y: usize| e[y * bw + x];
        let strip = |x0: usize, w: usize, y0: usize, h: usize| -> Vec<f64> {
            (y0..y0 + h).flat_map(|y| (x0..x0 + w).map(move |x| (x, y))).map(|(x, y)| err(x, y)).collect()
        };
        let (left, _) = min_cut_vertical(&strip(0, 2, 0, bh), 2, bh);
        let (top, _) = min_cut_horizontal(&strip(0, bw, 0, 3), bw, 3);
        let (right, _) = min_cut_vertical(&strip(4, 2, 0, bh), 2, bh);
        let (bottom, _) = min_cut_horizontal(&strip(0, bw, 3, 3), bw, 3);
        for (sides, name) in [([2, 3, 0, 0], "L"), ([2, 3, 2, 3], "torus corner")] {
            let new = new_region(bw, bh, sides, err);
            for y in 0..bh {
                for x in 0..bw {
                    let mut want = x >= left[y] && y >= top[x];
                    if sides[2] > 0 {
                        want &= x <= 4 + right[y] && y <= 3 + bottom[x];
                    }
                    assert_eq!(new[y * bw + x], want, "{name} ({x},{y})");
                }
            }
        }
    }
}
