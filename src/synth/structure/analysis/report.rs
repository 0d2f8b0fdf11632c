//! Statistics report: how close a synthesised structure is to its sample (V29 of
//! [references: frasson §3.6]). The thesis mentions "some evaluation metrics" without defining them; these are
//! ours.
//!
//! [`compare`] takes the two [`StatModel`]s and reports
//! * two-sample Kolmogorov–Smirnov distances `D` (with the asymptotic p-value) for the
//!   axes ratio `a/b`, the relative area `r_i / r̄`, the ellipse angle `θ`, the edges per
//!   region, the edge lengths, the interior angles and the angles between edges around a
//!   vertex;
//! * the axial circular means of `θ` (`½·atan2(Σ sin 2θ, Σ cos 2θ)`), their difference and
//!   mean resultant lengths;
//! * the L1 distance between the valency distributions, with and without valency-2 vertices
//!   (V31), and the share of valency-3 vertices;
//! * the counts of both structures.
//!
//! Sources: the region variables (`a/b`, relative area, `θ`, edges per region) are computed
//! exactly from the per-region records of the models, over the regions each model uses for
//! its statistics (border regions skipped when its `exclude_border_regions` is set). `θ`
//! skips near-isotropic regions (`λ1/λ2 < 1.02`, i.e. `(a/b)² < 1.02`, [references: frasson §3.4]), whose
//! angle is unstable. The models keep only histograms of the edge lengths, interior angles,
//! vertex angles and valencies, so those distances compare the histograms' piecewise-linear
//! CDFs (uniform inside each bin, as sampling assumes); their supremum is reached at a bin
//! edge of either histogram, where it is evaluated exactly. Valency histograms have unit bins
//! in practice (the Diaconis–Freedman width is rounded and at least 1); a wider bin's count is
//! spread evenly over its integers.
//!
//! Conventions: `D = 0` when both samples are empty and `D = 1` when only one is; `p = 1`
//! when `D = 0`. [`to_json`] writes pretty JSON with sorted keys and every float rounded to
//! 1e-9, so the bytes are stable.

use crate::synth::structure::analysis::ellipse::axial_angle_diff;
use crate::synth::structure::analysis::stats::{ks_two_sample, round_json, Counts, Histogram1, StatModel};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// Where a distance was computed from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// Exact per-region values.
    Values,
    /// The histograms' piecewise-linear CDFs.
    Histogram,
}

/// A two-sample Kolmogorov–Smirnov comparison.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ks {
    /// `D = sup |F_sample − F_generated|`.
    pub ks: f64,
    /// Asymptotic p-value (Kolmogorov distribution with Stephens' small-sample correction).
    pub p_value: f64,
    pub n_sample: usize,
    pub n_generated: usize,
    pub mean_sample: Option<f64>,
    pub mean_generated: Option<f64>,
    pub source: Source,
}

/// The ellipse angle: KS plus axial circular statistics.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AngleComparison {
    pub ks: Ks,
    /// Axial circular means in `[0, π)` (`None` without anisotropic regions).
    pub circular_mean_sample: Option<f64>,
    pub circular_mean_generated: Option<f64>,
    /// Axial difference of the circular means, in `[0, π/2]`.
    pub circular_mean_diff: Option<f64>,
    /// Mean resultant lengths of `2θ` (1 = all parallel, 0 = no preferred direction).
    pub resultant_sample: Option<f64>,
    pub resultant_generated: Option<f64>,
}

/// Valency distributions.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ValencyComparison {
    /// `Σ_k |p_sample(k) − p_generated(k)|` over all valencies (in `[0, 2]`).
    pub l1: f64,
    /// The same without valency-2 vertices.
    pub l1_without_2: f64,
    /// Share of valency-3 vertices among all vertices.
    pub share_3_sample: f64,
    pub share_3_generated: f64,
    /// Share of valency-3 vertices among the vertices of valency ≠ 2.
    pub share_3_without_2_sample: f64,
    pub share_3_without_2_generated: f64,
    /// The distributions as `(valency, share)` pairs, ascending.
    pub pmf_sample: Vec<(i64, f64)>,
    pub pmf_generated: Vec<(i64, f64)>,
}

