//! `layer`: image quilting of a sample onto a surface, gradient-domain blending of layers
//! under a mask, and evaluation of a procedural texture.
//!
//! ```text
//! sample, [mix], [surface], [orientation], [density], [guide] ─► layer.quilt ─► layer.image
//!                                                                     └─► layer.seams (seams = gradient)
//! sources…, mask ─► layer.blend
//! procedural, [morph, morph_by] ─► layer.procedural (evaluation: `procedural.rs`)
//! sample ─► layer.tiling_prepare ─► layer.tiling (histogram-preserving blending: `tiling.rs`)
//! ```
//!
//! The quilt stage keeps its whole result (index map, seams, block records), so a change
//! to what follows it (seam removal, an output view) never re-runs the search; a blend's
//! mask threshold is a blend parameter, so editing it re-runs only the blend onward.

use super::output::{encode_image, View, VIEWS};
use super::{Bytes, Encoded, FnStage, OutputFormat, Planner};
use crate::graph::{AnyHandle, Handle, In, Inputs, RunCx, StageError};
use crate::lang::source::Span;
use crate::lang::{Decl, Diagnostic};
use crate::raster::{self, Image};
use crate::synth::blend::{self, BlendError, BlendParams, Selector};
use crate::synth::map as m;
use crate::synth::quilt::{
    self, Coherence, Guide, Orientation, QuiltError, QuiltOptions, QuiltParams, QuiltResult, SampleChoice, Terms,
};
use crate::synth::surface::Plane;
use crate::synth::Progress;

pub(super) mod procedural;
mod relief;
mod spec;
mod tiling;
pub use spec::SPEC;

/// The inputs of a quilt stage: the sample, and those the declaration names.
#[derive(Clone, Copy, serde::Serialize)]
struct Wiring {
    sample: In<Image>,
    mix: Option<In<Image>>,
    surface: Option<In<Plane>>,
    orientation: Option<In<Image>>,
    density: Option<In<Image>>,
    guide: Option<In<Image>>,
    guide_weight: Option<In<Image>>,
}

pub fn plan(p: &mut Planner, d: &Decl) -> Result<Handle<Image>, Diagnostic> {
    let props = &d.props;
    if props.get("relief").is_some() {
        return relief::plan(p, d);
    }
    for key in ["terms", "depth_blur", "contour_relief"] {
        if let Some(span) = props.span(key) {
            return Err(Diagnostic::error(format!("`{key}` applies only to relief layers"))
                .with_code("tessera::layer")
                .with_label(span, "remove this")
                .with_help(
                    "`terms` and `depth_blur` weigh and smooth the depth of a layer made with `relief = [PATCH, …]`",
                ));
        }
    }
    if let Some(texture) = props.reference("procedural") {
        if let Some((key, span)) = ["quilt", "blend"].iter().find_map(|k| Some((*k, props.span(k)?))) {
            return Err(Diagnostic::error(format!(
                "layer `{}` is evaluated from a procedural texture: `{key}` does not apply",
                d.name
            ))
            .with_code("tessera::layer")
            .with_label(span, "remove this"));
        }
        return procedural::plan(p, d, texture);
    }
    if let Some(sample) = props.reference("tiling") {
        if let Some((key, span)) = ["quilt", "blend"].iter().find_map(|k| Some((*k, props.span(k)?))) {
            return Err(Diagnostic::error(format!("layer `{}` tiles a sample: `{key}` does not apply", d.name))
                .with_code("tessera::layer")
                .with_label(span, "remove this"));
        }
        if let Some(span) =
            ["band_gain", "solid", "slice", "correct_slice", "morph", "morph_by"].iter().find_map(|k| props.span(k))
        {
            return Err(Diagnostic::error("this property applies only to layers evaluated from a procedural texture")
                .with_code("tessera::layer")
                .with_label(span, "remove this"));
        }
        return tiling::plan(p, d, sample);
    }
    if let Some(span) = tiling::PROPS.iter().find_map(|k| props.span(k)) {
        return Err(Diagnostic::error("this property applies only to layers made with `tiling = SAMPLE`")
            .with_code("tessera::layer")
            .with_label(span, "remove this"));
    }
    if let Some(span) = procedural::PROPS.iter().find_map(|k| props.span(k)) {
        return Err(Diagnostic::error("this property applies only to layers evaluated from a procedural texture")
            .with_code("tessera::layer")
            .with_label(span, "remove this")
            .with_help("`zoom`, `origin`, `band_gain`, `solid`, `slice`, `correct_slice`, `morph` and `morph_by` shape a layer made with `procedural = TEXTURE`"));
    }
    match (props.reference("quilt"), props.get("blend")) {
        (Some(sample), None) => plan_quilt(p, d, sample),
        (None, Some(_)) => plan_blend(p, d),
        (Some(_), Some(_)) => Err(Diagnostic::error(format!("layer `{}` both quilts and blends", d.name))
            .with_code("tessera::layer")
            .with_label(props.span("blend").unwrap_or(d.name_span), "remove `blend` or `quilt`")
            .with_help("a layer is either grown from a sample (`quilt`) or blended from layers (`blend`)")),
        (None, None) => {
            Err(Diagnostic::error(format!("layer `{}` says neither what to quilt nor what to blend", d.name))
                .with_code("tessera::missing_property")
                .with_label(
                    d.name_span,
                    "give it `quilt = SAMPLE`, `blend = [A, B]`, `relief = [PATCH, …]` or `procedural = TEXTURE`",
                ))
        }
    }
}

