//! `layer`: image quilting of a sample onto a surface, and gradient-domain blending of
//! layers under a mask.
//!
//! ```text
//! sample, [mix], [surface], [orientation], [density], [guide] ─► layer.quilt ─► layer.image
//!                                                                     └─► layer.seams (seams = gradient)
//! sources…, mask ─► layer.blend
//! ```
//!
//! The quilt stage keeps its whole result (index map, seams, block records), so a change
//! to what follows it (seam removal, an output view) never re-runs the search; a blend's
//! mask threshold is a blend parameter, so editing it re-runs only the blend onward.

use super::output::encode_image;
use super::{Encoded, FnStage, OutputFormat, Planner};
use crate::graph::{NodeId, RunCx, StageError};
use crate::lang::source::Span;
use crate::lang::{Decl, Diagnostic};
use crate::raster::{self, Image};
use crate::synth::blend::{self, BlendError, BlendParams, Selector};
use crate::synth::map as m;
use crate::synth::quilt::{
    self, Coherence, Guide, Orientation, QuiltError, QuiltOptions, QuiltParams, QuiltResult, SampleChoice, Terms,
};
use crate::synth::surface::Plane;

mod spec;
pub use spec::SPEC;

/// Which optional inputs a quilt stage has, in the order they are wired.
#[derive(Clone, Copy, Default)]
struct Wiring {
    mix: Option<usize>,
    surface: Option<usize>,
    orientation: Option<usize>,
    density: Option<usize>,
    guide: Option<usize>,
    guide_weight: Option<usize>,
}

pub fn plan(p: &mut Planner, d: &Decl) -> Result<NodeId, Diagnostic> {
    let props = &d.props;
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
                .with_label(d.name_span, "give it `quilt = SAMPLE` or `blend = [A, B]`"))
        }
    }
}

/// Working memory of a quilted layer per pixel: the RGB result, index map, seam mask and
/// error surfaces, and the seam-removal solve (measured: a 1024² quilt peaks at ≈ 120 bytes
/// per pixel, sample included).
const QUILT_BYTES_PER_PIXEL: f64 = 128.0;

/// The size of a quilted layer and where it was set: its surface's plane, or the scene size.
fn quilt_size(p: &Planner, d: &Decl) -> ((usize, usize), Option<Span>) {
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

    fn plan(&self, p: &mut Planner, d: &Decl) -> Result<Option<NodeId>, Diagnostic> {
        let node = plan(p, d)?;
        // A layer's values are in the colour space of the image it grows from (blends:
        // their first source's).
        let source = match d.props.reference("quilt") {
            Some(s) => s.to_string(),
            None => d.props.refs("blend")[0].clone(),
        };
        p.export(d).image = Some(p.color_space(&source));
        Ok(Some(node))
    }

    fn plan_output(&self, p: &mut Planner, out: &super::OutputRequest) -> Result<Option<super::ViewNode>, Diagnostic> {
        let view = out.view;
        if view == "auto" {
            return Ok(None);
        }
        let d = out.decl;
        if !matches!(view, "seams" | "index") || out.format.is_text() {
            return Err(Diagnostic::error(format!("a layer has no `{view}` view as `.{}`", out.ext))
                .with_code("tessera::output_view")
                .with_label(d.props.span("view").unwrap_or(d.name_span), "here")
                .with_help("layers are images; their views are `seams` and `index`"));
        }
        let node = plan_output(p, d, out.from, out.format, view)?;
        // Source positions are identities: a pixel taken from elsewhere is a regression.
        Ok(Some(super::ViewNode { node, exact: view == "index" }))
    }
}

