//! S7, junctions ([references: frasson §4.2.2]): every target vertex gets a star with one
//! branch per incident edge, the atlas star whose angle tuple is nearest over all cyclic
//! shifts and mirrors (exact k-NN, `k = 5`), the candidate closest in colour to the strips
//! already placed around it, and a piecewise-affine map star vertex to star vertex (V24).
//!
//! Star convention (shared with the atlas builder): branches in increasing direction angle
//! (from +x towards +y, the raw-coordinate orientation of the mesh's regions), branch `i` of
//! direction `d_i` and length `L_i = min(branch_len, 0.45·|e_i|)`, outline
//! `tip_right_i = c + L_i·d_i − w_i·n_i`, `tip_left_i = c + L_i·d_i + w_i·n_i` (`n_i = perp(d_i)`,
//! the side facing branch `i + 1`), then `M_i` on the bisector between branches `i` and `i + 1`
//! at `w / sin(φ_i / 2)`, capped at `3w`. `w_i = w` unless the angle next to the branch is so
//! small that the tip would pass the bisector (then `w_i = L_i·tan(0.45·φ)`), which keeps every
//! star star-shaped from its centre, so its fan is a valid triangulation.

use std::collections::BTreeMap;
use std::f64::consts::{PI, TAU};

use rayon::prelude::*;

use crate::synth::appearance::color::{delta_e, mean_lab};
use crate::synth::appearance::dress::geom::{add, mul, norm, perp, sub};
use crate::synth::appearance::dress::interstices::Strip;
use crate::synth::appearance::dress::params::DressParams;
use crate::synth::appearance::types::{
    Corner, IntersticeAtlas, JunctionAtlas, Lab, Layer, Mesh, Piece, Point, TextureId,
};

/// Angles between consecutive directions (sorted ascending), summing to 2π.
pub fn gaps(directions: &[f64]) -> Vec<f64> {
    let v = directions.len();
    if v == 1 {
        return vec![TAU];
    }
    (0..v).map(|i| (directions[(i + 1) % v] - directions[i]).rem_euclid(TAU)).collect()
}

/// The star outline (`3v` points, see the module doc) and each branch's half-width.
pub fn star_outline(center: Point, directions: &[f64], lengths: &[f64], w: f64) -> (Vec<Point>, Vec<f64>) {
    let v = directions.len();
    let g = gaps(directions);
    let widths: Vec<f64> = (0..v)
        .map(|i| {
            let phi = g[i].min(g[(i + v - 1) % v]).min(PI);
            w.min(lengths[i] * (0.45 * phi).tan())
        })
        .collect();
    let mut out = Vec::with_capacity(3 * v);
    for i in 0..v {
        let d = [directions[i].cos(), directions[i].sin()];
        let n = perp(d);
        let tip = add(center, mul(d, lengths[i]));
        out.push(sub(tip, mul(n, widths[i])));
        out.push(add(tip, mul(n, widths[i])));
        let half = 0.5 * g[i];
        let r = if half.sin() > 1e-12 { (w / half.sin()).min(3.0 * w) } else { 3.0 * w };
        let b = directions[i] + half;
        out.push(add(center, [r * b.cos(), r * b.sin()]));
    }
    (out, widths)
}

/// Atlas branch shown on generated branch `j` under a variant `(shift, mirror)`.
#[inline]
pub fn atlas_branch(j: usize, v: usize, shift: usize, mirror: bool) -> usize {
    if mirror {
        (shift + v - j % v) % v
    } else {
        (j + shift) % v
    }
}

/// The variant's angle tuple: `t_j` = the atlas angle between atlas branches
/// `atlas_branch(j)` and `atlas_branch(j + 1)`.
pub fn variant_tuple(angles: &[f64], shift: usize, mirror: bool) -> Vec<f64> {
    let v = angles.len();
    (0..v).map(|j| if mirror { angles[(shift + 2 * v - j - 1) % v] } else { angles[(j + shift) % v] }).collect()
}

