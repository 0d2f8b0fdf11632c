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
//!
//! With an `appearance` as guide the depth is quilted per texture of the appearance and drawn
//! through its UVs instead (see [`plan_instanced`]); the colour is then the appearance's.

use super::{exact_size, prop_of, quilt_error, wire, QUILT_BYTES_PER_PIXEL};
use crate::graph::{Handle, In, Inputs, RunCx, StageError};
use crate::kinds::artifact::{self, Encoded};
use crate::kinds::sample::patch::{self, HEIGHT, MASK};
use crate::kinds::{ColorSpace, FnStage, Planner};
use crate::lang::{Decl, Diagnostic};
use crate::raster::{self, Image};
use crate::synth::appearance::analysis::{Contours, Interiors};
use crate::synth::appearance::Dressing;
use crate::synth::map as m;
use crate::synth::quilt::{self, Guide, QuiltOptions, QuiltParams, QuiltResult, SampleChoice, Terms};
use crate::synth::relief::instanced::{self, DepthTextures};
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
    if p.has_part(guide_name, "dressing") {
        return plan_instanced(p, d, guide_name, block, overlap, [terms[0] as f32, terms[1] as f32, terms[2] as f32]);
    }
    if let Some(span) = props.span("contour_relief") {
        return Err(Diagnostic::error(
            "`contour_relief` serves the contour atlases of an appearance; this guide is an image",
        )
        .with_code("tessera::relief")
        .with_label(span, "remove this")
        .with_label(props.span("guide").unwrap_or(d.name_span), "not an appearance"));
    }
    let mut inputs = Inputs::new();
    let patches = wire_patches(p, d, &mut inputs, "relief")?;
    let guide = (
        inputs.add(p.value::<Image>(guide_name, props.span("guide").unwrap_or(d.name_span))?),
        p.color_space(guide_name),
    );
    let surface: Option<In<Plane>> = wire(p, d, &mut inputs, "on")?;
    let mut params = search_params(p, d, (w, h), block, overlap);
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

/// The patches a list property names, as inputs with their colour spaces.
fn wire_patches(
    p: &Planner,
    d: &Decl,
    inputs: &mut Inputs,
    key: &str,
) -> Result<Vec<(In<Image>, ColorSpace)>, Diagnostic> {
    let span = d.props.span(key).unwrap_or(d.name_span);
    let mut patches = Vec::new();
    for name in d.props.refs(key) {
        let node = patch::patch_of(p, name, span)?;
        patches.push((inputs.add(node), p.color_space(name)));
    }
    Ok(patches)
}

/// The quilt's size, block, overlap, seed and search settings as the layer states them.
fn search_params(p: &Planner, d: &Decl, (w, h): (usize, usize), block: usize, overlap: usize) -> QuiltParams {
    let props = &d.props;
    let mut params = QuiltParams::new(w, h, block, p.seed(d, "layer.relief"));
    params.overlap = overlap;
    params.tolerance = props.opt_num("tolerance").unwrap_or(0.0) as f32;
    params.metric = super::spec::METRICS.get(props.enumeration("metric"));
    params.equalise = super::spec::EQUALISE.get(props.enumeration("equalise"));
    params.candidate_stride = props.int("stride") as usize;
    params
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
    let (images, masks) = load_patches(cx, &r.patches)?;
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
    quilt::quilt_with(&refs, &r.params, &options).map_err(relief_error)
}

/// The patches as linear RGB + depth (channel 3), with their masks where any pixel is masked.
type Patches = (Vec<Image>, Vec<Option<Image>>);

