//! Rebuilding regions from edges ([references: frasson §3.4], Algorithm 1, tessera's DCEL variant).
//!
//! The thesis sweeps a line over the vertices; we build a half-edge structure instead:
//! outgoing half-edges are sorted by angle around each vertex, `next(h)` is the outgoing
//! half-edge at `h`'s head that comes right before `twin(h)` in counter-clockwise order, and
//! the cycles of `next` are the faces. Concave faces need no special case.
//!
//! Orientation: all signed areas use the raw `(x, y)` coordinates (y down), with
//! `A = ½ Σ (x_i y_{i+1} − x_{i+1} y_i)`. Region boundaries have `A > 0` (this is
//! counter-clockwise in a y-up frame, as in [references: frasson §3.4], and the orientation [`Mesh`]
//! documents as "positive signed area with y down"; drawn on a y-down screen it appears
//! clockwise). Each region lies to the *left* of its boundary half-edges in that y-up sense.
//!
//! Half-edge `2k` runs from `edges[k][0]` to `edges[k][1]`, half-edge `2k + 1` back. The
//! region on the left of edge `k` is the face of half-edge `2k`, the region on its right
//! the face of `2k + 1`.
//!
//! Components: every connected component has one cycle with negative area, its outside.
//! If that cycle lies inside a region of another component, it is a hole of that region
//! (an island); otherwise it is part of the unbounded face. With `C` components, the Euler
//! relation reads `N_R + N_V = N_E + C` (`C = 1`: the thesis's `N_R + N_V = N_E + 1`, [references: frasson §B.1.2]).
//!
//! The input must be valid (see [`crate::synth::structure::validate`]); dangling edges are tolerated (both
//! sides get the same face and the boundary walks around them) but should be pruned first
//! with [`crate::synth::structure::validate::clean`], as [`analyse_faces`] does.

use crate::synth::structure::types::{Mesh, Point, Subdivision};
use crate::synth::structure::validate::{self, Cleaned};
use crate::synth::structure::StructureError;
use std::cmp::Ordering;

/// One bounded face.
#[derive(Clone, Debug, PartialEq)]
pub struct Region {
    /// The outer boundary as a vertex cycle with positive signed area.
    pub boundary: Vec<usize>,
    /// `boundary_edges[i]` is the edge from `boundary[i]` to `boundary[i + 1]`.
    pub boundary_edges: Vec<usize>,
    /// Boundaries of islands inside the region (negative signed area each).
    pub holes: Vec<Vec<usize>>,
    /// Area of the boundary minus the holes.
    pub area: f64,
    /// The region shares an edge with the unbounded face (a "border region", [references: frasson §3.4]).
    pub touches_outer: bool,
    /// A boundary vertex lies on or outside the sample rectangle (only with a sample size).
    pub touches_sample_border: bool,
}

impl Region {
    /// Border region in the sense of `stats.exclude_border_regions`: touches the unbounded
    /// face or the sample border.
    pub fn is_border(&self) -> bool {
        self.touches_outer || self.touches_sample_border
    }
}

/// The faces of a subdivision.
#[derive(Clone, Debug, PartialEq)]
pub struct Faces {
    pub regions: Vec<Region>,
    /// Per input edge: `[left, right]` region (`None` = the unbounded face).
    pub edge_regions: Vec<[Option<usize>; 2]>,
    /// The cycles bounding the unbounded face (negative signed area), one per top-level
    /// component.
    pub outer_boundaries: Vec<Vec<usize>>,
    /// Number of connected components (vertices without edges are not counted).
    pub components: usize,
    /// Number of vertices with at least one edge.
    pub vertex_count: usize,
    pub edge_count: usize,
}

impl Faces {
    /// Whether `N_R + N_V = N_E + C` holds.
    pub fn euler_holds(&self) -> bool {
        self.regions.len() + self.vertex_count == self.edge_count + self.components
    }

