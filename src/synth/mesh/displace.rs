//! Per-face subdivision and displacement of a coarse polygon [`Mesh`] by a height map (Frasson
//! Ch. 5, rendering).
//!
//! Each coarse face is subdivided **on its own**: no vertex is shared across a coarse edge, so
//! neighbouring faces may have different subdivision levels. Triangles are subdivided
//! barycentrically into `n²` sub-triangles, quads bilinearly into `n × n` cells (two triangles
//! each), and other polygons are fanned from their centroid, each fan triangle then subdivided
//! barycentrically. Every sample vertex moves by `scale·(g − mid)·N`, where `g` is the bilinear
//! height at the vertex's interpolated UV and `N` the coarse face's unit (Newell) normal. The gaps
//! this opens along the coarse edges are closed by [`super::seam`].

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::raster::Image;

use super::meshes::Mesh;

/// How finely each coarse face is subdivided.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Subdiv {
    /// `n` per side = the face's depth resolution / 2, clamped to `[1, 256]`; the depth resolution
    /// is the face's footprint in the height map: its longest UV edge, in texels.
    Auto,
    /// `n` per side for every face (at least 1).
    Fixed(u32),
}

/// Displacement settings.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DisplaceParams {
    /// Displacement of a height-map value of 1 relative to `mid`, in mesh units.
    pub scale: f32,
    /// The height-map value that does not move the surface (0.5: grey is the original surface).
    pub mid: f32,
    pub subdiv: Subdiv,
    /// Refuse to build more vertices than this (checked before anything is allocated).
    pub max_vertices: usize,
}

impl Default for DisplaceParams {
    fn default() -> Self {
        Self { scale: 1.0, mid: 0.5, subdiv: Subdiv::Auto, max_vertices: 50_000_000 }
    }
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DisplaceError {
    #[error("the height map must have 1 channel and at least one pixel (got {width}x{height}x{channels})")]
    HeightMap { width: usize, height: usize, channels: usize },
    #[error("displacement parameters must be finite (scale {scale}, mid {mid})")]
    Params { scale: f32, mid: f32 },
    #[error("face {face}: {reason}")]
    Face { face: usize, reason: &'static str },
    #[error("displacement would build {needed} vertices, more than the limit of {limit}")]
    TooManyVertices { needed: u64, limit: usize },
}

/// One displaced coarse face: its own vertex grid and triangles.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DisplacedFace {
    /// Subdivision level per side.
    pub n: u32,
    /// The coarse face's unit Newell normal (the displacement direction).
    pub normal: Vec3,
    /// The coarse corners, by index into [`Mesh::positions`], in winding order.
    pub corners: Vec<u32>,
    /// The coarse corners' UVs, in winding order.
    pub corner_uvs: Vec<Vec2>,
    /// The coarse corners' positions before displacement, in winding order.
    pub corner_positions: Vec<Vec3>,
    pub positions: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    /// Vertex normals of the displaced geometry (area-weighted).
    pub normals: Vec<Vec3>,
    /// Counter-clockwise seen from outside, as the coarse face.
    pub triangles: Vec<[u32; 3]>,
    /// For each coarse edge `i` (corner `i` to corner `i + 1`), its boundary vertices in order,
    /// from the vertex at corner `i` to the one at corner `i + 1`.
    pub edges: Vec<Vec<u32>>,
    /// Triangles whose displaced normal points against the coarse normal.
    pub folded: usize,
}

/// A displaced mesh: every coarse face with its own vertices (nothing shared across coarse edges).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Displaced {
    pub faces: Vec<DisplacedFace>,
    /// Self-intersection heuristic: displaced triangles whose normal flipped against their coarse
    /// face's normal (dot < 0), over all faces. The caller warns when this is not 0.
    pub folded_triangles: usize,
}

impl Displaced {
    /// Total vertices over all faces.
    pub fn vertex_count(&self) -> usize {
        self.faces.iter().map(|f| f.positions.len()).sum()
    }

    /// Index of each face's first vertex in the concatenation of all faces' vertices.
    pub fn vertex_offsets(&self) -> Vec<u32> {
        let mut at = 0u32;
        self.faces
            .iter()
            .map(|f| {
                let o = at;
                at += f.positions.len() as u32;
                o
            })
            .collect()
    }
}

