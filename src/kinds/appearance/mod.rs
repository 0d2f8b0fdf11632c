//! `appearance`: structured appearance from example [references: frasson §4], as cached
//! stages:
//!
//! ```text
//! `from` image + structure ─────► appearance.interiors (A2a–d) ──┐
//! `contours` image + structure ─► appearance.contours (A2e–f) ───┼─► appearance.dress (S5–S8)
//! the dressed structure's mesh (or a sample's own) ──────────────┘        └─► appearance.render (R2)
//! ```
//!
//! The structure stages never read the photo, and these never re-run a structure stage: a
//! new appearance sample re-runs A2–R2 only; painting a unified texture re-runs the render
//! only (the UVs do not change).
//!
//! With `cluster_choice = sticky` the dress stage reads the `keep_clusters` table as its
//! file (`table`), so the graph stays a function of its inputs: the clusters to keep are an
//! input like any other, exported by a `view = cluster_table` output.

mod codecs;
mod spec;
mod table;

use std::path::PathBuf;

use super::output::{encode_image, View, VIEWS};
use super::structure::codecs::Shaped;
use super::{Bytes, ColorSpace, FnStage, Planner};
use crate::graph::{AnyHandle, Handle, In, Inputs, RunCx, StageError};
use crate::lang::source::Span;
use crate::lang::{Decl, Diagnostic};
use crate::raster::{self, Image};
use crate::synth::appearance::analysis::{self, ContourParams, Contours, Interiors};
use crate::synth::appearance::cluster::Clusters;
use crate::synth::appearance::dress::{self, ClusterChoice, DressHints, DressParams, FlipMode};
use crate::synth::appearance::render::{self, RenderParams};
use crate::synth::appearance::unified::{InteriorError, InteriorParams, UnifiedParams};
use crate::synth::appearance::Dressing;
use crate::synth::structure::analysis::sample::SampleStructure;

pub use spec::SPEC;

/// Working memory per rendered pixel: the RGBA result, its supersampled coverage and the
/// per-layer scratch (four f32 planes each).
const RENDER_BYTES_PER_PIXEL: f64 = 48.0;

/// Memory per texel of one cluster's unified texture while it is made and kept: the guide
/// and its weights, the texture, its index and source maps, the quilting planes (about
/// 100–130 bytes measured on a 1024² texture).
const UNIFIED_BYTES_PER_TEXEL: f64 = 128.0;

/// Memory per pixel of the interstice and junction atlases: the RGBA atlas, the cut pieces
/// held until they are pasted, their colours, and the copies the dressing and render read.
const ATLAS_BYTES_PER_PIXEL: f64 = 64.0;

/// The sample a role (`from`, `contours`, `on`) names: its image node and the analysis of its
/// drawn structure.
struct SampleInputs {
    image: Handle<Image>,
    space: ColorSpace,
    analysis: Handle<SampleStructure>,
}

fn sample_inputs(p: &mut Planner, d: &Decl, role: &'static str, name: &str) -> Result<SampleInputs, Diagnostic> {
    let at = d.props.span(role).unwrap_or(d.name_span);
    let sample = p.decl(name);
    let exports = p.exports(name);
    let Some((path, path_span)) = exports.example else {
        return Err(Diagnostic::error(format!("{} `{name}` has no `structure` drawn on its image", sample.kind))
            .with_code("tessera::appearance_sample")
            .with_label(at, "this sample")
            .with_label(sample.name_span, "declared here")
            .with_help("an appearance sample needs an `image` and the `structure` drawn on it (a JSON subdivision or a painted label image)"));
    };
    let Some(space) = exports.image else {
        return Err(Diagnostic::error(format!(
            "{} `{name}` has a structure but no image to take appearance from",
            sample.kind
        ))
        .with_code("tessera::appearance_sample")
        .with_label(at, "this sample")
        .with_label(sample.name_span, "declared here")
        .with_help("give the sample an `image` (the photo its structure was drawn on)"));
    };
    let analysis = plan_analysis(p, name, path, path_span);
    Ok(SampleInputs { image: p.result(name), space, analysis })
}

