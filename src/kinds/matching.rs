//! `match`: the shader of the library, and its parameters, that reproduce a target image
//! [references: bourque §4]. The result is a match record (`.toml`), a scene declaration that
//! renders the match (`.tess`: a matched photo becomes a versioned procedural texture) and the
//! target beside the match (`.png`).
//!
//! ```text
//! shader A ─► match.catalogue ─┐   (one per candidate, shared by every match in the cache)
//! shader B ─► match.catalogue ─┤
//! target ───► match.target ────┴─► match.search ─► record, snippet, side by side
//! ```
//!
//! A catalogue keys on its shader's name and code version, the canonical side, the metric and
//! the sampling constants, never on the target: a second photo, or a new residual, reuses
//! every catalogue, and a shader whose code changes rebuilds only its own.

use serde::{Deserialize, Serialize};

use super::artifact::{pack, unpack};
use super::{Bytes, Encoded, FnStage, OutputFormat, Planner};
use std::sync::LazyLock;

use super::shader::SEARCH_CALLS;
use crate::graph::{AnyHandle, Handle, In, Inputs, RunCx, StageError};
use crate::lang::schema::{Default, Extent, KindSpec, Naming, PropSpec, Range, Ty, Unit, Value};
use crate::lang::{Decl, Diagnostic};
use crate::raster::Image;
use crate::synth::matching::{
    build_catalogue, feature, match_target, AxisOverride, Candidate, Catalogue, CatalogueConfig, Feature, MatchConfig,
    MatchRecord, Metric, Optimiser, Probe, Pruning, Space,
};
use crate::synth::metrics::{PowerFeature, PowerParams, PyramidParams};
use crate::synth::shader::{self as lib, ParamKind, ShaderDef};

#[derive(Clone, Copy)]
pub(super) enum MetricChoice {
    Power,
    LogPower,
    Pyramid,
}

crate::choices!(pub(super) METRICS: MetricChoice {
    "power" => MetricChoice::Power, "log_power" => MetricChoice::LogPower, "pyramid" => MetricChoice::Pyramid
});

crate::choices!(PRUNINGS: Pruning {
    "redundancy" => Pruning::Redundancy, "coverage" => Pruning::Coverage
});

crate::choices!(OPTIMISERS: Optimiser {
    "simplex" => Optimiser::Simplex, "gradient" => Optimiser::Gradient
});

pub(super) fn metric(choice: MetricChoice) -> Metric {
    match choice {
        MetricChoice::Power => Metric::Power(PowerParams::default()),
        MetricChoice::LogPower => Metric::Power(PowerParams::log_power()),
        MetricChoice::Pyramid => Metric::Pyramid(PyramidParams::default()),
    }
}

const fn prop(name: &'static str, ty: Ty, default: Default, doc: &'static str) -> PropSpec {
    PropSpec { name, ty, default, doc }
}

