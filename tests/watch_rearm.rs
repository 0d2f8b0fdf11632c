//! `tessera watch` keeps hearing after the directories it relies on are removed, replaced or
//! renamed (as `git checkout` does), and after a build that failed because a file or its
//! directory did not exist yet: once the files are back, it rebuilds. Each test prints the
//! time from the files' return to the new output (run with `--nocapture` to see them).

mod common;

use std::process::Child;
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use common::Project;

/// Generous: the machine may be shared and loaded; a deaf watch fails after this.
const PATIENCE: Duration = Duration::from_secs(60);

struct Watch {
    child: Child,
    lines: Receiver<String>,
    /// Everything read so far, for failure messages.
    log: std::cell::RefCell<Vec<String>>,
}

impl Watch {
    fn start(p: &Project, scene: &str) -> Watch {
        let (child, rx) = common::spawn_watch(p, scene);
        Watch { child, lines: rx, log: Default::default() }
    }

    /// The next line, or `None` once `deadline` has passed.
    fn next(&self, deadline: Instant) -> Option<String> {
        let left = deadline.checked_duration_since(Instant::now())?;
        let l = self.lines.recv_timeout(left).ok()?;
        self.log.borrow_mut().push(l.clone());
        Some(l)
    }

    fn fail(&self, what: &str) -> ! {
        panic!("{what} within {PATIENCE:?}; watch said:\n{}", self.log.borrow().join("\n"));
    }

    /// Reads lines up to the first containing `needle`.
    fn until(&self, needle: &str) {
        let deadline = Instant::now() + PATIENCE;
        while let Some(l) = self.next(deadline) {
            if l.contains(needle) {
                return;
            }
        }
        self.fail(&format!("no line containing {needle:?}"))
    }

    /// Reads lines until a build has written `want` into `output`; returns the time taken.
    fn until_value(&self, p: &Project, output: &str, want: f32) -> Duration {
        let start = Instant::now();
        let deadline = start + PATIENCE;
        while let Some(l) = self.next(deadline) {
            if l.contains("[watch] built") && value(p, output).is_some_and(|v| (v - want).abs() < 0.003) {
                return start.elapsed();
            }
        }
        self.fail(&format!("`{output}` never held {want} (it holds {:?})", value(p, output)))
    }
}

