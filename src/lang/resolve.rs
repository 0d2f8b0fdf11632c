//! Loading, name resolution and type checking: syntax trees in, a typed `Scene` out.

use std::collections::{BTreeMap, HashMap};
use std::path::{Component, Path, PathBuf};
use std::sync::Arc;

use super::ast::{self, ValueKind};
use super::diag::{suggest, Diagnostic, Diagnostics};
use super::ir::{Call, Decl, Prop, Props, Scene, Val};
use super::parse::{parse_file, parse_value};
use super::schema::{self, CallSpec, Default, KindSpec, Naming, PropSpec, Range, Setting, Ty, Unit, Value};
use super::source::{FileId, SourceMap, Span};

/// The largest side of any raster a scene may ask for: 16384² f32 pixels is already 1 GiB
/// per channel, and a typo should not be able to exhaust the machine's memory.
const MAX_SIDE: f64 = 16384.0;

/// The largest magnitude of a number: stages compute in f32, and a larger f64 would reach
/// them as an infinity (reported as "inf", far from the number the user wrote).
const MAX_NUMBER: f64 = f32::MAX as f64;

/// The largest integer a property may hold: 2^53, up to which every integer is exactly an
/// f64 (integers also serve as numbers, and params pass through the same values).
const MAX_EXACT_INT: i64 = 1 << 53;

/// The exact value of an integer literal (`12`, `-3`, `1.5e3`, `20.0`) from its digits:
/// `None` if the text is not a whole number, `Some(None)` if it is one too large for i128.
fn integer_literal(text: &str) -> Option<Option<i128>> {
    let (negative, t) = match text.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, text),
    };
    let (mantissa, exponent) = match t.find(['e', 'E']) {
        Some(i) => (&t[..i], &t[i + 1..]),
        None => (t, "0"),
    };
    let (int, frac) = mantissa.split_once('.').unwrap_or((mantissa, ""));
    // An exponent too long for i64 makes the value certainly too large (or below 1).
    let exponent: i64 = exponent.parse().unwrap_or(if exponent.starts_with('-') { i64::MIN / 2 } else { i64::MAX / 2 });
    let digits: String = format!("{int}{frac}");
    let digits = digits.trim_start_matches('0');
    if digits.is_empty() {
        return Some(Some(0));
    }
    // value = digits × 10^scale
    let scale = exponent - frac.len() as i64;
    let (whole, rest) = if scale >= 0 {
        (digits.to_string(), "")
    } else {
        let cut = digits.len() as i64 + scale;
        if cut <= 0 {
            return None; // 0 < value < 1
        }
        (digits[..cut as usize].to_string(), &digits[cut as usize..])
    };
    if rest.bytes().any(|b| b != b'0') {
        return None;
    }
    if whole.len() as i64 + scale.max(0) > 38 {
        return Some(None);
    }
    let n: i128 = whole.parse().ok()?;
    let n = n * 10i128.pow(scale.max(0) as u32);
    Some(Some(if negative { -n } else { n }))
}

/// Where scene text comes from. The compiler reads every file through one such door so
/// that the caller can hash and record what was read (watch mode follows those files).
pub trait Loader {
    fn load(&self, path: &Path) -> std::io::Result<Arc<str>>;

    /// The entries of a directory (files only), for properties that name a directory.
    fn list(&self, dir: &Path) -> std::io::Result<Vec<PathBuf>> {
        let mut out = Vec::new();
        for e in std::fs::read_dir(dir)? {
            let e = e?;
            if e.file_type()?.is_file() {
                out.push(e.path());
            }
        }
        Ok(out)
    }
}

pub struct Options<'a> {
    /// `--set name=value` overrides of `param` declarations.
    pub sets: &'a [(String, String)],
    pub registry: &'a [&'static KindSpec],
}

