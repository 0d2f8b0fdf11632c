//! The checker's state and the scene's one namespace: declarations by kind and name, `param`
//! values, and the `--set` overrides applied to them before any value is checked.

use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;
use std::sync::Arc;

use super::load::Loader;
use crate::lang::ast;
use crate::lang::diag::{suggest, Diagnostic};
use crate::lang::ir::Decl;
use crate::lang::parse::parse_value;
use crate::lang::schema::{KindSpec, Naming};
use crate::lang::source::{FileId, SourceMap, Span};

pub struct Options<'a> {
    /// `--set name=value` overrides of `param` declarations.
    pub sets: &'a [(String, String)],
    /// Whether a `--set` of a param the scene does not declare is skipped rather than an
    /// error (a command over many scenes refuses only a set that no scene takes).
    pub sets_may_miss: bool,
    /// Instead of the scene's `seed`, for exploring variations.
    pub seed: Option<u64>,
    pub registry: &'a [&'static KindSpec],
}

pub(super) struct ParamDef {
    pub(super) value: ast::Value,
    pub(super) span: Span,
}

pub(super) struct DeclAst<'a> {
    pub(super) spec: &'static KindSpec,
    pub(super) name: String,
    pub(super) name_span: Span,
    pub(super) decl: &'a ast::Decl,
    pub(super) file: FileId,
}

pub(super) struct Checker<'a> {
    pub(super) registry: &'a [&'static KindSpec],
    pub(super) loader: &'a dyn Loader,
    pub(super) sources: SourceMap,
    pub(super) errors: Vec<Diagnostic>,
    pub(super) params: HashMap<String, ParamDef>,
    pub(super) decls: Vec<DeclAst<'a>>,
    pub(super) kinds: HashMap<String, &'static KindSpec>,
    pub(super) out: Vec<Decl>,
    pub(super) seed: u64,
    pub(super) size: (u32, u32),
    /// Where the scene's size was written, if it was.
    pub(super) size_span: Option<Span>,
    pub(super) default_file: Option<FileId>,
    /// References made by the declaration being checked: (name, span).
    pub(super) deps: Vec<(String, Span)>,
    pub(super) ref_spans: BTreeMap<String, Vec<(String, Span)>>,
    /// What relative lengths of the declaration being checked are of (`None`: refused).
    pub(super) extent: Option<(f64, f64)>,
    /// Which side of it a relative length being checked is a part of.
    pub(super) axis: super::axis::Axis,
    /// Operands evaluated for the value being checked (bounded: see `expr::MAX_STEPS`).
    pub(super) steps: usize,
}

impl<'a> Checker<'a> {
    pub(super) fn new(opts: &'a Options, sources: SourceMap, loader: &'a dyn Loader) -> Self {
        Checker {
            registry: opts.registry,
            loader,
            sources,
            errors: Vec::new(),
            params: HashMap::new(),
            decls: Vec::new(),
            kinds: HashMap::new(),
            out: Vec::new(),
            seed: 0,
            size: (256, 256),
            size_span: None,
            default_file: None,
            deps: Vec::new(),
            ref_spans: BTreeMap::new(),
            extent: None,
            axis: super::axis::Axis::Short,
            steps: 0,
        }
    }

