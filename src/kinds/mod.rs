//! Declarations → stages. One module per declaration kind, each a [`Kind`] listed in
//! [`KINDS`]: its schema, what it produces, how a checked declaration becomes nodes of the
//! stage graph, and its output views. This is the only layer that knows both the language
//! and the algorithms.

mod appearance;
mod artifact;
mod layer;
mod library;
mod map;
mod matching;
mod model;
mod output;
mod procedural;
mod representation;
mod sample;
mod scene;
mod shader;
mod structure;
mod surface;
mod transform;

use std::any::Any;
use std::collections::HashMap;
use std::path::PathBuf;

pub use artifact::{Bytes, Encoded, FnStage};
pub use library::{axis_name, entries as library_entries, plan_standalone, Ranking, Standalone};
pub use output::{OutputFormat, PlannedOutput, View, VIEWS};

use crate::graph::{AnyHandle, Budget, Graph, Handle, Inputs};
use crate::lang::source::Span;
use crate::lang::{Decl, Diagnostic, KindSpec, Scene};

/// A declaration kind: its schema, what a reference to it yields, how it plans its stages
/// and which views an `output` may write of it. Each kind is one module and one entry of
/// [`KINDS`]; the planner, `output`, `explain`, the docs and reference checking all go
/// through the list, so nothing outside a kind's module names it.
pub trait Kind: Sync {
    fn spec(&self) -> &'static KindSpec;

    /// Plans a checked declaration into stages; the node holding its result, if it has one.
    /// Planning runs in dependency order, so what the declaration refers to is planned.
    fn plan(&self, p: &mut Planner, d: &Decl) -> Result<Option<AnyHandle>, Diagnostic>;

    /// Plans `output` of a declaration of this kind when the kind has views of its own
    /// (a structure's labels, a layer's seams, a sample's ranking); `None` leaves it to
    /// the generic encoding of the value the declaration exports.
    fn plan_output(&self, _p: &mut Planner, _out: &OutputRequest) -> Result<Option<ViewNode>, Diagnostic> {
        Ok(None)
    }

    /// Why a declaration of this kind, referred to `at`, has no value to use there (a
    /// sample holding only a structure file has no image).
    fn refuse_value(&self, _d: &Decl, _at: Span) -> Option<Diagnostic> {
        None
    }
}

/// Every declaration kind the language accepts, in the order `explain` lists them.
pub static KINDS: &[&dyn Kind] = &[
    &scene::Scene,
    &sample::Sample,
    &representation::Representation,
    &map::Map,
    &surface::Surface,
    &structure::Structure,
    &appearance::Appearance,
    &procedural::ProceduralKind,
    &shader::ShaderKind,
    &matching::MatchKind,
    &transform::TransformKind,
    &layer::Layer,
    &library::Library,
    &model::ModelKind,
    &output::Output,
];

/// The schemas of [`KINDS`], as the language checks scenes against them.
pub fn registry() -> Vec<&'static KindSpec> {
    KINDS.iter().map(|k| k.spec()).collect()
}

/// The kind named `name` (a resolved declaration's kind is always one of them).
pub fn kind(name: &str) -> &'static dyn Kind {
    *KINDS.iter().find(|k| k.spec().name == name).expect("resolved declarations have a known kind")
}

/// An `output` declaration's request to write a view of another declaration.
pub struct OutputRequest<'a> {
    /// The output declaration.
    pub decl: &'a Decl,
    /// The declaration it writes.
    pub from: &'a str,
    pub format: OutputFormat,
    /// The `view` property (`auto` when absent).
    pub view: View,
    /// The output file's extension, lower-case.
    pub ext: &'a str,
}

impl OutputRequest<'_> {
    /// Refuses a `view` on the output of a kind that has no views, `message` saying what its
    /// outputs are instead.
    pub fn refuse_views(&self, message: impl Into<String>) -> Result<(), Diagnostic> {
        if self.view == View::Auto {
            return Ok(());
        }
        Err(Diagnostic::error(message)
            .with_code("tessera::output_view")
            .with_label(self.decl.props.span("view").unwrap_or(self.decl.name_span), "remove this"))
    }
}

/// A planned view: the node producing the file's bytes, and whether its values are
/// identities compared exactly by the golden check.
pub struct ViewNode {
    pub node: Handle<Bytes>,
    pub exact: bool,
    /// The files a view writes under names of its own (a frame sequence), instead of the
    /// output's name; `node` is then the first of them.
    pub more: Vec<(String, Handle<Bytes>)>,
}

