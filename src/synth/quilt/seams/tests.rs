//! Unit tests of seam removal: every block's reach is covered, interiors stay bit-identical
//! while the seam energy drops, tileability is kept, every channel converges, large overlaps
//! work, results do not depend on the thread count, and invalid inputs give their error.

use super::super::{quilt, quilt_with, Orientation, QuiltOptions, QuiltParams};
use super::*;
use crate::synth::blend::{BlendError, SolverKind};

/// The quilt tests' smooth noise under a strong horizontal brightness ramp, one field per
/// channel: quilting it leaves clearly visible seams.
fn ramp_texture(n: usize, channels: usize, seed: u64) -> Image {
    let noise = crate::synth::quilt::tests::noise_texture(n, channels, 8, seed);
    Image::from_fn(n, n, channels, |x, y, c| {
        let t = x as f32 / n as f32;
        let ramp = if c % 2 == 0 { t } else { 1.0 - t };
        0.3 * noise.get(x, y, c) + 0.7 * ramp
    })
}

fn params(w: usize, h: usize, block: usize, overlap: usize, tileable: bool, seed: u64) -> QuiltParams {
    let mut p = QuiltParams::new(w, h, block, seed);
    p.overlap = overlap;
    p.tolerance = 1.0;
    p.tileable = tileable;
    p
}

fn bits(img: &Image) -> Vec<u32> {
    img.data.iter().map(|v| v.to_bits()).collect()
}

/// Label-seam edges `(p, q)` (right and down, wrapping on the torus).
fn seam_edges(labels: &[u32], w: usize, h: usize, wrap: bool) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            for (q, dx, dy) in neighbours(x, y, w, h, wrap) {
                if (dx, dy) >= (0, 0) && labels[p] != labels[q] {
                    out.push((p, q));
                }
            }
        }
    }
    out
}

/// Mean over the given seam edges and channels of `(f(q) − f(p) − v_pq)²`, `v` the averaged
/// guidance: how far the output's differences across seams are from the sources' own.
fn seam_energy(img: &Image, cls: &Classes, edges: &[(usize, usize)]) -> f64 {
    let n = img.plane_len();
    let mut acc = 0.0;
    for &(p, q) in edges {
        for c in 0..img.channels {
            let s = |l: u32, i: usize| f64::from(cls.images[l as usize].data[c * n + i]);
            let (lp, lq) = (cls.labels[p], cls.labels[q]);
            let v = 0.5 * ((s(lp, q) - s(lp, p)) + (s(lq, q) - s(lq, p)));
            let d = f64::from(img.data[c * n + q]) - f64::from(img.data[c * n + p]);
            acc += (d - v) * (d - v);
        }
    }
    acc / (edges.len() * img.channels).max(1) as f64
}

/// Independent check of the reach: for every pixel p and every neighbour q, class image L(p) at
/// q (and at p) holds block(p)'s source at `(sx, sy) + (q − block corner)`, from the block record.
fn assert_reach_covered(r: &QuiltResult, samples: &[&Image], cls: &Classes) {
    let (w, h, n) = (r.image.width, r.image.height, r.image.plane_len());
    let copies: Vec<(Image, Vec<bool>)> = r
        .sources
        .iter()
        .map(|s| {
            let sample = samples[s.sample];
            if s.angle == 0.0 {
                (sample.clone(), vec![true; sample.plane_len()])
            } else {
                rotate_sample(sample, s.angle)
            }
        })
        .collect();
    let mut checked = 0usize;
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            let rec = &r.blocks[r.index.block[p] as usize];
            let class = &cls.images[cls.labels[p] as usize];
            assert_eq!(cls.labels[p], cls.of_block[r.index.block[p] as usize]);
            let targets = std::iter::once((p, 0i64, 0i64)).chain(neighbours(x, y, w, h, r.tileable));
            for (q, _, _) in targets {
                let (qx, qy) = ((q % w) as i64, (q / w) as i64);
                // Offset from the block corner, unwrapped into [−1, size − 2].
                let off = |v: i64, corner: usize, size: usize| {
                    let d = if r.tileable { (v - corner as i64).rem_euclid(size as i64) } else { v - corner as i64 };
                    if d == size as i64 - 1 && r.tileable {
                        -1
                    } else {
                        d
                    }
                };
                let (sx, sy) = (rec.sx as i64 + off(qx, rec.x, w), rec.sy as i64 + off(qy, rec.y, h));
                let (src, valid) = &copies[rec.source];
                let inside = sx >= 0 && sy >= 0 && sx < src.width as i64 && sy < src.height as i64;
                if !inside || !valid[sy as usize * src.width + sx as usize] {
                    continue;
                }
                for c in 0..r.image.channels {
                    let want = src.get(sx as usize, sy as usize, c);
                    assert_eq!(class.data[c * n + q].to_bits(), want.to_bits(), "p=({x},{y}) q={q} c{c}");
                }
                checked += 1;
            }
        }
    }
    assert!(checked > 4 * w * h, "checked {checked}");
}

