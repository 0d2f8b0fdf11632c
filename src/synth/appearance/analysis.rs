//! A sample's appearance analysis as two cached values ([references: frasson §4]): the
//! region interiors (A2a–d: extracts, clusters, guides, unified textures) and the contours
//! (A2e–f: alpha, interstice and junction atlases), which may come from different samples.

use serde::{Deserialize, Serialize};

use super::alpha::{sample_alpha, AlphaError, AlphaParams};
use super::interstice::{build_interstice_atlas, interstice_atlas_size, IntersticeParams};
use super::junction::{build_junction_atlas, junction_atlas_size, JunctionParams};
use super::types::{
    AppearanceData, Clustering, IntersticeAtlas, IntersticeEntry, JunctionAtlas, JunctionEntry, Lab, Original,
    UnifiedTexture,
};
use super::types::{Mesh, Point};
use super::unified::{self, analyse_interiors, originals, InteriorError, InteriorParams};
use crate::raster::color::{lab_to_linear_rgb, linear_to_srgb};
use crate::raster::Image;
use crate::synth::structure::analysis::labels_import::rasterize_polygons;
use crate::synth::structure::analysis::sample::SampleStructure;

/// The interiors of a sample (A2a–d).
#[derive(Clone, Debug, PartialEq)]
pub struct Interiors {
    pub unified: Vec<UnifiedTexture>,
    /// The guiding texture of each cluster (a debug view).
    pub guides: Vec<Image>,
    /// The regions a generated region's closest shape is searched among, with their cluster.
    pub originals: Vec<Original>,
    pub clustering: Clustering,
    /// The sample with each region painted in its cluster's mean colour (a debug view).
    pub cluster_view: Image,
    pub warnings: Vec<String>,
}

/// [`Interiors`] without its images, for the cache's header.
#[derive(Serialize, Deserialize)]
pub struct InteriorsMeta {
    labs: Vec<Lab>,
    originals: Vec<Original>,
    clustering: Clustering,
    warnings: Vec<String>,
    guides: usize,
}

impl Interiors {
    /// The images (unified textures, guides, cluster view) and the rest.
    pub fn split(&self) -> (InteriorsMeta, Vec<&Image>) {
        let meta = InteriorsMeta {
            labs: self.unified.iter().map(|u| u.lab).collect(),
            originals: self.originals.clone(),
            clustering: self.clustering.clone(),
            warnings: self.warnings.clone(),
            guides: self.guides.len(),
        };
        let mut images: Vec<&Image> = self.unified.iter().map(|u| &u.image).collect();
        images.extend(self.guides.iter());
        images.push(&self.cluster_view);
        (meta, images)
    }

    pub fn join(meta: InteriorsMeta, mut images: Vec<Image>) -> Result<Interiors, String> {
        let k = meta.labs.len();
        if images.len() != k + meta.guides + 1 {
            return Err("appearance interiors: wrong image count".into());
        }
        let cluster_view = images.pop().expect("counted");
        let guides = images.split_off(k);
        let unified = images.into_iter().zip(meta.labs).map(|(image, lab)| UnifiedTexture { image, lab }).collect();
        Ok(Interiors {
            unified,
            guides,
            originals: meta.originals,
            clustering: meta.clustering,
            cluster_view,
            warnings: meta.warnings,
        })
    }

    /// The index in [`Interiors::originals`] of sample region `region`, if it is one.
    pub fn original_of_region(&self, region: usize) -> Option<usize> {
        self.originals.iter().position(|o| o.region == region)
    }
}

/// The contours of a sample (A2e–f).
#[derive(Clone, Debug, PartialEq)]
pub struct Contours {
    pub interstices: IntersticeAtlas,
    pub junctions: JunctionAtlas,
    /// The sample's alpha (1 = mortar), automatic or painted.
    pub alpha: Image,
}

/// [`Contours`] without its images.
#[derive(Serialize, Deserialize)]
pub struct ContoursMeta {
    interstices: Vec<IntersticeEntry>,
    junctions: Vec<JunctionEntry>,
    half_width: f64,
    extension: f64,
    branch_len: f64,
}

