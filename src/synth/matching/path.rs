//! Shortest paths over a catalogue graph with the p-norm cost of [references: bourque §ch5.2]
//! (Eq. 5.1): a path's cost is `(e₁ⁿ + … + e_mⁿ)^(1/n)`, relaxed as
//! `d[j] = (d[i]ⁿ + e(i, j)ⁿ)^(1/n)`. `n = 1` is the ordinary shortest path; a larger `n`
//! punishes big steps, so the path takes more, smaller ones (a smoother transformation); as
//! `n` grows the path tends to the bottleneck (minimax) path.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// An undirected graph with non-negative edge lengths, as adjacency lists.
#[derive(Clone, Debug, Default)]
pub struct Graph {
    adj: Vec<Vec<(usize, f64)>>,
}

impl Graph {
    pub fn new(nodes: usize) -> Graph {
        Graph { adj: vec![Vec::new(); nodes] }
    }

    pub fn len(&self) -> usize {
        self.adj.len()
    }

    pub fn is_empty(&self) -> bool {
        self.adj.is_empty()
    }

    /// Adds a node; its index.
    pub fn add_node(&mut self) -> usize {
        self.adj.push(Vec::new());
        self.adj.len() - 1
    }

    /// Adds the edge `a — b` of length `e` (negative or NaN lengths count as 0).
    pub fn add_edge(&mut self, a: usize, b: usize, e: f64) {
        let e = if e.is_nan() { 0.0 } else { e.max(0.0) };
        self.adj[a].push((b, e));
        self.adj[b].push((a, e));
    }

    pub fn neighbours(&self, a: usize) -> &[(usize, f64)] {
        &self.adj[a]
    }
}

#[derive(PartialEq)]
struct Entry {
    cost: f64,
    node: usize,
}

impl Eq for Entry {}

impl Ord for Entry {
    // A min-heap on cost; equal costs pop the lower node first, so ties break the same way
    // on every run.
    fn cmp(&self, other: &Self) -> Ordering {
        other.cost.total_cmp(&self.cost).then(other.node.cmp(&self.node))
    }
}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// A path and its cost.
#[derive(Clone, Debug, PartialEq)]
pub struct Path {
    pub nodes: Vec<usize>,
    pub cost: f64,
}

impl Path {
    /// The lengths of its edges, in order.
    pub fn edges(&self, g: &Graph) -> Vec<f64> {
        self.nodes
            .windows(2)
            .map(|w| {
                g.neighbours(w[0]).iter().filter(|&&(b, _)| b == w[1]).map(|&(_, e)| e).fold(f64::INFINITY, f64::min)
            })
            .collect()
    }
}

/// The path from `source` to `target` of least p-norm cost (Eq. 5.1, Dijkstra as in the
/// thesis's Alg. 3), or `None` when `target` cannot be reached. `n ≥ 1`.
pub fn pnorm_path(g: &Graph, source: usize, target: usize, n: f64) -> Option<Path> {
    let relax = |d: f64, e: f64| (d.powf(n) + e.powf(n)).powf(1.0 / n);
    dijkstra(g, source, target, relax)
}

/// Dijkstra with a monotone relaxation `relax(d[i], e) ≥ d[i]`.
fn dijkstra(g: &Graph, source: usize, target: usize, relax: impl Fn(f64, f64) -> f64) -> Option<Path> {
    let mut dist = vec![f64::INFINITY; g.len()];
    let mut prev = vec![usize::MAX; g.len()];
    let mut done = vec![false; g.len()];
    let mut heap = BinaryHeap::new();
    dist[source] = 0.0;
    heap.push(Entry { cost: 0.0, node: source });
    while let Some(Entry { cost, node }) = heap.pop() {
        if done[node] {
            continue;
        }
        done[node] = true;
        if node == target {
            break;
        }
        for &(next, e) in g.neighbours(node) {
            let d = relax(cost, e);
            if d < dist[next] {
                dist[next] = d;
                prev[next] = node;
                heap.push(Entry { cost: d, node: next });
            }
        }
    }
    if !dist[target].is_finite() {
        return None;
    }
    let mut nodes = vec![target];
    while *nodes.last().expect("not empty") != source {
        nodes.push(prev[*nodes.last().expect("not empty")]);
    }
    nodes.reverse();
    Some(Path { nodes, cost: dist[target] })
}

