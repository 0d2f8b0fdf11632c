//! Unit tests of the discrete Voronoi diagrams: flooding against argmin and a brute force,
//! connectivity, scale invariance, forbidden pixels, the queue order, and the certified flood
//! against a reference flood.

use super::*;
use crate::synth::rng::Rng;
use std::f64::consts::PI;

/// Naive per-pixel argmin over all sites (test oracle).
fn brute_force(domain: &Domain, sites: &[Site], kind: MetricKind) -> Vec<u32> {
    let prepared: Vec<Prepared> = sites.iter().map(Prepared::new).collect();
    let mut out = vec![NO_REGION; domain.width * domain.height];
    for y in 0..domain.height {
        for x in 0..domain.width {
            let i = y * domain.width + x;
            if domain.allowed.is_some_and(|a| !a[i]) {
                continue;
            }
            let k = domain.metric_map.map_or(kind, |m| m[i]);
            let mut best = (f64::INFINITY, NO_REGION);
            for (g, s) in prepared.iter().enumerate() {
                let d = s.distance(k, x as f64 + 0.5, y as f64 + 0.5);
                if d < best.0 {
                    best = (d, g as u32);
                }
            }
            out[i] = best.1;
        }
    }
    out
}

pub(crate) fn random_ellipses(rng: &mut Rng, n: usize, w: usize, h: usize, amin: f64, amax: f64) -> Vec<Ellipse> {
    (0..n)
        .map(|_| {
            let a = rng.range(amin, amax);
            let b = a / rng.range(1.0, 3.0);
            Ellipse { center: [rng.range(0.0, w as f64), rng.range(0.0, h as f64)], a, b, theta: rng.range(0.0, PI) }
        })
        .collect()
}

fn agreement(a: &[u32], b: &[u32]) -> f64 {
    a.iter().zip(b).filter(|(x, y)| x == y).count() as f64 / a.len() as f64
}

/// Checks 8-connectivity of every region and that it contains its seed pixel.
fn regions_connected_with_seed(labels: &Labels, ellipses: &[Ellipse], orphans: &[usize]) -> Result<(), String> {
    let (w, h) = (labels.width, labels.height);
    let domain = Domain::new(w, h);
    let n = ellipses.len();
    let sizes = region_sizes(labels, n);
    let mut seen = vec![false; w * h];
    for (g, e) in ellipses.iter().enumerate() {
        if orphans.contains(&g) {
            if sizes[g] != 0 {
                return Err(format!("orphan {g} has pixels"));
            }
            continue;
        }
        let s = seed_pixel(&domain, e.center);
        if labels.data[s] != g as u32 {
            return Err(format!("generator {g} not in its seed pixel"));
        }
        let mut stack = vec![s];
        seen[s] = true;
        let mut count = 0;
        while let Some(p) = stack.pop() {
            count += 1;
            let (x, y) = ((p % w) as i64, (p / w) as i64);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                        continue;
                    }
                    let q = ny as usize * w + nx as usize;
                    if !seen[q] && labels.data[q] == g as u32 {
                        seen[q] = true;
                        stack.push(q);
                    }
                }
            }
        }
        if count != sizes[g] {
            return Err(format!("region {g} not 8-connected: {count} of {}", sizes[g]));
        }
    }
    Ok(())
}

/// F5: Euclidean special case (equal circles): flooding matches brute-force argmin.
#[test]
fn f5_euclidean_flooding_matches_argmin() {
    let (w, h) = (256, 192);
    let domain = Domain::new(w, h);
    let mut rng = Rng::new(55);
    let mut worst: f64 = 1.0;
    for _ in 0..5 {
        let sites: Vec<Site> = (0..120)
            .map(|_| {
                Site::Ellipse(Ellipse {
                    center: [rng.range(0.0, w as f64), rng.range(0.0, h as f64)],
                    a: 10.0,
                    b: 10.0,
                    theta: 0.0,
                })
            })
            .collect();
        let grow = voronoi(&domain, &sites, &VoronoiParams::default());
        let brute = brute_force(&domain, &sites, MetricKind::Elliptic);
        worst = worst.min(agreement(&grow.labels.data, &brute));
    }
    eprintln!(
        "F5 euclidean agreement (worst of 5): {:.6} ({:.0} of {} px differ)",
        worst,
        (1.0 - worst) * (w * h) as f64,
        w * h
    );
    assert!(worst >= 0.995, "agreement {worst}");
}

