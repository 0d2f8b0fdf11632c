//! Candidate scoring: the error model, the per-block template, direct and FFT scoring, and the
//! deterministic selection rule.
//!
//! The error of candidate `q` (top-left corner in a source) for a block is
//!
//! ```text
//! E(q) = Σ_{p ∈ overlap} Σ_c ov_coef(p, c)·d(S_c(q + p) − X_c(p))
//!      + Σ_{p ∈ guided} Σ_i gd_coef(p, i)·d(S_{m(i)}(q + p) − G_i(p))
//! ```
//!
//! with `d = |·|` (SAD) or `(·)²` (SSD), `S` the equalised source, `X` the equalised output already
//! synthesised, `G` the equalised guide and the coefficients carrying the term weights, the channel
//! weights and the per-term normalisation (weighted means). The direct evaluation sums channel by
//! channel, pixel by pixel, in `f64`, in one fixed order: it defines "the" error.
//!
//! Bulk scoring is approximate but bounded. SSD scores every candidate at once by FFT correlation
//! (`f64`, norm-wise rounding bound); SAD sums every candidate in `f32` (rigorous relative bound,
//! all terms being non-negative). Only candidates that can be within the tolerance of the minimum
//! under the bound are re-scored directly, so the final choice never depends on bulk rounding (nor on
//! the CPU's FFT or SIMD code path).

use rayon::prelude::*;

use super::params::Metric;
use crate::raster::Image;
use crate::synth::fft::correlate::{self, Cx, Plan, Real};
use crate::synth::rng::Rng;

/// One source image that blocks are copied from: an input sample, possibly rotated.
pub(super) struct Source {
    pub sample: usize,
    pub angle: f32,
    /// Raw values (what the output receives).
    pub raw: Image,
    /// Equalised planes, `C × w × h`.
    pub work: Vec<f32>,
    /// Candidate grid: top-left positions `0..cw × 0..ch` (block fully inside).
    pub cw: usize,
    pub ch: usize,
    /// Allowed candidates (stride, user mask, rotation validity), as `qy * cw + qx`, ascending.
    pub allowed: Vec<u32>,
    pub allowed_mask: Vec<bool>,
    /// Per pixel, 1 to use it and 0 to ignore it (the mask layer); `None` uses every pixel.
    pub keep: Option<Vec<f32>>,
    /// Half spectra of the real planes `[S_0 … S_{C−1}, Q_o?, Q_g?]` (SSD only).
    pub spectra: Vec<Vec<Cx>>,
    /// L1 and L2 norms of each real plane (for the FFT rounding bound).
    pub norm1: Vec<f64>,
    pub norm2: Vec<f64>,
}

impl Source {
    pub fn w(&self) -> usize {
        self.raw.width
    }

    pub fn h(&self) -> usize {
        self.raw.height
    }

    pub fn is_allowed(&self, qx: usize, qy: usize) -> bool {
        qx < self.cw && qy < self.ch && self.allowed_mask[qy * self.cw + qx]
    }
}

/// The parts of the error model that stay fixed during one synthesis.
pub(super) struct Model {
    pub channels: usize,
    pub metric: Metric,
    /// Overlap weight per sample channel (O and D terms, with their normalisation over channels).
    pub mu_o: Vec<f64>,
    /// Guide weight per guide channel, and the sample channel each guide channel is compared with.
    pub mu_g: Vec<f64>,
    pub guide_map: Vec<usize>,
    /// Channel weights of the boundary-cut error (the non-depth channels).
    pub mu_cut: Vec<f64>,
    /// Sample channels with a non-zero overlap weight, and guide channels with a non-zero weight.
    pub active_o: Vec<usize>,
    pub active_g: Vec<usize>,
    /// Index of the `Q_o = Σ μ_o S²` real plane, if used.
    pub q_o: Option<usize>,
    /// Index of the `Q_g = Σ μ_g S²` real plane and its factor, if used: `Q_o`'s with the ratio
    /// `Q_g / Q_o` when the two are proportional (plain guided quilting: one plane less to
    /// correlate), else a plane of its own with factor 1.
    pub q_g: Option<(usize, f64)>,
}

