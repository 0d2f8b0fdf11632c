//! Golden review: diff images named after the whole output file name and removed on pass,
//! stale goldens (and those of deleted scenes) reported by `check` and removed by
//! `bless --prune` (nothing else),
//! `bless SCENE:OUTPUT`, `tessera review` driven by piped answers, and the two-colour diff of
//! line art.

mod common;

use std::io::Write;
use std::process::{Command, Stdio};

use common::{png, Project, Run};
use tessera::golden::{ADDED, REMOVED};
use tessera::raster::{self, Image};

/// A scene whose outputs are constant 8×8 maps: `(file name, value)`.
fn scene_with(outputs: &[(&str, f64)]) -> String {
    let mut s = String::new();
    for (i, (name, v)) in outputs.iter().enumerate() {
        s.push_str(&format!("map m{i} {{\n  from = constant({v})\n  size = 8 x 8\n}}\n\n"));
        s.push_str(&format!("output \"{name}\" {{\n  from = m{i}\n}}\n\n"));
    }
    s
}

/// Runs `tessera ARGS` in `p` with `input` on stdin.
fn with_stdin(p: &Project, args: &[&str], input: &str) -> Run {
    let mut child = Command::new(common::bin())
        .args(args)
        .current_dir(p.dir.path())
        .env("NO_COLOR", "1")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn tessera");
    child.stdin.take().expect("stdin").write_all(input.as_bytes()).expect("write answers");
    Run { out: child.wait_with_output().expect("wait") }
}

#[test]
fn diff_images_of_final_png_and_final_exr_do_not_collide_and_go_on_pass() {
    let p = Project::new(&[("scene.tess", &scene_with(&[("final.png", 0.25), ("final.exr", 0.25)]))]);
    p.tessera(&["bless", "scene.tess"]).ok();
    p.write("scene.tess", &scene_with(&[("final.png", 0.75), ("final.exr", 0.5)]));
    let run = p.tessera(&["check", "scene.tess"]);
    run.failed();
    let (png_diff, exr_diff) =
        (p.path("out/.diff/scene/final.png.diff.png"), p.path("out/.diff/scene/final.exr.diff.png"));
    assert!(png_diff.exists() && exr_diff.exists(), "{}", run.stdout());
    for d in [&png_diff, &exr_diff] {
        assert!(
            run.stdout().contains(&d.strip_prefix(p.dir.path()).unwrap().display().to_string()),
            "{}",
            run.stdout()
        );
    }
    // Only the PNG passes again: its diff goes, the EXR's stays.
    p.write("scene.tess", &scene_with(&[("final.png", 0.25), ("final.exr", 0.5)]));
    p.tessera(&["check", "scene.tess"]).failed();
    assert!(!png_diff.exists() && exr_diff.exists());
    p.write("scene.tess", &scene_with(&[("final.png", 0.25), ("final.exr", 0.25)]));
    p.tessera(&["check", "scene.tess"]).ok();
    assert!(!exr_diff.exists());
}

