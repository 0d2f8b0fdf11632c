//! A user's files are sacred: what tessera writes and deletes, proven at the command line
//! (issue 10, items 1–6b and 9). Each test is a case that lost or changed files before.

mod common;

use std::path::Path;

use common::{tree, Project};

const SCENE: &str = "output \"a.png\" {\n  from = m\n}\n\nmap m {\n  from = constant(0.25)\n  size = 8 x 8\n}\n";

fn scene_with(outputs: &[(&str, f64)]) -> String {
    let mut s = String::new();
    for (i, (name, v)) in outputs.iter().enumerate() {
        s.push_str(&format!("map m{i} {{\n  from = constant({v})\n  size = 8 x 8\n}}\n\n"));
        s.push_str(&format!("output \"{name}\" {{\n  from = m{i}\n}}\n\n"));
    }
    s
}

/// A diagnostic's words without the frame miette wraps them in.
fn said(stderr: &str) -> String {
    stderr.replace(['│', '×'], " ").split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Every file below `dir` with its bytes, except tessera's cache.
fn snapshot(dir: &Path) -> Vec<(std::path::PathBuf, Vec<u8>)> {
    tree(dir).into_iter().filter(|(p, _)| !p.starts_with(".tessera")).collect()
}

#[test]
fn gc_never_deletes_the_project() {
    for cache in ["", ".", "./", "..", "scenes/.."] {
        let p = Project::new(&[("scene.tess", SCENE), ("src/main.rs", "fn main() {}"), ("notes.txt", "mine")]);
        p.write("tessera.toml", &format!("[paths]\nscenes = \".\"\ncache = \"{cache}\"\n"));
        p.write("scenes/keep.txt", "x");
        let before = snapshot(p.dir.path());
        for args in [&["gc"][..], &["gc", "--all"], &["build", "scene.tess"]] {
            let run = p.tessera(args);
            run.failed();
            assert!(run.stderr().contains("[paths] cache"), "cache = {cache:?}: {}", run.stderr());
        }
        assert_eq!(snapshot(p.dir.path()), before, "cache = {cache:?} changed the project");
    }
}

#[test]
fn gc_leaves_a_directory_that_is_not_a_cache_alone() {
    let p = Project::new(&[("scene.tess", SCENE)]);
    p.write("tessera.toml", "[paths]\nscenes = \".\"\ncache = \"stuff\"\n");
    p.write("stuff/photo.png", "not a cache entry");
    p.write("stuff/ab/cdef", "nor this");
    let run = p.tessera(&["gc", "--all"]);
    run.failed();
    assert!(run.stderr().contains("is not a tessera cache"), "{}", run.stderr());
    assert!(p.path("stuff/photo.png").exists() && p.path("stuff/ab/cdef").exists());
    // Nor does a build write cache entries there; it still builds, uncached.
    p.tessera(&["build", "scene.tess"]).ok();
    assert_eq!(std::fs::read_dir(p.path("stuff")).unwrap().count(), 2);
}

#[test]
fn gc_removes_only_entries_and_reports_strays() {
    let p = Project::new(&[("scene.tess", SCENE)]);
    p.tessera(&["build", "scene.tess"]).ok();
    let cache = p.path(".tessera/cache");
    assert!(cache.join("CACHEDIR.TAG").exists(), "a new cache is marked");
    let shard = std::fs::read_dir(&cache).unwrap().flatten().find(|e| e.path().is_dir()).unwrap().path();
    std::fs::write(shard.join("readme.txt"), "mine").unwrap();
    let run = p.tessera(&["gc", "--all"]);
    run.ok();
    assert!(run.stderr().contains("not cache entries"), "{}", run.stderr());
    assert!(shard.join("readme.txt").exists());
}

#[test]
fn a_scene_name_cannot_leave_the_output_directory() {
    for file in ["...tess", ".hidden.tess"] {
        let p = Project::new(&[(file, SCENE), ("samples/bricks.png", "precious")]);
        let before = snapshot(p.dir.path());
        for cmd in ["build", "bless", "check"] {
            let run = p.tessera(&[cmd, file]);
            run.failed();
            assert!(run.stderr().contains("cannot name its output directory"), "{file} {cmd}: {}", run.stderr());
        }
        assert_eq!(snapshot(p.dir.path()), before, "{file}");
    }
}

#[cfg(unix)]
#[test]
fn a_link_inside_the_output_directory_cannot_lead_out() {
    let p = Project::new(&[("scene.tess", SCENE)]);
    std::fs::create_dir_all(p.path("out")).unwrap();
    std::fs::create_dir_all(p.path("elsewhere")).unwrap();
    std::os::unix::fs::symlink(p.path("elsewhere"), p.path("out/scene")).unwrap();
    let run = p.tessera(&["build", "scene.tess"]);
    run.failed();
    assert!(run.stderr().contains("leave its directory"), "{}", run.stderr());
    assert_eq!(std::fs::read_dir(p.path("elsewhere")).unwrap().count(), 0);
}

#[test]
fn a_failed_write_changes_no_output() {
    let p = Project::new(&[("scene.tess", &scene_with(&[("a.png", 0.25), ("b.png", 0.5), ("sub/c.png", 0.75)]))]);
    p.tessera(&["build", "scene.tess"]).ok();
    let before = tree(&p.path("out"));
    p.write("scene.tess", &scene_with(&[("a.png", 0.3), ("b.png", 0.6), ("sub/c.png", 0.9)]));

    // A directory where an output must go.
    std::fs::remove_file(p.path("out/scene/b.png")).unwrap();
    std::fs::create_dir_all(p.path("out/scene/b.png/x")).unwrap();
    let run = p.tessera(&["build", "scene.tess"]);
    run.failed();
    assert!(said(&run.stderr()).contains("none of the scene's outputs was changed"), "{}", run.stderr());
    let now = tree(&p.path("out"));
    let unchanged = |name: &str| {
        let pick = |t: &[(std::path::PathBuf, Vec<u8>)]| t.iter().find(|(p, _)| p.ends_with(name)).cloned();
        assert_eq!(pick(&now), pick(&before), "{name} changed");
    };
    unchanged("scene/a.png");
    unchanged("scene/sub/c.png");
    std::fs::remove_dir_all(p.path("out/scene/b.png")).unwrap();

    // A read-only directory.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(p.path("out/scene/sub"), std::fs::Permissions::from_mode(0o555)).unwrap();
        p.tessera(&["build", "scene.tess"]).failed();
        std::fs::set_permissions(p.path("out/scene/sub"), std::fs::Permissions::from_mode(0o755)).unwrap();
        let now = tree(&p.path("out"));
        assert_eq!(
            now.iter().find(|(f, _)| f.ends_with("scene/a.png")),
            before.iter().find(|(f, _)| f.ends_with("scene/a.png"))
        );
    }

    // No temporary is left behind, and with the obstacle gone the whole set is written.
    p.tessera(&["build", "scene.tess"]).ok();
    let after = tree(&p.path("out"));
    assert_eq!(after.len(), 3, "{:?}", after.iter().map(|(p, _)| p).collect::<Vec<_>>());
    assert!(after.iter().all(|(a, bytes)| before.iter().find(|(b, _)| b == a).is_some_and(|(_, old)| old != bytes)));
}

