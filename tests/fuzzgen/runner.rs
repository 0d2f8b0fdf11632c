//! Running cases: in-process with `catch_unwind` (a panic is a finding with a minimised
//! reproducer), in worker processes under an address-space limit with a per-case wall-clock
//! watchdog (an abort, a stack overflow, an allocation past the budget or a hang is a
//! finding too), driven by a parent that restarts workers past the case that killed them
//! and writes every finding to a directory.

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader, Write};
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::Ordering;
use std::sync::{mpsc, Arc, Mutex};
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use super::{files, mutate, scene, Rng};

/// The environment variable through which a parent hands a worker its job.
pub const WORKER_ENV: &str = "TESSERA_FUZZ_WORKER";
const TAG: &str = "@@FUZZ ";

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, PartialOrd, Ord)]
pub enum Stream {
    Scene,
    File,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, PartialOrd, Ord)]
pub struct CaseId {
    pub stream: Stream,
    pub index: u64,
}

impl std::fmt::Display for CaseId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = match self.stream {
            Stream::Scene => "scene",
            Stream::File => "file",
        };
        write!(f, "{s}-{}", self.index)
    }
}

/// A generated case: scene text, its extra files, and how far to drive it.
#[derive(Clone, Debug)]
pub struct Case {
    pub id: CaseId,
    pub what: String,
    pub text: String,
    pub files: Vec<(String, Vec<u8>)>,
    pub sets: Vec<(String, String)>,
    /// Build (and emit) after compiling; mutants of the larger bundled scenes only compile
    /// most of the time, to keep throughput.
    pub build: bool,
}

pub struct Generator {
    pub seed: u64,
    corpus: Vec<(String, String)>,
}

impl Generator {
    pub fn new(seed: u64) -> Generator {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        Generator { seed, corpus: mutate::corpus(&dir) }
    }

    pub fn case(&self, id: CaseId) -> Case {
        match id.stream {
            Stream::Scene => {
                let mut rng = Rng::for_case(self.seed, 1, id.index);
                if rng.chance(0.2) {
                    let (name, src) = rng.pick(&self.corpus).clone();
                    let text = mutate::mutate(&mut rng, &src, &self.corpus);
                    let build = rng.chance(0.1);
                    return Case {
                        id,
                        what: format!("mutant of scenes/{name}"),
                        text,
                        files: vec![],
                        sets: vec![],
                        build,
                    };
                }
                let g = scene::generate(&mut rng);
                let mut sets = Vec::new();
                if rng.chance(0.03) {
                    sets.push(("p0".to_string(), rng.pick(&["1", "0", "1e308", "\"x\"", "64 x 64", "-1"]).to_string()));
                }
                let what = if g.clean { "generated scene (clean)" } else { "generated scene (noisy)" };
                Case { id, what: what.into(), text: g.text, files: g.files, sets, build: true }
            }
            Stream::File => {
                let mut rng = Rng::for_case(self.seed, 2, id.index);
                let f = files::generate(&mut rng);
                Case { id, what: f.what, text: f.scene, files: f.files, sets: vec![], build: true }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// One case, in-process

/// A scratch project: the pool of valid input files, the bundled scene libraries and a
/// link to the repository's samples (which the bundled scenes read).
pub struct Workspace {
    pub root: PathBuf,
}

impl Workspace {
    pub fn create(root: PathBuf) -> Workspace {
        let _ = std::fs::remove_dir_all(&root);
        let scenes = root.join("scenes");
        std::fs::create_dir_all(&scenes).expect("workspace");
        populate(&scenes);
        #[cfg(unix)]
        let _ = std::os::unix::fs::symlink(Path::new(env!("CARGO_MANIFEST_DIR")).join("samples"), root.join("samples"));
        Workspace { root }
    }

    fn scene_path(&self) -> PathBuf {
        self.root.join("scenes").join("scene.tess")
    }
}

impl Drop for Workspace {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.root);
    }
}

fn populate(scenes: &Path) {
    for (name, bytes) in files::pool() {
        let p = scenes.join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, bytes).unwrap();
    }
    for d in files::EMPTY_DIRS {
        std::fs::create_dir_all(scenes.join(d)).unwrap();
    }
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    for e in std::fs::read_dir(repo).unwrap().flatten() {
        if e.file_name().to_string_lossy().starts_with('_') {
            std::fs::copy(e.path(), scenes.join(e.file_name())).unwrap();
        }
    }
}

#[derive(Debug, Default, Clone, Copy)]
pub struct Ran {
    pub compiled: bool,
    pub built: bool,
}

/// A case's failure other than a clean diagnostic.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Problem {
    /// `panic`, `mismatch`, `crash`, `hang`, `alloc`, `stack-overflow`.
    pub kind: String,
    /// Where (a panic's location), for grouping.
    pub signature: String,
    pub message: String,
}

static LAST_PANIC: Mutex<Option<(String, String)>> = Mutex::new(None);

