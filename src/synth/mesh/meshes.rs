//! The two shapes of mesh that relief exchanges: the author's polygons ([`Mesh`]) and indexed
//! triangles with per-vertex attributes ([`TriMesh`]).

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
