//! The fitted procedural texture [references: lagae §7]: the analysis that turns one photo of an
//! isotropic stochastic texture into a handful of numbers (the mean, the PCA transform, per
//! decorrelated channel the band weights of multiresolution wavelet noise and the knots of an
//! inverse-CDF curve), and the parameter file that holds them.
//!
//! The file is the artifact users version and edit: TOML, one table per channel, every number
//! written in its shortest exact form, so the same sample and options give the same bytes and a
//! file read back is the parameter set that was written. Metadata (the noise version, seed,
//! tile size and sample size) says which noise the numbers drive; the paper does not count it.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::colour::{pca, ColourMode, Pca};
use super::marginal::{gaussianize_ranked, needs_histogram, Abscissa, Curve, Ranked};
use super::spectrum::{self, BandPowers, Border};
use super::tile::{self, Tile};
use super::NoiseError;
use crate::raster::Image;

/// Changes whenever the noise a parameter set drives changes (tile generation, offsets, bands).
pub const NOISE_VERSION: u32 = 1;

/// When the histogram curve is fitted (proposal 9; the paper decides per example).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum HistogramMode {
    On,
    Off,
    /// On when the channel is measurably non-Gaussian.
    Auto,
}

/// How band weights are estimated from band powers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Estimator {
    /// Eq. 9, each band on its own.
    Paper,
    /// Non-negative least squares against the simulated leakage between bands.
    Nnls,
}

/// Everything the analysis is told.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FitOptions {
    pub colour: ColourMode,
    pub histogram: HistogramMode,
    pub knots: usize,
    pub abscissa: Abscissa,
    pub estimator: Estimator,
    pub border: Border,
    /// Side of the 2-D noise tile (lattice cells).
    pub tile: usize,
    pub seed: u64,
    /// Bands finer than the sample's pixels added by extrapolating the top bands' weights
    /// (0 to [`MAX_EXTRAPOLATED`]): detail for magnified renders, where the paper's bands stop.
    pub extrapolate: usize,
    /// Where [`fit_masked`] measures the band powers.
    pub mask_spectrum: MaskSpectrum,
}

/// Where a masked fit measures its band powers [references: lagae §9].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MaskSpectrum {
    /// The largest power-of-two square inside the mask: only the class's pixels, but the mask
    /// must hold a 16² square.
    Square,
    /// The periodogram of the sample's centred power-of-two square with the unmasked pixels at
    /// the class's mean, divided by the masked fraction (the mean of mask²): any mask shape, an
    /// approximation (the mask's own edges leak power across bands; for 6-pixel joints every 32
    /// pixels the finer bands come within 1.5 dB, the coarsest 6 dB low).
    Masked,
}

/// The most bands `extrapolate` adds: each halves the finest wavelength, so four carry detail to
/// 16× the sample's resolution.
pub const MAX_EXTRAPOLATED: usize = 4;

/// How many of the top bands the extrapolation line is fitted to (four: [`extrapolate`]).
const EXTRAPOLATION_FIT: usize = 4;

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            colour: ColourMode::Pca,
            histogram: HistogramMode::Auto,
            knots: super::marginal::DEFAULT_KNOTS,
            abscissa: Abscissa::Gaussian,
            estimator: Estimator::Paper,
            border: Border::None,
            tile: 256,
            seed: 0,
            extrapolate: 0,
            mask_spectrum: MaskSpectrum::Square,
        }
    }
}

/// One decorrelated channel: the weights of bands `2..` and, if fitted, its histogram curve.
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    pub weights: Vec<f64>,
    pub curve: Option<Curve>,
}

/// A parameter set: `colour = U·v + mean`, each `v_c` multiresolution wavelet noise (eq. 1)
/// mapped through its curve.
#[derive(Clone, Debug, PartialEq)]
pub struct Procedural {
    pub noise_version: u32,
    pub seed: u64,
    pub tile: usize,
    /// Side of the (cropped) sample: its bands are `2..=log2(sample_size)`.
    pub sample_size: usize,
    pub colour: ColourMode,
    pub mean: [f64; 3],
    /// Columns `u[c]` of U (the identity in the RGB modes).
    pub u: [[f64; 3]; 3],
    pub channels: [Channel; 3],
}