/// Working memory of a quilted layer per pixel: the RGB result, index map, seam mask and
/// error surfaces, and the seam-removal solve (measured: a 1024² quilt peaks at ≈ 120 bytes
/// per pixel, sample included).
const QUILT_BYTES_PER_PIXEL: f64 = 128.0;

/// The size of a quilted layer and where it was set: its surface's plane, or the scene size.
pub(super) fn quilt_size(p: &Planner, d: &Decl) -> ((usize, usize), Option<Span>) {
    match d.props.reference("on") {
        Some(s) => p.plane(s),
        None => ((p.scene.size.0 as usize, p.scene.size.1 as usize), None),
    }
}

/// The layer kind: quilting and blending.
pub struct Layer;

impl super::Kind for Layer {
    fn spec(&self) -> &'static crate::lang::KindSpec {
        &SPEC
    }

    fn plan(&self, p: &mut Planner, d: &Decl) -> Result<Option<AnyHandle>, Diagnostic> {
        let node = plan(p, d)?.erase();
        // A layer's values are in the colour space of the image it grows from (blends:
        // their first source's).
        if let Some(texture) = d.props.reference("procedural") {
            p.export(d).image = Some(super::procedural::color_space(p, texture));
            return Ok(Some(node));
        }
        let source = match d.props.reference("quilt").or(d.props.reference("tiling")) {
            Some(s) => s.to_string(),
            // Guided by an appearance, the colour is the appearance's.
            None if d.props.get("relief").is_some() => match d.props.reference("guide") {
                Some(g) if p.has_part(g, "dressing") => g.to_string(),
                _ => d.props.refs("relief")[0].clone(),
            },
            None => d.props.refs("blend")[0].clone(),
        };
        p.export(d).image = Some(p.color_space(&source));
        Ok(Some(node))
    }

    fn plan_output(&self, p: &mut Planner, out: &super::OutputRequest) -> Result<Option<super::ViewNode>, Diagnostic> {
        let view = out.view;
        if let Some(surface) = p.part::<super::representation::Relightable>(out.from, "relightable") {
            let own = matches!(view, View::Albedo | View::Normal | View::Height | View::Maps);
            let file = matches!(out.format, super::OutputFormat::Ptm(_));
            if own || file || (view == View::Auto && out.decl.props.span("light").is_some()) {
                return super::representation::plan_view(p, out, surface).map(Some);
            }
        }
        if let (View::Height, Some(depth)) = (view, p.part::<Image>(out.from, "depth")) {
            if out.format.is_text() {
                return Err(Diagnostic::error("a relief layer's height is an image")
                    .with_code("tessera::output_view")
                    .with_label(out.decl.name_span, "write it as .png or .exr"));
            }
            let mut inputs = Inputs::new();
            let depth = inputs.add(depth);
            let format = out.format;
            let stage = FnStage::keyed("output.image", 1, (depth, format), |cx, &(d, f)| encode_image(&cx.get(d), f));
            let node = p.add(format!("output {}", out.decl.name), stage, inputs, vec![]);
            return Ok(Some(super::ViewNode { node, exact: false, more: Vec::new() }));
        }
        if view == View::Auto {
            if let Some(span) = out.decl.props.span("light") {
                return Err(Diagnostic::error(
                    "`light` relights a layer quilted from a representation; this one is not",
                )
                .with_code("tessera::output_view")
                .with_label(span, "remove this"));
            }
            return Ok(None);
        }
        let d = out.decl;
        if !matches!(view, View::Seams | View::Index) || out.format.is_text() {
            return Err(Diagnostic::error(format!("a layer has no `{}` view as `.{}`", VIEWS.name(view), out.ext))
                .with_code("tessera::output_view")
                .with_label(d.props.span("view").unwrap_or(d.name_span), "here")
                .with_help("layers are images; their views are `seams` and `index`"));
        }
        let node = plan_output(p, d, out.from, out.format, view)?;
        // Source positions are identities: a pixel taken from elsewhere is a regression.
        Ok(Some(super::ViewNode { node, exact: view == View::Index, more: Vec::new() }))
    }
}

