//! Statistics of a structure sample ([references: frasson §3.4]): the inventory, histograms with the
//! `W = 2·IQR·N^(-1/3)` bin-width rule, and seeded inverse-transform sampling.
//!
//! Inventory ([`StatModel`]):
//! * topology: vertex valency (with and without valency-2 vertices, V31), the angles
//!   between angularly consecutive edges around each vertex, edge lengths;
//! * regions: edges per region, interior angles, ellipse centre `(x, y)` (2-D), axes
//!   `(a, b)` (2-D), angle `θ ∈ [0, π)` (1-D).
//!
//! Topology statistics use the cleaned graph (dangling edges pruned). Region statistics skip
//! border regions when `exclude_border_regions` is set (the default, V30): they are cut off
//! by the sample border, so their shapes are not representative.
//!
//! Histogram rules ([references: frasson §3.4]): range `[min, max]` of the data; bins of width `W` from
//! `min`, the last bin ending at `max` (so `max` falls in the last bin, as the
//! `W·1e-9` padding of the choice intends, without letting samples exceed `max`). If `IQR = 0` or `N < 4`:
//! width 1 for integer variables, Sturges' `k = ceil(log2 N) + 1` bins otherwise. Integer
//! variables use half-integer bin edges (`[min − ½, max + ½]`) and integer bin widths
//! (`max(1, round(W))`), and samples are rounded, so sampling returns integers in
//! `[min, max]`. The ellipse angle uses the fixed range `[0, π)`. At most
//! [`MAX_BINS`] bins per axis (a wider `W` is used beyond that). Sampling draws one `u64`
//! per 1-D sample (two per 2-D sample): the draw picks a bin through the cumulative counts
//! and its position within the bin gives the value (uniform inside the bin, i.e. the
//! piecewise-linear CDF is inverted exactly).

use crate::synth::rng::Rng;
use crate::synth::structure::analysis::ellipse::{self, Moments};
use crate::synth::structure::mesh::faces::{self, FaceOptions, Faces};
use crate::synth::structure::types::{Ellipse, Point, Subdivision};
use crate::synth::structure::validate::Cleaned;
use crate::synth::structure::{round_to, StructureError};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Most bins per histogram axis.
pub const MAX_BINS: usize = 4096;
/// Most bins per axis of a 2-D histogram.
pub const MAX_BINS_2D: usize = 256;

/// How a variable is binned and sampled.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VarKind {
    /// Integer-valued (valency, edge count): unit-aligned bins, integer samples.
    Integer,
    /// Real-valued, range `[min, max]` of the data.
    Continuous,
    /// Axial angle, fixed range `[0, π)`.
    Angle,
}

/// Which rule set the bin width.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BinRule {
    /// `W = 2·IQR·N^(-1/3)` (Diaconis–Freedman).
    FreedmanDiaconis,
    /// Degenerate IQR or `N < 4`, integer variable: `W = 1`.
    Unit,
    /// Degenerate IQR or `N < 4`, real variable: `ceil(log2 N) + 1` bins.
    Sturges,
    /// All samples equal (real variable): one bin of zero width.
    Constant,
    /// The rule's width would give more than the bin cap; the width was widened.
    Capped,
}

/// Percentile with linear interpolation between order statistics (`q ∈ [0, 1]`; numpy's
/// default "linear" method). `sorted` must be sorted and non-empty.
pub fn percentile(sorted: &[f64], q: f64) -> f64 {
    let n = sorted.len();
    if n == 1 {
        return sorted[0];
    }
    let pos = q * (n - 1) as f64;
    let i = pos.floor() as usize;
    let f = pos - i as f64;
    if i + 1 >= n {
        sorted[n - 1]
    } else {
        sorted[i] + f * (sorted[i + 1] - sorted[i])
    }
}

