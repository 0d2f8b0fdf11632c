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
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use super::colour::ColourMode;
use super::marginal::{Curve, CurveLut, CurveTable};
use super::params::Procedural;
use super::tile::{self, CollapsedRow, RowXs, Tile};
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

    /// The 2-D tile and the solid one.
    pub fn tiles(&self) -> (&Tile, Option<&Tile>) {
        (&self.tile, self.solid.as_ref())
    }

    /// Channel `c`'s offsets of band `k + 2`, in lattice units (None past its bands).
    pub fn offset(&self, c: usize, k: usize) -> Option<[f64; 3]> {
        self.offsets.get(c)?.get(k).copied()
    }

    /// Band `k + 2`'s lattice frequency, 2^(k+2) cells a sample width.
    pub fn band_scale(k: usize) -> f64 {
        band_scale(k)
    }
}

/// What a parameter set (with band gains applied) needs at each point.
#[derive(Clone, Debug, PartialEq)]
pub struct Look {
    mean: [f64; 3],
    u: [[f64; 3]; 3],
    weights: [Vec<f64>; 3],
    curves: [Option<Curve>; 3],
    /// Each curve's knot abscissae and slopes, worked out once.
    tables: [CurveTable; 3],
    /// Eq. 2 per channel, with the gains.
    sigma_m: [f64; 3],
    /// Whether the curves map through tables ([`CurveLut`]) or exactly. A table repays its
    /// points only over thousands of pixels; a morph's in-between looks each colour a sliver of
    /// the image, so they map exactly (fixed per look, so any window of a render gets the same
    /// bits).
    tabulate: bool,
    luts: Luts,
}

/// A channel's curve table under one σ_d, shared by the threads of a render.
type SharedLut = Arc<Option<CurveLut>>;

/// Each channel's [`CurveLut`]s by σ_d, built on first use. A table depends only on the curve and
/// the two σ, so when it is built cannot change a pixel; a clone starts empty and equality
/// ignores it.
#[derive(Debug, Default)]
struct Luts(Mutex<Vec<(usize, u64, SharedLut)>>);

impl Clone for Luts {
    fn clone(&self) -> Luts {
        Luts::default()
    }
}

impl PartialEq for Luts {
    fn eq(&self, _: &Luts) -> bool {
        true
    }
}

/// Most curve tables a look keeps (32 KiB each; a render needs one per channel).
const MAX_LUTS: usize = 48;

/// A thread's memo of the tables it has used (looks by address: they outlive the render), so
/// a pixel takes no lock.
#[derive(Default)]
struct LutMemo(HashMap<(usize, usize, u64), SharedLut>);

impl LutMemo {
    fn get(&mut self, look: &Look, c: usize, sigma_d: f64) -> &SharedLut {
        let key = (look as *const Look as usize, c, sigma_d.to_bits());
        self.0.entry(key).or_insert_with(|| look.lut(c, sigma_d))
    }
}

impl Look {
    /// `gains[k]` multiplies band `k + 2`'s weight in every channel (missing gains are 1): the
    /// paper's Fig. 11(d) edit.
    pub fn new(p: &Procedural, gains: &[f64]) -> Look {
        let weights: [Vec<f64>; 3] = std::array::from_fn(|c| {
            p.channels[c].weights.iter().enumerate().map(|(k, w)| w * gains.get(k).copied().unwrap_or(1.0)).collect()
        });
        let sigma_m = std::array::from_fn(|c| (SIGMA_N2 * weights[c].iter().map(|w| w * w).sum::<f64>()).sqrt());
        let curves: [Option<Curve>; 3] = std::array::from_fn(|c| p.channels[c].curve.clone());
        let tables = std::array::from_fn(|c| curves[c].as_ref().map_or_else(CurveTable::default, Curve::table));
        Look { mean: p.mean, u: p.u, weights, curves, tables, sigma_m, tabulate: true, luts: Luts::default() }
    }

