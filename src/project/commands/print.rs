//! What the commands print about a build: diagnostics (rendered by miette, coloured only
//! on a terminal), stage warnings, where a scene's outputs went, the `check` table and one
//! row as `review` shows it; with `--message-format json`, the same as JSON lines (`messages`).

use std::path::Path;

use miette::GraphicalTheme;
use serde_json::json;

use super::messages;
use super::{Global, Reported};
use crate::graph::Report;
use crate::lang::Diagnostics;
use crate::project::{self, Built, CheckRow, CheckStatus, Emitted, Failed, Project};

pub(super) fn print_failed(f: &Failed) -> Reported {
    diagnostics(&f.diagnostics);
    Reported
}

pub(super) fn diagnostics(d: &Diagnostics) {
    if messages::json() {
        for item in &d.items {
            messages::emit(messages::diagnostic(item, &d.sources));
        }
        return;
    }
    // Colour only on a terminal; plain unicode otherwise, so logs and tests read cleanly.
    let theme = if std::io::IsTerminal::is_terminal(&std::io::stderr()) && std::env::var_os("NO_COLOR").is_none() {
        GraphicalTheme::unicode()
    } else {
        GraphicalTheme::unicode_nocolor()
    };
    for drawn in d.draw(theme, 100) {
        eprintln!("{drawn}");
    }
}

/// The warnings of a build's stages (of `scene`, when they belong to one), on stderr.
pub(super) fn warnings(scene: Option<&str>, report: &Report) {
    for s in &report.stages {
        for w in &s.warnings {
            if messages::json() {
                messages::emit(messages::stage_warning(scene, &s.label, w));
            } else {
                eprintln!("warning: {}: {w}", s.label);
            }
        }
    }
}

/// The one warning of a remote cache that failed (once per process: the remote is off from
/// then on).
pub(super) fn remote_warning(p: &Project) {
    let Some(w) = p.remote.as_ref().and_then(|r| r.take_warning()) else { return };
    if messages::json() {
        let mut v = messages::stage_warning(None, "remote cache", &w);
        v["code"] = "tessera::remote".into();
        messages::emit(v);
    } else {
        eprintln!("warning: {w}");
    }
}

/// What one scene's build did: its stages and where its outputs went (unless `-q`), with
/// `--timings` each stage's time.
pub(super) fn built(g: &Global, p: &Project, scene: &Path, built: &Built, emitted: &[Emitted]) {
    if messages::json() {
        messages::stages(&built.name, &built.report);
        messages::outputs(&built.name, emitted);
        return;
    }
    if g.quiet {
        return;
    }
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
    let dir = p.outputs_dir(&built.name);
    let dir = dir.strip_prefix(".").unwrap_or(&dir);
    match written {
        0 => println!("  outputs unchanged in {}/", dir.display()),
        1 => println!("  wrote 1 output to {}/", dir.display()),
        n => println!("  wrote {n} outputs to {}/", dir.display()),
    }
    if g.timings {
        print!("{}", project::timings_table(&built.report));
    }
}

/// What `build`, `check` and `bless` add up to, counted over their scenes.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Tally {
    pub scenes: usize,
    pub built: usize,
    pub outputs: usize,
    pub written: usize,
}

/// The last message of `--message-format json` (nothing in human format, whose summary
/// lines come as the scenes are built).
/// `checks` are the rows of `check`, `None` for the other commands.
pub(super) fn summary(command: &str, t: &Tally, checks: Option<&[CheckRow]>, failed: bool) {
    if !messages::json() {
        return;
    }
    let mut v = json!({
        "type": "summary",
        "command": command,
        "success": !failed,
        "scenes": t.scenes,
        "scenes_built": t.built,
        "outputs": t.outputs,
        "written": t.written,
    });
    if let Some(rows) = checks {
        let count = |s: CheckStatus| rows.iter().filter(|r| r.status == s).count();
        v["checks"] = json!({
            "pass": count(CheckStatus::Pass),
            "fail": count(CheckStatus::Fail),
            "missing": count(CheckStatus::Missing),
        });
    }
    messages::emit(v);
}

/// The check results as a table; with `-q`, only the rows that did not pass (and nothing
/// at all when every output passed).
pub(super) fn check_table(rows: &[CheckRow], quiet: bool) {
    if messages::json() {
        rows.iter().for_each(messages::check);
        return;
    }
    let shown: Vec<&CheckRow> = rows.iter().filter(|r| !quiet || r.status != CheckStatus::Pass).collect();
    if shown.is_empty() {
        return;
    }
    println!(
        "\n{:<6} {:<20} {:<28} {:>10} {:>10} {:>14}",
        "status", "scene", "output", "max diff", "tolerance", "failing px"
    );
    for r in shown {
        let status = match r.status {
            CheckStatus::Pass => "ok",
            CheckStatus::Fail => "FAIL",
            CheckStatus::Missing => "MISS",
        };
        println!(
            "{:<6} {:<20} {:<28} {:>10.5} {:>10.5} {:>14}",
            status,
            r.scene,
            r.output,
            r.max_abs,
            r.tolerance,
            format!("{}/{}", r.failing_pixels, r.total_pixels)
        );
        if r.exact {
            println!("       compared exactly: its values are identities");
        } else if let (Some(bits), Some(tol)) = (r.bits, r.tolerance_steps) {
            if r.status == CheckStatus::Fail {
                println!(
                    "       in {bits}-bit steps: max diff {}, tolerance {tol} (the fraction rounded down to whole steps)",
                    r.max_steps.unwrap_or(0)
                );
            }
        }
        if let Some(n) = &r.note {
            println!("       {n}");
        }
        if let Some(d) = &r.diff {
            println!("       diff image: {}", d.display());
        }
    }
    let pass = rows.iter().filter(|r| r.status == CheckStatus::Pass).count();
    println!("\ncheck: {} passed, {} failed", pass, rows.len() - pass);
}

/// One check row as `review` shows it: scene, output, status, the numbers the check
/// computed, its note (a mesh's Hausdorff distance, a size mismatch) and the diff image.
pub(super) fn row_summary(r: &CheckRow) -> String {
    let status = match r.status {
        CheckStatus::Pass => "passes",
        CheckStatus::Fail => "FAILS",
        CheckStatus::Missing => "has no golden",
    };
    let mut s = format!("scene `{}`, output `{}` {status}", r.scene, r.output);
    if r.status == CheckStatus::Fail {
        let share = if r.total_pixels > 0 { 100.0 * r.failing_pixels as f64 / r.total_pixels as f64 } else { 0.0 };
        s += &format!(
            "\n  max diff {:.5}, tolerance {:.5}; beyond it: {}/{} ({share:.3} %)",
            r.max_abs, r.tolerance, r.failing_pixels, r.total_pixels
        );
        if let (Some(bits), Some(steps)) = (r.bits, r.max_steps) {
            s += &format!("\n  in {bits}-bit steps: max diff {steps}, tolerance {}", r.tolerance_steps.unwrap_or(0));
        }
        if r.exact {
            s += "\n  compared exactly: its values are identities";
        }
    }
    if let Some(n) = &r.note {
        s += &format!("\n  {n}");
    }
    if let Some(d) = &r.diff {
        s += &format!("\n  diff image: {}", shown(d).display());
    }
    s
}

/// A path as shown in messages, without `.` components (`././scene.tess` is `scene.tess`).
pub(super) fn shown(path: &std::path::Path) -> std::path::PathBuf {
    path.components().filter(|c| !matches!(c, std::path::Component::CurDir)).collect()
}
