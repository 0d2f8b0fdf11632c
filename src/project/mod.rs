//! The commands, as library calls: build, check, bless, graph, gc, watch. The CLI in
//! `main.rs` only parses arguments and prints what these return.

mod check;
pub mod manifest;
mod show;
pub mod texture;
mod watch;

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

pub use check::{CheckRow, CheckStatus};
pub use manifest::Manifest;
pub use show::{graph_dot, graph_text, timings_table};
pub use watch::{watch, WatchEvent};

use crate::graph::{self, Budget, Cache, Executor, Key, MemoryCache, Report, World};
use crate::lang::{self, Diagnostic, Diagnostics, Scene};
use crate::stages::{self, Bytes, Plan, PlannedOutput};

/// An open scene repository.
pub struct Project {
    pub root: PathBuf,
    pub manifest: Manifest,
    pub world: World,
    pub cache: Cache,
    /// In-memory artifacts kept between builds (watch mode).
    pub memory: Option<MemoryCache>,
    pub sets: Vec<(String, String)>,
    pub progress: bool,
    /// The memory budget planning and stages are held to (see `set_budget`).
    pub budget: Budget,
}

/// A build that did not complete: diagnostics, and the stage report up to the failure.
#[derive(Debug)]
pub struct Failed {
    pub diagnostics: Diagnostics,
    pub report: Option<Report>,
}

impl From<Diagnostics> for Failed {
    fn from(diagnostics: Diagnostics) -> Self {
        Failed { diagnostics, report: None }
    }
}

fn plain_error(message: String) -> Failed {
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
        let root = relative_to(&root, cwd);
        let cache = Cache::new(root.join(&manifest.paths.cache));
        let budget = manifest.limits.max_memory.map(Budget::new).unwrap_or_else(Budget::from_machine);
        let world = World::with_max_file(budget.max_file());
        Ok(Project { root, manifest, world, cache, memory: None, sets: Vec::new(), progress: true, budget })
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
        let registry = stages::registry();
        let opts = lang::Options { sets: &self.sets, registry: &registry };
        let scene = lang::compile(path, &WorldLoader(&self.world), &opts)?;
        match stages::plan_with(&scene, &stages::PlanOptions { budget: self.budget }) {
            Ok(plan) => Ok((scene, plan)),
            Err(errors) => Err(Diagnostics::new(errors, scene.sources).into()),
        }
    }

    fn executor(&self) -> Executor<'_> {
        Executor { world: &self.world, cache: &self.cache, memory: self.memory.as_ref(), progress: self.progress }
    }

    /// Builds a scene's outputs (in memory; `emit` writes them).
    pub fn build(&self, path: &Path) -> Result<Built, Failed> {
        let start = Instant::now();
        let (scene, plan) = self.compile(path)?;
        let targets: Vec<_> = plan.outputs.iter().map(|o| o.node).collect();
        let outcome = match self.executor().run(&plan.graph, &targets) {
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
            name: scene_name(path),
            scene,
            plan,
            outputs,
            report: outcome.report,
            millis: start.elapsed().as_secs_f64() * 1000.0,
        })
    }

    /// Writes a build's outputs atomically, skipping files that already hold those bytes.
    pub fn emit(&self, built: &Built) -> Result<Vec<Emitted>, Failed> {
        let dir = self.output_dir(&built.name);
        let mut out = Vec::new();
        for (o, bytes) in &built.outputs {
            let path = dir.join(&o.name);
            let same = std::fs::metadata(&path).is_ok_and(|m| m.len() == bytes.0.len() as u64)
                && std::fs::read(&path).is_ok_and(|b| b == bytes.0);
            if !same {
                graph::write_atomic(&path, &bytes.0)
                    .map_err(|e| plain_error(format!("cannot write `{}`: {e}", path.display())))?;
            }
            out.push(Emitted { path, written: !same });
        }
        Ok(out)
    }

    /// Writes the current outputs of a build as its goldens.
    pub fn bless(&self, built: &Built) -> Result<Vec<PathBuf>, Failed> {
        let dir = self.golden_dir(&built.name);
        let mut out = Vec::new();
        for (o, bytes) in &built.outputs {
            let path = dir.join(&o.name);
            graph::write_atomic(&path, &bytes.0)
                .map_err(|e| plain_error(format!("cannot write `{}`: {e}", path.display())))?;
            out.push(path);
        }
        Ok(out)
    }

    /// The keys of every stage of a scene, for `gc` and `graph`.
    pub fn keys(&self, plan: &Plan) -> Result<Vec<Key>, Failed> {
        let all: Vec<usize> = (0..plan.graph.nodes.len()).collect();
        let keys = self.executor().keys(&plan.graph, &all).map_err(|f| plain_error(f.error.message))?;
        Ok(all.iter().map(|n| keys[n]).collect())
    }

    /// Removes cache entries no current scene uses (every entry with `all`).
    pub fn gc(&self, scenes: &[PathBuf], all: bool) -> Result<graph::cache::GcReport, Failed> {
        let mut keep = HashSet::new();
        if !all {
            for s in scenes {
                let (_, plan) = self.compile(s)?;
                keep.extend(self.keys(&plan)?);
            }
        }
        self.cache.gc(&keep).map_err(|e| plain_error(format!("cannot collect the cache: {e}")))
    }
}

/// A scene's name: its file stem, which names its output and golden directories.
pub fn scene_name(path: &Path) -> String {
    path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "scene".into())
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
