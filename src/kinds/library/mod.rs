//! `library`: a directory of texture samples with their features, and `similar(...)`, the
//! query that ranks them against a sample ([references: welsman-dinelle §4.1, §4.3]).
//!
//! ```text
//! each file ─► library.features ─┐
//!                                ├─► library.index ─┐
//! target sample ─► library.target ──────────────────┴─► library.query ─► library.pick
//! ```
//!
//! Features are cached per file, so touching one file recomputes its features and the
//! queries, nothing else.

use std::path::PathBuf;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::{Bytes, ColorSpace, Encoded, FnStage, Planner};
use crate::graph::{AnyHandle, Handle, In, Inputs, RunCx, StageError};
use crate::lang::ir::Call;
use crate::lang::schema::{CallSpec, Default, Extent, KindSpec, Naming, PropSpec, Range, Ty, Unit, Value};
use crate::lang::{Decl, Diagnostic, Val};
use crate::raster::{self, Image};
use crate::synth::blend::mask::Luma;
use crate::synth::library::{
    self as lib, Axis, FeatureParams, Features, FourierMode, HistogramNorm, Normalise, QueryParams,
};

const fn prop(name: &'static str, ty: Ty, default: Default, doc: &'static str) -> PropSpec {
    PropSpec { name, ty, default, doc }
}

/// Image files a library reads.
pub const EXTENSIONS: &[&str] = &["png", "exr"];

crate::choices!(pub LUMAS: Luma { "mean" => Luma::Mean, "rec601" => Luma::Rec601, "rec709" => Luma::Rec709 });
crate::choices!(
    /// `off`: no Fourier axis.
    pub FOURIER: Option<FourierMode> {
        "reim" => Some(FourierMode::ReIm), "modulus" => Some(FourierMode::Modulus),
        "magnitude" => Some(FourierMode::Magnitude), "radial" => Some(FourierMode::Radial), "off" => None
    }
);
crate::choices!(pub NORMALISE: Normalise { "per_query_max" => Normalise::PerQueryMax, "fixed" => Normalise::Fixed });

pub static SPEC: KindSpec = KindSpec {
    name: "library",
    doc: "A texture library: every PNG or EXR image in a directory, with colour-histogram and Fourier features computed once per file. Queried with `similar(...)`.",
    naming: Naming::Ident,
    produces: &[Value::Library],
    settings: &[],
    extent: Extent::None,
    props: &[
        prop("dir", Ty::Dir(EXTENSIONS), Default::Required, "The directory, relative to this scene file (not recursive)."),
        prop(
            "bins",
            Ty::Int(2, 64),
            Default::Text("32"),
            "Colour histogram bins per RGB axis (32 in the thesis: 32³ bins).",
        ),
        prop(
            "size",
            Ty::Int(8, 1024),
            Default::Text("128"),
            "Side of the square analysis image of the Fourier features, a power of two; images are box-resampled to it.",
        ),
        prop(
            "luma",
            Ty::Enum(LUMAS.names),
            Default::Text("mean"),
            "Grey formula for the Fourier features (thesis: the plain mean).",
        ),
    ],
};

/// Where a sample can come from besides a file: `similar(lib, to = sample, ...)`.
pub static SAMPLE_SOURCES: &[CallSpec] = &[CallSpec {
    name: "similar",
    doc: "The library entry nearest to a sample (Welsman-Dinelle Eq. 4.5): per enabled axis the distance to every entry, scaled to [0, 1], combined as sqrt(Σ d̂²); then `k` candidates drawn with `randomness` (seeded) and the `pick`-th taken.",
    args: &[
        prop("library", Ty::Ref(&[Value::Library]), Default::Required, "The library to search."),
        prop("to", Ty::Ref(&[Value::Image]), Default::Required, "The image to match (a sample or a layer)."),
        prop("k", Ty::Int(1, 1000), Default::Text("8"), "Size of the candidate set."),
        prop(
            "randomness",
            Ty::Number(Unit::Plain, Range { min: 0.0, max: 1.0 }),
            Default::Text("0"),
            "0: the k nearest in order; 1: k drawn uniformly; between: weights exp(−d̂/τ), τ = ρ/(1 − ρ).",
        ),
        prop("pick", Ty::Int(1, 1000), Default::Text("1"), "Which candidate (1 = first) becomes the sample."),
        prop("colour", Ty::Bool, Default::Text("true"), "Compare colour histograms (Eq. 4.2)."),
        prop(
            "fourier",
            Ty::Enum(FOURIER.names),
            Default::Text("reim"),
            "Compare spectra: real and imaginary parts (the thesis), complex modulus, magnitude only (shift invariant), radial profile (rotation robust), or not at all.",
        ),
        prop("orientation", Ty::Bool, Default::Text("false"), "Also compare the dominant orientations (Chandra)."),
        prop(
            "normalise",
            Ty::Enum(NORMALISE.names),
            Default::Text("per_query_max"),
            "Scale each axis by this query's largest distance (the thesis), or by a bound independent of the library.",
        ),
        prop("seed", Ty::Int(0, 1 << 53), Default::Absent, "An explicit seed instead of the one derived from the scene's."),
    ],
}];

