//! Unit tests of the polygoniser: watertight meshes (F13), occupancy borders, hole bridges,
//! valency-4 junctions, diagonal touches and noisy labels.

use super::assemble::*;
use super::cleanup::*;
use super::simplify::*;
use super::*;
use crate::synth::rng::Rng;
use crate::synth::structure::fixtures::ellipses::random_ellipses;
use crate::synth::structure::relaxation::controls::Controls;
use crate::synth::structure::relaxation::lloyd::{lloyd, LloydParams};
use crate::synth::structure::relaxation::voronoi::{voronoi_ellipses, Domain, VoronoiMode, VoronoiParams};
use crate::synth::structure::types::Mesh;
use std::collections::HashSet;

#[derive(Debug, Default)]
struct Report {
    interior_edges: usize,
    border_edges: usize,
    bridge_edges: usize,
    bad_edges: usize,
    worst_area_excess: f64,
    /// Largest |area − pixel count| / (0.5·perimeter + 4).
    worst_area_ratio: f64,
    euler_lhs: i64,
    euler_rhs: i64,
    shortest: f64,
    valency4: usize,
    self_conflicts: usize,
}

fn ring_area(m: &Mesh, r: &[usize]) -> f64 {
    let mut s = 0.0;
    for k in 0..r.len() {
        let (a, b) = (m.vertices[r[k]], m.vertices[r[(k + 1) % r.len()]]);
        s += a[0] * b[1] - b[0] * a[1];
    }
    0.5 * s
}

/// Mesh checks of F13. `holes` = bounded faces that are not regions (enclosed forbidden
/// areas) for the Euler relation.
fn check(p: &Polygonization, labels: &Labels, holes: i64) -> Report {
    let m = &p.mesh;
    let mut rep = Report { shortest: f64::INFINITY, ..Default::default() };
    // Directed edge uses.
    let mut uses: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
    for (ri, r) in m.regions.iter().enumerate() {
        for k in 0..r.len() {
            let (a, b) = (r[k], r[(k + 1) % r.len()]);
            uses.entry((a.min(b), a.max(b))).or_default().push(ri);
        }
    }
    let fixed = p.fixed_vertices();
    for (&(a, b), rs) in &uses {
        let len = dist2(m.vertices[a], m.vertices[b]).sqrt();
        match rs.len() {
            1 if fixed[a] && fixed[b] => rep.border_edges += 1,
            2 if rs[0] != rs[1] => rep.interior_edges += 1,
            2 => rep.bridge_edges += 1,
            _ => rep.bad_edges += 1,
        }
        if !(rs.len() == 2 && rs[0] == rs[1]) {
            rep.shortest = rep.shortest.min(len);
        }
    }
    // Area vs pixel count.
    let mut count: HashMap<u32, f64> = HashMap::new();
    for &l in &labels.data {
        if l != NO_REGION {
            *count.entry(l).or_default() += 1.0;
        }
    }
    for (ri, r) in m.regions.iter().enumerate() {
        let area = ring_area(m, r);
        let per: f64 = (0..r.len()).map(|k| dist2(m.vertices[r[k]], m.vertices[r[(k + 1) % r.len()]]).sqrt()).sum();
        let px = count[&p.region_labels[ri]];
        rep.worst_area_excess = rep.worst_area_excess.max((area - px).abs() - (0.5 * per + 4.0));
        rep.worst_area_ratio = rep.worst_area_ratio.max((area - px).abs() / (0.5 * per + 4.0));
        // Simple (weakly): non-adjacent edges of a ring do not cross.
        for i in 0..r.len() {
            for j in i + 2..r.len() {
                if i == 0 && j == r.len() - 1 {
                    continue;
                }
                let (a0, a1) = (m.vertices[r[i]], m.vertices[r[(i + 1) % r.len()]]);
                let (b0, b1) = (m.vertices[r[j]], m.vertices[r[(j + 1) % r.len()]]);
                let share = [r[i], r[(i + 1) % r.len()]].iter().any(|v| *v == r[j] || *v == r[(j + 1) % r.len()]);
                if !share && segments_conflict(a0, a1, b0, b1) {
                    rep.self_conflicts += 1;
                }
            }
        }
    }
    // Euler: N_R + holes + N_V = N_E + 1 (connected graph, bridges included).
    let used: HashSet<usize> = m.regions.iter().flatten().copied().collect();
    rep.euler_lhs = m.regions.len() as i64 + holes + used.len() as i64;
    rep.euler_rhs = uses.len() as i64 + 1;
    let mut valency = vec![0usize; m.vertices.len()];
    for &(a, b) in uses.keys() {
        valency[a] += 1;
        valency[b] += 1;
    }
    rep.valency4 = valency.iter().filter(|&&v| v >= 4).count();
    rep
}