/// Bilinear sample of channel 0 at `uv` (v up: texel row = (1 − v)·height), texel centres at
/// half-integers, clamped at the borders.
pub fn sample_bilinear(img: &Image, uv: Vec2) -> f32 {
    sample_channel(img, uv, 0)
}

/// Bilinear sample of channel `c` at `uv`, as [`sample_bilinear`].
pub fn sample_channel(img: &Image, uv: Vec2, c: usize) -> f32 {
    let (w, h) = (img.width, img.height);
    let x = (uv.x * w as f32 - 0.5).clamp(0.0, (w - 1) as f32);
    let y = ((1.0 - uv.y) * h as f32 - 0.5).clamp(0.0, (h - 1) as f32);
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let top = img.get(x0, y0, c) * (1.0 - fx) + img.get(x1, y0, c) * fx;
    let bottom = img.get(x0, y1, c) * (1.0 - fx) + img.get(x1, y1, c) * fx;
    top * (1.0 - fy) + bottom * fy
}

/// Newell normal of a polygon, unit length; `None` when degenerate.
pub fn newell_normal(points: &[Vec3]) -> Option<Vec3> {
    let k = points.len();
    let sum: Vec3 = (0..k).map(|i| points[i].cross(points[(i + 1) % k])).sum();
    let len = sum.length();
    (len.is_finite() && len > 0.0).then(|| sum / len)
}

/// The subdivision level of a face with corner UVs `uvs` on a `width × height` height map.
pub fn subdivision_level(uvs: &[Vec2], width: usize, height: usize, subdiv: Subdiv) -> u32 {
    match subdiv {
        Subdiv::Fixed(n) => n.max(1),
        Subdiv::Auto => {
            let k = uvs.len();
            let size = Vec2::new(width as f32, height as f32);
            let res = (0..k).map(|i| ((uvs[(i + 1) % k] - uvs[i]) * size).length()).fold(0.0f32, f32::max);
            let n = (res / 2.0).round();
            if n.is_finite() {
                n.clamp(1.0, 256.0) as u32
            } else {
                1
            }
        }
    }
}

/// Vertices of a face with `corners` corners at level `n` (saturating).
pub fn face_vertex_count(corners: usize, n: u32) -> u64 {
    let n = u64::from(n);
    match corners {
        3 => (n + 1).saturating_mul(n + 2) / 2,
        4 => (n + 1).saturating_mul(n + 1),
        k => {
            let k = k as u64;
            1u64.saturating_add(k.saturating_mul(n)).saturating_add(k.saturating_mul(n.saturating_mul(n - 1) / 2))
        }
    }
}

/// Subdivides every face of `mesh` and moves its vertices along the coarse face normal by
/// `scale·(g − mid)`, `g` the bilinear `height` (1 channel, values in [0, 1]) at the vertex's UV.
pub fn displace(mesh: &Mesh, height: &Image, params: &DisplaceParams) -> Result<Displaced, DisplaceError> {
    if height.channels != 1 || height.width == 0 || height.height == 0 {
        return Err(DisplaceError::HeightMap { width: height.width, height: height.height, channels: height.channels });
    }
    if !params.scale.is_finite() || !params.mid.is_finite() {
        return Err(DisplaceError::Params { scale: params.scale, mid: params.mid });
    }
    // Validate and plan every face before allocating any grid.
    let mut plans = Vec::with_capacity(mesh.faces.len());
    let mut needed = 0u64;
    for (fi, face) in mesh.faces.iter().enumerate() {
        let bad = |reason| DisplaceError::Face { face: fi, reason };
        if face.positions.len() < 3 {
            return Err(bad("fewer than 3 corners"));
        }
        if face.uvs.len() != face.positions.len() {
            return Err(bad("needs one UV per corner"));
        }
        let ps: Option<Vec<Vec3>> = face.positions.iter().map(|&i| mesh.positions.get(i as usize).copied()).collect();
        let uvs: Option<Vec<Vec2>> = face.uvs.iter().map(|&i| mesh.uvs.get(i as usize).copied()).collect();
        let (Some(ps), Some(uvs)) = (ps, uvs) else {
            return Err(bad("index out of range"));
        };
        if !ps.iter().all(|p| p.is_finite()) || !uvs.iter().all(|u| u.is_finite()) {
            return Err(bad("non-finite position or UV"));
        }
        let normal = newell_normal(&ps).ok_or_else(|| bad("degenerate (zero area)"))?;
        let n = subdivision_level(&uvs, height.width, height.height, params.subdiv);
        needed = needed.saturating_add(face_vertex_count(ps.len(), n));
        plans.push((face.positions.clone(), ps, uvs, normal, n));
    }
    if needed > params.max_vertices as u64 {
        return Err(DisplaceError::TooManyVertices { needed, limit: params.max_vertices });
    }
    let faces: Vec<DisplacedFace> = plans
        .into_par_iter()
        .map(|(corners, ps, uvs, normal, n)| {
            let mut f = subdivide(&ps, &uvs, n as usize);
            f.n = n;
            f.normal = normal;
            f.corners = corners;
            f.corner_uvs = uvs;
            f.corner_positions = ps;
            for (p, &uv) in f.positions.iter_mut().zip(&f.uvs) {
                let g = sample_bilinear(height, uv);
                *p += params.scale * (g - params.mid) * normal;
            }
            finish_normals(&mut f);
            f
        })
        .collect();
    let folded_triangles = faces.iter().map(|f| f.folded).sum();
    Ok(Displaced { faces, folded_triangles })
}

