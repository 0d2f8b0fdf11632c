//! Tangent frames on a polygon [`Mesh`], and its triangulation into a [`TriMesh`]: what
//! displacement along the surface and a normal-mapped render both need.
//!
//! Both work on the same **vertices**: the distinct (position, UV) pairs of the faces' corners,
//! numbered in the order corners first use them. A position on a UV seam is one vertex per UV, so
//! each side of the seam gets its own frame; a normal is shared by every vertex of a position
//! (area-weighted over the faces around it, so seams stay closed in 3-D).
//!
//! Every face is cut into triangles the same way wherever that is needed
//! ([`face_triangles`]): a triangle is kept; a quad takes the diagonal that gives the better pair
//! of triangles; a larger polygon is ear-clipped in the plane of its Newell normal. Polygons need
//! not be planar or convex (a polygon whose projection crosses itself still gets a deterministic
//! triangulation, just not a good one).
//!
//! A frame is `tangent` (the direction of increasing u on the surface), `bitangent` (increasing
//! v) and `normal`, orthonormal: the tangent is the area-weighted average of the triangles'
//! `dP/du`, made orthogonal to the vertex normal (Gram–Schmidt), and the bitangent is
//! `w · normal × tangent` with `w = ±1` the handedness (glTF's convention for a tangent's `w`):
//! `+1` where the UVs run counter-clockwise like the face, `−1` where they are mirrored.

use std::collections::HashMap;

use glam::{DVec2, DVec3, Vec2, Vec3};

use super::check::newell;
use super::meshes::{Face, Mesh, TriMesh};

/// An orthonormal frame at a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Unit; the direction of increasing u, orthogonal to `normal`.
    pub tangent: Vec3,
    /// Unit; `w * normal.cross(tangent)`, the direction of increasing v.
    pub bitangent: Vec3,
    /// Unit; the area-weighted normal of the vertex's position.
    pub normal: Vec3,
    /// Handedness, `1.0` or `-1.0`.
    pub w: f32,
}

/// Tangent frames per vertex (see the module doc), and which vertex each face corner is.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Frames {
    /// Each vertex's `[position, uv]` indices into the mesh (`uv` is `u32::MAX` for a face
    /// without UVs).
    pub vertices: Vec<[u32; 2]>,
    /// One frame per vertex.
    pub frames: Vec<Frame>,
    /// The vertex of each face corner, faces one after the other.
    pub corners: Vec<u32>,
    /// Where each face's corners start in `corners`, plus the end: face `f` is
    /// `corners[face_starts[f]..face_starts[f + 1]]`. A face [`super::check::validate`] would
    /// refuse for its indices (or fewer than 3 corners) has no corners here.
    pub face_starts: Vec<u32>,
}

impl Frames {
    /// The vertex of corner `corner` of face `face`.
    pub fn vertex(&self, face: usize, corner: usize) -> u32 {
        let start = self.face_starts[face] as usize;
        assert!(start + corner < self.face_starts[face + 1] as usize, "face {face} has no corner {corner}");
        self.corners[start + corner]
    }

    /// The frame at corner `corner` of face `face`.
    pub fn at(&self, face: usize, corner: usize) -> &Frame {
        &self.frames[self.vertex(face, corner) as usize]
    }
}

/// A face relief can triangulate: at least 3 corners, all indices in range, one UV per corner or
/// none.
fn usable(mesh: &Mesh, face: &Face) -> bool {
    face.positions.len() >= 3
        && (face.uvs.is_empty() || face.uvs.len() == face.positions.len())
        && face.positions.iter().all(|&p| (p as usize) < mesh.positions.len())
        && face.uvs.iter().all(|&t| (t as usize) < mesh.uvs.len())
}

/// A triangle's quality: 1 for equilateral, 0 for degenerate (`4√3 · area / Σ edge²`).
fn quality(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let twice_area = (b - a).cross(c - a).length();
    let edges = a.distance_squared(b) + b.distance_squared(c) + c.distance_squared(a);
    if edges > 0.0 {
        2.0 * 3f64.sqrt() * twice_area / edges
    } else {
        0.0
    }
}

