//! The answers to an editor's requests: hover, completion, definition, rename and
//! formatting. Each reads the document's text (and the files it imports) and the kinds'
//! schemas; none writes a file. A request the text cannot answer gets an empty answer.

use std::collections::HashMap;
use std::path::Path;

use lsp_types::{
    CompletionItem, CompletionItemKind, CompletionTextEdit, Documentation, Hover, HoverContents, Location,
    MarkupContent, MarkupKind, TextEdit, Uri, WorkspaceEdit,
};

use super::context::{context_at, word_at, Context, Frame};
use super::position::LineIndex;
use super::scene::{uri_of, Unit};
use crate::lang::schema::{self, PropSpec, Ty, Value};
use crate::lang::KindSpec;

/// At most this many file names are offered in one completion.
const MAX_ENTRIES: usize = 500;

fn registry() -> Vec<&'static KindSpec> {
    crate::kinds::registry()
}

fn spec(kind: &str) -> Option<&'static KindSpec> {
    registry().into_iter().find(|k| k.name == kind)
}

/// The properties valid inside the innermost of `frames`, and the property a value there
/// belongs to when the innermost frames are vectors or calls of one.
fn resolve(frames: &[Frame]) -> Option<(&'static [PropSpec], Option<&'static PropSpec>)> {
    let mut props: &'static [PropSpec] = &[];
    let mut owner: Option<&'static PropSpec> = None;
    for f in frames {
        let find = |name: &str| props.iter().find(|p| p.name == name);
        match f {
            Frame::Decl { kind } => {
                props = spec(kind)?.props;
                owner = None;
            }
            Frame::Block { prop } => match &find(prop)?.ty {
                Ty::Block(inner) => {
                    props = inner;
                    owner = None;
                }
                _ => return None,
            },
            Frame::Group { prop } => owner = prop.as_deref().and_then(find).or(owner),
            Frame::Call { prop, name } => {
                let p = prop.as_deref().and_then(find).or(owner)?;
                let (Ty::Source { calls, .. } | Ty::Calls(calls)) = &p.ty else { return None };
                props = calls.iter().find(|c| c.name == name)?.args;
                owner = None;
            }
        }
    }
    Some((props, owner))
}

/// The property a value belongs to.
fn value_prop(frames: &[Frame], prop: Option<&str>) -> Option<&'static PropSpec> {
    let (props, owner) = resolve(frames)?;
    match prop {
        Some(name) => props.iter().find(|p| p.name == name).or(owner),
        None => owner,
    }
}

fn markdown(text: String) -> HoverContents {
    HoverContents::Markup(MarkupContent { kind: MarkupKind::Markdown, value: text })
}

/// Hover: a kind's reference (as `tessera explain --markdown` prints it), a property's type,
/// default, bounds and doc, a constructor's doc, or what a referenced declaration is.
pub fn hover(text: &str, offset: usize, unit: &Unit) -> Option<Hover> {
    let (start, end) = word_at(text, offset)?;
    let word = &text[start..end];
    let ix = LineIndex::new(text);
    let range = Some(ix.range(start, end));
    let called = text[end..].trim_start().starts_with('(');
    let contents = match context_at(text, end).0 {
        Context::Item { .. } => markdown(schema::markdown(spec(word)?)),
        Context::Property { frames, .. } => {
            let (props, _) = resolve(&frames)?;
            markdown(schema::property_markdown(props.iter().find(|p| p.name == word)?))
        }
        Context::Value { frames, prop, .. } => {
            let p = value_prop(&frames, prop.as_deref());
            if let (true, Some(Ty::Source { calls, .. } | Ty::Calls(calls))) = (called, p.map(|p| &p.ty)) {
                markdown(schema::call_line(calls.iter().find(|c| c.name == word)?))
            } else if let Some(m) = symbol_markdown(unit, word) {
                m
            } else {
                markdown(schema::property_markdown(p.filter(|p| matches!(p.ty, Ty::Enum(_)))?))
            }
        }
        // A declaration's own name.
        _ => symbol_markdown(unit, word)?,
    };
    Some(Hover { contents, range })
}