/// The analysis of a sample's drawn structure, with the structure kind's default settings
/// (so a structure learning from the same sample shares the cache entry).
fn plan_analysis(p: &mut Planner, sample: &str, path: PathBuf, span: Span) -> Handle<SampleStructure> {
    super::structure::plan_default_analysis(p, format!("sample {sample} (structure analysis)"), path, span)
}

/// What the dressed mesh is.
#[derive(Clone, Copy, serde::Serialize)]
enum Target {
    /// A synthesised structure; `associated` when it learnt from the interiors sample, so
    /// its stage-2 associations name that sample's regions.
    Structure { mesh: In<Shaped>, associated: bool },
    /// A sample's own drawn structure.
    Sample(In<SampleStructure>),
}

/// What A2a–d work from.
#[derive(serde::Serialize)]
struct InteriorWork {
    image: In<Image>,
    space: ColorSpace,
    analysis: In<SampleStructure>,
    params: InteriorSettings,
    seed: u64,
}

/// What A2e–f work from; the alpha override is the stage's file, when given.
#[derive(serde::Serialize)]
struct ContourWork {
    image: In<Image>,
    space: ColorSpace,
    analysis: In<SampleStructure>,
    params: ContourParams,
    alpha_override: bool,
}

/// What S5–S8 work from.
#[derive(serde::Serialize)]
struct DressWork {
    target: Target,
    interiors: In<Interiors>,
    contours: In<Contours>,
    params: DressSettings,
    seed: u64,
}

/// What R2 works from.
#[derive(serde::Serialize)]
struct RenderWork {
    dressing: In<Dressing>,
    interiors: In<Interiors>,
    contours: In<Contours>,
    size: RenderSize,
    scale: f64,
}

/// The rendered size: a structure's surface's, or a dressed sample's (known once analysed),
/// times `resolution`.
#[derive(Clone, Copy, serde::Serialize)]
enum RenderSize {
    Fixed(usize, usize),
    OfSample(In<SampleStructure>),
}

fn scaled(n: usize, scale: f64) -> usize {
    ((n as f64) * scale).round().max(1.0) as usize
}