fn distinct_labels(l: &Labels) -> Vec<u32> {
    let mut v: Vec<u32> = l.data.iter().copied().filter(|&x| x != NO_REGION).collect();
    v.sort_unstable();
    v.dedup();
    v
}

fn assert_f13(name: &str, p: &Polygonization, labels: &Labels, holes: i64, params: &PolygonizeParams) {
    let r = check(p, labels, holes);
    eprintln!(
        "F13 {name}: {} regions, {} vertices, {} interior / {} border / {} bridge edges, bad {}, worst |area - px| / (0.5 per + 4) {:.3}, Euler {} = {}, shortest {:.3}, valency-4 {}, self conflicts {}, short kept {}, relabelled {}",
        p.mesh.regions.len(),
        p.mesh.vertices.len(),
        r.interior_edges,
        r.border_edges,
        r.bridge_edges,
        r.bad_edges,
        r.worst_area_ratio,
        r.euler_lhs,
        r.euler_rhs,
        r.shortest,
        r.valency4,
        r.self_conflicts,
        p.short_edges_kept,
        p.relabelled_pixels
    );
    assert_eq!(r.bad_edges, 0, "{name}: edges not shared by exactly 2 sides");
    assert_eq!(p.unbridged_holes, 0);
    assert!(r.worst_area_excess <= 0.0, "{name}: area off by {}", r.worst_area_excess);
    assert_eq!(r.euler_lhs, r.euler_rhs, "{name}: Euler");
    assert_eq!(r.self_conflicts, 0, "{name}: self-crossing ring");
    assert!(r.shortest >= params.min_edge, "{name}: edge of {}", r.shortest);
    assert_eq!(p.short_edges_kept, 0);
}

fn relaxed(seed: u64, w: usize, h: usize, n: usize) -> Labels {
    let mut rng = Rng::new(seed);
    let gens = random_ellipses(&mut rng, n, w, h, 8.0, 24.0, 2.5);
    lloyd(w, h, &gens, None, &Controls::default(), &LloydParams { max_iters: 20, ..Default::default() }).labels
}

/// F13 on Lloyd output, raw anisotropic Voronoi output and argmin output (needs cleanup).
#[test]
fn f13_watertight_mesh() {
    let params = PolygonizeParams::default();
    for seed in [130, 131] {
        let labels = relaxed(seed, 360, 280, 110);
        let p = polygonize(&labels, &params);
        assert_eq!(p.region_labels, distinct_labels(&labels), "one polygon per label");
        assert_f13(&format!("lloyd {seed}"), &p, &labels, 0, &params);
    }
    let (w, h) = (300, 240);
    let mut rng = Rng::new(132);
    let gens = random_ellipses(&mut rng, 90, w, h, 4.0, 30.0, 3.0);
    let vd = voronoi_ellipses(&Domain::new(w, h), &gens, &VoronoiParams::default());
    let p = polygonize(&vd.labels, &params);
    assert_eq!(p.region_labels, distinct_labels(&vd.labels));
    assert_f13("raw voronoi", &p, &vd.labels, 0, &params);
    let am =
        voronoi_ellipses(&Domain::new(w, h), &gens, &VoronoiParams { mode: VoronoiMode::Argmin, ..Default::default() });
    let p = polygonize(&am.labels, &params);
    assert!(p.relabelled_pixels > 0);
    // Labels after cleanup: every label keeps its main component.
    assert_eq!(p.region_labels, distinct_labels(&am.labels));
    let mut cleaned = am.labels.data.clone();
    single_components(&mut cleaned, w, h);
    let cleaned = Labels { width: w, height: h, data: cleaned };
    assert_f13("argmin", &p, &cleaned, 0, &params);
}

