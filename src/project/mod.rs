//! The commands, as library calls: build, check, bless, graph, gc, watch. `commands` runs
//! them as the CLI does (what is printed, when a command fails); `main.rs` only parses
//! arguments and calls it.

mod check;
pub mod commands;
pub mod format;
mod goldens;
pub mod lsp;
pub mod manifest;
pub mod preview;
mod show;
pub mod texture;
mod watch;

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

pub use check::{check_diagnostics, CheckRow, CheckStatus};
pub use manifest::Manifest;
pub use show::{graph_dot, graph_text, timings_table};
pub use watch::{watch, WatchEvent};

use crate::graph::remote::{Auth, Remote, RemoteConfig};
use crate::graph::{self, files, Budget, Cache, Executor, Key, MemoryCache, Report, World};
use crate::kinds::{self, Bytes, Plan, PlannedOutput};
use crate::lang::{self, Diagnostic, Diagnostics, Scene};

/// An open scene repository.
pub struct Project {
    pub root: PathBuf,
    pub manifest: Manifest,
    pub world: World,
    pub cache: Cache,
    /// In-memory artifacts kept between builds (watch mode).
    pub memory: Option<MemoryCache>,
    pub sets: Vec<(String, String)>,
    /// Whether a scene may lack a param of `sets` (see `lang::Options::sets_may_miss`).
    pub sets_may_miss: bool,
    /// Instead of every scene's `seed`.
    pub seed: Option<u64>,
    pub progress: bool,
    /// The memory budget planning and stages are held to (see `set_budget`).
    pub budget: Budget,
    /// The shared cache under the local one (`[cache] remote`, `--remote-cache`).
    pub remote: Option<Arc<Remote>>,
}

/// A build that did not complete: diagnostics, and the stage report up to the failure.
#[derive(Debug)]
pub struct Failed {
    pub diagnostics: Diagnostics,
    pub report: Option<Report>,
}

impl std::fmt::Display for Failed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.diagnostics.fmt(f)
    }
}

impl std::error::Error for Failed {}

impl From<Diagnostics> for Failed {
    fn from(diagnostics: Diagnostics) -> Self {
        Failed { diagnostics, report: None }
    }
}

pub(crate) fn plain_error(message: String) -> Failed {
    Diagnostics::new(vec![Diagnostic::error(message)], Default::default()).into()
}

pub struct Built {
    pub scene_path: PathBuf,
    pub name: String,
    pub scene: Scene,
    pub plan: Plan,
    pub outputs: Vec<(PlannedOutput, Arc<Bytes>)>,
    pub report: Report,
    pub millis: f64,
}

#[derive(Clone, Debug)]
pub struct Emitted {
    pub path: PathBuf,
    pub written: bool,
}

struct WorldLoader<'a>(&'a World);

impl lang::Loader for WorldLoader<'_> {
    fn load(&self, path: &Path) -> std::io::Result<Arc<str>> {
        self.0.read_text(path)
    }

    fn list(&self, dir: &Path) -> std::io::Result<Vec<PathBuf>> {
        self.0.list(dir)
    }
}

impl Project {
    /// Opens the repository containing `cwd` (or `cwd` itself when it has no manifest).
    pub fn open(cwd: &Path) -> Result<Project, Failed> {
        let root = manifest::find_root(cwd).unwrap_or_else(|| cwd.to_path_buf());
        let manifest = manifest::load(&root)?;
        // Paths are shown relative to where the command runs. A caller opening another
        // directory than the process's own (the fuzz harness, an embedding tool) keeps the
        // full path: relative to `cwd`, it would lead from the process's directory instead.
        let root = match std::env::current_dir() {
            Ok(here) if here == cwd => relative_to(&root, cwd),
            _ => root,
        };
        let cache = Cache::new(root.join(&manifest.paths.cache));
        let budget = manifest.limits.max_memory.map(Budget::new).unwrap_or_else(Budget::from_machine);
        let world = World::with_max_file(budget.max_file());
        Ok(Project {
            root,
            manifest,
            world,
            cache,
            memory: None,
            sets: Vec::new(),
            sets_may_miss: false,
            seed: None,
            progress: true,
            budget,
            remote: None,
        })
    }

