//! Per-channel assembly (composite, free pixels, guidance) and solver dispatch.
//!
//! This file groups the channels by selector plane and runs each group's solve; the pieces it
//! assembles from live in `validate` (input checks), `grid` (graph, selector, free pixels),
//! `guidance` (the target differences) and `residual` (the f64 residual and its sums).

mod grid;
mod guidance;
mod residual;
mod validate;

use std::borrow::Cow;

use rayon::prelude::*;

use super::lanes::{F32x4, Lanes, Pooled};
use super::multigrid::{self, CycleParams, Driver, Hierarchy, Level, SolveBuffers, Stop};
use super::params::WrapGuidance;
use super::params::{BlendParams, Method, Mode, Run, Seam, Selector, SolveReport, SolverKind, Topology};
use super::spectral::{solve_neumann, solve_periodic};
use crate::raster::Image;
use grid::{apply_rim, free_pixels, ChanSel, Graph};
use guidance::{binary_insert_prep, div, guidance, value_range};
use residual::{relative, residual, residual_lanes, ResidualSums};

pub(super) use validate::validate;

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
    run: &Run<'_>,
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
        for (&c, report) in chans.iter().zip(group.blend(sources, params, run, &chans, outs)) {
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
        run: &Run<'_>,
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
                1 => self.solve_masked::<f32>(sources, params, run, &hier, batch, bo),
                _ => self.solve_masked::<F32x4>(sources, params, run, &hier, batch, bo),
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
        run: &Run<'_>,
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
                if let Some(wm) = run.warm {
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
            let stats = multigrid::solve(hier, &mut bufs, &mut rhs, &mut u, &stops, driver, cp, run.progress);
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
