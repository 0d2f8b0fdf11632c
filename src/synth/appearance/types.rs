//! Plain data shared by appearance analysis, synthesis and rendering ([references: frasson §4]).
//!
//! Conventions are the structure module's: pixel units, `f64` geometry, y pointing down,
//! pixel `(i, j)` has its centre at `(i + 0.5, j + 0.5)`. Texture coordinates of pieces are in
//! texture pixels (same convention); divide by the texture size for normalised UVs.

use serde::{Deserialize, Serialize};

use crate::raster::Image;
pub use crate::synth::structure::{Mesh, Point};

/// A CIELAB colour (D65, L* in 0–100).
pub type Lab = [f64; 3];

/// A region's pixels cut out of the sample photo (stage A2a): the pixels of the region's
/// polygon at least `shrink` pixels inside it, so no interstice pixel is included.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Extract {
    /// Index of the region in the analysed sample (`SampleStructure::polygons`).
    pub region: usize,
    /// Top-left pixel of the bounding box in the sample.
    pub origin: [usize; 2],
    pub width: usize,
    pub height: usize,
    /// Row-major over the bounding box: the pixel belongs to the extract.
    pub mask: Vec<bool>,
    /// Mean CIELAB of the masked pixels.
    pub lab: Lab,
    /// Number of masked pixels.
    pub pixels: usize,
}

/// The clustering of the extracts by mean colour (stage A2b).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Clustering {
    /// Number of clusters, `1..=10`.
    pub k: usize,
    /// Cluster of each extract (same order as the extracts).
    pub assignment: Vec<usize>,
    /// Mean CIELAB of each cluster.
    pub centres: Vec<Lab>,
    /// Mean silhouette of each `k` tried (index `k − 1`; `k = 1` has none and is `0`).
    pub silhouettes: Vec<f64>,
}

/// One texture per cluster of regions (stage A2d), "the quarry the stones came from".
#[derive(Clone, Debug, PartialEq)]
pub struct UnifiedTexture {
    /// RGB, sRGB-encoded.
    pub image: Image,
    /// Mean CIELAB of the texture.
    pub lab: Lab,
}

/// One strip of the interstice atlas: a drawn edge rectified in its own frame (`u` along the
/// edge from its first to its second vertex, `v` across it, left of the direction first).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IntersticeEntry {
    /// Index of the edge in the sample's mesh edge list (`structure::render::mesh_edges`).
    pub edge: usize,
    /// Length of the original edge, px.
    pub length: f64,
    /// `[x, y, w, h]` of the strip in the atlas, px; `w = length + 2·extension`,
    /// `h = 2·half_width` (rounded up).
    pub rect: [usize; 4],
    /// Mean CIELAB of the strip's mortar pixels (alpha ≥ 0.5), or of all its pixels.
    pub lab: Lab,
}

/// The interstice atlas (stage A2e): every drawn edge's strip, with alpha, and the entries
/// sorted by length for lookup by binary search.
#[derive(Clone, Debug, PartialEq)]
pub struct IntersticeAtlas {
    /// RGBA, sRGB-encoded colour; alpha 1 = interstice (mortar), 0 = interior (stone).
    pub image: Image,
    /// Sorted by `length`, ties by `edge`.
    pub entries: Vec<IntersticeEntry>,
    pub half_width: f64,
    pub extension: f64,
}

/// One star of the junction atlas: a drawn vertex of valency `v` with its branches.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JunctionEntry {
    /// Index of the vertex in the sample's mesh.
    pub vertex: usize,
    /// The vertex position in the atlas, px.
    pub center: Point,
    /// Star outline in the atlas, px: for each branch `i` (in counter-clockwise order on
    /// screen), `tip_right_i`, `tip_left_i`, `M_i`.
    pub star: Vec<Point>,
    /// Branch directions (radians, from +x towards +y), in the same order.
    pub directions: Vec<f64>,
    /// Angles between consecutive branches, radians, summing to 2π.
    pub angles: Vec<f64>,
    /// Mean CIELAB of the star's mortar pixels.
    pub lab: Lab,
}

/// The junction atlas (stage A2f).
#[derive(Clone, Debug, PartialEq)]
pub struct JunctionAtlas {
    /// RGBA, sRGB-encoded colour; alpha 1 = junction (mortar).
    pub image: Image,
    pub entries: Vec<JunctionEntry>,
    pub half_width: f64,
    pub branch_len: f64,
}

/// Everything appearance synthesis needs from a sample (the "appearance generator").
#[derive(Clone, Debug, PartialEq)]
pub struct AppearanceData {
    pub unified: Vec<UnifiedTexture>,
    /// The originals searched for a generated region's closest shape, with their cluster.
    pub originals: Vec<Original>,
    pub interstices: IntersticeAtlas,
    pub junctions: JunctionAtlas,
}

/// A clustered region of the appearance sample.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Original {
    /// Index in the sample's polygons.
    pub region: usize,
    pub polygon: Vec<Point>,
    pub cluster: usize,
    pub lab: Lab,
}

/// Which texture a piece samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum TextureId {
    Unified(usize),
    Interstices,
    Junctions,
}

/// Draw order: interiors at the bottom, then interstices, then junctions ("slightly in
/// front", blended with alpha).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Layer {
    Interior,
    Interstice,
    Junction,
}

/// A triangle corner: a target position and the texture position it shows, both px.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Corner {
    pub pos: Point,
    pub uv: Point,
}

/// One textured polygon of the output (a region, an edge's quad or a vertex's star), as
/// triangles so the texture map is affine per triangle (piecewise affine for stars).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Piece {
    pub layer: Layer,
    pub texture: TextureId,
    /// The region, edge or vertex index of the target mesh this piece dresses.
    pub owner: usize,
    pub triangles: Vec<[Corner; 3]>,
}

/// The synthesised appearance of a mesh (S5–S8): polygons and UVs only, no texels.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Dressing {
    /// In draw order: every interior, then every interstice, then every junction.
    pub pieces: Vec<Piece>,
    /// Per target region: the cluster its texture comes from (`None` when not dressed).
    pub clusters: Vec<Option<usize>>,
    /// What fell back (missing valencies, regions larger than every texture), in words.
    pub warnings: Vec<String>,
}
