//! Gradient-domain seam removal after quilting: the band variant of [references: welsman-dinelle §4.2].
//!
//! The label map is the quilt's block map (every pixel belongs to the block that wrote it). The
//! guidance on an edge ⟨p,q⟩ inside one block is `S_ℓ(p) − S_ℓ(q)`, `S_ℓ` being block ℓ's source
//! content continued in output space; across a seam it is the mean of both blocks' differences
//! ([`Seam::Average`], the default), the higher class's difference ([`Seam::Insert`]) or 0. Only
//! pixels within Chebyshev distance `radius` of a block boundary are solved; everything else keeps
//! the quilt's values bit-exactly and acts as the Dirichlet boundary. A tileable quilt is solved on
//! the torus, so it stays tileable.
//!
//! **Few images instead of one per block.** [`blend`] takes its sources as output-sized images, and
//! the guidance reads source ℓ only at pixels labelled ℓ and at their 4-neighbours: a block's
//! *reach*. Blocks whose reaches are disjoint can therefore share one image, a *class*. Each block
//! takes the parity class of its grid position (column mod 2, row mod 2; on a torus with an odd
//! number of block columns or rows the last one gets a third value, so it differs from both
//! neighbours across the wrap: at most 9 classes). When same-class footprints are at least two
//! pixels apart (overlap ≤ block/2 − 1 on a plain grid) same-class reaches never meet; where they
//! do, a block whose parity class is taken by an earlier block it meets gets the first extra class
//! free of them, so any overlap works. Class image k holds, at every pixel in the reach of a
//! class-k block, that block's source value: the source copy (rotated exactly like the engine
//! rotated it) at the block's offset, so the guidance is exactly the one cited above. A continuation that
//! leaves the source (or a rotated copy's valid area) takes the value of the block's pixel next to
//! it, i.e. that block contributes a zero difference on that edge. Pixels outside every class-k
//! reach are never read; they hold the quilt image, so the values' range (which scales the
//! solver's max-residual stop) is unchanged.
//!
//! Everything is derived from the result's index map, so no block size or overlap is needed. The
//! given samples must be the ones the result was quilted from: the class images rebuild the quilt
//! bit-exactly, which is checked.

use std::borrow::Cow;

use super::params::{check_finite_image, check_size, Input, QuiltError};
use super::rotate::rotate_sample;
use super::{IndexMap, QuiltResult};
use crate::raster::Image;
use crate::synth::blend::{blend, BlendParams, Domain, Mode, Seam, Selector, SolveReport, Solver, Topology};

/// Settings of [`remove_seams`].
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SeamParams {
    /// Pixels within this Chebyshev distance of a block boundary are solved (typically 4–16).
    pub radius: usize,
    /// Guidance across a block boundary. [`Seam::Average`] is symmetric and recommended; with
    /// [`Seam::Insert`] the block of the higher class wins, which has no meaning of its own here.
    pub seam: Seam,
    pub solver: Solver,
}

impl Default for SeamParams {
    fn default() -> Self {
        SeamParams { radius: 4, seam: Seam::Average, solver: Solver::default() }
    }
}

/// A quilt with its seams removed.
#[derive(Clone, Debug, PartialEq)]
pub struct Deseamed {
    /// Unclamped floats, the quilt's size and channels.
    pub image: Image,
    /// One report per channel.
    pub reports: Vec<SolveReport>,
    /// Number of class images the blocks were packed into.
    pub classes: usize,
}

/// Removes the visible seams of a quilt by a band-Dirichlet Poisson solve around block boundaries.
///
/// `samples` are the input samples of the quilt (`samples[i]` is sample `i`, as given to
/// [`quilt_with`](super::quilt_with)); rotated copies are rebuilt from them.
pub fn remove_seams(result: &QuiltResult, samples: &[&Image], params: &SeamParams) -> Result<Deseamed, QuiltError> {
    let classes = build_classes(result, samples)?;
    let sources: Vec<&Image> = classes.images.iter().collect();
    let blend_params = BlendParams {
        mode: Mode::Gradient,
        topology: if result.tileable { Topology::Torus } else { Topology::Open },
        seam: params.seam,
        domain: Domain::Band { radius: params.radius },
        solver: params.solver,
        ..BlendParams::default()
    };
    let out = blend(&sources, Selector::Labels(&classes.labels), &blend_params).map_err(QuiltError::Blend)?;
    Ok(Deseamed { image: out.image, reports: out.reports, classes: classes.images.len() })
}