#[test]
fn a_stale_golden_is_reported_by_check_and_removed_by_bless_prune_alone() {
    let p = Project::new(&[
        ("scene.tess", &scene_with(&[("a.png", 0.25), ("old/b.png", 0.5)])),
        ("scene/sub.tess", &scene_with(&[("c.png", 0.75)])),
    ]);
    p.tessera(&["bless"]).ok();
    p.write("scene.tess", &scene_with(&[("a.png", 0.25), ("old/b.png", 0.75)]));
    p.tessera(&["check", "scene.tess"]).failed();
    let diff = p.path("out/.diff/scene/old/b.png.diff.png");
    assert!(diff.exists());
    p.write("scene.tess", &scene_with(&[("a.png", 0.25)]));
    // Files that are not goldens of `scene`: notes, a hidden file, a link leading out, the
    // goldens of the scene `scene/sub`.
    p.write("golden/scene/notes.txt", "mine");
    p.write("golden/scene/.hidden.png", "mine");
    p.write("outside/x.png", "mine");
    #[cfg(unix)]
    std::os::unix::fs::symlink(p.path("outside/x.png"), p.path("golden/scene/link.png")).expect("link");
    #[cfg(unix)]
    std::os::unix::fs::symlink(p.path("outside"), p.path("golden/scene/linked")).expect("link");

    let run = p.tessera(&["check"]);
    run.ok();
    let err = run.stderr();
    assert!(err.contains("warning: `golden/scene/old/b.png` is the golden of no output of `scene.tess`"), "{err}");
    assert_eq!(err.matches("warning:").count(), 1, "{err}");

    let run = p.tessera(&["bless", "--prune", "scene.tess"]);
    run.ok();
    assert!(run.stdout().contains("pruned golden/scene/old/b.png"), "{}", run.stdout());
    assert!(!p.path("golden/scene/old").exists(), "the emptied directory goes too");
    assert!(!diff.exists(), "its diff image goes too");
    for kept in [
        "golden/scene/a.png",
        "golden/scene/notes.txt",
        "golden/scene/.hidden.png",
        "golden/scene/sub/c.png",
        "outside/x.png",
    ] {
        assert!(p.path(kept).exists(), "{kept} was removed");
    }
    #[cfg(unix)]
    assert!(p.path("golden/scene/link.png").symlink_metadata().is_ok() && p.path("golden/scene/linked/x.png").exists());
    let run = p.tessera(&["check"]);
    run.ok();
    assert!(!run.stderr().contains("warning:"), "{}", run.stderr());
}

#[test]
fn bless_scene_output_blesses_only_that_output() {
    let p = Project::new(&[("scene.tess", &scene_with(&[("a.png", 0.25), ("b.png", 0.5)]))]);
    p.tessera(&["bless", "scene.tess"]).ok();
    let (a, b) = (p.read("golden/scene/a.png"), p.read("golden/scene/b.png"));
    p.write("scene.tess", &scene_with(&[("a.png", 0.75), ("b.png", 0.0)]));
    let run = p.tessera(&["bless", "scene.tess:b.png"]);
    run.ok();
    assert!(run.stdout().contains("golden/scene/b.png") && !run.stdout().contains("a.png"), "{}", run.stdout());
    assert_eq!(p.read("golden/scene/a.png"), a);
    assert_ne!(p.read("golden/scene/b.png"), b);
    assert_eq!(p.read("golden/scene/b.png"), p.read("out/scene/b.png"));
    let run = p.tessera(&["check", "scene.tess"]);
    run.failed();
    assert!(run.stdout().lines().any(|l| l.starts_with("FAIL") && l.contains("a.png")), "{}", run.stdout());
    assert!(run.stdout().lines().any(|l| l.starts_with("ok") && l.contains("b.png")), "{}", run.stdout());

    // Unknown outputs and scenes are errors naming them; nothing is blessed.
    let run = p.tessera(&["bless", "scene.tess:b.pgn"]);
    run.failed();
    assert!(
        run.stderr().contains("no output `b.pgn`") && run.stderr().contains("did you mean `b.png`?"),
        "{}",
        run.stderr()
    );
    let run = p.tessera(&["bless", "scnee.tess:a.png"]);
    run.failed();
    assert!(run.stderr().contains("`scnee.tess`") && run.stderr().contains("did you mean"), "{}", run.stderr());
    assert_eq!(p.read("golden/scene/a.png"), a);
}

