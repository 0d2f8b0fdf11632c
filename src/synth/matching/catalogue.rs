//! A shader's catalogue by adaptive random sampling ([references: bourque §4.3], Eqs. 4.2–4.5):
//! renders at points of its parameter space chosen so that they cover what the shader can
//! look like, with every pair's similarity (the full graph matching scans and transformations
//! walk) and a much smaller subset for screening.
//!
//! 1. **Construction**: `k` uniform points; one too similar to a kept vertex (`S' > ω`) is
//!    dropped; a kept one gets its local roughness `H` (Eq. 4.2) from `2·dim` axis neighbours.
//! 2. **Refinement**, while the coverage `κ` (Eq. 4.3) is above its threshold: `k` more uniform
//!    points, then `local` points within `radius` of each of the `q` most isolated vertices by
//!    `γ` (Eq. 4.4: roughness and distance to the nearest vertex, as the thesis's text says;
//!    its formula's farthest vertex is an option).
//! 3. **Pruning** to the cap by redundancy `λ` (Eq. 4.5): the most redundant vertices go, all
//!    at once as the thesis does; or ([`Pruning::Coverage`], our option) one vertex at a time,
//!    the one whose loss costs the graph's coverage of its own vertices least.
//!
//! The screening subset removes one most-redundant vertex at a time (λ recomputed), down to its
//! cap: one cut from 200 to 16 would keep only the outliers.
//!
//! Similarities are calibrated per catalogue ([`Calibration`], `d₀` the median distance of the
//! first `k` random points), so `ω` and `κ` mean the same for a shader of noise and one of
//! hard edges. The builder is generic over an [`Oracle`] (a space, its renders' features and
//! their similarity) so its steps can be tested on shaders with known behaviour; features are
//! computed in parallel, decisions are taken in a fixed order: same seed, same catalogue.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::synth::metrics::Calibration;
use crate::synth::rng::Rng;

/// What a catalogue samples: points of the unit cube, their renders' features and a raw
/// similarity in `[0, 1]` between features.
pub trait Oracle: Sync {
    type Feature: Send + Sync;
    fn dim(&self) -> usize;
    /// Moves a point onto one a render can show (whole numbers whole).
    fn snap(&self, _x: &mut [f64]) {}
    fn feature(&self, x: &[f64]) -> Self::Feature;
    fn similarity(&self, a: &Self::Feature, b: &Self::Feature) -> f64;
}

/// The sampling constants (the thesis names them without values; defaults are tessera's).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CatalogueConfig {
    /// Random points per construction or refinement step.
    pub k: usize,
    /// Calibrated similarity above which a new point duplicates a vertex.
    pub omega: f64,
    /// Exponent of the coverage measure.
    pub sigma: f64,
    /// Weights of roughness and isolation in `γ`.
    pub alpha: f64,
    pub beta: f64,
    /// `γ` takes the farthest vertex (the printed formula) instead of the nearest (the text).
    pub gamma_farthest: bool,
    /// Most isolated vertices resampled per round, and points around each, within `radius`.
    pub q: usize,
    pub local: usize,
    pub radius: f64,
    /// Axis step of the roughness neighbourhood.
    pub h_step: f64,
    /// Vertex cap of the full graph and of the screening subset.
    pub cap: usize,
    /// Which vertices go when the graph is over its cap.
    pub pruning: Pruning,
    pub screen_cap: usize,
    /// Refinement stops once `κ` is at most this, or after `rounds` rounds.
    pub kappa: f64,
    pub rounds: usize,
}

impl Default for CatalogueConfig {
    fn default() -> Self {
        CatalogueConfig {
            k: 48,
            omega: 0.98,
            sigma: 2.0,
            alpha: 0.5,
            beta: 0.5,
            gamma_farthest: false,
            q: 6,
            local: 4,
            radius: 0.05,
            h_step: 0.02,
            cap: 160,
            pruning: Pruning::Redundancy,
            screen_cap: 16,
            kappa: 0.004,
            rounds: 4,
        }
    }
}

/// How a graph over its cap is pruned.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Pruning {
    /// The thesis's Eq. 4.5: the vertices with the largest redundancy λ (summed similarity to
    /// every other vertex) go, all at once. It keeps the renders least like the rest, so the
    /// common looks of a shader thin out: measured on the eyeball and the weave, a catalogue
    /// pruned this way covers held-out random renders worse than as many random renders do.
    /// It stays the default because the unusual looks it keeps are what real photographs
    /// need: the example brick wall finds the brick through them, and a starfield without.
    #[default]
    Redundancy,
    /// (Ours, not the thesis's.) The vertex whose loss costs the graph's coverage of its own vertices least
    /// goes, one at a time: each vertex is covered by its most similar kept vertex (itself
    /// while kept), and the cost of a removal is how much the vertices it covers lose by
    /// falling back to their next best, weighed by how many uniform points each stands for
    /// (local samples stand for none). One of two near-twins goes long before a unique render,
    /// and a common look keeps as many renders as the parameter space gives it.
    Coverage,
}

