//! Per-channel assembly (composite, free pixels, guidance) and solver dispatch.

use std::borrow::Cow;

use rayon::prelude::*;

use super::lanes::{F32x4, Lanes, Pooled};
use super::multigrid::{self, wrap_or_skip, CycleParams, Driver, Hierarchy, Level, SolveBuffers, Stop};
use super::params::WrapGuidance;
use super::params::{
    BlendError, BlendParams, Domain, Method, Mode, Param, Seam, Selector, SolveReport, SolverKind, Topology,
};
use super::spectral::{solve_neumann, solve_periodic};
use crate::raster::Image;

/// Rows per reduction block in this file's f64 sums (fixed: thread-count independent).
const ROWS_PER_BLOCK: usize = 16;

pub(super) fn validate(
    sources: &[&Image],
    selector: &Selector<'_>,
    params: &BlendParams,
    warm: Option<&Image>,
) -> Result<(), BlendError> {
    let first = *sources.first().ok_or(BlendError::NoSources)?;
    let (w, h, c) = (first.width, first.height, first.channels);
    if w == 0 || h == 0 || c == 0 {
        return Err(BlendError::Empty { what: "source 0".into() });
    }
    for (i, s) in sources.iter().enumerate() {
        let what = format!("source {i}");
        if !s.same_size(first) {
            return Err(BlendError::SizeMismatch { what, expected: (w, h), found: (s.width, s.height) });
        }
        if s.channels != c {
            return Err(BlendError::ChannelMismatch { what, expected: c, found: s.channels });
        }
        check_finite(s, &what)?;
    }
    match selector {
        Selector::Binary(m) | Selector::Soft(m) => {
            if sources.len() != 2 {
                return Err(BlendError::SourceCount { expected: 2, found: sources.len() });
            }
            if m.width == 0 || m.height == 0 || m.channels == 0 {
                return Err(BlendError::Empty { what: "mask".into() });
            }
            if !m.same_size(first) {
                return Err(BlendError::SizeMismatch {
                    what: "mask".into(),
                    expected: (w, h),
                    found: (m.width, m.height),
                });
            }
            if m.channels != 1 && m.channels != c {
                return Err(BlendError::ChannelMismatch { what: "mask".into(), expected: c, found: m.channels });
            }
            check_finite(m, "mask")?;
        }
        Selector::Labels(l) => {
            if l.len() != w * h {
                return Err(BlendError::BadParameter {
                    name: Param::Labels,
                    reason: format!("has {} entries; the sources are {w}x{h} = {}", l.len(), w * h),
                });
            }
            if let Some(i) = l.iter().position(|&v| v as usize >= sources.len()) {
                return Err(BlendError::LabelOutOfRange { x: i % w, y: i / w, label: l[i], sources: sources.len() });
            }
        }
    }
    if let Some(wm) = warm {
        if !wm.same_size(first) {
            return Err(BlendError::SizeMismatch {
                what: "warm start".into(),
                expected: (w, h),
                found: (wm.width, wm.height),
            });
        }
        if wm.channels != c {
            return Err(BlendError::ChannelMismatch { what: "warm start".into(), expected: c, found: wm.channels });
        }
        check_finite(wm, "warm start")?;
    }
    let s = &params.solver;
    if !(s.tol > 0.0 && s.tol.is_finite()) {
        return Err(BlendError::BadParameter {
            name: Param::Tol,
            reason: format!("{} is not a positive number", s.tol),
        });
    }
    if s.max_tol.is_nan() || s.max_tol <= 0.0 {
        return Err(BlendError::BadParameter { name: Param::MaxTol, reason: format!("{} is not positive", s.max_tol) });
    }
    if s.max_iter == 0 {
        return Err(BlendError::BadParameter { name: Param::MaxIter, reason: "must be at least 1".into() });
    }
    if s.smooth == 0 {
        return Err(BlendError::BadParameter { name: Param::Smooth, reason: "must be at least 1".into() });
    }
    if let Topology::Rim { source } = params.topology {
        if source >= sources.len() {
            return Err(BlendError::BadParameter {
                name: Param::RimSource,
                reason: format!("source {source} does not exist ({} given)", sources.len()),
            });
        }
    }
    Ok(())
}

fn check_finite(img: &Image, what: &str) -> Result<(), BlendError> {
    const CHUNK: usize = 1 << 14;
    let all_finite = |c: &[f32]| c.iter().fold(true, |ok, v| ok & v.is_finite());
    if let Some(ci) = img.data.par_chunks(CHUNK).position_first(|c| !all_finite(c)) {
        let i = ci * CHUNK + img.data[ci * CHUNK..].iter().position(|v| !v.is_finite()).unwrap_or(0);
        let n = img.plane_len();
        let (c, p) = (i / n, i % n);
        return Err(BlendError::NonFinite { what: what.into(), x: p % img.width, y: p / img.width, channel: c });
    }
    Ok(())
}

/// The selector restricted to one channel.
enum ChanSel<'a> {
    Labels(Cow<'a, [u32]>),
    Weights(Vec<f32>),
}

/// The grid graph.
#[derive(Clone, Copy)]
struct Graph {
    w: usize,
    h: usize,
    periodic: bool,
}