/// Records panics (message, location and the tessera frames of the backtrace) instead of
/// printing them, so a caught panic becomes a finding.
pub fn install_panic_hook() {
    std::panic::set_hook(Box::new(|info| {
        let msg = if let Some(s) = info.payload().downcast_ref::<&str>() {
            s.to_string()
        } else if let Some(s) = info.payload().downcast_ref::<String>() {
            s.clone()
        } else {
            "(non-string panic payload)".into()
        };
        // Dependencies' paths from the registry's source directory on.
        let loc = info
            .location()
            .map(|l| {
                let f = l.file();
                let f = f.find("/registry/src/").and_then(|i| f[i..].splitn(5, '/').nth(4)).unwrap_or(f);
                format!("{f}:{}", l.line())
            })
            .unwrap_or_default();
        let bt = std::backtrace::Backtrace::force_capture().to_string();
        // The frames of code that is not the panic machinery, innermost first.
        let machinery = ["std::", "core::", "alloc::", "rust_begin", "__rust", "<alloc::", "<core::", "<std::"];
        let frames: Vec<&str> = bt
            .lines()
            .map(str::trim)
            .filter_map(|l| l.split_once(": ").filter(|(n, _)| n.chars().all(|c| c.is_ascii_digit())))
            .map(|(_, f)| f)
            .filter(|f| !machinery.iter().any(|p| f.starts_with(p)) && !f.contains("install_panic_hook"))
            .take(10)
            .collect();
        let mut last = LAST_PANIC.lock().unwrap_or_else(|e| e.into_inner());
        if last.is_none() {
            // A panic inside std or a dependency is told apart by the tessera frame below it.
            let site = if loc.starts_with("src/") {
                loc.clone()
            } else {
                let via =
                    frames.iter().find(|f| f.starts_with("tessera::")).map(|f| f.trim_end_matches("::{{closure}}"));
                let short = loc.rsplit("/src/").next().unwrap_or(&loc).to_string();
                match via {
                    Some(v) => format!("{short} in {v}"),
                    None => loc.clone(),
                }
            };
            *last = Some((format!("{msg}\n  at {loc}\n  {}", frames.join("\n  ")), site));
        }
    }));
}

fn write_case(ws: &Workspace, text: &str, case: &Case) -> Vec<PathBuf> {
    let scenes = ws.root.join("scenes");
    let mut written = vec![ws.scene_path()];
    std::fs::write(ws.scene_path(), text).expect("scene");
    for (name, bytes) in &case.files {
        let p = scenes.join(name);
        if let Some(parent) = p.parent() {
            if !parent.exists() {
                std::fs::create_dir_all(parent).unwrap();
                written.push(parent.to_path_buf());
            }
        }
        std::fs::write(&p, bytes).unwrap();
        written.push(p);
    }
    written
}

fn clean_case(ws: &Workspace, written: &[PathBuf]) {
    for p in written.iter().rev() {
        if p.is_dir() {
            let _ = std::fs::remove_dir_all(p);
        } else {
            let _ = std::fs::remove_file(p);
        }
    }
    let _ = std::fs::remove_dir_all(ws.root.join("out"));
    let _ = std::fs::remove_dir_all(ws.root.join(".tessera"));
}

fn render(d: &tessera::lang::Diagnostics) -> usize {
    let handler = miette::GraphicalReportHandler::new_themed(miette::GraphicalTheme::unicode_nocolor()).with_width(100);
    let mut n = 0;
    for item in &d.items {
        let rendered = tessera::lang::diag::render(item, &d.sources);
        let mut out = String::new();
        let _ = handler.render_report(&mut out, &rendered);
        n += out.len();
    }
    n
}

fn safe_output_name(name: &str) -> bool {
    !name.is_empty() && !name.starts_with('/') && !name.split(['/', '\\']).any(|c| c == ".." || c.is_empty())
}

/// The pipeline: format, compile, build, render the diagnostics or emit, then build again
/// from the cache and compare.
fn pipeline(ws: &Workspace, case: &Case, text: &str) -> Result<Ran, Problem> {
    if std::env::var_os(SELFTEST_ENV).is_some() {
        selftest(text);
    }
    let _ = tessera::lang::fmt::format_source(text);
    let mut ran = Ran::default();
    let mut project = tessera::project::Project::open(&ws.root).map_err(|f| Problem {
        kind: "setup".into(),
        signature: "setup".into(),
        message: f.diagnostics.to_string(),
    })?;
    project.progress = false;
    project.sets = case.sets.clone();
    let path = ws.scene_path();
    if !case.build {
        match project.compile(&path) {
            Ok(_) => ran.compiled = true,
            Err(f) => {
                render(&f.diagnostics);
            }
        }
        return Ok(ran);
    }
    match project.build(&path) {
        Err(f) => {
            render(&f.diagnostics);
        }
        Ok(built) => {
            ran.compiled = true;
            ran.built = true;
            if built.outputs.iter().all(|(o, _)| safe_output_name(&o.name)) {
                if let Err(f) = project.emit(&built) {
                    render(&f.diagnostics);
                }
            }
            // From the cache: the same bytes.
            let mut again = tessera::project::Project::open(&ws.root).expect("opened before");
            again.progress = false;
            again.sets = case.sets.clone();
            match again.build(&path) {
                Ok(second) => {
                    for ((o, a), (_, b)) in built.outputs.iter().zip(&second.outputs) {
                        if a.0 != b.0 {
                            return Err(Problem {
                                kind: "mismatch".into(),
                                signature: format!("mismatch {}", o.name.rsplit('.').next().unwrap_or("")),
                                message: format!("output `{}` differs when rebuilt from the cache", o.name),
                            });
                        }
                    }
                }
                Err(f) => {
                    return Err(Problem {
                        kind: "mismatch".into(),
                        signature: "rebuild-fails".into(),
                        message: format!("the rebuild from the cache failed: {}", f.diagnostics),
                    })
                }
            }
        }
    }
    Ok(ran)
}

