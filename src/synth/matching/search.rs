//! Matching a target image against catalogued shaders ([references: bourque §4.3] and §4.4):
//!
//! 1. **Screening**: each shader's screening subset against the target; shaders whose best
//!    calibrated similarity reaches `screen` stay, and the `keep` best always do (16 by
//!    default, the whole library: the scan of every catalogue costs less than one local
//!    search, and a 16-render subset can miss a shader's narrow basin altogether).
//! 2. **Scan** (Eq. 4.6): every vertex of the kept catalogues; the best `per_shader` of each
//!    shader; of those, the best of every shader and the `seeds` best others, in decreasing
//!    similarity, seeds within `tie` of each other taken smoothest first
//!    (lowest `H`). A shader that passed screening always gets its own local search: its best
//!    vertex can rank below another shader's near misses (a brick wall's peaks a little off
//!    the target's score lower than a blur) and still be the only one in the right basin.
//! 3. **Refinement**: the bounded simplex (or, with [`Optimiser::Gradient`], conjugate
//!    gradients) from each seed, `batch` seeds at a time (in parallel; the batch size, not the
//!    thread count, fixes which seeds run, so results do not depend on the machine), stopping
//!    early once a result reaches `accept_at`; then a sweep of ±1 over the integer parameters
//!    of the best point.
//! 4. **Status**: `matched` when the best calibrated similarity reaches `residual`, else
//!    `no good match` (the target is outside what the library can make).
//!
//! Scores are calibrated across the library ([`Calibration`] from pairs of screening vertices
//! of different shaders), so thresholds mean the same whichever shaders are candidates.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::catalogue::{Catalogue, Oracle};
use super::gradient::{descend, GradientConfig};
use super::probe::{similarity, Feature, Probe};
use super::simplex::{minimise, SimplexConfig};
use super::space::Space;
use crate::synth::metrics::Calibration;

/// A catalogued shader offered to the matcher.
pub struct Candidate<'a> {
    pub probe: Probe<'a>,
    pub catalogue: &'a Catalogue<Feature>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MatchConfig {
    /// Calibrated similarity a shader's screening subset must reach to be scanned.
    pub screen: f64,
    /// Shaders scanned whatever their screening score (the best ones).
    pub keep: usize,
    pub per_shader: usize,
    /// Seeds beyond each scanned shader's best vertex.
    pub seeds: usize,
    /// Seeds whose calibrated similarities differ by at most this are ordered by roughness.
    pub tie: f64,
    pub batch: usize,
    /// The local search refining each seed, and the settings of both.
    pub optimiser: Optimiser,
    pub simplex: SimplexConfig,
    pub gradient: GradientConfig,
    /// A calibrated similarity that ends the search as soon as a result reaches it.
    pub accept_at: Option<f64>,
    /// Calibrated similarity below which the result is `no good match`.
    pub residual: f64,
}

impl Default for MatchConfig {
    fn default() -> Self {
        MatchConfig {
            screen: 0.6,
            keep: 16,
            per_shader: 4,
            seeds: 8,
            tie: 0.005,
            batch: 2,
            optimiser: Optimiser::Simplex,
            simplex: SimplexConfig::default(),
            gradient: GradientConfig::default(),
            accept_at: None,
            residual: 0.8,
        }
    }
}

/// The local search of step 3.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Optimiser {
    /// The bounded downhill simplex (the thesis's choice).
    Simplex,
    /// Conjugate gradients on finite differences (the thesis's alternative).
    Gradient,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    Matched,
    NoGoodMatch,
}

/// One local search, for the record.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SeedRun {
    pub shader: String,
    /// The catalogue vertex it started from, its calibrated similarity and roughness.
    pub vertex: usize,
    pub start: f64,
    pub roughness: f64,
    /// The calibrated similarity it reached, in how many iterations and renders.
    pub reached: f64,
    pub iterations: usize,
    pub renders: usize,
}

/// The result of a match.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MatchRecord {
    pub status: Status,
    pub shader: String,
    /// The flat parameter vector.
    pub values: Vec<f64>,
    /// Raw similarity `S` of the match's render to the target, and calibrated `S'`.
    pub similarity: f64,
    pub score: f64,
    /// The library calibration.
    pub calibration: Calibration,
    /// Shaders that passed screening, in scan order.
    pub scanned: Vec<String>,
    pub runs: Vec<SeedRun>,
    /// Renders of the whole match.
    pub renders: usize,
}

