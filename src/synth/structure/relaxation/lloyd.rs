//! Anisotropic discrete Lloyd relaxation ([references: frasson §3.5.2]) with the constraint-map hooks of
//! [references: frasson §3.7.2].
//!
//! Each iteration: (i) discrete anisotropic Voronoi of the generators (growth by default,
//! [`crate::synth::structure::relaxation::voronoi`]); (ii) per region, the density-weighted centroid of its pixels; the
//! generator moves there. Options:
//!
//! * `rotate`: θ becomes the angle of the region's fitted ellipse (unweighted pixel
//!   covariance, `θ = ½·atan2(2Σxy, Σxx − Σyy)`); the axis lengths are never changed.
//! * orientation map ([`Controls::orientation`]): overrides θ (region axial mean or centre
//!   sample); pixels with a zero vector impose nothing.
//! * size map ([`Controls::size`]): the Voronoi step uses the axes multiplied by
//!   `k(centre)`, re-evaluated every iteration; the generators keep their unscaled axes
//!   (so re-running Lloyd, e.g. after an edit, does not apply the map twice).
//! * occupancy ([`Controls::occupancy`]): forbidden pixels are never labelled, so never enter a
//!   centroid. A centroid that falls in a forbidden pixel (concave allowed area) is moved to
//!   the nearest pixel of its own region.
//! * frozen generators never move or rotate.
//! * `resolution < 1`: the iterations run on a raster scaled by `resolution` (maps resampled:
//!   density and orientation bilinearly, occupancy and metric by nearest pixel); the final
//!   labels are computed at full resolution from the final generators.
//!
//! Convergence: stop after the first iteration whose mean displacement of the non-frozen
//! generators (full-resolution pixels) is below `tol`, or after `max_iters` iterations.
//!
//! Determinism: the flood is exact whatever the thread count (its parallel parts write disjoint
//! pixels; see [`crate::synth::structure::relaxation::voronoi`]); centroid, covariance, orientation and energy sums are
//! integers (pixel coordinates doubled, weights quantised to `0..=65535`) added in any order,
//! and the energy is then evaluated per region in id order, so results are bit-identical for
//! any rayon thread count.
//!
//! A generator whose region is empty (an *orphan*: its seed pixel is forbidden or shared with a
//! lower id) stays where it is; the final orphans are reported and, with `drop_orphans`,
//! removed from the output.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::synth::structure::relaxation::controls::{
    density_weight, doubled_angle_field, orientation_at, point_allowed, quantize_weight, resample_bilinear,
    resample_nearest, size_factor, Controls, OrientationMode,
};
use crate::synth::structure::relaxation::metric::{wrap_axial, MetricKind};
use crate::synth::structure::relaxation::voronoi::{Domain, VoronoiMode, VoronoiParams, VoronoiWorkspace};
use crate::synth::structure::types::{Ellipse, Labels, NO_REGION};

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LloydParams {
    pub max_iters: usize,
    /// Mean displacement threshold, in full-resolution pixels.
    pub tol: f64,
    /// Fraction of the target resolution the iterations run at (`(0, 1]`).
    pub resolution: f64,
    pub rotate: bool,
    pub metric: MetricKind,
    pub mode: VoronoiMode,
    /// Remove the final orphans from the output (their input indices stay in `orphans`).
    pub drop_orphans: bool,
}

impl Default for LloydParams {
    fn default() -> Self {
        LloydParams {
            max_iters: 50,
            tol: 0.25,
            resolution: 1.0,
            rotate: false,
            metric: MetricKind::Elliptic,
            mode: VoronoiMode::Growth,
            drop_orphans: true,
        }
    }
}

/// Diagnostics of one iteration.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct IterationStats {
    /// Mean move of the non-frozen generators (full-resolution pixels).
    pub mean_displacement: f64,
    pub max_displacement: f64,
    /// `Σ w‖p − g‖²` of the partition at the start of the iteration, with `w ∈ (0, 1]` and
    /// positions in Lloyd-raster pixels.
    pub energy: f64,
    /// Generators with an empty region in this iteration.
    pub orphans: usize,
}

