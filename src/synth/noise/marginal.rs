//! First-order statistics of one channel [references: lagae §7] (the paper's §5, intensity
//! distribution matching): the standard normal Φ and Φ⁻¹, Gaussianisation by rank, the compact
//! monotone inverse-CDF curve that maps a Gaussian noise value back to the photo's histogram
//! (with its smoothed form for clamped bands, proposal 14), and the distribution checks (KS
//! distances, moments) that decide whether a channel needs the curve.
//!
//! The curve is why histogram matching stays procedural: multiresolution noise is Gaussian with
//! the variance of eq. 2, so its CDF is known in closed form and every point is mapped on its
//! own, `T(g) = Q(Φ(g/σ_M))`, without measuring the output's histogram.
//!
//! Transcendental functions come from `libm`, so a parameter file and a render are the same bits
//! on every platform (proposal 18).

use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicU64, Ordering};

/// Knots per curve when the caller does not say: the paper's 10 for a 512² photo.
pub const DEFAULT_KNOTS: usize = 10;

/// Most knots a curve may have: more would no longer be a compact parameter set.
pub const MAX_KNOTS: usize = 256;

/// The Gaussian abscissa spans z ∈ [−3, 3] (proposal 8): 99.73 % of the mass, beyond which a
/// photo's empirical quantiles are a handful of outlier pixels.
pub const GAUSSIAN_RANGE: f64 = 3.0;

/// Why a marginal could not be measured or a curve built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MarginalError {
    #[error("no values: a distribution needs at least one")]
    Empty,
    #[error("value {index} is not a finite number ({value})")]
    NonFinite { index: usize, value: f64 },
    #[error("{0} knots: a curve needs at least 2")]
    TooFewKnots(usize),
    #[error("{0} knots: a curve holds at most {MAX_KNOTS}")]
    TooManyKnots(usize),
    #[error("{u} abscissae for {y} knot values")]
    LengthMismatch { u: usize, y: usize },
    #[error("knot abscissa {0} does not exceed the one before it (they must increase strictly)")]
    NotIncreasing(usize),
    #[error("cannot interpolate a {a:?} curve of {ka} knots with a {b:?} curve of {kb} knots")]
    CurveMismatch { a: Abscissa, ka: usize, b: Abscissa, kb: usize },
    #[error("interpolation parameter {0}: it must lie in [0, 1]")]
    BadParameter(f64),
    #[error("the values are too large: their variance overflows")]
    Overflow,
    #[error("{0} values: a channel ranks at most 2³² of them")]
    TooMany(usize),
    #[error("{ranked} ranked values for {values} values (rank the same values)")]
    RankedMismatch { ranked: usize, values: usize },
}

fn check_values(values: &[f64]) -> Result<(), MarginalError> {
    if values.is_empty() {
        return Err(MarginalError::Empty);
    }
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(MarginalError::NonFinite { index, value: values[index] }),
        None => Ok(()),
    }
}

// ---------------------------------------------------------------------------------------------
// Φ and Φ⁻¹.

/// The low part of 1/√2 (1/√2 − `FRAC_1_SQRT_2`, from 50-digit arithmetic).
const FRAC_1_SQRT_2_LO: f64 = -4.833646656726457e-17;

/// The standard normal CDF, `Φ(x) = erfc(−x/√2)/2`: through erfc rather than erf so the lower
/// tail keeps its relative accuracy (Φ(−30) ≈ 5e-198 is representable, 1 − Φ(30) is not).
/// Rounding x/√2 costs about y² ulps of relative accuracy at y = −x/√2, so beyond y = 4 the
/// rounding error is recovered with an FMA and corrected to first order (erfc′ = −2/√π e^{−y²}).
pub fn phi(x: f64) -> f64 {
    let a = -x;
    let y = a * std::f64::consts::FRAC_1_SQRT_2;
    let e = libm::erfc(y);
    if y > 4.0 && y.is_finite() {
        let dy = libm::fma(a, std::f64::consts::FRAC_1_SQRT_2, -y) + a * FRAC_1_SQRT_2_LO;
        0.5 * (e - dy * std::f64::consts::FRAC_2_SQRT_PI * libm::exp(-y * y))
    } else {
        0.5 * e
    }
}

/// Acklam's rational approximation of Φ⁻¹ (relative error 1.15e-9; his published coefficients,
/// written in their shortest exact form), central region.
const ACKLAM_A: [f64; 6] = [
    -39.69683028665376,
    220.9460984245205,
    -275.9285104469687,
    138.357751867269,
    -30.66479806614716,
    2.506628277459239,
];
const ACKLAM_B: [f64; 5] =
    [-54.47609879822406, 161.5858368580409, -155.6989798598866, 66.80131188771972, -13.28068155288572];
/// Tail region.
const ACKLAM_C: [f64; 6] = [
    -0.007784894002430293,
    -0.3223964580411365,
    -2.400758277161838,
    -2.549732539343734,
    4.374664141464968,
    2.938163982698783,
];
const ACKLAM_D: [f64; 4] = [0.007784695709041462, 0.3224671290700398, 2.445134137142996, 3.754408661907416];
const ACKLAM_LOW: f64 = 0.02425;

/// Acklam's approximation of Φ⁻¹ on (0, ½] (relative error 1.15e-9).
fn acklam_lower(p: f64) -> f64 {
    if p < ACKLAM_LOW {
        let q = libm::sqrt(-2.0 * libm::log(p));
        let c = &ACKLAM_C;
        let d = &ACKLAM_D;
        (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5])
            / ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0)
    } else {
        let q = p - 0.5;
        let r = q * q;
        let a = &ACKLAM_A;
        let b = &ACKLAM_B;
        (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q
            / (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0)
    }
}

/// Acklam alone on (0, 1), odd about ½: quadrature nodes need no more than its 1e-9.
fn acklam(u: f64) -> f64 {
    if u > 0.5 {
        -acklam_lower(1.0 - u)
    } else {
        acklam_lower(u)
    }
}

/// Φ⁻¹ on (0, ½]: Acklam, then one Halley step on `Φ(x) − p` (cubic convergence turns the 1e-9
/// start into the accuracy of erfc itself).
fn phi_inv_lower(p: f64) -> f64 {
    let x = acklam_lower(p);
    let e = phi(x) - p;
    // e / pdf(x), the density written out so its exponent stays in range down to p = 2.2e-308.
    let u = e * (2.0 * std::f64::consts::PI).sqrt() * libm::exp(0.5 * x * x);
    if u.is_finite() {
        x - u / (1.0 + 0.5 * x * u)
    } else {
        x
    }
}

/// The inverse standard normal CDF. `u` is clamped into the open interval (0, 1): below the
/// smallest normal double it answers as for that double (`phi_inv(0) ≈ −37.52`), and `u ≥ 1`
/// answers the mirror image (`phi_inv(1) ≈ +37.52`), so the result is always finite; NaN stays
/// NaN. The upper half is computed as `−Φ⁻¹(1 − u)` (1 − u is exact there), which keeps the
/// relative accuracy of the upper tail and makes the function exactly odd about ½.
pub fn phi_inv(u: f64) -> f64 {
    if u.is_nan() {
        return f64::NAN;
    }
    if u > 0.5 {
        -phi_inv_lower((1.0 - u).max(f64::MIN_POSITIVE))
    } else if u == 0.5 {
        0.0
    } else {
        phi_inv_lower(u.max(f64::MIN_POSITIVE))
    }
}

// ---------------------------------------------------------------------------------------------
// Gaussianisation and distribution checks.

/// A channel's values in ascending order, each with its index: what rank Gaussianisation and
/// the curve fit both read, so an analysis sorts each channel once.
#[derive(Clone, Debug)]
pub struct Ranked {
    order: Vec<(f64, u32)>,
}

impl Ranked {
    /// Sorts `values` (finite, at most 2³² of them). By radix on the values' bits (the total
    /// order of `f64::total_cmp`), about four times the speed of a comparison sort at 512²;
    /// the order among equal values is left as it falls, as everything read from it treats
    /// equal values alike.
    pub fn new(values: &[f64]) -> Result<Ranked, MarginalError> {
        check_values(values)?;
        if u32::try_from(values.len()).is_err() {
            return Err(MarginalError::TooMany(values.len()));
        }
        let mut order: Vec<(f64, u32)> = values.iter().copied().zip(0..).collect();
        radsort::sort_by_key(&mut order, |&(v, _)| v);
        Ok(Ranked { order })
    }

    /// The values in ascending order.
    pub fn sorted(&self) -> Vec<f64> {
        self.order.iter().map(|&(v, _)| v).collect()
    }
}

/// Proposal 7 (tessera's choice for "a variance that best fits the histogram"): replaces each
/// value by the Gaussian quantile of its rank, `g = σ·Φ⁻¹((rank + ½)/P)`, with mid-ranks for
/// ties and σ the population standard deviation of the values. Order preserving, equal inputs
/// give equal outputs, and the result is N(0, σ²) up to the 1/(2P) of its empirical steps.
/// Returns the Gaussianised values (in input order) and σ. A constant channel maps to zeros.
pub fn gaussianize(values: &[f64]) -> Result<(Vec<f64>, f64), MarginalError> {
    gaussianize_ranked(values, &Ranked::new(values)?)
}