/// The block and overlap of a quilted or relief layer, the overlap checked against the block.
fn block_and_overlap(d: &Decl) -> Result<(usize, usize), Diagnostic> {
    let props = &d.props;
    let block = props.pixels("block");
    let overlap = props.opt_pixels("overlap").unwrap_or(quilt::default_overlap(block));
    if overlap >= block {
        return Err(Diagnostic::error(format!(
            "the overlap ({overlap} px) must be smaller than the block ({block} px)"
        ))
        .with_code("tessera::quilt")
        .with_label(props.span("overlap").unwrap_or(d.name_span), "too large")
        .with_help(format!(
            "blocks are placed every `block − overlap` pixels; try `overlap = {} px`",
            quilt::default_overlap(block)
        )));
    }
    Ok((block, overlap))
}

fn plan_quilt(p: &mut Planner, d: &Decl, sample: &str) -> Result<Handle<Image>, Diagnostic> {
    let props = &d.props;
    let ((w, h), size_at) = quilt_size(p, d);
    p.check_pixels(d, size_at, (w, h), QUILT_BYTES_PER_PIXEL)?;
    let (block, overlap) = block_and_overlap(d)?;
    if props.get("mix").is_some() != props.get("density").is_some() {
        let (have, missing) = if props.get("mix").is_some() { ("mix", "density") } else { ("density", "mix") };
        return Err(Diagnostic::error(format!("`{have}` needs `{missing}`"))
            .with_code("tessera::quilt")
            .with_label(props.span(have).unwrap_or(d.name_span), "here")
            .with_help("`mix = SAMPLE` names the second sample and `density = MAP` how much of it to take"));
    }
    let mut inputs = Inputs::new();
    let wiring = Wiring {
        sample: wire(p, d, &mut inputs, "quilt")?.expect("a quilted layer names its sample"),
        mix: wire(p, d, &mut inputs, "mix")?,
        surface: wire(p, d, &mut inputs, "on")?,
        orientation: wire(p, d, &mut inputs, "orientation")?,
        density: wire(p, d, &mut inputs, "density")?,
        guide: wire(p, d, &mut inputs, "guide")?,
        guide_weight: wire(p, d, &mut inputs, "guide_weight")?,
    };
    let mut params = QuiltParams::new(w, h, block, p.seed(d, "layer.quilt"));
    params.overlap = overlap;
    params.tolerance = props.opt_num("tolerance").unwrap_or(0.1) as f32;
    params.metric = spec::METRICS.get(props.enumeration("metric"));
    params.equalise = spec::EQUALISE.get(props.enumeration("equalise"));
    params.channel_weights = props.opt_numbers("weights").map(|w| w.iter().map(|&v| v as f32).collect());
    params.coherence = if props.bool("coherence") {
        Coherence::On { forced_search: props.num("forced_search") as f32 }
    } else {
        Coherence::Off
    };
    params.candidate_stride = props.int("stride") as usize;
    params.tileable = props.bool("tileable");
    let quilting = Quilting { params, copies: props.int("copies") as usize, alpha: props.num("alpha") as f32, wiring };
    let stage = FnStage::keyed("layer.quilt", 2, quilting, run_quilt);
    let quilt_node = p.add(format!("layer {} (quilt)", d.name), stage, inputs, vec![]);
    p.set_part(d, "quilt", quilt_node);

    let mut inputs = Inputs::new();
    let quilted = inputs.add(quilt_node);
    if spec::SEAMS.get(props.enumeration("seams")) == spec::SeamRemoval::Gradient {
        let mut samples = vec![inputs.add(p.result::<Image>(sample))];
        if let Some(s) = props.reference("mix") {
            samples.push(inputs.add(p.result::<Image>(s)));
        }
        let removal = SeamRemoval { quilted, samples, radius: props.pixels("seam_band"), solver: solver_of(d) };
        let stage = FnStage::keyed("layer.seams", 3, removal, remove_seams);
        let image = p.add(format!("layer {} (seams)", d.name), stage, inputs, vec![]);
        return relit(p, d, sample, quilt_node, image);
    }
    let stage = FnStage::keyed("layer.image", 2, quilted, |cx, &quilted| Ok(cx.get(quilted).image.clone()));
    // A relit layer's image is its relit maps; the quilted maps are a stage of their own.
    let label = if super::representation::is_representation(p, sample) { " (maps)" } else { "" };
    let image = p.add(format!("layer {}{label}", d.name), stage, inputs, vec![]);
    relit(p, d, sample, quilt_node, image)
}

