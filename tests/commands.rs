//! The commands outside scenes: `tessera similar` runs the `library` kind's cached stages
//! (a second run loads what the first computed; a scene's library of the same files shares
//! the features) and ranks as a scene's `similar(...)` does; `main.rs` only parses arguments.

mod common;

use std::path::Path;

use common::{parse_report, png, texture, Project, Stage};

/// A library `tex/` of four textures and a target `q.png`.
fn library() -> Project {
    let p = Project::new(&[]);
    p.write_bytes("q.png", &png(&texture(32, 32, 1)));
    for i in 0..4 {
        p.write_bytes(&format!("tex/t{i}.png"), &png(&texture(32, 32, 5 + i)));
    }
    p
}

/// Runs `tessera similar` with a stage report; returns the table and the stages.
fn similar(p: &Project, args: &[&str]) -> (String, Vec<Stage>) {
    let report = p.path("similar.json");
    let mut all = vec!["similar", "--report", report.to_str().expect("utf-8 path")];
    all.extend_from_slice(args);
    let run = p.tessera(&all);
    run.ok();
    let json: serde_json::Value = serde_json::from_slice(&p.read("similar.json")).expect("report is JSON");
    std::fs::remove_file(&report).expect("remove report");
    let stages = parse_report(&serde_json::json!({ "scenes": json["queries"] }).to_string());
    (run.stdout(), stages)
}

fn with_status<'a>(stages: &'a [Stage], status: &str) -> Vec<&'a str> {
    let mut v: Vec<&str> = stages.iter().filter(|s| s.status == status).map(|s| s.kind.as_str()).collect();
    v.sort();
    v
}

fn cache_entries(dir: &Path) -> usize {
    let Ok(shards) = std::fs::read_dir(dir) else { return 0 };
    shards
        .filter_map(|s| s.ok())
        .filter(|s| s.file_type().is_ok_and(|t| t.is_dir()))
        .map(|s| std::fs::read_dir(s.path()).map(|e| e.count()).unwrap_or(0))
        .sum()
}

#[test]
fn a_second_similar_loads_what_the_first_computed() {
    let p = library();
    let args = ["tex", "q.png", "-k", "3", "--size", "32"];
    let (first, stages) = similar(&p, &args);
    let features = ["library.features"; 5];
    assert_eq!(with_status(&stages, "ran"), [&features[..], &["library.index", "library.query"]].concat());
    let entries = cache_entries(&p.path(".tessera/cache"));
    assert_eq!(entries, 7, "four entries, the target, the index and the query");

    // The same query again: one cache entry loaded, nothing computed, nothing new stored.
    let (second, stages) = similar(&p, &args);
    assert_eq!(second, first);
    assert!(with_status(&stages, "ran").is_empty(), "{stages:?}");
    assert_eq!(with_status(&stages, "hit"), ["library.query"]);
    assert_eq!(cache_entries(&p.path(".tessera/cache")), entries);

    // Another query of the same directory reuses the index and the target's features.
    let (_, stages) = similar(&p, &["tex", "q.png", "-k", "2", "--size", "32"]);
    assert_eq!(with_status(&stages, "ran"), ["library.query"]);
    assert_eq!(with_status(&stages, "hit"), ["library.features", "library.index"]);

    // A new file: its features, the index and the query run; the other files' load.
    p.write_bytes("tex/t9.png", &png(&texture(32, 32, 42)));
    let (_, stages) = similar(&p, &args);
    assert_eq!(with_status(&stages, "ran"), ["library.features", "library.index", "library.query"]);
    assert_eq!(with_status(&stages, "hit"), vec!["library.features"; 5]);

    // Features are keyed by content: a copy of the target is loaded, and ranks first.
    p.write_bytes("tex/t10.png", &p.read("q.png"));
    let (table, stages) = similar(&p, &args);
    assert_eq!(with_status(&stages, "ran"), ["library.index", "library.query"]);
    assert!(table.lines().nth(1).is_some_and(|l| l.contains("t10.png") && l.contains("0.0000")), "{table}");
}

/// (name, distance) per row of a `tessera similar` table.
fn rows(table: &str) -> Vec<(String, f64)> {
    table
        .lines()
        .skip(1)
        .map(|l| {
            let cols: Vec<&str> = l.split_whitespace().collect();
            (cols[1].to_string(), cols[2].parse().expect("distance"))
        })
        .collect()
}

#[test]
fn similar_ranks_as_a_scene_does_and_shares_its_features() {
    let scene = r#"scene { size = 32 x 32 }
library lib { dir = "tex"  size = 32 }
sample q { image = "q.png" }
sample near { from = similar(lib, to = q, k = 4) }
output "near.json" { from = near }
"#;
    let p = library();
    p.write("scene.tess", scene);
    p.tessera(&["build", "scene.tess"]).ok();
    let ranking: serde_json::Value = serde_json::from_slice(&p.read("out/scene/near.json")).expect("ranking");
    let from_scene: Vec<(String, f64)> = ranking["candidates"]
        .as_array()
        .expect("candidates")
        .iter()
        .map(|c| (c["name"].as_str().expect("name").to_string(), c["distance"].as_f64().expect("distance")))
        .collect();

    let (table, stages) = similar(&p, &["tex", "q.png", "-k", "4", "--size", "32"]);
    let from_cli = rows(&table);
    assert_eq!(from_cli.len(), 4, "{table}");
    for ((a, da), (b, db)) in from_cli.iter().zip(&from_scene) {
        assert_eq!(a, b, "{table}\n{ranking}");
        assert!((da - db).abs() < 1e-4, "{a}: {da} from the command, {db} from the scene");
    }
    // The scene's features of the library files are the command's: only the target's
    // features (read as a file, not as a sample) and the query are new.
    assert_eq!(with_status(&stages, "ran"), ["library.features", "library.query"]);
    assert_eq!(with_status(&stages, "hit"), ["library.index"]);
}

#[test]
fn similar_errors_name_the_file_and_exit_1() {
    let p = library();
    p.write_bytes("tex/broken.png", b"\x89PNG\r\n\x1a\nnot really");
    let run = p.tessera(&["similar", "tex", "q.png"]);
    run.failed();
    assert!(run.stderr().starts_with("error: cannot decode `broken.png`: "), "{}", run.stderr());
    let run = p.tessera(&["similar", "tex", "q.png", "--fourier", "off", "--no-colour"]);
    run.failed();
    assert!(run.stderr().contains("error: cannot decode `broken.png`"), "{}", run.stderr());
    std::fs::remove_file(p.path("tex/broken.png")).unwrap();
    let run = p.tessera(&["similar", "tex", "q.png", "--fourier", "off", "--no-colour"]);
    run.failed();
    assert_eq!(run.stderr(), "error: every axis is off: enable colour, fourier or orientation\n");
    let run = p.tessera(&["similar", "tex", "missing.png"]);
    run.failed();
    assert_eq!(run.stderr(), "error: cannot read `missing.png`: No such file or directory (os error 2)\n");
}

#[test]
fn main_only_parses_arguments() {
    let main = std::fs::read_to_string(common::repo().join("src/main.rs")).expect("main.rs");
    let uses: Vec<&str> = main.lines().filter(|l| l.trim_start().starts_with("use ")).collect();
    for u in &uses {
        let ok = ["use std::", "use clap::", "use tessera::project::"].iter().any(|p| u.trim_start().starts_with(p));
        assert!(ok, "main.rs imports `{u}`: commands belong in tessera::project::commands");
    }
    assert!(!main.contains("tessera::synth") && !main.contains("tessera::graph") && !main.contains("tessera::lang"));
}
