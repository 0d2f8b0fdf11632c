//! What can be wrong with a structure, and the tolerance that decides two points are one.
//!
//! Its own module so that both the file format (which validates what it parses) and the
//! validator (which reports with these errors) depend on it, not on each other.

use super::types::{round_to, Point};
use std::fmt;

/// Two vertices closer than this (pixel units) are duplicates, and a vertex closer than
/// this to an edge it is not an end of touches that edge.
pub const VERTEX_EPS: f64 = 1e-9;

/// Everything that can be wrong with a structure. Messages name the offending indices
/// (0-based) and positions so a user can find them in the file.
#[derive(Clone, Debug, PartialEq)]
pub enum StructureError {
    /// The text is not valid JSON or does not have the documented shape.
    Json { line: usize, column: usize, message: String },
    /// A field has a valid JSON type but an invalid value (`units`, `size`, a non-finite
    /// coordinate).
    InvalidField { field: String, message: String },
    /// No vertices or no edges.
    Empty { vertices: usize, edges: usize },
    /// Edge `edge` refers to vertex `index`, but only `vertex_count` vertices exist.
    EdgeIndexOutOfRange { edge: usize, index: usize, vertex_count: usize },
    /// Edge `edge` joins vertex `vertex` to itself.
    SelfLoop { edge: usize, vertex: usize },
    /// Vertices `first < second` coincide (closer than [`VERTEX_EPS`]).
    DuplicateVertices { first: usize, second: usize, position: Point },
    /// Edges `first < second` cross, overlap or touch at `point` (a vertex lying on an edge
    /// it does not end at counts as touching).
    CrossingEdges { first: usize, second: usize, point: Point },
    /// Every edge is dangling (or the input is otherwise degenerate): no closed region is
    /// left once dangling edges are pruned.
    AllDegenerate { edges: usize, pruned: usize },
}

impl fmt::Display for StructureError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StructureError::Json { line, column, message } => {
                write!(f, "malformed structure JSON at line {line}, column {column}: {message}")
            }
            StructureError::InvalidField { field, message } => write!(f, "invalid `{field}`: {message}"),
            StructureError::Empty { vertices, edges } => write!(
                f,
                "empty structure: {vertices} vertices and {edges} edges (a structure needs at least 3 vertices \
                 and 3 edges forming a closed region)"
            ),
            StructureError::EdgeIndexOutOfRange { edge, index, vertex_count } => write!(
                f,
                "edge {edge} refers to vertex {index}, but there are only {vertex_count} vertices (valid indices \
                 are 0..={})",
                vertex_count.saturating_sub(1)
            ),
            StructureError::SelfLoop { edge, vertex } => {
                write!(f, "edge {edge} is a self-loop: both ends are vertex {vertex}")
            }
            StructureError::DuplicateVertices { first, second, position } => write!(
                f,
                "vertices {first} and {second} coincide at ({}, {}); merge them and renumber the edges",
                fmt_coord(position[0]),
                fmt_coord(position[1])
            ),
            StructureError::CrossingEdges { first, second, point } => write!(
                f,
                "edges {first} and {second} cross at ({}, {}); split them with a shared vertex at the crossing",
                fmt_coord(point[0]),
                fmt_coord(point[1])
            ),
            StructureError::AllDegenerate { edges, pruned } => write!(
                f,
                "degenerate structure: no closed region; all {pruned} of {edges} edges are dangling (pruned) or \
                 the edges do not enclose any area"
            ),
        }
    }
}

impl std::error::Error for StructureError {}

fn fmt_coord(v: f64) -> String {
    let r = round_to(v, 1e-6);
    format!("{}", if r == 0.0 { 0.0 } else { r })
}