/// A layer grown from a representation is its quilted maps relit (and a relightable surface
/// for outputs); any other layer is the quilted image.
fn relit(
    p: &mut Planner,
    d: &Decl,
    sample: &str,
    quilt: Handle<QuiltResult>,
    image: Handle<Image>,
) -> Result<Handle<Image>, Diagnostic> {
    if super::representation::is_representation(p, sample) {
        return super::representation::plan_relit_layer(p, d, sample, quilt, image);
    }
    if let Some(span) = d.props.span("light") {
        return Err(Diagnostic::error(format!("layer `{}` does not grow a representation: it has no light", d.name))
            .with_code("tessera::layer")
            .with_label(span, "remove this")
            .with_help("`light` relights a layer quilted from a `representation`"));
    }
    Ok(image)
}

/// The value of the reference property `name` of `d`, if it has one, as an input.
fn wire<T: std::any::Any>(p: &Planner, d: &Decl, inputs: &mut Inputs, name: &str) -> Result<Option<In<T>>, Diagnostic> {
    let Some(s) = d.props.reference(name) else { return Ok(None) };
    Ok(Some(inputs.add(p.value(s, d.props.span(name).unwrap_or(d.name_span))?)))
}

/// What gradient-domain seam removal works from: the quilting result and its samples.
#[derive(serde::Serialize)]
struct SeamRemoval {
    quilted: In<QuiltResult>,
    samples: Vec<In<Image>>,
    radius: usize,
    solver: blend::Solver,
}

fn remove_seams(cx: &RunCx, s: &SeamRemoval) -> Result<Image, StageError> {
    let result = cx.get(s.quilted);
    let samples: Vec<std::sync::Arc<Image>> = s.samples.iter().map(|&i| cx.get(i)).collect();
    let refs: Vec<&Image> = samples.iter().map(|s| &**s).collect();
    let params = quilt::SeamParams { radius: s.radius, solver: s.solver, ..quilt::SeamParams::default() };
    let out =
        quilt::remove_seams(&result, &refs, &params).map_err(|e| StageError::new(e.to_string()).at_prop("seams"))?;
    warn_unconverged(cx, &out.reports);
    Ok(out.image)
}

