//! An open document as the compiler sees it: its diagnostics (the project's own compile,
//! parse to plan, with open documents read from memory) and the declarations of the
//! document and the files it imports, for hover, completion, definition and rename.

use std::cell::RefCell;
use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::Arc;

use lsp_types::{DiagnosticRelatedInformation, DiagnosticSeverity, Location, NumberOrString, Uri};

use super::position::LineIndex;
use crate::lang::ast::{self, Item, ValueKind};
use crate::lang::parse::parse_file;
use crate::lang::schema::{self, Ty};
use crate::lang::source::{FileId, Span};
use crate::lang::{self, Diagnostics, KindSpec};
use crate::project::{Project, WorldLoader};

/// The largest file read from disk for navigation (an import, say).
const MAX_FILE: u64 = 16 << 20;
/// At most this many files of an import closure are read for navigation.
const MAX_FILES: usize = 256;

/// The text of the open documents, by normalised path.
pub type Open = HashMap<PathBuf, Arc<str>>;

/// Reads open documents from memory and everything else as a build would, and notes what
/// was read, so a change to one document re-checks exactly the documents that read it.
struct Overlay<'a> {
    open: &'a Open,
    disk: WorldLoader<'a>,
    read: RefCell<BTreeSet<PathBuf>>,
}

impl lang::Loader for Overlay<'_> {
    fn load(&self, path: &Path) -> std::io::Result<Arc<str>> {
        self.read.borrow_mut().insert(path.to_path_buf());
        match self.open.get(path) {
            Some(text) => Ok(text.clone()),
            None => self.disk.load(path),
        }
    }

    fn list(&self, dir: &Path) -> std::io::Result<Vec<PathBuf>> {
        self.read.borrow_mut().insert(dir.to_path_buf());
        self.disk.list(dir)
    }
}

/// The file URI of a path, percent-encoded.
pub fn uri_of(path: &Path) -> Option<Uri> {
    const KEEP: &percent_encoding::AsciiSet =
        &percent_encoding::NON_ALPHANUMERIC.remove(b'/').remove(b'-').remove(b'.').remove(b'_').remove(b'~');
    let abs = if path.is_absolute() { path.to_path_buf() } else { std::env::current_dir().ok()?.join(path) };
    let s = abs.to_str()?;
    Uri::from_str(&format!("file://{}", percent_encoding::utf8_percent_encode(s, KEEP))).ok()
}

/// The path of a `file:` URI; `None` for any other scheme or an undecodable one.
pub fn path_of(uri: &Uri) -> Option<PathBuf> {
    let rest = uri.as_str().strip_prefix("file://")?;
    // `file://host/path`: only the local host (empty or `localhost`) names a local file.
    let rest = rest.strip_prefix("localhost").unwrap_or(rest);
    if !rest.starts_with('/') || rest.contains(['?', '#']) {
        return None;
    }
    let decoded = percent_encoding::percent_decode_str(rest).decode_utf8().ok()?;
    Some(lang::normalize(Path::new(decoded.as_ref())))
}

/// What checking one document found: its diagnostics and every file it read.
pub struct Checked {
    pub diagnostics: Vec<lsp_types::Diagnostic>,
    pub read: BTreeSet<PathBuf>,
}

/// Compiles the document at `path` (its text in `open`) as `tessera check` does before it
/// runs any stage: parse, resolve, type-check and plan. Nothing is built or written.
pub fn check(path: &Path, open: &Open) -> Checked {
    let dir = path.parent().unwrap_or(Path::new("/"));
    let text = open.get(path).cloned().unwrap_or_else(|| "".into());
    let mut project = match Project::open(dir) {
        Ok(p) => p,
        Err(f) => {
            return Checked { diagnostics: convert(&f.diagnostics, path, &text), read: BTreeSet::new() };
        }
    };
    project.progress = false;
    let overlay = Overlay { open, disk: WorldLoader(&project.world), read: RefCell::default() };
    let diagnostics = match project.compile_through(path, &overlay) {
        Ok(_) => Vec::new(),
        Err(f) => convert(&f.diagnostics, path, &text),
    };
    Checked { diagnostics, read: overlay.read.into_inner() }
}

