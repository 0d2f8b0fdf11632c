//! `structure`: structure from example [references: frasson §3], as cached stages:
//!
//! ```text
//! sample's structure file ─► structure.analyse (A1) ─┐
//! surface, size/orientation/density maps ────────────┼─► structure.sample (S1)
//!                                                    │      └─► structure.lloyd (S2)
//!                                                    │            └─► [structure.edits ─► structure.lloyd]
//!                                                    │                  └─► structure.polygonize (S3)
//!                                                    └────────────────────────► structure.shapes (S4)
//! ```
//!
//! A density-map edit re-runs S2 and what follows, never the analysis; an output's view or
//! edge width re-runs only that output.
//!
//! A layered sample (the analysis finds courses, `layout = auto | courses`) takes another
//! path through the same stages: S1 lays courses of bricks, S2 rasterises them instead of
//! running Lloyd, S4 only associates the bricks with their closest originals.

use super::map::fit;
use super::{FnStage, Planner};
use crate::graph::{AnyHandle, Handle, In, Inputs, RunCx, StageError};
use crate::lang::{Decl, Diagnostic, Props};
use crate::raster::{self, Image};
use crate::synth::rng::Rng;
use crate::synth::structure::analysis::courses;
use crate::synth::structure::analysis::sample::{analyse_label_image, analyse_sample, SampleStructure};
use crate::synth::structure::analysis::stats::{EllipseFit, StatsConfig};
use crate::synth::structure::generation::courses as generation_courses;
use crate::synth::structure::generation::edits::{self, Edit, Target};
use crate::synth::structure::generation::synthesis::{
    self, CenterSource, EmpiricalSampler, ShapeSampling, StatisticalParams,
};
use crate::synth::structure::mesh::polygonize::{self, Polygonization, PolygonizeParams};
use crate::synth::structure::relaxation::controls::{
    allowed_from_occupancy, Controls, DensityParams, OrientationMode, RemoveMode, SizeMode,
};
use crate::synth::structure::relaxation::lloyd::{self, LloydParams};
use crate::synth::structure::relaxation::metric::MetricKind;
use crate::synth::structure::shapes::optimize::{self, ShapeParams};
use crate::synth::structure::{Ellipse, Point};
use crate::synth::surface::Plane;
use crate::synth::Progress;

pub(crate) mod codecs;
mod spec;
mod views;
pub use codecs::{Associated, Generators, Relaxed, Shaped};
pub use spec::SPEC;
pub use views::plan_output;

/// The control maps a stage reads.
#[derive(Clone, Copy, Default, serde::Serialize)]
struct MapInputs {
    density: Option<In<Image>>,
    size: Option<In<Image>>,
    orientation: Option<In<Image>>,
    metric: Option<In<Image>>,
}

/// Which of the declaration's maps a stage reads.
#[derive(Clone, Copy)]
enum MapProp {
    Density,
    Size,
    Orientation,
    Metric,
}

impl MapInputs {
    fn add(p: &Planner, props: &Props, inputs: &mut Inputs, which: &[MapProp]) -> MapInputs {
        let mut m = MapInputs::default();
        for &which in which {
            let (name, slot) = match which {
                MapProp::Density => ("density", &mut m.density),
                MapProp::Size => ("size", &mut m.size),
                MapProp::Orientation => ("orientation", &mut m.orientation),
                MapProp::Metric => ("metric_map", &mut m.metric),
            };
            *slot = props.reference(name).map(|map| inputs.add(p.result(map)));
        }
        m
    }
}

/// The maps of one stage, prepared at the target size.
struct Maps {
    density: Option<Vec<f32>>,
    size: Option<Vec<f32>>,
    orientation: Option<Image>,
    metric: Option<Vec<MetricKind>>,
}

fn scalar_map(img: &Image, w: usize, h: usize) -> Vec<f32> {
    let img = fit(img, w, h);
    if img.channels == 1 {
        img.data
    } else {
        raster::color::luminance(&img).data
    }
}

fn prepare_maps(cx: &RunCx, m: MapInputs, w: usize, h: usize) -> Result<Maps, StageError> {
    let orientation = match m.orientation {
        None => None,
        Some(i) => {
            let img = cx.get(i);
            if img.channels != 2 {
                return Err(StageError::new("the orientation map must be a 2-channel field (e.g. `radial(field = tangential)` or `image(..., channel = vector)`)").at_prop("orientation"));
            }
            let mut f = fit(&img, w, h);
            // Resampling shortens vectors; the direction is what matters.
            let n = w * h;
            for i in 0..n {
                let (x, y) = (f.data[i], f.data[n + i]);
                let l = (x * x + y * y).sqrt();
                if l > 1e-6 {
                    f.data[i] = x / l;
                    f.data[n + i] = y / l;
                }
            }
            Some(f)
        }
    };
    Ok(Maps {
        density: m.density.map(|i| scalar_map(&cx.get(i), w, h)),
        size: m.size.map(|i| scalar_map(&cx.get(i), w, h)),
        orientation,
        metric: m.metric.map(|i| {
            crate::synth::structure::relaxation::controls::metric_map_from_levels(&scalar_map(&cx.get(i), w, h))
        }),
    })
}

