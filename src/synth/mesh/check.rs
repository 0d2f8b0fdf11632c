//! Validation of a target [`Mesh`] before relief works on it: every problem a coarse polygon mesh
//! read from an untrusted OBJ can have that would make displacement, tangent frames or seam
//! zipping go wrong, each as a [`MeshError`] that says which face (and, for a mesh read from OBJ,
//! on which line that face's `f` statement is).
//!
//! [`problems`] lists them all; [`validate`] returns the first. The checks are:
//! - sizes first ([`MeshError::TooLarge`], against [`Limits`]; nothing else is checked past that),
//! - the mesh has faces ([`MeshError::NoFaces`]),
//! - positions and UVs are finite ([`MeshError::NonFinite`]),
//! - each face in order: indices in range, one UV per corner, at least 3 distinct corners and a
//!   3-D area above a relative epsilon, a UV area above it too,
//! - each edge, in order of its position indices: used by at most two faces
//!   ([`MeshError::NonManifoldEdge`]), and by two faces in opposite directions
//!   ([`MeshError::InconsistentWinding`] otherwise).
//!
//! Polygons with more than 3 corners need not be planar: [`super::frames::face_triangles`]
//! triangulates every face the same way wherever it is needed. The whole check sorts the edges
//! once: O(n log n) in the number of corners.

use std::fmt;

use glam::{DVec2, DVec3};

use super::meshes::Mesh;

/// A face's area (3-D, or in UV space) counts as zero below this fraction of its longest edge
/// squared: far below any face an author means, far above the rounding of `f32` coordinates.
pub const RELATIVE_AREA_EPSILON: f64 = 1e-6;

/// Upper bounds on the sizes of a mesh, checked before anything is allocated from counts an
/// untrusted file states.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    pub positions: usize,
    pub uvs: usize,
    pub faces: usize,
    /// Corners over all faces.
    pub corners: usize,
    /// Corners of one face (a polygon's triangulation is quadratic in its corners).
    pub face_corners: usize,
}

impl Limits {
    /// 4 M positions, UVs and faces, 16 M corners, 1024 corners in one face.
    pub const DEFAULT: Limits =
        Limits { positions: 4_000_000, uvs: 4_000_000, faces: 4_000_000, corners: 16_000_000, face_corners: 1024 };
}

impl Default for Limits {
    fn default() -> Self {
        Limits::DEFAULT
    }
}

/// Which face a problem is on: its index in [`Mesh::faces`] (from 0) and, for a mesh read from
/// OBJ, the line (from 1) of its `f` statement. Shown as `face 12 (line 40)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct FaceAt {
    pub index: usize,
    pub line: Option<usize>,
}

impl FaceAt {
    /// Face `index`, its line looked up in `face_lines` (empty when there are none).
    pub fn new(index: usize, face_lines: &[usize]) -> FaceAt {
        FaceAt { index, line: face_lines.get(index).copied() }
    }
}

impl fmt::Display for FaceAt {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "face {}", self.index)?;
        if let Some(line) = self.line {
            write!(f, " (line {line})")?;
        }
        Ok(())
    }
}

/// The two kinds of vertex attribute a face indexes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Attribute {
    Position,
    Uv,
}

impl fmt::Display for Attribute {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Attribute::Position => "position",
            Attribute::Uv => "texture coordinate",
        })
    }
}

/// Why a face is degenerate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Degeneracy {
    /// Fewer than 3 distinct positions among its corners.
    FewCorners { distinct: usize },
    /// Its corners (nearly) lie on one line or point: no area to displace.
    ZeroArea,
}

impl fmt::Display for Degeneracy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Degeneracy::FewCorners { distinct } => write!(f, "only {distinct} distinct corners, 3 needed"),
            Degeneracy::ZeroArea => f.write_str("its corners enclose no area"),
        }
    }
}

