//! Relief layers: colour and depth synthesised together from patches under a guide image,
//! Frasson's multi-patch depth synthesis [references: frasson §5.3.1].
//!
//! ```text
//! patches (sample.patch)…, guide, [surface] ─► layer.relief ─► layer.image (colour)
//!                                                    └──────► layer.depth (height, blurred)
//! ```
//!
//! Each block takes the patch whose mean CIELAB colour is nearest the guide block's, scored by
//! `α1·O + α2·G + α3·D`; colour and depth are pasted through the same cut. Colours are matched in
//! linear RGB (so CIELAB is exact) whatever the spaces of the guide and patches; the colour image
//! is handed on in the first patch's space. The depth blur is a stage of its own, so changing it
//! never searches again.

use super::{exact_size, prop_of, quilt_error, wire, QUILT_BYTES_PER_PIXEL};
use crate::graph::{Handle, In, Inputs, RunCx, StageError};
use crate::kinds::sample::patch::{self, HEIGHT, MASK};
use crate::kinds::{ColorSpace, FnStage, Planner};
use crate::lang::{Decl, Diagnostic};
use crate::raster::{self, Image};
use crate::synth::map as m;
use crate::synth::quilt::{self, Guide, QuiltOptions, QuiltParams, QuiltResult, SampleChoice, Terms};
use crate::synth::surface::Plane;
use crate::synth::Progress;

/// How far the three weights may sum from 1 (they are written with a few decimals).
const TERMS_SUM_TOLERANCE: f64 = 1e-6;

pub(super) fn plan(p: &mut Planner, d: &Decl) -> Result<Handle<Image>, Diagnostic> {
    let props = &d.props;
    let ((w, h), size_at) = super::quilt_size(p, d);
    p.check_pixels(d, size_at, (w, h), QUILT_BYTES_PER_PIXEL)?;
    let (block, overlap) = super::block_and_overlap(d)?;
    let Some(guide_name) = props.reference("guide") else {
        return Err(Diagnostic::error(format!("relief layer `{}` has no `guide`", d.name))
            .with_code("tessera::missing_property")
            .with_label(props.span("relief").unwrap_or(d.name_span), "depth is read from a guide image")
            .with_help("name the texture the relief is for: `guide = photo`"));
    };
    let terms = props.numbers("terms");
    let sum: f64 = terms.iter().sum();
    if terms.len() != 3 || (sum - 1.0).abs() > TERMS_SUM_TOLERANCE {
        return Err(Diagnostic::error(format!(
            "`terms` are the three weights [α1, α2, α3] of overlap, guide and depth error, summing to 1; these {} sum to {sum}",
            terms.len()
        ))
        .with_code("tessera::relief")
        .with_label(props.span("terms").unwrap_or(d.name_span), "here")
        .with_help("e.g. `terms = [0.3, 0.5, 0.2]`"));
    }
    for key in ["quilt", "blend", "mix", "density", "orientation", "coherence", "light", "seams"] {
        if let Some(span) = props.span(key) {
            return Err(Diagnostic::error(format!("`{key}` is not a property of relief layers"))
                .with_code("tessera::relief")
                .with_label(span, "remove this")
                .with_help("a relief layer takes `relief`, `guide`, `on`, `block`, `overlap`, `tolerance`, `terms`, `depth_blur`"));
        }
    }
    let mut inputs = Inputs::new();
    let span = props.span("relief").unwrap_or(d.name_span);
    let mut patches = Vec::new();
    for name in props.refs("relief") {
        let node = patch::patch_of(p, name, span)?;
        patches.push((inputs.add(node), p.color_space(name)));
    }
    let guide = (
        inputs.add(p.value::<Image>(guide_name, props.span("guide").unwrap_or(d.name_span))?),
        p.color_space(guide_name),
    );
    let surface: Option<In<Plane>> = wire(p, d, &mut inputs, "on")?;
    let mut params = QuiltParams::new(w, h, block, p.seed(d, "layer.relief"));
    params.overlap = overlap;
    params.tolerance = props.opt_num("tolerance").unwrap_or(0.0) as f32;
    params.metric = super::spec::METRICS.get(props.enumeration("metric"));
    params.equalise = super::spec::EQUALISE.get(props.enumeration("equalise"));
    params.candidate_stride = props.int("stride") as usize;
    params.tileable = props.bool("tileable");
    let relief = Relief {
        params,
        terms: [terms[0] as f32, terms[1] as f32, terms[2] as f32],
        patches,
        guide,
        surface,
        space: p.color_space(&props.refs("relief")[0]),
    };
    let stage = FnStage::keyed("layer.relief", 1, relief, run_relief);
    let quilt_node = p.add(format!("layer {} (relief)", d.name), stage, inputs, vec![]);
    p.set_part(d, "quilt", quilt_node);

    let mut inputs = Inputs::new();
    let quilted = inputs.add(quilt_node);
    let blur = props.num("depth_blur");
    let stage = FnStage::keyed("layer.depth", 1, (quilted, blur), depth);
    let depth = p.add(format!("layer {} (depth)", d.name), stage, inputs, vec![]);
    p.set_part(d, "depth", depth);

    let mut inputs = Inputs::new();
    let quilted = inputs.add(quilt_node);
    let space = p.color_space(&props.refs("relief")[0]);
    let stage = FnStage::keyed("layer.image", 2, (quilted, space), colour);
    Ok(p.add(format!("layer {}", d.name), stage, inputs, vec![]))
}

