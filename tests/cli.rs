//! The small commands: fmt, explain, completions, man.

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

#[test]
fn bash_completions_name_the_subcommands() {
    let run = run_in(&repo(), &["completions", "bash"]);
    run.ok();
    for sub in ["build", "check", "bless", "watch", "explain", "completions", "man", "--message-format"] {
        assert!(run.stdout().contains(sub), "no {sub} in the bash completions");
    }
    for shell in ["zsh", "fish", "elvish", "powershell"] {
        let run = run_in(&repo(), &["completions", shell]);
        run.ok();
        assert!(run.stdout().contains("tessera"), "{shell}");
    }
}

#[test]
fn the_man_page_is_roff() {
    let run = run_in(&repo(), &["man"]);
    run.ok();
    // The title header is the first line after the page's string definitions (`.ie`/`.el`).
    let first = run.stdout().lines().find(|l| !l.starts_with(".ie") && !l.starts_with(".el")).map(str::to_owned);
    assert!(first.as_deref().is_some_and(|l| l.starts_with(".TH tessera 1")), "{first:?}");
    assert!(run.stdout().contains("message\\-format"), "the global options are documented");
}

#[test]
fn quiet_is_honoured_by_every_command_that_reports() {
    let p = Project::new(&[(
        "scene.tess",
        "scene { size = 16 x 16 }\nmap m { from = constant(0.5) }\noutput \"m.png\" { from = m }\n",
    )]);
    for args in [
        &["-q", "build", "scene.tess"][..],
        &["-q", "bless", "scene.tess"],
        &["-q", "check", "scene.tess"],
        &["-q", "fmt", "scene.tess"],
        &["-q", "gc"],
    ] {
        let run = p.tessera(args);
        run.ok();
        assert_eq!(run.stdout(), "", "{args:?} printed on stdout");
        assert_eq!(run.stderr(), "", "{args:?} printed on stderr");
    }
    // A failing check still says what failed, and only that.
    p.write("scene.tess", "scene { size = 16 x 16 }\nmap m { from = constant(0.6) }\noutput \"m.png\" { from = m }\n");
    let run = p.tessera(&["-q", "check", "scene.tess"]);
    run.failed();
    assert!(run.stdout().contains("FAIL") && run.stdout().contains("m.png"), "{}", run.stdout());
    assert!(run.stdout().contains("check: 0 passed, 1 failed"), "{}", run.stdout());
}