/// The tile-pruned argmin mode is exactly the naive argmin (all kinds, masks, maps).
#[test]
fn argmin_mode_is_exact() {
    let (w, h) = (150, 110);
    let mut rng = Rng::new(5);
    let ellipses = random_ellipses(&mut rng, 60, w, h, 4.0, 20.0);
    let mut sites: Vec<Site> = ellipses.iter().map(|e| Site::Ellipse(*e)).collect();
    sites.push(Site::Segment([[10.0, 10.0], [80.0, 40.0]]));
    let allowed: Vec<bool> = (0..w * h).map(|i| (i % w) < 120 || (i / w) > 30).collect();
    let map: Vec<MetricKind> = (0..w * h)
        .map(|i| [MetricKind::Elliptic, MetricKind::Manhattan, MetricKind::Chebyshev][(i % w) * 3 / w])
        .collect();
    for kind in [MetricKind::Elliptic, MetricKind::Manhattan, MetricKind::Chebyshev] {
        for (al, mm) in [(None, None), (Some(&allowed[..]), None), (Some(&allowed[..]), Some(&map[..]))] {
            let domain = Domain::new(w, h).with_allowed(al).with_metric_map(mm);
            let params = VoronoiParams { mode: VoronoiMode::Argmin, metric: kind };
            let fast = voronoi(&domain, &sites, &params);
            let slow = brute_force(&domain, &sites, kind);
            assert_eq!(fast.labels.data, slow, "kind {kind:?}");
        }
    }
}

/// F5: every region is 8-connected and contains its seed pixel (elliptic metric, random
/// ellipses, 100 trials); also all allowed pixels are labelled.
#[test]
fn f5_regions_connected_and_contain_seed() {
    let (w, h) = (128, 96);
    let domain = Domain::new(w, h);
    let mut rng = Rng::new(500);
    let mut agree_min: f64 = 1.0;
    for trial in 0..100 {
        let n = 10 + rng.below(50);
        let ellipses = random_ellipses(&mut rng, n, w, h, 3.0, 30.0);
        let vd = voronoi_ellipses(&domain, &ellipses, &VoronoiParams::default());
        regions_connected_with_seed(&vd.labels, &ellipses, &vd.orphans)
            .unwrap_or_else(|e| panic!("trial {trial}: {e}"));
        // Orphans only from shared seed pixels.
        for &o in &vd.orphans {
            let s = seed_pixel(&domain, ellipses[o].center);
            assert!((0..o).any(|g| seed_pixel(&domain, ellipses[g].center) == s));
        }
        assert!(vd.labels.data.iter().all(|&l| l != NO_REGION));
        let am =
            voronoi_ellipses(&domain, &ellipses, &VoronoiParams { mode: VoronoiMode::Argmin, ..Default::default() });
        agree_min = agree_min.min(agreement(&vd.labels.data, &am.labels.data));
    }
    eprintln!("F5 elliptic growth vs argmin agreement (min over 100 trials): {agree_min:.4}");
}

/// F5: segment generators vs the point-to-segment argmin (≥ 99 %).
#[test]
fn f5_segments_match_argmin() {
    let (w, h) = (256, 256);
    let domain = Domain::new(w, h);
    let mut rng = Rng::new(35);
    let mut worst: f64 = 1.0;
    for _ in 0..5 {
        let sites: Vec<Site> = (0..25)
            .map(|_| {
                let c = [rng.range(0.0, w as f64), rng.range(0.0, h as f64)];
                let len = rng.range(5.0, 40.0);
                let t = rng.range(0.0, PI);
                let d = [0.5 * len * t.cos(), 0.5 * len * t.sin()];
                Site::Segment([[c[0] - d[0], c[1] - d[1]], [c[0] + d[0], c[1] + d[1]]])
            })
            .collect();
        let grow = voronoi(&domain, &sites, &VoronoiParams::default());
        let brute = brute_force(&domain, &sites, MetricKind::Elliptic);
        worst = worst.min(agreement(&grow.labels.data, &brute));
    }
    eprintln!(
        "F5 segment agreement (worst of 5): {worst:.6} ({:.0} of {} px differ)",
        (1.0 - worst) * (w * h) as f64,
        w * h
    );
    assert!(worst >= 0.99, "agreement {worst}");
}