/// What the declaration or param `name` is and where it is declared.
fn symbol_markdown(unit: &Unit, name: &str) -> Option<HoverContents> {
    let s = unit.symbol(name)?;
    let file = unit.sources[s.file].path.display();
    Some(match s.spec {
        Some(k) => markdown(format!("`{} {}` (declared in {file})\n\n{}", k.name, s.name, k.doc)),
        None => markdown(format!("`param {}` (declared in {file})", s.name)),
    })
}

/// A completion item. `detail` is plain text in the protocol (editors show it as it is), so
/// the schemas' Markdown backticks are taken out of it.
fn item(label: &str, kind: CompletionItemKind, detail: Option<String>) -> CompletionItem {
    let detail = detail.map(|d| d.replace('`', ""));
    CompletionItem { label: label.to_string(), kind: Some(kind), detail, ..Default::default() }
}

/// A completion item with a one-line `detail` and Markdown documentation.
fn documented(label: &str, kind: CompletionItemKind, detail: &str, doc: &str) -> CompletionItem {
    let mut i = item(label, kind, Some(detail.to_string()));
    i.documentation =
        Some(Documentation::MarkupContent(MarkupContent { kind: MarkupKind::Markdown, value: doc.to_string() }));
    i
}

/// The names of the declarations (and params) that may stand where `prop` takes a value.
fn names_for(unit: &Unit, accepts: &[Value], params: bool, out: &mut Vec<CompletionItem>) {
    for s in &unit.symbols {
        let fits = match s.spec {
            Some(k) => k.produces.iter().any(|v| accepts.contains(v)),
            None => params,
        };
        if fits {
            let detail = s.spec.map_or_else(|| "param".to_string(), |k| format!("{} {}", k.name, s.name));
            out.push(item(&s.name, CompletionItemKind::REFERENCE, Some(detail)));
        }
    }
}

/// Completion: kinds at the start of an item, the properties of the enclosing kind (or
/// block, or call) not yet set, the values a property takes (enum words, `true`/`false`,
/// constructors, declarations of the right kind, params), and file paths in strings.
pub fn complete(text: &str, offset: usize, path: Option<&Path>, unit: &Unit) -> Vec<CompletionItem> {
    let mut out = Vec::new();
    let (ctx, block) = context_at(text, offset);
    match ctx {
        Context::Item { .. } => {
            for k in registry() {
                out.push(documented(k.name, CompletionItemKind::CLASS, "kind", k.doc));
            }
            for keyword in ["import", "param"] {
                out.push(item(keyword, CompletionItemKind::KEYWORD, None));
            }
        }
        Context::Property { frames, .. } => {
            let Some((props, _)) = resolve(&frames) else { return out };
            let set = block.map(|b| set_properties(text, b, offset)).unwrap_or_default();
            for p in props.iter().filter(|p| !set.contains(&p.name)) {
                out.push(documented(
                    p.name,
                    CompletionItemKind::PROPERTY,
                    &p.ty.describe(),
                    &schema::property_markdown(p),
                ));
            }
        }
        Context::Value { frames, prop, .. } => {
            let Some(p) = value_prop(&frames, prop.as_deref()) else { return out };
            match &p.ty {
                Ty::Enum(words) => {
                    words.iter().for_each(|w| out.push(item(w, CompletionItemKind::ENUM_MEMBER, None)));
                }
                Ty::Bool => ["true", "false"].iter().for_each(|w| out.push(item(w, CompletionItemKind::KEYWORD, None))),
                Ty::Ref(vs) | Ty::Refs(vs) => names_for(unit, vs, false, &mut out),
                Ty::Source { calls, refs } => {
                    for c in calls.iter() {
                        out.push(documented(c.name, CompletionItemKind::FUNCTION, "constructor", c.doc));
                    }
                    names_for(unit, refs, false, &mut out);
                }
                Ty::Calls(calls) => {
                    for c in calls.iter() {
                        out.push(documented(c.name, CompletionItemKind::FUNCTION, "constructor", c.doc));
                    }
                }
                Ty::Number(..) | Ty::Pixels(_) | Ty::Int(..) | Ty::Numbers(..) | Ty::Vec2(_) | Ty::Size => {
                    names_for(unit, &[], true, &mut out)
                }
                _ => {}
            }
        }
        Context::Str { frames, import, content, start, .. } => {
            // A quoted declaration name (`output "a.png"`) names a file to write, not one to read.
            if frames.is_empty() && !import {
                return out;
            }
            if let Some(dir) = path.and_then(Path::parent) {
                files(text, dir, &content, start, import, &mut out);
            }
        }
        Context::Nothing => {}
    }
    out
}

