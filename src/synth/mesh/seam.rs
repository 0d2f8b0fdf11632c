//! Seam zipping: the triangle strips that close the gaps displacement opens along the coarse
//! edges (Frasson Ch. 5, "stitching"), and the small fans that close the holes left where three
//! or more faces meet at a coarse corner.
//!
//! A **seam** is a coarse edge shared by two faces `A` and `B` (by position index, in opposite
//! directions). Its two sides are `E1`, face A's boundary vertices along the edge, and `E2`, face
//! B's, both walked in face A's direction. Their vertex counts `N1` and `N2` may differ (each face
//! has its own subdivision level). The zip is built in two passes:
//! 1. a monotone map `j(i) = argmin_{j ≥ j(i−1)} |u_i − v_j|` (3-D distance);
//! 2. each `v_j` left unmatched between `j(i)` and `j(i+1)` is linked to the nearer of `u_i` and
//!    `u_{i+1}`,
//!
//! and the strip is triangulated between consecutive links. Two choices are made here that the
//! description leaves open: the end links are pinned to the corners (`j(0) = 0` and
//! `j(N1−1) = N2−1`), so the strip ends where the faces' corners are and the corner fans can
//! close the surface; and in pass 2 once a `v_j` goes to `u_{i+1}` the later ones do too, so
//! links never cross.

use std::collections::{BTreeMap, HashMap};

use glam::Vec3;
use rayon::prelude::*;

use super::displace::Displaced;
use super::meshes::TriMesh;

/// A vertex of a displaced face: [`Displaced::faces`]`[face].positions[vertex]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
pub struct VertexRef {
    pub face: u32,
    pub vertex: u32,
}

/// The triangle strip zipping one seam.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Strip {
    pub face_a: u32,
    /// The seam's edge index in face A (corner `edge_a` to `edge_a + 1`).
    pub edge_a: u32,
    pub face_b: u32,
    pub edge_b: u32,
    /// The coarse edge by position index, in face A's winding.
    pub edge: (u32, u32),
    /// `E1`: face A's boundary vertices along the seam, from `edge.0` to `edge.1`.
    pub side_a: Vec<u32>,
    /// `E2`: face B's boundary vertices along the seam, also from `edge.0` to `edge.1`.
    pub side_b: Vec<u32>,
    /// The links `(i, j)` between `side_a[i]` and `side_b[j]`, in order along the seam: both
    /// coordinates non-decreasing, consecutive links one step apart.
    pub links: Vec<(u32, u32)>,
    /// Oriented like the faces (outward).
    pub triangles: Vec<[VertexRef; 3]>,
}

/// The fan closing the hole at a coarse vertex where three or more faces meet.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CornerFan {
    /// The coarse vertex, by position index.
    pub vertex: u32,
    /// The faces' corner vertices around it, in the order the fan joins them.
    pub corners: Vec<VertexRef>,
    pub triangles: Vec<[VertexRef; 3]>,
}

/// Every seam strip and corner fan of a displaced mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Seams {
    pub strips: Vec<Strip>,
    pub corners: Vec<CornerFan>,
}

/// Which side of a seam a strip vertex lies on, and its index along that side.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    A(u32),
    B(u32),
}