/// What is wrong with a mesh, or with the OBJ text it is read from.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MeshError {
    /// A line of the OBJ text that cannot be read.
    #[error("OBJ line {line}: {message}")]
    Syntax { line: usize, message: String },
    /// The OBJ parser refused the text (it does not say where).
    #[error("the OBJ could not be read: {0}")]
    Obj(String),
    #[error("the mesh has no faces")]
    NoFaces,
    /// A face without one texture coordinate per corner (an OBJ `f v` or `f v//vn` corner).
    #[error("{face}: {corners} corners but {uvs} texture coordinates; relief needs a UV at every corner")]
    MissingUvs { face: FaceAt, corners: usize, uvs: usize },
    /// A corner refers to a position or UV that does not exist (`index` from 0, as resolved).
    #[error("{face}, corner {corner}: {attribute} {index} does not exist (there are {count})")]
    IndexOutOfRange { face: FaceAt, corner: usize, attribute: Attribute, index: i64, count: usize },
    #[error("{face} is degenerate: {reason}")]
    DegenerateFace { face: FaceAt, reason: Degeneracy },
    /// The face's texture coordinates enclose no area: no texture can be laid on it.
    #[error("{face}: its texture coordinates enclose no area")]
    ZeroUvArea { face: FaceAt },
    /// The edge between positions `a < b` is used `faces` times (a face using it twice counts
    /// twice); a surface allows 2. `first` is the first face using it.
    #[error(
        "the edge between positions {a} and {b} is used by {faces} faces (at most 2 on a surface), first by {first}"
    )]
    NonManifoldEdge { a: u32, b: u32, faces: usize, first: FaceAt },
    /// Two faces both run from position `a` to `b`: one of them is wound the other way round.
    #[error("{first} and {second} both run from position {a} to {b}: their windings disagree (one is flipped)")]
    InconsistentWinding { a: u32, b: u32, first: FaceAt, second: FaceAt },
    #[error("{attribute} {index} is not a finite number")]
    NonFinite { attribute: Attribute, index: usize },
    #[error("{count} {what} is more than the {max} allowed")]
    TooLarge { what: &'static str, count: usize, max: usize },
}

impl MeshError {
    /// The face the problem is on (the first of two for a winding problem).
    pub fn face(&self) -> Option<FaceAt> {
        match self {
            MeshError::MissingUvs { face, .. }
            | MeshError::IndexOutOfRange { face, .. }
            | MeshError::DegenerateFace { face, .. }
            | MeshError::ZeroUvArea { face } => Some(*face),
            MeshError::NonManifoldEdge { first, .. } | MeshError::InconsistentWinding { first, .. } => Some(*first),
            _ => None,
        }
    }

    /// The OBJ line the problem is on, when known.
    pub fn line(&self) -> Option<usize> {
        match self {
            MeshError::Syntax { line, .. } => Some(*line),
            MeshError::InconsistentWinding { second, .. } => second.line,
            other => other.face().and_then(|f| f.line),
        }
    }
}

/// The first problem of the mesh, if any (see [`problems`]).
pub fn validate(mesh: &Mesh) -> Result<(), MeshError> {
    validate_with_lines(mesh, &[])
}

