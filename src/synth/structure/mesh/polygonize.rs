//! Watertight polygonisation of a label raster (digest 004 §2.8, "Stage 1 → mesh"; F13).
//!
//! 1. **Cleanup.** Each label is reduced to one 4-connected component: smaller components are
//!    given to the neighbouring label sharing the most pixel edges with them (`NO_REGION` if
//!    none). Flooding output is 8-connected, so this only moves the odd pixel that hangs on a
//!    diagonal contact; argmin output can lose whole fragments.
//! 2. **Crack graph.** Edges run along pixel borders between different labels, where at least
//!    one side is a region; "outside the raster" (`OUT`) and "forbidden" (`NO_REGION`) count as
//!    labels. Vertices are pixel corners at integer coordinates (pixel `(i, j)` spans
//!    `[i, i+1] × [j, j+1]`).
//! 3. **Junctions** are corners of degree ≠ 2, corners where the label pair changes (e.g.
//!    2 regions + the domain border) and the raster corners. Each chain between two junctions
//!    is traced once (closed loops without a junction get an anchor vertex).
//! 4. **Region rings.** Each region's boundary is followed chain by chain with the region on
//!    the left (positive shoelace area with y down, the [`Mesh`] convention). At a corner where
//!    a region touches itself diagonally the ring hugs the pixel it came along, so a 4-connected
//!    region has a single outer ring (possibly touching itself at a vertex). Holes (enclosed regions or
//!    forbidden areas) give extra rings; they are joined to the outer ring by a *bridge*, a
//!    zero-width slit used twice by the region (counted in [`Polygonization::bridges`]).
//! 5. **Simplification.** Each chain is simplified once by Douglas–Peucker with its end
//!    vertices fixed, and both neighbouring regions use the same simplified chain, so the mesh
//!    stays watertight with no snapping. If simplified chains cross, touch or flip a ring, the
//!    chains involved are re-simplified with half the tolerance (after 3 halvings they keep
//!    every turning corner, which is the exact pixel boundary).
//! 6. **Short edges.** Edges shorter than `min_edge` are collapsed shortest first by merging
//!    their end vertices (a junction keeps its position; domain-border vertices stay on the
//!    border; raster corners never move), unless the merge would make any ring degenerate,
//!    flip or cross another edge. Merging two close junctions creates valency-4 vertices.
//! 7. **Straightening.** Chain-interior vertices turning by less than `straight_deg` are
//!    dropped (same validity guard).
//!
//! Vertices on a chain that borders `OUT` are flagged `on_domain_border`, those on a chain
//! bordering `NO_REGION` `on_occupancy_border` (stage 2 keeps them fixed).

use std::collections::HashMap;

use serde::{Deserialize, Serialize};

use crate::synth::structure::types::{Labels, Mesh, Point, NO_REGION};

/// Label of the pixels outside the raster.
const OUT: u32 = u32::MAX - 1;

#[inline]
fn is_region(l: u32) -> bool {
    l < OUT
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PolygonizeParams {
    /// Douglas–Peucker tolerance (px).
    pub tolerance: f64,
    /// Edges shorter than this are collapsed (px).
    pub min_edge: f64,
    /// Valency-2 vertices turning by less than this are dropped (degrees).
    pub straight_deg: f64,
}

impl Default for PolygonizeParams {
    fn default() -> Self {
        PolygonizeParams { tolerance: 1.0, min_edge: 2.0, straight_deg: 5.0 }
    }
}

/// The polygon mesh of a label raster.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Polygonization {
    /// One ring per region label present (ascending label order), positive shoelace area.
    pub mesh: Mesh,
    /// The label of each `mesh.regions[i]`.
    pub region_labels: Vec<u32>,
    /// Per vertex: lies on the raster border.
    pub on_domain_border: Vec<bool>,
    /// Per vertex: lies on the border of a forbidden (`NO_REGION`) area.
    pub on_occupancy_border: Vec<bool>,
    /// Number of hole bridges inserted into rings.
    pub bridges: usize,
    /// Holes that could not be bridged (their rings are missing from the mesh; 0 in practice).
    pub unbridged_holes: usize,
    /// Pixels relabelled by the connectivity cleanup.
    pub relabelled_pixels: usize,
    /// Edges shorter than `min_edge` that could not be collapsed without invalidating the mesh.
    pub short_edges_kept: usize,
}

impl Polygonization {
    /// Vertices that stage 2 must keep fixed (occupancy border) or constrain (domain border).
    pub fn fixed_vertices(&self) -> Vec<bool> {
        self.on_domain_border.iter().zip(&self.on_occupancy_border).map(|(a, b)| *a || *b).collect()
    }
}