#[test]
fn an_output_name_too_long_for_the_file_system_is_a_diagnostic() {
    let long = format!("{}.png", "x".repeat(260));
    let p = Project::new(&[("scene.tess", &scene_with(&[("a.png", 0.25), (&long, 0.5)]))]);
    let run = p.tessera(&["build", "scene.tess"]);
    run.failed();
    assert!(run.stderr().contains("at most 255"), "{}", run.stderr());
    assert!(!p.path("out").exists());
}

#[test]
fn two_outputs_of_one_file_are_a_diagnostic() {
    for (a, b, says) in [
        ("a.png", "./a.png", "two outputs write `a.png`"),
        ("d.png", "d.png/x.png", "cannot be written inside it"),
        ("s/a.png", "s//a.png", "two outputs write `s/a.png`"),
    ] {
        let p = Project::new(&[("scene.tess", &scene_with(&[(a, 0.25), (b, 0.5)]))]);
        let run = p.tessera(&["build", "scene.tess"]);
        run.failed();
        let err = run.stderr();
        assert!(err.contains(says), "{a} / {b}: {err}");
        assert!(err.contains(&format!("\"{a}\"")) && err.contains(&format!("\"{b}\"")), "names both: {err}");
        assert!(!p.path("out").exists());
    }
}

#[test]
fn scenes_in_subdirectories_have_directories_of_their_own() {
    let p =
        Project::new(&[("s.tess", &scene_with(&[("a.png", 0.25)])), ("sub/s.tess", &scene_with(&[("a.png", 0.5)]))]);
    p.tessera(&["build"]).ok();
    assert_ne!(p.read("out/s/a.png"), p.read("out/sub/s/a.png"));
    p.tessera(&["bless"]).ok();
    assert!(p.path("golden/sub/s/a.png").exists() && p.path("golden/s/a.png").exists());
    p.tessera(&["check"]).ok();
}