/// The first diagnostic a case stops at (or `built`), for tuning the generators.
pub fn first_diagnostic(ws: &Workspace, case: &Case) -> String {
    let written = write_case(ws, &case.text, case);
    let mut project = tessera::project::Project::open(&ws.root).expect("workspace");
    project.progress = false;
    project.sets = case.sets.clone();
    let r = match std::panic::catch_unwind(AssertUnwindSafe(|| project.build(&ws.scene_path()))) {
        Ok(Ok(_)) => "built".to_string(),
        Ok(Err(f)) => f.diagnostics.items.first().map(|d| d.message.clone()).unwrap_or_default(),
        Err(_) => "PANIC".into(),
    };
    clean_case(ws, &written);
    r
}

/// Set by the harness's own tests: a scene holding `# selftest: KIND` then misbehaves
/// that way, so the tests can check each kind of failure is caught and classified.
pub const SELFTEST_ENV: &str = "TESSERA_FUZZ_SELFTEST";

#[inline(never)]
fn recurse(n: u64) -> u64 {
    let pad = std::hint::black_box([n; 64]);
    if n == 0 {
        0
    } else {
        recurse(n - 1) + pad[3]
    }
}

fn selftest(text: &str) {
    let Some(kind) = text.split("# selftest: ").nth(1).and_then(|t| t.split_whitespace().next()) else { return };
    match kind {
        "panic" => panic!("selftest panic"),
        "abort" => std::process::abort(),
        "loop" => loop {
            std::hint::black_box(0u64);
        },
        "alloc" => {
            let v: Vec<u8> = Vec::with_capacity(1 << 40);
            std::hint::black_box(v);
        }
        "stack" => {
            std::hint::black_box(recurse(u64::MAX));
        }
        _ => {}
    }
}

/// Runs one case in-process; a panic anywhere (the pipeline or a rayon task) is a problem.
pub fn run_case(ws: &Workspace, case: &Case, text: &str) -> Result<Ran, Problem> {
    *LAST_PANIC.lock().unwrap_or_else(|e| e.into_inner()) = None;
    let written = write_case(ws, text, case);
    let result = std::panic::catch_unwind(AssertUnwindSafe(|| pipeline(ws, case, text)));
    clean_case(ws, &written);
    match result {
        Ok(r) => r,
        Err(payload) => {
            let (message, loc) = LAST_PANIC.lock().unwrap_or_else(|e| e.into_inner()).take().unwrap_or_else(|| {
                let m = payload
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| payload.downcast_ref::<String>().cloned())
                    .unwrap_or_default();
                (m, "unknown".into())
            });
            Err(Problem { kind: "panic".into(), signature: format!("panic {loc}"), message })
        }
    }
}

/// Line-based delta debugging: the smallest text (by lines) that still fails `test`.
pub fn minimize(text: &str, budget: usize, mut test: impl FnMut(&str) -> bool) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let mut n = 2usize;
    let mut tries = 0;
    while lines.len() >= 2 && tries < budget {
        let chunk = lines.len().div_ceil(n);
        let mut reduced = false;
        let mut start = 0;
        while start < lines.len() && tries < budget {
            let end = (start + chunk).min(lines.len());
            let mut candidate = lines.clone();
            candidate.drain(start..end);
            tries += 1;
            if !candidate.is_empty() && test(&(candidate.join("\n") + "\n")) {
                lines = candidate;
                n = (n - 1).max(2);
                reduced = true;
                break;
            }
            start = end;
        }
        if !reduced {
            if n >= lines.len() {
                break;
            }
            n = (n * 2).min(lines.len());
        }
    }
    lines.join("\n") + "\n"
}

// ---------------------------------------------------------------------------------------
// Worker process

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct WorkerJob {
    pub seed: u64,
    pub stream: Stream,
    pub start: u64,
    pub end: u64,
    pub time_limit_s: f64,
    pub mem_limit_mb: u64,
    pub scratch: PathBuf,
    /// Replay a reproducer's `scenes` directory instead of generated cases.
    pub replay: Option<PathBuf>,
    /// Signatures already found: their cases are not minimised again.
    pub known: Vec<String>,
}

#[derive(Debug, Serialize, Deserialize)]
enum Msg {
    Start(CaseId),
    Done { id: CaseId, compiled: bool, built: bool, millis: f64 },
    Problem { id: CaseId, problem: Problem, minimized: String },
    Hang { id: CaseId, seconds: f64 },
    Finished,
}