/// Why nothing can be matched.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MatchError {
    #[error("no shader to match against")]
    NoCandidates,
}

/// The library calibration: pairs of screening vertices of different shaders (or of one, if
/// there is only one).
pub fn library_calibration(cands: &[Candidate]) -> Calibration {
    calibration_of(&cands.iter().map(|c| c.catalogue).collect::<Vec<_>>())
}

/// [`library_calibration`] of catalogues.
pub fn calibration_of(cats: &[&Catalogue<Feature>]) -> Calibration {
    let mut sims = Vec::new();
    for (a, ca) in cats.iter().enumerate() {
        for (b, cb) in cats.iter().enumerate().skip(a + (cats.len() > 1) as usize) {
            for &i in &ca.screen {
                for &j in &cb.screen {
                    if a != b || i < j {
                        sims.push(similarity(&ca.features[i], &cb.features[j]));
                    }
                }
            }
        }
    }
    Calibration::from_pairs(&sims).unwrap_or(Calibration { d0: 1.0 })
}

struct Seed {
    cand: usize,
    vertex: usize,
    score: f64,
    roughness: f64,
}

/// Matches `target` (the feature of the target at the probes' side, computed with their
/// metric) against `cands` (see the module documentation).
pub fn match_target(target: &Feature, cands: &[Candidate], cfg: &MatchConfig) -> Result<MatchRecord, MatchError> {
    if cands.is_empty() || cands.iter().all(|c| c.catalogue.is_empty()) {
        return Err(MatchError::NoCandidates);
    }
    let cal = library_calibration(cands);
    let score = |f: &Feature| cal.apply(similarity(f, target));

    // Screening.
    let screened: Vec<f64> = cands
        .iter()
        .map(|c| c.catalogue.screen.iter().map(|&i| score(&c.catalogue.features[i])).fold(0.0, f64::max))
        .collect();
    let mut order: Vec<usize> = (0..cands.len()).filter(|&i| !cands[i].catalogue.is_empty()).collect();
    order.sort_by(|&a, &b| screened[b].total_cmp(&screened[a]).then(a.cmp(&b)));
    let kept: Vec<usize> = order
        .iter()
        .enumerate()
        .filter(|&(rank, &i)| rank < cfg.keep || screened[i] >= cfg.screen)
        .map(|(_, &i)| i)
        .collect();

    // Scan.
    let mut seeds = Vec::new();
    for &c in &kept {
        let cat = cands[c].catalogue;
        let s: Vec<f64> = cat.features.par_iter().map(score).collect();
        let mut idx: Vec<usize> = (0..s.len()).collect();
        idx.sort_by(|&a, &b| s[b].total_cmp(&s[a]).then(a.cmp(&b)));
        for &v in idx.iter().take(cfg.per_shader.max(1)) {
            seeds.push(Seed { cand: c, vertex: v, score: s[v], roughness: cat.roughness[v] });
        }
    }
    // Every scanned shader's best vertex, then the best of the rest up to `seeds`.
    let by_score = |a: &Seed, b: &Seed| b.score.total_cmp(&a.score).then((a.cand, a.vertex).cmp(&(b.cand, b.vertex)));
    let (mut firsts, mut rest): (Vec<Seed>, Vec<Seed>) = {
        let mut seen = Vec::new();
        seeds.into_iter().partition(|s| {
            let first = !seen.contains(&s.cand);
            seen.push(s.cand);
            first
        })
    };
    rest.sort_by(by_score);
    rest.truncate(cfg.seeds);
    firsts.append(&mut rest);
    let mut seeds = firsts;
    seeds.sort_by(by_score);
    order_by_roughness(&mut seeds, cfg.tie);

    // Refinement.
    let mut runs = Vec::new();
    let mut best: Option<(usize, Vec<f64>, f64)> = None;
    let mut renders = 0;
    for batch in seeds.chunks(cfg.batch.max(1)) {
        let results: Vec<_> = batch
            .par_iter()
            .map(|s| {
                let c = &cands[s.cand];
                let x0 = &c.catalogue.points[s.vertex];
                let loss = |x: &[f64]| 1.0 - similarity(&c.probe.feature(x), target);
                let snap = |x: &mut [f64]| c.probe.snap(x);
                let stop = |loss: f64| cfg.accept_at.is_some_and(|a| cal.apply(1.0 - loss) >= a);
                let r = match cfg.optimiser {
                    Optimiser::Simplex => minimise(loss, snap, x0, &cfg.simplex, stop),
                    Optimiser::Gradient => descend(loss, snap, x0, &cfg.gradient, stop),
                };
                (s, r)
            })
            .collect();
        for (s, r) in results {
            let reached = cal.apply(1.0 - r.loss);
            renders += r.evaluations;
            runs.push(SeedRun {
                shader: cands[s.cand].probe.space.shader.name.to_string(),
                vertex: s.vertex,
                start: s.score,
                roughness: s.roughness,
                reached,
                iterations: r.iterations,
                renders: r.evaluations,
            });
            if best.as_ref().is_none_or(|b| reached > b.2) {
                best = Some((s.cand, r.x, reached));
            }
        }
        if cfg.accept_at.is_some_and(|a| best.as_ref().is_some_and(|b| b.2 >= a)) {
            break;
        }
    }
    let (c, mut x, _) = best.expect("at least one seed");
    let probe = &cands[c].probe;
    let mut loss = 1.0 - similarity(&probe.feature(&x), target);
    renders += 1;
    renders += integer_sweep(probe, probe.space, target, &cfg.simplex, &mut x, &mut loss);
    let similarity = 1.0 - loss;
    let score = cal.apply(similarity);
    Ok(MatchRecord {
        status: if score >= cfg.residual { Status::Matched } else { Status::NoGoodMatch },
        shader: probe.space.shader.name.to_string(),
        values: probe.space.values(&x),
        similarity,
        score,
        calibration: cal,
        scanned: kept.iter().map(|&i| cands[i].probe.space.shader.name.to_string()).collect(),
        runs,
        renders,
    })
}