#[derive(Clone, Debug, PartialEq)]
pub struct LloydResult {
    /// The relaxed generators (unscaled axes; see the size map note).
    pub generators: Vec<Ellipse>,
    /// The generators as the final Voronoi step saw them (axes scaled by the size map).
    pub sized: Vec<Ellipse>,
    pub frozen: Vec<bool>,
    /// Input index of each output generator.
    pub source: Vec<usize>,
    /// Full-resolution labels; ids index `generators`.
    pub labels: Labels,
    /// Input indices of the generators with an empty final region.
    pub orphans: Vec<usize>,
    pub iterations: Vec<IterationStats>,
    pub converged: bool,
}

/// Integer region sums (coordinates doubled: `X = 2x + 1` is twice the pixel centre).
#[derive(Clone, Copy, Debug, Default)]
struct Acc {
    sw: u64,
    swx: u64,
    swy: u64,
    /// `Σ w·(X² + Y²)` (for the energy).
    swrr: u128,
    n: u64,
    sx: u64,
    sy: u64,
    sxx: u64,
    sxy: u64,
    syy: u64,
    oc: i64,
    os: i64,
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
}

impl Acc {
    fn empty() -> Self {
        Acc { x0: u32::MAX, y0: u32::MAX, ..Default::default() }
    }

    fn merge(&mut self, o: &Acc) {
        self.sw += o.sw;
        self.swx += o.swx;
        self.swy += o.swy;
        self.swrr += o.swrr;
        self.n += o.n;
        self.sx += o.sx;
        self.sy += o.sy;
        self.sxx += o.sxx;
        self.sxy += o.sxy;
        self.syy += o.syy;
        self.oc += o.oc;
        self.os += o.os;
        self.x0 = self.x0.min(o.x0);
        self.y0 = self.y0.min(o.y0);
        self.x1 = self.x1.max(o.x1);
        self.y1 = self.y1.max(o.y1);
    }

    /// Angle of the unweighted covariance's major axis, `None` if degenerate.
    fn covariance_angle(&self) -> Option<f64> {
        if self.n < 2 {
            return None;
        }
        let n = self.n as i128;
        // n²·Σ = n·ΣXX − (ΣX)², exact in i128 (the doubled-coordinate factor 4 cancels).
        let cxx = n * self.sxx as i128 - (self.sx as i128) * (self.sx as i128);
        let cyy = n * self.syy as i128 - (self.sy as i128) * (self.sy as i128);
        let cxy = n * self.sxy as i128 - (self.sx as i128) * (self.sy as i128);
        if cxy == 0 && cxx == cyy {
            return None;
        }
        Some(wrap_axial(0.5 * (2.0 * cxy as f64).atan2((cxx - cyy) as f64)))
    }
}

/// Scale of the orientation doubled-angle vectors before rounding to integers.
const ORIENT_Q: f32 = 32768.0;
/// Rows per accumulation chunk.
const CHUNK_ROWS: usize = 16;

/// Per-raster inputs of the iterations.
struct Grid {
    w: usize,
    allowed: Option<Vec<bool>>,
    weights: Option<Vec<u32>>,
    orient: Option<(Vec<i32>, Vec<i32>)>,
    metric: Option<Vec<MetricKind>>,
}

