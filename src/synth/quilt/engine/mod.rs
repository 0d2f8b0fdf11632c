//! Validation, preparation of the sources and the block-by-block synthesis loop.
//!
//! This file holds the driver, `run`: the error model, the prepared sources and the loop over
//! waves of blocks. The pieces live in `validate`, `prepare` (equalisation, mean colours),
//! `grid` (block positions and waves), `block` (one block's choice, cut and paste) and `trace`
//! (what tests observe).

mod block;
mod grid;
mod prepare;
mod trace;
mod validate;

use std::f64::consts::TAU;

use rayon::prelude::*;

use super::params::{Metric, QuiltError, QuiltOptions, QuiltParams, SampleChoice};
use super::result::{BlockRecord, IndexMap, QuiltResult, SourceInfo};
use super::rotate::rotate_sample;
use super::search::{prepare_spectra, Model, Scratch, Source};
use crate::raster::Image;
use crate::synth::fft::correlate::Plan;
use block::{Ctx, Job, State};
use grid::{waves, Axis};
use prepare::{equalisation, equalise_planes, mean_colour};
use trace::Observer;
use validate::validate;

#[cfg(test)]
pub(super) use trace::{Trace, RASTER_ORDER};

pub(super) fn run(
    samples: &[&Image],
    p: &QuiltParams,
    o: &QuiltOptions,
    #[allow(unused_variables, unused_mut)] mut observer: Observer,
) -> Result<QuiltResult, QuiltError> {
    validate(samples, p, o)?;
    let channels = samples[0].channels;
    let (out_w, out_h, b) = (p.width, p.height, p.block);

    // ---- error model -------------------------------------------------------------------------
    let cw: Vec<f64> = match &p.channel_weights {
        Some(w) => w.iter().map(|&v| f64::from(v)).collect(),
        None => vec![1.0; channels],
    };
    let is_depth: Vec<bool> = (0..channels).map(|c| o.depth_channels.contains(&c)).collect();
    let colour_sum: f64 = (0..channels).filter(|&c| !is_depth[c]).map(|c| cw[c]).sum();
    let depth_sum: f64 = (0..channels).filter(|&c| is_depth[c]).map(|c| cw[c]).sum();
    let mu_o: Vec<f64> = (0..channels)
        .map(|c| {
            let (term, sum) = if is_depth[c] {
                (f64::from(o.terms.depth), depth_sum)
            } else {
                (f64::from(o.terms.overlap), colour_sum)
            };
            if sum > 0.0 {
                term * cw[c] / sum
            } else {
                0.0
            }
        })
        .collect();
    let guide_map: Vec<usize> = match &o.guide {
        Some(g) => g.channels.map(<[usize]>::to_vec).unwrap_or_else(|| (0..g.image.channels).collect()),
        None => Vec::new(),
    };
    let guide_sum: f64 = guide_map.iter().map(|&c| cw[c]).sum();
    let mu_g: Vec<f64> = guide_map
        .iter()
        .map(|&c| if guide_sum > 0.0 { f64::from(o.terms.guide) * cw[c] / guide_sum } else { 0.0 })
        .collect();
    let mut mu_cut: Vec<f64> = (0..channels).map(|c| if is_depth[c] { 0.0 } else { cw[c] }).collect();
    if mu_cut.iter().all(|&m| m == 0.0) {
        mu_cut = cw.clone();
    }
    let active_o: Vec<usize> = (0..channels).filter(|&c| mu_o[c] > 0.0).collect();
    let active_g: Vec<usize> = (0..guide_map.len()).filter(|&i| mu_g[i] > 0.0).collect();
    let mut n_real = channels;
    let q_o = (!active_o.is_empty()).then(|| {
        n_real += 1;
        n_real - 1
    });
    // Σ μ_g S² per sample channel; a multiple of Σ μ_o S² (to a few roundings, far inside the
    // FFT scores' margin) shares its plane.
    let mut per_channel_g = vec![0.0f64; channels];
    for &i in &active_g {
        per_channel_g[guide_map[i]] += mu_g[i];
    }
    let ratio = q_o.and_then(|_| {
        let f = per_channel_g[active_o[0]] / mu_o[active_o[0]];
        let close = |c: usize| (per_channel_g[c] - f * mu_o[c]).abs() <= 4.0 * f64::EPSILON * per_channel_g[c].abs();
        (f > 0.0 && f.is_finite() && (0..channels).all(close)).then_some(f)
    });
    let q_g = (!active_g.is_empty()).then(|| match (q_o, ratio) {
        (Some(q), Some(f)) => (q, f),
        _ => {
            n_real += 1;
            (n_real - 1, 1.0)
        }
    });
    let model = Model {
        channels,
        metric: p.metric,
        mu_o,
        mu_g,
        guide_map: guide_map.clone(),
        mu_cut,
        active_o,
        active_g,
        q_o,
        q_g,
    };

    // ---- sources -----------------------------------------------------------------------------
    let eq = equalisation(samples, &o.ignore, p.equalise);
    let all_channels: Vec<usize> = (0..channels).collect();
    let copies = o.orientation.map_or(1, |or| or.copies);
    let plan = (p.metric == Metric::Ssd).then(|| {
        let mw = samples.iter().map(|s| s.width).max().unwrap_or(1);
        let mh = samples.iter().map(|s| s.height).max().unwrap_or(1);
        Plan::new(mw, mh, b)
    });
    let mut sources: Vec<Source> = Vec::with_capacity(samples.len() * copies);
    for (si, sample) in samples.iter().enumerate() {
        for k in 0..copies {
            let angle = (TAU * k as f64 / copies as f64) as f32;
            let (raw, valid) = if k == 0 {
                ((*sample).clone(), None)
            } else {
                let (r, v) = rotate_sample(sample, angle);
                (r, Some(v))
            };
            let (w, h) = (raw.width, raw.height);
            let allowed_map =
                o.allowed
                    .get(si)
                    .copied()
                    .flatten()
                    .map(|m| if k == 0 { m.clone() } else { rotate_sample(m, angle).0 });
            // Pixels to ignore (the mask layer), 1 = keep.
            let keep: Option<Vec<f32>> = o.ignore.get(si).copied().flatten().map(|m| {
                let m = if k == 0 { m.clone() } else { rotate_sample(m, angle).0 };
                m.data.iter().map(|&v| if v > 0.5 { 0.0 } else { 1.0 }).collect()
            });
            // Summed-area tables of invalid pixels (rotation) and of ignored ones.
            let table = |bad: &dyn Fn(usize) -> bool| {
                let mut sat = vec![0u32; (w + 1) * (h + 1)];
                for y in 0..h {
                    for x in 0..w {
                        sat[(y + 1) * (w + 1) + x + 1] =
                            u32::from(bad(y * w + x)) + sat[y * (w + 1) + x + 1] + sat[(y + 1) * (w + 1) + x]
                                - sat[y * (w + 1) + x];
                    }
                }
                sat
            };
            let sat = match &valid {
                Some(v) => table(&|i| !v[i]),
                None => Vec::new(),
            };
            let ignored = match &keep {
                Some(kp) => table(&|i| kp[i] == 0.0),
                None => Vec::new(),
            };
            let boxed = |sat: &[u32], qx: usize, qy: usize| {
                let s = |x: usize, y: usize| sat[y * (w + 1) + x];
                s(qx + b, qy + b) + s(qx, qy) - s(qx + b, qy) - s(qx, qy + b)
            };
            let (cgw, cgh) = (w - b + 1, h - b + 1);
            let mut allowed_mask = vec![false; cgw * cgh];
            let mut allowed = Vec::new();
            for qy in 0..cgh {
                for qx in 0..cgw {
                    let mut ok = qx % p.candidate_stride == 0 && qy % p.candidate_stride == 0;
                    if let Some(m) = &allowed_map {
                        ok &= m.data[qy * w + qx] > 0.5;
                    }
                    if valid.is_some() {
                        ok &= boxed(&sat, qx, qy) == 0;
                    }
                    if keep.is_some() {
                        // Candidates more than half ignored are rejected.
                        ok &= 2 * boxed(&ignored, qx, qy) as usize <= b * b;
                    }
                    if ok {
                        allowed_mask[qy * cgw + qx] = true;
                        allowed.push((qy * cgw + qx) as u32);
                    }
                }
            }
            // A rotated copy may be too small for the block (its valid area shrinks); blocks then use
            // the nearest copy that has candidates. The unrotated sample must have some.
            if allowed.is_empty() && k == 0 {
                return Err(QuiltError::NoCandidates { sample: si });
            }
            let work = equalise_planes(&raw, &eq, &all_channels);
            let mut src = Source {
                sample: si,
                angle,
                raw,
                work,
                cw: cgw,
                ch: cgh,
                allowed,
                allowed_mask,
                keep,
                spectra: Vec::new(),
                norm1: Vec::new(),
                norm2: Vec::new(),
            };
            if let Some(plan) = &plan {
                prepare_spectra(&model, plan, &mut src);
            }
            sources.push(src);
        }
    }

    // ---- output-sized inputs -----------------------------------------------------------------
    let n_px = out_w * out_h;
    let occupied: Vec<bool> = match o.occupancy {
        Some(m) => m.data.iter().map(|&v| v > 0.5).collect(),
        None => vec![true; n_px],
    };
    let guide_work: Option<(Vec<f32>, Vec<f64>)> = o.guide.as_ref().filter(|_| !model.active_g.is_empty()).map(|g| {
        let work = equalise_planes(g.image, &eq, &guide_map);
        let w: Vec<f64> = (0..n_px)
            .map(|i| if occupied[i] { g.weights.map_or(1.0, |wt| f64::from(wt.data[i])) } else { 0.0 })
            .collect();
        (work, w)
    });
    let sample_means: Vec<Vec<f64>> = match (o.choice, &o.guide) {
        (SampleChoice::NearestMean { lab }, Some(_)) => samples
            .iter()
            .enumerate()
            .map(|(si, s)| {
                let ignore = o.ignore.get(si).copied().flatten();
                let weight = |i: usize| ignore.map_or(1.0, |m| if m.data[i] > 0.5 { 0.0 } else { 1.0 });
                mean_colour(s, &guide_map, lab, (0..s.plane_len()).map(|i| (i, weight(i)))).unwrap_or_default()
            })
            .collect(),
        _ => Vec::new(),
    };

    // ---- synthesis ---------------------------------------------------------------------------
    let ax = Axis::new(out_w, b, p.overlap, p.tileable);
    let ay = Axis::new(out_h, b, p.overlap, p.tileable);
    let ctx = Ctx {
        p,
        o,
        samples,
        model: &model,
        sources: &sources,
        plan: plan.as_ref(),
        ax: &ax,
        ay: &ay,
        occupied: &occupied,
        guide_work: guide_work.as_ref(),
        guide_map: &guide_map,
        sample_means: &sample_means,
        copies,
        n_px,
        tolerance: f64::from(p.tolerance),
    };
    let (nbx, nby) = (ax.pos.len(), ay.pos.len());
    // Blocks entirely outside the occupancy mask are skipped; the others are numbered in raster order.
    let mut numbers: Vec<Option<u32>> = vec![None; nbx * nby];
    let mut count = 0u32;
    for j in 0..nby {
        for i in 0..nbx {
            let (bw, bh) = (ax.extent(i, b), ay.extent(j, b));
            if (0..bh).any(|dy| (0..bw).any(|dx| occupied[ay.at(j, dy) * out_w + ax.at(i, dx)])) {
                numbers[j * nbx + i] = Some(count);
                count += 1;
            }
        }
    }
    let mut state = State {
        canvas: vec![0.0f32; channels * n_px],
        filled: vec![false; n_px],
        placed: vec![None; nbx * nby],
        index: IndexMap::empty(out_w, out_h),
    };
    let mut records: Vec<Option<BlockRecord>> = vec![None; count as usize];
    let pool: std::sync::Mutex<Vec<Scratch>> = std::sync::Mutex::new(Vec::new());
    let threads = rayon::current_num_threads();
    let mut placed = 0;
    for wave in waves(&ax, &ay, b) {
        let wave: Vec<(usize, usize)> = wave.into_iter().filter(|&(i, j)| numbers[j * nbx + i].is_some()).collect();
        // Few blocks in the wave: split each block's work instead (results are the same either way).
        let inner = wave.len() < threads;
        let jobs: Vec<Job> = wave
            .par_iter()
            .map(|&(i, j)| {
                let mut scratch = pool.lock().map(|mut v| v.pop()).ok().flatten().unwrap_or_default();
                scratch.par = inner;
                let job = ctx.block(i, j, &state, &mut scratch);
                if let Ok(mut v) = pool.lock() {
                    v.push(scratch);
                }
                job
            })
            .collect();
        for job in jobs {
            let no = numbers[job.j * nbx + job.i].expect("placed blocks are numbered");
            ctx.paste(&job, no, &mut state);
            #[cfg(test)]
            if let Some(obs) = observer.as_mut() {
                obs(&Trace {
                    model: &model,
                    sources: &sources,
                    template: &job.template,
                    eligible: &job.eligible,
                    record: &job.record,
                });
            }
            records[no as usize] = Some(job.record);
            placed += 1;
        }
        if !wave.is_empty() {
            o.progress.report(placed, count as usize);
        }
    }
    let blocks: Vec<BlockRecord> = records.into_iter().map(|r| r.expect("every numbered block is placed")).collect();
    let searches = blocks.iter().filter(|r| r.searched).count();
    let infos: Vec<SourceInfo> =
        sources.iter().map(|s| SourceInfo { sample: s.sample, angle: s.angle, width: s.w(), height: s.h() }).collect();
    let raws: Vec<&Image> = sources.iter().map(|s| &s.raw).collect();
    let index = state.index;
    let image = index.gather_sources(&raws);
    let seams = index.seam_mask(p.tileable);
    Ok(QuiltResult { image, index, seams, sources: infos, blocks, searches, tileable: p.tileable })
}