/// The Diaconis–Freedman width `2·IQR·N^(-1/3)` of a sample (0 if degenerate).
pub fn freedman_diaconis_width(values: &[f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let mut s = values.to_vec();
    s.sort_by(f64::total_cmp);
    let iqr = percentile(&s, 0.75) - percentile(&s, 0.25);
    2.0 * iqr * (s.len() as f64).powf(-1.0 / 3.0)
}

/// One histogram axis: bins `[lo + i·width, lo + (i+1)·width)`, the last one ending at `hi`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Axis {
    pub kind: VarKind,
    pub rule: BinRule,
    pub lo: f64,
    pub hi: f64,
    pub width: f64,
    pub bins: usize,
    /// Smallest and largest sample (for integer variables the range is padded by ½).
    pub data_min: f64,
    pub data_max: f64,
}

impl Axis {
    /// Builds the axis of a non-empty sample.
    pub fn fit(values: &[f64], kind: VarKind, max_bins: usize) -> Axis {
        let mut s = values.to_vec();
        s.sort_by(f64::total_cmp);
        let n = s.len();
        let (dmin, dmax) = (s[0], s[n - 1]);
        let iqr = match kind {
            VarKind::Angle => axial_iqr(&s),
            _ => percentile(&s, 0.75) - percentile(&s, 0.25),
        };
        let fd = 2.0 * iqr * (n as f64).powf(-1.0 / 3.0);
        let degenerate = iqr.is_nan() || iqr <= 0.0 || n < 4;
        let (lo, hi) = match kind {
            VarKind::Integer => (dmin.round() - 0.5, dmax.round() + 0.5),
            VarKind::Continuous => (dmin, dmax),
            VarKind::Angle => (0.0, PI),
        };
        let range = hi - lo;
        let (mut rule, mut width) = match (kind, degenerate) {
            (VarKind::Integer, true) => (BinRule::Unit, 1.0),
            (VarKind::Integer, false) => (BinRule::FreedmanDiaconis, fd.round().max(1.0)),
            (_, false) => (BinRule::FreedmanDiaconis, fd),
            (_, true) if range > 0.0 => {
                let k = (n as f64).log2().ceil() + 1.0;
                (BinRule::Sturges, range / k)
            }
            (_, true) => (BinRule::Constant, 0.0),
        };
        if rule == BinRule::Constant {
            return Axis { kind, rule, lo, hi, width, bins: 1, data_min: dmin, data_max: dmax };
        }
        // The relative slack keeps `range / width = 3 + 1e-16` at 3 bins.
        let mut bins = ((range / width * (1.0 - 1e-12)).ceil() as usize).max(1);
        if bins > max_bins {
            rule = BinRule::Capped;
            width = if kind == VarKind::Integer { (range / max_bins as f64).ceil() } else { range / max_bins as f64 };
            bins = ((range / width * (1.0 - 1e-12)).ceil() as usize).clamp(1, max_bins);
        }
        Axis { kind, rule, lo, hi, width, bins, data_min: dmin, data_max: dmax }
    }

    /// Lower edge of bin `i` (`i == bins` gives `hi`).
    pub fn edge(&self, i: usize) -> f64 {
        if i >= self.bins {
            self.hi
        } else {
            self.lo + i as f64 * self.width
        }
    }

    /// The bin of a value (clamped into range).
    pub fn bin(&self, x: f64) -> usize {
        if self.width <= 0.0 {
            return 0;
        }
        let i = ((x - self.lo) / self.width).floor();
        if i.is_nan() || i < 0.0 {
            0
        } else {
            (i as usize).min(self.bins - 1)
        }
    }

    /// The value at fraction `f ∈ [0, 1)` of bin `i`, post-processed by kind (rounded for
    /// integers, clamped to the data range or `[0, π)`).
    fn value(&self, i: usize, f: f64) -> f64 {
        let (a, b) = (self.edge(i), self.edge(i + 1));
        let x = a + f * (b - a);
        match self.kind {
            VarKind::Integer => x.round().clamp(self.data_min, self.data_max),
            VarKind::Continuous => x.clamp(self.data_min, self.data_max),
            VarKind::Angle => {
                if x >= PI {
                    x - PI
                } else {
                    x.max(0.0)
                }
            }
        }
    }
}

