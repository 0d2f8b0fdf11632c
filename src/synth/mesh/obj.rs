//! Wavefront OBJ in and out, from and to bytes in memory (the caller reads and writes files).
//!
//! Reading goes through the `tobj` parser, polygons kept as they are (no triangulation, positions
//! and texture coordinates indexed separately). Two things `tobj` does not do are done by a scan
//! of the text before it:
//! - **line numbers**: `tobj` does not say where a face came from, so the scan records the line
//!   of each `f` statement in order, for diagnostics such as `face 12 (line 40)`, and reports
//!   the lines of unreadable text and of corners that index nothing;
//! - **bounds**: the numbers of `v`, `vt` and `f` statements and of corners are counted against
//!   [`Limits`] before `tobj` allocates anything for them.
//!
//! The scan also blanks (keeps as empty lines, so that line numbers hold) the statements a
//! target mesh has no use for: `o`, `g` and `usemtl`, at which `tobj` would start a new model with
//! its own copy of the positions it shares with the previous one (cutting the surface along
//! group borders), `mtllib` (so no material file is ever looked for) and `l` (polylines are not
//! surface). Normals (`vn`) are read past: relief computes its own.

use std::fmt::Write as _;

use glam::{Vec2, Vec3};

use super::check::{self, Attribute, FaceAt, Limits, MeshError};
use super::meshes::{Face, Mesh, TriMesh};

/// A mesh read from OBJ with the line (from 1) of each face's `f` statement.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjMesh {
    pub mesh: Mesh,
    /// `face_lines[i]` is the line of `mesh.faces[i]`.
    pub face_lines: Vec<usize>,
}

impl ObjMesh {
    /// [`check::validate_with_lines`]: the first problem, naming its face's line.
    pub fn validate(&self) -> Result<(), MeshError> {
        check::validate_with_lines(&self.mesh, &self.face_lines)
    }

    /// [`check::problems`], naming each face's line.
    pub fn problems(&self) -> Vec<MeshError> {
        check::problems(&self.mesh, &self.face_lines)
    }
}

/// Reads an OBJ into one polygon mesh (all objects and groups together). Faces keep their arity;
/// a face with a corner that has no texture coordinate gets no UVs at all (which
/// [`check::validate`] reports). Errors are the text's: unreadable lines, indices out of range,
/// sizes beyond [`Limits::DEFAULT`]. The mesh itself is not validated (see [`load_obj`]).
pub fn read_obj(bytes: &[u8]) -> Result<Mesh, MeshError> {
    read_obj_with_lines(bytes).map(|o| o.mesh)
}

/// [`read_obj`], then [`check::validate_with_lines`]: a mesh relief can work on, or the first
/// problem with its face and line.
pub fn load_obj(bytes: &[u8]) -> Result<Mesh, MeshError> {
    let obj = read_obj_with_lines(bytes)?;
    obj.validate()?;
    Ok(obj.mesh)
}

/// [`read_obj`], keeping the line of each face.
pub fn read_obj_with_lines(bytes: &[u8]) -> Result<ObjMesh, MeshError> {
    read_obj_within(bytes, &Limits::DEFAULT)
}

/// [`read_obj_with_lines`] against other [`Limits`].
pub fn read_obj_within(bytes: &[u8], limits: &Limits) -> Result<ObjMesh, MeshError> {
    let scan = scan(bytes, limits)?;
    let options =
        tobj::LoadOptions { triangulate: false, single_index: false, ignore_points: false, ignore_lines: false };
    let mut reader = std::io::Cursor::new(&scan.text[..]);
    // `mtllib` is blanked, so this is never called; if it were, it opens nothing.
    let (models, _materials) = tobj::load_obj_buf(&mut reader, &options, |_| Err(tobj::LoadError::OpenFileFailed))
        .map_err(|e| MeshError::Obj(e.to_string()))?;

    let mut mesh = Mesh::default();
    for model in &models {
        let m = &model.mesh;
        let position_base = mesh.positions.len() as u32;
        let uv_base = mesh.uvs.len() as u32;
        mesh.positions.extend(m.positions.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])));
        mesh.uvs.extend(m.texcoords.chunks_exact(2).map(|c| Vec2::new(c[0], c[1])));
        let has_uvs = m.texcoord_indices.len() == m.indices.len();
        // `face_arities` is empty when every face is a triangle.
        let arities: Vec<usize> = if m.face_arities.is_empty() {
            vec![3; m.indices.len() / 3]
        } else {
            m.face_arities.iter().map(|&a| a as usize).collect()
        };
        let mut start = 0;
        for arity in arities {
            let end = start + arity;
            let positions = m.indices[start..end].iter().map(|&i| i + position_base).collect();
            let uvs = if has_uvs {
                m.texcoord_indices[start..end].iter().map(|&i| i + uv_base).collect()
            } else {
                Vec::new()
            };
            mesh.faces.push(Face { positions, uvs });
            start = end;
        }
    }

    // The scan saw the same `f` statements in the same order; if the counts ever disagreed,
    // no line is better than a wrong one.
    let mut face_lines = Vec::new();
    if scan.faces.len() == mesh.faces.len() {
        for (face, seen) in mesh.faces.iter_mut().zip(&scan.faces) {
            if !seen.all_uvs {
                // `tobj` makes up a UV for a corner without one; relief wants to know.
                face.uvs.clear();
            }
            face_lines.push(seen.line);
        }
    }
    Ok(ObjMesh { mesh, face_lines })
}