/// [`gaussianize`] with `values` already ranked ([`Ranked::new`] of the same values).
pub fn gaussianize_ranked(values: &[f64], ranked: &Ranked) -> Result<(Vec<f64>, f64), MarginalError> {
    check_values(values)?;
    let p = values.len();
    let order = &ranked.order;
    if order.len() != p {
        return Err(MarginalError::RankedMismatch { ranked: order.len(), values: p });
    }
    let mean = values.iter().sum::<f64>() / p as f64;
    let sigma = libm::sqrt(values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / p as f64);
    if !sigma.is_finite() {
        return Err(MarginalError::Overflow);
    }
    let mut out = vec![0.0; p];
    let mut start = 0;
    while start < p {
        let v = order[start].0;
        let mut end = start + 1;
        // `==`, not total order: −0.0 and +0.0 are one tie group (they sort next to each other).
        while end < p && order[end].0 == v {
            end += 1;
        }
        // Mid-rank of positions start..end, plus ½: (start + end − 1)/2 + ½ = (start + end)/2.
        let u = (start + end) as f64 * 0.5 / p as f64;
        let g = sigma * phi_inv(u);
        for &(_, i) in &order[start..end] {
            out[i as usize] = g;
        }
        start = end;
    }
    Ok((out, sigma))
}

/// The finite values, sorted.
fn sorted_finite(a: &[f64]) -> Vec<f64> {
    let mut s: Vec<f64> = a.iter().copied().filter(|v| v.is_finite()).collect();
    s.sort_unstable_by(f64::total_cmp);
    s
}

/// The two-sample Kolmogorov–Smirnov distance sup |F_a − F_b| between the empirical CDFs.
/// Non-finite values are ignored; with no finite value on either side the answer is 1 (nothing
/// supports the two agreeing).
pub fn ks_two_sample(a: &[f64], b: &[f64]) -> f64 {
    let (a, b) = (sorted_finite(a), sorted_finite(b));
    if a.is_empty() || b.is_empty() {
        return 1.0;
    }
    let (n, m) = (a.len() as f64, b.len() as f64);
    let (mut i, mut j, mut d) = (0, 0, 0.0f64);
    while i < a.len() && j < b.len() {
        // Step over every copy of the next value on both sides before comparing: the CDFs are
        // right-continuous, so ties must not open a spurious gap.
        let v = a[i].min(b[j]);
        while i < a.len() && a[i] <= v {
            i += 1;
        }
        while j < b.len() && b[j] <= v {
            j += 1;
        }
        d = d.max((i as f64 / n - j as f64 / m).abs());
    }
    d
}

/// The one-sample Kolmogorov–Smirnov distance between the empirical CDF of `a` and N(0, σ²).
/// Non-finite values are ignored; no finite value, or σ negative or not finite, gives 1. σ = 0
/// is the step at 0.
pub fn ks_normal(a: &[f64], sigma: f64) -> f64 {
    let a = sorted_finite(a);
    if a.is_empty() || !(sigma.is_finite() && sigma >= 0.0) {
        return 1.0;
    }
    let n = a.len() as f64;
    let mut d = 0.0f64;
    for (i, &x) in a.iter().enumerate() {
        // The CDF at x and just left of it (they differ only for the step of σ = 0).
        let (f, f_left) = if sigma > 0.0 {
            let f = phi(x / sigma);
            (f, f)
        } else {
            (if x >= 0.0 { 1.0 } else { 0.0 }, if x > 0.0 { 1.0 } else { 0.0 })
        };
        d = d.max((i + 1) as f64 / n - f).max(f_left - i as f64 / n);
    }
    d
}

/// The first four moments of a sample (population, i.e. biased, estimators: the channel is the
/// whole photo, not a draw from it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Moments {
    /// How many finite values they were measured on (non-finite values are ignored).
    pub count: usize,
    pub mean: f64,
    /// Population standard deviation.
    pub std: f64,
    /// m₃ / m₂^{3/2}; 0 when the sample is constant.
    pub skew: f64,
    /// m₄ / m₂² − 3; 0 when the sample is constant.
    pub excess_kurtosis: f64,
}

/// Mean, standard deviation, skewness and excess kurtosis (all 0 for an empty sample), two-pass
/// and summed in input order (deterministic).
pub fn moments(a: &[f64]) -> Moments {
    let finite = || a.iter().copied().filter(|v| v.is_finite());
    let count = finite().count();
    if count == 0 {
        return Moments { count, mean: 0.0, std: 0.0, skew: 0.0, excess_kurtosis: 0.0 };
    }
    let n = count as f64;
    let mean = finite().sum::<f64>() / n;
    let (mut m2, mut m3, mut m4) = (0.0, 0.0, 0.0);
    for v in finite() {
        let d = v - mean;
        let d2 = d * d;
        m2 += d2;
        m3 += d2 * d;
        m4 += d2 * d2;
    }
    let (m2, m3, m4) = (m2 / n, m3 / n, m4 / n);
    let std = libm::sqrt(m2);
    if !(m2 > 0.0 && m2.is_finite()) {
        return Moments { count, mean, std, skew: 0.0, excess_kurtosis: 0.0 };
    }
    Moments { count, mean, std, skew: m3 / (m2 * std), excess_kurtosis: m4 / (m2 * m2) - 3.0 }
}

/// KS distance to N(0,1) above which `histogram = auto` fits a curve (proposal 9).
pub const AUTO_KS: f64 = 0.03;
/// |Skewness| above which `histogram = auto` fits a curve.
pub const AUTO_SKEW: f64 = 0.3;
/// |Excess kurtosis| above which `histogram = auto` fits a curve.
pub const AUTO_KURTOSIS: f64 = 0.5;

/// Proposal 9's `auto` (tessera's choice; the paper decides per example): the channel needs
/// histogram matching when, standardised, its KS distance to N(0,1) exceeds 0.03, or
/// |skewness| > 0.3, or |excess kurtosis| > 0.5. A constant or empty channel does not (there
/// is no shape to match). Non-finite values are ignored.
pub fn needs_histogram(values: &[f64]) -> bool {
    let m = moments(values);
    if m.count == 0 || !(m.std > 0.0 && m.std.is_finite()) {
        return false;
    }
    if m.skew.abs() > AUTO_SKEW || m.excess_kurtosis.abs() > AUTO_KURTOSIS {
        return true;
    }
    let z: Vec<f64> = values.iter().filter(|v| v.is_finite()).map(|v| (v - m.mean) / m.std).collect();
    ks_normal(&z, 1.0) > AUTO_KS
}

// ---------------------------------------------------------------------------------------------
// Monotone cubic interpolation.

/// The secant of interval `l` (None outside the knots).
fn secant(x: &impl Fn(usize) -> f64, y: &[f64], l: isize) -> Option<f64> {
    if l < 0 || l as usize + 1 >= y.len() {
        return None;
    }
    let l = l as usize;
    Some((y[l + 1] - y[l]) / (x(l + 1) - x(l)))
}

/// The Fritsch–Carlson slope at a knot from the four secants around it, δ_{j−2} … δ_{j+1}:
/// the averaged secants inside, zero at an extremum or next to a flat interval, the one-sided
/// secant at an end; then each of the knot's two intervals pulls its (α, β) = (m_j, m_{j+1})/δ
/// into the disk α² + β² ≤ 9, and the knot takes the smaller of the two factors.
///
/// Both factors are computed from the unscaled slopes (tessera's choice; the usual sweep scales
/// as it goes): the result does not depend on a sweep direction, so the curve of mirrored knots
/// (a negated PCA channel) is exactly the mirrored curve, and each slope needs only its four
/// nearest secants, so a curve is evaluated without building its slope table. It stays monotone
/// because shrinking α or β only moves a point deeper into the disk.
fn fc_slope(d: [Option<f64>; 4]) -> f64 {
    let unlimited = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) => {
            if a * b > 0.0 {
                0.5 * (a + b)
            } else {
                0.0
            }
        }
        (Some(a), None) | (None, Some(a)) => a,
        (None, None) => 0.0,
    };
    let (before, here, after) = (unlimited(d[0], d[1]), unlimited(d[1], d[2]), unlimited(d[2], d[3]));
    let limit = |delta: Option<f64>, a: f64, b: f64| match delta {
        Some(delta) if delta != 0.0 => {
            let (a, b) = (a / delta, b / delta);
            let s = a * a + b * b;
            if s > 9.0 {
                3.0 / libm::sqrt(s)
            } else {
                1.0
            }
        }
        _ => 1.0,
    };
    here * limit(d[1], before, here).min(limit(d[2], here, after))
}

/// The slope at knot `j`.
fn knot_slope(x: &impl Fn(usize) -> f64, y: &[f64], j: usize) -> f64 {
    let j = j as isize;
    fc_slope([secant(x, y, j - 2), secant(x, y, j - 1), secant(x, y, j), secant(x, y, j + 1)])
}

/// Interval `i`'s ends and their slopes, `(x_i, x_{i+1}, m_i, m_{i+1})`, from the six knots
/// around it (each abscissa computed once; the same arithmetic as [`knot_slope`]).
fn interval_slopes(x: &impl Fn(usize) -> f64, y: &[f64], i: usize) -> (f64, f64, f64, f64) {
    let k = y.len() as isize;
    let at = |o: usize| i as isize + o as isize - 2;
    let xs: [f64; 6] = std::array::from_fn(|o| if (0..k).contains(&at(o)) { x(at(o) as usize) } else { 0.0 });
    let d: [Option<f64>; 5] = std::array::from_fn(|o| {
        let l = at(o);
        (l >= 0 && l + 1 < k).then(|| (y[l as usize + 1] - y[l as usize]) / (xs[o + 1] - xs[o]))
    });
    (xs[2], xs[3], fc_slope([d[0], d[1], d[2], d[3]]), fc_slope([d[1], d[2], d[3], d[4]]))
}

/// One cubic Hermite piece from (x0, y0, m0) to (x1, y1, m1) at `s` in [x0, x1]. At x0 it returns
/// y0 exactly; the result is kept within [y0, y1] (each Fritsch–Carlson piece is monotone, so
/// this only removes rounding overshoot).
fn hermite_piece(x0: f64, x1: f64, y0: f64, y1: f64, m0: f64, m1: f64, s: f64) -> f64 {
    let h = x1 - x0;
    let t = (s - x0) / h;
    let (t2, u) = (t * t, 1.0 - t);
    let h10 = t * u * u;
    let h01 = t2 * (3.0 - 2.0 * t);
    let h11 = -t2 * u;
    let v = y0 + (y1 - y0) * h01 + h * (m0 * h10 + m1 * h11);
    v.max(y0.min(y1)).min(y0.max(y1))
}