/// Polygonises `labels` (ids must be `< u32::MAX − 1`; `NO_REGION` = no region).
pub fn polygonize(labels: &Labels, params: &PolygonizeParams) -> Polygonization {
    let (w, h) = (labels.width, labels.height);
    assert!(w > 0 && h > 0 && (w + 1) * (h + 1) < u32::MAX as usize, "raster size");
    assert!(labels.data.iter().all(|&l| l == NO_REGION || l < OUT), "label ids must be < u32::MAX - 1");
    let mut lab = labels.data.clone();
    let relabelled = single_components(&mut lab, w, h);
    let grid = CrackGrid { w, h, lab: &lab };
    let mut chains = grid.trace_chains();
    let rings = region_rings(&grid, &chains);

    // 5. Simplify with validation.
    let tol = params.tolerance.max(0.0);
    for c in chains.iter_mut() {
        c.pts = simplify_chain(&grid, &c.raw, tol);
    }
    for _round in 0..8 {
        let bad = invalid_chains(&grid, &chains, &rings);
        if bad.is_empty() {
            break;
        }
        for ci in bad {
            let c = &mut chains[ci];
            c.level += 1;
            let t = if c.level >= 4 { 0.0 } else { tol / f64::from(1u32 << c.level) };
            c.pts = simplify_chain(&grid, &c.raw, t);
        }
    }

    // Compact vertex ids, flags and positions.
    let mut vid: HashMap<u32, u32> = HashMap::new();
    let mut pos: Vec<Point> = Vec::new();
    let mut corner_id: Vec<u32> = Vec::new();
    let mut dom = Vec::new();
    let mut occ = Vec::new();
    let mut junction = Vec::new();
    let mut mchains: Vec<MChain> = Vec::with_capacity(chains.len());
    for c in &chains {
        let mut pts = Vec::with_capacity(c.pts.len());
        for (k, &corner) in c.pts.iter().enumerate() {
            let id = *vid.entry(corner).or_insert_with(|| {
                let (x, y) = grid.corner_xy(corner);
                pos.push([x as f64, y as f64]);
                corner_id.push(corner);
                dom.push(false);
                occ.push(false);
                junction.push(false);
                (pos.len() - 1) as u32
            });
            let i = id as usize;
            if c.fwd == OUT || c.bwd == OUT {
                dom[i] = true;
            }
            if c.fwd == NO_REGION || c.bwd == NO_REGION {
                occ[i] = true;
            }
            if k == 0 || k + 1 == c.pts.len() {
                junction[i] = true;
            }
            pts.push(id);
        }
        mchains.push(MChain { pts });
    }
    let fixed_corner: Vec<bool> = corner_id.iter().map(|&c| grid.is_raster_corner(c)).collect();
    let mut mesh = Editable::new(pos, mchains, rings, dom, occ, junction, fixed_corner, w as f64, h as f64);
    let short_kept = mesh.collapse_short(params.min_edge);
    mesh.straighten(params.straight_deg);
    mesh.assemble(relabelled, short_kept)
}

// ---------------------------------------------------------------------------------------------
// 1. Cleanup

/// Keeps the largest 4-connected component of every label; returns the relabelled pixel count.
///
/// 4- rather than 8-connectivity: a region joined only through a diagonal pixel contact would
/// be two faces of the planar graph although its ring is one (the Euler relation would fail).
///
/// Smaller components are merged, smallest first, into the label of the *main* component that
/// shares the most pixel edges with them (ties: lowest label). Merged pixels join that main
/// component, so a component surrounded only by other small ones is merged once a neighbour
/// has been; components that never touch a main component become `NO_REGION`.
fn single_components(lab: &mut [u32], w: usize, h: usize) -> usize {
    let n = lab.len();
    let mut comp = vec![u32::MAX; n];
    let mut comps: Vec<(u32, usize, usize)> = Vec::new(); // (label, size, first pixel)
    let mut members: Vec<Vec<usize>> = Vec::new();
    let mut stack = Vec::new();
    for s in 0..n {
        if comp[s] != u32::MAX || !is_region(lab[s]) {
            continue;
        }
        let id = comps.len() as u32;
        let l = lab[s];
        comp[s] = id;
        stack.push(s);
        let mut px = Vec::new();
        while let Some(p) = stack.pop() {
            px.push(p);
            let (x, y) = ((p % w) as i64, (p / w) as i64);
            for (dx, dy) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
                let (nx, ny) = (x + dx, y + dy);
                if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                    continue;
                }
                let q = ny as usize * w + nx as usize;
                if comp[q] == u32::MAX && lab[q] == l {
                    comp[q] = id;
                    stack.push(q);
                }
            }
        }
        comps.push((l, px.len(), s));
        members.push(px);
    }
    // The main component of each label: largest, ties by first pixel.
    let mut main: HashMap<u32, usize> = HashMap::new();
    for (i, c) in comps.iter().enumerate() {
        let e = main.entry(c.0).or_insert(i);
        let m = comps[*e];
        if c.1 > m.1 || (c.1 == m.1 && c.2 < m.2) {
            *e = i;
        }
    }
    let mut in_main = vec![false; n];
    for &m in main.values() {
        for &p in &members[m] {
            in_main[p] = true;
        }
    }
    let mut minor: Vec<usize> = (0..comps.len()).filter(|&i| main[&comps[i].0] != i).collect();
    minor.sort_by_key(|&i| (comps[i].1, comps[i].2));
    let mut total = 0;
    loop {
        let mut progress = false;
        let mut waiting = Vec::new();
        for &m in &minor {
            let mut votes: Vec<(u32, usize)> = Vec::new();
            for &p in &members[m] {
                let (x, y) = (p % w, p / w);
                let mut nb = [usize::MAX; 4];
                if x > 0 {
                    nb[0] = p - 1;
                }
                if x + 1 < w {
                    nb[1] = p + 1;
                }
                if y > 0 {
                    nb[2] = p - w;
                }
                if y + 1 < h {
                    nb[3] = p + w;
                }
                for q in nb.into_iter().filter(|&q| q != usize::MAX) {
                    if in_main[q] && comp[q] != m as u32 {
                        match votes.iter_mut().find(|v| v.0 == lab[q]) {
                            Some(v) => v.1 += 1,
                            None => votes.push((lab[q], 1)),
                        }
                    }
                }
            }
            if let Some(&(l, _)) = votes.iter().max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0))) {
                for &p in &members[m] {
                    lab[p] = l;
                    in_main[p] = true;
                }
                total += members[m].len();
                progress = true;
            } else {
                waiting.push(m);
            }
        }
        minor = waiting;
        if minor.is_empty() {
            break;
        }
        if !progress {
            // Enclosed only by forbidden / outside pixels or by each other.
            for &m in &minor {
                for &p in &members[m] {
                    lab[p] = NO_REGION;
                }
                total += members[m].len();
            }
            break;
        }
    }
    total
}

