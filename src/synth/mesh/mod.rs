//! Target meshes for relief (Frasson Ch. 5): coarse polygon meshes with texture coordinates, as
//! read from OBJ files, and the triangle meshes that displacement, seam zipping, the renderer and
//! the exporters exchange.
//!
//! Two shapes of mesh, because the work needs both:
//! - [`Mesh`] keeps the author's **polygons** (a quad stays a quad): displacement subdivides each
//!   coarse face on its own grid, and seams are the borders between coarse faces
//!   ([references: frasson §5.3.2]).
//! - [`TriMesh`] is indexed triangles with one position, normal and UV per vertex: what a renderer
//!   draws and what glTF stores.
//!
//! Around them: [`obj`] reads and writes OBJ text, [`check`] validates a mesh (every problem with
//! its face and OBJ line), [`frames`] gives per-vertex tangent frames and the triangulation,
//! [`displace`] and [`seam`] relieve a mesh and close its seams, [`seam_texture`] textures the
//! seams from the faces beside them, [`textured`] gathers it all into one textured triangle mesh,
//! [`gltf`] writes glTF binaries.

pub mod check;
pub mod detail;
pub mod displace;
pub mod frames;
pub mod gltf;
mod meshes;
pub mod obj;
pub mod seam;
pub mod seam_texture;
#[cfg(test)]
mod tests;
pub mod textured;

pub use check::{problems, validate, validate_with_lines, FaceAt, Limits, MeshError};
pub use frames::{face_triangles, position_normals, tangent_frames, triangulate, Frame, Frames};
pub use obj::{load_obj, read_obj, read_obj_with_lines, write_obj, write_polygon_obj, ObjMesh};

pub use gltf::{write_glb, GlbTextures};
pub use meshes::{edge_uses, Face, Mesh, TriMesh};
