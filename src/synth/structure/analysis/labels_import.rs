//! Importing a structure from a label image (a raster of region ids).
//!
//! Boundaries run along pixel *cracks*: the unit segments of the integer lattice between two
//! pixels with different ids (pixel `(i, j)` covers `[i, i+1] × [j, j+1]`, its centre is at
//! `(i + ½, j + ½)`). Outside the image counts as [`NO_REGION`], so regions touching the
//! border are closed along it, and `NO_REGION` pixels are treated like the outside (no edge
//! between two `NO_REGION` pixels).
//!
//! Junction vertices are lattice points where three or more cracks meet (three or more ids,
//! or two ids meeting diagonally), plus the image corners on a boundary. The cracks between
//! junctions form chains (closed loops where no junction is met); each chain is reduced to
//! its corners (straight runs merged), then simplified with Douglas–Peucker at `tolerance`
//! px keeping its end junctions. A simplified chain that would cross or duplicate another
//! is re-simplified with half the tolerance (down to 0, where it follows the cracks
//! exactly), so the output is always a valid subdivision.
//!
//! The faces of the result correspond to the 4-connected components of the ids (including
//! `NO_REGION` areas enclosed by labelled pixels); [`face_labels`] recovers the id of each
//! face.

use crate::synth::structure::mesh::faces::Faces;
use crate::synth::structure::types::{Labels, Point, Subdivision, NO_REGION};
use crate::synth::structure::validate;
use crate::synth::structure::StructureError;

struct Lattice<'a> {
    ids: &'a [u32],
    w: usize,
    h: usize,
}

impl Lattice<'_> {
    fn id(&self, x: isize, y: isize) -> u32 {
        if x < 0 || y < 0 || x >= self.w as isize || y >= self.h as isize {
            NO_REGION
        } else {
            self.ids[y as usize * self.w + x as usize]
        }
    }
    /// Horizontal crack from lattice point (x, y) to (x + 1, y).
    fn hcrack(&self, x: usize, y: usize) -> bool {
        x < self.w && self.id(x as isize, y as isize - 1) != self.id(x as isize, y as isize)
    }
    /// Vertical crack from lattice point (x, y) to (x, y + 1).
    fn vcrack(&self, x: usize, y: usize) -> bool {
        y < self.h && self.id(x as isize - 1, y as isize) != self.id(x as isize, y as isize)
    }
    fn pidx(&self, x: usize, y: usize) -> usize {
        y * (self.w + 1) + x
    }
    /// Cracks at a lattice point, as directions: 0 = +x, 1 = +y, 2 = −x, 3 = −y.
    fn dirs(&self, x: usize, y: usize) -> [bool; 4] {
        [self.hcrack(x, y), self.vcrack(x, y), x > 0 && self.hcrack(x - 1, y), y > 0 && self.vcrack(x, y - 1)]
    }
}

const STEP: [(isize, isize); 4] = [(1, 0), (0, 1), (-1, 0), (0, -1)];

