//! Steps 6–7 of polygonisation: the editable mesh of simplified chains, where short edges are
//! collapsed and straight valency-2 vertices dropped, each edit checked against the
//! neighbouring segments so that the mesh stays valid.

use std::collections::HashMap;

use super::cracks::RegionRings;
use super::simplify::{dist2, segments_conflict};
use crate::synth::structure::types::Point;

pub(super) struct MChain {
    pub(super) pts: Vec<u32>,
}

pub(super) struct Editable {
    pub(super) pos: Vec<Point>,
    pub(super) chains: Vec<MChain>,
    pub(super) rings: RegionRings,
    pub(super) dom: Vec<bool>,
    pub(super) occ: Vec<bool>,
    pub(super) junction: Vec<bool>,
    pub(super) fixed: Vec<bool>,
    /// Union-find parent.
    pub(super) parent: Vec<u32>,
    /// Chains using each (representative) vertex.
    pub(super) vchains: Vec<Vec<usize>>,
    /// Rings (region index, ring index) using each chain.
    pub(super) chain_rings: Vec<Vec<(usize, usize)>>,
    /// Which chains have segments near each place, so that validating an edit looks at
    /// its neighbourhood, not at every segment of the mesh.
    pub(super) near: SegmentIndex,
    pub(super) w: f64,
    pub(super) h: f64,
}

/// A uniform grid of cells listing the chains whose segments' boxes meet them. Entries are
/// added as chains change and never removed: a stale entry costs a look, never a wrong
/// answer, since the chains' current points are what is tested.
pub(super) struct SegmentIndex {
    pub(super) cell: f64,
    pub(super) gw: usize,
    pub(super) gh: usize,
    pub(super) cells: Vec<Vec<u32>>,
}

impl SegmentIndex {
    /// About one cell per segment, so a look visits a few segments whatever the mesh size.
    pub(super) fn new(w: f64, h: f64, segments: usize) -> Self {
        let cell = (w * h / segments.max(1) as f64).sqrt().max(2.0);
        let gw = (w / cell) as usize + 1;
        let gh = (h / cell) as usize + 1;
        SegmentIndex { cell, gw, gh, cells: vec![Vec::new(); gw * gh] }
    }

    pub(super) fn range(&self, lo: Point, hi: Point) -> (usize, usize, usize, usize) {
        let c = |v: f64, n: usize| ((v / self.cell).floor().max(0.0) as usize).min(n - 1);
        (c(lo[0], self.gw), c(hi[0], self.gw), c(lo[1], self.gh), c(hi[1], self.gh))
    }

    pub(super) fn insert(&mut self, chain: usize, pos: &[Point], pts: &[u32]) {
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
    pub(super) fn chains_near(&self, lo: Point, hi: Point, out: &mut Vec<usize>) {
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
    pub(super) fn new(
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

    pub(super) fn find(&mut self, mut v: u32) -> u32 {
        while self.parent[v as usize] != v {
            let p = self.parent[v as usize];
            self.parent[v as usize] = self.parent[p as usize];
            v = p;
        }
        v
    }

    pub(super) fn ring_area2(&self, ri: usize, k: usize, chains: &HashMap<usize, Vec<u32>>) -> f64 {
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

    pub(super) fn ring_vertex_count(&self, ri: usize, k: usize, chains: &HashMap<usize, Vec<u32>>) -> usize {
        let ring = &self.rings.regions[ri].1[k];
        ring.iter().map(|&(ci, _)| chains.get(&ci).unwrap_or(&self.chains[ci].pts).len().saturating_sub(1)).sum()
    }

    /// Checks a tentative edit: `new_chains` replace some chains; `moved` is the vertex whose
    /// position changed (already set in `self.pos`). Returns whether the mesh stays valid.
    pub(super) fn valid_after(&self, new_chains: &HashMap<usize, Vec<u32>>, check_vertex: u32) -> bool {
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
    pub(super) fn collapse_short(&mut self, min_edge: f64) -> usize {
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
    pub(super) fn merge_position(&self, u: u32, v: u32) -> Option<Point> {
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
    pub(super) fn straighten(&mut self, deg: f64) {
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
}