/// Vertex normals from the displaced triangles, and the count of folded triangles.
fn finish_normals(f: &mut DisplacedFace) {
    let mut normals = vec![Vec3::ZERO; f.positions.len()];
    let mut folded = 0;
    for t in &f.triangles {
        let [a, b, c] = t.map(|i| f.positions[i as usize]);
        let cross = (b - a).cross(c - a);
        if cross.dot(f.normal) < 0.0 {
            folded += 1;
        }
        for &i in t {
            normals[i as usize] += cross;
        }
    }
    for nrm in &mut normals {
        *nrm = nrm.try_normalize().unwrap_or(f.normal);
    }
    f.normals = normals;
    f.folded = folded;
}

/// The undisplaced grid of one face: positions, UVs, triangles and edge lists.
fn subdivide(ps: &[Vec3], uvs: &[Vec2], n: usize) -> DisplacedFace {
    match ps.len() {
        3 => subdivide_triangle(ps, uvs, n),
        4 => subdivide_quad(ps, uvs, n),
        _ => subdivide_fan(ps, uvs, n),
    }
}

fn subdivide_triangle(ps: &[Vec3], uvs: &[Vec2], n: usize) -> DisplacedFace {
    // Lattice (i, j), i + j <= n, i along corner 0 -> 1, j along corner 0 -> 2; rows by j.
    let offset = |j: usize| j * (n + 1) - j * j.saturating_sub(1) / 2;
    let idx = |i: usize, j: usize| (offset(j) + i) as u32;
    let count = (n + 1) * (n + 2) / 2;
    let mut f =
        DisplacedFace { positions: Vec::with_capacity(count), uvs: Vec::with_capacity(count), ..Default::default() };
    let inv = 1.0 / n as f32;
    for j in 0..=n {
        for i in 0..=n - j {
            let (a, b) = (i as f32 * inv, j as f32 * inv);
            f.positions.push(ps[0] * (1.0 - a - b) + ps[1] * a + ps[2] * b);
            f.uvs.push(uvs[0] * (1.0 - a - b) + uvs[1] * a + uvs[2] * b);
        }
    }
    f.triangles.reserve(n * n);
    for j in 0..n {
        for i in 0..n - j {
            f.triangles.push([idx(i, j), idx(i + 1, j), idx(i, j + 1)]);
            if i + 1 < n - j {
                f.triangles.push([idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)]);
            }
        }
    }
    f.edges = vec![
        (0..=n).map(|t| idx(t, 0)).collect(),
        (0..=n).map(|t| idx(n - t, t)).collect(),
        (0..=n).map(|t| idx(0, n - t)).collect(),
    ];
    f
}