/// The interquartile range of axial angles (period π), measured around their axial mean so
/// that a tight cluster across the cut (stones tilted either way of horizontal: θ near 0 and
/// near π) has a small spread, not one of nearly π.
fn axial_iqr(angles: &[f64]) -> f64 {
    let (sx, sy) = angles.iter().fold((0.0, 0.0), |(x, y), t| (x + (2.0 * t).cos(), y + (2.0 * t).sin()));
    let mean = 0.5 * sy.atan2(sx);
    let mut centred: Vec<f64> = angles.iter().map(|t| (t - mean + PI / 2.0).rem_euclid(PI) - PI / 2.0).collect();
    centred.sort_by(f64::total_cmp);
    percentile(&centred, 0.75) - percentile(&centred, 0.25)
}

/// A 1-D histogram.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Histogram1 {
    pub n: usize,
    pub axis: Axis,
    pub counts: Vec<u64>,
}

impl Histogram1 {
    /// `None` for an empty sample. Non-finite values are ignored.
    pub fn build(values: &[f64], kind: VarKind) -> Option<Histogram1> {
        let vals: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        if vals.is_empty() {
            return None;
        }
        let axis = Axis::fit(&vals, kind, MAX_BINS);
        let mut counts = vec![0u64; axis.bins];
        for &v in &vals {
            counts[axis.bin(v)] += 1;
        }
        Some(Histogram1 { n: vals.len(), axis, counts })
    }

    /// One sample (one draw from `rng`).
    pub fn sample(&self, rng: &mut Rng) -> f64 {
        let (i, f) = pick(&self.counts, self.n, rng.next_f64());
        self.axis.value(i, f)
    }

    /// The piecewise-linear CDF (uniform density inside each bin).
    pub fn cdf(&self, x: f64) -> f64 {
        axis_cdf(&self.axis, &self.counts, self.n, x)
    }
}

/// Picks a bin from cumulative counts with `u ∈ [0, 1)`; returns the bin and the position
/// of `u` inside it (`∈ [0, 1)`).
fn pick(counts: &[u64], n: usize, u: f64) -> (usize, f64) {
    let target = u * n as f64;
    let mut cum = 0.0;
    for (i, &c) in counts.iter().enumerate() {
        let next = cum + c as f64;
        if c > 0 && target < next {
            return (i, ((target - cum) / c as f64).clamp(0.0, 1.0 - f64::EPSILON));
        }
        cum = next;
    }
    let last = counts.iter().rposition(|&c| c > 0).unwrap_or(0);
    (last, 1.0 - f64::EPSILON)
}

fn axis_cdf(axis: &Axis, counts: &[u64], n: usize, x: f64) -> f64 {
    if n == 0 {
        return 0.0;
    }
    if x < axis.lo {
        return 0.0;
    }
    if x >= axis.hi {
        return 1.0;
    }
    let i = axis.bin(x);
    let before: u64 = counts[..i].iter().sum();
    let (a, b) = (axis.edge(i), axis.edge(i + 1));
    let f = if b > a { ((x - a) / (b - a)).clamp(0.0, 1.0) } else { 1.0 };
    (before as f64 + f * counts[i] as f64) / n as f64
}

/// A 2-D histogram (independent axis widths), `counts[iy * x.bins + ix]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Histogram2 {
    pub n: usize,
    pub x: Axis,
    pub y: Axis,
    pub counts: Vec<u64>,
}

