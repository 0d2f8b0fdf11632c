//! Unit tests of the label-image import: blocks, islands, diagonal touches, discs, and a stand-in's labels round trip (in their own file because the fixtures build on this import).

use super::*;
use crate::synth::structure::fixtures::standins;
use crate::synth::structure::mesh::faces::extract_faces;

fn check_valid(sub: &Subdivision) -> Faces {
    let cleaned = validate::clean(sub).expect("valid import");
    assert!(cleaned.pruned_edges.is_empty() && cleaned.duplicate_edges.is_empty());
    let f = extract_faces(sub);
    assert!(f.euler_holds());
    f
}

#[test]
fn two_by_two_blocks() {
    // 4 quadrants of a 10×8 image: one interior junction, 4 border junctions, 4 corners.
    let (w, h) = (10, 8);
    let ids: Vec<u32> = (0..w * h).map(|i| ((i % w) / 5 + 2 * ((i / w) / 4)) as u32).collect();
    let sub = import_labels(&ids, w, h, 1.0).unwrap();
    let f = check_valid(&sub);
    assert_eq!(f.regions.len(), 4);
    assert_eq!(sub.vertices.len(), 9);
    assert_eq!(sub.edges.len(), 12);
    let total: f64 = f.regions.iter().map(|r| r.area).sum();
    assert_eq!(total, 80.0);
    let labels = face_labels(&ids, w, h, &sub, &f);
    let mut sorted = labels.clone();
    sorted.sort_unstable();
    assert_eq!(sorted, vec![0, 1, 2, 3]);
}

#[test]
fn island_and_single_region() {
    let (w, h) = (12, 12);
    let ids: Vec<u32> = (0..w * h).map(|i| u32::from((3..8).contains(&(i % w)) && (4..9).contains(&(i / w)))).collect();
    let sub = import_labels(&ids, w, h, 0.6).unwrap();
    let f = check_valid(&sub);
    assert_eq!(f.regions.len(), 2);
    assert_eq!(f.components, 2);
    let outer = f.regions.iter().find(|r| r.holes.len() == 1).unwrap();
    assert_eq!(outer.area, 144.0 - 25.0);
    // A single label: the image rectangle.
    let sub = import_labels(&[5; 20], 5, 4, 1.0).unwrap();
    assert_eq!(sub.vertices.len(), 4);
    let f = check_valid(&sub);
    assert_eq!(f.regions[0].area, 20.0);
    assert!(import_labels(&[NO_REGION; 6], 3, 2, 1.0).is_err());
}

#[test]
fn diagonal_touch_and_disc() {
    // A disc (simplified loop) and a checkerboard corner.
    let (w, h) = (40, 40);
    let mut ids = vec![0u32; w * h];
    for y in 0..h {
        for x in 0..w {
            let (dx, dy) = (x as f64 + 0.5 - 20.0, y as f64 + 0.5 - 20.0);
            if dx * dx + dy * dy < 144.0 {
                ids[y * w + x] = 1;
            }
        }
    }
    ids[0] = 2;
    ids[w + 1] = 2;
    let count = ids.iter().filter(|&&l| l == 1).count() as f64;
    for tol in [0.0, 0.5, 1.0, 2.0] {
        let sub = import_labels(&ids, w, h, tol).unwrap();
        let f = check_valid(&sub);
        assert_eq!(f.regions.len(), 4, "tol {tol}");
        let disc = f.regions.iter().map(|r| r.area).filter(|&a| a > 300.0 && a < 600.0).collect::<Vec<_>>();
        assert_eq!(disc.len(), 1);
        // Exact at tolerance 0; otherwise the boundary moves by at most `tol` px along a
        // perimeter of about 2π·12 px (the bound is loose: chords cut both ways).
        if tol == 0.0 {
            assert_eq!(disc[0], count);
        }
        assert!((disc[0] - count).abs() <= 0.5 * 2.0 * std::f64::consts::PI * 12.0 * tol, "{} vs {count}", disc[0]);
    }
}

