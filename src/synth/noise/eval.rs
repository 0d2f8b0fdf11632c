//! Evaluating a fitted procedural texture anywhere [references: lagae §7]: every point on its own
//! (random access: a window rendered alone is the same window of a larger render, bit for bit,
//! on any thread count), at any resolution (bands finer than a pixel's footprint are clamped
//! away, proposal 13, and a histogram curve is smoothed by the variance they took with them,
//! proposal 14, so minification keeps the mean colour), in 2-D or solid (3-D bands, sliced).
//!
//! Every tile is normalised to the band variance σ_N² = 0.265 the analysis assumes, 2-D or 3-D,
//! so weights fitted once drive any seed and the solid variant with the same contrast (tessera's
//! choice; the measured variance of a tile varies by a few percent with its seed).

use rayon::prelude::*;

use super::colour::ColourMode;
use super::marginal::Curve;
use super::params::Procedural;
use super::tile::{self, Tile};
use super::{NoiseError, SIGMA_N2};
use crate::raster::Image;
use crate::synth::rng::{derive_seed, Rng};

/// A tile generated from `seed` and scaled so its band variance is exactly [`SIGMA_N2`].
pub fn noise_tile(dim: usize, n: usize, seed: u64) -> Result<Tile, NoiseError> {
    Ok(tile::normalised(dim, n, seed, SIGMA_N2)?)
}

/// The noise itself: one shared tile (and its solid counterpart), and each channel's random
/// band offsets (one set for all channels in `rgb_shared`, which is what makes them correlate).
#[derive(Clone, Debug)]
pub struct Noise {
    tile: Tile,
    solid: Option<Tile>,
    /// `offsets[c][k]` of band `k + 2`, in lattice units.
    offsets: [Vec<[f64; 3]>; 3],
}

/// Default side of the solid tile (64³ f64 = 2 MiB).
pub const SOLID_TILE: usize = 64;

impl Noise {
    /// The noise of `seed` for `bands` bands (2..), 2-D tile side `tile`, with a solid tile too
    /// when `solid`.
    pub fn new(seed: u64, tile: usize, bands: usize, colour: ColourMode, solid: bool) -> Result<Noise, NoiseError> {
        let t = noise_tile(2, tile, derive_seed(seed, "noise", "tile"))?;
        let solid =
            if solid { Some(noise_tile(3, SOLID_TILE, derive_seed(seed, "noise", "solid tile"))?) } else { None };
        let offsets = std::array::from_fn(|c| {
            let c = if colour == ColourMode::RgbShared { 0 } else { c };
            let mut rng = Rng::new(derive_seed(seed, "noise", &format!("offsets {c}")));
            (0..bands).map(|_| std::array::from_fn(|_| rng.range(0.0, tile as f64))).collect()
        });
        Ok(Noise { tile: t, solid, offsets })
    }

    /// Whether solid evaluation is available.
    pub fn is_solid(&self) -> bool {
        self.solid.is_some()
    }
}

/// What a parameter set (with band gains applied) needs at each point.
#[derive(Clone, Debug, PartialEq)]
pub struct Look {
    mean: [f64; 3],
    u: [[f64; 3]; 3],
    weights: [Vec<f64>; 3],
    curves: [Option<Curve>; 3],
    /// Eq. 2 per channel, with the gains.
    sigma_m: [f64; 3],
}

impl Look {
    /// `gains[k]` multiplies band `k + 2`'s weight in every channel (missing gains are 1): the
    /// paper's Fig. 11(d) edit.
    pub fn new(p: &Procedural, gains: &[f64]) -> Look {
        let weights: [Vec<f64>; 3] = std::array::from_fn(|c| {
            p.channels[c].weights.iter().enumerate().map(|(k, w)| w * gains.get(k).copied().unwrap_or(1.0)).collect()
        });
        let sigma_m = std::array::from_fn(|c| (SIGMA_N2 * weights[c].iter().map(|w| w * w).sum::<f64>()).sqrt());
        Look { mean: p.mean, u: p.u, weights, curves: std::array::from_fn(|c| p.channels[c].curve.clone()), sigma_m }
    }

    pub fn bands(&self) -> usize {
        self.weights[0].len()
    }
}

/// Proposal 13: the weight factor of band `b` under a footprint of `footprint` sample widths:
/// 1 while a lattice cell of the band spans at least a pixel, fading to 0 over one octave.
pub fn alpha(band: u32, footprint: f64) -> f64 {
    if footprint.is_nan() || footprint <= 0.0 {
        return 1.0;
    }
    (-footprint.log2() - f64::from(band) + 1.0).clamp(0.0, 1.0)
}

impl Noise {
    /// The colour at `x` (sample widths), for a pixel of `footprint` sample widths.
    pub fn eval(&self, look: &Look, x: [f64; 2], footprint: f64) -> [f64; 3] {
        self.shade(look, footprint, |c, k, scale| {
            let o = self.offsets[c][k];
            self.tile.eval2(scale * x[0] + o[0], scale * x[1] + o[1])
        })
    }