/// What the analysis found besides the parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct Fitted {
    pub params: Procedural,
    /// The band powers each channel's weights were estimated from.
    pub powers: Vec<BandPowers>,
    /// The max/min power ratio over angular sectors (above [`spectrum::ANISOTROPY_LIMIT`] the
    /// sample is not isotropic and the fit loses its structure).
    pub anisotropy: f64,
    /// `(width, height)` of the input when it was cropped to a power-of-two square.
    pub cropped_from: Option<(usize, usize)>,
}

impl Procedural {
    /// The number of fitted numbers (the paper's count: mean, transform, weights, knots).
    pub fn count(&self) -> usize {
        12 + self
            .channels
            .iter()
            .map(|c| c.weights.len() + c.curve.as_ref().map_or(0, |k| k.knots.len()))
            .sum::<usize>()
    }

    /// The bands the weights stand for: `2..=log2(sample_size)`, then any extrapolated ones.
    pub fn bands(&self) -> Vec<u32> {
        (2..2 + self.channels[0].weights.len() as u32).collect()
    }
}

/// Three channel planes of the same pixels.
type Planes = [Vec<f64>; 3];

/// Where the band powers are measured.
enum Measure {
    /// On the region itself: the sample's centred power-of-two square.
    Region,
    /// On a power-of-two square inside the mask.
    Square(Planes),
    /// On the sample's centred square, `crop` naming each pixel's place in the region (`None`
    /// outside the mask), `fraction` of them in it.
    Masked { crop: Vec<Option<usize>>, fraction: f64 },
}

/// The sample's channels as three planes (grey repeated, alpha dropped).
fn rgb_planes(img: &Image) -> Result<[Vec<f64>; 3], NoiseError> {
    if img.channels == 0 || img.width == 0 || img.height == 0 {
        return Err(NoiseError::Sample("the sample has no pixels".into()));
    }
    let plane =
        |c: usize| img.plane(c.min(img.channels.min(3) - 1)).iter().map(|&v| f64::from(v)).collect::<Vec<f64>>();
    let planes = [plane(0), plane(1), plane(2)];
    if planes.iter().flatten().any(|v| !v.is_finite()) {
        return Err(NoiseError::Sample("the sample holds values that are not finite".into()));
    }
    Ok(planes)
}

/// Fits a parameter set to `img` (proposal 4: a sample that is not a power-of-two square is
/// cropped to its largest centred one; the caller warns).
pub fn fit(img: &Image, opts: &FitOptions) -> Result<Fitted, NoiseError> {
    fit_masked(img, None, opts)
}

