//! Distances, the per-query normalised combination, and candidate selection.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::error::LibraryError;
use super::features::Features;
use crate::synth::rng::Rng;

/// How two spectra are compared (Eq. 4.4 and the Ch 6 alternatives).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum FourierMode {
    /// `Σ |ΔRe| + |ΔIm|`: the thesis's comparison of both components (faithful).
    ReIm,
    /// `Σ |F_A − F_B|`: the complex-modulus reading of Eq. 4.4.
    Modulus,
    /// `Σ ||F_A| − |F_B||`: magnitude only (translation invariant; Ch 6).
    Magnitude,
    /// `Σ |R_A − R_B|` over the radial `|F|` profile (rotation robust).
    Radial,
}

/// One axis of texture space.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Axis {
    /// Eq. 4.2 on the colour histograms.
    Colour,
    /// Eq. 4.4 in the given mode.
    Fourier(FourierMode),
    /// Angular difference of the Chandra orientations (degrees, folded to `[0, 90]`).
    Orientation,
}

/// How each axis is scaled to `[0, 1]` before the Euclidean combination (Eq. 4.5).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Normalise {
    /// Divide by the largest distance of this query over the library (the thesis).
    #[default]
    PerQueryMax,
    /// Divide by a bound that does not depend on the library (results stay stable as the
    /// library grows): colour by the two pixel counts' sum (= 2N, Eq. 4.2's maximum), or 2
    /// for fractions; Fourier by the sum of the two spectra's norms in that mode;
    /// orientation by 90°.
    Fixed,
}

/// Histogram counts as stored (the thesis; equal sizes) or as fractions of the pixel count.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum HistogramNorm {
    #[default]
    Counts,
    Fraction,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct QueryParams {
    /// Enabled axes (the thesis's checkboxes); default colour + Fourier (re/im).
    pub axes: Vec<Axis>,
    pub normalise: Normalise,
    pub histogram: HistogramNorm,
    /// Library index of the query itself, left out of the results (the UI keeps the
    /// selection in the centre).
    pub exclude: Option<usize>,
}

impl Default for QueryParams {
    fn default() -> Self {
        QueryParams {
            axes: vec![Axis::Colour, Axis::Fourier(FourierMode::ReIm)],
            normalise: Normalise::PerQueryMax,
            histogram: HistogramNorm::Counts,
            exclude: None,
        }
    }
}

/// One library entry in a ranking.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ranked {
    /// Index into the library slice.
    pub index: usize,
    /// `sqrt(Σ d̂²)` over the enabled axes.
    pub distance: f64,
    /// Normalised distance `d̂` per enabled axis, in `QueryParams::axes` order.
    pub axes: Vec<f64>,
    /// Raw distance per enabled axis.
    pub raw: Vec<f64>,
}

/// Eq. 4.2: `Σ |C_A − C_B|` over the bins (counts, or fractions of each pixel count).
pub fn colour_distance(a: &Features, b: &Features, norm: HistogramNorm) -> Result<f64, LibraryError> {
    if a.bins != b.bins {
        return Err(LibraryError::Incompatible { what: "histogram bins", left: a.bins, right: b.bins });
    }
    let (sa, sb) = match norm {
        HistogramNorm::Counts => (1.0, 1.0),
        HistogramNorm::Fraction => (1.0 / a.pixels as f64, 1.0 / b.pixels as f64),
    };
    let (mut i, mut j, mut d) = (0, 0, 0.0f64);
    let (ha, hb) = (&a.histogram, &b.histogram);
    while i < ha.len() || j < hb.len() {
        let ka = ha.get(i).map_or(u32::MAX, |e| e.0);
        let kb = hb.get(j).map_or(u32::MAX, |e| e.0);
        if ka == kb {
            d += (ha[i].1 as f64 * sa - hb[j].1 as f64 * sb).abs();
            i += 1;
            j += 1;
        } else if ka < kb {
            d += ha[i].1 as f64 * sa;
            i += 1;
        } else {
            d += hb[j].1 as f64 * sb;
            j += 1;
        }
    }
    Ok(d)
}

fn check_sizes(a: &Features, b: &Features) -> Result<(), LibraryError> {
    if a.size != b.size {
        return Err(LibraryError::Incompatible { what: "spectrum size", left: a.size, right: b.size });
    }
    Ok(())
}

/// Eq. 4.4 in the given mode.
pub fn fourier_distance(a: &Features, b: &Features, mode: FourierMode) -> Result<f64, LibraryError> {
    check_sizes(a, b)?;
    let pairs = a.spectrum.iter().zip(&b.spectrum);
    let d = match mode {
        FourierMode::ReIm => {
            pairs.map(|(p, q)| (p[0] as f64 - q[0] as f64).abs() + (p[1] as f64 - q[1] as f64).abs()).sum()
        }
        FourierMode::Modulus => pairs.map(|(p, q)| (p[0] as f64 - q[0] as f64).hypot(p[1] as f64 - q[1] as f64)).sum(),
        FourierMode::Magnitude => pairs.map(|(p, q)| (modulus(p) - modulus(q)).abs()).sum(),
        FourierMode::Radial => a.radial.iter().zip(&b.radial).map(|(p, q)| (*p as f64 - *q as f64).abs()).sum(),
    };
    Ok(d)
}

fn modulus(c: &[f32; 2]) -> f64 {
    (c[0] as f64).hypot(c[1] as f64)
}

/// The mode's norm of one spectrum (the `Fixed` normalisation bound is the sum of two).
fn fourier_norm(a: &Features, mode: FourierMode) -> f64 {
    match mode {
        FourierMode::ReIm => a.spectrum.iter().map(|c| (c[0] as f64).abs() + (c[1] as f64).abs()).sum(),
        FourierMode::Modulus | FourierMode::Magnitude => a.spectrum.iter().map(modulus).sum(),
        FourierMode::Radial => a.radial.iter().map(|&v| (v as f64).abs()).sum(),
    }
}