    /// The solid texture at `p` (sample widths); the plain 2-D texture when built without a
    /// solid tile.
    pub fn eval_solid(&self, look: &Look, p: [f64; 3], footprint: f64) -> [f64; 3] {
        let Some(solid) = &self.solid else { return self.eval(look, [p[0], p[1]], footprint) };
        self.shade(look, footprint, |c, k, scale| {
            let o = self.offsets[c][k];
            solid.eval3(scale * p[0] + o[0], scale * p[1] + o[1], scale * p[2] + o[2])
        })
    }

    /// Eq. 1 per channel (bands a footprint clamps away are not evaluated), the histogram
    /// back-mapping, then `U·v + mean`.
    #[inline]
    fn shade(&self, look: &Look, footprint: f64, band: impl Fn(usize, usize, f64) -> f64) -> [f64; 3] {
        let mut v = [0.0; 3];
        for (c, v) in v.iter_mut().enumerate() {
            let (mut g, mut dropped) = (0.0, 0.0);
            for (k, &w) in look.weights[c].iter().enumerate() {
                let b = k as u32 + 2;
                let a = alpha(b, footprint);
                dropped += (1.0 - a * a) * w * w;
                if a > 0.0 && w != 0.0 {
                    g += a * w * band(c, k, f64::from(1u32 << b.min(31)));
                }
            }
            *v = match &look.curves[c] {
                Some(curve) => curve.map_smoothed(g, look.sigma_m[c], (SIGMA_N2 * dropped).sqrt()),
                None => g,
            };
        }
        std::array::from_fn(|r| look.mean[r] + (0..3).map(|c| look.u[c][r] * v[c]).sum::<f64>())
    }
}

/// Where the pixels of a render lie, in sample widths.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub enum Domain {
    /// Pixel `(i, j)` at `origin + (i + ½, j + ½)·pixel`.
    Plane { origin: [f64; 2], pixel: f64 },
    /// A planar slice of the solid texture: pixel `(i, j)` at `origin + (i + ½)·pixel·u + (j + ½)·pixel·v`
    /// (`u`, `v` unit and orthogonal).
    Slice { origin: [f64; 3], u: [f64; 3], v: [f64; 3], pixel: f64 },
}

/// Most pixels one render makes (64 M: 768 MB of RGB f32).
pub const MAX_PIXELS: usize = 1 << 26;

/// Renders `width × height` pixels of the texture, each pixel by `look_at(i, j)`'s look (one
/// look everywhere, or a morph driven by a map). Rows in parallel; each pixel on its own.
pub fn render<'a>(
    noise: &Noise,
    width: usize,
    height: usize,
    domain: Domain,
    look_at: impl Fn(usize, usize) -> &'a Look + Sync,
) -> Result<Image, NoiseError> {
    if width.saturating_mul(height) > MAX_PIXELS {
        return Err(NoiseError::TooLarge { pixels: width.saturating_mul(height) as u64, limit: MAX_PIXELS as u64 });
    }
    let m = width * height;
    let mut rgb = vec![[0.0f32; 3]; m];
    rgb.par_chunks_mut(width.max(1)).enumerate().for_each(|(j, row)| {
        for (i, px) in row.iter_mut().enumerate() {
            let look = look_at(i, j);
            let (fi, fj) = (i as f64 + 0.5, j as f64 + 0.5);
            let c = match domain {
                Domain::Plane { origin, pixel } => {
                    noise.eval(look, [origin[0] + fi * pixel, origin[1] + fj * pixel], pixel)
                }
                Domain::Slice { origin, u, v, pixel } => {
                    let p = std::array::from_fn(|a| origin[a] + fi * pixel * u[a] + fj * pixel * v[a]);
                    noise.eval_solid(look, p, pixel)
                }
            };
            *px = c.map(|x| x as f32);
        }
    });
    let mut img = Image::new(width, height, 3);
    for c in 0..3 {
        for (d, px) in img.plane_mut(c).iter_mut().zip(&rgb) {
            *d = px[c];
        }
    }
    Ok(img)
}

/// How many steps a map-driven morph quantises `t` to (the looks are built once; `t` is off by
/// at most 1/512, and 0 and 1 are exact).
pub const MORPH_STEPS: usize = 256;

/// The looks of a morph from `a` to `b` at `t = k / MORPH_STEPS`.
pub fn morph_looks(a: &Procedural, b: &Procedural, gains: &[f64]) -> Result<Vec<Look>, NoiseError> {
    (0..=MORPH_STEPS).map(|k| Ok(Look::new(&a.morph(b, k as f64 / MORPH_STEPS as f64)?, gains))).collect()
}

/// The step of `t` (clamped into [0, 1]; NaN is 0).
pub fn morph_step(t: f32) -> usize {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    (f64::from(t) * MORPH_STEPS as f64).round() as usize
}
