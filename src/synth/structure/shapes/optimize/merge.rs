//! Tidying the optimised mesh: short edges merged (keeping fixed and border vertices where they
//! must be) and straight valency-2 vertices removed.

use super::moves::{distinct, edges_conflict, star_valid, Freedom};
use super::state::{mesh_edges, State};
use crate::synth::structure::mesh::faces::signed_area;
use crate::synth::structure::types::{Mesh, Point};

/// Which side(s) of the domain a vertex lies on: bit 0 `x = 0`, 1 `x = w`, 2 `y = 0`,
/// 3 `y = h`.
pub(super) fn sides(p: Point, domain: [f64; 2], eps: f64) -> u8 {
    let mut s = 0;
    if p[0].abs() <= eps {
        s |= 1;
    }
    if (p[0] - domain[0]).abs() <= eps {
        s |= 2;
    }
    if p[1].abs() <= eps {
        s |= 4;
    }
    if (p[1] - domain[1]).abs() <= eps {
        s |= 8;
    }
    s
}

/// Collapses edges shorter than `min_edge`, shortest first (ties: lower indices), until none
/// can be collapsed. Returns the merges `(removed, kept)` in order.
pub(super) fn merge_short_edges(
    st: &mut State,
    fixed: &mut [bool],
    border: &mut [bool],
    min_edge: f64,
) -> Vec<(usize, usize)> {
    let nv = st.verts.len();
    let mut pairs = Vec::new();
    if min_edge.is_nan() || min_edge <= 0.0 {
        return pairs;
    }
    let len = |v: &[Point], a: usize, b: usize| ((v[b][0] - v[a][0]).powi(2) + (v[b][1] - v[a][1]).powi(2)).sqrt();
    loop {
        let mut short: Vec<(f64, [usize; 2])> = mesh_edges(&st.regions)
            .into_iter()
            .map(|[a, b]| (len(&st.verts, a, b), [a, b]))
            .filter(|(l, _)| *l < min_edge)
            .collect();
        short.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let mut done = false;
        let mut touched = vec![false; nv];
        for (_, [a, b]) in short {
            if touched[a] || touched[b] {
                continue;
            }
            if try_merge(st, fixed, border, a, b) {
                pairs.push((b, a));
            } else if try_merge(st, fixed, border, b, a) {
                pairs.push((a, b));
            } else {
                continue;
            }
            touched[a] = true;
            touched[b] = true;
            done = true;
        }
        if !done {
            break;
        }
    }
    pairs
}

/// Merges `b` into `keep` if allowed and valid; see the module documentation.
pub(super) fn try_merge(st: &mut State, fixed: &mut [bool], border: &mut [bool], keep: usize, b: usize) -> bool {
    let (pk, pb) = (st.verts[keep], st.verts[b]);
    // The merged position.
    let p = match (fixed[keep], fixed[b]) {
        (true, true) => return false,
        (true, false) => pk,
        (false, true) => return false, // tried the other way round
        (false, false) => match (border[keep], border[b]) {
            (false, false) => [(pk[0] + pb[0]) / 2.0, (pk[1] + pb[1]) / 2.0],
            (true, false) => pk,
            (false, true) => return false,
            (true, true) => {
                let (sk, sb) = (sides(pk, st.domain, st.eps), sides(pb, st.domain, st.eps));
                if sk.count_ones() >= 2 || sb == 0 {
                    // `keep` is a corner (or `b` is a border vertex on no side): stay at `keep`.
                    pk
                } else if sb.count_ones() >= 2 {
                    return false;
                } else if sk == sb {
                    let mut m = [(pk[0] + pb[0]) / 2.0, (pk[1] + pb[1]) / 2.0];
                    // Stay exactly on the side.
                    if sk & 1 != 0 {
                        m[0] = 0.0;
                    }
                    if sk & 2 != 0 {
                        m[0] = st.domain[0];
                    }
                    if sk & 4 != 0 {
                        m[1] = 0.0;
                    }
                    if sk & 8 != 0 {
                        m[1] = st.domain[1];
                    }
                    m
                } else {
                    return false;
                }
            }
        },
    };
    // Trial cycles of the regions containing `keep` or `b`.
    let mut rids: Vec<usize> = st.incidence[keep].iter().chain(&st.incidence[b]).map(|&(r, _)| r).collect();
    rids.sort_unstable();
    rids.dedup();
    let mut trial: Vec<Vec<usize>> = Vec::with_capacity(rids.len());
    for &r in &rids {
        let mut c: Vec<usize> = Vec::with_capacity(st.regions[r].len());
        for &v in &st.regions[r] {
            let v = if v == b { keep } else { v };
            if c.last() != Some(&v) {
                c.push(v);
            }
        }
        while c.len() > 1 && c.first() == c.last() {
            c.pop();
        }
        if c.len() < 3 || !distinct(&c) {
            return false;
        }
        trial.push(c);
    }
    let verts = &st.verts;
    let pos = |i: usize| if i == keep { p } else { verts[i] };
    let cycles: Vec<&[usize]> = trial.iter().map(|c| c.as_slice()).collect();
    if !star_valid(&pos, &cycles, keep, st.eps) {
        return false;
    }
    // Commit.
    st.verts[keep] = p;
    for (&r, c) in rids.iter().zip(trial) {
        st.regions[r] = c;
    }
    rebuild_incidence(st, &rids, &[b]);
    fixed[keep] |= fixed[b];
    border[keep] |= border[b];
    st.freedom[b] = Freedom::Locked;
    true
}