/// Occupancy: a forbidden blob inside the domain and a forbidden band on the border;
/// border vertices are flagged.
#[test]
fn f13_occupancy_borders() {
    let (w, h) = (320, 240);
    let occ: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
            let blob = (x - 160.0).hypot(y - 120.0) < 40.0;
            let band = x < 30.0;
            if blob || band {
                0.0
            } else {
                1.0
            }
        })
        .collect();
    let mut rng = Rng::new(133);
    let gens: Vec<_> = random_ellipses(&mut rng, 100, w, h, 8.0, 20.0, 2.0)
        .into_iter()
        .filter(|e| {
            crate::synth::structure::relaxation::controls::point_allowed(
                Some(&crate::synth::structure::relaxation::controls::allowed_from_occupancy(&occ)),
                w,
                h,
                e.center,
            )
        })
        .collect();
    let controls = Controls { occupancy: Some(&occ), ..Default::default() };
    let labels = lloyd(w, h, &gens, None, &controls, &LloydParams { max_iters: 15, ..Default::default() }).labels;
    let params = PolygonizeParams::default();
    let p = polygonize(&labels, &params);
    assert_eq!(p.region_labels, distinct_labels(&labels));
    // The band touches the raster border, so it merges with the outer face; the blob is one
    // extra bounded face.
    assert_f13("occupancy", &p, &labels, 1, &params);
    let nocc = p.on_occupancy_border.iter().filter(|&&b| b).count();
    let ndom = p.on_domain_border.iter().filter(|&&b| b).count();
    assert!(nocc > 20 && ndom > 10);
    // Occupancy-border vertices lie on the forbidden area's pixel border (within 1 px).
    for (v, &b) in p.mesh.vertices.iter().zip(&p.on_occupancy_border) {
        if b {
            let x = v[0];
            let r = (v[0] - 160.0).hypot(v[1] - 120.0);
            assert!((x - 30.0).abs() <= 1.5 || (r - 40.0).abs() <= 2.0, "vertex {v:?}");
        }
    }
    for (v, &b) in p.mesh.vertices.iter().zip(&p.on_domain_border) {
        if b {
            assert!(v[0] == 0.0 || v[1] == 0.0 || v[0] == w as f64 || v[1] == h as f64, "vertex {v:?}");
        }
    }
}

/// Holes: a region enclosed by another (and a nested pair) gets a bridge.
#[test]
fn f13_holes_are_bridged() {
    let (w, h) = (60, 50);
    let data: Vec<u32> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            if (20..30).contains(&x) && (15..25).contains(&y) {
                if (23..26).contains(&x) && (18..21).contains(&y) {
                    3
                } else {
                    2
                }
            } else if x < 40 {
                0
            } else {
                1
            }
        })
        .collect();
    let labels = Labels { width: w, height: h, data };
    let params = PolygonizeParams::default();
    let p = polygonize(&labels, &params);
    assert_eq!(p.region_labels, vec![0, 1, 2, 3]);
    assert_eq!(p.bridges, 2);
    let r = check(&p, &labels, 0);
    assert_eq!(r.bad_edges, 0);
    assert_eq!(r.euler_lhs, r.euler_rhs);
    assert!(r.worst_area_excess <= 0.0);
    // Exact areas (axis-aligned shapes survive simplification).
    let areas: Vec<f64> = p.mesh.regions.iter().map(|r| ring_area(&p.mesh, r)).collect();
    assert_eq!(areas, vec![40.0 * 50.0 - 100.0, 20.0 * 50.0, 100.0 - 9.0, 9.0]);
}