fn send(m: &Msg) {
    let mut out = std::io::stdout().lock();
    let sent = writeln!(out, "{TAG}{}", serde_json::to_string(m).expect("message")).and_then(|_| out.flush());
    if sent.is_err() {
        // The parent is gone: nobody would hear of what this worker finds.
        std::process::exit(0);
    }
}

#[cfg(unix)]
pub fn limit_memory(mb: u64) {
    if mb == 0 {
        return;
    }
    let bytes = mb * 1024 * 1024;
    let lim = libc::rlimit { rlim_cur: bytes, rlim_max: bytes };
    // SAFETY: setrlimit reads the struct we pass and changes only this process's limits.
    unsafe {
        libc::setrlimit(libc::RLIMIT_AS, &lim);
    }
}

#[cfg(not(unix))]
fn limit_memory(_mb: u64) {}

/// A case's wall-clock time limit, as a multiple of its CPU time limit.
const WALL_FACTOR: f64 = 20.0;

#[derive(Clone, Copy)]
struct Started {
    wall: Instant,
    cpu: f64,
}

impl Started {
    fn now() -> Started {
        Started { wall: Instant::now(), cpu: cpu_seconds() }
    }
}

/// CPU time of this process (all threads), in seconds.
#[cfg(unix)]
fn cpu_seconds() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes only the struct we pass.
    unsafe {
        libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts);
    }
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

#[cfg(not(unix))]
fn cpu_seconds() -> f64 {
    0.0
}

/// The worker's main: runs when `WORKER_ENV` holds a job. Returns false when it does not.
pub fn worker_main() -> bool {
    let Ok(job) = std::env::var(WORKER_ENV) else { return false };
    let job: WorkerJob = serde_json::from_str(&job).expect("worker job");
    limit_memory(job.mem_limit_mb);
    install_panic_hook();
    let ws = Workspace::create(job.scratch.clone());
    let current: Arc<Mutex<Option<(CaseId, Started)>>> = Arc::new(Mutex::new(None));
    {
        let current = current.clone();
        let limit = job.time_limit_s;
        std::thread::spawn(move || loop {
            std::thread::sleep(Duration::from_millis(100));
            let c = *current.lock().unwrap_or_else(|e| e.into_inner());
            if let Some((id, t)) = c {
                // CPU time, so that a loaded machine does not make slow cases hangs; the
                // wall clock still catches a case that waits forever.
                let (cpu, wall) = (cpu_seconds() - t.cpu, t.wall.elapsed().as_secs_f64());
                if cpu > limit || wall > limit * WALL_FACTOR {
                    send(&Msg::Hang { id, seconds: cpu });
                    std::process::exit(124);
                }
            }
        });
    }
    let generator = Generator::new(job.seed);
    if let Some(dir) = &job.replay {
        // A reproducer directory: its scene and every file beside it.
        let text = std::fs::read_to_string(dir.join("scene.tess")).expect("reproducer scene");
        let mut files = Vec::new();
        collect_files(dir, dir, &mut files);
        let id = CaseId { stream: job.stream, index: job.start };
        let case = Case { id, what: "replay".into(), text: text.clone(), files, sets: vec![], build: true };
        *current.lock().unwrap_or_else(|e| e.into_inner()) = Some((id, Started::now()));
        send(&Msg::Start(id));
        match run_case(&ws, &case, &text) {
            Ok(ran) => send(&Msg::Done { id, compiled: ran.compiled, built: ran.built, millis: 0.0 }),
            Err(problem) => send(&Msg::Problem { id, problem, minimized: text.clone() }),
        }
        *current.lock().unwrap_or_else(|e| e.into_inner()) = None;
        send(&Msg::Finished);
        return true;
    }
    for index in job.start..job.end {
        let id = CaseId { stream: job.stream, index };
        let case = generator.case(id);
        let t = Instant::now();
        *current.lock().unwrap_or_else(|e| e.into_inner()) = Some((id, Started::now()));
        send(&Msg::Start(id));
        match run_case(&ws, &case, &case.text) {
            Ok(ran) => send(&Msg::Done {
                id,
                compiled: ran.compiled,
                built: ran.built,
                millis: t.elapsed().as_secs_f64() * 1000.0,
            }),
            Err(problem) => {
                // Minimise while the watchdog still guards us, each try a few seconds at most.
                let sig = problem.signature.clone();
                let budget = if job.known.contains(&sig) { 0 } else { 60 };
                let deadline = Instant::now() + Duration::from_secs(budget);
                let minimized = minimize(&case.text, 300, |candidate| {
                    if Instant::now() > deadline {
                        return false;
                    }
                    *current.lock().unwrap_or_else(|e| e.into_inner()) = Some((id, Started::now()));
                    matches!(run_case(&ws, &case, candidate), Err(p) if p.signature == sig)
                });
                send(&Msg::Problem { id, problem, minimized });
                // A caught panic may have poisoned process-wide state: start afresh.
                *current.lock().unwrap_or_else(|e| e.into_inner()) = None;
                return true;
            }
        }
    }
    *current.lock().unwrap_or_else(|e| e.into_inner()) = None;
    send(&Msg::Finished);
    true
}

