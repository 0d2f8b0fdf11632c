//! Clustering of region extracts by mean CIELAB colour (stage A2b), our stand-in for
//! the adaptive k-means the thesis cites without details ([references: frasson §4.1.2]).
//!
//! For each `k = 1..=k_max`, `k_max = min(10, ⌊n/2⌋)` (so there are always at least `2k`
//! regions), seeded k-means++ is run [`RESTARTS`] times and the restart with the least
//! inertia kept (ties to the first restart); the `k ≥ 2` with the best mean silhouette wins,
//! and `k = 1` is chosen when that silhouette is below [`MIN_SILHOUETTE`].
//!
//! **Determinism.** Every `(k, restart)` run draws from its own named stream
//! `Rng::derived(seed, "appearance.cluster", "k{k}.r{restart}")`; runs for different `k` may
//! execute in parallel, but each is sequential and results are collected in `k` order, so the
//! clustering is identical for any rayon thread count.

use rayon::prelude::*;

use super::color::delta_e;
use super::types::{Clustering, Lab};
use crate::synth::rng::Rng;

/// The largest number of clusters ("typically … less than 10 clusters").
pub const MAX_CLUSTERS: usize = 10;
/// Below this best mean silhouette the regions form one cluster.
pub const MIN_SILHOUETTE: f64 = 0.25;
/// k-means++ restarts per `k`.
pub const RESTARTS: usize = 8;
/// Lloyd iterations per restart, at most.
const MAX_ITERS: usize = 100;

/// How many clusters to make.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Clusters {
    /// Chosen by the mean silhouette.
    Auto,
    /// Exactly this many, clamped to `1..=min(10, n)` for `n` regions (no panic: `0` becomes 1,
    /// more clusters than regions become one cluster per region). The kinds layer rejects a
    /// user's `k` outside `1..=10` before calling this.
    Fixed(usize),
}

/// Clusters `labs` (one mean colour per region extract).
///
/// With no colours the result is `k = 1`, no assignment and the centre `[0, 0, 0]`.
/// `silhouettes[k − 1]` holds the mean silhouette of each `k` tried (`0` for `k = 1`); with
/// `Fixed(k)` only that `k` is tried and the vector has length `k`, zeros before it.
pub fn cluster(labs: &[Lab], clusters: Clusters, seed: u64) -> Clustering {
    let n = labs.len();
    if n == 0 {
        return Clustering { k: 1, assignment: Vec::new(), centres: vec![[0.0; 3]], silhouettes: vec![0.0] };
    }
    match clusters {
        Clusters::Fixed(k) => {
            let k = k.clamp(1, MAX_CLUSTERS.min(n));
            let (assignment, centres) = best_kmeans(labs, k, seed);
            let mut silhouettes = vec![0.0; k];
            if k >= 2 {
                silhouettes[k - 1] = mean_silhouette(labs, &assignment, k);
            }
            Clustering { k, assignment, centres, silhouettes }
        }
        Clusters::Auto => {
            let k_max = MAX_CLUSTERS.min(n / 2).max(1);
            let runs: Vec<(Vec<usize>, Vec<Lab>, f64)> = (1..=k_max)
                .into_par_iter()
                .map(|k| {
                    let (a, c) = best_kmeans(labs, k, seed);
                    let s = if k >= 2 { mean_silhouette(labs, &a, k) } else { 0.0 };
                    (a, c, s)
                })
                .collect();
            let silhouettes: Vec<f64> = runs.iter().map(|r| r.2).collect();
            // The best k ≥ 2 (ties to the smaller k).
            let mut best = 0usize;
            for i in 1..runs.len() {
                if best == 0 || runs[i].2 > runs[best].2 {
                    best = i;
                }
            }
            if best == 0 || runs[best].2 < MIN_SILHOUETTE {
                best = 0;
            }
            let (assignment, centres, _) = runs.into_iter().nth(best).expect("k = 1 is always run");
            Clustering { k: best + 1, assignment, centres, silhouettes }
        }
    }
}

