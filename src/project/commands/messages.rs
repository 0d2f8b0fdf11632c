//! `--message-format json`: what the commands report (diagnostics, stages, outputs, check
//! results, a summary) as one JSON object per line on stdout, for scripts and editors. The
//! objects are made from the same data the human output prints (`Diagnostic`, the stage
//! `Report`, `Emitted`, `CheckRow`); their fields are documented in `docs/message-format.md`.

use std::io::Write;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

use serde_json::{json, Value};

use crate::graph::Report;
use crate::lang::diag::Diagnostic;
use crate::lang::source::{SourceMap, Span};
use crate::project::{CheckRow, Emitted};

/// How the commands report: text for people, or JSON lines for programs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MessageFormat {
    /// Rendered diagnostics on stderr, tables and summaries on stdout.
    #[default]
    Human,
    /// One JSON object per line on stdout (`docs/message-format.md`).
    Json,
}

static JSON: AtomicBool = AtomicBool::new(false);

/// Chooses how every command of this process reports (set once, by the command line).
pub fn set_message_format(format: MessageFormat) {
    JSON.store(format == MessageFormat::Json, Ordering::Relaxed);
}

/// Whether the commands report as JSON lines.
pub(super) fn json() -> bool {
    JSON.load(Ordering::Relaxed)
}

/// Prints one message: `value` on one line of stdout, flushed so a reader sees it at once.
pub(super) fn emit(value: Value) {
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "{value}");
    let _ = out.flush();
}

/// A diagnostic: its code, message and help, and each label at its file, line and column.
pub(super) fn diagnostic(d: &Diagnostic, sources: &SourceMap) -> Value {
    let labels: Vec<Value> = d
        .labels
        .iter()
        .map(|(span, text)| {
            let mut l = location(sources, *span);
            l["message"] = json!(text);
            l
        })
        .collect();
    let mut v = json!({
        "type": "diagnostic",
        "severity": "error",
        "code": d.code,
        "message": d.message,
        "file": null, "line": null, "column": null, "span": null,
        "labels": labels,
        "help": d.help,
    });
    if let Some(span) = d.primary_span() {
        for (k, x) in as_object(location(sources, span)) {
            v[k.as_str()] = x;
        }
    }
    v
}

fn as_object(v: Value) -> serde_json::Map<String, Value> {
    match v {
        Value::Object(m) => m,
        _ => serde_json::Map::new(),
    }
}

/// Where a span is: the file as shown to the user, 1-based line and column (in characters),
/// and the byte offsets into the file.
fn location(sources: &SourceMap, span: Span) -> Value {
    let f = sources.get(span.file);
    let start = floor_char_boundary(&f.text, span.start);
    let before = &f.text[..start];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before[line_start..].chars().count() + 1;
    json!({
        "file": f.display,
        "line": line,
        "column": column,
        "span": { "start": span.start, "end": span.end },
    })
}

fn floor_char_boundary(text: &str, at: usize) -> usize {
    let mut i = at.min(text.len());
    while !text.is_char_boundary(i) {
        i -= 1;
    }
    i
}

/// A warning a stage gave (in `scene`, when the stage belongs to one).
pub(super) fn stage_warning(scene: Option<&str>, stage: &str, message: &str) -> Value {
    json!({
        "type": "diagnostic",
        "severity": "warning",
        "code": "tessera::stage",
        "message": message,
        "scene": scene,
        "stage": stage,
        "file": null, "line": null, "column": null, "span": null,
        "labels": [],
        "help": null,
    })
}

/// One message per stage of a build: the `--report` record with its scene.
pub(super) fn stages(scene: &str, report: &Report) {
    for s in &report.stages {
        let mut v = json!({ "type": "stage", "scene": scene });
        for (k, x) in as_object(json!(s)) {
            v[k.as_str()] = x;
        }
        if v.get("warnings").is_none() {
            v["warnings"] = json!([]);
        }
        emit(v);
    }
}

/// One message per output of a scene: where it is and whether this build changed it.
pub(super) fn outputs(scene: &str, emitted: &[Emitted]) {
    for e in emitted {
        emit(json!({ "type": "output", "scene": scene, "path": path(&e.path), "written": e.written }));
    }
}

/// One message per golden `bless` wrote.
pub(super) fn blessed(scene: &str, paths: &[std::path::PathBuf]) {
    for p in paths {
        emit(json!({ "type": "blessed", "scene": scene, "path": path(p) }));
    }
}

/// A check result: the row of the check table, field for field.
pub(super) fn check(row: &CheckRow) {
    let mut v = json!({ "type": "check" });
    for (k, x) in as_object(json!(row)) {
        v[k.as_str()] = x;
    }
    emit(v);
}

fn path(p: &Path) -> String {
    p.display().to_string()
}