// ---------------------------------------------------------------------------------------
// Parent

#[derive(Clone, Debug)]
pub struct Config {
    pub seed: u64,
    pub scenes: u64,
    pub files: u64,
    pub jobs: usize,
    pub time_limit_s: f64,
    pub mem_limit_mb: u64,
    pub findings: PathBuf,
    pub chunk: u64,
    /// Threads per worker (rayon).
    pub threads: usize,
    /// Print progress every this many seconds (0: never).
    pub progress_s: f64,
    /// Run one reproducer (its `scenes` directory) in a worker instead of generated cases.
    pub replay: Option<PathBuf>,
    /// Minimise the scenes of crashes and hangs too (a fresh worker per try: slow).
    pub minimize_crashes: bool,
}

#[derive(Debug, Serialize)]
pub struct FindingGroup {
    pub signature: String,
    pub kind: String,
    pub message: String,
    pub count: u64,
    pub cases: Vec<String>,
    pub reproducer: PathBuf,
}

#[derive(Debug, Default, Serialize)]
pub struct Summary {
    pub seed: u64,
    pub scenes_run: u64,
    pub files_run: u64,
    pub compiled: u64,
    pub built: u64,
    pub seconds: f64,
    pub findings: BTreeMap<String, FindingGroup>,
    /// The slowest cases, (millis, case).
    pub slowest: Vec<(f64, String)>,
}

impl Summary {
    pub fn cases_per_second(&self) -> f64 {
        (self.scenes_run + self.files_run) as f64 / self.seconds.max(1e-9)
    }

    pub fn report(&self) -> String {
        let mut s = format!(
            "seed {}: {} scenes, {} files in {:.1} s ({:.1} cases/s); {} compiled, {} built; {} finding group(s)\n",
            self.seed,
            self.scenes_run,
            self.files_run,
            self.seconds,
            self.cases_per_second(),
            self.compiled,
            self.built,
            self.findings.len()
        );
        for g in self.findings.values() {
            let first = g.message.lines().next().unwrap_or("");
            s.push_str(&format!(
                "  [{}] {} x{} ({}…): {first}\n    reproducer: {}\n",
                g.kind,
                g.signature,
                g.count,
                g.cases.iter().take(3).cloned().collect::<Vec<_>>().join(", "),
                g.reproducer.display()
            ));
        }
        s
    }
}

/// How to start a worker process: the parent adds the job in `WORKER_ENV`.
pub type Spawn = dyn Fn() -> Command + Sync;

struct Shared {
    summary: Mutex<Summary>,
    queue: Mutex<Vec<(Stream, u64, u64)>>,
    generator: Generator,
    config: Config,
}

pub fn drive(config: Config, spawn: &Spawn) -> Summary {
    std::fs::create_dir_all(&config.findings).expect("findings directory");
    let start = Instant::now();
    // Chunks of both streams, interleaved, so both advance together.
    let mut queue = Vec::new();
    let (mut s, mut f) = (0u64, 0u64);
    while s < config.scenes || f < config.files {
        if s < config.scenes {
            let e = (s + config.chunk).min(config.scenes);
            queue.push((Stream::Scene, s, e));
            s = e;
        }
        if f < config.files {
            let e = (f + config.chunk / 10 + 1).min(config.files);
            queue.push((Stream::File, f, e));
            f = e;
        }
    }
    if config.replay.is_some() {
        queue = vec![(Stream::Scene, 0, 1)];
    }
    queue.reverse();
    let shared = Shared {
        summary: Mutex::new(Summary { seed: config.seed, ..Default::default() }),
        queue: Mutex::new(queue),
        generator: Generator::new(config.seed),
        config: config.clone(),
    };
    let running = std::sync::atomic::AtomicUsize::new(config.jobs.max(1));
    std::thread::scope(|scope| {
        for slot in 0..config.jobs.max(1) {
            let shared = &shared;
            let running = &running;
            scope.spawn(move || {
                loop {
                    let next = shared.queue.lock().unwrap().pop();
                    let Some((stream, a, b)) = next else { break };
                    run_chunk(shared, spawn, slot, stream, a, b);
                }
                running.fetch_sub(1, Ordering::SeqCst);
            });
        }
        if config.progress_s > 0.0 {
            let shared = &shared;
            let running = &running;
            scope.spawn(move || {
                let mut last = Instant::now();
                while running.load(Ordering::SeqCst) > 0 {
                    std::thread::sleep(Duration::from_millis(200));
                    if last.elapsed().as_secs_f64() >= shared.config.progress_s {
                        last = Instant::now();
                        let mut s = shared.summary.lock().unwrap();
                        s.seconds = start.elapsed().as_secs_f64();
                        eprintln!(
                            "fuzz: {} scenes, {} files, {:.1} cases/s, {} finding group(s)",
                            s.scenes_run,
                            s.files_run,
                            s.cases_per_second(),
                            s.findings.len()
                        );
                        write_summary(&shared.config.findings, &s);
                    }
                }
            });
        }
    });
    let mut summary = shared.summary.into_inner().unwrap();
    summary.seconds = start.elapsed().as_secs_f64();
    write_summary(&config.findings, &summary);
    summary
}