/// One id per distinct colour of a label image (quantised to 8 bits per channel, so that
/// 16-bit or EXR images with the same painted colours give the same regions).
fn colour_ids(img: &Image) -> Vec<u32> {
    let n = img.width * img.height;
    let channels = img.channels.min(3);
    let mut ids = Vec::with_capacity(n);
    let mut map = std::collections::HashMap::new();
    for i in 0..n {
        let mut key = 0u32;
        for c in 0..channels {
            key = key << 8 | (img.data[c * n + i].clamp(0.0, 1.0) * 255.0).round() as u32;
        }
        let next = map.len() as u32;
        ids.push(*map.entry(key).or_insert(next));
    }
    ids
}

pub(super) fn metric_kind(name: &str) -> MetricKind {
    match spec::METRICS.get(name) {
        spec::MetricChoice::Elliptic => MetricKind::Elliptic,
        spec::MetricChoice::Manhattan => MetricKind::Manhattan,
        spec::MetricChoice::Chebyshev => MetricKind::Chebyshev,
    }
}

/// Working memory of a structure per target pixel: the label raster, Lloyd's distances,
/// flood queue and control maps, the polygoniser's edge maps (measured: a 1024² structure
/// peaks at ≈ 40 bytes per pixel).
const STRUCTURE_BYTES_PER_PIXEL: f64 = 48.0;

