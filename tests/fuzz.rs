//! The bounded fuzz sample CI runs: a few thousand generated and mutated scenes and a few
//! hundred generated input files, deterministic by seed, through parse → resolve → plan →
//! build → emit in worker processes under an address-space limit and a per-case time
//! limit (`tests/fuzzgen`). The long campaign is `examples/fuzz.rs` (docs/fuzzing.md).

mod fuzzgen;

use std::path::PathBuf;
use std::process::Command;

use fuzzgen::runner::{self, Config};

#[global_allocator]
static ALLOCATOR: runner::Allocator = runner::Allocator;

/// Fail on any finding (a panic, an abort, a hang or an allocation past the budget). Turn it
/// off only to survey findings without failing.
const STRICT: bool = true;

const SEED: u64 = 10;
const SCENES: u64 = 3000;
const FILES: u64 = 300;

/// Not a test: the entry point of the worker processes the sample starts (a no-op unless
/// the parent set the job in the environment).
#[test]
fn fuzz_worker_entry() {
    runner::worker_main();
}

/// The harness itself: each way a case can go wrong becomes a finding of its kind.
#[test]
fn fuzz_harness_catches_every_kind_of_failure() {
    if std::env::var_os(runner::WORKER_ENV).is_some() {
        return;
    }
    let exe = std::env::current_exe().expect("test binary");
    let spawn = move || {
        let mut c = Command::new(&exe);
        c.args(["fuzz_worker_entry", "--exact", "--nocapture", "--test-threads=1"]).env(runner::SELFTEST_ENV, "1");
        c
    };
    let base = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz-selftest");
    for (kind, expected) in [
        ("panic", "panic"),
        ("abort", "crash"),
        ("loop", "hang"),
        ("alloc", "alloc"),
        ("stack", "stack-overflow"),
        ("none", ""),
    ] {
        let dir = base.join(kind);
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("scenes")).unwrap();
        std::fs::write(
            dir.join("scenes/scene.tess"),
            format!("# selftest: {kind}\nmap m {{\n  from = constant(1)\n}}\n"),
        )
        .unwrap();
        let config = Config {
            seed: 0,
            scenes: 1,
            files: 0,
            jobs: 1,
            time_limit_s: 1.0,
            mem_limit_mb: 1024,
            findings: dir.join("findings"),
            chunk: 1,
            threads: 1,
            progress_s: 0.0,
            replay: Some(dir.join("scenes")),
            minimize_crashes: false,
        };
        let summary = runner::drive(config, &spawn);
        let kinds: Vec<&str> = summary.findings.values().map(|g| g.kind.as_str()).collect();
        if expected.is_empty() {
            assert!(kinds.is_empty(), "{kind}: {}", summary.report());
        } else {
            assert_eq!(kinds, [expected], "{kind}: {}", summary.report());
        }
    }
}

#[test]
fn fuzz_sample() {
    if std::env::var_os(runner::WORKER_ENV).is_some() {
        return;
    }
    let findings = std::env::var_os("TESSERA_FUZZ_FINDINGS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz-findings"));
    let _ = std::fs::remove_dir_all(&findings);
    let config = Config {
        seed: SEED,
        scenes: SCENES,
        files: FILES,
        jobs: 2,
        time_limit_s: 10.0,
        mem_limit_mb: 3072,
        findings,
        chunk: 500,
        threads: 1,
        progress_s: 0.0,
        replay: None,
        minimize_crashes: false,
    };
    let exe = std::env::current_exe().expect("test binary");
    let spawn = move || {
        let mut c = Command::new(&exe);
        c.args(["fuzz_worker_entry", "--exact", "--nocapture", "--test-threads=1"]);
        c
    };
    let summary = runner::drive(config, &spawn);
    // Shown with `--nocapture`; the findings directory has the reproducers.
    eprintln!("{}", summary.report());
    assert_eq!(summary.scenes_run, SCENES, "every scene case ran");
    assert_eq!(summary.files_run, FILES, "every file case ran");
    // The generators must reach the stages, not only the error paths.
    assert!(summary.built > SCENES / 10, "only {} cases built", summary.built);
    if STRICT || std::env::var_os("TESSERA_FUZZ_STRICT").is_some() {
        assert!(summary.findings.is_empty(), "fuzz findings:\n{}", summary.report());
    }
}

/// For tuning the generators: the first diagnostic clean generated scenes stop at, most common
/// first (`cargo test --release --test fuzz -- --ignored survey --nocapture`).
#[test]
#[ignore]
fn survey_clean_scene_stops() {
    if std::env::var_os(runner::WORKER_ENV).is_some() {
        return;
    }
    let gen = runner::Generator::new(SEED);
    let ws = runner::Workspace::create(PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz-survey"));
    let mut tally = std::collections::BTreeMap::<String, u32>::new();
    for index in 0..600 {
        let case = gen.case(runner::CaseId { stream: runner::Stream::Scene, index });
        if case.what != "generated scene (clean)" {
            continue;
        }
        *tally.entry(runner::first_diagnostic(&ws, &case)).or_default() += 1;
    }
    let mut rows: Vec<_> = tally.into_iter().collect();
    rows.sort_by_key(|r| std::cmp::Reverse(r.1));
    for (message, n) in rows {
        eprintln!("{n:5}  {message}");
    }
}
