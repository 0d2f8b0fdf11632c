//! Declarations and blocks: each property checked against its spec, defaults filled in, scene
//! settings taken, and constructor calls with their positional and named arguments.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::namespace::Checker;
use crate::lang::ast;
use crate::lang::diag::{suggest, Diagnostic};
use crate::lang::ir::{Call, Decl, Prop, Props, Val};
use crate::lang::parse::parse_value;
use crate::lang::schema::{CallSpec, Default, PropSpec, Setting};
use crate::lang::source::{FileId, Span};

impl Checker<'_> {
    pub(super) fn check_all(&mut self) {
        // Declarations setting scene settings first: other defaults (`SceneSize`) depend on them.
        let order: Vec<usize> = {
            let mut v: Vec<usize> = (0..self.decls.len()).collect();
            v.sort_by_key(|&i| self.decls[i].spec.settings.is_empty());
            v
        };
        for i in order {
            let (spec, decl) = (self.decls[i].spec, self.decls[i].decl);
            self.deps.clear();
            let dir = self.dir_of(self.decls[i].file);
            self.extent = self.extent_of(i, 0);
            let props = self.check_block(&decl.block, spec.props, &dir, self.decls[i].name_span, spec.name);
            for (setting, prop) in spec.settings {
                match (setting, props.get(prop)) {
                    (Setting::Seed, Some(Val::Int(s))) => self.seed = *s as u64,
                    (Setting::Size, Some(Val::Size(w, h))) => {
                        self.size = (*w, *h);
                        self.size_span = props.span(prop);
                    }
                    _ => {}
                }
            }
            let d = &self.decls[i];
            let mut deps: Vec<String> = Vec::new();
            for (n, _) in &self.deps {
                if !deps.contains(n) {
                    deps.push(n.clone());
                }
            }
            self.ref_spans.insert(d.name.clone(), self.deps.clone());
            self.out.push(Decl {
                kind: spec.name,
                name: d.name.clone(),
                name_span: d.name_span,
                span: decl.span,
                file: d.file,
                props,
                deps,
            });
        }
        // Source order (files in import order), which is what users expect in reports.
        let pos: HashMap<&str, usize> = self.decls.iter().enumerate().map(|(i, d)| (d.name.as_str(), i)).collect();
        self.out.sort_by_key(|d| pos[d.name.as_str()]);
    }

    pub(super) fn dir_of(&self, file: FileId) -> PathBuf {
        self.sources.get(file).path.parent().unwrap_or(Path::new("")).to_path_buf()
    }

    pub(super) fn check_block(
        &mut self,
        block: &ast::Block,
        specs: &[PropSpec],
        dir: &Path,
        owner: Span,
        what: &str,
    ) -> Props {
        let mut props = Props::default();
        let mut seen: HashMap<&str, Span> = HashMap::new();
        for p in block.properties() {
            let Some(spec) = specs.iter().find(|s| s.name == p.name.text) else {
                self.errors.push(unknown_property(&p.name, specs, what));
                continue;
            };
            if let Some(prev) = seen.get(spec.name) {
                self.errors.push(
                    Diagnostic::error(format!("property `{}` is set twice", spec.name))
                        .with_code("tessera::duplicate_property")
                        .with_label(p.name.span, "set again here")
                        .with_label(*prev, "first set here"),
                );
                continue;
            }
            seen.insert(spec.name, p.name.span);
            if let Some(val) = self.check_value(&p.value, &spec.ty, dir, 0) {
                props.0.insert(spec.name.to_string(), Prop { val, span: Some(p.value.span) });
            }
        }
        let written: Vec<&str> = seen.into_keys().collect();
        self.fill_defaults(&mut props, specs, owner, what, dir, &written);
        props
    }

    /// Fills what the user did not write; a written value that failed its check already
    /// has its own error and is not reported again as missing.
    fn fill_defaults(
        &mut self,
        props: &mut Props,
        specs: &[PropSpec],
        owner: Span,
        what: &str,
        dir: &Path,
        written: &[&str],
    ) {
        for spec in specs {
            if props.0.contains_key(spec.name) || written.contains(&spec.name) {
                continue;
            }
            let val = match spec.default {
                Default::Absent => continue,
                Default::Required => {
                    self.errors.push(
                        Diagnostic::error(format!("`{what}` needs a `{}` property", spec.name))
                            .with_code("tessera::missing_property")
                            .with_label(owner, format!("`{}` is missing here", spec.name))
                            .with_help(format!("{}: {}", spec.name, spec.doc)),
                    );
                    continue;
                }
                Default::SceneSize => Some(Val::Size(self.size.0, self.size.1)),
                Default::Text(t) => {
                    let file = *self.default_file.get_or_insert_with(|| {
                        self.sources.add(PathBuf::from("<default>"), "<default>".into(), Arc::from(""))
                    });
                    let v = parse_value(t, file).expect("schema defaults parse");
                    self.check_value(&v, &spec.ty, dir, 0)
                }
            };
            if let Some(val) = val {
                props.0.insert(spec.name.to_string(), Prop { val, span: None });
            }
        }
    }

    pub(super) fn call(
        &mut self,
        calls: &[CallSpec],
        name: &ast::Ident,
        args: &[ast::Arg],
        span: Span,
        dir: &Path,
    ) -> Option<Val> {
        let Some(spec) = calls.iter().find(|c| c.name == name.text) else {
            let mut d = Diagnostic::error(format!("unknown constructor `{}`", name.text))
                .with_code("tessera::unknown_constructor")
                .with_label(name.span, "not available here");
            d = match suggest(&name.text, calls.iter().map(|c| c.name)) {
                Some(s) => d.with_help(format!("did you mean `{s}`?")),
                None => d.with_help(format!(
                    "the constructors here are {}",
                    calls.iter().map(|c| format!("`{}`", c.name)).collect::<Vec<_>>().join(", ")
                )),
            };
            self.errors.push(d);
            return None;
        };
        let mut props = Props::default();
        let mut named_seen = false;
        let mut ok = true;
        let mut failed: Vec<&str> = Vec::new();
        for (i, a) in args.iter().enumerate() {
            let arg_spec = match &a.name {
                Some(n) => {
                    named_seen = true;
                    match spec.args.iter().find(|s| s.name == n.text) {
                        Some(s) => s,
                        None => {
                            self.errors.push(unknown_property(n, spec.args, spec.name));
                            ok = false;
                            continue;
                        }
                    }
                }
                None if named_seen => {
                    self.errors.push(
                        Diagnostic::error("positional arguments must come before named ones")
                            .with_code("tessera::call")
                            .with_label(a.value.span, "name this argument"),
                    );
                    ok = false;
                    continue;
                }
                None => match spec.args.get(i) {
                    Some(s) => s,
                    None => {
                        self.errors.push(
                            Diagnostic::error(format!("`{}` takes at most {} arguments", spec.name, spec.args.len()))
                                .with_code("tessera::call")
                                .with_label(a.value.span, "one too many"),
                        );
                        ok = false;
                        continue;
                    }
                },
            };
            if props.0.contains_key(arg_spec.name) {
                self.errors.push(
                    Diagnostic::error(format!("argument `{}` is given twice", arg_spec.name))
                        .with_code("tessera::duplicate_property")
                        .with_label(a.value.span, "given again here"),
                );
                ok = false;
                continue;
            }
            match self.check_value(&a.value, &arg_spec.ty, dir, 0) {
                Some(val) => {
                    props.0.insert(arg_spec.name.to_string(), Prop { val, span: Some(a.value.span) });
                }
                None => {
                    ok = false;
                    failed.push(arg_spec.name);
                }
            }
        }
        let before = self.errors.len();
        self.fill_defaults(&mut props, spec.args, span, spec.name, dir, &failed);
        if !ok || self.errors.len() > before {
            return None;
        }
        Some(Val::Call(Call { name: spec.name.to_string(), args: props, span: Some(span) }))
    }
}

fn unknown_property(name: &ast::Ident, specs: &[PropSpec], what: &str) -> Diagnostic {
    let mut d = Diagnostic::error(format!("unknown property `{}` for `{what}`", name.text))
        .with_code("tessera::unknown_property")
        .with_label(name.span, "unknown property");
    d = match suggest(&name.text, specs.iter().map(|s| s.name)) {
        Some(s) => d.with_help(format!("did you mean `{s}`?")),
        None => d.with_help(format!(
            "`{what}` takes {}",
            specs.iter().map(|s| format!("`{}`", s.name)).collect::<Vec<_>>().join(", ")
        )),
    };
    d
}
