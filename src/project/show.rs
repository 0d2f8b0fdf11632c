//! Text renderings: the stage graph (text and DOT) and the timings table.

use std::fmt::Write;

use crate::graph::budget::Bytes;
use crate::graph::{Cache, Key, Report, Status};
use crate::kinds::Plan;

/// The DAG as indented text, one node per line with its inputs and cache state.
pub fn graph_text(plan: &Plan, keys: &[Key], cache: &Cache) -> String {
    let mut s = String::new();
    for (i, n) in plan.graph.nodes.iter().enumerate() {
        let state = if cache.contains(&keys[i]) { "cached" } else { "stale" };
        let inputs: Vec<String> = n.inputs.iter().map(|j| format!("#{j}")).collect();
        let _ = write!(s, "#{i:<3} {:<7} {:<16} {:<36} {}", state, n.stage.kind(), n.label, keys[i].short());
        if !inputs.is_empty() {
            let _ = write!(s, "  <- {}", inputs.join(", "));
        }
        for f in &n.files {
            let _ = write!(s, "  [{}]", f.display());
        }
        s.push('\n');
    }
    s
}

/// The DAG in Graphviz DOT; cached stages green, stale ones orange.
pub fn graph_dot(plan: &Plan, keys: &[Key], cache: &Cache) -> String {
    let mut s =
        String::from("digraph tessera {\n  rankdir=LR;\n  node [shape=box, style=filled, fontname=\"monospace\"];\n");
    for (i, n) in plan.graph.nodes.iter().enumerate() {
        let colour = if cache.contains(&keys[i]) { "palegreen" } else { "orange" };
        let label = format!("{}\\n{}", n.label.replace('"', "\\\""), n.stage.kind());
        let _ = writeln!(s, "  n{i} [label=\"{label}\", fillcolor={colour}];");
        for j in &n.inputs {
            let _ = writeln!(s, "  n{j} -> n{i};");
        }
    }
    s.push_str("}\n");
    s
}

/// Per-stage times and cache state, for `--timings`: where each stage came from (`local`
/// and `memory` caches, the `remote` one, `ran`, `rebuilt` over a damaged entry, or `fresh`,
/// not needed) and the bytes it moved to or from a remote cache.
pub fn timings_table(report: &Report) -> String {
    let mut s = String::new();
    for r in &report.stages {
        let state = match r.status {
            Status::Fresh => "fresh",
            Status::Hit => "local",
            Status::Remote => "remote",
            Status::Memory => "memory",
            Status::Ran => "ran",
            Status::Rebuilt => "rebuilt",
        };
        let moved = match (r.bytes_down, r.bytes_up) {
            (0, 0) => String::new(),
            (down, 0) => format!("  ↓ {}", Bytes(down as f64)),
            (0, up) => format!("  ↑ {}", Bytes(up as f64)),
            (down, up) => format!("  ↓ {} ↑ {}", Bytes(down as f64), Bytes(up as f64)),
        };
        let _ = writeln!(s, "  {:>9.2} ms  {:<7} {:<16} {}{moved}", r.millis, state, r.kind, r.label);
    }
    s
}