    fn spec(&self, kind: &str) -> Option<&'static KindSpec> {
        self.registry.iter().copied().find(|k| k.name == kind)
    }

    pub(super) fn collect(&mut self, files: &'a [(FileId, ast::File)]) {
        let mut seen: HashMap<String, Span> = HashMap::new();
        for (file, f) in files {
            for item in &f.items {
                match item {
                    ast::Item::Param(p) => {
                        if let Some(prev) = seen.get(&p.name.text) {
                            self.errors.push(duplicate(&p.name.text, p.name.span, *prev));
                            continue;
                        }
                        seen.insert(p.name.text.clone(), p.name.span);
                        self.params.insert(p.name.text.clone(), ParamDef { value: p.value.clone(), span: p.name.span });
                    }
                    ast::Item::Decl(d) => self.collect_decl(d, *file, &mut seen),
                    ast::Item::Comment(_) | ast::Item::Import(_) => {}
                }
            }
        }
    }

    fn collect_decl(&mut self, d: &'a ast::Decl, file: FileId, seen: &mut HashMap<String, Span>) {
        let Some(spec) = self.spec(&d.kind.text) else {
            let mut diag = Diagnostic::error(format!("unknown declaration kind `{}`", d.kind.text))
                .with_code("tessera::unknown_kind")
                .with_label(d.kind.span, "not a kind tessera knows");
            let names = self.registry.iter().map(|k| k.name);
            diag = match suggest(&d.kind.text, names) {
                Some(s) => diag.with_help(format!("did you mean `{s}`?")),
                None => diag.with_help(format!(
                    "the kinds are {}",
                    self.registry.iter().map(|k| format!("`{}`", k.name)).collect::<Vec<_>>().join(", ")
                )),
            };
            self.errors.push(diag);
            return;
        };
        let (name, name_span) = match (spec.naming, &d.name) {
            (Naming::Anonymous, None) => (spec.name.to_string(), d.kind.span),
            (Naming::Anonymous, Some(n)) => {
                self.errors.push(
                    Diagnostic::error(format!("`{}` takes no name", spec.name))
                        .with_code("tessera::naming")
                        .with_label(n.span, "remove this name"),
                );
                return;
            }
            (Naming::Ident, Some(n)) if !n.quoted => (n.text.clone(), n.span),
            (Naming::Path, Some(n)) if n.quoted && n.text.trim().is_empty() => {
                self.errors.push(
                    Diagnostic::error(format!("`{}` needs a file name", spec.name))
                        .with_code("tessera::naming")
                        .with_label(n.span, "empty file name")
                        .with_help(format!("write `{} \"result.png\" {{ ... }}`", spec.name)),
                );
                return;
            }
            (Naming::Path, Some(n)) if n.quoted => (n.text.clone(), n.span),
            (Naming::Ident, _) => {
                self.errors.push(
                    Diagnostic::error(format!("a `{}` needs a name", spec.name))
                        .with_code("tessera::naming")
                        .with_label(d.name.as_ref().map_or(d.kind.span, |n| n.span), "expected a bare name here")
                        .with_help(format!("write `{} my_name {{ ... }}`", spec.name)),
                );
                return;
            }
            (Naming::Path, _) => {
                self.errors.push(
                    Diagnostic::error(format!("a `{}` is named by a quoted file name", spec.name))
                        .with_code("tessera::naming")
                        .with_label(d.name.as_ref().map_or(d.kind.span, |n| n.span), "expected a string here")
                        .with_help(format!("write `{} \"result.png\" {{ ... }}`", spec.name)),
                );
                return;
            }
        };
        if let Some(prev) = seen.get(&name) {
            self.errors.push(duplicate(&name, name_span, *prev));
            return;
        }
        seen.insert(name.clone(), name_span);
        self.kinds.insert(name.clone(), spec);
        self.decls.push(DeclAst { spec, name, name_span, decl: d, file });
    }

    pub(super) fn apply_sets(&mut self, sets: &[(String, String)], may_miss: bool) {
        for (name, text) in sets {
            let Some(def) = self.params.get_mut(name) else {
                if may_miss {
                    continue;
                }
                let mut d = Diagnostic::error(format!("`--set {name}=…`: the scene declares no `param {name}`"))
                    .with_code("tessera::unknown_param");
                if let Some(s) = suggest(name, self.params.keys().map(|k| k.as_str())) {
                    d = d.with_help(format!("did you mean `{s}`?"));
                }
                self.errors.push(d);
                continue;
            };
            let id = self.sources.add(PathBuf::from("--set"), format!("--set {name}"), Arc::from(text.as_str()));
            match parse_value(text, id) {
                Ok(v) => def.value = v,
                Err(d) => self.errors.push(d),
            }
        }
    }
}

fn duplicate(name: &str, span: Span, prev: Span) -> Diagnostic {
    Diagnostic::error(format!("`{name}` is declared twice"))
        .with_code("tessera::duplicate_name")
        .with_label(span, "declared again here")
        .with_label(prev, "first declared here")
        .with_help("names are shared by all declarations and params of a scene and its imports; rename one")
}
