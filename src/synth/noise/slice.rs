//! Correcting a planar slice of the solid texture [references: lagae §7]: a slice of a 3-D
//! band is not confined to its octave (for an ideal cube-shell spectrum about 1/7 of its power
//! falls into the two octaves below), so with the 2-D weights a slice is darker in its finest
//! band and brighter where a strong band sits above a weak one. `correct_slice` refits the
//! solid weights by non-negative least squares so that a slice's band powers, through the
//! simulated slice leakage matrix, match the powers the 2-D texture has through its own.
//!
//! The target is the 2-D texture's modelled powers `K₂·w²`, not a sample's measurement, so a
//! hand-edited parameter file and band gains are corrected as they are.

use super::eval::Noise;
use super::params::Procedural;
use super::spectrum;
use super::NoiseError;
use crate::synth::rng::{derive_seed, Rng};
use rayon::prelude::*;

/// How many random slices (and 2-D renders) each column of the matrices averages.
const SEEDS: usize = 4;

/// The largest side the matrices are simulated at (8 bands). A texture with more bands (a fit
/// of a larger sample, or bands extrapolated past it) corrects its first eight, and each band
/// beyond keeps the factor of the last corrected one: the leakage pattern is the same octave
/// after octave.
pub const MAX_SIDE: usize = 512;

/// The smallest side the band powers are measured at (two bands).
const MIN_SIDE: usize = 16;

/// The leakage matrices of one noise and one slice, per channel: `flat[c][i][j]` the power
/// channel `c`'s 2-D band `j + 2` of unit weight puts in annulus `i + 2`, `slice[c][i][j]` the
/// same for its solid band on the slice.
#[derive(Clone, Debug, PartialEq)]
pub struct SliceCorrection {
    flat: [Matrix; 3],
    slice: [Matrix; 3],
}

/// Rows by annulus, columns by band.
type Matrix = Vec<Vec<f64>>;

/// `size²` pixels of 1/`size` sample widths of band `band`, read by `at(x, y)` in lattice units
/// with the lattice shifted by `shift`.
fn render_band_with(band: u32, size: usize, shift: [f64; 2], at: impl Fn(f64, f64) -> f64 + Sync) -> Vec<f64> {
    let scale = f64::from(band).exp2();
    let side = size as f64;
    let mut out = vec![0.0; size * size];
    out.par_chunks_mut(size).enumerate().for_each(|(j, row)| {
        let y = scale * (j as f64 + 0.5) / side + shift[1];
        for (i, v) in row.iter_mut().enumerate() {
            *v = at(scale * (i as f64 + 0.5) / side + shift[0], y);
        }
    });
    out
}

impl SliceCorrection {
    /// The matrices for the first `bands` bands of `noise` (which must hold a solid tile) and
    /// the slice through `origin` (sample widths) parallel to the x–y plane, simulated at
    /// 2^(bands + 1) pixels a side (clamped to 16..=[`MAX_SIDE`]).
    ///
    /// Each render is placed where the texture's own render puts that band, up to a whole
    /// number of lattice cells drawn from `seed`: a slice parallel to the lattice meets a band
    /// at one depth within its cells, and a render of one pixel per cell meets it at one
    /// fraction across them; the quadratic B-spline's variance depends on that fraction (by
    /// more than a decibel), so random fractions would predict another texture's powers.
    pub fn new(noise: &Noise, bands: usize, origin: [f64; 3], seed: u64) -> Result<SliceCorrection, NoiseError> {
        let (flat_tile, solid) = noise.tiles();
        let Some(solid) = solid else {
            return Err(NoiseError::Options("a slice correction needs the solid tile".into()));
        };
        let side = 1usize << (bands.saturating_add(1)).clamp(MIN_SIDE.ilog2() as usize, MAX_SIDE.ilog2() as usize);
        // Band `band` of channel `c` where the render puts it, `s` whole cells along (a
        // different part of the tile for each of the averaged renders).
        let place = |what: &str, c: usize, band: u32, s: usize, n: usize| {
            let k = band as usize - 2;
            let o = noise.offset(c, k).unwrap_or([0.0; 3]);
            let scale = Noise::band_scale(k);
            let mut rng = Rng::new(derive_seed(seed, "noise", &format!("slice leakage {what} {c} {band} {s}")));
            let mut cells = || rng.below(n.max(1)) as f64;
            ([scale * origin[0] + o[0] + cells(), scale * origin[1] + o[1] + cells()], scale * origin[2] + o[2])
        };
        let matrices = |c: usize| -> Result<(Matrix, Matrix), NoiseError> {
            let flat = spectrum::leakage_matrix(side, SEEDS, |band, s| {
                let (shift, _) = place("flat", c, band, s, flat_tile.n);
                render_band_with(band, side, shift, |x, y| flat_tile.eval2(x, y))
            })?;
            let slice = spectrum::leakage_matrix(side, SEEDS, |band, s| {
                let (shift, z) = place("slice", c, band, s, solid.n);
                render_band_with(band, side, shift, |x, y| solid.eval3(x, y, z))
            })?;
            Ok((flat, slice))
        };
        let first = matrices(0)?;
        // Channels that share their offsets share their matrices.
        let same = |c: usize| (0..bands).all(|k| noise.offset(c, k) == noise.offset(0, k));
        let second = if same(1) { first.clone() } else { matrices(1)? };
        let third = if same(2) { first.clone() } else { matrices(2)? };
        Ok(SliceCorrection { flat: [first.0, second.0, third.0], slice: [first.1, second.1, third.1] })
    }

