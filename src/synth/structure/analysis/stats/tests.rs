//! Unit tests of the sample statistics: bin widths and sampling (F3), 2-D marginals, the
//! inventory (F4) and its JSON snapshot in `../testdata`.

use super::*;
use crate::synth::structure::format::parse_structure_file;

#[test]
fn f3_bin_width_matches_hand_computation() {
    // 1..=27: Q25 = 7.5, Q75 = 20.5 (linear interpolation), IQR = 13, N^(-1/3) = 1/3.
    let vals: Vec<f64> = (1..=27).map(|i| i as f64).collect();
    let h = Histogram1::build(&vals, VarKind::Continuous).unwrap();
    let w = 2.0 * 13.0 / 3.0;
    assert!((h.axis.width - w).abs() < 1e-12, "{}", h.axis.width);
    assert_eq!(h.axis.rule, BinRule::FreedmanDiaconis);
    assert_eq!(h.axis.bins, 3); // 26 / 8.667 = 3 exactly: max falls in the last bin
    assert_eq!(h.counts.iter().sum::<u64>(), 27);
    assert_eq!(h.counts[2], 9);
    assert!((freedman_diaconis_width(&vals) - w).abs() < 1e-12);
    // Non-uniform hand example: sorted [1,2,2,3,5,8,13,21], Q25 = 2, Q75 = 9.25,
    // W = 2·7.25·8^(-1/3) = 7.25.
    let v2 = [13.0, 1.0, 2.0, 21.0, 3.0, 2.0, 8.0, 5.0];
    let h2 = Histogram1::build(&v2, VarKind::Continuous).unwrap();
    assert!((h2.axis.width - 7.25).abs() < 1e-12);
    assert_eq!(h2.axis.bins, 3);
    assert_eq!(h2.counts, vec![6, 1, 1]);
}

fn skewed_sample(n: usize, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed);
    (0..n).map(|_| (rng.normal() * 0.5).exp() * 10.0 + 2.0).collect()
}

#[test]
fn f3_sampling_stays_in_range_and_matches_cdf() {
    let data = skewed_sample(2000, 1);
    let h = Histogram1::build(&data, VarKind::Continuous).unwrap();
    let mut rng = Rng::derived(3, "stats", "f3");
    let samples: Vec<f64> = (0..10_000).map(|_| h.sample(&mut rng)).collect();
    let (lo, hi) = (h.axis.data_min, h.axis.data_max);
    assert!(samples.iter().all(|&x| x >= lo && x <= hi));
    let d = ks_one_sample(&samples, |x| h.cdf(x));
    eprintln!("F3 1-D: {} bins, KS D = {d:.4}", h.axis.bins);
    assert!(d < 0.02, "KS D = {d}");
    // Integer variable.
    let ints: Vec<f64> = data.iter().map(|x| (x / 3.0).floor()).collect();
    let hi_ = Histogram1::build(&ints, VarKind::Integer).unwrap();
    for _ in 0..1000 {
        let s = hi_.sample(&mut rng);
        assert_eq!(s, s.round());
        assert!(s >= hi_.axis.data_min && s <= hi_.axis.data_max);
    }
}

#[test]
fn f3_two_d_marginals() {
    let mut rng = Rng::new(8);
    let pts: Vec<Point> = (0..1500)
        .map(|_| {
            let a = rng.range(5.0, 40.0);
            [a, a * rng.range(0.3, 0.9) + rng.normal()]
        })
        .collect();
    let h = Histogram2::build(&pts, VarKind::Continuous, VarKind::Continuous).unwrap();
    let mut r = Rng::new(99);
    let s: Vec<Point> = (0..10_000).map(|_| h.sample(&mut r)).collect();
    let xs: Vec<f64> = s.iter().map(|p| p[0]).collect();
    let ys: Vec<f64> = s.iter().map(|p| p[1]).collect();
    let dx = ks_one_sample(&xs, |x| h.cdf_x(x));
    let dy = ks_one_sample(&ys, |y| h.cdf_y(y));
    eprintln!("F3 2-D: {}×{} bins, KS x {dx:.4} y {dy:.4}", h.x.bins, h.y.bins);
    assert!(dx < 0.02 && dy < 0.02, "KS x {dx} y {dy}");
    assert!(xs.iter().all(|&x| x >= h.x.data_min && x <= h.x.data_max));
    assert!(ys.iter().all(|&y| y >= h.y.data_min && y <= h.y.data_max));
}