/// One `f` statement as the scan saw it.
struct ScannedFace {
    line: usize,
    /// Every corner names a texture coordinate (`v/vt` or `v/vt/vn`).
    all_uvs: bool,
}

struct Scan {
    /// The text with the statements of the module doc blanked.
    text: Vec<u8>,
    faces: Vec<ScannedFace>,
}

fn check_count(what: &'static str, count: usize, max: usize) -> Result<(), MeshError> {
    if count > max {
        Err(MeshError::TooLarge { what, count, max })
    } else {
        Ok(())
    }
}

/// An OBJ index (from 1, or negative from the end of what is defined so far) as an index from 0.
fn resolve(token: &str, defined: usize) -> Option<i64> {
    let x: i64 = token.parse().ok()?;
    match x {
        0 => None,
        x if x > 0 => Some(x - 1),
        x => Some(defined as i64 + x),
    }
}

fn scan(bytes: &[u8], limits: &Limits) -> Result<Scan, MeshError> {
    let mut text = bytes.to_vec();
    let mut faces = Vec::new();
    let (mut positions, mut uvs, mut corners) = (0usize, 0usize, 0usize);
    let mut start = 0;
    for (n, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = n + 1;
        let range = start..start + raw.len();
        start = range.end + 1;
        let Ok(s) = std::str::from_utf8(raw) else {
            return Err(MeshError::Syntax { line, message: "not UTF-8 text".into() });
        };
        let mut words = s.split_whitespace();
        match words.next() {
            Some("v") => {
                positions += 1;
                check_count("positions", positions, limits.positions)?;
            }
            Some("vt") => {
                uvs += 1;
                check_count("texture coordinates", uvs, limits.uvs)?;
            }
            Some("f") => {
                let at = FaceAt { index: faces.len(), line: Some(line) };
                check_count("faces", faces.len() + 1, limits.faces)?;
                let mut all_uvs = true;
                for (corner, word) in words.enumerate() {
                    check_count("corners in one face", corner + 1, limits.face_corners)?;
                    corners += 1;
                    check_count("corners", corners, limits.corners)?;
                    let mut parts = word.split('/');
                    let refs = [(Attribute::Position, parts.next(), positions), (Attribute::Uv, parts.next(), uvs)];
                    for (attribute, part, count) in refs {
                        match part {
                            None | Some("") if attribute == Attribute::Uv => all_uvs = false,
                            _ => {
                                let part = part.unwrap_or("");
                                let Some(index) = resolve(part, count) else {
                                    let message =
                                        format!("`{word}` is not a corner (`v`, `v/vt` or `v/vt/vn`, from 1)");
                                    return Err(MeshError::Syntax { line, message });
                                };
                                if index < 0 || index >= count as i64 {
                                    return Err(MeshError::IndexOutOfRange {
                                        face: at,
                                        corner,
                                        attribute,
                                        index,
                                        count,
                                    });
                                }
                            }
                        }
                    }
                }
                faces.push(ScannedFace { line, all_uvs });
            }
            Some("o" | "g" | "usemtl" | "mtllib" | "l") => text[range].fill(b' '),
            _ => {}
        }
    }
    Ok(Scan { text, faces })
}

