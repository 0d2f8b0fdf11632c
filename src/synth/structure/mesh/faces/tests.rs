//! Unit tests of face extraction: Euler's relation and areas on grids (F1), L- and U-shaped faces, orientation, islands as holes, dangling edges, and the stand-ins' imports (which is why these live in their own file: the fixtures build on faces).

use super::*;
use crate::synth::structure::format::parse_structure;

fn rect_grid(nx: usize, ny: usize, s: f64) -> Subdivision {
    let mut sub = Subdivision::default();
    for j in 0..=ny {
        for i in 0..=nx {
            sub.vertices.push([i as f64 * s, j as f64 * s * 0.7]);
        }
    }
    let id = |i: usize, j: usize| j * (nx + 1) + i;
    for j in 0..=ny {
        for i in 0..=nx {
            if i < nx {
                sub.edges.push([id(i, j), id(i + 1, j)]);
            }
            if j < ny {
                sub.edges.push([id(i, j + 1), id(i, j)]);
            }
        }
    }
    sub
}

fn check_invariants(sub: &Subdivision, f: &Faces) {
    assert!(f.euler_holds(), "Euler: R {} V {} E {} C {}", f.regions.len(), f.vertex_count, f.edge_count, f.components);
    // Each edge borders at most 2 regions, by construction; here also check that every
    // region's boundary edges name the region on the correct side.
    for (r, reg) in f.regions.iter().enumerate() {
        assert!(reg.area > 0.0);
        assert!(signed_area(&f.polygon(sub, r)) > 0.0);
        for (i, &e) in reg.boundary_edges.iter().enumerate() {
            let forward = sub.edges[e][0] == reg.boundary[i];
            assert_eq!(f.edge_regions[e][if forward { 0 } else { 1 }], Some(r));
        }
    }
    let total: f64 = f.regions.iter().map(|r| r.area).sum();
    let outer = f.outer_area(sub);
    assert!((total - outer).abs() <= 1e-9 * outer, "areas {total} vs {outer}");
}

#[test]
fn f1_grid_euler_and_areas() {
    let sub = rect_grid(7, 5, 10.0);
    let f = extract_faces(&sub);
    assert_eq!(f.regions.len(), 35);
    check_invariants(&sub, &f);
    // Interior edges have two regions, border edges one.
    let two = f.edge_regions.iter().filter(|e| e[0].is_some() && e[1].is_some()).count();
    assert_eq!(two, sub.edges.len() - 2 * (7 + 5));
    assert_eq!(f.regions.iter().filter(|r| r.touches_outer).count(), 2 * 7 + 2 * 5 - 4);
}

#[test]
fn f1_l_and_u_shaped_faces() {
    // L shape beside a square, sharing an edge.
    let l = r#"{"vertices": [[0,0],[20,0],[20,10],[10,10],[10,30],[0,30],[30,0],[30,10]],
                "edges": [[0,1],[1,2],[2,3],[3,4],[4,5],[5,0],[1,6],[6,7],[7,2]]}"#;
    let sub = parse_structure(l).unwrap();
    let f = extract_faces(&sub);
    assert_eq!(f.regions.len(), 2);
    check_invariants(&sub, &f);
    let mut areas: Vec<f64> = f.regions.iter().map(|r| r.area).collect();
    areas.sort_by(f64::total_cmp);
    assert_eq!(areas, vec![100.0, 400.0]);
    let lreg = f.regions.iter().find(|r| r.area == 400.0).unwrap();
    assert_eq!(lreg.boundary.len(), 6);

    // U shape with a block filling its notch: 2 regions.
    let u = r#"{"vertices": [[0,0],[30,0],[30,30],[20,30],[20,10],[10,10],[10,30],[0,30]],
                "edges": [[0,1],[1,2],[2,3],[3,4],[4,5],[5,6],[6,7],[7,0],[6,3]]}"#;
    let sub = parse_structure(u).unwrap();
    let f = extract_faces(&sub);
    assert_eq!(f.regions.len(), 2);
    check_invariants(&sub, &f);
    let mut areas: Vec<f64> = f.regions.iter().map(|r| r.area).collect();
    areas.sort_by(f64::total_cmp);
    assert_eq!(areas, vec![200.0, 700.0]);
    // Alone, the U is one face of 8 vertices.
    let u_alone = Subdivision { vertices: sub.vertices.clone(), edges: sub.edges[..8].to_vec() };
    let f = extract_faces(&u_alone);
    assert_eq!(f.regions.len(), 1);
    assert_eq!(f.regions[0].boundary.len(), 8);
    assert_eq!(f.regions[0].area, 700.0);
    assert!(f.euler_holds());
}