/// The compiler's diagnostics as the protocol's, on the document at `path`. A diagnostic in
/// another file (an imported one) is shown on the import that leads to it, with the place
/// itself as related information; one with no place at all, on the first character.
fn convert(d: &Diagnostics, path: &Path, text: &str) -> Vec<lsp_types::Diagnostic> {
    let ix = LineIndex::new(text);
    let here = |file: FileId| d.sources.files().any(|(id, f)| id == file && f.path == path);
    let location = |span: Span| -> Option<Location> {
        let f = d.sources.files().find(|(id, _)| *id == span.file)?.1;
        let ix = LineIndex::new(&f.text);
        Some(Location::new(uri_of(&f.path)?, ix.range(span.start, span.end)))
    };
    let imports: Vec<(PathBuf, Span)> = match parse_file(text, FileId(0)) {
        Ok(file) => file
            .items
            .iter()
            .filter_map(|i| match i {
                Item::Import(imp) => Some((lang::normalize(&path.parent()?.join(&imp.path)), imp.path_span)),
                _ => None,
            })
            .collect(),
        Err(_) => Vec::new(),
    };
    d.items
        .iter()
        .map(|item| {
            let mut message = item.message.clone();
            let mut related = Vec::new();
            let range = match item.labels.first() {
                Some((span, label)) if here(span.file) => {
                    // A label that only repeats the message (`unknown property` under
                    // "unknown property `gird` for `layer`") adds nothing in an editor, where
                    // the range already points at the text.
                    if !label.is_empty() && !item.message.to_lowercase().contains(&label.to_lowercase()) {
                        message.push_str(&format!("\n{label}"));
                    }
                    ix.range(span.start, span.end)
                }
                Some((span, label)) => {
                    let other = d.sources.files().find(|(id, _)| *id == span.file).map(|(_, f)| f.path.clone());
                    let via = imports.iter().find(|(p, _)| Some(p) == other.as_ref()).or(imports.first());
                    if let Some(o) = &other {
                        message = format!("{}: {message}", o.display());
                    }
                    if let Some(loc) = location(*span) {
                        related.push(DiagnosticRelatedInformation { location: loc, message: label.clone() });
                    }
                    via.map_or_else(|| ix.range(0, 0), |(_, s)| ix.range(s.start, s.end))
                }
                None => ix.range(0, 0),
            };
            for (span, label) in item.labels.iter().skip(1) {
                if let Some(location) = location(*span) {
                    related.push(DiagnosticRelatedInformation { location, message: label.clone() });
                }
            }
            if let Some(help) = &item.help {
                message.push_str(&format!("\nhelp: {help}"));
            }
            lsp_types::Diagnostic {
                range,
                severity: Some(DiagnosticSeverity::ERROR),
                code: Some(NumberOrString::String(item.code.to_string())),
                source: Some("tessera".into()),
                message,
                related_information: (!related.is_empty()).then_some(related),
                ..Default::default()
            }
        })
        .collect()
}

/// One file of a document's import closure.
pub struct Source {
    pub path: PathBuf,
    pub text: Arc<str>,
    /// `None` when it does not parse.
    pub ast: Option<ast::File>,
}

/// A declaration or param by name.
pub struct Symbol {
    pub name: String,
    /// The kind's spec; `None` for a param.
    pub spec: Option<&'static KindSpec>,
    pub file: usize,
    pub span: Span,
}

/// A document and the files it imports (transitively), parsed on their own so that
/// navigation works while the document has errors elsewhere.
pub struct Unit {
    /// The document first.
    pub sources: Vec<Source>,
    pub symbols: Vec<Symbol>,
}