/// [`validate`], naming the OBJ line of each face: `face_lines[i]` is face `i`'s line.
pub fn validate_with_lines(mesh: &Mesh, face_lines: &[usize]) -> Result<(), MeshError> {
    match problems_within(mesh, face_lines, &Limits::DEFAULT).into_iter().next() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// Every problem of the mesh, in the order of the module doc; `face_lines` as in
/// [`validate_with_lines`] (empty when unknown).
pub fn problems(mesh: &Mesh, face_lines: &[usize]) -> Vec<MeshError> {
    problems_within(mesh, face_lines, &Limits::DEFAULT)
}

/// [`problems`] against other [`Limits`].
pub fn problems_within(mesh: &Mesh, face_lines: &[usize], limits: &Limits) -> Vec<MeshError> {
    if let Some(e) = too_large(mesh, limits) {
        return vec![e];
    }
    let mut out = Vec::new();
    if mesh.faces.is_empty() {
        out.push(MeshError::NoFaces);
    }
    let bad_position = mesh.positions.iter().position(|p| !p.is_finite());
    if let Some(index) = bad_position {
        out.push(MeshError::NonFinite { attribute: Attribute::Position, index });
    }
    if let Some(index) = mesh.uvs.iter().position(|t| !t.is_finite()) {
        out.push(MeshError::NonFinite { attribute: Attribute::Uv, index });
    }
    // Faces whose indices are all in range take part in the edge check.
    let mut in_range = vec![true; mesh.faces.len()];
    for (i, face) in mesh.faces.iter().enumerate() {
        let at = FaceAt::new(i, face_lines);
        let before = out.len();
        check_indices(mesh, i, at, &mut out);
        if out.len() > before {
            in_range[i] = false;
            continue;
        }
        if face.uvs.len() != face.positions.len() {
            out.push(MeshError::MissingUvs { face: at, corners: face.positions.len(), uvs: face.uvs.len() });
        }
        let mut distinct = face.positions.clone();
        distinct.sort_unstable();
        distinct.dedup();
        if distinct.len() < 3 {
            out.push(MeshError::DegenerateFace {
                face: at,
                reason: Degeneracy::FewCorners { distinct: distinct.len() },
            });
            continue;
        }
        if bad_position.is_none() {
            let points: Vec<DVec3> = face.positions.iter().map(|&p| mesh.positions[p as usize].as_dvec3()).collect();
            if zero_area(&points) {
                out.push(MeshError::DegenerateFace { face: at, reason: Degeneracy::ZeroArea });
            }
        }
        if face.uvs.len() == face.positions.len() {
            let uvs: Vec<DVec2> = face.uvs.iter().map(|&t| mesh.uvs[t as usize].as_dvec2()).collect();
            if uvs.iter().all(|t| t.is_finite()) && zero_uv_area(&uvs) {
                out.push(MeshError::ZeroUvArea { face: at });
            }
        }
    }
    check_edges(mesh, &in_range, face_lines, &mut out);
    out
}

fn too_large(mesh: &Mesh, limits: &Limits) -> Option<MeshError> {
    let counts = [
        ("positions", mesh.positions.len(), limits.positions),
        ("texture coordinates", mesh.uvs.len(), limits.uvs),
        ("faces", mesh.faces.len(), limits.faces),
    ];
    for (what, count, max) in counts {
        if count > max {
            return Some(MeshError::TooLarge { what, count, max });
        }
    }
    let mut corners = 0usize;
    for face in &mesh.faces {
        let n = face.positions.len().max(face.uvs.len());
        if n > limits.face_corners {
            return Some(MeshError::TooLarge { what: "corners in one face", count: n, max: limits.face_corners });
        }
        corners += n;
    }
    (corners > limits.corners).then_some(MeshError::TooLarge { what: "corners", count: corners, max: limits.corners })
}

fn check_indices(mesh: &Mesh, i: usize, at: FaceAt, out: &mut Vec<MeshError>) {
    let face = &mesh.faces[i];
    let lists =
        [(Attribute::Position, &face.positions, mesh.positions.len()), (Attribute::Uv, &face.uvs, mesh.uvs.len())];
    for (attribute, indices, count) in lists {
        for (corner, &index) in indices.iter().enumerate() {
            if index as usize >= count {
                out.push(MeshError::IndexOutOfRange { face: at, corner, attribute, index: index as i64, count });
            }
        }
    }
}

/// Twice the vector area of a closed polygon (Newell's method): its direction is the polygon's
/// normal by the right-hand rule, its length twice the area for a planar polygon, and it is
/// well defined for a non-planar one.
pub(crate) fn newell(points: &[DVec3]) -> DVec3 {
    let n = points.len();
    (0..n).map(|i| points[i].cross(points[(i + 1) % n])).sum()
}

fn longest_edge_squared<T: Copy>(points: &[T], dist2: impl Fn(T, T) -> f64) -> f64 {
    let n = points.len();
    (0..n).map(|i| dist2(points[i], points[(i + 1) % n])).fold(0.0, f64::max)
}

fn zero_area(points: &[DVec3]) -> bool {
    // Newell about the first corner, so that far-away faces keep their precision.
    let local: Vec<DVec3> = points.iter().map(|&p| p - points[0]).collect();
    let area = 0.5 * newell(&local).length();
    area <= RELATIVE_AREA_EPSILON * longest_edge_squared(&local, DVec3::distance_squared)
}

fn zero_uv_area(uvs: &[DVec2]) -> bool {
    let n = uvs.len();
    let o = uvs[0];
    let twice: f64 = (0..n).map(|i| (uvs[i] - o).perp_dot(uvs[(i + 1) % n] - o)).sum();
    0.5 * twice.abs() <= RELATIVE_AREA_EPSILON * longest_edge_squared(uvs, DVec2::distance_squared)
}

fn check_edges(mesh: &Mesh, in_range: &[bool], face_lines: &[usize], out: &mut Vec<MeshError>) {
    // (low, high, face, forward): one entry per use of an undirected edge.
    let mut uses: Vec<(u32, u32, u32, bool)> = Vec::new();
    for (i, face) in mesh.faces.iter().enumerate().filter(|(i, _)| in_range[*i]) {
        for (a, b) in face.edges().filter(|(a, b)| a != b) {
            uses.push((a.min(b), a.max(b), i as u32, a < b));
        }
    }
    uses.sort_unstable();
    for group in uses.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
        let (low, high, first, forward) = group[0];
        let first_at = FaceAt::new(first as usize, face_lines);
        if group.len() > 2 {
            out.push(MeshError::NonManifoldEdge { a: low, b: high, faces: group.len(), first: first_at });
        } else if group.len() == 2 && group[1].3 == forward {
            let (a, b) = if forward { (low, high) } else { (high, low) };
            let second = FaceAt::new(group[1].2 as usize, face_lines);
            out.push(MeshError::InconsistentWinding { a, b, first: first_at, second });
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::{Vec2, Vec3};

    use super::super::meshes::Face;
    use super::*;

    fn face(positions: &[u32], uvs: &[u32]) -> Face {
        Face { positions: positions.to_vec(), uvs: uvs.to_vec() }
    }

    /// Two unit squares side by side in the xy-plane (quads 0-1-4-3 and 1-2-5-4), uv = xy.
    fn two_quads() -> Mesh {
        let mut positions = Vec::new();
        for y in 0..2 {
            for x in 0..3 {
                positions.push(Vec3::new(x as f32, y as f32, 0.0));
            }
        }
        let uvs = positions.iter().map(|p| p.truncate()).collect();
        Mesh { positions, uvs, faces: vec![face(&[0, 1, 4, 3], &[0, 1, 4, 3]), face(&[1, 2, 5, 4], &[1, 2, 5, 4])] }
    }

    #[test]
    fn a_good_mesh_has_no_problem() {
        assert_eq!(validate(&two_quads()), Ok(()));
        assert!(problems(&two_quads(), &[]).is_empty());
    }

    #[test]
    fn an_empty_mesh_has_no_faces() {
        assert_eq!(validate(&Mesh::default()), Err(MeshError::NoFaces));
    }

    #[test]
    fn missing_uvs_name_the_face_and_its_line() {
        let mut m = two_quads();
        m.faces[1].uvs.clear();
        let e = validate_with_lines(&m, &[7, 9]).unwrap_err();
        assert_eq!(e, MeshError::MissingUvs { face: FaceAt { index: 1, line: Some(9) }, corners: 4, uvs: 0 });
        assert_eq!(e.line(), Some(9));
        assert!(e.to_string().starts_with("face 1 (line 9): 4 corners but 0 texture coordinates"), "{e}");
    }

    #[test]
    fn out_of_range_indices_are_reported_per_corner() {
        let mut m = two_quads();
        m.faces[0].positions[2] = 6;
        m.faces[1].uvs[3] = 60;
        let p = problems(&m, &[]);
        let at0 = FaceAt { index: 0, line: None };
        let at1 = FaceAt { index: 1, line: None };
        assert_eq!(
            p,
            [
                MeshError::IndexOutOfRange { face: at0, corner: 2, attribute: Attribute::Position, index: 6, count: 6 },
                MeshError::IndexOutOfRange { face: at1, corner: 3, attribute: Attribute::Uv, index: 60, count: 6 },
            ]
        );
        assert_eq!(p[0].to_string(), "face 0, corner 2: position 6 does not exist (there are 6)");
    }

    #[test]
    fn degenerate_faces_few_corners_and_zero_area() {
        let mut m = two_quads();
        m.faces.push(face(&[0, 1, 0], &[0, 1, 0]));
        // Collinear: 0, 1, 2 lie on the x axis.
        m.faces.push(face(&[0, 1, 2], &[0, 1, 3]));
        let p = problems(&m, &[]);
        assert!(p.contains(&MeshError::DegenerateFace {
            face: FaceAt { index: 2, line: None },
            reason: Degeneracy::FewCorners { distinct: 2 }
        }));
        assert!(p.contains(&MeshError::DegenerateFace {
            face: FaceAt { index: 3, line: None },
            reason: Degeneracy::ZeroArea
        }));
        // A tiny but honest face far from the origin is not degenerate.
        let o = Vec3::new(1.0e4, -2.0e4, 3.0e3);
        let tiny = Mesh {
            positions: vec![o, o + Vec3::new(0.01, 0.0, 0.0), o + Vec3::new(0.0, 0.01, 0.0)],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::Y],
            faces: vec![face(&[0, 1, 2], &[0, 1, 2])],
        };
        assert_eq!(validate(&tiny), Ok(()));
    }

    #[test]
    fn collapsed_uvs_have_zero_uv_area() {
        let mut m = two_quads();
        m.faces[1].uvs = vec![1, 2, 2, 1];
        assert_eq!(validate(&m), Err(MeshError::ZeroUvArea { face: FaceAt { index: 1, line: None } }));
        // Mirrored UVs (negative area) are fine.
        let mut m = two_quads();
        for t in &mut m.uvs {
            t.x = -t.x;
        }
        assert_eq!(validate(&m), Ok(()));
    }

    #[test]
    fn a_flipped_face_is_inconsistent_winding() {
        let mut m = two_quads();
        m.faces[1].positions.reverse();
        m.faces[1].uvs.reverse();
        let e = validate_with_lines(&m, &[3, 4]).unwrap_err();
        // Face 0 (0-1-4-3) runs 1 → 4; so does the reversed face 1 (4-5-2-1).
        assert_eq!(
            e,
            MeshError::InconsistentWinding {
                a: 1,
                b: 4,
                first: FaceAt { index: 0, line: Some(3) },
                second: FaceAt { index: 1, line: Some(4) }
            }
        );
        assert_eq!(e.line(), Some(4));
    }

    #[test]
    fn a_fin_is_a_non_manifold_edge() {
        let mut m = two_quads();
        m.positions.push(Vec3::new(1.0, 0.5, 1.0));
        m.uvs.push(Vec2::new(0.5, 0.5));
        // A triangle standing on the shared edge 1-4.
        m.faces.push(face(&[1, 4, 6], &[1, 4, 6]));
        let p = problems(&m, &[]);
        assert_eq!(p, [MeshError::NonManifoldEdge { a: 1, b: 4, faces: 3, first: FaceAt { index: 0, line: None } }]);
    }

    #[test]
    fn non_finite_values_are_reported() {
        let mut m = two_quads();
        m.positions[2].y = f32::NAN;
        m.uvs[5].x = f32::INFINITY;
        let p = problems(&m, &[]);
        assert_eq!(p[0], MeshError::NonFinite { attribute: Attribute::Position, index: 2 });
        assert_eq!(p[1], MeshError::NonFinite { attribute: Attribute::Uv, index: 5 });
    }

    #[test]
    fn sizes_are_bounded_before_anything_else() {
        let m = two_quads();
        let small = Limits { positions: 5, ..Limits::DEFAULT };
        assert_eq!(problems_within(&m, &[], &small), [MeshError::TooLarge { what: "positions", count: 6, max: 5 }]);
        let small = Limits { face_corners: 3, ..Limits::DEFAULT };
        assert_eq!(
            problems_within(&m, &[], &small),
            [MeshError::TooLarge { what: "corners in one face", count: 4, max: 3 }]
        );
        let small = Limits { corners: 7, ..Limits::DEFAULT };
        assert_eq!(problems_within(&m, &[], &small), [MeshError::TooLarge { what: "corners", count: 8, max: 7 }]);
    }

    #[test]
    fn a_non_planar_quad_is_allowed() {
        let mut m = two_quads();
        m.positions[4].z = 0.3;
        assert_eq!(validate(&m), Ok(()));
    }
}