fn orientation_distance(a: &Features, b: &Features) -> f64 {
    let d = (a.orientation.angle_deg as f64 - b.orientation.angle_deg as f64).abs() % 180.0;
    d.min(180.0 - d)
}

fn raw_distance(a: &Features, b: &Features, axis: Axis, params: &QueryParams) -> Result<f64, LibraryError> {
    match axis {
        Axis::Colour => colour_distance(a, b, params.histogram),
        Axis::Fourier(m) => fourier_distance(a, b, m),
        Axis::Orientation => Ok(orientation_distance(a, b)),
    }
}

fn fixed_bound(a: &Features, b: &Features, axis: Axis, params: &QueryParams) -> f64 {
    match axis {
        Axis::Colour => match params.histogram {
            HistogramNorm::Counts => (a.pixels + b.pixels) as f64,
            HistogramNorm::Fraction => 2.0,
        },
        Axis::Fourier(m) => fourier_norm(a, m) + fourier_norm(b, m),
        Axis::Orientation => 90.0,
    }
}

/// Every library entry (but `params.exclude`) with its distances to `query`, nearest first
/// (ties by index).
pub fn rank(library: &[Features], query: &Features, params: &QueryParams) -> Result<Vec<Ranked>, LibraryError> {
    if params.axes.is_empty() {
        return Err(LibraryError::BadParameter { name: "axes", reason: "enable at least one axis".into() });
    }
    let raw: Vec<Vec<f64>> = library
        .par_iter()
        .map(|e| params.axes.iter().map(|&ax| raw_distance(query, e, ax, params)).collect::<Result<Vec<f64>, _>>())
        .collect::<Result<_, _>>()?;
    let keep: Vec<usize> = (0..library.len()).filter(|&i| Some(i) != params.exclude).collect();
    let maxima: Vec<f64> =
        (0..params.axes.len()).map(|a| keep.iter().map(|&i| raw[i][a]).fold(0.0f64, f64::max)).collect();
    let mut out: Vec<Ranked> = keep
        .iter()
        .map(|&i| {
            let axes: Vec<f64> = params
                .axes
                .iter()
                .enumerate()
                .map(|(a, &ax)| {
                    let scale = match params.normalise {
                        Normalise::PerQueryMax => maxima[a],
                        Normalise::Fixed => fixed_bound(query, &library[i], ax, params),
                    };
                    if scale > 0.0 {
                        raw[i][a] / scale
                    } else {
                        0.0
                    }
                })
                .collect();
            let distance = axes.iter().map(|d| d * d).sum::<f64>().sqrt();
            Ranked { index: i, distance, axes, raw: raw[i].clone() }
        })
        .collect();
    out.sort_by(|a, b| a.distance.total_cmp(&b.distance).then(a.index.cmp(&b.index)));
    Ok(out)
}

/// Draws up to `k` entries from a ranking without replacement ([references: welsman-dinelle §4.1]): `ρ = 0`
/// takes the nearest in order, `ρ = 1` draws uniformly, and in between each draw picks by
/// inverse CDF over weights `exp(−(d̂ − d̂_min)/τ)`, `τ = ρ/(1−ρ)`, of the entries left.
/// Deterministic for a given `seed`. Returns the entries in draw order.
pub fn select(ranked: &[Ranked], k: usize, randomness: f64, seed: u64) -> Result<Vec<Ranked>, LibraryError> {
    if !(0.0..=1.0).contains(&randomness) {
        return Err(LibraryError::BadParameter {
            name: "randomness",
            reason: format!("{randomness} is not in [0, 1]"),
        });
    }
    let k = k.min(ranked.len());
    if randomness == 0.0 {
        return Ok(ranked[..k].to_vec());
    }
    let mut rng = Rng::new(seed);
    let mut left: Vec<usize> = (0..ranked.len()).collect();
    let mut out = Vec::with_capacity(k);
    let tau = if randomness >= 1.0 { f64::INFINITY } else { randomness / (1.0 - randomness) };
    let mut weights = Vec::with_capacity(ranked.len());
    for _ in 0..k {
        let dmin = left.iter().map(|&i| ranked[i].distance).fold(f64::INFINITY, f64::min);
        weights.clear();
        weights.extend(left.iter().map(|&i| {
            if tau.is_infinite() {
                1.0
            } else {
                (-(ranked[i].distance - dmin) / tau).exp()
            }
        }));
        let total: f64 = weights.iter().sum();
        let u = rng.next_f64() * total;
        let mut acc = 0.0;
        let mut pick = left.len() - 1;
        for (j, &wgt) in weights.iter().enumerate() {
            acc += wgt;
            if u < acc {
                pick = j;
                break;
            }
        }
        out.push(ranked[left.remove(pick)].clone());
    }
    Ok(out)
}

/// [`rank`] then [`select`].
pub fn query(
    library: &[Features],
    target: &Features,
    params: &QueryParams,
    k: usize,
    randomness: f64,
    seed: u64,
) -> Result<Vec<Ranked>, LibraryError> {
    select(&rank(library, target, params)?, k, randomness, seed)
}

/// The first version's range query: the `max(|{d̂ ≤ r}|, k_min)` nearest entries.
pub fn range_query(ranked: &[Ranked], r: f64, k_min: usize) -> Vec<Ranked> {
    let within = ranked.iter().filter(|e| e.distance <= r).count();
    ranked[..within.max(k_min).min(ranked.len())].to_vec()
}
