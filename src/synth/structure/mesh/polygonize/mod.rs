//! Watertight polygonisation of a label raster ([references: frasson §3.5.4], "label image → mesh"; F13).
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
//!    the left (positive shoelace area with y down, the `Mesh` convention). At a corner where
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
//!
//! One file per step: `cleanup` (1), `cracks` (2–4), `simplify` (5), `editable` (6–7)
//! and `assemble` (the rings and the result); this file runs them in order.

mod assemble;
mod cleanup;
mod cracks;
mod editable;
mod simplify;

use std::collections::HashMap;

use serde::{Deserialize, Serialize};

use crate::synth::structure::types::{Labels, Point, NO_REGION};
pub use assemble::Polygonization;
use cleanup::single_components;
use cracks::{region_rings, CrackGrid, OUT};
use editable::{Editable, MChain};
use simplify::{invalid_chains, simplify_chain};

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

#[cfg(test)]
mod tests;