pub fn plan(p: &mut Planner, d: &Decl) -> Result<Handle<Image>, Diagnostic> {
    let props = &d.props;
    let from = props.reference("from").expect("required").to_string();
    let contours_name = props.reference("contours").unwrap_or(&from).to_string();
    let seed = props.get("seed").map(|_| props.int("seed") as u64).unwrap_or_else(|| p.seed(d, "appearance"));
    let interiors_in = sample_inputs(p, d, "from", &from)?;
    let contours_in = if contours_name == from { None } else { Some(sample_inputs(p, d, "contours", &contours_name)?) };

    // The mesh to dress, and the size it is drawn on (a sample's is known when analysed).
    let on = props.reference("on").unwrap_or(&from).to_string();
    let scale = props.num("resolution");
    let (target_handle, size) = if p.exports(&on).example.is_some() {
        // Only the drawing of a sample dressed in place is read: it needs no image.
        let analysis = if on == from {
            interiors_in.analysis
        } else {
            let (path, span) = p.exports(&on).example.expect("checked above");
            plan_analysis(p, &on, path, span)
        };
        (TargetHandle::Sample(analysis), None)
    } else {
        let on_decl = p.decl(&on);
        let mesh = p.part(&on, "mesh").expect("structures plan a mesh stage");
        let associated = on_decl.props.reference("from") == Some(from.as_str());
        let surface = on_decl.props.reference("on").expect("required").to_string();
        let ((w, h), _) = p.plane(&surface);
        let (rw, rh) = (scaled(w, scale), scaled(h, scale));
        p.check_pixels(d, props.span("resolution"), (rw, rh), RENDER_BYTES_PER_PIXEL)?;
        (TargetHandle::Structure { mesh, associated }, Some((rw, rh)))
    };

    // A2a–d: region interiors.
    let mut inputs = Inputs::new();
    let work = InteriorWork {
        image: inputs.add(interiors_in.image),
        space: interiors_in.space,
        analysis: inputs.add(interiors_in.analysis),
        params: interior_settings(props),
        seed,
    };
    let a2 = p.add(
        format!("appearance {} (interiors)", d.name),
        FnStage::keyed("appearance.interiors", 2, work, run_interiors),
        inputs,
        vec![],
    );

    // A2e–f: interstice and junction atlases.
    let c = contours_in.as_ref().unwrap_or(&interiors_in);
    let mut inputs = Inputs::new();
    let mut files = Vec::new();
    if let Some(path) = props.path("alpha") {
        files.push((path.clone(), props.span("alpha").unwrap_or(d.name_span)));
    }
    let work = ContourWork {
        image: inputs.add(c.image),
        space: c.space,
        analysis: inputs.add(c.analysis),
        params: contour_settings(props),
        alpha_override: !files.is_empty(),
    };
    let a3 = p.add(
        format!("appearance {} (contours)", d.name),
        FnStage::keyed("appearance.contours", 1, work, run_contours),
        inputs,
        files,
    );

    // S5–S8: the dressing; a sticky choice reads its table.
    let keep = keep_clusters(d)?;
    let mut inputs = Inputs::new();
    let target = match target_handle {
        TargetHandle::Structure { mesh, associated } => Target::Structure { mesh: inputs.add(mesh), associated },
        TargetHandle::Sample(a) => Target::Sample(inputs.add(a)),
    };
    let work =
        DressWork { target, interiors: inputs.add(a2), contours: inputs.add(a3), params: dress_settings(props), seed };
    let s5 = p.add(
        format!("appearance {} (dress)", d.name),
        FnStage::keyed("appearance.dress", 1, work, run_dress),
        inputs,
        keep.into_iter().collect(),
    );

    // R2: the render.
    let mut inputs = Inputs::new();
    let size = match (size, target_handle) {
        (Some(wh), _) => RenderSize::Fixed(wh.0, wh.1),
        (None, TargetHandle::Sample(a)) => RenderSize::OfSample(inputs.add(a)),
        (None, TargetHandle::Structure { .. }) => unreachable!("a structure's size is its surface's"),
    };
    let work =
        RenderWork { dressing: inputs.add(s5), interiors: inputs.add(a2), contours: inputs.add(a3), size, scale };
    let r2 = p.add(
        format!("appearance {} (render)", d.name),
        FnStage::keyed("appearance.render", 2, work, run_render),
        inputs,
        vec![],
    );

    p.set_part(d, "interiors", a2);
    p.set_part(d, "contours", a3);
    p.set_part(d, "dressing", s5);
    Ok(r2)
}

/// The cluster table of a sticky choice, with the span that names it: `keep_clusters` is
/// required with `cluster_choice = sticky` and means nothing without it.
fn keep_clusters(d: &Decl) -> Result<Option<(PathBuf, Span)>, Diagnostic> {
    let props = &d.props;
    let sticky = spec::CLUSTER_CHOICES.get(props.enumeration("cluster_choice")) == spec::ClusterChoice::Sticky;
    match (sticky, props.path("keep_clusters")) {
        (true, Some(path)) => Ok(Some((path.clone(), props.span("keep_clusters").unwrap_or(d.name_span)))),
        (false, None) => Ok(None),
        (true, None) => Err(Diagnostic::error("`cluster_choice = sticky` needs the clusters to keep")
            .with_code("tessera::appearance_sticky")
            .with_label(props.span("cluster_choice").unwrap_or(d.name_span), "no `keep_clusters` to keep")
            .with_help(
                "write the current clusters with an output of this appearance with `view = cluster_table` (a `.json` file), then name it: `keep_clusters = \"clusters.json\"`",
            )),
        (false, Some(_)) => Err(Diagnostic::error("`keep_clusters` applies only with `cluster_choice = sticky`")
            .with_code("tessera::appearance_sticky")
            .with_label(props.span("keep_clusters").unwrap_or(d.name_span), "this table is not read")
            .with_help("add `cluster_choice = sticky`, or remove `keep_clusters`")),
    }
}

/// The interior analysis settings as the language gives them.
#[derive(Clone, Copy, serde::Serialize)]
struct InteriorSettings {
    shrink: f64,
    clusters: Option<usize>,
    texture_size: Option<usize>,
    block: usize,
}