impl Drop for Watch {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn value(p: &Project, output: &str) -> Option<f32> {
    let bytes = std::fs::read(p.path(output)).ok()?;
    Some(tessera::raster::io::decode(&bytes).ok()?.get(0, 0, 0))
}

fn png(v: f32) -> Vec<u8> {
    tessera::raster::io::encode_png(&tessera::raster::Image::filled(8, 8, 1, v), 8).expect("encode")
}

/// A scene whose output copies the image `samples/in.png`.
const READS_SAMPLE: &str =
    "map a {\n  from = image(\"samples/in.png\")\n  size = 8 x 8\n}\noutput \"a.png\" { from = a }\n";

fn constant_scene(v: f32) -> String {
    format!("map a {{\n  from = constant({v})\n  size = 8 x 8\n}}\n\noutput \"a.png\" {{ from = a }}\n")
}

fn report(what: &str, took: Duration) {
    eprintln!("watch re-arm latency, {what}: {:.0} ms", took.as_secs_f64() * 1000.0);
}

#[test]
fn a_removed_input_directory_that_comes_back_rebuilds() {
    let p = Project::new(&[("scene.tess", READS_SAMPLE)]);
    p.write_bytes("samples/in.png", &png(0.2));
    let w = Watch::start(&p, "scene.tess");
    w.until_value(&p, "out/scene/a.png", 0.2);

    // Removed: the rebuild fails and keeps the output.
    std::fs::remove_dir_all(p.path("samples")).expect("rm -rf");
    w.until("build failed");
    assert_eq!(value(&p, "out/scene/a.png"), Some(0.2));

    // Back, with new content: rebuilt. Twice, so the second removal is heard as well.
    for (round, v) in [0.6f32, 0.4].into_iter().enumerate() {
        let start = Instant::now();
        p.write_bytes("samples/in.png", &png(v));
        w.until_value(&p, "out/scene/a.png", v);
        report(&format!("directory recreated (round {})", round + 1), start.elapsed());
        if round == 0 {
            std::fs::remove_dir_all(p.path("samples")).expect("rm -rf");
            w.until("build failed");
        }
    }
    // And the new directory is followed for ordinary edits.
    p.write_bytes("samples/in.png", &png(0.9));
    w.until_value(&p, "out/scene/a.png", 0.9);
}

#[test]
fn a_directory_replaced_at_once_as_git_checkout_does_rebuilds() {
    let p = Project::new(&[("scene.tess", READS_SAMPLE)]);
    p.write_bytes("samples/in.png", &png(0.2));
    let w = Watch::start(&p, "scene.tess");
    w.until_value(&p, "out/scene/a.png", 0.2);
    for (round, v) in [0.6f32, 0.3, 0.8].into_iter().enumerate() {
        // `rm -rf samples && git checkout samples`: no pause between removal and return.
        let start = Instant::now();
        std::fs::remove_dir_all(p.path("samples")).expect("rm -rf");
        p.write_bytes("samples/in.png", &png(v));
        let took = w.until_value(&p, "out/scene/a.png", v);
        report(&format!("rm -rf + recreate (round {})", round + 1), start.elapsed().max(took));
    }
}

#[test]
fn a_directory_moved_aside_and_replaced_by_a_new_one_rebuilds_and_stays_followed() {
    let p = Project::new(&[("scene.tess", READS_SAMPLE)]);
    p.write_bytes("samples/in.png", &png(0.2));
    let w = Watch::start(&p, "scene.tess");
    w.until_value(&p, "out/scene/a.png", 0.2);

    // `mv samples samples.old && mkdir samples && cp ...`
    let start = Instant::now();
    std::fs::rename(p.path("samples"), p.path("samples.old")).expect("mv");
    std::fs::create_dir(p.path("samples")).expect("mkdir");
    std::fs::write(p.path("samples/in.png"), png(0.7)).expect("cp");
    w.until_value(&p, "out/scene/a.png", 0.7);
    report("mv aside + mkdir + cp", start.elapsed());

    // The new directory is the one followed: an edit there rebuilds.
    p.write_bytes("samples/in.png", &png(0.35));
    w.until_value(&p, "out/scene/a.png", 0.35);
}

#[test]
fn a_directory_renamed_away_and_back_rebuilds_and_stays_followed() {
    let p = Project::new(&[("scene.tess", READS_SAMPLE)]);
    p.write_bytes("samples/in.png", &png(0.2));
    let w = Watch::start(&p, "scene.tess");
    w.until_value(&p, "out/scene/a.png", 0.2);

    std::fs::rename(p.path("samples"), p.path("elsewhere")).expect("mv away");
    w.until("build failed");
    // Edited while away, then brought back: the same directory (same inode) returns.
    std::fs::write(p.path("elsewhere/in.png"), png(0.65)).expect("edit");
    let start = Instant::now();
    std::fs::rename(p.path("elsewhere"), p.path("samples")).expect("mv back");
    w.until_value(&p, "out/scene/a.png", 0.65);
    report("directory renamed back", start.elapsed());

    // Away and back at once, before the watcher has seen either rename.
    std::fs::rename(p.path("samples"), p.path("elsewhere")).expect("mv away");
    std::fs::write(p.path("elsewhere/in.png"), png(0.15)).expect("edit");
    std::fs::rename(p.path("elsewhere"), p.path("samples")).expect("mv back");
    w.until_value(&p, "out/scene/a.png", 0.15);

    p.write_bytes("samples/in.png", &png(0.45));
    w.until_value(&p, "out/scene/a.png", 0.45);
}

#[test]
fn an_import_in_a_directory_that_does_not_exist_yet_rebuilds_once_created() {
    let scene = "import \"lib/deep/defs.tess\"\noutput \"a.png\" { from = shared }\n";
    let p = Project::new(&[("scene.tess", scene)]);
    let w = Watch::start(&p, "scene.tess");
    w.until("build failed");
    assert!(!p.path("out/scene/a.png").exists());

    // First the directories, one at a time, then the file: each step is followed.
    std::fs::create_dir(p.path("lib")).expect("mkdir lib");
    std::fs::create_dir(p.path("lib/deep")).expect("mkdir lib/deep");
    let start = Instant::now();
    std::fs::write(p.path("lib/deep/defs.tess"), "map shared { from = constant(0.5)  size = 4 x 4 }\n").expect("write");
    w.until_value(&p, "out/scene/a.png", 0.5);
    report("import created in a new directory", start.elapsed());

    // The import is followed from now on.
    p.write("lib/deep/defs.tess", "map shared { from = constant(0.25)  size = 4 x 4 }\n");
    w.until_value(&p, "out/scene/a.png", 0.25);
}

#[test]
fn an_import_created_with_its_directories_at_once_rebuilds() {
    let scene = "import \"a/b/c/defs.tess\"\noutput \"a.png\" { from = shared }\n";
    let p = Project::new(&[("scene.tess", scene)]);
    let w = Watch::start(&p, "scene.tess");
    w.until("build failed");
    // `mkdir -p a/b/c && cp`: the file may exist before any watch below `a` does.
    let start = Instant::now();
    p.write("a/b/c/defs.tess", "map shared { from = constant(0.75)  size = 4 x 4 }\n");
    w.until_value(&p, "out/scene/a.png", 0.75);
    report("mkdir -p + import", start.elapsed());
}

#[test]
fn the_scene_deleted_and_recreated_rebuilds() {
    let p = Project::new(&[("scene.tess", &constant_scene(0.25))]);
    let w = Watch::start(&p, "scene.tess");
    w.until_value(&p, "out/scene/a.png", 0.25);
    std::fs::remove_file(p.path("scene.tess")).expect("rm");
    w.until("build failed");
    let start = Instant::now();
    p.write("scene.tess", &constant_scene(0.5));
    w.until_value(&p, "out/scene/a.png", 0.5);
    report("scene recreated", start.elapsed());
    p.write("scene.tess", &constant_scene(0.75));
    w.until_value(&p, "out/scene/a.png", 0.75);
}

#[test]
fn the_scene_replaced_by_rename_as_editors_save_rebuilds_each_time() {
    let p = Project::new(&[("scene.tess", &constant_scene(0.25))]);
    let w = Watch::start(&p, "scene.tess");
    w.until_value(&p, "out/scene/a.png", 0.25);
    for v in [0.5f32, 0.75, 1.0] {
        p.write(".scene.tess.swp", &constant_scene(v));
        std::fs::rename(p.path(".scene.tess.swp"), p.path("scene.tess")).expect("rename over");
        w.until_value(&p, "out/scene/a.png", v);
    }
}

#[test]
fn the_scenes_own_directory_replaced_rebuilds() {
    let p = Project::new(&[("scenes/s.tess", &constant_scene(0.25))]);
    let w = Watch::start(&p, "scenes/s.tess");
    w.until_value(&p, "out/scenes/s/a.png", 0.25);
    for (round, v) in [0.5f32, 0.75].into_iter().enumerate() {
        let start = Instant::now();
        std::fs::remove_dir_all(p.path("scenes")).expect("rm -rf");
        p.write("scenes/s.tess", &constant_scene(v));
        w.until_value(&p, "out/scenes/s/a.png", v);
        report(&format!("scene directory replaced (round {})", round + 1), start.elapsed());
    }
    p.write("scenes/s.tess", &constant_scene(0.125));
    w.until_value(&p, "out/scenes/s/a.png", 0.125);
}

#[test]
fn a_library_directory_removed_and_recreated_is_followed_again() {
    let scene = r#"library lib { dir = "tex"  size = 8 }
sample q { image = "q.png" }
sample near { from = similar(lib, to = q, k = 1) }
output "near.json" { from = near }
"#;
    let p = Project::new(&[("scene.tess", scene)]);
    let rgb = |v: f32| tessera::raster::io::encode_png(&tessera::raster::Image::filled(8, 8, 3, v), 8).expect("encode");
    p.write_bytes("q.png", &rgb(0.8));
    p.write_bytes("tex/a.png", &rgb(0.2));
    let w = Watch::start(&p, "scene.tess");
    let nearest = || -> Option<String> {
        let v: serde_json::Value = serde_json::from_slice(&std::fs::read(p.path("out/scene/near.json")).ok()?).ok()?;
        v["candidates"][0]["name"].as_str().map(str::to_string)
    };
    let until_nearest = |want: &str| {
        let deadline = Instant::now() + PATIENCE;
        while nearest().as_deref() != Some(want) {
            match w.next(deadline) {
                Some(_) => {}
                None => w.fail(&format!("the nearest file never became {want}")),
            }
        }
    };
    until_nearest("a.png");
    std::fs::remove_dir_all(p.path("tex")).expect("rm -rf");
    let start = Instant::now();
    p.write_bytes("tex/a.png", &rgb(0.2));
    p.write_bytes("tex/b.png", &rgb(0.8));
    until_nearest("b.png");
    report("library directory recreated", start.elapsed());
    // Files added to the new directory count.
    p.write_bytes("tex/c.png", &rgb(0.81));
    std::fs::remove_file(p.path("tex/b.png")).expect("rm");
    until_nearest("c.png");
}

#[test]
fn a_steady_stream_of_unrelated_events_does_not_hold_back_a_rebuild() {
    let p = Project::new(&[("scene.tess", &constant_scene(0.25))]);
    let w = Watch::start(&p, "scene.tess");
    w.until_value(&p, "out/scene/a.png", 0.25);
    // Another program writing a log next to the scene, every 2 ms: each write is an event
    // in a watched directory, none about a followed file.
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let (s, log) = (stop.clone(), p.path("noise.log"));
    let noisy = std::thread::spawn(move || {
        use std::io::Write;
        let mut f = std::fs::File::create(log).expect("log");
        while !s.load(std::sync::atomic::Ordering::SeqCst) {
            let _ = writeln!(f, "noise");
            std::thread::sleep(Duration::from_millis(2));
        }
    });
    p.write("scene.tess", &constant_scene(0.5));
    let took = w.until_value(&p, "out/scene/a.png", 0.5);
    stop.store(true, std::sync::atomic::Ordering::SeqCst);
    noisy.join().expect("noise");
    report("edit amid unrelated events", took);
}

/// Directories the user may not read cannot be watched (inotify needs read access); the
/// files in them are polled instead of the watch stopping. Privileged users read every
/// directory, so there the case cannot arise and the test has nothing to show.
#[cfg(unix)]
#[test]
fn an_input_in_a_directory_that_cannot_be_watched_is_polled() {
    use std::os::unix::fs::PermissionsExt;
    let p = Project::new(&[(
        "scene.tess",
        "map a {\n  from = image(\"locked/in.png\")\n  size = 8 x 8\n}\noutput \"a.png\" { from = a }\n",
    )]);
    p.write_bytes("locked/in.png", &png(0.2));
    let locked = p.path("locked");
    let mode = |m: u32| std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(m)).expect("chmod");
    mode(0o311); // enter and write, not list
    if std::fs::read_dir(&locked).is_ok() {
        mode(0o755);
        eprintln!("skipped: this user reads every directory");
        return;
    }
    let w = Watch::start(&p, "scene.tess");
    w.until("cannot watch");
    w.until_value(&p, "out/scene/a.png", 0.2);
    std::fs::write(locked.join("in.png"), png(0.7)).expect("edit");
    let took = w.until_value(&p, "out/scene/a.png", 0.7);
    report("edit in an unwatchable directory (polled)", took);
    drop(w);
    mode(0o755);
}

#[cfg(unix)]
#[test]
fn a_symlinked_scene_is_rebuilt_when_its_target_changes_or_it_is_retargeted() {
    let p = Project::new(&[("real/one.tess", &constant_scene(0.25)), ("real/two.tess", &constant_scene(0.75))]);
    std::os::unix::fs::symlink("real/one.tess", p.path("scene.tess")).expect("symlink");
    let w = Watch::start(&p, "scene.tess");
    w.until_value(&p, "out/scene/a.png", 0.25);
    // The target is edited in its own directory.
    p.write("real/one.tess", &constant_scene(0.5));
    w.until_value(&p, "out/scene/a.png", 0.5);
    // The link is pointed elsewhere (replaced by rename, as `ln -sf` does).
    std::os::unix::fs::symlink("real/two.tess", p.path(".scene.tess.new")).expect("symlink");
    std::fs::rename(p.path(".scene.tess.new"), p.path("scene.tess")).expect("retarget");
    w.until_value(&p, "out/scene/a.png", 0.75);
    p.write("real/two.tess", &constant_scene(1.0));
    w.until_value(&p, "out/scene/a.png", 1.0);
}
