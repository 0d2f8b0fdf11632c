//! `tessera watch`: an edit rebuilds the output; a broken edit prints a diagnostic and keeps
//! the old output; the fix rebuilds. Prints the edit-to-output latency.

mod common;

use std::process::Child;
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use common::Project;

struct Watch {
    child: Child,
    lines: Receiver<String>,
}

impl Watch {
    fn start(p: &Project, scene: &str) -> Watch {
        let (child, rx) = common::spawn_watch(p, scene);
        Watch { child, lines: rx }
    }

    /// Lines until each needle has been seen (stdout and stderr interleave in any order).
    fn until_all(&self, needles: &[&str]) -> Vec<String> {
        let mut seen: Vec<String> = Vec::new();
        while !needles.iter().all(|n| seen.iter().any(|l| l.contains(n))) {
            let missing = needles.iter().find(|n| !seen.iter().any(|l| l.contains(*n))).expect("one missing");
            seen.extend(self.until(missing));
        }
        seen
    }

    /// Lines up to and including the first that contains `needle`.
    fn until(&self, needle: &str) -> Vec<String> {
        common::lines_until(&self.lines, needle, Duration::from_secs(20))
    }
}

impl Drop for Watch {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

const SCENE: &str = "map a {\n  from = constant(0.25)\n  size = 32 x 32\n}\n\noutput \"a.png\" { from = a }\n";

fn value(p: &Project) -> f32 {
    let img = tessera::raster::io::decode(&p.read("out/scene/a.png")).expect("decode");
    img.get(0, 0, 0)
}

/// Writes the scene and waits until the output file holds `want`; returns the latency.
/// A write is a truncation and then the data, so a rebuild may first see the empty file
/// (and build nothing); the next event rebuilds with the full text.
fn edit_and_wait(p: &Project, w: &Watch, text: &str, want: f32) -> Duration {
    // Filesystems with coarse timestamps need the edit to land in a new tick.
    std::thread::sleep(Duration::from_millis(20));
    let start = Instant::now();
    p.write("scene.tess", text);
    loop {
        w.until("[watch] built");
        if (value(p) - want).abs() < 0.003 {
            return start.elapsed();
        }
        assert!(start.elapsed() < Duration::from_secs(20), "output holds {}, want {want}", value(p));
    }
}

#[test]
fn edits_rebuild_broken_edits_keep_the_output_and_fixes_recover() {
    let p = Project::new(&[("scene.tess", SCENE)]);
    let w = Watch::start(&p, "scene.tess");
    w.until("[watch] built");
    assert!((value(&p) - 0.25).abs() < 0.003);

    let first = edit_and_wait(&p, &w, &SCENE.replace("0.25", "0.5"), 0.5);

    // A broken edit: a diagnostic, the old output stays.
    std::thread::sleep(Duration::from_millis(20));
    p.write("scene.tess", &SCENE.replace("constant(0.25)", "constnt(0.75)"));
    // (A rebuild may first see the truncated file and fail differently; wait for this one.)
    w.until_all(&["unknown constructor `constnt`", "build failed"]);
    assert!((value(&p) - 0.5).abs() < 0.003, "a failed rebuild changed the output");

    // The fix rebuilds.
    let fix = edit_and_wait(&p, &w, &SCENE.replace("0.25", "0.75"), 0.75);
    let again = edit_and_wait(&p, &w, &SCENE.replace("0.25", "1.0"), 1.0);
    eprintln!("watch edit-to-output latency: {first:?}, {fix:?}, {again:?}");
}

#[test]
fn watch_follows_input_files_read_by_the_build() {
    let scene = "map a {\n  from = image(\"in.png\")\n  size = 8 x 8\n}\noutput \"a.png\" { from = a }\n";
    let p = Project::new(&[("scene.tess", scene)]);
    let png = |v: f32| tessera::raster::io::encode_png(&tessera::raster::Image::filled(8, 8, 1, v), 8).expect("encode");
    p.write_bytes("in.png", &png(0.2));
    let w = Watch::start(&p, "scene.tess");
    w.until("[watch] built");
    std::thread::sleep(Duration::from_millis(20));
    p.write_bytes("in.png", &png(0.8));
    let lines = w.until("[watch] built").join("\n");
    assert!(lines.contains("map a"), "the image reader did not re-run: {lines}");
    assert!((value(&p) - 0.8).abs() < 0.003);
}

#[test]
fn watch_follows_files_added_to_a_library_directory() {
    let scene = r#"library lib { dir = "tex"  size = 8 }
sample q { image = "q.png" }
sample near { from = similar(lib, to = q, k = 1) }
output "near.json" { from = near }
"#;
    let p = Project::new(&[("scene.tess", scene)]);
    let png = |v: f32| tessera::raster::io::encode_png(&tessera::raster::Image::filled(8, 8, 3, v), 8).expect("encode");
    p.write_bytes("q.png", &png(0.8));
    p.write_bytes("tex/a.png", &png(0.2));
    let w = Watch::start(&p, "scene.tess");
    w.until("[watch] built");
    let nearest = || {
        let v: serde_json::Value = serde_json::from_slice(&p.read("out/scene/near.json")).expect("ranking");
        v["candidates"][0]["name"].as_str().unwrap_or_default().to_string()
    };
    assert_eq!(nearest(), "a.png");
    std::thread::sleep(Duration::from_millis(20));
    // A new file, nearer to the target, is seen without touching the scene.
    p.write_bytes("tex/b.png", &png(0.8));
    let deadline = Instant::now() + Duration::from_secs(20);
    while nearest() != "b.png" {
        w.until("[watch] built");
        assert!(Instant::now() < deadline, "the new library file was not picked up");
    }
}