impl Graph {
    #[inline]
    fn right(&self, x: usize, y: usize) -> Option<usize> {
        if x + 1 < self.w {
            Some(y * self.w + x + 1)
        } else if self.periodic {
            Some(y * self.w)
        } else {
            None
        }
    }
    #[inline]
    fn down(&self, x: usize, y: usize) -> Option<usize> {
        if y + 1 < self.h {
            Some((y + 1) * self.w + x)
        } else if self.periodic {
            Some(x)
        } else {
            None
        }
    }
    #[inline]
    fn left(&self, x: usize, y: usize) -> Option<usize> {
        if x > 0 {
            Some(y * self.w + x - 1)
        } else if self.periodic {
            Some(y * self.w + self.w - 1)
        } else {
            None
        }
    }
    #[inline]
    fn up(&self, x: usize, y: usize) -> Option<usize> {
        if y > 0 {
            Some((y - 1) * self.w + x)
        } else if self.periodic {
            Some((self.h - 1) * self.w + x)
        } else {
            None
        }
    }
}

/// Rows per parallel block of this file's per-pixel passes that reduce nothing.
const ROWS_PER_TASK: usize = 16;

/// Blends every channel (see the module documentation) into a new image. Channels that
/// share a selector plane (a one-channel mask or a label map) form one group: the selector,
/// the free pixels and the multigrid hierarchy are built once, and the masked solves of up
/// to four channels run together, one lane each (see `multigrid`), which gives the same
/// values as solving them one by one.
pub(super) fn blend_all(
    sources: &[&Image],
    selector: &Selector<'_>,
    params: &BlendParams,
    warm: Option<&Image>,
) -> (Image, Vec<SolveReport>) {
    let first = sources[0];
    let (w, h, nc) = (first.width, first.height, first.channels);
    let mut out = Image::new(w, h, nc);
    let mut reports: Vec<Option<SolveReport>> = vec![None; nc];
    let shared = match selector {
        Selector::Binary(m) | Selector::Soft(m) => m.channels == 1,
        Selector::Labels(_) => true,
    };
    let groups: Vec<(usize, Vec<usize>)> =
        if shared { vec![(0, (0..nc).collect())] } else { (0..nc).map(|c| (c, vec![c])).collect() };
    let mut planes: Vec<Option<&mut [f32]>> = out.data.chunks_mut(w * h).map(Some).collect();
    for (sel_channel, chans) in groups {
        let group = Group::new(sources, selector, params, sel_channel);
        let outs: Vec<&mut [f32]> = chans.iter().map(|&c| planes[c].take().expect("one group per channel")).collect();
        for (&c, report) in chans.iter().zip(group.blend(sources, params, warm, &chans, outs)) {
            reports[c] = Some(report);
        }
    }
    (out, reports.into_iter().map(|r| r.expect("every channel is blended")).collect())
}

/// A selector plane and everything derived from it alone, shared by the channels it
/// selects for.
struct Group<'a> {
    g: Graph,
    sel: ChanSel<'a>,
    free: Vec<u8>,
    unknowns: usize,
}

/// What the masked solve of one channel needs besides the shared group (its output plane
/// holds the start, then the result).
struct Prepared {
    tx: Vec<f32>,
    ty: Vec<f32>,
    bnorm: f64,
    range: f64,
}