/// Atlas star vertex shown on generated star vertex `k` (`3j + {0: right, 1: left, 2: M}`).
#[inline]
pub fn atlas_vertex(k: usize, v: usize, shift: usize, mirror: bool) -> usize {
    let (j, kind) = (k / 3, k % 3);
    if !mirror {
        return 3 * atlas_branch(j, v, shift, false) + kind;
    }
    match kind {
        0 => 3 * atlas_branch(j, v, shift, true) + 1,
        1 => 3 * atlas_branch(j, v, shift, true),
        _ => 3 * ((shift + 2 * v - j - 1) % v) + 2,
    }
}

/// One hit of the junction search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub entry: usize,
    pub shift: usize,
    pub mirror: bool,
    pub distance: f64,
}

/// One valency's variants `(entry, shift, mirror)` and their tuples, flattened.
type Table = (Vec<(usize, usize, bool)>, Vec<f64>);

/// Exact nearest-neighbour search over the atlas's angle tuples with every cyclic shift and
/// mirror, one flat table per valency (duplicate tuples of one star stored once).
#[derive(Clone, Debug, Default)]
pub struct JunctionIndex {
    /// valency → (variants `(entry, shift, mirror)`, their tuples flattened).
    tables: BTreeMap<usize, Table>,
}

impl JunctionIndex {
    pub fn new(atlas: &JunctionAtlas) -> Self {
        let mut tables: BTreeMap<usize, Table> = BTreeMap::new();
        for (i, e) in atlas.entries.iter().enumerate() {
            let v = e.angles.len();
            if v == 0 || e.star.len() != 3 * v || e.directions.len() != v {
                continue;
            }
            let t = tables.entry(v).or_default();
            let mut seen: Vec<Vec<f64>> = Vec::new();
            for mirror in [false, true] {
                for shift in 0..v {
                    let tuple = variant_tuple(&e.angles, shift, mirror);
                    if seen.contains(&tuple) {
                        continue;
                    }
                    t.0.push((i, shift, mirror));
                    t.1.extend_from_slice(&tuple);
                    seen.push(tuple);
                }
            }
        }
        JunctionIndex { tables }
    }

    /// Valencies present.
    pub fn valencies(&self) -> Vec<usize> {
        self.tables.keys().copied().collect()
    }

    /// Number of stored tuples of valency `v`.
    pub fn len(&self, v: usize) -> usize {
        self.tables.get(&v).map_or(0, |t| t.0.len())
    }

    pub fn is_empty(&self) -> bool {
        self.tables.is_empty()
    }

    /// The present valency nearest to `v` (ties: the smaller).
    pub fn nearest_valency(&self, v: usize) -> Option<usize> {
        self.tables.keys().copied().min_by_key(|&u| (u.abs_diff(v), u))
    }

    /// The `k` nearest distinct stars of the tuple's valency, each with its best variant,
    /// sorted by (distance, entry); Euclidean distance in radians.
    pub fn query(&self, tuple: &[f64], k: usize) -> Vec<Hit> {
        let v = tuple.len();
        let Some((meta, flat)) = self.tables.get(&v) else {
            return Vec::new();
        };
        let mut best: Vec<Hit> = Vec::with_capacity(k + 1);
        let mut i = 0;
        while i < meta.len() {
            let entry = meta[i].0;
            let mut hit: Option<Hit> = None;
            while i < meta.len() && meta[i].0 == entry {
                let d2: f64 = flat[i * v..(i + 1) * v].iter().zip(tuple).map(|(a, b)| (a - b) * (a - b)).sum();
                if hit.is_none_or(|h| d2 < h.distance) {
                    hit = Some(Hit { entry, shift: meta[i].1, mirror: meta[i].2, distance: d2 });
                }
                i += 1;
            }
            let h = hit.expect("one variant");
            if best.len() < k || h.distance < best[best.len() - 1].distance {
                let at = best.partition_point(|b| b.distance <= h.distance);
                best.insert(at, h);
                best.truncate(k);
            }
        }
        for h in &mut best {
            h.distance = h.distance.sqrt();
        }
        best
    }
}