impl Unit {
    pub fn load(path: &Path, open: &Open) -> Unit {
        let registry = crate::kinds::registry();
        let mut sources: Vec<Source> = Vec::new();
        let mut queue = vec![path.to_path_buf()];
        while let Some(p) = queue.pop() {
            if sources.len() >= MAX_FILES || sources.iter().any(|s| s.path == p) {
                continue;
            }
            let text: Arc<str> = match open.get(&p) {
                Some(t) => t.clone(),
                None => match crate::graph::world::read_regular_text(&p, MAX_FILE) {
                    Ok(t) => t.into(),
                    Err(_) => continue,
                },
            };
            let id = FileId(sources.len() as u32);
            let ast = parse_file(&text, id).ok();
            let dir = p.parent().unwrap_or(Path::new("/")).to_path_buf();
            let imports: Vec<String> = match &ast {
                Some(file) => file
                    .items
                    .iter()
                    .filter_map(|item| match item {
                        Item::Import(imp) => Some(imp.path.clone()),
                        _ => None,
                    })
                    .collect(),
                None => outline(&text, id).0,
            };
            for imp in imports.iter().rev() {
                queue.push(lang::normalize(&dir.join(imp)));
            }
            sources.push(Source { path: p, text, ast });
        }
        let mut symbols = Vec::new();
        for (i, s) in sources.iter().enumerate() {
            if s.ast.is_none() {
                for (kind, name, span) in outline(&s.text, FileId(i as u32)).1 {
                    let spec = registry.iter().copied().find(|k| k.name == kind);
                    symbols.push(Symbol { name, spec, file: i, span });
                }
            }
            for item in s.ast.iter().flat_map(|f| &f.items) {
                match item {
                    Item::Decl(d) => {
                        if let Some(name) = d.name.as_ref().filter(|n| !n.quoted) {
                            let spec = registry.iter().copied().find(|k| k.name == d.kind.text);
                            symbols.push(Symbol { name: name.text.clone(), spec, file: i, span: name.span });
                        }
                    }
                    Item::Param(p) => {
                        symbols.push(Symbol { name: p.name.text.clone(), spec: None, file: i, span: p.name.span })
                    }
                    _ => {}
                }
            }
        }
        Unit { sources, symbols }
    }

    pub fn symbol(&self, name: &str) -> Option<&Symbol> {
        self.symbols.iter().find(|s| s.name == name)
    }

    /// Every place file `file` names `name` as a reference (not its declaration).
    pub fn references(&self, file: usize, name: &str) -> Vec<Span> {
        let mut out = Vec::new();
        let Some(ast) = &self.sources[file].ast else { return out };
        let registry = crate::kinds::registry();
        for item in &ast.items {
            match item {
                Item::Param(p) => refs_in(&p.value, None, name, &mut out),
                Item::Decl(d) => {
                    let spec = registry.iter().find(|k| k.name == d.kind.text);
                    block_refs(&d.block, spec.map(|s| s.props), name, &mut out);
                }
                _ => {}
            }
        }
        out
    }
}