pub static SPEC: LazyLock<KindSpec> = LazyLock::new(|| {
    KindSpec {
    name: "match",
    doc: "The built-in shader and parameters that best reproduce a target image (Bourque 2005): every candidate shader's catalogue (renders spread over its parameter space by adaptive random sampling, cached apart from any target) is scanned for the renders nearest the target, a bounded downhill simplex refines the best of each shader and the best others, and whole-number parameters are swept. The result is `matched` when its calibrated similarity reaches `residual`, else `no good match`. Written as a record (`.toml`), a `shader` declaration reproducing it (`.tess`) or the target beside the match (`.png`).",
    naming: Naming::Ident,
    produces: &[Value::Match],
    settings: &[],
    extent: Extent::None,
    props: Box::leak(Box::new([
        prop("target", Ty::Ref(&[Value::Image]), Default::Required, "The image to reproduce; its centred square is compared, resampled to `side`."),
        prop("candidates", Ty::Str, Default::Absent, "The shaders to try, by name, separated by commas or spaces (`\"brick, weave\"`); every library shader when absent."),
        prop("metric", Ty::Enum(METRICS.names), Default::Text("power"), "How renders are compared: `power` (the 2-D power spectrum S_F, sensitive to orientation, blind to position), `log_power` (its log-power variant, each spectrum scaled to unit length) or `pyramid` (Laplacian-pyramid histograms S_L)."),
        prop("side", Ty::Int(16, 256), Default::Text("128"), "Pixels across the canonical square renders and the target are compared at (at most 256, the thesis's renders: every catalogue holds a spectrum of side² / 2 numbers per render)."),
        prop("seeds", Ty::Int(0, 64), Default::Text("8"), "Local searches beyond one from each candidate's best catalogue render."),
        prop("optimiser", Ty::Enum(OPTIMISERS.names), Default::Text("simplex"), "The local search refining each seed: `simplex` (bounded Nelder–Mead, at most 100 iterations, the thesis's choice) or `gradient` (Polak–Ribière conjugate gradients on central differences with bounded Brent line searches, at most 30 iterations, 2 renders per searched parameter per gradient: the thesis's alternative for unforgiving cases)."),
        prop("residual", Ty::Number(Unit::Plain, Range { min: 0.0, max: 1.0 }), Default::Text("0.8"), "Calibrated similarity below which the result is `no good match` (1: identical; 1/e: as alike as two unrelated renders of the library)."),
        prop("accept", Ty::Number(Unit::Plain, Range { min: 0.0, max: 1.0 }), Default::Absent, "Stop searching as soon as a result reaches this calibrated similarity (fewer renders, maybe not the best match)."),
        prop("catalogue", Ty::Int(8, 2000), Default::Text("160"), "Renders kept in each shader's catalogue after pruning."),
        prop("pruning", Ty::Enum(PRUNINGS.names), Default::Text("redundancy"), "Which renders a catalogue over its size drops: `redundancy` (the thesis's Eq. 4.5: the renders most similar to all others, all at once; it keeps a shader's unusual looks, which photographs often need) or `coverage` (one at a time, the one whose loss costs the catalogue's coverage of the renders it has seen least: it covers random renders of the shader better than as many random renders do, and keeps fewer unusual looks)."),
        prop("search", Ty::Calls(*SEARCH_CALLS), Default::Text("[]"), "Narrower search ranges for candidate shaders, one call per shader: `search = [brick(width = [0.1, 0.4], mortar = [0.01, 0.01])]` searches the brick's width over [0.1, 0.4] and fixes its mortar at 0.01; a parameter the shader does not search by default is searched when given a range. A shader's catalogue is built over its ranges, so editing one shader's ranges rebuilds only its catalogue and the search."),
    ])),
}
});

/// One shader's catalogue as a cached artifact.
pub struct ShaderCatalogue(pub Catalogue<Feature>);

/// A feature without its power vector (packed apart, as raw floats).
#[derive(Serialize, Deserialize)]
enum FeatureHead {
    Power { side: usize, params: PowerParams },
    Pyramid(crate::synth::metrics::PyramidFeature),
}

fn split(f: &Feature) -> (FeatureHead, Option<Image>) {
    match f {
        Feature::Power(p) => {
            let img = Image { width: p.weighted.len(), height: 1, channels: 1, data: p.weighted.clone() };
            (FeatureHead::Power { side: p.side, params: p.params }, Some(img))
        }
        Feature::Pyramid(p) => (FeatureHead::Pyramid(p.clone()), None),
    }
}

fn join(head: FeatureHead, vectors: &mut impl Iterator<Item = Image>) -> Result<Feature, String> {
    Ok(match head {
        FeatureHead::Power { side, params } => {
            let v = vectors.next().ok_or("a power feature without its vector")?;
            Feature::Power(PowerFeature { side, params, weighted: v.data })
        }
        FeatureHead::Pyramid(p) => Feature::Pyramid(p),
    })
}

fn encode_features(features: &[Feature]) -> (Vec<FeatureHead>, Vec<Image>) {
    let (heads, vectors): (Vec<_>, Vec<_>) = features.iter().map(split).unzip();
    (heads, vectors.into_iter().flatten().collect())
}

