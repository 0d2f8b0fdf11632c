//! A geometric account of how two mesh files differ, for a failed check of a mesh output.
//!
//! The check itself compares the text number by number (see [`super::compare_text`]); when that
//! fails, "number 412 differs by 3.1" says little about the mesh. This gives the counts and the
//! symmetric Hausdorff distance between the two edge sets, with where it is reached, so that a
//! reviewer knows whether a boundary moved by a pixel or the partition changed.

use serde_json::Value;

/// Vertices and edges of a mesh file (`{"vertices": [[x, y], …], "edges": [[i, j], …], …}`).
struct Mesh {
    vertices: Vec<[f64; 2]>,
    edges: Vec<[usize; 2]>,
    regions: Option<usize>,
}

fn parse(text: &str) -> Option<Mesh> {
    let v: Value = serde_json::from_str(text).ok()?;
    let point = |p: &Value| Some([p.get(0)?.as_f64()?, p.get(1)?.as_f64()?]);
    let vertices: Vec<[f64; 2]> = v.get("vertices")?.as_array()?.iter().map(point).collect::<Option<_>>()?;
    let index = |x: &Value| x.as_u64().map(|i| i as usize).filter(|&i| i < vertices.len());
    let edges = v
        .get("edges")?
        .as_array()?
        .iter()
        .map(|e| Some([index(e.get(0)?)?, index(e.get(1)?)?]))
        .collect::<Option<_>>()?;
    let regions = v.get("regions").and_then(Value::as_array).map(Vec::len);
    Some(Mesh { vertices, edges, regions })
}

type Segment = ([f64; 2], [f64; 2]);

fn segments(m: &Mesh) -> Vec<Segment> {
    m.edges.iter().map(|&[i, j]| (m.vertices[i], m.vertices[j])).collect()
}

fn point_segment(p: [f64; 2], (a, b): Segment) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 { (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
    let (ex, ey) = (a[0] + t * dx - p[0], a[1] + t * dy - p[1]);
    (ex * ex + ey * ey).sqrt()
}

/// Largest distance from a point of `from` (its edges sampled every `step`) to the edges of
/// `to`, and that point. Brute force: it only runs on a failed check.
fn directed(from: &[Segment], to: &[Segment], step: f64) -> (f64, [f64; 2]) {
    let mut worst = (0.0, [0.0, 0.0]);
    for &(a, b) in from {
        let n = ((b[0] - a[0]).hypot(b[1] - a[1]) / step).ceil().max(1.0) as usize;
        for k in 0..=n {
            let t = k as f64 / n as f64;
            let p = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
            let d = to.iter().map(|&s| point_segment(p, s)).fold(f64::INFINITY, f64::min);
            if d > worst.0 {
                worst = (d, p);
            }
        }
    }
    worst
}

/// Symmetric Hausdorff distance between the edge sets of two meshes and a point where it is
/// reached; `None` when either has no edges. Edges are sampled every `step` px, so the value
/// is low by at most `step / 2`.
fn hausdorff(a: &Mesh, b: &Mesh, step: f64) -> Option<(f64, [f64; 2])> {
    let (sa, sb) = (segments(a), segments(b));
    if sa.is_empty() || sb.is_empty() {
        return None;
    }
    let (ab, bc) = (directed(&sa, &sb, step), directed(&sb, &sa, step));
    Some(if ab.0 >= bc.0 { ab } else { bc })
}

/// One line on how mesh `actual` differs from mesh `golden`, or `None` when either text is
/// not a mesh.
pub fn mesh_difference(actual: &str, golden: &str) -> Option<String> {
    let (a, g) = (parse(actual)?, parse(golden)?);
    let mut s = format!(
        "mesh: {} vertices (golden {}), {} edges (golden {})",
        a.vertices.len(),
        g.vertices.len(),
        a.edges.len(),
        g.edges.len()
    );
    if let (Some(ra), Some(rg)) = (a.regions, g.regions) {
        s += &format!(", {ra} regions (golden {rg})");
    }
    if let Some((d, p)) = hausdorff(&a, &g, 0.5) {
        s += &format!("; Hausdorff distance between the edge sets {d:.3} px, reached near ({:.1}, {:.1})", p[0], p[1]);
    }
    Some(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(dx: f64, extra: bool) -> String {
        let mut edges = vec!["[0,1]", "[1,2]", "[2,3]", "[3,0]"];
        if extra {
            edges.push("[0,2]");
        }
        format!(
            r#"{{"vertices": [[{0},0],[{1},0],[{1},10],[{0},10]], "edges": [{2}], "regions": [[0,1,2,3]]}}"#,
            dx,
            10.0 + dx,
            edges.join(",")
        )
    }

    #[test]
    fn a_shifted_mesh_is_as_far_as_its_shift() {
        let s = mesh_difference(&square(0.75, false), &square(0.0, false)).expect("meshes");
        assert!(s.contains("4 vertices (golden 4), 4 edges (golden 4), 1 regions (golden 1)"), "{s}");
        assert!(s.contains("Hausdorff distance between the edge sets 0.750 px"), "{s}");
    }

    #[test]
    fn an_extra_edge_is_as_far_as_its_farthest_point() {
        // The diagonal's midpoint (5, 5) is 5 px from every side of the square; sampling every
        // 0.5 px finds a point within 0.25 px of it.
        let s = mesh_difference(&square(0.0, true), &square(0.0, false)).expect("meshes");
        assert!(s.contains("5 edges (golden 4)"), "{s}");
        let d: f64 = s.split("edge sets ").nth(1).and_then(|t| t.split(' ').next()).expect("distance").parse().unwrap();
        assert!((4.75..=5.0).contains(&d), "{s}");
    }

    #[test]
    fn texts_that_are_not_meshes_give_none() {
        assert_eq!(mesh_difference("<svg/>", &square(0.0, false)), None);
        assert_eq!(mesh_difference(r#"{"vertices": [[0,0]], "edges": [[0,5]]}"#, &square(0.0, false)), None);
        assert_eq!(mesh_difference(r#"{"regions": 3}"#, r#"{"regions": 3}"#), None);
    }
}
