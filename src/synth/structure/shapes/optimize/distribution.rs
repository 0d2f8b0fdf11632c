//! The distribution check: the structure's edges (chains between junctions) compared with the
//! originals' edge-length percentiles, and the pulls that bring outliers back into range.

use std::collections::HashSet;

use super::moves::Freedom;
use super::state::{mesh_edges, State};
use crate::synth::structure::analysis::stats::percentile;
use crate::synth::structure::types::Point;

/// `[P_lo, P_hi]` of the original edge lengths (edges shared by two originals counted once).
pub(super) fn edge_length_range(originals: &[Vec<Point>], q: [f64; 2]) -> Option<[f64; 2]> {
    let mut seen: HashSet<[u64; 4]> = HashSet::new();
    let mut lengths = Vec::new();
    for poly in originals {
        let n = poly.len();
        for k in 0..n {
            let (a, b) = (poly[k], poly[(k + 1) % n]);
            let (ka, kb) = ([a[0].to_bits(), a[1].to_bits()], [b[0].to_bits(), b[1].to_bits()]);
            let key = if ka <= kb { [ka[0], ka[1], kb[0], kb[1]] } else { [kb[0], kb[1], ka[0], ka[1]] };
            if seen.insert(key) {
                let l = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
                if l > 0.0 && l.is_finite() {
                    lengths.push(l);
                }
            }
        }
    }
    if lengths.is_empty() {
        return None;
    }
    lengths.sort_by(f64::total_cmp);
    Some([percentile(&lengths, q[0]), percentile(&lengths, q[1])])
}

/// The structure's edges: maximal paths of the mesh graph whose inner vertices have exactly
/// two neighbours and are not pinned, from junction to junction (polygonisation leaves such
/// valency-2 vertices along the boundary between two regions). Closed loops without a
/// junction are skipped. Each chain is listed once, from its smaller end.
pub(super) fn chains(regions: &[Vec<usize>], nv: usize, pinned: &[bool]) -> Vec<Vec<usize>> {
    let mut nbrs: Vec<Vec<usize>> = vec![Vec::new(); nv];
    for [a, b] in mesh_edges(regions) {
        nbrs[a].push(b);
        nbrs[b].push(a);
    }
    let junction = |v: usize| nbrs[v].len() != 2 || pinned[v];
    let mut out = Vec::new();
    for a in 0..nv {
        if nbrs[a].is_empty() || !junction(a) {
            continue;
        }
        for &first in &nbrs[a] {
            let mut path = vec![a, first];
            let (mut prev, mut cur) = (a, first);
            while !junction(cur) {
                let next = if nbrs[cur][0] == prev { nbrs[cur][1] } else { nbrs[cur][0] };
                prev = cur;
                cur = next;
                path.push(cur);
                if path.len() > nv + 1 {
                    break;
                }
            }
            let last = *path.last().expect("non-empty");
            // List each chain once: from its smaller end (ties: smaller second vertex).
            let second_last = path[path.len() - 2];
            if (a, first) < (last, second_last) {
                out.push(path);
            }
        }
    }
    out
}

/// The distribution-check displacements: every chain with both ends not pinned, or one,
/// whose chord length lies outside `[lo, hi]` has its ends pulled along the chord towards
/// the nearest bound by `step` times the length error (half each, or all of it on the only
/// movable end); the inner vertices follow by linear interpolation along the chain's arc
/// length. Returns the displacements and the number of chains corrected.
pub(super) fn distribution_pulls(st: &State, pinned: &[bool], range: [f64; 2], step: f64) -> (Vec<Point>, usize) {
    let nv = st.verts.len();
    let mut pull = vec![[0.0f64; 2]; nv];
    let mut n = 0;
    for path in chains(&st.regions, nv, pinned) {
        let (a, b) = (path[0], *path.last().expect("non-empty"));
        if a == b || (pinned[a] && pinned[b]) {
            continue;
        }
        let (pa, pb) = (st.verts[a], st.verts[b]);
        let (dx, dy) = (pb[0] - pa[0], pb[1] - pa[1]);
        let len = (dx * dx + dy * dy).sqrt();
        if len.is_nan() || len <= 0.0 || (len >= range[0] && len <= range[1]) {
            continue;
        }
        let goal = if len < range[0] { range[0] } else { range[1] };
        let change = step * (goal - len);
        let (ma, mb) = (st.freedom[a] != Freedom::Locked, st.freedom[b] != Freedom::Locked);
        let share = match (ma, mb) {
            (true, true) => 0.5,
            (true, false) | (false, true) => 1.0,
            (false, false) => continue,
        };
        let (ux, uy) = (dx / len, dy / len);
        let da = if ma { [-ux * change * share, -uy * change * share] } else { [0.0, 0.0] };
        let db = if mb { [ux * change * share, uy * change * share] } else { [0.0, 0.0] };
        // Arc-length fractions of the chain's vertices.
        let mut acc = vec![0.0; path.len()];
        for k in 1..path.len() {
            let (p, q) = (st.verts[path[k - 1]], st.verts[path[k]]);
            acc[k] = acc[k - 1] + ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2)).sqrt();
        }
        let total = acc[path.len() - 1];
        for (k, &v) in path.iter().enumerate() {
            let f = if total > 0.0 { acc[k] / total } else { k as f64 / (path.len() - 1) as f64 };
            if st.freedom[v] == Freedom::Locked {
                continue;
            }
            pull[v][0] += (1.0 - f) * da[0] + f * db[0];
            pull[v][1] += (1.0 - f) * da[1] + f * db[1];
        }
        n += 1;
    }
    (pull, n)
}