    /// Connects the remote cache at `url` (`None`: none), reading credentials from the
    /// environment: `TESSERA_REMOTE_CACHE_TOKEN` (bearer) or `TESSERA_REMOTE_CACHE_BASIC`
    /// (`user:password`). `[cache]` gives the timeout, the blob limit and the rest after a
    /// fault.
    pub fn set_remote(&mut self, url: Option<&str>, read_only: bool) -> Result<(), Failed> {
        let Some(url) = url else {
            self.remote = None;
            return Ok(());
        };
        let url = graph::remote::parse_url(url).map_err(plain_error)?;
        let secret = |name: &str| std::env::var(name).ok().filter(|v| !v.is_empty());
        let auth = match (secret("TESSERA_REMOTE_CACHE_TOKEN"), secret("TESSERA_REMOTE_CACHE_BASIC")) {
            (Some(_), Some(_)) => {
                return Err(plain_error(
                    "both TESSERA_REMOTE_CACHE_TOKEN and TESSERA_REMOTE_CACHE_BASIC are set; keep one".into(),
                ))
            }
            (Some(t), None) => Some(Auth::Bearer(t)),
            (None, Some(b)) if !b.contains(':') => {
                return Err(plain_error("TESSERA_REMOTE_CACHE_BASIC is `user:password`, and has no `:`".into()))
            }
            (None, Some(b)) => Some(Auth::Basic(b)),
            (None, None) => None,
        };
        let c = &self.manifest.cache;
        self.remote = Some(Remote::new(RemoteConfig {
            url,
            read_only,
            timeout: std::time::Duration::from_secs_f64(c.timeout),
            max_blob: c.max_blob,
            retry: std::time::Duration::from_secs_f64(c.retry),
            auth,
        }));
        Ok(())
    }

    /// Holds planning, stages and file reads to `budget`.
    pub fn set_budget(&mut self, budget: Budget) {
        self.budget = budget;
        self.world.set_max_file(budget.max_file());
    }

    pub fn scenes_dir(&self) -> PathBuf {
        self.root.join(&self.manifest.paths.scenes)
    }

    pub fn output_dir(&self, scene: &str) -> PathBuf {
        self.root.join(&self.manifest.paths.outputs).join(scene)
    }

    pub fn golden_dir(&self, scene: &str) -> PathBuf {
        self.root.join(&self.manifest.paths.golden).join(scene)
    }

    /// Scene files named by `args` (files, or directories searched for `*.tess`), or all
    /// scenes of the repository.
    pub fn scene_files(&self, args: &[PathBuf]) -> Result<Vec<PathBuf>, Failed> {
        let roots: Vec<PathBuf> = if args.is_empty() { vec![self.scenes_dir()] } else { args.to_vec() };
        let mut out = Vec::new();
        for r in roots {
            if r.is_dir() {
                let mut found = Vec::new();
                collect_scenes(&r, &mut found)
                    .map_err(|e| plain_error(format!("cannot list `{}`: {e}", r.display())))?;
                found.sort();
                out.extend(found);
            } else if r.is_file() {
                out.push(r);
            } else {
                return Err(plain_error(format!("no such scene file or directory: `{}`", r.display())));
            }
        }
        Ok(out)
    }

    /// Parses, resolves and plans a scene.
    pub fn compile(&self, path: &Path) -> Result<(Scene, Plan), Failed> {
        self.compile_through(path, &WorldLoader(&self.world))
    }

    /// Parses, resolves and plans a scene, reading its files through `loader`: the language
    /// server's, which serves the text of open documents from memory.
    pub fn compile_through(&self, path: &Path, loader: &dyn lang::Loader) -> Result<(Scene, Plan), Failed> {
        let registry = kinds::registry();
        let opts =
            lang::Options { sets: &self.sets, sets_may_miss: self.sets_may_miss, seed: self.seed, registry: &registry };
        let scene = lang::compile(path, loader, &opts)?;
        match kinds::plan_with(&scene, &kinds::PlanOptions { budget: self.budget, loader: Some(loader) }) {
            Ok(plan) => Ok((scene, plan)),
            Err(errors) => Err(Diagnostics::new(errors, scene.sources).into()),
        }
    }