/// Fritsch–Carlson monotone piecewise cubic Hermite interpolation (PCHIP) through (u_k, y_k),
/// u strictly increasing: monotone wherever the data are. `m` holds the slopes at the knots.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pchip {
    pub u: Vec<f64>,
    pub y: Vec<f64>,
    pub m: Vec<f64>,
}

impl Pchip {
    /// The interpolant through `(u[k], y[k])`: 2 to [`MAX_KNOTS`] finite knots, `u` strictly
    /// increasing.
    pub fn new(u: Vec<f64>, y: Vec<f64>) -> Result<Pchip, MarginalError> {
        if u.len() != y.len() {
            return Err(MarginalError::LengthMismatch { u: u.len(), y: y.len() });
        }
        check_knot_count(y.len())?;
        check_values(&u)?;
        check_values(&y)?;
        if let Some(i) = (1..u.len()).find(|&i| u[i] <= u[i - 1]) {
            return Err(MarginalError::NotIncreasing(i));
        }
        let x = |j: usize| u[j];
        let m = (0..y.len()).map(|j| knot_slope(&x, &y, j)).collect();
        Ok(Pchip { u, y, m })
    }

    /// The interpolant at `x`; outside the knots it holds the end values (NaN gives NaN). At
    /// a knot it is that knot's value exactly.
    pub fn eval(&self, x: f64) -> f64 {
        let (u, y, m) = (&self.u, &self.y, &self.m);
        let k = y.len();
        if k == 0 || u.len() != k || m.len() != k || x.is_nan() {
            return f64::NAN;
        }
        if k == 1 || x <= u[0] {
            return y[0];
        }
        if x >= u[k - 1] {
            return y[k - 1];
        }
        let i = u.partition_point(|&v| v <= x).saturating_sub(1).min(k - 2);
        hermite_piece(u[i], u[i + 1], y[i], y[i + 1], m[i], m[i + 1], x)
    }
}

fn check_knot_count(k: usize) -> Result<(), MarginalError> {
    if k < 2 {
        Err(MarginalError::TooFewKnots(k))
    } else if k > MAX_KNOTS {
        Err(MarginalError::TooManyKnots(k))
    } else {
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// The inverse-CDF curve.

/// Where the inverse-CDF knots lie (proposal 8).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Abscissa {
    /// The paper's subsampled inverse cumulative histogram: u_k = k/(K−1), so the first and
    /// last knots are the channel's min and max; interpolated in u.
    Quantile,
    /// Knots uniform in Gaussian space, z_k ∈ [−3, 3], y_k = Q(Φ(z_k)); interpolated in z, linear
    /// beyond ±3 and clamped to [min, max] (tessera's choice: the same parameter count fits the
    /// tails far better, because the knots are dense where the mass is).
    Gaussian,
}

/// The compact inverse cumulative histogram of one channel (the paper's §5): the K knot values
/// are the only fitted numbers; `min` and `max` (the channel's range) bound the Gaussian
/// abscissa's extrapolation and equal the end knots for the quantile abscissa.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Curve {
    pub abscissa: Abscissa,
    pub knots: Vec<f64>,
    pub min: f64,
    pub max: f64,
}

/// A curve's knot abscissae and slopes worked out once ([`Curve::table`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CurveTable {
    x: Vec<f64>,
    m: Vec<f64>,
}

/// [`Curve::map_smoothed`] under one (σ_M, σ_d), tabulated at [`LUT_POINTS`] values of g over
/// ±[`LUT_RANGE`]·σ_M (within the knots' span for the Gaussian abscissa) and interpolated by
/// Catmull–Rom cubics; exact evaluation outside that range. A render maps every pixel through
/// the same few curves, and a table lookup costs a few nanoseconds where the exact map costs Φ
/// and a knot search (and 33 of each once a footprint smooths the curve): the lookup table over
/// (g/σ_M, σ_d/σ_M) that the method's proposal 14 allows, one σ_d at a time.
///
/// Points are worked out when first read and kept (a morph touches hundreds of tables with a
/// few thousand values each, which would not repay filling them), so whichever path reads a
/// point, and whenever, it gets the same number: every path of a render agrees bit for bit.
#[derive(Debug)]
pub struct CurveLut {
    lo: f64,
    step: f64,
    inv_step: f64,
    sigma_m: f64,
    sigma_d: f64,
    /// Each point's bits once worked out, 0 before (a point that is +0.0 is worked out at every
    /// read: the same number). Empty: nothing is kept.
    values: Box<[AtomicU64]>,
}

/// Points of a [`CurveLut`] (32 KiB of f64).
pub const LUT_POINTS: usize = 4096;

/// Half-width of a [`CurveLut`] in σ_M (g beyond 8σ_M is rarer than 10⁻¹⁵).
pub const LUT_RANGE: f64 = 8.0;

impl CurveLut {
    /// The curve's smoothed map at `g`: the table where it covers `g`, the exact map elsewhere.
    #[inline]
    pub fn map(&self, curve: &Curve, table: &CurveTable, g: f64) -> f64 {
        let s = (g - self.lo) * self.inv_step;
        // Also false for NaN, which the exact map handles.
        if s >= 1.0 && s < (LUT_POINTS - 2) as f64 {
            // In range, so a u32 holds it (and converts in one instruction each way).
            let i = s as u32;
            let f = s - f64::from(i);
            let i = i as usize;
            let (a0, a1) = (self.point(curve, table, i - 1), self.point(curve, table, i));
            let (a2, a3) = (self.point(curve, table, i + 1), self.point(curve, table, i + 2));
            // Catmull–Rom: cubic between the two middle points, slopes by central differences.
            a1 + 0.5 * f * ((a2 - a0) + f * ((2.0 * a0 - 5.0 * a1 + 4.0 * a2 - a3) + f * (3.0 * (a1 - a2) + a3 - a0)))
        } else {
            curve.map_smoothed_with(g, self.sigma_m, self.sigma_d, table)
        }
    }

    /// Point `k`: kept, or worked out (and kept where the table keeps points). Two threads may
    /// both work out a point; they store the same bits.
    #[inline(always)]
    fn point(&self, curve: &Curve, table: &CurveTable, k: usize) -> f64 {
        match self.values.get(k).map(|v| v.load(Ordering::Relaxed)) {
            Some(bits) if bits != 0 => f64::from_bits(bits),
            _ => self.work_out(curve, table, k),
        }
    }

    #[cold]
    #[inline(never)]
    fn work_out(&self, curve: &Curve, table: &CurveTable, k: usize) -> f64 {
        let v = curve.map_smoothed_with(self.lo + k as f64 * self.step, self.sigma_m, self.sigma_d, table);
        if let Some(kept) = self.values.get(k) {
            kept.store(v.to_bits(), Ordering::Relaxed);
        }
        v
    }

    /// How many points are kept (worked out and stored).
    #[cfg(test)]
    pub(crate) fn kept(&self) -> usize {
        self.values.iter().filter(|v| v.load(Ordering::Relaxed) != 0).count()
    }
}

/// The 16-node Gauss–Hermite rule for E[f(Z)], Z ~ N(0,1), folded: nodes ±`GH_NODES[i]` (the
/// physicists' nodes times √2) with weight `GH_WEIGHTS[i]` each (the physicists' weights over
/// √π, so all 16 sum to 1). Computed at 40 digits with mpmath.
const GH_NODES: [f64; 8] = [
    0.3867606045005573,
    1.1638291005549648,
    1.9519803457163334,
    2.7602450476307014,
    3.600873624171548,
    4.492955302520011,
    5.472225705949343,
    6.630878198393129,
];
const GH_WEIGHTS: [f64; 8] = [
    0.28656852123801213,
    0.1583383727509496,
    0.047284752354014026,
    0.007266937601184733,
    0.0005259849265739092,
    1.5300032162487272e-5,
    1.3094732162868227e-7,
    1.4978147231618397e-10,
];

/// Up to this many knots, a smoothed value computes the slope table once (on the stack) for its
/// 33 evaluations; larger hand-built curves compute slopes per evaluation.
const SLOPE_TABLE: usize = 32;

/// 4-point Gauss–Legendre on [0, 1]: (node, weight), weights summing to 1 (40-digit mpmath).
const GL4: [(f64, f64); 4] = [
    (0.06943184420297371, 0.17392742256872692),
    (0.33000947820757187, 0.32607257743127305),
    (0.6699905217924281, 0.32607257743127305),
    (0.9305681557970263, 0.17392742256872692),
];
/// 2-point Gauss–Legendre on [0, 1], for curves with more than 32 intervals.
const GL2: [(f64, f64); 2] = [(0.2113248654051871, 0.5), (0.7886751345948129, 0.5)];

/// The smoothing width s = σ_d/σ_M from which a quantile-abscissa curve is smoothed in u rather
/// than by Gauss–Hermite, for K knots: 6/(K−1) within [0.25, 0.75] (measured crossover of the
/// two rules' errors).
fn wide_smoothing(k: usize) -> f64 {
    (6.0 / (k.max(2) - 1) as f64).clamp(0.25, 0.75)
}

/// Appends `v`, raised to the last knot where rounding put it below (knots never decrease).
fn push_not_below(knots: &mut Vec<f64>, v: f64) {
    knots.push(knots.last().map_or(v, |&p| v.max(p)));
}

