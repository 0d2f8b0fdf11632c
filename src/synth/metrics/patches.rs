//! Bidirectional patch similarity (Simakov et al. 2008 style): *coherence* is the mean
//! distance from each output patch to its nearest sample patch (does everything in the
//! output come from the sample?), *completeness* the mean distance from each sample patch to
//! its nearest output patch (is everything in the sample represented?).
//!
//! Patches are `size × size` over all channels (luma when the channel counts differ), fully
//! inside the image (no wrap). The patch distance is the RMS difference over the patch's
//! values, in image units. Query patches sit on a grid of step `stride`; candidate patches
//! are all positions (step 1).
//!
//! Nearest neighbours are found by PatchMatch (Barnes et al. 2009): initialisation at the
//! proportionally scaled position (the identity for equal sizes, so identical images score
//! exactly 0), then `iterations` rounds of propagation and random search. To be parallel
//! and still deterministic, grid rows are processed concurrently: horizontal propagation runs
//! within the row in scan order (alternating direction per round), vertical candidates come
//! from the previous round at row offsets 1, 4 and 16 (fast vertical spread), and random
//! search draws from a generator seeded per (round, row, column). The search is approximate;
//! with the defaults it finds exact matches wherever they exist over all but a few patches
//! (e.g. an output cropped from the sample scores ≈ 0).

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::luma::luma;
use crate::raster::Image;
use crate::synth::rng::Rng;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PatchParams {
    /// Patch side in pixels (clamped to the smaller image's sides).
    pub size: usize,
    /// Step of the query grid.
    pub stride: usize,
    /// PatchMatch rounds.
    pub iterations: usize,
    pub seed: u64,
}