impl Contours {
    pub fn split(&self) -> (ContoursMeta, Vec<&Image>) {
        let meta = ContoursMeta {
            interstices: self.interstices.entries.clone(),
            junctions: self.junctions.entries.clone(),
            half_width: self.interstices.half_width,
            extension: self.interstices.extension,
            branch_len: self.junctions.branch_len,
        };
        (meta, vec![&self.interstices.image, &self.junctions.image, &self.alpha])
    }

    pub fn join(meta: ContoursMeta, images: Vec<Image>) -> Result<Contours, String> {
        let [interstices, junctions, alpha]: [Image; 3] =
            images.try_into().map_err(|_| "appearance contours: wrong image count".to_string())?;
        Ok(Contours {
            interstices: IntersticeAtlas {
                image: interstices,
                entries: meta.interstices,
                half_width: meta.half_width,
                extension: meta.extension,
            },
            junctions: JunctionAtlas {
                image: junctions,
                entries: meta.junctions,
                half_width: meta.half_width,
                branch_len: meta.branch_len,
            },
            alpha,
        })
    }
}

/// What appearance synthesis reads: the interiors of one sample and the contours of another
/// (or the same).
pub fn appearance_data(interiors: &Interiors, contours: &Contours) -> AppearanceData {
    AppearanceData {
        unified: interiors.unified.clone(),
        originals: interiors.originals.clone(),
        interstices: contours.interstices.clone(),
        junctions: contours.junctions.clone(),
    }
}

/// Images side by side on a black background, top-aligned, 4 px apart: one picture of a
/// texture set. Channels are the most any image has (missing ones 0; a missing alpha 1).
pub fn side_by_side<'a>(images: impl IntoIterator<Item = &'a Image>) -> Image {
    let images: Vec<&Image> = images.into_iter().collect();
    let gap = 4;
    let width = images.iter().map(|i| i.width).sum::<usize>() + gap * images.len().saturating_sub(1);
    let height = images.iter().map(|i| i.height).max().unwrap_or(1);
    let channels = images.iter().map(|i| i.channels).max().unwrap_or(3).max(3);
    let mut out = Image::new(width.max(1), height, channels);
    let mut x0 = 0;
    for img in images {
        for c in 0..channels {
            for y in 0..img.height {
                for x in 0..img.width {
                    let v = if c < img.channels {
                        img.get(x, y, c)
                    } else if c == 3 {
                        1.0
                    } else {
                        img.get(x, y, 0)
                    };
                    out.set(x0 + x, y, c, v);
                }
            }
        }
        x0 += img.width + gap;
    }
    out
}

/// Parameters of the contour analysis (A2e–f).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContourParams {
    /// Strip and branch half-width `w`, px.
    pub half_width: f64,
    /// How far strips reach past their edge's ends (`None` = `half_width`).
    pub extension: Option<f64>,
    /// Longest star branch (`None` = `2·half_width`).
    pub branch_len: Option<f64>,
    /// Region masks shrunk by this much seed the stone class of the automatic alpha.
    pub shrink: f64,
}

impl Default for ContourParams {
    fn default() -> Self {
        ContourParams { half_width: 6.0, extension: None, branch_len: None, shrink: 2.0 }
    }
}

impl ContourParams {
    fn interstice(&self) -> IntersticeParams {
        IntersticeParams { half_width: self.half_width, extension: self.extension, ..IntersticeParams::default() }
    }

    fn junction(&self) -> JunctionParams {
        JunctionParams { half_width: self.half_width, branch_len: self.branch_len, ..JunctionParams::default() }
    }
}

/// The pixels of the two atlases [`contours`] cuts from a sample drawn as `mesh` (the
/// interstice atlas's and the junction atlas's, packed), found without cutting them: what a
/// caller holds to a memory budget before calling [`contours`].
pub fn contour_atlas_pixels(mesh: &Mesh, params: &ContourParams) -> f64 {
    let [iw, ih] = interstice_atlas_size(mesh, &params.interstice());
    let [jw, jh] = junction_atlas_size(mesh, &params.junction());
    iw as f64 * ih as f64 + jw as f64 * jh as f64
}