/// The triangles of a polygon given by its corner points, as corner indices, counter-clockwise
/// like the polygon (see the module doc for how).
pub fn polygon_triangles(points: &[Vec3]) -> Vec<[usize; 3]> {
    let n = points.len();
    if n < 3 {
        return Vec::new();
    }
    if n == 3 {
        return vec![[0, 1, 2]];
    }
    let p: Vec<DVec3> = points.iter().map(|q| q.as_dvec3() - points[0].as_dvec3()).collect();
    let normal = newell(&p);
    if normal.length_squared() == 0.0 || !normal.is_finite() {
        return (1..n - 1).map(|i| [0, i, i + 1]).collect();
    }
    let normal = normal.normalize();
    let u = normal.any_orthonormal_vector();
    let v = normal.cross(u);
    let flat: Vec<DVec2> = p.iter().map(|q| DVec2::new(q.dot(u), q.dot(v))).collect();
    let scale = p.iter().map(|q| q.length_squared()).fold(0.0, f64::max);
    let eps = 1e-12 * scale;
    let ccw = |a: usize, b: usize, c: usize| (flat[b] - flat[a]).perp_dot(flat[c] - flat[a]);
    if n == 4 {
        let options = [[[0, 1, 2], [0, 2, 3]], [[0, 1, 3], [1, 2, 3]]];
        let valid = |o: &[[usize; 3]; 2]| o.iter().all(|t| ccw(t[0], t[1], t[2]) > eps);
        let worst = |o: &[[usize; 3]; 2]| o.iter().map(|t| quality(p[t[0]], p[t[1]], p[t[2]])).fold(f64::MAX, f64::min);
        let pick = match (valid(&options[0]), valid(&options[1])) {
            (true, true) if worst(&options[1]) > worst(&options[0]) => 1,
            (false, true) => 1,
            _ => 0,
        };
        return options[pick].to_vec();
    }
    ear_clip(&flat, eps)
}

/// Ear clipping of a simple counter-clockwise polygon in the plane, O(n²).
fn ear_clip(flat: &[DVec2], eps: f64) -> Vec<[usize; 3]> {
    let mut left: Vec<usize> = (0..flat.len()).collect();
    let mut out = Vec::with_capacity(flat.len() - 2);
    let cross = |a: usize, b: usize, c: usize| (flat[b] - flat[a]).perp_dot(flat[c] - flat[a]);
    let inside = |q: DVec2, a: usize, b: usize, c: usize| {
        let (pa, pb, pc) = (flat[a], flat[b], flat[c]);
        if q == pa || q == pb || q == pc {
            return false;
        }
        (pb - pa).perp_dot(q - pa) >= 0.0 && (pc - pb).perp_dot(q - pb) >= 0.0 && (pa - pc).perp_dot(q - pc) >= 0.0
    };
    let mut i = 0;
    while left.len() > 3 {
        let m = left.len();
        let corner = |j: usize| (left[(j + m - 1) % m], left[j], left[(j + 1) % m]);
        let is_ear = |j: usize| {
            let (a, b, c) = corner(j);
            cross(a, b, c) > eps && !left.iter().any(|&x| x != a && x != b && x != c && inside(flat[x], a, b, c))
        };
        let found = (0..m).map(|s| (i + s) % m).find(|&j| is_ear(j));
        // No ear (the projection crosses itself): clip the most convex corner anyway.
        let j = found.unwrap_or_else(|| {
            (0..m)
                .max_by(|&x, &y| {
                    let (a, b, c) = corner(x);
                    let (d, e, f) = corner(y);
                    cross(a, b, c).total_cmp(&cross(d, e, f)).then(y.cmp(&x))
                })
                .unwrap_or(0)
        });
        let (a, b, c) = corner(j);
        out.push([a, b, c]);
        left.remove(j);
        i = j % left.len();
    }
    out.push([left[0], left[1], left[2]]);
    out
}

/// The triangles of one face as indices of its corners (see the module doc); empty for a face
/// with fewer than 3 corners or an index out of range.
pub fn face_triangles(mesh: &Mesh, face: &Face) -> Vec<[usize; 3]> {
    if !usable(mesh, face) {
        return Vec::new();
    }
    let points: Vec<Vec3> = face.positions.iter().map(|&p| mesh.positions[p as usize]).collect();
    polygon_triangles(&points)
}