impl Model {
    pub fn n_real(&self) -> usize {
        self.channels + usize::from(self.q_o.is_some()) + usize::from(self.q_g.is_some_and(|q| Some(q.0) != self.q_o))
    }

    #[inline]
    pub fn dist(&self, d: f64) -> f64 {
        match self.metric {
            Metric::Sad => d.abs(),
            Metric::Ssd => d * d,
        }
    }

    /// The real planes of a source (equalised channels, then the squared-sum planes).
    pub fn real_planes(&self, work: &[f32], plane: usize) -> Vec<Vec<Real>> {
        let mut planes: Vec<Vec<Real>> = (0..self.channels)
            .map(|c| work[c * plane..(c + 1) * plane].iter().map(|&v| Real::from(v)).collect())
            .collect();
        let squares = |mu: &[(usize, f64)]| {
            let mut q = vec![0.0; plane];
            for &(c, m) in mu {
                for (q, &v) in q.iter_mut().zip(&work[c * plane..(c + 1) * plane]) {
                    *q += m * f64::from(v) * f64::from(v);
                }
            }
            q
        };
        if self.q_o.is_some() {
            let mu: Vec<(usize, f64)> = self.active_o.iter().map(|&c| (c, self.mu_o[c])).collect();
            planes.push(squares(&mu));
        }
        if self.q_g.is_some_and(|q| Some(q.0) != self.q_o) {
            let mu: Vec<(usize, f64)> = self.active_g.iter().map(|&i| (self.guide_map[i], self.mu_g[i])).collect();
            planes.push(squares(&mu));
        }
        planes
    }
}

/// Precomputes the FFT spectra and norms of a source (SSD).
pub(super) fn prepare_spectra(model: &Model, plan: &Plan, src: &mut Source) {
    let (w, h) = (src.w(), src.h());
    let planes = model.real_planes(&src.work, w * h);
    src.norm1 = planes.iter().map(|p| p.iter().map(|v| v.abs()).sum()).collect();
    src.norm2 = planes.iter().map(|p| p.iter().map(|v| v * v).sum::<f64>().sqrt()).collect();
    src.spectra = planes
        .iter()
        .map(|plane| {
            let mut out = vec![Cx::new(0.0, 0.0); plan.len()];
            plan.forward(plane, w, h, &mut out, true);
            out
        })
        .collect();
}

/// What one block is matched against: already synthesised overlap pixels and guided pixels.
#[derive(Default)]
pub(super) struct Template {
    pub bw: usize,
    pub bh: usize,
    /// Overlap pixels `(dx, dy)`, their weight `1/N_o`, values (`C` per pixel) and coefficients.
    pub ov_off: Vec<(usize, usize)>,
    pub ov_w: Vec<f64>,
    pub ov_val: Vec<f32>,
    pub ov_coef: Vec<f64>,
    /// Guided pixels, weight `g(p)/N_g`, guide values (`Cg` per pixel) and coefficients.
    pub gd_off: Vec<(usize, usize)>,
    pub gd_w: Vec<f64>,
    pub gd_val: Vec<f32>,
    pub gd_coef: Vec<f64>,
}

impl Template {
    pub fn is_empty(&self) -> bool {
        self.ov_off.is_empty() && self.gd_off.is_empty()
    }
}

/// The error of one candidate, summed in the canonical order (overlap term: channel by channel, pixel
/// by pixel; then the guide term likewise).
pub(super) fn direct_error(model: &Model, t: &Template, src: &Source, qx: usize, qy: usize) -> f64 {
    if let Some(keep) = &src.keep {
        return direct_error_masked(model, t, src, keep, qx, qy);
    }
    let c_n = model.channels;
    let w = src.w();
    let plane = w * src.h();
    let mut acc = 0.0f64;
    for &c in &model.active_o {
        let work = &src.work[c * plane..(c + 1) * plane];
        for (k, &(dx, dy)) in t.ov_off.iter().enumerate() {
            let d = f64::from(work[(qy + dy) * w + qx + dx]) - f64::from(t.ov_val[k * c_n + c]);
            acc += t.ov_coef[k * c_n + c] * model.dist(d);
        }
    }
    let g_n = model.mu_g.len();
    for &i in &model.active_g {
        let c = model.guide_map[i];
        let work = &src.work[c * plane..(c + 1) * plane];
        for (k, &(dx, dy)) in t.gd_off.iter().enumerate() {
            let d = f64::from(work[(qy + dy) * w + qx + dx]) - f64::from(t.gd_val[k * g_n + i]);
            acc += t.gd_coef[k * g_n + i] * model.dist(d);
        }
    }
    acc
}

