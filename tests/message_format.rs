//! `--message-format json`: every line of stdout is one JSON object with the documented
//! fields (docs/message-format.md), for a scene with an error, a build and a failing check.

mod common;

use common::{Project, Run};
use serde_json::Value;

const SCENE: &str = r#"
scene { size = 32 x 24 }

map mask { from = rect(at = [4, 4], size = [12, 8]) }
map soft {
  from = mask
  blur = 1 px
}

output "mask.png" { from = mask }
output "soft.png" { from = soft }
"#;

/// Every line of stdout parsed as a JSON object; nothing else may be printed there.
fn messages(run: &Run) -> Vec<Value> {
    run.stdout()
        .lines()
        .map(|l| {
            let v: Value = serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON ({e}): {l}"));
            assert!(v["type"].is_string(), "no type: {l}");
            v
        })
        .collect()
}

fn of_type<'a>(all: &'a [Value], ty: &str) -> Vec<&'a Value> {
    all.iter().filter(|v| v["type"] == ty).collect()
}

#[test]
fn a_scene_with_an_error_is_a_diagnostic_with_its_place() {
    let bad = SCENE.replace("blur = 1 px", "blurr = 1 px");
    let p = Project::new(&[("scene.tess", &bad)]);
    let run = p.tessera(&["--message-format", "json", "build", "scene.tess"]);
    run.failed();
    let all = messages(&run);
    let diags = of_type(&all, "diagnostic");
    assert_eq!(diags.len(), 1, "{all:#?}");
    let d = diags[0];
    assert_eq!(d["severity"], "error");
    assert!(d["code"].as_str().expect("code").starts_with("tessera::"), "{d}");
    assert!(d["message"].as_str().expect("message").contains("blurr"), "{d}");
    assert_eq!(d["file"], "scene.tess");
    assert_eq!(d["line"], 7);
    assert_eq!(d["column"], 3);
    let (start, end) = (d["span"]["start"].as_u64().expect("start"), d["span"]["end"].as_u64().expect("end"));
    assert_eq!(&bad[start as usize..end as usize], "blurr");
    assert_eq!(d["labels"][0]["line"], 7, "{d}");
    assert!(d["help"].as_str().is_some_and(|h| h.contains("blur")), "{d}");
    let summary = of_type(&all, "summary");
    assert_eq!(summary.len(), 1);
    assert_eq!(summary[0]["success"], false);
    assert_eq!(summary[0]["scenes_built"], 0);
    assert!(run.stderr().is_empty(), "{}", run.stderr());
}

#[test]
fn a_build_reports_its_stages_and_outputs() {
    let p = Project::new(&[("scene.tess", SCENE)]);
    let run = p.tessera(&["--message-format", "json", "build", "scene.tess"]);
    run.ok();
    let all = messages(&run);
    let stages = of_type(&all, "stage");
    assert!(!stages.is_empty());
    for s in &stages {
        assert_eq!(s["scene"], "scene");
        for field in ["label", "kind", "key", "status"] {
            assert!(s[field].is_string(), "{field} in {s}");
        }
        assert!(s["millis"].is_number() && s["warnings"].is_array(), "{s}");
    }
    let outputs = of_type(&all, "output");
    assert_eq!(outputs.len(), 2);
    assert!(outputs.iter().all(|o| o["written"] == true && o["path"].as_str().is_some_and(|p| p.ends_with(".png"))));
    let summary = of_type(&all, "summary");
    assert_eq!(summary.len(), 1);
    assert_eq!(all.last(), Some(summary[0]), "the summary comes last");
    assert_eq!(summary[0]["command"], "build");
    assert_eq!(summary[0]["success"], true);
    assert_eq!(summary[0]["written"], 2);
    // A second build writes nothing and says so.
    let again = messages(p.tessera(&["--message-format", "json", "build", "scene.tess"]).ok());
    assert!(of_type(&again, "output").iter().all(|o| o["written"] == false));
    assert!(of_type(&again, "stage").iter().all(|s| s["status"] != "ran"));
}