fn quilt_ramp(tileable: bool, block: usize, overlap: usize) -> (Image, QuiltResult) {
    let sample = ramp_texture(64, 3, 7);
    let r = quilt(&sample, &params(96, 80, block, overlap, tileable, 11)).unwrap();
    (sample, r)
}

#[test]
fn reach_of_every_block_is_covered() {
    for tileable in [false, true] {
        let (sample, r) = quilt_ramp(tileable, 24, 4);
        let cls = build_classes(&r, &[&sample]).unwrap();
        // Overlap < block/2: the 2×2 grid parity; on the 5×4-block torus the odd column count needs a third column class.
        println!("tileable {tileable}: {} blocks, {} classes", r.blocks.len(), cls.images.len());
        assert_eq!(cls.images.len(), if tileable { 6 } else { 4 });
        assert_reach_covered(&r, &[&sample], &cls);
    }
    // Rotated copies (quarter turns on the left half, an oblique angle on the right).
    let sample = ramp_texture(48, 2, 3);
    let field = Image::from_fn(64, 64, 1, |x, _, _| if x < 32 { std::f32::consts::FRAC_PI_2 } else { 0.7 });
    let o = QuiltOptions { orientation: Some(Orientation { field: &field, copies: 8 }), ..QuiltOptions::default() };
    let r = quilt_with(&[&sample], &params(64, 64, 12, 3, false, 5), &o).unwrap();
    assert!(r.blocks.iter().any(|b| r.sources[b.source].angle != 0.0));
    let cls = build_classes(&r, &[&sample]).unwrap();
    assert_reach_covered(&r, &[&sample], &cls);
    let d = remove_seams(&r, &[&sample], &SeamParams::default()).unwrap();
    assert!(d.reports.iter().all(|rep| rep.converged));
}

#[test]
fn interiors_are_bit_identical_and_seam_energy_drops() {
    let (sample, r) = quilt_ramp(false, 24, 4);
    let sp = SeamParams::default();
    let d = remove_seams(&r, &[&sample], &sp).unwrap();
    let cls = build_classes(&r, &[&sample]).unwrap();
    let (w, h, n) = (r.image.width, r.image.height, r.image.plane_len());
    // Chebyshev distance to the nearest label-seam pixel > radius ⇒ untouched.
    let seam: Vec<(i64, i64)> = seam_edges(&cls.labels, w, h, false)
        .into_iter()
        .flat_map(|(p, q)| [p, q])
        .map(|p| ((p % w) as i64, (p / w) as i64))
        .collect();
    let (mut kept, mut changed) = (0, 0);
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let p = y as usize * w + x as usize;
            let far = seam.iter().all(|&(sx, sy)| (sx - x).abs().max((sy - y).abs()) > sp.radius as i64);
            let same = (0..3).all(|c| d.image.data[c * n + p].to_bits() == r.image.data[c * n + p].to_bits());
            if far {
                assert!(same, "pixel ({x},{y}) is outside the band but changed");
                kept += 1;
            } else {
                changed += usize::from(!same);
            }
        }
    }
    assert!(kept > 0 && changed > 0, "kept {kept}, changed {changed}");
    let edges = seam_edges(&cls.labels, w, h, false);
    let (before, after) = (seam_energy(&r.image, &cls, &edges), seam_energy(&d.image, &cls, &edges));
    println!("open: seam energy {before:.3e} -> {after:.3e} (x{:.0}), {} edges", before / after, edges.len());
    assert!(after * 20.0 < before, "seam energy {before} -> {after}");
}