#[test]
fn two_scenes_writing_one_file_are_a_diagnostic() {
    let p = Project::new(&[
        ("sub.tess", &scene_with(&[("s/a.png", 0.25)])),
        ("sub/s.tess", &scene_with(&[("a.png", 0.5)])),
    ]);
    let run = p.tessera(&["build"]);
    run.failed();
    let err = said(&run.stderr());
    assert!(
        err.contains("`sub/s/a.png` is also written by output \"s/a.png\" of `sub.tess`")
            || err.contains("`sub/s/a.png` is also written by output \"a.png\" of `sub/s.tess`"),
        "{err}"
    );
}

#[test]
fn diff_images_never_overwrite_an_output() {
    let p = Project::new(&[("scene.tess", &scene_with(&[("a.png", 0.25), ("a.diff.png", 0.5)]))]);
    p.tessera(&["bless", "scene.tess"]).ok();
    p.write("scene.tess", &scene_with(&[("a.png", 0.75), ("a.diff.png", 0.5)]));
    let run = p.tessera(&["check", "scene.tess"]);
    run.failed();
    let output = p.read("out/scene/a.diff.png");
    assert_eq!(output, p.read("golden/scene/a.diff.png"), "the output named a.diff.png is intact");
    let diff = p.path("out/.diff/scene/a.png.diff.png");
    assert!(diff.exists(), "{}", run.stdout());
    assert!(run.stdout().contains(".diff/scene/a.png.diff.png"), "{}", run.stdout());
    // Passing again removes the stale diff.
    p.write("scene.tess", &scene_with(&[("a.png", 0.25), ("a.diff.png", 0.5)]));
    p.tessera(&["check", "scene.tess"]).ok();
    assert!(!diff.exists());
}

#[test]
fn paths_resolve_as_the_operating_system_resolves_them() {
    // `scenes/../../../shared/a.png` is outside the project; the old lexical rule let one `..`
    // cancel another and read `./shared/a.png` instead.
    let png = image_png();
    let p = Project::new(&[]);
    p.write("tessera.toml", "[paths]\nscenes = \"scenes\"\n");
    p.write_bytes("shared/a.png", &png);
    p.write(
        "scenes/s.tess",
        "sample s {\n  image = \"../../../shared/a.png\"\n}\n\noutput \"a.png\" {\n  from = s\n}\n",
    );
    let run = p.tessera(&["build", "scenes/s.tess"]);
    run.failed();
    assert!(!p.path("out").exists());
    // The same file named the right way builds.
    p.write("scenes/s.tess", "sample s {\n  image = \"../shared/a.png\"\n}\n\noutput \"a.png\" {\n  from = s\n}\n");
    p.tessera(&["build", "scenes/s.tess"]).ok();
    // Imports too.
    p.write("lib/_l.tess", "map m {\n  from = constant(0.5)\n  size = 4 x 4\n}\n");
    p.write("scenes/i.tess", "import \"../../../lib/_l.tess\"\n\noutput \"m.png\" {\n  from = m\n}\n");
    p.tessera(&["build", "scenes/i.tess"]).failed();
    p.write("scenes/i.tess", "import \"../lib/_l.tess\"\n\noutput \"m.png\" {\n  from = m\n}\n");
    p.tessera(&["build", "scenes/i.tess"]).ok();
}