/// Runs anisotropic Lloyd on a `width × height` target.
///
/// `frozen[i] == true` pins generator `i` (position and angle). Generators keep their index;
/// see [`LloydResult::source`] when `drop_orphans` removes some.
pub fn lloyd(
    width: usize,
    height: usize,
    generators: &[Ellipse],
    frozen: Option<&[bool]>,
    controls: &Controls,
    params: &LloydParams,
) -> LloydResult {
    controls.check(width, height);
    assert!(params.resolution > 0.0 && params.resolution <= 1.0, "resolution must be in (0, 1]");
    let n = generators.len();
    let frozen: Vec<bool> = frozen.map_or_else(|| vec![false; n], |f| f.to_vec());
    assert_eq!(frozen.len(), n, "frozen flags");

    let full_allowed = controls.allowed();
    let lw = ((width as f64 * params.resolution).round() as usize).max(1);
    let lh = ((height as f64 * params.resolution).round() as usize).max(1);
    let sx = lw as f64 / width as f64;
    let sy = lh as f64 / height as f64;
    let grid = Grid {
        w: lw,
        allowed: full_allowed.as_ref().map(|a| resample_nearest(a, width, height, lw, lh)),
        weights: controls.density.map(|d| {
            resample_bilinear(d, width, height, lw, lh)
                .iter()
                .map(|&l| quantize_weight(density_weight(l, &controls.density_params)))
                .collect()
        }),
        orient: match (controls.orientation, controls.orientation_mode) {
            (Some(f), OrientationMode::Region) => {
                let (c2, s2) = doubled_angle_field(f, lw, lh);
                let q = |v: &Vec<f32>| v.iter().map(|&x| (x * ORIENT_Q).round() as i32).collect::<Vec<i32>>();
                Some((q(&c2), q(&s2)))
            }
            _ => None,
        },
        metric: controls.metric.map(|m| resample_nearest(m, width, height, lw, lh)),
    };

    let mut gens: Vec<Ellipse> = generators.to_vec();
    let mut ws = VoronoiWorkspace::default();
    let vparams = VoronoiParams { mode: params.mode, metric: params.metric };
    let mut iterations = Vec::new();
    let mut converged = false;

    // Effective ellipses (size map) in raster coordinates scaled by (fx, fy).
    let effective = |gens: &[Ellipse], fx: f64, fy: f64| -> Vec<Ellipse> {
        gens.iter()
            .map(|e| {
                let k = controls.size.map_or(1.0, |s| size_factor(s, width, height, controls.size_mode, e));
                Ellipse { center: [e.center[0] * fx, e.center[1] * fy], a: e.a * k, b: e.b * k, theta: e.theta }
            })
            .collect()
    };

    let mut had_region = vec![false; n];
    for _ in 0..params.max_iters {
        let eff = effective(&gens, sx, sy);
        let domain = Domain::new(lw, lh).with_allowed(grid.allowed.as_deref()).with_metric_map(grid.metric.as_deref());
        ws.run_ellipses(&domain, &eff, &vparams);
        let (accs, energy) = accumulate(&grid, ws.label_data(), &eff);
        let mut orphans = 0;
        let mut moved = 0usize;
        let mut sum_d = 0.0;
        let mut max_d: f64 = 0.0;
        for g in 0..n {
            let acc = &accs[g];
            if acc.n == 0 {
                orphans += 1;
            }
            had_region[g] = acc.n > 0;
            if frozen[g] {
                continue;
            }
            moved += 1;
            let old = gens[g];
            let mut e = old;
            if acc.sw > 0 {
                let mut c = [acc.swx as f64 / (2.0 * acc.sw as f64), acc.swy as f64 / (2.0 * acc.sw as f64)];
                if let Some(a) = &grid.allowed {
                    let (px, py) = (c[0].floor() as usize, c[1].floor() as usize);
                    if !a[py.min(lh - 1) * lw + px.min(lw - 1)] {
                        c = nearest_region_pixel(ws.label_data(), lw, acc, g as u32, c);
                    }
                }
                e.center = [c[0] / sx, c[1] / sy];
            }
            if acc.n > 0 {
                let forced = match (controls.orientation, controls.orientation_mode) {
                    (Some(_), OrientationMode::Region) => {
                        // Axial mean: halve the angle of the summed doubled-angle vectors.
                        (acc.oc != 0 || acc.os != 0).then(|| wrap_axial(0.5 * (acc.os as f64).atan2(acc.oc as f64)))
                    }
                    (Some(f), OrientationMode::Center) => orientation_at(f, e.center),
                    _ => None,
                };
                if let Some(t) = forced {
                    e.theta = t;
                } else if params.rotate {
                    if let Some(t) = acc.covariance_angle() {
                        e.theta = t;
                    }
                }
            }
            let d = (e.center[0] - old.center[0]).hypot(e.center[1] - old.center[1]);
            sum_d += d;
            max_d = max_d.max(d);
            gens[g] = e;
        }
        let mean = if moved > 0 { sum_d / moved as f64 } else { 0.0 };
        iterations.push(IterationStats { mean_displacement: mean, max_displacement: max_d, energy, orphans });
        controls.progress.report(iterations.len(), params.max_iters);
        if mean < params.tol {
            converged = true;
            break;
        }
    }

    // At reduced resolution a centroid can sit in an allowed coarse pixel whose full-resolution
    // pixel is forbidden: move such (moved, non-frozen) generators to the nearest allowed pixel.
    if let (Some(a), true) = (&full_allowed, lw != width || lh != height) {
        for g in 0..n {
            if had_region[g] && !frozen[g] && !point_allowed(Some(a), width, height, gens[g].center) {
                let radius = (2.0 / params.resolution).ceil() as usize + 1;
                if let Some(p) = nearest_allowed(a, width, height, gens[g].center, radius) {
                    gens[g].center = p;
                }
            }
        }
    }

    // Final labels at full resolution.
    let mut eff = effective(&gens, 1.0, 1.0);
    let domain = Domain::new(width, height).with_allowed(full_allowed.as_deref()).with_metric_map(controls.metric);
    let orphans = ws.run_ellipses(&domain, &eff, &vparams);
    let mut labels = ws.labels(&domain);
    let mut source: Vec<usize> = (0..n).collect();
    let mut out_frozen = frozen;
    if params.drop_orphans && !orphans.is_empty() {
        let mut remap = vec![NO_REGION; n];
        let mut kept = Vec::with_capacity(n);
        let mut is_orphan = vec![false; n];
        for &o in &orphans {
            is_orphan[o] = true;
        }
        for g in 0..n {
            if !is_orphan[g] {
                remap[g] = kept.len() as u32;
                kept.push(g);
            }
        }
        for l in &mut labels.data {
            if *l != NO_REGION {
                *l = remap[*l as usize];
            }
        }
        gens = kept.iter().map(|&g| gens[g]).collect();
        eff = kept.iter().map(|&g| eff[g]).collect();
        out_frozen = kept.iter().map(|&g| out_frozen[g]).collect();
        source = kept;
    }
    LloydResult { generators: gens, sized: eff, frozen: out_frozen, source, labels, orphans, iterations, converged }
}