impl Histogram2 {
    /// `None` for an empty sample. Pairs with a non-finite coordinate are ignored.
    pub fn build(values: &[Point], kind_x: VarKind, kind_y: VarKind) -> Option<Histogram2> {
        let vals: Vec<Point> = values.iter().copied().filter(|p| p[0].is_finite() && p[1].is_finite()).collect();
        if vals.is_empty() {
            return None;
        }
        let xs: Vec<f64> = vals.iter().map(|p| p[0]).collect();
        let ys: Vec<f64> = vals.iter().map(|p| p[1]).collect();
        let x = Axis::fit(&xs, kind_x, MAX_BINS_2D);
        let y = Axis::fit(&ys, kind_y, MAX_BINS_2D);
        let mut counts = vec![0u64; x.bins * y.bins];
        for p in &vals {
            counts[y.bin(p[1]) * x.bins + x.bin(p[0])] += 1;
        }
        Some(Histogram2 { n: vals.len(), x, y, counts })
    }

    /// One sample (two draws from `rng`: the cell and `x` inside it, then `y`).
    pub fn sample(&self, rng: &mut Rng) -> Point {
        let (cell, fx) = pick(&self.counts, self.n, rng.next_f64());
        let fy = rng.next_f64();
        let (ix, iy) = (cell % self.x.bins, cell / self.x.bins);
        [self.x.value(ix, fx), self.y.value(iy, fy)]
    }

    /// Marginal counts along `x`.
    pub fn marginal_x(&self) -> Vec<u64> {
        let mut m = vec![0u64; self.x.bins];
        for (c, &v) in self.counts.iter().enumerate() {
            m[c % self.x.bins] += v;
        }
        m
    }

    /// Marginal counts along `y`.
    pub fn marginal_y(&self) -> Vec<u64> {
        let mut m = vec![0u64; self.y.bins];
        for (c, &v) in self.counts.iter().enumerate() {
            m[c / self.x.bins] += v;
        }
        m
    }

    /// Piecewise-linear CDF of the `x` marginal.
    pub fn cdf_x(&self, x: f64) -> f64 {
        axis_cdf(&self.x, &self.marginal_x(), self.n, x)
    }

    /// Piecewise-linear CDF of the `y` marginal.
    pub fn cdf_y(&self, y: f64) -> f64 {
        axis_cdf(&self.y, &self.marginal_y(), self.n, y)
    }
}

/// One-sample Kolmogorov–Smirnov statistic `D = sup |F_n − F|`.
pub fn ks_one_sample(samples: &[f64], cdf: impl Fn(f64) -> f64) -> f64 {
    let mut s = samples.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len() as f64;
    let mut d: f64 = 0.0;
    for (i, &x) in s.iter().enumerate() {
        let f = cdf(x);
        d = d.max((f - i as f64 / n).abs()).max(((i + 1) as f64 / n - f).abs());
    }
    d
}

/// Two-sample Kolmogorov–Smirnov statistic.
pub fn ks_two_sample(a: &[f64], b: &[f64]) -> f64 {
    if a.is_empty() || b.is_empty() {
        return 1.0;
    }
    let mut a = a.to_vec();
    let mut b = b.to_vec();
    a.sort_by(f64::total_cmp);
    b.sort_by(f64::total_cmp);
    let (mut i, mut j, mut d) = (0usize, 0usize, 0.0f64);
    while i < a.len() && j < b.len() {
        let x = a[i].min(b[j]);
        while i < a.len() && a[i] <= x {
            i += 1;
        }
        while j < b.len() && b[j] <= x {
            j += 1;
        }
        d = d.max((i as f64 / a.len() as f64 - j as f64 / b.len() as f64).abs());
    }
    d
}

/// Summary statistics of a variable.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub n: usize,
    pub min: f64,
    pub max: f64,
    pub mean: f64,
    pub std: f64,
    pub q25: f64,
    pub median: f64,
    pub q75: f64,
}