    fn executor(&self) -> Executor<'_> {
        Executor {
            world: &self.world,
            cache: &self.cache,
            memory: self.memory.as_ref(),
            remote: self.remote.as_ref(),
            progress: self.progress,
            budget: self.budget,
        }
    }

    /// Builds a scene's outputs (in memory; `emit` writes them).
    pub fn build(&self, path: &Path) -> Result<Built, Failed> {
        let start = Instant::now();
        let name = self.scene_name(path)?;
        let (scene, plan) = self.compile(path)?;
        let targets: Vec<_> = plan.outputs.iter().map(|o| o.node).collect();
        let before = self.remote.as_ref().map(|r| r.traffic()).unwrap_or_default();
        if let Some(remote) = &self.remote {
            remote.wake();
        }
        let run = self.executor().run(&plan.graph, &targets);
        let run = self.settle_remote(run, before);
        let outcome = match run {
            Ok(o) => o,
            Err((failure, report)) => {
                let d = plan.diagnose(&scene, &failure);
                return Err(Failed { diagnostics: Diagnostics::new(vec![d], scene.sources), report: Some(report) });
            }
        };
        if let Some(mem) = &self.memory {
            mem.retain(&outcome.keys.values().copied().collect());
        }
        let outputs = plan
            .outputs
            .iter()
            .map(|o| {
                let bytes = outcome.values[&o.node].clone().downcast::<Bytes>().expect("outputs are bytes");
                (o.clone(), bytes)
            })
            .collect();
        Ok(Built {
            scene_path: path.to_path_buf(),
            name,
            scene,
            plan,
            outputs,
            report: outcome.report,
            millis: start.elapsed().as_secs_f64() * 1000.0,
        })
    }

    /// Waits (at most the remote's timeout) for the build's uploads, notes the bytes each
    /// stage sent, and adds the build to the cache's counts.
    fn settle_remote(
        &self,
        mut run: Result<graph::Outcome, (graph::Failure, Report)>,
        before: graph::remote::Traffic,
    ) -> Result<graph::Outcome, (graph::Failure, Report)> {
        let completed = run.is_ok();
        let report = match &mut run {
            Ok(o) => &mut o.report,
            Err((_, r)) => r,
        };
        let mut traffic = graph::remote::Traffic::default();
        if let Some(remote) = &self.remote {
            let sent = remote.settle();
            for s in &mut report.stages {
                s.bytes_up = sent.get(&s.key).copied().unwrap_or(0);
            }
            let now = remote.traffic();
            traffic = graph::remote::Traffic {
                lookups: now.lookups - before.lookups,
                bytes_down: now.bytes_down - before.bytes_down,
                bytes_up: report.stages.iter().map(|s| s.bytes_up).sum(),
                faults: now.faults - before.faults,
            };
        }
        // Completed builds are counted (a failed one leaves the cache as it was); counting
        // is best effort: a cache that cannot be written costs the count only.
        if completed {
            let _ = self.cache.add_stats(&report.stats(traffic));
        }
        run
    }

    /// The name of a scene, which names its output and golden directories: its path below
    /// the scenes directory without `.tess` (`scenes/sub/s.tess` → `sub/s`), or its file
    /// stem when it lies elsewhere. Refused when it could not name a directory of its own
    /// (`...tess` has the stem `..`; names starting with `.` are kept for tessera's own).
    pub fn scene_name(&self, path: &Path) -> Result<String, Failed> {
        let file = path.file_name().map(Path::new).unwrap_or(path);
        let below = path
            .parent()
            .map(|p| if p.as_os_str().is_empty() { Path::new(".") } else { p })
            .and_then(|p| p.canonicalize().ok())
            .zip(self.scenes_dir().canonicalize().ok())
            .and_then(|(p, d)| p.strip_prefix(d).ok().map(Path::to_path_buf))
            .unwrap_or_default();
        let rel = below.join(file);
        let rel = match rel.to_str().and_then(|r| r.strip_suffix(".tess")) {
            Some(stem) => PathBuf::from(stem),
            None => rel.with_extension(""),
        };
        let bad = |why: String| {
            plain_error(format!(
                "the scene `{}` cannot name its output directory: {why}; rename the file",
                path.display()
            ))
        };
        let mut parts = Vec::new();
        for c in rel.components() {
            let std::path::Component::Normal(c) = c else {
                return Err(bad("its name is not a plain file name".into()));
            };
            let Some(c) = c.to_str() else { return Err(bad("its name is not valid UTF-8".into())) };
            if c.is_empty() || c.starts_with('.') {
                return Err(bad(format!("`{c}` starts with `.`, which tessera keeps for its own files")));
            }
            parts.push(c);
        }
        if parts.is_empty() {
            return Err(bad("its name is empty".into()));
        }
        let name = parts.join("/");
        files::normal_relative(&name).map_err(|p| bad(p.to_string()))?;
        Ok(name)
    }

    fn outputs_root(&self) -> PathBuf {
        self.root.join(&self.manifest.paths.outputs)
    }

    /// The directory a scene's outputs are written to (`out/<scene>`).
    pub fn outputs_dir(&self, scene: &str) -> PathBuf {
        self.outputs_root().join(scene)
    }

    fn golden_root(&self) -> PathBuf {
        self.root.join(&self.manifest.paths.golden)
    }

    /// Where `check` writes the diff image of a failing output: a directory no output can be
    /// in (scene names never start with `.`), named after the whole output file name.
    pub fn diff_path(&self, scene: &str, output: &str) -> Result<PathBuf, Failed> {
        files::contained(&self.outputs_root(), &format!(".diff/{scene}/{output}.diff.png"))
            .map_err(|p| plain_error(format!("cannot place the diff image of `{scene}/{output}`: {p}")))
    }

    /// The files a build writes below `root`, each proven to lie inside it.
    fn destinations(&self, built: &Built, root: &Path) -> Result<Vec<PathBuf>, Failed> {
        built
            .outputs
            .iter()
            .map(|(o, _)| {
                files::contained(root, &format!("{}/{}", built.name, o.name)).map_err(|p| {
                    let d = Diagnostic::error(format!("cannot write `{}`: {p}", o.name))
                        .with_code("tessera::output_path")
                        .with_label(o.span, "this output");
                    Failed::from(Diagnostics::new(vec![d], built.scene.sources.clone()))
                })
            })
            .collect()
    }

    /// Writes a build's outputs as one set: every destination checked first, every file
    /// flushed to a temporary, then all renamed into place; on any failure no output
    /// changes. Files that already hold their bytes are not touched.
    pub fn emit(&self, built: &Built) -> Result<Vec<Emitted>, Failed> {
        let root = self.outputs_root();
        self.commit(built, &root, "outputs")
    }

    /// Writes the current outputs of a build as its goldens, as one set.
    pub fn bless(&self, built: &Built) -> Result<Vec<PathBuf>, Failed> {
        let root = self.golden_root();
        Ok(self.commit(built, &root, "goldens")?.into_iter().map(|e| e.path).collect())
    }

    fn commit(&self, built: &Built, root: &Path, what: &str) -> Result<Vec<Emitted>, Failed> {
        self.commit_some(built, root, what, &|_| true)
    }

    /// Writes the outputs `keep` selects as one set below `root`.
    fn commit_some(
        &self,
        built: &Built,
        root: &Path,
        what: &str,
        keep: &dyn Fn(&PlannedOutput) -> bool,
    ) -> Result<Vec<Emitted>, Failed> {
        let chosen: Vec<usize> = (0..built.outputs.len()).filter(|&i| keep(&built.outputs[i].0)).collect();
        let all = self.destinations(built, root)?;
        let paths: Vec<PathBuf> = chosen.iter().map(|&i| all[i].clone()).collect();
        let mut dirs: Vec<&Path> = paths.iter().filter_map(|p| p.parent()).collect();
        dirs.sort();
        dirs.dedup();
        for d in dirs {
            files::sweep_stale(d);
        }
        let mut set = files::OutputSet::new();
        for (path, &i) in paths.iter().zip(&chosen) {
            set.add(path.clone(), built.outputs[i].1 .0.clone());
        }
        let written = set.commit().map_err(|e| {
            let mut d =
                Diagnostic::error(format!("{e}; none of the scene's {what} was changed")).with_code("tessera::write");
            if let Some(i) = paths.iter().position(|p| *p == e.path) {
                d = d.with_label(built.outputs[chosen[i]].0.span, "this output");
            }
            Failed::from(Diagnostics::new(vec![d], built.scene.sources.clone()))
        })?;
        Ok(written.into_iter().map(|w| Emitted { path: w.path, written: w.changed }).collect())
    }

    /// The names of every scene of the repository (those whose name is valid).
    pub fn scene_names(&self) -> Vec<String> {
        let files = self.scene_files(&[]).unwrap_or_default();
        files.iter().filter_map(|f| self.scene_name(f).ok()).collect()
    }

    /// The keys of every stage of a scene, for `gc` and `graph`.
    pub fn keys(&self, plan: &Plan) -> Result<Vec<Key>, Failed> {
        let all: Vec<usize> = (0..plan.graph.nodes.len()).collect();
        let keys = self.executor().keys(&plan.graph, &all).map_err(|f| plain_error(f.error.message))?;
        Ok(all.iter().map(|n| keys[n]).collect())
    }

    /// The stage keys of every stage of `scenes`.
    fn scenes_keys(&self, scenes: &[PathBuf]) -> Result<HashSet<Key>, Failed> {
        let mut keys = HashSet::new();
        for s in scenes {
            let (_, plan) = self.compile(s)?;
            keys.extend(self.keys(&plan)?);
        }
        Ok(keys)
    }

    /// Removes cache entries no current scene uses (every entry with `all`).
    pub fn gc(&self, scenes: &[PathBuf], all: bool) -> Result<graph::cache::GcReport, Failed> {
        let keep = if all { HashSet::new() } else { self.scenes_keys(scenes)? };
        self.cache.gc(&keep).map_err(|e| plain_error(format!("cannot collect the cache: {e}")))
    }

    /// Uploads to the remote the local cache's entries of `scenes`' stages that it lacks:
    /// stages built before the remote was set, or while it was off.
    pub fn push(&self, scenes: &[PathBuf]) -> Result<graph::remote::Pushed, Failed> {
        let Some(remote) = &self.remote else {
            return Err(plain_error("no remote cache to push to: set `[cache] remote` or `--remote-cache`".into()));
        };
        let mut keys: Vec<Key> = self.scenes_keys(scenes)?.into_iter().collect();
        keys.sort();
        remote.push(&self.cache, &keys).map_err(plain_error)
    }
}