/// The empirical quantile of sorted `s` at `u` ∈ [0,1], linear between order statistics at
/// positions (P−1)·u (so u = 0 is the min and u = 1 the max).
fn empirical_quantile(s: &[f64], u: f64) -> f64 {
    let last = s.len() - 1;
    let h = last as f64 * u.clamp(0.0, 1.0);
    let lo = (h.floor() as usize).min(last);
    if lo == last {
        return s[last];
    }
    let f = h - lo as f64;
    let v = s[lo] + f * (s[lo + 1] - s[lo]);
    v.max(s[lo]).min(s[lo + 1])
}

impl Curve {
    /// The abscissa of knot `k` of `n` (u for the quantile kind, z for the Gaussian one).
    fn knot_abscissa(abscissa: Abscissa, k: usize, n: usize) -> f64 {
        let f = k as f64 / (n - 1) as f64;
        match abscissa {
            Abscissa::Quantile => f,
            Abscissa::Gaussian => -GAUSSIAN_RANGE + 2.0 * GAUSSIAN_RANGE * f,
        }
    }

    /// Fits the curve to a channel's values (the original ones, not the Gaussianised): K knots
    /// of the empirical inverse CDF at the abscissa's positions. Knots never decrease.
    pub fn fit(values: &[f64], k: usize, abscissa: Abscissa) -> Result<Curve, MarginalError> {
        check_knot_count(k)?;
        Curve::fit_sorted(&Ranked::new(values)?.sorted(), k, abscissa)
    }

    /// [`Curve::fit`] to values already sorted (ascending, finite, at least one).
    pub fn fit_sorted(s: &[f64], k: usize, abscissa: Abscissa) -> Result<Curve, MarginalError> {
        check_knot_count(k)?;
        check_values(s)?;
        let mut knots = Vec::with_capacity(k);
        for i in 0..k {
            let u = match abscissa {
                Abscissa::Quantile => Curve::knot_abscissa(abscissa, i, k),
                Abscissa::Gaussian => phi(Curve::knot_abscissa(abscissa, i, k)),
            };
            let y = empirical_quantile(s, u);
            // Rounding between two order statistics must not let a knot dip below its
            // predecessor (a parameter file with decreasing knots is refused on reading).
            push_not_below(&mut knots, y);
        }
        Ok(Curve { abscissa, knots, min: s[0], max: s[s.len() - 1] })
    }

    /// The abscissa of knot `j` of this curve.
    fn x(&self, j: usize) -> f64 {
        Curve::knot_abscissa(self.abscissa, j, self.knots.len())
    }

    /// The interval [x_i, x_{i+1}) holding `s`, for x_0 < s < x_{K−1}: guessed from the uniform
    /// spacing, then settled against the same knot abscissae evaluation uses, so a value exactly
    /// at a knot lands at the start of that knot's interval.
    fn interval(&self, s: f64, x: &impl Fn(usize) -> f64) -> usize {
        let k = self.knots.len();
        let (lo, hi) = (x(0), x(k - 1));
        // `as usize` saturates (negative or NaN to 0), so the guess is always an index.
        let mut i = (((s - lo) / (hi - lo)) * (k - 1) as f64) as usize;
        i = i.min(k - 2);
        while i > 0 && s < x(i) {
            i -= 1;
        }
        while i + 2 < k && s >= x(i + 1) {
            i += 1;
        }
        i
    }

    /// The curve at abscissa value `s` (u or z), with the Gaussian kind's linear tails and clamp.
    fn eval_at(&self, s: f64) -> f64 {
        self.eval_with(s, None)
    }

    /// `eval_at`, reading the knot abscissae and slopes from `table` (`(x, m)`, K each) when
    /// given: the same numbers, computed once for many evaluations.
    fn eval_with(&self, s: f64, table: Option<(&[f64], &[f64])>) -> f64 {
        let y = &self.knots;
        let k = y.len();
        if k == 0 || s.is_nan() {
            return f64::NAN;
        }
        let x = |j: usize| match table {
            Some((x, _)) => x[j],
            None => self.x(j),
        };
        let inside = |s: f64| {
            if k == 1 || s <= x(0) {
                return y[0];
            }
            if s >= x(k - 1) {
                return y[k - 1];
            }
            let i = self.interval(s, &x);
            let (x0, x1, m0, m1) = match table {
                Some((_, m)) => (x(i), x(i + 1), m[i], m[i + 1]),
                None => interval_slopes(&x, y, i),
            };
            hermite_piece(x0, x1, y[i], y[i + 1], m0, m1, s)
        };
        match self.abscissa {
            Abscissa::Quantile => inside(s),
            Abscissa::Gaussian => {
                let tail = |j: usize, ds: f64| {
                    let slope = table.map_or_else(|| knot_slope(&x, y, j), |(_, m)| m[j]);
                    // A zero slope times an infinite distance is still the end knot.
                    if slope != 0.0 {
                        y[j] + slope * ds
                    } else {
                        y[j]
                    }
                };
                let v = if k >= 2 && s < -GAUSSIAN_RANGE {
                    tail(0, s + GAUSSIAN_RANGE)
                } else if k >= 2 && s > GAUSSIAN_RANGE {
                    tail(k - 1, s - GAUSSIAN_RANGE)
                } else {
                    inside(s)
                };
                // max/min, not clamp: a hand-built curve with min > max must not panic.
                v.max(self.min).min(self.max)
            }
        }
    }

    /// The abscissa value of a Gaussian value g under N(0, σ_M²): z = g/σ_M, or u = Φ(z).
    fn abscissa_of(&self, g: f64, sigma_m: f64) -> f64 {
        let z = if sigma_m > 0.0 {
            g / sigma_m
        } else if g > 0.0 {
            f64::INFINITY
        } else if g < 0.0 {
            f64::NEG_INFINITY
        } else {
            g
        };
        match self.abscissa {
            Abscissa::Quantile => phi(z),
            Abscissa::Gaussian => z,
        }
    }

    /// Q(u), the inverse CDF at u ∈ \[0, 1\] (u outside is clamped; NaN gives NaN).
    pub fn quantile(&self, u: f64) -> f64 {
        if u.is_nan() {
            return f64::NAN;
        }
        let s = match self.abscissa {
            Abscissa::Quantile => u.clamp(0.0, 1.0),
            Abscissa::Gaussian => phi_inv(u),
        };
        self.eval_at(s)
    }

    /// The back-mapping `T(g) = Q(Φ(g/σ_M))` with σ_M from eq. 2, the variance the weights
    /// give the noise, *not* the σ fitted at analysis: the output histogram is then the
    /// photo's whatever the weight estimation's error. σ_M ≤ 0 (all weights zero) maps 0 to the
    /// median and any other value to the matching end of the range.
    pub fn map(&self, g: f64, sigma_m: f64) -> f64 {
        self.eval_at(self.abscissa_of(g, sigma_m))
    }

    /// Proposal 14 (tessera's choice; the paper is silent): the back-mapping smoothed by the
    /// variance σ_d² of the bands a footprint clamped away, `E[T(g + Z)]`, Z ~ N(0, σ_d²).
    /// Without it the mean of a minified render drifts, because T(mean) is not the mean of T.
    /// When every band is clamped (g = 0, σ_d = σ_M) it is the curve's mean ∫Q(u)du.
    /// σ_d = 0 (or negative, or NaN) is `map` exactly.
    ///
    /// By 16-node Gauss–Hermite quadrature, except for a quantile-abscissa curve smoothed wider
    /// than `wide_smoothing`: there T(x) = Q(Φ(x)) climbs most of its range in the two end
    /// intervals, which stretch to ±∞ in x, and 16 Hermite nodes miss the mean by up to 1.3 % of
    /// the range (measured). That case integrates by parts in u instead,
    /// `E = Q(1) − ∫ Q′(u) P(Φ(X) ≤ u) du` with `P(Φ(X) ≤ u) = Φ((Φ⁻¹(u) − μ)/s)`, by
    /// Gauss–Legendre on each knot interval (where Q′ is a quadratic); it is exact when every
    /// band is dropped (then P = u).
    pub fn map_smoothed(&self, g: f64, sigma_m: f64, sigma_d: f64) -> f64 {
        self.map_smoothed_with(g, sigma_m, sigma_d, &CurveTable::default())
    }

    /// Every knot's abscissa and slope, for [`Curve::map_smoothed_with`] (a render maps
    /// millions of values through one curve).
    pub fn table(&self) -> CurveTable {
        let x = |j: usize| self.x(j);
        let k = self.knots.len();
        CurveTable { x: (0..k).map(x).collect(), m: (0..k).map(|j| knot_slope(&x, &self.knots, j)).collect() }
    }

    /// The [`CurveLut`] of this curve under (σ_M, σ_d), keeping its points as they are read;
    /// None where σ_M is not a positive finite number (the map is then a step, which no table
    /// resolves).
    pub fn lut(&self, sigma_m: f64, sigma_d: f64) -> Option<CurveLut> {
        self.lut_keeping(sigma_m, sigma_d, true)
    }

    /// [`Curve::lut`] keeping no points: each map works out the four it needs (the same
    /// numbers), for a one-off evaluation that would not repay 32 KiB.
    pub fn lut_unkept(&self, sigma_m: f64, sigma_d: f64) -> Option<CurveLut> {
        self.lut_keeping(sigma_m, sigma_d, false)
    }