/// The imports and top-level declarations of a file that does not parse (one being typed),
/// read line by line: `import "…"`, `KIND NAME {` and `param NAME =` at bracket depth 0. A
/// param's kind is empty.
fn outline(text: &str, file: FileId) -> (Vec<String>, Vec<(String, String, Span)>) {
    let (mut imports, mut decls) = (Vec::new(), Vec::new());
    let mut depth = 0i64;
    let mut at = 0;
    for line in text.split_inclusive('\n') {
        let start = at;
        at += line.len();
        if depth == 0 {
            let words: Vec<&str> = line.split_whitespace().collect();
            let ident = |w: &str| !w.is_empty() && w.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
            match words.as_slice() {
                ["import", path, ..] if path.len() >= 2 && path.starts_with('"') && path.ends_with('"') => {
                    imports.push(path[1..path.len() - 1].to_string())
                }
                [kind, name, ..] if ident(kind) && ident(name.trim_end_matches(['{', '='])) => {
                    let name = name.trim_end_matches(['{', '=']);
                    let offset = start + line.find(kind).unwrap_or(0) + kind.len();
                    let offset = offset + line[offset - start..].find(name).unwrap_or(0);
                    let kind = if *kind == "param" { String::new() } else { kind.to_string() };
                    decls.push((kind, name.to_string(), Span::new(file, offset, offset + name.len())));
                }
                _ => {}
            }
        }
        let code = line.split('#').next().unwrap_or("");
        let mut in_string = false;
        for c in code.chars() {
            match c {
                '"' => in_string = !in_string,
                '{' | '[' | '(' if !in_string => depth += 1,
                '}' | ']' | ')' if !in_string => depth = (depth - 1).max(0),
                _ => {}
            }
        }
    }
    (imports, decls)
}

fn block_refs(b: &ast::Block, props: Option<&[schema::PropSpec]>, name: &str, out: &mut Vec<Span>) {
    for p in b.properties() {
        let spec = props.and_then(|ps| ps.iter().find(|s| s.name == p.name.text));
        refs_in(&p.value, spec.map(|s| &s.ty), name, out);
    }
}

/// References to `name` in a value; the words of an enum property are not references.
fn refs_in(v: &ast::Value, ty: Option<&Ty>, name: &str, out: &mut Vec<Span>) {
    match &v.kind {
        ValueKind::Ident(s) if s == name && !matches!(ty, Some(Ty::Enum(_) | Ty::Bool)) => out.push(v.span),
        ValueKind::Field { base, .. }
            if base.text == name && base.text != schema::SCENE_SIZE && base.text != schema::OWN_EXTENT =>
        {
            out.push(base.span)
        }
        ValueKind::Vector(items) => items.iter().for_each(|i| refs_in(i, ty, name, out)),
        ValueKind::Call { args, .. } => args.iter().for_each(|a| refs_in(&a.value, None, name, out)),
        ValueKind::Block(b) => {
            let inner = match ty {
                Some(Ty::Block(inner)) => Some(*inner),
                _ => None,
            };
            block_refs(b, inner, name, out)
        }
        ValueKind::Chain { first, rest } => {
            refs_in(first, None, name, out);
            rest.iter().for_each(|(_, r)| refs_in(r, None, name, out));
        }
        ValueKind::Neg(x) | ValueKind::Paren(x) => refs_in(x, None, name, out),
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_being_typed_still_has_an_outline() {
        let text = "import \"_lib.tess\"\nparam k = 2\nkind a {\n  x = [\n  inner b {\n}\nother c{\n  in\n";
        let (imports, decls) = outline(text, FileId(0));
        assert_eq!(imports, vec!["_lib.tess"]);
        let names: Vec<(&str, &str)> = decls.iter().map(|(k, n, _)| (k.as_str(), n.as_str())).collect();
        assert_eq!(names, vec![("", "k"), ("kind", "a")], "`inner b` is inside an open bracket");
        let (_, _, span) = &decls[1];
        assert_eq!(&text[span.start..span.end], "a");
    }

    #[test]
    fn file_uris_round_trip_through_paths() {
        let p = Path::new("/tmp/a dir/s×.tess");
        let uri = uri_of(p).unwrap();
        assert_eq!(uri.as_str(), "file:///tmp/a%20dir/s%C3%97.tess");
        assert_eq!(path_of(&uri).unwrap(), p);
        assert_eq!(path_of(&Uri::from_str("untitled:Untitled-1").unwrap()), None);
        assert_eq!(path_of(&Uri::from_str("file://elsewhere/x.tess").unwrap()), None);
        assert_eq!(path_of(&Uri::from_str("file://localhost/x.tess").unwrap()).unwrap(), Path::new("/x.tess"));
    }
}
