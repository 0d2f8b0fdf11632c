//! Declarations → stages. One module per declaration kind: its schema (`SPEC`) and the
//! code that turns a checked declaration into nodes of the stage graph. This is the only
//! layer that knows both the language and the algorithms.

mod artifact;
mod layer;

mod library;
mod map;
mod output;
mod sample;
mod scene;
mod structure;

mod surface;

use std::collections::HashMap;
use std::path::PathBuf;

pub use artifact::{Bytes, Encoded, FnStage};
pub use library::{axis_name, entries as library_entries, plan_standalone, Ranking, Standalone};
pub use output::{OutputFormat, PlannedOutput};

use crate::graph::{Budget, Graph, Node, NodeId, Stage};
use crate::lang::source::Span;
use crate::lang::{Decl, Diagnostic, KindSpec, Scene};

/// Every declaration kind the language accepts.
pub fn registry() -> Vec<&'static KindSpec> {
    vec![
        &scene::SPEC,
        &sample::SPEC,
        &map::SPEC,
        &surface::SPEC,
        &structure::SPEC,
        &layer::SPEC,
        &library::SPEC,
        &output::SPEC,
    ]
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
        } else if let Some(s) = failure.error.prop.and_then(|p| decl.props.span(p)) {
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
#[derive(Clone, Copy, Debug, Default)]
pub struct PlanOptions {
    /// Declarations whose sizes imply more memory are refused at plan time; stages refuse
    /// what their inputs imply beyond it at run time. Not part of any key: it decides
    /// whether a result is computed, never what it is.
    pub budget: Budget,
}

pub(crate) struct Planner<'a> {
    pub scene: &'a Scene,
    pub budget: Budget,
    graph: Graph,
    blame: Vec<Blame>,
    /// The node holding each declaration's result.
    results: HashMap<String, NodeId>,
    /// Further named nodes of multi-stage declarations: (declaration, part) → node.
    parts: HashMap<(String, &'static str), NodeId>,
    outputs: Vec<PlannedOutput>,
    decl_index: usize,
}

impl Planner<'_> {
    pub fn add(
        &mut self,
        label: String,
        stage: impl Stage + 'static,
        inputs: Vec<NodeId>,
        files: Vec<(PathBuf, Span)>,
    ) -> NodeId {
        let decl = &self.scene.decls[self.decl_index];
        let (files, spans): (Vec<PathBuf>, Vec<Span>) = files.into_iter().unzip();
        self.blame.push(Blame { decl: self.decl_index, span: decl.name_span, files: spans });
        self.graph.add(Node { label, stage: Box::new(stage), inputs, files, origin: self.decl_index })
    }

    /// A named part of a multi-stage declaration (e.g. a structure's `lloyd` result).
    pub fn part(&self, name: &str, part: &'static str) -> Option<NodeId> {
        self.parts.get(&(name.to_string(), part)).copied()
    }

    /// The node added last.
    pub fn last(&self) -> NodeId {
        self.graph.nodes.len() - 1
    }

    /// The node holding the result of the declaration `name` (planned earlier).
    pub fn result(&self, name: &str) -> NodeId {
        self.results[name]
    }

    /// The result of `name` where a value (an image, a map, a plane) is needed, `at` the
    /// span that named it: a sample that holds only a structure file has none.
    pub fn value(&self, name: &str, at: Span) -> Result<NodeId, Diagnostic> {
        let d = self.decl(name);
        if d.kind == "sample" && d.props.get("image").is_none() && d.props.get("from").is_none() {
            return Err(Diagnostic::error(format!("sample `{name}` holds only a structure file, not an image"))
                .with_code("tessera::sample_image")
                .with_label(at, "an image is needed here")
                .with_help("give the sample an `image`, or use it as a structure's `from`"));
        }
        Ok(self.result(name))
    }

    pub fn decl(&self, name: &str) -> &Decl {
        self.scene.decl(name).expect("resolved reference")
    }

    /// Refuses a declaration whose raster of `w × h` pixels, at about `bytes_per_pixel` of
    /// working memory each, cannot fit the budget. The size was set by `size_prop` of
    /// `size_owner` (or, defaulted, by the scene's `size`); the diagnostic points there.
    pub fn check_pixels(
        &self,
        d: &Decl,
        size_owner: &Decl,
        size_prop: &str,
        (w, h): (usize, usize),
        bytes_per_pixel: f64,
    ) -> Result<(), Diagnostic> {
        let what = format!("{} `{}` at {w} x {h} pixels", d.kind, d.name);
        let Err(message) = self.budget.check(w as f64 * h as f64 * bytes_per_pixel, &what) else { return Ok(()) };
        let scene_size = || self.scene.decls.iter().find(|s| s.kind == "scene").and_then(|s| s.props.span("size"));
        let span = size_owner.props.span(size_prop).or_else(scene_size).unwrap_or(d.name_span);
        let mut diag = Diagnostic::error(message).with_code("tessera::budget").with_label(span, "this size");
        if span != d.name_span && size_owner.name != d.name {
            diag = diag.with_label(d.name_span, "needed by this declaration");
        }
        Err(diag.with_help(
            "use a smaller size, or raise the budget with `--max-memory` or `[limits] max_memory` in tessera.toml",
        ))
    }

    /// A seed for a random stream of this declaration.
    pub fn seed(&self, decl: &Decl, stream: &str) -> u64 {
        crate::synth::rng::derive_seed(self.scene.seed, &decl.name, stream)
    }
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
pub fn plan_with(scene: &Scene, options: &PlanOptions) -> Result<Plan, Vec<Diagnostic>> {
    let mut p = Planner {
        scene,
        budget: options.budget,
        graph: Graph::default(),
        blame: Vec::new(),
        results: HashMap::new(),
        parts: HashMap::new(),
        outputs: Vec::new(),
        decl_index: 0,
    };
    let mut errors = Vec::new();
    let index: HashMap<&str, usize> = scene.decls.iter().enumerate().map(|(i, d)| (d.name.as_str(), i)).collect();
    for d in scene.topo_order() {
        // A declaration that depends on a failed one is not planned (its error would only repeat).
        if d.deps.iter().any(|dep| !p.results.contains_key(dep) && scene.decl(dep).is_some_and(|x| x.kind != "scene")) {
            continue;
        }
        p.decl_index = index[d.name.as_str()];
        let r = match d.kind {
            "scene" => continue,
            "sample" => sample::plan(&mut p, d),
            "map" => map::plan(&mut p, d),
            "surface" => surface::plan(&mut p, d),
            "structure" => structure::plan(&mut p, d),
            "layer" => layer::plan(&mut p, d),
            "library" => library::plan(&mut p, d),
            "output" => output::plan(&mut p, d),
            k => unreachable!("kind `{k}` is in the registry but has no planner"),
        };
        match r {
            Ok(node) => {
                p.results.insert(d.name.clone(), node);
            }
            Err(e) => errors.push(e),
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
