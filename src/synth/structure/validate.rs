//! Validation and cleanup of a structure ([references: frasson §3.4], tessera's choices).
//!
//! [`validate`] reports the first problem in a fixed order (empty input, edge indices,
//! self-loops, duplicate vertices, crossing edges, nothing left after pruning), with the
//! lowest offending indices, so the same input always gives the same message.
//! [`clean`] validates, then removes duplicate edges, prunes dangling edges (repeatedly
//! removing the edge of a degree-1 vertex) and isolated vertices, and reports what it
//! removed.
//!
//! Crossing detection uses a uniform grid over the edges' bounding box (about one cell per
//! edge), so inputs with evenly spread edges cost close to `O(E)`.

use super::error::{StructureError, VERTEX_EPS};
use super::types::{Point, Subdivision};
use std::collections::HashSet;
use std::fmt;

/// Two edges that cross, overlap, or touch away from a shared end vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossing {
    /// The two edge indices, `edges[0] < edges[1]`.
    pub edges: [usize; 2],
    /// The crossing point (for a touch or an overlap, the vertex that lies on the other edge).
    pub point: Point,
}

/// Something [`clean`] changed or noticed that is not an error.
#[derive(Clone, Debug, PartialEq)]
pub enum CleanWarning {
    /// Edge `edge` joins the same two vertices as the earlier edge `duplicate_of`; removed.
    DuplicateEdge { edge: usize, duplicate_of: usize },
    /// These edges were dangling (part of a tree hanging off the graph, or of a component with
    /// no cycle) and were pruned.
    DanglingEdges { edges: Vec<usize> },
    /// These vertices have no edge left and were dropped.
    IsolatedVertices { vertices: Vec<usize> },
    /// The cleaned graph has several connected components (islands are fine: a component
    /// inside a region becomes a hole of that region).
    Disconnected { components: usize },
}

impl fmt::Display for CleanWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CleanWarning::DuplicateEdge { edge, duplicate_of } => {
                write!(f, "edge {edge} duplicates edge {duplicate_of}; removed")
            }
            CleanWarning::DanglingEdges { edges } => {
                write!(f, "pruned {} dangling edge(s): {}", edges.len(), list(edges))
            }
            CleanWarning::IsolatedVertices { vertices } => {
                write!(f, "dropped {} vertex(es) without edges: {}", vertices.len(), list(vertices))
            }
            CleanWarning::Disconnected { components } => {
                write!(f, "the structure has {components} separate connected parts")
            }
        }
    }
}

fn list(ids: &[usize]) -> String {
    const SHOWN: usize = 12;
    let mut s: Vec<String> = ids.iter().take(SHOWN).map(|i| i.to_string()).collect();
    if ids.len() > SHOWN {
        s.push(format!("… ({} more)", ids.len() - SHOWN));
    }
    s.join(", ")
}

/// A cleaned structure: no duplicate edges, no dangling edges, no isolated vertices; indices
/// compacted. The maps lead back to the input's indices.
#[derive(Clone, Debug, PartialEq)]
pub struct Cleaned {
    pub subdivision: Subdivision,
    /// `vertex_map[new] = original vertex index`.
    pub vertex_map: Vec<usize>,
    /// `edge_map[new] = original edge index`.
    pub edge_map: Vec<usize>,
    /// Original indices of the pruned dangling edges, ascending.
    pub pruned_edges: Vec<usize>,
    /// Original indices of the removed duplicate edges, ascending.
    pub duplicate_edges: Vec<usize>,
    /// Number of connected components of the cleaned graph.
    pub components: usize,
    pub warnings: Vec<CleanWarning>,
}

/// Validates a structure; see the module documentation for the order of the checks.
pub fn validate(sub: &Subdivision) -> Result<(), StructureError> {
    clean(sub).map(|_| ())
}