// ---------------------------------------------------------------------------------------------
// 2–4. Crack graph, chains, rings

/// Directions: 0 = E (+x), 1 = S (+y), 2 = W, 3 = N.
const DX: [i64; 4] = [1, 0, -1, 0];
const DY: [i64; 4] = [0, 1, 0, -1];

struct CrackGrid<'a> {
    w: usize,
    h: usize,
    lab: &'a [u32],
}

/// A traced chain between two junctions (`raw` corner ids), the region on its positive side
/// when walked forward (`fwd`) and on the other side (`bwd`).
struct Chain {
    raw: Vec<u32>,
    first_dir: u8,
    last_dir: u8,
    fwd: u32,
    bwd: u32,
    pts: Vec<u32>,
    level: u32,
}

/// A region ring: `(chain, reversed)` pairs.
type Ring = Vec<(usize, bool)>;

/// Rings of each region label: (label, rings); ring 0 is the outer one, then holes.
struct RegionRings {
    regions: Vec<(u32, Vec<Ring>)>,
}

impl CrackGrid<'_> {
    #[inline]
    fn pix(&self, x: i64, y: i64) -> u32 {
        if x < 0 || y < 0 || x >= self.w as i64 || y >= self.h as i64 {
            OUT
        } else {
            self.lab[y as usize * self.w + x as usize]
        }
    }

    #[inline]
    fn corner(&self, x: i64, y: i64) -> u32 {
        (y as usize * (self.w + 1) + x as usize) as u32
    }

    #[inline]
    fn corner_xy(&self, c: u32) -> (i64, i64) {
        let c = c as usize;
        ((c % (self.w + 1)) as i64, (c / (self.w + 1)) as i64)
    }

    fn is_raster_corner(&self, c: u32) -> bool {
        let (x, y) = self.corner_xy(c);
        (x == 0 || x == self.w as i64) && (y == 0 || y == self.h as i64)
    }

    /// The four pixels around corner `(x, y)`: NW, NE, SW, SE.
    #[inline]
    fn quad(&self, x: i64, y: i64) -> [u32; 4] {
        [self.pix(x - 1, y - 1), self.pix(x, y - 1), self.pix(x - 1, y), self.pix(x, y)]
    }

    /// `(positive side, other side)` of the crack leaving corner `(x, y)` in direction `d`,
    /// or `None` if there is no edge.
    #[inline]
    fn edge(&self, x: i64, y: i64, d: u8) -> Option<(u32, u32)> {
        let [nw, ne, sw, se] = self.quad(x, y);
        let (pos, neg) = match d {
            0 => (se, ne), // E: below is positive
            1 => (sw, se), // S: left is positive
            2 => (nw, sw), // W: above is positive
            _ => (ne, nw), // N: right is positive
        };
        (pos != neg && (is_region(pos) || is_region(neg))).then_some((pos, neg))
    }

    fn degree_and_junction(&self, x: i64, y: i64) -> (usize, bool) {
        let mut deg = 0;
        let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(4);
        for d in 0..4 {
            if let Some((a, b)) = self.edge(x, y, d) {
                deg += 1;
                pairs.push((a.min(b), a.max(b)));
            }
        }
        let raster_corner = (x == 0 || x == self.w as i64) && (y == 0 || y == self.h as i64);
        let junction = (deg != 2 && deg != 0) || (deg == 2 && pairs[0] != pairs[1]) || (deg > 0 && raster_corner);
        (deg, junction)
    }

    /// Index of the crack leaving `(x, y)` in direction `d` (horizontal cracks first).
    #[inline]
    fn crack_index(&self, x: i64, y: i64, d: u8) -> usize {
        let nh = self.w * (self.h + 1);
        match d {
            0 => y as usize * self.w + x as usize,
            2 => y as usize * self.w + (x - 1) as usize,
            1 => nh + y as usize * (self.w + 1) + x as usize,
            _ => nh + (y - 1) as usize * (self.w + 1) + x as usize,
        }
    }

    fn trace_chains(&self) -> Vec<Chain> {
        let (w, h) = (self.w as i64, self.h as i64);
        let ncracks = self.w * (self.h + 1) + (self.w + 1) * self.h;
        let mut visited = vec![false; ncracks];
        let mut is_junction = vec![false; (self.w + 1) * (self.h + 1)];
        for y in 0..=h {
            for x in 0..=w {
                is_junction[self.corner(x, y) as usize] = self.degree_and_junction(x, y).1;
            }
        }
        let mut chains = Vec::new();
        let trace = |x0: i64, y0: i64, d0: u8, visited: &mut Vec<bool>, is_junction: &Vec<bool>| -> Chain {
            let (fwd, bwd) = self.edge(x0, y0, d0).expect("edge");
            let mut raw = vec![self.corner(x0, y0)];
            let (mut x, mut y, mut d) = (x0, y0, d0);
            loop {
                visited[self.crack_index(x, y, d)] = true;
                x += DX[d as usize];
                y += DY[d as usize];
                let c = self.corner(x, y);
                raw.push(c);
                if is_junction[c as usize] {
                    break;
                }
                // Degree-2 corner: continue along the other crack.
                let back = (d + 2) % 4;
                let next = (0..4u8).find(|&nd| nd != back && self.edge(x, y, nd).is_some()).expect("degree-2 corner");
                d = next;
            }
            Chain { raw, first_dir: d0, last_dir: d, fwd, bwd, pts: Vec::new(), level: 0 }
        };
        for y in 0..=h {
            for x in 0..=w {
                if !is_junction[self.corner(x, y) as usize] {
                    continue;
                }
                for d in 0..4u8 {
                    if self.edge(x, y, d).is_some() && !visited[self.crack_index(x, y, d)] {
                        chains.push(trace(x, y, d, &mut visited, &is_junction));
                    }
                }
            }
        }
        // Closed loops without any junction: anchor at their first corner in index order.
        for y in 0..=h {
            for x in 0..=w {
                for d in 0..4u8 {
                    if self.edge(x, y, d).is_some() && !visited[self.crack_index(x, y, d)] {
                        is_junction[self.corner(x, y) as usize] = true;
                        chains.push(trace(x, y, d, &mut visited, &is_junction));
                    }
                }
            }
        }
        chains
    }

    /// The direction in which region `a` leaves corner `(x, y)` after arriving in direction
    /// `d_in`: the crack whose positive side is `a`; at a diagonal self-touch, the one owned by
    /// the same pixel as the arrival crack (the ring hugs the pixel, i.e. `a` is treated as
    /// 4-connected; after the cleanup every region is, so its boundary is one outer ring that
    /// may touch itself at such a corner, plus holes).
    fn out_dir(&self, x: i64, y: i64, d_in: u8, a: u32) -> u8 {
        let [nw, ne, sw, se] = self.quad(x, y);
        // Pixel (as quad index) owning the incoming / outgoing crack.
        const IN_PIX: [usize; 4] = [2, 0, 1, 3]; // arrive E: SW, S: NW, W: NE, N: SE
        const OUT_PIX: [usize; 4] = [3, 2, 0, 1]; // leave E: SE, S: SW, W: NW, N: NE
        let _ = (nw, ne, sw, se);
        let cands: Vec<u8> = (0..4u8).filter(|&d| self.edge(x, y, d).is_some_and(|(p, _)| p == a)).collect();
        match cands.len() {
            1 => cands[0],
            0 => panic!("region {a} has no outgoing crack at ({x}, {y})"),
            _ => *cands.iter().find(|&&d| OUT_PIX[d as usize] == IN_PIX[d_in as usize]).unwrap_or(&cands[0]),
        }
    }
}

