//! Checks of matching: catalogue steps on synthetic shaders with known behaviour, the simplex
//! and the conjugate gradients on functions with known optima, and the library search on
//! renders of the library itself.

use std::sync::OnceLock;

use super::catalogue::{coverage_pruned_set, kappa, pruned_set, redundancy, screening_subset};
use super::*;
use crate::synth::shader;

pub(super) fn probe(space: &Space, side: usize) -> Probe<'_> {
    Probe { space, seed: 7, side, metric: Metric::default() }
}

/// A one-parameter "shader" whose render is a brightness `f(x)`, compared by `1 − |Δ|`.
struct Ramp(fn(f64) -> f64);

impl Oracle for Ramp {
    type Feature = f64;
    fn dim(&self) -> usize {
        1
    }
    fn feature(&self, x: &[f64]) -> f64 {
        (self.0)(x[0])
    }
    fn similarity(&self, a: &f64, b: &f64) -> f64 {
        1.0 - (a - b).abs()
    }
}

/// Two parameters, the render a pair of brightnesses.
struct Plane;

impl Oracle for Plane {
    type Feature = [f64; 2];
    fn dim(&self) -> usize {
        2
    }
    fn feature(&self, x: &[f64]) -> [f64; 2] {
        [x[0], x[1] * x[1]]
    }
    fn similarity(&self, a: &[f64; 2], b: &[f64; 2]) -> f64 {
        1.0 - ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt() / 2f64.sqrt()
    }
}

#[test]
fn construction_rejects_duplicates_and_connects_every_pair() {
    // F12, F13.
    let cfg = CatalogueConfig { omega: 0.9, ..CatalogueConfig::default() };
    let cat = build_catalogue(&Plane, &cfg, 3);
    let n = cat.len();
    assert!(n > 10, "{n}");
    assert_eq!(cat.weights.len(), n * n);
    for a in 0..n {
        assert_eq!(cat.weight(a, a), 1.0);
        for b in 0..n {
            assert_eq!(cat.weight(a, b), cat.weight(b, a));
            if a != b {
                assert!(cat.weight(a, b) <= cfg.omega, "{a} {b} {}", cat.weight(a, b));
            }
        }
    }
    assert!(cat.rounds.iter().any(|r| r.duplicates > 0), "the test should exercise rejection");
}

/// [`Plane`] counting its feature extractions (by point) and its comparisons.
#[derive(Default)]
struct Counted {
    features: std::sync::Mutex<std::collections::HashMap<Vec<u64>, usize>>,
    comparisons: std::sync::atomic::AtomicUsize,
}

impl Oracle for Counted {
    type Feature = [f64; 2];
    fn dim(&self) -> usize {
        2
    }
    fn feature(&self, x: &[f64]) -> [f64; 2] {
        *self.features.lock().unwrap().entry(x.iter().map(|v| v.to_bits()).collect()).or_default() += 1;
        Plane.feature(x)
    }
    fn similarity(&self, a: &[f64; 2], b: &[f64; 2]) -> f64 {
        self.comparisons.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        Plane.similarity(a, b)
    }
}

#[test]
fn features_are_extracted_once_per_render_and_each_pair_compared_once() {
    // F11: N vertices (no duplicates, no refinement) cost N extractions and N(N−1)/2
    // comparisons, beside the 2·dim neighbours of each vertex's roughness (one extraction and
    // one comparison each). The builder's own counters agree with the oracle's.
    let cfg = CatalogueConfig { rounds: 0, omega: 1.0, ..CatalogueConfig::default() };
    let oracle = Counted::default();
    let cat = build_catalogue(&oracle, &cfg, 11);
    let n = cat.len();
    assert_eq!(n, cfg.k);
    let per_point = oracle.features.lock().unwrap().clone();
    let twice: Vec<Vec<f64>> =
        per_point.iter().filter(|(_, &c)| c > 1).map(|(k, _)| k.iter().map(|&b| f64::from_bits(b)).collect()).collect();
    assert!(twice.is_empty(), "rendered more than once: {twice:?}");
    let extractions: usize = per_point.values().sum();
    let neighbours = extractions - n;
    assert!(neighbours <= 2 * 2 * n);
    let comparisons = oracle.comparisons.load(std::sync::atomic::Ordering::Relaxed);
    assert_eq!(comparisons - neighbours, n * (n - 1) / 2);
    assert_eq!((cat.features_computed, cat.comparisons), (extractions, comparisons));
    eprintln!(
        "F11: {n} vertices, {extractions} extractions ({neighbours} roughness neighbours), {comparisons} comparisons"
    );

    // With refinement and pruning, the counters still tell the truth and no point is
    // extracted twice.
    let oracle = Counted::default();
    let cat = build_catalogue(&oracle, &CatalogueConfig { cap: 40, ..CatalogueConfig::default() }, 12);
    let per_point = oracle.features.lock().unwrap().clone();
    assert!(per_point.values().all(|&c| c == 1), "a point was rendered twice");
    assert!(cat.rounds.iter().any(|r| r.duplicates > 0), "the test should offer duplicates");
    assert_eq!(cat.features_computed, per_point.values().sum::<usize>());
    assert_eq!(cat.comparisons, oracle.comparisons.load(std::sync::atomic::Ordering::Relaxed));
}

