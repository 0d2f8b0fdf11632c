//! The architecture's rules (`docs/architecture.md`, "Invariants"), checked on the source
//! text: which layer may import which, that every file opens with a module doc, that no two
//! files import each other round a cycle, that no kind name is matched outside its own module,
//! and that every cited source exists in `docs/references.md`. Text scanning only (nothing
//! is compiled or run), so the whole file takes well under a second.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

// ---- the source tree as text -------------------------------------------------------------------

/// One `.rs` file of the tree: its path (`src/synth/blend/mod.rs`), its module path
/// (`["synth", "blend"]`), its text and the paths it names.
struct File {
    rel: String,
    module: Vec<String>,
    text: String,
    /// Comments blanked, strings kept (for the kind-name check).
    uncommented: String,
    /// Every path the file names: `use` leaves and inline `crate::` / `super::` / `self::`
    /// / `tessera::` / child-module paths, with the module they are written in.
    refs: Vec<PathRef>,
    /// `pub use` leaves: the name they bind and the path they name.
    reexports: Vec<(String, PathRef)>,
    /// Names of the items (fn, struct, enum, ...) the file defines.
    defines: BTreeSet<String>,
    /// Inline modules (`mod tests { ... }`), as module paths.
    inline_modules: Vec<Vec<String>>,
    /// Modules declared under `#[cfg(test)]` here (inline or in their own file).
    test_modules: Vec<Vec<String>>,
}

#[derive(Clone, Debug)]
struct PathRef {
    line: usize,
    /// The module the path is written in (the file's, plus inline modules around it).
    module: Vec<String>,
    segments: Vec<String>,
    /// Written inside a `#[cfg(test)]` module.
    test: bool,
}

/// The source tree: every file below `src/` but `main.rs` (the library crate), and `main.rs`
/// on its own (the binary crate, which reaches the library as `tessera::`).
struct Tree {
    files: Vec<File>,
    /// Module path → index of the file that holds it (inline modules map to their file).
    module_file: BTreeMap<Vec<String>, usize>,
    /// Files compiled for tests only (`#[cfg(test)] mod tests;`).
    test_files: BTreeSet<usize>,
}

fn read_tree(root: &Path) -> Vec<(String, String)> {
    fn walk(dir: &Path, root: &Path, out: &mut Vec<(String, String)>) {
        let mut entries: Vec<_> = std::fs::read_dir(dir).expect("read src").map(|e| e.expect("entry").path()).collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                walk(&p, root, out);
            } else if p.extension().is_some_and(|e| e == "rs") {
                let rel = p.strip_prefix(root).expect("below root").to_string_lossy().replace('\\', "/");
                out.push((rel, std::fs::read_to_string(&p).expect("read source")));
            }
        }
    }
    let mut out = Vec::new();
    walk(&root.join("src"), root, &mut out);
    out
}

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The module path of a file: `src/lib.rs` → `[]`, `src/a/mod.rs` → `[a]`, `src/a/b.rs` →
/// `[a, b]`. `src/main.rs` is the root of the other crate, also `[]`.
fn module_of(rel: &str) -> Vec<String> {
    let inner = rel.strip_prefix("src/").unwrap_or(rel).strip_suffix(".rs").unwrap_or(rel);
    let mut parts: Vec<String> = inner.split('/').map(str::to_string).collect();
    if matches!(parts.last().map(String::as_str), Some("mod" | "lib" | "main")) {
        parts.pop();
    }
    parts
}

impl Tree {
    fn new(sources: Vec<(String, String)>) -> Tree {
        let mut files: Vec<File> = sources.into_iter().map(|(rel, text)| parse_file(rel, text)).collect();
        files.sort_by(|a, b| a.rel.cmp(&b.rel));
        let mut module_file = BTreeMap::new();
        for (i, f) in files.iter().enumerate() {
            if f.rel == "src/main.rs" {
                continue;
            }
            module_file.insert(f.module.clone(), i);
            for m in &f.inline_modules {
                module_file.entry(m.clone()).or_insert(i);
            }
        }
        let test_modules: BTreeSet<&Vec<String>> = files.iter().flat_map(|f| &f.test_modules).collect();
        let test_files =
            (0..files.len()).filter(|&i| test_modules.iter().any(|m| files[i].module.starts_with(m))).collect();
        Tree { files, module_file, test_files }
    }

    fn is_bin(&self, file: usize) -> bool {
        self.files[file].rel == "src/main.rs"
    }