fn write_summary(dir: &Path, s: &Summary) {
    let _ = std::fs::write(dir.join("summary.json"), serde_json::to_string_pretty(s).unwrap_or_default());
    let _ = std::fs::write(dir.join("summary.txt"), s.report());
}

/// A name for one chunk's scratch files, unique within the machine: campaigns running at
/// once in one process (the tests of one test binary) must not share a workspace.
fn run_tag() -> String {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    format!("{}-{}", std::process::id(), NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed))
}

fn run_chunk(shared: &Shared, spawn: &Spawn, slot: usize, stream: Stream, start: u64, end: u64) {
    let cfg = &shared.config;
    let mut next = start;
    let tag = run_tag();
    let scratch = std::env::temp_dir().join(format!("tessera-fuzz-{tag}-{slot}"));
    let stderr_path = std::env::temp_dir().join(format!("tessera-fuzz-{tag}-{slot}.stderr"));
    while next < end {
        let job = WorkerJob {
            seed: cfg.seed,
            stream,
            start: next,
            end,
            time_limit_s: cfg.time_limit_s,
            mem_limit_mb: cfg.mem_limit_mb,
            scratch: scratch.clone(),
            replay: cfg.replay.clone(),
            known: shared.summary.lock().unwrap().findings.keys().cloned().collect(),
        };
        let stderr = std::fs::File::create(&stderr_path).expect("stderr file");
        let mut child = spawn()
            .env(WORKER_ENV, serde_json::to_string(&job).unwrap())
            .env("RAYON_NUM_THREADS", cfg.threads.to_string())
            .env("RUST_BACKTRACE", "0")
            .stdout(Stdio::piped())
            .stderr(stderr)
            .spawn()
            .expect("worker starts");
        let out = child.stdout.take().unwrap();
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                if let Some(m) = line.find(TAG).map(|i| &line[i + TAG.len()..]) {
                    if let Ok(m) = serde_json::from_str::<Msg>(m) {
                        if tx.send(m).is_err() {
                            break;
                        }
                    }
                }
            }
        });
        let mut current: Option<CaseId> = None;
        let mut finished = false;
        let mut reported = false;
        // The worker's own watchdog fires at the time limit; this one is a backstop.
        let backstop = Duration::from_secs_f64(cfg.time_limit_s * WALL_FACTOR + 120.0);
        loop {
            match rx.recv_timeout(backstop) {
                Ok(Msg::Start(id)) => current = Some(id),
                Ok(Msg::Done { id, compiled, built, millis }) => {
                    let mut s = shared.summary.lock().unwrap();
                    match id.stream {
                        Stream::Scene => s.scenes_run += 1,
                        Stream::File => s.files_run += 1,
                    }
                    s.compiled += u64::from(compiled);
                    s.built += u64::from(built);
                    s.slowest.push((millis, id.to_string()));
                    if s.slowest.len() > 40 {
                        s.slowest.sort_by(|a, b| b.0.total_cmp(&a.0));
                        s.slowest.truncate(20);
                    }
                    next = id.index + 1;
                    current = None;
                }
                Ok(Msg::Problem { id, problem, minimized }) => {
                    record(shared, id, problem, &minimized);
                    count(shared, id);
                    next = id.index + 1;
                    reported = true;
                    current = None;
                }
                Ok(Msg::Hang { id, seconds }) => {
                    let problem = Problem {
                        kind: "hang".into(),
                        signature: "hang".into(),
                        message: format!(
                            "the case ran past the limit of {:.0} s of CPU time ({seconds:.1} s) or {:.0} s of wall-clock time",
                            cfg.time_limit_s,
                            cfg.time_limit_s * WALL_FACTOR
                        ),
                    };
                    let text = minimize_crash(shared, spawn, slot, id, &problem.signature);
                    record(shared, id, problem, &text);
                    count(shared, id);
                    next = id.index + 1;
                    reported = true;
                    current = None;
                }
                Ok(Msg::Finished) => {
                    finished = true;
                }
                Err(mpsc::RecvTimeoutError::Timeout) => {
                    let _ = child.kill();
                }
                Err(mpsc::RecvTimeoutError::Disconnected) => break,
            }
        }
        let status = child.wait().expect("worker exit");
        if finished {
            break;
        }
        if let Some(id) = current {
            // The worker died inside a case: an abort, a signal, the backstop.
            let tail = std::fs::read_to_string(&stderr_path).unwrap_or_default();
            let tail: String =
                tail.lines().rev().take(12).collect::<Vec<_>>().into_iter().rev().collect::<Vec<_>>().join("\n");
            let (kind, signature) = classify(&tail, &status);
            let problem = Problem { kind, signature, message: format!("{status}\n{tail}") };
            let text = minimize_crash(shared, spawn, slot, id, &problem.signature);
            record(shared, id, problem, &text);
            count(shared, id);
            next = id.index + 1;
        } else if !reported && next < end {
            // Died between cases (should not happen): skip ahead rather than loop.
            let problem = Problem {
                kind: "crash".into(),
                signature: format!("worker died between cases ({status})"),
                message: std::fs::read_to_string(&stderr_path).unwrap_or_default(),
            };
            record(shared, CaseId { stream, index: next }, problem, "");
            next += 1;
        }
    }
    let _ = std::fs::remove_dir_all(&scratch);
    let _ = std::fs::remove_file(&stderr_path);
}