#[test]
fn local_samples_stay_within_the_radius_of_their_parent() {
    // F16: γ by hand on the matrix of F15 (roughness 1, 2, 4 → 0.25, 0.5, 1; nearest
    // distances 0.5, 0.1, 0.1; farthest 0.8, 0.5, 0.8), α = β = 0.5.
    let rows = vec![vec![1.0, 0.5, 0.2], vec![0.5, 1.0, 0.9], vec![0.2, 0.9, 1.0]];
    let cfg = CatalogueConfig::default();
    let close = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12);
    assert!(close(&catalogue::isolation(&rows, &[1.0, 2.0, 4.0], &cfg), &[0.375, 0.3, 0.55]));
    let far = CatalogueConfig { gamma_farthest: true, ..cfg };
    assert!(close(&catalogue::isolation(&rows, &[1.0, 2.0, 4.0], &far), &[0.525, 0.5, 0.9]));
    // Local samples: per axis within r of the parent, inside the cube even at its corners.
    let mut rng = crate::synth::rng::Rng::new(16);
    for parent in [vec![0.5, 0.5, 0.5], vec![0.0, 1.0, 0.02], vec![0.999, 0.001, 0.3]] {
        for radius in [0.0, 0.01, 0.05, 0.3] {
            let points = catalogue::local_samples(&mut rng, &parent, radius, 50);
            assert_eq!(points.len(), 50);
            for p in &points {
                for (c, q) in p.iter().zip(&parent) {
                    assert!((c - q).abs() <= radius && (0.0..=1.0).contains(c), "{p:?} around {parent:?}");
                }
            }
            if radius > 0.0 && parent[0] == 0.5 {
                assert!(points.iter().any(|p| p != &parent), "samples must move");
            }
        }
    }
}

#[test]
fn roughness_is_larger_where_the_render_changes_faster() {
    // F14: brightness x⁸ changes fastest near 1; a linear ramp changes evenly.
    let cfg = CatalogueConfig { rounds: 0, omega: 1.0, ..CatalogueConfig::default() };
    let steep = build_catalogue(&Ramp(|x| x.powi(8)), &cfg, 5);
    let linear = build_catalogue(&Ramp(|x| x), &cfg, 5);
    assert!(steep.roughness.iter().chain(&linear.roughness).all(|&h| h >= 0.0));
    let mean = |cat: &Catalogue<f64>, lo: f64, hi: f64| {
        let h: Vec<f64> =
            (0..cat.len()).filter(|&i| (lo..hi).contains(&cat.points[i][0])).map(|i| cat.roughness[i]).collect();
        h.iter().sum::<f64>() / h.len() as f64
    };
    assert!(mean(&steep, 0.8, 1.0) > 5.0 * mean(&steep, 0.0, 0.5));
    let (lo, hi) = (mean(&linear, 0.0, 0.5), mean(&linear, 0.5, 1.0));
    assert!((lo / hi - 1.0).abs() < 0.3, "{lo} {hi}");
}