/// F6: scaling all ellipses by 0.5 and 2 leaves the labels bit-identical in both modes.
#[test]
fn f6_global_scale_leaves_labels_identical() {
    let (w, h) = (200, 150);
    let domain = Domain::new(w, h);
    let mut rng = Rng::new(66);
    let ellipses = random_ellipses(&mut rng, 80, w, h, 3.0, 25.0);
    for mode in [VoronoiMode::Growth, VoronoiMode::Argmin] {
        for kind in [MetricKind::Elliptic, MetricKind::Manhattan, MetricKind::Chebyshev] {
            let params = VoronoiParams { mode, metric: kind };
            let base = voronoi_ellipses(&domain, &ellipses, &params);
            for k in [0.5, 2.0] {
                let scaled: Vec<Ellipse> = ellipses.iter().map(|e| Ellipse { a: e.a * k, b: e.b * k, ..*e }).collect();
                let other = voronoi_ellipses(&domain, &scaled, &params);
                assert_eq!(base, other, "mode {mode:?} kind {kind:?} scale {k}");
            }
        }
    }
}

#[test]
fn forbidden_pixels_never_labelled_and_orphans_reported() {
    let (w, h) = (100, 80);
    let allowed: Vec<bool> =
        (0..w * h).map(|i| !((30..60).contains(&(i % w)) && (20..50).contains(&(i / w)))).collect();
    let domain = Domain::new(w, h).with_allowed(Some(&allowed));
    let ellipses = vec![
        Ellipse { center: [10.5, 10.5], a: 8.0, b: 4.0, theta: 0.3 },
        Ellipse { center: [45.0, 35.0], a: 8.0, b: 4.0, theta: 0.3 }, // forbidden seed
        Ellipse { center: [80.5, 60.5], a: 8.0, b: 8.0, theta: 0.0 },
        Ellipse { center: [10.7, 10.2], a: 8.0, b: 4.0, theta: 0.3 }, // shares seed with 0
    ];
    for mode in [VoronoiMode::Growth, VoronoiMode::Argmin] {
        let vd = voronoi_ellipses(&domain, &ellipses, &VoronoiParams { mode, ..Default::default() });
        for (i, (&l, &ok)) in vd.labels.data.iter().zip(&allowed).enumerate() {
            assert_eq!(l == NO_REGION, !ok, "pixel {i}");
        }
        if mode == VoronoiMode::Growth {
            assert_eq!(vd.orphans, vec![1, 3]);
        }
    }
}

#[test]
fn queue_pops_in_global_order_with_nonmonotone_pushes() {
    let mut q = BucketQueue::default();
    q.reset(1.0);
    let mut rng = Rng::new(1);
    let mut reference = Vec::new();
    let mut popped = Vec::new();
    let mut pending: Vec<u128> = Vec::new();
    for step in 0..20000u32 {
        if step % 3 != 2 {
            let k = rng.range(0.0, 3.0);
            let e = ((k.to_bits() as u128) << 64) | step as u128;
            q.push(e, k);
            pending.push(e);
        } else if let Some(e) = q.pop() {
            popped.push(e);
            let (mi, _) = pending.iter().enumerate().min_by_key(|(_, &v)| v).unwrap();
            reference.push(pending.swap_remove(mi));
        }
    }
    assert_eq!(popped, reference);
}