fn interior_settings(props: &crate::lang::Props) -> InteriorSettings {
    InteriorSettings {
        shrink: props.num("shrink"),
        clusters: props.get("clusters").map(|_| props.int("clusters") as usize),
        texture_size: props.get("texture_size").map(|_| props.num("texture_size") as usize),
        block: props.num("block") as usize,
    }
}

impl InteriorSettings {
    fn params(&self) -> InteriorParams {
        let mut p = InteriorParams::default();
        p.shrink = self.shrink;
        p.clusters = match self.clusters {
            Some(k) => Clusters::Fixed(k),
            None => Clusters::Auto,
        };
        p.unified = UnifiedParams { size: self.texture_size, block: self.block, ..p.unified.clone() };
        p
    }
}

fn contour_settings(props: &crate::lang::Props) -> ContourParams {
    let i = props.block("interstice");
    let j = props.block("junction");
    ContourParams {
        half_width: i.num("half_width"),
        extension: i.opt_num("extension"),
        branch_len: j.opt_num("branch_length"),
        shrink: props.num("shrink"),
    }
}

/// The synthesis settings as the language gives them.
#[derive(Clone, Copy, serde::Serialize)]
struct DressSettings {
    cluster_choice: spec::ClusterChoice,
    flip: spec::Flip,
    candidates: usize,
    match_contours: bool,
}

fn dress_settings(props: &crate::lang::Props) -> DressSettings {
    DressSettings {
        cluster_choice: spec::CLUSTER_CHOICES.get(props.enumeration("cluster_choice")),
        flip: spec::FLIPS.get(props.block("interstice").enumeration("flip")),
        candidates: props.block("junction").int("candidates") as usize,
        match_contours: props.bool("match"),
    }
}

impl DressSettings {
    fn params(&self) -> DressParams {
        DressParams {
            cluster_choice: match self.cluster_choice {
                spec::ClusterChoice::ClosestShape => ClusterChoice::ClosestShape,
                spec::ClusterChoice::Random => ClusterChoice::Random,
                spec::ClusterChoice::Sticky => ClusterChoice::Sticky,
            },
            flip: match self.flip {
                spec::Flip::Random => FlipMode::Random,
                spec::Flip::None => FlipMode::None,
                spec::Flip::BestColor => FlipMode::BestColor,
            },
            junction_k: self.candidates,
            match_contours: self.match_contours,
            ..DressParams::default()
        }
    }
}

#[derive(Clone, Copy)]
enum TargetHandle {
    Structure { mesh: Handle<Shaped>, associated: bool },
    Sample(Handle<SampleStructure>),
}

/// The sample image as sRGB-encoded values, whatever colour space it was declared in.
fn srgb(img: &Image, space: ColorSpace) -> Image {
    match space {
        ColorSpace::Srgb => img.clone(),
        ColorSpace::Linear => raster::color::image_linear_to_srgb(img),
        ColorSpace::Lab => raster::color::image_linear_to_srgb(&raster::color::image_lab_to_linear(img)),
    }
}

/// The sample image checked against its structure: RGB, the structure's size.
fn checked_image(img: &Image, space: ColorSpace, s: &SampleStructure, role: &'static str) -> Result<Image, StageError> {
    let (w, h) = (s.size[0].round() as usize, s.size[1].round() as usize);
    if img.width != w || img.height != h {
        return Err(StageError::new(format!(
            "the sample's image is {}x{} but its structure is drawn on {w}x{h}",
            img.width, img.height
        ))
        .at_prop(role)
        .with_help("draw the structure on the image itself (same size), or crop/resize the image to the structure"));
    }
    let img = srgb(img, space);
    Ok(match img.channels {
        1 | 2 => Image::from_fn(img.width, img.height, 3, |x, y, _| img.get(x, y, 0)),
        _ => Image::from_fn(img.width, img.height, 3, |x, y, c| img.get(x, y, c)),
    })
}

