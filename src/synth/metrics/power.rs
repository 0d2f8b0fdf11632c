//! Bourque's two-dimensional power-spectrum similarity `S_F` ([references: bourque §4.5],
//! Eq. 4.10) as a feature computed once per image and a cheap comparison of two features, so
//! that a catalogue of N renders costs N transforms and N(N − 1)/2 vector differences.
//!
//! Unlike [`super::spectrum_distance`] (radially averaged, for images of different sizes) the
//! spectrum is kept whole: it turns with the image, so orientation is seen (the thesis's bar
//! grid is matched through its orientation parameter). The normalisation is tessera's choice
//! (the thesis leaves it open):
//!
//! 1. luma, mean removed (so the DC term is left out and an inverted image, `c − T`, has the
//!    same spectrum), optionally multiplied by a separable Hann window;
//! 2. `P(k) = |F(k)|² / N⁴`, so `Σ P ≤ 1` for values in `[0, 1]` (Parseval);
//! 3. weighted toward low frequencies by `w(r) = 1 / (1 + r / r₀)`, `r = |k|` in cycles per
//!    image, `r₀ = N / 16`;
//! 4. `S_F = 1 − ½‖w·(P₁ − P₂)‖₂`, clamped to `[0, 1]`.
//!
//! Raw `S_F` sits near 1 for most pairs (broadband power spreads over thousands of bins);
//! [`Calibration`] rescales distances so that thresholds mean the same for any metric.
//!
//! The log-power variant (`log_floor`) compares `ln(1 + w·P / floor)` scaled to unit length:
//! the few strongest peaks no longer decide alone, so the thin mortar of a brick wall or the
//! crossings of a weave count, and a low-contrast target is not "near" every flat render. On
//! random targets of the shader library it ranks the generating shader first in 36 of 52
//! cases against 27 for plain power (the `feature_variants` exploration in
//! `synth::matching`). It is an option, not the default: catalogues built on it matched fewer
//! random targets (14 of 26, 16 with `pool = 4`) than plain power, whose exact peaks give the
//! local search of deterministic shaders its sharp minima.

use serde::{Deserialize, Serialize};

use super::luma::luma;
use crate::raster::Image;
use crate::synth::fft::RealFft2;

/// The options of [`power_feature`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PowerParams {
    /// A separable Hann window before the transform (for images that do not tile; without
    /// it a circular shift leaves the spectrum exactly unchanged).
    pub window: bool,
    /// `r₀` as a fraction of the image side.
    pub r0: f64,
    /// Compare log power above this floor, each feature scaled to unit length.
    pub log_floor: Option<f64>,
    /// Sum the weighted power over blocks of `pool × pool` frequencies (1: every frequency
    /// apart), so that peaks a little apart still meet.
    pub pool: usize,
    /// Divide the distance by the sum of the two spectra's lengths (`‖P₁ − P₂‖ / (‖P₁‖ +
    /// ‖P₂‖)`), so that two faint textures are not alike merely for being faint.
    pub relative: bool,
}

impl Default for PowerParams {
    fn default() -> Self {
        PowerParams { window: true, r0: 1.0 / 16.0, log_floor: None, pool: 1, relative: false }
    }
}

impl PowerParams {
    /// The log-power variant matching uses.
    pub fn log_power() -> PowerParams {
        PowerParams { log_floor: Some(1e-6), ..PowerParams::default() }
    }
}

/// The weighted half spectrum of a square image: `S_F` of two features is a plain vector
/// difference. The half of the spectrum that is the mirror of the other is folded in (each
/// entry scaled by the square root of how many frequencies it stands for), so the stored
/// vector's norm is the full spectrum's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PowerFeature {
    pub side: usize,
    pub params: PowerParams,
    pub weighted: Vec<f32>,
}

/// Why an image has no power feature.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PowerError {
    #[error("the power-spectrum metric compares square images; this one is {0} x {1}")]
    NotSquare(usize, usize),
    #[error("the power-spectrum metric needs at least {MIN_SIDE} x {MIN_SIDE} pixels, not {0} x {0}")]
    TooSmall(usize),
}

/// The smallest side with a spectrum worth comparing (r₀ of one frequency step at 16).
pub const MIN_SIDE: usize = 16;