/// The least-inertia k-means of [`RESTARTS`] seeded k-means++ runs, clusters renumbered by
/// their first member so the labelling is canonical.
fn best_kmeans(labs: &[Lab], k: usize, seed: u64) -> (Vec<usize>, Vec<Lab>) {
    let mut best: Option<(f64, Vec<usize>, Vec<Lab>)> = None;
    for r in 0..RESTARTS {
        let mut rng = Rng::derived(seed, "appearance.cluster", &format!("k{k}.r{r}"));
        let (a, c) = kmeans(labs, k, &mut rng);
        let inertia: f64 = labs.iter().zip(&a).map(|(p, &j)| dist2(*p, c[j])).sum();
        if best.as_ref().is_none_or(|b| inertia < b.0) {
            best = Some((inertia, a, c));
        }
        if k == 1 {
            break;
        }
    }
    let (_, a, c) = best.expect("at least one restart");
    canonical(a, c, k)
}

/// Renumbers clusters in order of their first member.
fn canonical(a: Vec<usize>, c: Vec<Lab>, k: usize) -> (Vec<usize>, Vec<Lab>) {
    let mut map = vec![usize::MAX; k];
    let mut next = 0;
    for &j in &a {
        if map[j] == usize::MAX {
            map[j] = next;
            next += 1;
        }
    }
    for m in map.iter_mut() {
        if *m == usize::MAX {
            *m = next;
            next += 1;
        }
    }
    let mut centres = vec![[0.0; 3]; k];
    for (j, cj) in c.into_iter().enumerate() {
        centres[map[j]] = cj;
    }
    (a.into_iter().map(|j| map[j]).collect(), centres)
}

fn dist2(a: Lab, b: Lab) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)
}

/// One k-means++ seeding followed by Lloyd iterations. Needs `1 ≤ k ≤ n`. A cluster left
/// empty takes the point farthest from its centre (lowest index on ties), so every cluster
/// keeps a member.
fn kmeans(labs: &[Lab], k: usize, rng: &mut Rng) -> (Vec<usize>, Vec<Lab>) {
    let n = labs.len();
    // k-means++ seeding: the first centre uniform, then ∝ D².
    let mut centres: Vec<Lab> = vec![labs[rng.below(n)]];
    let mut d2: Vec<f64> = labs.iter().map(|p| dist2(*p, centres[0])).collect();
    while centres.len() < k {
        let total: f64 = d2.iter().sum();
        let pick = if total > 0.0 {
            let mut t = rng.next_f64() * total;
            let mut chosen = n - 1;
            for (i, &d) in d2.iter().enumerate() {
                if d > 0.0 && t < d {
                    chosen = i;
                    break;
                }
                t -= d;
            }
            // Rounding can run past the end: take the last point with positive weight.
            if d2[chosen] == 0.0 {
                chosen = d2.iter().rposition(|&d| d > 0.0).unwrap_or(chosen);
            }
            chosen
        } else {
            rng.below(n)
        };
        centres.push(labs[pick]);
        for (i, p) in labs.iter().enumerate() {
            d2[i] = d2[i].min(dist2(*p, labs[pick]));
        }
    }
    let mut assign = vec![0usize; n];
    for iter in 0..MAX_ITERS {
        let mut changed = false;
        for (i, p) in labs.iter().enumerate() {
            let mut bj = 0;
            let mut bd = f64::INFINITY;
            for (j, c) in centres.iter().enumerate() {
                let d = dist2(*p, *c);
                if d < bd {
                    bd = d;
                    bj = j;
                }
            }
            if bj != assign[i] {
                assign[i] = bj;
                changed = true;
            }
        }
        // Refill empty clusters with the worst-fitting point.
        let mut counts = vec![0usize; k];
        for &j in &assign {
            counts[j] += 1;
        }
        for j in 0..k {
            if counts[j] == 0 {
                let (mut wi, mut wd) = (None, -1.0);
                for (i, p) in labs.iter().enumerate() {
                    if counts[assign[i]] <= 1 {
                        continue;
                    }
                    let d = dist2(*p, centres[assign[i]]);
                    if d > wd {
                        wd = d;
                        wi = Some(i);
                    }
                }
                if let Some(i) = wi {
                    counts[assign[i]] -= 1;
                    assign[i] = j;
                    counts[j] = 1;
                    changed = true;
                }
            }
        }
        let mut sums = vec![[0.0f64; 4]; k];
        for (p, &j) in labs.iter().zip(&assign) {
            for c in 0..3 {
                sums[j][c] += p[c];
            }
            sums[j][3] += 1.0;
        }
        for j in 0..k {
            if sums[j][3] > 0.0 {
                centres[j] = [sums[j][0] / sums[j][3], sums[j][1] / sums[j][3], sums[j][2] / sums[j][3]];
            }
        }
        if !changed && iter > 0 {
            break;
        }
    }
    (assign, centres)
}