#[test]
fn f3_degenerate_iqr() {
    let threes = vec![3.0; 50];
    let h = Histogram1::build(&threes, VarKind::Integer).unwrap();
    assert_eq!(h.axis.rule, BinRule::Unit);
    let mut rng = Rng::new(1);
    assert!((0..100).all(|_| h.sample(&mut rng) == 3.0));
    let c = Histogram1::build(&[2.5; 7], VarKind::Continuous).unwrap();
    assert_eq!(c.axis.rule, BinRule::Constant);
    assert!((0..100).all(|_| c.sample(&mut rng) == 2.5));
    // Few samples: Sturges.
    let s = Histogram1::build(&[1.0, 2.0, 4.0], VarKind::Continuous).unwrap();
    assert_eq!(s.axis.rule, BinRule::Sturges);
    assert_eq!(s.axis.bins, 3);
    // IQR 0 but a wide range (mostly equal values, outliers).
    let mut v = vec![5.0; 40];
    v.push(100.0);
    let o = Histogram1::build(&v, VarKind::Continuous).unwrap();
    assert_eq!(o.axis.rule, BinRule::Sturges);
    assert!(Histogram1::build(&[], VarKind::Continuous).is_none());
    // Angles live in [0, π).
    let a = Histogram1::build(&[0.1, 3.1, 1.0, 2.0, 0.5], VarKind::Angle).unwrap();
    assert_eq!((a.axis.lo, a.axis.hi), (0.0, PI));
    assert!((0..1000).all(|_| (0.0..PI).contains(&a.sample(&mut rng))));
}

const SNAPSHOT_INPUT: &str = include_str!("../testdata/stats_input.json");
const SNAPSHOT: &str = include_str!("../testdata/stats_snapshot.json");

fn snapshot_model() -> StatModel {
    let file = parse_structure_file(SNAPSHOT_INPUT).unwrap();
    analyse(&file.subdivision, file.size, &StatsConfig::default()).unwrap().model
}

#[test]
fn f4_inventory_and_snapshot() {
    let m = snapshot_model();
    for (name, var) in [
        ("valency", &m.valency),
        ("vertex_angles", &m.vertex_angles),
        ("edge_lengths", &m.edge_lengths),
        ("edges_per_region", &m.edges_per_region),
        ("interior_angles", &m.interior_angles),
        ("ellipse_angle", &m.ellipse_angle),
    ] {
        assert!(var.histogram.is_some() && var.summary.is_some(), "{name} missing");
    }
    assert!(m.ellipse_center.histogram.is_some());
    assert!(m.ellipse_axes.histogram.is_some());
    assert!(m.counts.regions_used > 0 && m.counts.regions_used < m.counts.regions);
    // Angles around a vertex sum to 2π: mean gap = 2π / mean valency (among valency ≥ 2).
    let json = m.to_json();
    assert_eq!(StatModel::from_json(&json).unwrap().to_json(), json);
    assert_eq!(json, SNAPSHOT, "snapshot changed; regenerate with `cargo test -- --ignored print_stats_snapshot`");
}

#[test]
#[ignore]
fn print_stats_snapshot() {
    print!("{}", snapshot_model().to_json());
}

#[test]
fn interior_angles_of_an_l() {
    let l = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]];
    let a = interior_angles(&l);
    let deg: Vec<f64> = a.iter().map(|x| x.to_degrees().round()).collect();
    assert_eq!(deg, vec![90.0, 90.0, 90.0, 270.0, 90.0, 90.0]);
    assert!((a.iter().sum::<f64>() - 4.0 * PI).abs() < 1e-12);
}

/// Near-horizontal axial angles fall on both sides of the cut (θ near 0 and near π): their
/// bins are as narrow as the same spread around π/2 gets, and samples stay near horizontal.
#[test]
fn angle_bins_follow_the_axial_spread_across_the_cut() {
    let mut rng = crate::synth::rng::Rng::new(4);
    let tilts: Vec<f64> = (0..40).map(|_| rng.range(-0.15, 0.15)).collect();
    let across: Vec<f64> = tilts.iter().map(|t| t.rem_euclid(PI)).collect();
    let upright: Vec<f64> = tilts.iter().map(|t| PI / 2.0 + t).collect();
    let a = Axis::fit(&across, VarKind::Angle, 64);
    let b = Axis::fit(&upright, VarKind::Angle, 64);
    assert!((a.width - b.width).abs() < 1e-12, "across the cut {} vs upright {}", a.width, b.width);
    assert!(a.width < 0.2, "bin width {}", a.width);
    let h = Histogram1::build(&across, VarKind::Angle).expect("histogram");
    let mut r = crate::synth::rng::Rng::new(5);
    for _ in 0..500 {
        let t = h.sample(&mut r);
        let off = (t + PI / 2.0).rem_euclid(PI) - PI / 2.0;
        assert!(off.abs() <= 0.15 + a.width, "sampled {t} is {off} rad off horizontal");
    }
}