fn run_interiors(cx: &RunCx, w: &InteriorWork) -> Result<Interiors, StageError> {
    let s = cx.get(w.analysis);
    let img = checked_image(&cx.get(w.image), w.space, &s, "from")?;
    let params = w.params.params();
    if let Some(side) = w.params.texture_size {
        // One texture per cluster: as many as asked, else at most ten (or one per region).
        let k = w.params.clusters.unwrap_or(10).min(s.polygons.len()).max(1);
        let what = format!("quilting {k} unified texture{} of {side} x {side} px", if k == 1 { "" } else { "s" });
        cx.budget().check(k as f64 * (side as f64).powi(2) * UNIFIED_BYTES_PER_TEXEL, &what).map_err(|e| {
            StageError::new(e).at_prop("texture_size").with_help(
                "use a smaller `texture_size` or fewer `clusters`, or raise the budget with `--max-memory` or `[limits] max_memory` in tessera.toml",
            )
        })?;
    }
    let r = analysis::interiors(&img, &s, &params, w.seed).map_err(|e| interior_error(&e, &params))?;
    for warning in &r.warnings {
        cx.warn(warning.clone());
    }
    Ok(r)
}

/// An interior analysis error at the property that decides it.
fn interior_error(e: &InteriorError, params: &InteriorParams) -> StageError {
    let message = e.to_string();
    match *e {
        InteriorError::NoInteriors { .. } => StageError::new(message).at_prop("shrink").with_help(
            "regions are cut out `shrink` inside their outline; the sample's regions must be wider than twice that",
        ),
        InteriorError::TooManyBlocks { side, block, wanted, .. } => {
            let u = &params.unified;
            let smaller = format!("use `texture_size` of at most {} px", u.max_side(block));
            // A larger block helps only when the regions held the one asked for.
            let larger = u.min_block(side, wanted + 1).filter(|&b| block == wanted && b as f64 <= spec::BLOCK_MAX);
            let help = match larger {
                Some(b) => format!("{smaller}, or `block` of at least {b} px"),
                None => smaller,
            };
            StageError::new(message).at_prop("texture_size").with_help(help)
        }
        InteriorError::Quilt { .. } => StageError::new(message).at_prop("from"),
    }
}

fn run_contours(cx: &RunCx, w: &ContourWork) -> Result<Contours, StageError> {
    let s = cx.get(w.analysis);
    let img = checked_image(&cx.get(w.image), w.space, &s, "contours")?;
    // The atlases grow with the strips' and stars' sizes: held to the budget before cutting.
    let pixels = analysis::contour_atlas_pixels(&s.mesh, &w.params);
    cx.budget().check(pixels * ATLAS_BYTES_PER_PIXEL, "cutting the interstice and junction atlases").map_err(|e| {
        StageError::new(e).at_prop("interstice.half_width").with_help(
            "use a smaller `half_width`, `extension` or `branch_length`, or raise the budget with `--max-memory` or `[limits] max_memory` in tessera.toml",
        )
    })?;
    let alpha = if w.alpha_override {
        let bytes = cx.file(0)?;
        let a = super::decode_image(&bytes, cx.budget())
            .map_err(|e| StageError::new(format!("cannot decode the alpha map: {e}")).in_file(0))?;
        if a.width != img.width || a.height != img.height {
            return Err(StageError::new(format!(
                "the alpha map is {}x{} but the contours sample is {}x{}",
                a.width, a.height, img.width, img.height
            ))
            .in_file(0)
            .with_help("paint the alpha map over the sample image itself: white = mortar, black = stone"));
        }
        Some(Image::from_fn(a.width, a.height, 1, |x, y, _| a.get(x, y, 0)))
    } else {
        None
    };
    analysis::contours(&img, &s, &w.params, alpha.as_ref())
        .map_err(|e| StageError::new(e.to_string()).at_prop("contours"))
}