#[test]
fn left_right_orientation() {
    // Triangle 0-1-2 with positive area: the edges go around it in boundary order.
    let sub = Subdivision { vertices: vec![[0.0, 0.0], [4.0, 0.0], [0.0, 3.0]], edges: vec![[0, 1], [1, 2], [0, 2]] };
    let f = extract_faces(&sub);
    assert_eq!(f.regions.len(), 1);
    assert_eq!(f.edge_regions, vec![[Some(0), None], [Some(0), None], [None, Some(0)]]);
    assert_eq!(f.regions[0].area, 6.0);
}

#[test]
fn islands_become_holes() {
    let sub = Subdivision {
        vertices: vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0], [2.0, 2.0], [4.0, 2.0], [2.0, 4.0]],
        edges: vec![[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 4]],
    };
    let f = extract_faces(&sub);
    assert_eq!(f.components, 2);
    assert_eq!(f.regions.len(), 2);
    assert!(f.euler_holds());
    let big = f.regions.iter().position(|r| r.holes.len() == 1).unwrap();
    assert_eq!(f.regions[big].area, 98.0);
    assert_eq!(f.outer_boundaries.len(), 1);
    let small = 1 - big;
    assert!(!f.regions[small].touches_outer);
    assert!(f.regions[big].touches_outer);
    let total: f64 = f.regions.iter().map(|r| r.area).sum();
    assert_eq!(total, f.outer_area(&sub));
}

#[test]
fn dangling_edges_are_pruned_before_tracing() {
    let mut sub = rect_grid(3, 3, 5.0);
    let n = sub.vertices.len();
    sub.vertices.push([7.0, 3.0]);
    sub.edges.push([5, n]);
    sub.vertices.push([-4.0, -4.0]);
    sub.edges.push([0, n + 1]);
    let (cleaned, f) = analyse_faces(&sub, &FaceOptions::default()).unwrap();
    assert_eq!(cleaned.pruned_edges.len(), 2);
    assert_eq!(f.regions.len(), 9);
    check_invariants(&cleaned.subdivision, &f);
}

#[test]
fn f1_import_of_standins() {
    use crate::synth::structure::fixtures::standins;
    use crate::synth::structure::format::{parse_structure_file, to_json_sized};
    for s in [
        standins::wall_random(&Default::default(), 4),
        standins::wall_layered(&Default::default(), 4),
        standins::cells_iso(&Default::default(), 4),
        standins::scales_diag(&Default::default(), 4),
    ] {
        let text = to_json_sized(&s.subdivision, [s.width as f64, s.height as f64]);
        let file = parse_structure_file(&text).unwrap();
        let opts = FaceOptions { sample_size: file.size, border_tol: 1e-6 };
        let (cleaned, f) = analyse_faces(&file.subdivision, &opts).unwrap();
        check_invariants(&cleaned.subdivision, &f);
        assert_eq!(f.regions.len(), s.mesh.regions.len(), "{}", s.name);
        let total: f64 = f.regions.iter().map(|r| r.area).sum();
        let full = (s.width * s.height) as f64;
        let rel = (total - f.outer_area(&cleaned.subdivision)).abs() / full;
        eprintln!(
            "F1 {}: R {} V {} E {} (Euler ok), area rel. error {rel:.1e}",
            s.name,
            f.regions.len(),
            f.vertex_count,
            f.edge_count
        );
        assert!((total - full).abs() < 1e-6 * full);
        // Border flags: exactly the regions with a vertex on the rectangle. (A region can
        // touch it at a vertex only, without an edge on the outer face, so `touches_outer`
        // alone may flag fewer.)
        let border = s.border_regions();
        let outer = f.regions.iter().filter(|r| r.touches_outer).count();
        assert_eq!(
            f.regions.iter().filter(|r| r.is_border()).count(),
            border.iter().filter(|&&b| b).count(),
            "{}",
            s.name
        );
        assert!(outer <= border.iter().filter(|&&b| b).count());
    }
}

#[test]
fn sample_border_flag() {
    let sub = rect_grid(3, 3, 10.0);
    let f = extract_faces_with(&sub, &FaceOptions { sample_size: Some([30.0, 21.0]), border_tol: 0.5 });
    assert_eq!(f.regions.iter().filter(|r| r.touches_sample_border).count(), 8);
    assert!(f.regions.iter().all(|r| r.touches_sample_border == r.touches_outer));
}
