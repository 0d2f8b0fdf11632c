//! Generator synthesis ([references: frasson §3.5.3]): trivial synthesis (perturb / swap the original
//! ellipses) and statistical synthesis stage 1 (sample `N'` ellipses, then relax them with
//! [`crate::synth::structure::relaxation::lloyd::lloyd`]).
//!
//! Statistical synthesis:
//!
//! * `N' = round(A' / (s²·r̄))` with `A'` the allowed area (pixels not forbidden by the
//!   occupancy map), `s` the linear scale and `r̄` the mean original region area. With a size
//!   map, `A'` is the size-weighted area `Σ_allowed area_weight(p)` (`1/k(p)²` in `scale`
//!   mode: each region is `k²` times smaller where the map is dark, so more of them are
//!   needed; without this, Lloyd would only shuffle the same count of regions around).
//! * shapes `(a, b, θ)` come from a [`ShapeSampler`]: any closure
//!   `FnMut(&mut Rng) -> (a, b, θ)` (e.g. the analysis histograms), [`Independent`] axes and
//!   angle samplers (the thesis's default, [references: frasson §3.4]), or the [`EmpiricalSampler`] over example
//!   ellipses (independent or joint bootstrap). Axes are multiplied by `s`.
//! * centres: [`CenterSource::Uniform`] over allowed pixels, [`CenterSource::Density`]
//!   proportional to the density-map weight (uniform without a map; the default), or
//!   [`CenterSource::Histogram`] (a sampler in sample coordinates whose bounding box is mapped
//!   onto the target). With a size map, placement is also weighted by the area weight.
//! * occupancy: centres are only placed in allowed pixels (`RemoveMode::Center`); with
//!   `RemoveMode::AnyOverlap` an ellipse overlapping the forbidden area is re-placed up to
//!   `max_retries` times and then dropped (counted in `dropped`).
//!
//! Random draws per generator, in order: the centre (two draws for the pixel search and
//! sub-pixel offset, more on retries), then the shape sampler.

use serde::{Deserialize, Serialize};

use crate::synth::rng::Rng;
use crate::synth::structure::relaxation::controls::{
    allowed_area, allowed_from_occupancy, area_weight, density_weight, ellipse_overlaps_forbidden, point_allowed,
    Controls, RemoveMode,
};
use crate::synth::structure::relaxation::metric::canonical;
use crate::synth::structure::types::{Ellipse, Point};

/// Draws one region shape `(a, b, θ)` (semi-axes, angle; any order of `a`, `b` is accepted
/// and canonicalised).
pub trait ShapeSampler {
    fn sample(&mut self, rng: &mut Rng) -> (f64, f64, f64);
}

impl<F: FnMut(&mut Rng) -> (f64, f64, f64)> ShapeSampler for F {
    fn sample(&mut self, rng: &mut Rng) -> (f64, f64, f64) {
        self(rng)
    }
}

/// Axes and angle drawn independently (the thesis's assumption): `axes` then `angle`.
pub struct Independent<A, T> {
    pub axes: A,
    pub angle: T,
}

impl<A: FnMut(&mut Rng) -> (f64, f64), T: FnMut(&mut Rng) -> f64> ShapeSampler for Independent<A, T> {
    fn sample(&mut self, rng: &mut Rng) -> (f64, f64, f64) {
        let (a, b) = (self.axes)(rng);
        (a, b, (self.angle)(rng))
    }
}

/// How shapes are drawn from examples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShapeSampling {
    /// `(a, b)` of one random example, `θ` of another (thesis, [references: frasson §3.4]).
    #[default]
    Independent,
    /// A whole `(a, b, θ)` triple of one example (bootstrap, tessera's choice, [references: frasson §3.5.4]).
    Joint,
}

/// Bootstrap sampler over example ellipses (a simple stand-in for the histogram sampler).
#[derive(Clone, Debug)]
pub struct EmpiricalSampler {
    examples: Vec<Ellipse>,
    pub mode: ShapeSampling,
    /// Full widths of a uniform jitter added to `a`, `b`, `θ` (`±width/2`).
    pub jitter: [f64; 3],
}