/// Compiles the scene rooted at `root` into a typed scene, or every problem found.
pub fn compile(root: &Path, loader: &dyn Loader, opts: &Options) -> Result<Scene, Diagnostics> {
    let mut cx = Cx { sources: SourceMap::default(), errors: Vec::new(), files: Vec::new() };
    let root = normalize(root);
    cx.load(&root, None, &mut Vec::new(), loader);
    if !cx.errors.is_empty() {
        return Err(Diagnostics::new(cx.errors, cx.sources));
    }
    let Cx { sources, mut errors, files } = cx;
    let mut checker = Checker::new(opts, sources, loader);
    checker.collect(&files);
    checker.apply_sets(opts.sets);
    checker.check_all();
    errors.append(&mut checker.errors);
    if errors.is_empty() {
        checker.check_cycles(&mut errors);
    }
    if !errors.is_empty() {
        return Err(Diagnostics::new(errors, checker.sources));
    }
    Ok(Scene {
        root,
        seed: checker.seed,
        size: checker.size,
        size_span: checker.size_span,
        decls: checker.out,
        sources: checker.sources,
    })
}

/// Lexical normalisation (`a/./b/../c` → `a/c`), so one file reached by two paths is one file.
///
/// A `..` cancels the component before it only where the operating system would agree:
/// that component is a real directory (not a link, which the system follows first, nor a
/// missing name, which makes the whole path fail). Elsewhere the `..` stays, so the read
/// resolves, or fails, exactly as the system resolves it. `/..` is `/`.
pub fn normalize(p: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => match out.components().next_back() {
                Some(Component::RootDir | Component::Prefix(_)) => {}
                Some(Component::Normal(_)) => {
                    match std::fs::symlink_metadata(&out) {
                        Ok(m) if m.is_dir() => {
                            out.pop();
                        }
                        Ok(m) if m.file_type().is_symlink() && out.is_dir() => {
                            // Follow the link as the system would, then go up from its target.
                            match out.canonicalize() {
                                Ok(real) => {
                                    out = real;
                                    out.pop();
                                }
                                Err(_) => out.push(".."),
                            }
                        }
                        _ => out.push(".."),
                    }
                }
                _ => out.push(".."),
            },
            c => out.push(c),
        }
    }
    out
}

struct Cx {
    sources: SourceMap,
    errors: Vec<Diagnostic>,
    files: Vec<(FileId, ast::File)>,
}

impl Cx {
    fn load(&mut self, path: &Path, via: Option<Span>, stack: &mut Vec<PathBuf>, loader: &dyn Loader) {
        if let Some(pos) = stack.iter().position(|p| p == path) {
            let chain: Vec<String> =
                stack[pos..].iter().chain(std::iter::once(&path.to_path_buf())).map(|p| file_name(p)).collect();
            let mut d = Diagnostic::error(format!("import cycle: {}", chain.join(" → ")))
                .with_code("tessera::import_cycle")
                .with_help(
                    "scenes may share declarations through imports, but no file may import itself, even indirectly",
                );
            if let Some(s) = via {
                d = d.with_label(s, "this import closes the cycle");
            }
            self.errors.push(d);
            return;
        }
        if self.sources.find(path).is_some() {
            return; // already loaded through another import
        }
        let text = match loader.load(path) {
            Ok(t) => t,
            Err(e) => {
                let mut d =
                    Diagnostic::error(format!("cannot read `{}`: {e}", path.display())).with_code("tessera::io");
                if let Some(s) = via {
                    d = d.with_label(s, "imported here");
                }
                self.errors.push(d);
                return;
            }
        };
        let id = self.sources.add(path.to_path_buf(), path.display().to_string(), text.clone());
        let file = match parse_file(&text, id) {
            Ok(f) => f,
            Err(d) => {
                self.errors.push(d);
                return;
            }
        };
        stack.push(path.to_path_buf());
        let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
        for item in &file.items {
            if let ast::Item::Import(imp) = item {
                let target = normalize(&dir.join(&imp.path));
                self.load(&target, Some(imp.path_span), stack, loader);
            }
        }
        stack.pop();
        self.files.push((id, file));
    }
}

fn file_name(p: &Path) -> String {
    p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| p.display().to_string())
}

struct ParamDef {
    value: ast::Value,
    span: Span,
}