/// A number as OBJ text: the shortest decimal that reads back to the same `f32` (deterministic,
/// exact on a round trip), with `-0` written `0`.
fn number(out: &mut String, x: f32) {
    let x = if x == 0.0 { 0.0 } else { x };
    let _ = write!(out, " {x}");
}

fn vec_line(out: &mut String, key: &str, values: &[f32]) {
    out.push_str(key);
    for &x in values {
        number(out, x);
    }
    out.push('\n');
}

/// A triangle mesh as OBJ text: `v` lines (one per distinct position), `vt` and `vn` lines (one
/// per vertex, only when there is one per vertex) and `f p/a/a q/b/b r/c/c` lines, indices from 1.
pub fn write_obj(mesh: &TriMesh) -> String {
    let n = mesh.positions.len();
    let (with_uvs, with_normals) = (mesh.uvs.len() == n, mesh.normals.len() == n);
    // Vertices that differ only in UV or normal (a UV seam) share one `v` line, as OBJ indexes
    // positions apart from texture coordinates: a mesh closed by position reads back closed.
    let mut first: std::collections::HashMap<[u32; 3], u32> = std::collections::HashMap::new();
    let mut position_of = Vec::with_capacity(n);
    let mut out = String::from("# tessera triangle mesh\n");
    for p in &mesh.positions {
        let next = first.len() as u32;
        let at = *first.entry(p.to_array().map(|c| if c == 0.0 { 0 } else { c.to_bits() })).or_insert_with(|| {
            vec_line(&mut out, "v", &p.to_array());
            next
        });
        position_of.push(at);
    }
    if with_uvs {
        for t in &mesh.uvs {
            vec_line(&mut out, "vt", &t.to_array());
        }
    }
    if with_normals {
        for v in &mesh.normals {
            vec_line(&mut out, "vn", &v.to_array());
        }
    }
    for tri in &mesh.triangles {
        out.push('f');
        for &i in tri {
            let p = position_of.get(i as usize).map_or(i, |&p| p) + 1;
            let i = i + 1;
            let _ = match (with_uvs, with_normals) {
                (true, true) => write!(out, " {p}/{i}/{i}"),
                (true, false) => write!(out, " {p}/{i}"),
                (false, true) => write!(out, " {p}//{i}"),
                (false, false) => write!(out, " {p}"),
            };
        }
        out.push('\n');
    }
    out
}

