//! Jump points between two shaders ([references: bourque §ch5.3], Fig. 5-4): pairs of
//! parameter vectors, one per shader, whose renders look most alike, where a transformation
//! can switch from one shader to the other.
//!
//! 1. **Cross-comparison**: every vertex of one catalogue against every vertex of the other;
//!    the `pairs` best pairs that share no vertex (distinct regions of both spaces).
//! 2. **Alternation**: from each pair, the bounded simplex moves the first shader's point to
//!    match the second's render, then the second's to match the first's, until both move less
//!    than `step` in a round (normalised coordinates) or after `rounds` rounds.
//!
//! The result does not depend on the order of the two shaders: the search always runs from
//! the shader whose name sorts first, and swapped arguments get the swapped result.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::catalogue::Oracle;
use super::probe::{energy, similarity, Feature};
use super::search::{calibration_of, Candidate};
use super::simplex::{minimise, SimplexConfig};
use crate::synth::metrics::Calibration;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JumpConfig {
    /// Pairs kept from the cross-comparison, each refined into one jump point.
    pub pairs: usize,
    /// Alternation rounds at most, and the move (largest coordinate change) below which both
    /// points count as settled.
    pub rounds: usize,
    pub step: f64,
    /// Each half-round's simplex.
    pub simplex: SimplexConfig,
    /// Renders whose [`energy`] is below this fraction of their catalogue's median are not
    /// jump points: every shader can fade to a flat image, and two flat images are identical,
    /// so without this floor most jumps would pass through nothing (a rectangle shrinking away
    /// and a circle growing back). 0 allows such "plain background" jumps (Fig. 5-11); if no
    /// pair passes the floor, all pairs compete.
    pub presence: f64,
}

impl Default for JumpConfig {
    fn default() -> Self {
        JumpConfig {
            pairs: 3,
            rounds: 10,
            step: 1e-3,
            simplex: SimplexConfig { max_iterations: 60, restarts: 0, ..SimplexConfig::default() },
            presence: 0.25,
        }
    }
}

/// One jump point: a point of each shader's unit cube.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JumpPoint {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    /// Raw similarity of the two renders, and calibrated by the pair's calibration.
    pub similarity: f64,
    pub score: f64,
    /// Alternation rounds run, and whether both points settled before the cap.
    pub rounds: usize,
    pub settled: bool,
    pub renders: usize,
}

/// The jump points between two shaders, best first, and the calibration of their scores
/// (pairs of the two shaders' screening renders).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JumpSet {
    pub points: Vec<JumpPoint>,
    pub calibration: Calibration,
}

impl JumpSet {
    fn swapped(mut self) -> JumpSet {
        for p in &mut self.points {
            std::mem::swap(&mut p.x, &mut p.y);
        }
        self
    }
}

/// The jump points from `a`'s shader to `b`'s (see the module documentation).
pub fn jump_points(a: &Candidate, b: &Candidate, cfg: &JumpConfig) -> JumpSet {
    if a.probe.space.shader.name > b.probe.space.shader.name {
        return jump_points(b, a, cfg).swapped();
    }
    let calibration = calibration_of(&[a.catalogue, b.catalogue]);
    let (fa, fb) = (&a.catalogue.features, &b.catalogue.features);
    let sims: Vec<f64> =
        (0..fa.len() * fb.len()).into_par_iter().map(|k| similarity(&fa[k / fb.len()], &fb[k % fb.len()])).collect();
    let (floor_a, floor_b) = (floor(fa, cfg.presence), floor(fb, cfg.presence));
    let (ea, eb): (Vec<f64>, Vec<f64>) = (fa.iter().map(energy).collect(), fb.iter().map(energy).collect());
    let present = |k: usize| ea[k / fb.len()] >= floor_a && eb[k % fb.len()] >= floor_b;
    let any = (0..sims.len()).any(present);
    let (floor_a, floor_b) = if any { (floor_a, floor_b) } else { (0.0, 0.0) };
    let mut order: Vec<usize> = (0..sims.len()).filter(|&k| !any || present(k)).collect();
    order.sort_by(|&p, &q| sims[q].total_cmp(&sims[p]).then(p.cmp(&q)));
    let mut chosen: Vec<(usize, usize)> = Vec::new();
    for k in order {
        if chosen.len() >= cfg.pairs {
            break;
        }
        let (i, j) = (k / fb.len(), k % fb.len());
        if chosen.iter().all(|&(ci, cj)| ci != i && cj != j) {
            chosen.push((i, j));
        }
    }
    let mut points: Vec<JumpPoint> = chosen
        .par_iter()
        .map(|&(i, j)| {
            alternate(a, b, &a.catalogue.points[i], &b.catalogue.points[j], cfg, &calibration, [floor_a, floor_b])
        })
        .collect();
    points.sort_by(|p, q| q.similarity.total_cmp(&p.similarity));
    JumpSet { points, calibration }
}

/// `fraction` of the median energy of `features`.
fn floor(features: &[Feature], fraction: f64) -> f64 {
    let mut e: Vec<f64> = features.iter().map(energy).collect();
    e.sort_by(f64::total_cmp);
    e.get(e.len() / 2).map_or(0.0, |m| fraction * m)
}

/// `1 − S` between a render and a fixed feature; 1 (no better than anything) for a render
/// below the energy floor.
fn loss(f: &Feature, other: &Feature, floor: f64) -> f64 {
    if energy(f) < floor {
        1.0
    } else {
        1.0 - similarity(f, other)
    }
}

fn alternate(
    a: &Candidate,
    b: &Candidate,
    x0: &[f64],
    y0: &[f64],
    cfg: &JumpConfig,
    cal: &Calibration,
    [floor_a, floor_b]: [f64; 2],
) -> JumpPoint {
    let (mut x, mut y) = (x0.to_vec(), y0.to_vec());
    let mut fy = b.probe.feature(&y);
    let mut fx: Feature;
    let mut renders = 1;
    let mut rounds = 0;
    let mut settled = false;
    let moved = |p: &[f64], q: &[f64]| p.iter().zip(q).map(|(u, v)| (u - v).abs()).fold(0.0, f64::max);
    while rounds < cfg.rounds {
        rounds += 1;
        let r = minimise(|p| loss(&a.probe.feature(p), &fy, floor_a), |p| a.probe.snap(p), &x, &cfg.simplex, |_| false);
        let dx = moved(&r.x, &x);
        x = r.x;
        fx = a.probe.feature(&x);
        let r2 =
            minimise(|q| loss(&b.probe.feature(q), &fx, floor_b), |q| b.probe.snap(q), &y, &cfg.simplex, |_| false);
        let dy = moved(&r2.x, &y);
        y = r2.x;
        fy = b.probe.feature(&y);
        renders += r.evaluations + r2.evaluations + 2;
        if dx < cfg.step && dy < cfg.step {
            settled = true;
            break;
        }
    }
    let s = similarity(&a.probe.feature(&x), &fy);
    JumpPoint { x, y, similarity: s, score: cal.apply(s), rounds, settled, renders: renders + 1 }
}
