//! The layout rules of `src/synth`, checked on the source text: no two files import each other
//! (directly or through a chain of files), and every file opens with a `//!` module doc.
//!
//! An import is any path in a file that resolves to another file's module: `crate::…`,
//! `super::…`, `self::…` (with `use a::{b, c}` groups expanded) and bare paths into a child
//! module (`engine::run` in `quilt/mod.rs`). Declaring a child (`mod tests;`) is not an
//! import. Paths resolve to the deepest module that is a file, so `use super::lloyd::X` in
//! `relaxation/voronoi.rs` is an edge to `relaxation/lloyd.rs`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

type Module = Vec<String>;
/// Each file's module and the file modules it imports.
type Graph = BTreeMap<Module, BTreeSet<Module>>;

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("read src") {
        let path = entry.expect("entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// `src/synth/quilt/mod.rs` → `[synth, quilt]`; `src/synth/rng.rs` → `[synth, rng]`.
fn module_of(src: &Path, file: &Path) -> Module {
    let rel = file.strip_prefix(src).expect("under src").with_extension("");
    let mut parts: Module = rel.iter().map(|p| p.to_string_lossy().into_owned()).collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    parts
}

/// The text without line comments (doc comments name paths in links, which are not imports).
fn code(text: &str) -> String {
    text.lines().map(|l| l.find("//").map_or(l, |i| &l[..i])).collect::<Vec<_>>().join("\n")
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// Every `a::b::c` path in `text`, with `a::{b, c::d}` groups expanded (one level).
fn paths(text: &str) -> Vec<Vec<String>> {
    let chars: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let starts = is_ident(chars[i]) && (i == 0 || !(is_ident(chars[i - 1]) || chars[i - 1] == ':'));
        if !starts {
            i += 1;
            continue;
        }
        let mut segs = Vec::new();
        let mut j = i;
        loop {
            let s = j;
            while j < chars.len() && is_ident(chars[j]) {
                j += 1;
            }
            segs.push(chars[s..j].iter().collect::<String>());
            if j + 2 < chars.len() && chars[j] == ':' && chars[j + 1] == ':' {
                j += 2;
                if chars[j] == '{' {
                    let close = (j..chars.len()).find(|&k| chars[k] == '}').unwrap_or(chars.len());
                    let inner: String = chars[j + 1..close].iter().collect();
                    for item in inner.split(',') {
                        let mut p = segs.clone();
                        p.extend(item.trim().split("::").map(|s| s.trim().to_string()).filter(|s| !s.is_empty()));
                        out.push(p);
                    }
                    j = close;
                    break;
                }
                if j < chars.len() && is_ident(chars[j]) {
                    continue;
                }
            }
            break;
        }
        if segs.len() > 1 {
            out.push(segs);
        }
        i = j.max(i + 1);
    }
    out
}

/// The file module a path used in `from` names, if any (the deepest one on the path).
fn resolve(from: &Module, path: &[String], files: &BTreeSet<Module>) -> Option<Module> {
    let (mut base, rest): (Module, &[String]) = match path[0].as_str() {
        "crate" => (Vec::new(), &path[1..]),
        "super" | "self" => {
            let mut base = from.clone();
            let mut k = 0;
            while k < path.len() && (path[k] == "super" || path[k] == "self") {
                if path[k] == "super" {
                    base.pop();
                }
                k += 1;
            }
            (base, &path[k..])
        }
        // A bare path into a child module of `from`.
        _ => {
            let mut child = from.clone();
            child.push(path[0].clone());
            if !files.contains(&child) {
                return None;
            }
            (from.clone(), path)
        }
    };
    let mut best = files.contains(&base).then(|| base.clone());
    for seg in rest {
        base.push(seg.clone());
        if files.contains(&base) {
            best = Some(base.clone());
        } else {
            break;
        }
    }
    best.filter(|m| m != from)
}

fn synth_graph() -> (Graph, Vec<(PathBuf, Module)>) {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut all = Vec::new();
    rust_files(&src, &mut all);
    let mods: Vec<(PathBuf, Module)> = all.iter().map(|f| (f.clone(), module_of(&src, f))).collect();
    let files: BTreeSet<Module> = mods.iter().map(|(_, m)| m.clone()).collect();
    let mut graph = BTreeMap::new();
    let synth: Vec<(PathBuf, Module)> =
        mods.into_iter().filter(|(_, m)| m.first().is_some_and(|s| s == "synth")).collect();
    for (file, module) in &synth {
        let text = code(&std::fs::read_to_string(file).expect("read"));
        let targets: BTreeSet<Module> = paths(&text)
            .iter()
            .filter_map(|p| resolve(module, p, &files))
            .filter(|m| m.first().is_some_and(|s| s == "synth"))
            .collect();
        graph.insert(module.clone(), targets);
    }
    (graph, synth)
}

/// A cycle through the graph, as module paths, if there is one.
fn find_cycle(graph: &Graph) -> Option<Vec<String>> {
    // 0 = unvisited, 1 = on the stack, 2 = done.
    fn visit(
        m: &Module,
        graph: &Graph,
        state: &mut BTreeMap<Module, u8>,
        stack: &mut Vec<Module>,
    ) -> Option<Vec<String>> {
        state.insert(m.clone(), 1);
        stack.push(m.clone());
        for next in graph.get(m).into_iter().flatten() {
            match state.get(next).copied().unwrap_or(0) {
                1 => {
                    let at = stack.iter().position(|s| s == next).expect("on stack");
                    let mut cycle: Vec<String> = stack[at..].iter().map(|s| s.join("/")).collect();
                    cycle.push(next.join("/"));
                    return Some(cycle);
                }
                0 => {
                    if let Some(c) = visit(next, graph, state, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(m.clone(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for m in graph.keys() {
        if state.get(m).copied().unwrap_or(0) == 0 {
            if let Some(c) = visit(m, graph, &mut state, &mut Vec::new()) {
                return Some(c);
            }
        }
    }
    None
}

#[test]
fn no_two_files_of_synth_import_each_other() {
    let (graph, _) = synth_graph();
    assert!(graph.len() > 50, "the walk found only {} files under src/synth", graph.len());
    // The checker itself: the structure kind's Lloyd imports its Voronoi diagrams.
    let lloyd: Module = ["synth", "structure", "relaxation", "lloyd"].map(String::from).to_vec();
    let voronoi: Module = ["synth", "structure", "relaxation", "voronoi"].map(String::from).to_vec();
    assert!(graph[&lloyd].contains(&voronoi), "the import graph misses lloyd -> voronoi");
    if let Some(cycle) = find_cycle(&graph) {
        panic!("files of src/synth import each other: {}", cycle.join(" -> "));
    }
}

#[test]
fn the_cycle_finder_finds_a_cycle() {
    let m = |s: &str| s.split('/').map(String::from).collect::<Module>();
    let graph: Graph = [
        (m("synth/a"), [m("synth/b")].into()),
        (m("synth/b"), [m("synth/c")].into()),
        (m("synth/c"), [m("synth/a")].into()),
    ]
    .into();
    assert_eq!(find_cycle(&graph).expect("cycle"), ["synth/a", "synth/b", "synth/c", "synth/a"]);
    let files: BTreeSet<Module> = [m("synth/q"), m("synth/q/engine"), m("synth/q/params")].into();
    let p = |s: &str| s.split("::").map(String::from).collect::<Vec<_>>();
    assert_eq!(resolve(&m("synth/q"), &p("engine::run"), &files), Some(m("synth/q/engine")));
    assert_eq!(resolve(&m("synth/q/engine"), &p("super::params::X"), &files), Some(m("synth/q/params")));
    assert_eq!(resolve(&m("synth/q/engine"), &p("super::X"), &files), Some(m("synth/q")));
    assert_eq!(paths("use super::{params::X, Y};"), [p("super::params::X"), p("super::Y")]);
}

#[test]
fn every_file_of_synth_opens_with_a_module_doc() {
    let (_, files) = synth_graph();
    let missing: Vec<String> = files
        .iter()
        .filter(|(f, _)| !std::fs::read_to_string(f).expect("read").starts_with("//!"))
        .map(|(f, _)| f.display().to_string())
        .collect();
    assert!(missing.is_empty(), "files without a `//!` module doc: {missing:?}");
}