/// The properties already set in the block opened just before byte `block`, other than the
/// one being typed at `offset`.
fn set_properties(text: &str, block: usize, offset: usize) -> Vec<&str> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let (mut depth, mut i, mut stmt) = (0usize, block, block);
    while i < b.len() {
        match b[i] {
            b'"' => {
                i += 1;
                while i < b.len() && b[i] != b'"' && b[i] != b'\n' {
                    i += 1;
                }
            }
            b'#' => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
                continue;
            }
            b'{' | b'[' | b'(' => depth += 1,
            b'}' | b']' | b')' if depth == 0 => break,
            b'}' | b']' | b')' => depth -= 1,
            b'=' if depth == 0 => {
                let name = text[stmt..i].trim();
                if !(stmt..=i).contains(&offset) && !name.is_empty() {
                    out.push(name);
                }
            }
            b'\n' | b',' if depth == 0 => stmt = i + 1,
            _ => {}
        }
        i += 1;
    }
    out
}

/// The entries of the directory a path string being typed names, relative to the scene.
fn files(text: &str, base: &Path, content: &str, start: usize, import: bool, out: &mut Vec<CompletionItem>) {
    let (dir_part, name_part) = content.rsplit_once('/').map_or(("", content), |(d, n)| (d, n));
    let dir = if dir_part.is_empty() && content.starts_with('/') {
        Path::new("/").to_path_buf()
    } else {
        base.join(dir_part)
    };
    let Ok(entries) = std::fs::read_dir(&dir) else { return };
    let ix = LineIndex::new(text);
    let at = start + content.len() - name_part.len();
    let range = ix.range(at, start + content.len());
    let mut names: Vec<(String, bool)> = entries
        .filter_map(|e| {
            let e = e.ok()?;
            let name = e.file_name().into_string().ok()?;
            let is_dir = e.file_type().ok()?.is_dir();
            let hidden = name.starts_with('.') && !name_part.starts_with('.');
            let fits = is_dir || !import || name.ends_with(".tess");
            (!hidden && fits).then_some((name, is_dir))
        })
        .take(MAX_ENTRIES)
        .collect();
    names.sort();
    for (name, is_dir) in names {
        let label = if is_dir { format!("{name}/") } else { name };
        let kind = if is_dir { CompletionItemKind::FOLDER } else { CompletionItemKind::FILE };
        let mut i = item(&label, kind, None);
        i.text_edit = Some(CompletionTextEdit::Edit(TextEdit::new(range, label.clone())));
        out.push(i);
    }
}

/// Definition: the declaration (or param) a name refers to, in the document or a file it
/// imports.
pub fn definition(text: &str, offset: usize, unit: &Unit, doc: &Uri) -> Option<Location> {
    let (start, end) = word_at(text, offset)?;
    let s = unit.symbol(&text[start..end])?;
    let source = &unit.sources[s.file];
    let ix = LineIndex::new(&source.text);
    let uri = if s.file == 0 { doc.clone() } else { uri_of(&source.path)? };
    Some(Location::new(uri, ix.range(s.span.start, s.span.end)))
}