    /// `U·v + mean`.
    #[inline]
    fn mix(&self, v: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|r| self.mean[r] + (0..3).map(|c| self.u[c][r] * v[c]).sum::<f64>())
    }

    pub fn bands(&self) -> usize {
        self.weights[0].len()
    }

    /// Channel `c`'s curve table under `sigma_d` (None without a curve, or where the curve
    /// takes none).
    fn lut(&self, c: usize, sigma_d: f64) -> SharedLut {
        if !self.tabulate {
            return Arc::new(None);
        }
        let bits = sigma_d.to_bits();
        // A poisoned lock only means another thread panicked mid-render; the list is still valid.
        let mut list = self.luts.0.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, _, lut)) = list.iter().find(|(at, b, _)| *at == c && *b == bits) {
            return lut.clone();
        }
        let (curve, sigma_m) = (self.curves[c].as_ref(), self.sigma_m[c]);
        if list.len() >= MAX_LUTS {
            // A caller sweeping the footprint would grow the list without end: past the cap, each
            // call works out the points it needs (the same numbers, more slowly).
            return Arc::new(curve.and_then(|k| k.lut_unkept(sigma_m, sigma_d)));
        }
        let lut = Arc::new(curve.and_then(|k| k.lut(sigma_m, sigma_d)));
        list.push((c, bits, lut.clone()));
        lut
    }

    /// The histogram back-mapping of channel `c` (identity without a curve), through `lut`.
    #[inline]
    fn map(&self, c: usize, g: f64, sigma_d: f64, lut: &Option<CurveLut>) -> f64 {
        match (&self.curves[c], lut) {
            (None, _) => g,
            (Some(curve), Some(lut)) => lut.map(curve, &self.tables[c], g),
            (Some(curve), None) => curve.map_smoothed_with(g, self.sigma_m[c], sigma_d, &self.tables[c]),
        }
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

/// Band `k + 2`'s lattice frequency, 2^(k+2) cells a sample width.
#[inline]
fn band_scale(k: usize) -> f64 {
    f64::from(1u32 << (k as u32 + 2).min(31))
}

/// [`alpha`] of every band `2..2 + bands` under one footprint (the same numbers for every
/// pixel of a render, so they are worked out once).
fn alphas(footprint: f64, bands: usize) -> Vec<f64> {
    (0..bands).map(|k| alpha(k as u32 + 2, footprint)).collect()
}

impl Noise {
    /// The colour at `x` (sample widths), for a pixel of `footprint` sample widths.
    pub fn eval(&self, look: &Look, x: [f64; 2], footprint: f64) -> [f64; 3] {
        self.eval_with(look, x, footprint, &alphas(footprint, look.bands()), &mut LutMemo::default())
    }

    fn eval_with(&self, look: &Look, x: [f64; 2], footprint: f64, alphas: &[f64], memo: &mut LutMemo) -> [f64; 3] {
        self.shade(look, footprint, alphas, memo, |c, k, scale| match self.offsets[c].get(k) {
            Some(o) => self.tile.eval2(scale * x[0] + o[0], scale * x[1] + o[1]),
            None => 0.0,
        })
    }

    /// The solid texture at `p` (sample widths); the plain 2-D texture when built without a
    /// solid tile.
    pub fn eval_solid(&self, look: &Look, p: [f64; 3], footprint: f64) -> [f64; 3] {
        self.eval_solid_with(look, p, footprint, &alphas(footprint, look.bands()), &mut LutMemo::default())
    }

    fn eval_solid_with(
        &self,
        look: &Look,
        p: [f64; 3],
        footprint: f64,
        alphas: &[f64],
        memo: &mut LutMemo,
    ) -> [f64; 3] {
        let Some(solid) = &self.solid else { return self.eval_with(look, [p[0], p[1]], footprint, alphas, memo) };
        self.shade(look, footprint, alphas, memo, |c, k, scale| match self.offsets[c].get(k) {
            Some(o) => solid.eval3(scale * p[0] + o[0], scale * p[1] + o[1], scale * p[2] + o[2]),
            None => 0.0,
        })
    }

    /// One row `j` of a plane render: each band's three tile rows are collapsed once for the
    /// whole row ([`Tile::collapse_row`]), leaving three taps a pixel instead of nine, and each
    /// band is evaluated along the row in a tight loop. Under one look for the whole row (no
    /// morph map) the weighted sum of eq. 1 runs band by band too. The numbers are those of
    /// [`Noise::eval`] bit for bit (the same operations in the same order), so a window
    /// rendered alone (by either path) equals the same window of a larger render.
    fn plane_row<'a>(
        &self,
        buf: &mut RowBuffers,
        row: [&mut [f32]; 3],
        j: usize,
        (origin, pixel): ([f64; 2], f64),
        alphas: &[f64],
        look_at: &impl Fn(usize, usize) -> &'a Look,
    ) {
        let (bands, width) = (self.offsets[0].len(), row[0].len());
        let y = origin[1] + (j as f64 + 0.5) * pixel;
        buf.live.clear();
        buf.live.resize(3 * bands, false);
        let active = |k: usize| alphas.get(k).is_some_and(|&a| a > 0.0);
        // Band k of channel c at this row's height (false where it reads nothing: zeros).
        let collapse = |c: usize, k: usize, collapsed: &mut CollapsedRow| {
            let [_, oy, _] = self.offsets[c][k];
            self.tile.collapse_row(band_scale(k) * y + oy, collapsed)
        };
        buf.xs.set((0..width).map(|i| origin[0] + (i as f64 + 0.5) * pixel));
        let along = |c: usize, k: usize| (band_scale(k), self.offsets[c][k][0]);
        let first = look_at(0, j);
        if (1..width).all(|i| std::ptr::eq(look_at(i, j), first)) {
            let look = first;
            buf.sums.resize(3 * width, 0.0);
            for c in 0..3 {
                let g = &mut buf.sums[c * width..][..width];
                g.fill(0.0);
                let mut dropped = 0.0;
                for (k, &w) in look.weights[c].iter().enumerate() {
                    let b = k as u32 + 2;
                    let a = alphas.get(k).copied().unwrap_or_else(|| alpha(b, pixel));
                    dropped += (1.0 - a * a) * w * w;
                    if a > 0.0 && w != 0.0 {
                        let aw = a * w;
                        if k < bands && active(k) && collapse(c, k, &mut buf.collapsed) {
                            let (scale, offset) = along(c, k);
                            buf.collapsed.accumulate_along(&buf.xs, scale, offset, aw, g);
                        } else {
                            for g in g.iter_mut() {
                                *g += aw * 0.0;
                            }
                        }
                    }
                }
                let sigma_d = (SIGMA_N2 * dropped).sqrt();
                // `Look::map`, its arm chosen once for the row.
                if let Some(curve) = &look.curves[c] {
                    let (table, sigma_m) = (&look.tables[c], look.sigma_m[c]);
                    match buf.memo.get(look, c, sigma_d).as_ref() {
                        Some(lut) => g.iter_mut().for_each(|g| *g = lut.map(curve, table, *g)),
                        None => g.iter_mut().for_each(|g| *g = curve.map_smoothed_with(*g, sigma_m, sigma_d, table)),
                    }
                }
            }
            let [r, g, b] = row;
            for (i, ((r, g), b)) in r.iter_mut().zip(g.iter_mut()).zip(b.iter_mut()).enumerate() {
                let v = [buf.sums[i], buf.sums[width + i], buf.sums[2 * width + i]];
                [*r, *g, *b] = look.mix(v).map(|x| x as f32);
            }
            return;
        }
        buf.values.resize(3 * bands * width, 0.0);
        for c in 0..3 {
            for k in (0..bands).filter(|&k| active(k)) {
                let at = c * bands + k;
                buf.live[at] = collapse(c, k, &mut buf.collapsed);
                if buf.live[at] {
                    let (scale, offset) = along(c, k);
                    buf.collapsed.along(&buf.xs, scale, offset, &mut buf.values[at * width..][..width]);
                }
            }
        }
        let [r, g, b] = row;
        for (i, ((r, g), b)) in r.iter_mut().zip(g.iter_mut()).zip(b.iter_mut()).enumerate() {
            let look = look_at(i, j);
            let colour = self.shade(look, pixel, alphas, &mut buf.memo, |c, k, _| {
                let at = c * bands + k;
                if k < bands && buf.live[at] {
                    buf.values[at * width + i]
                } else {
                    0.0
                }
            });
            [*r, *g, *b] = colour.map(|x| x as f32);
        }
    }

    /// Eq. 1 per channel (bands a footprint clamps away are not evaluated), the histogram
    /// back-mapping, then `U·v + mean`. `alphas[k]` is band `k + 2`'s [`alpha`] under
    /// `footprint`.
    #[inline]
    fn shade(
        &self,
        look: &Look,
        footprint: f64,
        alphas: &[f64],
        memo: &mut LutMemo,
        band: impl Fn(usize, usize, f64) -> f64,
    ) -> [f64; 3] {
        let mut v = [0.0; 3];
        for (c, v) in v.iter_mut().enumerate() {
            let (mut g, mut dropped) = (0.0, 0.0);
            for (k, &w) in look.weights[c].iter().enumerate() {
                let b = k as u32 + 2;
                let a = alphas.get(k).copied().unwrap_or_else(|| alpha(b, footprint));
                dropped += (1.0 - a * a) * w * w;
                if a > 0.0 && w != 0.0 {
                    g += a * w * band(c, k, band_scale(k));
                }
            }
            if look.curves[c].is_some() {
                let sigma_d = (SIGMA_N2 * dropped).sqrt();
                g = look.map(c, g, sigma_d, memo.get(look, c, sigma_d));
            }
            *v = g;
        }
        look.mix(v)
    }
}