/// The unit normal of each position: the sum of the Newell vectors (twice the vector areas) of
/// the faces around it, so larger faces count more. A position no face uses, or whose faces
/// cancel out, gets the normal of the first face with an area around it, else `+z`.
pub fn position_normals(mesh: &Mesh) -> Vec<Vec3> {
    let mut sum = vec![DVec3::ZERO; mesh.positions.len()];
    let mut first = vec![DVec3::ZERO; mesh.positions.len()];
    for face in mesh.faces.iter().filter(|f| usable(mesh, f)) {
        let o = mesh.positions[face.positions[0] as usize].as_dvec3();
        let points: Vec<DVec3> = face.positions.iter().map(|&p| mesh.positions[p as usize].as_dvec3() - o).collect();
        let n = newell(&points);
        if !n.is_finite() {
            continue;
        }
        for &p in &face.positions {
            sum[p as usize] += n;
            if first[p as usize] == DVec3::ZERO {
                first[p as usize] = n;
            }
        }
    }
    sum.iter()
        .zip(&first)
        .map(|(s, f)| {
            let n = if s.length() > 1e-9 * f.length() { s.normalize_or_zero() } else { f.normalize_or_zero() };
            if n == DVec3::ZERO {
                Vec3::Z
            } else {
                n.as_vec3()
            }
        })
        .collect()
}

/// The vertices of the module doc and the triangles over them.
struct Layout {
    vertices: Vec<[u32; 2]>,
    corners: Vec<u32>,
    face_starts: Vec<u32>,
    triangles: Vec<[u32; 3]>,
}

fn layout(mesh: &Mesh) -> Layout {
    let mut ids: HashMap<[u32; 2], u32> = HashMap::new();
    let mut l = Layout { vertices: Vec::new(), corners: Vec::new(), face_starts: vec![0], triangles: Vec::new() };
    for face in &mesh.faces {
        if usable(mesh, face) {
            let start = l.corners.len();
            for k in 0..face.len() {
                let key = [face.positions[k], face.uvs.get(k).copied().unwrap_or(u32::MAX)];
                let id = *ids.entry(key).or_insert_with(|| {
                    l.vertices.push(key);
                    (l.vertices.len() - 1) as u32
                });
                l.corners.push(id);
            }
            for t in face_triangles(mesh, face) {
                l.triangles.push(t.map(|k| l.corners[start + k]));
            }
        }
        l.face_starts.push(l.corners.len() as u32);
    }
    l
}

fn uv_of(mesh: &Mesh, vertex: [u32; 2]) -> Vec2 {
    mesh.uvs.get(vertex[1] as usize).copied().unwrap_or(Vec2::ZERO)
}

/// The tangent frame of every vertex (see the module doc).
pub fn tangent_frames(mesh: &Mesh) -> Frames {
    let l = layout(mesh);
    let normals = position_normals(mesh);
    let mut du = vec![DVec3::ZERO; l.vertices.len()];
    let mut dv = vec![DVec3::ZERO; l.vertices.len()];
    for tri in &l.triangles {
        let v = tri.map(|i| l.vertices[i as usize]);
        let p = v.map(|x| mesh.positions[x[0] as usize].as_dvec3());
        let t = v.map(|x| uv_of(mesh, x).as_dvec2());
        let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
        let (s1, s2) = (t[1] - t[0], t[2] - t[0]);
        let r = s1.perp_dot(s2);
        let area = 0.5 * e1.cross(e2).length();
        if r == 0.0 || area == 0.0 || !r.is_finite() {
            continue;
        }
        // dP/du and dP/dv of the triangle's linear map from UV to space.
        let dpdu = ((e1 * s2.y - e2 * s1.y) / r).normalize_or_zero() * area;
        let dpdv = ((e2 * s1.x - e1 * s2.x) / r).normalize_or_zero() * area;
        for &i in tri {
            du[i as usize] += dpdu;
            dv[i as usize] += dpdv;
        }
    }
    let frames = l
        .vertices
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let n = normals[v[0] as usize].as_dvec3();
            frame(n, du[i], dv[i])
        })
        .collect();
    Frames { vertices: l.vertices, frames, corners: l.corners, face_starts: l.face_starts }
}