/// The colour space an image's values are in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ColorSpace {
    Srgb,
    Linear,
    Lab,
}

crate::choices!(
    /// The `color` property of samples.
    pub COLOR_SPACES: ColorSpace { "srgb" => ColorSpace::Srgb, "linear" => ColorSpace::Linear, "lab" => ColorSpace::Lab }
);

/// What a planned declaration offers those that refer to it, beyond its result node.
#[derive(Clone, Default)]
pub struct Exports {
    /// It is an image in this colour space.
    pub image: Option<ColorSpace>,
    /// It is a plane of this size, set at this span (absent: the scene's size).
    pub plane: Option<((usize, usize), Option<Span>)>,
    /// It holds a structure example: this file, named at this span.
    pub example: Option<(PathBuf, Span)>,
}

/// Where to point when a node fails.
#[derive(Clone, Debug)]
pub struct Blame {
    pub decl: usize,
    pub span: Span,
    /// For each of the node's files, the span of the string that named it.
    pub files: Vec<Span>,
}

/// A scene planned into a stage graph.
pub struct Plan {
    pub graph: Graph,
    pub outputs: Vec<PlannedOutput>,
    pub blame: Vec<Blame>,
}

impl Plan {
    /// A stage failure as a diagnostic pointing into the scene.
    pub fn diagnose(&self, scene: &Scene, failure: &crate::graph::Failure) -> Diagnostic {
        let blame = &self.blame[failure.node];
        let decl = &scene.decls[blame.decl];
        let (span, label) = if let Some(s) = failure.error.file.and_then(|i| blame.files.get(i).copied()) {
            (s, "this file")
        } else if let Some(s) = failure.error.prop.and_then(|p| decl.props.span_at(p)) {
            (s, "this value")
        } else {
            (blame.span, "in this declaration")
        };
        let mut d =
            Diagnostic::error(failure.error.message.clone()).with_code("tessera::stage").with_label(span, label);
        if let Some(h) = &failure.error.help {
            d = d.with_help(h.clone());
        }
        d
    }
}

/// What planning needs besides the scene.
#[derive(Clone, Copy, Default)]
pub struct PlanOptions<'a> {
    /// Declarations whose sizes imply more memory are refused at plan time; stages refuse
    /// what their inputs imply beyond it at run time. Not part of any key: it decides
    /// whether a result is computed, never what it is.
    pub budget: Budget,
    /// The door through which planning reads the few files that decide the graph's shape
    /// (a light-position file naming a capture's images), so that they are hashed and
    /// watched like the scene; without one, such files are read directly.
    pub loader: Option<&'a dyn crate::lang::Loader>,
}

pub struct Planner<'a> {
    pub scene: &'a Scene,
    pub budget: Budget,
    loader: Option<&'a dyn crate::lang::Loader>,
    graph: Graph,
    blame: Vec<Blame>,
    /// The node holding each declaration's result.
    results: HashMap<String, AnyHandle>,
    /// Further named nodes of multi-stage declarations: (declaration, part) → node.
    parts: HashMap<(String, &'static str), AnyHandle>,
    /// Stages several declarations share, by a key their kind makes (a match's catalogues).
    shared: HashMap<String, AnyHandle>,
    exports: HashMap<String, Exports>,
    outputs: Vec<PlannedOutput>,
    decl_index: usize,
}

