//! Helpers shared by the integration tests: a scratch project and the `tessera` binary.
#![allow(dead_code)]

pub mod nginx;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A temporary scene repository with a `tessera.toml` and the given files.
pub struct Project {
    pub dir: tempfile::TempDir,
}

impl Project {
    pub fn new(files: &[(&str, &str)]) -> Self {
        let dir = tempfile::tempdir().expect("tempdir");
        std::fs::write(dir.path().join("tessera.toml"), "[paths]\nscenes = \".\"\n").expect("manifest");
        let p = Project { dir };
        for (name, text) in files {
            p.write(name, text);
        }
        p
    }

    /// A copy of this repository's scenes, samples and goldens.
    pub fn copy_of_repo() -> Self {
        let dir = tempfile::tempdir().expect("tempdir");
        for sub in ["scenes", "samples", "golden"] {
            copy_dir(&repo().join(sub), &dir.path().join(sub));
        }
        std::fs::copy(repo().join("tessera.toml"), dir.path().join("tessera.toml")).expect("manifest");
        Project { dir }
    }

    pub fn path(&self, rel: &str) -> PathBuf {
        self.dir.path().join(rel)
    }

    pub fn write(&self, rel: &str, text: &str) {
        let p = self.path(rel);
        std::fs::create_dir_all(p.parent().expect("parent")).expect("mkdir");
        std::fs::write(p, text).expect("write");
    }

    pub fn write_bytes(&self, rel: &str, bytes: &[u8]) {
        let p = self.path(rel);
        std::fs::create_dir_all(p.parent().expect("parent")).expect("mkdir");
        std::fs::write(p, bytes).expect("write");
    }

    pub fn read_text(&self, rel: &str) -> String {
        String::from_utf8(self.read(rel)).expect("utf-8")
    }

    pub fn read(&self, rel: &str) -> Vec<u8> {
        std::fs::read(self.path(rel)).unwrap_or_else(|e| panic!("read {rel}: {e}"))
    }

    pub fn tessera(&self, args: &[&str]) -> Run {
        run_in(self.dir.path(), args)
    }

    /// Builds with a JSON stage report and returns the report's stages of the first scene.
    pub fn build_report(&self, args: &[&str]) -> (Run, Vec<Stage>) {
        let report = self.path("report.json");
        let mut all: Vec<&str> = vec!["build", "--report", report.to_str().expect("utf-8 path")];
        all.extend_from_slice(args);
        let run = self.tessera(&all);
        let stages =
            if report.exists() { parse_report(&std::fs::read_to_string(&report).expect("report")) } else { vec![] };
        let _ = std::fs::remove_file(&report);
        (run, stages)
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Stage {
    pub label: String,
    pub kind: String,
    pub status: String,
}

impl Project {
    /// Builds `scene.tess`, which must fail with `message` (whitespace-flattened) labelled on
    /// `snippet`, writing nothing; returns stderr.
    #[track_caller]
    pub fn refuses(&self, message: &str, snippet: &str) -> String {
        let run = self.tessera(&["build", "scene.tess"]);
        run.failed();
        let err = run.stderr();
        assert!(flat(&err).contains(message), "expected `{message}` in:\n{err}");
        assert!(err.contains(snippet), "expected the label on `{snippet}`:\n{err}");
        assert!(!self.path("out/scene").exists(), "nothing is written");
        err
    }
}

pub fn parse_report(json: &str) -> Vec<Stage> {
    let v: serde_json::Value = serde_json::from_str(json).expect("report is JSON");
    v["scenes"]
        .as_array()
        .expect("scenes")
        .iter()
        .flat_map(|s| s["stages"].as_array().expect("stages").clone())
        .map(|s| Stage {
            label: s["label"].as_str().expect("label").into(),
            kind: s["kind"].as_str().expect("kind").into(),
            status: s["status"].as_str().expect("status").into(),
        })
        .collect()
}

pub fn ran(stages: &[Stage]) -> Vec<String> {
    let mut v: Vec<String> =
        stages.iter().filter(|s| s.status == "ran" || s.status == "rebuilt").map(|s| s.label.clone()).collect();
    v.sort();
    v
}

pub struct Run {
    pub out: Output,
}

impl Run {
    pub fn code(&self) -> i32 {
        self.out.status.code().unwrap_or(-1)
    }
    pub fn stdout(&self) -> String {
        String::from_utf8_lossy(&self.out.stdout).into_owned()
    }
    pub fn stderr(&self) -> String {
        String::from_utf8_lossy(&self.out.stderr).into_owned()
    }
    #[track_caller]
    pub fn ok(&self) -> &Self {
        assert_eq!(self.code(), 0, "tessera failed:\nstdout:\n{}\nstderr:\n{}", self.stdout(), self.stderr());
        self
    }
    /// Failed cleanly: exit code 1 and no panic.
    #[track_caller]
    pub fn failed(&self) -> &Self {
        assert_eq!(self.code(), 1, "expected exit 1:\nstdout:\n{}\nstderr:\n{}", self.stdout(), self.stderr());
        assert!(!self.stderr().contains("panicked"), "panic:\n{}", self.stderr());
        self
    }
}

pub fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_tessera")
}

pub fn run_in(dir: &Path, args: &[&str]) -> Run {
    let out = Command::new(bin())
        .args(args)
        .current_dir(dir)
        .env("NO_COLOR", "1")
        .env_remove("RUST_BACKTRACE")
        .output()
        .expect("run tessera");
    Run { out }
}

/// Runs tessera in `dir`, killing it after `limit` (a hang fails the test instead of stalling
/// it); the run and how long it took.
pub fn run_within(dir: &Path, args: &[&str], limit: Duration) -> (Run, Duration) {
    let start = Instant::now();
    let mut child = Command::new(bin())
        .args(args)
        .current_dir(dir)
        .env("NO_COLOR", "1")
        .env_remove("RUST_BACKTRACE")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run tessera");
    while child.try_wait().expect("wait").is_none() {
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("tessera {args:?} ran past {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().expect("output");
    (Run { out }, start.elapsed())
}

/// Stderr with miette's wrapping undone: one line, single spaces, no gutter bars.
pub fn flat(text: &str) -> String {
    text.replace(['│', '\n'], " ").split_whitespace().collect::<Vec<_>>().join(" ")
}

pub fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("mkdir");
    for e in std::fs::read_dir(from).expect("read_dir") {
        let e = e.expect("entry");
        let target = to.join(e.file_name());
        if e.file_type().expect("type").is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), target).expect("copy");
        }
    }
}