    fn lut_keeping(&self, sigma_m: f64, sigma_d: f64, keep: bool) -> Option<CurveLut> {
        if !(sigma_m.is_finite() && sigma_m > 0.0) {
            return None;
        }
        let (mut lo, mut hi) = (-LUT_RANGE * sigma_m, LUT_RANGE * sigma_m);
        let k = self.knots.len();
        if self.abscissa == Abscissa::Gaussian && k >= 2 {
            // The Gaussian-abscissa curve turns a corner where its linear tails reach the clamp
            // (beyond the end knots), which no cubic follows, and smoothing spreads the corner
            // by a few σ_d: the table covers the knots less that, the tails stay exact.
            let margin = 4.0 * sigma_d.max(0.0);
            lo = lo.max(self.x(0) * sigma_m + margin);
            hi = hi.min(self.x(k - 1) * sigma_m - margin);
        }
        if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        let step = (hi - lo) / (LUT_POINTS - 1) as f64;
        let values = if keep { (0..LUT_POINTS).map(|_| AtomicU64::new(0)).collect() } else { Box::default() };
        Some(CurveLut { lo, step, inv_step: 1.0 / step, sigma_m, sigma_d, values })
    }

    /// [`Curve::map_smoothed`] reading the knots' abscissae and slopes from `table` (from
    /// [`Curve::table`]; a table of another length is ignored): the same numbers, bit for bit.
    pub fn map_smoothed_with(&self, g: f64, sigma_m: f64, sigma_d: f64, table: &CurveTable) -> f64 {
        let k = self.knots.len();
        let given = (k > 0 && table.x.len() == k && table.m.len() == k).then(|| (&table.x[..], &table.m[..]));
        if sigma_d.is_nan() || sigma_d <= 0.0 {
            return self.eval_with(self.abscissa_of(g, sigma_m), given);
        }
        if g.is_nan() {
            return f64::NAN;
        }
        let k = self.knots.len();
        if self.abscissa == Abscissa::Quantile && sigma_m > 0.0 && k >= 2 {
            let s = sigma_d / sigma_m;
            if s >= wide_smoothing(k) {
                return self.smoothed_in_u(g / sigma_m, s);
            }
        }
        let (mut xs, mut ms) = ([0.0; SLOPE_TABLE], [0.0; SLOPE_TABLE]);
        let table = if given.is_some() {
            given
        } else if (2..=SLOPE_TABLE).contains(&k) {
            let x = |j: usize| self.x(j);
            for j in 0..k {
                xs[j] = x(j);
                ms[j] = knot_slope(&x, &self.knots, j);
            }
            Some((&xs[..k], &ms[..k]))
        } else {
            None
        };
        // About the centre value, so a flat curve stays exactly flat whatever the rounding of
        // the weights' sum.
        let centre = self.eval_with(self.abscissa_of(g, sigma_m), table);
        let mut sum = 0.0;
        for (&x, &w) in GH_NODES.iter().zip(&GH_WEIGHTS) {
            let d = sigma_d * x;
            let lo = self.eval_with(self.abscissa_of(g - d, sigma_m), table);
            let hi = self.eval_with(self.abscissa_of(g + d, sigma_m), table);
            sum += w * ((lo - centre) + (hi - centre));
        }
        centre + sum
    }

    /// `E[Q(Φ(X))]`, X ~ N(μ, s²), for the quantile abscissa, by parts in u (see `map_smoothed`).
    fn smoothed_in_u(&self, mu: f64, s: f64) -> f64 {
        let y = &self.knots;
        let k = y.len();
        let x = |j: usize| self.x(j);
        let rule: &[(f64, f64)] = if k - 1 <= 32 { &GL4 } else { &GL2 };
        let mut sum = 0.0;
        for i in 0..k - 1 {
            let (x0, x1, m0, m1) = interval_slopes(&x, y, i);
            let h = x1 - x0;
            let (y0, y1) = (y[i], y[i + 1]);
            let mut piece = 0.0;
            for &(t, w) in rule {
                // Q′ of the Hermite cubic at u = x_i + t·h.
                let dq =
                    6.0 * t * (t - 1.0) * (y0 - y1) / h + m0 * (t * (3.0 * t - 4.0) + 1.0) + m1 * t * (3.0 * t - 2.0);
                let below = phi((acklam(x0 + t * h) - mu) / s);
                piece += w * dq * below;
            }
            sum += h * piece;
        }
        y[k - 1] - sum
    }

    /// The curve of the negated channel, `Q'(u) = −Q(1 − u)`: the knots reversed and negated
    /// (both abscissae are symmetric about their middle), the range mirrored. A PCA column
    /// whose sign flips flips its channel this way.
    pub fn negated(&self) -> Curve {
        Curve {
            abscissa: self.abscissa,
            knots: self.knots.iter().rev().map(|v| -v).collect(),
            min: -self.max,
            max: -self.min,
        }
    }

    /// The curve with `k` knots at its abscissa's positions for `k`, read off this one (itself
    /// when it has `k` already). Knots never decrease, as the interpolation keeps monotone data
    /// monotone; rounding is clamped.
    pub fn resampled(&self, k: usize) -> Curve {
        if k == self.knots.len() || k < 2 || self.knots.is_empty() {
            return self.clone();
        }
        let mut knots: Vec<f64> = Vec::with_capacity(k);
        for j in 0..k {
            let v = self.eval_at(Curve::knot_abscissa(self.abscissa, j, k));
            push_not_below(&mut knots, v);
        }
        Curve { knots, ..self.clone() }
    }