impl Summary {
    /// `None` for an empty sample.
    pub fn of(values: &[f64]) -> Option<Summary> {
        if values.is_empty() {
            return None;
        }
        let mut s = values.to_vec();
        s.sort_by(f64::total_cmp);
        let n = s.len();
        let mean = s.iter().sum::<f64>() / n as f64;
        let var = s.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n as f64;
        Some(Summary {
            n,
            min: s[0],
            max: s[n - 1],
            mean,
            std: var.sqrt(),
            q25: percentile(&s, 0.25),
            median: percentile(&s, 0.5),
            q75: percentile(&s, 0.75),
        })
    }
}

/// A 1-D variable of the inventory.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Variable1 {
    pub summary: Option<Summary>,
    pub histogram: Option<Histogram1>,
}

impl Variable1 {
    pub fn of(values: &[f64], kind: VarKind) -> Variable1 {
        Variable1 { summary: Summary::of(values), histogram: Histogram1::build(values, kind) }
    }
}

/// A 2-D variable of the inventory.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Variable2 {
    pub summary_x: Option<Summary>,
    pub summary_y: Option<Summary>,
    pub histogram: Option<Histogram2>,
}

impl Variable2 {
    pub fn of(values: &[Point], kx: VarKind, ky: VarKind) -> Variable2 {
        let xs: Vec<f64> = values.iter().map(|p| p[0]).collect();
        let ys: Vec<f64> = values.iter().map(|p| p[1]).collect();
        Variable2 {
            summary_x: Summary::of(&xs),
            summary_y: Summary::of(&ys),
            histogram: Histogram2::build(values, kx, ky),
        }
    }
}

/// Options of the statistics.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct StatsConfig {
    /// Skip border regions in the region statistics (V30).
    pub exclude_border_regions: bool,
    /// How region ellipses are fitted (F2): analytic polygon moments, or the moments of the
    /// pixel centres inside the region.
    #[serde(default)]
    pub ellipse_fit: EllipseFit,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EllipseFit {
    #[default]
    Polygon,
    Pixels,
}

impl Default for StatsConfig {
    fn default() -> Self {
        StatsConfig { exclude_border_regions: true, ellipse_fit: EllipseFit::Polygon }
    }
}

/// Moments of the pixel centres inside `rings` (outer boundary and holes, even-odd).
fn pixel_moments(rings: &[Vec<Point>]) -> Option<Moments> {
    let outer = rings.first()?;
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for p in outer {
        x0 = x0.min(p[0]);
        y0 = y0.min(p[1]);
        x1 = x1.max(p[0]);
        y1 = y1.max(p[1]);
    }
    let mut pts = Vec::new();
    for j in (y0.floor().max(0.0) as i64)..=(y1.ceil() as i64) {
        for i in (x0.floor().max(0.0) as i64)..=(x1.ceil() as i64) {
            let c = [i as f64 + 0.5, j as f64 + 0.5];
            let inside = rings.iter().filter(|r| faces::point_in_polygon(c, r)).count() % 2 == 1;
            if inside {
                pts.push(c);
            }
        }
    }
    ellipse::point_moments(&pts, None)
}

/// Per-region record kept in the model (all regions, border ones flagged).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RegionStat {
    pub area: f64,
    pub edges: usize,
    pub border: bool,
    pub ellipse: Option<Ellipse>,
}

/// Counts of the analysed structure.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Counts {
    pub vertices: usize,
    pub edges: usize,
    pub regions: usize,
    pub border_regions: usize,
    /// Regions that contribute to the region statistics.
    pub regions_used: usize,
    pub components: usize,
}

/// The statistics of a structure sample ([references: frasson §3.4]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StatModel {
    pub config: StatsConfig,
    pub counts: Counts,
    pub valency: Variable1,
    pub valency_without_2: Variable1,
    pub vertex_angles: Variable1,
    pub edge_lengths: Variable1,
    pub edges_per_region: Variable1,
    pub interior_angles: Variable1,
    pub ellipse_center: Variable2,
    pub ellipse_axes: Variable2,
    pub ellipse_angle: Variable1,
    /// Mean area `r̄` of the regions used (0 if none).
    pub mean_region_area: f64,
    pub regions: Vec<RegionStat>,
}