fn subdivide_quad(ps: &[Vec3], uvs: &[Vec2], n: usize) -> DisplacedFace {
    // Grid (s, t), s along corner 0 -> 1, t along corner 0 -> 3; rows by t.
    let idx = |s: usize, t: usize| (t * (n + 1) + s) as u32;
    let count = (n + 1) * (n + 1);
    let mut f =
        DisplacedFace { positions: Vec::with_capacity(count), uvs: Vec::with_capacity(count), ..Default::default() };
    let inv = 1.0 / n as f32;
    for t in 0..=n {
        let b = t as f32 * inv;
        for s in 0..=n {
            let a = s as f32 * inv;
            let (w0, w1, w2, w3) = ((1.0 - a) * (1.0 - b), a * (1.0 - b), a * b, (1.0 - a) * b);
            f.positions.push(ps[0] * w0 + ps[1] * w1 + ps[2] * w2 + ps[3] * w3);
            f.uvs.push(uvs[0] * w0 + uvs[1] * w1 + uvs[2] * w2 + uvs[3] * w3);
        }
    }
    f.triangles.reserve(2 * n * n);
    for t in 0..n {
        for s in 0..n {
            f.triangles.push([idx(s, t), idx(s + 1, t), idx(s + 1, t + 1)]);
            f.triangles.push([idx(s, t), idx(s + 1, t + 1), idx(s, t + 1)]);
        }
    }
    f.edges = vec![
        (0..=n).map(|k| idx(k, 0)).collect(),
        (0..=n).map(|k| idx(n, k)).collect(),
        (0..=n).map(|k| idx(n - k, n)).collect(),
        (0..=n).map(|k| idx(0, n - k)).collect(),
    ];
    f
}

fn subdivide_fan(ps: &[Vec3], uvs: &[Vec2], n: usize) -> DisplacedFace {
    let m = ps.len();
    let centre_p = ps.iter().copied().sum::<Vec3>() / m as f32;
    let centre_uv = uvs.iter().copied().sum::<Vec2>() / m as f32;
    // Vertex 0 is the centre; spoke k (centre -> corner k) holds 1 + k·n + (t − 1) for t = 1..=n
    // (t = n is the corner); then each fan triangle's interior lattice points (i, j >= 1).
    let per_interior = n * (n - 1) / 2;
    let spoke = |k: usize, t: usize| (1 + (k % m) * n + t - 1) as u32;
    let interior_row = |j: usize| (j - 1) * n - (j - 1) * j / 2;
    let interior = |k: usize, i: usize, j: usize| (1 + m * n + k * per_interior + interior_row(j) + i - 1) as u32;
    let idx = |k: usize, i: usize, j: usize| match (i, j) {
        (0, 0) => 0,
        (i, 0) => spoke(k, i),
        (0, j) => spoke(k + 1, j),
        (i, j) => interior(k, i, j),
    };
    let count = 1 + m * n + m * per_interior;
    let mut f =
        DisplacedFace { positions: vec![Vec3::ZERO; count], uvs: vec![Vec2::ZERO; count], ..Default::default() };
    let inv = 1.0 / n as f32;
    f.positions[0] = centre_p;
    f.uvs[0] = centre_uv;
    for k in 0..m {
        for t in 1..=n {
            let a = t as f32 * inv;
            let v = spoke(k, t) as usize;
            f.positions[v] = centre_p * (1.0 - a) + ps[k] * a;
            f.uvs[v] = centre_uv * (1.0 - a) + uvs[k] * a;
        }
    }
    for k in 0..m {
        let k1 = (k + 1) % m;
        for j in 1..n {
            for i in 1..=n - j {
                let (a, b) = (i as f32 * inv, j as f32 * inv);
                let v = interior(k, i, j) as usize;
                f.positions[v] = centre_p * (1.0 - a - b) + ps[k] * a + ps[k1] * b;
                f.uvs[v] = centre_uv * (1.0 - a - b) + uvs[k] * a + uvs[k1] * b;
            }
        }
        for j in 0..n {
            for i in 0..n - j {
                f.triangles.push([idx(k, i, j), idx(k, i + 1, j), idx(k, i, j + 1)]);
                if i + 1 < n - j {
                    f.triangles.push([idx(k, i + 1, j), idx(k, i + 1, j + 1), idx(k, i, j + 1)]);
                }
            }
        }
        f.edges.push((0..=n).map(|t| idx(k, n - t, t)).collect());
    }
    f
}