    /// The boundary polygon of region `r`.
    pub fn polygon(&self, sub: &Subdivision, r: usize) -> Vec<Point> {
        self.regions[r].boundary.iter().map(|&i| sub.vertices[i]).collect()
    }

    /// The boundary polygon and the hole polygons of region `r`.
    pub fn rings(&self, sub: &Subdivision, r: usize) -> Vec<Vec<Point>> {
        let reg = &self.regions[r];
        std::iter::once(&reg.boundary)
            .chain(reg.holes.iter())
            .map(|c| c.iter().map(|&i| sub.vertices[i]).collect())
            .collect()
    }

    /// The area enclosed by the outer boundaries (the union of all regions).
    pub fn outer_area(&self, sub: &Subdivision) -> f64 {
        self.outer_boundaries
            .iter()
            .map(|c| -signed_area(&c.iter().map(|&i| sub.vertices[i]).collect::<Vec<_>>()))
            .sum()
    }

    /// The regions as a [`Mesh`] (holes are dropped: a mesh region is one cycle).
    pub fn to_mesh(&self, sub: &Subdivision) -> Mesh {
        Mesh { vertices: sub.vertices.clone(), regions: self.regions.iter().map(|r| r.boundary.clone()).collect() }
    }
}

/// Options of [`extract_faces_with`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceOptions {
    /// The sample's `[width, height]`; regions with a vertex within `border_tol` of (or
    /// outside) `[0, w] × [0, h]` get `touches_sample_border`.
    pub sample_size: Option<[f64; 2]>,
    pub border_tol: f64,
}

impl Default for FaceOptions {
    fn default() -> Self {
        FaceOptions { sample_size: None, border_tol: 0.5 }
    }
}

/// Signed area `½ Σ (x_i y_{i+1} − x_{i+1} y_i)` (raw coordinates, y down), computed
/// relative to the first vertex for precision.
pub fn signed_area(poly: &[Point]) -> f64 {
    if poly.len() < 3 {
        return 0.0;
    }
    let o = poly[0];
    let mut s = 0.0;
    for i in 1..poly.len() - 1 {
        let (a, b) = (poly[i], poly[i + 1]);
        s += (a[0] - o[0]) * (b[1] - o[1]) - (b[0] - o[0]) * (a[1] - o[1]);
    }
    0.5 * s
}