/// The error of a candidate in a source with ignored pixels: each term sums over the pixels kept
/// and is divided by the share of its weight they hold (a term with nothing kept is 0), so a
/// candidate is neither favoured nor penalised for what the mask hides.
fn direct_error_masked(model: &Model, t: &Template, src: &Source, keep: &[f32], qx: usize, qy: usize) -> f64 {
    let c_n = model.channels;
    let w = src.w();
    let plane = w * src.h();
    let at = |dx: usize, dy: usize| (qy + dy) * w + qx + dx;
    let share = |offs: &[(usize, usize)], wts: &[f64]| -> f64 {
        offs.iter().zip(wts).map(|(&(dx, dy), &wt)| wt * f64::from(keep[at(dx, dy)])).sum()
    };
    let mut o = 0.0f64;
    for &c in &model.active_o {
        let work = &src.work[c * plane..(c + 1) * plane];
        for (k, &(dx, dy)) in t.ov_off.iter().enumerate() {
            let i = at(dx, dy);
            let d = f64::from(work[i]) - f64::from(t.ov_val[k * c_n + c]);
            o += f64::from(keep[i]) * t.ov_coef[k * c_n + c] * model.dist(d);
        }
    }
    let g_n = model.mu_g.len();
    let mut g = 0.0f64;
    for &gi in &model.active_g {
        let c = model.guide_map[gi];
        let work = &src.work[c * plane..(c + 1) * plane];
        for (k, &(dx, dy)) in t.gd_off.iter().enumerate() {
            let i = at(dx, dy);
            let d = f64::from(work[i]) - f64::from(t.gd_val[k * g_n + gi]);
            g += f64::from(keep[i]) * t.gd_coef[k * g_n + gi] * model.dist(d);
        }
    }
    let ratio = |sum: f64, share: f64| if share > 0.0 { sum / share } else { 0.0 };
    ratio(o, share(&t.ov_off, &t.ov_w)) + ratio(g, share(&t.gd_off, &t.gd_w))
}

/// Approximate errors of every candidate position of a source (row-major over the candidate grid)
/// summed in `f32` (twice the SIMD width of `f64`), in parallel over candidate rows, and the relative
/// rounding bound `δ`: `|E32 − E| ≤ δ·E` for every candidate, because every term is non-negative (SAD).
pub(super) fn direct_all_f32(model: &Model, t: &Template, src: &Source, par: bool, out: &mut Vec<f32>) -> f64 {
    let (cw, chh) = (src.cw, src.ch);
    let c_n = model.channels;
    let g_n = model.mu_g.len();
    let w = src.w();
    let plane = w * src.h();
    out.clear();
    out.resize(cw * chh, 0.0);
    if let Some(keep) = &src.keep {
        return masked_all_f32(model, t, src, keep, par, out);
    }
    out.par_chunks_mut(cw).with_min_len(if par { 1 } else { usize::MAX }).enumerate().for_each(|(qy, acc)| {
        let mut run = |dx: usize, dy: usize, c: usize, coef: f64, target: f32| {
            let row = &src.work[c * plane + (qy + dy) * w + dx..][..cw];
            let coef = coef as f32;
            match model.metric {
                Metric::Sad => {
                    for (a, &s) in acc.iter_mut().zip(row) {
                        *a += coef * (s - target).abs();
                    }
                }
                Metric::Ssd => {
                    for (a, &s) in acc.iter_mut().zip(row) {
                        let d = s - target;
                        *a += coef * (d * d);
                    }
                }
            }
        };
        for &c in &model.active_o {
            for (k, &(dx, dy)) in t.ov_off.iter().enumerate() {
                run(dx, dy, c, t.ov_coef[k * c_n + c], t.ov_val[k * c_n + c]);
            }
        }
        for &i in &model.active_g {
            for (k, &(dx, dy)) in t.gd_off.iter().enumerate() {
                run(dx, dy, model.guide_map[i], t.gd_coef[k * g_n + i], t.gd_val[k * g_n + i]);
            }
        }
    });
    // Each term carries ≤ 4 roundings (difference, square or none, coefficient, product) and the
    // running sum ≤ n more, each ≤ 2^-24 relative; all terms are ≥ 0, so the bound is relative to E.
    let n = model.active_o.len() * t.ov_off.len() + model.active_g.len() * t.gd_off.len();
    // A coefficient that is not a normal f32 has no relative rounding bound: score exactly instead.
    let normal = |c: &f64| *c == 0.0 || ((*c as f32).is_normal() && *c < f64::from(f32::MAX));
    if !(t.ov_coef.iter().all(normal) && t.gd_coef.iter().all(normal)) {
        return f64::INFINITY;
    }
    let u = f64::from(f32::EPSILON) / 2.0;
    let k = (n + 5) as f64 * u;
    1.01 * k / (1.0 - k)
}

