//! The long fuzz campaign (docs/fuzzing.md):
//!
//! ```text
//! nice -n 19 cargo run --release --example fuzz -- --scenes 1000000 --files 100000 \
//!     --findings /tmp/fuzz-findings
//! ```
//!
//! Cases run in worker processes (this binary again) under an address-space limit and a
//! per-case time limit; findings go to the findings directory, each with a reproducer.

#[path = "../tests/fuzzgen/mod.rs"]
mod fuzzgen;

use std::path::PathBuf;
use std::process::{Command, ExitCode};

use fuzzgen::runner::{self, Config};

#[global_allocator]
static ALLOCATOR: runner::Allocator = runner::Allocator;

const USAGE: &str = "usage: fuzz [--seed N] [--scenes N] [--files N] [--jobs N] [--threads N] \
[--time-limit SECONDS] [--max-memory MB] [--findings DIR] [--chunk N]\n       fuzz --replay DIR   (run a reproducer under the same limits)\n       fuzz --case scene-N|file-N [--seed N]   (print a case's scene text)";

fn main() -> ExitCode {
    if runner::worker_main() {
        return ExitCode::SUCCESS;
    }
    let mut config = Config {
        seed: 1,
        scenes: 10_000,
        files: 1_000,
        jobs: 2,
        time_limit_s: 30.0,
        mem_limit_mb: 3072,
        findings: std::env::temp_dir().join("tessera-fuzz-findings"),
        chunk: 2000,
        threads: 1,
        progress_s: 30.0,
        replay: None,
        minimize_crashes: true,
    };
    let mut show: Option<String> = None;
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < args.len() {
        let value = args.get(i + 1).cloned().unwrap_or_default();
        let num = || value.replace('_', "").parse::<u64>().ok();
        match args[i].as_str() {
            "--seed" => config.seed = num().expect("--seed N"),
            "--scenes" => config.scenes = num().expect("--scenes N"),
            "--files" => config.files = num().expect("--files N"),
            "--jobs" => config.jobs = num().expect("--jobs N") as usize,
            "--threads" => config.threads = num().expect("--threads N") as usize,
            "--chunk" => config.chunk = num().expect("--chunk N").max(1),
            "--time-limit" => config.time_limit_s = value.parse().expect("--time-limit SECONDS"),
            "--max-memory" => config.mem_limit_mb = num().expect("--max-memory MB"),
            "--findings" => config.findings = PathBuf::from(&value),
            "--case" => show = Some(value.clone()),
            "--replay" => {
                // A reproducer directory (or its `scenes` directory).
                let dir = PathBuf::from(&value);
                config.replay = Some(if dir.join("scenes").is_dir() { dir.join("scenes") } else { dir });
                config.jobs = 1;
            }
            "--diagnose" => {
                // Tally where the first N scene and file cases stop, in-process.
                let n = num().expect("--diagnose N");
                runner::limit_memory(3072);
                runner::install_panic_hook();
                let g = runner::Generator::new(config.seed);
                let ws = runner::Workspace::create(std::env::temp_dir().join("tessera-fuzz-diagnose"));
                let mut tally = std::collections::BTreeMap::<String, usize>::new();
                for stream in [runner::Stream::Scene, runner::Stream::File] {
                    for index in 0..n {
                        let case = g.case(runner::CaseId { stream, index });
                        let d = runner::first_diagnostic(&ws, &case);
                        let d: String = d.chars().map(|c| if c.is_ascii_digit() { '#' } else { c }).take(70).collect();
                        let w: String = case.what.chars().take(24).collect();
                        *tally.entry(format!("{stream:?} {w:24} {d}")).or_default() += 1;
                    }
                }
                let mut v: Vec<_> = tally.into_iter().collect();
                v.sort_by_key(|b| std::cmp::Reverse(b.1));
                for (d, n) in v.iter().take(60) {
                    println!("{n:6} {d}");
                }
                return ExitCode::SUCCESS;
            }
            _ => {
                eprintln!("{USAGE}");
                return ExitCode::FAILURE;
            }
        }
        i += 2;
    }
    if let Some(name) = show {
        let (stream, index) = match name.split_once('-') {
            Some(("scene", n)) => (runner::Stream::Scene, n.parse().expect("index")),
            Some(("file", n)) => (runner::Stream::File, n.parse().expect("index")),
            _ => {
                eprintln!("{USAGE}");
                return ExitCode::FAILURE;
            }
        };
        let case = runner::Generator::new(config.seed).case(runner::CaseId { stream, index });
        println!("# {}\n{}", case.what, case.text);
        return ExitCode::SUCCESS;
    }
    let exe = std::env::current_exe().expect("own executable");
    let spawn = move || Command::new(&exe);
    eprintln!(
        "fuzz: seed {}, {} scenes, {} files, {} job(s), {} s and {} MB per case; findings in {}",
        config.seed,
        config.scenes,
        config.files,
        config.jobs,
        config.time_limit_s,
        config.mem_limit_mb,
        config.findings.display()
    );
    let summary = runner::drive(config, &spawn);
    println!("{}", summary.report());
    if summary.findings.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