/// What the relief stage works from.
#[derive(serde::Serialize)]
struct Relief {
    params: QuiltParams,
    terms: [f32; 3],
    patches: Vec<(In<Image>, ColorSpace)>,
    guide: (In<Image>, ColorSpace),
    surface: Option<In<Plane>>,
    /// The colour space of the layer's image (the first patch's).
    space: ColorSpace,
}

/// Linear RGB from an image of 1 to 4 channels in `space`.
fn linear_rgb(img: &Image, space: ColorSpace) -> Result<Image, String> {
    let rgb = match img.channels {
        1 | 2 => Image::from_fn(img.width, img.height, 3, |x, y, _| img.get(x, y, 0)),
        _ => Image::from_fn(img.width, img.height, 3, |x, y, c| img.get(x, y, c)),
    };
    Ok(match space {
        ColorSpace::Linear => rgb,
        ColorSpace::Srgb => raster::color::image_srgb_to_linear(&rgb),
        ColorSpace::Lab => raster::color::image_lab_to_linear_rgb(&rgb).map_err(|e| e.to_string())?,
    })
}

fn run_relief(cx: &RunCx, r: &Relief) -> Result<QuiltResult, StageError> {
    let (w, h) = (r.params.width, r.params.height);
    let guide = cx.get(r.guide.0);
    exact_size(&guide, w, h, "guide")?;
    let guide = linear_rgb(&guide, r.guide.1).map_err(|e| StageError::new(e).at_prop("guide"))?;
    let mut images = Vec::with_capacity(r.patches.len());
    let mut masks = Vec::with_capacity(r.patches.len());
    for &(node, space) in &r.patches {
        let pt = cx.get(node);
        let colour = Image::from_fn(pt.width, pt.height, 3, |x, y, c| pt.get(x, y, c));
        let colour = linear_rgb(&colour, space).map_err(|e| StageError::new(e).at_prop("relief"))?;
        images.push(Image::from_fn(pt.width, pt.height, 4, |x, y, c| {
            if c < 3 {
                colour.get(x, y, c)
            } else {
                pt.get(x, y, HEIGHT)
            }
        }));
        let mask = pt.plane(MASK);
        masks.push(mask.iter().any(|&v| v > 0.5).then(|| Image {
            width: pt.width,
            height: pt.height,
            channels: 1,
            data: mask.to_vec(),
        }));
    }
    let plane = r.surface.map(|i| cx.get(i));
    if let Some(pl) = &plane {
        exact_size(&pl.occupancy, w, h, "on")?;
    }
    let occupancy = plane.as_ref().filter(|pl| pl.occupancy.data.iter().any(|&v| v <= 0.5)).map(|pl| &pl.occupancy);
    let report = |done, total| cx.progress(done, total);
    let [a1, a2, a3] = r.terms;
    let options = QuiltOptions {
        occupancy,
        guide: Some(Guide { image: &guide, weights: None, channels: Some(&[0, 1, 2]) }),
        terms: Terms::with_depth(a1, a2, a3),
        depth_channels: vec![3],
        choice: SampleChoice::NearestMean { lab: true },
        ignore: masks.iter().map(Option::as_ref).collect(),
        progress: Progress::new(&report),
        ..QuiltOptions::default()
    };
    let refs: Vec<&Image> = images.iter().collect();
    quilt::quilt_with(&refs, &r.params, &options).map_err(|e| match e {
        quilt::QuiltError::BlockTooLarge { .. } | quilt::QuiltError::NoCandidates { .. } => {
            quilt_error(e).at_prop("block").with_help("every patch must hold at least one block")
        }
        quilt::QuiltError::SizeMismatch { what, .. } | quilt::QuiltError::ChannelMismatch { what, .. } => {
            StageError::new(e.to_string()).at_prop(prop_of(what))
        }
        _ => quilt_error(e),
    })
}

/// The depth image: channel 3 of the quilted patches, blurred by `σ` pixels (0 = off).
fn depth(cx: &RunCx, &(quilted, sigma): &(In<QuiltResult>, f64)) -> Result<Image, StageError> {
    let r = cx.get(quilted);
    let img = &r.image;
    let d = Image { width: img.width, height: img.height, channels: 1, data: img.plane(HEIGHT).to_vec() };
    if sigma <= 0.0 {
        return Ok(d);
    }
    m::blur(&d, sigma as f32).map_err(|e| StageError::new(e.to_string()).at_prop("depth_blur"))
}

/// The colour image, back in the first patch's colour space.
fn colour(cx: &RunCx, &(quilted, space): &(In<QuiltResult>, ColorSpace)) -> Result<Image, StageError> {
    let r = cx.get(quilted);
    let img = &r.image;
    let rgb = Image::from_fn(img.width, img.height, 3, |x, y, c| img.get(x, y, c));
    Ok(match space {
        ColorSpace::Linear => rgb,
        ColorSpace::Srgb => raster::color::image_linear_to_srgb(&rgb),
        ColorSpace::Lab => raster::color::image_linear_rgb_to_lab(&rgb).map_err(|e| StageError::new(e.to_string()))?,
    })
}