/// Checks for empty input, out-of-range indices and self-loops (cheap, `O(E)`).
pub fn check_indices(sub: &Subdivision) -> Result<(), StructureError> {
    if sub.vertices.is_empty() || sub.edges.is_empty() {
        return Err(StructureError::Empty { vertices: sub.vertices.len(), edges: sub.edges.len() });
    }
    let n = sub.vertices.len();
    for (k, e) in sub.edges.iter().enumerate() {
        for &i in e {
            if i >= n {
                return Err(StructureError::EdgeIndexOutOfRange { edge: k, index: i, vertex_count: n });
            }
        }
    }
    for (k, e) in sub.edges.iter().enumerate() {
        if e[0] == e[1] {
            return Err(StructureError::SelfLoop { edge: k, vertex: e[0] });
        }
    }
    Ok(())
}

/// Pairs `[i, j]` (`i < j`) of vertices closer than `eps`, sorted. Sort-and-sweep on `x`.
pub fn find_duplicate_vertices(vertices: &[Point], eps: f64) -> Vec<[usize; 2]> {
    let mut order: Vec<usize> = (0..vertices.len()).collect();
    order.sort_by(|&a, &b| vertices[a][0].total_cmp(&vertices[b][0]).then(a.cmp(&b)));
    let mut out = Vec::new();
    for (k, &i) in order.iter().enumerate() {
        for &j in &order[k + 1..] {
            if vertices[j][0] - vertices[i][0] > eps {
                break;
            }
            let dx = vertices[j][0] - vertices[i][0];
            let dy = vertices[j][1] - vertices[i][1];
            if dx * dx + dy * dy <= eps * eps {
                out.push([i.min(j), i.max(j)]);
            }
        }
    }
    out.sort_unstable();
    out
}

/// Pairs `[first, duplicate]` of edges joining the same two vertices (either direction);
/// `first` is the lowest index of its group. Sorted by `duplicate`.
pub fn find_duplicate_edges(edges: &[[usize; 2]]) -> Vec<[usize; 2]> {
    let mut keyed: Vec<([usize; 2], usize)> =
        edges.iter().enumerate().map(|(k, e)| ([e[0].min(e[1]), e[0].max(e[1])], k)).collect();
    keyed.sort_unstable();
    let mut out = Vec::new();
    let mut g = 0;
    while g < keyed.len() {
        let mut h = g + 1;
        while h < keyed.len() && keyed[h].0 == keyed[g].0 {
            out.push([keyed[g].1, keyed[h].1]);
            h += 1;
        }
        g = h;
    }
    out.sort_unstable_by_key(|p| p[1]);
    out
}

#[inline]
fn orient(a: Point, b: Point, c: Point) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Distance from `p` to the segment `ab`.
pub fn point_segment_distance(p: Point, a: Point, b: Point) -> f64 {
    let dx = b[0] - a[0];
    let dy = b[1] - a[1];
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 { (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0) } else { 0.0 };
    let qx = a[0] + t * dx - p[0];
    let qy = a[1] + t * dy - p[1];
    (qx * qx + qy * qy).sqrt()
}