fn decode_features(heads: Vec<FeatureHead>, vectors: Vec<Image>) -> Result<Vec<Feature>, String> {
    let mut it = vectors.into_iter();
    heads.into_iter().map(|h| join(h, &mut it)).collect()
}

impl Encoded for ShaderCatalogue {
    fn encode(&self) -> Vec<u8> {
        let c = &self.0;
        let (heads, vectors) = encode_features(&c.features);
        let meta = Catalogue {
            points: c.points.clone(),
            features: heads,
            calibration: c.calibration,
            weights: c.weights.clone(),
            roughness: c.roughness.clone(),
            screen: c.screen.clone(),
            rounds: c.rounds.clone(),
            kappa: c.kappa,
            features_computed: c.features_computed,
            comparisons: c.comparisons,
        };
        pack(&meta, &vectors.iter().collect::<Vec<_>>())
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let (meta, vectors): (Catalogue<FeatureHead>, _) = unpack(bytes)?;
        let features = decode_features(meta.features, vectors)?;
        Ok(ShaderCatalogue(Catalogue {
            points: meta.points,
            features,
            calibration: meta.calibration,
            weights: meta.weights,
            roughness: meta.roughness,
            screen: meta.screen,
            rounds: meta.rounds,
            kappa: meta.kappa,
            features_computed: meta.features_computed,
            comparisons: meta.comparisons,
        }))
    }
}

/// The target's feature.
pub struct TargetFeature(pub Feature);

impl Encoded for TargetFeature {
    fn encode(&self) -> Vec<u8> {
        let (heads, vectors) = encode_features(std::slice::from_ref(&self.0));
        pack(&heads, &vectors.iter().collect::<Vec<_>>())
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let (heads, vectors) = unpack(bytes)?;
        let mut f = decode_features(heads, vectors)?;
        f.pop().map(TargetFeature).ok_or_else(|| "an empty target feature".to_string())
    }
}

/// The result of a match: the record, and what a render of it needs.
#[derive(Serialize, Deserialize)]
pub struct Matched {
    pub record: MatchRecord,
    pub seed: u64,
    pub side: usize,
}

impl Encoded for Matched {
    fn encode(&self) -> Vec<u8> {
        serde_json::to_vec(self).expect("a match serialises")
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        serde_json::from_slice(bytes).map_err(|e| e.to_string())
    }
}

/// A shader's search narrowed by a match's `search`: its fixed values and changed axes.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub(super) struct Narrowed {
    base: Vec<f64>,
    overrides: Vec<AxisOverride>,
}

/// The search space of `def`: its default one, or as narrowed.
fn space_of(def: &'static ShaderDef, narrowed: Option<&Narrowed>) -> Result<Space, StageError> {
    match narrowed {
        None => Ok(Space::new(def)),
        Some(n) => {
            Space::with(def, n.base.clone(), &n.overrides).map_err(|e| StageError::new(e.to_string()).at_prop("search"))
        }
    }
}

#[derive(Serialize)]
struct CatalogueKey {
    shader: &'static str,
    version: u32,
    side: usize,
    metric: Metric,
    config: CatalogueConfig,
    seed: u64,
    /// Absent for the default search, so those catalogues keep their keys.
    #[serde(skip_serializing_if = "Option::is_none")]
    narrowed: Option<Narrowed>,
}

fn run_catalogue(_: &RunCx, k: &CatalogueKey) -> Result<ShaderCatalogue, StageError> {
    let def = lib::shader(k.shader).expect("planned from the library");
    let space = space_of(def, k.narrowed.as_ref())?;
    let probe = Probe { space: &space, seed: k.seed, side: k.side, metric: k.metric };
    Ok(ShaderCatalogue(build_catalogue(&probe, &k.config, k.seed)))
}

#[derive(Serialize)]
struct TargetKey {
    image: In<Image>,
    side: usize,
    metric: Metric,
}

