//! Appearance synthesis onto a mesh (S5–S8, [references: frasson §4.1.3, §4.2.3]).
//!
//! [`dress`] runs, in this order: S5 interiors (`interiors`), S6 interstices
//! (`interstices`), S7 junctions (`junctions`, whose colour heuristic reads S6's strips),
//! S8 matching (`matching`). The result holds polygons and texture coordinates only: no texel
//! is produced, so texture memory stays that of the appearance data whatever the target size.
//! `params` holds the options, `geom` the plane geometry, `testkit` hand-made appearance
//! data for tests and benches; `tests` checks F23–F27, `tests_edits` F28 (mixed sources,
//! painted textures, local edits and sticky clusters).

pub mod geom;
pub mod interiors;
pub mod interstices;
pub mod junctions;
pub mod matching;
pub mod params;
#[cfg(any(test, feature = "fixtures"))]
pub mod testkit;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_edits;

use crate::synth::appearance::types::{AppearanceData, Dressing, Mesh};
use crate::synth::structure::render::mesh_edges;
use interiors::{interiors, Interiors};
use interstices::{interstices, Strip};
use junctions::{junctions, JunctionIndex, Star};
use matching::{match_contours, MatchReport};
pub use params::{ClusterChoice, DressHints, DressParams, FlipMode};

/// Every stage's result, for inspection; [`Stages::dressing`] is what [`dress`] returns.
#[derive(Clone, Debug)]
pub struct Stages {
    pub edges: Vec<[usize; 2]>,
    pub interiors: Interiors,
    /// Per edge of `edges` (after S8: clipped, moved, or without polygon when skipped).
    pub strips: Vec<Option<Strip>>,
    /// Per mesh vertex.
    pub stars: Vec<Option<Star>>,
    /// S8's record (empty when `match_contours` is off).
    pub matching: MatchReport,
    pub dressing: Dressing,
}

/// S5–S8 with every intermediate result.
pub fn dress_stages(mesh: &Mesh, data: &AppearanceData, params: &DressParams, seed: u64, hints: &DressHints) -> Stages {
    let edges = mesh_edges(mesh);
    let interiors = interiors(mesh, data, params, seed, hints);
    let mut strips = interstices(mesh, &edges, &data.interstices, params, seed);
    let index = JunctionIndex::new(&data.junctions);
    let (mut stars, junction_warnings) =
        junctions(mesh, &edges, &strips, &data.interstices, &data.junctions, &index, params);
    let mut warnings = interiors.warnings.clone();
    warnings.extend(junction_warnings);
    if data.interstices.entries.is_empty() && !edges.is_empty() {
        warnings.push("empty interstice atlas: edges are not dressed".to_string());
    }
    let matching = if params.match_contours {
        match_contours(&mut stars, &mut strips, &data.interstices, &data.junctions, params)
    } else {
        MatchReport::default()
    };
    if !matching.restored_stars.is_empty() {
        warnings.push(format!(
            "{} junctions kept unmatched: their matched outline was not star-shaped",
            matching.restored_stars.len()
        ));
    }
    if !matching.restored_strips.is_empty() {
        warnings.push(format!(
            "{} interstices kept unmoved: their moved quad was not simple",
            matching.restored_strips.len()
        ));
    }
    let mut pieces = interiors.pieces.clone();
    pieces.extend(strips.iter().flatten().filter_map(Strip::piece));
    pieces.extend(stars.iter().flatten().map(Star::piece));
    let dressing = Dressing { pieces, clusters: interiors.clusters.clone(), warnings };
    Stages { edges, interiors, strips, stars, matching, dressing }
}

/// Appearance synthesis of `mesh` from `data` (S5–S8): one textured polygon per region, per
/// edge and per vertex, in draw order.
pub fn dress(mesh: &Mesh, data: &AppearanceData, params: &DressParams, seed: u64, hints: &DressHints) -> Dressing {
    dress_stages(mesh, data, params, seed, hints).dressing
}