/// Region sums and the energy of the current partition.
fn accumulate(grid: &Grid, labels: &[u32], eff: &[Ellipse]) -> (Vec<Acc>, f64) {
    let n = eff.len();
    let w = grid.w;
    let chunks: Vec<Vec<Acc>> = labels
        .par_chunks(CHUNK_ROWS * w)
        .enumerate()
        .map(|(ci, rows)| {
            let mut acc = vec![Acc::empty(); n];
            let y0 = ci * CHUNK_ROWS;
            for (ry, row) in rows.chunks(w).enumerate() {
                let y = y0 + ry;
                let yy = (2 * y + 1) as u64;
                for (x, &l) in row.iter().enumerate() {
                    if l == NO_REGION {
                        continue;
                    }
                    let i = y * w + x;
                    let xx = (2 * x + 1) as u64;
                    let wq = grid.weights.as_ref().map_or(1, |wt| wt[i]) as u64;
                    let a = &mut acc[l as usize];
                    a.sw += wq;
                    a.swx += wq * xx;
                    a.swy += wq * yy;
                    a.n += 1;
                    a.sx += xx;
                    a.sy += yy;
                    a.sxx += xx * xx;
                    a.sxy += xx * yy;
                    a.syy += yy * yy;
                    a.swrr += (wq * (xx * xx + yy * yy)) as u128;
                    if let Some((c2, s2)) = &grid.orient {
                        a.oc += c2[i] as i64;
                        a.os += s2[i] as i64;
                    }
                    a.x0 = a.x0.min(x as u32);
                    a.x1 = a.x1.max(x as u32);
                    a.y0 = a.y0.min(y as u32);
                    a.y1 = a.y1.max(y as u32);
                }
            }
            acc
        })
        .collect();
    let mut total = vec![Acc::empty(); n];
    for acc in &chunks {
        for (t, a) in total.iter_mut().zip(acc) {
            if a.n > 0 {
                t.merge(a);
            }
        }
    }
    // Energy from the exact integer moments, region by region in id order:
    // Σ w‖p − c‖² = ¼Σw(X² + Y²) − c·ΣwP + ‖c‖²Σw with P = (X, Y)/2.
    let scale = if grid.weights.is_some() { 1.0 / 65535.0 } else { 1.0 };
    let mut energy = 0.0;
    for (a, e) in total.iter().zip(eff) {
        if a.n == 0 {
            continue;
        }
        let c = e.center;
        let sum = 0.25 * a.swrr as f64 - c[0] * a.swx as f64 - c[1] * a.swy as f64
            + (c[0] * c[0] + c[1] * c[1]) * a.sw as f64;
        energy += scale * sum;
    }
    (total, energy)
}

