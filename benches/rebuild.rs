//! No-op rebuild of each example scene: target < 50 ms.
//!
//! Two views: the library call a long-lived process makes (open the project, compile, key,
//! load the outputs' artifacts, compare with the files on disk), and the whole CLI process
//! as a user runs it (`tessera build scene -q`), process start-up included.

use std::path::PathBuf;
use std::process::Command;

#[path = "../tests/common/mod.rs"]
mod common;

use common::copy_dir;
use criterion::{criterion_group, criterion_main, Criterion};
use tessera::project::Project;

fn workspace() -> tempfile::TempDir {
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    for sub in ["scenes", "samples"] {
        copy_dir(&repo.join(sub), &dir.path().join(sub));
    }
    std::fs::copy(repo.join("tessera.toml"), dir.path().join("tessera.toml")).unwrap();
    dir
}

fn noop_rebuild(c: &mut Criterion) {
    let dir = workspace();
    let root = dir.path();
    let bin = env!("CARGO_BIN_EXE_tessera");
    let status = Command::new(bin).args(["build", "-q"]).current_dir(root).status().unwrap();
    assert!(status.success());
    let mut group = c.benchmark_group("noop_rebuild");
    group.sample_size(20);
    group.warm_up_time(std::time::Duration::from_millis(500));
    group.measurement_time(std::time::Duration::from_secs(2));
    let mut scenes: Vec<String> = std::fs::read_dir(root.join("scenes"))
        .unwrap()
        .filter_map(|e| {
            let name = e.unwrap().file_name().to_string_lossy().into_owned();
            (name.ends_with(".tess") && !name.starts_with('_')).then(|| name.trim_end_matches(".tess").to_string())
        })
        .collect();
    scenes.sort();
    for scene in &scenes {
        let path = PathBuf::from(format!("scenes/{scene}.tess"));
        group.bench_function(format!("{scene}/library"), |b| {
            b.iter(|| {
                let p = Project::open(root).unwrap();
                let built = p.build(&root.join(&path)).unwrap();
                assert_eq!(built.report.ran().count(), 0);
                let emitted = p.emit(&built).unwrap();
                assert!(emitted.iter().all(|e| !e.written));
            })
        });
        group.bench_function(format!("{scene}/cli"), |b| {
            b.iter(|| {
                let s = Command::new(bin).args(["build", "-q"]).arg(&path).current_dir(root).status().unwrap();
                assert!(s.success());
            })
        });
    }
    group.finish();
}

criterion_group!(benches, noop_rebuild);
criterion_main!(benches);