/// What the quilt stage works from.
#[derive(serde::Serialize)]
struct Quilting {
    params: QuiltParams,
    copies: usize,
    alpha: f32,
    wiring: Wiring,
}

fn run_quilt(cx: &RunCx, q: &Quilting) -> Result<QuiltResult, StageError> {
    let (params, wiring, copies, alpha) = (&q.params, q.wiring, q.copies, q.alpha);
    let (w, h) = (params.width, params.height);
    let sample = cx.get(wiring.sample);
    let mix = wiring.mix.map(|i| cx.get(i));
    let plane = wiring.surface.map(|i| cx.get(i));
    let map = |slot: Option<In<Image>>,
               prop: &'static str,
               channels: &[usize]|
     -> Result<Option<std::sync::Arc<Image>>, StageError> {
        let Some(i) = slot else { return Ok(None) };
        let img = cx.get(i);
        exact_size(&img, w, h, prop)?;
        if !channels.contains(&img.channels) {
            return Err(StageError::new(format!(
                "`{prop}` has {} channel(s); it must have {}",
                img.channels,
                channels.iter().map(|c| c.to_string()).collect::<Vec<_>>().join(" or ")
            ))
            .at_prop(prop));
        }
        Ok(Some(img))
    };
    let orientation = map(wiring.orientation, "orientation", &[1, 2])?;
    let density = map(wiring.density, "density", &[1])?;
    let guide = map(wiring.guide, "guide", &[1, 2, 3, 4])?;
    let guide_weight = map(wiring.guide_weight, "guide_weight", &[1])?;
    // A full plane constrains nothing; leave it out so the fast path stays open.
    let occupancy = plane.as_ref().filter(|pl| pl.occupancy.data.iter().any(|&v| v <= 0.5)).map(|pl| &pl.occupancy);
    let report = |done, total| cx.progress(done, total);
    let mut options = QuiltOptions { occupancy, progress: Progress::new(&report), ..QuiltOptions::default() };
    if let Some(g) = &guide {
        if g.channels > sample.channels {
            return Err(StageError::new(format!(
                "the guide has {} channels but the sample only {}",
                g.channels, sample.channels
            ))
            .at_prop("guide"));
        }
        options.guide = Some(Guide { image: g, weights: guide_weight.as_deref(), channels: None });
        options.terms = Terms::guided(alpha);
    }
    if let Some(o) = &orientation {
        options.orientation = Some(Orientation { field: o, copies });
    }
    let mut samples: Vec<&Image> = vec![&sample];
    if let (Some(b), Some(dm)) = (&mix, &density) {
        if b.channels != sample.channels {
            return Err(StageError::new(format!(
                "the mixed sample has {} channels, the quilted one {}",
                b.channels, sample.channels
            ))
            .at_prop("mix"));
        }
        samples.push(b);
        options.choice = SampleChoice::Density(dm);
    }
    quilt::quilt_with(&samples, params, &options).map_err(quilt_error)
}

/// Quilting errors, pointed at the property that can fix them.
fn quilt_error(e: QuiltError) -> StageError {
    let msg = e.to_string();
    match e {
        QuiltError::BlockTooLarge { block, width, height, .. } => StageError::new(msg).at_prop("block").with_help(
            format!("the sample is {width}x{height}; use `block` of at most {} px", width.min(height).min(block)),
        ),
        QuiltError::OverlapTooLarge { .. } | QuiltError::TileableZeroOverlap => StageError::new(msg).at_prop("overlap"),
        QuiltError::TileableTooSmall { .. } => StageError::new(msg).at_prop("tileable"),
        QuiltError::Empty { what: input }
        | QuiltError::SizeMismatch { what: input, .. }
        | QuiltError::ChannelMismatch { what: input, .. }
        | QuiltError::NonFinite { what: input, .. }
        | QuiltError::Invalid { name: input, .. } => StageError::new(msg).at_prop(prop_of(input)),
        _ => StageError::new(msg).at_prop("quilt"),
    }
}