/// A render thread's scratch rows, kept from row to row.
#[derive(Default)]
struct RowBuffers {
    memo: LutMemo,
    /// The row's pixel centres in sample widths (x only).
    xs: RowXs,
    collapsed: CollapsedRow,
    values: Vec<f64>,
    sums: Vec<f64>,
    live: Vec<bool>,
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
    let mut img = Image::new(width, height, 3);
    if width == 0 || height == 0 {
        return Ok(img);
    }
    let (r, rest) = img.data.split_at_mut(width * height);
    let (g, b) = rest.split_at_mut(width * height);
    let rows = r.par_chunks_mut(width).zip(g.par_chunks_mut(width)).zip(b.par_chunks_mut(width));
    let pixel = match domain {
        Domain::Plane { pixel, .. } | Domain::Slice { pixel, .. } => pixel,
    };
    let alphas = alphas(pixel, noise.offsets[0].len());
    // Collapsing a row's tile rows costs about n/4 pixels' worth of taps per band: narrow
    // windows evaluate point by point instead (the same numbers either way).
    let collapse = width >= noise.tile.n / 4;
    rows.enumerate().for_each_init(RowBuffers::default, |buf, (j, ((r, g), b))| match domain {
        Domain::Plane { origin, pixel } if collapse => {
            noise.plane_row(buf, [r, g, b], j, (origin, pixel), &alphas, &look_at)
        }
        _ => {
            for (i, ((r, g), b)) in r.iter_mut().zip(g.iter_mut()).zip(b.iter_mut()).enumerate() {
                let look = look_at(i, j);
                let (fi, fj) = (i as f64 + 0.5, j as f64 + 0.5);
                let c = match domain {
                    Domain::Plane { origin, pixel } => noise.eval_with(
                        look,
                        [origin[0] + fi * pixel, origin[1] + fj * pixel],
                        pixel,
                        &alphas,
                        &mut buf.memo,
                    ),
                    Domain::Slice { origin, u, v, pixel } => {
                        let p = std::array::from_fn(|a| origin[a] + fi * pixel * u[a] + fj * pixel * v[a]);
                        noise.eval_solid_with(look, p, pixel, &alphas, &mut buf.memo)
                    }
                };
                [*r, *g, *b] = c.map(|x| x as f32);
            }
        }
    });
    Ok(img)
}

/// How many steps a map-driven morph quantises `t` to (the looks are built once; `t` is off by
/// at most 1/512, and 0 and 1 are exact).
pub const MORPH_STEPS: usize = 256;

/// The looks of a morph from `a` to `b` at `t = k / MORPH_STEPS` (the in-between ones map
/// their curves exactly: see [`Look`]).
pub fn morph_looks(a: &Procedural, b: &Procedural, gains: &[f64]) -> Result<Vec<Look>, NoiseError> {
    (0..=MORPH_STEPS)
        .map(|k| {
            let look = Look::new(&a.morph(b, k as f64 / MORPH_STEPS as f64)?, gains);
            Ok(Look { tabulate: k == 0 || k == MORPH_STEPS, ..look })
        })
        .collect()
}

/// The step of `t` (clamped into [0, 1]; NaN is 0).
pub fn morph_step(t: f32) -> usize {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    (f64::from(t) * MORPH_STEPS as f64).round() as usize
}