struct DeclAst<'a> {
    spec: &'static KindSpec,
    name: String,
    name_span: Span,
    decl: &'a ast::Decl,
    file: FileId,
}

struct Checker<'a> {
    registry: &'a [&'static KindSpec],
    loader: &'a dyn Loader,
    sources: SourceMap,
    errors: Vec<Diagnostic>,
    params: HashMap<String, ParamDef>,
    decls: Vec<DeclAst<'a>>,
    kinds: HashMap<String, &'static KindSpec>,
    out: Vec<Decl>,
    seed: u64,
    size: (u32, u32),
    /// Where the scene's size was written, if it was.
    size_span: Option<Span>,
    default_file: Option<FileId>,
    /// References made by the declaration being checked: (name, span).
    deps: Vec<(String, Span)>,
    ref_spans: BTreeMap<String, Vec<(String, Span)>>,
}

impl<'a> Checker<'a> {
    fn new(opts: &'a Options, sources: SourceMap, loader: &'a dyn Loader) -> Self {
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
        }
    }

    fn spec(&self, kind: &str) -> Option<&'static KindSpec> {
        self.registry.iter().copied().find(|k| k.name == kind)
    }

    fn collect(&mut self, files: &'a [(FileId, ast::File)]) {
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

    fn apply_sets(&mut self, sets: &[(String, String)]) {
        for (name, text) in sets {
            let Some(def) = self.params.get_mut(name) else {
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

    fn check_all(&mut self) {
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

    fn dir_of(&self, file: FileId) -> PathBuf {
        self.sources.get(file).path.parent().unwrap_or(Path::new("")).to_path_buf()
    }

    fn check_block(&mut self, block: &ast::Block, specs: &[PropSpec], dir: &Path, owner: Span, what: &str) -> Props {
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

    fn mismatch(&mut self, v: &ast::Value, ty: &Ty) -> Option<Val> {
        self.errors.push(
            Diagnostic::error(format!("expected {}, found {}", ty.describe(), v.kind.describe_shape()))
                .with_code("tessera::type")
                .with_label(v.span, format!("expected {}", ty.describe())),
        );
        None
    }

    fn check_value(&mut self, v: &ast::Value, ty: &Ty, dir: &Path, depth: usize) -> Option<Val> {
        // A bare name that is a `param` stands for the param's value, unless a declaration
        // is expected and one of that name exists.
        if let ValueKind::Ident(name) = &v.kind {
            let wants_ref = matches!(ty, Ty::Ref(_) | Ty::Refs(_) | Ty::Source { .. });
            if !(wants_ref && self.kinds.contains_key(name)) {
                if let Some(def) = self.params.get(name) {
                    if depth > 16 {
                        self.errors.push(
                            Diagnostic::error(format!("param `{name}` refers to itself"))
                                .with_code("tessera::reference_cycle")
                                .with_label(def.span, "in this param"),
                        );
                        return None;
                    }
                    let value = def.value.clone();
                    return self.check_value(&value, ty, dir, depth + 1);
                }
            }
        }
        if let (Ty::Pixels(range), ValueKind::Number { text, unit, .. }) = (ty, &v.kind) {
            let text = match unit {
                Some(u) => format!("{text} {u}"),
                None => text.clone(),
            };
            let val = self.check_value(v, &Ty::Number(Unit::Length, *range), dir, depth + 1)?;
            if let Val::Num(x) = val {
                if x.fract() != 0.0 {
                    self.errors.push(
                        Diagnostic::error(format!("`{text}` is not a whole number of pixels"))
                            .with_code("tessera::whole_pixels")
                            .with_label(v.span, format!("{x} pixels"))
                            .with_help(format!("this property counts pixels: use `{} px`", x.round())),
                    );
                    return None;
                }
            }
            return Some(val);
        }
        match (ty, &v.kind) {
            (Ty::Number(unit, range), ValueKind::Number { value, unit: u, text }) => {
                if !value.is_finite() || value.abs() > MAX_NUMBER {
                    self.errors.push(
                        Diagnostic::error(format!("`{text}` is too large: numbers lie within ±{MAX_NUMBER:.1e}"))
                            .with_code("tessera::range")
                            .with_label(v.span, "beyond the range of numbers")
                            .with_help("tessera computes in 32-bit floats, whose largest value is about 3.4e38"),
                    );
                    return None;
                }
                let x = self.convert_unit(*value, u.as_deref(), *unit, v.span)?;
                if !x.is_finite() || x.abs() > MAX_NUMBER {
                    self.errors.push(
                        Diagnostic::error(format!("`{text}` overflows when converted to {}", unit.canonical()))
                            .with_code("tessera::range")
                            .with_label(v.span, "too large once converted"),
                    );
                    return None;
                }
                if x != 0.0 && (x.abs() as f32) < f32::MIN_POSITIVE {
                    self.errors.push(
                        Diagnostic::error(format!("`{text}` is too small: it rounds to 0 in 32-bit floats"))
                            .with_code("tessera::range")
                            .with_label(v.span, "below the smallest normal 32-bit float (about 1.2e-38)")
                            .with_help("write `0` if zero is meant"),
                    );
                    return None;
                }
                self.in_range(x, *range, *unit, v.span)
            }
            (Ty::Int(lo, hi), ValueKind::Number { text, unit: None, .. }) => {
                // Integers are read from their digits, not through an f64 (which rounds
                // 9007199254740993 to ...992), and are kept within ±2^53 so that any use
                // of them as a number is exact too.
                let (lo, hi) = ((*lo).max(-MAX_EXACT_INT), (*hi).min(MAX_EXACT_INT));
                match integer_literal(text) {
                    Some(Some(n)) if (i128::from(lo)..=i128::from(hi)).contains(&n) => Some(Val::Int(n as i64)),
                    found => {
                        let label = if found.is_none() { "not a whole number" } else { "out of range" };
                        let mut d = Diagnostic::error(format!("expected an integer from {lo} to {hi}, found {text}"))
                            .with_code("tessera::range")
                            .with_label(v.span, label);
                        if hi == MAX_EXACT_INT {
                            d = d.with_help(
                                "integers are limited to 2^53, the largest range a 64-bit float holds exactly",
                            );
                        }
                        self.errors.push(d);
                        None
                    }
                }
            }
            (Ty::Bool, ValueKind::Bool(b)) => Some(Val::Bool(*b)),
            (Ty::Size, ValueKind::Size { w, h, .. }) => {
                let ok = |x: f64| x.fract() == 0.0 && (1.0..=MAX_SIDE).contains(&x);
                if !ok(*w) || !ok(*h) {
                    self.errors.push(
                        Diagnostic::error(format!("sizes are whole numbers of pixels from 1 to {MAX_SIDE}"))
                            .with_code("tessera::range")
                            .with_label(v.span, "invalid size"),
                    );
                    return None;
                }
                Some(Val::Size(*w as u32, *h as u32))
            }
            (Ty::Vec2(unit), ValueKind::Vector(items)) => {
                if items.len() != 2 {
                    self.errors.push(
                        Diagnostic::error(format!("expected a vector of 2 numbers, found {}", items.len()))
                            .with_code("tessera::type")
                            .with_label(v.span, "expected `[x, y]`"),
                    );
                    return None;
                }
                self.numbers(items, *unit, super::schema::ANY).map(Val::Numbers)
            }
            (Ty::Numbers(unit, range), ValueKind::Vector(items)) => {
                self.numbers(items, *unit, *range).map(Val::Numbers)
            }
            (Ty::Points, ValueKind::Vector(items)) => {
                let mut pts = Vec::new();
                for it in items {
                    match &it.kind {
                        ValueKind::Vector(xy) if xy.len() == 2 => {
                            let n = self.numbers(xy, Unit::Length, super::schema::ANY)?;
                            pts.push([n[0], n[1]]);
                        }
                        _ => return self.mismatch(it, &Ty::Vec2(Unit::Length)),
                    }
                }
                Some(Val::Points(pts))
            }
            (Ty::Str, ValueKind::Str(s)) => Some(Val::Str(s.clone())),
            (Ty::Path, ValueKind::Str(s)) => {
                if s.is_empty() {
                    self.errors.push(
                        Diagnostic::error("empty file path").with_code("tessera::type").with_label(v.span, "here"),
                    );
                    return None;
                }
                Some(Val::Path(normalize(&dir.join(s))))
            }
            (Ty::Dir(extensions), ValueKind::Str(s)) => self.directory(s, v.span, dir, extensions),
            (Ty::Enum(options), ValueKind::Ident(name)) => {
                if options.contains(&name.as_str()) {
                    Some(Val::Enum(name.clone()))
                } else {
                    let mut d = Diagnostic::error(format!("`{name}` is not one of {}", ty.describe()))
                        .with_code("tessera::enum")
                        .with_label(v.span, "unknown option");
                    if let Some(s) = suggest(name, options.iter().copied()) {
                        d = d.with_help(format!("did you mean `{s}`?"));
                    }
                    self.errors.push(d);
                    None
                }
            }
            (Ty::Ref(kinds), ValueKind::Ident(name)) => self.reference(name, v.span, kinds).map(Val::Ref),
            (Ty::Refs(kinds), ValueKind::Vector(items)) => {
                let mut out = Vec::new();
                for it in items {
                    match &it.kind {
                        ValueKind::Ident(n) => out.push(self.reference(n, it.span, kinds)?),
                        _ => return self.mismatch(it, &Ty::Ref(kinds)),
                    }
                }
                Some(Val::Refs(out))
            }
            (Ty::Source { refs, .. }, ValueKind::Ident(name)) if !refs.is_empty() => {
                self.reference(name, v.span, refs).map(Val::Ref)
            }
            (Ty::Source { calls, .. }, ValueKind::Call { name, args }) => self.call(calls, name, args, v.span, dir),
            (Ty::Calls(calls), ValueKind::Vector(items)) => {
                let mut out = Vec::with_capacity(items.len());
                let mut ok = true;
                for it in items {
                    match &it.kind {
                        ValueKind::Call { name, args } => match self.call(calls, name, args, it.span, dir) {
                            Some(Val::Call(c)) => out.push(c),
                            _ => ok = false,
                        },
                        _ => {
                            self.mismatch(it, &Ty::Source { calls, refs: &[] });
                            ok = false;
                        }
                    }
                }
                ok.then_some(Val::Calls(out))
            }
            (Ty::Block(specs), ValueKind::Block(b)) => {
                Some(Val::Block(self.check_block(b, specs, dir, v.span, "block")))
            }
            (Ty::Block(_), _) => self.mismatch(v, ty),
            (_, ValueKind::Ident(name)) if !matches!(ty, Ty::Enum(_)) && !self.kinds.contains_key(name) => {
                self.unknown_name(name, v.span, ty)
            }
            _ => self.mismatch(v, ty),
        }
    }

    fn unknown_name(&mut self, name: &str, span: Span, ty: &Ty) -> Option<Val> {
        let mut d = Diagnostic::error(format!("unknown name `{name}`"))
            .with_code("tessera::unknown_name")
            .with_label(span, format!("expected {}", ty.describe()));
        let candidates: Vec<&str> = self.params.keys().map(|k| k.as_str()).collect();
        if let Some(s) = suggest(name, candidates) {
            d = d.with_help(format!("did you mean the param `{s}`?"));
        }
        self.errors.push(d);
        None
    }

    /// A directory and the files in it with one of `extensions`, sorted by name.
    fn directory(&mut self, s: &str, span: Span, dir: &Path, extensions: &[&str]) -> Option<Val> {
        let path = normalize(&dir.join(s));
        let listed = match self.loader.list(&path) {
            Ok(l) => l,
            Err(e) => {
                self.errors.push(
                    Diagnostic::error(format!("cannot read the directory `{}`: {e}", path.display()))
                        .with_code("tessera::directory")
                        .with_label(span, "this directory"),
                );
                return None;
            }
        };
        let mut files: Vec<PathBuf> = listed
            .into_iter()
            .filter(|f| {
                f.extension()
                    .and_then(|e| e.to_str())
                    .is_some_and(|e| extensions.iter().any(|x| x.eq_ignore_ascii_case(e)))
            })
            .collect();
        files.sort();
        if files.is_empty() {
            let list = extensions.iter().map(|e| format!("`.{e}`")).collect::<Vec<_>>().join(", ");
            self.errors.push(
                Diagnostic::error(format!("the directory `{}` holds no {list} files", path.display()))
                    .with_code("tessera::empty_directory")
                    .with_label(span, "this directory is empty")
                    .with_help("put at least one image in it, or name another directory"),
            );
            return None;
        }
        Some(Val::Dir(path, files))
    }

    fn numbers(&mut self, items: &[ast::Value], unit: Unit, range: Range) -> Option<Vec<f64>> {
        let mut out = Vec::with_capacity(items.len());
        for it in items {
            match self.check_value(it, &Ty::Number(unit, range), Path::new(""), 0)? {
                Val::Num(x) => out.push(x),
                _ => return None,
            }
        }
        Some(out)
    }

    fn convert_unit(&mut self, x: f64, written: Option<&str>, unit: Unit, span: Span) -> Option<f64> {
        let v = match (unit, written) {
            (Unit::Length, None | Some("px")) => Some(x),
            (Unit::Angle, None | Some("deg")) => Some(x.to_radians()),
            (Unit::Angle, Some("rad")) => Some(x),
            (Unit::Fraction, None) => Some(x),
            (Unit::Fraction, Some("%")) => Some(x / 100.0),
            (Unit::Plain, None) => Some(x),
            _ => None,
        };
        if v.is_none() {
            let w = written.unwrap_or("");
            let help = match unit {
                Unit::Length => "lengths are in pixels: write `px` or no unit",
                Unit::Angle => "angles take `deg` (the default) or `rad`",
                Unit::Fraction => "fractions are plain numbers or percentages",
                Unit::Plain => "remove the unit",
            };
            self.errors.push(
                Diagnostic::error(format!("unit `{w}` does not fit here: expected {}", unit.describe()))
                    .with_code("tessera::unit")
                    .with_label(span, "wrong unit")
                    .with_help(help),
            );
        }
        v
    }

    fn in_range(&mut self, x: f64, r: Range, unit: Unit, span: Span) -> Option<Val> {
        if !x.is_finite() {
            self.errors.push(
                Diagnostic::error("number too large")
                    .with_code("tessera::range")
                    .with_label(span, "not a finite number"),
            );
            return None;
        }
        if x >= r.min && x <= r.max {
            return Some(Val::Num(x));
        }
        let compact = |b: f64| {
            if b != 0.0 && !(1e-4..1e9).contains(&b.abs()) {
                format!("{b:e}")
            } else {
                format!("{b}")
            }
        };
        let shown = |b: f64| if unit == Unit::Angle { format!("{} deg", compact(b.to_degrees())) } else { compact(b) };
        let msg = if r.max == f64::INFINITY && r.min == f64::MIN_POSITIVE {
            "must be greater than 0".to_string()
        } else if r.max == f64::INFINITY {
            format!("must be at least {}", shown(r.min))
        } else {
            format!("must be from {} to {}", shown(r.min), shown(r.max))
        };
        self.errors.push(
            Diagnostic::error(format!("value out of range: {msg}")).with_code("tessera::range").with_label(span, msg),
        );
        None
    }

    /// The kinds whose declarations produce one of `values`, for messages: `sample or layer`.
    fn producers(&self, values: &[Value]) -> String {
        let kinds: Vec<&str> =
            self.registry.iter().filter(|k| k.produces.iter().any(|v| values.contains(v))).map(|k| k.name).collect();
        kinds.join(" or ")
    }

    fn reference(&mut self, name: &str, span: Span, values: &[Value]) -> Option<String> {
        let produces = |k: &KindSpec| k.produces.iter().any(|v| values.contains(v));
        match self.kinds.get(name) {
            Some(k) if produces(k) => {
                self.deps.push((name.to_string(), span));
                Some(name.to_string())
            }
            Some(k) => {
                let producers = self.producers(values);
                let mut d = Diagnostic::error(format!(
                    "`{name}` is a {}, but {} is expected here",
                    k.name,
                    schema::values(values)
                ))
                .with_code("tessera::wrong_kind")
                .with_label(span, format!("this is a {}", k.name));
                if producers.contains(" or ") {
                    d = d.with_help(format!("{} comes from a {producers}", schema::values(values)));
                }
                self.errors.push(d);
                None
            }
            None => {
                let mut d = Diagnostic::error(format!("unknown name `{name}`"))
                    .with_code("tessera::unknown_name")
                    .with_label(span, format!("no {} of this name", self.producers(values)));
                let candidates: Vec<&str> =
                    self.kinds.iter().filter(|(_, k)| produces(k)).map(|(n, _)| n.as_str()).collect();
                if let Some(s) = suggest(name, candidates) {
                    d = d.with_help(format!("did you mean `{s}`?"));
                }
                self.errors.push(d);
                None
            }
        }
    }

    fn call(
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

    fn check_cycles(&self, errors: &mut Vec<Diagnostic>) {
        // Colour DFS over declaration references; report each cycle once.
        let mut state: HashMap<&str, u8> = HashMap::new();
        let mut stack: Vec<(&str, Span)> = Vec::new();
        fn visit<'b>(
            c: &'b Checker,
            n: &'b str,
            state: &mut HashMap<&'b str, u8>,
            stack: &mut Vec<(&'b str, Span)>,
            errors: &mut Vec<Diagnostic>,
        ) {
            state.insert(n, 1);
            for (dep, span) in c.ref_spans.get(n).map(|v| v.as_slice()).unwrap_or(&[]) {
                match state.get(dep.as_str()) {
                    Some(1) => {
                        let start = stack.iter().position(|(s, _)| *s == dep.as_str()).unwrap_or(0);
                        let mut names: Vec<&str> = stack[start..].iter().map(|(s, _)| *s).collect();
                        names.push(n);
                        names.push(dep);
                        names.dedup();
                        let mut d = Diagnostic::error(format!("reference cycle: {}", names.join(" → ")))
                            .with_code("tessera::reference_cycle")
                            .with_label(*span, format!("`{n}` refers to `{dep}` here"))
                            .with_help("a declaration cannot depend on its own result; break the cycle");
                        for (s, sp) in stack[start..].iter().skip(1) {
                            d = d.with_label(*sp, format!("…which leads to `{s}`"));
                        }
                        errors.push(d);
                    }
                    Some(_) => {}
                    None => {
                        stack.push((dep, *span));
                        visit(c, dep, state, stack, errors);
                        stack.pop();
                    }
                }
            }
            state.insert(n, 2);
        }
        for d in &self.out {
            if !state.contains_key(d.name.as_str()) {
                stack.push((&d.name, d.name_span));
                visit(self, &d.name, &mut state, &mut stack, errors);
                stack.pop();
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

#[cfg(test)]
mod tests {
    use super::integer_literal;

    #[test]
    fn integer_literals_are_read_exactly() {
        assert_eq!(integer_literal("9007199254740993"), Some(Some(9_007_199_254_740_993)));
        assert_eq!(integer_literal("-12"), Some(Some(-12)));
        assert_eq!(integer_literal("1.5e3"), Some(Some(1500)));
        assert_eq!(integer_literal("20.000"), Some(Some(20)));
        assert_eq!(integer_literal("0.0"), Some(Some(0)));
        assert_eq!(integer_literal("1200e-2"), Some(Some(12)));
        assert_eq!(integer_literal("1.5"), None);
        assert_eq!(integer_literal("9007199254740992.5"), None);
        assert_eq!(integer_literal("5e-1"), None);
        assert_eq!(integer_literal("1e400"), Some(None));
        assert_eq!(integer_literal("1e99999999999999999999"), Some(None));
        assert_eq!(integer_literal("1e-99999999999999999999"), None);
    }
}