/// The layer property that sets a quilting input.
fn prop_of(input: quilt::Input) -> &'static str {
    use quilt::Input as I;
    match input {
        I::Block => "block",
        I::Tolerance => "tolerance",
        I::ForcedSearch => "forced_search",
        I::CandidateStride => "stride",
        I::ChannelWeights | I::ChannelWeight => "weights",
        I::Guide | I::GuideChannelMap | I::GuideChannelIndex | I::GuideChannels | I::LabGuide => "guide",
        I::GuideWeights | I::GuideWeight => "guide_weight",
        I::OverlapWeight | I::DepthWeight | I::TermWeights => "alpha",
        I::Density => "density",
        I::Orientation => "orientation",
        I::OrientationCopies => "copies",
        I::Occupancy => "on",
        I::IgnoreMask => "relief",
        I::Output
        | I::Sample
        | I::Samples
        | I::SampleChannels
        | I::DepthChannel
        | I::AllowedPositions
        | I::Gathered
        | I::GatheredImages
        | I::QuiltResult
        | I::IndexMap
        | I::IndexMapEntry
        | I::SearchRate
        | I::Neighbourhood => "quilt",
    }
}

fn exact_size(img: &Image, w: usize, h: usize, prop: &'static str) -> Result<(), StageError> {
    if img.width != w || img.height != h {
        return Err(StageError::new(format!("`{prop}` is {}x{} but the layer is {w}x{h}", img.width, img.height))
            .at_prop(prop)
            .with_help(format!("give it the layer's size (for a map: `size = {w} x {h}`)")));
    }
    Ok(())
}

fn solver_of(d: &Decl) -> blend::Solver {
    let s = d.props.block("solver");
    blend::Solver {
        kind: spec::SOLVER_KINDS.get(s.enumeration("kind")),
        tol: s.num("tol"),
        max_iter: s.int("max_iter") as usize,
        ..blend::Solver::default()
    }
}

fn warn_unconverged(cx: &RunCx, reports: &[blend::SolveReport]) {
    for r in reports.iter().filter(|r| !r.converged) {
        cx.warn(format!(
            "channel {}: the solver stopped after {} iterations at relative residual {:.2e}",
            r.channel, r.iterations, r.residual
        ));
    }
}

fn plan_blend(p: &mut Planner, d: &Decl) -> Result<Handle<Image>, Diagnostic> {
    let props = &d.props;
    let sources = props.refs("blend").to_vec();
    let span = props.span("blend").unwrap_or(d.name_span);
    if sources.is_empty() {
        return Err(Diagnostic::error("`blend` names no layers")
            .with_code("tessera::layer")
            .with_label(span, "give at least one"));
    }
    if sources.iter().any(|s| s == &d.name) {
        return Err(Diagnostic::error("a layer cannot blend itself")
            .with_code("tessera::cycle")
            .with_label(span, "here"));
    }
    let mode = spec::MODES.get(props.enumeration("mode"));
    if sources.len() >= 2 && props.get("mask").is_none() {
        return Err(Diagnostic::error(format!("blending {} layers needs a `mask`", sources.len()))
            .with_code("tessera::missing_property")
            .with_label(d.name_span, "add `mask = MAP`"));
    }
    if sources.len() > 2 && props.get("threshold").is_some() {
        return Err(Diagnostic::error("`threshold` applies to two-source blends")
            .with_code("tessera::layer")
            .with_label(props.span("threshold").unwrap_or(d.name_span), "remove this")
            .with_help("with more sources the mask value v picks source round(v·(n − 1))"));
    }
    let at = props.span("blend").unwrap_or(d.name_span);
    let mut inputs = Inputs::new();
    let sources: Vec<In<Image>> =
        sources.iter().map(|s| Ok(inputs.add(p.value(s, at)?))).collect::<Result<_, Diagnostic>>()?;
    let mask = props.reference("mask").map(|mk| inputs.add(p.result::<Image>(mk)));
    let params = BlendParams {
        mode,
        topology: spec::TOPOLOGIES.get(props.enumeration("topology")),
        seam: spec::SEAM_GUIDANCE.get(props.enumeration("seam")),
        domain: match spec::DOMAINS.get(props.enumeration("domain")) {
            spec::DomainChoice::Mask => blend::Domain::Mask,
            spec::DomainChoice::Band => blend::Domain::Band { radius: props.pixels("band").max(1) },
            spec::DomainChoice::Whole => blend::Domain::Whole,
        },
        solver: solver_of(d),
        ..BlendParams::default()
    };
    let blending = Blending { sources, mask, params, threshold: props.opt_num("threshold").map(|t| t as f32) };
    let stage = FnStage::keyed("layer.blend", 3, blending, run_blend);
    Ok(p.add(format!("layer {} (blend)", d.name), stage, inputs, vec![]))
}