/// Imports the region boundaries of a label raster (`ids` row-major, `w × h`) as a
/// subdivision, simplified with Douglas–Peucker at `tolerance` px (0 keeps every corner).
///
/// Errors: [`StructureError::Empty`] if the raster has no boundary at all (for example, all
/// `NO_REGION`).
pub fn import_labels(ids: &[u32], w: usize, h: usize, tolerance: f64) -> Result<Subdivision, StructureError> {
    assert_eq!(ids.len(), w * h, "label raster size");
    let lat = Lattice { ids, w, h };
    let np = (w + 1) * (h + 1);
    let mut junction = vec![false; np];
    let mut any = false;
    for y in 0..=h {
        for x in 0..=w {
            let d = lat.dirs(x, y);
            let deg = d.iter().filter(|&&b| b).count();
            any |= deg > 0;
            let corner = (x == 0 || x == w) && (y == 0 || y == h);
            if deg >= 3 || (corner && deg >= 2) {
                junction[lat.pidx(x, y)] = true;
            }
        }
    }
    if !any {
        return Err(StructureError::Empty { vertices: 0, edges: 0 });
    }
    // Used cracks: horizontal ones indexed by their left point, vertical ones by their top.
    let mut hused = vec![false; np];
    let mut vused = vec![false; np];
    let mut chains: Vec<Vec<[usize; 2]>> = Vec::new();
    let walk = |start: [usize; 2], dir: usize, hused: &mut Vec<bool>, vused: &mut Vec<bool>| -> Vec<[usize; 2]> {
        let mut pts = vec![start];
        let (mut p, mut d) = (start, dir);
        loop {
            // Mark the crack from p in direction d.
            match d {
                0 => hused[lat.pidx(p[0], p[1])] = true,
                1 => vused[lat.pidx(p[0], p[1])] = true,
                2 => hused[lat.pidx(p[0] - 1, p[1])] = true,
                _ => vused[lat.pidx(p[0], p[1] - 1)] = true,
            }
            let q = [(p[0] as isize + STEP[d].0) as usize, (p[1] as isize + STEP[d].1) as usize];
            pts.push(q);
            if junction[lat.pidx(q[0], q[1])] || q == start {
                return pts;
            }
            // Degree-2 point: continue along the other crack.
            let ds = lat.dirs(q[0], q[1]);
            let back = (d + 2) % 4;
            d = (0..4).find(|&k| k != back && ds[k]).expect("degree-2 crack point");
            p = q;
        }
    };
    let used = |p: [usize; 2], d: usize, hused: &Vec<bool>, vused: &Vec<bool>| match d {
        0 => hused[lat.pidx(p[0], p[1])],
        1 => vused[lat.pidx(p[0], p[1])],
        2 => hused[lat.pidx(p[0] - 1, p[1])],
        _ => vused[lat.pidx(p[0], p[1] - 1)],
    };
    for y in 0..=h {
        for x in 0..=w {
            if !junction[lat.pidx(x, y)] {
                continue;
            }
            let ds = lat.dirs(x, y);
            for (d, &has) in ds.iter().enumerate() {
                if has && !used([x, y], d, &hused, &vused) {
                    chains.push(walk([x, y], d, &mut hused, &mut vused));
                }
            }
        }
    }
    // Closed loops without junctions: start at their first point in scan order.
    for y in 0..=h {
        for x in 0..=w {
            let ds = lat.dirs(x, y);
            for (d, &has) in ds.iter().enumerate().take(2) {
                if has && !used([x, y], d, &hused, &vused) {
                    chains.push(walk([x, y], d, &mut hused, &mut vused));
                }
            }
        }
    }
    // Corners of each chain (straight runs merged).
    let chains: Vec<Vec<Point>> = chains
        .iter()
        .map(|c| {
            let mut out: Vec<Point> = vec![[c[0][0] as f64, c[0][1] as f64]];
            for i in 1..c.len() - 1 {
                let (a, b, n) = (c[i - 1], c[i], c[i + 1]);
                let straight = (a[0] == b[0] && b[0] == n[0]) || (a[1] == b[1] && b[1] == n[1]);
                if !straight {
                    out.push([b[0] as f64, b[1] as f64]);
                }
            }
            let last = c[c.len() - 1];
            out.push([last[0] as f64, last[1] as f64]);
            out
        })
        .collect();
    let mut tol = vec![tolerance.max(0.0); chains.len()];
    for _round in 0..64 {
        let kept: Vec<Vec<usize>> = chains.iter().zip(&tol).map(|(c, &t)| simplify_chain(c, t)).collect();
        let (sub, edge_chain) = assemble(&chains, &kept);
        let mut bad = vec![false; chains.len()];
        for c in validate::find_crossings(&sub) {
            bad[edge_chain[c.edges[0]]] = true;
            bad[edge_chain[c.edges[1]]] = true;
        }
        for [a, b] in validate::find_duplicate_edges(&sub.edges) {
            bad[edge_chain[a]] = true;
            bad[edge_chain[b]] = true;
        }
        let mut changed = false;
        for (k, &is_bad) in bad.iter().enumerate() {
            if is_bad && tol[k] > 0.0 {
                tol[k] = if tol[k] < 0.125 { 0.0 } else { tol[k] * 0.5 };
                changed = true;
            }
        }
        if !changed {
            return Ok(sub);
        }
    }
    // Unreachable in practice: at tolerance 0 the chains follow disjoint cracks.
    let kept: Vec<Vec<usize>> = chains.iter().map(|c| simplify_chain(c, 0.0)).collect();
    Ok(assemble(&chains, &kept).0)
}