/// Counts of both structures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CountComparison {
    pub sample: Counts,
    pub generated: Counts,
    /// Mean area `r̄` of the regions used by each model.
    pub mean_region_area_sample: f64,
    pub mean_region_area_generated: f64,
}

/// The comparison of a synthesised structure with its sample (V29).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StatsReport {
    pub axes_ratio: Ks,
    pub relative_area: Ks,
    pub theta: AngleComparison,
    pub edges_per_region: Ks,
    pub edge_lengths: Ks,
    pub interior_angles: Ks,
    pub vertex_angles: Ks,
    pub valency: ValencyComparison,
    pub counts: CountComparison,
}

/// Near-isotropic regions (`λ1/λ2 < 1.02`) are skipped in the angle statistics.
const ISOTROPIC: f64 = 1.02;

struct RegionValues {
    ratio: Vec<f64>,
    rel_area: Vec<f64>,
    theta: Vec<f64>,
    edges: Vec<f64>,
}

fn region_values(m: &StatModel) -> RegionValues {
    let used: Vec<_> = m.regions.iter().filter(|r| !(m.config.exclude_border_regions && r.border)).collect();
    let mean_area = if used.is_empty() { 0.0 } else { used.iter().map(|r| r.area).sum::<f64>() / used.len() as f64 };
    let mut v = RegionValues { ratio: Vec::new(), rel_area: Vec::new(), theta: Vec::new(), edges: Vec::new() };
    for r in used {
        v.edges.push(r.edges as f64);
        if mean_area > 0.0 {
            v.rel_area.push(r.area / mean_area);
        }
        if let Some(e) = r.ellipse {
            if e.b > 0.0 {
                let q = e.a / e.b;
                v.ratio.push(q);
                if q * q >= ISOTROPIC {
                    v.theta.push(e.theta);
                }
            }
        }
    }
    v
}

fn mean(x: &[f64]) -> Option<f64> {
    if x.is_empty() {
        None
    } else {
        Some(x.iter().sum::<f64>() / x.len() as f64)
    }
}

/// Kolmogorov's asymptotic p-value of `D` for sample sizes `n1`, `n2`.
pub fn ks_p_value(d: f64, n1: usize, n2: usize) -> f64 {
    if n1 == 0 || n2 == 0 {
        return if d == 0.0 { 1.0 } else { 0.0 };
    }
    if d <= 0.0 {
        return 1.0;
    }
    let ne = (n1 as f64 * n2 as f64) / (n1 + n2) as f64;
    let s = ne.sqrt();
    let lambda = (s + 0.12 + 0.11 / s) * d;
    if lambda < 0.2 {
        return 1.0;
    }
    let mut sum = 0.0;
    for j in 1..=100 {
        let jf = j as f64;
        let term = (-2.0 * jf * jf * lambda * lambda).exp();
        sum += if j % 2 == 1 { term } else { -term };
        if term < 1e-16 {
            break;
        }
    }
    (2.0 * sum).clamp(0.0, 1.0)
}

fn ks_values(a: &[f64], b: &[f64]) -> Ks {
    let d = match (a.is_empty(), b.is_empty()) {
        (true, true) => 0.0,
        (true, false) | (false, true) => 1.0,
        _ => ks_two_sample(a, b),
    };
    Ks {
        ks: d,
        p_value: ks_p_value(d, a.len(), b.len()),
        n_sample: a.len(),
        n_generated: b.len(),
        mean_sample: mean(a),
        mean_generated: mean(b),
        source: Source::Values,
    }
}

/// The float just below `x` (for finite `x`).
fn below(x: f64) -> f64 {
    if x == 0.0 {
        -f64::MIN_POSITIVE
    } else if x > 0.0 {
        f64::from_bits(x.to_bits() - 1)
    } else {
        f64::from_bits(x.to_bits() + 1)
    }
}

