//! A cold build of every example scene with a warm remote cache, against a cold build that
//! computes everything: nginx as a Bazel HTTP cache on loopback (`tests/common/nginx.rs`).
//! Each round builds a fresh copy of the repository with an empty local cache; the two kinds
//! of round alternate, so the shared machine's noise falls on both. Prints both medians and
//! their ratio.
//!
//! `cargo bench --bench remote_cache` (needs nginx: `apt-get install nginx-light`).

use std::process::Command;
use std::time::{Duration, Instant};

#[path = "../tests/common/mod.rs"]
mod common;

use common::nginx::Nginx;
use common::Project;

const ROUNDS: usize = 3;

fn build(p: &Project, remote: Option<&str>) -> Duration {
    let mut args = vec!["build", "-q"];
    match remote {
        Some(url) => args.extend(["--remote-cache", url]),
        None => args.push("--no-remote-cache"),
    }
    let start = Instant::now();
    let out = Command::new(common::bin())
        .args(&args)
        .current_dir(p.dir.path())
        .env("NO_PROXY", "127.0.0.1,localhost")
        .output()
        .expect("tessera");
    let t = start.elapsed();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(!String::from_utf8_lossy(&out.stderr).contains("warning: remote cache"), "the remote failed");
    t
}

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

fn main() {
    if std::env::args().any(|a| a == "--list" || a == "--test") {
        return; // `cargo test --benches` runs this with `--test`: nothing to check quickly
    }
    let Some((server, _one)) = Nginx::start() else { return };
    let url = server.url("cache");
    // Fill the remote.
    build(&Project::copy_of_repo(), Some(&url));
    let (mut cold, mut warm) = (Vec::new(), Vec::new());
    for round in 0..ROUNDS {
        let c = build(&Project::copy_of_repo(), None);
        let w = build(&Project::copy_of_repo(), Some(&url));
        println!(
            "round {}: computing everything {:.2} s, from the remote {:.3} s",
            round + 1,
            c.as_secs_f64(),
            w.as_secs_f64()
        );
        cold.push(c);
        warm.push(w);
    }
    let (c, w) = (median(cold), median(warm));
    println!(
        "remote_cache/all scenes: cold, computing everything {:.2} s; cold, warm remote over loopback {:.3} s; {:.0}× faster",
        c.as_secs_f64(),
        w.as_secs_f64(),
        c.as_secs_f64() / w.as_secs_f64()
    );
}