/// The smallest scene (by lines) that still kills a worker the same way, found by running
/// each candidate in a fresh worker; only for the first case of a signature.
fn minimize_crash(shared: &Shared, spawn: &Spawn, slot: usize, id: CaseId, signature: &str) -> String {
    let case = shared.generator.case(id);
    let skip = !shared.config.minimize_crashes || shared.config.replay.is_some();
    if skip || shared.summary.lock().unwrap().findings.contains_key(signature) {
        return case.text;
    }
    let limit = shared.config.time_limit_s.min(10.0);
    let deadline = Instant::now() + Duration::from_secs(180);
    let tag = run_tag();
    let dir = std::env::temp_dir().join(format!("tessera-fuzz-{tag}-{slot}-probe"));
    let scratch = std::env::temp_dir().join(format!("tessera-fuzz-{tag}-{slot}-probe-ws"));
    let stderr_path = std::env::temp_dir().join(format!("tessera-fuzz-{tag}-{slot}-probe.stderr"));
    let min = minimize(&case.text, 60, |candidate| {
        if Instant::now() > deadline {
            return false;
        }
        let _ = std::fs::remove_dir_all(&dir);
        for (name, bytes) in &case.files {
            let p = dir.join(name);
            let _ = std::fs::create_dir_all(p.parent().unwrap());
            let _ = std::fs::write(p, bytes);
        }
        let _ = std::fs::create_dir_all(&dir);
        let _ = std::fs::write(dir.join("scene.tess"), candidate);
        let job = WorkerJob {
            seed: shared.config.seed,
            stream: id.stream,
            start: id.index,
            end: id.index + 1,
            time_limit_s: limit,
            mem_limit_mb: shared.config.mem_limit_mb,
            scratch: scratch.clone(),
            replay: Some(dir.clone()),
            known: Vec::new(),
        };
        probe(spawn, &shared.config, &job, &stderr_path).as_deref() == Some(signature)
    });
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&scratch);
    let _ = std::fs::remove_file(&stderr_path);
    min
}

/// Runs one replay job; the signature of what went wrong, if anything did.
fn probe(spawn: &Spawn, cfg: &Config, job: &WorkerJob, stderr_path: &Path) -> Option<String> {
    let stderr = std::fs::File::create(stderr_path).ok()?;
    let mut child = spawn()
        .env(WORKER_ENV, serde_json::to_string(job).unwrap())
        .env("RAYON_NUM_THREADS", cfg.threads.to_string())
        .stdout(Stdio::piped())
        .stderr(stderr)
        .spawn()
        .ok()?;
    let out = child.stdout.take()?;
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            if let Some(m) =
                line.find(TAG).map(|i| &line[i + TAG.len()..]).and_then(|m| serde_json::from_str::<Msg>(m).ok())
            {
                if tx.send(m).is_err() {
                    break;
                }
            }
        }
    });
    let mut started = false;
    let mut found = None;
    loop {
        match rx.recv_timeout(Duration::from_secs_f64(job.time_limit_s * WALL_FACTOR + 60.0)) {
            Ok(Msg::Start(_)) => started = true,
            Ok(Msg::Problem { problem, .. }) => found = Some(problem.signature),
            Ok(Msg::Hang { .. }) => found = Some("hang".to_string()),
            Ok(Msg::Done { .. }) => started = false,
            Ok(Msg::Finished) => {}
            Err(mpsc::RecvTimeoutError::Timeout) => {
                let _ = child.kill();
            }
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
        }
    }
    let status = child.wait().ok()?;
    if found.is_none() && started {
        let tail = std::fs::read_to_string(stderr_path).unwrap_or_default();
        found = Some(classify(&tail, &status).1);
    }
    found
}

fn collect_files(root: &Path, dir: &Path, out: &mut Vec<(String, Vec<u8>)>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            collect_files(root, &p, out);
        } else if p.file_name().is_some_and(|n| n != "scene.tess") {
            if let (Ok(rel), Ok(bytes)) = (p.strip_prefix(root), std::fs::read(&p)) {
                out.push((rel.to_string_lossy().into_owned(), bytes));
            }
        }
    }
}

fn count(shared: &Shared, id: CaseId) {
    let mut s = shared.summary.lock().unwrap();
    match id.stream {
        Stream::Scene => s.scenes_run += 1,
        Stream::File => s.files_run += 1,
    }
}