fn load_patches(cx: &RunCx, patches: &[(In<Image>, ColorSpace)]) -> Result<Patches, StageError> {
    let mut images = Vec::with_capacity(patches.len());
    let mut masks = Vec::with_capacity(patches.len());
    for &(node, space) in patches {
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
    Ok((images, masks))
}

/// The errors of a relief quilt, at the property to fix.
fn relief_error(e: quilt::QuiltError) -> StageError {
    match e {
        quilt::QuiltError::BlockTooLarge { .. } | quilt::QuiltError::NoCandidates { .. } => {
            quilt_error(e).at_prop("block").with_help("every patch must hold at least one block")
        }
        quilt::QuiltError::SizeMismatch { what, .. } | quilt::QuiltError::ChannelMismatch { what, .. } => {
            StageError::new(e.to_string()).at_prop(prop_of(what))
        }
        _ => quilt_error(e),
    }
}

/// The depth image: channel 3 of the quilted patches, blurred by `σ` pixels (0 = off).
fn depth(cx: &RunCx, &(quilted, sigma): &(In<QuiltResult>, f64)) -> Result<Image, StageError> {
    let r = cx.get(quilted);
    let img = &r.image;
    let d = Image { width: img.width, height: img.height, channels: 1, data: img.plane(HEIGHT).to_vec() };
    blur_depth(d, sigma)
}

/// `d` blurred by `σ` pixels (0 = off).
fn blur_depth(d: Image, sigma: f64) -> Result<Image, StageError> {
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

/// A relief layer guided by an appearance [references: frasson §5.4]: one depth quilted per
/// unified texture and per contour atlas (keyed on the textures and patches only, never on the
/// structure the appearance dresses), drawn through the dressing's own UVs.
///
/// ```text
/// appearance.interiors + .contours, patches ─► layer.relief_textures ─┐
/// appearance.dress ───────────────────────────────────────────────────┴► layer.instanced_depth ─► layer.depth_blur
/// appearance.render ─► layer.image (the appearance's colour)
/// ```
fn plan_instanced(
    p: &mut Planner,
    d: &Decl,
    guide: &str,
    block: usize,
    overlap: usize,
    terms: [f32; 3],
) -> Result<Handle<Image>, Diagnostic> {
    let props = &d.props;
    for key in ["on", "tileable"] {
        if let Some(span) = props.span(key) {
            return Err(Diagnostic::error(format!(
                "`{key}` does not apply to a relief guided by an appearance: its depth is drawn where the appearance draws its colour"
            ))
            .with_code("tessera::relief")
            .with_label(span, "remove this")
            .with_label(props.span("guide").unwrap_or(d.name_span), "an appearance"));
        }
    }
    let interiors: Handle<Interiors> = p.part(guide, "interiors").expect("appearances plan their interiors");
    let contours: Handle<Contours> = p.part(guide, "contours").expect("appearances plan their contours");
    let dressing: Handle<Dressing> = p.part(guide, "dressing").expect("checked by the caller");
    let guide_at = props.span("guide").unwrap_or(d.name_span);
    let render = p.value::<Image>(guide, guide_at)?;
    let scale = p.decl(guide).props.num("resolution");

    let mut inputs = Inputs::new();
    let patches = wire_patches(p, d, &mut inputs, "relief")?;
    let contour_patches = match props.get("contour_relief") {
        Some(_) => Some(wire_patches(p, d, &mut inputs, "contour_relief")?),
        None => None,
    };
    // Each texture's quilt takes its own size.
    let params = search_params(p, d, (1, 1), block, overlap);
    let work = TextureRelief {
        params,
        terms,
        patches,
        contour_patches,
        interiors: inputs.add(interiors),
        contours: inputs.add(contours),
        space: p.color_space(guide),
    };
    let stage = FnStage::keyed("layer.relief_textures", 1, work, run_texture_relief);
    let textures = p.add(format!("layer {} (relief textures)", d.name), stage, inputs, vec![]);

    let mut inputs = Inputs::new();
    let work = (inputs.add(dressing), inputs.add(textures), inputs.add(render), scale);
    let stage = FnStage::keyed("layer.instanced_depth", 1, work, instanced_depth);
    let raw = p.add(format!("layer {} (instanced depth)", d.name), stage, inputs, vec![]);

    let mut inputs = Inputs::new();
    let work = (inputs.add(raw), props.num("depth_blur"));
    let stage = FnStage::keyed("layer.depth_blur", 1, work, blurred);
    let depth = p.add(format!("layer {} (depth)", d.name), stage, inputs, vec![]);
    p.set_part(d, "depth", depth);

    let mut inputs = Inputs::new();
    let colour = inputs.add(render);
    let stage = FnStage::keyed("layer.appearance_colour", 1, colour, |cx, &c| {
        let img = cx.get(c);
        Ok(Image::from_fn(img.width, img.height, 3, |x, y, k| img.get(x, y, k.min(img.channels - 1))))
    });
    Ok(p.add(format!("layer {}", d.name), stage, inputs, vec![]))
}

/// What the per-texture depth quilt works from.
#[derive(serde::Serialize)]
struct TextureRelief {
    params: QuiltParams,
    terms: [f32; 3],
    patches: Vec<(In<Image>, ColorSpace)>,
    /// The atlases' own patches (`contour_relief`), when given.
    contour_patches: Option<Vec<(In<Image>, ColorSpace)>>,
    interiors: In<Interiors>,
    contours: In<Contours>,
    /// The colour space of the appearance's textures.
    space: ColorSpace,
}

impl Encoded for DepthTextures {
    fn encode(&self) -> Vec<u8> {
        let mut images: Vec<&Image> = self.unified.iter().collect();
        images.extend([&self.interstices, &self.junctions]);
        artifact::pack(&self.unified.len(), &images)
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let (n, mut images) = artifact::unpack::<usize>(bytes)?;
        if images.len() != n + 2 {
            return Err(format!("{} depth textures, expected {}", images.len(), n + 2));
        }
        let junctions = images.pop().expect("counted");
        let interstices = images.pop().expect("counted");
        Ok(DepthTextures { unified: images, interstices, junctions })
    }
}

fn run_texture_relief(cx: &RunCx, r: &TextureRelief) -> Result<DepthTextures, StageError> {
    let interiors = cx.get(r.interiors);
    let contours = cx.get(r.contours);
    let atlases = [&contours.interstices.image, &contours.junctions.image];
    let pixels: usize = interiors.unified.iter().map(|u| &u.image).chain(atlases).map(|g| g.width * g.height).sum();
    cx.budget()
        .check(pixels as f64 * QUILT_BYTES_PER_PIXEL, "the relief's depth textures")
        .map_err(|e| StageError::new(e).at_prop("guide"))?;
    let interior_patches = load_patches(cx, &r.patches)?;
    let contour_patches = match &r.contour_patches {
        Some(p) => Some(load_patches(cx, p)?),
        None => None,
    };
    let [a1, a2, a3] = r.terms;
    let total = (interiors.unified.len() + 2) as u64;
    let mut depths = Vec::with_capacity(interiors.unified.len() + 2);
    let textures = interiors.unified.iter().map(|u| &u.image).chain(atlases);
    for (i, texture) in textures.enumerate() {
        let atlas = i >= interiors.unified.len();
        let ((images, masks), at) = match (&contour_patches, atlas) {
            (Some(c), true) => (c, Some("contour_relief")),
            _ => (&interior_patches, None),
        };
        // An atlas guides by its RGB, the photo's colour under alpha 0 included (the band
        // beside each contour places the joint).
        let guide = linear_rgb(texture, r.space).map_err(|e| StageError::new(e).at_prop("guide"))?;
        let alpha = atlas.then(|| texture.plane(3.min(texture.channels - 1)));
        let options = QuiltOptions {
            terms: Terms::with_depth(a1, a2, a3),
            depth_channels: vec![HEIGHT],
            choice: SampleChoice::NearestMean { lab: true },
            ignore: masks.iter().map(Option::as_ref).collect(),
            ..QuiltOptions::default()
        };
        let params = QuiltParams { seed: instanced::texture_seed(r.params.seed, i), ..r.params.clone() };
        let refs: Vec<&Image> = images.iter().collect();
        let depth = instanced::quilt_depth(&guide, alpha, &refs, HEIGHT, &params, &options)
            .map_err(|e| at.into_iter().fold(relief_error(e), StageError::at_prop))?;
        depths.push(depth);
        cx.progress(i as u64 + 1, total);
    }
    let junctions = depths.pop().expect("one per texture");
    let interstices = depths.pop().expect("one per texture");
    Ok(DepthTextures { unified: depths, interstices, junctions })
}

fn instanced_depth(
    cx: &RunCx,
    &(dressing, textures, render, scale): &(In<Dressing>, In<DepthTextures>, In<Image>, f64),
) -> Result<Image, StageError> {
    let render = cx.get(render);
    Ok(instanced::render_depth(&cx.get(dressing), &cx.get(textures), render.width, render.height, scale))
}

/// A depth image blurred by `σ` pixels (0 = off).
fn blurred(cx: &RunCx, &(depth, sigma): &(In<Image>, f64)) -> Result<Image, StageError> {
    blur_depth((*cx.get(depth)).clone(), sigma)
}