impl Planner<'_> {
    /// A text file that decides what the plan reads (see [`PlanOptions::loader`]).
    pub fn read_text(&self, path: &std::path::Path) -> std::io::Result<std::sync::Arc<str>> {
        match self.loader {
            Some(l) => l.load(path),
            None => crate::graph::world::read_regular_text(path, self.budget.max_file()).map(Into::into),
        }
    }

    /// Adds a stage of the declaration being planned, reading `inputs` and `files` (each
    /// with the span of the string that named it); the handle of its artifact.
    pub fn add<T: Encoded>(
        &mut self,
        label: String,
        stage: FnStage<T>,
        inputs: Inputs,
        files: Vec<(PathBuf, Span)>,
    ) -> Handle<T> {
        let decl = &self.scene.decls[self.decl_index];
        let (files, spans): (Vec<PathBuf>, Vec<Span>) = files.into_iter().unzip();
        self.blame.push(Blame { decl: self.decl_index, span: decl.name_span, files: spans });
        self.graph.add_typed(label, stage, inputs, files, self.decl_index)
    }

    /// The stage planned under `key` by an earlier declaration, or the one `make` plans now:
    /// declarations that need the same work (two matches trying one shader) share one stage.
    pub fn shared<T: Encoded>(&mut self, key: String, make: impl FnOnce(&mut Self) -> Handle<T>) -> Handle<T> {
        if let Some(h) = self.shared.get(&key) {
            return typed(*h, &key);
        }
        let h = make(self);
        self.shared.insert(key, h.erase());
        h
    }

    /// Records a named part of the multi-stage declaration `d` (a structure's `lloyd`).
    pub fn set_part<T: Any>(&mut self, d: &Decl, part: &'static str, h: Handle<T>) {
        self.parts.insert((d.name.clone(), part), h.erase());
    }

    /// Whether the declaration `name` recorded a part `part` (of any type).
    pub fn has_part(&self, name: &str, part: &'static str) -> bool {
        self.parts.contains_key(&(name.to_string(), part))
    }

    /// A named part of a multi-stage declaration planned earlier.
    pub fn part<T: Any>(&self, name: &str, part: &'static str) -> Option<Handle<T>> {
        self.parts.get(&(name.to_string(), part)).map(|h| typed(*h, name))
    }

    /// The node holding the result of the declaration `name` (planned earlier), which its
    /// kind makes a `T`.
    pub fn result<T: Any>(&self, name: &str) -> Handle<T> {
        typed(self.results[name], name)
    }

    /// The result of `name` where a value (an image, a map, a plane) is needed, `at` the
    /// span that named it; its kind may refuse (see [`Kind::refuse_value`]).
    pub fn value<T: Any>(&self, name: &str, at: Span) -> Result<Handle<T>, Diagnostic> {
        let d = self.decl(name);
        if let Some(refusal) = kind(d.kind).refuse_value(d, at) {
            return Err(refusal);
        }
        Ok(self.result(name))
    }

    /// What the declaration being planned offers to later ones.
    pub fn export(&mut self, d: &Decl) -> &mut Exports {
        self.exports.entry(d.name.clone()).or_default()
    }

    /// What `name` (planned earlier) offers.
    pub fn exports(&self, name: &str) -> Exports {
        self.exports.get(name).cloned().unwrap_or_default()
    }

    /// The colour space of the image `name` (linear for data that is not an image).
    pub fn color_space(&self, name: &str) -> ColorSpace {
        self.exports(name).image.unwrap_or(ColorSpace::Linear)
    }

    /// The size of the plane `name` and where it was set (absent: the scene's size).
    pub fn plane(&self, name: &str) -> ((usize, usize), Option<Span>) {
        self.exports(name).plane.expect("a plane reference names a declaration exporting a plane")
    }

    pub fn decl(&self, name: &str) -> &Decl {
        self.scene.decl(name).expect("resolved reference")
    }

    /// Refuses a declaration whose raster of `w × h` pixels, at about `bytes_per_pixel` of
    /// working memory each, cannot fit the budget. The size was written at `size_at` (absent:
    /// defaulted from the scene's `size`); the diagnostic points there.
    pub fn check_pixels(
        &self,
        d: &Decl,
        size_at: Option<Span>,
        (w, h): (usize, usize),
        bytes_per_pixel: f64,
    ) -> Result<(), Diagnostic> {
        let what = format!("{} `{}` at {w} x {h} pixels", d.kind, d.name);
        let Err(message) = self.budget.check(w as f64 * h as f64 * bytes_per_pixel, &what) else { return Ok(()) };
        let span = size_at.or(self.scene.size_span).unwrap_or(d.name_span);
        let mut diag = Diagnostic::error(message).with_code("tessera::budget").with_label(span, "this size");
        let inside = span.file == d.span.file && d.span.start <= span.start && span.end <= d.span.end;
        if !inside {
            diag = diag.with_label(d.name_span, "needed by this declaration");
        }
        Err(diag.with_help(
            "use a smaller size, or raise the budget with `--max-memory` or `[limits] max_memory` in tessera.toml",
        ))
    }

    /// A seed from the scene's seed and a name other than a declaration's (a stream shared
    /// by declarations).
    pub fn scene_seed_for(&self, name: &str, stream: &str) -> u64 {
        crate::synth::rng::derive_seed(self.scene.seed, name, stream)
    }

    /// A seed for a random stream of this declaration.
    pub fn seed(&self, decl: &Decl, stream: &str) -> u64 {
        crate::synth::rng::derive_seed(self.scene.seed, &decl.name, stream)
    }
}