pub fn plan(p: &mut Planner, d: &Decl) -> Result<Handle<Shaped>, Diagnostic> {
    let props = &d.props;
    let from = props.reference("from").expect("required");
    let Some((path, path_span)) = p.exports(from).example else {
        let sample = p.decl(from);
        return Err(Diagnostic::error(format!("{} `{from}` has no `structure` file to learn from", sample.kind))
            .with_code("tessera::structure")
            .with_label(props.span("from").unwrap_or(d.name_span), format!("this {}", sample.kind))
            .with_label(sample.name_span, "declared here")
            .with_help(format!("give the {} `structure = \"file.json\"`", sample.kind)));
    };
    let on = props.reference("on").expect("required");
    let ((w, h), size_at) = p.plane(on);
    p.check_pixels(d, size_at, (w, h), STRUCTURE_BYTES_PER_PIXEL)?;
    let seed = props.get("seed").map(|_| props.int("seed") as u64).unwrap_or_else(|| p.seed(d, "structure"));
    // The courses' stream: named apart, so laying courses never shifts the statistical one.
    let courses_seed = match props.get("seed") {
        Some(_) => crate::synth::rng::derive_seed(props.int("seed") as u64, &d.name, "courses"),
        None => p.seed(d, "courses"),
    };

    // A1: analysis of the sample's structure.
    let config = StatsConfig {
        exclude_border_regions: props.bool("exclude_border_regions"),
        ellipse_fit: match spec::ELLIPSE_FITS.get(props.enumeration("ellipse_fit")) {
            spec::Either::First => EllipseFit::Polygon,
            spec::Either::Second => EllipseFit::Pixels,
        },
    };
    let a1 = plan_analysis(p, format!("structure {} (analysis)", d.name), config, path, path_span);
    let surface = p.result::<Plane>(on);

    // S1: generators. Uniform centres are drawn in proportion to the density map too, so
    // the map places regions from the start and not only through Lloyd
    // [references: frasson §3.5.3]: S1 reads the occupancy, size and, for `centers =
    // uniform`, density maps.
    let mut inputs = Inputs::new();
    let (analysis, surface_in) = (inputs.add(a1), inputs.add(surface));
    let s1_maps: &[MapProp] =
        if centers(props) == spec::Centers::Uniform { &[MapProp::Size, MapProp::Density] } else { &[MapProp::Size] };
    let maps = MapInputs::add(p, props, &mut inputs, s1_maps);
    let sampling =
        Sampling { analysis, surface: surface_in, maps, w, h, seed, courses_seed, options: SampleOptions::from(props) };
    let s1 = FnStage::keyed("structure.sample", 6, sampling, sample_generators);
    let s1 = p.add(format!("structure {} (sampling)", d.name), s1, inputs, vec![]);

    // S2: Lloyd; with edits, S1e applies them to the relaxed generators and Lloyd runs
    // again from there (edits act on the current state, [references: frasson §3.7.1]).
    let mut s2 = plan_lloyd(p, d, s1, surface, w, h, "lloyd");
    let mut last_generators = s1;
    let edits = convert_edits(props)?;
    if !edits.is_empty() {
        let mut inputs = Inputs::new();
        let editing = Editing { relaxed: inputs.add(s2), surface: inputs.add(surface), edits, w, h };
        let s1e = FnStage::keyed("structure.edits", 2, editing, apply_edits);
        let s1e = p.add(format!("structure {} (edits)", d.name), s1e, inputs, vec![]);
        last_generators = s1e;
        s2 = plan_lloyd(p, d, s1e, surface, w, h, "lloyd after edits");
    }

    // S3: polygonisation of the label raster.
    let block = props.block("polygonize");
    let params = PolygonizeParams {
        tolerance: block.num("tolerance"),
        min_edge: block.num("min_edge"),
        straight_deg: block.num("straight").to_degrees(),
    };
    let mut inputs = Inputs::new();
    let polygonizing = Polygonizing { relaxed: inputs.add(s2), params };
    let s3 = FnStage::keyed("structure.polygonize", 2, polygonizing, |cx, s| {
        Ok(polygonize::polygonize(&cx.get(s.relaxed).labels, &s.params))
    });
    let s3 = p.add(format!("structure {} (polygonize)", d.name), s3, inputs, vec![]);

    // S4: shape optimisation towards the closest original shapes.
    let shapes = props.block("shapes");
    let params = ShapeParams {
        step: shapes.num("step"),
        max_iters: if shapes.bool("enabled") { shapes.int("iterations") as usize } else { 0 },
        reassociate_every: shapes.int("reassociate") as usize,
        area_tol: shapes.num("area_tolerance"),
        allow_rotation: shapes.bool("allow_rotation"),
        ellipse_weight: shapes.num("ellipse_weight"),
        tol: shapes.num("tolerance"),
        min_edge: block.num("min_edge"),
        straight_deg: block.num("straight").to_degrees(),
        ..ShapeParams::default()
    };
    let mut inputs = Inputs::new();
    let shaping = Shaping {
        mesh: inputs.add(s3),
        analysis: inputs.add(a1),
        generators: inputs.add(last_generators),
        relaxed: inputs.add(s2),
        scale: props.num("scale"),
        params,
        w,
        h,
    };
    let s4 = FnStage::keyed("structure.shapes", 6, shaping, optimise_shapes);
    let s4 = p.add(format!("structure {} (shapes)", d.name), s4, inputs, vec![]);

    p.set_part(d, "lloyd", s2);
    p.set_part(d, "analysis", a1);
    p.set_part(d, "mesh", s4);
    Ok(s4)
}

/// A1 of a sample's structure file, as a stage of its own.
fn plan_analysis(
    p: &mut Planner,
    label: String,
    config: StatsConfig,
    path: std::path::PathBuf,
    span: crate::lang::source::Span,
) -> Handle<SampleStructure> {
    p.add(label, FnStage::keyed("structure.analyse", 5, config, analyse), Inputs::new(), vec![(path, span)])
}

/// A1 with the default settings (border regions left out of the statistics, polygon
/// moments): what other kinds read of a sample's drawn structure.
pub(crate) fn plan_default_analysis(
    p: &mut Planner,
    label: String,
    path: std::path::PathBuf,
    span: crate::lang::source::Span,
) -> Handle<SampleStructure> {
    let config = StatsConfig { exclude_border_regions: true, ellipse_fit: EllipseFit::Polygon };
    plan_analysis(p, label, config, path, span)
}

/// A1: the sample's structure file (JSON or a painted label image) analysed.
fn analyse(cx: &RunCx, config: &StatsConfig) -> Result<SampleStructure, StageError> {
    let bytes = cx.file(0)?;
    let s = if raster::io::sniff(&bytes).is_some() {
        // A painted label image: one colour per region.
        let img = super::decode_image(&bytes, cx.budget())
            .map_err(|e| StageError::new(format!("cannot decode the label image: {e}")).in_file(0))?;
        let ids = colour_ids(&img);
        analyse_label_image(&ids, img.width, img.height, 1.0, config)
    } else {
        let text = std::str::from_utf8(&bytes).map_err(|_| {
            StageError::new("the structure file is neither JSON text nor a PNG/EXR label image").in_file(0)
        })?;
        analyse_sample(text, config)
    }
    .map_err(|e| StageError::new(e.to_string()).in_file(0))?;
    for w in &s.warnings {
        cx.warn(format!("structure sample: {w}"));
    }
    if s.originals().is_empty() {
        return Err(StageError::new("the structure has no interior region to learn from")
            .in_file(0)
            .with_help("draw closed regions; regions touching the sample border are left out of the statistics unless `exclude_border_regions = false`"));
    }
    Ok(s)
}