#[test]
fn review_accepts_rejects_and_skips_by_piped_answers() {
    let p = Project::new(&[("scene.tess", &scene_with(&[("a.png", 0.25), ("b.png", 0.25), ("c.png", 0.25)]))]);
    p.tessera(&["bless", "scene.tess"]).ok();
    let before = p.read("golden/scene/a.png");
    p.write("scene.tess", &scene_with(&[("a.png", 0.5), ("b.png", 0.5), ("c.png", 0.5)]));
    let run = with_stdin(&p, &["review", "scene.tess"], "a\nr\ns\n");
    run.ok();
    let out = run.stdout();
    assert!(out.contains("[1/3] scene `scene`, output `a.png` FAILS"), "{out}");
    assert!(out.contains("max diff 0.25") && out.contains("64/64") && out.contains("in 8-bit steps"), "{out}");
    assert!(out.contains("diff image: out/.diff/scene/b.png.diff.png"), "{out}");
    assert!(out.contains("review: 1 accepted, 1 rejected, 1 skipped"), "{out}");
    assert_eq!(p.read("golden/scene/a.png"), p.read("out/scene/a.png"), "accepted");
    assert_ne!(p.read("golden/scene/a.png"), before);
    for kept in ["b.png", "c.png"] {
        assert_eq!(p.read(&format!("golden/scene/{kept}")), before, "{kept} kept its golden");
        assert!(p.path(&format!("out/.diff/scene/{kept}.diff.png")).exists());
    }
    assert!(!p.path("out/.diff/scene/a.png.diff.png").exists());

    // No answers left: the review stops cleanly; quiet leaves out the build lines.
    let run = with_stdin(&p, &["review", "-q", "scene.tess"], "");
    run.ok();
    assert!(run.stdout().contains("no more answers; 2 outputs left"), "{}", run.stdout());
    assert!(!run.stdout().contains("stages"), "{}", run.stdout());
    let run = with_stdin(&p, &["review", "scene.tess"], "maybe\nq\n");
    run.ok();
    assert!(run.stdout().contains("answer a, r, s or q"), "{}", run.stdout());
    assert_eq!(p.read("golden/scene/b.png"), before);
}

/// A white 8×6 RGB image with a black vertical line at `column`.
fn line_at(column: usize) -> Image {
    Image::from_fn(8, 6, 3, |x, _, _| if x == column { 0.0 } else { 1.0 })
}

#[test]
fn line_art_diffs_show_removed_and_added_pixels_in_two_colours() {
    let scene = "sample s {\n  image = \"lines.png\"\n}\n\noutput \"edges.png\" {\n  from = s\n}\n";
    let p = Project::new(&[("scene.tess", scene)]);
    p.write_bytes("lines.png", &png(&line_at(2)));
    p.tessera(&["bless", "scene.tess"]).ok();
    p.write_bytes("lines.png", &png(&line_at(5)));
    p.tessera(&["check", "scene.tess"]).failed();
    let d = raster::io::decode(&p.read("out/.diff/scene/edges.png.diff.png")).expect("diff decodes");
    let px = |x: usize, y: usize| [d.get(x, y, 0), d.get(x, y, 1), d.get(x, y, 2)];
    let near = |a: [f32; 3], b: [f32; 3]| a.iter().zip(b).all(|(a, b)| (a - b).abs() <= 1.0 / 255.0);
    for y in 0..6 {
        assert!(near(px(2, y), REMOVED), "removed at y {y}: {:?}", px(2, y));
        assert!(near(px(5, y), ADDED), "added at y {y}: {:?}", px(5, y));
        assert!(near(px(0, y), [1.0; 3]), "white ground at y {y}: {:?}", px(0, y));
    }
}

#[test]
fn label_diffs_show_moved_boundaries_in_two_colours_over_the_faded_golden() {
    let scene = |seed: u32| {
        format!(
            "scene {{ seed = {seed}  size = 96 x 64 }}\nsample s {{ structure = \"wall.json\" }}\n\
             surface t {{ plane = 96 x 64 }}\nstructure st {{\n  from = s\n  on = t\n}}\n\
             output \"labels.png\" {{ from = st }}\n"
        )
    };
    let p = Project::new(&[("scene.tess", &scene(3))]);
    let json = std::fs::read(common::repo().join("samples/standins/wall_random.json")).expect("stand-in");
    p.write_bytes("wall.json", &json);
    p.tessera(&["bless", "scene.tess"]).ok();
    p.write("scene.tess", &scene(4));
    let run = p.tessera(&["check", "scene.tess"]);
    run.failed();
    assert!(run.stdout().contains("compared exactly"), "{}", run.stdout());
    let d = raster::io::decode(&p.read("out/.diff/scene/labels.png.diff.png")).expect("diff decodes");
    let near = |a: [f32; 3], b: [f32; 3]| a.iter().zip(b).all(|(a, b)| (a - b).abs() <= 1.0 / 255.0);
    let (mut removed, mut added) = (0, 0);
    for y in 0..d.height {
        for x in 0..d.width {
            let c = [d.get(x, y, 0), d.get(x, y, 1), d.get(x, y, 2)];
            if near(c, REMOVED) {
                removed += 1;
            } else if near(c, ADDED) {
                added += 1;
            } else {
                let faded = c[0] == c[1] && c[1] == c[2] && c[0] >= 0.74;
                assert!(faded || near(c, tessera::golden::CHANGED), "({x}, {y}): {c:?}");
            }
        }
    }
    assert!(removed > 0 && added > 0, "removed {removed}, added {added}");
}