#[cfg(unix)]
#[test]
fn dot_dot_after_a_link_follows_the_link() {
    // `link/../x` is `target/../x` to the operating system, not `./x`.
    let png = image_png();
    let p = Project::new(&[]);
    p.write_bytes("deep/dir/a.png", &png);
    std::os::unix::fs::symlink(p.path("deep/dir"), p.path("link")).unwrap();
    p.write_bytes("deep/b.png", &png);
    p.write("scene.tess", "sample s {\n  image = \"link/../b.png\"\n}\n\noutput \"a.png\" {\n  from = s\n}\n");
    p.tessera(&["build", "scene.tess"]).ok();
}

fn image_png() -> Vec<u8> {
    let img = image::RgbImage::from_fn(4, 4, |x, y| image::Rgb([x as u8 * 60, y as u8 * 60, 128]));
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).unwrap();
    bytes
}

#[test]
fn swapped_cache_entries_are_rebuilt_not_trusted() {
    let p = Project::new(&[("scene.tess", &scene_with(&[("a.png", 0.25), ("b.png", 0.75)]))]);
    p.tessera(&["build", "scene.tess"]).ok();
    let good = tree(&p.path("out"));
    std::fs::remove_dir_all(p.path("out")).unwrap();
    // Swap the bytes of every pair of entries.
    let mut entries: Vec<_> =
        tree(&p.path(".tessera/cache")).into_iter().filter(|(f, _)| f.components().count() == 2).collect();
    assert!(entries.len() >= 4, "{}", entries.len());
    entries.sort();
    for pair in entries.chunks(2) {
        if let [(a, da), (b, db)] = pair {
            std::fs::write(p.path(".tessera/cache").join(a), db).unwrap();
            std::fs::write(p.path(".tessera/cache").join(b), da).unwrap();
        }
    }
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    assert!(stages.iter().any(|s| s.status == "rebuilt"), "{stages:?}");
    assert_eq!(tree(&p.path("out")), good);
}

#[test]
fn identity_outputs_compare_exactly() {
    // `scale` 0.9 → 0.92 moved 31 007 region ids by up to 61 and the 16-bit id map still
    // passed a 0.004 tolerance (262 steps).
    let p = Project::copy_of_repo();
    let scene = std::fs::read_to_string(p.path("scenes/wall_random.tess")).unwrap();
    p.write("scenes/wall_random.tess", &scene.replace("scale = 0.9", "scale = 0.92"));
    let run = p.tessera(&["check", "scenes/wall_random.tess"]);
    run.failed();
    let out = run.stdout();
    let row = out.lines().find(|l| l.contains("ids.png")).unwrap_or_else(|| panic!("{out}"));
    assert!(row.starts_with("FAIL"), "{row}");
    assert!(out.contains("compared exactly"), "{out}");
    // A tolerance on an identity output is refused.
    p.write(
        "scenes/wall_random.tess",
        &scene.replace("  view = labels16\n", "  view = labels16\n  tolerance = 0.01\n"),
    );
    let run = p.tessera(&["build", "scenes/wall_random.tess"]);
    run.failed();
    assert!(run.stderr().contains("compared exactly"), "{}", run.stderr());
}