/// Follows every region's chains into rings; per region the outer ring first, then holes.
fn region_rings(grid: &CrackGrid, chains: &[Chain]) -> RegionRings {
    // Departures: (corner, direction) → (chain, reversed).
    let mut dep: HashMap<(u32, u8), (usize, bool)> = HashMap::new();
    for (i, c) in chains.iter().enumerate() {
        dep.insert((c.raw[0], c.first_dir), (i, false));
        dep.insert((*c.raw.last().unwrap(), (c.last_dir + 2) % 4), (i, true));
    }
    let mut used = vec![[false; 2]; chains.len()];
    let mut by_label: HashMap<u32, Vec<(i64, Ring)>> = HashMap::new();
    for start in 0..chains.len() {
        for rev in [false, true] {
            let region = if rev { chains[start].bwd } else { chains[start].fwd };
            if !is_region(region) || used[start][rev as usize] {
                continue;
            }
            let mut ring: Ring = Vec::new();
            let (mut ci, mut r) = (start, rev);
            loop {
                used[ci][r as usize] = true;
                ring.push((ci, r));
                let c = &chains[ci];
                let (end, d_in) =
                    if r { (c.raw[0], (c.first_dir + 2) % 4) } else { (*c.raw.last().unwrap(), c.last_dir) };
                let (x, y) = grid.corner_xy(end);
                let d_out = grid.out_dir(x, y, d_in, region);
                let next = dep[&(end, d_out)];
                if next == (start, rev) {
                    break;
                }
                (ci, r) = next;
            }
            let area2 = ring_area2_raw(grid, chains, &ring);
            by_label.entry(region).or_default().push((area2, ring));
            debug_assert!(
                by_label[&region].iter().filter(|r| r.0 > 0).count() <= 1,
                "region {region} has several outer rings (not 4-connected)"
            );
        }
    }
    let mut labels: Vec<u32> = by_label.keys().copied().collect();
    labels.sort_unstable();
    let regions = labels
        .into_iter()
        .map(|l| {
            let mut rings = by_label.remove(&l).unwrap();
            // Outer ring (largest positive area) first, then holes in trace order.
            let outer = (0..rings.len()).max_by_key(|&i| (rings[i].0, std::cmp::Reverse(i))).unwrap();
            let o = rings.remove(outer);
            let mut out = vec![o.1];
            out.extend(rings.into_iter().map(|r| r.1));
            (l, out)
        })
        .collect();
    RegionRings { regions }
}