/// F8: fit ellipses to a ground-truth tiling, rebuild the anisotropic VD (no Lloyd):
/// median IoU of interior regions ≥ 0.75 and valency 3 at ≥ 95 % of junction corners.
#[test]
fn f8_fit_then_voronoi() {
    use crate::synth::structure::fixtures::ellipses::fit_regions;
    let (w, h) = (480, 400);
    let mut rng = Rng::new(80);
    // Ground truth 1: Euclidean Voronoi of a jittered grid (cells-like).
    let mut pts = Vec::new();
    for gy in 0..12 {
        for gx in 0..14 {
            let c = [
                (gx as f64 + 0.5 + rng.range(-0.35, 0.35)) * w as f64 / 14.0,
                (gy as f64 + 0.5 + rng.range(-0.35, 0.35)) * h as f64 / 12.0,
            ];
            pts.push(Site::Ellipse(Ellipse { center: c, a: 1.0, b: 1.0, theta: 0.0 }));
        }
    }
    let cells =
        voronoi(&Domain::new(w, h), &pts, &VoronoiParams { mode: VoronoiMode::Argmin, ..Default::default() }).labels;
    // Ground truth 2: a running-bond brick wall (courses of 40 px, bricks 70–110 px).
    let mut bricks = vec![0u32; w * h];
    let mut next = 0u32;
    for course in 0..10 {
        let mut x = -(rng.range(0.0, 60.0) as i64);
        let mut row_ids = Vec::new();
        while x < w as i64 {
            let len = rng.range(70.0, 110.0) as i64;
            row_ids.push((x, x + len, next));
            next += 1;
            x += len;
        }
        for y in course * 40..(course + 1) * 40 {
            for xx in 0..w {
                let id = row_ids.iter().find(|r| (xx as i64) >= r.0 && (xx as i64) < r.1).unwrap().2;
                bricks[y * w + xx] = id;
            }
        }
    }
    let bricks = Labels { width: w, height: h, data: bricks };
    for (name, gt, n) in [("cells", &cells, pts.len()), ("bricks", &bricks, next as usize)] {
        let fits = fit_regions(gt, n);
        let ellipses: Vec<Ellipse> = fits.iter().map(|f| f.unwrap().ellipse).collect();
        let vd = voronoi_ellipses(&Domain::new(w, h), &ellipses, &VoronoiParams::default());
        let mut inter = vec![0usize; n];
        let mut uni = vec![0usize; n];
        for (&a, &b) in gt.data.iter().zip(&vd.labels.data) {
            if a == b {
                inter[a as usize] += 1;
                uni[a as usize] += 1;
            } else {
                uni[a as usize] += 1;
                uni[b as usize] += 1;
            }
        }
        let mut iou: Vec<f64> =
            (0..n).filter(|&i| !fits[i].unwrap().border).map(|i| inter[i] as f64 / uni[i] as f64).collect();
        iou.sort_by(f64::total_cmp);
        let median = iou[iou.len() / 2];
        let (mut v3, mut v4) = (0, 0);
        for y in 1..h {
            for x in 1..w {
                let mut q = [
                    vd.labels.get(x - 1, y - 1),
                    vd.labels.get(x, y - 1),
                    vd.labels.get(x - 1, y),
                    vd.labels.get(x, y),
                ];
                q.sort_unstable();
                let distinct = 1 + q.windows(2).filter(|p| p[0] != p[1]).count();
                match distinct {
                    3 => v3 += 1,
                    4 => v4 += 1,
                    _ => {}
                }
            }
        }
        let share3 = v3 as f64 / (v3 + v4) as f64;
        eprintln!("F8 {name}: {} interior regions, median IoU {median:.3} (min {:.3}), valency-3 share {share3:.4} ({v3} / {})", iou.len(), iou[0], v3 + v4);
        assert!(median >= 0.75);
        assert!(share3 >= 0.95);
    }
}

/// Textbook flooding (one global binary heap, every unlabelled neighbour pushed, no
/// pruning) as the reference for the optimised queue.
fn reference_flood(domain: &Domain, ellipses: &[Ellipse], kind: MetricKind) -> Vec<u32> {
    use std::cmp::Reverse;
    let (w, h) = (domain.width, domain.height);
    let frames: Vec<EllipseFrame> = ellipses.iter().map(EllipseFrame::new).collect();
    let ok = |i: usize| domain.allowed.is_none_or(|a| a[i]);
    let d = |g: usize, i: usize| {
        let k = domain.metric_map.map_or(kind, |m| m[i]);
        frames[g].distance(k, (i % w) as f64 + 0.5, (i / w) as f64 + 0.5)
    };
    let mut lab = vec![NO_REGION; w * h];
    let mut heap = std::collections::BinaryHeap::new();
    let push_nb =
        |p: usize, g: usize, lab: &Vec<u32>, heap: &mut std::collections::BinaryHeap<Reverse<(u64, u32, usize)>>| {
            let (x, y) = ((p % w) as i64, (p / w) as i64);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (nx, ny) = (x + dx, y + dy);
                    if (dx, dy) == (0, 0) || nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                        continue;
                    }
                    let q = ny as usize * w + nx as usize;
                    if lab[q] == NO_REGION && ok(q) {
                        heap.push(Reverse((d(g, q).to_bits(), g as u32, q)));
                    }
                }
            }
        };
    let mut seeded = Vec::new();
    for (g, e) in ellipses.iter().enumerate() {
        let s = seed_pixel(domain, e.center);
        if lab[s] == NO_REGION && ok(s) {
            lab[s] = g as u32;
            seeded.push((s, g));
        }
    }
    for (s, g) in seeded {
        push_nb(s, g, &lab, &mut heap);
    }
    while let Some(Reverse((_, g, p))) = heap.pop() {
        if lab[p] == NO_REGION {
            lab[p] = g;
            push_nb(p, g as usize, &lab, &mut heap);
        }
    }
    lab
}