    /// Knot-by-knot linear interpolation (the paper's Fig. 15 morph; in quantile terms this is
    /// displacement interpolation of the two distributions). Both curves must have the same
    /// abscissa and K; t ∈ [0, 1], with t = 0 giving `self` and t = 1 `other` bit for bit.
    pub fn lerp(&self, other: &Curve, t: f64) -> Result<Curve, MarginalError> {
        if self.abscissa != other.abscissa || self.knots.len() != other.knots.len() {
            return Err(MarginalError::CurveMismatch {
                a: self.abscissa,
                ka: self.knots.len(),
                b: other.abscissa,
                kb: other.knots.len(),
            });
        }
        if !(0.0..=1.0).contains(&t) {
            return Err(MarginalError::BadParameter(t));
        }
        if t == 0.0 {
            return Ok(self.clone());
        }
        if t == 1.0 {
            return Ok(other.clone());
        }
        let mix = |a: f64, b: f64| a + (b - a) * t;
        let monotone = |k: &[f64]| k.windows(2).all(|w| w[0] <= w[1]);
        let keep_monotone = monotone(&self.knots) && monotone(&other.knots);
        let mut knots: Vec<f64> = Vec::with_capacity(self.knots.len());
        for (&a, &b) in self.knots.iter().zip(&other.knots) {
            let v = mix(a, b);
            // A convex combination of two non-decreasing sequences does not decrease; rounding
            // must not make it.
            knots.push(match knots.last() {
                Some(&p) if keep_monotone => v.max(p),
                _ => v,
            });
        }
        Ok(Curve { abscissa: self.abscissa, knots, min: mix(self.min, other.min), max: mix(self.max, other.max) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::rng::{derive_seed, Rng};

    const N: usize = 100_000;

    fn rng(label: &str) -> Rng {
        Rng::new(derive_seed(2009, "noise", label))
    }

    /// Test marginals, 1e5 values each.
    fn sample(kind: &str) -> Vec<f64> {
        let mut r = rng(kind);
        let exp = |r: &mut Rng| -libm::log(1.0 - r.next_f64());
        (0..N)
            .map(|_| match kind {
                "gaussian" => 0.3 + 0.2 * r.normal(),
                "exponential" => exp(&mut r),
                "gamma" => exp(&mut r) + exp(&mut r) + exp(&mut r),
                "lognormal" => libm::exp(0.6 * r.normal()),
                "bimodal" => {
                    if r.next_f64() < 0.4 {
                        -2.0 + 0.5 * r.normal()
                    } else {
                        1.5 + 0.8 * r.normal()
                    }
                }
                "uniform" => r.range(-1.0, 3.0),
                _ => unreachable!(),
            })
            .collect()
    }

    /// Item 14's "reproduced marginal": 1e5 N(0, σ_M²) draws mapped through the curve.
    fn reproduce(curve: &Curve, sigma_m: f64, label: &str) -> Vec<f64> {
        let mut r = rng(label);
        (0..N).map(|_| curve.map(sigma_m * r.normal(), sigma_m)).collect()
    }

    #[test]
    fn phi_and_phi_inv_match_reference_values() {
        // References at 30 digits (mpmath).
        let cases = [
            (0.0, 0.5),
            (-5.0, 2.866515718791939e-7),
            (-10.0, 7.619853024160525e-24),
            (-30.0, 4.906713927148187e-198),
            (1.9599639845400543, 0.975),
        ];
        for (x, p) in cases {
            let rel = (phi(x) - p).abs() / p;
            assert!(rel < 1e-14, "phi({x}) = {} vs {p}: rel {rel:e}", phi(x));
        }
        for (p, x) in [(0.975, 1.9599639845400543), (1e-10, -6.361340902404057), (0.3, -0.5244005127080408)] {
            let rel = (phi_inv(p) - x).abs() / x.abs();
            assert!(rel < 1e-14, "phi_inv({p}) = {} vs {x}: rel {rel:e}", phi_inv(p));
        }
        assert_eq!(phi_inv(0.5), 0.0);
        assert!(phi_inv(0.0).is_finite() && phi_inv(0.0) < -37.0, "{}", phi_inv(0.0));
        assert!(phi_inv(-1.0) == phi_inv(0.0) && phi_inv(1.0) == -phi_inv(0.0) && phi_inv(2.0) == phi_inv(1.0));
        assert!(phi_inv(f64::NAN).is_nan() && phi(f64::NAN).is_nan());
        assert_eq!((phi(f64::NEG_INFINITY), phi(f64::INFINITY)), (0.0, 1.0));
        // Odd about ½ wherever 1 − u is exact.
        for u in [0.0625, 0.125, 0.25, 0.375, 0.4375] {
            assert_eq!(1.0 - (1.0 - u), u);
            assert_eq!(phi_inv(1.0 - u), -phi_inv(u));
        }
    }

    #[test]
    fn phi_inv_round_trips_within_1e_12_on_the_open_unit_interval() {
        // u from 1e-12 to ½ on a log grid and its mirror 1 − u; each tail measured relative to
        // its own probability (1 − u for the upper one, read back as Φ(−x)).
        let mut worst: f64 = 0.0;
        for i in 0..=20_000 {
            let u = 1e-12 * libm::pow(0.5e12, i as f64 / 20_000.0);
            let x = phi_inv(u);
            worst = worst.max((phi(x) - u).abs() / u);
            let v = 1.0 - u;
            let y = phi_inv(v);
            worst = worst.max((phi(-y) - (1.0 - v)).abs() / (1.0 - v));
            worst = worst.max((phi(y) - v).abs());
        }
        println!("Φ(Φ⁻¹(u)) worst relative error on [1e-12, 1 − 1e-12]: {worst:e}");
        assert!(worst < 1e-12, "{worst:e}");
    }

    #[test]
    fn gaussianize_preserves_order_and_maps_ties_equally() {
        let mut r = rng("ties");
        // Quantised values: many ties, including −0 and +0.
        let values: Vec<f64> = (0..5_000).map(|_| (r.normal() * 4.0).round() / 4.0).chain([-0.0, 0.0]).collect();
        let (g, sigma) = gaussianize(&values).unwrap();
        assert!(sigma > 0.9 && sigma < 1.1, "{sigma}");
        for i in (0..values.len()).step_by(7) {
            for j in 0..values.len() {
                if values[i] < values[j] {
                    assert!(g[i] < g[j]);
                } else if values[i] == values[j] {
                    assert_eq!(g[i].to_bits(), g[j].to_bits());
                }
            }
        }
        let (c, s) = gaussianize(&[2.5; 10]).unwrap();
        assert_eq!((c, s), (vec![0.0; 10], 0.0));
        assert_eq!(gaussianize(&[7.0]).unwrap(), (vec![0.0], 0.0));
    }

    #[test]
    fn gaussianized_marginals_are_normal_within_ks_0_005() {
        for kind in ["lognormal", "bimodal", "uniform"] {
            let values = sample(kind);
            let (g, sigma) = gaussianize(&values).unwrap();
            let ks = ks_normal(&g, sigma);
            println!("gaussianize {kind}: σ = {sigma:.4}, KS to N(0, σ²) = {ks:.2e}");
            assert!(ks < 0.005, "{kind}: {ks}");
        }
    }

    #[test]
    fn gaussianize_refuses_empty_and_non_finite_input() {
        assert_eq!(gaussianize(&[]), Err(MarginalError::Empty));
        assert!(matches!(gaussianize(&[1.0, f64::NAN]), Err(MarginalError::NonFinite { index: 1, .. })));
        assert!(matches!(gaussianize(&[f64::INFINITY]), Err(MarginalError::NonFinite { index: 0, .. })));
        assert_eq!(gaussianize(&[f64::MAX, -f64::MAX, 0.0]), Err(MarginalError::Overflow));
    }

    #[test]
    fn ranking_sorts_as_total_order_and_ties_share_a_rank() {
        // The radix sort against the comparison sort, on values with ties, both zeros, negatives
        // and subnormals; ties (−0 and +0 among them) get one Gaussian value.
        let mut values: Vec<f64> = sample("lognormal").iter().map(|v| (v * 8.0).round() / 8.0 - 1.0).collect();
        values.extend([0.0, -0.0, 0.0, f64::MIN_POSITIVE / 4.0, -f64::MIN_POSITIVE / 4.0, -1e100, 1e100]);
        let mut want = values.clone();
        want.sort_by(f64::total_cmp);
        let ranked = Ranked::new(&values).unwrap();
        let got = ranked.sorted();
        assert_eq!(
            got.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            want.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        let (g, _) = gaussianize_ranked(&values, &ranked).unwrap();
        for (i, a) in values.iter().enumerate() {
            for (j, b) in values.iter().enumerate().skip(i + 1).step_by(97) {
                assert_eq!(a == b, g[i] == g[j], "{a} and {b}");
                assert_eq!(a < b, g[i] < g[j], "{a} and {b}");
            }
        }
        assert_eq!(
            gaussianize_ranked(&values[1..], &ranked),
            Err(MarginalError::RankedMismatch { ranked: values.len(), values: values.len() - 1 })
        );
    }

    #[test]
    fn ks_distances_and_moments_behave_on_known_samples() {
        let a = sample("gaussian");
        assert_eq!(ks_two_sample(&a, &a), 0.0);
        let shifted: Vec<f64> = a.iter().map(|v| v + 10.0).collect();
        assert_eq!(ks_two_sample(&a, &shifted), 1.0);
        assert_eq!(ks_two_sample(&[], &a), 1.0);
        assert_eq!(ks_two_sample(&[1.0, 1.0, 2.0], &[1.0, 2.0, 2.0]), 1.0 / 3.0);
        let q: Vec<f64> = (0..1000).map(|i| 2.0 * phi_inv((i as f64 + 0.5) / 1000.0)).collect();
        assert!(ks_normal(&q, 2.0) <= 0.0005 + 1e-12, "{}", ks_normal(&q, 2.0));
        assert_eq!(ks_normal(&q, f64::NAN), 1.0);
        assert_eq!(ks_normal(&[0.0, 0.0], 0.0), 0.0);
        let m = moments(&sample("uniform"));
        assert!((m.excess_kurtosis + 1.2).abs() < 0.02 && m.skew.abs() < 0.02, "{m:?}");
        let m = moments(&sample("exponential"));
        assert!((m.skew - 2.0).abs() < 0.15 && (m.excess_kurtosis - 6.0).abs() < 1.5, "{m:?}");
        let m = moments(&[1.0, f64::NAN, 3.0]);
        assert_eq!((m.count, m.mean, m.std, m.skew, m.excess_kurtosis), (2, 2.0, 1.0, 0.0, -2.0));
        assert_eq!(moments(&[]).count, 0);
    }

    #[test]
    fn needs_histogram_flags_non_gaussian_channels_only() {
        assert!(!needs_histogram(&sample("gaussian")));
        for kind in ["exponential", "gamma", "lognormal", "bimodal", "uniform"] {
            assert!(needs_histogram(&sample(kind)), "{kind}");
        }
        assert!(!needs_histogram(&[]));
        assert!(!needs_histogram(&[3.0; 100]));
        assert!(!needs_histogram(&[f64::NAN; 4]));
    }

    /// Monotone test data with flat runs and a steep jump.
    fn monotone_knots() -> (Vec<f64>, Vec<f64>) {
        let u = vec![0.0, 0.1, 0.15, 0.4, 0.5, 0.55, 0.7, 0.9, 0.95, 1.0];
        let y = vec![-3.0, -2.9, -2.9, -2.9, -1.0, 4.0, 4.1, 4.3, 9.0, 9.0];
        (u, y)
    }

    #[test]
    fn pchip_passes_exactly_through_its_knots_and_is_monotone_on_a_dense_grid() {
        let (u, y) = monotone_knots();
        let p = Pchip::new(u.clone(), y.clone()).unwrap();
        for k in 0..u.len() {
            assert_eq!(p.eval(u[k]).to_bits(), y[k].to_bits(), "knot {k}");
        }
        let grid: Vec<f64> = (0..10_000).map(|i| -0.1 + 1.2 * i as f64 / 9_999.0).map(|x| p.eval(x)).collect();
        assert!(grid.windows(2).all(|w| w[0] <= w[1]));
        assert_eq!((grid[0], grid[9_999]), (-3.0, 9.0));
        // Decreasing data: monotone the other way.
        let p = Pchip::new(u.clone(), y.iter().map(|v| -v).collect()).unwrap();
        assert!((0..10_000).map(|i| p.eval(i as f64 / 9_999.0)).collect::<Vec<_>>().windows(2).all(|w| w[0] >= w[1]));
        assert!(p.eval(f64::NAN).is_nan());
    }

    /// The slope table built the usual way (all raw slopes, flat intervals zeroed, then each
    /// interval's factor), with the factors of a knot's two intervals combined by `min`.
    fn slope_table(x: &[f64], y: &[f64]) -> Vec<f64> {
        let k = y.len();
        let delta = |i: usize| (y[i + 1] - y[i]) / (x[i + 1] - x[i]);
        let mut m = vec![0.0; k];
        m[0] = delta(0);
        m[k - 1] = delta(k - 2);
        for (i, mi) in m.iter_mut().enumerate().take(k - 1).skip(1) {
            let (a, b) = (delta(i - 1), delta(i));
            *mi = if a * b > 0.0 { 0.5 * (a + b) } else { 0.0 };
        }
        for i in 0..k - 1 {
            if delta(i) == 0.0 {
                m[i] = 0.0;
                m[i + 1] = 0.0;
            }
        }
        let tau: Vec<f64> = (0..k - 1)
            .map(|i| {
                let d = delta(i);
                let s = if d == 0.0 { 0.0 } else { (m[i] / d).powi(2) + (m[i + 1] / d).powi(2) };
                if s > 9.0 {
                    3.0 / libm::sqrt(s)
                } else {
                    1.0
                }
            })
            .collect();
        (0..k)
            .map(|j| m[j] * tau.get(j.wrapping_sub(1)).copied().unwrap_or(1.0).min(tau.get(j).copied().unwrap_or(1.0)))
            .collect()
    }

    #[test]
    fn local_slopes_equal_the_full_fritsch_carlson_table_and_curves_equal_pchip() {
        let mut r = rng("slopes");
        for trial in 0..200 {
            let k = 2 + trial % 30;
            let x: Vec<f64> = (0..k)
                .scan(0.0, |a, _| {
                    *a += r.range(0.01, 1.0);
                    Some(*a)
                })
                .collect();
            // Monotone with flats and jumps, or wandering (extrema).
            let y: Vec<f64> = (0..k)
                .scan(0.0, |a, _| {
                    let step = match r.below(4) {
                        0 => 0.0,
                        1 => r.range(0.0, 20.0),
                        _ => r.range(0.0, 1.0),
                    };
                    *a += if trial % 2 == 0 { step } else { step - 0.5 };
                    Some(*a)
                })
                .collect();
            let p = Pchip::new(x.clone(), y.clone()).unwrap();
            let want = slope_table(&x, &y);
            for (j, (got, want)) in p.m.iter().zip(&want).enumerate() {
                assert_eq!(got.to_bits(), want.to_bits(), "trial {trial} knot {j}");
            }
        }
        // A curve evaluates its spline without a table: the same numbers as the PCHIP through
        // its knots, bit for bit.
        let c = Curve::fit(&sample("lognormal"), DEFAULT_KNOTS, Abscissa::Quantile).unwrap();
        let p = Pchip::new((0..DEFAULT_KNOTS).map(|i| i as f64 / 9.0).collect(), c.knots.clone()).unwrap();
        for i in 0..=10_000 {
            let u = i as f64 / 10_000.0;
            assert_eq!(c.quantile(u).to_bits(), p.eval(u).to_bits(), "u = {u}");
        }
    }

    #[test]
    fn pchip_refuses_bad_knots() {
        assert_eq!(Pchip::new(vec![0.0], vec![1.0]), Err(MarginalError::TooFewKnots(1)));
        assert_eq!(Pchip::new(vec![0.0, 1.0], vec![1.0]), Err(MarginalError::LengthMismatch { u: 2, y: 1 }));
        assert_eq!(Pchip::new(vec![0.0, 1.0, 1.0], vec![1.0, 2.0, 3.0]), Err(MarginalError::NotIncreasing(2)));
        assert!(matches!(Pchip::new(vec![0.0, f64::NAN], vec![1.0, 2.0]), Err(MarginalError::NonFinite { .. })));
        let many: Vec<f64> = (0..257).map(f64::from).collect();
        assert_eq!(Pchip::new(many.clone(), many), Err(MarginalError::TooManyKnots(257)));
    }

    #[test]
    fn curves_pass_through_their_knots_and_are_monotone() {
        assert_eq!(DEFAULT_KNOTS, 10);
        let values = sample("bimodal");
        for abscissa in [Abscissa::Quantile, Abscissa::Gaussian] {
            for k in [2, 3, DEFAULT_KNOTS, 33, MAX_KNOTS] {
                let c = Curve::fit(&values, k, abscissa).unwrap();
                assert_eq!(c.knots.len(), k);
                for (i, &y) in c.knots.iter().enumerate() {
                    let at = match abscissa {
                        Abscissa::Quantile => c.quantile(i as f64 / (k - 1) as f64),
                        Abscissa::Gaussian => c.map(Curve::knot_abscissa(abscissa, i, k), 1.0),
                    };
                    assert_eq!(at.to_bits(), y.to_bits(), "{abscissa:?} K={k} knot {i}");
                }
                let grid: Vec<f64> = (0..10_000).map(|i| c.quantile(i as f64 / 9_999.0)).collect();
                assert!(grid.windows(2).all(|w| w[0] <= w[1]), "{abscissa:?} K={k}");
                let mapped: Vec<f64> = (0..10_000).map(|i| c.map(-8.0 + 16.0 * i as f64 / 9_999.0, 1.7)).collect();
                assert!(mapped.windows(2).all(|w| w[0] <= w[1]), "{abscissa:?} K={k}");
                assert!(grid.iter().all(|v| (c.min..=c.max).contains(v)));
            }
            assert_eq!(Curve::fit(&values, 1, abscissa), Err(MarginalError::TooFewKnots(1)));
            assert_eq!(Curve::fit(&values, 257, abscissa), Err(MarginalError::TooManyKnots(257)));
            assert_eq!(Curve::fit(&[], 10, abscissa), Err(MarginalError::Empty));
            assert!(matches!(Curve::fit(&[0.0, f64::NAN], 10, abscissa), Err(MarginalError::NonFinite { .. })));
        }
        // The paper's abscissa: the end knots are the channel's extremes.
        let c = Curve::fit(&values, 10, Abscissa::Quantile).unwrap();
        let (lo, hi) = values.iter().fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        assert_eq!((c.knots[0], c.knots[9], c.min, c.max), (lo, hi, lo, hi));
        // Few values, many knots: knots may repeat but never decrease.
        let c = Curve::fit(&[3.0, 1.0, 2.0], 256, Abscissa::Gaussian).unwrap();
        assert!(c.knots.windows(2).all(|w| w[0] <= w[1]));
    }

    #[test]
    fn reproduced_marginals_match_the_original_within_item_14_bounds() {
        // σ_M deliberately unrelated to the channel's σ: the mapping must not care.
        let sigma_m = 0.7;
        for kind in ["gaussian", "exponential", "gamma", "lognormal", "bimodal", "uniform"] {
            let values = sample(kind);
            let q = Curve::fit(&values, DEFAULT_KNOTS, Abscissa::Quantile).unwrap();
            let g = Curve::fit(&values, DEFAULT_KNOTS, Abscissa::Gaussian).unwrap();
            let ks_q = ks_two_sample(&reproduce(&q, sigma_m, kind), &values);
            let ks_g = ks_two_sample(&reproduce(&g, sigma_m, kind), &values);
            println!("reproduced {kind:11}: KS quantile K=10 {ks_q:.4}, gaussian K=10 {ks_g:.4}");
            assert!(ks_q <= 0.07, "{kind} quantile: {ks_q}");
            if ["gaussian", "exponential", "gamma"].contains(&kind) {
                assert!(ks_g <= 0.01, "{kind} gaussian: {ks_g}");
            }
        }
    }

    #[test]
    fn mapping_uses_sigma_m_so_the_output_follows_the_curves_own_distribution() {
        // The curve's own distribution: Q at 4e5 uniform quantiles. The Gaussian values come
        // with σ_M = 2.5 while the channel's σ is ≈ 1; mapped with σ_M they follow the curve,
        // mapped with the fitted σ instead they would not.
        let values = sample("gamma");
        let sigma_fit = moments(&values).std;
        for abscissa in [Abscissa::Quantile, Abscissa::Gaussian] {
            let c = Curve::fit(&values, DEFAULT_KNOTS, abscissa).unwrap();
            let own: Vec<f64> = (0..400_000).map(|i| c.quantile((i as f64 + 0.5) / 4e5)).collect();
            let sigma_m = 2.5;
            let mut r = rng("item 15");
            let g: Vec<f64> = (0..N).map(|_| sigma_m * r.normal()).collect();
            let right: Vec<f64> = g.iter().map(|&v| c.map(v, sigma_m)).collect();
            let wrong: Vec<f64> = g.iter().map(|&v| c.map(v, sigma_fit)).collect();
            let (ks, ks_wrong) = (ks_two_sample(&right, &own), ks_two_sample(&wrong, &own));
            println!(
                "{abscissa:?}: KS to the curve's own distribution {ks:.4} (with the fitted σ instead: {ks_wrong:.3})"
            );
            assert!(ks < 0.005, "{abscissa:?}: {ks}");
            // Not a checklist bound: shows the test can tell σ_M from the fitted σ.
            assert!(ks_wrong > 0.05, "{ks_wrong}");
        }
    }

    /// ∫ f(x) φ(x) dx over ±9 by composite Simpson on `n` intervals.
    fn gaussian_expectation(f: impl Fn(f64) -> f64, n: usize) -> f64 {
        let h = 18.0 / n as f64;
        let mut sum = 0.0;
        for i in 0..=n {
            let x = -9.0 + h * i as f64;
            let w = if i == 0 || i == n {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            sum += w * f(x) * libm::exp(-0.5 * x * x);
        }
        sum * h / 3.0 / (2.0 * std::f64::consts::PI).sqrt()
    }

    /// ∫Q(u)du: in closed form for the quantile abscissa (each Hermite piece integrates to
    /// h(y₀+y₁)/2 + h²(m₀−m₁)/12), as E[T(Z)] by Simpson for the Gaussian one.
    fn curve_mean(c: &Curve) -> f64 {
        match c.abscissa {
            Abscissa::Quantile => {
                let k = c.knots.len();
                let u: Vec<f64> = (0..k).map(|i| i as f64 / (k - 1) as f64).collect();
                let p = Pchip::new(u, c.knots.clone()).unwrap();
                (0..k - 1)
                    .map(|i| {
                        let h = p.u[i + 1] - p.u[i];
                        h * (p.y[i] + p.y[i + 1]) / 2.0 + h * h * (p.m[i] - p.m[i + 1]) / 12.0
                    })
                    .sum()
            }
            Abscissa::Gaussian => gaussian_expectation(|z| c.map(z, 1.0), 40_000),
        }
    }

    #[test]
    fn smoothed_map_equals_map_without_dropped_variance() {
        let values = sample("lognormal");
        for abscissa in [Abscissa::Quantile, Abscissa::Gaussian] {
            let c = Curve::fit(&values, DEFAULT_KNOTS, abscissa).unwrap();
            for i in 0..1000 {
                let g = -5.0 + 10.0 * i as f64 / 999.0;
                assert_eq!(c.map_smoothed(g, 1.3, 0.0).to_bits(), c.map(g, 1.3).to_bits());
            }
        }
    }

    #[test]
    fn slopes_worked_out_once_give_the_same_numbers_bit_for_bit() {
        let values = sample("lognormal");
        for abscissa in [Abscissa::Quantile, Abscissa::Gaussian] {
            // 40 knots is past the table `map_smoothed` builds on its stack.
            for k in [2, 3, DEFAULT_KNOTS, 40] {
                let c = Curve::fit(&values, k, abscissa).unwrap();
                let m = c.table();
                for i in 0..2001 {
                    let g = -6.0 + 12.0 * i as f64 / 2000.0;
                    for sd in [0.0, 0.05, 0.7] {
                        let (a, b) = (c.map_smoothed(g, 1.3, sd), c.map_smoothed_with(g, 1.3, sd, &m));
                        assert_eq!(a.to_bits(), b.to_bits(), "{abscissa:?} k={k} g={g} sd={sd}");
                    }
                }
                // A table of the wrong length is ignored.
                assert_eq!(
                    c.map_smoothed_with(0.4, 1.3, 0.0, &CurveTable { x: vec![0.0], m: vec![1.0] }).to_bits(),
                    c.map(0.4, 1.3).to_bits()
                );
            }
        }
    }

    #[test]
    fn smoothed_map_tends_to_the_curve_mean_when_all_variance_is_dropped() {
        // Every band clamped away: g = 0 and σ_d = σ_M, so E[T(Z)] = ∫Q(u)du (proposal 14's
        // "far away this tends to the exact mean colour"). Also at intermediate σ_d, averaging
        // the smoothed map over the remaining g ~ N(0, σ_M² − σ_d²) keeps that mean.
        let sigma_m = 0.9;
        for kind in ["gaussian", "exponential", "lognormal", "bimodal", "uniform"] {
            let values = sample(kind);
            for abscissa in [Abscissa::Quantile, Abscissa::Gaussian] {
                let c = Curve::fit(&values, DEFAULT_KNOTS, abscissa).unwrap();
                let range = c.max - c.min;
                let mean = curve_mean(&c);
                let far = (c.map_smoothed(0.0, sigma_m, sigma_m) - mean).abs() / range;
                let mut worst_mid: f64 = 0.0;
                for frac in [0.3, 0.6, 0.9] {
                    let sd = frac * sigma_m;
                    let rest = (sigma_m * sigma_m - sd * sd).sqrt();
                    // E over the remaining g ~ N(0, rest²).
                    let avg = gaussian_expectation(|x| c.map_smoothed(rest * x, sigma_m, sd), 4_000);
                    worst_mid = worst_mid.max((avg - mean).abs() / range);
                }
                println!(
                    "{kind:11} {abscissa:?}: |E − ∫Q| / range: all dropped {far:.1e}, partly dropped ≤ {worst_mid:.1e}"
                );
                assert!(far < 1e-3, "{kind} {abscissa:?}: {far}");
                assert!(worst_mid < 1e-3, "{kind} {abscissa:?}: {worst_mid}");
            }
        }
    }

    #[test]
    fn smoothed_map_matches_a_fine_reference_integral() {
        // Pointwise accuracy of the quadrature against composite Simpson on 20 000 intervals
        // of ±9 standard deviations, over widths s = σ_d/σ_M and centres g within the spread
        // the remaining bands give g (std √(1 − s²)·σ_M). A regression guard, not a checklist
        // bound: the figures go in the report.
        let simpson = |c: &Curve, mu: f64, s: f64| gaussian_expectation(|x| c.map(mu + s * x, 1.0), 20_000);
        for kind in ["exponential", "lognormal", "bimodal"] {
            let values = sample(kind);
            for abscissa in [Abscissa::Quantile, Abscissa::Gaussian] {
                let c = Curve::fit(&values, DEFAULT_KNOTS, abscissa).unwrap();
                let range = c.max - c.min;
                let mut worst: f64 = 0.0;
                for s in [0.1f64, 0.3, 0.5, 0.7, 0.8, 0.9, 0.97, 1.0] {
                    let spread = (1.0 - s * s).sqrt();
                    for k in [-2.0, -1.0, 0.0, 1.0, 2.0] {
                        let mu = k * spread;
                        let e = (c.map_smoothed(mu * 1.5, 1.5, s * 1.5) - simpson(&c, mu, s)).abs() / range;
                        worst = worst.max(e);
                    }
                }
                println!("{kind:11} {abscissa:?}: worst |smoothed − reference| / range {worst:.1e}");
                assert!(worst < 1e-2, "{kind} {abscissa:?}: {worst}");
            }
        }
    }

    #[test]
    fn negated_curve_reproduces_the_negated_marginal() {
        for kind in ["exponential", "bimodal"] {
            let values = sample(kind);
            let negated: Vec<f64> = values.iter().map(|v| -v).collect();
            for abscissa in [Abscissa::Quantile, Abscissa::Gaussian] {
                let c = Curve::fit(&values, DEFAULT_KNOTS, abscissa).unwrap();
                let n = c.negated();
                assert_eq!(n.negated(), c);
                let direct = Curve::fit(&negated, DEFAULT_KNOTS, abscissa).unwrap();
                let range = c.max - c.min;
                for (a, b) in n.knots.iter().zip(&direct.knots) {
                    assert!((a - b).abs() <= 1e-12 * range, "{kind} {abscissa:?}: {a} vs {b}");
                }
                assert_eq!((n.min, n.max), (direct.min, direct.max));
                // Q'(u) = −Q(1 − u) on a grid, and the reproduced marginal.
                for i in 0..=1000 {
                    let u = i as f64 / 1000.0;
                    let (a, b) = (n.quantile(u), -c.quantile(1.0 - u));
                    assert!((a - b).abs() <= 1e-12 * range, "{kind} {abscissa:?} u={u}: {a} vs {b}");
                }
                let ks = ks_two_sample(&reproduce(&n, 1.0, kind), &negated);
                let ks_c = ks_two_sample(&reproduce(&c, 1.0, kind), &values);
                println!("negated {kind} {abscissa:?}: KS {ks:.4} (unnegated {ks_c:.4})");
                // Item 14's bounds (the Gaussian one holds for unimodal marginals only).
                match abscissa {
                    Abscissa::Quantile => assert!(ks <= 0.07, "{ks}"),
                    Abscissa::Gaussian if kind == "exponential" => assert!(ks <= 0.01, "{ks}"),
                    Abscissa::Gaussian => {}
                }
            }
        }
    }

    #[test]
    fn lerp_is_exact_at_the_ends_and_stays_monotone() {
        let a = Curve::fit(&sample("exponential"), DEFAULT_KNOTS, Abscissa::Gaussian).unwrap();
        let b = Curve::fit(&sample("bimodal"), DEFAULT_KNOTS, Abscissa::Gaussian).unwrap();
        assert_eq!(a.lerp(&b, 0.0).unwrap(), a);
        assert_eq!(b.lerp(&a, 0.0).unwrap(), b);
        assert_eq!(a.lerp(&b, 1.0).unwrap(), b);
        for i in 1..20 {
            let m = a.lerp(&b, i as f64 / 20.0).unwrap();
            assert!(m.knots.windows(2).all(|w| w[0] <= w[1]));
            assert!(m.min <= m.knots[0] && m.knots[9] <= m.max);
        }
        let mid = a.lerp(&b, 0.5).unwrap();
        assert_eq!(mid.knots[3], 0.5 * (a.knots[3] + b.knots[3]));
        let q = Curve::fit(&sample("exponential"), DEFAULT_KNOTS, Abscissa::Quantile).unwrap();
        assert!(matches!(a.lerp(&q, 0.5), Err(MarginalError::CurveMismatch { .. })));
        let short = Curve::fit(&sample("exponential"), 5, Abscissa::Gaussian).unwrap();
        assert!(matches!(a.lerp(&short, 0.5), Err(MarginalError::CurveMismatch { .. })));
        assert!(matches!(a.lerp(&b, f64::NAN), Err(MarginalError::BadParameter(_))));
        assert_eq!(a.lerp(&b, 1.5), Err(MarginalError::BadParameter(1.5)));
    }

    #[test]
    fn curves_do_not_panic_on_degenerate_input() {
        let c = Curve::fit(&sample("gamma"), DEFAULT_KNOTS, Abscissa::Gaussian).unwrap();
        assert!(c.map(f64::NAN, 1.0).is_nan());
        assert!(c.quantile(f64::NAN).is_nan());
        assert_eq!(c.map(0.0, 0.0), c.quantile(0.5));
        assert_eq!((c.map(1.0, 0.0), c.map(-1.0, 0.0)), (c.max, c.min));
        assert_eq!((c.map(f64::INFINITY, 1.0), c.map(f64::NEG_INFINITY, 1.0)), (c.max, c.min));
        assert_eq!(c.map_smoothed(0.3, 1.0, f64::NAN), c.map(0.3, 1.0));
        assert!(c.map_smoothed(0.3, 1.0, f64::INFINITY).is_finite());
        for abscissa in [Abscissa::Quantile, Abscissa::Gaussian] {
            for knots in [vec![], vec![1.0], vec![3.0, 1.0, 2.0], (0..300).map(f64::from).collect()] {
                let bad = Curve { abscissa, knots, min: 5.0, max: -5.0 };
                let _ = (bad.map(0.2, 1.0), bad.quantile(0.9), bad.map_smoothed(0.1, 1.0, 0.5), bad.negated());
            }
        }
        let flat = Curve::fit(&[4.0; 50], DEFAULT_KNOTS, Abscissa::Gaussian).unwrap();
        assert_eq!((flat.map(2.0, 1.0), flat.map_smoothed(2.0, 1.0, 0.7)), (4.0, 4.0));
    }

    #[test]
    fn curves_round_trip_through_toml() {
        #[derive(Serialize, Deserialize, PartialEq, Debug)]
        struct Wrap {
            curve: Curve,
        }
        let w = Wrap { curve: Curve::fit(&sample("lognormal"), DEFAULT_KNOTS, Abscissa::Gaussian).unwrap() };
        let text = toml::to_string(&w).unwrap();
        assert!(text.contains("abscissa = \"gaussian\""), "{text}");
        assert_eq!(toml::from_str::<Wrap>(&text).unwrap(), w);
    }
}
