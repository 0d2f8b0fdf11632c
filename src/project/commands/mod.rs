//! The `tessera` subcommands as the command line runs them: each opens the project, calls
//! the library, prints what it returns and says whether it failed. `main.rs` parses the
//! arguments and calls one of these; everything a user sees is decided here.

mod explain;
mod fmt;
mod generate;
mod messages;
mod print;
mod review;
mod scenes;
mod watch;

use std::path::{Path, PathBuf};

pub use explain::explain;
pub use fmt::fmt;
pub use generate::{completions, man, Shell};
pub use messages::{set_message_format, MessageFormat};
pub use scenes::{bless, scenes, Mode};
pub use watch::watch;

/// Parses a memory size (`4GiB`, `512MiB`, bytes), for `--max-memory`.
pub use crate::graph::budget::parse_bytes;

use super::texture::{self, SimilarOptions};
use super::Project;
use print::print_failed;

/// The command failed and has said why on stderr (the process exits with 1).
#[derive(Debug)]
pub struct Reported;

pub type Outcome = Result<(), Reported>;

/// The options every command takes.
#[derive(Clone, Debug, Default)]
pub struct Global {
    /// Scene `param` overrides, `NAME=VALUE`.
    pub sets: Vec<(String, String)>,
    /// Print each stage's time and cache state.
    pub timings: bool,
    /// Write the stage report as JSON to this file.
    pub report: Option<PathBuf>,
    /// Print nothing but errors.
    pub quiet: bool,
    /// Memory budget in bytes, instead of the manifest's or the machine's.
    pub max_memory: Option<u64>,
    /// Instead of every scene's `seed`.
    pub seed: Option<u64>,
}

/// Runs parallel work on `jobs` threads (at least one). Outputs do not depend on it.
pub fn set_jobs(jobs: usize) {
    let _ = rayon::ThreadPoolBuilder::new().num_threads(jobs.max(1)).build_global();
}

impl Global {
    /// Opens the repository around the working directory, with these options applied.
    pub fn open(&self) -> Result<Project, Reported> {
        let cwd = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("."));
        let mut p = Project::open(&cwd).map_err(|f| print_failed(&f))?;
        p.sets = self.sets.clone();
        p.seed = self.seed;
        p.progress = !self.quiet && !messages::json();
        if let Some(m) = self.max_memory {
            p.set_budget(crate::graph::Budget::new(m));
        }
        Ok(p)
    }
}

/// `tessera graph`: a scene's stage graph with cache state, as text or DOT.
pub fn graph(g: &Global, scene: &Path, dot: bool) -> Outcome {
    let p = g.open()?;
    let (_, plan) = p.compile(scene).map_err(|f| print_failed(&f))?;
    let keys = p.keys(&plan).map_err(|f| print_failed(&f))?;
    let text = if dot { super::graph_dot(&plan, &keys, &p.cache) } else { super::graph_text(&plan, &keys, &p.cache) };
    print!("{text}");
    Ok(())
}

/// `tessera gc`: removes cache entries no current scene uses (every entry with `all`).
pub fn gc(g: &Global, all: bool) -> Outcome {
    let p = g.open()?;
    let scenes = if all { Vec::new() } else { p.scene_files(&[]).map_err(|f| print_failed(&f))? };
    let r = p.gc(&scenes, all).map_err(|f| print_failed(&f))?;
    if messages::json() {
        messages::emit(serde_json::json!({
            "type": "gc", "kept": r.kept, "removed": r.removed, "freed_bytes": r.freed_bytes,
            "foreign": r.foreign.iter().map(|f| f.display().to_string()).collect::<Vec<_>>(),
        }));
        return Ok(());
    }
    if !g.quiet {
        println!("gc: kept {} entries, removed {} ({:.1} KiB freed)", r.kept, r.removed, r.freed_bytes as f64 / 1024.0);
    }
    if !r.foreign.is_empty() {
        eprintln!(
            "warning: {} file(s) in the cache directory are not cache entries and were left alone, e.g. `{}`",
            r.foreign.len(),
            r.foreign[0].display()
        );
    }
    Ok(())
}

/// `tessera similar`: ranks a directory's images against a target through the `library`
/// kind's cached stages and prints the table (with `--timings`, the stages after it).
pub fn similar(g: &Global, dir: &Path, target: &Path, options: &SimilarOptions) -> Outcome {
    let p = g.open()?;
    let s = texture::similar(&p, dir, target, options).map_err(|e| {
        eprintln!("error: {e}");
        Reported
    })?;
    print!("{}", s.table);
    if g.timings && !g.quiet {
        print!("{}", super::timings_table(&s.report));
    }
    print::warnings(None, &s.report);
    match &g.report {
        Some(path) => scenes::write_report(
            path,
            serde_json::json!({ "queries": [{
                "library": dir.display().to_string(),
                "target": target.display().to_string(),
                "millis": s.millis,
                "stages": s.report.stages,
            }] }),
        ),
        None => Ok(()),
    }
}

/// `tessera lsp`: the language server, on stdin and stdout, until the editor ends it.
pub fn lsp() -> Outcome {
    super::lsp::serve().map_err(|e| {
        eprintln!("error: language server: {e}");
        Reported
    })
}

/// `tessera compare`: every texture measure of image `a` against image `b`.
pub fn compare(a: &Path, b: &Path) -> Outcome {
    match texture::compare(a, b) {
        Ok(table) => {
            print!("{table}");
            Ok(())
        }
        Err(e) => {
            eprintln!("error: {e}");
            Err(Reported)
        }
    }
}
