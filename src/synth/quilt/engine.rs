//! Validation, preparation of the sources and the block-by-block synthesis loop.

use std::f64::consts::TAU;

use rayon::prelude::*;

use super::cut::new_region;
use super::params::{
    check_finite_image, check_range, check_size, Coherence, Equalise, Input, Metric, QuiltError, QuiltOptions,
    QuiltParams, SampleChoice,
};
use super::result::{BlockRecord, IndexMap, QuiltResult, SourceInfo};
use super::rotate::rotate_sample;
use super::search::{direct_error, prepare_spectra, random_choice, search, Choice, Model, Scratch, Source, Template};
use crate::raster::color::linear_rgb_to_lab;
use crate::raster::Image;
use crate::synth::fft::correlate::Plan;
use crate::synth::rng::Rng;

/// What a test observer sees after each placed block.
#[cfg(test)]
pub(super) struct Trace<'a> {
    pub model: &'a Model,
    pub sources: &'a [Source],
    pub template: &'a Template,
    pub eligible: &'a [usize],
    pub record: &'a BlockRecord,
}

#[cfg(test)]
impl Trace<'_> {
    /// The error of any candidate against this block's template (the engine's own definition).
    pub fn error(&self, source: usize, qx: usize, qy: usize) -> f64 {
        direct_error(self.model, self.template, &self.sources[source], qx, qy)
    }

    /// Allowed candidates of the eligible sources in index order, as `(source, qx, qy)`.
    pub fn candidates(&self) -> Vec<(usize, usize, usize)> {
        let mut v = Vec::new();
        for &s in self.eligible {
            let src = &self.sources[s];
            v.extend(src.allowed.iter().map(|&i| (s, i as usize % src.cw, i as usize / src.cw)));
        }
        v
    }

    /// Overlap error of one channel only (the per-channel SAD/SSD of Dong Eq. 6.2.2).
    pub fn channel_error(&self, c: usize, source: usize, qx: usize, qy: usize) -> f64 {
        let src = &self.sources[source];
        let (w, plane, c_n) = (src.w(), src.w() * src.h(), self.model.channels);
        let mut acc = 0.0;
        for (k, &(dx, dy)) in self.template.ov_off.iter().enumerate() {
            let d =
                f64::from(src.work[c * plane + (qy + dy) * w + qx + dx]) - f64::from(self.template.ov_val[k * c_n + c]);
            acc += self.template.ov_coef[k * c_n + c] * self.model.dist(d);
        }
        acc
    }
}