fn classify(tail: &str, status: &std::process::ExitStatus) -> (String, String) {
    if let Some(i) = tail.find(ALLOC_FAIL) {
        // The innermost tessera frame the allocator's hook printed names the place.
        let frame = tail[i..]
            .lines()
            .skip(1)
            .find(|l| l.contains("tessera::"))
            .unwrap_or("")
            .trim()
            .trim_end_matches("::{{closure}}");
        ("alloc".into(), format!("allocation past the budget in {frame}"))
    } else if tail.contains("memory allocation of") {
        ("alloc".into(), "allocation past the address-space budget".into())
    } else if tail.contains("has overflowed its stack") {
        ("stack-overflow".into(), "stack overflow".into())
    } else if tail.contains("capacity overflow") {
        ("alloc".into(), "capacity overflow (abort)".into())
    } else {
        #[cfg(unix)]
        {
            use std::os::unix::process::ExitStatusExt;
            if let Some(sig) = status.signal() {
                return ("crash".into(), format!("killed by signal {sig}"));
            }
        }
        ("crash".into(), format!("worker exited: {status}"))
    }
}

const ALLOC_FAIL: &str = "@@FUZZ-ALLOC-FAILED";

/// The system allocator, printing where an allocation failed before Rust aborts (the
/// allocation error hook is unstable), so allocations past the budget are told apart.
pub struct Allocator;

thread_local! {
    static IN_HOOK: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

fn allocation_failed(size: usize) {
    if IN_HOOK.with(|h| h.replace(true)) {
        return;
    }
    let bt = std::backtrace::Backtrace::force_capture().to_string();
    let frames: Vec<&str> = bt
        .lines()
        .map(str::trim)
        .filter_map(|l| l.split_once(": ").filter(|(n, _)| n.chars().all(|c| c.is_ascii_digit())))
        .map(|(_, f)| f)
        .filter(|f| f.contains("tessera::") && !f.contains("fuzzgen"))
        .take(8)
        .collect();
    eprintln!("{ALLOC_FAIL} {size} bytes\n{}", frames.join("\n"));
    IN_HOOK.with(|h| h.set(false));
}

// SAFETY: every call forwards to the system allocator with the same arguments; the hook
// only runs after a failed allocation and before the caller sees the null pointer.
unsafe impl std::alloc::GlobalAlloc for Allocator {
    unsafe fn alloc(&self, layout: std::alloc::Layout) -> *mut u8 {
        let p = unsafe { std::alloc::System.alloc(layout) };
        if p.is_null() {
            allocation_failed(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: std::alloc::Layout) -> *mut u8 {
        let p = unsafe { std::alloc::System.alloc_zeroed(layout) };
        if p.is_null() {
            allocation_failed(layout.size());
        }
        p
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: std::alloc::Layout, new_size: usize) -> *mut u8 {
        let p = unsafe { std::alloc::System.realloc(ptr, layout, new_size) };
        if p.is_null() {
            allocation_failed(new_size);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: std::alloc::Layout) {
        unsafe { std::alloc::System.dealloc(ptr, layout) }
    }
}

fn slug(s: &str) -> String {
    let mut out: String = s.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '_' }).collect();
    out.truncate(80);
    out
}

/// Adds a finding to its group; the first case of a group gets a reproducer directory: a
/// project whose `scenes/scene.tess` is the minimised scene (the original beside it) with
/// every input file the case had.
fn record(shared: &Shared, id: CaseId, problem: Problem, minimized: &str) {
    let cfg = &shared.config;
    let mut s = shared.summary.lock().unwrap();
    let key = problem.signature.clone();
    if let Some(g) = s.findings.get_mut(&key) {
        g.count += 1;
        if g.cases.len() < 20 {
            g.cases.push(id.to_string());
        }
        return;
    }
    if let Some(dir) = &cfg.replay {
        s.findings.insert(
            key.clone(),
            FindingGroup {
                signature: key,
                kind: problem.kind,
                message: problem.message,
                count: 1,
                cases: vec!["replay".into()],
                reproducer: dir.clone(),
            },
        );
        return;
    }
    let dir = cfg.findings.join(format!("{}-{}", slug(&key), id));
    let case = shared.generator.case(id);
    let scenes = dir.join("scenes");
    let _ = std::fs::create_dir_all(&scenes);
    populate(&scenes);
    for (name, bytes) in &case.files {
        let p = scenes.join(name);
        let _ = std::fs::create_dir_all(p.parent().unwrap());
        let _ = std::fs::write(p, bytes);
    }
    #[cfg(unix)]
    let _ = std::os::unix::fs::symlink(Path::new(env!("CARGO_MANIFEST_DIR")).join("samples"), dir.join("samples"));
    let _ = std::fs::write(scenes.join("scene.tess"), if minimized.is_empty() { &case.text } else { minimized });
    let _ = std::fs::write(scenes.join("scene.orig.tess.txt"), &case.text);
    let sets: Vec<String> = case.sets.iter().map(|(k, v)| format!("--set {k}={v}")).collect();
    let readme = format!(
        "{} ({}) in case {id} (seed {}): {}\n\n{}\n\nreproduce: cd {} && tessera build scenes/scene.tess {}\n",
        problem.kind,
        problem.signature,
        cfg.seed,
        case.what,
        problem.message,
        dir.display(),
        sets.join(" ")
    );
    let _ = std::fs::write(dir.join("README.txt"), readme);
    s.findings.insert(
        key.clone(),
        FindingGroup {
            signature: key,
            kind: problem.kind,
            message: problem.message,
            count: 1,
            cases: vec![id.to_string()],
            reproducer: dir,
        },
    );
}