/// Where the segments `ab` and `cd` (no shared end vertex) meet, if they come closer than
/// `eps`: a proper crossing point, or the end vertex lying on the other segment.
pub fn segment_contact(a: Point, b: Point, c: Point, d: Point, eps: f64) -> Option<Point> {
    if a[0].max(b[0]) + eps < c[0].min(d[0])
        || c[0].max(d[0]) + eps < a[0].min(b[0])
        || a[1].max(b[1]) + eps < c[1].min(d[1])
        || c[1].max(d[1]) + eps < a[1].min(b[1])
    {
        return None;
    }
    let o1 = orient(a, b, c);
    let o2 = orient(a, b, d);
    let o3 = orient(c, d, a);
    let o4 = orient(c, d, b);
    let opposite = |p: f64, q: f64| (p > 0.0 && q < 0.0) || (p < 0.0 && q > 0.0);
    let proper = opposite(o1, o2) && opposite(o3, o4);
    // Touches and overlaps first: they report a vertex position, which is exact.
    for (p, s, t) in [(c, a, b), (d, a, b), (a, c, d), (b, c, d)] {
        if point_segment_distance(p, s, t) <= eps {
            return Some(p);
        }
    }
    if proper {
        let t = o3 / (o3 - o4);
        return Some([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
    }
    None
}

/// Where the edges `e` and `f` meet away from shared end vertices (see [`segment_contact`]).
/// Edges joining the same two vertices are duplicates, not crossings, and return `None`.
fn edge_contact(v: &[Point], e: [usize; 2], f: [usize; 2], eps: f64) -> Option<Point> {
    let shared: Vec<usize> = e.iter().copied().filter(|i| f.contains(i)).collect();
    match shared.len() {
        0 => segment_contact(v[e[0]], v[e[1]], v[f[0]], v[f[1]], eps),
        1 => {
            let s = shared[0];
            let eo = if e[0] == s { e[1] } else { e[0] };
            let fo = if f[0] == s { f[1] } else { f[0] };
            // Two segments from one vertex meet elsewhere only by overlapping collinearly,
            // in which case the shorter one's far end lies on the longer one.
            if point_segment_distance(v[fo], v[s], v[eo]) <= eps {
                Some(v[fo])
            } else if point_segment_distance(v[eo], v[s], v[fo]) <= eps {
                Some(v[eo])
            } else {
                None
            }
        }
        _ => None,
    }
}

/// All pairs of crossing, overlapping or touching edges, sorted by edge indices. Edges must
/// have valid indices. Uses a uniform grid; pairs are tested once.
pub fn find_crossings(sub: &Subdivision) -> Vec<Crossing> {
    find_crossings_limited(sub, usize::MAX)
}

/// Like [`find_crossings`] but stops collecting after `limit` crossings (the returned ones
/// are then not necessarily the lowest-indexed).
pub fn find_crossings_limited(sub: &Subdivision, limit: usize) -> Vec<Crossing> {
    let v = &sub.vertices;
    let edges = &sub.edges;
    let ne = edges.len();
    if ne < 2 {
        return Vec::new();
    }
    let (mut x0, mut y0, mut x1, mut y1) = (f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
    for e in edges {
        for &i in e {
            x0 = x0.min(v[i][0]);
            y0 = y0.min(v[i][1]);
            x1 = x1.max(v[i][0]);
            y1 = y1.max(v[i][1]);
        }
    }
    let w = (x1 - x0).max(1e-12);
    let h = (y1 - y0).max(1e-12);
    // About one cell per edge, at most 1024 per side.
    let cell = ((w * h) / ne as f64).sqrt().max(w.max(h) / 1024.0).max(1e-9);
    let gx = ((w / cell).floor() as usize + 1).min(1024);
    let gy = ((h / cell).floor() as usize + 1).min(1024);
    let col = |x: f64| (((x - x0) / cell).floor().max(0.0) as usize).min(gx - 1);
    let row = |y: f64| (((y - y0) / cell).floor().max(0.0) as usize).min(gy - 1);
    let mut cells: Vec<Vec<u32>> = vec![Vec::new(); gx * gy];
    let pad = VERTEX_EPS * 2.0;
    for (k, e) in edges.iter().enumerate() {
        let (a, b) = (v[e[0]], v[e[1]]);
        let r0 = row(a[1].min(b[1]) - pad);
        let r1 = row(a[1].max(b[1]) + pad);
        for r in r0..=r1 {
            // The part of the segment inside this row band, in x.
            let band_lo = y0 + r as f64 * cell - pad;
            let band_hi = y0 + (r + 1) as f64 * cell + pad;
            let (xa, xb) = if (b[1] - a[1]).abs() < 1e-300 {
                (a[0].min(b[0]), a[0].max(b[0]))
            } else {
                let t0 = ((band_lo - a[1]) / (b[1] - a[1])).clamp(0.0, 1.0);
                let t1 = ((band_hi - a[1]) / (b[1] - a[1])).clamp(0.0, 1.0);
                let xa = a[0] + t0 * (b[0] - a[0]);
                let xb = a[0] + t1 * (b[0] - a[0]);
                (xa.min(xb), xa.max(xb))
            };
            for c in col(xa - pad)..=col(xb + pad) {
                cells[r * gx + c].push(k as u32);
            }
        }
    }
    let mut tested: HashSet<(u32, u32)> = HashSet::new();
    let mut out = Vec::new();
    'cells: for cell_edges in &cells {
        for (p, &i) in cell_edges.iter().enumerate() {
            for &j in &cell_edges[p + 1..] {
                let (i, j) = (i.min(j), i.max(j));
                if !tested.insert((i, j)) {
                    continue;
                }
                if let Some(point) = edge_contact(v, edges[i as usize], edges[j as usize], VERTEX_EPS) {
                    out.push(Crossing { edges: [i as usize, j as usize], point });
                    if out.len() >= limit {
                        break 'cells;
                    }
                }
            }
        }
    }
    out.sort_by_key(|c| c.edges);
    out
}

/// Brute-force `O(E²)` reference for [`find_crossings`] (used by tests).
pub fn find_crossings_brute(sub: &Subdivision) -> Vec<Crossing> {
    let mut out = Vec::new();
    for i in 0..sub.edges.len() {
        for j in i + 1..sub.edges.len() {
            if let Some(point) = edge_contact(&sub.vertices, sub.edges[i], sub.edges[j], VERTEX_EPS) {
                out.push(Crossing { edges: [i, j], point });
            }
        }
    }
    out
}

/// Repeatedly removes the edge of a degree-1 vertex. `alive[k]` marks the edges to consider
/// (others are ignored) and is updated; returns the pruned edge indices, ascending.
pub fn prune_dangling(vertex_count: usize, edges: &[[usize; 2]], alive: &mut [bool]) -> Vec<usize> {
    let mut incident: Vec<Vec<usize>> = vec![Vec::new(); vertex_count];
    let mut degree = vec![0usize; vertex_count];
    for (k, e) in edges.iter().enumerate() {
        if alive[k] {
            for &i in e {
                incident[i].push(k);
                degree[i] += 1;
            }
        }
    }
    let mut stack: Vec<usize> = (0..vertex_count).rev().filter(|&i| degree[i] == 1).collect();
    let mut pruned = Vec::new();
    while let Some(vtx) = stack.pop() {
        if degree[vtx] != 1 {
            continue;
        }
        let Some(&k) = incident[vtx].iter().find(|&&k| alive[k]) else { continue };
        alive[k] = false;
        pruned.push(k);
        for &i in &edges[k] {
            degree[i] -= 1;
            if degree[i] == 1 {
                stack.push(i);
            }
        }
    }
    pruned.sort_unstable();
    pruned
}

/// Validates `sub` and returns the cleaned structure (see [`Cleaned`]).
pub fn clean(sub: &Subdivision) -> Result<Cleaned, StructureError> {
    check_indices(sub)?;
    if let Some(&[first, second]) = find_duplicate_vertices(&sub.vertices, VERTEX_EPS).first() {
        return Err(StructureError::DuplicateVertices { first, second, position: sub.vertices[first] });
    }
    if let Some(c) = find_crossings(sub).first() {
        return Err(StructureError::CrossingEdges { first: c.edges[0], second: c.edges[1], point: c.point });
    }
    let mut warnings = Vec::new();
    let mut alive = vec![true; sub.edges.len()];
    let dups = find_duplicate_edges(&sub.edges);
    let mut duplicate_edges = Vec::new();
    for &[first, dup] in &dups {
        alive[dup] = false;
        duplicate_edges.push(dup);
        warnings.push(CleanWarning::DuplicateEdge { edge: dup, duplicate_of: first });
    }
    duplicate_edges.sort_unstable();
    let pruned_edges = prune_dangling(sub.vertices.len(), &sub.edges, &mut alive);
    if !pruned_edges.is_empty() {
        warnings.push(CleanWarning::DanglingEdges { edges: pruned_edges.clone() });
    }
    let kept = alive.iter().filter(|&&a| a).count();
    if kept == 0 {
        return Err(StructureError::AllDegenerate { edges: sub.edges.len(), pruned: pruned_edges.len() });
    }
    let mut used = vec![false; sub.vertices.len()];
    for (k, e) in sub.edges.iter().enumerate() {
        if alive[k] {
            used[e[0]] = true;
            used[e[1]] = true;
        }
    }
    let mut new_index = vec![usize::MAX; sub.vertices.len()];
    let mut vertex_map = Vec::new();
    let mut vertices = Vec::new();
    for (i, &u) in used.iter().enumerate() {
        if u {
            new_index[i] = vertices.len();
            vertex_map.push(i);
            vertices.push(sub.vertices[i]);
        }
    }
    let isolated: Vec<usize> = (0..sub.vertices.len()).filter(|&i| !used[i]).collect();
    if !isolated.is_empty() {
        warnings.push(CleanWarning::IsolatedVertices { vertices: isolated });
    }
    let mut edges = Vec::with_capacity(kept);
    let mut edge_map = Vec::with_capacity(kept);
    for (k, e) in sub.edges.iter().enumerate() {
        if alive[k] {
            edges.push([new_index[e[0]], new_index[e[1]]]);
            edge_map.push(k);
        }
    }
    let components = count_components(vertices.len(), &edges);
    if components > 1 {
        warnings.push(CleanWarning::Disconnected { components });
    }
    Ok(Cleaned {
        subdivision: Subdivision { vertices, edges },
        vertex_map,
        edge_map,
        pruned_edges,
        duplicate_edges,
        components,
        warnings,
    })
}

/// Number of connected components of the graph (vertices without edges count as their own
/// component).
pub fn count_components(vertex_count: usize, edges: &[[usize; 2]]) -> usize {
    let mut parent: Vec<usize> = (0..vertex_count).collect();
    fn find(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    let mut n = vertex_count;
    for e in edges {
        let (a, b) = (find(&mut parent, e[0]), find(&mut parent, e[1]));
        if a != b {
            parent[a.max(b)] = a.min(b);
            n -= 1;
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::rng::Rng;

    fn square_with_tail() -> Subdivision {
        // Unit square 0-1-2-3, a tail 2-4-5 and a branch 4-6, a duplicate of edge 0 reversed,
        // and an isolated vertex 7.
        Subdivision {
            vertices: vec![
                [0.0, 0.0],
                [10.0, 0.0],
                [10.0, 10.0],
                [0.0, 10.0],
                [15.0, 15.0],
                [20.0, 15.0],
                [15.0, 20.0],
                [30.0, 30.0],
            ],
            edges: vec![[0, 1], [1, 2], [2, 3], [3, 0], [2, 4], [4, 5], [4, 6], [1, 0]],
        }
    }

    #[test]
    fn clean_prunes_and_reports() {
        let c = clean(&square_with_tail()).unwrap();
        assert_eq!(c.pruned_edges, vec![4, 5, 6]);
        assert_eq!(c.duplicate_edges, vec![7]);
        assert_eq!(c.subdivision.edges.len(), 4);
        assert_eq!(c.subdivision.vertices.len(), 4);
        assert_eq!(c.edge_map, vec![0, 1, 2, 3]);
        assert_eq!(c.vertex_map, vec![0, 1, 2, 3]);
        assert_eq!(c.components, 1);
        assert!(c.warnings.contains(&CleanWarning::DuplicateEdge { edge: 7, duplicate_of: 0 }));
        assert!(c.warnings.contains(&CleanWarning::DanglingEdges { edges: vec![4, 5, 6] }));
        assert!(c.warnings.contains(&CleanWarning::IsolatedVertices { vertices: vec![4, 5, 6, 7] }));
        let text: Vec<String> = c.warnings.iter().map(|w| w.to_string()).collect();
        assert!(text.iter().any(|t| t.contains("pruned 3 dangling edge(s): 4, 5, 6")), "{text:?}");
    }

    #[test]
    fn duplicate_edges_found() {
        let d = find_duplicate_edges(&[[0, 1], [1, 2], [1, 0], [2, 1], [0, 1]]);
        assert_eq!(d, vec![[0, 2], [1, 3], [0, 4]]);
    }

    #[test]
    fn duplicate_vertices_found() {
        let v = vec![[0.0, 0.0], [1.0, 1.0], [0.0, 5e-10], [1.0, 1.0 + 2e-9], [1.0 + 1e-10, 1.0]];
        assert_eq!(find_duplicate_vertices(&v, VERTEX_EPS), vec![[0, 2], [1, 4]]);
    }

    #[test]
    fn grid_crossings_match_brute_force() {
        // Random segments of mixed lengths, many crossings, some long edges.
        let mut rng = Rng::new(17);
        let mut sub = Subdivision::default();
        for k in 0..400 {
            let a = [rng.range(0.0, 500.0), rng.range(0.0, 300.0)];
            let len = if k % 50 == 0 { 400.0 } else { rng.range(1.0, 30.0) };
            let ang = rng.range(0.0, std::f64::consts::TAU);
            let b = [a[0] + len * ang.cos(), a[1] + len * ang.sin()];
            sub.vertices.push(a);
            sub.vertices.push(b);
            sub.edges.push([2 * k, 2 * k + 1]);
        }
        // Axis-aligned and touching cases.
        let n = sub.vertices.len();
        sub.vertices.extend([[0.0, 400.0], [100.0, 400.0], [50.0, 400.0], [50.0, 450.0], [100.0, 400.0 + 1e-12]]);
        sub.edges.extend([[n, n + 1], [n + 2, n + 3], [n + 4, n + 3]]);
        let fast = find_crossings(&sub);
        let brute = find_crossings_brute(&sub);
        assert!(brute.len() > 100, "{}", brute.len());
        assert_eq!(fast, brute);
    }

    #[test]
    fn large_grid_validates() {
        // 150 × 150 cells, 45 300 edges: the grid makes this about linear.
        let n = 150;
        let mut sub = Subdivision::default();
        for j in 0..=n {
            for i in 0..=n {
                sub.vertices.push([i as f64 * 3.0 + 0.1 * (j % 3) as f64, j as f64 * 2.0]);
            }
        }
        for j in 0..=n {
            for i in 0..=n {
                let v = j * (n + 1) + i;
                if i < n {
                    sub.edges.push([v, v + 1]);
                }
                if j < n {
                    sub.edges.push([v, v + n + 1]);
                }
            }
        }
        assert!(find_crossings(&sub).is_empty());
        let c = clean(&sub).unwrap();
        assert_eq!(c.subdivision.edges.len(), 2 * n * (n + 1));
        // One extra long diagonal crosses about 2n edges.
        let last = sub.vertices.len() - 1;
        sub.edges.push([0, last]);
        let crossings = find_crossings(&sub);
        assert!(crossings.len() > n, "{}", crossings.len());
        assert!(matches!(clean(&sub), Err(StructureError::CrossingEdges { .. })));
    }

    #[test]
    fn components_counted() {
        let sub = Subdivision {
            vertices: vec![[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [2.0, 2.0], [4.0, 2.0], [2.0, 4.0]],
            edges: vec![[0, 1], [1, 2], [2, 0], [3, 4], [4, 5], [5, 3]],
        };
        let c = clean(&sub).unwrap();
        assert_eq!(c.components, 2);
        assert!(c.warnings.contains(&CleanWarning::Disconnected { components: 2 }));
    }
}