/// A2e–f: the alpha of the sample (the painted `alpha_override`, or automatic), then the
/// interstice and junction atlases cut from it. `image` is RGB, sRGB-encoded, the size of
/// the structure `sample` was drawn on.
pub fn contours(
    image: &Image,
    sample: &SampleStructure,
    params: &ContourParams,
    alpha_override: Option<&Image>,
) -> Result<Contours, AlphaError> {
    let w = params.half_width;
    // The band of the automatic alpha covers the strips and the stars' inner vertices.
    let band = (2.0 * w).max(w + params.extension.unwrap_or(w)).max(1.0);
    let alpha_params = AlphaParams { shrink: params.shrink, band, ..AlphaParams::default() };
    let alpha = sample_alpha(image, &sample.polygons, &alpha_params, alpha_override)?;
    let (interstices, junctions) = rayon::join(
        || build_interstice_atlas(image, &alpha, &sample.mesh, &params.interstice()),
        || build_junction_atlas(image, &alpha, &sample.mesh, &params.junction()),
    );
    Ok(Contours { interstices, junctions, alpha })
}

/// A2a–d: every region of the sample extracted, clustered by colour, and one unified
/// texture per cluster. The originals searched for closest shapes are the sample's interior
/// regions (those its structure statistics use), or every extracted region when it has
/// none. `image` is RGB, sRGB-encoded, the size of the structure's drawing.
pub fn interiors(
    image: &Image,
    sample: &SampleStructure,
    params: &InteriorParams,
    seed: u64,
) -> Result<Interiors, InteriorError> {
    let regions: Vec<usize> = (0..sample.polygons.len()).collect();
    let analysed = analyse_interiors(image, &sample.polygons, &regions, params, seed)?;
    let all = originals(&sample.polygons, &analysed);
    let inner: std::collections::BTreeSet<usize> = sample.original_regions().into_iter().collect();
    let kept: Vec<Original> = all.iter().filter(|o| inner.contains(&o.region)).cloned().collect();
    let mut warnings = Vec::new();
    let originals = if kept.is_empty() {
        warnings.push(
            "the appearance sample has no interior region: closest shapes are searched among border regions too"
                .to_string(),
        );
        all
    } else {
        kept
    };
    let cluster_view = paint_clusters(image.width, image.height, &sample.polygons, &analysed);
    Ok(Interiors {
        unified: analysed.unified(),
        guides: analysed.textures.iter().map(|t| t.guide.image.clone()).collect(),
        originals,
        clustering: analysed.clustering,
        cluster_view,
        warnings,
    })
}

/// The sample's regions painted in their cluster's mean colour (unclustered pixels black).
fn paint_clusters(width: usize, height: usize, polygons: &[Vec<Point>], analysed: &unified::Interiors) -> Image {
    let labels = rasterize_polygons(polygons, width, height);
    let mut cluster_of = vec![None; polygons.len()];
    for (e, &c) in analysed.extracts.iter().zip(&analysed.clustering.assignment) {
        cluster_of[e.region] = Some(c);
    }
    let colours: Vec<[f32; 3]> = analysed
        .clustering
        .centres
        .iter()
        .map(|l| {
            let rgb = lab_to_linear_rgb([l[0] as f32, l[1] as f32, l[2] as f32]);
            rgb.map(|v| linear_to_srgb(v.clamp(0.0, 1.0)))
        })
        .collect();
    let mut out = Image::new(width, height, 3);
    let n = width * height;
    for (i, &id) in labels.data.iter().enumerate() {
        if let Some(c) = cluster_of.get(id as usize).copied().flatten() {
            for (ch, v) in colours[c].iter().enumerate() {
                out.data[ch * n + i] = *v;
            }
        }
    }
    out
}