/// `sup |F_a − F_b|` of two histograms' piecewise-linear CDFs.
pub fn histogram_ks(a: &Histogram1, b: &Histogram1) -> f64 {
    let mut xs: Vec<f64> = Vec::new();
    for h in [a, b] {
        for i in 0..=h.axis.bins {
            xs.push(h.axis.edge(i));
        }
        xs.push(h.axis.lo);
        xs.push(h.axis.hi);
    }
    let mut d: f64 = 0.0;
    for &x in &xs {
        if !x.is_finite() {
            continue;
        }
        // The CDFs are continuous except for zero-width (constant) histograms, which jump at
        // their value: look just below every breakpoint too.
        for y in [x, below(x)] {
            d = d.max((a.cdf(y) - b.cdf(y)).abs());
        }
    }
    d
}

fn histogram_mean(h: &Histogram1) -> f64 {
    let mut s = 0.0;
    for (i, &c) in h.counts.iter().enumerate() {
        s += c as f64 * 0.5 * (h.axis.edge(i) + h.axis.edge(i + 1));
    }
    if h.n > 0 {
        s / h.n as f64
    } else {
        0.0
    }
}

fn ks_histograms(a: Option<&Histogram1>, b: Option<&Histogram1>) -> Ks {
    let d = match (a, b) {
        (None, None) => 0.0,
        (Some(_), None) | (None, Some(_)) => 1.0,
        (Some(x), Some(y)) => histogram_ks(x, y),
    };
    let (na, nb) = (a.map_or(0, |h| h.n), b.map_or(0, |h| h.n));
    Ks {
        ks: d,
        p_value: ks_p_value(d, na, nb),
        n_sample: na,
        n_generated: nb,
        mean_sample: a.map(histogram_mean),
        mean_generated: b.map(histogram_mean),
        source: Source::Histogram,
    }
}

/// The axial circular mean in `[0, π)` and the mean resultant length of `2θ`.
pub fn axial_circular_mean(theta: &[f64]) -> Option<(f64, f64)> {
    if theta.is_empty() {
        return None;
    }
    let (mut s, mut c) = (0.0, 0.0);
    for &t in theta {
        s += (2.0 * t).sin();
        c += (2.0 * t).cos();
    }
    let n = theta.len() as f64;
    let r = (s * s + c * c).sqrt() / n;
    let m = (0.5 * s.atan2(c)).rem_euclid(PI);
    Some((if m >= PI { 0.0 } else { m }, r))
}

/// The valency distribution of a histogram, as shares per integer valency.
fn valency_pmf(h: Option<&Histogram1>) -> BTreeMap<i64, f64> {
    let mut pmf = BTreeMap::new();
    let Some(h) = h else { return pmf };
    if h.n == 0 {
        return pmf;
    }
    for (i, &c) in h.counts.iter().enumerate() {
        if c == 0 {
            continue;
        }
        let (lo, hi) = (h.axis.edge(i), h.axis.edge(i + 1));
        // Integers k with k − ½ ≥ lo and k + ½ ≤ hi (the bins have half-integer edges).
        let k0 = (lo + 0.5).round() as i64;
        let k1 = ((hi - 0.5).round() as i64).max(k0);
        let share = c as f64 / h.n as f64 / (k1 - k0 + 1) as f64;
        for k in k0..=k1 {
            *pmf.entry(k).or_insert(0.0) += share;
        }
    }
    pmf
}

fn l1(a: &BTreeMap<i64, f64>, b: &BTreeMap<i64, f64>) -> f64 {
    let keys: std::collections::BTreeSet<i64> = a.keys().chain(b.keys()).copied().collect();
    keys.iter().map(|k| (a.get(k).copied().unwrap_or(0.0) - b.get(k).copied().unwrap_or(0.0)).abs()).sum()
}

