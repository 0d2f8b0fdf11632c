//! The typed scene: declarations with every property checked, converted to canonical units
//! and defaulted. This is what `kinds/` plans from.

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::Serialize;

use super::source::{FileId, SourceMap, Span};

#[derive(Clone, Debug, Serialize, PartialEq)]
#[serde(rename_all = "snake_case")]
pub enum Val {
    Num(f64),
    Int(i64),
    Bool(bool),
    Size(u32, u32),
    Numbers(Vec<f64>),
    Points(Vec<[f64; 2]>),
    Str(String),
    /// A resolved file path. Serialised (for cache keys) by file name only: the content
    /// hash of the file, not where it lives, is what a stage's result depends on.
    Path(#[serde(serialize_with = "file_name_only")] PathBuf),
    /// A directory and the files it holds (sorted). Serialised by file names only.
    Dir(#[serde(skip)] PathBuf, #[serde(serialize_with = "file_names_only")] Vec<PathBuf>),
    /// Files named one by one or by a pattern, in order (a pattern's matches sorted by name),
    /// each with the span of the string that named it. Serialised by file names only.
    Files(#[serde(serialize_with = "file_names_only")] Vec<PathBuf>, #[serde(skip)] Vec<Span>),
    Enum(String),
    Ref(String),
    Refs(Vec<String>),
    Call(Call),
    Calls(Vec<Call>),
    Block(Props),
}

fn file_name_only<S: serde::Serializer>(p: &std::path::Path, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default())
}

fn file_names_only<S: serde::Serializer>(ps: &[PathBuf], s: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeSeq;
    let mut seq = s.serialize_seq(Some(ps.len()))?;
    for p in ps {
        seq.serialize_element(&p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default())?;
    }
    seq.end()
}

#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Call {
    pub name: String,
    pub args: Props,
    /// Where the call was written, for errors found when it is applied.
    #[serde(skip)]
    pub span: Option<Span>,
}

#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Prop {
    pub val: Val,
    /// Where the user wrote it; `None` for a default.
    #[serde(skip)]
    pub span: Option<Span>,
}

/// Checked properties by name, in a stable order.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct Props(pub BTreeMap<String, Prop>);

impl Props {
    pub fn get(&self, name: &str) -> Option<&Val> {
        self.0.get(name).map(|p| &p.val)
    }

    pub fn span(&self, name: &str) -> Option<Span> {
        self.0.get(name).and_then(|p| p.span)
    }

    /// The span of the property at `path`, `block.name` for one inside a block; when the
    /// user did not write it, the span of the nearest enclosing block they wrote.
    pub fn span_at(&self, path: &str) -> Option<Span> {
        let (head, rest) = match path.split_once('.') {
            Some((head, rest)) => (head, Some(rest)),
            None => (path, None),
        };
        let prop = self.0.get(head)?;
        let inner = match (rest, &prop.val) {
            (Some(rest), Val::Block(b)) => b.span_at(rest),
            _ => None,
        };
        inner.or(prop.span)
    }

    fn expect(&self, name: &str) -> &Val {
        self.get(name).unwrap_or_else(|| panic!("schema guarantees property `{name}`"))
    }

    pub fn num(&self, name: &str) -> f64 {
        match self.expect(name) {
            Val::Num(v) => *v,
            Val::Int(v) => *v as f64,
            v => panic!("property `{name}` is not a number: {v:?}"),
        }
    }

    pub fn opt_num(&self, name: &str) -> Option<f64> {
        self.get(name).map(|_| self.num(name))
    }

    pub fn opt_int(&self, name: &str) -> Option<i64> {
        self.get(name).map(|_| self.int(name))
    }

    pub fn int(&self, name: &str) -> i64 {
        match self.expect(name) {
            Val::Int(v) => *v,
            v => panic!("property `{name}` is not an integer: {v:?}"),
        }
    }

    /// A whole-pixel length (`Ty::Pixels`, checked whole and in range by the schema).
    pub fn pixels(&self, name: &str) -> usize {
        self.opt_pixels(name).unwrap_or_else(|| panic!("property `{name}` has no value"))
    }

    pub fn opt_pixels(&self, name: &str) -> Option<usize> {
        self.opt_num(name).map(|v| {
            debug_assert!(v.fract() == 0.0 && v >= 0.0, "`{name}` = {v} is not whole pixels");
            v as usize
        })
    }

    pub fn bool(&self, name: &str) -> bool {
        match self.expect(name) {
            Val::Bool(v) => *v,
            v => panic!("property `{name}` is not a boolean: {v:?}"),
        }
    }

    pub fn size(&self, name: &str) -> (u32, u32) {
        self.opt_size(name).unwrap_or_else(|| panic!("property `{name}` is not a size"))
    }