#[test]
fn a_failing_check_reports_each_output() {
    let p = Project::new(&[("scene.tess", SCENE)]);
    p.tessera(&["-q", "bless", "scene.tess"]).ok();
    std::fs::remove_file(p.path("golden/scene/soft.png")).expect("remove a golden");
    p.write("scene.tess", &SCENE.replace("size = [12, 8]", "size = [14, 8]"));
    let run = p.tessera(&["--message-format", "json", "check", "scene.tess"]);
    run.failed();
    let all = messages(&run);
    let checks = of_type(&all, "check");
    assert_eq!(checks.len(), 2, "{all:#?}");
    let by = |o: &str| *checks.iter().find(|c| c["output"] == o).unwrap_or_else(|| panic!("no check of {o}"));
    let mask = by("mask.png");
    assert_eq!(mask["status"], "fail");
    assert_eq!(mask["scene"], "scene");
    assert!(mask["max_abs"].as_f64().expect("max_abs") > 0.0);
    assert!(mask["failing_pixels"].as_u64().expect("failing_pixels") > 0);
    assert!(mask["diff"].is_string(), "{mask}");
    assert_eq!(by("soft.png")["status"], "missing");
    // Each failure is also a diagnostic at its output's name, for editors.
    let diagnostics = of_type(&all, "diagnostic");
    let at =
        |code: &str| *diagnostics.iter().find(|d| d["code"] == code).unwrap_or_else(|| panic!("no {code}: {all:#?}"));
    let differs = at("tessera::check::differs");
    assert_eq!(
        (differs["file"].as_str(), differs["line"].as_u64(), differs["column"].as_u64()),
        (Some("scene.tess"), Some(10), Some(8))
    );
    assert!(differs["help"].as_str().is_some_and(|h| h.contains("diff image")), "{differs}");
    let missing = at("tessera::check::missing");
    assert_eq!((missing["line"].as_u64(), missing["column"].as_u64()), (Some(11), Some(8)), "{missing}");
    let summary = of_type(&all, "summary");
    assert_eq!(summary[0]["checks"], serde_json::json!({ "pass": 0, "fail": 1, "missing": 1 }));
    assert_eq!(summary[0]["success"], false);
}

#[test]
fn fmt_and_gc_speak_json_too() {
    let p = Project::new(&[("scene.tess", &SCENE.replace("  blur = 1 px", "blur=1 px"))]);
    let check = p.tessera(&["--message-format", "json", "fmt", "--check", "scene.tess"]);
    check.failed();
    let all = messages(&check);
    assert_eq!(of_type(&all, "unformatted").len(), 1, "{all:#?}");
    assert_eq!(all[0]["path"], "scene.tess");
    let all = messages(p.tessera(&["--message-format", "json", "fmt", "scene.tess"]).ok());
    assert_eq!(of_type(&all, "formatted").len(), 1, "{all:#?}");

    p.tessera(&["-q", "build", "scene.tess"]).ok();
    p.write("scene.tess", &SCENE.replace("blur = 1 px", "blur = 2 px"));
    p.tessera(&["-q", "build", "scene.tess"]).ok();
    let all = messages(p.tessera(&["--message-format", "json", "gc"]).ok());
    assert_eq!(all.len(), 1, "{all:#?}");
    let gc = &all[0];
    assert_eq!(gc["type"], "gc");
    assert!(gc["removed"].as_u64().expect("removed") >= 1, "the blur-1 stages are garbage: {gc}");
    assert!(gc["kept"].as_u64().expect("kept") >= 1, "{gc}");
    assert!(gc["freed_bytes"].as_u64().expect("freed_bytes") > 0, "{gc}");
    assert_eq!(gc["foreign"], serde_json::json!([]));
}