/// The optimised flood (bucketed queue, pruned pushes) equals textbook flooding bit for
/// bit, with masks and metric maps, including heavy ties (equal circles on a lattice).
#[test]
fn flood_equals_reference() {
    let mut rng = Rng::new(9);
    for trial in 0..30 {
        let (w, h) = (40 + rng.below(80), 30 + rng.below(80));
        let n = 3 + rng.below(40);
        let mut ellipses = random_ellipses(&mut rng, n, w, h, 1.0, 25.0);
        if trial % 5 == 0 {
            // Lattice of equal circles: many exactly equal keys.
            for (i, e) in ellipses.iter_mut().enumerate() {
                *e = Ellipse {
                    center: [(i % 6) as f64 * 9.0 + 4.5, (i / 6) as f64 * 9.0 + 4.5],
                    a: 3.0,
                    b: 3.0,
                    theta: 0.0,
                };
            }
        }
        let allowed: Vec<bool> = (0..w * h).map(|_| rng.below(10) != 0).collect();
        let map: Vec<MetricKind> = (0..w * h)
            .map(|_| [MetricKind::Elliptic, MetricKind::Manhattan, MetricKind::Chebyshev][rng.below(3)])
            .collect();
        let kind = [MetricKind::Elliptic, MetricKind::Manhattan, MetricKind::Chebyshev][trial % 3];
        for (al, mm) in
            [(None, None), (Some(&allowed[..]), None), (None, Some(&map[..])), (Some(&allowed[..]), Some(&map[..]))]
        {
            let domain = Domain::new(w, h).with_allowed(al).with_metric_map(mm);
            let fast = voronoi_ellipses(&domain, &ellipses, &VoronoiParams { mode: VoronoiMode::Growth, metric: kind });
            assert_eq!(fast.labels.data, reference_flood(&domain, &ellipses, kind), "trial {trial}");
        }
    }
}

/// On larger diagrams with elongated ellipses (axis ratio up to 6) the advance labelling
/// decides most pixels, and the flood still equals textbook flooding, on 1 and 3 threads.
#[test]
fn certified_flood_equals_reference_on_large_elongated_diagrams() {
    let mut rng = Rng::new(41);
    for trial in 0..6 {
        let (w, h) = (200 + rng.below(100), 150 + rng.below(100));
        let mut ellipses = random_ellipses(&mut rng, 60, w, h, 4.0, 30.0);
        for e in &mut ellipses {
            e.b = e.a / rng.range(1.0, 6.0);
        }
        let kind = [MetricKind::Elliptic, MetricKind::Manhattan, MetricKind::Chebyshev][trial % 3];
        let domain = Domain::new(w, h);
        let params = VoronoiParams { mode: VoronoiMode::Growth, metric: kind };
        let reference = reference_flood(&domain, &ellipses, kind);
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let fast = pool.install(|| voronoi_ellipses(&domain, &ellipses, &params));
            assert_eq!(fast.labels.data, reference, "trial {trial}, {threads} threads");
        }
        // How much the advance labelling decided.
        let prepared: Vec<Prepared> = ellipses.iter().map(|e| Prepared::Ellipse(EllipseFrame::new(e))).collect();
        let (mut al, mut ad) = (Vec::new(), Vec::new());
        argmin_labels(&domain, &prepared, kind, &mut al, &mut ad);
        let seeds: Vec<usize> = ellipses.iter().map(|e| seed_pixel(&domain, e.center)).collect();
        let mut label = vec![NO_REGION; w * h];
        let mut seeded = Vec::new();
        for (g, &s) in seeds.iter().enumerate() {
            if label[s] == NO_REGION {
                label[s] = g as u32;
                seeded.push(g);
            }
        }
        let fronts = certify_regions(&mut label, &al, &ad, &seeds, &seeded, w);
        let decided = label.iter().filter(|&&l| l != NO_REGION).count() as f64 / (w * h) as f64;
        eprintln!("trial {trial} ({kind:?}): {:.1} % decided in advance, {} fronts", decided * 100.0, fronts.len());
        assert!(decided > 0.6, "only {decided} decided in advance");
    }
}