/// Mean silhouette over all points (Rousseeuw): `s = (b − a) / max(a, b)`, `0` for a point
/// alone in its cluster; distances are ΔE76.
pub fn mean_silhouette(labs: &[Lab], assignment: &[usize], k: usize) -> f64 {
    let n = labs.len();
    if n == 0 || k < 2 {
        return 0.0;
    }
    let mut counts = vec![0usize; k];
    for &j in assignment {
        counts[j] += 1;
    }
    let mut total = 0.0;
    let mut sums = vec![0.0f64; k];
    for i in 0..n {
        sums.iter_mut().for_each(|s| *s = 0.0);
        for (j, p) in labs.iter().enumerate() {
            if j != i {
                sums[assignment[j]] += delta_e(labs[i], *p);
            }
        }
        let own = assignment[i];
        if counts[own] <= 1 {
            continue;
        }
        let a = sums[own] / (counts[own] - 1) as f64;
        let b = (0..k)
            .filter(|&c| c != own && counts[c] > 0)
            .map(|c| sums[c] / counts[c] as f64)
            .fold(f64::INFINITY, f64::min);
        if !b.is_finite() {
            continue;
        }
        let m = a.max(b);
        if m > 0.0 {
            total += (b - a) / m;
        }
    }
    total / n as f64
}