/// Every file under `dir`, relative, with its bytes; for comparing two output trees.
pub fn tree(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    fn walk(base: &Path, d: &Path, out: &mut Vec<(PathBuf, Vec<u8>)>) {
        let Ok(rd) = std::fs::read_dir(d) else { return };
        for e in rd {
            let p = e.expect("entry").path();
            if p.is_dir() {
                walk(base, &p, out);
            } else {
                out.push((p.strip_prefix(base).expect("prefix").to_path_buf(), std::fs::read(&p).expect("read")));
            }
        }
    }
    walk(dir, dir, &mut out);
    out.sort();
    out
}

/// Builds `scene.tess` (plus extra files) in a fresh project, expecting a failure with nothing
/// written; returns what was printed on stderr.
pub fn failed_build(name: &str, scene: &str, extra: &[(&str, &[u8])]) -> String {
    let p = Project::new(&[("scene.tess", scene)]);
    for (rel, bytes) in extra {
        p.write_bytes(rel, bytes);
    }
    let run = p.tessera(&["build", "scene.tess"]);
    run.failed();
    assert!(!p.path("out").exists(), "{name}: a failed build wrote outputs");
    run.stderr()
}

/// Starts `tessera watch SCENE` in `p` and a reader of its stdout and stderr lines (in the
/// order they arrive, the two streams interleaved).
pub fn spawn_watch(p: &Project, scene: &str) -> (std::process::Child, std::sync::mpsc::Receiver<String>) {
    spawn_tessera(p, &["watch", scene])
}

/// `tessera ARGS` in `dir`, uncoloured, loopback servers reached directly, its stdout and
/// stderr piped: to spawn.
pub fn piped_tessera(dir: &Path, args: &[&str]) -> Command {
    let mut c = Command::new(bin());
    c.args(args)
        .current_dir(dir)
        .env("NO_COLOR", "1")
        .env("NO_PROXY", "127.0.0.1,localhost")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    c
}

/// Starts `tessera ARGS` in `p` and a reader of its stdout and stderr lines, interleaved.
pub fn spawn_tessera(p: &Project, args: &[&str]) -> (std::process::Child, std::sync::mpsc::Receiver<String>) {
    use std::io::{BufRead, BufReader};
    let mut child = piped_tessera(p.dir.path(), args).spawn().expect("spawn tessera");
    let (tx, rx) = std::sync::mpsc::channel();
    let out = child.stdout.take().expect("stdout");
    let err = child.stderr.take().expect("stderr");
    let tx2 = tx.clone();
    std::thread::spawn(move || BufReader::new(out).lines().map_while(Result::ok).for_each(|l| drop(tx.send(l))));
    std::thread::spawn(move || BufReader::new(err).lines().map_while(Result::ok).for_each(|l| drop(tx2.send(l))));
    (child, rx)
}

/// Lines from `lines` up to and including the first that contains `needle`; a panic showing
/// what came when none does `within`.
pub fn lines_until(lines: &std::sync::mpsc::Receiver<String>, needle: &str, within: Duration) -> Vec<String> {
    let deadline = Instant::now() + within;
    let mut seen = Vec::new();
    while let Some(left) = deadline.checked_duration_since(Instant::now()) {
        let Ok(l) = lines.recv_timeout(left) else { break };
        let hit = l.contains(needle);
        seen.push(l);
        if hit {
            return seen;
        }
    }
    panic!("no line containing {needle:?} within {within:?}; saw:\n{}", seen.join("\n"))
}

/// A small seeded RGB texture with enough structure to quilt and to rank.
pub fn texture(w: usize, h: usize, seed: u32) -> tessera::raster::Image {
    tessera::raster::Image::from_fn(w, h, 3, |x, y, c| {
        let (x, y) = (x as f32, y as f32);
        let s = seed as f32;
        let v = 0.5
            + 0.25 * ((x * 0.31 + s).sin() * (y * 0.23 + 0.7 * s).cos())
            + 0.15 * ((x * 0.07 - y * 0.11 + s * 1.3).sin());
        (v + 0.05 * c as f32).clamp(0.0, 1.0)
    })
}

/// An image as 8-bit PNG bytes.
pub fn png(img: &tessera::raster::Image) -> Vec<u8> {
    tessera::raster::io::encode_png(img, 8).expect("encode")
}