/// Close junctions collapse into valency-4 vertices.
#[test]
fn f13_close_junctions_give_valency_4() {
    let (w, h) = (80, 60);
    // Four quadrants whose vertical split is offset by 1 px between the halves.
    let data: Vec<u32> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let split = if y < 30 { 40 } else { 41 };
            (if x < split { 0 } else { 1 }) + (if y < 30 { 0 } else { 2 })
        })
        .collect();
    let labels = Labels { width: w, height: h, data };
    let params = PolygonizeParams::default();
    let p = polygonize(&labels, &params);
    let r = check(&p, &labels, 0);
    eprintln!("F13 close junctions: valency-4 vertices {}", r.valency4);
    assert!(r.valency4 >= 1);
    assert_f13("close junctions", &p, &labels, 0, &params);
    // Without collapsing, the two junctions stay 1 px apart (valency 3 each).
    let p0 = polygonize(&labels, &PolygonizeParams { min_edge: 0.0, ..params });
    assert_eq!(check(&p0, &labels, 0).valency4, 0);
}

/// A 4-connected region touching itself diagonally (enclosing another region) keeps one
/// ring through the pinch vertex; a diagonal-only fragment is cleaned up.
#[test]
fn diagonal_touches() {
    #[rustfmt::skip]
    let data = vec![
        1, 1, 1, 0,
        1, 2, 1, 0,
        1, 1, 0, 0,
        0, 0, 0, 0,
    ];
    let labels = Labels { width: 4, height: 4, data };
    let exact = PolygonizeParams { tolerance: 0.0, min_edge: 0.0, straight_deg: 0.0 };
    let p = polygonize(&labels, &exact);
    assert_eq!(p.region_labels, vec![0, 1, 2]);
    assert_eq!(p.relabelled_pixels, 0);
    let areas: Vec<f64> = p.mesh.regions.iter().map(|r| ring_area(&p.mesh, r)).collect();
    assert_eq!(areas, vec![8.0, 7.0, 1.0]);
    let r = check(&p, &labels, 0);
    assert_eq!(r.bad_edges, 0);
    assert_eq!(r.euler_lhs, r.euler_rhs);
    // Region 1's ring visits the pinch corner (2, 2) twice.
    let pinch = p.mesh.vertices.iter().position(|v| *v == [2.0, 2.0]).unwrap();
    assert_eq!(p.mesh.regions[1].iter().filter(|&&v| v == pinch).count(), 2);
    // Two blocks of label 0 touching only diagonally: the later one is relabelled.
    let data = vec![0, 0, 1, 1, 0, 0, 1, 1, 2, 2, 0, 0, 2, 2, 0, 0];
    let labels = Labels { width: 4, height: 4, data };
    let p = polygonize(&labels, &exact);
    assert_eq!(p.relabelled_pixels, 4);
    assert_eq!(p.mesh.regions.len(), 3);
}

/// Robustness: noisy argmin labels with forbidden speckles never break watertightness or
/// ring simplicity, and every label keeps one polygon.
#[test]
fn stress_noisy_labels() {
    let params = PolygonizeParams::default();
    let mut worst_short = 0;
    for seed in 0..40u64 {
        let mut rng = Rng::new(1000 + seed);
        let (w, h) = (90 + rng.below(60), 70 + rng.below(60));
        let n = 10 + rng.below(40);
        let gens = random_ellipses(&mut rng, n, w, h, 2.0, 25.0, 4.0);
        let mut vd = voronoi_ellipses(
            &Domain::new(w, h),
            &gens,
            &VoronoiParams { mode: VoronoiMode::Argmin, ..Default::default() },
        );
        for _ in 0..rng.below(200) {
            let i = rng.below(w * h);
            vd.labels.data[i] = if rng.below(3) == 0 { NO_REGION } else { rng.below(gens.len()) as u32 };
        }
        let p = polygonize(&vd.labels, &params);
        let mut cleaned = vd.labels.data.clone();
        single_components(&mut cleaned, w, h);
        let cleaned = Labels { width: w, height: h, data: cleaned };
        assert_eq!(p.region_labels, distinct_labels(&cleaned), "seed {seed}");
        let r = check(&p, &cleaned, 0);
        assert_eq!(r.bad_edges, 0, "seed {seed}");
        assert_eq!(r.self_conflicts, 0, "seed {seed}");
        assert_eq!(p.unbridged_holes, 0, "seed {seed}");
        assert!(r.worst_area_excess <= 0.0, "seed {seed}");
        worst_short = worst_short.max(p.short_edges_kept);
    }
    eprintln!("stress: most short edges kept in one mesh: {worst_short}");
}