    /// The absolute module path (inside the library) a path names, or `None` for another
    /// crate (`std::`, `serde::`, ...) or the binary's own items.
    fn resolve(&self, file: usize, r: &PathRef) -> Option<Vec<String>> {
        let bin = self.is_bin(file);
        let (first, rest) = r.segments.split_first()?;
        let mut base: Vec<String> = match first.as_str() {
            "crate" if !bin => Vec::new(),
            "tessera" if bin => Vec::new(),
            "self" if !bin => r.module.clone(),
            "super" if !bin => {
                let mut m = r.module.clone();
                m.pop()?;
                let mut rest = rest;
                while let Some(("super", tail)) = rest.split_first().map(|(h, t)| (h.as_str(), t)) {
                    m.pop()?;
                    rest = tail;
                }
                m.extend(rest.iter().cloned());
                return Some(m);
            }
            // A child module named without a prefix (`use spec::SPEC;`, `sample::plan(..)`).
            name if !bin => {
                let mut m = r.module.clone();
                m.push(name.to_string());
                if !self.module_file.contains_key(&m) {
                    return None;
                }
                m
            }
            _ => return None,
        };
        base.extend(rest.iter().cloned());
        Some(base)
    }

    /// The file that defines what an absolute path names, following `pub use` re-exports (so
    /// a use of `crate::raster::Image` is an import of `raster/image.rs`, not of the
    /// `raster/mod.rs` that re-exports it).
    fn target(&self, abs: &[String]) -> Option<usize> {
        let mut abs = abs.to_vec();
        for _ in 0..16 {
            let k = (0..=abs.len()).rev().find(|&k| self.module_file.contains_key(&abs[..k]))?;
            let file = self.module_file[&abs[..k]];
            let Some(item) = abs.get(k).cloned() else { return Some(file) };
            if item == "*" {
                return Some(file);
            }
            let f = &self.files[file];
            let explicit = f.reexports.iter().find(|(name, _)| *name == item);
            let next = match explicit {
                Some((_, r)) => self.resolve(file, r),
                None if f.defines.contains(&item) => None,
                None => f
                    .reexports
                    .iter()
                    .filter(|(name, _)| name == "*")
                    .filter_map(|(_, r)| self.resolve(file, r))
                    .map(|mut g| {
                        g.pop(); // the `*`
                        g.push(item.clone());
                        g
                    })
                    .find(|g| self.target(&g[..g.len() - 1]).is_some_and(|t| self.files[t].defines.contains(&item))),
            };
            match next {
                Some(n) => {
                    let mut n = n;
                    n.extend(abs[k + 1..].iter().cloned());
                    if n == abs {
                        return Some(file);
                    }
                    abs = n;
                }
                None => return Some(file),
            }
        }
        None
    }

    /// Every library path the shipped code of a file names, resolved, with its line: none for
    /// test code (`#[cfg(test)]` modules and files), which may take fixtures from anywhere.
    fn shipped_uses(&self, file: usize) -> Vec<(usize, Vec<String>)> {
        if self.test_files.contains(&file) {
            return Vec::new();
        }
        let shipped = self.files[file].refs.iter().filter(|r| !r.test);
        shipped.filter_map(|r| Some((r.line, self.resolve(file, r)?))).collect()
    }

    /// File → file imports of the shipped code: `from` names something `to` defines. A
    /// file's use of the `mod.rs`/`lib.rs` of a module around it does not count (a parent owns
    /// its children; their use of its items is not a dependency between peers), and neither
    /// does a use of itself or one made by test code (`#[cfg(test)]` modules and files, whose
    /// fixtures may come from anywhere). Values are the first line of each import.
    fn imports(&self) -> BTreeMap<usize, BTreeMap<usize, usize>> {
        let mut edges: BTreeMap<usize, BTreeMap<usize, usize>> = BTreeMap::new();
        for i in 0..self.files.len() {
            if self.is_bin(i) {
                continue;
            }
            for (line, abs) in self.shipped_uses(i) {
                let Some(t) = self.target(&abs) else { continue };
                let tm = &self.files[t].module;
                let ancestor = tm.len() < self.files[i].module.len() && self.files[i].module.starts_with(tm);
                if t != i && !ancestor {
                    edges.entry(i).or_default().entry(t).or_insert(line);
                }
            }
        }
        edges
    }
}

// ---- lexing ---------------------------------------------------------------------------------------