    pub fn opt_size(&self, name: &str) -> Option<(u32, u32)> {
        match self.get(name)? {
            Val::Size(w, h) => Some((*w, *h)),
            v => panic!("property `{name}` is not a size: {v:?}"),
        }
    }

    pub fn numbers(&self, name: &str) -> &[f64] {
        self.opt_numbers(name).unwrap_or_else(|| panic!("property `{name}` is not a vector"))
    }

    pub fn opt_numbers(&self, name: &str) -> Option<&[f64]> {
        match self.get(name)? {
            Val::Numbers(v) => Some(v),
            v => panic!("property `{name}` is not a vector: {v:?}"),
        }
    }

    pub fn vec2(&self, name: &str) -> [f64; 2] {
        let v = self.numbers(name);
        [v[0], v[1]]
    }

    pub fn points(&self, name: &str) -> &[[f64; 2]] {
        match self.expect(name) {
            Val::Points(v) => v,
            v => panic!("property `{name}` is not a point list: {v:?}"),
        }
    }

    pub fn str(&self, name: &str) -> &str {
        match self.expect(name) {
            Val::Str(v) | Val::Enum(v) | Val::Ref(v) => v,
            v => panic!("property `{name}` is not a string: {v:?}"),
        }
    }

    pub fn enumeration(&self, name: &str) -> &str {
        self.str(name)
    }

    pub fn path(&self, name: &str) -> Option<&PathBuf> {
        match self.get(name)? {
            Val::Path(p) => Some(p),
            v => panic!("property `{name}` is not a path: {v:?}"),
        }
    }

    /// A directory property: the directory and its files.
    pub fn dir(&self, name: &str) -> Option<(&PathBuf, &[PathBuf])> {
        match self.get(name)? {
            Val::Dir(d, files) => Some((d, files)),
            v => panic!("property `{name}` is not a directory: {v:?}"),
        }
    }

    /// A files property: the files, each with the span of the string that named it.
    pub fn files(&self, name: &str) -> Option<(&[PathBuf], &[Span])> {
        match self.get(name)? {
            Val::Files(files, spans) => Some((files, spans)),
            v => panic!("property `{name}` is not a list of files: {v:?}"),
        }
    }

    pub fn reference(&self, name: &str) -> Option<&str> {
        match self.get(name)? {
            Val::Ref(r) => Some(r),
            v => panic!("property `{name}` is not a reference: {v:?}"),
        }
    }

    pub fn refs(&self, name: &str) -> &[String] {
        match self.expect(name) {
            Val::Refs(r) => r,
            v => panic!("property `{name}` is not a reference list: {v:?}"),
        }
    }

    pub fn calls(&self, name: &str) -> &[Call] {
        match self.expect(name) {
            Val::Calls(c) => c,
            v => panic!("property `{name}` is not a call list: {v:?}"),
        }
    }

    pub fn block(&self, name: &str) -> &Props {
        match self.expect(name) {
            Val::Block(b) => b,
            v => panic!("property `{name}` is not a block: {v:?}"),
        }
    }

    /// A canonical text of these properties, for stage keys.
    pub fn canonical(&self) -> String {
        serde_json::to_string(self).expect("props serialise")
    }
}

#[derive(Clone, Debug)]
pub struct Decl {
    pub kind: &'static str,
    pub name: String,
    pub name_span: Span,
    pub span: Span,
    pub file: FileId,
    pub props: Props,
    /// Names of declarations this one refers to, in first-use order.
    pub deps: Vec<String>,
}

/// A resolved, type-checked scene.
#[derive(Debug)]
pub struct Scene {
    pub root: PathBuf,
    pub seed: u64,
    pub size: (u32, u32),
    /// Where the size was written (absent: the default).
    pub size_span: Option<Span>,
    pub decls: Vec<Decl>,
    pub sources: SourceMap,
    /// The names of its `param`s, sorted (which `--set`s it takes).
    pub params: Vec<String>,
}

impl Scene {
    pub fn decl(&self, name: &str) -> Option<&Decl> {
        self.decls.iter().find(|d| d.name == name)
    }

    /// Declarations ordered so that each comes after everything it refers to.
    pub fn topo_order(&self) -> Vec<&Decl> {
        let mut order = Vec::with_capacity(self.decls.len());
        let mut state = BTreeMap::new();
        fn visit<'a>(s: &'a Scene, d: &'a Decl, state: &mut BTreeMap<&'a str, bool>, out: &mut Vec<&'a Decl>) {
            if state.contains_key(d.name.as_str()) {
                return;
            }
            state.insert(&d.name, false);
            for dep in &d.deps {
                if let Some(dd) = s.decl(dep) {
                    visit(s, dd, state, out);
                }
            }
            state.insert(&d.name, true);
            out.push(d);
        }
        for d in &self.decls {
            visit(self, d, &mut state, &mut order);
        }
        order
    }
}