impl<'a> Group<'a> {
    fn new(sources: &[&Image], selector: &Selector<'a>, params: &BlendParams, sel_channel: usize) -> Group<'a> {
        let (w, h) = (sources[0].width, sources[0].height);
        let g = Graph { w, h, periodic: params.topology == Topology::Torus };
        let sel = match selector {
            Selector::Binary(m) => {
                ChanSel::Labels(Cow::Owned(m.plane(sel_channel).par_iter().map(|&v| (v >= 0.5) as u32).collect()))
            }
            Selector::Soft(m) => {
                ChanSel::Weights(m.plane(sel_channel).par_iter().map(|&v| v.clamp(0.0, 1.0)).collect())
            }
            Selector::Labels(l) => ChanSel::Labels(Cow::Borrowed(l)),
        };
        let free = free_pixels(&g, &sel, params);
        let unknowns = free.par_chunks(1 << 16).map(|c| c.iter().filter(|&&v| v != 0).count()).sum();
        Group { g, sel, free, unknowns }
    }

    /// Writes the composite f0 into `f`: the hard composite for labels, the cross-fade for
    /// soft masks (Cut thresholds it at 0.5); the rim set in rim topology.
    fn composite(&self, srcs: &[&[f32]], params: &BlendParams, f: &mut [f32]) {
        let (w, h) = (self.g.w, self.g.h);
        let mut rows = |body: &(dyn Fn(usize, &mut [f32]) + Sync)| {
            f.par_chunks_mut(w).enumerate().with_min_len(8).for_each(|(y, fr)| body(y * w, fr));
        };
        match &self.sel {
            ChanSel::Labels(l) if srcs.len() == 2 => {
                let (a, b) = (srcs[0], srcs[1]);
                rows(&|o, fr| {
                    let (ar, br, lr) = (&a[o..o + w], &b[o..o + w], &l[o..o + w]);
                    for x in 0..w {
                        fr[x] = if lr[x] != 0 { br[x] } else { ar[x] };
                    }
                });
            }
            ChanSel::Labels(l) => rows(&|o, fr| {
                for (x, v) in fr.iter_mut().enumerate() {
                    *v = srcs[l[o + x] as usize][o + x];
                }
            }),
            ChanSel::Weights(m) => rows(&|o, fr| {
                for (x, v) in fr.iter_mut().enumerate() {
                    let (i, mi) = (o + x, m[o + x]);
                    *v = if params.mode == Mode::Cut {
                        if mi >= 0.5 {
                            srcs[1][i]
                        } else {
                            srcs[0][i]
                        }
                    } else {
                        (1.0 - mi) * srcs[0][i] + mi * srcs[1][i]
                    };
                }
            }),
        }
        if let Topology::Rim { source } = params.topology {
            apply_rim(f, srcs[source], w, h);
        }
    }

    /// Blends channels `chans` of the sources (all selected by this group) into `outs`.
    fn blend(
        &self,
        sources: &[&Image],
        params: &BlendParams,
        warm: Option<&Image>,
        chans: &[usize],
        mut outs: Vec<&mut [f32]>,
    ) -> Vec<SolveReport> {
        let g = &self.g;
        let n = g.w * g.h;
        let srcs_of = |c: usize| -> Vec<&[f32]> { sources.iter().map(|s| s.plane(c)).collect() };
        let direct = |c: usize, unknowns: usize| SolveReport {
            channel: c,
            method: Method::Direct,
            unknowns,
            iterations: 0,
            residual: 0.0,
            max_residual: 0.0,
            converged: true,
        };
        let mut each = |f: &dyn Fn(usize, &mut [f32]) -> SolveReport| -> Vec<SolveReport> {
            chans.iter().zip(outs.iter_mut()).map(|(&c, o)| f(c, o)).collect()
        };
        match params.mode {
            Mode::Cut => {
                return each(&|c, o| {
                    self.composite(&srcs_of(c), params, o);
                    direct(c, 0)
                })
            }
            Mode::Average => {
                return each(&|c, f| {
                    let srcs = srcs_of(c);
                    self.composite(&srcs, params, f);
                    if let ChanSel::Labels(l) = &self.sel {
                        for i in 0..n {
                            if self.free[i] != 0 {
                                f[i] = 0.5 * (srcs[0][i] + srcs[l[i] as usize][i]);
                            }
                        }
                    } // soft masks: f0 already is the cross-fade
                    direct(c, 0)
                });
            }
            Mode::Gradient | Mode::Mixed => {}
        }
        if self.unknowns == 0 {
            return each(&|c, o| {
                self.composite(&srcs_of(c), params, o);
                direct(c, 0)
            });
        }
        // A single source everywhere with its own gradients: the answer is that source.
        if let ChanSel::Labels(l) = &self.sel {
            let l0 = l[0];
            if params.mode == Mode::Gradient
                && l.iter().all(|&v| v == l0)
                && (params.wrap_guidance == WrapGuidance::Source || !g.periodic)
                && !matches!(params.topology, Topology::Rim { .. })
            {
                return each(&|c, o| {
                    self.composite(&srcs_of(c), params, o);
                    direct(c, self.unknowns)
                });
            }
        }
        if self.unknowns == n {
            let lv0 = Level::new(g.w, g.h, g.periodic, self.free.clone());
            return each(&|c, o| self.transform(&srcs_of(c), params, c, &lv0, o));
        }
        let hier = Hierarchy::new(g.w, g.h, g.periodic, self.free.clone(), params.solver.coarsening);
        let mut reports = Vec::with_capacity(chans.len());
        let mut outs = outs.into_iter();
        for batch in chans.chunks(4) {
            let bo: Vec<&mut [f32]> = outs.by_ref().take(batch.len()).collect();
            reports.extend(match batch.len() {
                1 => self.solve_masked::<f32>(sources, params, warm, &hier, batch, bo),
                _ => self.solve_masked::<F32x4>(sources, params, warm, &hier, batch, bo),
            });
        }
        reports
    }

    /// Nothing fixed: an exact transform solve with the composite's mean, into `f`.
    fn transform(&self, srcs: &[&[f32]], params: &BlendParams, c: usize, lv0: &Level, f: &mut [f32]) -> SolveReport {
        let g = &self.g;
        let (w, h) = (g.w, g.h);
        let n = w * h;
        self.composite(srcs, params, f);
        let (tx, ty) = guidance(g, srcs, &self.sel, params);
        let bnorm = residual::<true>(g, lv0, f, &self.free, &tx, &ty).bb.sqrt();
        let mean = f.iter().map(|&v| v as f64).sum::<f64>() / n as f64;
        let b: Vec<f64> = (0..n).map(|i| -div(g, &tx, &ty, i % w, i / w)).collect();
        let (sol, method) = if g.periodic {
            (solve_periodic(&b, w, h, mean), Method::Periodic)
        } else {
            (solve_neumann(&b, w, h, mean), Method::Neumann)
        };
        for (o, &v) in f.iter_mut().zip(&sol) {
            *o = v as f32;
        }
        let fin = residual::<false>(g, lv0, f, &self.free, &tx, &ty);
        SolveReport {
            channel: c,
            method,
            unknowns: self.unknowns,
            iterations: 0,
            residual: relative(fin.rr.sqrt(), bnorm),
            max_residual: fin.rmax,
            converged: true,
        }
    }

    /// Masked solve of up to `V::N` channels together: channel `chans[k]` in lane k, its
    /// result in `outs[k]`. Each solves for the correction `u = f − f_start`.
    #[allow(clippy::too_many_arguments)]
    fn solve_masked<V: Pooled>(
        &self,
        sources: &[&Image],
        params: &BlendParams,
        warm: Option<&Image>,
        hier: &Hierarchy,
        chans: &[usize],
        mut outs: Vec<&mut [f32]>,
    ) -> Vec<SolveReport> {
        let g = &self.g;
        let n = g.w * g.h;
        let lv0 = &hier.levels[0];
        let mut prepared: Vec<Prepared> = chans
            .iter()
            .zip(outs.iter_mut())
            .map(|(&c, start)| {
                let srcs: Vec<&[f32]> = sources.iter().map(|s| s.plane(c)).collect();
                let (tx, ty, range) = match &self.sel {
                    ChanSel::Labels(l)
                        if srcs.len() == 2 && params.mode == Mode::Gradient && params.seam == Seam::Insert =>
                    {
                        let zero_wrap = params.wrap_guidance == WrapGuidance::Zero;
                        let fused = binary_insert_prep(g, srcs[0], srcs[1], l, zero_wrap, start);
                        if let Topology::Rim { source } = params.topology {
                            apply_rim(start, srcs[source], g.w, g.h);
                        }
                        fused
                    }
                    _ => {
                        self.composite(&srcs, params, start);
                        let (tx, ty) = guidance(g, &srcs, &self.sel, params);
                        (tx, ty, value_range(&srcs))
                    }
                };
                if let Some(wm) = warm {
                    let wp = wm.plane(c);
                    for i in 0..n {
                        if self.free[i] != 0 {
                            start[i] = wp[i];
                        }
                    }
                }
                Prepared { tx, ty, bnorm: 0.0, range }
            })
            .collect();
        let driver = match params.solver.kind {
            SolverKind::Mgpcg => Driver::Pcg,
            SolverKind::Multigrid => Driver::VCycles,
        };
        let cp = CycleParams { pre: params.solver.smooth, post: params.solver.smooth };
        let s = &params.solver;
        // Scratch planes: rhs is written and read on free pixels only; u is zeroed there.
        let mut rhs = V::pool().take(n);
        let mut u = V::pool().take(n);
        let mut bufs = SolveBuffers::<V>::new(hier);
        let mut sums = residual_lanes(g, lv0, &self.free, &lane_views(&prepared, &outs), &mut rhs);
        for (p, s) in prepared.iter_mut().zip(&sums) {
            p.bnorm = s.bb.sqrt();
        }
        let stops: Vec<Stop> = prepared
            .iter()
            .map(|p| Stop {
                norm: s.tol * if p.bnorm > 0.0 { p.bnorm } else { 1.0 },
                max: s.max_tol * p.range,
                max_iter: s.max_iter,
            })
            .collect();
        let met = |k: usize, sums: &[ResidualSums]| sums[k].rr.sqrt() <= stops[k].norm && sums[k].rmax <= stops[k].max;
        let mut iterations = vec![0usize; chans.len()];
        let mut capped = vec![false; chans.len()];
        // Mixed-precision iterative refinement: the solver works in f32 on the correction u,
        // so the f64 residual of the f32 result `f + u` can land just above the bound. Each
        // further round solves for a correction of that residual; lanes that already meet
        // their bound stay at zero.
        for round in 0..=REFINE_ROUNDS {
            lv0.zero(&mut u);
            let stats = multigrid::solve(hier, &mut bufs, &mut rhs, &mut u, &stops, driver, cp);
            for (k, st) in stats.iter().enumerate() {
                iterations[k] += st.iterations;
                capped[k] |= !st.converged;
            }
            add_correction(g, lv0, &u, &mut outs);
            sums = residual_lanes(g, lv0, &self.free, &lane_views(&prepared, &outs), &mut rhs);
            let all_met = (0..chans.len()).all(|k| met(k, &sums));
            if all_met || round == REFINE_ROUNDS || capped.iter().any(|&c| c) {
                break;
            }
        }
        V::pool().give(rhs);
        V::pool().give(u);
        prepared
            .into_iter()
            .enumerate()
            .map(|(lane, p)| {
                f32::pool().give(p.tx);
                f32::pool().give(p.ty);
                SolveReport {
                    channel: chans[lane],
                    method: if driver == Driver::Pcg { Method::Mgpcg } else { Method::Multigrid },
                    unknowns: self.unknowns,
                    iterations: iterations[lane],
                    residual: relative(sums[lane].rr.sqrt(), p.bnorm),
                    max_residual: sums[lane].rmax,
                    converged: !capped[lane] && met(lane, &sums),
                }
            })
            .collect()
    }
}

/// Refinement rounds after the first solve of a masked blend (see `solve_masked`).
const REFINE_ROUNDS: usize = 2;

/// (f, tx, ty) of every lane, for [`residual_lanes`].
fn lane_views<'p>(prepared: &'p [Prepared], outs: &'p [&mut [f32]]) -> Vec<(&'p [f32], &'p [f32], &'p [f32])> {
    prepared.iter().zip(outs).map(|(p, o)| (&o[..], &p.tx[..], &p.ty[..])).collect()
}

