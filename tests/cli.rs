//! The small commands: fmt, explain.

mod common;

use common::{repo, run_in, Project};

#[test]
fn fmt_is_idempotent_and_keeps_comments() {
    let messy = "# head\nmap   a{from=constant( 0.5 ) # why\n  invert=true}\noutput \"a.png\"{from=a}\n";
    let p = Project::new(&[("scene.tess", messy)]);
    p.tessera(&["fmt", "--check", "scene.tess"]).failed();
    p.tessera(&["fmt", "scene.tess"]).ok();
    let once = String::from_utf8(p.read("scene.tess")).expect("utf-8");
    assert!(once.contains("# head") && once.contains("# why"));
    p.tessera(&["fmt", "scene.tess"]).ok();
    assert_eq!(String::from_utf8(p.read("scene.tess")).expect("utf-8"), once);
    p.tessera(&["fmt", "--check", "scene.tess"]).ok();
    // The formatted scene still builds.
    p.tessera(&["build", "scene.tess"]).ok();
}

#[test]
fn bundled_scenes_are_formatted() {
    run_in(&repo(), &["fmt", "--check", "scenes", "scenes/_common.tess"]).ok();
}

#[test]
fn explain_prints_every_property() {
    let run = run_in(&repo(), &["explain", "map"]);
    run.ok();
    for word in ["from", "blur", "threshold", "invert", "remap", "noise(", "radial(", "default"] {
        assert!(run.stdout().contains(word), "missing {word}:\n{}", run.stdout());
    }
    run_in(&repo(), &["explain"]).ok();
    let bad = run_in(&repo(), &["explain", "mapp"]);
    bad.failed();
    assert!(bad.stderr().contains("did you mean `map`"), "{}", bad.stderr());
}

#[test]
fn language_reference_is_current() {
    let run = run_in(&repo(), &["explain", "--markdown"]);
    run.ok();
    let doc = std::fs::read_to_string(repo().join("docs/language.md")).expect("docs/language.md");
    let start = doc.find("<!-- reference:start -->\n").expect("start marker") + "<!-- reference:start -->\n".len();
    let end = doc.find("<!-- reference:end -->").expect("end marker");
    assert!(
        doc[start..end] == run.stdout(),
        "docs/language.md's reference is stale: regenerate it with `cargo run -- explain --markdown`"
    );
}
