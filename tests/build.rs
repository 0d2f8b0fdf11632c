//! Building scenes: caching, incremental rebuilds, determinism, atomic outputs.

mod common;

use common::{ran, tree, Project};

const SCENE: &str = r#"
scene { seed = 5  size = 64 x 48 }

map base { from = noise(scale = 16 px, octaves = 3) }
map soft {
  from = base
  blur = 1 px
}
map mask { from = rect(at = [8, 8], size = [30, 20]) }
map both { from = combine(a = soft, b = mask, op = multiply) }
surface plane { occupancy = mask }

output "both.png" { from = both }
output "mask.png" { from = plane }
output "base.exr" { from = base }
"#;

#[test]
fn second_build_runs_nothing() {
    let p = Project::new(&[("scene.tess", SCENE)]);
    let (run, first) = p.build_report(&["scene.tess"]);
    run.ok();
    assert!(!ran(&first).is_empty());
    let (run, second) = p.build_report(&["scene.tess"]);
    run.ok();
    assert_eq!(ran(&second), Vec::<String>::new(), "second build ran stages: {second:?}");
    assert!(run.stdout().contains("0 of 3 outputs written"), "{}", run.stdout());
}

#[test]
fn one_property_change_reruns_exactly_its_downstream() {
    let p = Project::new(&[("scene.tess", SCENE)]);
    p.build_report(&["scene.tess"]).0.ok();
    // `blur` of `soft` feeds `both` and its output; nothing else.
    p.write("scene.tess", &SCENE.replace("blur = 1 px", "blur = 2 px"));
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    assert_eq!(ran(&stages), vec!["map both", "map soft (ops)", "output both.png"]);
    // The mask feeds the plane and `both`: a change there re-runs those, not the noise.
    p.write("scene.tess", &SCENE.replace("blur = 1 px", "blur = 2 px").replace("size = [30, 20]", "size = [31, 20]"));
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    assert_eq!(ran(&stages), vec!["map both", "map mask", "output both.png", "output mask.png", "surface plane"]);
}

#[test]
fn an_edit_to_an_input_file_reruns_its_readers() {
    let p = Project::new(&[(
        "scene.tess",
        r#"
map a { from = image("in.png")  size = 16 x 16 }
map b { from = constant(0.5)  size = 16 x 16 }
output "a.png" { from = a }
output "b.png" { from = b }
"#,
    )]);
    let png =
        |v: f32| tessera::raster::io::encode_png(&tessera::raster::Image::filled(16, 16, 1, v), 8).expect("encode");
    p.write_bytes("in.png", &png(0.25));
    p.build_report(&["scene.tess"]).0.ok();
    p.write_bytes("in.png", &png(0.75));
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    assert_eq!(ran(&stages), vec!["map a", "output a.png"]);
    let out = tessera::raster::io::decode(&p.read("out/scene/a.png")).expect("decode");
    assert!((out.get(3, 3, 0) - 0.75).abs() < 0.003);
}

#[test]
fn thread_count_does_not_change_outputs() {
    let a = Project::copy_of_repo();
    let b = Project::copy_of_repo();
    a.tessera(&["-j", "1", "build", "scenes"]).ok();
    b.tessera(&["-j", "2", "build", "scenes"]).ok();
    let (ta, tb) = (tree(&a.path("out")), tree(&b.path("out")));
    assert!(!ta.is_empty());
    assert_eq!(ta.len(), tb.len());
    for ((pa, ba), (pb, bb)) in ta.iter().zip(&tb) {
        assert_eq!(pa, pb);
        assert!(ba == bb, "{} differs between -j 1 and -j 2", pa.display());
    }
}

#[test]
fn failed_build_keeps_previous_outputs_and_cache() {
    let p = Project::new(&[("scene.tess", SCENE)]);
    p.tessera(&["build", "scene.tess"]).ok();
    let before = tree(&p.path("out"));
    let cache_before = tree(&p.path(".tessera/cache"));
    // A stage failure late in the graph (the occupancy map does not fit the plane).
    p.write(
        "scene.tess",
        &SCENE.replace("surface plane { occupancy = mask }", "surface plane { plane = 10 x 10  occupancy = mask }"),
    );
    p.tessera(&["build", "scene.tess"]).failed();
    assert_eq!(tree(&p.path("out")), before, "a failed build touched the outputs");
    let cache_after = tree(&p.path(".tessera/cache"));
    for entry in &cache_before {
        assert!(cache_after.contains(entry), "a failed build lost a cache entry");
    }
    // A syntax error: nothing runs, nothing is written.
    p.write("scene.tess", "map {");
    p.tessera(&["build", "scene.tess"]).failed();
    assert_eq!(tree(&p.path("out")), before);
}

