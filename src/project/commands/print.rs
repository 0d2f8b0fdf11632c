//! What the commands print about a build: diagnostics (rendered by miette, coloured only
//! on a terminal), stage warnings and the `check` table.

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