/// [`fit`] to the pixels of `img` where `mask` (row-major, one flag per pixel) is set: one region
/// class of a structured sample [references: lagae §9]. The mean, colour axes and histogram
/// curves come from every masked pixel; the band powers as `opts.mask_spectrum` says (see
/// [`MaskSpectrum`]): from the largest power-of-two square inside the mask, so that no unmasked
/// pixel leaks into the spectrum, or from the masked periodogram for any shape.
pub fn fit_masked(img: &Image, mask: Option<&[bool]>, opts: &FitOptions) -> Result<Fitted, NoiseError> {
    if !(2..=256).contains(&opts.knots) {
        return Err(NoiseError::Options(format!("{} histogram knots: between 2 and 256", opts.knots)));
    }
    let planes = rgb_planes(img)?;
    let (w, h) = (img.width, img.height);
    // The region's pixels (colour and marginals) and where its spectrum is measured.
    let (region, measure, n): (Planes, Measure, usize) = match mask {
        None => {
            let mut cropped: Planes = Default::default();
            let mut n = 0;
            for (c, p) in cropped.iter_mut().zip(&planes) {
                let (crop, side) = spectrum::pow2_crop(p, w, h)?;
                (*c, n) = (crop, side);
            }
            (cropped, Measure::Region, n)
        }
        Some(mask) => {
            if mask.len() != w * h {
                return Err(NoiseError::Mask(format!("a mask of {} flags for {} pixels", mask.len(), w * h)));
            }
            let region = planes.clone().map(|p| p.into_iter().zip(mask).filter(|(_, &m)| m).map(|(v, _)| v).collect());
            match opts.mask_spectrum {
                MaskSpectrum::Square => {
                    let Some((x0, y0, n)) = spectrum::inscribed_pow2_square(mask, w, h) else {
                        return Err(NoiseError::Mask(format!(
                            "the mask holds no {0} x {0} square of the sample: too little to measure a spectrum (`mask_spectrum = masked` measures any shape, approximately)",
                            spectrum::MIN_SIDE
                        )));
                    };
                    let square =
                        planes.map(|p| (y0..y0 + n).flat_map(|y| p[y * w + x0..y * w + x0 + n].to_vec()).collect());
                    (region, Measure::Square(square), n)
                }
                MaskSpectrum::Masked => {
                    // Each region pixel's index, then the centred square's pixels as region indices.
                    let mut next = 0;
                    let index: Vec<Option<usize>> = mask
                        .iter()
                        .map(|&m| {
                            next += usize::from(m);
                            m.then(|| next - 1)
                        })
                        .collect();
                    let (crop, n) = spectrum::pow2_crop(&index, w, h)?;
                    let inside = crop.iter().flatten().count();
                    let least = spectrum::MIN_SIDE * spectrum::MIN_SIDE;
                    if inside < least {
                        return Err(NoiseError::Mask(format!(
                            "the mask holds {inside} pixels of the sample's centred {n} x {n} square: at least {least} are needed to measure a spectrum"
                        )));
                    }
                    let fraction = inside as f64 / (n * n) as f64;
                    (region, Measure::Masked { crop, fraction }, n)
                }
            }
        }
    };
    let cropped_from = (mask.is_none() && (w != n || h != n)).then_some((w, h));
    let square = match &measure {
        Measure::Square(square) => Some(square),
        _ => None,
    };
    let m = n * n;
    let (mean, u, pca) = match opts.colour {
        ColourMode::Pca => {
            let pca: Pca = pca(&region[0], &region[1], &region[2])?;
            (pca.mean, pca.u, Some(pca))
        }
        ColourMode::RgbIndependent | ColourMode::RgbShared => {
            let k = region[0].len() as f64;
            let mean: [f64; 3] = std::array::from_fn(|c| region[c].iter().sum::<f64>() / k);
            (mean, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], None)
        }
    };
    let decorrelate = |planes: &Planes| -> Vec<Vec<f64>> {
        let len = planes[0].len();
        let mut out = vec![vec![0.0; len]; 3];
        for i in 0..len {
            let p = [planes[0][i], planes[1][i], planes[2][i]];
            let v = match &pca {
                Some(pca) => pca.decorrelate(p),
                None => std::array::from_fn(|c| p[c] - mean[c]),
            };
            for (o, v) in out.iter_mut().zip(v) {
                o[i] = v;
            }
        }
        out
    };
    let decorrelated = decorrelate(&region);
    let square_decorrelated = square.map(decorrelate);
    let grey = |p: &Planes, i: usize| (p[0][i] + p[1][i] + p[2][i]) / 3.0;
    let luminance: Vec<f64> = match &measure {
        Measure::Region => (0..m).map(|i| grey(&region, i)).collect(),
        Measure::Square(square) => (0..m).map(|i| grey(square, i)).collect(),
        Measure::Masked { crop, .. } => {
            let mean = (0..region[0].len()).map(|i| grey(&region, i)).sum::<f64>() / region[0].len() as f64;
            crop.iter().map(|k| k.map_or(mean, |k| grey(&region, k))).collect()
        }
    };
    let leakage = match opts.estimator {
        Estimator::Nnls => Some(leakage(&tile::normalised(2, opts.tile, opts.seed, super::SIGMA_N2)?, n, opts.seed)?),
        Estimator::Paper => None,
    };
    // The three channels are independent from here: in parallel (each is the same numbers
    // whichever thread fits it).
    let fitted = decorrelated
        .par_iter()
        .enumerate()
        .map(|(c, values)| -> Result<(BandPowers, Channel), NoiseError> {
            let on = match opts.histogram {
                HistogramMode::On => true,
                HistogramMode::Off => false,
                HistogramMode::Auto => needs_histogram(values),
            };
            let (gauss, curve) = if on {
                let ranked = Ranked::new(values)?;
                let mut curve = Curve::fit_sorted(&ranked.sorted(), opts.knots, opts.abscissa)?;
                // A Gaussian-abscissa curve clamps at its end knots (z = ±3: 0.13 % of each
                // tail), so it costs no numbers beyond its knots, like the paper's.
                if let (Some(&lo), Some(&hi)) = (curve.knots.first(), curve.knots.last()) {
                    curve.min = lo;
                    curve.max = hi;
                }
                // A square is Gaussianised by its own ranks: the same map from values to z as
                // the region's, up to sampling.
                let gauss = match &square_decorrelated {
                    None => gaussianize_ranked(values, &ranked)?.0,
                    Some(sq) => gaussianize_ranked(&sq[c], &Ranked::new(&sq[c])?)?.0,
                };
                (gauss, Some(curve))
            } else {
                (square_decorrelated.as_ref().map_or(values, |sq| &sq[c]).clone(), None)
            };
            let p = match &measure {
                Measure::Masked { crop, fraction } => {
                    // Both are zero-mean over the region, so the unmasked pixels sit at its mean.
                    let plane: Vec<f64> = crop.iter().map(|k| k.map_or(0.0, |k| gauss[k])).collect();
                    let mut p = spectrum::band_powers_with(&plane, n, opts.border)?;
                    p.powers.iter_mut().for_each(|v| *v /= fraction);
                    p.nyquist /= fraction;
                    p
                }
                _ => spectrum::band_powers_with(&gauss, n, opts.border)?,
            };
            let mut weights = match &leakage {
                None => spectrum::weights_paper(&p, super::SIGMA_N2),
                Some(k) => spectrum::weights_nnls(&p, k)?,
            };
            extrapolate(&mut weights, opts.extrapolate.min(MAX_EXTRAPOLATED));
            Ok((p, Channel { weights, curve }))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let (powers, channels): (Vec<BandPowers>, Vec<Channel>) = fitted.into_iter().unzip();
    let anisotropy = spectrum::anisotropy(&luminance, n)?;
    let channels: [Channel; 3] = channels.try_into().map_err(|_| NoiseError::Sample("three channels".into()))?;
    let params = Procedural {
        noise_version: NOISE_VERSION,
        seed: opts.seed,
        tile: opts.tile,
        sample_size: n,
        colour: opts.colour,
        mean,
        u,
        channels,
    };
    Ok(Fitted { params, powers, anisotropy, cropped_from })
}

/// Appends `k` bands to `weights` on the straight line that log₂ w_b follows against b over the
/// top four bands (least squares; bands of weight 0 carry no log and are left
/// out). With fewer than two such bands there is no line, and the added bands are 0. The added
/// weights are capped at the parameter file's bound (10⁶), so a rising spectrum stays finite.
pub fn extrapolate(weights: &mut Vec<f64>, k: usize) {
    if k == 0 {
        return;
    }
    let top = weights.len().saturating_sub(EXTRAPOLATION_FIT);
    let points: Vec<(f64, f64)> = weights[top..]
        .iter()
        .enumerate()
        .filter(|(_, &w)| w > 0.0)
        .map(|(i, &w)| ((top + i) as f64, w.log2()))
        .collect();
    let last = weights.len();
    if points.len() < 2 {
        weights.extend(std::iter::repeat_n(0.0, k));
        return;
    }
    let n = points.len() as f64;
    let (mx, my) = (points.iter().map(|p| p.0).sum::<f64>() / n, points.iter().map(|p| p.1).sum::<f64>() / n);
    let sxx: f64 = points.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let slope = sxy / sxx;
    weights.extend((0..k).map(|j| (my + slope * ((last + j) as f64 - mx)).exp2().min(1e6)));
}

/// How many random band renders the leakage matrix averages.
const LEAKAGE_SEEDS: usize = 4;

/// The leakage matrix of this tile at sample size `n`, by simulation (each band alone, unit
/// weight, at offsets drawn from the seed).
pub fn leakage(tile: &Tile, n: usize, seed: u64) -> Result<Vec<Vec<f64>>, NoiseError> {
    let k = spectrum::leakage_matrix(n, LEAKAGE_SEEDS, |band, s| {
        let mut rng =
            crate::synth::rng::Rng::new(crate::synth::rng::derive_seed(seed, "noise", &format!("leakage {band} {s}")));
        let offset = [rng.range(0.0, tile.n as f64), rng.range(0.0, tile.n as f64)];
        tile::render_band(tile, band, n, offset)
    })?;
    Ok(k)
}

// ---------------------------------------------------------------------------------------------
// The parameter file.

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    noise_version: u32,
    /// Hexadecimal: TOML integers stop at 2^63.
    seed: String,
    tile: usize,
    sample_size: usize,
    colour: ColourMode,
    mean: [f64; 3],
    /// Rows of U, as a reader writes a matrix.
    transform: [[f64; 3]; 3],
    channel: Vec<ChannelFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ChannelFile {
    /// Band `2 + i`.
    weights: Vec<f64>,
    #[serde(default)]
    histogram: Option<HistogramFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct HistogramFile {
    /// `quantile` (the paper's) when absent.
    #[serde(default = "quantile")]
    abscissa: Abscissa,
    knots: Vec<f64>,
    /// The clamp of a Gaussian-abscissa curve (a quantile curve clamps at its end knots).
    #[serde(default)]
    min: Option<f64>,
    #[serde(default)]
    max: Option<f64>,
}

/// `x` in its shortest exact form: decimal, or with an exponent where that is shorter.
fn number(x: f64) -> String {
    let (plain, exp) = (format!("{x:?}"), format!("{x:e}"));
    if exp.len() < plain.len() {
        exp
    } else {
        plain
    }
}

fn quantile() -> Abscissa {
    Abscissa::Quantile
}

const HEADER: &str = "# tessera: a procedural texture fitted by example (Lagae et al. 2009)\n";

impl Procedural {
    /// The parameter file's text. Written by hand rather than through the TOML serialiser,
    /// which spells a tiny weight as forty decimal digits: every number here is its shortest
    /// exact form, with an exponent where that is shorter (TOML reads both).
    pub fn to_toml(&self) -> String {
        use std::fmt::Write;
        let list = |v: &[f64]| v.iter().map(|&x| number(x)).collect::<Vec<_>>().join(", ");
        let mut out = String::from(HEADER);
        let colour = match self.colour {
            ColourMode::Pca => "pca",
            ColourMode::RgbIndependent => "rgb_independent",
            ColourMode::RgbShared => "rgb_shared",
        };
        let rows: Vec<String> =
            (0..3).map(|r| format!("[{}]", list(&[self.u[0][r], self.u[1][r], self.u[2][r]]))).collect();
        let _ = write!(
            out,
            "noise_version = {}\nseed = \"{:016x}\"\ntile = {}\nsample_size = {}\ncolour = \"{colour}\"\nmean = [{}]\ntransform = [{}]\n",
            self.noise_version,
            self.seed,
            self.tile,
            self.sample_size,
            list(&self.mean),
            rows.join(", ")
        );
        for c in &self.channels {
            let _ = write!(out, "\n[[channel]]\nweights = [{}]\n", list(&c.weights));
            if let Some(k) = &c.curve {
                out.push_str("\n[channel.histogram]\n");
                if k.abscissa == Abscissa::Gaussian {
                    out.push_str("abscissa = \"gaussian\"\n");
                }
                let _ = writeln!(out, "knots = [{}]", list(&k.knots));
            }
        }
        out
    }

    /// Reads a parameter file back, checking what evaluation relies on.
    pub fn from_toml(text: &str) -> Result<Procedural, NoiseError> {
        let file: File = toml::from_str(text).map_err(|e| NoiseError::File(e.to_string()))?;
        let bad = |m: String| Err(NoiseError::File(m));
        let Ok(seed) = u64::from_str_radix(&file.seed, 16) else {
            return bad(format!("seed `{}`: up to 16 hexadecimal digits", file.seed));
        };
        if file.noise_version != NOISE_VERSION {
            return bad(format!("noise_version {} (this tessera makes version {NOISE_VERSION})", file.noise_version));
        }
        if !file.sample_size.is_power_of_two() || !(16..=1 << 16).contains(&file.sample_size) {
            return bad(format!("sample_size {}: a power of two from 16 to 65536", file.sample_size));
        }
        if file.tile % 2 != 0 || !(8..=1024).contains(&file.tile) {
            return bad(format!("tile {}: even, from 8 to 1024", file.tile));
        }
        if file.channel.len() != 3 {
            return bad(format!("{} [[channel]] tables: there are three", file.channel.len()));
        }
        let bands = file.sample_size.trailing_zeros() as usize - 1;
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !finite(&file.mean) || !file.transform.iter().all(|r| finite(r)) {
            return bad("the mean and the transform must be finite numbers".into());
        }
        let mut channels = Vec::with_capacity(3);
        for (i, c) in file.channel.into_iter().enumerate() {
            let count_ok = (bands..=bands + MAX_EXTRAPOLATED).contains(&c.weights.len());
            if !count_ok || !finite(&c.weights) || c.weights.iter().any(|w| !(0.0..=1e6).contains(w)) {
                return bad(format!(
                    "channel {i}: {bands} weights (bands 2 to {}, and up to {MAX_EXTRAPOLATED} extrapolated bands after them) between 0 and 1e6, not {:?}",
                    bands + 1,
                    c.weights
                ));
            }
            let curve = match c.histogram {
                None => None,
                Some(h) => {
                    if !(2..=256).contains(&h.knots.len()) || !finite(&h.knots) {
                        return bad(format!("channel {i}: 2 to 256 finite knots"));
                    }
                    if h.knots.windows(2).any(|k| k[1] < k[0]) {
                        return bad(format!("channel {i}: the knots must not decrease (a curve is monotone)"));
                    }
                    let (lo, hi) = (h.knots[0], h.knots[h.knots.len() - 1]);
                    let (min, max) = match h.abscissa {
                        Abscissa::Quantile => (lo, hi),
                        Abscissa::Gaussian => (h.min.unwrap_or(lo), h.max.unwrap_or(hi)),
                    };
                    if !(min.is_finite() && max.is_finite() && min <= lo && hi <= max) {
                        return bad(format!("channel {i}: min and max must enclose the knots"));
                    }
                    Some(Curve { abscissa: h.abscissa, knots: h.knots, min, max })
                }
            };
            channels.push(Channel { weights: c.weights, curve });
        }
        if channels.iter().any(|c: &Channel| c.weights.len() != channels[0].weights.len()) {
            return bad("the three channels must weight the same bands".into());
        }
        let channels: [Channel; 3] = channels.try_into().map_err(|_| NoiseError::File("three channels".into()))?;
        Ok(Procedural {
            noise_version: file.noise_version,
            seed,
            tile: file.tile,
            sample_size: file.sample_size,
            colour: file.colour,
            mean: file.mean,
            u: std::array::from_fn(|c| std::array::from_fn(|r| file.transform[r][c])),
            channels,
        })
    }

    /// The set between `self` (t = 0) and `other` (t = 1), the paper's Fig. 15: everything
    /// linear but the transform (its rotations slerped after `other`'s principal axes are
    /// matched to `self`'s, by permutation and sign), the curves knot by knot. t = 0 is `self`
    /// bit for bit; t = 1 is `other` with its axes so matched (bit for bit `other` when they
    /// already are: a permuted or negated axis is the same texture, its channel's noise aside).
    ///
    /// Two textures fitted at different sample sizes (the paper morphs equal ones) differ in
    /// their finest bands: the smaller sample has no power there, as it renders, so its missing
    /// weights are zeros and in-between sets have the larger count (and sample size). Curves of
    /// different knot counts are interpolated after the one with fewer knots is resampled at
    /// the other's (quantile interpolation still); curves on different abscissae are an error.
    pub fn morph(&self, other: &Procedural, t: f64) -> Result<Procedural, NoiseError> {
        if (self.colour == ColourMode::Pca) != (other.colour == ColourMode::Pca) {
            return Err(NoiseError::Morph("one texture is in PCA colour, the other in RGB".into()));
        }
        if t == 0.0 {
            return Ok(self.clone());
        }
        let (mean, u, order) = if self.colour == ColourMode::Pca {
            let a = Pca { mean: self.mean, u: self.u, eigenvalues: [1.0; 3], flipped: [false; 3] };
            let b = Pca { mean: other.mean, u: other.u, eigenvalues: [1.0; 3], flipped: [false; 3] };
            let (m, order) = a.morph(&b, t);
            (m.mean, m.u, order)
        } else {
            let mean = std::array::from_fn(|c| lerp(self.mean[c], other.mean[c], t));
            (mean, self.u, [(0, false), (1, false), (2, false)])
        };
        let bands = self.channels[0].weights.len().max(other.channels[0].weights.len());
        let weight = |w: &[f64], k: usize| w.get(k).copied().unwrap_or(0.0);
        let mut channels = Vec::with_capacity(3);
        for (c, &(j, negate)) in order.iter().enumerate() {
            let (a, b) = (&self.channels[c], &other.channels[j]);
            let weights = if t == 1.0 {
                b.weights.clone()
            } else {
                (0..bands).map(|k| lerp(weight(&a.weights, k), weight(&b.weights, k), t)).collect()
            };
            let b_curve = b.curve.as_ref().map(|k| if negate { k.negated() } else { k.clone() });
            let curve = match (&a.curve, &b_curve) {
                (None, None) => None,
                (Some(_), Some(y)) if t == 1.0 => Some(y.clone()),
                (Some(x), Some(y)) if x.abscissa != y.abscissa => {
                    return Err(NoiseError::Morph(format!(
                        "one texture's curves are on the {:?} abscissa, the other's on the {:?}",
                        x.abscissa, y.abscissa
                    )))
                }
                (Some(x), Some(y)) => {
                    let k = x.knots.len().max(y.knots.len());
                    let (x, y) = (x.resampled(k), y.resampled(k));
                    Some(x.lerp(&y, t)?)
                }
                _ => return Err(NoiseError::Morph("one texture has a histogram curve, the other none".into())),
            };
            channels.push(Channel { weights, curve });
        }
        let channels: [Channel; 3] = channels.try_into().map_err(|_| NoiseError::Morph("three channels".into()))?;
        let sample_size =
            if t == 1.0 || other.sample_size > self.sample_size { other.sample_size } else { self.sample_size };
        Ok(Procedural { mean, u, channels, sample_size, ..self.clone() })
    }
}

fn lerp(a: f64, b: f64, t: f64) -> f64 {
    if t == 1.0 {
        b
    } else {
        a + (b - a) * t
    }
}
