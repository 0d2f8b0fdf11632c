//! Options of appearance synthesis (S5–S8) and what the caller already knows about the target
//! regions ([references: frasson §4.1.3]).

use crate::synth::structure::shapes::associate::AssociateParams;

/// How a target region picks the cluster (unified texture) it is dressed with (V21).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClusterChoice {
    /// The cluster of the region's closest original (turning function, ±20 % area).
    ClosestShape,
    /// A seeded uniform cluster per region.
    Random,
    /// The caller's previous cluster of the region id when there is one, else the closest shape.
    Sticky,
}

/// Which end of an atlas strip goes on the first vertex of an edge (V23).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlipMode {
    /// A seeded coin per edge.
    Random,
    /// Never flipped: the strip's start is on the edge's lower vertex index.
    None,
    /// Greedy in edge order: the orientation whose end colours best match the ends of the
    /// strips already placed at the same vertices.
    BestColor,
}

/// Parameters of [`crate::synth::appearance::dress::dress`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DressParams {
    pub cluster_choice: ClusterChoice,
    /// Texels per structure pixel (the sample/structure resolution ratio); 1 by default.
    pub texel_scale: f64,
    /// Closest-shape association options (only used for regions without a known association).
    pub associate: AssociateParams,
    pub flip: FlipMode,
    /// Candidates of the junction search kept for the colour heuristic (`junction.k`, V24).
    pub junction_k: usize,
    /// Run S8 (junction–interstice matching); `false` leaves the raw quads and stars.
    pub match_contours: bool,
    /// Matching scales outside `[1/r, r]` move the interstice instead of the junction (V25: 2).
    pub max_scale: f64,
    /// Edges shorter than this many interstice half-widths take the junction-to-junction path.
    pub short_edge: f64,
    /// Alpha threshold of the matching extents (0.5).
    pub alpha_threshold: f32,
}

impl Default for DressParams {
    fn default() -> Self {
        DressParams {
            cluster_choice: ClusterChoice::ClosestShape,
            texel_scale: 1.0,
            associate: AssociateParams::default(),
            flip: FlipMode::Random,
            junction_k: 5,
            match_contours: true,
            max_scale: 2.0,
            short_edge: 2.0,
            alpha_threshold: 0.5,
        }
    }
}

/// What the caller already knows per target region (indexed by region id).
#[derive(Clone, Copy, Debug, Default)]
pub struct DressHints<'a> {
    /// Each region's associated original (index into `AppearanceData::originals`), e.g. from
    /// the structure's stage 2; regions with `None` (or past the end) are searched.
    pub associations: Option<&'a [Option<usize>]>,
    /// Each region's cluster from an earlier dressing, for [`ClusterChoice::Sticky`].
    pub previous_clusters: Option<&'a [Option<usize>]>,
}

/// A per-item generator stream: `base` (a named stream) mixed with the item index, so items
/// draw independently and in parallel.
pub fn item_seed(base: u64, i: usize) -> u64 {
    base ^ (i as u64).wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15)
}
