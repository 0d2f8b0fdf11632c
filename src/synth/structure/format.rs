//! The structure file format ([references: frasson §3.1]): parsing (with validation) and writing.
//!
//! A structure is a JSON object in pixel units with `y` pointing down:
//!
//! ```json
//! {
//!   "units": "px",
//!   "size": [640, 480],
//!   "vertices": [[10.0, 12.5], [80, 12.5], [80, 60]],
//!   "edges": [[0, 1], [1, 2], [2, 0]]
//! }
//! ```
//!
//! * `units` is optional; when present it must be `"px"`.
//! * `size` is optional (`[width, height]`, both positive); it is the sample's extent and is
//!   used to flag regions that touch the sample border.
//! * `vertices` are `[x, y]` pairs; `edges` are pairs of vertex indices (0-based).
//! * Unknown keys are rejected, so a typo (`"edge"`) is reported instead of ignored.
//!
//! [`parse_structure`] parses and validates: indices in range, no self-loops, no two
//! vertices closer than [`VERTEX_EPS`](super::error::VERTEX_EPS), no crossing or overlapping edges, and at least one
//! closed region once dangling edges are pruned. Duplicate edges and dangling edges are not
//! errors; [`super::validate::clean`] removes them and reports what it removed.

use super::error::StructureError;
use super::types::{round_to, Subdivision};
use super::validate;
use serde::Deserialize;
use std::fmt::Write as _;

/// The largest coordinate a structure file may hold, in pixels (the largest image side).
pub const MAX_COORD: f64 = 16384.0;

/// A parsed structure file: the subdivision and the optional sample size.
#[derive(Clone, Debug, PartialEq)]
pub struct StructureFile {
    pub size: Option<[f64; 2]>,
    pub subdivision: Subdivision,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawStructure {
    #[serde(default)]
    units: Option<String>,
    #[serde(default)]
    size: Option<[f64; 2]>,
    vertices: Vec<[f64; 2]>,
    edges: Vec<[usize; 2]>,
}

/// Parses and validates a structure (see the module documentation for the format and the
/// checks). The sample size, if given, is dropped; use [`parse_structure_file`] to keep it.
pub fn parse_structure(text: &str) -> Result<Subdivision, StructureError> {
    parse_structure_file(text).map(|f| f.subdivision)
}

/// Like [`parse_structure`] but also returns the optional `size`.
pub fn parse_structure_file(text: &str) -> Result<StructureFile, StructureError> {
    let raw: RawStructure = serde_json::from_str(text).map_err(|e| StructureError::Json {
        line: e.line(),
        column: e.column(),
        message: strip_position(&e.to_string()),
    })?;
    if let Some(units) = &raw.units {
        if units != "px" {
            return Err(StructureError::InvalidField {
                field: "units".into(),
                message: format!("unsupported unit {units:?}; structures are in pixels (\"px\")"),
            });
        }
    }
    if let Some([w, h]) = raw.size {
        if !(w.is_finite() && h.is_finite() && w > 0.0 && h > 0.0 && w <= MAX_COORD && h <= MAX_COORD) {
            return Err(StructureError::InvalidField {
                field: "size".into(),
                message: format!("size must be two positive numbers [width, height], got [{w}, {h}]"),
            });
        }
    }
    for (i, v) in raw.vertices.iter().enumerate() {
        if !(v[0].is_finite() && v[1].is_finite()) {
            return Err(StructureError::InvalidField {
                field: "vertices".into(),
                message: format!("vertex {i} has a non-finite coordinate"),
            });
        }
        // Structures are drawn on images, whose sides are at most MAX_COORD pixels; a vertex
        // far beyond would make per-pixel analysis rasterise an unbounded area.
        if v[0].abs() > MAX_COORD || v[1].abs() > MAX_COORD {
            return Err(StructureError::InvalidField {
                field: "vertices".into(),
                message: format!(
                    "vertex {i} at ({:e}, {:e}) lies beyond ±{MAX_COORD} px, the largest image side",
                    v[0], v[1]
                ),
            });
        }
    }
    let subdivision = Subdivision { vertices: raw.vertices, edges: raw.edges };
    validate::validate(&subdivision)?;
    Ok(StructureFile { size: raw.size, subdivision })
}

/// serde_json appends " at line L column C" to its messages; the position is reported in
/// separate fields.
fn strip_position(msg: &str) -> String {
    match msg.rfind(" at line ") {
        Some(i) => msg[..i].to_string(),
        None => msg.to_string(),
    }
}

fn push_num(out: &mut String, v: f64) {
    let r = round_to(v, 1e-6);
    let _ = write!(out, "{r}");
}

/// Serialises a subdivision in the documented format. The size is the bounding box of the
/// vertices rounded up to whole pixels (see [`to_json_sized`] to give it explicitly).
pub fn to_json(sub: &Subdivision) -> String {
    let mut w: f64 = 0.0;
    let mut h: f64 = 0.0;
    for v in &sub.vertices {
        w = w.max(v[0]);
        h = h.max(v[1]);
    }
    to_json_sized(sub, [w.ceil().max(1.0), h.ceil().max(1.0)])
}

/// Serialises a subdivision with an explicit sample size. Coordinates are rounded to 1e-6
/// px; the bytes depend only on the data (one vertex or edge per line, `\n` line ends).
pub fn to_json_sized(sub: &Subdivision, size: [f64; 2]) -> String {
    let mut out = String::with_capacity(32 * (sub.vertices.len() + sub.edges.len()) + 64);
    out.push_str("{\n  \"units\": \"px\",\n  \"size\": [");
    push_num(&mut out, size[0]);
    out.push_str(", ");
    push_num(&mut out, size[1]);
    out.push_str("],\n  \"vertices\": [");
    for (i, v) in sub.vertices.iter().enumerate() {
        out.push_str(if i == 0 { "\n    [" } else { ",\n    [" });
        push_num(&mut out, v[0]);
        out.push_str(", ");
        push_num(&mut out, v[1]);
        out.push(']');
    }
    out.push_str(if sub.vertices.is_empty() { "],\n" } else { "\n  ],\n" });
    out.push_str("  \"edges\": [");
    for (i, e) in sub.edges.iter().enumerate() {
        out.push_str(if i == 0 { "\n    [" } else { ",\n    [" });
        let _ = write!(out, "{}, {}]", e[0], e[1]);
    }
    out.push_str(if sub.edges.is_empty() { "]\n}\n" } else { "\n  ]\n}\n" });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const SQUARE: &str = r#"{ "units": "px", "size": [10, 10],
        "vertices": [[0,0],[4,0],[4,4],[0,4]], "edges": [[0,1],[1,2],[2,3],[3,0]] }"#;