/// Output-sized class images and the label map (class of each pixel's block).
pub(super) struct Classes {
    pub images: Vec<Image>,
    pub labels: Vec<u32>,
    /// Class of each block.
    #[cfg_attr(not(test), allow(dead_code))]
    pub of_block: Vec<u32>,
}

/// The 4-neighbours of `(x, y)` as `(index, dx, dy)`, wrapping on a torus; never the pixel itself.
fn neighbours(x: usize, y: usize, w: usize, h: usize, wrap: bool) -> impl Iterator<Item = (usize, i64, i64)> {
    [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)].into_iter().filter_map(move |(dx, dy)| {
        let (nx, ny) = (x as i64 + dx, y as i64 + dy);
        let inside = nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64;
        if !inside && !wrap {
            return None;
        }
        let q = ny.rem_euclid(h as i64) as usize * w + nx.rem_euclid(w as i64) as usize;
        (q != y * w + x).then_some((q, dx, dy))
    })
}

/// A source copy as the engine saw it, with its valid-pixel mask for rotated copies.
struct SourceCopy<'a> {
    image: Cow<'a, Image>,
    valid: Option<Vec<bool>>,
}

impl SourceCopy<'_> {
    /// Pixel index of `(x, y)` if it lies in the copy's valid area.
    fn at(&self, x: i64, y: i64) -> Option<usize> {
        let (w, h) = (self.image.width as i64, self.image.height as i64);
        if x < 0 || y < 0 || x >= w || y >= h {
            return None;
        }
        let j = (y * w + x) as usize;
        self.valid.as_ref().is_none_or(|v| v[j]).then_some(j)
    }
}

fn validate(result: &QuiltResult, samples: &[&Image]) -> Result<(), QuiltError> {
    let (img, idx) = (&result.image, &result.index);
    let (w, h) = (img.width, img.height);
    if w == 0 || h == 0 || img.channels == 0 {
        return Err(QuiltError::Empty { what: Input::QuiltResult });
    }
    if idx.width != w || idx.height != h {
        return Err(QuiltError::SizeMismatch { what: Input::IndexMap, expected: [w, h], got: [idx.width, idx.height] });
    }
    let empty = idx.block.iter().filter(|&&b| b == IndexMap::EMPTY).count();
    if empty > 0 {
        return Err(QuiltError::SeamsNeedFullCoverage { empty });
    }
    let needed = result.sources.iter().map(|s| s.sample + 1).max().unwrap_or(0);
    if samples.len() < needed || samples.is_empty() {
        return Err(QuiltError::SampleCount { got: samples.len(), expected: "one image per input sample" });
    }
    for s in &result.sources {
        let o = samples[s.sample];
        check_size(Input::Sample, o, s.width, s.height)?;
        if o.channels != img.channels {
            return Err(QuiltError::ChannelMismatch { what: Input::Samples, expected: img.channels, got: o.channels });
        }
        check_finite_image(Input::Sample, o)?;
    }
    for i in 0..w * h {
        let (b, s) = (idx.block[i] as usize, idx.source[i] as usize);
        let ok = b < result.blocks.len()
            && s < result.sources.len()
            && (idx.x[i] as usize) < result.sources[s].width
            && (idx.y[i] as usize) < result.sources[s].height;
        if !ok {
            return Err(QuiltError::Invalid {
                name: Input::IndexMapEntry,
                value: i as f64,
                expected: "a block, source and position of this result",
            });
        }
    }
    Ok(())
}