/// f += u on the free pixels, every lane in one pass over u.
fn add_correction<V: Lanes>(g: &Graph, lv0: &Level, u: &[V], outs: &mut [&mut [f32]]) {
    let w = g.w;
    let mut planes: Vec<std::slice::ChunksMut<'_, f32>> =
        outs.iter_mut().map(|o| o.chunks_mut(w * ROWS_PER_TASK)).collect();
    let blocks: Vec<Vec<&mut [f32]>> =
        (0..g.h.div_ceil(ROWS_PER_TASK)).map(|_| planes.iter_mut().filter_map(|it| it.next()).collect()).collect();
    blocks.into_par_iter().enumerate().for_each(|(bi, mut block)| {
        for dy in 0..ROWS_PER_TASK.min(g.h - bi * ROWS_PER_TASK) {
            let y = bi * ROWS_PER_TASK + dy;
            for &(x0, x1) in lv0.row_runs(y) {
                for (lane, plane) in block.iter_mut().enumerate() {
                    let frow = &mut plane[dy * w..(dy + 1) * w];
                    for (fv, uv) in frow[x0..x1].iter_mut().zip(&u[y * w + x0..y * w + x1]) {
                        *fv += uv.get(lane);
                    }
                }
            }
        }
    });
}

/// `max − min` over the sources' values (1 when they are constant): the scale that
/// `Solver::max_tol` is relative to.
fn value_range(srcs: &[&[f32]]) -> f64 {
    let (lo, hi) = srcs
        .par_iter()
        .flat_map(|s| s.par_chunks(1 << 16))
        .map(chunk_range)
        .reduce(|| (f32::MAX, f32::MIN), |a, b| (a.0.min(b.0), a.1.max(b.1)));
    range_of(lo, hi)
}