fn plan_quilt(p: &mut Planner, d: &Decl, sample: &str) -> Result<NodeId, Diagnostic> {
    let props = &d.props;
    let ((w, h), size_at) = quilt_size(p, d);
    p.check_pixels(d, size_at, (w, h), QUILT_BYTES_PER_PIXEL)?;
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
    if props.get("mix").is_some() != props.get("density").is_some() {
        let (have, missing) = if props.get("mix").is_some() { ("mix", "density") } else { ("density", "mix") };
        return Err(Diagnostic::error(format!("`{have}` needs `{missing}`"))
            .with_code("tessera::quilt")
            .with_label(props.span(have).unwrap_or(d.name_span), "here")
            .with_help("`mix = SAMPLE` names the second sample and `density = MAP` how much of it to take"));
    }
    let mut inputs = vec![p.value(sample, props.span("quilt").unwrap_or(d.name_span))?];
    let mut wiring = Wiring::default();
    let wire = |slot: &mut Option<usize>, node: NodeId, inputs: &mut Vec<NodeId>| {
        *slot = Some(inputs.len());
        inputs.push(node);
    };
    if let Some(s) = props.reference("mix") {
        wire(&mut wiring.mix, p.value(s, props.span("mix").unwrap_or(d.name_span))?, &mut inputs);
    }
    if let Some(s) = props.reference("on") {
        wire(&mut wiring.surface, p.value(s, props.span("on").unwrap_or(d.name_span))?, &mut inputs);
    }
    if let Some(s) = props.reference("orientation") {
        wire(&mut wiring.orientation, p.value(s, props.span("orientation").unwrap_or(d.name_span))?, &mut inputs);
    }
    if let Some(s) = props.reference("density") {
        wire(&mut wiring.density, p.value(s, props.span("density").unwrap_or(d.name_span))?, &mut inputs);
    }
    if let Some(s) = props.reference("guide") {
        wire(&mut wiring.guide, p.value(s, props.span("guide").unwrap_or(d.name_span))?, &mut inputs);
    }
    if let Some(s) = props.reference("guide_weight") {
        wire(&mut wiring.guide_weight, p.value(s, props.span("guide_weight").unwrap_or(d.name_span))?, &mut inputs);
    }
    let mut params = QuiltParams::new(w, h, block, p.seed(d, "layer.quilt"));
    params.overlap = overlap;
    params.tolerance = props.num("tolerance") as f32;
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
    let copies = props.int("copies") as usize;
    let alpha = props.num("alpha") as f32;
    let key = serde_json::json!({ "params": params, "copies": copies, "alpha": alpha, "wired": [
        wiring.mix.is_some(), wiring.surface.is_some(), wiring.orientation.is_some(),
        wiring.density.is_some(), wiring.guide.is_some(), wiring.guide_weight.is_some()] })
    .to_string();
    let stage = FnStage::new("layer.quilt", 1, key, move |cx| run_quilt(cx, &params, wiring, copies, alpha));
    let quilt_node = p.add(format!("layer {} (quilt)", d.name), stage, inputs, vec![]);
    p.parts.insert((d.name.clone(), "quilt"), quilt_node);

    if spec::SEAMS.get(props.enumeration("seams")) == spec::SeamRemoval::Gradient {
        let radius = props.pixels("seam_band");
        let solver = solver_of(d);
        let key = serde_json::json!({ "radius": radius, "solver": solver }).to_string();
        let mut inputs = vec![quilt_node, p.result(sample)];
        if let Some(s) = props.reference("mix") {
            inputs.push(p.result(s));
        }
        let stage = FnStage::new("layer.seams", 2, key, move |cx| {
            let result = cx.input::<QuiltResult>(0);
            let samples: Vec<std::sync::Arc<Image>> = (1..cx.input_count()).map(|i| cx.input::<Image>(i)).collect();
            let refs: Vec<&Image> = samples.iter().map(|s| &**s).collect();
            let params = quilt::SeamParams { radius, solver, ..quilt::SeamParams::default() };
            let out = quilt::remove_seams(&result, &refs, &params)
                .map_err(|e| StageError::new(e.to_string()).at_prop("seams"))?;
            warn_unconverged(cx, &out.reports);
            Ok(out.image)
        });
        return Ok(p.add(format!("layer {} (seams)", d.name), stage, inputs, vec![]));
    }
    let stage = FnStage::new("layer.image", 1, String::new(), |cx| Ok(cx.input::<QuiltResult>(0).image.clone()));
    Ok(p.add(format!("layer {}", d.name), stage, vec![quilt_node], vec![]))
}