/// The files one command writes, across scenes: two scenes may not write one file, nor
/// may one need as a directory what another writes as a file.
#[derive(Default)]
pub struct Claims {
    files: std::collections::HashMap<PathBuf, (String, String)>,
    dirs: std::collections::HashMap<PathBuf, (String, String)>,
}

impl Claims {
    /// Claims the outputs of a build, or says which other scene's output is in the way.
    pub fn claim(&mut self, built: &Built) -> Result<(), Failed> {
        let shown: PathBuf =
            built.scene_path.components().filter(|c| !matches!(c, std::path::Component::CurDir)).collect();
        let owner = |o: &PlannedOutput| (shown.display().to_string(), o.name.clone());
        let mut clash = None;
        for (o, _) in &built.outputs {
            let path = Path::new(&built.name).join(&o.name);
            let other = self
                .files
                .get(&path)
                .or_else(|| self.dirs.get(&path))
                .or_else(|| path.ancestors().skip(1).find_map(|a| self.files.get(a)));
            if let Some((scene, output)) = other {
                clash = Some((o, format!("`{}` is also written by output \"{output}\" of `{scene}`", path.display())));
                break;
            }
        }
        if let Some((o, message)) = clash {
            let d = Diagnostic::error(message)
                .with_code("tessera::output_collision")
                .with_label(o.span, "this output")
                .with_help("two scenes with one name write one directory; rename a scene or an output");
            return Err(Diagnostics::new(vec![d], built.scene.sources.clone()).into());
        }
        for (o, _) in &built.outputs {
            let path = Path::new(&built.name).join(&o.name);
            for a in path.ancestors().skip(1) {
                if !a.as_os_str().is_empty() {
                    self.dirs.entry(a.to_path_buf()).or_insert_with(|| owner(o));
                }
            }
            self.files.insert(path, owner(o));
        }
        Ok(())
    }
}

fn collect_scenes(dir: &Path, out: &mut Vec<PathBuf>) -> std::io::Result<()> {
    for e in std::fs::read_dir(dir)? {
        let p = e?.path();
        if p.is_dir() {
            collect_scenes(&p, out)?;
        } else if p.extension().is_some_and(|x| x == "tess")
            && !p.file_name().is_some_and(|n| n.to_string_lossy().starts_with('_'))
        {
            // `_name.tess` files are libraries for imports, not scenes.
            out.push(p);
        }
    }
    Ok(())
}

/// `path` relative to `base` when it lies below it, so diagnostics show short paths.
fn relative_to(path: &Path, base: &Path) -> PathBuf {
    match path.strip_prefix(base) {
        Ok(p) if p.as_os_str().is_empty() => PathBuf::from("."),
        Ok(p) => p.to_path_buf(),
        Err(_) => path.to_path_buf(),
    }
}