/// Adjusted Rand index of two labelings of the same items (Hubert & Arabie); 1 for identical
/// partitions up to renaming. Used by the tests and the quality reports.
pub fn adjusted_rand_index(a: &[usize], b: &[usize]) -> f64 {
    assert_eq!(a.len(), b.len(), "labelings of the same items");
    let n = a.len();
    if n < 2 {
        return 1.0;
    }
    let ka = a.iter().max().map_or(0, |m| m + 1);
    let kb = b.iter().max().map_or(0, |m| m + 1);
    let mut table = vec![0u64; ka * kb];
    for (&x, &y) in a.iter().zip(b) {
        table[x * kb + y] += 1;
    }
    let c2 = |m: u64| (m * m.saturating_sub(1)) as f64 / 2.0;
    let sum_ij: f64 = table.iter().map(|&m| c2(m)).sum();
    let sum_a: f64 = (0..ka).map(|i| c2((0..kb).map(|j| table[i * kb + j]).sum())).sum();
    let sum_b: f64 = (0..kb).map(|j| c2((0..ka).map(|i| table[i * kb + j]).sum())).sum();
    let total = c2(n as u64);
    let expected = sum_a * sum_b / total;
    let max = 0.5 * (sum_a + sum_b);
    if max == expected {
        return 1.0;
    }
    (sum_ij - expected) / (max - expected)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::appearance::extract::{extract_regions, DEFAULT_SHRINK};
    use crate::synth::structure::fixtures::standins::{paint, wall_random, PaintParams, WallRandomParams};

    /// Painted wall_random: the extracts' colours and their true tint classes.
    fn wall(seed: u64) -> (Vec<Lab>, Vec<usize>) {
        let s = wall_random(&WallRandomParams::default(), seed);
        let painted = paint(&s, &PaintParams::default(), seed);
        let polys = s.polygons();
        let all: Vec<usize> = (0..polys.len()).collect();
        let ex = extract_regions(&painted.image, &polys, &all, DEFAULT_SHRINK);
        (ex.iter().map(|e| e.lab).collect(), ex.iter().map(|e| s.classes[e.region] as usize).collect())
    }

    /// F21: three true tints give k = 3 and the true partition (ARI ≥ 0.9), for several seeds.
    #[test]
    fn f21_auto_k_finds_the_three_tints() {
        for seed in [1u64, 2, 3] {
            let (labs, truth) = wall(seed);
            let c = cluster(&labs, Clusters::Auto, seed);
            let ari = adjusted_rand_index(&c.assignment, &truth);
            eprintln!("seed {seed}: n = {}, k = {}, ARI = {ari:.4}, silhouettes {:?}", labs.len(), c.k, c.silhouettes);
            assert_eq!(c.k, 3);
            assert!(ari >= 0.9, "ARI {ari}");
            assert_eq!(c.centres.len(), 3);
            assert_eq!(c.silhouettes.len(), 10);
        }
    }

    /// F21: k ≤ 10 always, one cluster for structureless colours, fixed k clamped.
    #[test]
    fn f21_k_is_bounded_and_falls_back_to_one() {
        let mut rng = Rng::new(4);
        // 40 well separated groups: auto never goes past 10.
        let many: Vec<Lab> = (0..200).map(|i| [(i % 40) as f64 * 30.0 + rng.range(-1.0, 1.0), 0.0, 0.0]).collect();
        let c = cluster(&many, Clusters::Auto, 1);
        assert!(c.k <= MAX_CLUSTERS && c.k >= 2, "k {}", c.k);
        // Clouds without clear groups: k = 1 exactly when the best silhouette is below 0.25.
        let clouds: Vec<Vec<Lab>> = vec![
            (0..100).map(|_| [rng.range(0.0, 10.0), rng.range(0.0, 10.0), rng.range(0.0, 10.0)]).collect(),
            (0..100).map(|_| [50.0 + 3.0 * rng.normal(), 3.0 * rng.normal(), 3.0 * rng.normal()]).collect(),
            (0..60).map(|i| [i as f64 * 0.1, 0.0, 0.0]).collect(),
        ];
        for cloud in &clouds {
            let c = cluster(cloud, Clusters::Auto, 1);
            let best = c.silhouettes.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            assert_eq!(c.k == 1, best < MIN_SILHOUETTE, "k {} silhouettes {:?}", c.k, c.silhouettes);
        }
        // Identical colours have no silhouette at all: one cluster.
        let c = cluster(&vec![[50.0, 1.0, 2.0]; 30], Clusters::Auto, 1);
        assert_eq!((c.k, c.centres.clone()), (1, vec![[50.0, 1.0, 2.0]]));
        assert!(c.assignment.iter().all(|&a| a == 0));
        // Fewer than 2k regions: two points can only be one cluster.
        assert_eq!(cluster(&[[0.0; 3], [90.0, 0.0, 0.0]], Clusters::Auto, 1).k, 1);
        assert_eq!(cluster(&[[0.0; 3], [90.0, 0.0, 0.0], [1.0, 0.0, 0.0]], Clusters::Auto, 1).k, 1);
        assert_eq!(cluster(&[], Clusters::Auto, 1).k, 1);
        // Fixed k: clamped, never panics.
        assert_eq!(cluster(&many, Clusters::Fixed(0), 1).k, 1);
        assert_eq!(cluster(&many, Clusters::Fixed(40), 1).k, 10);
        assert_eq!(cluster(&many[..3], Clusters::Fixed(5), 1).k, 3);
        let f = cluster(&many, Clusters::Fixed(4), 1);
        assert_eq!((f.k, f.centres.len(), f.silhouettes.len()), (4, 4, 4));
        assert!(f.assignment.iter().all(|&a| a < 4));
        // Identical colours: every cluster still gets a member.
        let same = vec![[50.0, 0.0, 0.0]; 12];
        let f = cluster(&same, Clusters::Fixed(3), 1);
        for j in 0..3 {
            assert!(f.assignment.contains(&j));
        }
    }

    /// F21: same seed, same clustering; and the rayon thread count changes nothing.
    #[test]
    fn f21_clustering_is_reproducible_and_thread_independent() {
        let (labs, _) = wall(2);
        let a = cluster(&labs, Clusters::Auto, 9);
        assert_eq!(a, cluster(&labs, Clusters::Auto, 9));
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| cluster(&labs, Clusters::Auto, 9))
        };
        assert_eq!(run(1), a);
        assert_eq!(run(2), a);
    }

    #[test]
    fn ari_reference_values() {
        assert_eq!(adjusted_rand_index(&[0, 0, 1, 1], &[1, 1, 0, 0]), 1.0);
        // sklearn: adjusted_rand_score([0, 0, 1, 1], [0, 0, 1, 2]) = 0.5714285714285715
        assert!((adjusted_rand_index(&[0, 0, 1, 1], &[0, 0, 1, 2]) - 0.5714285714285715).abs() < 1e-12);
    }
}