fn run_quilt(
    cx: &RunCx,
    params: &QuiltParams,
    wiring: Wiring,
    copies: usize,
    alpha: f32,
) -> Result<QuiltResult, StageError> {
    let (w, h) = (params.width, params.height);
    let sample = cx.input::<Image>(0);
    let mix = wiring.mix.map(|i| cx.input::<Image>(i));
    let plane = wiring.surface.map(|i| cx.input::<Plane>(i));
    let map = |slot: Option<usize>,
               prop: &'static str,
               channels: &[usize]|
     -> Result<Option<std::sync::Arc<Image>>, StageError> {
        let Some(i) = slot else { return Ok(None) };
        let img = cx.input::<Image>(i);
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
    let mut options = QuiltOptions { occupancy, ..QuiltOptions::default() };
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

fn plan_blend(p: &mut Planner, d: &Decl) -> Result<NodeId, Diagnostic> {
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
    let mut inputs: Vec<NodeId> = sources.iter().map(|s| p.value(s, at)).collect::<Result<_, _>>()?;
    let has_mask = props.reference("mask").is_some();
    if let Some(mk) = props.reference("mask") {
        inputs.push(p.result(mk));
    }
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
    let threshold = props.opt_num("threshold").map(|t| t as f32);
    let n = sources.len();
    let key = serde_json::json!({ "params": params, "threshold": threshold, "n": n, "mask": has_mask }).to_string();
    let stage = FnStage::new("layer.blend", 2, key, move |cx| {
        let images: Vec<std::sync::Arc<Image>> = (0..n).map(|i| cx.input::<Image>(i)).collect();
        let refs: Vec<&Image> = images.iter().map(|s| &**s).collect();
        if n == 1 {
            return Ok(refs[0].clone());
        }
        let mask = cx.input::<Image>(n);
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
        let result = if n == 2 {
            match threshold {
                Some(t) => {
                    let binary = m::threshold(&mask, t);
                    blend::blend(&refs, Selector::Binary(&binary), &params)
                }
                None => blend::blend(&refs, Selector::Soft(&mask), &params),
            }
        } else {
            let top = (n - 1) as f32;
            let labels: Vec<u32> =
                mask.plane(0).iter().map(|&v| (v.clamp(0.0, 1.0) * top).round() as u32).collect::<Vec<_>>();
            blend::blend(&refs, Selector::Labels(&labels), &params)
        }
        .map_err(blend_error)?;
        warn_unconverged(cx, &result.reports);
        Ok(result.image)
    });
    Ok(p.add(format!("layer {} (blend)", d.name), stage, inputs, vec![]))
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
    view: &str,
) -> Result<NodeId, Diagnostic> {
    let Some(quilt_node) = p.part(from, "quilt") else {
        return Err(Diagnostic::error(format!("view `{view}` shows how a layer was quilted; `{from}` is a blend"))
            .with_code("tessera::output_view")
            .with_label(d.props.span("view").unwrap_or(d.name_span), "here"));
    };
    let view = view.to_string();
    let params = serde_json::json!({ "view": view, "format": format!("{format:?}") }).to_string();
    let stage = FnStage::new("output.layer", 1, params, move |cx| {
        let r = cx.input::<QuiltResult>(0);
        let img = match view.as_str() {
            "seams" => r.seams.clone(),
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
        encode_image(&img, format)
    });
    Ok(p.add(format!("output {}", d.name), stage, vec![quilt_node], vec![]))
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