/// The colour heuristic: the candidate with minimal ΔE to `target` (first on ties); the
/// nearest when there is no target.
pub fn pick_by_colour(hits: &[Hit], atlas: &JunctionAtlas, target: Option<Lab>) -> Option<Hit> {
    let t = match target {
        Some(t) => t,
        None => return hits.first().copied(),
    };
    let mut best: Option<(f64, Hit)> = None;
    for &h in hits {
        let d = delta_e(atlas.entries[h.entry].lab, t);
        if best.is_none_or(|b| d < b.0) {
            best = Some((d, h));
        }
    }
    best.map(|b| b.1)
}

/// One target vertex dressed with an atlas star.
#[derive(Clone, Debug, PartialEq)]
pub struct Star {
    pub vertex: usize,
    pub center: Point,
    /// Branch directions, ascending, and each branch's edge (index in `mesh_edges`) and far
    /// vertex.
    pub directions: Vec<f64>,
    pub edges: Vec<usize>,
    pub others: Vec<usize>,
    pub lengths: Vec<f64>,
    pub widths: Vec<f64>,
    /// The generated outline (`3v` points) and the atlas position each shows.
    pub outline: Vec<Point>,
    pub uvs: Vec<Point>,
    pub center_uv: Point,
    pub hit: Hit,
    /// A star of another valency, mapped rigidly (the valency was missing from the atlas).
    pub fallback: bool,
}

impl Star {
    /// The star as a fan of triangles from its centre.
    pub fn piece(&self) -> Piece {
        let n = self.outline.len();
        let c = Corner { pos: self.center, uv: self.center_uv };
        let triangles = (0..n)
            .map(|k| {
                let l = (k + 1) % n;
                [c, Corner { pos: self.outline[k], uv: self.uvs[k] }, Corner { pos: self.outline[l], uv: self.uvs[l] }]
            })
            .collect();
        Piece { layer: Layer::Junction, texture: TextureId::Junctions, owner: self.vertex, triangles }
    }
}

/// Each vertex's incident edges as `(direction, edge index, other vertex)`, ascending.
pub fn incidence(mesh: &Mesh, edges: &[[usize; 2]]) -> Vec<Vec<(f64, usize, usize)>> {
    let mut inc: Vec<Vec<(f64, usize, usize)>> = vec![Vec::new(); mesh.vertices.len()];
    for (e, &[a, b]) in edges.iter().enumerate() {
        let d = sub(mesh.vertices[b], mesh.vertices[a]);
        if norm(d) <= 1e-12 {
            continue;
        }
        inc[a].push((d[1].atan2(d[0]).rem_euclid(TAU), e, b));
        inc[b].push(((-d[1]).atan2(-d[0]).rem_euclid(TAU), e, a));
    }
    for l in &mut inc {
        l.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    }
    inc
}

/// A tuple of another valency: merge the smallest angle into its successor, or split the
/// largest in two, until it has `target` entries.
fn adjust_tuple(tuple: &[f64], target: usize) -> Vec<f64> {
    let mut t = tuple.to_vec();
    while t.len() > target && t.len() > 1 {
        let i = (0..t.len()).min_by(|&a, &b| t[a].total_cmp(&t[b])).expect("nonempty");
        let j = (i + 1) % t.len();
        t[j] += t[i];
        t.remove(i);
    }
    while t.len() < target {
        let i = (0..t.len()).max_by(|&a, &b| t[a].total_cmp(&t[b]).then(b.cmp(&a))).expect("nonempty");
        t[i] *= 0.5;
        let half = t[i];
        t.insert(i + 1, half);
    }
    t
}

