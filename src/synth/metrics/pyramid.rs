//! Laplacian-pyramid histogram distance ([references: bourque §4.5], Eq. 4.11, with
//! tessera's choices).
//!
//! Box pyramid as the thesis describes it: each coarser level averages 2 × 2 blocks (a
//! last odd row or column averages what exists), down to 1 × 1; the Laplacian level is
//! `L_i = G_i − replicate(G_{i+1})` and the top level is the 1 × 1 mean, so replicating and
//! adding back reconstructs the image exactly. Each level with both sides ≥ `min_side`
//! contributes a `bins`-bin histogram of its values over `[−range, range]` (ends clamped),
//! normalised to sum 1; `D = ½ Σ_i w_i ‖h_i(a) − h_i(b)‖₁` with uniform weights `w_i`
//! summing to 1, so `D ∈ [0, 1]` (S_L = 1 − D is the similarity). Levels are matched from
//! the finest, so images of different sizes compare their common number of levels. With
//! `magnitude`, levels are histogrammed by `|L_i|` over `[0, range]` (the "energy" reading,
//! invariant to intensity inversion).

use serde::{Deserialize, Serialize};

use super::luma::luma;
use crate::raster::Image;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PyramidParams {
    pub bins: usize,
    pub range: f32,
    /// Levels smaller than this (either side) get weight 0.
    pub min_side: usize,
    pub magnitude: bool,
}

impl Default for PyramidParams {
    fn default() -> Self {
        PyramidParams { bins: 64, range: 0.5, min_side: 4, magnitude: false }
    }
}

/// One level of a Laplacian pyramid.
#[derive(Clone, Debug, PartialEq)]
pub struct PyramidLevel {
    pub width: usize,
    pub height: usize,
    pub data: Vec<f32>,
}

/// Box Laplacian pyramid of a plane, finest level first, ending with the 1 × 1 mean.
pub fn laplacian_pyramid(plane: &[f32], width: usize, height: usize) -> Vec<PyramidLevel> {
    let mut gauss = vec![PyramidLevel { width, height, data: plane.to_vec() }];
    while {
        let g = gauss.last().unwrap();
        g.width > 1 || g.height > 1
    } {
        let g = gauss.last().unwrap();
        let (w2, h2) = (g.width.div_ceil(2), g.height.div_ceil(2));
        let mut data = vec![0.0f32; w2 * h2];
        for y in 0..h2 {
            for x in 0..w2 {
                let (mut s, mut n) = (0.0f32, 0.0f32);
                for yy in 2 * y..(2 * y + 2).min(g.height) {
                    for xx in 2 * x..(2 * x + 2).min(g.width) {
                        s += g.data[yy * g.width + xx];
                        n += 1.0;
                    }
                }
                data[y * w2 + x] = s / n;
            }
        }
        gauss.push(PyramidLevel { width: w2, height: h2, data });
    }
    let mut lap = Vec::with_capacity(gauss.len());
    for i in 0..gauss.len() {
        let g = &gauss[i];
        if i + 1 == gauss.len() {
            lap.push(g.clone());
            continue;
        }
        let c = &gauss[i + 1];
        let data = (0..g.width * g.height)
            .map(|p| {
                let (x, y) = (p % g.width, p / g.width);
                g.data[p] - c.data[(y / 2) * c.width + x / 2]
            })
            .collect();
        lap.push(PyramidLevel { width: g.width, height: g.height, data });
    }
    lap
}

/// Rebuilds the finest level from a Laplacian pyramid (replicate and add, coarse to fine).
pub fn reconstruct(levels: &[PyramidLevel]) -> Vec<f32> {
    let mut cur = levels.last().map(|l| l.data.clone()).unwrap_or_default();
    for i in (0..levels.len().saturating_sub(1)).rev() {
        let (l, c) = (&levels[i], &levels[i + 1]);
        cur = (0..l.width * l.height)
            .map(|p| {
                let (x, y) = (p % l.width, p / l.width);
                l.data[p] + cur[(y / 2) * c.width + x / 2]
            })
            .collect();
    }
    cur
}

fn level_histogram(l: &PyramidLevel, params: &PyramidParams) -> Vec<f64> {
    let b = params.bins.max(1);
    let mut h = vec![0.0f64; b];
    let inc = 1.0 / l.data.len() as f64;
    for &v in &l.data {
        let t = if params.magnitude { v.abs() / params.range } else { (v + params.range) / (2.0 * params.range) };
        let i = ((t.clamp(0.0, 1.0) * b as f32) as usize).min(b - 1);
        h[i] += inc;
    }
    h
}

/// Laplacian-pyramid histogram distance in `[0, 1]` (see the module documentation).
pub fn pyramid_distance(a: &Image, b: &Image, params: &PyramidParams) -> f64 {
    let pa = laplacian_pyramid(&luma(a), a.width, a.height);
    let pb = laplacian_pyramid(&luma(b), b.width, b.height);
    let mut ds = Vec::new();
    for (la, lb) in pa.iter().zip(&pb) {
        let ok = |l: &PyramidLevel| l.width >= params.min_side && l.height >= params.min_side;
        if !ok(la) || !ok(lb) {
            break;
        }
        let (ha, hb) = (level_histogram(la, params), level_histogram(lb, params));
        ds.push(ha.iter().zip(&hb).map(|(x, y)| (x - y).abs()).sum::<f64>());
    }
    if ds.is_empty() {
        return 0.0;
    }
    0.5 * ds.iter().sum::<f64>() / ds.len() as f64
}