/// `hi − lo`, or 1 when that is not positive.
fn range_of(lo: f32, hi: f32) -> f64 {
    let r = (hi - lo) as f64;
    if r > 0.0 {
        r
    } else {
        1.0
    }
}

/// Exact (min, max) of `c` (eight running extremes, so it vectorises; any order gives the
/// same result).
fn chunk_range(c: &[f32]) -> (f32, f32) {
    let (mut lo, mut hi) = ([f32::MAX; 8], [f32::MIN; 8]);
    let q = c.chunks_exact(8);
    for &v in q.remainder() {
        lo[0] = if v < lo[0] { v } else { lo[0] };
        hi[0] = if v > hi[0] { v } else { hi[0] };
    }
    for q in q {
        for k in 0..8 {
            lo[k] = if q[k] < lo[k] { q[k] } else { lo[k] };
            hi[k] = if q[k] > hi[k] { q[k] } else { hi[k] };
        }
    }
    (lo.iter().fold(f32::MAX, |a, &b| a.min(b)), hi.iter().fold(f32::MIN, |a, &b| a.max(b)))
}

fn relative(rn: f64, bnorm: f64) -> f64 {
    if bnorm > 0.0 {
        rn / bnorm
    } else {
        rn
    }
}

/// Sets the outer rim to `src`'s values averaged over opposite sides (corners: the mean of
/// the four corners), so opposite rim lines are bitwise equal.
fn apply_rim(f: &mut [f32], src: &[f32], w: usize, h: usize) {
    for y in 0..h {
        let v = 0.5 * (src[y * w] + src[y * w + w - 1]);
        f[y * w] = v;
        f[y * w + w - 1] = v;
    }
    for x in 0..w {
        let v = 0.5 * (src[x] + src[(h - 1) * w + x]);
        f[x] = v;
        f[(h - 1) * w + x] = v;
    }
    let corner = 0.25 * (src[0] + src[w - 1] + src[(h - 1) * w] + src[(h - 1) * w + w - 1]);
    for i in [0, w - 1, (h - 1) * w, (h - 1) * w + w - 1] {
        f[i] = corner;
    }
}

/// Free pixels (1) for the domain, minus the rim in rim topology.
fn free_pixels(g: &Graph, sel: &ChanSel<'_>, params: &BlendParams) -> Vec<u8> {
    let (w, h) = (g.w, g.h);
    let n = w * h;
    let mut free: Vec<u8> = match params.domain {
        Domain::Whole => vec![1; n],
        Domain::Mask => match sel {
            ChanSel::Labels(l) => l.iter().map(|&v| (v != 0) as u8).collect(),
            ChanSel::Weights(m) => m.iter().map(|&v| (v > 0.0) as u8).collect(),
        },
        Domain::Band { radius } => {
            let differs = |i: usize, j: usize| match sel {
                ChanSel::Labels(l) => l[i] != l[j],
                ChanSel::Weights(m) => m[i] != m[j],
            };
            let mut seam = vec![0u8; n];
            for y in 0..h {
                for x in 0..w {
                    let i = y * w + x;
                    let nbs = [g.left(x, y), g.right(x, y), g.up(x, y), g.down(x, y)];
                    if nbs.iter().flatten().any(|&j| differs(i, j)) {
                        seam[i] = 1;
                    }
                }
            }
            dilate(&seam, w, h, radius, g.periodic)
        }
    };
    if matches!(params.topology, Topology::Rim { .. }) {
        for y in 0..h {
            for x in 0..w {
                if x == 0 || y == 0 || x == w - 1 || y == h - 1 {
                    free[y * w + x] = 0;
                }
            }
        }
    }
    free
}

/// Chebyshev dilation by `r` (separable running maximum), wrapping when `periodic`.
fn dilate(m: &[u8], w: usize, h: usize, r: usize, periodic: bool) -> Vec<u8> {
    let pass = |src: &[u8], len: usize, count: usize, stride: usize, step: usize| -> Vec<u8> {
        let mut out = vec![0u8; src.len()];
        for line in 0..count {
            let base = line * stride;
            for i in 0..len {
                let mut v = 0u8;
                let ri = r as isize;
                for d in -ri..=ri {
                    let Some(j) = wrap_or_skip(i as isize + d, len, periodic) else { continue };
                    v |= src[base + j * step];
                    if v != 0 {
                        break;
                    }
                }
                out[base + i * step] = v;
            }
        }
        out
    };
    let a = pass(m, w, h, w, 1);
    pass(&a, h, w, 1, w)
}