#[test]
fn goldens_of_a_deleted_scene_are_reported_and_pruned_by_a_whole_bless_prune() {
    let p = Project::new(&[
        ("scenes/a.tess", &scene_with(&[("a.png", 0.25)])),
        ("scenes/sub/b.tess", &scene_with(&[("b.png", 0.5), ("deep/c.png", 0.5)])),
        ("scenes/sub/keep.tess", &scene_with(&[("k.png", 0.5)])),
        ("tessera.toml", "[paths]\nscenes = \"scenes\"\n"),
    ]);
    p.tessera(&["-q", "bless"]).ok();
    assert!(p.path("golden/sub/b/deep/c.png").exists());
    // `a` renamed to `renamed`, `sub/b` deleted; `sub/keep` stays.
    std::fs::rename(p.path("scenes/a.tess"), p.path("scenes/renamed.tess")).expect("rename");
    std::fs::remove_file(p.path("scenes/sub/b.tess")).expect("delete");
    p.tessera(&["-q", "bless", "scenes/renamed.tess"]).ok();
    // Files tessera did not make: in the golden root, not golden-named, hidden, behind a link.
    p.write("golden/notes.png", "mine");
    p.write("golden/mine/readme.txt", "mine");
    p.write("golden/.hidden/x.png", "mine");
    p.write("outside/x.png", "mine");
    #[cfg(unix)]
    std::os::unix::fs::symlink(p.path("outside"), p.path("golden/linked")).expect("link");

    let run = p.tessera(&["check"]);
    run.ok();
    let err = run.stderr();
    assert!(err.contains("warning: `golden/a/` holds 1 golden(s) of no scene"), "{err}");
    assert!(err.contains("warning: `golden/sub/b/` holds 2 golden(s) of no scene"), "{err}");
    assert_eq!(err.matches("warning:").count(), 2, "{err}");

    // Pruning one scene leaves other scenes' leftovers, and says how to remove them.
    let run = p.tessera(&["bless", "--prune", "scenes/renamed.tess"]);
    run.ok();
    assert!(p.path("golden/a/a.png").exists());
    assert!(run.stderr().contains("(of every scene) removes them"), "{}", run.stderr());

    let run = p.tessera(&["bless", "--prune"]);
    run.ok();
    for gone in ["golden/a/a.png", "golden/sub/b/b.png", "golden/sub/b/deep/c.png"] {
        assert!(run.stdout().contains(&format!("pruned {gone}")), "{}", run.stdout());
        assert!(!p.path(gone).exists(), "{gone}");
    }
    assert!(!p.path("golden/a").exists() && !p.path("golden/sub/b").exists(), "emptied directories go");
    for kept in [
        "golden/renamed/a.png",
        "golden/sub/keep/k.png",
        "golden/notes.png",
        "golden/mine/readme.txt",
        "golden/.hidden/x.png",
        "outside/x.png",
    ] {
        assert!(p.path(kept).exists(), "{kept} was removed");
    }
    #[cfg(unix)]
    assert!(p.path("golden/linked").symlink_metadata().is_ok(), "the link was removed");
    let run = p.tessera(&["check"]);
    run.ok();
    assert!(!run.stderr().contains("warning"), "{}", run.stderr());
}