/// Gram–Schmidt: the tangent is `du` without its part along `n`; when that is nothing, it comes
/// from `dv` (`dv × n`), else any direction orthogonal to `n`.
fn frame(n: DVec3, du: DVec3, dv: DVec3) -> Frame {
    let scale = du.length().max(dv.length());
    let ortho = |x: DVec3| x - n * n.dot(x);
    let mut t = ortho(du);
    if t.length() <= 1e-9 * scale || scale == 0.0 {
        t = ortho(dv.cross(n));
    }
    let t = if t.length() > 1e-9 * scale && scale > 0.0 { t.normalize() } else { n.any_orthonormal_vector() };
    let w = if n.cross(t).dot(dv) < 0.0 { -1.0 } else { 1.0 };
    Frame { tangent: t.as_vec3(), bitangent: (n.cross(t) * w).as_vec3(), normal: n.as_vec3(), w: w as f32 }
}

/// The mesh as indexed triangles over the vertices of the module doc (vertex `i` here is vertex
/// `i` of [`tangent_frames`]), with the area-weighted normal of each vertex's position and the
/// triangulation of [`face_triangles`]. Faces [`super::check::validate`] would refuse for their
/// indices are left out; a face without UVs gets UV `(0, 0)`.
pub fn triangulate(mesh: &Mesh) -> TriMesh {
    let l = layout(mesh);
    let normals = position_normals(mesh);
    TriMesh {
        positions: l.vertices.iter().map(|v| mesh.positions[v[0] as usize]).collect(),
        normals: l.vertices.iter().map(|v| normals[v[0] as usize]).collect(),
        uvs: l.vertices.iter().map(|&v| uv_of(mesh, v)).collect(),
        triangles: l.triangles,
    }
}

#[cfg(test)]
mod tests {
    use std::f32::consts::{PI, TAU};

    use super::super::check::validate;
    use super::*;

    fn face(positions: Vec<u32>, uvs: Vec<u32>) -> Face {
        Face { positions, uvs }
    }

    /// A UV sphere of radius 1: `rings` bands from the south pole (v = 0) to the north (v = 1),
    /// `segments` around (u from 0 to 1 eastwards, a seam at u = 0 = 1), quads between the
    /// bands and triangles at the poles (one pole position, one UV per segment).
    fn uv_sphere(rings: u32, segments: u32) -> Mesh {
        let mut m = Mesh::default();
        m.positions.push(-Vec3::Z);
        for r in 1..rings {
            let phi = PI * r as f32 / rings as f32;
            for s in 0..segments {
                let theta = TAU * s as f32 / segments as f32;
                m.positions.push(Vec3::new(phi.sin() * theta.cos(), phi.sin() * theta.sin(), -phi.cos()));
            }
        }
        m.positions.push(Vec3::Z);
        let north = m.positions.len() as u32 - 1;
        let ring_uv = |r: u32, s: u32| (r - 1) * (segments + 1) + s;
        for r in 1..rings {
            for s in 0..=segments {
                m.uvs.push(Vec2::new(s as f32 / segments as f32, r as f32 / rings as f32));
            }
        }
        let pole_uv = m.uvs.len() as u32;
        for s in 0..segments {
            m.uvs.push(Vec2::new((s as f32 + 0.5) / segments as f32, 0.0));
        }
        for s in 0..segments {
            m.uvs.push(Vec2::new((s as f32 + 0.5) / segments as f32, 1.0));
        }
        let pos = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
        for s in 0..segments {
            // Counter-clockwise seen from outside: east along the lower ring, then back west
            // above (the south pole is the lower ring of its triangles, the north the upper).
            m.faces.push(face(vec![0, pos(1, s + 1), pos(1, s)], vec![pole_uv + s, ring_uv(1, s + 1), ring_uv(1, s)]));
            for r in 1..rings - 1 {
                m.faces.push(face(
                    vec![pos(r, s), pos(r, s + 1), pos(r + 1, s + 1), pos(r + 1, s)],
                    vec![ring_uv(r, s), ring_uv(r, s + 1), ring_uv(r + 1, s + 1), ring_uv(r + 1, s)],
                ));
            }
            let r = rings - 1;
            m.faces.push(face(
                vec![pos(r, s), pos(r, s + 1), north],
                vec![ring_uv(r, s), ring_uv(r, s + 1), pole_uv + segments + s],
            ));
        }
        m
    }