/// Guidance differences: `tx[p]` is the target of `f(right(p)) − f(p)`, `ty[p]` of
/// `f(down(p)) − f(p)` (unused where the edge does not exist).
fn guidance(g: &Graph, srcs: &[&[f32]], sel: &ChanSel<'_>, params: &BlendParams) -> (Vec<f32>, Vec<f32>) {
    let mixed = params.mode == Mode::Mixed;
    match sel {
        ChanSel::Labels(l) if srcs.len() == 2 && !mixed && params.seam == Seam::Insert => {
            binary_insert_guidance(g, srcs[0], srcs[1], l, params.wrap_guidance == WrapGuidance::Zero)
        }
        ChanSel::Labels(l) => {
            let d = |s: usize, p: usize, q: usize| srcs[s][q] - srcs[s][p];
            if mixed {
                fill_guidance(g, params, |p, q| {
                    let (lp, lq) = (l[p] as usize, l[q] as usize);
                    let mut best = d(lp, p, q);
                    for s in [lq, 0] {
                        let v = d(s, p, q);
                        if v.abs() > best.abs() {
                            best = v;
                        }
                    }
                    best
                })
            } else {
                match params.seam {
                    Seam::Insert => fill_guidance(g, params, |p, q| d(l[p].max(l[q]) as usize, p, q)),
                    Seam::Average => {
                        fill_guidance(g, params, |p, q| 0.5 * (d(l[p] as usize, p, q) + d(l[q] as usize, p, q)))
                    }
                    Seam::Zero => {
                        fill_guidance(g, params, |p, q| if l[p] == l[q] { d(l[p] as usize, p, q) } else { 0.0 })
                    }
                }
            }
        }
        ChanSel::Weights(m) => {
            let (a, b) = (srcs[0], srcs[1]);
            let insert = params.seam == Seam::Insert;
            let weight = |p: usize, q: usize| if insert { m[p].max(m[q]) } else { 0.5 * (m[p] + m[q]) };
            if mixed {
                fill_guidance(g, params, |p, q| {
                    let (da, db) = (a[q] - a[p], b[q] - b[p]);
                    if weight(p, q) > 0.0 && db.abs() >= da.abs() {
                        db
                    } else {
                        da
                    }
                })
            } else {
                fill_guidance(g, params, |p, q| {
                    let wgt = weight(p, q);
                    (1.0 - wgt) * (a[q] - a[p]) + wgt * (b[q] - b[p])
                })
            }
        }
    }
}

/// Two sources, labels 0/1, insert seams (the thesis's case): the edge takes source 1's
/// difference when either end is labelled 1.
fn binary_insert_guidance(g: &Graph, a: &[f32], b: &[f32], l: &[u32], zero_wrap: bool) -> (Vec<f32>, Vec<f32>) {
    let w = g.w;
    let mut tx = vec![0.0f32; w * g.h];
    let mut ty = vec![0.0f32; w * g.h];
    tx.par_chunks_mut(w)
        .zip(ty.par_chunks_mut(w))
        .enumerate()
        .with_min_len(8)
        .for_each(|(y, (rx, ry))| binary_insert_row(g, a, b, l, zero_wrap, y, rx, ry));
    (tx, ty)
}

/// Start of the row below row `y` whose edge to `y` carries guidance: the next row, on a
/// torus the first row after the last (unless the wrap carries none), else none.
fn below(g: &Graph, y: usize, zero_wrap: bool) -> Option<usize> {
    if y + 1 < g.h {
        Some((y + 1) * g.w)
    } else if g.periodic && !zero_wrap {
        Some(0)
    } else {
        None
    }
}

/// Row `y` of [`binary_insert_guidance`], every value of `rx` and `ry` written. Row slices
/// and a branch-free select keep the loops vectorisable.
#[allow(clippy::too_many_arguments)]
#[inline]
fn binary_insert_row(
    g: &Graph,
    a: &[f32],
    b: &[f32],
    l: &[u32],
    zero_wrap: bool,
    y: usize,
    rx: &mut [f32],
    ry: &mut [f32],
) {
    let w = g.w;
    let pick = |lp: u32, lq: u32, da: f32, db: f32| if (lp | lq) != 0 { db } else { da };
    let row = y * w;
    let (ar, br, lr) = (&a[row..row + w], &b[row..row + w], &l[row..row + w]);
    for x in 0..w - 1 {
        rx[x] = pick(lr[x], lr[x + 1], ar[x + 1] - ar[x], br[x + 1] - br[x]);
    }
    rx[w - 1] =
        if g.periodic && !zero_wrap { pick(lr[w - 1], lr[0], ar[0] - ar[w - 1], br[0] - br[w - 1]) } else { 0.0 };
    match below(g, y, zero_wrap) {
        Some(nr) => {
            let (an, bn, ln) = (&a[nr..nr + w], &b[nr..nr + w], &l[nr..nr + w]);
            for x in 0..w {
                ry[x] = pick(lr[x], ln[x], an[x] - ar[x], bn[x] - br[x]);
            }
        }
        None => ry.fill(0.0),
    }
}

/// [`binary_insert_guidance`] fused with the composite (written into `f`) and the sources'
/// value range ([`value_range`]), in one pass over the sources.
fn binary_insert_prep(
    g: &Graph,
    a: &[f32],
    b: &[f32],
    l: &[u32],
    zero_wrap: bool,
    f: &mut [f32],
) -> (Vec<f32>, Vec<f32>, f64) {
    let (w, h) = (g.w, g.h);
    // Scratch planes (every value is written below).
    let mut tx = f32::pool().take(w * h);
    let mut ty = f32::pool().take(w * h);
    let (lo, hi) = tx
        .par_chunks_mut(w)
        .zip(ty.par_chunks_mut(w))
        .zip(f.par_chunks_mut(w))
        .enumerate()
        .with_min_len(8)
        .map(|(y, ((rx, ry), fr))| {
            let row = y * w;
            let (ar, br, lr) = (&a[row..row + w], &b[row..row + w], &l[row..row + w]);
            for x in 0..w {
                fr[x] = if lr[x] != 0 { br[x] } else { ar[x] };
            }
            binary_insert_row(g, a, b, l, zero_wrap, y, rx, ry);
            let (l0, h0) = chunk_range(ar);
            let (l1, h1) = chunk_range(br);
            (l0.min(l1), h0.max(h1))
        })
        .reduce(|| (f32::MAX, f32::MIN), |p, q| (p.0.min(q.0), p.1.max(q.1)));
    (tx, ty, range_of(lo, hi))
}