#[test]
fn truncated_cache_entry_is_rebuilt_not_trusted() {
    let p = Project::new(&[("scene.tess", SCENE)]);
    p.tessera(&["build", "scene.tess"]).ok();
    let good = tree(&p.path("out"));
    for (rel, bytes) in tree(&p.path(".tessera/cache")) {
        let path = p.path(".tessera/cache").join(rel);
        std::fs::write(&path, &bytes[..bytes.len() / 2]).expect("truncate");
    }
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    assert!(stages.iter().any(|s| s.status == "rebuilt"), "{stages:?}");
    assert_eq!(tree(&p.path("out")), good);
    let (_, again) = p.build_report(&["scene.tess"]);
    assert_eq!(ran(&again), Vec::<String>::new());
}

#[test]
fn concurrent_builds_share_the_cache_safely() {
    let p = Project::copy_of_repo();
    let spawn = || {
        std::process::Command::new(common::bin())
            .args(["build", "scenes", "-q"])
            .current_dir(p.dir.path())
            .spawn()
            .expect("spawn")
    };
    let (mut a, mut b) = (spawn(), spawn());
    assert!(a.wait().expect("wait").success());
    assert!(b.wait().expect("wait").success());
    let (run, stages) = p.build_report(&["scenes"]);
    run.ok();
    assert_eq!(ran(&stages), Vec::<String>::new(), "cache entries were not usable after concurrent builds");
    p.tessera(&["check", "scenes"]).ok();
}

#[test]
fn gc_removes_only_unused_entries() {
    let p = Project::new(&[("scene.tess", SCENE)]);
    p.tessera(&["build", "scene.tess"]).ok();
    p.write("scene.tess", &SCENE.replace("blur = 1 px", "blur = 3 px"));
    p.tessera(&["build", "scene.tess"]).ok();
    let run = p.tessera(&["gc"]);
    run.ok();
    assert!(run.stdout().contains("removed 3"), "{}", run.stdout());
    let (_, stages) = p.build_report(&["scene.tess"]);
    assert_eq!(ran(&stages), Vec::<String>::new(), "gc removed a live entry");
    p.tessera(&["gc", "--all"]).ok();
    // Only the marker that makes the directory a tessera cache stays, and the hit counts of
    // past builds (`tessera cache stats`), which are history rather than entries.
    let left: Vec<_> = tree(&p.path(".tessera/cache")).into_iter().map(|(f, _)| f).collect();
    assert_eq!(left, [std::path::PathBuf::from("CACHEDIR.TAG"), std::path::PathBuf::from("stats.json")]);
}

#[test]
fn graph_prints_text_and_dot_with_cache_state() {
    let p = Project::new(&[("scene.tess", SCENE)]);
    let text = p.tessera(&["graph", "scene.tess"]);
    text.ok();
    assert!(text.stdout().contains("stale") && text.stdout().contains("map.ops"), "{}", text.stdout());
    p.tessera(&["build", "scene.tess"]).ok();
    let dot = p.tessera(&["graph", "--dot", "scene.tess"]);
    dot.ok();
    let s = dot.stdout();
    assert!(s.starts_with("digraph") && s.contains("->") && s.contains("palegreen") && !s.contains("orange"), "{s}");
}

#[test]
fn timings_list_every_stage() {
    let p = Project::new(&[("scene.tess", SCENE)]);
    let run = p.tessera(&["build", "--timings", "scene.tess"]);
    run.ok();
    for label in ["map base", "map soft (ops)", "surface plane", "output both.png"] {
        assert!(run.stdout().contains(label), "missing {label}:\n{}", run.stdout());
    }
    let run = p.tessera(&["build", "--timings", "scene.tess"]);
    assert!(!run.stdout().contains(" ran "), "{}", run.stdout());
}

#[test]
fn params_are_overridable_from_the_command_line() {
    let scene = "param v = 0.25\nmap a { from = constant(v)  size = 4 x 4 }\noutput \"a.png\" { from = a }\n";
    let p = Project::new(&[("scene.tess", scene)]);
    p.tessera(&["build", "--set", "v=0.75", "scene.tess"]).ok();
    let img = tessera::raster::io::decode(&p.read("out/scene/a.png")).expect("decode");
    assert!((img.get(0, 0, 0) - 0.75).abs() < 0.003);
}

#[test]
fn imports_share_declarations() {
    let p = Project::new(&[
        ("_lib.tess", "map shared { from = constant(0.5)  size = 4 x 4 }\n"),
        ("scene.tess", "import \"_lib.tess\"\noutput \"a.png\" { from = shared }\n"),
    ]);
    let run = p.tessera(&["build"]);
    run.ok();
    assert!(!run.stdout().contains("_lib"), "library files are not scenes: {}", run.stdout());
    assert!(p.path("out/scene/a.png").exists());
}