/// What S1e works from: the relaxed generators, the surface, and the edits in order.
#[derive(serde::Serialize)]
struct Editing {
    relaxed: In<Relaxed>,
    surface: In<Plane>,
    edits: Vec<Edit>,
    w: usize,
    h: usize,
}

fn apply_edits(cx: &RunCx, s: &Editing) -> Result<Generators, StageError> {
    let r = cx.get(s.relaxed);
    let plane = cx.get(s.surface);
    let allowed = allowed_from_occupancy(plane.occupancy.plane(0));
    let target = Target { width: s.w, height: s.h, allowed: Some(&allowed) };
    let mut g = edits::Generators { ellipses: r.generators.clone(), frozen: r.frozen.clone() };
    for (i, e) in s.edits.iter().enumerate() {
        edits::apply_edit(&mut g, e, &target)
            .map_err(|err| StageError::new(format!("edit {} ({}): {err}", i + 1, edit_name(e))).at_prop("edits"))?;
    }
    let n = g.ellipses.len();
    Ok(Generators { set: g, target_count: n, dropped: 0, courses: None })
}

/// What S3 works from.
#[derive(serde::Serialize)]
struct Polygonizing {
    relaxed: In<Relaxed>,
    params: PolygonizeParams,
}

/// What S4 works from: the polygonised mesh, the sample's originals at the structure's
/// `scale`, and the optimisation's parameters.
#[derive(serde::Serialize)]
struct Shaping {
    mesh: In<Polygonization>,
    analysis: In<SampleStructure>,
    /// The generators Lloyd last ran on: laid courses keep their bricks' shapes.
    generators: In<Generators>,
    /// The generators each region was grown from (the association's priors).
    relaxed: In<Relaxed>,
    scale: f64,
    params: ShapeParams,
    w: usize,
    h: usize,
}

fn optimise_shapes(cx: &RunCx, s: &Shaping) -> Result<Shaped, StageError> {
    let m = cx.get(s.mesh);
    let sample = cx.get(s.analysis);
    let sparams = &s.params;
    // Originals at the structure's scale: the ±20 % area rule compares like with like.
    let regions = sample.original_regions();
    let originals: Vec<Vec<Point>> = regions
        .iter()
        .map(|&r| sample.polygons[r].iter().map(|p| [p[0] * s.scale, p[1] * s.scale]).collect())
        .collect();
    let associated = |all: &[Option<optimize::Association>]| -> Vec<Option<Associated>> {
        all.iter()
            .map(|a| {
                a.as_ref().map(|a| Associated {
                    region: regions[a.original],
                    rotation: a.rotation,
                    distance: a.distance,
                    area_ratio: a.area_ratio,
                })
            })
            .collect()
    };
    // Each region's generator as the final Voronoi step saw it (size map applied).
    let sized = &cx.get(s.relaxed).sized;
    let priors: Vec<Option<optimize::Prior>> = m
        .region_labels
        .iter()
        .map(|&l| sized.get(l as usize).map(|e| optimize::Prior { a: e.a, b: e.b, theta: e.theta }))
        .collect();
    if sparams.max_iters == 0 || cx.get(s.generators).courses.is_some() {
        // Stage 2 is off, or the regions are laid bricks (whose shapes come from the sample
        // already; moving their vertices would bend the courses): the mesh stays as it is,
        // but its regions still learn their closest originals (appearance needs them).
        let found = optimize::associate_mesh(
            &m.mesh,
            &m.on_occupancy_border,
            &m.on_domain_border,
            &originals,
            &priors,
            sparams,
        );
        return Ok(Shaped {
            mesh: m.mesh.clone(),
            placed: vec![None; m.mesh.regions.len()],
            associated: associated(&found),
            errors: vec![],
        });
    }
    let r = optimize::optimize_shapes(
        &m.mesh,
        &m.on_occupancy_border,
        &m.on_domain_border,
        (s.w as f64, s.h as f64),
        &originals,
        &priors,
        sparams,
    );
    if r.fallback_associations > 0 || r.failed_associations > 0 {
        cx.warn(format!(
            "{} region(s) matched an original outside ±{:.0} % area, {} matched none",
            r.fallback_associations,
            sparams.area_tol * 100.0,
            r.failed_associations
        ));
    }
    Ok(Shaped {
        placed: r.associations.iter().map(|a| a.as_ref().map(|a| a.placed.clone())).collect(),
        associated: associated(&r.associations),
        mesh: r.mesh,
        errors: r.errors,
    })
}