/// The target's canonical square, or a diagnostic at `target`.
fn canonical(img: &Image, side: usize) -> Result<Image, StageError> {
    crate::synth::matching::canonical(img, side).map_err(|e| StageError::new(e.to_string()).at_prop("target"))
}

fn run_target(cx: &RunCx, k: &TargetKey) -> Result<TargetFeature, StageError> {
    let img = canonical(&cx.get(k.image), k.side)?;
    Ok(TargetFeature(feature(&img, &k.metric)))
}

#[derive(Serialize)]
struct SearchKey {
    target: In<TargetFeature>,
    catalogues: Vec<(&'static str, In<ShaderCatalogue>)>,
    side: usize,
    metric: Metric,
    seed: u64,
    config: MatchConfig,
    /// The candidates whose search `search` narrowed.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    narrowed: Vec<(&'static str, Narrowed)>,
}

fn run_search(cx: &RunCx, k: &SearchKey) -> Result<Matched, StageError> {
    let target = cx.get(k.target);
    let spaces = k
        .catalogues
        .iter()
        .map(|(s, _)| {
            let narrowed = k.narrowed.iter().find(|(n, _)| n == s).map(|(_, n)| n);
            space_of(lib::shader(s).expect("library"), narrowed)
        })
        .collect::<Result<Vec<Space>, _>>()?;
    let catalogues: Vec<_> = k.catalogues.iter().map(|(_, h)| cx.get(*h)).collect();
    let cands: Vec<Candidate> = spaces
        .iter()
        .zip(&catalogues)
        .map(|(space, c)| Candidate {
            probe: Probe { space, seed: k.seed, side: k.side, metric: k.metric },
            catalogue: &c.0,
        })
        .collect();
    let record =
        match_target(&target.0, &cands, &k.config).map_err(|e| StageError::new(e.to_string()).at_prop("candidates"))?;
    Ok(Matched { record, seed: k.seed, side: k.side })
}

/// The shaders a match may find: its candidates.
pub(super) fn candidate_shaders(d: &Decl) -> Result<Vec<&'static ShaderDef>, Diagnostic> {
    candidates(d)
}