fn run_dress(cx: &RunCx, w: &DressWork) -> Result<Dressing, StageError> {
    let interiors = cx.get(w.interiors);
    let contours = cx.get(w.contours);
    let data = analysis::appearance_data(&interiors, &contours);
    let (shaped, sample);
    let (mesh, known) = match w.target {
        Target::Structure { mesh, associated } => {
            shaped = cx.get(mesh);
            let known: Option<Vec<Option<usize>>> = associated.then(|| {
                shaped.associated.iter().map(|a| a.and_then(|a| interiors.original_of_region(a.region))).collect()
            });
            (&shaped.mesh, known)
        }
        Target::Sample(a) => {
            sample = cx.get(a);
            (&sample.mesh, None)
        }
    };
    let previous = match w.params.cluster_choice {
        spec::ClusterChoice::Sticky => Some(kept_clusters(cx, mesh.regions.len(), data.unified.len())?),
        _ => None,
    };
    let hints = DressHints { associations: known.as_deref(), previous_clusters: previous.as_deref() };
    let dressing = dress::dress(mesh, &data, &w.params.params(), w.seed, &hints);
    for warning in &dressing.warnings {
        cx.warn(warning.clone());
    }
    Ok(dressing)
}

/// The clusters the `keep_clusters` table (the stage's file) keeps for `regions` regions of
/// an appearance with `clusters` clusters.
fn kept_clusters(cx: &RunCx, regions: usize, clusters: usize) -> Result<Vec<Option<usize>>, StageError> {
    const HELP: &str = "a cluster table is `{ \"clusters\": <count>, \"regions\": { \"<region id>\": <cluster>, … } }`, as an output of the appearance with `view = cluster_table` writes it";
    let bytes = cx.file(0)?;
    let kept = table::parse(&bytes)
        .map_err(|e| StageError::new(format!("not a cluster table: {e}")).in_file(0).with_help(HELP))?;
    let (previous, beyond) = table::previous_clusters(&kept, regions, clusters).map_err(|e| {
        StageError::new(e.to_string()).in_file(0).with_help(
            "the table was written for another clustering of the appearance: build once with `cluster_choice = closest_shape` and write the table again (`view = cluster_table`), or set `clusters` to the table's count",
        )
    })?;
    if beyond > 0 {
        cx.warn(format!(
            "the cluster table names {beyond} regions the dressed structure does not have (it has {regions}): ignored"
        ));
    }
    Ok(previous)
}

fn run_render(cx: &RunCx, w: &RenderWork) -> Result<Image, StageError> {
    let dressing = cx.get(w.dressing);
    let interiors = cx.get(w.interiors);
    let contours = cx.get(w.contours);
    let data = analysis::appearance_data(&interiors, &contours);
    let (width, height) = match w.size {
        RenderSize::Fixed(width, height) => (width, height),
        RenderSize::OfSample(a) => {
            let s = cx.get(a);
            let (width, height) =
                (scaled(s.size[0].round() as usize, w.scale), scaled(s.size[1].round() as usize, w.scale));
            cx.budget()
                .check(width as f64 * height as f64 * RENDER_BYTES_PER_PIXEL, "the appearance's render")
                .map_err(|e| StageError::new(e).at_prop("resolution"))?;
            (width, height)
        }
    };
    let params = RenderParams { width, height, scale: w.scale, background: [0.0; 3] };
    let r = render::render(&dressing, &data, &params);
    // RGBA: the albedo and its coverage (openings and the outside stay transparent).
    let n = width * height;
    let mut data = r.color.data;
    data.truncate(3 * n);
    data.extend_from_slice(&r.coverage.data[..n]);
    Ok(Image { width, height, channels: 4, data })
}

/// The file a view writes.
#[derive(serde::Serialize)]
struct ViewWork {
    view: View,
    format: super::OutputFormat,
    interiors: In<Interiors>,
    contours: In<Contours>,
    render: In<Image>,
}

/// What the cluster table is written from: the dressing and, for the cluster count, the
/// interiors.
#[derive(serde::Serialize)]
struct TableWork {
    dressing: In<Dressing>,
    interiors: In<Interiors>,
}