#[test]
fn sixteen_bit_tolerances_are_whole_steps() {
    let scene = |v: f64| {
        format!("map m {{\n  from = constant({v})\n  size = 8 x 8\n}}\n\noutput \"h.png\" {{\n  from = m\n  format = png16\n  tolerance = 0.0001\n}}\n")
    };
    let p = Project::new(&[("scene.tess", &scene(0.5))]);
    p.tessera(&["bless", "scene.tess"]).ok();
    // 0.0001 of 65 535 is 6.55: 6 whole steps. 0.5 + 7/65535 fails, + 6/65535 passes.
    p.write("scene.tess", &scene(0.5 + 7.0 / 65535.0));
    let run = p.tessera(&["check", "scene.tess"]);
    run.failed();
    assert!(run.stdout().contains("16-bit steps: max diff 7, tolerance 6"), "{}", run.stdout());
    p.write("scene.tess", &scene(0.5 + 6.0 / 65535.0));
    p.tessera(&["check", "scene.tess"]).ok();
}

#[test]
fn temporaries_of_killed_builds_are_removed() {
    let p = Project::new(&[("scene.tess", &scene_with(&[("a.png", 0.25), ("sub/b.png", 0.5)]))]);
    p.tessera(&["build", "scene.tess"]).ok();
    // What a build killed between writing and renaming leaves (its process is gone).
    for dir in ["out/scene", "out/scene/sub"] {
        p.write(&format!("{dir}/.tessera-tmp-4194304999-7"), "partial");
        p.write(&format!("{dir}/.tessera-old-4194304999-8"), "partial");
    }
    p.write("out/scene/.tessera-notes", "a user's file that merely looks similar");
    p.write("scene.tess", &scene_with(&[("a.png", 0.3), ("sub/b.png", 0.6)]));
    p.tessera(&["build", "scene.tess"]).ok();
    let left: Vec<_> = tree(&p.path("out")).into_iter().map(|(f, _)| f).collect();
    assert_eq!(left.len(), 3, "{left:?}");
    assert!(p.path("out/scene/.tessera-notes").exists());
}

#[test]
fn a_killed_build_leaves_no_temporary_behind() {
    // Kill builds at many moments; after one more build nothing but outputs remains.
    let p = Project::new(&[("scene.tess", &scene_with(&[("a.png", 0.25), ("b.png", 0.5), ("c.png", 0.75)]))]);
    for (i, delay) in [0u64, 5, 10, 20, 40].iter().enumerate() {
        let v = 0.1 + 0.1 * i as f64;
        p.write("scene.tess", &scene_with(&[("a.png", v), ("b.png", v + 0.05), ("c.png", v + 0.1)]));
        let mut child = std::process::Command::new(common::bin())
            .args(["build", "scene.tess"])
            .current_dir(p.dir.path())
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(*delay));
        let _ = child.kill();
        let _ = child.wait();
    }
    p.tessera(&["build", "scene.tess"]).ok();
    let left: Vec<_> = tree(&p.path("out")).into_iter().map(|(f, _)| f).collect();
    assert_eq!(left.len(), 3, "{left:?}");
}

#[test]
fn a_project_opened_from_another_directory_writes_into_that_project() {
    // Was: `Project::open(dir)` made its root relative to `dir` even when the process ran
    // elsewhere, so outputs and the cache landed in the process's own directory (the fuzz
    // harness filled 32 GB of a campaign directory, and `cargo test` wrote `out/scene/`
    // into the repository).
    let p = Project::new(&[("scenes/s.tess", "map m { from = constant(0.5) }\noutput \"m.png\" { from = m }\n")]);
    let here = std::env::current_dir().expect("cwd");
    assert_ne!(here, p.dir.path());
    let before = here.join("out/scenes/s/m.png").exists();
    let project = tessera::project::Project::open(p.dir.path()).expect("open");
    let mut project = project;
    project.progress = false;
    let built = project.build(&p.path("scenes/s.tess")).expect("build");
    project.emit(&built).expect("emit");
    assert!(
        p.path("out/scenes/s/m.png").is_file(),
        "the output is not in the project: {:?}",
        common::tree(p.dir.path()).iter().map(|(f, _)| f.clone()).collect::<Vec<_>>()
    );
    assert!(p.path(".tessera/cache").is_dir(), "the cache is not in the project");
    assert_eq!(here.join("out/scenes/s/m.png").exists(), before, "wrote into the process's directory");
}