/// The links of a seam with sides `e1` (`u`) and `e2` (`v`), both walked in the same direction:
/// pass 1 (monotone nearest), pass 2 (the unmatched `v_j` to the nearer neighbour), ends pinned
/// to `(0, 0)` and `(N1 − 1, N2 − 1)`. Empty when a side is.
pub fn zip_links(e1: &[Vec3], e2: &[Vec3]) -> Vec<(u32, u32)> {
    let (n1, n2) = (e1.len(), e2.len());
    if n1 == 0 || n2 == 0 {
        return Vec::new();
    }
    // Pass 1.
    let mut map = vec![0usize; n1];
    for i in 1..n1 {
        map[i] = if i + 1 == n1 {
            n2 - 1
        } else {
            let from = map[i - 1];
            let mut best = from;
            let mut best_d = e1[i].distance_squared(e2[from]);
            for (j, v) in e2.iter().enumerate().skip(from + 1) {
                let d = e1[i].distance_squared(*v);
                if d < best_d {
                    best = j;
                    best_d = d;
                }
            }
            best
        };
    }
    // Pass 2.
    let mut links = Vec::with_capacity(n1 + n2);
    links.push((0u32, 0u32));
    for i in 0..n1 - 1 {
        let (lo, hi) = (map[i], map[i + 1]);
        let mut to_next = false;
        for (j, v) in e2.iter().enumerate().take(hi).skip(lo + 1) {
            to_next = to_next || v.distance_squared(e1[i + 1]) < v.distance_squared(e1[i]);
            links.push(((if to_next { i + 1 } else { i }) as u32, j as u32));
        }
        links.push(((i + 1) as u32, hi as u32));
    }
    // One side of a single vertex: the rest of the other side links to it.
    if n1 == 1 {
        links.extend((1..n2).map(|j| (0, j as u32)));
    }
    links
}

/// The strip's triangles between consecutive links, oriented for a face A on the left of the
/// walking direction and a face B on its right (seen from outside): a step in `i` gives
/// `u_{i+1} u_i v_j`, a step in `j` gives `u_i v_j v_{j+1}`, a diagonal step the two triangles
/// of the quad split along its shorter diagonal.
pub fn strip_triangles(e1: &[Vec3], e2: &[Vec3], links: &[(u32, u32)]) -> Vec<[Side; 3]> {
    let mut out = Vec::with_capacity(links.len() * 2);
    for w in links.windows(2) {
        let ((i, j), (i2, j2)) = (w[0], w[1]);
        let step_i = [Side::A(i + 1), Side::A(i), Side::B(j)];
        let step_j = [Side::A(i), Side::B(j), Side::B(j + 1)];
        match (i2 - i, j2 - j) {
            (1, 0) => out.push(step_i),
            (0, 1) => out.push(step_j),
            (1, 1) => {
                let (u0, u1, v0, v1) = (e1[i as usize], e1[i2 as usize], e2[j as usize], e2[j2 as usize]);
                if u1.distance_squared(v0) <= u0.distance_squared(v1) {
                    out.push(step_i);
                    out.push([Side::A(i + 1), Side::B(j), Side::B(j + 1)]);
                } else {
                    out.push(step_j);
                    out.push([Side::A(i + 1), Side::A(i), Side::B(j + 1)]);
                }
            }
            _ => unreachable!("links are one step apart"),
        }
    }
    out
}

/// Zips every seam of a displaced mesh and closes the corner holes.
pub fn zip(displaced: &Displaced) -> Seams {
    let faces = &displaced.faces;
    // Directed coarse edge -> (face, edge index); the first use wins on a non-manifold mesh.
    let mut directed: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
    for (fi, f) in faces.iter().enumerate() {
        let k = f.corners.len();
        for e in 0..k {
            directed.entry((f.corners[e], f.corners[(e + 1) % k])).or_insert((fi as u32, e as u32));
        }
    }
    let mut pairs = Vec::new();
    for (fi, f) in faces.iter().enumerate() {
        let k = f.corners.len();
        for e in 0..k {
            let (a, b) = (f.corners[e], f.corners[(e + 1) % k]);
            if a == b || directed.get(&(a, b)) != Some(&(fi as u32, e as u32)) {
                continue;
            }
            if let Some(&(g, e2)) = directed.get(&(b, a)) {
                if (fi as u32, e as u32) < (g, e2) {
                    pairs.push((fi as u32, e as u32, g, e2, (a, b)));
                }
            }
        }
    }
    let strips: Vec<Strip> = pairs
        .into_par_iter()
        .map(|(fa, ea, fb, eb, edge)| {
            let (face_a, face_b) = (&faces[fa as usize], &faces[fb as usize]);
            let side_a = face_a.edges[ea as usize].clone();
            let side_b: Vec<u32> = face_b.edges[eb as usize].iter().rev().copied().collect();
            let e1: Vec<Vec3> = side_a.iter().map(|&v| face_a.positions[v as usize]).collect();
            let e2: Vec<Vec3> = side_b.iter().map(|&v| face_b.positions[v as usize]).collect();
            let links = zip_links(&e1, &e2);
            let at = |s: Side| match s {
                Side::A(i) => VertexRef { face: fa, vertex: side_a[i as usize] },
                Side::B(j) => VertexRef { face: fb, vertex: side_b[j as usize] },
            };
            let triangles = strip_triangles(&e1, &e2, &links).into_iter().map(|t| t.map(at)).collect();
            Strip { face_a: fa, edge_a: ea, face_b: fb, edge_b: eb, edge, side_a, side_b, links, triangles }
        })
        .collect();
    let corners = corner_fans(&strips);
    Seams { strips, corners }
}