#[test]
fn coverage_matches_a_hand_calculation_and_stops_refinement() {
    // F15: e₁₂ = 0.5, e₁₃ = 0.2, e₂₃ = 0.9, σ = 2: (2·(0.25 + 0.64 + 0.01))^½ / 3.
    let rows = vec![vec![1.0, 0.5, 0.2], vec![0.5, 1.0, 0.9], vec![0.2, 0.9, 1.0]];
    assert!((kappa(&rows, 2.0) - 1.8f64.sqrt() / 3.0).abs() < 1e-12);
    assert_eq!(kappa(&rows[..1], 2.0), 0.0);
    for threshold in [0.0, 0.01, 1.0] {
        let cfg = CatalogueConfig { kappa: threshold, rounds: 3, ..CatalogueConfig::default() };
        let cat = build_catalogue(&Plane, &cfg, 9);
        assert!(cat.rounds.len() <= cfg.rounds);
        assert!(cat.rounds.iter().all(|r| r.kappa > threshold));
        assert!(cat.rounds.len() == cfg.rounds || cat.kappa <= threshold, "{threshold} {:?}", cat.rounds);
    }
}

#[test]
fn coverage_pruning_removes_the_vertex_whose_loss_costs_least() {
    // Two twins (0, 1), a unique vertex (2) and one near it (3): a twin goes first, the lower
    // index on a tie, the lighter one when they stand for different numbers of points.
    let rows =
        vec![vec![1.0, 0.97, 0.1, 0.1], vec![0.97, 1.0, 0.1, 0.1], vec![0.1, 0.1, 1.0, 0.6], vec![0.1, 0.1, 0.6, 1.0]];
    assert_eq!(coverage_pruned_set(&rows, &[1.0; 4], 3), vec![0]);
    assert_eq!(coverage_pruned_set(&rows, &[3.0, 1.0, 1.0, 1.0], 3), vec![1]);
    assert_eq!(coverage_pruned_set(&rows, &[1.0; 4], 4), Vec::<usize>::new());
    // On random graphs, each removal is the one a brute-force recount of the weighed coverage
    // (every vertex's best kept similarity) finds cheapest.
    let mut rng = crate::synth::rng::Rng::new(17);
    for _ in 0..20 {
        let n = 12;
        let upper: Vec<f64> = (0..n * n).map(|_| rng.next_f64()).collect();
        let rows: Vec<Vec<f64>> = (0..n)
            .map(|a| (0..n).map(|b| if a == b { 1.0 } else { upper[a.min(b) * n + a.max(b)] }).collect())
            .collect();
        let mass: Vec<f64> = (0..n).map(|_| rng.range(0.0, 3.0)).collect();
        let coverage = |alive: &[bool]| -> f64 {
            (0..n)
                .map(|u| mass[u] * (0..n).filter(|&v| alive[v]).map(|v| rows[u][v]).fold(f64::NEG_INFINITY, f64::max))
                .sum()
        };
        let gone = coverage_pruned_set(&rows, &mass, 5);
        assert_eq!(gone.len(), n - 5);
        let mut alive = vec![true; n];
        for &g in &gone {
            let before = coverage(&alive);
            let loss = |v: usize| {
                let mut a = alive.clone();
                a[v] = false;
                before - coverage(&a)
            };
            let best = (0..n).filter(|&v| alive[v]).map(loss).fold(f64::INFINITY, f64::min);
            assert!(loss(g) <= best + 1e-12, "{g}: {} > {best}", loss(g));
            alive[g] = false;
        }
    }
}

#[test]
fn pruning_removes_exactly_the_most_redundant_vertices() {
    // F17: λ recomputed here independently of the builder's.
    let cfg = CatalogueConfig { cap: 30, ..CatalogueConfig::default() };
    let cat = build_catalogue(&Plane, &cfg, 4);
    assert!(cat.len() <= 30);
    assert!(cat.rounds.iter().any(|r| r.pruned > 0));
    let rows =
        vec![vec![1.0, 0.9, 0.8, 0.1], vec![0.9, 1.0, 0.7, 0.2], vec![0.8, 0.7, 1.0, 0.3], vec![0.1, 0.2, 0.3, 1.0]];
    let lambda: Vec<f64> =
        rows.iter().enumerate().map(|(l, r)| (0..4).filter(|&m| m != l).map(|m| r[m]).sum()).collect();
    assert_eq!(redundancy(&rows), lambda);
    // λ = 1.8, 1.8, 1.8, 0.6: the two first by index among the tied.
    assert_eq!(pruned_set(&rows, 2), vec![0, 1]);
    assert_eq!(pruned_set(&rows, 4), Vec::<usize>::new());
    // One at a time (λ recomputed): 0 goes, then 1 and 2 have λ 0.9 and 1.0, so 2 goes.
    assert_eq!(screening_subset(&rows, 2), vec![1, 3]);
}