/// Evaluates `target(p, q)` on every right and down edge of the graph (monomorphised per
/// selector variant, so the inner loops carry no dispatch).
fn fill_guidance(g: &Graph, params: &BlendParams, target: impl Fn(usize, usize) -> f32 + Sync) -> (Vec<f32>, Vec<f32>) {
    let (w, h) = (g.w, g.h);
    let zero_wrap = params.wrap_guidance == WrapGuidance::Zero;
    let mut tx = vec![0.0f32; w * h];
    let mut ty = vec![0.0f32; w * h];
    tx.par_chunks_mut(w).zip(ty.par_chunks_mut(w)).enumerate().with_min_len(8).for_each(|(y, (rx, ry))| {
        let row = y * w;
        for (x, v) in rx.iter_mut().enumerate().take(w.saturating_sub(1)) {
            *v = target(row + x, row + x + 1);
        }
        if g.periodic {
            rx[w - 1] = if zero_wrap { 0.0 } else { target(row + w - 1, row) };
        }
        if let Some(nr) = below(g, y, zero_wrap) {
            for (x, v) in ry.iter_mut().enumerate() {
                *v = target(row + x, nr + x);
            }
        }
    });
    (tx, ty)
}

/// `Σ_q t(p→q)` over the existing edges of p: the divergence of the guidance (so the
/// normal equations read `L f = −div` on the whole graph).
#[inline]
fn div(g: &Graph, tx: &[f32], ty: &[f32], x: usize, y: usize) -> f64 {
    let p = y * g.w + x;
    let mut s = 0.0f64;
    if g.right(x, y).is_some() {
        s += tx[p] as f64;
    }
    if let Some(q) = g.left(x, y) {
        s -= tx[q] as f64;
    }
    if g.down(x, y).is_some() {
        s += ty[p] as f64;
    }
    if let Some(q) = g.up(x, y) {
        s -= ty[q] as f64;
    }
    s
}

/// Sums over free pixels returned by [`residual`].
#[derive(Clone, Copy, Default)]
struct ResidualSums {
    /// `Σ r²` with `r_p = Σ_q (f_q − f_p) − Σ_q t(p→q)`.
    rr: f64,
    /// `max |r|`.
    rmax: f64,
    /// `Σ b²` with `b_p = Σ_{q fixed} f_q − Σ_q t(p→q)` (the normal equations' right-hand
    /// side, fixed values taken from `f`).
    bb: f64,
}

/// Residual of the normal equations on the free pixels (runs of `lv`) of row `y`, in f64;
/// optionally stored (as f32) in `out_row` (the row's slice of a plane). With `WITH_B` the
/// right-hand side's `Σ b²` is summed too (else `bb` is 0). Interior pixels use a
/// branch-free stencil; the image border goes through the graph's neighbour functions.
#[allow(clippy::too_many_arguments)]
#[inline]
fn residual_row<const WITH_B: bool>(
    g: &Graph,
    lv: &Level,
    f: &[f32],
    free: &[u8],
    tx: &[f32],
    ty: &[f32],
    y: usize,
    mut out_row: Option<&mut [f32]>,
) -> ResidualSums {
    let w = g.w;
    let mut acc = ResidualSums::default();
    let generic = |x: usize| -> (f64, f64) {
        let p = y * w + x;
        let fp = f[p] as f64;
        let mut lap = 0.0f64;
        let mut fixed = 0.0f64;
        for q in [g.left(x, y), g.right(x, y), g.up(x, y), g.down(x, y)].into_iter().flatten() {
            lap += f[q] as f64 - fp;
            if free[q] == 0 {
                fixed += f[q] as f64;
            }
        }
        let dv = div(g, tx, ty, x, y);
        (lap - dv, fixed - dv)
    };
    let push = |x: usize, r: f64, b: f64, acc: &mut ResidualSums, out_row: &mut Option<&mut [f32]>| {
        acc.rr += r * r;
        let ra = r.abs();
        acc.rmax = if ra > acc.rmax { ra } else { acc.rmax };
        if WITH_B {
            acc.bb += b * b;
        }
        if let Some(o) = out_row.as_deref_mut() {
            o[x] = r as f32;
        }
    };
    let interior_row = g.periodic || (y > 0 && y + 1 < g.h);
    let (up, dn) = if interior_row { (((y + g.h - 1) % g.h) * w, ((y + 1) % g.h) * w) } else { (0, 0) };
    let row = y * w;
    for &(x0, x1) in lv.row_runs(y) {
        if !interior_row {
            for x in x0..x1 {
                let (r, b) = generic(x);
                push(x, r, b, &mut acc, &mut out_row);
            }
            continue;
        }
        let mut xs = x0;
        let mut xe = x1;
        if xs == 0 {
            let (r, b) = generic(0);
            push(0, r, b, &mut acc, &mut out_row);
            xs = 1;
        }
        let last = xe == w && xe > xs;
        if last {
            xe -= 1;
        }
        if xe > xs {
            let n = xe - xs;
            let (fc, fl, frt) =
                (&f[row + xs..row + xe], &f[row + xs - 1..row + xe - 1], &f[row + xs + 1..row + xe + 1]);
            let (fu, fd) = (&f[up + xs..up + xe], &f[dn + xs..dn + xe]);
            let (txc, txl) = (&tx[row + xs..row + xe], &tx[row + xs - 1..row + xe - 1]);
            let (tyc, tyu) = (&ty[row + xs..row + xe], &ty[up + xs..up + xe]);
            let (frl, frr) = (&free[row + xs - 1..row + xe - 1], &free[row + xs + 1..row + xe + 1]);
            let (fru, frd) = (&free[up + xs..up + xe], &free[dn + xs..dn + xe]);
            let (fc, fl, frt, fu, fd) = (&fc[..n], &fl[..n], &frt[..n], &fu[..n], &fd[..n]);
            let (txc, txl, tyc, tyu) = (&txc[..n], &txl[..n], &tyc[..n], &tyu[..n]);
            let (frl, frr, fru, frd) = (&frl[..n], &frr[..n], &fru[..n], &frd[..n]);
            // Residual and right-hand side of pixel i of the run.
            macro_rules! cell {
                ($i:expr) => {{
                    let i = $i;
                    let nb = [fl[i] as f64, frt[i] as f64, fu[i] as f64, fd[i] as f64];
                    let lap = -4.0 * fc[i] as f64 + nb[0] + nb[1] + nb[2] + nb[3];
                    let dv = txc[i] as f64 - txl[i] as f64 + tyc[i] as f64 - tyu[i] as f64;
                    let b = if WITH_B {
                        let fr = [frl[i], frr[i], fru[i], frd[i]];
                        let mut fixed = 0.0f64;
                        for k in 0..4 {
                            fixed += if fr[k] == 0 { nb[k] } else { 0.0 };
                        }
                        fixed - dv
                    } else {
                        0.0
                    };
                    (lap - dv, b)
                }};
            }
            // Two interleaved accumulators (pixels of even and odd offset), then combined.
            let (mut rr0, mut rr1, mut bb0, mut bb1, mut m0, mut m1) =
                (0.0f64, 0.0f64, 0.0f64, 0.0f64, acc.rmax, acc.rmax);
            let mut o = out_row.as_deref_mut().map(|o| &mut o[xs..xe]);
            let mut i = 0;
            while i + 1 < n {
                let (r0, b0) = cell!(i);
                let (r1, b1) = cell!(i + 1);
                rr0 += r0 * r0;
                rr1 += r1 * r1;
                bb0 += b0 * b0;
                bb1 += b1 * b1;
                let (a0, a1) = (r0.abs(), r1.abs());
                m0 = if a0 > m0 { a0 } else { m0 };
                m1 = if a1 > m1 { a1 } else { m1 };
                if let Some(o) = o.as_deref_mut() {
                    o[i] = r0 as f32;
                    o[i + 1] = r1 as f32;
                }
                i += 2;
            }
            if i < n {
                let (r0, b0) = cell!(i);
                rr0 += r0 * r0;
                bb0 += b0 * b0;
                let a0 = r0.abs();
                m0 = if a0 > m0 { a0 } else { m0 };
                if let Some(o) = o {
                    o[i] = r0 as f32;
                }
            }
            acc.rr += rr0 + rr1;
            if WITH_B {
                acc.bb += bb0 + bb1;
            }
            acc.rmax = m0.max(m1);
        }
        if last {
            let (r, b) = generic(w - 1);
            push(w - 1, r, b, &mut acc, &mut out_row);
        }
    }
    acc
}