    #[test]
    fn coordinates_beyond_the_largest_image_are_refused() {
        // Found by fuzzing: a vertex at -1e308 panicked in synthesis and one at 1e308 made the
        // pixel moments rasterise gigabytes.
        for v in ["-1e308", "1e308", "16385"] {
            let text = SQUARE.replace("[4,4]", &format!("[{v},4]"));
            let e = parse_structure_file(&text).unwrap_err().to_string();
            assert!(e.contains("largest image side"), "{v}: {e}");
        }
        assert!(parse_structure_file(&SQUARE.replace("\"size\": [10, 10]", "\"size\": [1e9, 10]")).is_err());
    }

    #[test]
    fn parses_a_square() {
        let f = parse_structure_file(SQUARE).unwrap();
        assert_eq!(f.size, Some([10.0, 10.0]));
        assert_eq!(f.subdivision.vertices.len(), 4);
        assert_eq!(f.subdivision.edges, vec![[0, 1], [1, 2], [2, 3], [3, 0]]);
    }

    #[test]
    fn roundtrip_is_stable() {
        let sub = Subdivision {
            vertices: vec![[0.1 + 0.2, 0.0], [10.123_456_789, -0.0], [5.0, 7.000_000_4]],
            edges: vec![[0, 1], [1, 2], [2, 0]],
        };
        let text = to_json(&sub);
        assert_eq!(
            text,
            "{\n  \"units\": \"px\",\n  \"size\": [11, 8],\n  \"vertices\": [\n    [0.3, 0],\n    [10.123457, 0],\n    \
             [5, 7]\n  ],\n  \"edges\": [\n    [0, 1],\n    [1, 2],\n    [2, 0]\n  ]\n}\n"
        );
        // Re-parsing and writing with the parsed size gives the same bytes.
        let back = parse_structure_file(&text).unwrap();
        assert_eq!(to_json_sized(&back.subdivision, back.size.unwrap()), text);
    }

