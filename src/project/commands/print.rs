//! What the commands print about a build: diagnostics (rendered by miette, coloured only
//! on a terminal), stage warnings, the `check` table and one row as `review` shows it.

use miette::{GraphicalReportHandler, GraphicalTheme};

use super::Reported;
use crate::graph::Report;
use crate::lang::{self, Diagnostics};
use crate::project::{CheckRow, CheckStatus, Failed};

pub(super) fn print_failed(f: &Failed) -> Reported {
    diagnostics(&f.diagnostics);
    Reported
}

pub(super) fn diagnostics(d: &Diagnostics) {
    // Colour only on a terminal; plain unicode otherwise, so logs and tests read cleanly.
    let theme = if std::io::IsTerminal::is_terminal(&std::io::stderr()) && std::env::var_os("NO_COLOR").is_none() {
        GraphicalTheme::unicode()
    } else {
        GraphicalTheme::unicode_nocolor()
    };
    let handler = GraphicalReportHandler::new_themed(theme).with_width(100);
    for item in &d.items {
        let rendered = lang::diag::render(item, &d.sources);
        let mut out = String::new();
        if handler.render_report(&mut out, &rendered).is_ok() {
            eprintln!("{out}");
        } else {
            eprintln!("error: {}", item.message);
        }
    }
}

pub(super) fn warnings(report: &Report) {
    for s in &report.stages {
        for w in &s.warnings {
            eprintln!("warning: {}: {w}", s.label);
        }
    }
}

pub(super) fn check_table(rows: &[CheckRow]) {
    println!(
        "\n{:<6} {:<20} {:<28} {:>10} {:>10} {:>14}",
        "status", "scene", "output", "max diff", "tolerance", "failing px"
    );
    for r in rows {
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
