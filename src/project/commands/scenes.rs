//! `tessera build`, `check` and `bless`: every named scene in turn, each built, claimed
//! against the others' outputs, written, then checked or blessed; a failing scene is
//! reported and the rest still run. With `--report`, the stage reports of all scenes go to
//! one JSON file.

use std::path::{Path, PathBuf};

use super::messages;
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

impl Mode {
    /// The command's name: `build`, `check` or `bless`.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Build => "build",
            Mode::Check => "check",
            Mode::Bless => "bless",
        }
    }
}

/// Builds the scenes named by `paths` (every scene of the repository when empty).
pub fn scenes(g: &Global, paths: &[PathBuf], mode: Mode) -> Outcome {
    let p = g.open()?;
    let scenes = p.scene_files(paths).map_err(|f| print_failed(&f))?;
    let mut failed = false;
    let mut rows = Vec::new();
    let mut reports = Vec::new();
    let mut claims = project::Claims::default();
    let mut tally = print::Tally { scenes: scenes.len(), ..Default::default() };
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
        print::warnings(Some(&built.name), &built.report);
        tally.outputs += emitted.len();
        tally.written += emitted.iter().filter(|e| e.written).count();
        print::built(g, &p, scene, &built, &emitted);
        reports.push(serde_json::json!({
            "scene": scene.display().to_string(),
            "millis": built.millis,
            "stages": built.report.stages,
        }));
        match mode {
            Mode::Build => {}
            Mode::Bless => match p.bless(&built) {
                Ok(paths) if messages::json() => messages::blessed(&built.name, &paths),
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
    tally.built = reports.len();
    print::summary(mode.name(), &tally, (mode == Mode::Check).then_some(&rows[..]), failed);
    if failed {
        Err(Reported)
    } else {
        Ok(())
    }
}

/// The `--report` file: `report` as pretty JSON.
pub(super) fn write_report(path: &Path, report: serde_json::Value) -> Outcome {
    let json = serde_json::to_string_pretty(&report).expect("report serialises");
    std::fs::write(path, json).map_err(|e| {
        eprintln!("error: cannot write the report to {}: {e}", path.display());
        Reported
    })
}