#[test]
fn the_screening_subset_is_part_of_the_full_graph() {
    // F18: indices into the full graph (features shared, nothing stored twice).
    let cfg = CatalogueConfig { screen_cap: 8, ..CatalogueConfig::default() };
    let cat = build_catalogue(&Plane, &cfg, 2);
    assert_eq!(cat.screen.len(), 8);
    assert!(cat.screen.windows(2).all(|w| w[0] < w[1]));
    assert!(cat.screen.iter().all(|&i| i < cat.len()));
}

#[test]
fn a_catalogue_is_the_same_for_a_seed_whatever_the_threads() {
    // F20.
    let space = Space::new(shader::shader("circle").unwrap());
    let p = probe(&space, 64);
    let cfg = CatalogueConfig { k: 24, cap: 60, rounds: 2, ..CatalogueConfig::default() };
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let a = one.install(|| build_catalogue(&p, &cfg, 17));
    let b = build_catalogue(&p, &cfg, 17);
    assert_eq!(a.points, b.points);
    assert_eq!(a.weights, b.weights);
    assert_eq!(a.roughness, b.roughness);
    assert_eq!(a.screen, b.screen);
    let c = build_catalogue(&p, &cfg, 18);
    assert_ne!(a.points, c.points);
}

fn sphere(x: &[f64]) -> f64 {
    x.iter().map(|&c| (c - 0.3) * (c - 0.3)).sum()
}

fn rosenbrock(x: &[f64]) -> f64 {
    // Optimum (1, 1) moved to (0.75, 0.75) of the unit square.
    let (u, v) = (4.0 * x[0] - 2.0, 4.0 * x[1] - 2.0);
    (1.0 - u).powi(2) + 100.0 * (v - u * u).powi(2)
}

#[test]
fn the_simplex_reaches_known_optima_inside_the_box() {
    // F25.
    for (f, x0, optimum, tol) in [
        (sphere as fn(&[f64]) -> f64, vec![0.9, 0.1, 0.6], vec![0.3, 0.3, 0.3], 1e-2),
        (rosenbrock, vec![0.2, 0.9], vec![0.75, 0.75], 2e-2),
    ] {
        let mut outside = 0;
        let cfg = SimplexConfig { restarts: 3, ftol: 1e-10, ..SimplexConfig::default() };
        let r = minimise(
            |x| {
                outside += x.iter().any(|c| !(0.0..=1.0).contains(c)) as usize;
                f(x)
            },
            |_| {},
            &x0,
            &cfg,
            |_| false,
        );
        assert_eq!(outside, 0);
        assert!(r.iterations <= cfg.max_iterations);
        assert!(r.trace.windows(2).all(|w| w[1] <= w[0]));
        let err = r.x.iter().zip(&optimum).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(err < tol, "{:?} loss {} after {}", r.x, r.loss, r.iterations);
    }
    // An optimum outside the box ends on its wall.
    let r = minimise(|x| (x[0] - 2.0).powi(2), |_| {}, &[0.5], &SimplexConfig::default(), |_| false);
    assert!((r.x[0] - 1.0).abs() < 1e-3);
    // The cap holds.
    let cfg = SimplexConfig { max_iterations: 7, ftol: 0.0, ..SimplexConfig::default() };
    assert!(minimise(rosenbrock, |_| {}, &[0.2, 0.9], &cfg, |_| false).iterations <= 7);
}

