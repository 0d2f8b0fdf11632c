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
use super::result::{BlockRecord, IndexMap, QuiltResult};
use super::rotate::rotate_sample;
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
    let grid = |pick: fn(&BlockRecord) -> usize| {
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
mod tests;