/// What a blend works from: its sources (in order), the mask, and the blend's parameters.
#[derive(serde::Serialize)]
struct Blending {
    sources: Vec<In<Image>>,
    mask: Option<In<Image>>,
    params: BlendParams,
    threshold: Option<f32>,
}

fn run_blend(cx: &RunCx, b: &Blending) -> Result<Image, StageError> {
    let (params, threshold, n) = (&b.params, b.threshold, b.sources.len());
    let images: Vec<std::sync::Arc<Image>> = b.sources.iter().map(|&i| cx.get(i)).collect();
    let refs: Vec<&Image> = images.iter().map(|s| &**s).collect();
    let Some(mask) = b.mask.filter(|_| n > 1) else {
        return Ok(refs[0].clone());
    };
    let mask = cx.get(mask);
    let (w, h) = (refs[0].width, refs[0].height);
    for (i, s) in refs.iter().enumerate().skip(1) {
        if s.width != w || s.height != h {
            return Err(StageError::new(format!(
                "source {} is {}x{} but the first is {w}x{h}; blended layers must have one size",
                i + 1,
                s.width,
                s.height
            ))
            .at_prop("blend"));
        }
    }
    exact_size(&mask, w, h, "mask")?;
    if mask.channels == 2 {
        return Err(StageError::new("the mask must be scalar, not an orientation field").at_prop("mask"));
    }
    let report = |done, total| cx.progress(done, total);
    let run = blend::Run { progress: Progress::new(&report), ..blend::Run::default() };
    let result = if n == 2 {
        match threshold {
            Some(t) => {
                let binary = m::threshold(&mask, t);
                blend::blend_with(&refs, Selector::Binary(&binary), params, &run)
            }
            None => blend::blend_with(&refs, Selector::Soft(&mask), params, &run),
        }
    } else {
        let top = (n - 1) as f32;
        let labels: Vec<u32> =
            mask.plane(0).iter().map(|&v| (v.clamp(0.0, 1.0) * top).round() as u32).collect::<Vec<_>>();
        blend::blend_with(&refs, Selector::Labels(&labels), params, &run)
    }
    .map_err(blend_error)?;
    warn_unconverged(cx, &result.reports);
    Ok(result.image)
}

fn blend_error(e: BlendError) -> StageError {
    let msg = e.to_string();
    match e {
        BlendError::SizeMismatch { .. } | BlendError::SourceCount { .. } => StageError::new(msg).at_prop("blend"),
        BlendError::BadParameter { name, .. } => StageError::new(msg).at_prop(match name {
            blend::Param::Tol | blend::Param::MaxTol | blend::Param::MaxIter | blend::Param::Smooth => "solver",
            blend::Param::RimSource => "topology",
            blend::Param::Labels => "mask",
        }),
        _ => StageError::new(msg).at_prop("blend"),
    }
}