/// Compares the statistics of a generated structure with those of its sample.
pub fn compare(sample: &StatModel, generated: &StatModel) -> StatsReport {
    let (rs, rg) = (region_values(sample), region_values(generated));
    let cm_s = axial_circular_mean(&rs.theta);
    let cm_g = axial_circular_mean(&rg.theta);
    let theta = AngleComparison {
        ks: ks_values(&rs.theta, &rg.theta),
        circular_mean_sample: cm_s.map(|x| x.0),
        circular_mean_generated: cm_g.map(|x| x.0),
        circular_mean_diff: match (cm_s, cm_g) {
            (Some(a), Some(b)) => Some(axial_angle_diff(a.0, b.0)),
            _ => None,
        },
        resultant_sample: cm_s.map(|x| x.1),
        resultant_generated: cm_g.map(|x| x.1),
    };
    let (ps, pg) = (valency_pmf(sample.valency.histogram.as_ref()), valency_pmf(generated.valency.histogram.as_ref()));
    let (ps2, pg2) = (
        valency_pmf(sample.valency_without_2.histogram.as_ref()),
        valency_pmf(generated.valency_without_2.histogram.as_ref()),
    );
    let share3 = |p: &BTreeMap<i64, f64>| p.get(&3).copied().unwrap_or(0.0);
    let valency = ValencyComparison {
        l1: l1(&ps, &pg),
        l1_without_2: l1(&ps2, &pg2),
        share_3_sample: share3(&ps),
        share_3_generated: share3(&pg),
        share_3_without_2_sample: share3(&ps2),
        share_3_without_2_generated: share3(&pg2),
        pmf_sample: ps.into_iter().collect(),
        pmf_generated: pg.into_iter().collect(),
    };
    StatsReport {
        axes_ratio: ks_values(&rs.ratio, &rg.ratio),
        relative_area: ks_values(&rs.rel_area, &rg.rel_area),
        theta,
        edges_per_region: ks_values(&rs.edges, &rg.edges),
        edge_lengths: ks_histograms(sample.edge_lengths.histogram.as_ref(), generated.edge_lengths.histogram.as_ref()),
        interior_angles: ks_histograms(
            sample.interior_angles.histogram.as_ref(),
            generated.interior_angles.histogram.as_ref(),
        ),
        vertex_angles: ks_histograms(
            sample.vertex_angles.histogram.as_ref(),
            generated.vertex_angles.histogram.as_ref(),
        ),
        valency,
        counts: CountComparison {
            sample: sample.counts.clone(),
            generated: generated.counts.clone(),
            mean_region_area_sample: sample.mean_region_area,
            mean_region_area_generated: generated.mean_region_area,
        },
    }
}

