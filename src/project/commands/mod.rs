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
    /// The remote cache instead of `[cache] remote`.
    pub remote_cache: Option<String>,
    /// Read from the remote cache, never upload (whatever `[cache] mode` says).
    pub remote_read_only: bool,
    /// No remote cache, whatever `[cache] remote` says.
    pub no_remote_cache: bool,
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
        let url =
            if self.no_remote_cache { None } else { self.remote_cache.clone().or(p.manifest.cache.remote.clone()) };
        let read_only = self.remote_read_only || p.manifest.cache.mode == super::manifest::RemoteMode::ReadOnly;
        p.set_remote(url.as_deref(), read_only).map_err(|f| print_failed(&f))?;
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

/// `tessera cache stats`: the hit rates of the builds this cache has seen.
pub fn cache_stats(g: &Global) -> Outcome {
    let p = g.open()?;
    let s = p.cache.stats();
    let (entries, bytes) = p.cache.size();
    let remote = p.remote.as_ref().map(|r| (r.url().to_string(), r.read_only()));
    if messages::json() {
        let mut v = serde_json::json!({ "type": "cache_stats", "entries": entries, "bytes": bytes });
        for (k, x) in serde_json::to_value(s).unwrap_or_default().as_object().into_iter().flatten() {
            v[k.as_str()] = x.clone();
        }
        v["remote"] = remote.map(|(url, ro)| serde_json::json!({ "url": url, "read_only": ro })).into();
        messages::emit(v);
        return Ok(());
    }
    let size = |n: u64| crate::graph::budget::Bytes(n as f64).to_string();
    use crate::graph::stats::Stats;
    let pct = |n| Stats::percent(n, s.needed);
    println!("cache {}: {entries} entries, {}", print::shown(p.cache.dir()).display(), size(bytes));
    println!("{} builds needed {} stages:", s.builds, s.needed);
    println!("  local hits   {:>8}  {:5.1} %", s.local_hits, pct(s.local_hits));
    println!("  remote hits  {:>8}  {:5.1} %", s.remote_hits, pct(s.remote_hits));
    println!("  computed     {:>8}  {:5.1} %", s.computed, pct(s.computed));
    match remote {
        Some((url, ro)) => println!("remote {url}{}", if ro { " (read-only)" } else { "" }),
        None => println!("remote: none configured"),
    }
    if s.remote_lookups > 0 || s.bytes_up > 0 {
        println!(
            "  {} lookups, {} hits ({:.1} %); {} down, {} up; {} builds with a fault",
            s.remote_lookups,
            s.remote_hits,
            Stats::percent(s.remote_hits, s.remote_lookups),
            size(s.bytes_down),
            size(s.bytes_up),
            s.remote_faults
        );
    }
    Ok(())
}

/// `tessera cache push`: uploads the local entries of the scenes' stages the remote lacks.
pub fn cache_push(g: &Global, paths: &[PathBuf]) -> Outcome {
    let p = g.open()?;
    let scenes = p.scene_files(paths).map_err(|f| print_failed(&f))?;
    let r = p.push(&scenes).map_err(|f| print_failed(&f))?;
    if messages::json() {
        messages::emit(serde_json::json!({
            "type": "cache_push", "uploaded": r.uploaded, "bytes": r.bytes, "present": r.present,
            "not_local": r.not_local, "too_large": r.too_large,
        }));
    } else if !g.quiet {
        let url = p.remote.as_ref().map(|r| r.url().to_string()).unwrap_or_default();
        println!(
            "push to {url}: {} entries uploaded ({}), {} there already, {} not in the local cache, {} over max_blob",
            r.uploaded,
            crate::graph::budget::Bytes(r.bytes as f64),
            r.present,
            r.not_local,
            r.too_large
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