/// [`direct_all_f32`] for a source with ignored pixels: per candidate row, the overlap and guide
/// sums over kept pixels and the kept share of each term's weight, then `o/share_o + g/share_g`
/// as in [`direct_error_masked`]. Every sum is of non-negative terms, so the relative bound holds,
/// with a few roundings more for the shares and the division.
fn masked_all_f32(model: &Model, t: &Template, src: &Source, keep: &[f32], par: bool, out: &mut [f32]) -> f64 {
    let (cw, c_n, g_n) = (src.cw, model.channels, model.mu_g.len());
    let w = src.w();
    let plane = w * src.h();
    out.par_chunks_mut(cw).with_min_len(if par { 1 } else { usize::MAX }).enumerate().for_each(|(qy, row_out)| {
        let mut sums = [vec![0.0f32; cw], vec![0.0f32; cw]];
        let mut shares = [vec![0.0f32; cw], vec![0.0f32; cw]];
        let mut run = |term: usize, dx: usize, dy: usize, c: usize, coef: f64, target: f32| {
            let base = (qy + dy) * w + dx;
            let row = &src.work[c * plane + base..][..cw];
            let kept = &keep[base..][..cw];
            let coef = coef as f32;
            for ((a, &s), &k) in sums[term].iter_mut().zip(row).zip(kept) {
                let d = s - target;
                let e = match model.metric {
                    Metric::Sad => d.abs(),
                    Metric::Ssd => d * d,
                };
                *a += k * (coef * e);
            }
        };
        for &c in &model.active_o {
            for (k, &(dx, dy)) in t.ov_off.iter().enumerate() {
                run(0, dx, dy, c, t.ov_coef[k * c_n + c], t.ov_val[k * c_n + c]);
            }
        }
        for &i in &model.active_g {
            for (k, &(dx, dy)) in t.gd_off.iter().enumerate() {
                run(1, dx, dy, model.guide_map[i], t.gd_coef[k * g_n + i], t.gd_val[k * g_n + i]);
            }
        }
        for (term, (offs, wts)) in [(&t.ov_off, &t.ov_w), (&t.gd_off, &t.gd_w)].into_iter().enumerate() {
            for (&(dx, dy), &wt) in offs.iter().zip(wts.iter()) {
                let kept = &keep[(qy + dy) * w + dx..][..cw];
                for (a, &k) in shares[term].iter_mut().zip(kept) {
                    *a += k * wt as f32;
                }
            }
        }
        for (x, o) in row_out.iter_mut().enumerate() {
            let ratio = |term: usize| if shares[term][x] > 0.0 { sums[term][x] / shares[term][x] } else { 0.0 };
            *o = ratio(0) + ratio(1);
        }
    });
    let n = model.active_o.len() * t.ov_off.len() + model.active_g.len() * t.gd_off.len();
    let normal = |c: &f64| *c == 0.0 || ((*c as f32).is_normal() && *c < f64::from(f32::MAX));
    if !(t.ov_coef.iter().all(normal) && t.gd_coef.iter().all(normal) && t.ov_w.iter().chain(&t.gd_w).all(normal)) {
        return f64::INFINITY;
    }
    let u = f64::from(f32::EPSILON) / 2.0;
    // The sum carries ≤ n + 6 roundings; each share ≤ n_pixels + 2 more and divides it.
    let k = (2 * n + t.ov_off.len() + t.gd_off.len() + 12) as f64 * u;
    1.01 * k / (1.0 - k)
}