    /// `p` with band gains `gains` applied (missing gains are 1) and every channel's weights
    /// corrected ([`SliceCorrection::correct`]).
    pub fn corrected(&self, p: &Procedural, gains: &[f64]) -> Result<Procedural, NoiseError> {
        let mut out = p.clone();
        for (c, channel) in out.channels.iter_mut().enumerate() {
            let gained: Vec<f64> =
                channel.weights.iter().enumerate().map(|(k, w)| w * gains.get(k).copied().unwrap_or(1.0)).collect();
            channel.weights = self.correct(c, &gained)?;
        }
        Ok(out)
    }

    /// Channel `c`'s solid weights whose slice has the band powers `weights` give the 2-D
    /// texture: the 2-D powers `K₂·w²`, then `w′² = NNLS(K_slice, K₂·w²)`. Bands beyond the
    /// matrices keep the factor `w′/w` of the last band they cover (1 where its weight is 0).
    pub fn correct(&self, c: usize, weights: &[f64]) -> Result<Vec<f64>, NoiseError> {
        let c = c.min(2);
        let covered = self.flat[c].len();
        let squared: Vec<f64> = (0..covered).map(|k| weights.get(k).map_or(0.0, |w| w * w)).collect();
        let target: Vec<f64> =
            self.flat[c].iter().map(|row| row.iter().zip(&squared).map(|(k, w2)| k * w2).sum()).collect();
        let solved = spectrum::nnls(&self.slice[c], &target)?;
        let mut out: Vec<f64> = solved.iter().take(weights.len()).map(|v| v.max(0.0).sqrt()).collect();
        if weights.len() > covered {
            let last = covered - 1;
            let factor = if weights[last] > 0.0 { out[last] / weights[last] } else { 1.0 };
            out.extend(weights[covered..].iter().map(|w| w * factor));
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::noise::colour::ColourMode;

    #[test]
    fn bands_past_the_matrices_keep_the_last_factor() {
        // Three bands simulate at 16² (three annuli); five weights keep the third's factor.
        let noise = Noise::new(4, 32, 3, ColourMode::RgbShared, true).unwrap();
        let k = SliceCorrection::new(&noise, 3, [0.0, 0.0, 0.3], 9).unwrap();
        assert_eq!(k.flat[0].len(), 3);
        assert_eq!(k.flat[1], k.flat[0], "shared offsets share their matrices");
        let w = [0.4, 0.6, 0.8, 0.5, 0.2];
        let out = k.correct(0, &w).unwrap();
        assert_eq!(out.len(), 5);
        let factor = out[2] / w[2];
        assert!(factor > 0.0 && factor.is_finite());
        assert_eq!(out[3], w[3] * factor);
        assert_eq!(out[4], w[4] * factor);
        assert_eq!(k.correct(0, &[0.4]).unwrap().len(), 1, "fewer weights than bands");
        assert_eq!(k, SliceCorrection::new(&noise, 3, [0.0, 0.0, 0.3], 9).unwrap(), "deterministic");
    }

    #[test]
    fn a_plane_noise_has_no_slice_to_correct() {
        let noise = Noise::new(4, 32, 3, ColourMode::RgbShared, false).unwrap();
        assert!(matches!(SliceCorrection::new(&noise, 3, [0.0; 3], 9), Err(NoiseError::Options(_))));
    }
}