/// One refinement round, for the catalogue's manifest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Round {
    /// Coverage before the round.
    pub kappa: f64,
    pub added: usize,
    pub duplicates: usize,
    pub pruned: usize,
}

/// A built catalogue: vertices in the unit cube, their features, the calibrated similarity of
/// every pair and their roughness, and the screening subset.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Catalogue<F> {
    pub points: Vec<Vec<f64>>,
    pub features: Vec<F>,
    pub calibration: Calibration,
    /// Calibrated similarities, `n × n`, row-major, symmetric with a unit diagonal.
    pub weights: Vec<f64>,
    /// Local roughness `H` of each vertex (Eq. 4.2).
    pub roughness: Vec<f64>,
    /// Indices of the screening subset, ascending.
    pub screen: Vec<usize>,
    pub rounds: Vec<Round>,
    /// Coverage after the last round.
    pub kappa: f64,
    /// Features computed (renders) and similarities evaluated while building.
    pub features_computed: usize,
    pub comparisons: usize,
}

impl<F> Catalogue<F> {
    pub fn len(&self) -> usize {
        self.points.len()
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    pub fn weight(&self, a: usize, b: usize) -> f64 {
        self.weights[a * self.len() + b]
    }
}

/// Coverage (Eq. 4.3) of a weight matrix given as rows: over ordered pairs, divided by the
/// number of unordered edges, as printed (it shrinks as the graph grows when `σ > 1`).
pub fn kappa(rows: &[Vec<f64>], sigma: f64) -> f64 {
    let n = rows.len();
    if n < 2 {
        return 0.0;
    }
    let mut sum = 0.0;
    for (l, row) in rows.iter().enumerate() {
        for (m, &e) in row.iter().enumerate() {
            if l != m {
                sum += (1.0 - e).max(0.0).powf(sigma);
            }
        }
    }
    let edges = (n * (n - 1) / 2) as f64;
    sum.powf(1.0 / sigma) / edges
}

/// Redundancy λ (Eq. 4.5) of every vertex.
pub fn redundancy(rows: &[Vec<f64>]) -> Vec<f64> {
    rows.iter()
        .enumerate()
        .map(|(l, row)| row.iter().enumerate().filter(|&(m, _)| m != l).map(|(_, e)| e).sum())
        .collect()
}

/// Isolation γ (Eq. 4.4) of every vertex, roughness rescaled to `[0, 1]` by its maximum.
pub fn isolation(rows: &[Vec<f64>], roughness: &[f64], cfg: &CatalogueConfig) -> Vec<f64> {
    let hmax = roughness.iter().copied().fold(0.0, f64::max);
    rows.iter()
        .enumerate()
        .map(|(l, row)| {
            let others = row.iter().enumerate().filter(|&(m, _)| m != l).map(|(_, e)| 1.0 - e);
            let d = if cfg.gamma_farthest { others.fold(0.0, f64::max) } else { others.fold(f64::INFINITY, f64::min) };
            let d = if d.is_finite() { d } else { 0.0 };
            let h = if hmax > 0.0 { roughness[l] / hmax } else { 0.0 };
            cfg.alpha * h + cfg.beta * d
        })
        .collect()
}

/// The index among `candidates` with the largest score, ties to the lowest index (a fixed
/// choice); `None` when there are no candidates.
pub(super) fn largest(score: &[f64], candidates: impl Iterator<Item = usize>) -> Option<usize> {
    candidates.max_by(|&a, &b| score[a].total_cmp(&score[b]).then(b.cmp(&a)))
}

/// Indices sorted by a score, largest first, ties by index (a fixed order).
fn ranked(score: &[f64]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..score.len()).collect();
    idx.sort_by(|&a, &b| score[b].total_cmp(&score[a]).then(a.cmp(&b)));
    idx
}