    /// An open cylinder of radius 1 around z from 0 to 2, u around (seam at u = 0 = 1), v = z/2.
    fn cylinder(segments: u32) -> Mesh {
        let mut m = Mesh::default();
        for z in 0..2 {
            for s in 0..segments {
                let theta = TAU * s as f32 / segments as f32;
                m.positions.push(Vec3::new(theta.cos(), theta.sin(), 2.0 * z as f32));
            }
            for s in 0..=segments {
                m.uvs.push(Vec2::new(s as f32 / segments as f32, z as f32));
            }
        }
        for s in 0..segments {
            let s1 = (s + 1) % segments;
            m.faces.push(face(
                vec![s, s1, segments + s1, segments + s],
                vec![s, s + 1, segments + 1 + s + 1, segments + 1 + s],
            ));
        }
        m
    }

    /// The cube [-1, 1]³: six quads, each with its own four UVs (the unit square, u along the
    /// face's first edge).
    fn unit_box() -> Mesh {
        let mut m = Mesh::default();
        for x in [-1.0, 1.0] {
            for y in [-1.0, 1.0] {
                for z in [-1.0, 1.0] {
                    m.positions.push(Vec3::new(x, y, z));
                }
            }
        }
        let id = |x: u32, y: u32, z: u32| x * 4 + y * 2 + z;
        let quads = [
            [id(0, 0, 0), id(0, 0, 1), id(0, 1, 1), id(0, 1, 0)], // -x
            [id(1, 0, 0), id(1, 1, 0), id(1, 1, 1), id(1, 0, 1)], // +x
            [id(0, 0, 0), id(1, 0, 0), id(1, 0, 1), id(0, 0, 1)], // -y
            [id(0, 1, 0), id(0, 1, 1), id(1, 1, 1), id(1, 1, 0)], // +y
            [id(0, 0, 0), id(0, 1, 0), id(1, 1, 0), id(1, 0, 0)], // -z
            [id(0, 0, 1), id(1, 0, 1), id(1, 1, 1), id(0, 1, 1)], // +z
        ];
        for q in quads {
            let base = m.uvs.len() as u32;
            m.uvs.extend([Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y]);
            m.faces.push(face(q.to_vec(), (base..base + 4).collect()));
        }
        m
    }

    /// The unit square in the xy-plane split into `n × n` quads, uv = `uv(x, y)`.
    fn plane(n: u32, uv: impl Fn(Vec2) -> Vec2) -> Mesh {
        let mut m = Mesh::default();
        for y in 0..=n {
            for x in 0..=n {
                let p = Vec2::new(x as f32, y as f32) / n as f32;
                m.positions.push(p.extend(0.0));
                m.uvs.push(uv(p));
            }
        }
        let id = |x: u32, y: u32| y * (n + 1) + x;
        for y in 0..n {
            for x in 0..n {
                let q = vec![id(x, y), id(x + 1, y), id(x + 1, y + 1), id(x, y + 1)];
                m.faces.push(face(q.clone(), q));
            }
        }
        m
    }

    /// Every frame orthonormal, `bitangent = w · normal × tangent`, and on every triangle each
    /// corner's tangent along the triangle's dP/du and bitangent along its dP/dv.
    fn assert_frames_agree(m: &Mesh, f: &Frames) {
        for fr in &f.frames {
            for (a, b) in [(fr.tangent, fr.bitangent), (fr.tangent, fr.normal), (fr.bitangent, fr.normal)] {
                assert!(a.dot(b).abs() < 1e-5, "{fr:?}");
            }
            for x in [fr.tangent, fr.bitangent, fr.normal] {
                assert!((x.length() - 1.0).abs() < 1e-5, "{fr:?}");
            }
            assert!(fr.w == 1.0 || fr.w == -1.0);
            assert!((fr.bitangent - fr.w * fr.normal.cross(fr.tangent)).length() < 1e-5);
        }
        let tri = triangulate(m);
        assert_eq!(tri.positions.len(), f.vertices.len());
        for t in &tri.triangles {
            let p = t.map(|i| tri.positions[i as usize]);
            let uv = t.map(|i| tri.uvs[i as usize]);
            let (e1, e2, s1, s2) = (p[1] - p[0], p[2] - p[0], uv[1] - uv[0], uv[2] - uv[0]);
            let r = s1.perp_dot(s2);
            let dpdu = (e1 * s2.y - e2 * s1.y) / r;
            let dpdv = (e2 * s1.x - e1 * s2.x) / r;
            for &i in t {
                let fr = &f.frames[i as usize];
                assert!(fr.tangent.dot(dpdu) > 0.0, "tangent against dP/du at vertex {i}: {fr:?} {dpdu}");
                assert!(fr.bitangent.dot(dpdv) > 0.0, "bitangent against dP/dv at vertex {i}: {fr:?} {dpdv}");
            }
        }
    }