/// Builds the subdivision from the kept points of each chain; returns it and the chain of
/// each edge. Chain end points are shared through their lattice coordinates.
fn assemble(chains: &[Vec<Point>], kept: &[Vec<usize>]) -> (Subdivision, Vec<usize>) {
    use std::collections::HashMap;
    let mut index: HashMap<(i64, i64), usize> = HashMap::new();
    let mut sub = Subdivision::default();
    let mut edge_chain = Vec::new();
    for (c, (pts, keep)) in chains.iter().zip(kept).enumerate() {
        let mut prev: Option<usize> = None;
        for &k in keep {
            let p = pts[k];
            let key = (p[0] as i64, p[1] as i64);
            let id = *index.entry(key).or_insert_with(|| {
                sub.vertices.push(p);
                sub.vertices.len() - 1
            });
            if let Some(q) = prev {
                sub.edges.push([q, id]);
                edge_chain.push(c);
            }
            prev = Some(id);
        }
    }
    (sub, edge_chain)
}

fn seg_dist(p: Point, a: Point, b: Point) -> f64 {
    validate::point_segment_distance(p, a, b)
}

/// Douglas–Peucker on `pts[lo..=hi]`; pushes kept interior indices into `out` (in order).
fn dp(pts: &[Point], lo: usize, hi: usize, tol: f64, out: &mut Vec<usize>) {
    if hi <= lo + 1 {
        return;
    }
    let (mut far, mut fd) = (lo, -1.0);
    for (i, &p) in pts.iter().enumerate().take(hi).skip(lo + 1) {
        let d = seg_dist(p, pts[lo], pts[hi]);
        if d > fd {
            fd = d;
            far = i;
        }
    }
    if fd > tol {
        dp(pts, lo, far, tol, out);
        out.push(far);
        dp(pts, far, hi, tol, out);
    }
}

/// Indices of the points kept from a chain (ends always kept). A closed chain (first point
/// = last point) keeps at least two interior points, so it stays a polygon.
fn simplify_chain(pts: &[Point], tol: f64) -> Vec<usize> {
    let n = pts.len();
    if tol <= 0.0 {
        return (0..n).collect();
    }
    let closed = pts[0] == pts[n - 1];
    let mut out = vec![0];
    if closed {
        // Split at the point farthest from the start, simplify both halves.
        let far = (1..n - 1)
            .max_by(|&a, &b| dist2(pts[a], pts[0]).total_cmp(&dist2(pts[b], pts[0])).then(b.cmp(&a)))
            .expect("closed chain has interior points");
        let mut first = Vec::new();
        dp(pts, 0, far, tol, &mut first);
        let mut second = Vec::new();
        dp(pts, far, n - 1, tol, &mut second);
        if first.is_empty() && second.is_empty() {
            // Keep the point farthest from the chord in the larger half.
            let pick = |lo: usize, hi: usize| {
                (lo + 1..hi)
                    .map(|i| (seg_dist(pts[i], pts[lo], pts[hi]), i))
                    .max_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)))
            };
            match (pick(0, far), pick(far, n - 1)) {
                (Some(a), Some(b)) => {
                    if a.0 >= b.0 {
                        first.push(a.1)
                    } else {
                        second.push(b.1)
                    }
                }
                (Some(a), None) => first.push(a.1),
                (None, Some(b)) => second.push(b.1),
                (None, None) => {}
            }
        }
        out.extend(first);
        out.push(far);
        out.extend(second);
    } else {
        dp(pts, 0, n - 1, tol, &mut out);
    }
    out.push(n - 1);
    out
}