impl EmpiricalSampler {
    pub fn new(examples: &[Ellipse], mode: ShapeSampling) -> Self {
        assert!(!examples.is_empty(), "no example ellipses");
        EmpiricalSampler { examples: examples.to_vec(), mode, jitter: [0.0; 3] }
    }

    pub fn with_jitter(mut self, jitter: [f64; 3]) -> Self {
        self.jitter = jitter;
        self
    }
}

impl ShapeSampler for EmpiricalSampler {
    /// Draws: example index (1, or 2 when independent), then three jitter draws if any jitter
    /// width is non-zero.
    fn sample(&mut self, rng: &mut Rng) -> (f64, f64, f64) {
        let i = rng.below(self.examples.len());
        let e = self.examples[i];
        let theta = match self.mode {
            ShapeSampling::Joint => e.theta,
            ShapeSampling::Independent => self.examples[rng.below(self.examples.len())].theta,
        };
        let (mut a, mut b, mut t) = (e.a, e.b, theta);
        if self.jitter != [0.0; 3] {
            a += (rng.next_f64() - 0.5) * self.jitter[0];
            b += (rng.next_f64() - 0.5) * self.jitter[1];
            t += (rng.next_f64() - 0.5) * self.jitter[2];
        }
        (a.max(1e-3), b.max(1e-3), t)
    }
}