/// Rename: the declaration and every reference to it in the document and the files it
/// imports. `Err` says why not (not a declaration's name, not an identifier, taken).
// `WorkspaceEdit` is keyed by `Uri`, whose `Hash` and `Eq` are those of its text; the cell
// inside it is fluent-uri's parse cache, which neither reads.
#[allow(clippy::mutable_key_type)]
pub fn rename(text: &str, offset: usize, new_name: &str, unit: &Unit, doc: &Uri) -> Result<WorkspaceEdit, String> {
    let (start, end) = word_at(text, offset).ok_or("no name here")?;
    let old = &text[start..end];
    let s = unit.symbol(old).ok_or_else(|| format!("`{old}` is not a declaration or param of this scene"))?;
    let valid = new_name.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && new_name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if !valid {
        return Err(format!("`{new_name}` is not a name (letters, digits and `_`, not starting with a digit)"));
    }
    if new_name != old && unit.symbol(new_name).is_some() {
        return Err(format!("`{new_name}` is already declared"));
    }
    if let Some(i) = unit.sources.iter().position(|src| src.ast.is_none()) {
        return Err(format!("{} does not parse; fix it before renaming", unit.sources[i].path.display()));
    }
    let mut changes: HashMap<Uri, Vec<TextEdit>> = HashMap::new();
    for (i, src) in unit.sources.iter().enumerate() {
        let ix = LineIndex::new(&src.text);
        let mut spans = unit.references(i, old);
        if i == s.file {
            spans.push(s.span);
        }
        if spans.is_empty() {
            continue;
        }
        let uri = if i == 0 { doc.clone() } else { uri_of(&src.path).ok_or("a file without a URI")? };
        let edits = spans.iter().map(|sp| TextEdit::new(ix.range(sp.start, sp.end), new_name.to_string())).collect();
        changes.insert(uri, edits);
    }
    Ok(WorkspaceEdit { changes: Some(changes), ..Default::default() })
}

/// Formatting: the text as `tessera fmt` writes it, as one edit of the whole document; no
/// edit when it is formatted already, or when it does not parse (its diagnostics say why).
pub fn format(text: &str) -> Vec<TextEdit> {
    match crate::lang::fmt::format_source(text) {
        Ok(formatted) if formatted != text => vec![TextEdit::new(LineIndex::new(text).all(), formatted)],
        _ => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_properties_are_those_of_the_block_only() {
        let text = "k a {\n  x = 1\n  inner = { y = 2 }\n  call = f(z = 3, w = [1, 2])\n  typing\n}\nk b { v = 1 }";
        let block = text.find('{').unwrap() + 1;
        let at = text.find("typing").unwrap() + 3;
        assert_eq!(set_properties(text, block, at), vec!["x", "inner", "call"]);
        // The property being typed is not counted as set.
        let text = "k a {\n  x = 1\n  y = \n}";
        let at = text.find("y =").unwrap() + 1;
        assert_eq!(set_properties(text, text.find('{').unwrap() + 1, at), vec!["x"]);
    }

    #[test]
    fn frames_resolve_through_blocks_and_calls_to_their_properties() {
        let registry = registry();
        let (kind, block) = registry
            .iter()
            .find_map(|k| k.props.iter().find(|p| matches!(p.ty, Ty::Block(_))).map(|p| (k, p)))
            .expect("some kind has a block property");
        let Ty::Block(inner) = &block.ty else { unreachable!() };
        let frames = vec![Frame::Decl { kind: kind.name.into() }, Frame::Block { prop: block.name.into() }];
        let (props, owner) = resolve(&frames).unwrap();
        assert!(std::ptr::eq(props, *inner) && owner.is_none());

        let (kind, source, call) = registry
            .iter()
            .find_map(|k| {
                k.props.iter().find_map(|p| match &p.ty {
                    Ty::Source { calls, .. } => calls.first().map(|c| (k, p, c)),
                    _ => None,
                })
            })
            .expect("some kind has a constructor");
        let frames = vec![
            Frame::Decl { kind: kind.name.into() },
            Frame::Call { prop: Some(source.name.into()), name: call.name.into() },
        ];
        assert!(std::ptr::eq(resolve(&frames).unwrap().0, call.args));
        // A vector of the property, then the call inside it: the vector's property owns it.
        let frames = vec![
            Frame::Decl { kind: kind.name.into() },
            Frame::Group { prop: Some(source.name.into()) },
            Frame::Call { prop: None, name: call.name.into() },
        ];
        assert!(std::ptr::eq(resolve(&frames).unwrap().0, call.args));
        assert!(resolve(&[Frame::Decl { kind: "no such kind".into() }]).is_none());
        assert_eq!(value_prop(&frames[..2], None).map(|p| p.name), Some(source.name));
    }
}