/// Drops merged vertices and renumbers; returns the mesh, the input → output vertex map and
/// the flags of the output vertices.
pub(super) fn compact(
    st: &State,
    merged: &[Option<usize>],
    dropped: &[bool],
    fixed: &[bool],
    border: &[bool],
) -> (Mesh, Vec<Option<usize>>, Vec<bool>, Vec<bool>) {
    let nv = st.verts.len();
    let mut new_id = vec![None; nv];
    let mut vertices = Vec::new();
    let (mut f, mut b) = (Vec::new(), Vec::new());
    for v in 0..nv {
        if merged[v].is_none() && !dropped[v] {
            new_id[v] = Some(vertices.len());
            vertices.push(st.verts[v]);
            f.push(fixed[v]);
            b.push(border[v]);
        }
    }
    let map: Vec<Option<usize>> = (0..nv).map(|v| new_id[merged[v].unwrap_or(v)]).collect();
    let regions =
        st.regions.iter().map(|c| c.iter().map(|&v| map[v].expect("cycle vertices are kept")).collect()).collect();
    (Mesh { vertices, regions }, map, f, b)
}

/// Rebuilds the incidence lists of the vertices of regions `rids` (and of `extra`) after
/// their cycles changed.
pub(super) fn rebuild_incidence(st: &mut State, rids: &[usize], extra: &[usize]) {
    let mut touched: Vec<usize> = rids.iter().flat_map(|&r| st.regions[r].iter().copied()).collect();
    touched.extend_from_slice(extra);
    touched.sort_unstable();
    touched.dedup();
    for &v in &touched {
        st.incidence[v].retain(|&(r, _)| !rids.contains(&r));
    }
    for &r in rids {
        for (k, &v) in st.regions[r].iter().enumerate() {
            st.incidence[v].push((r, k));
        }
    }
    for &v in &touched {
        st.incidence[v].sort_unstable();
    }
}

/// Removes valency-2 vertices (not fixed) whose turn is below `straight` radians, when the
/// result stays valid (polygonisation's `straight` rule: stage 2 lines vertices up along
/// the originals' sides). Returns the removed vertices.
pub(super) fn drop_straight(st: &mut State, fixed: &[bool], straight: f64) -> Vec<bool> {
    let nv = st.verts.len();
    let mut dropped = vec![false; nv];
    if straight.is_nan() || straight <= 0.0 {
        return dropped;
    }
    loop {
        let mut any = false;
        for v in 0..nv {
            if dropped[v] || fixed[v] || st.incidence[v].is_empty() {
                continue;
            }
            // The neighbours of v over all its regions.
            let mut nb: Vec<usize> = Vec::with_capacity(4);
            for &(r, k) in &st.incidence[v] {
                let c = &st.regions[r];
                let n = c.len();
                for u in [c[(k + n - 1) % n], c[(k + 1) % n]] {
                    if !nb.contains(&u) {
                        nb.push(u);
                    }
                }
            }
            if nb.len() != 2 {
                continue;
            }
            let (a, b) = (nb[0], nb[1]);
            if crate::synth::structure::analysis::stats::turn_angle(st.verts[a], st.verts[v], st.verts[b]).abs()
                >= straight
            {
                continue;
            }
            let rids: Vec<usize> = st.incidence[v].iter().map(|&(r, _)| r).collect();
            let trial: Vec<Vec<usize>> =
                rids.iter().map(|&r| st.regions[r].iter().copied().filter(|&u| u != v).collect()).collect();
            if trial.iter().any(|c| c.len() < 3) {
                continue;
            }
            // The new edge (a, b) against every edge of the regions around a and b.
            let mut around: Vec<usize> =
                st.incidence[a].iter().chain(&st.incidence[b]).map(|&(r, _)| r).filter(|r| !rids.contains(r)).collect();
            around.sort_unstable();
            around.dedup();
            let verts = &st.verts;
            let pos = |i: usize| verts[i];
            let mut cycles: Vec<&[usize]> = trial.iter().map(|c| c.as_slice()).collect();
            cycles.extend(around.iter().map(|&r| st.regions[r].as_slice()));
            let ok = trial.iter().all(|c| signed_area(&c.iter().map(|&i| verts[i]).collect::<Vec<_>>()) > 0.0)
                && cycles.iter().all(|c| {
                    let n = c.len();
                    (0..n).all(|k| !edges_conflict(&pos, a, b, c[k], c[(k + 1) % n], st.eps))
                });
            if !ok {
                continue;
            }
            for (&r, c) in rids.iter().zip(trial) {
                st.regions[r] = c;
            }
            rebuild_incidence(st, &rids, &[v]);
            dropped[v] = true;
            any = true;
        }
        if !any {
            return dropped;
        }
    }
}