/// Reusable buffers of the FFT scorer.
#[derive(Default)]
pub(super) struct Scratch {
    /// Whether the work inside one block may be split over threads (off when whole blocks already
    /// run in parallel).
    pub par: bool,
    real: Vec<Real>,
    fft: correlate::Scratch,
}

/// FFT-correlated approximate errors of every candidate (row-major grid) and their rounding bound.
pub(super) fn fft_all(model: &Model, t: &Template, src: &Source, plan: &Plan, s: &mut Scratch) -> (Vec<f64>, f64) {
    let (bw, bh) = (t.bw, t.bh);
    let n = bw * bh;
    let c_n = model.channels;
    let g_n = model.mu_g.len();
    let n_real = model.n_real();
    let mut tau = vec![vec![0.0 as Real; n]; n_real];
    let mut constant = 0.0f64;
    for (k, &(dx, dy)) in t.ov_off.iter().enumerate() {
        let i = dy * bw + dx;
        for &c in &model.active_o {
            let (coef, x) = (t.ov_coef[k * c_n + c], f64::from(t.ov_val[k * c_n + c]));
            tau[c][i] -= 2.0 * coef * x;
            constant += coef * x * x;
        }
        if let Some(q) = model.q_o {
            tau[q][i] += t.ov_w[k];
        }
    }
    for (k, &(dx, dy)) in t.gd_off.iter().enumerate() {
        let i = dy * bw + dx;
        for &gi in &model.active_g {
            let (coef, g) = (t.gd_coef[k * g_n + gi], f64::from(t.gd_val[k * g_n + gi]));
            tau[model.guide_map[gi]][i] -= 2.0 * coef * g;
            constant += coef * g * g;
        }
        if let Some((q, f)) = model.q_g {
            tau[q][i] += f * t.gd_w[k];
        }
    }
    let mut bound = 0.0f64;
    let mut pairs: Vec<(&[Real], &[Cx])> = Vec::with_capacity(n_real);
    for (k, (p, spec)) in tau.iter().zip(&src.spectra).enumerate() {
        if p.iter().all(|&v| v == 0.0) {
            continue;
        }
        let l1: f64 = p.iter().map(|v| v.abs()).sum();
        let l2: f64 = p.iter().map(|v| v * v).sum::<f64>().sqrt();
        bound += 2.0 * l1 * src.norm2[k] + l2 * src.norm1[k];
        pairs.push((p, spec));
    }
    let mut errors = std::mem::take(&mut s.real);
    plan.correlate(&pairs, bw, bh, src.cw, src.ch, constant, &mut errors, &mut s.fft, s.par);
    // Norm-wise rounding bound of FFT correlation (forward, product, inverse), with a safety factor;
    // orders of magnitude above the observed error, and still far below error differences that matter.
    let log_n = ((plan.nx * plan.ny) as f64).log2().max(1.0);
    let margin = 8.0 * f64::EPSILON * log_n * bound + 1e-12 * constant.abs() + f64::MIN_POSITIVE;
    (errors, margin)
}

/// Returns a scores buffer to the scratch for reuse.
pub(super) fn recycle(s: &mut Scratch, v: Vec<f64>) {
    s.real = v;
}

/// The outcome of one block's search.
pub(super) struct Choice {
    pub source: usize,
    pub qx: usize,
    pub qy: usize,
    pub error: f64,
    /// Candidates within the tolerance (1 when the minimum was taken outright).
    pub within: usize,
}