#[test]
fn conjugate_gradients_reach_known_optima_inside_the_box() {
    // F26: the same analytic functions as the simplex's F25.
    for (f, x0, optimum, tol, cap) in [
        (sphere as fn(&[f64]) -> f64, vec![0.9, 0.1, 0.6], vec![0.3, 0.3, 0.3], 1e-3, 30),
        (rosenbrock, vec![0.2, 0.9], vec![0.75, 0.75], 2e-2, 200),
        // The optimum outside the box: the search stops on the wall.
        (|x: &[f64]| (x[0] - 1.4).powi(2) + (x[1] - 0.5).powi(2), vec![0.2, 0.2], vec![1.0, 0.5], 1e-3, 30),
    ] {
        // Forward differences' O(h) error stalls them in Rosenbrock's curved valley (at
        // h = 1e-3 they stop near (0.67, 0.62)); they are tested on the other two.
        let modes: &[Differences] =
            if cap == 200 { &[Differences::Central] } else { &[Differences::Central, Differences::Forward] };
        for &differences in modes {
            let mut outside = 0;
            let cfg = GradientConfig { max_iterations: cap, differences, ..GradientConfig::default() };
            let r = descend(
                |x| {
                    outside += x.iter().any(|c| !(0.0..=1.0).contains(c)) as usize;
                    f(x)
                },
                |_| {},
                &x0,
                &cfg,
                |_| false,
            );
            assert_eq!(outside, 0);
            assert!(r.iterations <= cap);
            assert!(r.trace.windows(2).all(|w| w[1] <= w[0]), "{:?}", r.trace);
            assert!(r.loss <= f(&x0));
            let err = r.x.iter().zip(&optimum).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            assert!(err < tol, "{differences:?} {:?} from {x0:?}: {:?} (loss {})", optimum, r.x, r.loss);
        }
    }
}

#[test]
fn a_gradient_costs_2n_renders_central_and_n_forward() {
    // F26: beside the loss at the point, which the caller already has.
    let x = vec![0.4, 0.5, 0.6];
    for (differences, expected) in [(Differences::Central, 6), (Differences::Forward, 3)] {
        let cfg = GradientConfig { differences, ..GradientConfig::default() };
        let mut calls = 0;
        let mut eval = |p: &mut Vec<f64>| {
            calls += 1;
            sphere(p)
        };
        let (g, renders) = gradient::gradient(&mut eval, &x, sphere(&x), &cfg);
        assert_eq!((renders, calls), (expected, expected));
        for (i, v) in g.iter().enumerate() {
            let exact = 2.0 * (x[i] - 0.3);
            assert!((v - exact).abs() < 2e-3, "{differences:?} {i}: {v} vs {exact}");
        }
    }
    // A whole-number axis whose small step snaps back has no derivative.
    let mut eval = |p: &mut Vec<f64>| {
        p[0] = (p[0] * 4.0).round() / 4.0;
        sphere(p)
    };
    let (g, _) = gradient::gradient(&mut eval, &[0.5, 0.5], 0.08, &GradientConfig::default());
    assert_eq!(g[0], 0.0);
    assert!(g[1] > 0.0);
}

/// The library's catalogues at the default side, each built once, when a test first needs it.
pub(super) struct Library {
    pub spaces: Vec<Space>,
    catalogues: Vec<OnceLock<Catalogue<Feature>>>,
}

pub(super) const SIDE: usize = 128;

pub(super) fn library() -> &'static Library {
    static LIBRARY: OnceLock<Library> = OnceLock::new();
    LIBRARY.get_or_init(|| {
        let spaces: Vec<Space> = shader::LIBRARY.iter().map(|d| Space::new(d)).collect();
        let catalogues = spaces.iter().map(|_| OnceLock::new()).collect();
        Library { spaces, catalogues }
    })
}

impl Library {
    pub fn catalogue(&'static self, i: usize) -> &'static Catalogue<Feature> {
        self.catalogues[i]
            .get_or_init(|| build_catalogue(&probe(&self.spaces[i], SIDE), &CatalogueConfig::default(), 1))
    }
}

/// The library's shaders named in `only` (all when empty) with their catalogues, in the
/// library's order.
pub(super) fn candidates(only: &[&str]) -> Vec<Candidate<'static>> {
    let lib = library();
    let chosen: Vec<usize> =
        (0..lib.spaces.len()).filter(|&i| only.is_empty() || only.contains(&lib.spaces[i].shader.name)).collect();
    // Built here, on the test's thread: a rayon worker blocked on a cell another job of its own
    // stack is filling would deadlock.
    chosen.iter().map(|&i| Candidate { probe: probe(&lib.spaces[i], SIDE), catalogue: lib.catalogue(i) }).collect()
}