/// Where generator centres are placed.
pub enum CenterSource<'a> {
    /// Uniform over allowed pixels.
    Uniform,
    /// Proportional to the density-map weight (uniform without a density map).
    Density,
    /// A centre sampler in sample coordinates (e.g. the analysis's centre histogram) and the
    /// bounding box `[min, max]` of the sample; the box is mapped onto the target. Samples in
    /// forbidden pixels are redrawn (up to 64 times, then a density-weighted draw is used).
    Histogram { sampler: &'a mut dyn FnMut(&mut Rng) -> Point, bbox: [Point; 2] },
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct StatisticalParams {
    /// Linear scale `s` (smaller = more, smaller regions).
    pub scale: f64,
    /// Mean original region area `r̄` (pixels, at scale 1).
    pub mean_area: f64,
    pub remove: RemoveMode,
    /// Re-placements of an ellipse overlapping the forbidden area (`AnyOverlap` only).
    pub max_retries: usize,
    /// Most generators the caller can hold (its memory budget); fewer than one region per
    /// allowed pixel is enforced regardless.
    pub max_regions: usize,
}

impl StatisticalParams {
    pub fn new(mean_area: f64) -> Self {
        StatisticalParams {
            scale: 1.0,
            mean_area,
            remove: RemoveMode::Center,
            max_retries: 32,
            max_regions: usize::MAX,
        }
    }
}

/// Why [`statistical`] refused to sample: `N'` is not a count the label raster or the
/// caller's memory can hold. Decided before anything is allocated.
#[derive(Clone, Debug, PartialEq)]
pub struct TooManyRegions {
    /// `N'` as computed (may be infinite or NaN).
    pub count: f64,
    /// `N'` without the size map: above `limit` too means `scale` alone is at fault.
    pub unsized_count: f64,
    /// The mean region area `s²·r̄`, in px².
    pub region_area: f64,
    /// Allowed pixels of the target.
    pub pixels: usize,
    /// The bound `N'` broke: the allowed pixels or `max_regions`, whichever is smaller.
    pub limit: usize,
}

/// Sampled generators, ready for Lloyd.
#[derive(Clone, Debug, PartialEq)]
pub struct Synthesized {
    pub generators: Vec<Ellipse>,
    pub frozen: Vec<bool>,
    /// `N'`.
    pub target_count: usize,
    /// Ellipses dropped by the occupancy test (`AnyOverlap`).
    pub dropped: usize,
}

/// `N' = round(A' / (s²·r̄))`.
pub fn region_count(allowed_area: f64, scale: f64, mean_area: f64) -> usize {
    assert!(scale > 0.0 && mean_area > 0.0, "scale and mean area must be positive");
    (allowed_area / (scale * scale * mean_area)).round() as usize
}

/// Mean area `r̄` of the given regions.
pub fn mean_area(areas: &[f64]) -> f64 {
    areas.iter().sum::<f64>() / areas.len() as f64
}

/// The area `A'` used for `N'`: allowed pixels, each counted by its [`area_weight`] with a
/// size map (`region_area`: the mean region area `s²·r̄` without one).
pub fn effective_area(width: usize, height: usize, controls: &Controls, region_area: f64) -> f64 {
    let allowed = controls.allowed();
    let mut total = 0.0;
    for y in 0..height {
        for x in 0..width {
            let i = y * width + x;
            if allowed.as_ref().is_some_and(|a| !a[i]) {
                continue;
            }
            total += match controls.size {
                Some(s) => {
                    area_weight(s, width, height, controls.size_mode, [x as f64 + 0.5, y as f64 + 0.5], region_area)
                }
                None => 1.0,
            };
        }
    }
    total
}

/// Samples pixels proportionally to per-pixel weights (prefix sums, binary search).
struct PixelSampler {
    cumulative: Vec<f64>,
    width: usize,
}

impl PixelSampler {
    fn new(weights: impl Iterator<Item = f64>, width: usize) -> Self {
        let mut acc = 0.0;
        let cumulative = weights
            .map(|w| {
                acc += w.max(0.0);
                acc
            })
            .collect();
        PixelSampler { cumulative, width }
    }

    fn total(&self) -> f64 {
        self.cumulative.last().copied().unwrap_or(0.0)
    }

    /// Two draws: the pixel, then one 64-bit value split into two 26-bit sub-pixel offsets.
    fn sample(&self, rng: &mut Rng) -> Point {
        let u = rng.next_f64() * self.total();
        let i = self.cumulative.partition_point(|&c| c <= u).min(self.cumulative.len() - 1);
        let r = rng.next_u64();
        let ox = (r >> 38) as f64 / (1u64 << 26) as f64;
        let oy = ((r >> 12) & ((1 << 26) - 1)) as f64 / (1u64 << 26) as f64;
        [(i % self.width) as f64 + ox, (i / self.width) as f64 + oy]
    }
}

/// Statistical synthesis stage 1, sampling: `N'` generators with shapes from `shapes` and
/// centres from `centers`. Relax the result with [`crate::synth::structure::relaxation::lloyd::lloyd`].
pub fn statistical(
    width: usize,
    height: usize,
    controls: &Controls,
    shapes: &mut dyn ShapeSampler,
    centers: CenterSource,
    params: &StatisticalParams,
    rng: &mut Rng,
) -> Result<Synthesized, TooManyRegions> {
    controls.check(width, height);
    let allowed = controls.allowed();
    let region_area = params.scale * params.scale * params.mean_area;
    let area = effective_area(width, height, controls, region_area);
    // A region smaller than a pixel cannot be a label of the raster, so `N'` above the
    // allowed pixel count (a tiny `scale`, a size map shrinking regions to nothing) is
    // refused here, before the generator list or the sampler's loop is sized by it.
    let allowed_pixels = allowed_area(allowed.as_deref(), width, height);
    let count = area / region_area;
    let limit = allowed_pixels.min(params.max_regions);
    if !(region_area > 0.0 && count <= limit as f64) {
        return Err(TooManyRegions {
            count,
            unsized_count: allowed_pixels as f64 / region_area,
            region_area,
            pixels: allowed_pixels,
            limit,
        });
    }
    let target = region_count(area, params.scale, params.mean_area);
    let use_density = !matches!(centers, CenterSource::Uniform);
    let weights = (0..width * height).map(|i| {
        if allowed.as_ref().is_some_and(|a| !a[i]) {
            return 0.0;
        }
        let p = [(i % width) as f64 + 0.5, (i / width) as f64 + 0.5];
        let mut w = 1.0;
        if use_density {
            if let Some(d) = controls.density {
                w *= density_weight(d[i], &controls.density_params) as f64;
            }
        }
        if let Some(s) = controls.size {
            w *= area_weight(s, width, height, controls.size_mode, p, region_area);
        }
        w
    });
    let pixels = PixelSampler::new(weights, width);
    let mut out =
        Synthesized { generators: Vec::with_capacity(target), frozen: Vec::new(), target_count: target, dropped: 0 };
    if pixels.total() <= 0.0 {
        out.dropped = target;
        return Ok(out);
    }
    let mut centers = centers;
    let mut place = |rng: &mut Rng| -> Point {
        if let CenterSource::Histogram { sampler, bbox } = &mut centers {
            for _ in 0..64 {
                let q = sampler(rng);
                let sx = (bbox[1][0] - bbox[0][0]).max(1e-12);
                let sy = (bbox[1][1] - bbox[0][1]).max(1e-12);
                let p = [(q[0] - bbox[0][0]) / sx * width as f64, (q[1] - bbox[0][1]) / sy * height as f64];
                if point_allowed(allowed.as_deref(), width, height, p) {
                    return p;
                }
            }
        }
        pixels.sample(rng)
    };
    for _ in 0..target {
        let mut center = place(rng);
        let (a, b, t) = shapes.sample(rng);
        let mut e = canonical(Ellipse { center, a: a * params.scale, b: b * params.scale, theta: t });
        if params.remove == RemoveMode::AnyOverlap {
            if let Some(al) = &allowed {
                let mut tries = 0;
                while ellipse_overlaps_forbidden(&e, width, height, al) && tries < params.max_retries {
                    center = place(rng);
                    e.center = center;
                    tries += 1;
                }
                if ellipse_overlaps_forbidden(&e, width, height, al) {
                    out.dropped += 1;
                    continue;
                }
            }
        }
        out.generators.push(e);
    }
    out.frozen = vec![false; out.generators.len()];
    Ok(out)
}

/// Trivial synthesis: Gaussian noise on the centres (`σ` px) and angles (`σ` rad).
pub fn perturb(originals: &[Ellipse], center_sigma: f64, theta_sigma: f64, rng: &mut Rng) -> Vec<Ellipse> {
    originals
        .iter()
        .map(|e| {
            let dx = rng.normal() * center_sigma;
            let dy = rng.normal() * center_sigma;
            let dt = rng.normal() * theta_sigma;
            canonical(Ellipse { center: [e.center[0] + dx, e.center[1] + dy], theta: e.theta + dt, ..*e })
        })
        .collect()
}

/// Trivial synthesis: `swaps` random swaps of two regions' shapes `(a, b, θ)` (the centres
/// stay; equivalently the two regions trade places).
pub fn swap_regions(originals: &[Ellipse], swaps: usize, rng: &mut Rng) -> Vec<Ellipse> {
    let mut out = originals.to_vec();
    if out.len() < 2 {
        return out;
    }
    for _ in 0..swaps {
        let i = rng.below(out.len());
        let j = rng.below(out.len());
        let (ci, cj) = (out[i].center, out[j].center);
        out.swap(i, j);
        out[i].center = ci;
        out[j].center = cj;
    }
    out
}

/// Removes ellipses whose centre is forbidden (occupancy operation 1, `Center` mode) from a
/// generator list; returns the kept list and the removed count. Convenience for trivial
/// synthesis under an occupancy map.
pub fn drop_forbidden(
    ellipses: &[Ellipse],
    width: usize,
    height: usize,
    occupancy: &[f32],
    mode: RemoveMode,
) -> (Vec<Ellipse>, usize) {
    let allowed = allowed_from_occupancy(occupancy);
    let removed =
        crate::synth::structure::relaxation::controls::remove_forbidden(ellipses, width, height, &allowed, mode);
    let kept: Vec<Ellipse> =
        ellipses.iter().enumerate().filter(|(i, _)| removed.binary_search(i).is_err()).map(|(_, e)| *e).collect();
    (kept, removed.len())
}

#[cfg(test)]
mod tests;
