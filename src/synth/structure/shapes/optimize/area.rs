//! The area check of stage 2: region sizes pulled back towards their stage-1 areas, so that
//! shape correction does not spoil the region-size distribution ([references: frasson §3.5.4]: regions are
//! "never scaled, because size can be an important feature"; tessera's completion of the
//! distribution check, V15).
//!
//! For a region of signed area `A` and target `A₀`, the gradient of `A` with respect to its
//! vertex `v_k` is `g_k = ½ (y_{k+1} − y_{k−1}, x_{k−1} − x_{k+1})`. Moving the vertices by
//! `λ g_k` with `λ = (A₀ − A) / Σ|g_k|²` restores the area to first order; the pulls use
//! `step · λ g_k`, with the gradient restricted to what each vertex may do (nothing for a
//! locked vertex, its side for a sliding one), and each vertex sums the pulls of its regions.

use super::moves::Freedom;
use super::state::State;
use crate::synth::structure::mesh::faces::signed_area;
use crate::synth::structure::types::Point;

/// The signed areas of the regions.
pub(super) fn region_areas(verts: &[Point], regions: &[Vec<usize>]) -> Vec<f64> {
    regions.iter().map(|c| signed_area(&c.iter().map(|&v| verts[v]).collect::<Vec<_>>())).collect()
}

/// The area-restoring displacements of every vertex (see the module documentation), for
/// the regions with a finite target.
pub(super) fn area_pulls(st: &State, targets: &[f64], step: f64) -> Vec<Point> {
    let nv = st.verts.len();
    let mut pull = vec![[0.0f64; 2]; nv];
    if step.is_nan() || step <= 0.0 {
        return pull;
    }
    let mut grads: Vec<Point> = Vec::new();
    for (r, c) in st.regions.iter().enumerate() {
        let Some(&target) = targets.get(r) else { continue };
        let n = c.len();
        if n < 3 || !target.is_finite() {
            continue;
        }
        let poly: Vec<Point> = c.iter().map(|&v| st.verts[v]).collect();
        let a = signed_area(&poly);
        if !a.is_finite() || a == target {
            continue;
        }
        grads.clear();
        let mut norm = 0.0;
        for k in 0..n {
            let (p, q) = (poly[(k + n - 1) % n], poly[(k + 1) % n]);
            let mut g = [0.5 * (q[1] - p[1]), 0.5 * (p[0] - q[0])];
            match st.freedom[c[k]] {
                Freedom::Free => {}
                Freedom::Slide { axis, .. } => g[1 - axis] = 0.0,
                Freedom::Locked => g = [0.0, 0.0],
            }
            norm += g[0] * g[0] + g[1] * g[1];
            grads.push(g);
        }
        if norm.is_nan() || norm <= 0.0 {
            continue;
        }
        let lambda = step * (target - a) / norm;
        for (k, g) in grads.iter().enumerate() {
            pull[c[k]][0] += lambda * g[0];
            pull[c[k]][1] += lambda * g[1];
        }
    }
    pull
}