/// The feature of `img` (square, at least [`MIN_SIDE`] wide).
pub fn power_feature(img: &Image, params: &PowerParams) -> Result<PowerFeature, PowerError> {
    let (w, h) = (img.width, img.height);
    if w != h {
        return Err(PowerError::NotSquare(w, h));
    }
    if w < MIN_SIDE {
        return Err(PowerError::TooSmall(w));
    }
    let n = w;
    let g = luma(img);
    let mean = g.iter().map(|&v| v as f64).sum::<f64>() / (n * n) as f64;
    let hann: Vec<f64> =
        (0..n)
            .map(|i| {
                if params.window {
                    0.5 - 0.5 * (std::f64::consts::TAU * (i as f64 + 0.5) / n as f64).cos()
                } else {
                    1.0
                }
            })
            .collect();
    let plane: Vec<f64> = (0..n * n).map(|i| (g[i] as f64 - mean) * hann[i % n] * hann[i / n]).collect();
    let fft = RealFft2::new(n, n);
    let spec = fft.forward(&plane);
    let norm = (n as f64).powi(4);
    let r0 = params.r0 * n as f64;
    let mut weighted = Vec::with_capacity(fft.half_width() * n);
    for kx in 0..fft.half_width() {
        // Columns 0 and n/2 (even n) are their own mirror; the others stand for two.
        let fold = if kx == 0 || 2 * kx == n { 1.0 } else { std::f64::consts::SQRT_2 };
        for ky in 0..n {
            let fy = if ky > n / 2 { ky as f64 - n as f64 } else { ky as f64 };
            let r = (kx as f64).hypot(fy);
            let p = spec[fft.index(kx, ky)].norm_sqr() / norm;
            weighted.push((fold * p / (1.0 + r / r0)) as f32);
        }
    }
    let mut weighted = pooled(weighted, n, fft.half_width(), params.pool.max(1));
    if let Some(floor) = params.log_floor {
        let floor = floor.max(f64::MIN_POSITIVE) as f32;
        for v in &mut weighted {
            *v = (*v / floor).ln_1p();
        }
        let len = weighted.iter().map(|&v| (v as f64).powi(2)).sum::<f64>().sqrt();
        if len > 0.0 {
            for v in &mut weighted {
                *v = (*v as f64 / len) as f32;
            }
        }
    }
    Ok(PowerFeature { side: n, params: *params, weighted })
}

/// Sums a half spectrum (`half` columns of `n` signed frequencies) over `pool × pool` blocks.
fn pooled(weighted: Vec<f32>, n: usize, half: usize, pool: usize) -> Vec<f32> {
    if pool == 1 {
        return weighted;
    }
    let rows = n.div_ceil(pool) + 1;
    let mut out = vec![0.0f32; half.div_ceil(pool) * rows];
    for kx in 0..half {
        for ky in 0..n {
            let fy = if ky > n / 2 { ky + n / 2 - n } else { ky + n / 2 };
            out[(kx / pool) * rows + fy / pool] += weighted[kx * n + ky];
        }
    }
    out
}

/// `S_F` of two features in `[0, 1]`, 1 for identical spectra; `None` when they were computed
/// at different sizes or with different options (their spectra do not compare).
pub fn power_similarity(a: &PowerFeature, b: &PowerFeature) -> Option<f64> {
    if a.side != b.side || a.params != b.params {
        return None;
    }
    if a.params.log_floor.is_some() {
        // A flat image has no spectrum to scale: it is as far from anything as two images
        // with no frequency in common, not halfway.
        let zero = |f: &PowerFeature| f.weighted.iter().all(|&v| v == 0.0);
        if zero(a) != zero(b) {
            return Some(1.0 - std::f64::consts::FRAC_1_SQRT_2);
        }
    }
    let d2: f64 = a.weighted.iter().zip(&b.weighted).map(|(x, y)| ((x - y) as f64).powi(2)).sum();
    if a.params.relative {
        let len = |f: &PowerFeature| f.weighted.iter().map(|&v| (v as f64).powi(2)).sum::<f64>().sqrt();
        let sum = len(a) + len(b);
        return Some(if sum > 0.0 { (1.0 - d2.sqrt() / sum).clamp(0.0, 1.0) } else { 1.0 });
    }
    Some((1.0 - 0.5 * d2.sqrt()).clamp(0.0, 1.0))
}

/// Rescales a metric's distances `d = 1 − S` so that thresholds mean the same for every
/// metric ([references: bourque §9]): `S' = exp(−d / d₀)`, with `d₀` the median distance of
/// reference pairs of unrelated textures, which therefore score `1/e` by construction.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    pub d0: f64,
}

impl Calibration {
    /// From the similarities of reference pairs (at least one, not all identical images).
    pub fn from_pairs(similarities: &[f64]) -> Option<Calibration> {
        let mut d: Vec<f64> = similarities.iter().map(|s| 1.0 - s).filter(|d| d.is_finite()).collect();
        if d.is_empty() {
            return None;
        }
        d.sort_by(f64::total_cmp);
        let m = d.len() / 2;
        let d0 = if d.len() % 2 == 1 { d[m] } else { 0.5 * (d[m - 1] + d[m]) };
        (d0 > 0.0).then_some(Calibration { d0 })
    }

    /// The calibrated similarity of a raw one.
    pub fn apply(&self, similarity: f64) -> f64 {
        (-(1.0 - similarity).max(0.0) / self.d0).exp()
    }
}
