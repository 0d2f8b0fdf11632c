//! Loading, name resolution and type checking: syntax trees in, a typed `Scene` out.
//!
//! This file runs the passes in order; they live in `load` (files and imports), `namespace`
//! (the checker's state, declarations, params and `--set`), `props` (blocks, defaults and
//! constructor calls), `values` (each value against its type), `expr` (arithmetic and
//! relative lengths) and `refs` (references, cycles).

mod axis;
mod expr;
mod load;
mod namespace;
mod props;
mod refs;
mod values;

use std::path::Path;

use super::diag::Diagnostics;
use super::ir::Scene;
use super::source::SourceMap;
use load::Cx;
use namespace::Checker;

pub use load::{normalize, Loader};
pub use namespace::Options;

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
    checker.apply_sets(opts.sets, opts.sets_may_miss);
    checker.check_all();
    if let Some(seed) = opts.seed {
        checker.seed = seed;
    }
    errors.append(&mut checker.errors);
    if errors.is_empty() {
        checker.check_cycles(&mut errors);
    }
    if !errors.is_empty() {
        return Err(Diagnostics::new(errors, checker.sources));
    }
    let mut params: Vec<String> = checker.params.keys().cloned().collect();
    params.sort();
    Ok(Scene {
        params,
        root,
        seed: checker.seed,
        size: checker.size,
        size_span: checker.size_span,
        decls: checker.out,
        sources: checker.sources,
    })
}