impl Default for PatchParams {
    fn default() -> Self {
        PatchParams { size: 7, stride: 2, iterations: 6, seed: 0x5eed }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PatchSimilarity {
    pub coherence: f64,
    pub completeness: f64,
}

/// Both directions of [`nearest_patch_distance`].
pub fn patch_similarity(output: &Image, sample: &Image, params: &PatchParams) -> PatchSimilarity {
    PatchSimilarity {
        coherence: nearest_patch_distance(output, sample, params),
        completeness: nearest_patch_distance(sample, output, params),
    }
}

/// Pixel-interleaved copy (`[y][x][c]`) so a patch row is one contiguous slice.
struct Interleaved {
    w: usize,
    h: usize,
    c: usize,
    data: Vec<f32>,
}

impl Interleaved {
    fn new(img: &Image, use_luma: bool) -> Interleaved {
        let (w, h) = (img.width, img.height);
        if use_luma {
            return Interleaved { w, h, c: 1, data: luma(img) };
        }
        let c = img.channels;
        let mut data = vec![0.0f32; w * h * c];
        for ch in 0..c {
            for (i, &v) in img.plane(ch).iter().enumerate() {
                data[i * c + ch] = v;
            }
        }
        Interleaved { w, h, c, data }
    }

    #[inline]
    fn row(&self, x: usize, y: usize, len: usize) -> &[f32] {
        let s = (y * self.w + x) * self.c;
        &self.data[s..s + len]
    }
}

/// Sum of squared differences of two patches, stopping early once above `bound`.
#[inline]
fn ssd(
    q: &Interleaved,
    (qx, qy): (usize, usize),
    r: &Interleaved,
    (rx, ry): (usize, usize),
    p: usize,
    bound: f32,
) -> f32 {
    let len = p * q.c;
    let mut s = 0.0f32;
    for dy in 0..p {
        let (a, b) = (q.row(qx, qy + dy, len), r.row(rx, ry + dy, len));
        let mut t = 0.0f32;
        for i in 0..len {
            let d = a[i] - b[i];
            t += d * d;
        }
        s += t;
        if s > bound {
            return s;
        }
    }
    s
}

/// Mean over `query`'s patch grid of the RMS distance to the nearest `reference` patch.
pub fn nearest_patch_distance(query: &Image, reference: &Image, params: &PatchParams) -> f64 {
    let use_luma = query.channels != reference.channels;
    let q = Interleaved::new(query, use_luma);
    let r = Interleaved::new(reference, use_luma);
    let p = params.size.min(q.w).min(q.h).min(r.w).min(r.h);
    if p == 0 || q.c == 0 {
        return 0.0;
    }
    let stride = params.stride.max(1);
    let qxs: Vec<usize> = (0..=q.w - p).step_by(stride).collect();
    let qys: Vec<usize> = (0..=q.h - p).step_by(stride).collect();
    let (gx, gy) = (qxs.len(), qys.len());
    let (rmx, rmy) = ((r.w - p) as i64, (r.h - p) as i64);
    let scale = |v: usize, qmax: usize, rmax: i64| {
        if qmax == 0 {
            0
        } else {
            ((v as f64 * rmax as f64 / qmax as f64).round() as i64).clamp(0, rmax)
        }
    };
    // Initial field: the proportionally scaled position.
    let mut field: Vec<(i64, i64, f32)> = Vec::with_capacity(gx * gy);
    for &qy in &qys {
        for &qx in &qxs {
            let (rx, ry) = (scale(qx, q.w - p, rmx), scale(qy, q.h - p, rmy));
            let d = ssd(&q, (qx, qy), &r, (rx as usize, ry as usize), p, f32::INFINITY);
            field.push((rx, ry, d));
        }
    }
    let radius0 = r.w.max(r.h) as f64;
    for round in 0..params.iterations {
        let prev = field.clone();
        let forward = round % 2 == 0;
        let rows: Vec<Vec<(i64, i64, f32)>> = (0..gy)
            .into_par_iter()
            .map(|j| {
                let mut cur: Vec<(i64, i64, f32)> = prev[j * gx..(j + 1) * gx].to_vec();
                let qy = qys[j];
                let order: Vec<usize> = if forward { (0..gx).collect() } else { (0..gx).rev().collect() };
                for (k, &i) in order.iter().enumerate() {
                    let qx = qxs[i];
                    let (mut bx, mut by, mut bd) = cur[i];
                    let try_cand = |cx: i64, cy: i64, bx: &mut i64, by: &mut i64, bd: &mut f32| {
                        let (cx, cy) = (cx.clamp(0, rmx), cy.clamp(0, rmy));
                        if cx == *bx && cy == *by {
                            return;
                        }
                        let d = ssd(&q, (qx, qy), &r, (cx as usize, cy as usize), p, *bd);
                        if d < *bd {
                            (*bx, *by, *bd) = (cx, cy, d);
                        }
                    };
                    // Horizontal propagation from the neighbour processed just before.
                    if k > 0 {
                        let n = order[k - 1];
                        let shift = (qxs[i] as i64) - (qxs[n] as i64);
                        try_cand(cur[n].0 + shift, cur[n].1, &mut bx, &mut by, &mut bd);
                    }
                    // Vertical propagation from the previous round.
                    for d in [1usize, 4, 16] {
                        if j >= d {
                            let (nx, ny, _) = prev[(j - d) * gx + i];
                            try_cand(nx, ny + (qy - qys[j - d]) as i64, &mut bx, &mut by, &mut bd);
                        }
                        if j + d < gy {
                            let (nx, ny, _) = prev[(j + d) * gx + i];
                            try_cand(nx, ny - (qys[j + d] - qy) as i64, &mut bx, &mut by, &mut bd);
                        }
                    }
                    // Random search around the best, halving the radius.
                    let mix = params.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15)
                        ^ ((round as u64) << 56)
                        ^ ((j as u64) << 28)
                        ^ i as u64;
                    let mut rng = Rng::new(mix);
                    let mut radius = radius0;
                    while radius >= 1.0 {
                        let ox = ((rng.next_f64() * 2.0 - 1.0) * radius).round() as i64;
                        let oy = ((rng.next_f64() * 2.0 - 1.0) * radius).round() as i64;
                        try_cand(bx + ox, by + oy, &mut bx, &mut by, &mut bd);
                        radius *= 0.5;
                    }
                    cur[i] = (bx, by, bd);
                }
                cur
            })
            .collect();
        field = rows.concat();
    }
    let n_el = (p * p * q.c) as f64;
    field.iter().map(|&(_, _, d)| (d.max(0.0) as f64 / n_el).sqrt()).sum::<f64>() / field.len() as f64
}
