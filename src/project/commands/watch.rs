//! `tessera watch` on a terminal: one line per rebuild (what ran, what was written), the
//! diagnostics of a failed one, flushed at once so a reader sees each rebuild as it lands.

use std::io::Write;
use std::path::Path;
use std::time::Duration;

use super::messages;
use super::print::{self, print_failed};
use super::{Global, Outcome};
use crate::graph::Status;
use crate::project::{self, WatchEvent};

/// Builds `scene`, then rebuilds it whenever a file it read changes; returns only when the
/// project cannot be opened.
pub fn watch(g: &Global, scene: &Path, debounce: Duration) -> Outcome {
    let mut p = g.open()?;
    let (quiet, timings) = (g.quiet, g.timings);
    project::watch(&mut p, scene, debounce, |ev| {
        match ev {
            WatchEvent::Built { built, emitted, millis } => {
                print::warnings(Some(&built.name), &built.report);
                if messages::json() {
                    messages::stages(&built.name, &built.report);
                    messages::outputs(&built.name, emitted);
                    messages::emit(serde_json::json!({ "type": "summary", "command": "watch", "success": true }));
                } else if !quiet {
                    let ran: Vec<String> = built
                        .report
                        .stages
                        .iter()
                        .filter(|s| matches!(s.status, Status::Ran | Status::Rebuilt))
                        .map(|s| s.label.clone())
                        .collect();
                    let written = emitted.iter().filter(|e| e.written).count();
                    println!(
                        "[watch] built {} in {:.1} ms: ran {} stage(s){}; {} output(s) written",
                        scene.display(),
                        millis,
                        ran.len(),
                        if ran.is_empty() { String::new() } else { format!(" ({})", ran.join(", ")) },
                        written
                    );
                    if timings {
                        print!("{}", project::timings_table(&built.report));
                    }
                }
            }
            WatchEvent::Failed { failed } => {
                print_failed(failed);
                if messages::json() {
                    messages::emit(serde_json::json!({ "type": "summary", "command": "watch", "success": false }));
                } else {
                    println!("[watch] build failed; keeping the previous outputs");
                }
            }
            WatchEvent::Warning(w) => eprintln!("warning: {w}"),
        }
        let _ = std::io::stdout().flush();
    });
    Ok(())
}
