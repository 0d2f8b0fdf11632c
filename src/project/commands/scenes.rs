//! `tessera build`, `check` and `bless`: every named scene in turn, each built, claimed
//! against the others' outputs, written, then checked or blessed; a failing scene is
//! reported and the rest still run. With `--report`, the stage reports of all scenes go to
//! one JSON file.

use std::path::{Path, PathBuf};

use super::print::{self, print_failed};
use super::{Global, Outcome, Reported};
use crate::project::{self, CheckStatus};

/// What happens to a scene once it is built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Write its outputs.
    Build,
    /// Write its outputs and compare them with the goldens.
    Check,
    /// Write its outputs and make them the goldens.
    Bless,
}

/// Builds the scenes named by `paths` (every scene of the repository when empty).
pub fn scenes(g: &Global, paths: &[PathBuf], mode: Mode) -> Outcome {
    let mut p = g.open()?;
    let scenes = p.scene_files(paths).map_err(|f| print_failed(&f))?;
    p.sets_may_miss = true;
    takers_of_sets(&p, &scenes, g.quiet)?;
    let mut failed = false;
    let mut rows = Vec::new();
    let mut reports = Vec::new();
    let mut claims = project::Claims::default();
    for scene in &scenes {
        p.world.begin_build();
        let built = match p.build(scene) {
            Ok(b) => b,
            Err(f) => {
                print_failed(&f);
                failed = true;
                continue;
            }
        };
        if let Err(f) = claims.claim(&built) {
            print_failed(&f);
            failed = true;
            continue;
        }
        let emitted = match p.emit(&built) {
            Ok(e) => e,
            Err(f) => {
                print_failed(&f);
                failed = true;
                continue;
            }
        };
        print::warnings(&built.report);
        if !g.quiet {
            let ran = built.report.ran().count();
            let written = emitted.iter().filter(|e| e.written).count();
            println!(
                "{}: {} stages, {} ran, {} cached; {} of {} outputs written ({:.1} ms)",
                scene.display(),
                built.report.stages.len(),
                ran,
                built.report.stages.len() - ran,
                written,
                emitted.len(),
                built.millis
            );
            if g.timings {
                print!("{}", project::timings_table(&built.report));
            }
        }
        reports.push(serde_json::json!({
            "scene": scene.display().to_string(),
            "millis": built.millis,
            "stages": built.report.stages,
        }));
        match mode {
            Mode::Build => {}
            Mode::Bless => match p.bless(&built) {
                Ok(paths) => {
                    if !g.quiet {
                        for path in paths {
                            println!("  blessed {}", path.display());
                        }
                    }
                }
                Err(f) => {
                    print_failed(&f);
                    failed = true;
                }
            },
            Mode::Check => match p.check(&built) {
                Ok(r) => rows.extend(r),
                Err(f) => {
                    print_failed(&f);
                    failed = true;
                }
            },
        }
    }
    if let Some(path) = &g.report {
        if write_report(path, serde_json::json!({ "scenes": reports })).is_err() {
            failed = true;
        }
    }
    if mode == Mode::Check {
        print::check_table(&rows);
        if rows.iter().any(|r| r.status != CheckStatus::Pass) {
            failed = true;
        }
    }
    if failed {
        Err(Reported)
    } else {
        Ok(())
    }
}

/// Which of `scenes` declare each `--set` param: a set no scene takes is an error (a typo
/// would otherwise go unnoticed); the others say which scenes took them. A scene that does
/// not compile is left to the build to report.
fn takers_of_sets(p: &project::Project, scenes: &[PathBuf], quiet: bool) -> Outcome {
    if p.sets.is_empty() {
        return Ok(());
    }
    let declared: Vec<(&PathBuf, Vec<String>)> =
        scenes.iter().filter_map(|s| p.compile(s).ok().map(|(scene, _)| (s, scene.params))).collect();
    let mut unknown = Vec::new();
    for (name, value) in &p.sets {
        let takers: Vec<String> =
            declared.iter().filter(|(_, params)| params.contains(name)).map(|(s, _)| s.display().to_string()).collect();
        if takers.is_empty() {
            unknown.push(name.as_str());
        } else if !quiet {
            println!("--set {name}={value}: taken by {}", takers.join(", "));
        }
    }
    if unknown.is_empty() {
        return Ok(());
    }
    let all: Vec<&str> = declared.iter().flat_map(|(_, params)| params.iter().map(|p| p.as_str())).collect();
    for name in unknown {
        let who = if scenes.len() == 1 { "the scene declares no" } else { "no scene declares" };
        eprintln!("error: `--set {name}=…`: {who} `param {name}`");
        if let Some(s) = crate::lang::diag::suggest(name, all.iter().copied()) {
            eprintln!("  help: did you mean `{s}`?");
        }
    }
    Err(Reported)
}

/// The `--report` file: `report` as pretty JSON.
pub(super) fn write_report(path: &Path, report: serde_json::Value) -> Outcome {
    let json = serde_json::to_string_pretty(&report).expect("report serialises");
    std::fs::write(path, json).map_err(|e| {
        eprintln!("error: cannot write the report to {}: {e}", path.display());
        Reported
    })
}