fn edit_name(e: &Edit) -> &'static str {
    match e {
        Edit::Insert { .. } => "insert",
        Edit::Delete { .. } | Edit::DeleteAt { .. } => "delete",
        Edit::Freeze { .. } => "freeze",
        Edit::Move { .. } => "move",
        Edit::Set { .. } => "set",
    }
}

/// The declaration's `edits` as algorithm edits; arguments that do not fit together are
/// reported at the call that wrote them.
fn convert_edits(props: &Props) -> Result<Vec<Edit>, Diagnostic> {
    let mut out = Vec::new();
    for call in props.calls("edits") {
        let a = &call.args;
        let id = || a.int("id") as usize;
        let at = |n: &str| -> Point { a.vec2(n) };
        let edit = match call.name.as_str() {
            "insert" => Edit::Insert {
                ellipse: Ellipse { center: at("at"), a: a.num("a"), b: a.num("b"), theta: a.num("angle") },
                frozen: false,
            },
            "delete" => match (a.get("id").is_some(), a.get("at").is_some()) {
                (true, false) => Edit::Delete { id: id() },
                (false, true) => Edit::DeleteAt { point: at("at") },
                _ => {
                    let span = call.span.or(props.span("edits")).expect("edits are written in the scene");
                    return Err(Diagnostic::error("`delete` takes either `id` or `at`")
                        .with_code("tessera::edit")
                        .with_label(span, "give exactly one of them"));
                }
            },
            "freeze" => Edit::Freeze { id: id(), frozen: true },
            "move" => Edit::Move { id: id(), to: at("to") },
            "set" => Edit::Set { id: id(), a: a.opt_num("a"), b: a.opt_num("b"), theta: a.opt_num("angle") },
            other => unreachable!("edit `{other}` is in the schema but not converted"),
        };
        out.push(edit);
    }
    Ok(out)
}

/// How the size map sizes the ellipses (S1 and Lloyd).
fn size_mode(props: &Props) -> SizeMode {
    match spec::SIZE_MODES.get(props.enumeration("size_mode")) {
        spec::SizeModeChoice::Fixed => SizeMode::Fixed { radius: props.num("size_fixed") },
        spec::SizeModeChoice::Scale => SizeMode::Scale { k_min: props.num("size_min") },
    }
}

fn centers(props: &Props) -> spec::Centers {
    spec::CENTERS.get(props.enumeration("centers"))
}

/// What S1 needs from the declaration.
#[derive(Clone, serde::Serialize)]
struct SampleOptions {
    statistical: bool,
    layout: spec::Layout,
    /// The maps given that laid courses ignore (for the warning).
    unsteered: Vec<&'static str>,
    scale: f64,
    centers: spec::Centers,
    joint: bool,
    perturb: f64,
    swaps: f64,
    size_mode: SizeMode,
    remove: RemoveMode,
    density: DensityParams,
}

/// Memory a region costs along the structure's stages: its generator, Lloyd's moments,
/// its polygon and the mesh's vertices and edges, the original placed on it by the shape
/// stage, and their cache encodings.
const REGION_BYTES: f64 = 2048.0;

impl SampleOptions {
    fn from(props: &Props) -> Self {
        SampleOptions {
            statistical: spec::MODES.get(props.enumeration("mode")) == spec::Mode::Statistical,
            layout: spec::LAYOUTS.get(props.enumeration("layout")),
            unsteered: ["density", "size", "orientation", "metric_map"]
                .into_iter()
                .filter(|m| props.reference(m).is_some())
                .collect(),
            scale: props.num("scale"),
            centers: centers(props),
            joint: spec::SHAPE_SAMPLING.get(props.enumeration("shape_sampling")) == spec::Either::Second,
            perturb: props.num("perturb"),
            swaps: props.num("swaps"),
            size_mode: size_mode(props),
            remove: match spec::OCCUPANCY_REMOVE.get(props.enumeration("occupancy_remove")) {
                spec::Either::First => RemoveMode::Center,
                spec::Either::Second => RemoveMode::AnyOverlap,
            },
            density: DensityParams {
                eps: props.num("density_eps") as f32,
                gamma: props.num("density_gamma") as f32,
                invert: false,
            },
        }
    }
}