/// The fans at the coarse vertices: each strip leaves its end links on the border (`u_0 → v_0`
/// at its start, `v_J → u_I` at its end); around a coarse vertex these border edges chain into
/// a small polygon, which the fan covers in the opposite direction.
fn corner_fans(strips: &[Strip]) -> Vec<CornerFan> {
    // Per coarse vertex, the directed edges the fan must contain.
    let mut needed: BTreeMap<u32, Vec<(VertexRef, VertexRef)>> = BTreeMap::new();
    for s in strips {
        let (Some(&a0), Some(&b0), Some(&a1), Some(&b1)) =
            (s.side_a.first(), s.side_b.first(), s.side_a.last(), s.side_b.last())
        else {
            continue;
        };
        let ra = |v| VertexRef { face: s.face_a, vertex: v };
        let rb = |v| VertexRef { face: s.face_b, vertex: v };
        needed.entry(s.edge.0).or_default().push((rb(b0), ra(a0)));
        needed.entry(s.edge.1).or_default().push((ra(a1), rb(b1)));
    }
    let mut fans = Vec::new();
    for (vertex, edges) in needed {
        let next: BTreeMap<VertexRef, VertexRef> = edges.iter().copied().collect();
        let has_incoming: std::collections::BTreeSet<VertexRef> = edges.iter().map(|e| e.1).collect();
        let mut used = std::collections::BTreeSet::new();
        // Open chains first (from a start with no incoming edge), then cycles.
        let starts: Vec<VertexRef> =
            edges.iter().map(|e| e.0).filter(|s| !has_incoming.contains(s)).chain(edges.iter().map(|e| e.0)).collect();
        for start in starts {
            if used.contains(&start) {
                continue;
            }
            let mut chain = vec![start];
            used.insert(start);
            let mut at = start;
            while let Some(&to) = next.get(&at) {
                if to == start || used.contains(&to) {
                    break;
                }
                chain.push(to);
                used.insert(to);
                at = to;
            }
            if chain.len() >= 3 {
                let triangles = (1..chain.len() - 1).map(|t| [chain[0], chain[t], chain[t + 1]]).collect();
                fans.push(CornerFan { vertex, corners: chain, triangles });
            }
        }
    }
    fans
}

impl Displaced {
    /// One triangle mesh: every face's vertices and triangles, then the strips' and fans'
    /// triangles on those same vertices (nothing is duplicated, so a zipped closed mesh is
    /// closed by vertex index).
    pub fn to_trimesh(&self, strips: &[Strip], corners: &[CornerFan]) -> TriMesh {
        let offsets = self.vertex_offsets();
        let total = self.vertex_count();
        let mut m = TriMesh {
            positions: Vec::with_capacity(total),
            normals: Vec::with_capacity(total),
            uvs: Vec::with_capacity(total),
            triangles: Vec::new(),
        };
        for (f, &o) in self.faces.iter().zip(&offsets) {
            m.positions.extend_from_slice(&f.positions);
            m.normals.extend_from_slice(&f.normals);
            m.uvs.extend_from_slice(&f.uvs);
            m.triangles.extend(f.triangles.iter().map(|t| t.map(|v| v + o)));
        }
        let global = |r: VertexRef| offsets[r.face as usize] + r.vertex;
        for t in strips.iter().flat_map(|s| &s.triangles).chain(corners.iter().flat_map(|c| &c.triangles)) {
            m.triangles.push(t.map(global));
        }
        m
    }
}
