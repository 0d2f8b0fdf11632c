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

/// The level histograms of an image: [`pyramid_feature_distance`] of two features is
/// [`pyramid_distance`] of their images, so a catalogue histograms each render once.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PyramidFeature {
    pub params: PyramidParams,
    /// One normalised histogram per level with both sides at least `min_side`, finest first.
    pub levels: Vec<Vec<f64>>,
}

/// The feature of `img` (see the module documentation).
pub fn pyramid_feature(img: &Image, params: &PyramidParams) -> PyramidFeature {
    let levels = laplacian_pyramid(&luma(img), img.width, img.height)
        .iter()
        .take_while(|l| l.width >= params.min_side && l.height >= params.min_side)
        .map(|l| level_histogram(l, params))
        .collect();
    PyramidFeature { params: *params, levels }
}

/// The distance of two features in `[0, 1]` over their common levels (0 when they share none);
/// `None` when they were histogrammed with different options.
pub fn pyramid_feature_distance(a: &PyramidFeature, b: &PyramidFeature) -> Option<f64> {
    if a.params != b.params {
        return None;
    }
    let n = a.levels.len().min(b.levels.len());
    if n == 0 {
        return Some(0.0);
    }
    let sum: f64 =
        a.levels.iter().zip(&b.levels).map(|(x, y)| x.iter().zip(y).map(|(p, q)| (p - q).abs()).sum::<f64>()).sum();
    Some(0.5 * sum / n as f64)
}

/// Laplacian-pyramid histogram distance in `[0, 1]` (see the module documentation).
pub fn pyramid_distance(a: &Image, b: &Image, params: &PyramidParams) -> f64 {
    pyramid_feature_distance(&pyramid_feature(a, params), &pyramid_feature(b, params)).expect("same options")
}