pub(super) fn target(name: &str, set: &[(usize, f64)]) -> (Vec<f64>, Feature) {
    let def = shader::shader(name).unwrap();
    let mut v = def.defaults();
    for &(i, x) in set {
        v[i] = x;
    }
    let img = shader::render_square(def, &v, 7, SIDE).unwrap();
    (v, feature(&img, &Metric::default()))
}

fn assert_recovered(name: &str, set: &[(usize, f64)]) -> MatchRecord {
    let (v, f) = target(name, set);
    let r = match_target(&f, &candidates(&[]), &MatchConfig::default()).unwrap();
    assert_eq!(r.status, Status::Matched);
    assert_eq!(r.shader, name, "{r:?}");
    let space = Space::new(shader::shader(name).unwrap());
    for a in &space.axes {
        let d = (r.values[a.index] - v[a.index]).abs() / (a.max - a.min);
        assert!(d <= 1.0 / 256.0, "{name}.{}: {} for {}", a.name, r.values[a.index], v[a.index]);
    }
    assert!(r.score > 0.999, "{}", r.score);
    r
}

#[test]
fn deterministic_targets_off_the_catalogue_are_recovered_exactly() {
    // F27 (bar and weave; see the note for brick), F31 (whole numbers).
    assert_recovered("bar", &[(0, 0.37)]);
    assert_recovered("weave", &[(0, 7.3), (1, 0.55), (2, 0.42), (3, 0.3)]);
    let r = assert_recovered("star", &[(0, 4.0), (1, 0.15), (2, 0.4)]);
    assert_recovered("brick", &[(0, 0.3), (1, 0.1), (2, 0.02)]);
    assert_eq!(r.values[0], 4.0);
}

#[test]
fn conjugate_gradients_refine_a_match_too() {
    // F26 in the matcher: the bar's width from an off-catalogue target, by gradients alone.
    let (v, f) = target("bar", &[(0, 0.37)]);
    let cfg = MatchConfig { optimiser: Optimiser::Gradient, ..MatchConfig::default() };
    let r = match_target(&f, &candidates(&["bar", "circle"]), &cfg).unwrap();
    assert_eq!((r.status, r.shader.as_str()), (Status::Matched, "bar"));
    let space = Space::new(shader::shader("bar").unwrap());
    let a = &space.axes[0];
    let d = (r.values[a.index] - v[a.index]).abs() / (a.max - a.min);
    eprintln!(
        "F26: bar width {} for 0.37 (Δ {d:.5} of the range), S' {:.5}, {} renders",
        r.values[a.index], r.score, r.renders
    );
    assert!(d <= 1.0 / 256.0 && r.score > 0.999, "{r:?}");
    assert!(r.runs.iter().all(|run| run.iterations <= cfg.gradient.max_iterations));
}

#[test]
fn stochastic_targets_are_matched_by_similarity_not_parameters() {
    // F28: cyclone and clouds at random points, rendered with another seed than every render
    // the matcher makes. Parameters are not compared: the claim is the similarity. The ceiling
    // is what the generating parameters themselves score with the matcher's seed.
    let lib = library();
    let cands = candidates(&[]);
    let mut rng = crate::synth::rng::Rng::new(28);
    for name in ["cyclone", "clouds"] {
        let space = lib.spaces.iter().find(|s| s.shader.name == name).unwrap();
        for _ in 0..2 {
            let x: Vec<f64> = (0..space.dim()).map(|_| rng.next_f64()).collect();
            let img = shader::render_square(space.shader, &space.values(&x), 8, SIDE).unwrap();
            let f = feature(&img, &Metric::default());
            let r = match_target(&f, &cands, &MatchConfig::default()).unwrap();
            let ceiling = r.calibration.apply(similarity(&probe(space, SIDE).feature(&x), &f));
            eprintln!("F28 {name}: -> {} S' {:.4} (the generator with another seed: {ceiling:.4})", r.shader, r.score);
            assert_eq!(r.status, Status::Matched);
            assert!(r.score >= 0.9 && r.score >= ceiling - 0.02, "{name}: {} {} vs {ceiling}", r.shader, r.score);
        }
    }
}

