//! `tessera watch` on a terminal: one line per rebuild (what ran, what was written), the
//! diagnostics of a failed one, flushed at once so a reader sees each rebuild as it lands;
//! with `--serve`, the same rebuilds on the preview page.

use std::io::Write;
use std::path::Path;
use std::time::Duration;

use super::messages;
use super::print::{self, print_failed};
use super::{Global, Outcome, Reported};
use crate::graph::Status;
use crate::project::preview::{failed_view, Preview};
use crate::project::{self, WatchEvent};

/// Builds `scene`, then rebuilds it whenever a file it read changes; returns only when the
/// project cannot be opened or the preview cannot be served on `serve`.
pub fn watch(g: &Global, scene: &Path, debounce: Duration, serve: Option<&str>) -> Outcome {
    let mut p = g.open()?;
    let preview = match serve.map(Preview::start).transpose() {
        Ok(preview) => preview,
        Err(e) => {
            eprintln!("error: {e}");
            return Err(Reported);
        }
    };
    if let Some(preview) = &preview {
        if !preview.addr.ip().is_loopback() {
            eprintln!("warning: the preview is served on {}: anyone who can reach it sees the outputs", preview.addr);
        }
        if messages::json() {
            messages::emit(serde_json::json!({ "type": "preview", "url": preview.url() }));
        } else {
            println!("[watch] preview at {}", preview.url());
        }
        let _ = std::io::stdout().flush();
    }
    let (quiet, timings) = (g.quiet, g.timings);
    project::watch(&mut p, scene, debounce, |project, ev| {
        match ev {
            WatchEvent::Built { built, emitted, millis } => {
                if let Some(preview) = &preview {
                    // The page shows the goldens and the differences beside the outputs.
                    let rows = project.check(built).unwrap_or_default();
                    let view = project.scene_view(built, &rows, &mut preview.links(&project.root));
                    preview.publish(view, Some(project.preview_files()));
                }
                print::warnings(Some(&built.name), &built.report);
                print::remote_warning(project);
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
                if let Some(preview) = &preview {
                    preview.publish(failed_view(scene, preview.scene(), failed), None);
                }
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