impl StatModel {
    /// Pretty JSON with every float rounded to 1e-9 (stable bytes for golden files).
    pub fn to_json(&self) -> String {
        let mut v = serde_json::to_value(self).expect("StatModel serialises");
        round_json(&mut v, 1e-9);
        let mut s = serde_json::to_string_pretty(&v).expect("JSON value serialises");
        s.push('\n');
        s
    }

    /// Parses [`StatModel::to_json`] output.
    pub fn from_json(text: &str) -> Result<StatModel, serde_json::Error> {
        serde_json::from_str(text)
    }

    /// The ellipses of the regions used by the statistics, in region order.
    pub fn used_ellipses(&self) -> Vec<Ellipse> {
        self.regions
            .iter()
            .filter(|r| !(self.config.exclude_border_regions && r.border))
            .filter_map(|r| r.ellipse)
            .collect()
    }
}

/// Rounds every float in a JSON value to `step` and sorts object keys: stable golden bytes.
pub(crate) fn round_json(v: &mut serde_json::Value, step: f64) {
    match v {
        serde_json::Value::Number(n) if n.is_f64() => {
            let r = round_to(n.as_f64().unwrap_or(0.0), step);
            if let Some(m) = serde_json::Number::from_f64(r) {
                *n = m;
            }
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(|x| round_json(x, step)),
        serde_json::Value::Object(o) => {
            // Sorted keys whatever serde_json's map type (`preserve_order` keeps insertion order).
            let mut entries: Vec<(String, serde_json::Value)> = std::mem::take(o).into_iter().collect();
            entries.sort_by(|a, b| a.0.cmp(&b.0));
            for (k, mut x) in entries {
                round_json(&mut x, step);
                o.insert(k, x);
            }
        }
        _ => {}
    }
}

/// Turning angle at `b` from direction `a→b` to `b→c`, in `(−π, π]`, positive for a left
/// turn in the y-up sense (the turn of a positive-area polygon's convex corner).
pub fn turn_angle(a: Point, b: Point, c: Point) -> f64 {
    let d1 = [b[0] - a[0], b[1] - a[1]];
    let d2 = [c[0] - b[0], c[1] - b[1]];
    (d1[0] * d2[1] - d1[1] * d2[0]).atan2(d1[0] * d2[0] + d1[1] * d2[1])
}

/// Interior angles of a positive-area polygon (`π − turn` at each vertex, in `(0, 2π)`).
pub fn interior_angles(poly: &[Point]) -> Vec<f64> {
    let n = poly.len();
    (0..n).map(|i| PI - turn_angle(poly[(i + n - 1) % n], poly[i], poly[(i + 1) % n])).collect()
}

/// Collects the statistics of a cleaned subdivision and its faces.
pub fn collect_stats(sub: &Subdivision, faces: &Faces, config: &StatsConfig) -> StatModel {
    let v = &sub.vertices;
    let mut incident: Vec<Vec<usize>> = vec![Vec::new(); v.len()];
    for (k, e) in sub.edges.iter().enumerate() {
        incident[e[0]].push(k);
        incident[e[1]].push(k);
    }
    let mut valency = Vec::new();
    let mut valency_without_2 = Vec::new();
    let mut vertex_angles = Vec::new();
    for (i, inc) in incident.iter().enumerate() {
        if inc.is_empty() {
            continue;
        }
        valency.push(inc.len() as f64);
        if inc.len() != 2 {
            valency_without_2.push(inc.len() as f64);
        }
        if inc.len() >= 2 {
            let mut dirs: Vec<f64> = inc
                .iter()
                .map(|&k| {
                    let o = if sub.edges[k][0] == i { sub.edges[k][1] } else { sub.edges[k][0] };
                    (v[o][1] - v[i][1]).atan2(v[o][0] - v[i][0])
                })
                .collect();
            dirs.sort_by(f64::total_cmp);
            for j in 0..dirs.len() {
                let gap = if j + 1 < dirs.len() { dirs[j + 1] - dirs[j] } else { dirs[0] + 2.0 * PI - dirs[j] };
                vertex_angles.push(gap);
            }
        }
    }
    let edge_lengths: Vec<f64> = sub
        .edges
        .iter()
        .map(|e| {
            let (a, b) = (v[e[0]], v[e[1]]);
            ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt()
        })
        .collect();

    let mut regions = Vec::with_capacity(faces.regions.len());
    let mut edges_per_region = Vec::new();
    let mut interior = Vec::new();
    let mut centres = Vec::new();
    let mut axes = Vec::new();
    let mut angles = Vec::new();
    let mut area_sum = 0.0;
    let mut used = 0;
    for (r, reg) in faces.regions.iter().enumerate() {
        let rings = faces.rings(sub, r);
        let moments = match config.ellipse_fit {
            EllipseFit::Polygon => ellipse::rings_moments(&rings),
            EllipseFit::Pixels => pixel_moments(&rings),
        };
        let ell = moments.and_then(|m: Moments| ellipse::ellipse_from_cov(m.centroid, m.cov));
        let border = reg.is_border();
        regions.push(RegionStat { area: reg.area, edges: reg.boundary.len(), border, ellipse: ell });
        if config.exclude_border_regions && border {
            continue;
        }
        used += 1;
        area_sum += reg.area;
        edges_per_region.push(reg.boundary.len() as f64);
        interior.extend(interior_angles(&rings[0]));
        if let Some(e) = ell {
            centres.push(e.center);
            axes.push([e.a, e.b]);
            angles.push(e.theta);
        }
    }
    StatModel {
        config: *config,
        counts: Counts {
            vertices: faces.vertex_count,
            edges: faces.edge_count,
            regions: faces.regions.len(),
            border_regions: faces.regions.iter().filter(|r| r.is_border()).count(),
            regions_used: used,
            components: faces.components,
        },
        valency: Variable1::of(&valency, VarKind::Integer),
        valency_without_2: Variable1::of(&valency_without_2, VarKind::Integer),
        vertex_angles: Variable1::of(&vertex_angles, VarKind::Continuous),
        edge_lengths: Variable1::of(&edge_lengths, VarKind::Continuous),
        edges_per_region: Variable1::of(&edges_per_region, VarKind::Integer),
        interior_angles: Variable1::of(&interior, VarKind::Continuous),
        ellipse_center: Variable2::of(&centres, VarKind::Continuous, VarKind::Continuous),
        ellipse_axes: Variable2::of(&axes, VarKind::Continuous, VarKind::Continuous),
        ellipse_angle: Variable1::of(&angles, VarKind::Angle),
        mean_region_area: if used > 0 { area_sum / used as f64 } else { 0.0 },
        regions,
    }
}

/// Everything the analysis of a structure sample produces.
#[derive(Clone, Debug, PartialEq)]
pub struct Analysis {
    pub cleaned: Cleaned,
    pub faces: Faces,
    pub model: StatModel,
}

/// The whole analysis ([references: frasson §3.4]): validate and clean, extract faces (border regions
/// flagged against `sample_size` if given), fit ellipses and collect statistics.
pub fn analyse(
    sub: &Subdivision,
    sample_size: Option<[f64; 2]>,
    config: &StatsConfig,
) -> Result<Analysis, StructureError> {
    let (cleaned, faces) = faces::analyse_faces(sub, &FaceOptions { sample_size, ..FaceOptions::default() })?;
    let model = collect_stats(&cleaned.subdivision, &faces, config);
    Ok(Analysis { cleaned, faces, model })
}

#[cfg(test)]
mod tests;