pub(super) fn build_classes(result: &QuiltResult, samples: &[&Image]) -> Result<Classes, QuiltError> {
    validate(result, samples)?;
    let (img, idx) = (&result.image, &result.index);
    let (w, h, channels) = (img.width, img.height, img.channels);
    let (n, wrap) = (w * h, result.tileable);
    let copies: Vec<SourceCopy> = result
        .sources
        .iter()
        .map(|s| {
            let sample = samples[s.sample];
            if s.angle == 0.0 {
                SourceCopy { image: Cow::Borrowed(sample), valid: None }
            } else {
                let (r, v) = rotate_sample(sample, s.angle);
                SourceCopy { image: Cow::Owned(r), valid: Some(v) }
            }
        })
        .collect();

    // Blocks whose reaches (own pixels and their 4-neighbours) meet: all blocks seen from one pixel.
    let n_blocks = result.blocks.len();
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n_blocks];
    for y in 0..h {
        for x in 0..w {
            let mut seen = [idx.block[y * w + x]; 5];
            let mut k = 1;
            for (q, _, _) in neighbours(x, y, w, h, wrap) {
                let b = idx.block[q];
                if !seen[..k].contains(&b) {
                    seen[k] = b;
                    k += 1;
                }
            }
            for i in 0..k {
                for j in i + 1..k {
                    adj[seen[i] as usize].push(seen[j]);
                    adj[seen[j] as usize].push(seen[i]);
                }
            }
        }
    }
    // Classes in placement order: the block's grid parity class when no earlier block it meets has
    // it (always, for overlaps below half the block), else the first class free of them.
    let grid = |pick: fn(&super::BlockRecord) -> usize| {
        let mut v: Vec<usize> = result.blocks.iter().map(pick).collect();
        v.sort_unstable();
        v.dedup();
        v
    };
    let (xs, ys) = (grid(|b| b.x), grid(|b| b.y));
    // Position along an axis mod 2; on a torus with an odd count the last one also differs from the first.
    let parity = |pos: usize, all: &[usize]| {
        let (i, n) = (all.binary_search(&pos).expect("listed"), all.len());
        if wrap && n % 2 == 1 && n > 1 && i == n - 1 {
            2
        } else {
            i % 2
        }
    };
    let mut class = vec![0usize; n_blocks];
    let mut used = Vec::new();
    for b in 0..n_blocks {
        adj[b].sort_unstable();
        adj[b].dedup();
        used.clear();
        used.extend(adj[b].iter().filter(|&&a| (a as usize) < b).map(|&a| class[a as usize]));
        let rec = &result.blocks[b];
        let preferred = parity(rec.x, &xs) + 3 * parity(rec.y, &ys);
        class[b] = if used.contains(&preferred) {
            (9..).find(|c| !used.contains(c)).expect("a free class exists")
        } else {
            preferred
        };
    }
    // Number the classes in order of first use.
    let mut number: Vec<Option<u32>> = vec![None; class.iter().max().map_or(1, |&c| c + 1)];
    let mut n_classes = 0u32;
    let of_block: Vec<u32> = class
        .iter()
        .map(|&c| {
            *number[c].get_or_insert_with(|| {
                n_classes += 1;
                n_classes - 1
            })
        })
        .collect();
    let n_classes = (n_classes as usize).max(1);

    let labels: Vec<u32> = idx.block.iter().map(|&b| of_block[b as usize]).collect();
    let mut images = vec![img.clone(); n_classes];
    let write = |images: &mut [Image], class: u32, p: usize, src: &SourceCopy, j: usize| {
        let (dst, sn) = (&mut images[class as usize], src.image.plane_len());
        for c in 0..channels {
            dst.data[c * n + p] = src.image.data[c * sn + j];
        }
    };
    let mut mismatched = 0usize;
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            let a = idx.block[p];
            let own = &copies[idx.source[p] as usize];
            let j = idx.y[p] as usize * own.image.width + idx.x[p] as usize;
            write(&mut images, of_block[a as usize], p, own, j);
            let sn = own.image.plane_len();
            mismatched += usize::from(
                (0..channels).any(|c| own.image.data[c * sn + j].to_bits() != img.data[c * n + p].to_bits()),
            );
            // The continuation of each neighbouring block at p (its reach).
            let mut done = [a; 5];
            let mut k = 1;
            for (q, dx, dy) in neighbours(x, y, w, h, wrap) {
                let b = idx.block[q];
                if done[..k].contains(&b) {
                    continue;
                }
                done[k] = b;
                k += 1;
                let src = &copies[idx.source[q] as usize];
                let (qx, qy) = (i64::from(idx.x[q]), i64::from(idx.y[q]));
                // p = q − (dx, dy) in output space, so in the source too; outside: q's own value.
                let j = src.at(qx - dx, qy - dy).unwrap_or(qy as usize * src.image.width + qx as usize);
                write(&mut images, of_block[b as usize], p, src, j);
            }
        }
    }
    if mismatched > 0 {
        return Err(QuiltError::SampleContentMismatch { pixels: mismatched });
    }
    Ok(Classes { images, labels, of_block })
}

#[cfg(test)]
mod tests {
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
                        let d =
                            if r.tileable { (v - corner as i64).rem_euclid(size as i64) } else { v - corner as i64 };
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
        for (tileable, kind) in [(false, SolverKind::Mgpcg), (false, SolverKind::Multigrid), (true, SolverKind::Mgpcg)]
        {
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
}
