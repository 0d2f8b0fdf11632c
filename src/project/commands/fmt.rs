//! `tessera fmt`: rewrites scene files in the canonical layout, or with `--check` only
//! names those that are not.

use std::path::PathBuf;

use super::messages;
use super::print::{self, print_failed};
use super::{Global, Outcome, Reported};
use crate::lang::{self, Diagnostics};

/// Formats the scenes named by `paths` (every scene of the repository when empty).
pub fn fmt(g: &Global, paths: &[PathBuf], check: bool) -> Outcome {
    let p = g.open()?;
    let max_file = p.budget.max_file();
    let files = p.scene_files(paths).map_err(|f| print_failed(&f))?;
    let mut bad = false;
    for file in files {
        let text = match crate::graph::world::read_regular_text(&file, max_file) {
            Ok(t) => t,
            Err(e) => {
                eprintln!("error: cannot read {}: {e}", file.display());
                bad = true;
                continue;
            }
        };
        match lang::fmt::format_source(&text) {
            Ok(formatted) if formatted == text => {}
            Ok(_) if check => {
                if messages::json() {
                    messages::emit(serde_json::json!({ "type": "unformatted", "path": file.display().to_string() }));
                } else {
                    println!("not formatted: {}", file.display());
                }
                bad = true;
            }
            Ok(formatted) => {
                if let Err(e) = crate::project::format::rewrite_scene(&file, &formatted) {
                    eprintln!("error: {e}");
                    bad = true;
                } else if messages::json() {
                    messages::emit(serde_json::json!({ "type": "formatted", "path": file.display().to_string() }));
                } else if !g.quiet {
                    println!("formatted {}", file.display());
                }
            }
            Err(d) => {
                let mut sources = lang::source::SourceMap::default();
                sources.add(file.clone(), file.display().to_string(), text.into());
                print::diagnostics(&Diagnostics::new(vec![d], sources));
                bad = true;
            }
        }
    }
    if bad {
        Err(Reported)
    } else {
        Ok(())
    }
}
