//! Target meshes for relief (Frasson Ch. 5): coarse polygon meshes with texture coordinates, as
//! read from OBJ files, and the triangle meshes that displacement, seam zipping, the renderer and
//! the exporters exchange.
//!
//! Two shapes of mesh, because the work needs both:
//! - [`Mesh`] keeps the author's **polygons** (a quad stays a quad): displacement subdivides each
//!   coarse face on its own grid, and seams are the borders between coarse faces
//!   ([references: frasson §5.3.2]).
//!
//! Around them: [`obj`] reads and writes OBJ text, [`check`] validates a mesh (every problem with
//! its face and OBJ line), [`frames`] gives per-vertex tangent frames and the triangulation,
//! [`displace`] and [`seam`] relieve a mesh and close its seams, [`gltf`] writes glTF binaries.
//! - [`TriMesh`] is indexed triangles with one position, normal and UV per vertex: what a renderer
//!   draws and what glTF stores.

// `gltf` uses `TriMesh` from here, so its items are not re-exported here (that would make the
// two files import each other): use `mesh::gltf::{write_glb, GlbTextures}`.
pub mod check;
pub mod displace;
pub mod frames;
pub mod gltf;
pub mod obj;
pub mod seam;
pub mod seam_texture;

pub use check::{problems, validate, validate_with_lines, FaceAt, Limits, MeshError};
pub use frames::{face_triangles, position_normals, tangent_frames, triangulate, Frame, Frames};
pub use obj::{load_obj, read_obj, read_obj_with_lines, write_obj, write_polygon_obj, ObjMesh};

use glam::{Vec2, Vec3};

/// A polygon mesh with texture coordinates. Positions and UVs are indexed separately (as in OBJ),
/// so a vertex on a UV seam has one position and several UVs.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub faces: Vec<Face>,
}

/// One polygon: for each corner, counter-clockwise seen from outside, an index into
/// [`Mesh::positions`] and one into [`Mesh::uvs`].
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Face {
    pub positions: Vec<u32>,
    pub uvs: Vec<u32>,
}

impl Face {
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// The corner pairs `(a, b)` of the face's edges, by position index, in winding order.
    pub fn edges(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        let n = self.positions.len();
        (0..n).map(move |i| (self.positions[i], self.positions[(i + 1) % n]))
    }
}

/// Indexed triangles with per-vertex attributes (normals unit length, UVs in texture space with
/// v up, as OBJ and the UV convention of [`Mesh`]).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TriMesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Axis-aligned bounds `(min, max)`; `None` when there is no vertex.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let first = *self.positions.first()?;
        Some(self.positions.iter().fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p))))
    }
}

/// How many faces use each undirected edge, keyed `(min, max)` by position index: an edge used
/// once is on the border, twice is interior, more is non-manifold.
pub fn edge_uses<'a>(
    triangles_or_faces: impl IntoIterator<Item = &'a [u32]>,
) -> std::collections::BTreeMap<(u32, u32), u32> {
    let mut uses = std::collections::BTreeMap::new();
    for poly in triangles_or_faces {
        let n = poly.len();
        for i in 0..n {
            let (a, b) = (poly[i], poly[(i + 1) % n]);
            *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    uses
}