/// S7: one star per vertex with at least one edge (`None` elsewhere, and for all vertices when
/// the atlas is empty), plus warnings.
pub fn junctions(
    mesh: &Mesh,
    edges: &[[usize; 2]],
    strips: &[Option<Strip>],
    interstices: &IntersticeAtlas,
    atlas: &JunctionAtlas,
    index: &JunctionIndex,
    params: &DressParams,
) -> (Vec<Option<Star>>, Vec<String>) {
    let inc = incidence(mesh, edges);
    let w = atlas.half_width;
    let mut warnings = Vec::new();
    if index.is_empty() {
        if inc.iter().any(|l| !l.is_empty()) {
            warnings.push("empty junction atlas: vertices are not dressed".to_string());
        }
        return (vec![None; mesh.vertices.len()], warnings);
    }
    let stars: Vec<Option<Star>> = inc
        .par_iter()
        .enumerate()
        .map(|(vi, branches)| {
            if branches.is_empty() {
                return None;
            }
            let v = branches.len();
            let center = mesh.vertices[vi];
            let directions: Vec<f64> = branches.iter().map(|b| b.0).collect();
            let lengths: Vec<f64> =
                branches.iter().map(|b| atlas.branch_len.min(0.45 * norm(sub(mesh.vertices[b.2], center)))).collect();
            let (outline, widths) = star_outline(center, &directions, &lengths, w);
            let tuple = gaps(&directions);
            let target: Vec<Lab> = branches
                .iter()
                .filter_map(|b| strips[b.1].as_ref().map(|s| interstices.entries[s.entry].lab))
                .collect();
            let target = (!target.is_empty()).then(|| mean_lab(target));
            let present = index.len(v) > 0;
            let query_valency = if present { v } else { index.nearest_valency(v)? };
            let query = if present { tuple.clone() } else { adjust_tuple(&tuple, query_valency) };
            let hits = index.query(&query, params.junction_k.max(1));
            let hit = pick_by_colour(&hits, atlas, target)?;
            let e = &atlas.entries[hit.entry];
            let (uvs, center_uv) = if present {
                ((0..3 * v).map(|k| e.star[atlas_vertex(k, v, hit.shift, hit.mirror)]).collect(), e.center)
            } else {
                // Rigid map: generated branch 0 onto the atlas branch its query slot shows.
                let ab = atlas_branch(0, query_valency, hit.shift, hit.mirror);
                let (tg, ta) = (directions[0], e.directions[ab]);
                let f = if hit.mirror { -1.0 } else { 1.0 };
                let map = |p: Point| -> Point {
                    let r = sub(p, center);
                    let (c0, s0) = ((-tg).cos(), (-tg).sin());
                    let a = [c0 * r[0] - s0 * r[1], f * (s0 * r[0] + c0 * r[1])];
                    let (c1, s1) = (ta.cos(), ta.sin());
                    add(e.center, [c1 * a[0] - s1 * a[1], s1 * a[0] + c1 * a[1]])
                };
                (outline.iter().map(|&p| map(p)).collect(), e.center)
            };
            Some(Star {
                vertex: vi,
                center,
                directions,
                edges: branches.iter().map(|b| b.1).collect(),
                others: branches.iter().map(|b| b.2).collect(),
                lengths,
                widths,
                outline,
                uvs,
                center_uv,
                hit,
                fallback: !present,
            })
        })
        .collect();
    let mut missing: BTreeMap<usize, usize> = BTreeMap::new();
    for s in stars.iter().flatten().filter(|s| s.fallback) {
        *missing.entry(s.directions.len()).or_default() += 1;
    }
    for (v, n) in missing {
        let u = index.nearest_valency(v).unwrap_or(0);
        warnings.push(format!("{n} vertices of valency {v}: no atlas star of that valency, used valency {u}"));
    }
    (stars, warnings)
}