/// A polygon mesh as OBJ text: `v` and `vt` lines in the mesh's order, then one `f p/t ...` line
/// per face (`f p ...` for a face without a UV per corner), indices from 1. [`read_obj`] reads
/// it back to the same mesh when the positions and UVs are in the order faces first use them
/// and all are used (it renumbers them so otherwise; corners keep their values either way).
pub fn write_polygon_obj(mesh: &Mesh) -> String {
    let mut out = String::from("# tessera polygon mesh\n");
    for p in &mesh.positions {
        vec_line(&mut out, "v", &p.to_array());
    }
    for t in &mesh.uvs {
        vec_line(&mut out, "vt", &t.to_array());
    }
    for face in &mesh.faces {
        out.push('f');
        let with_uvs = face.uvs.len() == face.positions.len();
        for (k, &p) in face.positions.iter().enumerate() {
            let _ = if with_uvs { write!(out, " {}/{}", p + 1, face.uvs[k] + 1) } else { write!(out, " {}", p + 1) };
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::super::check::Degeneracy;
    use super::*;

    const QUAD_AND_TRIANGLE: &str = "\
# a quad and a triangle on top of it
mtllib nowhere.mtl
o thing
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0.5 1.5 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vt 0.5 1.5
vn 0 0 1
g bottom
usemtl stone
f 1/1/1 2/2/1 3/3/1 4/4/1
g top
f 4/4/1 3/3/1 5/5/1
l 1 5
";

    /// Each face's corners as values (position, uv), which renumbering keeps.
    fn corners(m: &Mesh) -> Vec<Vec<(Vec3, Option<Vec2>)>> {
        m.faces
            .iter()
            .map(|f| {
                (0..f.len())
                    .map(|k| (m.positions[f.positions[k] as usize], f.uvs.get(k).map(|&t| m.uvs[t as usize])))
                    .collect()
            })
            .collect()
    }

    #[test]
    fn reads_polygons_across_groups_as_one_connected_mesh() {
        let obj = read_obj_with_lines(QUAD_AND_TRIANGLE.as_bytes()).unwrap();
        let m = &obj.mesh;
        assert_eq!(m.positions.len(), 5);
        assert_eq!(m.uvs.len(), 5);
        assert_eq!(m.faces.len(), 2, "the polyline is not a face");
        assert_eq!(m.faces[0], Face { positions: vec![0, 1, 2, 3], uvs: vec![0, 1, 2, 3] });
        assert_eq!(m.faces[1], Face { positions: vec![3, 2, 4], uvs: vec![3, 2, 4] });
        assert_eq!(m.positions[4], Vec3::new(0.5, 1.5, 0.0));
        assert_eq!(m.uvs[4], Vec2::new(0.5, 1.5));
        assert_eq!(obj.face_lines, [17, 19]);
        // The groups share the edge 3-2 (one position each side, not a copy per group).
        let uses = super::super::meshes::edge_uses(m.faces.iter().map(|f| &f.positions[..]));
        assert_eq!(uses[&(2, 3)], 2);
        assert_eq!(obj.validate(), Ok(()));
        assert_eq!(load_obj(QUAD_AND_TRIANGLE.as_bytes()).as_ref(), Ok(m));
    }

    #[test]
    fn negative_indices_and_windows_line_ends() {
        let text = "v 0 0 0\r\nv 2 0 0\r\nv 0 2 0\r\nvt 0 0\r\nvt 1 0\r\nvt 0 1\r\nf -3/-3 -2/-2 -1/-1\r\n";
        let obj = read_obj_with_lines(text.as_bytes()).unwrap();
        assert_eq!(obj.mesh.faces, [Face { positions: vec![0, 1, 2], uvs: vec![0, 1, 2] }]);
        assert_eq!(obj.mesh.positions[1], Vec3::new(2.0, 0.0, 0.0));
        assert_eq!(obj.face_lines, [7]);
    }

    #[test]
    fn a_face_without_uvs_is_reported_with_its_line() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n\nf 1/1 2/2 3/3\n# next\nf 1 3 4\n";
        let obj = read_obj_with_lines(text.as_bytes()).unwrap();
        assert!(obj.mesh.faces[1].uvs.is_empty());
        let e = obj.validate().unwrap_err();
        assert_eq!(e, MeshError::MissingUvs { face: FaceAt { index: 1, line: Some(11) }, corners: 3, uvs: 0 });
        assert_eq!(load_obj(text.as_bytes()), Err(e));
    }

    #[test]
    fn problems_of_the_text_name_their_line() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf 1/1 2/1 3/1\nf 1/1 2/1 4/1\n";
        assert_eq!(
            read_obj(text.as_bytes()),
            Err(MeshError::IndexOutOfRange {
                face: FaceAt { index: 1, line: Some(6) },
                corner: 2,
                attribute: Attribute::Position,
                index: 3,
                count: 3
            })
        );
        let text = "v 0 0 0\nvt 0 0\nf 1/2 1/1 1/1\n";
        let e = read_obj(text.as_bytes()).unwrap_err();
        assert!(matches!(e, MeshError::IndexOutOfRange { attribute: Attribute::Uv, index: 1, count: 1, .. }), "{e:?}");
        assert_eq!(read_obj(b"v 0 0 0\nf 0 1 1\n").unwrap_err().line(), Some(2));
        assert_eq!(read_obj(b"v 0 0 0\nf a b c\n").unwrap_err().line(), Some(2));
        assert_eq!(read_obj(b"v 0 0 0\n\xff\n"), Err(MeshError::Syntax { line: 2, message: "not UTF-8 text".into() }));
        // What the parser refuses, without a line.
        assert!(matches!(read_obj(b"v 0 zero 0\n"), Err(MeshError::Obj(_))));
    }

    #[test]
    fn degenerate_faces_from_text_name_their_line() {
        let text = "v 0 0 0\nv 1 0 0\nv 2 0 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 2/2\n";
        let obj = read_obj_with_lines(text.as_bytes()).unwrap();
        let p = obj.problems();
        assert_eq!(
            p[0],
            MeshError::DegenerateFace { face: FaceAt { index: 0, line: Some(7) }, reason: Degeneracy::ZeroArea }
        );
        assert_eq!(
            p[1],
            MeshError::DegenerateFace {
                face: FaceAt { index: 1, line: Some(8) },
                reason: Degeneracy::FewCorners { distinct: 2 }
            }
        );
        assert_eq!(p[0].to_string(), "face 0 (line 7) is degenerate: its corners enclose no area");
    }

    #[test]
    fn counts_are_bounded_before_parsing() {
        let small = Limits { positions: 4, ..Limits::DEFAULT };
        let e = read_obj_within(QUAD_AND_TRIANGLE.as_bytes(), &small).unwrap_err();
        assert_eq!(e, MeshError::TooLarge { what: "positions", count: 5, max: 4 });
        let small = Limits { face_corners: 3, ..Limits::DEFAULT };
        let e = read_obj_within(QUAD_AND_TRIANGLE.as_bytes(), &small).unwrap_err();
        assert_eq!(e, MeshError::TooLarge { what: "corners in one face", count: 4, max: 3 });
        let small = Limits { faces: 1, ..Limits::DEFAULT };
        assert!(matches!(read_obj_within(QUAD_AND_TRIANGLE.as_bytes(), &small), Err(MeshError::TooLarge { .. })));
    }

    #[test]
    fn no_faces_reads_but_does_not_validate() {
        let m = read_obj(b"# nothing\nv 1 2 3\n").unwrap();
        assert!(m.faces.is_empty());
        assert_eq!(load_obj(b"v 1 2 3\n"), Err(MeshError::NoFaces));
        assert_eq!(load_obj(b""), Err(MeshError::NoFaces));
    }

    #[test]
    fn a_polygon_mesh_round_trips_exactly() {
        let m = read_obj(QUAD_AND_TRIANGLE.as_bytes()).unwrap();
        let text = write_polygon_obj(&m);
        assert_eq!(read_obj(text.as_bytes()).unwrap(), m);
        // Awkward numbers come back bit for bit.
        let mut odd = m.clone();
        odd.positions[1] = Vec3::new(0.1, -1.0e-7, 12345.678);
        odd.uvs[2] = Vec2::new(1.0 / 3.0, -0.0);
        let back = read_obj(write_polygon_obj(&odd).as_bytes()).unwrap();
        assert_eq!(back.positions[1].to_array().map(f32::to_bits), odd.positions[1].to_array().map(f32::to_bits));
        assert_eq!(back.uvs[2], Vec2::new(1.0 / 3.0, 0.0));
        assert_eq!(write_polygon_obj(&odd), write_polygon_obj(&odd.clone()), "deterministic");
    }

    #[test]
    fn a_renumbered_polygon_mesh_keeps_its_corners() {
        // Positions listed out of first-use order, one unused.
        let m = Mesh {
            positions: vec![Vec3::new(9.0, 9.0, 9.0), Vec3::Z, Vec3::X, Vec3::Y, Vec3::ZERO],
            uvs: vec![Vec2::ONE, Vec2::ZERO, Vec2::X, Vec2::Y],
            faces: vec![
                Face { positions: vec![4, 2, 3], uvs: vec![1, 2, 3] },
                Face { positions: vec![4, 3, 1], uvs: vec![1, 3, 0] },
            ],
        };
        let back = read_obj(write_polygon_obj(&m).as_bytes()).unwrap();
        assert_eq!(back.positions.len(), 4);
        assert_eq!(corners(&back), corners(&m));
    }

    #[test]
    fn a_triangle_mesh_round_trips_through_obj() {
        let tri = TriMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.5), Vec3::Y],
            normals: vec![Vec3::Z; 4],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        };
        let text = write_obj(&tri);
        assert!(text.contains("\nf 1/1/1 2/2/2 3/3/3\n"), "{text}");
        assert!(text.contains("\nv 1 1 0.5\n"), "{text}");
        assert!(text.contains("\nvn 0 0 1\n"), "{text}");
        let back = read_obj(text.as_bytes()).unwrap();
        assert_eq!(back.positions, tri.positions);
        assert_eq!(back.uvs, tri.uvs);
        let faces: Vec<[u32; 3]> =
            back.faces.iter().map(|f| [f.positions[0], f.positions[1], f.positions[2]]).collect();
        assert_eq!(faces, tri.triangles);
        assert!(back.faces.iter().all(|f| f.uvs == f.positions));
        // Without normals or UVs the faces say so.
        let bare = TriMesh { normals: Vec::new(), uvs: Vec::new(), ..tri.clone() };
        assert!(write_obj(&bare).contains("\nf 1 2 3\n"));
        let no_uv = TriMesh { uvs: Vec::new(), ..tri };
        assert!(write_obj(&no_uv).contains("\nf 1//1 2//2 3//3\n"));
    }
}