#[test]
fn tileable_quilt_stays_tileable() {
    let (sample, r) = quilt_ramp(true, 24, 4);
    let d = remove_seams(&r, &[&sample], &SeamParams::default()).unwrap();
    let cls = build_classes(&r, &[&sample]).unwrap();
    let (w, h) = (r.image.width, r.image.height);
    // Seam edges between the first and last block column or row: the torus-only seams.
    let grid = |pick: fn(&super::super::BlockRecord) -> usize| {
        let mut v: Vec<usize> = r.blocks.iter().map(pick).collect();
        v.sort_unstable();
        v.dedup();
        v
    };
    let (xs, ys) = (grid(|b| b.x), grid(|b| b.y));
    let cell = |p: usize| {
        let b = &r.blocks[r.index.block[p] as usize];
        (xs.binary_search(&b.x).unwrap(), ys.binary_search(&b.y).unwrap())
    };
    let across = |a: usize, b: usize, last: usize| a.min(b) == 0 && a.max(b) == last;
    let edges = seam_edges(&cls.labels, w, h, true);
    let wrap_edges: Vec<(usize, usize)> = edges
        .iter()
        .copied()
        .filter(|&(p, q)| {
            let ((px, py), (qx, qy)) = (cell(p), cell(q));
            across(px, qx, xs.len() - 1) || across(py, qy, ys.len() - 1)
        })
        .collect();
    assert!(!wrap_edges.is_empty());
    let (before, after) = (seam_energy(&r.image, &cls, &edges), seam_energy(&d.image, &cls, &edges));
    let (wb, wa) = (seam_energy(&r.image, &cls, &wrap_edges), seam_energy(&d.image, &cls, &wrap_edges));
    println!(
        "torus: seam energy {before:.3e} -> {after:.3e} (x{:.0}); wrap seams {wb:.3e} -> {wa:.3e} (x{:.0})",
        before / after,
        wb / wa
    );
    assert!(after * 20.0 < before && wa * 20.0 < wb);
    // The wrap column/row pair differs no more than typical neighbouring columns/rows.
    let msd = |a: (usize, usize), b: (usize, usize)| {
        let (ax, ay) = a;
        let (bx, by) = b;
        (0..3).map(|c| f64::from(d.image.get(ax, ay, c) - d.image.get(bx, by, c)).powi(2)).sum::<f64>()
    };
    let col = |x0: usize, x1: usize| (0..h).map(|y| msd((x0, y), (x1, y))).sum::<f64>() / h as f64;
    let row = |y0: usize, y1: usize| (0..w).map(|x| msd((x, y0), (x, y1))).sum::<f64>() / w as f64;
    let col_mean = (0..w - 1).map(|x| col(x, x + 1)).sum::<f64>() / (w - 1) as f64;
    let row_mean = (0..h - 1).map(|y| row(y, y + 1)).sum::<f64>() / (h - 1) as f64;
    println!(
        "wrap column {:.3e} vs mean {col_mean:.3e}; wrap row {:.3e} vs mean {row_mean:.3e}",
        col(w - 1, 0),
        row(h - 1, 0)
    );
    assert!(col(w - 1, 0) < 2.0 * col_mean && row(h - 1, 0) < 2.0 * row_mean);
}