/// An output of a layer other than its image (`view = seams | index`).
pub fn plan_output(
    p: &mut Planner,
    d: &Decl,
    from: &str,
    format: OutputFormat,
    view: View,
) -> Result<Handle<Bytes>, Diagnostic> {
    let Some(quilt_node) = p.part(from, "quilt") else {
        return Err(Diagnostic::error(format!(
            "view `{}` shows how a layer was quilted; `{from}` is a blend",
            VIEWS.name(view)
        ))
        .with_code("tessera::output_view")
        .with_label(d.props.span("view").unwrap_or(d.name_span), "here"));
    };
    let mut inputs = Inputs::new();
    let drawing = QuiltView { quilted: inputs.add(quilt_node), view, format };
    let stage = FnStage::keyed("output.layer", 2, drawing, quilt_view);
    Ok(p.add(format!("output {}", d.name), stage, inputs, vec![]))
}

/// What a layer's `seams` or `index` view is drawn from.
#[derive(serde::Serialize)]
struct QuiltView {
    quilted: In<QuiltResult>,
    view: View,
    format: OutputFormat,
}

fn quilt_view(cx: &RunCx, v: &QuiltView) -> Result<Bytes, StageError> {
    let r = cx.get(v.quilted);
    let img = match v.view {
        View::Seams => r.seams.clone(),
        // Where each pixel came from: x → red, y → green, source → blue.
        _ => {
            let sources = r.sources.len().max(1) as f32;
            Image::from_fn(r.index.width, r.index.height, 3, |x, y, c| match r.index.get(x, y) {
                None => 0.0,
                Some((s, sx, sy)) => {
                    let info = &r.sources[s];
                    match c {
                        0 => (sx as f32 + 0.5) / info.width as f32,
                        1 => (sy as f32 + 0.5) / info.height as f32,
                        _ => (s as f32 + 1.0) / sources,
                    }
                }
            })
        }
    };
    encode_image(&img, v.format)
}

impl Encoded for QuiltResult {
    fn encode(&self) -> Vec<u8> {
        let meta = serde_json::to_vec(&(
            &self.sources,
            &self.blocks,
            self.searches,
            self.tileable,
            &self.index.width,
            &self.index.height,
        ))
        .expect("quilt metadata serialises");
        let mut out = Vec::new();
        let mut chunk = |bytes: &[u8]| {
            out.extend_from_slice(&(bytes.len() as u64).to_le_bytes());
            out.extend_from_slice(bytes);
        };
        chunk(&meta);
        chunk(&raster::codec::to_bytes(&self.image));
        chunk(&raster::codec::to_bytes(&self.seams));
        for plane in [&self.index.source, &self.index.x, &self.index.y, &self.index.block] {
            chunk(&plane.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>());
        }
        out
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let mut rest = bytes;
        let mut chunk = || -> Result<&[u8], String> {
            let len = rest.get(..8).ok_or("truncated quilt result")?;
            let len = u64::from_le_bytes(len.try_into().expect("8 bytes")) as usize;
            let body = rest.get(8..8 + len).ok_or("truncated quilt result")?;
            rest = &rest[8 + len..];
            Ok(body)
        };
        type Meta = (Vec<quilt::SourceInfo>, Vec<quilt::BlockRecord>, usize, bool, usize, usize);
        let (sources, blocks, searches, tileable, width, height): Meta =
            serde_json::from_slice(chunk()?).map_err(|e| e.to_string())?;
        let image = raster::codec::from_bytes(chunk()?).map_err(|e| e.to_string())?;
        let seams = raster::codec::from_bytes(chunk()?).map_err(|e| e.to_string())?;
        let mut planes = Vec::with_capacity(4);
        for _ in 0..4 {
            let b = chunk()?;
            if b.len() != width * height * 4 {
                return Err("quilt index of the wrong size".into());
            }
            planes.push(
                b.chunks_exact(4).map(|c| u32::from_le_bytes(c.try_into().expect("4 bytes"))).collect::<Vec<u32>>(),
            );
        }
        let block = planes.pop().expect("4 planes");
        let y = planes.pop().expect("4 planes");
        let x = planes.pop().expect("4 planes");
        let source = planes.pop().expect("4 planes");
        Ok(QuiltResult {
            image,
            index: quilt::IndexMap { width, height, source, x, y, block },
            seams,
            sources,
            blocks,
            searches,
            tileable,
        })
    }
}