/// What S1 works from.
#[derive(serde::Serialize)]
struct Sampling {
    analysis: In<SampleStructure>,
    surface: In<Plane>,
    maps: MapInputs,
    w: usize,
    h: usize,
    seed: u64,
    /// The stream course-by-course synthesis draws from.
    courses_seed: u64,
    options: SampleOptions,
}

fn sample_generators(cx: &RunCx, s: &Sampling) -> Result<Generators, StageError> {
    let (o, w, h) = (&s.options, s.w, s.h);
    let sample = cx.get(s.analysis);
    let plane = cx.get(s.surface);
    let maps = prepare_maps(cx, s.maps, w, h)?;
    // Most regions the memory budget holds (`REGION_BYTES` each).
    let max_regions = (cx.budget().bytes as f64 / REGION_BYTES) as usize;
    let controls = Controls {
        density: maps.density.as_deref(),
        density_params: o.density,
        occupancy: Some(plane.occupancy.plane(0)),
        size: maps.size.as_deref(),
        size_mode: o.size_mode,
        ..Controls::default()
    };
    let coursed = &sample.courses;
    let use_courses = match o.layout {
        spec::Layout::Statistical => false,
        spec::Layout::Auto => coursed.layered && o.statistical,
        spec::Layout::Courses if coursed.layered => true,
        spec::Layout::Courses => {
            return Err(StageError::new(format!(
                "`layout = courses` but the sample has no courses: {:.0} % of its interior regions lie in a course, a row of side-by-side regions sharing their top and bottom lines ({} such rows), the detector asks {:.0} % in {} rows",
                coursed.score * 100.0,
                coursed.courses.len(),
                courses::LAYERED_SCORE * 100.0,
                courses::MIN_COURSES
            ))
            .at_prop("layout")
            .with_help("use `layout = auto` (or `statistical`) for an irregular sample; courses are looked for horizontally"));
        }
    };
    if use_courses {
        if !o.unsteered.is_empty() {
            let maps: Vec<String> = o.unsteered.iter().map(|m| format!("`{m}`")).collect();
            cx.warn(format!(
                "the sample is layered and is laid in courses, which {} do{} not steer (`layout = statistical` keeps Lloyd and the maps)",
                maps.join(", "),
                if maps.len() == 1 { "es" } else { "" }
            ));
        }
        let mut rng = Rng::new(s.courses_seed);
        let mut layout = generation_courses::layout_courses(w, h, coursed, o.scale, &mut rng);
        let total = layout.bricks.len();
        if total > max_regions {
            return Err(StageError::new(format!(
                "`scale = {}` lays {total} bricks, more than the memory budget holds ({max_regions})",
                o.scale
            ))
            .at_prop("scale"));
        }
        let allowed = allowed_from_occupancy(plane.occupancy.plane(0));
        let dropped = generation_courses::drop_forbidden_bricks(&mut layout, w, &allowed, o.remove);
        if dropped == total {
            return Err(StageError::new("no brick fits on the surface: the occupancy map forbids them all")
                .with_help("lower `scale` or free more of the surface"));
        }
        return Ok(Generators {
            set: edits::Generators::new(layout.ellipses()),
            target_count: total,
            dropped,
            courses: Some(layout),
        });
    }
    let mut rng = Rng::new(s.seed);
    let originals: Vec<Ellipse> = sample.originals().into_iter().map(|(_, e)| e).collect();
    if !o.statistical {
        // Trivial synthesis: the sample's own regions, mapped onto the target, perturbed
        // and swapped ([references: frasson §3.5.3]).
        let (sx, sy) = (w as f64 / sample.size[0].max(1.0), h as f64 / sample.size[1].max(1.0));
        let all: Vec<Ellipse> = sample
            .ellipses
            .iter()
            .flatten()
            .map(|e| Ellipse { center: [e.center[0] * sx, e.center[1] * sy], a: e.a * o.scale, b: e.b * o.scale, ..*e })
            .collect();
        let moved = synthesis::perturb(&all, o.perturb, 0.0, &mut rng);
        let swapped = synthesis::swap_regions(&moved, (o.swaps * moved.len() as f64).round() as usize, &mut rng);
        let (kept, dropped) = synthesis::drop_forbidden(&swapped, w, h, plane.occupancy.plane(0), o.remove);
        return Ok(Generators { set: edits::Generators::new(kept), target_count: all.len(), dropped, courses: None });
    }
    let model = &sample.model;
    let params = StatisticalParams {
        scale: o.scale,
        mean_area: model.mean_region_area,
        remove: o.remove,
        max_retries: 32,
        max_regions,
    };
    let axes_hist = model.ellipse_axes.histogram.clone();
    let angle_hist = model.ellipse_angle.histogram.clone();
    let mut centre_hist = model.ellipse_center.histogram.clone();
    let mut centre_fn = move |r: &mut Rng| centre_hist.as_mut().map(|hh| hh.sample(r)).unwrap_or([0.0, 0.0]);
    let centers = match o.centers {
        // Uniform over allowed pixels, in proportion to the density weight when S1 was given
        // the density map (uniform without one).
        spec::Centers::Uniform => CenterSource::Density,
        spec::Centers::Histogram if model.ellipse_center.histogram.is_some() => {
            CenterSource::Histogram { sampler: &mut centre_fn, bbox: [[0.0, 0.0], sample.size] }
        }
        // Too few regions for a centre histogram: uniform placement.
        spec::Centers::Histogram => CenterSource::Uniform,
    };
    let synthesized = match (o.joint, axes_hist, angle_hist) {
        (false, Some(axes), Some(angle)) => {
            let mut sampler = synthesis::Independent {
                axes: move |r: &mut Rng| {
                    let p = axes.sample(r);
                    (p[0], p[1])
                },
                angle: move |r: &mut Rng| angle.sample(r),
            };
            synthesis::statistical(w, h, &controls, &mut sampler, centers, &params, &mut rng)
        }
        (joint, axes, angle) => {
            // Joint triples with ±½-bin jitter (or, with too few regions for histograms,
            // a plain bootstrap of the originals).
            let jitter = [
                axes.as_ref().map_or(0.0, |a| a.x.width),
                axes.as_ref().map_or(0.0, |a| a.y.width),
                angle.as_ref().map_or(0.0, |a| a.axis.width),
            ];
            let mode = if joint { ShapeSampling::Joint } else { ShapeSampling::Independent };
            let mut sampler = EmpiricalSampler::new(&originals, mode).with_jitter(jitter);
            synthesis::statistical(w, h, &controls, &mut sampler, centers, &params, &mut rng)
        }
    }
    .map_err(|e| too_many_regions(&e, o))?;
    if synthesized.generators.is_empty() {
        return Err(StageError::new("no region fits on the surface: the occupancy map leaves no room at this scale")
            .with_help("lower `scale` or free more of the surface"));
    }
    Ok(Generators {
        set: edits::Generators { ellipses: synthesized.generators, frozen: synthesized.frozen },
        target_count: synthesized.target_count,
        dropped: synthesized.dropped,
        courses: None,
    })
}