/// The candidates' searches as `search` narrows them, each checked: a candidate's shader at
/// most once, each range a `[lo, hi]` with lo ≤ hi holding a whole number for integer
/// parameters; `[v, v]` fixes the parameter at v.
fn narrowed_searches(d: &Decl, defs: &[&'static ShaderDef]) -> Result<Vec<(&'static str, Narrowed)>, Diagnostic> {
    let mut out: Vec<(&'static str, Narrowed)> = Vec::new();
    for call in d.props.calls("search") {
        let at = call.span.or(d.props.span("search")).unwrap_or(d.name_span);
        let refuse = |message: String, span: crate::lang::source::Span, label: &str| {
            Diagnostic::error(message).with_code("tessera::match").with_label(span, label.to_string())
        };
        let Some(def) = defs.iter().copied().find(|def| def.name == call.name) else {
            let names: Vec<&str> = defs.iter().map(|d| d.name).collect();
            return Err(refuse(format!("`{}` is not a candidate of this match", call.name), at, "not a candidate")
                .with_help(format!("the candidates: {}", names.join(", "))));
        };
        if out.iter().any(|(n, _)| *n == def.name) {
            return Err(refuse(format!("the search of `{}` is narrowed twice", def.name), at, "again here"));
        }
        let mut base = def.defaults();
        let mut overrides = Vec::new();
        for (p, offset) in def.params.iter().zip(lib::params::offsets(def.params)) {
            let Some(range) = call.args.opt_numbers(p.name) else { continue };
            let span = call.args.span(p.name).unwrap_or(at);
            let &[lo, hi] = range else {
                return Err(refuse(
                    format!("a search range is two numbers `[lo, hi]`, not {}", range.len()),
                    span,
                    "here",
                )
                .with_help("`[v, v]` fixes the parameter at v"));
            };
            if lo > hi {
                return Err(refuse(format!("the search range [{lo}, {hi}] of `{}` is empty", p.name), span, "lo > hi")
                    .with_help(format!("write `[{hi}, {lo}]`")));
            }
            let int = matches!(p.kind, ParamKind::Int { .. });
            if int && lo.ceil() > hi.floor() {
                return Err(refuse(
                    format!("the search range [{lo}, {hi}] of `{}` holds no whole number", p.name),
                    span,
                    "a whole-number parameter",
                ));
            }
            if lo == hi {
                base[offset..offset + p.kind.width()].fill(lo);
                overrides.push(AxisOverride { name: p.name.to_string(), search: Some(false), range: None });
            } else {
                overrides.push(AxisOverride { name: p.name.to_string(), search: Some(true), range: Some((lo, hi)) });
            }
        }
        let narrowed = Narrowed { base, overrides };
        Space::with(def, narrowed.base.clone(), &narrowed.overrides)
            .map_err(|e| refuse(e.to_string(), at, "this search"))?;
        out.push((def.name, narrowed));
    }
    Ok(out)
}

/// The shaders `candidates` names, or the whole library.
fn candidates(d: &Decl) -> Result<Vec<&'static ShaderDef>, Diagnostic> {
    let Some(crate::lang::Val::Str(text)) = d.props.get("candidates") else { return Ok(lib::LIBRARY.to_vec()) };
    let span = d.props.span("candidates").unwrap_or(d.name_span);
    let out = shader_list(text, span)?;
    if out.is_empty() {
        return Err(Diagnostic::error("a match needs at least one candidate shader")
            .with_code("tessera::match")
            .with_label(span, "no shader named here")
            .with_help("name shaders (`\"brick, weave\"`) or leave `candidates` out to try the whole library"));
    }
    Ok(out)
}

/// Library shaders named in `text`, separated by commas or spaces, each once.
pub(super) fn shader_list(text: &str, span: crate::lang::source::Span) -> Result<Vec<&'static ShaderDef>, Diagnostic> {
    let mut out: Vec<&'static ShaderDef> = Vec::new();
    for name in text.split(|c: char| c == ',' || c.is_whitespace()).filter(|s| !s.is_empty()) {
        let Some(def) = lib::shader(name) else {
            let names: Vec<&str> = lib::LIBRARY.iter().map(|d| d.name).collect();
            return Err(Diagnostic::error(format!("there is no shader `{name}` in the library"))
                .with_code("tessera::match")
                .with_label(span, "here")
                .with_help(format!("the library's shaders: {}", names.join(", "))));
        };
        if !out.iter().any(|d| d.name == def.name) {
            out.push(def);
        }
    }
    Ok(out)
}

/// The catalogue of `def` at `side` under `metric`, shared by every match and transformation
/// of the scene that needs it.
pub(super) fn plan_catalogue(
    p: &mut Planner,
    def: &'static ShaderDef,
    side: usize,
    metric: Metric,
    config: &CatalogueConfig,
    narrowed: Option<&Narrowed>,
) -> Handle<ShaderCatalogue> {
    // One seed for every catalogue and render, from the scene's seed but not the match's
    // name: every match of a scene shares the catalogues, and a stochastic shader's renders
    // agree between the catalogue and the search.
    let seed = catalogue_seed(p);
    let key = CatalogueKey {
        shader: def.name,
        version: def.version,
        side,
        metric,
        config: config.clone(),
        seed,
        narrowed: narrowed.cloned(),
    };
    let id = serde_json::to_string(&key).expect("a catalogue key serialises");
    p.shared(id, |p| {
        let stage = FnStage::keyed("match.catalogue", 2, key, run_catalogue);
        p.add(format!("catalogue {}", def.name), stage, Inputs::new(), vec![])
    })
}

/// The seed of catalogues and of the renders compared with them.
pub(super) fn catalogue_seed(p: &Planner) -> u64 {
    p.scene_seed_for("match", "catalogue")
}

/// The match kind.
pub struct MatchKind;