struct Builder<'a, O: Oracle> {
    oracle: &'a O,
    cfg: &'a CatalogueConfig,
    cal: Calibration,
    points: Vec<Vec<f64>>,
    features: Vec<O::Feature>,
    rows: Vec<Vec<f64>>,
    roughness: Vec<f64>,
    /// How many uniform points each vertex stands for: 1 for its own (0 for a local sample),
    /// plus the duplicates it turned away and the vertices pruned in its favour. Coverage
    /// pruning weighs vertices by it, so the graph keeps covering the shader's parameter
    /// space as a whole rather than the looks its earlier rounds kept.
    mass: Vec<f64>,
    features_computed: usize,
    comparisons: usize,
}

impl<O: Oracle> Builder<'_, O> {
    fn sim(&self, a: &O::Feature, b: &O::Feature) -> f64 {
        self.cal.apply(self.oracle.similarity(a, b))
    }

    fn features(&mut self, points: &[Vec<f64>]) -> Vec<O::Feature> {
        self.features_computed += points.len();
        points.par_iter().map(|x| self.oracle.feature(x)).collect()
    }

    /// `H` (Eq. 4.2) of a point from its axis neighbours `x ± h·e_i` (clamped into the cube;
    /// an integer axis steps by at least one whole number).
    fn roughness_of(&self, x: &[f64], f: &O::Feature) -> (f64, usize) {
        let dim = self.oracle.dim();
        let mut sum = 0.0;
        let mut count = 0;
        let mut renders = 0;
        for i in 0..dim {
            for sign in [-1.0, 1.0] {
                let mut d = x.to_vec();
                d[i] = (d[i] + sign * self.cfg.h_step).clamp(0.0, 1.0);
                self.oracle.snap(&mut d);
                if d[i] == x[i] {
                    // An integer axis rounds a small step away: take one whole number.
                    d = bisect_step(self.oracle, x, i, sign);
                }
                let dist = d.iter().zip(x).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
                if dist == 0.0 {
                    continue;
                }
                renders += 1;
                let fd = self.oracle.feature(&d);
                sum += (1.0 - self.sim(f, &fd)) / dist;
                count += 1;
            }
        }
        (if count > 0 { sum / count as f64 } else { 0.0 }, renders)
    }

    /// Offers points in order; keeps those no vertex duplicates. Returns (kept, duplicates).
    fn offer(&mut self, mut points: Vec<Vec<f64>>, mass: f64) -> (usize, usize) {
        for x in &mut points {
            self.oracle.snap(x);
        }
        // A point offered twice, or snapped onto a vertex (whole numbers, the cube's walls), is
        // a duplicate without being rendered again.
        let bits = |x: &[f64]| -> Vec<u64> { x.iter().map(|c| c.to_bits()).collect() };
        let mut seen: std::collections::HashMap<Vec<u64>, Option<usize>> =
            self.points.iter().enumerate().map(|(i, x)| (bits(x), Some(i))).collect();
        let offered = points.len();
        points.retain(|x| match seen.get(&bits(x)) {
            Some(&vertex) => {
                // A repeat of a point offered in this call finds no vertex to credit yet.
                if let Some(v) = vertex {
                    self.mass[v] += mass;
                }
                false
            }
            None => {
                seen.insert(bits(x), None);
                true
            }
        });
        let repeated = offered - points.len();
        let feats = self.features(&points);
        let (kept, duplicates) = self.offer_rendered(points, feats, None, mass);
        (kept, duplicates + repeated)
    }

    /// Offers rendered points in order. `known` holds the raw similarity of every pair of
    /// these points (as [`pair_index`] orders them) when it was already computed, so no pair
    /// is compared twice.
    fn offer_rendered(
        &mut self,
        points: Vec<Vec<f64>>,
        feats: Vec<O::Feature>,
        known: Option<&[f64]>,
        mass: f64,
    ) -> (usize, usize) {
        let first = self.points.len();
        let n = points.len();
        let mut batch = Vec::new(); // the offered index of each vertex kept by this call
        let mut duplicates = 0;
        for (j, (x, f)) in points.into_iter().zip(feats).enumerate() {
            let row: Vec<f64> = match known {
                Some(raw) => {
                    let old = &self.features[..first];
                    let mut row: Vec<f64> = old.par_iter().map(|g| self.sim(&f, g)).collect();
                    self.comparisons += row.len();
                    row.extend(batch.iter().map(|&i| self.cal.apply(raw[pair_index(n, i, j)])));
                    row
                }
                None => {
                    self.comparisons += self.features.len();
                    self.features.par_iter().map(|g| self.sim(&f, g)).collect()
                }
            };
            if row.iter().any(|&e| e > self.cfg.omega) {
                duplicates += 1;
                let twin = largest(&row, 0..row.len()).expect("a row");
                self.mass[twin] += mass;
                continue;
            }
            batch.push(j);
            for (r, &e) in self.rows.iter_mut().zip(&row) {
                r.push(e);
            }
            let mut row = row;
            row.push(1.0);
            self.rows.push(row);
            self.points.push(x);
            self.features.push(f);
            self.mass.push(mass);
        }
        let fresh: Vec<(f64, usize)> = (first..self.points.len())
            .into_par_iter()
            .map(|i| self.roughness_of(&self.points[i], &self.features[i]))
            .collect();
        for (h, renders) in fresh {
            self.roughness.push(h);
            // Each neighbour is rendered once and compared once.
            self.features_computed += renders;
            self.comparisons += renders;
        }
        (self.points.len() - first, duplicates)
    }

    fn remove(&mut self, mut gone: Vec<usize>) {
        gone.sort_unstable();
        for &i in gone.iter().rev() {
            self.points.remove(i);
            self.features.remove(i);
            self.roughness.remove(i);
            self.mass.remove(i);
            self.rows.remove(i);
            for r in &mut self.rows {
                r.remove(i);
            }
        }
    }
}