fn merge_sums(a: ResidualSums, b: ResidualSums) -> ResidualSums {
    ResidualSums { rr: a.rr + b.rr, rmax: a.rmax.max(b.rmax), bb: a.bb + b.bb }
}

/// [`residual_row`] summed over all rows (fixed blocks of rows, merged in order).
fn residual<const WITH_B: bool>(g: &Graph, lv: &Level, f: &[f32], free: &[u8], tx: &[f32], ty: &[f32]) -> ResidualSums {
    let parts: Vec<ResidualSums> = (0..g.h.div_ceil(ROWS_PER_BLOCK))
        .into_par_iter()
        .map(|bi| {
            let mut acc = ResidualSums::default();
            for y in bi * ROWS_PER_BLOCK..((bi + 1) * ROWS_PER_BLOCK).min(g.h) {
                acc = merge_sums(acc, residual_row::<WITH_B>(g, lv, f, free, tx, ty, y, None));
            }
            acc
        })
        .collect();
    parts.into_iter().fold(ResidualSums::default(), merge_sums)
}

/// The residuals of up to `V::N` channels (`chans[k]` = (f, tx, ty) of lane k), with the
/// right-hand side sums, stored interleaved in `out` on free pixels (one pass over `out`).
fn residual_lanes<V: Lanes>(
    g: &Graph,
    lv: &Level,
    free: &[u8],
    chans: &[(&[f32], &[f32], &[f32])],
    out: &mut [V],
) -> Vec<ResidualSums> {
    let w = g.w;
    let nc = chans.len();
    let parts: Vec<Vec<ResidualSums>> = out
        .par_chunks_mut(w * ROWS_PER_BLOCK)
        .enumerate()
        .map(|(bi, chunk)| {
            let mut acc = vec![ResidualSums::default(); nc];
            let mut rows = vec![vec![0.0f32; w]; nc];
            for (dy, orow) in chunk.chunks_mut(w).enumerate() {
                let y = bi * ROWS_PER_BLOCK + dy;
                for (k, &(f, tx, ty)) in chans.iter().enumerate() {
                    let sums = residual_row::<true>(g, lv, f, free, tx, ty, y, Some(&mut rows[k]));
                    acc[k] = merge_sums(acc[k], sums);
                }
                for &(x0, x1) in lv.row_runs(y) {
                    for x in x0..x1 {
                        orow[x] = V::from_fn(|k| if k < nc { rows[k][x] } else { 0.0 });
                    }
                }
            }
            acc
        })
        .collect();
    (0..nc).map(|k| parts.iter().fold(ResidualSums::default(), |a, p| merge_sums(a, p[k]))).collect()
}
