//! Edit-to-output latency of `tessera watch` on an example scene (target < 300 ms).
//!
//! Starts `tessera watch scenes/masks.tess`, then repeatedly edits an output-side property
//! (the `remap` range of `density`) and times from the write of the scene file to the
//! moment the output PNG on disk changes. Prints the median and the worst of 15 edits.

use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn main() {
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    for sub in ["scenes", "samples"] {
        let status = Command::new("cp").arg("-r").arg(repo.join(sub)).arg(dir.path()).status().unwrap();
        assert!(status.success());
    }
    std::fs::copy(repo.join("tessera.toml"), dir.path().join("tessera.toml")).unwrap();
    let scene = dir.path().join("scenes/masks.tess");
    let output = dir.path().join("out/masks/density.png");
    let original = std::fs::read_to_string(&scene).unwrap();

    let mut child = Command::new(env!("CARGO_BIN_EXE_tessera"))
        .args(["watch", "scenes/masks.tess", "-q"])
        .current_dir(dir.path())
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let wait_for = |pred: &dyn Fn() -> bool| {
        let deadline = Instant::now() + Duration::from_secs(30);
        while !pred() {
            assert!(Instant::now() < deadline, "timed out");
            std::thread::sleep(Duration::from_millis(1));
        }
    };
    wait_for(&|| output.exists());
    std::thread::sleep(Duration::from_millis(300));

    let mut samples = Vec::new();
    for i in 0..15 {
        let before = std::fs::read(&output).unwrap();
        let lo = 0.05 + 0.01 * i as f64;
        let text = original.replace("remap = [0.2, 1]", &format!("remap = [{lo:.2}, 1]"));
        let start = Instant::now();
        std::fs::write(&scene, text).unwrap();
        wait_for(&|| std::fs::read(&output).map(|b| b != before).unwrap_or(false));
        samples.push(start.elapsed());
        std::thread::sleep(Duration::from_millis(100));
    }
    let _ = child.kill();
    let _ = child.wait();
    samples.sort();
    println!(
        "watch edit-to-output latency over {} edits (masks.tess, remap of `density`): median {:.1} ms, worst {:.1} ms",
        samples.len(),
        samples[samples.len() / 2].as_secs_f64() * 1000.0,
        samples[samples.len() - 1].as_secs_f64() * 1000.0
    );
}