fn plan_view(p: &mut Planner, out: &super::OutputRequest) -> Result<Option<super::ViewNode>, Diagnostic> {
    let d = out.decl;
    let json = out.format == super::OutputFormat::Json;
    let view = match out.view {
        View::Auto if json => View::ClusterTable,
        v => v,
    };
    if view == View::Auto {
        return Ok(None);
    }
    if view == View::ClusterTable || json {
        if view != View::ClusterTable || !json {
            return Err(Diagnostic::error(format!(
                "an appearance's `{}` view is not written to `.{}`",
                VIEWS.name(view),
                out.ext
            ))
            .with_code("tessera::output_view")
            .with_label(d.props.span("view").unwrap_or(d.name_span), "this view")
            .with_label(d.name_span, "this file")
            .with_help(
                "`cluster_table` is written to a `.json` file, the other views of an appearance to `.png` or `.exr`",
            ));
        }
        let mut inputs = Inputs::new();
        let work = TableWork {
            dressing: inputs.add(p.part(out.from, "dressing").expect("appearances plan a dressing")),
            interiors: inputs.add(p.part(out.from, "interiors").expect("appearances plan interiors")),
        };
        let node = p.add(
            format!("output {}", d.name),
            FnStage::keyed("appearance.cluster_table", 1, work, run_table),
            inputs,
            vec![],
        );
        // Cluster ids are identities: a region in another cluster is another texture.
        return Ok(Some(super::ViewNode { node, exact: true, more: Vec::new() }));
    }
    if !matches!(
        view,
        View::Albedo
            | View::Alpha
            | View::Unified
            | View::Interstices
            | View::Junctions
            | View::Guides
            | View::Clusters
    ) || out.format.is_text()
    {
        return Err(Diagnostic::error(format!("an appearance has no `{}` view in this format", VIEWS.name(view)))
            .with_code("tessera::output_view")
            .with_label(d.props.span("view").unwrap_or(d.name_span), "this view")
            .with_help("its views are albedo, alpha, unified, interstices, junctions, guides and clusters, written to `.png` or `.exr`, and cluster_table, written to `.json`"));
    }
    let mut inputs = Inputs::new();
    let work = ViewWork {
        view,
        format: out.format,
        interiors: inputs.add(p.part(out.from, "interiors").expect("appearances plan interiors")),
        contours: inputs.add(p.part(out.from, "contours").expect("appearances plan contours")),
        render: inputs.add(p.result(out.from)),
    };
    let node =
        p.add(format!("output {}", d.name), FnStage::keyed("appearance.view", 1, work, run_view), inputs, vec![]);
    Ok(Some(super::ViewNode { node, exact: false, more: Vec::new() }))
}

fn run_table(cx: &RunCx, w: &TableWork) -> Result<Bytes, StageError> {
    let dressing = cx.get(w.dressing);
    Ok(Bytes(table::write(&dressing.clusters, cx.get(w.interiors).unified.len()).into_bytes()))
}

fn run_view(cx: &RunCx, w: &ViewWork) -> Result<Bytes, StageError> {
    let img = match w.view {
        View::Albedo | View::Alpha => {
            let r = cx.get(w.render);
            let channels = if w.view == View::Albedo { 0..3 } else { 3..4 };
            Image::from_fn(r.width, r.height, channels.len(), |x, y, c| r.get(x, y, channels.start + c))
        }
        View::Unified => analysis::side_by_side(cx.get(w.interiors).unified.iter().map(|u| &u.image)),
        View::Guides => analysis::side_by_side(cx.get(w.interiors).guides.iter()),
        View::Clusters => cx.get(w.interiors).cluster_view.clone(),
        View::Interstices => cx.get(w.contours).interstices.image.clone(),
        View::Junctions => cx.get(w.contours).junctions.image.clone(),
        other => unreachable!("`{}` is checked when planned", VIEWS.name(other)),
    };
    // Textures and renders hold sRGB values; EXR files hold linear light.
    let img = match w.format {
        super::OutputFormat::Exr => raster::color::image_srgb_to_linear(&img),
        _ => img,
    };
    encode_image(&img, w.format)
}

/// The appearance kind.
pub struct Appearance;

impl super::Kind for Appearance {
    fn spec(&self) -> &'static crate::lang::KindSpec {
        &SPEC
    }

    fn plan(&self, p: &mut Planner, d: &Decl) -> Result<Option<AnyHandle>, Diagnostic> {
        let node = plan(p, d)?;
        p.export(d).image = Some(ColorSpace::Srgb);
        Ok(Some(node.erase()))
    }

    fn plan_output(&self, p: &mut Planner, out: &super::OutputRequest) -> Result<Option<super::ViewNode>, Diagnostic> {
        plan_view(p, out)
    }
}
