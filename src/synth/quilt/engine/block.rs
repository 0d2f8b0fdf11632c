//! One block of the synthesis: its sample and copy, template, search (or coherence shortcut)
//! and boundary cut, computed from the state before its wave, then pasted into that state.

use std::f64::consts::TAU;

use super::grid::Axis;
use super::prepare::mean_colour;
use crate::raster::Image;
use crate::synth::fft::correlate::Plan;
use crate::synth::quilt::cut::new_region;
use crate::synth::quilt::params::{Coherence, QuiltOptions, QuiltParams, SampleChoice};
use crate::synth::quilt::result::{BlockRecord, IndexMap};
use crate::synth::quilt::search::{direct_error, random_choice, search, Choice, Model, Scratch, Source, Template};
use crate::synth::rng::Rng;

fn block_rng(seed: u64, block: usize) -> Rng {
    Rng::new(seed ^ (block as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15))
}

/// The mutable synthesis state: written only between waves.
pub(super) struct State {
    /// Equalised values of the synthesised pixels, `C × W × H`.
    pub(super) canvas: Vec<f32>,
    pub(super) filled: Vec<bool>,
    /// `(source, qx, qy)` of each placed grid block.
    pub(super) placed: Vec<Option<(usize, usize, usize)>>,
    pub(super) index: IndexMap,
}

/// Everything that stays fixed during the block loop.
pub(super) struct Ctx<'a> {
    pub(super) p: &'a QuiltParams,
    pub(super) o: &'a QuiltOptions<'a>,
    pub(super) samples: &'a [&'a Image],
    pub(super) model: &'a Model,
    pub(super) sources: &'a [Source],
    pub(super) plan: Option<&'a Plan>,
    pub(super) ax: &'a Axis,
    pub(super) ay: &'a Axis,
    pub(super) occupied: &'a [bool],
    pub(super) guide_work: Option<&'a (Vec<f32>, Vec<f64>)>,
    pub(super) guide_map: &'a [usize],
    pub(super) sample_means: &'a [Vec<f64>],
    pub(super) copies: usize,
    pub(super) n_px: usize,
    pub(super) tolerance: f64,
}

/// One block's decision, computed from the state before its wave.
pub(super) struct Job {
    pub(super) i: usize,
    pub(super) j: usize,
    #[cfg_attr(not(test), allow(dead_code))]
    pub(super) template: Template,
    #[cfg_attr(not(test), allow(dead_code))]
    pub(super) eligible: Vec<usize>,
    pub(super) record: BlockRecord,
    /// Which block pixels the new block writes (cut applied, occupancy not yet).
    pub(super) new: Vec<bool>,
}

impl Ctx<'_> {
    /// Whether the output pixel `q` (filled) came from a sample pixel its mask keeps.
    fn kept(&self, st: &State, q: usize) -> bool {
        let Some((s, x, y)) = st.index.get(q % self.p.width, q / self.p.width) else { return true };
        self.sources[s].keep.as_ref().is_none_or(|k| k[y * self.sources[s].w() + x] > 0.0)
    }

    fn pix(&self, i: usize, j: usize, dx: usize, dy: usize) -> usize {
        self.ay.at(j, dy) * self.p.width + self.ax.at(i, dx)
    }

    pub(super) fn block(&self, i: usize, j: usize, st: &State, scratch: &mut Scratch) -> Job {
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
                // A pixel pasted from an ignored sample pixel is ignored in the overlap too.
                if st.filled[q] && !model.active_o.is_empty() && self.kept(st, q) {
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
            let s = (choice.qy + dy) * sw + choice.qx + dx;
            // Ignored pixels, on either side, cost nothing to cut through.
            if !st.filled[q] || !self.kept(st, q) || src.keep.as_ref().is_some_and(|k| k[s] == 0.0) {
                return 0.0;
            }
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

    pub(super) fn paste(&self, job: &Job, block_no: u32, st: &mut State) {
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
