//! The artifacts of the structure stages and their cache encodings: the analysed sample,
//! generators, the relaxed label raster (binary, so a 1024² raster stays 4 MiB) and meshes.

use serde::{Deserialize, Serialize};

use super::super::Encoded;
use crate::synth::structure::analysis::sample::SampleStructure;
use crate::synth::structure::generation::courses::CourseLayout;
use crate::synth::structure::generation::edits;
use crate::synth::structure::mesh::polygonize::Polygonization;
use crate::synth::structure::relaxation::lloyd::IterationStats;
use crate::synth::structure::{Ellipse, Labels, Mesh, Point};

/// Generators ready for Lloyd (S1, S1e): the editable set, and how sampling went.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Generators {
    #[serde(flatten)]
    pub set: edits::Generators,
    /// `N'` of statistical synthesis (the generator count before any removal).
    pub target_count: usize,
    /// Ellipses the occupancy map removed.
    pub dropped: usize,
    /// The wall of a course-by-course synthesis: Lloyd then only rasterises it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub courses: Option<CourseLayout>,
}

/// The relaxed generators and their label raster (S2).
#[derive(Clone, Debug, PartialEq)]
pub struct Relaxed {
    /// The generators with the axes they were sampled with: edits and re-runs start here.
    pub generators: Vec<Ellipse>,
    /// The generators as the final Voronoi step saw them (axes scaled by the size map; equal
    /// to `generators` without one): the ellipse and distance views draw these.
    pub sized: Vec<Ellipse>,
    pub frozen: Vec<bool>,
    pub labels: Labels,
    pub iterations: Vec<IterationStats>,
    pub converged: bool,
    pub orphans: Vec<usize>,
}

impl Encoded for SampleStructure {
    fn encode(&self) -> Vec<u8> {
        serde_json::to_vec(self).expect("sample structure serialises")
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        serde_json::from_slice(bytes).map_err(|e| e.to_string())
    }
}

impl Encoded for Generators {
    fn encode(&self) -> Vec<u8> {
        serde_json::to_vec(self).expect("generators serialise")
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        serde_json::from_slice(bytes).map_err(|e| e.to_string())
    }
}

#[derive(Serialize, Deserialize)]
struct RelaxedMeta {
    generators: Vec<Ellipse>,
    sized: Vec<Ellipse>,
    frozen: Vec<bool>,
    width: usize,
    height: usize,
    iterations: Vec<IterationStats>,
    converged: bool,
    orphans: Vec<usize>,
}

/// Metadata as JSON, then the labels as raw little-endian u32s: a 1024² raster stays 4 MiB.
impl Encoded for Relaxed {
    fn encode(&self) -> Vec<u8> {
        let meta = RelaxedMeta {
            generators: self.generators.clone(),
            sized: self.sized.clone(),
            frozen: self.frozen.clone(),
            width: self.labels.width,
            height: self.labels.height,
            iterations: self.iterations.clone(),
            converged: self.converged,
            orphans: self.orphans.clone(),
        };
        let json = serde_json::to_vec(&meta).expect("meta serialises");
        let mut out = Vec::with_capacity(8 + json.len() + 4 * self.labels.data.len());
        out.extend_from_slice(&(json.len() as u64).to_le_bytes());
        out.extend_from_slice(&json);
        for v in &self.labels.data {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let n = u64::from_le_bytes(bytes.get(..8).ok_or("truncated")?.try_into().map_err(|_| "truncated")?) as usize;
        let json = bytes.get(8..8 + n).ok_or("truncated")?;
        let meta: RelaxedMeta = serde_json::from_slice(json).map_err(|e| e.to_string())?;
        let raw = &bytes[8 + n..];
        if raw.len() != 4 * meta.width * meta.height {
            return Err("label raster has the wrong length".into());
        }
        let data = raw.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        Ok(Relaxed {
            generators: meta.generators,
            sized: meta.sized,
            frozen: meta.frozen,
            labels: Labels { width: meta.width, height: meta.height, data },
            iterations: meta.iterations,
            converged: meta.converged,
            orphans: meta.orphans,
        })
    }
}

/// The sample region a generated region was matched with (the closest shape, [references:
/// frasson §3.6]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Associated {
    /// Index of the region in the analysed sample (`SampleStructure::polygons`).
    pub region: usize,
    /// Rotation (radians, about the centroid) that turns the original onto the region; 0
    /// when `allow_rotation = false`.
    pub rotation: f64,
    /// Turning-function distance of the match.
    pub distance: f64,
    /// `area(original) / area(region)`.
    pub area_ratio: f64,
}

/// The final mesh of stage 2 and, per region, the original shape it was matched with.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Shaped {
    pub mesh: Mesh,
    pub placed: Vec<Option<Vec<Point>>>,
    /// Per region of `mesh`: the sample region it was matched with and how it was turned
    /// (appearance synthesis picks the region's texture by it).
    pub associated: Vec<Option<Associated>>,
    /// Mean shape error per iteration.
    pub errors: Vec<f64>,
}

impl Encoded for Shaped {
    fn encode(&self) -> Vec<u8> {
        serde_json::to_vec(self).expect("mesh serialises")
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        serde_json::from_slice(bytes).map_err(|e| e.to_string())
    }
}

impl Encoded for Polygonization {
    fn encode(&self) -> Vec<u8> {
        serde_json::to_vec(self).expect("mesh serialises")
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        serde_json::from_slice(bytes).map_err(|e| e.to_string())
    }
}
