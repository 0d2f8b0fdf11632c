//! Region extraction (stage A2a): each drawn region's pixels cut out of the sample photo, at
//! least `shrink` pixels inside its polygon so no interstice pixel is included, with their
//! mean CIELAB colour ([references: frasson §4.1.2]).
//!
//! A pixel belongs to a region's extract when its centre `(i + ½, j + ½)` lies inside the
//! polygon (even-odd rule, the scan-fill of `rasterize_polygons`, so neighbouring polygons
//! never share a pixel) and its distance to every polygon edge is at least `shrink`. This is
//! the polygon offset inward by `shrink`, tested per pixel centre, so the guarantee "every
//! extracted pixel centre lies ≥ `shrink` px inside" holds exactly, concave corners included.

use super::color::{lab_at, mean_lab};
use super::types::{Extract, Point};
use crate::raster::Image;
use crate::synth::structure::analysis::labels_import::row_crossings;

/// The default shrink: 2 px (our choice; the thesis only says "slightly").
pub const DEFAULT_SHRINK: f64 = 2.0;

/// Extracts `regions` (indices into `polygons`) from `image` (RGB, sRGB-encoded), in the order
/// given. A region whose shrunk interior holds no pixel centre (a sliver, a region thinner than
/// `2·shrink`, or one outside the image) is **skipped**: it has no entry in the result, so
/// callers find a region's extract by [`Extract::region`], never by position. Indices out of
/// range of `polygons` and polygons with fewer than 3 vertices are skipped the same way.
/// A negative or non-finite `shrink` counts as 0.
pub fn extract_regions(image: &Image, polygons: &[Vec<Point>], regions: &[usize], shrink: f64) -> Vec<Extract> {
    let shrink = if shrink.is_finite() { shrink.max(0.0) } else { 0.0 };
    regions.iter().filter_map(|&r| polygons.get(r).and_then(|poly| extract_one(image, poly, r, shrink))).collect()
}

/// The extract of one polygon, or `None` when it is empty.
fn extract_one(image: &Image, poly: &[Point], region: usize, shrink: f64) -> Option<Extract> {
    let mask_full = interior_mask(poly, image.width, image.height, shrink)?;
    let (x0, y0, w, h, mask) = mask_full;
    let mut labs = Vec::new();
    for y in 0..h {
        for x in 0..w {
            if mask[y * w + x] {
                labs.push(lab_at(image, x0 + x, y0 + y));
            }
        }
    }
    if labs.is_empty() {
        return None;
    }
    let pixels = labs.len();
    // Trim the box to the kept pixels so extracts are as small as they can be.
    let (mut tx0, mut ty0, mut tx1, mut ty1) = (w, h, 0, 0);
    for y in 0..h {
        for x in 0..w {
            if mask[y * w + x] {
                tx0 = tx0.min(x);
                ty0 = ty0.min(y);
                tx1 = tx1.max(x + 1);
                ty1 = ty1.max(y + 1);
            }
        }
    }
    let (tw, th) = (tx1 - tx0, ty1 - ty0);
    let mut trimmed = vec![false; tw * th];
    for y in 0..th {
        trimmed[y * tw..(y + 1) * tw].copy_from_slice(&mask[(ty0 + y) * w + tx0..(ty0 + y) * w + tx0 + tw]);
    }
    Some(Extract {
        region,
        origin: [x0 + tx0, y0 + ty0],
        width: tw,
        height: th,
        mask: trimmed,
        lab: mean_lab(labs),
        pixels,
    })
}