/// Pretty JSON of a report: sorted keys, floats rounded to 1e-9, trailing newline.
pub fn to_json(report: &StatsReport) -> String {
    let mut v = serde_json::to_value(report).expect("StatsReport serialises");
    round_json(&mut v, 1e-9);
    let mut s = serde_json::to_string_pretty(&v).expect("JSON value serialises");
    s.push('\n');
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::rng::Rng;
    use crate::synth::structure::analysis::stats::{analyse, StatsConfig};
    use crate::synth::structure::fixtures::standins::{self, StandIn};
    use crate::synth::structure::mesh::faces::mesh_to_subdivision;
    use crate::synth::structure::types::Mesh;

    fn model_of(mesh: &Mesh, w: f64, h: f64) -> StatModel {
        analyse(&mesh_to_subdivision(mesh), Some([w, h]), &StatsConfig::default()).expect("valid mesh").model
    }

    fn model(s: &StandIn) -> StatModel {
        model_of(&s.mesh, s.width as f64, s.height as f64)
    }

    fn all_ks(r: &StatsReport) -> [(&'static str, f64); 7] {
        [
            ("axes_ratio", r.axes_ratio.ks),
            ("relative_area", r.relative_area.ks),
            ("theta", r.theta.ks.ks),
            ("edges_per_region", r.edges_per_region.ks),
            ("edge_lengths", r.edge_lengths.ks),
            ("interior_angles", r.interior_angles.ks),
            ("vertex_angles", r.vertex_angles.ks),
        ]
    }

    fn wall() -> StandIn {
        standins::wall_regular(&standins::WallRegularParams::default(), 5)
    }

    #[test]
    fn identical_models_give_zero_distances() {
        for s in [wall(), standins::scales_diag(&standins::ScalesDiagParams::default(), 5)] {
            let m = model(&s);
            let r = compare(&m, &m);
            for (name, d) in all_ks(&r) {
                assert_eq!(d, 0.0, "{} {name}", s.name);
            }
            assert_eq!(r.axes_ratio.p_value, 1.0);
            assert_eq!(r.valency.l1, 0.0);
            assert_eq!(r.valency.l1_without_2, 0.0);
            assert_eq!(r.valency.share_3_sample, r.valency.share_3_generated);
            assert_eq!(r.theta.circular_mean_diff, Some(0.0));
            assert_eq!(r.counts.sample, r.counts.generated);
            let total: f64 = r.valency.pmf_sample.iter().map(|p| p.1).sum();
            assert!((total - 1.0).abs() < 1e-12, "{total}");
            assert!(r.axes_ratio.n_sample > 20 && r.edge_lengths.source == Source::Histogram);
            eprintln!(
                "{}: regions used {}, valency-3 share {:.4} (without 2: {:.4}), theta circular mean {:.2}°",
                s.name,
                r.counts.sample.regions_used,
                r.valency.share_3_sample,
                r.valency.share_3_without_2_sample,
                r.theta.circular_mean_sample.unwrap().to_degrees()
            );
        }
    }

    #[test]
    fn scaled_model_differs_only_in_lengths() {
        // Scaling by 2 is exact in floating point: shape statistics are bit-identical.
        let s = wall();
        let m = model(&s);
        let mut big = s.mesh.clone();
        big.vertices.iter_mut().for_each(|p| *p = [2.0 * p[0], 2.0 * p[1]]);
        let r = compare(&m, &model_of(&big, 2.0 * s.width as f64, 2.0 * s.height as f64));
        eprintln!("scaled x2: {:?}", all_ks(&r));
        for (name, d) in all_ks(&r) {
            if name == "edge_lengths" {
                assert!(d > 0.3, "edge lengths KS {d}");
                assert!(r.edge_lengths.p_value < 1e-6, "{}", r.edge_lengths.p_value);
            } else {
                assert_eq!(d, 0.0, "{name}");
            }
        }
        assert_eq!(r.valency.l1, 0.0);
        assert_eq!(r.counts.mean_region_area_generated, 4.0 * r.counts.mean_region_area_sample);
    }

    #[test]
    fn other_structures_give_larger_distances() {
        let s = wall();
        let m = model(&s);
        // Jittered vertices (interior ones by ±1 px): shapes change a little.
        let mut rng = Rng::new(9);
        let (w, h) = (s.width as f64, s.height as f64);
        let mut jit = s.mesh.clone();
        for p in jit.vertices.iter_mut() {
            let (dx, dy) = (rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
            if p[0] > 0.0 && p[0] < w && p[1] > 0.0 && p[1] < h {
                *p = [p[0] + dx, p[1] + dy];
            }
        }
        let rj = compare(&m, &model_of(&jit, w, h));
        // A different structure altogether.
        let c = standins::cells_iso(&standins::CellsIsoParams::default(), 5);
        let rc = compare(&m, &model(&c));
        eprintln!("jittered: {:?}", all_ks(&rj));
        eprintln!("cells_iso: {:?}", all_ks(&rc));
        eprintln!(
            "cells_iso: valency L1 {:.4} (without 2: {:.4}), theta circular means {:.1}° vs {:.1}° (diff {:.1}°)",
            rc.valency.l1,
            rc.valency.l1_without_2,
            rc.theta.circular_mean_sample.unwrap().to_degrees(),
            rc.theta.circular_mean_generated.unwrap().to_degrees(),
            rc.theta.circular_mean_diff.unwrap().to_degrees()
        );
        for (name, d) in all_ks(&rj) {
            if name != "edges_per_region" {
                assert!(d > 0.0, "jittered {name}");
            }
        }
        assert!(rj.interior_angles.ks > 0.3, "{}", rj.interior_angles.ks);
        for name in ["axes_ratio", "edge_lengths", "interior_angles", "vertex_angles"] {
            let d = all_ks(&rc).iter().find(|x| x.0 == name).unwrap().1;
            assert!(d > 0.3, "cells_iso {name}: {d}");
        }
        // Bricks with T-junctions and Voronoi cells both have about six edges per region.
        assert!(rc.edges_per_region.ks > 0.0 && rc.valency.l1 > 0.05);
        assert!(rc.axes_ratio.ks > rj.axes_ratio.ks);
        assert!(rc.theta.resultant_generated.unwrap() < rc.theta.resultant_sample.unwrap());
    }

    #[test]
    fn histogram_ks_and_p_values() {
        let a = Histogram1::build(
            &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0],
            crate::synth::structure::analysis::stats::VarKind::Continuous,
        )
        .unwrap();
        let b = Histogram1::build(
            &[5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0],
            crate::synth::structure::analysis::stats::VarKind::Continuous,
        )
        .unwrap();
        assert_eq!(histogram_ks(&a, &a), 0.0);
        let d = histogram_ks(&a, &b);
        // The piecewise-linear CDFs are a uniform on [1, 8] and one on [5, 12]: D = 4/7 at 5 and 8.
        assert!((d - 4.0 / 7.0).abs() < 1e-12, "{d}");
        // Constant samples jump: D = 1 between two different constants.
        let k =
            |v: f64| Histogram1::build(&[v; 5], crate::synth::structure::analysis::stats::VarKind::Continuous).unwrap();
        assert_eq!(histogram_ks(&k(2.0), &k(3.0)), 1.0);
        assert_eq!(histogram_ks(&k(2.0), &k(2.0)), 0.0);
        assert_eq!(ks_p_value(0.0, 50, 50), 1.0);
        let (p1, p2) = (ks_p_value(0.2, 50, 50), ks_p_value(0.4, 50, 50));
        assert!(p1 > p2 && p1 < 1.0 && p2 > 0.0, "{p1} {p2}");
        // Reference: D = 0.4 with n = m = 50 gives p ≈ 5e-4 (Stephens' approximation).
        assert!((p2 - 5.0e-4).abs() < 3e-4, "{p2}");
        let (m, r) = axial_circular_mean(&[0.1, PI - 0.1]).unwrap();
        assert!(m.min(PI - m) < 1e-12, "{m}");
        assert!(r > 0.9);
    }

    #[test]
    fn json_is_stable() {
        let s = wall();
        let m = model(&s);
        let c = standins::cells_iso(&standins::CellsIsoParams { count: 80, ..Default::default() }, 2);
        let r = compare(&m, &model(&c));
        let a = to_json(&r);
        assert_eq!(a, to_json(&compare(&model(&wall()), &model(&c))));
        let back: StatsReport = serde_json::from_str(&a).unwrap();
        assert_eq!(to_json(&back), a);
        assert!(a.ends_with("}\n"));
        // Sorted keys and rounded floats.
        let pos = |k: &str| a.find(&format!("\"{k}\"")).unwrap_or_else(|| panic!("{k}"));
        assert!(pos("axes_ratio") < pos("counts") && pos("counts") < pos("edge_lengths"));
        assert!(pos("edge_lengths") < pos("valency") && pos("theta") < pos("valency"));
        for tok in a.split(|ch: char| !(ch.is_ascii_digit() || ch == '.' || ch == 'e' || ch == '-')) {
            if let Some((_, frac)) = tok.split_once('.') {
                let digits = frac.split('e').next().unwrap();
                assert!(digits.len() <= 9, "{tok}");
            }
        }
    }
}