/// The centre of the allowed pixel nearest to `c` within `radius` pixels (ties: lowest index).
fn nearest_allowed(allowed: &[bool], w: usize, h: usize, c: [f64; 2], radius: usize) -> Option<[f64; 2]> {
    let cx = (c[0].floor() as i64).clamp(0, w as i64 - 1);
    let cy = (c[1].floor() as i64).clamp(0, h as i64 - 1);
    let r = radius as i64;
    let mut best: Option<(f64, [f64; 2])> = None;
    for y in (cy - r).max(0)..=(cy + r).min(h as i64 - 1) {
        for x in (cx - r).max(0)..=(cx + r).min(w as i64 - 1) {
            if allowed[y as usize * w + x as usize] {
                let p = [x as f64 + 0.5, y as f64 + 0.5];
                let d = (p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2);
                if best.is_none_or(|b| d < b.0) {
                    best = Some((d, p));
                }
            }
        }
    }
    best.map(|b| b.1)
}

/// The centre of the pixel of region `g` nearest to `c` (ties: lowest pixel index).
fn nearest_region_pixel(labels: &[u32], w: usize, acc: &Acc, g: u32, c: [f64; 2]) -> [f64; 2] {
    let mut best = (f64::INFINITY, c);
    for y in acc.y0..=acc.y1 {
        for x in acc.x0..=acc.x1 {
            if labels[y as usize * w + x as usize] == g {
                let p = [x as f64 + 0.5, y as f64 + 0.5];
                let d = (p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2);
                if d < best.0 {
                    best = (d, p);
                }
            }
        }
    }
    best.1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::Image;
    use crate::synth::rng::Rng;
    use crate::synth::structure::fixtures::ellipses::*;

    fn run(w: usize, h: usize, gens: &[Ellipse], controls: &Controls, params: &LloydParams) -> LloydResult {
        lloyd(w, h, gens, None, controls, params)
    }

    /// F7: isotropic Euclidean case, energy non-increasing within 1e-3 relative.
    #[test]
    fn f7_isotropic_energy_non_increasing() {
        let (w, h) = (256, 256);
        let mut rng = Rng::new(71);
        let gens: Vec<Ellipse> = (0..80)
            .map(|_| Ellipse { center: [rng.range(0.0, 256.0), rng.range(0.0, 256.0)], a: 10.0, b: 10.0, theta: 0.0 })
            .collect();
        let params = LloydParams { max_iters: 40, tol: 0.0, ..Default::default() };
        let r = run(w, h, &gens, &Controls::default(), &params);
        let e: Vec<f64> = r.iterations.iter().map(|s| s.energy).collect();
        let worst = e.windows(2).map(|p| (p[1] - p[0]) / p[0]).fold(f64::NEG_INFINITY, f64::max);
        eprintln!(
            "F7 isotropic: E0 {:.4e} -> E{} {:.4e}, worst relative increase {worst:.2e}",
            e[0],
            e.len() - 1,
            e[e.len() - 1]
        );
        assert!(worst <= 1e-3, "energy increased by {worst}");
        assert!(e[e.len() - 1] < e[0]);
    }

    #[test]
    fn progress_counts_iterations_and_changes_nothing() {
        let (w, h) = (128, 96);
        let mut rng = Rng::new(75);
        let gens = random_ellipses(&mut rng, 30, w, h, 6.0, 14.0, 2.0);
        let params = LloydParams { max_iters: 12, tol: 0.0, ..Default::default() };
        let seen = std::sync::Mutex::new(Vec::new());
        let report = |done, total| seen.lock().unwrap().push((done, total));
        let controls = Controls { progress: crate::synth::Progress::new(&report), ..Default::default() };
        let with = run(w, h, &gens, &controls, &params);
        let without = run(w, h, &gens, &Controls::default(), &params);
        assert_eq!(with.labels.data, without.labels.data, "reporting changed the result");
        let seen = seen.into_inner().unwrap();
        assert_eq!(seen, (1..=12).map(|i| (i, 12)).collect::<Vec<_>>());
    }

    /// F7: anisotropic case converges (mean displacement < tol within max_iters) and the
    /// displacement at iteration 10 is < 20 % of iteration 1.
    #[test]
    fn f7_anisotropic_converges() {
        let (w, h) = (384, 320);
        for seed in [72, 73, 74] {
            let mut rng = Rng::new(seed);
            let gens = random_ellipses(&mut rng, 120, w, h, 8.0, 24.0, 2.5);
            let r = run(w, h, &gens, &Controls::default(), &LloydParams::default());
            let d: Vec<f64> = r.iterations.iter().map(|s| s.mean_displacement).collect();
            let ratio = d.get(9).copied().unwrap_or(0.0) / d[0];
            eprintln!(
                "F7 anisotropic seed {seed}: {} iterations, d1 {:.3}, d10/d1 {:.4}, converged {}",
                d.len(),
                d[0],
                ratio,
                r.converged
            );
            assert!(r.converged, "not converged: {d:?}");
            assert!(ratio < 0.2, "d10/d1 = {ratio}");
        }
    }

    /// F7: rotate = true keeps axis lengths bit-identical; only θ and the centre change.
    #[test]
    fn f7_rotate_keeps_axes() {
        let (w, h) = (256, 200);
        let mut rng = Rng::new(75);
        let gens = random_ellipses(&mut rng, 60, w, h, 8.0, 20.0, 2.5);
        let params = LloydParams { rotate: true, max_iters: 15, drop_orphans: false, ..Default::default() };
        let r = run(w, h, &gens, &Controls::default(), &params);
        let mut rotated = 0;
        for (a, b) in gens.iter().zip(&r.generators) {
            assert_eq!(a.a.to_bits(), b.a.to_bits());
            assert_eq!(a.b.to_bits(), b.b.to_bits());
            if a.theta != b.theta {
                rotated += 1;
            }
        }
        eprintln!("F7 rotate: {rotated}/{} angles changed, axes bit-identical", gens.len());
        assert!(rotated > gens.len() / 2);
    }

    /// F7: resolution = 0.5 keeps every region that has ≥ 50 px at half resolution.
    #[test]
    fn f7_half_resolution_keeps_regions() {
        let (w, h) = (512, 384);
        let mut rng = Rng::new(76);
        let n = 150; // ≈ 327 px per region at half resolution
        let gens = random_ellipses(&mut rng, n, w, h, 10.0, 30.0, 2.0);
        let params = LloydParams { resolution: 0.5, ..Default::default() };
        let r = run(w, h, &gens, &Controls::default(), &params);
        let sizes = crate::synth::structure::relaxation::voronoi::region_sizes(&r.labels, r.generators.len());
        let nonempty = sizes.iter().filter(|&&s| s > 0).count();
        let min_half = sizes.iter().map(|&s| s as f64 / 4.0).fold(f64::INFINITY, f64::min);
        eprintln!(
            "F7 resolution 0.5: {} of {n} regions survive ({} orphans), smallest {:.0} px at half res, {} iterations",
            nonempty,
            r.orphans.len(),
            min_half,
            r.iterations.len()
        );
        assert_eq!(nonempty + r.orphans.len(), n);
        // Every orphan would have had < 50 px; here none is expected at all.
        assert!(r.orphans.is_empty());
        assert!(r.converged);
    }

    /// F7: bit-identical results with 1, 2 and 8 rayon threads (all hooks on).
    #[test]
    fn f7_thread_count_invariance() {
        let (w, h) = (300, 220);
        let mut rng = Rng::new(77);
        let gens = random_ellipses(&mut rng, 70, w, h, 8.0, 22.0, 2.5);
        let density: Vec<f32> = (0..w * h).map(|i| ((i % w) as f32 / w as f32 * 6.0).sin() * 0.5 + 0.5).collect();
        let occupancy: Vec<f32> = (0..w * h)
            .map(|i| if (100..140).contains(&(i % w)) && (60..120).contains(&(i / w)) { 0.0 } else { 1.0 })
            .collect();
        let field = Image::from_fn(w, h, 2, |x, _, c| {
            let t = x as f32 / w as f32 * 1.5;
            if c == 0 {
                t.cos()
            } else {
                t.sin()
            }
        });
        let mut gens = gens;
        gens.retain(|e| {
            crate::synth::structure::relaxation::controls::point_allowed(
                Some(&crate::synth::structure::relaxation::controls::allowed_from_occupancy(&occupancy)),
                w,
                h,
                e.center,
            )
        });
        let mut results = Vec::new();
        for threads in [1, 2, 8] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            for (orient, rotate) in [(false, true), (true, false)] {
                let controls = Controls {
                    density: Some(&density),
                    occupancy: Some(&occupancy),
                    orientation: orient.then_some(&field),
                    ..Default::default()
                };
                let params = LloydParams { rotate, max_iters: 12, resolution: 0.75, ..Default::default() };
                let r = pool.install(|| run(w, h, &gens, &controls, &params));
                results.push((threads, orient, r));
            }
        }
        for (threads, orient, r) in &results[2..] {
            let base = &results[if *orient { 1 } else { 0 }].2;
            assert_eq!(base.labels, r.labels, "threads {threads}");
            let bits = |r: &LloydResult| {
                r.generators
                    .iter()
                    .flat_map(|e| [e.center[0], e.center[1], e.a, e.b, e.theta])
                    .map(f64::to_bits)
                    .collect::<Vec<_>>()
            };
            assert_eq!(bits(base), bits(r), "threads {threads}");
            let eb = |r: &LloydResult| r.iterations.iter().map(|s| s.energy.to_bits()).collect::<Vec<_>>();
            assert_eq!(eb(base), eb(r), "threads {threads}");
        }
    }

    /// Frozen generators have exactly zero displacement.
    #[test]
    fn frozen_generators_stay() {
        let (w, h) = (200, 200);
        let mut rng = Rng::new(78);
        let gens = random_ellipses(&mut rng, 40, w, h, 8.0, 20.0, 2.0);
        let frozen: Vec<bool> = (0..40).map(|i| i % 5 == 0).collect();
        let params = LloydParams { rotate: true, drop_orphans: false, ..Default::default() };
        let r = lloyd(w, h, &gens, Some(&frozen), &Controls::default(), &params);
        for i in (0..40).step_by(5) {
            assert_eq!(gens[i], r.generators[i]);
        }
        assert!(gens.iter().zip(&r.generators).filter(|(a, b)| a != b).count() >= 30);
    }
}