/// Scores every allowed candidate of the eligible sources and applies the tolerance rule:
/// ε = 0 → the minimum, ties to the lowest index (source, then row, then column);
/// ε > 0 → uniform (seeded) among candidates with error ≤ (1 + ε)·min.
#[allow(clippy::too_many_arguments)]
pub(super) fn search(
    model: &Model,
    t: &Template,
    sources: &[Source],
    eligible: &[usize],
    tolerance: f64,
    plan: Option<&Plan>,
    scratch: &mut Scratch,
    rng: &mut Rng,
) -> Choice {
    // Candidates that may be within the tolerance of the minimum, in index order.
    let mut shortlist: Vec<(usize, u32)> = Vec::new();
    let masked = eligible.iter().any(|&si| sources[si].keep.is_some());
    match (model.metric, plan) {
        (Metric::Ssd, Some(plan)) if !masked => {
            // |E_fft − E| ≤ margin for every candidate.
            let mut approx: Vec<(usize, Vec<f64>)> = Vec::with_capacity(eligible.len());
            let mut lo = f64::INFINITY;
            let mut margin = 0.0f64;
            for &si in eligible {
                let (errs, m) = fft_all(model, t, &sources[si], plan, scratch);
                lo = sources[si].allowed.iter().map(|&i| errs[i as usize]).fold(lo, f64::min);
                margin = margin.max(m);
                approx.push((si, errs));
            }
            let threshold = (1.0 + tolerance) * (lo + margin) + margin;
            for (si, errs) in &approx {
                let keep = sources[*si].allowed.iter().filter(|&&i| errs[i as usize] <= threshold);
                shortlist.extend(keep.map(|&i| (*si, i)));
            }
            if let Some((_, errs)) = approx.pop() {
                recycle(scratch, errs);
            }
        }
        _ => {
            // Non-negative terms: E ≤ (1 + δ)·E32 and E32 ≤ (1 + δ)·E (plus an absolute slack for
            // subnormal products), so every candidate within the tolerance of the true minimum has
            // E32 ≤ (1 + ε)·(1 + δ)²·min E32 + slack.
            let mut approx: Vec<(usize, Vec<f32>)> = Vec::with_capacity(eligible.len());
            let mut lo = f64::INFINITY;
            let mut delta = 0.0f64;
            for &si in eligible {
                let mut errs = Vec::new();
                delta = delta.max(direct_all_f32(model, t, &sources[si], scratch.par, &mut errs));
                lo = sources[si].allowed.iter().map(|&i| f64::from(errs[i as usize])).fold(lo, f64::min);
                approx.push((si, errs));
            }
            let terms = model.active_o.len() * t.ov_off.len() + model.active_g.len() * t.gd_off.len();
            let slack = 4.0 * terms as f64 * f64::from(f32::MIN_POSITIVE);
            let threshold = (1.0 + tolerance) * (lo * (1.0 + delta) * (1.0 + delta) + slack) + slack;
            for (si, errs) in &approx {
                let keep = sources[*si].allowed.iter().filter(|&&i| f64::from(errs[i as usize]) <= threshold);
                shortlist.extend(keep.map(|&i| (*si, i)));
            }
        }
    }
    // Exact errors of the shortlist: (error, source, position).
    let exact: Vec<(f64, usize, u32)> = shortlist
        .par_iter()
        .with_min_len(if scratch.par { 64 } else { usize::MAX })
        .map(|&(si, i)| {
            let src = &sources[si];
            (direct_error(model, t, src, i as usize % src.cw, i as usize / src.cw), si, i)
        })
        .collect();
    let min = exact.iter().map(|e| e.0).fold(f64::INFINITY, f64::min);
    let pick = if tolerance == 0.0 {
        // The first candidate reaching the minimum is the lowest index.
        let k = exact.iter().position(|e| e.0 == min).expect("at least one candidate");
        (exact[k], 1)
    } else {
        let limit = (1.0 + tolerance) * min;
        let within: Vec<&(f64, usize, u32)> = exact.iter().filter(|e| e.0 <= limit).collect();
        (*within[rng.below(within.len())], within.len())
    };
    let ((error, si, i), within) = pick;
    let src = &sources[si];
    Choice { source: si, qx: i as usize % src.cw, qy: i as usize / src.cw, error, within }
}

/// Uniform choice among all allowed candidates of the eligible sources (unconstrained block).
pub(super) fn random_choice(sources: &[Source], eligible: &[usize], rng: &mut Rng) -> Choice {
    let total: usize = eligible.iter().map(|&s| sources[s].allowed.len()).sum();
    let mut r = rng.below(total);
    for &si in eligible {
        let src = &sources[si];
        if r < src.allowed.len() {
            let i = src.allowed[r] as usize;
            return Choice { source: si, qx: i % src.cw, qy: i / src.cw, error: 0.0, within: total };
        }
        r -= src.allowed.len();
    }
    unreachable!("eligible sources have allowed candidates")
}