/// Twice the signed area of a ring of raw chains (exact).
fn ring_area2_raw(grid: &CrackGrid, chains: &[Chain], ring: &Ring) -> i64 {
    ring.iter().map(|&(ci, rev)| chain_area2_int(grid, &chains[ci].raw, rev)).sum()
}

fn chain_area2_int(grid: &CrackGrid, pts: &[u32], rev: bool) -> i64 {
    let mut s = 0;
    for p in pts.windows(2) {
        let (x0, y0) = grid.corner_xy(p[0]);
        let (x1, y1) = grid.corner_xy(p[1]);
        s += x0 * y1 - x1 * y0;
    }
    if rev {
        -s
    } else {
        s
    }
}

// ---------------------------------------------------------------------------------------------
// 5. Simplification and validation

/// Douglas–Peucker of a raw chain with fixed ends; a closed chain is split at the corner
/// farthest from its anchor. Tolerance 0 keeps exactly the turning corners.
fn simplify_chain(grid: &CrackGrid, raw: &[u32], tol: f64) -> Vec<u32> {
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

fn dp(pts: &[[f64; 2]], i0: usize, i1: usize, tol: f64, keep: &mut [bool]) {
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
fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

/// Distance from `p` to segment `[a, b]`.
fn seg_dist(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
    let l2 = ex * ex + ey * ey;
    let t = if l2 > 0.0 { (((p[0] - a[0]) * ex + (p[1] - a[1]) * ey) / l2).clamp(0.0, 1.0) } else { 0.0 };
    ((p[0] - a[0] - t * ex).powi(2) + (p[1] - a[1] - t * ey).powi(2)).sqrt()
}

#[inline]
fn orient(a: Point, b: Point, c: Point) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

#[inline]
fn on_segment(p: Point, a: Point, b: Point) -> bool {
    p[0] >= a[0].min(b[0]) && p[0] <= a[0].max(b[0]) && p[1] >= a[1].min(b[1]) && p[1] <= a[1].max(b[1])
}

/// Do two segments conflict? Segments sharing one endpoint conflict only if they overlap
/// along a line; identical segments conflict; otherwise any contact is a conflict.
/// (Coordinates are small dyadic rationals, so the orientation tests are exact.)
fn segments_conflict(a0: Point, a1: Point, b0: Point, b1: Point) -> bool {
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
fn invalid_chains(grid: &CrackGrid, chains: &[Chain], rings: &RegionRings) -> Vec<usize> {
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

// ---------------------------------------------------------------------------------------------
// 6–7. Editable mesh: collapse, straighten, assemble

struct MChain {
    pts: Vec<u32>,
}

struct Editable {
    pos: Vec<Point>,
    chains: Vec<MChain>,
    rings: RegionRings,
    dom: Vec<bool>,
    occ: Vec<bool>,
    junction: Vec<bool>,
    fixed: Vec<bool>,
    /// Union-find parent.
    parent: Vec<u32>,
    /// Chains using each (representative) vertex.
    vchains: Vec<Vec<usize>>,
    /// Rings (region index, ring index) using each chain.
    chain_rings: Vec<Vec<(usize, usize)>>,
    /// Which chains have segments near each place, so that validating an edit looks at
    /// its neighbourhood, not at every segment of the mesh.
    near: SegmentIndex,
    w: f64,
    h: f64,
}

/// A uniform grid of cells listing the chains whose segments' boxes meet them. Entries are
/// added as chains change and never removed: a stale entry costs a look, never a wrong
/// answer, since the chains' current points are what is tested.
struct SegmentIndex {
    cell: f64,
    gw: usize,
    gh: usize,
    cells: Vec<Vec<u32>>,
}

impl SegmentIndex {
    /// About one cell per segment, so a look visits a few segments whatever the mesh size.
    fn new(w: f64, h: f64, segments: usize) -> Self {
        let cell = (w * h / segments.max(1) as f64).sqrt().max(2.0);
        let gw = (w / cell) as usize + 1;
        let gh = (h / cell) as usize + 1;
        SegmentIndex { cell, gw, gh, cells: vec![Vec::new(); gw * gh] }
    }

    fn range(&self, lo: Point, hi: Point) -> (usize, usize, usize, usize) {
        let c = |v: f64, n: usize| ((v / self.cell).floor().max(0.0) as usize).min(n - 1);
        (c(lo[0], self.gw), c(hi[0], self.gw), c(lo[1], self.gh), c(hi[1], self.gh))
    }

    fn insert(&mut self, chain: usize, pos: &[Point], pts: &[u32]) {
        for p in pts.windows(2) {
            let (a, b) = (pos[p[0] as usize], pos[p[1] as usize]);
            let (x0, x1, y0, y1) = self.range([a[0].min(b[0]), a[1].min(b[1])], [a[0].max(b[0]), a[1].max(b[1])]);
            for gy in y0..=y1 {
                for gx in x0..=x1 {
                    let c = &mut self.cells[gy * self.gw + gx];
                    if c.last() != Some(&(chain as u32)) {
                        c.push(chain as u32);
                    }
                }
            }
        }
    }

    /// Chains that may have a segment meeting the box, sorted, without repeats.
    fn chains_near(&self, lo: Point, hi: Point, out: &mut Vec<usize>) {
        let (x0, x1, y0, y1) = self.range(lo, hi);
        for gy in y0..=y1 {
            for gx in x0..=x1 {
                out.extend(self.cells[gy * self.gw + gx].iter().map(|&c| c as usize));
            }
        }
        out.sort_unstable();
        out.dedup();
    }
}

impl Editable {
    #[allow(clippy::too_many_arguments)]
    fn new(
        pos: Vec<Point>,
        chains: Vec<MChain>,
        rings: RegionRings,
        dom: Vec<bool>,
        occ: Vec<bool>,
        junction: Vec<bool>,
        fixed: Vec<bool>,
        w: f64,
        h: f64,
    ) -> Self {
        let n = pos.len();
        let mut vchains = vec![Vec::new(); n];
        for (ci, c) in chains.iter().enumerate() {
            for &v in &c.pts {
                if vchains[v as usize].last() != Some(&ci) {
                    vchains[v as usize].push(ci);
                }
            }
        }
        for l in &mut vchains {
            l.sort_unstable();
            l.dedup();
        }
        let mut chain_rings = vec![Vec::new(); chains.len()];
        for (ri, (_, rs)) in rings.regions.iter().enumerate() {
            for (k, ring) in rs.iter().enumerate() {
                for &(ci, _) in ring {
                    chain_rings[ci].push((ri, k));
                }
            }
        }
        let segments = chains.iter().map(|c| c.pts.len().saturating_sub(1)).sum();
        let mut near = SegmentIndex::new(w, h, segments);
        for (ci, c) in chains.iter().enumerate() {
            near.insert(ci, &pos, &c.pts);
        }
        Editable {
            near,
            pos,
            chains,
            rings,
            dom,
            occ,
            junction,
            fixed,
            parent: (0..n as u32).collect(),
            vchains,
            chain_rings,
            w,
            h,
        }
    }

    fn find(&mut self, mut v: u32) -> u32 {
        while self.parent[v as usize] != v {
            let p = self.parent[v as usize];
            self.parent[v as usize] = self.parent[p as usize];
            v = p;
        }
        v
    }

    fn ring_area2(&self, ri: usize, k: usize, chains: &HashMap<usize, Vec<u32>>) -> f64 {
        let ring = &self.rings.regions[ri].1[k];
        let mut s = 0.0;
        for &(ci, rev) in ring {
            let pts = chains.get(&ci).unwrap_or(&self.chains[ci].pts);
            let mut c = 0.0;
            for p in pts.windows(2) {
                let (a, b) = (self.pos[p[0] as usize], self.pos[p[1] as usize]);
                c += a[0] * b[1] - b[0] * a[1];
            }
            s += if rev { -c } else { c };
        }
        s
    }

    fn ring_vertex_count(&self, ri: usize, k: usize, chains: &HashMap<usize, Vec<u32>>) -> usize {
        let ring = &self.rings.regions[ri].1[k];
        ring.iter().map(|&(ci, _)| chains.get(&ci).unwrap_or(&self.chains[ci].pts).len().saturating_sub(1)).sum()
    }

    /// Checks a tentative edit: `new_chains` replace some chains; `moved` is the vertex whose
    /// position changed (already set in `self.pos`). Returns whether the mesh stays valid.
    fn valid_after(&self, new_chains: &HashMap<usize, Vec<u32>>, check_vertex: u32) -> bool {
        // Degenerate chains.
        for pts in new_chains.values() {
            let closed = pts.len() > 1 && pts[0] == pts[pts.len() - 1];
            if closed && pts.len() < 4 {
                return false;
            }
            if pts.windows(2).any(|p| p[0] == p[1]) {
                return false;
            }
        }
        // Rings of affected chains keep their orientation and ≥ 3 vertices.
        let mut rings: Vec<(usize, usize)> =
            new_chains.keys().flat_map(|&ci| self.chain_rings[ci].iter().copied()).collect();
        rings.sort_unstable();
        rings.dedup();
        for (ri, k) in rings {
            let a = self.ring_area2(ri, k, new_chains);
            let ok = if k == 0 { a > 1e-9 } else { a < -1e-9 };
            if !ok || self.ring_vertex_count(ri, k, new_chains) < 3 {
                return false;
            }
        }
        // New segments (those incident to the changed vertex) against every other segment.
        let mut new_segs: Vec<(usize, usize, Point, Point)> = Vec::new();
        for (&ci, pts) in new_chains {
            for (k, p) in pts.windows(2).enumerate() {
                if p[0] == check_vertex || p[1] == check_vertex {
                    new_segs.push((ci, k, self.pos[p[0] as usize], self.pos[p[1] as usize]));
                }
            }
        }
        let mut near = Vec::new();
        for &(ci, k, a0, a1) in &new_segs {
            let (bx0, bx1) = (a0[0].min(a1[0]), a0[0].max(a1[0]));
            let (by0, by1) = (a0[1].min(a1[1]), a0[1].max(a1[1]));
            // The index knows the unchanged chains; the changed ones are looked at whole.
            near.clear();
            near.extend(new_chains.keys().copied());
            self.near.chains_near([bx0, by0], [bx1, by1], &mut near);
            for &cj in &near {
                let pts = new_chains.get(&cj).unwrap_or(&self.chains[cj].pts);
                let n = pts.len().saturating_sub(1);
                let closed = pts.len() > 1 && pts[0] == pts[pts.len() - 1];
                for (kj, q) in pts.windows(2).enumerate() {
                    if cj == ci && (kj == k) {
                        continue;
                    }
                    let (b0, b1) = (self.pos[q[0] as usize], self.pos[q[1] as usize]);
                    if b0[0].max(b1[0]) < bx0
                        || b0[0].min(b1[0]) > bx1
                        || b0[1].max(b1[1]) < by0
                        || b0[1].min(b1[1]) > by1
                    {
                        continue;
                    }
                    let adjacent = cj == ci && (kj.abs_diff(k) == 1 || (closed && kj.abs_diff(k) == n - 1));
                    if adjacent && n <= 2 {
                        continue;
                    }
                    if segments_conflict(a0, a1, b0, b1) {
                        return false;
                    }
                }
            }
        }
        true
    }

    /// Collapses edges shorter than `min_edge`; returns how many short edges remain.
    fn collapse_short(&mut self, min_edge: f64) -> usize {
        if min_edge <= 0.0 {
            return 0;
        }
        let mut cands: Vec<(f64, u32, u32)> = Vec::new();
        for c in &self.chains {
            for p in c.pts.windows(2) {
                let l = dist2(self.pos[p[0] as usize], self.pos[p[1] as usize]).sqrt();
                if l < min_edge {
                    cands.push((l, p[0].min(p[1]), p[0].max(p[1])));
                }
            }
        }
        cands.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        cands.dedup_by(|a, b| a.1 == b.1 && a.2 == b.2);
        for &(_, a, b) in &cands {
            let (u, v) = (self.find(a), self.find(b));
            if u == v {
                continue;
            }
            let (pu, pv) = (self.pos[u as usize], self.pos[v as usize]);
            if dist2(pu, pv).sqrt() >= min_edge {
                continue;
            }
            // Only collapse an actual edge (u and v consecutive in some chain).
            let is_edge = self.vchains[u as usize].iter().any(|&ci| {
                self.chains[ci].pts.windows(2).any(|p| (p[0] == u && p[1] == v) || (p[0] == v && p[1] == u))
            });
            if !is_edge {
                continue;
            }
            let Some(p) = self.merge_position(u, v) else { continue };
            let keep = u.min(v);
            let gone = u.max(v);
            // Tentative chains with `gone` → `keep`.
            let mut affected: Vec<usize> =
                self.vchains[u as usize].iter().chain(&self.vchains[v as usize]).copied().collect();
            affected.sort_unstable();
            affected.dedup();
            let mut new_chains: HashMap<usize, Vec<u32>> = HashMap::new();
            let mut vanish = Vec::new();
            for &ci in &affected {
                let mut pts: Vec<u32> = Vec::with_capacity(self.chains[ci].pts.len());
                for &q in &self.chains[ci].pts {
                    let q = if q == gone { keep } else { q };
                    if pts.last() != Some(&q) {
                        pts.push(q);
                    }
                }
                if pts.len() == 1 {
                    vanish.push(ci);
                }
                new_chains.insert(ci, pts);
            }
            let old = self.pos[keep as usize];
            self.pos[keep as usize] = p;
            // A vanished chain contributes nothing; validate the rest.
            let check: HashMap<usize, Vec<u32>> =
                new_chains.iter().map(|(&k, v)| (k, if v.len() == 1 { Vec::new() } else { v.clone() })).collect();
            if self.valid_after(&check, keep) {
                self.parent[gone as usize] = keep;
                let moved = std::mem::take(&mut self.vchains[gone as usize]);
                self.vchains[keep as usize].extend(moved);
                self.vchains[keep as usize].sort_unstable();
                self.vchains[keep as usize].dedup();
                for (ci, pts) in check {
                    self.near.insert(ci, &self.pos, &pts);
                    self.chains[ci].pts = pts;
                }
                let (d, o, j) = (self.dom[gone as usize], self.occ[gone as usize], self.junction[gone as usize]);
                self.dom[keep as usize] |= d;
                self.occ[keep as usize] |= o;
                self.junction[keep as usize] |= j;
                self.fixed[keep as usize] |= self.fixed[gone as usize];
            } else {
                self.pos[keep as usize] = old;
            }
        }
        // Count what is left.
        let mut left = 0;
        for c in &self.chains {
            for q in c.pts.windows(2) {
                if dist2(self.pos[q[0] as usize], self.pos[q[1] as usize]).sqrt() < min_edge {
                    left += 1;
                }
            }
        }
        left
    }

    /// Where the merge of `u` and `v` goes, or `None` if they may not merge.
    fn merge_position(&self, u: u32, v: u32) -> Option<Point> {
        let (u, v) = (u as usize, v as usize);
        let (pu, pv) = (self.pos[u], self.pos[v]);
        let mid = [0.5 * (pu[0] + pv[0]), 0.5 * (pu[1] + pv[1])];
        if self.fixed[u] && self.fixed[v] {
            return None;
        }
        if self.fixed[u] {
            return Some(pu);
        }
        if self.fixed[v] {
            return Some(pv);
        }
        match (self.dom[u], self.dom[v]) {
            (true, false) => return Some(pu),
            (false, true) => return Some(pv),
            (true, true) => {
                let same_side = (pu[0] == pv[0] && (pu[0] == 0.0 || pu[0] == self.w))
                    || (pu[1] == pv[1] && (pu[1] == 0.0 || pu[1] == self.h));
                return same_side.then_some(mid);
            }
            _ => {}
        }
        match (self.occ[u], self.occ[v]) {
            (true, false) => return Some(pu),
            (false, true) => return Some(pv),
            _ => {}
        }
        match (self.junction[u], self.junction[v]) {
            (true, false) => Some(pu),
            (false, true) => Some(pv),
            _ => Some(mid),
        }
    }

    /// Drops chain-interior vertices turning by less than `deg` degrees.
    fn straighten(&mut self, deg: f64) {
        if deg <= 0.0 {
            return;
        }
        let limit = deg.to_radians();
        for ci in 0..self.chains.len() {
            let mut k = 1;
            while k + 1 < self.chains[ci].pts.len() {
                let pts = &self.chains[ci].pts;
                let (a, b, c) =
                    (self.pos[pts[k - 1] as usize], self.pos[pts[k] as usize], self.pos[pts[k + 1] as usize]);
                let t1 = (b[1] - a[1]).atan2(b[0] - a[0]);
                let t2 = (c[1] - b[1]).atan2(c[0] - b[0]);
                let mut turn = (t2 - t1).abs();
                if turn > std::f64::consts::PI {
                    turn = 2.0 * std::f64::consts::PI - turn;
                }
                let v = pts[k];
                if turn < limit && self.vchains[v as usize].len() == 1 && !self.junction[v as usize] {
                    let mut np = pts.clone();
                    np.remove(k);
                    let mut m = HashMap::new();
                    m.insert(ci, np.clone());
                    // Validate the new segment a–c: reuse the vertex check on its start.
                    if self.valid_after(&m, np[k - 1]) {
                        self.near.insert(ci, &self.pos, &np);
                        self.chains[ci].pts = np;
                        continue;
                    }
                }
                k += 1;
            }
        }
    }

    fn assemble(mut self, relabelled: usize, short_kept: usize) -> Polygonization {
        let mut index: HashMap<u32, usize> = HashMap::new();
        let mut vertices: Vec<Point> = Vec::new();
        let mut dom = Vec::new();
        let mut occ = Vec::new();
        let mut regions = Vec::new();
        let mut region_labels = Vec::new();
        let mut bridges = 0;
        let mut unbridged = 0;
        let regions_in = std::mem::take(&mut self.rings.regions);
        for (label, rings) in &regions_in {
            let mut ring_ids: Vec<Vec<usize>> = Vec::new();
            for ring in rings {
                let mut ids: Vec<usize> = Vec::new();
                for &(ci, rev) in ring {
                    let pts = &self.chains[ci].pts;
                    if pts.len() < 2 {
                        continue;
                    }
                    let seq: Vec<u32> = if rev { pts.iter().rev().copied().collect() } else { pts.clone() };
                    for &v in &seq[..seq.len() - 1] {
                        let id = *index.entry(v).or_insert_with(|| {
                            vertices.push(self.pos[v as usize]);
                            dom.push(self.dom[v as usize]);
                            occ.push(self.occ[v as usize]);
                            vertices.len() - 1
                        });
                        if ids.last() != Some(&id) {
                            ids.push(id);
                        }
                    }
                }
                while ids.len() > 1 && ids.first() == ids.last() {
                    ids.pop();
                }
                ring_ids.push(ids);
            }
            let mut outer = ring_ids.remove(0);
            let mut holes = ring_ids;
            while !holes.is_empty() {
                let hole = holes.remove(0);
                match bridge(&vertices, &outer, &hole, &holes) {
                    Some(merged) => {
                        outer = merged;
                        bridges += 1;
                    }
                    None => unbridged += 1,
                }
            }
            regions.push(outer);
            region_labels.push(*label);
        }
        Polygonization {
            mesh: Mesh { vertices, regions },
            region_labels,
            on_domain_border: dom,
            on_occupancy_border: occ,
            bridges,
            unbridged_holes: unbridged,
            relabelled_pixels: relabelled,
            short_edges_kept: short_kept,
        }
    }
}

/// Joins a hole ring to a ring by the shortest bridge that touches no edge of the region's
/// rings (`others`: the holes not joined yet) except at its own ends. Returns the merged ring.
fn bridge(vertices: &[Point], outer: &[usize], hole: &[usize], others: &[Vec<usize>]) -> Option<Vec<usize>> {
    let ring_edges = |r: &[usize]| r.iter().zip(r.iter().cycle().skip(1)).map(|(&a, &b)| (a, b)).collect::<Vec<_>>();
    let mut edges = ring_edges(outer);
    edges.extend(ring_edges(hole));
    for o in others {
        edges.extend(ring_edges(o));
    }
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (hi, &h) in hole.iter().enumerate() {
        for (oi, &o) in outer.iter().enumerate() {
            if h != o {
                pairs.push((dist2(vertices[h], vertices[o]), hi, oi));
            }
        }
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    for (_, hi, oi) in pairs {
        let (h, o) = (hole[hi], outer[oi]);
        let (p0, p1) = (vertices[h], vertices[o]);
        // Edges at the bridge ends only block by a collinear overlap (segments_conflict).
        let blocked = edges.iter().any(|&(a, b)| segments_conflict(p0, p1, vertices[a], vertices[b]));
        if !blocked {
            let mut merged = outer[..=oi].to_vec();
            merged.extend_from_slice(&hole[hi..]);
            merged.extend_from_slice(&hole[..=hi]);
            merged.extend_from_slice(&outer[oi..]);
            return Some(merged);
        }
    }
    None
}

#[cfg(test)]
mod tests;