impl super::Kind for MatchKind {
    fn spec(&self) -> &'static KindSpec {
        &SPEC
    }

    fn plan(&self, p: &mut Planner, d: &Decl) -> Result<Option<AnyHandle>, Diagnostic> {
        let props = &d.props;
        let defs = candidates(d)?;
        let side = props.int("side") as usize;
        let metric = metric(METRICS.get(props.enumeration("metric")));
        let config = CatalogueConfig {
            cap: props.int("catalogue") as usize,
            pruning: PRUNINGS.get(props.enumeration("pruning")),
            ..CatalogueConfig::default()
        };
        let seed = catalogue_seed(p);
        let narrowed = narrowed_searches(d, &defs)?;
        let mut inputs = Inputs::new();
        let mut catalogues = Vec::new();
        for def in defs {
            let n = narrowed.iter().find(|(s, _)| *s == def.name).map(|(_, n)| n);
            let h = plan_catalogue(p, def, side, metric, &config, n);
            catalogues.push((def.name, inputs.add(h)));
        }
        let at = props.span("target").unwrap_or(d.name_span);
        let image = p.value::<Image>(props.reference("target").expect("required"), at)?;
        let mut target_inputs = Inputs::new();
        let key = TargetKey { image: target_inputs.add(image), side, metric };
        let target: Handle<TargetFeature> = p.add(
            format!("match {} target", d.name),
            FnStage::keyed("match.target", 2, key, run_target),
            target_inputs,
            vec![],
        );
        let match_config = MatchConfig {
            seeds: props.int("seeds") as usize,
            residual: props.num("residual"),
            accept_at: props.opt_num("accept"),
            optimiser: OPTIMISERS.get(props.enumeration("optimiser")),
            ..MatchConfig::default()
        };
        let key =
            SearchKey { target: inputs.add(target), catalogues, side, metric, seed, config: match_config, narrowed };
        let node: Handle<Matched> =
            p.add(format!("match {}", d.name), FnStage::keyed("match.search", 1, key, run_search), inputs, vec![]);
        Ok(Some(node.erase()))
    }

    fn plan_output(&self, p: &mut Planner, out: &super::OutputRequest) -> Result<Option<super::ViewNode>, Diagnostic> {
        let d = out.decl;
        out.refuse_views("a match has no views: write its record (`.toml`), its scene declaration (`.tess`) or the target beside the match (`.png`)")?;
        let matched: Handle<Matched> = p.result(out.from);
        let name = out.from.to_string();
        let mut inputs = Inputs::new();
        let m = inputs.add(matched);
        let node = match out.format {
            OutputFormat::Toml => {
                let stage = FnStage::keyed("output.match_record", 1, m, |cx, &h| {
                    Ok(Bytes(record_toml(&cx.get(h)).into_bytes()))
                });
                p.add(format!("output {}", d.name), stage, inputs, vec![])
            }
            OutputFormat::Tess => {
                let stage = FnStage::keyed("output.match_scene", 1, (m, name), |cx, (h, name)| {
                    Ok(Bytes(snippet(&cx.get(*h), name).into_bytes()))
                });
                p.add(format!("output {}", d.name), stage, inputs, vec![])
            }
            OutputFormat::Png8 | OutputFormat::Png16 => {
                let target = p.decl(out.from).props.reference("target").expect("required").to_string();
                let at = p.decl(out.from).props.span("target").unwrap_or(d.name_span);
                let t = inputs.add(p.value::<Image>(&target, at)?);
                let format = out.format;
                let stage = FnStage::keyed("output.match_pair", 2, (m, t, format), |cx, &(h, t, format)| {
                    let pair = side_by_side(&cx.get(h), &cx.get(t))?;
                    super::output::encode_image(&pair, format)
                });
                p.add(format!("output {}", d.name), stage, inputs, vec![])
            }
            _ => {
                return Err(Diagnostic::error(format!(
                    "a match is written as `.toml`, `.tess` or `.png`, not `.{}`",
                    out.ext
                ))
                .with_code("tessera::output_format")
                .with_label(d.name_span, "here"))
            }
        };
        Ok(Some(super::ViewNode { node, exact: false, more: Vec::new() }))
    }
}