/// The bottleneck (minimax) path: the least largest edge over all paths.
pub fn bottleneck_path(g: &Graph, source: usize, target: usize) -> Option<Path> {
    dijkstra(g, source, target, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::rng::Rng;

    /// Three routes from A (0) to L (1), in the spirit of the thesis's Fig. 5-2 (whose own
    /// numbers tie under n = 1): two steps of 5, four of 2.6, eight of 1.85.
    fn routes() -> (Graph, [Vec<usize>; 3]) {
        let mut g = Graph::new(2);
        let mut route = |steps: usize, e: f64| {
            let mut nodes = vec![0];
            for _ in 1..steps {
                nodes.push(g.add_node());
            }
            nodes.push(1);
            for w in nodes.windows(2) {
                g.add_edge(w[0], w[1], e);
            }
            nodes
        };
        let short = route(2, 5.0);
        let middle = route(4, 2.6);
        let long = route(8, 1.85);
        (g, [short, middle, long])
    }

    #[test]
    fn the_exponent_trades_short_jumpy_paths_for_long_smooth_ones() {
        let (g, [short, middle, long]) = routes();
        assert_eq!(pnorm_path(&g, 0, 1, 1.0).unwrap().nodes, short);
        assert_eq!(pnorm_path(&g, 0, 1, 2.0).unwrap().nodes, middle);
        assert_eq!(pnorm_path(&g, 0, 1, 3.0).unwrap().nodes, long);
        let p = pnorm_path(&g, 0, 1, 3.0).unwrap();
        assert!((p.cost - (8.0 * 1.85f64.powi(3)).cbrt()).abs() < 1e-9, "{}", p.cost);
        assert_eq!(p.edges(&g), vec![1.85; 8]);
    }

    fn random_graph(rng: &mut Rng, n: usize) -> Graph {
        let mut g = Graph::new(n);
        for a in 0..n {
            for b in a + 1..n {
                if rng.next_f64() < 0.3 {
                    g.add_edge(a, b, 0.01 + rng.next_f64());
                }
            }
        }
        g
    }

    /// Dijkstra on lengths eⁿ, written apart from Eq. 5.1's relaxation.
    fn powered(g: &Graph, s: usize, t: usize, n: f64) -> Option<Vec<usize>> {
        let mut h = Graph::new(g.len());
        for a in 0..g.len() {
            for &(b, e) in g.neighbours(a) {
                if a < b {
                    h.add_edge(a, b, e.powf(n));
                }
            }
        }
        dijkstra(&h, s, t, |d, e| d + e).map(|p| p.nodes)
    }

    #[test]
    fn relaxing_by_eq_5_1_is_dijkstra_on_powered_lengths() {
        let mut rng = Rng::new(7);
        for case in 0..100 {
            let g = random_graph(&mut rng, 12 + case % 20);
            let n = [1.0, 2.0, 3.0, 5.0][case % 4];
            let (s, t) = (0, g.len() - 1);
            assert_eq!(pnorm_path(&g, s, t, n).map(|p| p.nodes), powered(&g, s, t, n), "graph {case}, n = {n}");
        }
    }

    #[test]
    fn a_large_exponent_finds_the_bottleneck() {
        let mut rng = Rng::new(11);
        for case in 0..50 {
            let g = random_graph(&mut rng, 16);
            let (Some(p), Some(b)) = (pnorm_path(&g, 0, 15, 16.0), bottleneck_path(&g, 0, 15)) else { continue };
            let worst = p.edges(&g).into_iter().fold(0.0, f64::max);
            assert!((worst - b.cost).abs() < 1e-12, "graph {case}: {worst} against {}", b.cost);
        }
    }

    #[test]
    fn unreachable_targets_have_no_path() {
        let mut g = Graph::new(3);
        g.add_edge(0, 1, 1.0);
        assert_eq!(pnorm_path(&g, 0, 2, 3.0), None);
        assert_eq!(pnorm_path(&g, 0, 0, 3.0).unwrap().nodes, vec![0]);
    }
}