fn count_4_components(l: &Labels) -> usize {
    let (w, h) = (l.width, l.height);
    let mut seen = vec![false; w * h];
    let mut n = 0;
    let mut stack = Vec::new();
    for start in 0..w * h {
        if seen[start] {
            continue;
        }
        n += 1;
        seen[start] = true;
        stack.push(start);
        while let Some(i) = stack.pop() {
            let (x, y) = (i % w, i / w);
            let mut nb = Vec::with_capacity(4);
            if x > 0 {
                nb.push(i - 1);
            }
            if x + 1 < w {
                nb.push(i + 1);
            }
            if y > 0 {
                nb.push(i - w);
            }
            if y + 1 < h {
                nb.push(i + w);
            }
            for j in nb {
                if !seen[j] && l.data[j] == l.data[i] {
                    seen[j] = true;
                    stack.push(j);
                }
            }
        }
    }
    n
}

#[test]
fn standin_labels_roundtrip() {
    for (name, s) in [
        ("wall_random", standins::wall_random(&Default::default(), 3)),
        ("cells_iso", standins::cells_iso(&Default::default(), 3)),
        ("scales_diag", standins::scales_diag(&Default::default(), 3)),
    ] {
        let truth = s.rasterize();
        let sub = import_labels(&truth.data, truth.width, truth.height, 1.0).unwrap();
        let f = check_valid(&sub);
        // Each 4-connected component of the ground-truth raster must come back as one
        // face. (A region can rasterise into several components where a bent edge leaves
        // a neck thinner than a pixel, so components, not regions, are compared.)
        let mut present: Vec<usize> = vec![0; s.mesh.regions.len()];
        for &l in &truth.data {
            present[l as usize] += 1;
        }
        let components = count_4_components(&truth);
        assert_eq!(f.regions.len(), components, "{name}: faces vs components");
        let with_pixels = present.iter().filter(|&&c| c > 0).count();
        let fl = face_labels(&truth.data, truth.width, truth.height, &sub, &f);
        let mut seen = fl.clone();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), with_pixels, "{name}: every region has a face");
        eprintln!("{name}: {} regions, {} with pixels, {} components", s.mesh.regions.len(), with_pixels, components);
        // IoU between each face's raster and its region's raster.
        let polys: Vec<Vec<Point>> = (0..f.regions.len()).map(|r| f.polygon(&sub, r)).collect();
        let fr = rasterize_polygons(&polys, truth.width, truth.height);
        let n = s.mesh.regions.len();
        let mut inter = vec![0usize; n];
        let mut face_px = vec![0usize; n];
        for (i, &t) in truth.data.iter().enumerate() {
            let g = fr.data[i];
            if g != NO_REGION {
                let lab = fl[g as usize] as usize;
                face_px[lab] += 1;
                if lab == t as usize {
                    inter[lab] += 1;
                }
            }
        }
        let iou = |r: usize| inter[r] as f64 / (present[r] + face_px[r] - inter[r]) as f64;
        let mut ious: Vec<f64> = (0..n).filter(|&r| present[r] >= 100).map(iou).collect();
        ious.sort_by(f64::total_cmp);
        let (min, med) = (ious[0], ious[ious.len() / 2]);
        let min_big = (0..n).filter(|&r| present[r] >= 500).map(iou).fold(1.0f64, f64::min);
        eprintln!(
            "{name}: {} faces, IoU (≥100 px) min {min:.4} median {med:.4}; min (≥500 px) {min_big:.4}",
            f.regions.len()
        );
        // Douglas–Peucker at 1 px moves the boundary by up to 1 px, which costs small
        // regions (100 px triangles of cells_iso) about 10 % IoU; large ones lose < 5 %.
        assert!(min > 0.85 && med > 0.97 && min_big > 0.93, "{name}: IoU min {min} median {med} big {min_big}");
    }
}
