//! The end of polygonisation: the edited chains assembled into one ring per region, holes
//! bridged into their region's ring, and the result with its per-vertex flags.

use std::collections::HashMap;

use serde::{Deserialize, Serialize};

use super::editable::Editable;
use super::simplify::{dist2, segments_conflict};
use crate::synth::structure::types::{Mesh, Point};

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

impl Editable {
    pub(super) fn assemble(mut self, relabelled: usize, short_kept: usize) -> Polygonization {
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
pub(super) fn bridge(vertices: &[Point], outer: &[usize], hole: &[usize], others: &[Vec<usize>]) -> Option<Vec<usize>> {
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