/// The polygon's pixel box clipped to the image, `(x0, y0, w, h, mask)`, with the pixels whose
/// centres lie inside and at least `shrink` from every edge; `None` when the box is empty.
#[allow(clippy::type_complexity)]
fn interior_mask(poly: &[Point], iw: usize, ih: usize, shrink: f64) -> Option<(usize, usize, usize, usize, Vec<bool>)> {
    let n = poly.len();
    if n < 3 || poly.iter().any(|p| !p[0].is_finite() || !p[1].is_finite()) {
        return None;
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in poly {
        for c in 0..2 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    // Pixel centres c + ½ in [lo, hi].
    let x0 = (lo[0] - 0.5).ceil().max(0.0) as usize;
    let y0 = (lo[1] - 0.5).ceil().max(0.0) as usize;
    let x1 = ((hi[0] - 0.5).floor() + 1.0).clamp(0.0, iw as f64) as usize;
    let y1 = ((hi[1] - 0.5).floor() + 1.0).clamp(0.0, ih as f64) as usize;
    if x1 <= x0 || y1 <= y0 {
        return None;
    }
    let (w, h) = (x1 - x0, y1 - y0);
    let mut mask = vec![false; w * h];
    let mut xs: Vec<f64> = Vec::new();
    let s2 = shrink * shrink;
    for j in 0..h {
        let yc = (y0 + j) as f64 + 0.5;
        row_crossings(poly, yc, &mut xs);
        for pair in xs.chunks(2) {
            if pair.len() < 2 {
                break;
            }
            // Pixel centres x + ½ in [pair[0], pair[1]) (the rasteriser's half-open span rule).
            let i0 = ((pair[0] - 0.5).ceil().max(x0 as f64)) as usize;
            let i1 = (pair[1] - 0.5).ceil().min(x1 as f64);
            if i1 <= i0 as f64 {
                continue;
            }
            for i in i0..(i1 as usize) {
                let c = [i as f64 + 0.5, yc];
                if shrink == 0.0 || edge_distance2(poly, c) >= s2 {
                    mask[j * w + (i - x0)] = true;
                }
            }
        }
    }
    Some((x0, y0, w, h, mask))
}

/// Squared distance from `c` to the nearest edge of the closed polygon.
pub(crate) fn edge_distance2(poly: &[Point], c: Point) -> f64 {
    let n = poly.len();
    let mut best = f64::INFINITY;
    for i in 0..n {
        let (p, q) = (poly[i], poly[(i + 1) % n]);
        let d = [q[0] - p[0], q[1] - p[1]];
        let e = [c[0] - p[0], c[1] - p[1]];
        let len2 = d[0] * d[0] + d[1] * d[1];
        let t = if len2 > 0.0 { ((e[0] * d[0] + e[1] * d[1]) / len2).clamp(0.0, 1.0) } else { 0.0 };
        let f = [e[0] - t * d[0], e[1] - t * d[1]];
        best = best.min(f[0] * f[0] + f[1] * f[1]);
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::structure::fixtures::standins::{paint, wall_random, PaintParams, WallRandomParams};

    fn square(x: f64, y: f64, s: f64) -> Vec<Point> {
        vec![[x, y], [x + s, y], [x + s, y + s], [x, y + s]]
    }

    #[test]
    fn a_square_shrinks_by_the_distance() {
        let mut img = Image::new(40, 40, 3);
        img.data.iter_mut().for_each(|v| *v = 0.5);
        // A 20 px square at (10, 10): centres 10.5..29.5; ≥ 2 px inside leaves 12.5..27.5 → 16.
        let ex = extract_regions(&img, &[square(10.0, 10.0, 20.0)], &[0], 2.0);
        assert_eq!(ex.len(), 1);
        assert_eq!((ex[0].origin, ex[0].width, ex[0].height, ex[0].pixels), ([12, 12], 16, 16, 256));
        let plain = extract_regions(&img, &[square(10.0, 10.0, 20.0)], &[0], 0.0);
        assert_eq!(plain[0].pixels, 400);
    }

    #[test]
    fn empty_and_invalid_regions_are_skipped() {
        let img = Image::new(40, 40, 3);
        let polys = vec![square(10.0, 10.0, 3.0), square(0.0, 0.0, 20.0), vec![[0.0, 0.0], [1.0, 1.0]]];
        let ex = extract_regions(&img, &polys, &[0, 1, 2, 7], 2.0);
        assert_eq!(ex.iter().map(|e| e.region).collect::<Vec<_>>(), vec![1]);
        let outside = extract_regions(&img, &[square(100.0, 100.0, 20.0)], &[0], 2.0);
        assert!(outside.is_empty());
    }

    /// F21: every extracted pixel centre lies at least `shrink` inside its polygon, and the
    /// mean colour is its pixels' mean.
    #[test]
    fn f21_extracted_pixels_lie_shrink_inside() {
        let s = wall_random(&WallRandomParams::default(), 5);
        let painted = paint(&s, &PaintParams::default(), 5);
        let polys = s.polygons();
        let all: Vec<usize> = (0..polys.len()).collect();
        for shrink in [2.0, 3.5] {
            let ex = extract_regions(&painted.image, &polys, &all, shrink);
            assert!(ex.len() >= polys.len() * 9 / 10, "{} of {}", ex.len(), polys.len());
            for e in &ex {
                let poly = &polys[e.region];
                let mut labs = Vec::new();
                for y in 0..e.height {
                    for x in 0..e.width {
                        if !e.mask[y * e.width + x] {
                            continue;
                        }
                        let (px, py) = (e.origin[0] + x, e.origin[1] + y);
                        assert_eq!(painted.labels[py * s.width + px] as usize, e.region);
                        let c = [px as f64 + 0.5, py as f64 + 0.5];
                        assert!(edge_distance2(poly, c).sqrt() >= shrink - 1e-9);
                        labs.push(lab_at(&painted.image, px, py));
                    }
                }
                assert_eq!(labs.len(), e.pixels);
                assert_eq!(mean_lab(labs), e.lab);
            }
        }
    }
}