/// The mean over `held` of (1 − the best calibrated similarity to any of `vertices`).
fn coverage_gap(cal: crate::synth::metrics::Calibration, vertices: &[Feature], held: &[Feature]) -> f64 {
    use rayon::prelude::*;
    let gaps: Vec<f64> = held
        .par_iter()
        .map(|h| 1.0 - vertices.iter().map(|v| cal.apply(similarity(v, h))).fold(0.0, f64::max))
        .collect();
    gaps.iter().sum::<f64>() / gaps.len() as f64
}

/// Pairs of `vertices` more alike than ω.
fn near_duplicates(cal: crate::synth::metrics::Calibration, vertices: &[Feature], omega: f64) -> usize {
    (0..vertices.len())
        .map(|a| (a + 1..vertices.len()).filter(|&b| cal.apply(similarity(&vertices[a], &vertices[b])) > omega).count())
        .sum()
}

/// F19's comparison on one shader at equal budget: the library's adaptive catalogue, a uniform
/// random catalogue and a grid of as many renders (at most), against 200 held-out random
/// renders. Returns the mean gaps and the near-duplicate pair counts, in that order.
fn adaptive_against_uniform(name: &str, pruning: super::Pruning) -> ([f64; 3], [usize; 3]) {
    use rayon::prelude::*;
    let lib = library();
    let i = lib.spaces.iter().position(|s| s.shader.name == name).unwrap();
    let p = probe(&lib.spaces[i], SIDE);
    let built;
    let cat = if pruning == CatalogueConfig::default().pruning {
        lib.catalogue(i)
    } else {
        built = build_catalogue(&p, &CatalogueConfig { pruning, ..CatalogueConfig::default() }, 1);
        &built
    };
    let (n, dim) = (cat.len(), p.dim());
    let feats = |points: &[Vec<f64>]| -> Vec<Feature> { points.par_iter().map(|x| p.feature(x)).collect() };
    let mut rng = crate::synth::rng::Rng::new(19);
    let random: Vec<Vec<f64>> = (0..n).map(|_| (0..dim).map(|_| rng.next_f64()).collect()).collect();
    let per_axis = ((n as f64).powf(1.0 / dim as f64).floor() as usize).max(1);
    let cell = |k: usize, a: usize| ((k / per_axis.pow(a as u32)) % per_axis) as f64;
    let grid: Vec<Vec<f64>> = (0..per_axis.pow(dim as u32))
        .map(|k| (0..dim).map(|a| (cell(k, a) + 0.5) / per_axis as f64).collect())
        .collect();
    let held: Vec<Vec<f64>> = (0..200).map(|_| (0..dim).map(|_| rng.next_f64()).collect()).collect();
    let held = feats(&held);
    let (random, grid) = (feats(&random), feats(&grid));
    let cal = cat.calibration;
    let omega = CatalogueConfig::default().omega;
    let sets = [&cat.features, &random, &grid];
    let gaps = sets.map(|v| coverage_gap(cal, v, &held));
    let dups = sets.map(|v| near_duplicates(cal, v, omega));
    eprintln!(
        "F19 {name} (dim {dim}, {pruning:?} pruning): {n} renders; mean gap to 200 held-out renders: adaptive {:.4}, uniform random \
         {:.4}, grid of {} {:.4}; pairs above ω: {} / {} / {}",
        gaps[0],
        gaps[1],
        grid.len(),
        gaps[2],
        dups[0],
        dups[1],
        dups[2]
    );
    (gaps, dups)
}

#[test]
fn adaptive_sampling_wastes_no_renders_on_near_duplicates() {
    // F19, its second half, on the eyeball and the weave (Figs. 4-4 and 4-5).
    for name in ["eyeball", "weave"] {
        for pruning in [super::Pruning::Redundancy, super::Pruning::Coverage] {
            let (_, dups) = adaptive_against_uniform(name, pruning);
            assert!(dups[0] < dups[1] && dups[0] <= dups[2], "{name} {pruning:?}: {dups:?}");
        }
    }
}