    #[test]
    fn the_test_meshes_are_valid() {
        assert_eq!(validate(&uv_sphere(8, 12)), Ok(()));
        assert_eq!(validate(&cylinder(10)), Ok(()));
        assert_eq!(validate(&unit_box()), Ok(()));
        assert_eq!(validate(&plane(3, |p| p)), Ok(()));
    }

    #[test]
    fn a_plane_with_uv_xy_has_the_axes_as_frames() {
        let m = plane(3, |p| p);
        let f = tangent_frames(&m);
        assert_eq!(f.frames.len(), 16);
        for fr in &f.frames {
            assert!((fr.tangent - Vec3::X).length() < 1e-6, "{fr:?}");
            assert!((fr.bitangent - Vec3::Y).length() < 1e-6, "{fr:?}");
            assert!((fr.normal - Vec3::Z).length() < 1e-6, "{fr:?}");
            assert_eq!(fr.w, 1.0);
        }
        assert_frames_agree(&m, &f);
    }

    #[test]
    fn mirrored_uvs_are_left_handed() {
        let m = plane(2, |p| Vec2::new(1.0 - p.x, p.y));
        let f = tangent_frames(&m);
        for fr in &f.frames {
            assert_eq!(fr.w, -1.0);
            assert!((fr.tangent + Vec3::X).length() < 1e-6, "{fr:?}");
            assert!((fr.bitangent - Vec3::Y).length() < 1e-6, "{fr:?}");
        }
        assert_frames_agree(&m, &f);
    }

    #[test]
    fn frames_on_a_sphere_a_cylinder_and_a_box() {
        for m in [uv_sphere(8, 12), uv_sphere(5, 7), cylinder(10), unit_box()] {
            let f = tangent_frames(&m);
            assert_frames_agree(&m, &f);
        }
        // On the sphere the normal is the radius and the tangent points east.
        let m = uv_sphere(16, 24);
        let f = tangent_frames(&m);
        for (v, fr) in f.vertices.iter().zip(&f.frames) {
            let p = m.positions[v[0] as usize];
            assert!(fr.normal.dot(p) > 0.99, "{p} {fr:?}");
            if p.truncate().length() > 0.3 {
                let east = Vec3::new(-p.y, p.x, 0.0).normalize();
                assert!(fr.tangent.dot(east) > 0.95, "{p} {fr:?}");
            }
        }
    }

    #[test]
    fn a_uv_seam_splits_a_position_into_two_frames() {
        let m = cylinder(8);
        let f = tangent_frames(&m);
        // 16 positions; the 2 on the seam have 2 UVs each.
        assert_eq!(f.vertices.len(), 18);
        let seam: Vec<usize> = (0..f.vertices.len()).filter(|&i| f.vertices[i][0] == 0).collect();
        assert_eq!(seam.len(), 2);
        let (a, b) = (f.frames[seam[0]], f.frames[seam[1]]);
        assert_ne!(f.vertices[seam[0]][1], f.vertices[seam[1]][1]);
        // The same surface on both sides: the same normal; the tangents both point around.
        assert!((a.normal - b.normal).length() < 1e-6);
        assert!(a.tangent.dot(b.tangent) > 0.9);
        // Corner lookups land on the seam vertices.
        assert_eq!(f.vertex(0, 0) as usize, seam[0]);
        assert_eq!(f.at(7, 1), &f.frames[seam[1]]);
    }