fn is_ident(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// The text with comments (and, unless `keep_strings`, the insides of string and character
/// literals) replaced by spaces; newlines stay, so lines keep their numbers.
fn blank(text: &str, keep_strings: bool) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let put = |out: &mut String, ch: char, keep: bool| out.push(if keep || ch == '\n' { ch } else { ' ' });
    let mut i = 0;
    while i < c.len() {
        let at = |k: usize| c.get(k).copied().unwrap_or('\0');
        let prev_ident = i > 0 && is_ident(c[i - 1]);
        if at(i) == '/' && at(i + 1) == '/' {
            while i < c.len() && c[i] != '\n' {
                put(&mut out, c[i], false);
                i += 1;
            }
        } else if at(i) == '/' && at(i + 1) == '*' {
            let mut depth = 0;
            while i < c.len() {
                if at(i) == '/' && at(i + 1) == '*' {
                    depth += 1;
                    out.push_str("  ");
                    i += 2;
                } else if at(i) == '*' && at(i + 1) == '/' {
                    depth -= 1;
                    out.push_str("  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    put(&mut out, c[i], false);
                    i += 1;
                }
            }
        } else if !prev_ident && (at(i) == 'r' || (at(i) == 'b' && at(i + 1) == 'r')) && {
            let s = if at(i) == 'b' { i + 2 } else { i + 1 };
            let mut h = s;
            while at(h) == '#' {
                h += 1;
            }
            at(h) == '"' && (h > s || at(s) == '"')
        } {
            // Raw string: r"..." or r#"..."#.
            let s = if at(i) == 'b' { i + 2 } else { i + 1 };
            let mut h = s;
            while at(h) == '#' {
                h += 1;
            }
            let hashes = h - s;
            for &ch in &c[i..=h] {
                out.push(ch);
            }
            i = h + 1;
            while i < c.len() {
                if c[i] == '"' && (0..hashes).all(|k| at(i + 1 + k) == '#') {
                    for &ch in &c[i..i + 1 + hashes] {
                        out.push(ch);
                    }
                    i += 1 + hashes;
                    break;
                }
                put(&mut out, c[i], keep_strings);
                i += 1;
            }
        } else if at(i) == '"' {
            out.push('"');
            i += 1;
            while i < c.len() {
                if c[i] == '\\' {
                    put(&mut out, c[i], keep_strings);
                    if i + 1 < c.len() {
                        put(&mut out, c[i + 1], keep_strings);
                    }
                    i += 2;
                } else if c[i] == '"' {
                    out.push('"');
                    i += 1;
                    break;
                } else {
                    put(&mut out, c[i], keep_strings);
                    i += 1;
                }
            }
        } else if at(i) == '\'' && (at(i + 1) == '\\' || (at(i + 2) == '\'' && at(i + 1) != '\'')) {
            // A character literal (a lifetime has no closing quote two places on).
            out.push('\'');
            i += 1;
            while i < c.len() {
                if c[i] == '\\' {
                    out.push_str("  ");
                    i += 2;
                } else if c[i] == '\'' {
                    out.push('\'');
                    i += 1;
                    break;
                } else {
                    put(&mut out, c[i], keep_strings);
                    i += 1;
                }
            }
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Ident(String),
    Path, // `::`
    Punct(char),
}

fn tokens(code: &str) -> Vec<(Tok, usize)> {
    let c: Vec<char> = code.chars().collect();
    let mut out = Vec::new();
    let (mut i, mut line) = (0, 1);
    while i < c.len() {
        let ch = c[i];
        if ch == '\n' {
            line += 1;
            i += 1;
        } else if ch.is_whitespace() {
            i += 1;
        } else if ch.is_ascii_digit() {
            while i < c.len() && (is_ident(c[i]) || c[i] == '.') {
                i += 1;
            }
        } else if is_ident(ch) {
            let s = i;
            while i < c.len() && is_ident(c[i]) {
                i += 1;
            }
            out.push((Tok::Ident(c[s..i].iter().collect()), line));
        } else if ch == ':' && c.get(i + 1) == Some(&':') {
            out.push((Tok::Path, line));
            i += 2;
        } else {
            out.push((Tok::Punct(ch), line));
            i += 1;
        }
    }
    out
}

fn ident(t: Option<&(Tok, usize)>) -> Option<&str> {
    match t {
        Some((Tok::Ident(s), _)) => Some(s),
        _ => None,
    }
}

/// The leaves of a use tree starting at `toks[*i]`: `(segments, bound name)`.
fn use_tree(toks: &[(Tok, usize)], i: &mut usize, prefix: Vec<String>, out: &mut Vec<(Vec<String>, String)>) {
    let mut path = prefix;
    while let Some((t, _)) = toks.get(*i) {
        match t {
            Tok::Path => *i += 1,
            Tok::Punct('*') => {
                *i += 1;
                path.push("*".into());
                out.push((path, "*".into()));
                return;
            }
            Tok::Punct('{') => {
                *i += 1;
                while let Some((t, _)) = toks.get(*i) {
                    match t {
                        Tok::Punct('}') => {
                            *i += 1;
                            break;
                        }
                        Tok::Punct(',') => *i += 1,
                        Tok::Punct(';') => return,
                        _ => use_tree(toks, i, path.clone(), out),
                    }
                }
                return;
            }
            Tok::Ident(s) => {
                path.push(s.clone());
                *i += 1;
                if toks.get(*i).map(|t| &t.0) == Some(&Tok::Path) {
                    continue;
                }
                let mut name = s.clone();
                if ident(toks.get(*i)) == Some("as") {
                    name = ident(toks.get(*i + 1)).unwrap_or("_").to_string();
                    *i += 2;
                }
                if s == "self" {
                    path.pop();
                    if name == "self" {
                        name = path.last().cloned().unwrap_or_default();
                    }
                }
                out.push((path, name));
                return;
            }
            Tok::Punct(_) => return,
        }
    }
}

fn parse_file(rel: String, text: String) -> File {
    let module = module_of(&rel);
    let code = blank(&text, false);
    let uncommented = blank(&text, true);
    let toks = tokens(&code);
    let mut refs = Vec::new();
    let mut reexports = Vec::new();
    let mut defines = BTreeSet::new();
    let mut inline_modules = Vec::new();
    let mut test_modules: Vec<Vec<String>> = Vec::new();
    // One entry per open brace: the inline module it opens, if any.
    let mut braces: Vec<Option<String>> = Vec::new();
    let mut pending_mod: Option<String> = None;
    let here = |braces: &[Option<String>]| {
        let mut m = module.clone();
        m.extend(braces.iter().flatten().cloned());
        m
    };
    let in_test = |m: &[String], test_modules: &[Vec<String>]| test_modules.iter().any(|t| m.starts_with(t));
    let mut i = 0;
    while i < toks.len() {
        let (tok, line) = (&toks[i].0, toks[i].1);
        let prev = i.checked_sub(1).map(|k| &toks[k].0);
        match tok {
            Tok::Punct('{') => {
                if let Some(m) = pending_mod.take() {
                    let mut full = here(&braces);
                    full.push(m.clone());
                    inline_modules.push(full);
                    braces.push(Some(m));
                } else {
                    braces.push(None);
                }
                i += 1;
            }
            Tok::Punct('}') => {
                braces.pop();
                i += 1;
            }
            Tok::Punct(';') => {
                pending_mod = None;
                i += 1;
            }
            Tok::Ident(kw)
                if matches!(
                    kw.as_str(),
                    "fn" | "struct" | "enum" | "trait" | "type" | "const" | "static" | "union"
                ) && ident(toks.get(i + 1)).is_some() =>
            {
                defines.insert(ident(toks.get(i + 1)).unwrap_or_default().to_string());
                i += 1;
            }
            Tok::Ident(kw) if kw == "mod" && ident(toks.get(i + 1)).is_some() => {
                let name = ident(toks.get(i + 1)).unwrap_or_default().to_string();
                defines.insert(name.clone());
                // `#[cfg(test)] mod x`, maybe with `pub` or `pub(crate)` between.
                let mut k = i;
                if k >= 4 && toks[k - 1].0 == Tok::Punct(')') && ident(toks.get(k - 4)) == Some("pub") {
                    k -= 4;
                } else if k >= 1 && ident(toks.get(k - 1)) == Some("pub") {
                    k -= 1;
                }
                let attr = [
                    Tok::Punct('#'),
                    Tok::Punct('['),
                    Tok::Ident("cfg".into()),
                    Tok::Punct('('),
                    Tok::Ident("test".into()),
                    Tok::Punct(')'),
                    Tok::Punct(']'),
                ];
                if k >= attr.len() && toks[k - attr.len()..k].iter().map(|t| &t.0).eq(attr.iter()) {
                    let mut full = here(&braces);
                    full.push(name.clone());
                    test_modules.push(full);
                }
                if toks.get(i + 2).map(|t| &t.0) == Some(&Tok::Punct('{')) {
                    pending_mod = Some(name);
                }
                i += 2;
            }
            Tok::Ident(kw) if kw == "use" && prev != Some(&Tok::Path) => {
                // `pub use`, `pub(crate) use`, `pub(super) use`: a re-export.
                let public = match prev {
                    Some(Tok::Ident(p)) => p == "pub",
                    Some(Tok::Punct(')')) => {
                        let open = (0..i).rev().find(|&k| toks[k].0 == Tok::Punct('('));
                        open.is_some_and(|k| k > 0 && ident(toks.get(k - 1)) == Some("pub"))
                    }
                    _ => false,
                };
                let mut j = i + 1;
                let mut leaves = Vec::new();
                use_tree(&toks, &mut j, Vec::new(), &mut leaves);
                let m = here(&braces);
                let test = in_test(&m, &test_modules);
                for (segments, name) in leaves {
                    let r = PathRef { line, module: m.clone(), segments, test };
                    if public {
                        reexports.push((name, r.clone()));
                    }
                    refs.push(r);
                }
                while j < toks.len() && toks[j].0 != Tok::Punct(';') {
                    j += 1;
                }
                i = j + 1;
            }
            Tok::Ident(first)
                if toks.get(i + 1).map(|t| &t.0) == Some(&Tok::Path)
                    && prev != Some(&Tok::Path)
                    && prev != Some(&Tok::Punct('$')) =>
            {
                let mut segments = vec![first.clone()];
                let mut j = i + 1;
                while toks.get(j).map(|t| &t.0) == Some(&Tok::Path) {
                    match ident(toks.get(j + 1)) {
                        Some(s) => segments.push(s.to_string()),
                        None => break,
                    }
                    j += 2;
                }
                let m = here(&braces);
                let test = in_test(&m, &test_modules);
                refs.push(PathRef { line, module: m, segments, test });
                i = j;
            }
            _ => i += 1,
        }
    }
    File { rel, module, text, uncommented, refs, reexports, defines, inline_modules, test_modules }
}

fn tree() -> Tree {
    Tree::new(read_tree(repo()))
}

// ---- the layering rules ---------------------------------------------------------------------------

/// Lines of the shipped code below `dir` (or of the file `dir`) that name a library path
/// whose top module (`synth`, `graph`, ...) `allowed` refuses.
fn layer_violations(tree: &Tree, dir: &str, allowed: &dyn Fn(&str) -> bool) -> Vec<String> {
    let mut bad = Vec::new();
    for (i, f) in tree.files.iter().enumerate() {
        if !f.rel.starts_with(dir) {
            continue;
        }
        for (line, abs) in tree.shipped_uses(i) {
            if let Some(top) = abs.first().filter(|t| !allowed(t)) {
                let src = f.text.lines().nth(line - 1).unwrap_or("").trim();
                bad.push(format!("{}:{line}: uses `{}` ({top}): {src}", f.rel, abs.join("::")));
            }
        }
    }
    bad.sort();
    bad.dedup();
    bad
}

fn assert_none(what: &str, bad: &[String]) {
    assert!(bad.is_empty(), "{what}: {} offending line(s)\n{}", bad.len(), bad.join("\n"));
}

#[test]
fn synth_uses_only_synth_and_raster() {
    let t = tree();
    assert_none(
        "synth imports from above it",
        &layer_violations(&t, "src/synth/", &|m| matches!(m, "synth" | "raster")),
    );
}

#[test]
fn raster_uses_nothing_above_it() {
    let t = tree();
    assert_none("raster imports from above it", &layer_violations(&t, "src/raster/", &|m| m == "raster"));
}

#[test]
fn golden_uses_only_raster() {
    let t = tree();
    assert_none(
        "golden imports from above it",
        &layer_violations(&t, "src/golden/", &|m| matches!(m, "golden" | "raster")),
    );
}

#[test]
fn graph_knows_no_language_kind_or_algorithm() {
    let t = tree();
    let rule = |m: &str| !matches!(m, "lang" | "kinds" | "synth" | "project" | "golden");
    assert_none("graph imports lang, kinds, synth, project or golden", &layer_violations(&t, "src/graph/", &rule));
}

#[test]
fn lang_knows_no_kind_graph_or_algorithm() {
    let t = tree();
    let rule = |m: &str| !matches!(m, "kinds" | "synth" | "graph" | "project" | "golden");
    assert_none("lang imports kinds, synth, graph, project or golden", &layer_violations(&t, "src/lang/", &rule));
}

#[test]
fn kinds_do_not_use_the_commands() {
    let t = tree();
    let rule = |m: &str| !matches!(m, "project" | "golden");
    assert_none("kinds imports project or golden", &layer_violations(&t, "src/kinds/", &rule));
}

#[test]
fn main_uses_nothing_of_synth() {
    let t = tree();
    assert_none("main.rs imports synth", &layer_violations(&t, "src/main.rs", &|m| m != "synth"));
}

/// `synth`, `raster` and `golden` work on values: no file, environment, process or network
/// access, in their tests either (their fixtures are made in memory).
#[test]
fn synth_raster_and_golden_touch_no_files() {
    let t = tree();
    let mut bad = Vec::new();
    for f in &t.files {
        if !["src/synth/", "src/raster/", "src/golden/"].iter().any(|d| f.rel.starts_with(d)) {
            continue;
        }
        for r in &f.refs {
            let s: Vec<&str> = r.segments.iter().map(String::as_str).collect();
            if let ["std", m, ..] = s[..] {
                if matches!(m, "fs" | "env" | "net" | "process") {
                    let src = f.text.lines().nth(r.line - 1).unwrap_or("").trim();
                    bad.push(format!("{}:{}: uses std::{m}: {src}", f.rel, r.line));
                }
            }
        }
    }
    assert_none("synth, raster or golden reaches outside the process", &bad);
}

#[test]
fn every_source_file_opens_with_a_module_doc() {
    let t = tree();
    let bad: Vec<String> = t
        .files
        .iter()
        .filter(|f| !f.text.lines().find(|l| !l.trim().is_empty()).is_some_and(|l| l.starts_with("//!")))
        .map(|f| format!("{}:1: no `//!` module doc", f.rel))
        .collect();
    assert_none("files without a module doc", &bad);
}

// ---- import cycles -------------------------------------------------------------------------------

/// The strongly connected components of more than one node (Tarjan), each sorted, in order of
/// their smallest node: the import cycles.
fn cycles(n: usize, edges: &BTreeMap<usize, BTreeSet<usize>>) -> Vec<Vec<usize>> {
    struct State<'a> {
        edges: &'a BTreeMap<usize, BTreeSet<usize>>,
        index: Vec<Option<usize>>,
        low: Vec<usize>,
        on_stack: Vec<bool>,
        stack: Vec<usize>,
        next: usize,
        out: Vec<Vec<usize>>,
    }
    fn visit(s: &mut State, v: usize) {
        s.index[v] = Some(s.next);
        s.low[v] = s.next;
        s.next += 1;
        s.stack.push(v);
        s.on_stack[v] = true;
        let succ: Vec<usize> = s.edges.get(&v).map(|e| e.iter().copied().collect()).unwrap_or_default();
        for w in succ {
            match s.index[w] {
                None => {
                    visit(s, w);
                    s.low[v] = s.low[v].min(s.low[w]);
                }
                Some(iw) if s.on_stack[w] => s.low[v] = s.low[v].min(iw),
                Some(_) => {}
            }
        }
        if Some(s.low[v]) == s.index[v] {
            let mut comp = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on_stack[w] = false;
                comp.push(w);
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                comp.sort();
                s.out.push(comp);
            }
        }
    }
    let mut s = State {
        edges,
        index: vec![None; n],
        low: vec![0; n],
        on_stack: vec![false; n],
        stack: Vec::new(),
        next: 0,
        out: Vec::new(),
    };
    for v in 0..n {
        if s.index[v].is_none() {
            visit(&mut s, v);
        }
    }
    s.out.sort();
    s.out
}

/// The import cycles of a tree, each as its files and the imports between them.
fn import_cycles(tree: &Tree) -> Vec<String> {
    let imports = tree.imports();
    let edges: BTreeMap<usize, BTreeSet<usize>> =
        imports.iter().map(|(k, v)| (*k, v.keys().copied().collect())).collect();
    cycles(tree.files.len(), &edges)
        .into_iter()
        .map(|comp| {
            let names: Vec<&str> = comp.iter().map(|&i| tree.files[i].rel.as_str()).collect();
            let mut s = format!("cycle: {}", names.join(" ⇄ "));
            for &a in &comp {
                for (&b, &line) in &imports[&a] {
                    if comp.contains(&b) {
                        s += &format!("\n  {}:{line} imports {}", tree.files[a].rel, tree.files[b].rel);
                    }
                }
            }
            s
        })
        .collect()
}

#[test]
fn no_import_cycle_between_files() {
    assert_none("import cycles between files", &import_cycles(&tree()));
}

// ---- kind names ----------------------------------------------------------------------------------

const KINDS: [&str; 8] = ["sample", "map", "surface", "structure", "layer", "library", "output", "scene"];

/// Places where a kind is told apart by its name: `x == "map"`, `x != "map"`, a match arm
/// `"map" =>` or `"map" | ...`, or a list of kind names accepted by a reference
/// (`Ty::Ref(&["map", ...])`), outside `src/kinds/<kind>/` (or `src/kinds/<kind>.rs`).
fn kind_name_matches(tree: &Tree) -> Vec<String> {
    let mut bad = Vec::new();
    for f in &tree.files {
        for (n, line) in f.uncommented.lines().enumerate() {
            let in_ref_list = line.contains("Ty::Ref(") || line.contains("Ty::Refs(") || line.contains("refs: &[");
            for kind in KINDS {
                let own = f.rel.starts_with(&format!("src/kinds/{kind}/")) || f.rel == format!("src/kinds/{kind}.rs");
                if own {
                    continue;
                }
                let lit = format!("\"{kind}\"");
                for (at, _) in line.match_indices(&lit) {
                    let before = line[..at].trim_end();
                    let after = line[at + lit.len()..].trim_start();
                    let compared = before.ends_with("==") || before.ends_with("!=");
                    let arm = after.starts_with("=>") || (after.starts_with('|') && !after.starts_with("||"));
                    let arm_tail = before.ends_with('|') && !before.ends_with("||");
                    if compared || arm || arm_tail || in_ref_list {
                        bad.push(format!("{}:{}: {kind}: {}", f.rel, n + 1, line.trim()));
                    }
                }
            }
        }
    }
    bad
}

#[test]
fn no_kind_name_is_matched_outside_its_module() {
    assert_none("kind names matched outside their module", &kind_name_matches(&tree()));
}

// ---- cited sources ---------------------------------------------------------------------------------

/// The anchors of `docs/references.md`: `<a id="..."></a>`.
fn reference_anchors() -> BTreeSet<String> {
    let text = std::fs::read_to_string(repo().join("docs/references.md")).expect("docs/references.md");
    text.split("<a id=\"").skip(1).filter_map(|s| s.split('"').next()).map(str::to_string).collect()
}

/// Every `[references: doc §s, §t]` citation in the sources, tests, benchmarks and docs
/// names an anchor of `docs/references.md` (`doc`, `doc-s`, `doc-t`), and nothing cites the
/// working notes the references replaced.
#[test]
fn every_cited_source_is_in_the_references() {
    let anchors = reference_anchors();
    let mut texts = read_tree(repo());
    for dir in ["tests", "benches", "docs"] {
        let mut stack = vec![repo().join(dir)];
        while let Some(d) = stack.pop() {
            for e in std::fs::read_dir(&d).expect("read dir") {
                let p = e.expect("entry").path();
                if p.is_dir() {
                    if !p.ends_with("snapshots") {
                        stack.push(p);
                    }
                } else if p.extension().is_some_and(|x| x == "rs" || x == "md") {
                    let rel = p.strip_prefix(repo()).expect("below root").to_string_lossy().replace('\\', "/");
                    texts.push((rel, std::fs::read_to_string(&p).expect("read")));
                }
            }
        }
    }
    texts.push(("README.md".into(), std::fs::read_to_string(repo().join("README.md")).expect("README")));
    let mut bad = Vec::new();
    let mut count = 0;
    for (rel, text) in &texts {
        if rel == "tests/architecture.rs" {
            continue;
        }
        for (n, line) in text.lines().enumerate() {
            let lower = line.to_lowercase();
            if lower.contains("digest 00") || lower.contains("the digest") || lower.contains("digest's") {
                bad.push(format!("{rel}:{}: cites a note that is not in the repository: {}", n + 1, line.trim()));
            }
            for cite in line.split("[references: ").skip(1) {
                count += 1;
                let Some((body, _)) = cite.split_once(']') else {
                    bad.push(format!("{rel}:{}: a citation must end on its line: {}", n + 1, line.trim()));
                    continue;
                };
                let (doc, sections) = body.split_once(' ').unwrap_or((body, ""));
                let mut want = vec![doc.to_string()];
                for sec in sections.split(", ").filter(|s| !s.trim().is_empty()) {
                    let sec = sec.trim();
                    match sec.strip_prefix('§') {
                        Some(s) => want.push(format!("{doc}-{s}")),
                        None => bad.push(format!("{rel}:{}: `{sec}` is not a section (`§…`): {}", n + 1, line.trim())),
                    }
                }
                for w in want.into_iter().filter(|w| !anchors.contains(w)) {
                    bad.push(format!("{rel}:{}: no anchor `{w}` in docs/references.md: {}", n + 1, line.trim()));
                }
            }
        }
    }
    assert!(count > 0, "no citation found: the scan is broken");
    assert_none("citations without a reference", &bad);
}

// ---- the checker's own tests ---------------------------------------------------------------------

fn made_up(files: &[(&str, &str)]) -> Tree {
    Tree::new(files.iter().map(|(r, t)| (r.to_string(), t.to_string())).collect())
}

#[test]
fn the_cycle_finder_finds_exactly_the_cycles_of_a_made_up_graph() {
    // 0 → 1 → 2 → 0 is a cycle; 3 → 4 → 4 (a self-loop) and 5 → 3 are not; 6 ⇄ 7 is.
    let edges: BTreeMap<usize, BTreeSet<usize>> = [
        (0, vec![1]),
        (1, vec![2]),
        (2, vec![0, 3]),
        (3, vec![4]),
        (4, vec![4]),
        (5, vec![3]),
        (6, vec![7]),
        (7, vec![6]),
    ]
    .into_iter()
    .map(|(k, v)| (k, v.into_iter().collect()))
    .collect();
    assert_eq!(cycles(8, &edges), vec![vec![0, 1, 2], vec![6, 7]]);
    assert_eq!(cycles(3, &BTreeMap::new()), Vec::<Vec<usize>>::new());
}

#[test]
fn a_made_up_two_file_cycle_is_reported_and_reexports_are_followed() {
    let t = made_up(&[
        ("src/lib.rs", "//! Root.\npub mod a;\n"),
        ("src/a/mod.rs", "//! A.\nmod format;\nmod validate;\nmod types;\npub use types::Point;\npub fn root() {}\n"),
        ("src/a/format.rs", "//! F.\nuse super::validate::check;\nuse super::Point;\nuse super::root;\n"),
        (
            "src/a/validate.rs",
            "//! V.\n// use super::nothing;\nconst S: &str = \"super::types::X\";\npub fn check() {}\n\
             fn f() { let _ = super::format::Error; }\n#[cfg(test)]\nmod tests {\n    use super::*;\n    use super::super::types::Point;\n}\n",
        ),
        ("src/a/types.rs", "//! T.\npub struct Point;\n"),
    ]);
    let cycles = import_cycles(&t);
    assert_eq!(cycles.len(), 1, "{cycles:?}");
    assert!(cycles[0].starts_with("cycle: src/a/format.rs ⇄ src/a/validate.rs"), "{}", cycles[0]);
    assert!(cycles[0].contains("src/a/validate.rs:5 imports src/a/format.rs"), "{}", cycles[0]);
    let by_name = |rel: &str| t.files.iter().position(|f| f.rel == rel).expect("file");
    let imports = t.imports();
    let from_format: Vec<&str> =
        imports[&by_name("src/a/format.rs")].keys().map(|&k| t.files[k].rel.as_str()).collect();
    // `super::Point` is `types.rs` (re-exported by `mod.rs`); `super::root` is the parent's own
    // item, which does not count; comments and strings name nothing.
    assert_eq!(from_format, ["src/a/types.rs", "src/a/validate.rs"]);
    assert!(!imports[&by_name("src/a/validate.rs")].contains_key(&by_name("src/a/types.rs")));
}

#[test]
fn a_made_up_layer_violation_is_reported_with_its_line() {
    let t = made_up(&[
        ("src/lib.rs", "//! Root.\npub mod synth;\npub mod graph;\npub mod raster;\n"),
        (
            "src/synth/mod.rs",
            "//! S.\nuse crate::raster::Image;\nuse crate::{graph::Key, raster};\n\
             #[cfg(test)]\nmod tests {\n    use crate::graph::run;\n}\n",
        ),
        ("src/synth/deep.rs", "//! D.\nfn f() { super::super::graph::run(); }\n"),
        ("src/graph/mod.rs", "//! G.\npub struct Key;\npub fn run() {}\n"),
        ("src/raster/mod.rs", "//! R.\npub struct Image;\n"),
    ]);
    let bad = layer_violations(&t, "src/synth/", &|m| matches!(m, "synth" | "raster"));
    assert_eq!(bad.len(), 2, "{bad:?}");
    assert!(bad[0].starts_with("src/synth/deep.rs:2: uses `graph::run`"), "{}", bad[0]);
    assert!(bad[1].starts_with("src/synth/mod.rs:3: uses `graph::Key`"), "{}", bad[1]);
}

#[test]
fn a_made_up_kind_name_match_is_reported_outside_its_module_only() {
    let t = made_up(&[
        ("src/kinds/mod.rs", "//! K.\nfn f(k: &str) { match k { \"map\" => {}, _ => {} } }\n"),
        ("src/kinds/map/mod.rs", "//! M.\nfn g(k: &str) -> bool { k == \"map\" }\n"),
        ("src/kinds/layer/mod.rs", "//! L.\nfn h(k: &str) -> bool { k != \"sample\" } // \"map\" =>\n"),
    ]);
    let bad = kind_name_matches(&t);
    assert_eq!(bad.len(), 2, "{bad:?}");
    assert!(bad[0].starts_with("src/kinds/layer/mod.rs:2: sample"), "{}", bad[0]);
    assert!(bad[1].starts_with("src/kinds/mod.rs:2: map"), "{}", bad[1]);
}
