//! A structure sample, analysed: what the synthesis stages need from a drawn subdivision
//! ([references: frasson §3.1, §3.4]), as one plain value that can be cached.

use serde::{Deserialize, Serialize};

use crate::synth::structure::analysis::courses::{detect_courses, CourseAnalysis};
use crate::synth::structure::analysis::labels_import::import_labels;
use crate::synth::structure::analysis::stats::{self, StatModel, StatsConfig};
use crate::synth::structure::format::{parse_structure_file, StructureFile};
use crate::synth::structure::StructureError;
use crate::synth::structure::{Ellipse, Mesh, Point, Subdivision};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SampleStructure {
    /// The sample's size in pixels (from the file, else the bounding box).
    pub size: [f64; 2],
    /// Every region's boundary polygon (holes dropped), in face order.
    pub polygons: Vec<Vec<Point>>,
    /// Per region: touches the sample border or the outer face.
    pub border: Vec<bool>,
    /// Per region: the fitted ellipse, when the region is not degenerate.
    pub ellipses: Vec<Option<Ellipse>>,
    /// The cleaned subdivision as a mesh (for views of the sample itself).
    pub mesh: Mesh,
    pub model: StatModel,
    /// The courses found among the regions, and whether the sample is layered.
    #[serde(default)]
    pub courses: CourseAnalysis,
    /// What cleaning changed, in words (pruned dangling edges, duplicates, islands).
    pub warnings: Vec<String>,
}

impl SampleStructure {
    /// Interior regions (not on the border) with their ellipses: the originals that
    /// synthesis samples from and shape optimisation matches against.
    pub fn originals(&self) -> Vec<(Vec<Point>, Ellipse)> {
        self.original_regions()
            .into_iter()
            .map(|r| (self.polygons[r].clone(), self.ellipses[r].expect("kept")))
            .collect()
    }

    /// The sample region index of each of [`SampleStructure::originals`], in the same order.
    pub fn original_regions(&self) -> Vec<usize> {
        (0..self.polygons.len())
            .filter(|&r| !(self.model.config.exclude_border_regions && self.border[r]))
            .filter(|&r| self.ellipses[r].is_some())
            .collect()
    }
}

/// Parses, validates, cleans and analyses a structure file's text.
pub fn analyse_sample(text: &str, config: &StatsConfig) -> Result<SampleStructure, StructureError> {
    let file = parse_structure_file(text)?;
    analyse_subdivision(&file.subdivision, file.size, config)
}

/// A painted label image as a structure sample: one id (or colour, packed by the caller)
/// per pixel; region boundaries are traced and simplified by `tolerance` pixels.
pub fn analyse_label_image(
    ids: &[u32],
    width: usize,
    height: usize,
    tolerance: f64,
    config: &StatsConfig,
) -> Result<SampleStructure, StructureError> {
    let sub = import_labels(ids, width, height, tolerance)?;
    analyse_subdivision(&sub, Some([width as f64, height as f64]), config)
}

/// Validates, cleans and analyses a subdivision.
pub fn analyse_subdivision(
    sub: &Subdivision,
    size: Option<[f64; 2]>,
    config: &StatsConfig,
) -> Result<SampleStructure, StructureError> {
    let file = StructureFile { size, subdivision: sub.clone() };
    let analysis = stats::analyse(&file.subdivision, file.size, config)?;
    let sub = &analysis.cleaned.subdivision;
    let faces = &analysis.faces;
    let size = file.size.unwrap_or_else(|| {
        let (mut w, mut h) = (0f64, 0f64);
        for v in &sub.vertices {
            w = w.max(v[0]);
            h = h.max(v[1]);
        }
        [w.ceil(), h.ceil()]
    });
    let polygons: Vec<Vec<Point>> = (0..faces.regions.len()).map(|r| faces.polygon(sub, r)).collect();
    let border: Vec<bool> = faces.regions.iter().map(|r| r.is_border()).collect();
    let ellipses: Vec<Option<Ellipse>> = analysis.model.regions.iter().map(|r| r.ellipse).collect();
    let interior: Vec<bool> =
        (0..polygons.len()).map(|r| !(config.exclude_border_regions && border[r]) && ellipses[r].is_some()).collect();
    let courses = detect_courses(&polygons, &border, &interior, size);
    Ok(SampleStructure {
        size,
        polygons,
        border,
        ellipses,
        courses,
        mesh: faces.to_mesh(sub),
        warnings: analysis.cleaned.warnings.iter().map(|w| w.to_string()).collect(),
        model: analysis.model,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::structure::analysis::stats::EllipseFit;
    use crate::synth::structure::fixtures::standins;

    #[test]
    fn a_standin_analyses_into_its_regions() {
        let st = standins::wall_random(&standins::WallRandomParams::default(), 1);
        let text = crate::synth::structure::format::to_json_sized(&st.subdivision, [st.width as f64, st.height as f64]);
        let s = analyse_sample(&text, &StatsConfig::default()).expect("analyses");
        assert_eq!(s.polygons.len(), st.mesh.regions.len());
        assert!(s.border.iter().any(|b| *b) && s.border.iter().any(|b| !*b));
        assert_eq!(s.originals().len(), s.model.counts.regions - s.model.counts.border_regions);
        assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    }

    #[test]
    fn pixel_fits_agree_with_polygon_fits() {
        let st = standins::wall_random(&standins::WallRandomParams::default(), 1);
        let text = crate::synth::structure::format::to_json_sized(&st.subdivision, [st.width as f64, st.height as f64]);
        let poly = analyse_sample(&text, &StatsConfig::default()).unwrap();
        let pix =
            analyse_sample(&text, &StatsConfig { ellipse_fit: EllipseFit::Pixels, ..StatsConfig::default() }).unwrap();
        for (a, b) in poly.ellipses.iter().zip(&pix.ellipses) {
            let (a, b) = (a.unwrap(), b.unwrap());
            if a.a * a.b * std::f64::consts::PI >= 500.0 {
                assert!((a.a - b.a).abs() / a.a < 0.03 && (a.b - b.b).abs() / a.b < 0.03, "{a:?} vs {b:?}");
            }
        }
    }
}