/// `h` as a `T`: a declaration's kind and the kinds reading it agree on what it makes, so a
/// mismatch is a planner bug, found by planning any scene that wires the two.
fn typed<T: Any>(h: AnyHandle, name: &str) -> Handle<T> {
    h.typed().unwrap_or_else(|| {
        panic!("`{name}` makes a {}, not a {} (a planner bug)", h.type_name(), std::any::type_name::<T>())
    })
}

/// Peak bytes per decoded sample: the decoder's own buffer (up to 16 bits), the planar f32
/// image and one converted copy.
const DECODE_BYTES_PER_SAMPLE: f64 = 10.0;

/// Decodes an image file after holding what its header says decoding will allocate to the
/// budget: a small file can unpack to gigabytes. Every kind decodes through here.
pub fn decode_image(bytes: &[u8], budget: Budget) -> Result<crate::raster::Image, String> {
    if let Some((w, h, c)) = crate::raster::io::decode_dimensions(bytes) {
        let need = w as f64 * h as f64 * c as f64 * DECODE_BYTES_PER_SAMPLE;
        budget.check(need, &format!("the {w} x {h} image ({c} channel(s))")).map_err(|m| {
            format!("{m}; use a smaller image, or raise the budget with `--max-memory` or `[limits] max_memory` in tessera.toml")
        })?;
    }
    crate::raster::io::decode(bytes).map_err(|e| e.to_string())
}

/// Plans a resolved scene under the machine's default budget (see [`plan_with`]).
pub fn plan(scene: &Scene) -> Result<Plan, Vec<Diagnostic>> {
    plan_with(scene, &PlanOptions::default())
}

/// Plans a resolved scene. Errors are problems only visible with the whole declaration in
/// view (a crop outside the image's declared size, an output extension tessera cannot write,
/// a size that cannot fit the memory budget).
pub fn plan_with(scene: &Scene, options: &PlanOptions<'_>) -> Result<Plan, Vec<Diagnostic>> {
    let mut p = Planner {
        scene,
        budget: options.budget,
        loader: options.loader,
        graph: Graph::default(),
        blame: Vec::new(),
        results: HashMap::new(),
        parts: HashMap::new(),
        shared: HashMap::new(),
        exports: HashMap::new(),
        outputs: Vec::new(),
        decl_index: 0,
    };
    let mut errors = Vec::new();
    let mut failed = std::collections::HashSet::new();
    let index: HashMap<&str, usize> = scene.decls.iter().enumerate().map(|(i, d)| (d.name.as_str(), i)).collect();
    for d in scene.topo_order() {
        // A declaration that depends on a failed one is not planned (its error would only repeat).
        if d.deps.iter().any(|dep| failed.contains(dep.as_str())) {
            failed.insert(d.name.as_str());
            continue;
        }
        p.decl_index = index[d.name.as_str()];
        match kind(d.kind).plan(&mut p, d) {
            Ok(Some(node)) => {
                p.results.insert(d.name.clone(), node);
            }
            Ok(None) => {}
            Err(e) => {
                failed.insert(d.name.as_str());
                errors.push(e);
            }
        }
    }
    errors.extend(output_collisions(&p.outputs));
    if !errors.is_empty() {
        return Err(errors);
    }
    Ok(Plan { graph: p.graph, outputs: p.outputs, blame: p.blame })
}

/// Two outputs of one scene that would be one file (`a.png` and `./a.png`), or where one
/// needs the other as its directory (`d.png` and `d.png/x.png`).
fn output_collisions(outputs: &[PlannedOutput]) -> Vec<Diagnostic> {
    let mut errors = Vec::new();
    let mut by_name: HashMap<&std::path::Path, &PlannedOutput> = HashMap::new();
    for o in outputs {
        by_name.entry(std::path::Path::new(&o.name)).or_insert(o);
    }
    for o in outputs {
        let path = std::path::Path::new(&o.name);
        let first = by_name[path];
        if !std::ptr::eq(first, o) {
            errors.push(
                Diagnostic::error(format!("two outputs write `{}`", o.name))
                    .with_code("tessera::output_collision")
                    .with_label(o.span, "this output")
                    .with_label(first.span, "is the same file as this one"),
            );
            continue;
        }
        if let Some(dir) = path.ancestors().skip(1).find_map(|a| by_name.get(a)) {
            errors.push(
                Diagnostic::error(format!(
                    "`{}` is an output file, so `{}` cannot be written inside it",
                    dir.name, o.name
                ))
                .with_code("tessera::output_collision")
                .with_label(o.span, "this output")
                .with_label(dir.span, "needs this file to be a directory"),
            );
        }
    }
    errors
}