fn dist2(a: Point, b: Point) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

/// Rasterises polygons into a label raster: pixel `(i, j)` gets the index of the polygon
/// containing its centre `(i + ½, j + ½)` (even-odd rule; later polygons win overlaps).
/// Polygons that share an edge split its pixels without gaps or double counting, because
/// each edge's crossing with a pixel-centre row is computed from its end points in `y`
/// order, and the span rule is half-open.
/// The sorted x of the crossings of the row `y = yc` with the closed polygon's edges (each
/// edge half-open in y, so a vertex on the row counts once): the spans of a scan fill.
pub(crate) fn row_crossings(poly: &[Point], yc: f64, xs: &mut Vec<f64>) {
    let n = poly.len();
    xs.clear();
    for i in 0..n {
        let (mut a, mut b) = (poly[i], poly[(i + 1) % n]);
        if a[1] > b[1] || (a[1] == b[1] && a[0] > b[0]) {
            std::mem::swap(&mut a, &mut b);
        }
        if a[1] <= yc && yc < b[1] {
            xs.push(a[0] + (yc - a[1]) / (b[1] - a[1]) * (b[0] - a[0]));
        }
    }
    xs.sort_by(f64::total_cmp);
}

pub fn rasterize_polygons(polys: &[Vec<Point>], w: usize, h: usize) -> Labels {
    let mut labels = Labels::new(w, h);
    let mut xs: Vec<f64> = Vec::new();
    for (id, poly) in polys.iter().enumerate() {
        let n = poly.len();
        if n < 3 {
            continue;
        }
        let (mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in poly {
            y0 = y0.min(p[1]);
            y1 = y1.max(p[1]);
        }
        let j0 = ((y0 - 0.5).ceil().max(0.0)) as usize;
        let j1 = ((y1 - 0.5).floor().min(h as f64 - 1.0)) as isize;
        if j1 < 0 {
            continue;
        }
        for j in j0..=(j1 as usize) {
            let yc = j as f64 + 0.5;
            row_crossings(poly, yc, &mut xs);
            for pair in xs.chunks(2) {
                if pair.len() < 2 {
                    break;
                }
                // Pixel centres x + ½ in [pair[0], pair[1]).
                let i0 = ((pair[0] - 0.5).ceil().max(0.0)) as usize;
                let i1 = (pair[1] - 0.5).ceil().min(w as f64);
                if i1 <= 0.0 {
                    continue;
                }
                for i in i0..(i1 as usize) {
                    labels.data[j * w + i] = id as u32;
                }
            }
        }
    }
    labels
}

/// The id of each face of an imported structure: the most common id among the pixels whose
/// centres lie inside the face (holes excluded). Ties go to the smallest id; a face without
/// pixel centres gets `NO_REGION`.
pub fn face_labels(ids: &[u32], w: usize, h: usize, sub: &Subdivision, faces: &Faces) -> Vec<u32> {
    let polys: Vec<Vec<Point>> = (0..faces.regions.len()).map(|r| faces.polygon(sub, r)).collect();
    // Holes are rasterised after the regions (as "no face") so they are not counted.
    let mut all = polys.clone();
    for r in &faces.regions {
        for hole in &r.holes {
            all.push(hole.iter().map(|&i| sub.vertices[i]).collect());
        }
    }
    let raster = rasterize_polygons(&all, w, h);
    let mut votes: Vec<std::collections::BTreeMap<u32, usize>> = vec![Default::default(); polys.len()];
    for (i, &f) in raster.data.iter().enumerate() {
        if (f as usize) < polys.len() {
            *votes[f as usize].entry(ids[i]).or_insert(0) += 1;
        }
    }
    votes
        .iter()
        .map(|v| v.iter().max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0))).map_or(NO_REGION, |(&id, _)| id))
        .collect()
}

#[cfg(test)]
mod tests;