/// Seeds sorted by decreasing score; within a run of scores no more than `tie` below its
/// first, the smoothest (lowest roughness) first.
fn order_by_roughness(seeds: &mut [Seed], tie: f64) {
    let mut i = 0;
    while i < seeds.len() {
        let mut j = i + 1;
        while j < seeds.len() && seeds[i].score - seeds[j].score <= tie {
            j += 1;
        }
        seeds[i..j]
            .sort_by(|a, b| a.roughness.total_cmp(&b.roughness).then((a.cand, a.vertex).cmp(&(b.cand, b.vertex))));
        i = j;
    }
}

/// Steps each integer axis by ±1 while that lowers the loss (the simplex moves integer axes
/// as reals, and between whole numbers the loss is flat). Each neighbour first gets a short
/// simplex over the real axes with the whole numbers held: a star of five points tuned as five
/// is worse than the start as four, tuned as four it is the match. Returns the renders made.
fn integer_sweep(
    probe: &Probe,
    space: &Space,
    target: &Feature,
    cfg: &SimplexConfig,
    x: &mut Vec<f64>,
    loss: &mut f64,
) -> usize {
    let reals: Vec<usize> = (0..space.dim()).filter(|&i| space.quantum(i) == 0.0).collect();
    let short = SimplexConfig { max_iterations: cfg.max_iterations.min(40), restarts: 0, ..cfg.clone() };
    let mut renders = 0;
    for _ in 0..8 {
        let mut improved = false;
        for i in 0..space.dim() {
            let q = space.quantum(i);
            if q == 0.0 {
                continue;
            }
            for sign in [-1.0, 1.0] {
                let mut y = x.clone();
                y[i] += sign * q;
                space.snap(&mut y);
                if y == *x {
                    continue;
                }
                let held = y.clone();
                let full = |r: &[f64]| {
                    let mut z = held.clone();
                    for (&k, &v) in reals.iter().zip(r) {
                        z[k] = v;
                    }
                    z
                };
                let r0: Vec<f64> = reals.iter().map(|&k| y[k]).collect();
                let r = minimise(
                    |r| 1.0 - similarity(&probe.feature(&full(r)), target),
                    |r| {
                        let mut z = full(r);
                        space.snap(&mut z);
                        for (k, v) in reals.iter().zip(r.iter_mut()) {
                            *v = z[*k];
                        }
                    },
                    &r0,
                    &short,
                    |_| false,
                );
                renders += r.evaluations;
                if r.loss < *loss {
                    (*x, *loss) = (full(&r.x), r.loss);
                    improved = true;
                }
            }
        }
        if !improved {
            break;
        }
    }
    renders
}