/// `N'` that no label raster or budget can hold, blamed on the property that made it so:
/// `scale` when the regions are too small without the size map, else the size map's setting.
fn too_many_regions(e: &synthesis::TooManyRegions, o: &SampleOptions) -> StageError {
    let n = |v: f64| if v.is_finite() { format!("{v:.3e}") } else { "unboundedly many".to_string() };
    // As a person would write the value: `1e-30`, not thirty zeros.
    let v = |x: f64| if x != 0.0 && !(1e-3..1e6).contains(&x.abs()) { format!("{x:e}") } else { format!("{x}") };
    let over_budget = e.limit < e.pixels;
    let what = if over_budget {
        format!(
            "{} regions need about {} but the memory budget is {}",
            n(e.count),
            crate::graph::budget::Bytes(e.count * REGION_BYTES),
            crate::graph::budget::Bytes(e.limit as f64 * REGION_BYTES)
        )
    } else {
        format!("{} regions on {} allowed pixels: a region cannot be smaller than a pixel", n(e.count), e.pixels)
    };
    if e.unsized_count.is_nan() || e.unsized_count > e.limit as f64 {
        // Regions scale with s², so the smallest scale that fits is s·√(N'/limit).
        let least = o.scale * (e.unsized_count / e.limit.max(1) as f64).sqrt();
        return StageError::new(format!(
            "`scale = {}` makes regions of {:.3e} px² on average: {what}",
            v(o.scale),
            e.region_area
        ))
        .at_prop("scale")
        .with_help(format!("use `scale` of at least {least:.3e}"));
    }
    match o.size_mode {
        SizeMode::Scale { k_min } => StageError::new(format!(
            "the size map shrinks regions to {} of their size at black (`size_min = {}`): {what}",
            v(k_min),
            v(k_min)
        ))
        .at_prop("size_min")
        .with_help("raise `size_min`, or lighten the size map"),
        SizeMode::Fixed { radius } => StageError::new(format!(
            "`size_fixed = {} px` makes regions of {:.3e} px² in the size map's dark half: {what}",
            v(radius),
            std::f64::consts::PI * radius * radius
        ))
        .at_prop("size_fixed")
        .with_help("raise `size_fixed` (a region of one pixel has a mean radius of 0.56 px)"),
    }
}