/// The point one whole-number step from `x` along an integer axis `i` (found by bisection on
/// the normalised coordinate, so the builder needs no knowledge of the range).
fn bisect_step<O: Oracle>(oracle: &O, x: &[f64], i: usize, sign: f64) -> Vec<f64> {
    let (mut near, mut far) = (0.0, if sign > 0.0 { 1.0 - x[i] } else { x[i] });
    for _ in 0..60 {
        let mid = 0.5 * (near + far);
        let mut d = x.to_vec();
        d[i] = x[i] + sign * mid;
        oracle.snap(&mut d);
        if d[i] == x[i] {
            near = mid;
        } else {
            far = mid;
        }
    }
    let mut d = x.to_vec();
    d[i] = x[i] + sign * far;
    oracle.snap(&mut d);
    d
}

/// The position of the pair `a < b` of `n` points in the order `(0, 1), (0, 2), …, (1, 2), …`.
fn pair_index(n: usize, a: usize, b: usize) -> usize {
    a * n - a * (a + 1) / 2 + (b - a - 1)
}

/// `count` points around `parent`, each coordinate within `radius` of the parent's (the
/// radius is per axis, in normalised units) and inside the unit cube.
pub fn local_samples(rng: &mut Rng, parent: &[f64], radius: f64, count: usize) -> Vec<Vec<f64>> {
    (0..count).map(|_| parent.iter().map(|&c| (c + rng.range(-radius, radius)).clamp(0.0, 1.0)).collect()).collect()
}

fn uniform(rng: &mut Rng, dim: usize, n: usize) -> Vec<Vec<f64>> {
    (0..n).map(|_| (0..dim).map(|_| rng.next_f64()).collect()).collect()
}

/// Builds the catalogue of `oracle` (see the module documentation).
pub fn build<O: Oracle>(oracle: &O, cfg: &CatalogueConfig, seed: u64) -> Catalogue<O::Feature> {
    let dim = oracle.dim();
    let mut rng = Rng::new(seed);
    let k = cfg.k.max(2);
    let mut first = uniform(&mut rng, dim, if dim == 0 { 1 } else { k });
    for x in &mut first {
        oracle.snap(x);
    }
    // Calibrate on the first random points: their median distance scores 1/e.
    let feats: Vec<O::Feature> = first.par_iter().map(|x| oracle.feature(x)).collect();
    let pairs: Vec<(usize, usize)> = (0..feats.len()).flat_map(|a| (a + 1..feats.len()).map(move |b| (a, b))).collect();
    let raw: Vec<f64> = pairs.par_iter().map(|&(a, b)| oracle.similarity(&feats[a], &feats[b])).collect();
    let cal = Calibration::from_pairs(&raw).unwrap_or(Calibration { d0: 1.0 });
    let mut b = Builder {
        oracle,
        cfg,
        cal,
        points: Vec::new(),
        features: Vec::new(),
        rows: Vec::new(),
        roughness: Vec::new(),
        mass: Vec::new(),
        features_computed: feats.len(),
        comparisons: raw.len(),
    };
    b.offer_rendered(first, feats, Some(&raw), 1.0);
    let mut rounds = Vec::new();
    if dim > 0 {
        for _ in 0..cfg.rounds {
            let kappa = kappa(&b.rows, cfg.sigma);
            if kappa <= cfg.kappa {
                break;
            }
            let (mut added, mut duplicates) = b.offer(uniform(&mut rng, dim, k), 1.0);
            let gamma = isolation(&b.rows, &b.roughness, cfg);
            let mut local = Vec::new();
            for &v in ranked(&gamma).iter().take(cfg.q) {
                local.extend(local_samples(&mut rng, &b.points[v], cfg.radius, cfg.local));
            }
            let (a, d) = b.offer(local, 0.0);
            added += a;
            duplicates += d;
            let mut pruned = 0;
            let gone = match cfg.pruning {
                Pruning::Redundancy => pruned_set(&b.rows, cfg.cap.max(1)),
                Pruning::Coverage => coverage_pruned_set(&b.rows, &b.mass, cfg.cap.max(1)),
            };
            // What a pruned vertex stood for passes to the kept vertex most like it.
            let mut kept = vec![true; b.rows.len()];
            gone.iter().for_each(|&g| kept[g] = false);
            for &g in &gone {
                if let Some(h) = largest(&b.rows[g], (0..kept.len()).filter(|&v| kept[v])) {
                    b.mass[h] += b.mass[g];
                }
            }
            if !gone.is_empty() {
                pruned = gone.len();
                b.remove(gone);
            }
            rounds.push(Round { kappa, added, duplicates, pruned });
        }
    }
    let screen = screening_subset(&b.rows, cfg.screen_cap.max(1));
    let kappa = kappa(&b.rows, cfg.sigma);
    Catalogue {
        points: b.points,
        features: b.features,
        calibration: cal,
        weights: b.rows.into_iter().flatten().collect(),
        roughness: b.roughness,
        screen,
        rounds,
        kappa,
        features_computed: b.features_computed,
        comparisons: b.comparisons,
    }
}