/// Every entry's features, in file-name order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Index {
    pub names: Vec<String>,
    pub features: Vec<Features>,
}

/// A query's answer: the candidates in draw order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ranking {
    pub target: String,
    pub axes: Vec<String>,
    pub candidates: Vec<Candidate>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    pub name: String,
    /// Position in the library (file-name order).
    pub index: usize,
    pub distance: f64,
    /// Normalised distance per axis, in `Ranking::axes` order.
    pub axes: Vec<f64>,
    pub raw: Vec<f64>,
}

macro_rules! json_artifact {
    ($t:ty) => {
        impl Encoded for $t {
            fn encode(&self) -> Vec<u8> {
                serde_json::to_vec(self).expect("serialises")
            }

            fn decode(bytes: &[u8]) -> Result<Self, String> {
                serde_json::from_slice(bytes).map_err(|e| e.to_string())
            }
        }
    };
}
json_artifact!(Features);
json_artifact!(Index);
json_artifact!(Ranking);

fn feature_params(d: &Decl) -> FeatureParams {
    FeatureParams {
        bins: d.props.int("bins") as usize,
        size: d.props.int("size") as usize,
        resample: true,
        luma: LUMAS.get(d.props.enumeration("luma")),
        ..FeatureParams::default()
    }
}

pub fn plan(p: &mut Planner, d: &Decl) -> Result<Handle<Index>, Diagnostic> {
    let size = d.props.int("size");
    if size & (size - 1) != 0 {
        return Err(Diagnostic::error(format!("the Fourier analysis size must be a power of two, not {size}"))
            .with_code("tessera::library")
            .with_label(d.props.span("size").unwrap_or(d.name_span), "here")
            .with_help(format!("try `size = {}`", (size as u64).next_power_of_two() / 2)));
    }
    let (_, files) = d.props.dir("dir").expect("required");
    let files: Vec<PathBuf> = files.to_vec();
    let span = d.props.span("dir").unwrap_or(d.name_span);
    let params = feature_params(d);
    let mut inputs = Inputs::new();
    let mut names = Vec::with_capacity(files.len());
    let mut features = Vec::with_capacity(files.len());
    for f in &files {
        let name = crate::graph::files::name_of(f);
        let stage = features_stage(params);
        let node = p.add(format!("library {} ({name})", d.name), stage, Inputs::new(), vec![(f.clone(), span)]);
        features.push(inputs.add(node));
        names.push(name);
    }
    Ok(p.add(format!("library {}", d.name), index_stage(Indexing { names, features }), inputs, vec![]))
}

/// The `library.features` stage of one file. Scenes and `tessera similar` build it here
/// alike, so they share cached features.
fn features_stage(params: FeatureParams) -> FnStage<Features> {
    FnStage::keyed("library.features", 2, params, |cx, params| {
        let shown = cx.file_name(0);
        let img = decode_entry(&cx.file(0)?, &shown, cx.budget())?;
        lib::features(&img, params).map_err(|e| StageError::new(format!("`{shown}`: {e}")).in_file(0))
    })
}

/// What the `library.index` stage gathers: the entries' names and features, in order.
#[derive(Serialize)]
struct Indexing {
    names: Vec<String>,
    features: Vec<In<Features>>,
}

fn index_stage(indexing: Indexing) -> FnStage<Index> {
    FnStage::keyed("library.index", 2, indexing, |cx, ix| {
        let features = ix.features.iter().map(|&f| (*cx.get(f)).clone()).collect();
        Ok(Index { names: ix.names.clone(), features })
    })
}

/// What the `library.query` stage ranks: an index against a target's features; a bad
/// query is blamed on `blame` when a scene property set it.
#[derive(Serialize)]
struct Querying {
    index: In<Index>,
    target: In<Features>,
    query: QueryParams,
    k: usize,
    randomness: f64,
    seed: u64,
    to: String,
    blame: Option<&'static str>,
}

fn query_stage(querying: Querying) -> FnStage<Ranking> {
    FnStage::keyed("library.query", 2, querying, run_query)
}

