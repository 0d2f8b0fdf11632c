//! What the optimisation tests build their cases from: stage-1-like label rasters of the
//! stand-ins (an elliptic Voronoi of their fitted ellipses) and their polygonised, analysed
//! meshes.

use super::*;
use crate::synth::structure::analysis::ellipse::fit_polygon;
use crate::synth::structure::analysis::labels_import::import_labels;
use crate::synth::structure::analysis::stats::{analyse, StatModel, StatsConfig};
use crate::synth::structure::fixtures::standins::StandIn;
use crate::synth::structure::mesh::faces::{extract_faces, mesh_to_subdivision};
use crate::synth::structure::types::NO_REGION;

/// Labels every pixel with the ellipse of smallest elliptic distance
/// `√((u/a)² + (v/b)²)` ([references: frasson §3.5.1]) among the ellipses fitted to the ground truth.
pub fn elliptic_voronoi(s: &StandIn) -> Vec<u32> {
    let (w, h) = (s.width, s.height);
    let ells: Vec<_> = s.polygons().iter().filter_map(|p| fit_polygon(p)).collect();
    let mut ids = vec![0u32; w * h];
    ids.par_chunks_mut(w).enumerate().for_each(|(j, row)| {
        for (i, px) in row.iter_mut().enumerate() {
            let p = [i as f64 + 0.5, j as f64 + 0.5];
            let mut best = (f64::INFINITY, 0u32);
            for (k, e) in ells.iter().enumerate() {
                let (dx, dy) = (p[0] - e.center[0], p[1] - e.center[1]);
                let (sn, cs) = e.theta.sin_cos();
                let (u, v) = (dx * cs + dy * sn, -dx * sn + dy * cs);
                let d = (u / e.a).powi(2) + (v / e.b).powi(2);
                if d < best.0 {
                    best = (d, k as u32);
                }
            }
            *px = best.1;
        }
    });
    ids
}

/// Makes every label one 4-connected component that is not an island inside a single
/// other label: stray components and islands are given to their neighbours.
pub fn clean_labels(ids: &mut [u32], w: usize, h: usize) {
    let nb = |p: usize| {
        let (x, y) = (p % w, p / w);
        let mut v = Vec::with_capacity(4);
        if x > 0 {
            v.push(p - 1);
        }
        if x + 1 < w {
            v.push(p + 1);
        }
        if y > 0 {
            v.push(p - w);
        }
        if y + 1 < h {
            v.push(p + w);
        }
        v
    };
    loop {
        let mut comp = vec![usize::MAX; w * h];
        let mut comps: Vec<(u32, Vec<usize>)> = Vec::new();
        for s in 0..w * h {
            if comp[s] != usize::MAX {
                continue;
            }
            let id = comps.len();
            let mut stack = vec![s];
            comp[s] = id;
            let mut pix = Vec::new();
            while let Some(p) = stack.pop() {
                pix.push(p);
                for q in nb(p) {
                    if comp[q] == usize::MAX && ids[q] == ids[s] {
                        comp[q] = id;
                        stack.push(q);
                    }
                }
            }
            comps.push((ids[s], pix));
        }
        // The largest component of each label survives; islands (touching one other
        // component and not the image border) do not.
        let mut largest: std::collections::BTreeMap<u32, usize> = Default::default();
        for (c, (l, pix)) in comps.iter().enumerate() {
            let e = largest.entry(*l).or_insert(c);
            if comps[*e].1.len() < pix.len() {
                *e = c;
            }
        }
        let mut changed = false;
        for (c, (l, pix)) in comps.iter().enumerate() {
            let mut others = std::collections::BTreeSet::new();
            let mut on_border = false;
            for &p in pix {
                let (x, y) = (p % w, p / w);
                on_border |= x == 0 || y == 0 || x + 1 == w || y + 1 == h;
                for q in nb(p) {
                    if comp[q] != c {
                        others.insert(comp[q]);
                    }
                }
            }
            if largest[l] != c || (!on_border && others.len() == 1) {
                for &p in pix {
                    ids[p] = NO_REGION;
                }
                changed = true;
            }
        }
        if !changed {
            return;
        }
        while ids.contains(&NO_REGION) {
            let snap = ids.to_vec();
            for p in 0..w * h {
                if snap[p] == NO_REGION {
                    if let Some(q) = nb(p).into_iter().find(|&q| snap[q] != NO_REGION) {
                        ids[p] = snap[q];
                    }
                }
            }
        }
    }
}

/// Stage-1 stand-in: the anisotropic Voronoi diagram of the ellipses fitted to the
/// ground truth (the "fit-then-Voronoi" reconstruction of F8 / Fig. 3.13, i.e. stage 1
/// with the sample's own ellipses and no Lloyd), polygonised along pixel cracks with
/// Douglas–Peucker at 1 px. Returns the mesh and its border flags.
pub fn stage1(s: &StandIn) -> (Mesh, Vec<bool>) {
    let (w, h) = (s.width, s.height);
    let mut ids = elliptic_voronoi(s);
    clean_labels(&mut ids, w, h);
    let sub = import_labels(&ids, w, h, 1.0).expect("labels import");
    let faces = extract_faces(&sub);
    assert!(faces.regions.iter().all(|r| r.holes.is_empty()), "stage-1 stand-in has islands");
    let mesh = faces.to_mesh(&sub);
    let border = on_domain_border(&mesh, w as f64, h as f64);
    (mesh, border)
}

pub fn on_domain_border(mesh: &Mesh, w: f64, h: f64) -> Vec<bool> {
    mesh.vertices.iter().map(|p| p[0] <= 1e-9 || p[1] <= 1e-9 || p[0] >= w - 1e-9 || p[1] >= h - 1e-9).collect()
}

pub fn interior_polygons(s: &StandIn) -> Vec<Vec<Point>> {
    let b = s.border_regions();
    s.polygons().into_iter().enumerate().filter(|(r, _)| !b[*r]).map(|(_, p)| p).collect()
}

pub fn model(mesh: &Mesh, w: usize, h: usize) -> StatModel {
    analyse(&mesh_to_subdivision(mesh), Some([w as f64, h as f64]), &StatsConfig::default()).expect("analyse").model
}

pub fn edge_lengths(mesh: &Mesh) -> Vec<f64> {
    mesh_edges(&mesh.regions)
        .iter()
        .map(|&[a, b]| {
            let (p, q) = (mesh.vertices[a], mesh.vertices[b]);
            ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2)).sqrt()
        })
        .collect()
}