/// The vertices pruning removes to bring the graph down to `cap`: the most redundant (largest
/// λ), all at once, ties by index.
pub fn pruned_set(rows: &[Vec<f64>], cap: usize) -> Vec<usize> {
    let excess = rows.len().saturating_sub(cap);
    ranked(&redundancy(rows)).into_iter().take(excess).collect()
}

/// The vertices coverage pruning removes to bring the graph down to `cap` (see
/// [`Pruning::Coverage`]), in the order it removes them; ties go to the lowest index.
pub fn coverage_pruned_set(rows: &[Vec<f64>], mass: &[f64], cap: usize) -> Vec<usize> {
    let n = rows.len();
    let mut alive = vec![true; n];
    // Each vertex's best and second-best kept cover: (similarity, vertex).
    let best_two = |u: usize, alive: &[bool]| -> [(f64, usize); 2] {
        let mut top = [(f64::NEG_INFINITY, usize::MAX); 2];
        for (v, &e) in rows[u].iter().enumerate() {
            if !alive[v] {
                continue;
            }
            if e > top[0].0 || (e == top[0].0 && v < top[0].1) {
                top[1] = top[0];
                top[0] = (e, v);
            } else if e > top[1].0 || (e == top[1].0 && v < top[1].1) {
                top[1] = (e, v);
            }
        }
        top
    };
    let mut cover: Vec<[(f64, usize); 2]> = (0..n).map(|u| best_two(u, &alive)).collect();
    let mut gone = Vec::with_capacity(n.saturating_sub(cap));
    for _ in cap..n {
        let mut cost = vec![0.0; n];
        for (c, &m) in cover.iter().zip(mass) {
            if c[1].1 != usize::MAX {
                cost[c[0].1] += m * (c[0].0 - c[1].0);
            }
        }
        let v =
            (0..n).filter(|&v| alive[v]).min_by(|&a, &b| cost[a].total_cmp(&cost[b]).then(a.cmp(&b))).expect("alive");
        alive[v] = false;
        gone.push(v);
        for (u, c) in cover.iter_mut().enumerate() {
            if c[0].1 == v || c[1].1 == v {
                *c = best_two(u, &alive);
            }
        }
    }
    gone
}

/// The screening subset: the most redundant vertex removed one at a time until `cap` remain.
pub fn screening_subset(rows: &[Vec<f64>], cap: usize) -> Vec<usize> {
    let n = rows.len();
    let mut alive: Vec<usize> = (0..n).collect();
    let mut lambda = redundancy(rows);
    while alive.len() > cap {
        let (pos, &v) = alive
            .iter()
            .enumerate()
            .max_by(|(_, &a), (_, &b)| lambda[a].total_cmp(&lambda[b]).then(b.cmp(&a)))
            .expect("more than cap ≥ 1 vertices");
        alive.remove(pos);
        for &u in &alive {
            lambda[u] -= rows[u][v];
        }
    }
    alive
}