    #[test]
    fn malformed_json_reports_line_and_column() {
        let err = parse_structure("{\n  \"vertices\": [[0,0],\n  [1,]\n}").unwrap_err();
        match &err {
            StructureError::Json { line, column, .. } => {
                assert_eq!(*line, 3);
                assert!(*column > 0);
            }
            e => panic!("wrong error {e:?}"),
        }
        assert!(err.to_string().contains("line 3"), "{err}");
        // Wrong shape and unknown keys are also JSON errors with a position.
        let err = parse_structure(r#"{"vertices": [[0,0]], "edge": []}"#).unwrap_err();
        assert!(matches!(err, StructureError::Json { .. }), "{err:?}");
        assert!(err.to_string().contains("edge"), "{err}");
        let err = parse_structure(r#"{"vertices": [[0,0,1]], "edges": []}"#).unwrap_err();
        assert!(matches!(err, StructureError::Json { .. }), "{err:?}");
    }

    #[test]
    fn bad_fields() {
        let err = parse_structure(r#"{"units": "mm", "vertices": [], "edges": []}"#).unwrap_err();
        assert!(matches!(&err, StructureError::InvalidField { field, .. } if field == "units"), "{err:?}");
        let err = parse_structure(r#"{"size": [0, 5], "vertices": [], "edges": []}"#).unwrap_err();
        assert!(matches!(&err, StructureError::InvalidField { field, .. } if field == "size"), "{err:?}");
    }

    #[test]
    fn empty_input() {
        let err = parse_structure(r#"{"vertices": [], "edges": []}"#).unwrap_err();
        assert_eq!(err, StructureError::Empty { vertices: 0, edges: 0 });
        let err = parse_structure(r#"{"vertices": [[0,0],[1,1]], "edges": []}"#).unwrap_err();
        assert_eq!(err, StructureError::Empty { vertices: 2, edges: 0 });
        assert!(err.to_string().contains("empty"));
    }

    #[test]
    fn edge_index_out_of_range() {
        let err = parse_structure(r#"{"vertices": [[0,0],[1,0],[0,1]], "edges": [[0,1],[1,2],[2,7]]}"#).unwrap_err();
        assert_eq!(err, StructureError::EdgeIndexOutOfRange { edge: 2, index: 7, vertex_count: 3 });
        let msg = err.to_string();
        assert!(msg.contains("edge 2") && msg.contains("vertex 7") && msg.contains("0..=2"), "{msg}");
    }

    #[test]
    fn self_loop() {
        let err = parse_structure(r#"{"vertices": [[0,0],[1,0],[0,1]], "edges": [[0,1],[1,1],[2,0]]}"#).unwrap_err();
        assert_eq!(err, StructureError::SelfLoop { edge: 1, vertex: 1 });
        assert!(err.to_string().contains("edge 1"));
    }

    #[test]
    fn duplicate_vertices() {
        let err = parse_structure(
            r#"{"vertices": [[0,0],[1,0],[0,1],[1,0.0000000000001]], "edges": [[0,1],[1,2],[2,0],[2,3]]}"#,
        )
        .unwrap_err();
        assert!(matches!(err, StructureError::DuplicateVertices { first: 1, second: 3, .. }), "{err:?}");
        let msg = err.to_string();
        assert!(msg.contains("vertices 1 and 3") && msg.contains("(1, 0)"), "{msg}");
    }

    #[test]
    fn crossing_edges() {
        // A bow tie: edges 0 (0-2) and 2 (1-3) cross at (1, 1).
        let err = parse_structure(r#"{"vertices": [[0,0],[2,0],[2,2],[0,2]], "edges": [[0,2],[2,1],[1,3],[3,0]]}"#)
            .unwrap_err();
        assert_eq!(err, StructureError::CrossingEdges { first: 0, second: 2, point: [1.0, 1.0] });
        let msg = err.to_string();
        assert!(msg.contains("edges 0 and 2") && msg.contains("(1, 1)"), "{msg}");
        // A vertex lying on another edge (unsplit T-junction) is reported too.
        let err = parse_structure(
            r#"{"vertices": [[0,0],[4,0],[4,4],[0,4],[2,0],[2,4]],
                "edges": [[0,1],[1,2],[2,3],[3,0],[4,5]]}"#,
        )
        .unwrap_err();
        assert_eq!(err, StructureError::CrossingEdges { first: 0, second: 4, point: [2.0, 0.0] });
        // Collinear overlap of two edges sharing a vertex.
        let err = parse_structure(r#"{"vertices": [[0,0],[4,0],[4,4],[2,0]], "edges": [[0,1],[1,2],[2,0],[0,3]]}"#)
            .unwrap_err();
        assert!(matches!(err, StructureError::CrossingEdges { first: 0, second: 3, .. }), "{err:?}");
    }

    #[test]
    fn all_degenerate() {
        // A tree (a path and a branch): every edge is dangling.
        let err =
            parse_structure(r#"{"vertices": [[0,0],[1,0],[2,0],[1,1]], "edges": [[0,1],[1,2],[1,3]]}"#).unwrap_err();
        assert_eq!(err, StructureError::AllDegenerate { edges: 3, pruned: 3 });
        assert!(err.to_string().contains("no closed region"));
    }
}
