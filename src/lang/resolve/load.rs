//! Reading the scene: the `Loader` every file goes through, path normalisation, and the
//! recursive load of the root file and its imports (with import cycles reported).

use std::path::{Component, Path, PathBuf};
use std::sync::Arc;

use crate::lang::ast;
use crate::lang::diag::Diagnostic;
use crate::lang::parse::parse_file;
use crate::lang::source::{FileId, SourceMap, Span};

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

/// Lexical normalisation (`a/./b/../c` → `a/c`), so one file reached by two paths is one file.
///
/// A `..` cancels the component before it only where the operating system would agree:
/// that component is a real directory (not a link, which the system follows first, nor a
/// missing name, which makes the whole path fail). Elsewhere the `..` stays, so the read
/// resolves, or fails, exactly as the system resolves it. `/..` is `/`; a path that cancels
/// out entirely is `.`.
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
    if out.as_os_str().is_empty() {
        // `.` or `a/..`: the directory itself, which reads as one (not as a missing file).
        out.push(".");
    }
    out
}

pub(super) struct Cx {
    pub(super) sources: SourceMap,
    pub(super) errors: Vec<Diagnostic>,
    pub(super) files: Vec<(FileId, ast::File)>,
}

impl Cx {
    pub(super) fn load(&mut self, path: &Path, via: Option<Span>, stack: &mut Vec<PathBuf>, loader: &dyn Loader) {
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