fn run_query(cx: &RunCx, q: &Querying) -> Result<Ranking, StageError> {
    let index = cx.get(q.index);
    let target = cx.get(q.target);
    let chosen = lib::query(&index.features, &target, &q.query, q.k, q.randomness, q.seed).map_err(|e| {
        let e = StageError::new(e.to_string());
        match q.blame {
            Some(prop) => e.at_prop(prop),
            None => e,
        }
    })?;
    Ok(Ranking {
        target: q.to.clone(),
        axes: q.query.axes.iter().map(axis_name).collect(),
        candidates: chosen
            .into_iter()
            .map(|r| Candidate {
                name: index.names[r.index].clone(),
                index: r.index,
                distance: r.distance,
                axes: r.axes,
                raw: r.raw,
            })
            .collect(),
    })
}

/// A library file as the features see it: 8-bit-style encoded values (EXR is linear and
/// is encoded to sRGB first), all values finite.
fn decode_entry(bytes: &[u8], name: &str, budget: crate::graph::Budget) -> Result<Image, StageError> {
    let img = super::decode_image(bytes, budget)
        .map_err(|e| StageError::new(format!("cannot decode `{name}`: {e}")).in_file(0))?;
    let bad = img.data.iter().filter(|v| !v.is_finite()).count();
    if bad > 0 {
        return Err(StageError::new(format!("`{name}` holds {bad} NaN or infinite value(s)")).in_file(0));
    }
    Ok(if raster::io::is_exr(bytes) { raster::color::image_linear_to_srgb(&img) } else { img })
}

/// Plans `similar(...)` for sample `d`: returns the query node; the caller picks the image.
pub fn plan_similar(p: &mut Planner, d: &Decl, call: &Call) -> Result<(Handle<Ranking>, Vec<PathBuf>), Diagnostic> {
    let a = &call.args;
    let library = a.str("library").to_string();
    let to = a.str("to").to_string();
    let lib_decl = p.decl(&library);
    let (_, files) = lib_decl.props.dir("dir").expect("required");
    let files = files.to_vec();
    let params = feature_params(lib_decl);
    let mut inputs = Inputs::new();
    let image = inputs.add(p.value(&to, a.span("to").unwrap_or(d.name_span))?);
    let targeting = Targeting { image, features: params, color: p.color_space(&to) };
    let stage = FnStage::keyed("library.target", 2, targeting, target_features);
    let target = p.add(format!("sample {} (features of {to})", d.name), stage, inputs, vec![]);

    let mut axes = Vec::new();
    if a.bool("colour") {
        axes.push(Axis::Colour);
    }
    if let Some(mode) = FOURIER.get(a.enumeration("fourier")) {
        axes.push(Axis::Fourier(mode));
    }
    if a.bool("orientation") {
        axes.push(Axis::Orientation);
    }
    if axes.is_empty() {
        return Err(Diagnostic::error("`similar` compares nothing: every axis is off")
            .with_code("tessera::library")
            .with_label(call.span.unwrap_or(d.name_span), "here")
            .with_help("enable `colour`, `fourier` or `orientation`"));
    }
    let k = a.int("k") as usize;
    let pick = a.int("pick") as usize;
    if pick > k {
        return Err(Diagnostic::error(format!("`pick = {pick}` is beyond the {k} candidates"))
            .with_code("tessera::library")
            .with_label(a.span("pick").unwrap_or(d.name_span), "here"));
    }
    let randomness = a.num("randomness");
    let seed = match a.get("seed") {
        Some(Val::Int(s)) => *s as u64,
        _ => p.seed(d, "library.similar"),
    };
    let query = QueryParams {
        axes,
        normalise: NORMALISE.get(a.enumeration("normalise")),
        // Fractions, not counts: library entries and the target need not have one size.
        histogram: HistogramNorm::Fraction,
        exclude: None,
    };
    let mut inputs = Inputs::new();
    let (index, target) = (inputs.add(p.result(&library)), inputs.add(target));
    let querying = Querying { index, target, query, k, randomness, seed, to, blame: Some("from") };
    let node = p.add(format!("sample {} (query)", d.name), query_stage(querying), inputs, vec![]);
    Ok((node, files))
}

/// What `library.target` works from: the target image, in its colour space.
#[derive(Serialize)]
struct Targeting {
    image: In<Image>,
    features: FeatureParams,
    color: ColorSpace,
}

fn target_features(cx: &RunCx, t: &Targeting) -> Result<Features, StageError> {
    let img = cx.get(t.image);
    let encoded = match t.color {
        ColorSpace::Linear => raster::color::image_linear_to_srgb(&img),
        ColorSpace::Lab => raster::color::image_linear_to_srgb(&raster::color::image_lab_to_linear(&img)),
        ColorSpace::Srgb => (*img).clone(),
    };
    lib::features(&encoded, &t.features).map_err(|e| StageError::new(e.to_string()).at_prop("from"))
}