/// Whether `p` is inside the polygon (even-odd rule; boundary points are unspecified).
pub fn point_in_polygon(p: Point, poly: &[Point]) -> bool {
    let mut inside = false;
    let n = poly.len();
    let mut j = n.wrapping_sub(1);
    for i in 0..n {
        let (a, b) = (poly[i], poly[j]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
        j = i;
    }
    inside
}

/// Counter-clockwise (y-up sense: increasing `atan2(dy, dx)` of the raw coordinates) order
/// of direction vectors, starting at +x. Exact for the given floats.
fn angle_cmp(a: Point, b: Point) -> Ordering {
    let half = |d: Point| if d[1] > 0.0 || (d[1] == 0.0 && d[0] > 0.0) { 0 } else { 1 };
    let (ha, hb) = (half(a), half(b));
    if ha != hb {
        return ha.cmp(&hb);
    }
    let cross = a[0] * b[1] - a[1] * b[0];
    if cross > 0.0 {
        Ordering::Less
    } else if cross < 0.0 {
        Ordering::Greater
    } else {
        Ordering::Equal
    }
}

/// Cleans (validates, removes duplicate and dangling edges) and extracts the faces of the
/// cleaned structure.
pub fn analyse_faces(sub: &Subdivision, options: &FaceOptions) -> Result<(Cleaned, Faces), StructureError> {
    let cleaned = validate::clean(sub)?;
    let faces = extract_faces_with(&cleaned.subdivision, options);
    if faces.regions.is_empty() {
        return Err(StructureError::AllDegenerate {
            edges: sub.edges.len(),
            pruned: cleaned.pruned_edges.len() + cleaned.duplicate_edges.len(),
        });
    }
    Ok((cleaned, faces))
}

/// [`extract_faces_with`] with default options (no sample size).
pub fn extract_faces(sub: &Subdivision) -> Faces {
    extract_faces_with(sub, &FaceOptions::default())
}

/// Extracts the faces of a valid subdivision (see the module documentation).
pub fn extract_faces_with(sub: &Subdivision, options: &FaceOptions) -> Faces {
    let v = &sub.vertices;
    let ne = sub.edges.len();
    let nh = 2 * ne;
    let origin = |h: usize| if h % 2 == 0 { sub.edges[h / 2][0] } else { sub.edges[h / 2][1] };
    let head = |h: usize| origin(h ^ 1);

    // Outgoing half-edges per vertex, sorted by angle.
    let mut out: Vec<Vec<usize>> = vec![Vec::new(); v.len()];
    for h in 0..nh {
        out[origin(h)].push(h);
    }
    let mut pos_in_out = vec![0usize; nh];
    for list in out.iter_mut() {
        if list.len() > 1 {
            list.sort_by(|&a, &b| {
                let (o, ha, hb) = (v[origin(a)], v[head(a)], v[head(b)]);
                angle_cmp([ha[0] - o[0], ha[1] - o[1]], [hb[0] - o[0], hb[1] - o[1]]).then(a.cmp(&b))
            });
        }
        for (p, &h) in list.iter().enumerate() {
            pos_in_out[h] = p;
        }
    }
    let next = |h: usize| {
        let t = h ^ 1;
        let list = &out[origin(t)];
        let p = pos_in_out[t];
        list[(p + list.len() - 1) % list.len()]
    };

    // Trace the cycles.
    let mut cycle_of = vec![usize::MAX; nh];
    let mut cycles: Vec<Vec<usize>> = Vec::new();
    for start in 0..nh {
        if cycle_of[start] != usize::MAX {
            continue;
        }
        let id = cycles.len();
        let mut cyc = Vec::new();
        let mut h = start;
        loop {
            cycle_of[h] = id;
            cyc.push(h);
            h = next(h);
            if h == start {
                break;
            }
        }
        cycles.push(cyc);
    }
    let cycle_points = |c: &Vec<usize>| -> Vec<Point> { c.iter().map(|&h| v[origin(h)]).collect::<Vec<Point>>() };
    let areas: Vec<f64> = cycles.iter().map(|c| signed_area(&cycle_points(c))).collect();

    // Components (union-find on edges).
    let mut parent: Vec<usize> = (0..v.len()).collect();
    fn find(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    for e in &sub.edges {
        let (a, b) = (find(&mut parent, e[0]), find(&mut parent, e[1]));
        if a != b {
            parent[a.max(b)] = a.min(b);
        }
    }
    let mut used = vec![false; v.len()];
    for e in &sub.edges {
        used[e[0]] = true;
        used[e[1]] = true;
    }
    let mut comp_id = vec![usize::MAX; v.len()];
    let mut components = 0;
    for i in 0..v.len() {
        if used[i] {
            let r = find(&mut parent, i);
            if comp_id[r] == usize::MAX {
                comp_id[r] = components;
                components += 1;
            }
            comp_id[i] = comp_id[r];
        }
    }
    let cycle_comp: Vec<usize> = cycles.iter().map(|c| comp_id[origin(c[0])]).collect();
    // The outside of each component: its cycle with the smallest signed area.
    let mut outside = vec![usize::MAX; components];
    for (c, &comp) in cycle_comp.iter().enumerate() {
        let cur = outside[comp];
        if cur == usize::MAX || areas[c] < areas[cur] {
            outside[comp] = c;
        }
    }
    let is_outside: Vec<bool> = (0..cycles.len()).map(|c| outside[cycle_comp[c]] == c).collect();

    // Bounded faces become regions, in cycle order (deterministic).
    let mut region_of_cycle = vec![usize::MAX; cycles.len()];
    let mut regions: Vec<Region> = Vec::new();
    for (c, cyc) in cycles.iter().enumerate() {
        if is_outside[c] {
            continue;
        }
        region_of_cycle[c] = regions.len();
        regions.push(Region {
            boundary: cyc.iter().map(|&h| origin(h)).collect(),
            boundary_edges: cyc.iter().map(|&h| h / 2).collect(),
            holes: Vec::new(),
            area: areas[c],
            touches_outer: false,
            touches_sample_border: false,
        });
    }

    // Attach each component's outside to the smallest region of another component that
    // contains it; the rest form the unbounded face.
    let mut outer_boundaries = Vec::new();
    let region_polys: Vec<Vec<Point>> = regions.iter().map(|r| r.boundary.iter().map(|&i| v[i]).collect()).collect();
    let region_comp: Vec<usize> = regions.iter().map(|r| comp_id[r.boundary[0]]).collect();
    let bboxes: Vec<[f64; 4]> = region_polys.iter().map(|p| bbox(p)).collect();
    for (comp, &c) in outside.iter().enumerate() {
        let probe = v[origin(cycles[c][0])];
        let mut best: Option<usize> = None;
        if components > 1 {
            for (r, poly) in region_polys.iter().enumerate() {
                if region_comp[r] == comp {
                    continue;
                }
                let b = bboxes[r];
                if probe[0] < b[0] || probe[0] > b[2] || probe[1] < b[1] || probe[1] > b[3] {
                    continue;
                }
                if point_in_polygon(probe, poly) && best.is_none_or(|q| regions[r].area < regions[q].area) {
                    best = Some(r);
                }
            }
        }
        let verts: Vec<usize> = cycles[c].iter().map(|&h| origin(h)).collect();
        match best {
            Some(r) => {
                region_of_cycle[c] = r;
                regions[r].holes.push(verts);
            }
            None => outer_boundaries.push(verts),
        }
    }
    for reg in regions.iter_mut() {
        let hole_area: f64 =
            reg.holes.iter().map(|hc| signed_area(&hc.iter().map(|&i| v[i]).collect::<Vec<_>>())).sum();
        reg.area += hole_area;
    }

    let edge_regions: Vec<[Option<usize>; 2]> = (0..ne)
        .map(|k| {
            let side = |h: usize| {
                let r = region_of_cycle[cycle_of[h]];
                (r != usize::MAX).then_some(r)
            };
            [side(2 * k), side(2 * k + 1)]
        })
        .collect();
    for er in &edge_regions {
        match *er {
            [Some(r), None] | [None, Some(r)] => regions[r].touches_outer = true,
            _ => {}
        }
    }
    if let Some([w, h]) = options.sample_size {
        let t = options.border_tol;
        for reg in regions.iter_mut() {
            reg.touches_sample_border = reg.boundary.iter().any(|&i| {
                let p = v[i];
                p[0] <= t || p[1] <= t || p[0] >= w - t || p[1] >= h - t
            });
        }
    }
    Faces {
        regions,
        edge_regions,
        outer_boundaries,
        components,
        vertex_count: used.iter().filter(|&&u| u).count(),
        edge_count: ne,
    }
}

fn bbox(p: &[Point]) -> [f64; 4] {
    let mut b = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
    for q in p {
        b[0] = b[0].min(q[0]);
        b[1] = b[1].min(q[1]);
        b[2] = b[2].max(q[0]);
        b[3] = b[3].max(q[1]);
    }
    b
}

/// Builds the subdivision of a mesh: the mesh's vertices and one edge per distinct pair of
/// consecutive cycle vertices, sorted.
pub fn mesh_to_subdivision(mesh: &Mesh) -> Subdivision {
    let mut edges: Vec<[usize; 2]> = Vec::new();
    for cyc in &mesh.regions {
        for i in 0..cyc.len() {
            let (a, b) = (cyc[i], cyc[(i + 1) % cyc.len()]);
            edges.push([a.min(b), a.max(b)]);
        }
    }
    edges.sort_unstable();
    edges.dedup();
    Subdivision { vertices: mesh.vertices.clone(), edges }
}

#[cfg(test)]
mod tests;