#[cfg(test)]
thread_local! {
    /// Test switch: one block per wave, i.e. the plain sequential raster order.
    pub(super) static RASTER_ORDER: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

#[cfg(test)]
pub(super) type Observer<'o> = Option<&'o mut dyn FnMut(&Trace)>;
#[cfg(not(test))]
pub(super) type Observer<'o> = Option<std::marker::PhantomData<&'o ()>>;

/// Block positions along one axis and whether blocks wrap (torus).
struct Axis {
    pos: Vec<usize>,
    size: usize,
    wrap: bool,
}

impl Axis {
    fn new(size: usize, block: usize, overlap: usize, wrap: bool) -> Axis {
        let step = block - overlap;
        let pos = if wrap {
            // Spread n = ceil(size/step) blocks evenly: spacings differ by at most 1, overlaps ≥ O.
            let n = size.div_ceil(step);
            (0..n).map(|i| i * size / n).collect()
        } else {
            let n = 1 + size.saturating_sub(block).div_ceil(step);
            (0..n).map(|i| i * step).collect()
        };
        Axis { pos, size, wrap }
    }

    /// Extent of block `i` inside the output (clipped unless wrapping).
    fn extent(&self, i: usize, block: usize) -> usize {
        if self.wrap {
            block
        } else {
            block.min(self.size - self.pos[i])
        }
    }

    fn at(&self, i: usize, d: usize) -> usize {
        let v = self.pos[i] + d;
        if self.wrap {
            v % self.size
        } else {
            v
        }
    }

    /// Overlap widths with the previous block and (torus, last block) with block 0 after wrapping.
    fn overlaps(&self, i: usize, block: usize) -> (usize, usize) {
        let before = if i > 0 { (self.pos[i - 1] + block).saturating_sub(self.pos[i]) } else { 0 };
        let after =
            if self.wrap && i + 1 == self.pos.len() { (self.pos[i] + block).saturating_sub(self.size) } else { 0 };
        (before, after)
    }
}

fn validate(samples: &[&Image], p: &QuiltParams, o: &QuiltOptions) -> Result<(), QuiltError> {
    match o.choice {
        SampleChoice::Density(_) if samples.len() != 2 => {
            return Err(QuiltError::SampleCount { got: samples.len(), expected: "exactly 2 for a density map" })
        }
        _ if samples.is_empty() => return Err(QuiltError::SampleCount { got: 0, expected: "at least 1" }),
        _ => {}
    }
    if p.width == 0 || p.height == 0 {
        return Err(QuiltError::Empty { what: Input::Output });
    }
    if p.block == 0 {
        return Err(QuiltError::Empty { what: Input::Block });
    }
    if p.overlap >= p.block {
        return Err(QuiltError::OverlapTooLarge { overlap: p.overlap, block: p.block });
    }
    if p.tileable && p.overlap == 0 {
        return Err(QuiltError::TileableZeroOverlap);
    }
    if p.tileable && (p.width < p.block || p.height < p.block) {
        return Err(QuiltError::TileableTooSmall { block: p.block, width: p.width, height: p.height });
    }
    check_range(Input::Tolerance, p.tolerance, 0.0, f32::MAX, "a finite number ≥ 0")?;
    if p.candidate_stride == 0 {
        return Err(QuiltError::Invalid { name: Input::CandidateStride, value: 0.0, expected: "an integer ≥ 1" });
    }
    if let Coherence::On { forced_search } = p.coherence {
        check_range(Input::ForcedSearch, forced_search, 0.0, 1.0, "a probability in [0, 1]")?;
    }
    let t = o.terms;
    for (name, v) in [(Input::OverlapWeight, t.overlap), (Input::GuideWeight, t.guide), (Input::DepthWeight, t.depth)] {
        check_range(name, v, 0.0, f32::MAX, "a finite number ≥ 0")?;
    }
    // Each weight is finite and ≥ 0 here.
    if t.overlap + t.guide + t.depth <= 0.0 {
        return Err(QuiltError::Invalid { name: Input::TermWeights, value: 0.0, expected: "a positive sum" });
    }
    let channels = samples[0].channels;
    for (i, s) in samples.iter().enumerate() {
        if s.width == 0 || s.height == 0 || s.channels == 0 {
            return Err(QuiltError::Empty { what: Input::Sample });
        }
        if s.channels != channels {
            return Err(QuiltError::ChannelMismatch {
                what: Input::SampleChannels,
                expected: channels,
                got: s.channels,
            });
        }
        check_finite_image(Input::Sample, s)?;
        if p.block > s.width || p.block > s.height {
            return Err(QuiltError::BlockTooLarge { block: p.block, sample: i, width: s.width, height: s.height });
        }
    }
    if let Some(w) = &p.channel_weights {
        if w.len() != channels {
            return Err(QuiltError::ChannelMismatch { what: Input::ChannelWeights, expected: channels, got: w.len() });
        }
        for &v in w {
            check_range(Input::ChannelWeight, v, 0.0, f32::MAX, "a finite number ≥ 0")?;
        }
    }
    if let Some(&c) = o.depth_channels.iter().find(|&&c| c >= channels) {
        return Err(QuiltError::ChannelMismatch { what: Input::DepthChannel, expected: channels, got: c });
    }
    let scalar_map = |what: Input, img: &Image| -> Result<(), QuiltError> {
        check_size(what, img, p.width, p.height)?;
        if img.channels != 1 {
            return Err(QuiltError::ChannelMismatch { what, expected: 1, got: img.channels });
        }
        check_finite_image(what, img)
    };
    if let Some(m) = o.occupancy {
        scalar_map(Input::Occupancy, m)?;
    }
    if let Some(g) = &o.guide {
        check_size(Input::Guide, g.image, p.width, p.height)?;
        check_finite_image(Input::Guide, g.image)?;
        if let Some(wt) = g.weights {
            scalar_map(Input::GuideWeights, wt)?;
            if wt.data.iter().any(|&v| v < 0.0) {
                return Err(QuiltError::Invalid { name: Input::GuideWeight, value: -1.0, expected: "values ≥ 0" });
            }
        }
        match g.channels {
            Some(map) => {
                if map.len() != g.image.channels {
                    return Err(QuiltError::ChannelMismatch {
                        what: Input::GuideChannelMap,
                        expected: g.image.channels,
                        got: map.len(),
                    });
                }
                if let Some(&c) = map.iter().find(|&&c| c >= channels) {
                    return Err(QuiltError::ChannelMismatch {
                        what: Input::GuideChannelIndex,
                        expected: channels,
                        got: c,
                    });
                }
            }
            None if g.image.channels > channels => {
                return Err(QuiltError::ChannelMismatch {
                    what: Input::GuideChannels,
                    expected: channels,
                    got: g.image.channels,
                })
            }
            None => {}
        }
    }
    match o.choice {
        SampleChoice::Density(map) => scalar_map(Input::Density, map)?,
        SampleChoice::NearestMean { lab } => match &o.guide {
            None => {
                return Err(QuiltError::Invalid {
                    name: Input::Guide,
                    value: 0.0,
                    expected: "a guide for nearest-mean",
                })
            }
            Some(g) if lab && g.image.channels != 3 => {
                return Err(QuiltError::ChannelMismatch { what: Input::LabGuide, expected: 3, got: g.image.channels })
            }
            _ => {}
        },
        SampleChoice::All => {}
    }
    if let Some(or) = &o.orientation {
        check_size(Input::Orientation, or.field, p.width, p.height)?;
        if or.field.channels != 1 && or.field.channels != 2 {
            return Err(QuiltError::ChannelMismatch { what: Input::Orientation, expected: 2, got: or.field.channels });
        }
        check_finite_image(Input::Orientation, or.field)?;
        if or.copies == 0 {
            return Err(QuiltError::Invalid { name: Input::OrientationCopies, value: 0.0, expected: "at least 1" });
        }
    }
    if o.allowed.len() > samples.len() {
        return Err(QuiltError::SampleCount { got: o.allowed.len(), expected: "one allowed map per sample at most" });
    }
    for (m, s) in o.allowed.iter().zip(samples) {
        if let Some(m) = m {
            check_size(Input::AllowedPositions, m, s.width, s.height)?;
            check_finite_image(Input::AllowedPositions, m)?;
        }
    }
    Ok(())
}

/// Per-channel `(offset, scale)` of the equalisation, pooled over all samples.
fn equalisation(samples: &[&Image], mode: Equalise) -> Vec<(f64, f64)> {
    let channels = samples[0].channels;
    (0..channels)
        .map(|c| {
            let values = || samples.iter().flat_map(move |s| s.plane(c).iter().map(|&v| f64::from(v)));
            match mode {
                Equalise::None => (0.0, 1.0),
                Equalise::MinMax => {
                    let lo = values().fold(f64::INFINITY, f64::min);
                    let hi = values().fold(f64::NEG_INFINITY, f64::max);
                    (lo, if hi > lo { 1.0 / (hi - lo) } else { 1.0 })
                }
                Equalise::ZScore => {
                    let n = values().count() as f64;
                    let mean = values().sum::<f64>() / n;
                    let var = values().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
                    (mean, if var > 0.0 { 1.0 / var.sqrt() } else { 1.0 })
                }
            }
        })
        .collect()
}

fn equalise_planes(img: &Image, eq: &[(f64, f64)], map: &[usize]) -> Vec<f32> {
    let plane = img.plane_len();
    let mut out = vec![0.0f32; plane * map.len()];
    for (i, &c) in map.iter().enumerate() {
        let (off, s) = eq[c];
        for (o, &v) in out[i * plane..(i + 1) * plane].iter_mut().zip(img.plane(i)) {
            *o = ((f64::from(v) - off) * s) as f32;
        }
    }
    out
}

/// Mean colour over the given channels (CIELAB from linear RGB when `lab`), weighted.
fn mean_colour(
    img: &Image,
    channels: &[usize],
    lab: bool,
    pixels: impl Iterator<Item = (usize, f64)>,
) -> Option<Vec<f64>> {
    let plane = img.plane_len();
    let mut sum = vec![0.0f64; channels.len()];
    let mut wsum = 0.0;
    for (p, w) in pixels {
        if w <= 0.0 {
            continue;
        }
        let v: Vec<f32> = channels.iter().map(|&c| img.data[c * plane + p]).collect();
        let v = if lab { linear_rgb_to_lab([v[0], v[1], v[2]]).to_vec() } else { v };
        for (s, x) in sum.iter_mut().zip(v) {
            *s += w * f64::from(x);
        }
        wsum += w;
    }
    (wsum > 0.0).then(|| sum.into_iter().map(|s| s / wsum).collect())
}

fn block_rng(seed: u64, block: usize) -> Rng {
    Rng::new(seed ^ (block as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15))
}

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
    let q_g = (!active_g.is_empty()).then(|| {
        n_real += 1;
        n_real - 1
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
    let eq = equalisation(samples, p.equalise);
    let all_channels: Vec<usize> = (0..channels).collect();
    let copies = o.orientation.map_or(1, |or| or.copies);
    let plan = (p.metric == Metric::Ssd).then(|| {
        let mw = samples.iter().map(|s| s.width).max().unwrap_or(1);
        let mh = samples.iter().map(|s| s.height).max().unwrap_or(1);
        Plan::new(mw, mh)
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
            // Invalid-pixel summed-area table for rotation validity.
            let mut sat = vec![0u32; (w + 1) * (h + 1)];
            if let Some(v) = &valid {
                for y in 0..h {
                    for x in 0..w {
                        sat[(y + 1) * (w + 1) + x + 1] =
                            u32::from(!v[y * w + x]) + sat[y * (w + 1) + x + 1] + sat[(y + 1) * (w + 1) + x]
                                - sat[y * (w + 1) + x];
                    }
                }
            }
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
                        let s = |x: usize, y: usize| sat[y * (w + 1) + x];
                        ok &= s(qx + b, qy + b) + s(qx, qy) == s(qx + b, qy) + s(qx, qy + b);
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
            .map(|s| mean_colour(s, &guide_map, lab, (0..s.plane_len()).map(|i| (i, 1.0))).unwrap_or_default())
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

/// Groups the block grid into waves: a block's wave is one more than that of every earlier (raster
/// order) block whose footprint overlaps its own. Blocks of one wave have disjoint footprints, so
/// computing them in parallel and pasting them in raster order gives exactly the raster-order result.
fn waves(ax: &Axis, ay: &Axis, b: usize) -> Vec<Vec<(usize, usize)>> {
    let (nbx, nby) = (ax.pos.len(), ay.pos.len());
    #[cfg(test)]
    if RASTER_ORDER.with(std::cell::Cell::get) {
        return (0..nby).flat_map(|j| (0..nbx).map(move |i| vec![(i, j)])).collect();
    }
    // Footprint intervals overlap, on the circle when the axis wraps.
    let overlaps = |a: &Axis, i: usize, k: usize| -> bool {
        let (l1, h1) = (a.pos[i] as i64, (a.pos[i] + a.extent(i, b)) as i64);
        let (l2, h2) = (a.pos[k] as i64, (a.pos[k] + a.extent(k, b)) as i64);
        let n = a.size as i64;
        let shifts: &[i64] = if a.wrap { &[-n, 0, n] } else { &[0] };
        shifts.iter().any(|&s| l1 < h2 + s && l2 + s < h1)
    };
    let mut level = vec![0usize; nbx * nby];
    let mut out: Vec<Vec<(usize, usize)>> = Vec::new();
    for j in 0..nby {
        for i in 0..nbx {
            let mut lv = 0;
            for jj in 0..=j {
                if !overlaps(ay, j, jj) {
                    continue;
                }
                for ii in 0..nbx {
                    if (jj, ii) >= (j, i) {
                        break;
                    }
                    if overlaps(ax, i, ii) {
                        lv = lv.max(level[jj * nbx + ii] + 1);
                    }
                }
            }
            level[j * nbx + i] = lv;
            if out.len() <= lv {
                out.resize(lv + 1, Vec::new());
            }
            out[lv].push((i, j));
        }
    }
    out
}

/// The mutable synthesis state: written only between waves.
struct State {
    /// Equalised values of the synthesised pixels, `C × W × H`.
    canvas: Vec<f32>,
    filled: Vec<bool>,
    /// `(source, qx, qy)` of each placed grid block.
    placed: Vec<Option<(usize, usize, usize)>>,
    index: IndexMap,
}

/// Everything that stays fixed during the block loop.
struct Ctx<'a> {
    p: &'a QuiltParams,
    o: &'a QuiltOptions<'a>,
    samples: &'a [&'a Image],
    model: &'a Model,
    sources: &'a [Source],
    plan: Option<&'a Plan>,
    ax: &'a Axis,
    ay: &'a Axis,
    occupied: &'a [bool],
    guide_work: Option<&'a (Vec<f32>, Vec<f64>)>,
    guide_map: &'a [usize],
    sample_means: &'a [Vec<f64>],
    copies: usize,
    n_px: usize,
    tolerance: f64,
}

/// One block's decision, computed from the state before its wave.
struct Job {
    i: usize,
    j: usize,
    #[cfg_attr(not(test), allow(dead_code))]
    template: Template,
    #[cfg_attr(not(test), allow(dead_code))]
    eligible: Vec<usize>,
    record: BlockRecord,
    /// Which block pixels the new block writes (cut applied, occupancy not yet).
    new: Vec<bool>,
}

impl Ctx<'_> {
    fn pix(&self, i: usize, j: usize, dx: usize, dy: usize) -> usize {
        self.ay.at(j, dy) * self.p.width + self.ax.at(i, dx)
    }

    fn block(&self, i: usize, j: usize, st: &State, scratch: &mut Scratch) -> Job {
        let (p, o, model, b) = (self.p, self.o, self.model, self.p.block);
        let (n_px, channels) = (self.n_px, model.channels);
        let (ax, ay) = (self.ax, self.ay);
        let nbx = ax.pos.len();
        let bidx = j * nbx + i;
        let (x0, y0) = (ax.pos[i], ay.pos[j]);
        let (bw, bh) = (ax.extent(i, b), ay.extent(j, b));
        let pix = |dx: usize, dy: usize| self.pix(i, j, dx, dy);
        let mut rng = block_rng(p.seed, bidx);
        let u_choice = rng.next_f64();
        let u_forced = rng.next_f64();
        let centre = pix(bw / 2, bh / 2);

        // Which samples, and which rotated copy.
        let n_samples = self.samples.len();
        let chosen_samples: Vec<usize> = match o.choice {
            SampleChoice::Density(map) => vec![usize::from(u_choice < f64::from(map.data[centre]))],
            SampleChoice::NearestMean { lab } => {
                let g = o.guide.as_ref().expect("validated");
                let weights = (0..bh).flat_map(|dy| (0..bw).map(move |dx| (dx, dy))).map(|(dx, dy)| {
                    let q = pix(dx, dy);
                    let w = if self.occupied[q] { g.weights.map_or(1.0, |wt| f64::from(wt.data[q])) } else { 0.0 };
                    (q, w)
                });
                let all: Vec<usize> = (0..g.image.channels).collect();
                match mean_colour(g.image, &all, lab, weights) {
                    Some(m) => {
                        let d = |s: &Vec<f64>| s.iter().zip(&m).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
                        let mut best = 0;
                        for s in 1..n_samples {
                            if d(&self.sample_means[s]) < d(&self.sample_means[best]) {
                                best = s;
                            }
                        }
                        vec![best]
                    }
                    None => (0..n_samples).collect(),
                }
            }
            SampleChoice::All => (0..n_samples).collect(),
        };
        let copy = match &o.orientation {
            Some(or) => {
                let f = or.field;
                let theta = if f.channels == 2 {
                    f64::from(f.data[n_px + centre]).atan2(f64::from(f.data[centre]))
                } else {
                    f64::from(f.data[centre])
                };
                let step = TAU / or.copies as f64;
                ((theta.rem_euclid(TAU) / step).round() as usize) % or.copies
            }
            None => 0,
        };
        let nearest_usable = |s: usize| {
            // Copies by angular distance from the wanted one; copy 0 always has candidates.
            (0..self.copies)
                .flat_map(|d| [(copy + d) % self.copies, (copy + self.copies - d) % self.copies])
                .map(|k| s * self.copies + k)
                .find(|&i| !self.sources[i].allowed.is_empty())
                .expect("the unrotated copy has candidates")
        };
        let eligible: Vec<usize> = chosen_samples.iter().map(|&s| nearest_usable(s)).collect();

        // Template: already synthesised pixels and guided pixels under the block.
        let mut t = Template { bw, bh, ..Template::default() };
        let g_n = self.guide_map.len();
        for dy in 0..bh {
            for dx in 0..bw {
                let q = pix(dx, dy);
                if st.filled[q] && !model.active_o.is_empty() {
                    t.ov_off.push((dx, dy));
                    t.ov_val.extend((0..channels).map(|c| st.canvas[c * n_px + q]));
                }
                if let Some((gw, wt)) = self.guide_work {
                    if wt[q] > 0.0 {
                        t.gd_off.push((dx, dy));
                        t.gd_w.push(wt[q]);
                        t.gd_val.extend((0..g_n).map(|gi| gw[gi * n_px + q]));
                    }
                }
            }
        }
        let n_o = t.ov_off.len() as f64;
        t.ov_w = vec![1.0 / n_o; t.ov_off.len()];
        t.ov_coef = (0..t.ov_off.len()).flat_map(|_| model.mu_o.iter().map(|&m| m / n_o)).collect();
        let n_g: f64 = t.gd_w.iter().sum();
        for w in &mut t.gd_w {
            *w /= n_g;
        }
        t.gd_coef = t.gd_w.iter().flat_map(|&w| model.mu_g.iter().map(move |&m| w * m)).collect();

        // Coherence shortcut: every placed neighbour predicts the same continuation.
        let wraps = p.tileable && (i + 1 == nbx || j + 1 == ay.pos.len());
        let mut shortcut: Option<(usize, usize, usize)> = None;
        if let Coherence::On { forced_search } = p.coherence {
            if !wraps && u_forced >= f64::from(forced_search) {
                let mut agree = true;
                let mut pred: Option<(usize, usize, usize)> = None;
                for (di, dj) in [(-1i64, 0i64), (-1, -1), (0, -1), (1, -1)] {
                    let (ni, nj) = (i as i64 + di, j as i64 + dj);
                    if ni < 0 || nj < 0 || ni >= nbx as i64 {
                        continue;
                    }
                    let (ni, nj) = (ni as usize, nj as usize);
                    let Some((s, qx, qy)) = st.placed[nj * nbx + ni] else { continue };
                    let px = qx as i64 + x0 as i64 - ax.pos[ni] as i64;
                    let py = qy as i64 + y0 as i64 - ay.pos[nj] as i64;
                    if px < 0 || py < 0 {
                        agree = false;
                        break;
                    }
                    let cand = (s, px as usize, py as usize);
                    match pred {
                        None => pred = Some(cand),
                        Some(prev) if prev != cand => {
                            agree = false;
                            break;
                        }
                        _ => {}
                    }
                }
                if let (true, Some((s, qx, qy))) = (agree, pred) {
                    if eligible.contains(&s) && self.sources[s].is_allowed(qx, qy) {
                        shortcut = Some((s, qx, qy));
                    }
                }
            }
        }

        let choice = match shortcut {
            Some((s, qx, qy)) => {
                Choice { source: s, qx, qy, error: direct_error(model, &t, &self.sources[s], qx, qy), within: 1 }
            }
            None if t.is_empty() => random_choice(self.sources, &eligible, &mut rng),
            None => search(model, &t, self.sources, &eligible, self.tolerance, self.plan, scratch, &mut rng),
        };

        // Boundary cut through the overlaps with already synthesised pixels.
        let src = &self.sources[choice.source];
        let (sw, splane) = (src.w(), src.w() * src.h());
        let (ov_l, ov_r) = ax.overlaps(i, b);
        let (ov_t, ov_b) = ay.overlaps(j, b);
        let any_filled = |xr: std::ops::Range<usize>, yr: std::ops::Range<usize>| {
            yr.clone().any(|dy| xr.clone().any(|dx| st.filled[pix(dx, dy)]))
        };
        let sides = [
            if ov_l > 0 && any_filled(0..ov_l.min(bw), 0..bh) { ov_l } else { 0 },
            if ov_t > 0 && any_filled(0..bw, 0..ov_t.min(bh)) { ov_t } else { 0 },
            if ov_r > 0 && any_filled(bw - ov_r.min(bw)..bw, 0..bh) { ov_r } else { 0 },
            if ov_b > 0 && any_filled(0..bw, bh - ov_b.min(bh)..bh) { ov_b } else { 0 },
        ];
        let new = new_region(bw, bh, sides, |dx, dy| {
            let q = pix(dx, dy);
            if !st.filled[q] {
                return 0.0;
            }
            let s = (choice.qy + dy) * sw + choice.qx + dx;
            let mut e = 0.0;
            for c in 0..channels {
                let m = model.mu_cut[c];
                if m > 0.0 {
                    e += m * model.dist(f64::from(src.work[c * splane + s]) - f64::from(st.canvas[c * n_px + q]));
                }
            }
            e
        });
        let record = BlockRecord {
            x: x0,
            y: y0,
            source: choice.source,
            sx: choice.qx,
            sy: choice.qy,
            error: choice.error,
            searched: shortcut.is_none(),
            within_tolerance: choice.within,
        };
        Job { i, j, template: t, eligible, record, new }
    }

    fn paste(&self, job: &Job, block_no: u32, st: &mut State) {
        let (i, j) = (job.i, job.j);
        let r = &job.record;
        let src = &self.sources[r.source];
        let (sw, splane) = (src.w(), src.w() * src.h());
        let (bw, bh) = (self.ax.extent(i, self.p.block), self.ay.extent(j, self.p.block));
        for dy in 0..bh {
            for dx in 0..bw {
                let q = self.pix(i, j, dx, dy);
                if !self.occupied[q] || (st.filled[q] && !job.new[dy * bw + dx]) {
                    continue;
                }
                let (sx, sy) = (r.sx + dx, r.sy + dy);
                for c in 0..self.model.channels {
                    st.canvas[c * self.n_px + q] = src.work[c * splane + sy * sw + sx];
                }
                st.filled[q] = true;
                st.index.source[q] = r.source as u32;
                st.index.x[q] = sx as u32;
                st.index.y[q] = sy as u32;
                st.index.block[q] = block_no;
            }
        }
        st.placed[j * self.ax.pos.len() + i] = Some((r.source, r.sx, r.sy));
    }
}