/// What S2 works from.
#[derive(serde::Serialize)]
struct Relaxing {
    generators: In<Generators>,
    surface: In<Plane>,
    maps: MapInputs,
    w: usize,
    h: usize,
    lloyd: LloydParams,
    density: DensityParams,
    orientation_mode: OrientationMode,
    size_mode: SizeMode,
}

/// S2 (and S2 after edits): anisotropic Lloyd over the generators `from` (sampled or edited).
fn plan_lloyd(
    p: &mut Planner,
    d: &Decl,
    from: Handle<Generators>,
    surface: Handle<Plane>,
    w: usize,
    h: usize,
    tag: &str,
) -> Handle<Relaxed> {
    let props = &d.props;
    let block = props.block("lloyd");
    let lloyd = LloydParams {
        max_iters: block.int("iterations") as usize,
        tol: block.num("tolerance"),
        resolution: block.num("resolution"),
        rotate: block.bool("rotate"),
        metric: metric_kind(props.enumeration("metric")),
        ..LloydParams::default()
    };
    let density =
        DensityParams { eps: props.num("density_eps") as f32, gamma: props.num("density_gamma") as f32, invert: false };
    let orientation_mode = match spec::ORIENTATION_MODES.get(props.enumeration("orientation_mode")) {
        spec::Either::First => OrientationMode::Region,
        spec::Either::Second => OrientationMode::Center,
    };
    let mut inputs = Inputs::new();
    let (generators, surface) = (inputs.add(from), inputs.add(surface));
    let maps = MapInputs::add(
        p,
        props,
        &mut inputs,
        &[MapProp::Density, MapProp::Orientation, MapProp::Metric, MapProp::Size],
    );
    let relaxing =
        Relaxing { generators, surface, maps, w, h, lloyd, density, orientation_mode, size_mode: size_mode(props) };
    let stage = FnStage::keyed("structure.lloyd", 5, relaxing, relax);
    p.add(format!("structure {} ({tag})", d.name), stage, inputs, vec![])
}

fn relax(cx: &RunCx, s: &Relaxing) -> Result<Relaxed, StageError> {
    let g = cx.get(s.generators);
    let plane = cx.get(s.surface);
    if let Some(layout) = &g.courses {
        // Laid courses: their bricks are the regions, cut by the occupancy map.
        let allowed = allowed_from_occupancy(plane.occupancy.plane(0));
        let (labels, ellipses) = generation_courses::rasterize_courses(layout, s.w, s.h, Some(&allowed));
        return Ok(Relaxed {
            frozen: vec![false; ellipses.len()],
            sized: ellipses.clone(),
            generators: ellipses,
            labels,
            iterations: vec![],
            converged: true,
            orphans: vec![],
        });
    }
    let m = prepare_maps(cx, s.maps, s.w, s.h)?;
    let report = |done, total| cx.progress(done, total);
    let controls = Controls {
        density: m.density.as_deref(),
        density_params: s.density,
        occupancy: Some(plane.occupancy.plane(0)),
        orientation: m.orientation.as_ref(),
        orientation_mode: s.orientation_mode,
        metric: m.metric.as_deref(),
        size: m.size.as_deref(),
        size_mode: s.size_mode,
        progress: Progress::new(&report),
    };
    let r = lloyd::lloyd(s.w, s.h, &g.set.ellipses, Some(&g.set.frozen), &controls, &s.lloyd);
    Ok(Relaxed {
        generators: r.generators,
        sized: r.sized,
        frozen: r.frozen,
        labels: r.labels,
        iterations: r.iterations,
        converged: r.converged,
        orphans: r.orphans,
    })
}

/// The structure kind: structure synthesis from an example.
pub struct Structure;

impl super::Kind for Structure {
    fn spec(&self) -> &'static crate::lang::KindSpec {
        &SPEC
    }

    fn plan(&self, p: &mut Planner, d: &Decl) -> Result<Option<AnyHandle>, Diagnostic> {
        plan(p, d).map(|h| Some(h.erase()))
    }

    fn plan_output(&self, p: &mut Planner, out: &super::OutputRequest) -> Result<Option<super::ViewNode>, Diagnostic> {
        use super::View;
        let d = out.decl;
        // Region ids and their colours are identities: an id off by one is a regression.
        let exact =
            matches!(out.view, View::Labels | View::Labels16) || (out.view == View::Auto && !out.format.is_text());
        let node = plan_output(p, d, out.from, out.format, out.view, d.props.num("edge_width"))?;
        Ok(Some(super::ViewNode { node, exact, more: Vec::new() }))
    }
}