    #[test]
    fn box_corners_get_the_diagonal_normal() {
        let m = unit_box();
        let tri = triangulate(&m);
        assert_eq!(tri.positions.len(), 24);
        assert_eq!(tri.triangles.len(), 12);
        for (p, n) in tri.positions.iter().zip(&tri.normals) {
            assert!((*n - p.normalize()).length() < 1e-6, "{p} {n}");
        }
        // Every triangle faces outwards and the surface area is 24.
        let mut area = 0.0;
        for t in &tri.triangles {
            let p = t.map(|i| tri.positions[i as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            assert!(n.dot(p[0] + p[1] + p[2]) > 0.0, "{p:?}");
            area += 0.5 * n.length();
        }
        assert!((area - 24.0).abs() < 1e-4);
    }

    #[test]
    fn triangulate_keeps_uvs_and_winding_of_a_sphere() {
        let m = uv_sphere(6, 9);
        let tri = triangulate(&m);
        // Quads give 2 triangles each, caps 1.
        assert_eq!(tri.triangles.len(), 9 * 2 + 9 * 4 * 2);
        for t in &tri.triangles {
            let p = t.map(|i| tri.positions[i as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            assert!(n.dot(p[0] + p[1] + p[2]) > 0.0, "inwards: {p:?}");
            let uv = t.map(|i| tri.uvs[i as usize]);
            assert!((uv[1] - uv[0]).perp_dot(uv[2] - uv[0]) > 0.0, "uv winding: {uv:?}");
        }
        for (p, n) in tri.positions.iter().zip(&tri.normals) {
            assert!((n.length() - 1.0).abs() < 1e-5);
            assert!(n.dot(*p) > 0.98);
        }
    }

    #[test]
    fn a_concave_polygon_is_ear_clipped() {
        // An L-shaped hexagon in a tilted plane, counter-clockwise.
        let flat = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0)];
        let (u, v) = (Vec3::new(1.0, 0.0, 1.0).normalize(), Vec3::Y);
        let points: Vec<Vec3> = flat.iter().map(|&(x, y)| u * x + v * y + Vec3::splat(5.0)).collect();
        let tris = polygon_triangles(&points);
        assert_eq!(tris.len(), 4);
        let normal = u.cross(v);
        let mut area = 0.0;
        for t in &tris {
            let n = (points[t[1]] - points[t[0]]).cross(points[t[2]] - points[t[0]]);
            assert!(n.dot(normal) > 1e-6, "{t:?} not counter-clockwise");
            area += 0.5 * n.length();
        }
        assert!((area - 3.0).abs() < 1e-5, "{area}");
        // The same polygon starting at the reflex corner.
        let rotated: Vec<Vec3> = (0..6).map(|i| points[(i + 3) % 6]).collect();
        let area2: f32 = polygon_triangles(&rotated)
            .iter()
            .map(|t| 0.5 * (rotated[t[1]] - rotated[t[0]]).cross(rotated[t[2]] - rotated[t[0]]).length())
            .sum();
        assert!((area2 - 3.0).abs() < 1e-5, "{area2}");
    }

    #[test]
    fn a_quad_takes_the_better_diagonal() {
        // A kite: the short diagonal 1-3 makes two fat triangles, 0-2 two slivers.
        let points =
            [Vec3::new(-5.0, 0.0, 0.0), Vec3::new(0.0, -1.0, 0.0), Vec3::new(5.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        assert_eq!(polygon_triangles(&points), [[0, 1, 3], [1, 2, 3]]);
        // A concave quad (dart): only the diagonal from the reflex corner is inside.
        let dart =
            [Vec3::new(0.0, 0.0, 0.0), Vec3::new(2.0, -1.0, 0.0), Vec3::new(0.5, 0.0, 0.0), Vec3::new(2.0, 1.0, 0.0)];
        let tris = polygon_triangles(&dart);
        assert_eq!(tris, [[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn faces_validation_refuses_are_left_out_not_panicked_on() {
        let mut m = plane(1, |p| p);
        m.faces.push(face(vec![0, 1, 9], vec![0, 1, 2]));
        m.faces.push(face(vec![0, 1], vec![0, 1]));
        let f = tangent_frames(&m);
        assert_eq!(f.face_starts, [0, 4, 4, 4]);
        assert_eq!(triangulate(&m).triangles.len(), 2);
    }
}