/// The target's canonical square beside the match's render (both as display values).
fn side_by_side(m: &Matched, target: &Image) -> Result<Image, StageError> {
    let side = m.side;
    let t = canonical(target, side)?;
    let def = lib::shader(&m.record.shader).expect("a match names a library shader");
    let r = lib::render_square(def, &m.record.values, m.seed, side).map_err(|e| StageError::new(e.to_string()))?;
    let gap = (side / 32).max(2);
    Ok(Image::from_fn(2 * side + gap, side, 3, |x, y, c| {
        if x < side {
            t.get(x, y, c.min(t.channels - 1))
        } else if x >= side + gap {
            r.get(x - side - gap, y, c)
        } else {
            1.0
        }
    }))
}

/// The flat values of a shader as named arguments in the language's syntax.
pub(super) fn arguments(def: &ShaderDef, values: &[f64]) -> Vec<(&'static str, String)> {
    let mut at = 0;
    def.params
        .iter()
        .map(|p| {
            let text = match p.kind {
                ParamKind::Colour => {
                    let c = &values[at..at + 3];
                    at += 3;
                    format!("[{}, {}, {}]", round(c[0]), round(c[1]), round(c[2]))
                }
                ParamKind::Int { .. } => {
                    at += 1;
                    format!("{}", values[at - 1] as i64)
                }
                ParamKind::Angle { .. } => {
                    at += 1;
                    format!("{} deg", round(values[at - 1].to_degrees()))
                }
                ParamKind::Float { .. } => {
                    at += 1;
                    round(values[at - 1])
                }
            };
            (p.name, text)
        })
        .collect()
}

/// Six significant digits: finer than any render shows, short enough to edit.
pub(super) fn round(v: f64) -> String {
    let s = format!("{:.6e}", v);
    let parsed: f64 = s.parse().expect("a formatted float parses");
    if parsed == 0.0 {
        "0".into()
    } else {
        format!("{parsed}")
    }
}

/// The match record as TOML.
pub fn record_toml(m: &Matched) -> String {
    let r = &m.record;
    let def = lib::shader(&r.shader).expect("a match names a library shader");
    let status = match r.status {
        crate::synth::matching::Status::Matched => "matched",
        crate::synth::matching::Status::NoGoodMatch => "no good match",
    };
    let mut s = String::new();
    s += "# tessera match record\n";
    s += &format!("status = \"{status}\"\nshader = \"{}\"\nversion = {}\n", r.shader, def.version);
    s += &format!("score = {}\nsimilarity = {}\n", round(r.score), round(r.similarity));
    s += &format!("calibration = {}\nrenders = {}\nside = {}\n", round(r.calibration.d0), r.renders, m.side);
    s += &format!("scanned = [{}]\n", r.scanned.iter().map(|n| format!("\"{n}\"")).collect::<Vec<_>>().join(", "));
    s += "\n[parameters]\n";
    for (name, text) in arguments(def, &r.values) {
        let text = text.trim_end_matches(" deg");
        s += &format!("{name} = {text}\n");
    }
    s
}

/// A `shader` declaration rendering the match.
pub fn snippet(m: &Matched, name: &str) -> String {
    let r = &m.record;
    let def = lib::shader(&r.shader).expect("a match names a library shader");
    let args: Vec<String> = arguments(def, &r.values).into_iter().map(|(n, t)| format!("{n} = {t}")).collect();
    let stochastic =
        if def.stochastic { " A stochastic shader: its noise differs with the declaration's seed." } else { "" };
    format!(
        "// Match `{name}`: {} (calibrated similarity {}).{stochastic}\nshader {name}_shader {{\n  pattern = {}({})\n}}\n",
        if r.status == crate::synth::matching::Status::Matched { "matched" } else { "no good match" },
        round(r.score),
        r.shader,
        args.join(", ")
    )
}