pub fn axis_name(a: &Axis) -> String {
    match a {
        Axis::Colour => "colour".into(),
        Axis::Fourier(m) => format!("fourier.{}", format!("{m:?}").to_lowercase()),
        Axis::Orientation => "orientation".into(),
    }
}

/// A ranking as the JSON a `.json` output of the sample holds.
pub fn ranking_json(r: &Ranking) -> Bytes {
    let mut value = serde_json::to_value(r).expect("serialises");
    crate::synth::structure::analysis::stats::round_json(&mut value, 1e-9);
    let mut text = serde_json::to_string_pretty(&value).expect("serialises");
    text.push('\n');
    Bytes(text.into_bytes())
}

/// The candidate `pick` (1-based) of a ranking, read from the stage's files (the
/// library's, in its order).
pub fn pick_bytes(cx: &RunCx, ranking: &Arc<Ranking>, pick: usize) -> Result<(Arc<[u8]>, usize), StageError> {
    let c = ranking.candidates.get(pick - 1).ok_or_else(|| {
        StageError::new(format!(
            "the query found only {} candidate(s), so there is no number {pick}",
            ranking.candidates.len()
        ))
        .at_prop("from")
    })?;
    debug_assert!(c.index < cx.file_count());
    Ok((cx.file(c.index)?, c.index))
}

/// The library kind: a directory of textures indexed for search.
pub struct Library;

impl super::Kind for Library {
    fn spec(&self) -> &'static crate::lang::KindSpec {
        &SPEC
    }

    fn plan(&self, p: &mut Planner, d: &Decl) -> Result<Option<AnyHandle>, Diagnostic> {
        plan(p, d).map(|h| Some(h.erase()))
    }
}

/// `tessera similar DIR TARGET`: a library query outside any scene.
pub struct Standalone {
    /// The directory's entries, as [`entries`] lists them.
    pub files: Vec<PathBuf>,
    pub target: PathBuf,
    pub bins: usize,
    pub size: usize,
    pub axes: Vec<Axis>,
    pub normalise: Normalise,
    pub k: usize,
    pub randomness: f64,
    pub seed: u64,
}

/// The image files of a library directory as a scene's `dir` lists them: regular files
/// with one of `EXTENSIONS` (any case), sorted by name.
pub fn entries(world: &crate::graph::World, dir: &std::path::Path) -> std::io::Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = world
        .list(dir)?
        .into_iter()
        .filter(|f| {
            f.extension().and_then(|e| e.to_str()).is_some_and(|e| EXTENSIONS.iter().any(|x| x.eq_ignore_ascii_case(e)))
        })
        .collect();
    files.sort();
    Ok(files)
}

/// Plans a [`Standalone`] query into `graph` and returns its `library.query` node, whose
/// inputs are the index and the target's features. The stages are those `plan` and
/// `plan_similar` add, with their kinds, versions and keys, so a directory ranked from the
/// command line and a scene's library of it share cached features. The target is read as
/// an entry is (`library.features` of its file, not a `sample`), as the command always has;
/// errors name files by their full paths, as the command's always have.
pub fn plan_standalone(graph: &mut crate::graph::Graph, q: Standalone) -> Handle<Ranking> {
    let params =
        FeatureParams { bins: q.bins, size: q.size, resample: true, luma: Luma::Mean, ..FeatureParams::default() };
    let features = |graph: &mut crate::graph::Graph, file: &PathBuf, label: String| {
        graph.add_typed(label, features_stage(params), Inputs::new(), vec![file.clone()], 0)
    };
    let names: Vec<String> = q.files.iter().map(|f| crate::graph::files::name_of(f)).collect();
    let nodes: Vec<Handle<Features>> =
        q.files.iter().zip(&names).map(|(f, name)| features(graph, f, format!("library ({name})"))).collect();
    let target = match q.files.iter().position(|f| *f == q.target) {
        Some(i) => nodes[i],
        None => features(graph, &q.target, format!("target {}", q.target.display())),
    };
    let mut inputs = Inputs::new();
    let indexing = Indexing { names, features: inputs.add_all(nodes) };
    let index = graph.add_typed("library".into(), index_stage(indexing), inputs, vec![], 0);
    let query = QueryParams { axes: q.axes, normalise: q.normalise, histogram: HistogramNorm::Fraction, exclude: None };
    let mut inputs = Inputs::new();
    let querying = Querying {
        index: inputs.add(index),
        target: inputs.add(target),
        query,
        k: q.k,
        randomness: q.randomness,
        seed: q.seed,
        to: q.target.display().to_string(),
        blame: None,
    };
    graph.add_typed("similar (query)".into(), query_stage(querying), inputs, vec![], 0)
}