#[test]
fn every_channel_converges() {
    // The blend refines its f32 solve until the f64 residual of the returned image meets
    // `tol`, so every report that says converged is within it.
    for (tileable, kind) in [(false, SolverKind::Mgpcg), (false, SolverKind::Multigrid), (true, SolverKind::Mgpcg)] {
        let tol = 1e-6;
        let (sample, r) = quilt_ramp(tileable, 24, 4);
        let sp = SeamParams { solver: Solver { kind, tol, ..Solver::default() }, ..SeamParams::default() };
        let d = remove_seams(&r, &[&sample], &sp).unwrap();
        assert_eq!(d.reports.len(), 3);
        for rep in &d.reports {
            println!(
                "tileable {tileable}, {kind:?}, tol {tol:.0e}: {} its, residual {:.2e}, max {:.2e}",
                rep.iterations, rep.residual, rep.max_residual
            );
            assert!(rep.converged && rep.residual <= tol && rep.unknowns > 0, "{rep:?}");
        }
    }
}

#[test]
fn large_overlaps_need_more_classes_but_work() {
    // overlap = block/2: blocks two apart touch, so the grid parity alone would not do.
    let (sample, r) = quilt_ramp(false, 16, 8);
    let cls = build_classes(&r, &[&sample]).unwrap();
    assert_reach_covered(&r, &[&sample], &cls);
    let d = remove_seams(&r, &[&sample], &SeamParams::default()).unwrap();
    let edges = seam_edges(&cls.labels, r.image.width, r.image.height, false);
    let (before, after) = (seam_energy(&r.image, &cls, &edges), seam_energy(&d.image, &cls, &edges));
    println!("overlap 8/16: {} classes, seam energy {before:.3e} -> {after:.3e}", d.classes);
    assert!(d.reports.iter().all(|rep| rep.converged) && after * 20.0 < before);
}

#[test]
fn bit_identical_for_1_and_2_threads() {
    let mut outs = Vec::new();
    for tileable in [false, true] {
        let (sample, r) = quilt_ramp(tileable, 24, 4);
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let d = pool.install(|| remove_seams(&r, &[&sample], &SeamParams::default()).unwrap());
            outs.push((tileable, bits(&d.image), d.reports));
        }
    }
    assert_eq!(outs[0], outs[1]);
    assert_eq!(outs[2], outs[3]);
}

#[test]
fn invalid_inputs_give_their_error() {
    let sample = ramp_texture(32, 3, 9);
    let p = params(48, 48, 12, 3, false, 1);
    let r = quilt(&sample, &p).unwrap();
    let sp = SeamParams::default();
    let mut mask = Image::filled(48, 48, 1, 1.0);
    for y in 20..30 {
        for x in 20..30 {
            mask.set(x, y, 0, 0.0);
        }
    }
    let holes =
        quilt_with(&[&sample], &p, &QuiltOptions { occupancy: Some(&mask), ..QuiltOptions::default() }).unwrap();
    let e = remove_seams(&holes, &[&sample], &sp).unwrap_err();
    assert_eq!(e, QuiltError::SeamsNeedFullCoverage { empty: 100 });
    assert_eq!(
        e.to_string(),
        "seam removal does not support occupancy masks yet: 100 output pixel(s) are empty; quilt without an \
         occupancy mask to remove seams"
    );
    assert!(matches!(remove_seams(&r, &[], &sp), Err(QuiltError::SampleCount { .. })));
    let small = ramp_texture(30, 3, 9);
    assert!(matches!(remove_seams(&r, &[&small], &sp), Err(QuiltError::SizeMismatch { .. })));
    let grey = Image::new(32, 32, 1);
    assert!(matches!(remove_seams(&r, &[&grey], &sp), Err(QuiltError::ChannelMismatch { .. })));
    let other = ramp_texture(32, 3, 10);
    let e = remove_seams(&r, &[&other], &sp).unwrap_err();
    assert!(matches!(e, QuiltError::SampleContentMismatch { pixels } if pixels > 0), "{e:?}");
    assert!(e.to_string().contains("not the ones the result was quilted from"), "{e}");
    let bad = SeamParams { solver: Solver { max_iter: 0, ..Solver::default() }, ..sp };
    let e = remove_seams(&r, &[&sample], &bad).unwrap_err();
    assert!(
        matches!(e, QuiltError::Blend(BlendError::BadParameter { name: crate::synth::blend::Param::MaxIter, .. })),
        "{e:?}"
    );
    assert!(e.to_string().starts_with("seam removal failed: "), "{e}");
}