#[test]
fn adaptive_sampling_covers_held_out_renders_better_than_uniform_sampling() {
    // F19, its first half: the mean of (1 − the best calibrated similarity to the catalogue)
    // over 200 held-out random renders is lower for the adaptive catalogue. It holds with
    // coverage pruning; the thesis's λ pruning (the default) fails it, and this test says so
    // too, so a change to either shows here.
    for name in ["eyeball", "weave"] {
        let (gaps, _) = adaptive_against_uniform(name, super::Pruning::Coverage);
        assert!(gaps[0] < gaps[1] && gaps[0] < gaps[2], "{name}, coverage pruning: {gaps:?}");
        let (gaps, _) = adaptive_against_uniform(name, super::Pruning::Redundancy);
        assert!(gaps[0] > gaps[1], "{name}, λ pruning now beats random sampling: {gaps:?}");
    }
}

#[test]
fn random_targets_are_matched_to_their_shader_or_an_equal_one() {
    // F29 (the generating shader, or another at least as good within 0.01), F30's second half
    // (in-range targets are matched).
    let lib = library();
    let cands = candidates(&[]);
    let mut rng = crate::synth::rng::Rng::new(29);
    let (mut hits, mut total) = (0, 0);
    for space in &lib.spaces {
        for _ in 0..3 {
            let x: Vec<f64> = (0..space.dim()).map(|_| rng.next_f64()).collect();
            let f = probe(space, SIDE).feature(&x);
            let r = match_target(&f, &cands, &MatchConfig::default()).unwrap();
            total += 1;
            assert_eq!(r.status, Status::Matched, "{} -> {} {}", space.shader.name, r.shader, r.score);
            let hit = r.shader == space.shader.name || r.score >= 0.99;
            hits += hit as usize;
            eprintln!("{} -> {} {:?} S' {:.4}", space.shader.name, r.shader, r.status, r.score);
        }
    }
    eprintln!("F29: {hits} of {total}");
    assert!(hits * 10 >= 9 * total, "{hits} of {total}");
}

#[test]
fn a_target_no_shader_can_make_is_no_good_match() {
    // F30.
    let checker = crate::raster::Image::from_fn(SIDE, SIDE, 3, |x, y, _| (((x / 16) + (y / 16)) % 2) as f32);
    let r = match_target(&feature(&checker, &Metric::default()), &candidates(&[]), &MatchConfig::default()).unwrap();
    assert_eq!(r.status, Status::NoGoodMatch, "{} {}", r.shader, r.score);
}

#[test]
fn screening_scans_only_the_candidates_and_the_scan_finds_a_catalogue_image() {
    // F22, F23, F24.
    let lib = library();
    let circle = lib.spaces.iter().position(|s| s.shader.name == "circle").unwrap();
    let v = 17;
    let f = lib.catalogue(circle).features[v].clone();
    let cands = candidates(&["circle", "rectangle"]);
    let r = match_target(&f, &cands, &MatchConfig::default()).unwrap();
    assert!(r.scanned.iter().all(|s| s == "circle" || s == "rectangle"));
    assert_eq!((r.runs[0].shader.as_str(), r.runs[0].vertex, r.runs[0].start), ("circle", v, 1.0));
    // Within a tie, smoother seeds first.
    let cfg = MatchConfig { tie: 1.0, ..MatchConfig::default() };
    let r = match_target(&f, &cands, &cfg).unwrap();
    assert!(r.runs.windows(2).all(|w| w[0].roughness <= w[1].roughness));
}

#[test]
fn accept_at_stops_early() {
    // F33.
    let (_, f) = target("bar", &[(0, 0.37)]);
    let cands = candidates(&[]);
    let full = match_target(&f, &cands, &MatchConfig::default()).unwrap();
    let early = match_target(&f, &cands, &MatchConfig { accept_at: Some(0.98), ..MatchConfig::default() }).unwrap();
    assert!(early.score >= 0.98);
    assert!(early.renders < full.renders, "{} {}", early.renders, full.renders);
}

#[test]
fn no_candidates_is_an_error() {
    let (_, f) = target("bar", &[(0, 0.37)]);
    assert_eq!(match_target(&f, &[], &MatchConfig::default()).unwrap_err(), MatchError::NoCandidates);
}
