//! Per-channel assembly (composite, free pixels, guidance) and solver dispatch.

use std::borrow::Cow;

use rayon::prelude::*;

use super::fft::{solve_neumann, solve_periodic};
use super::multigrid::{self, CycleParams, Driver, Hierarchy, Level, SolveBuffers, Stop};
use super::{BlendError, BlendParams, Domain, Method, Mode, Seam, Selector, SolveReport, SolverKind, Topology};
use super::{Image, WrapGuidance};

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
                    name: "labels",
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
        return Err(BlendError::BadParameter { name: "tol", reason: format!("{} is not a positive number", s.tol) });
    }
    if s.max_tol.is_nan() || s.max_tol <= 0.0 {
        return Err(BlendError::BadParameter { name: "max_tol", reason: format!("{} is not positive", s.max_tol) });
    }
    if s.max_iter == 0 {
        return Err(BlendError::BadParameter { name: "max_iter", reason: "must be at least 1".into() });
    }
    if s.smooth == 0 {
        return Err(BlendError::BadParameter { name: "smooth", reason: "must be at least 1".into() });
    }
    if let Topology::Rim { source } = params.topology {
        if source >= sources.len() {
            return Err(BlendError::BadParameter {
                name: "rim source",
                reason: format!("source {source} does not exist ({} given)", sources.len()),
            });
        }
    }
    Ok(())
}

fn check_finite(img: &Image, what: &str) -> Result<(), BlendError> {
    if let Some(i) = img.data.iter().position(|v| !v.is_finite()) {
        let n = img.plane_len();
        let (c, p) = (i / n, i % n);
        return Err(BlendError::NonFinite { what: what.into(), x: p % img.width, y: p / img.width, channel: c });
    }
    Ok(())
}

/// Reuses the multigrid hierarchy across channels that share a free-pixel pattern.
#[derive(Default)]
pub(super) struct HierarchyCache {
    key: Option<usize>,
    hier: Option<(Hierarchy, SolveBuffers)>,
    /// Per-channel planes reused across channels: r, u.
    r: Vec<f32>,
    u: Vec<f32>,
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

pub(super) fn blend_channel(
    sources: &[&Image],
    selector: &Selector<'_>,
    params: &BlendParams,
    warm: Option<&Image>,
    c: usize,
    cache: &mut HierarchyCache,
) -> (Vec<f32>, SolveReport) {
    let (w, h) = (sources[0].width, sources[0].height);
    let n = w * h;
    let g = Graph { w, h, periodic: params.topology == Topology::Torus };
    let srcs: Vec<&[f32]> = sources.iter().map(|s| s.plane(c)).collect();
    let (sel, sel_channel) = match selector {
        Selector::Binary(m) => {
            let sc = if m.channels == 1 { 0 } else { c };
            (ChanSel::Labels(Cow::Owned(m.plane(sc).iter().map(|&v| (v >= 0.5) as u32).collect())), sc)
        }
        Selector::Soft(m) => {
            let sc = if m.channels == 1 { 0 } else { c };
            (ChanSel::Weights(m.plane(sc).iter().map(|&v| v.clamp(0.0, 1.0)).collect()), sc)
        }
        Selector::Labels(l) => (ChanSel::Labels(Cow::Borrowed(l)), 0),
    };

    // Composite f0: the hard composite for labels, the cross-fade for soft masks (Cut
    // thresholds it at 0.5).
    let mut f0: Vec<f32> = match &sel {
        ChanSel::Labels(l) if srcs.len() == 2 => {
            let (a, b) = (srcs[0], srcs[1]);
            let mut f = vec![0.0f32; n];
            f.par_chunks_mut(w).zip(l.par_chunks(w)).enumerate().for_each(|(y, (fr, lr))| {
                let (ar, br) = (&a[y * w..(y + 1) * w], &b[y * w..(y + 1) * w]);
                for x in 0..w {
                    fr[x] = if lr[x] != 0 { br[x] } else { ar[x] };
                }
            });
            f
        }
        ChanSel::Labels(l) => (0..n).into_par_iter().map(|i| srcs[l[i] as usize][i]).collect(),
        ChanSel::Weights(m) => (0..n)
            .into_par_iter()
            .map(|i| {
                if params.mode == Mode::Cut {
                    if m[i] >= 0.5 {
                        srcs[1][i]
                    } else {
                        srcs[0][i]
                    }
                } else {
                    (1.0 - m[i]) * srcs[0][i] + m[i] * srcs[1][i]
                }
            })
            .collect(),
    };

    let free = free_pixels(&g, &sel, params);
    if let Topology::Rim { source } = params.topology {
        apply_rim(&mut f0, srcs[source], w, h);
    }

    let direct = |f: Vec<f32>, unknowns: usize| {
        (
            f,
            SolveReport {
                channel: c,
                method: Method::Direct,
                unknowns,
                iterations: 0,
                residual: 0.0,
                max_residual: 0.0,
                converged: true,
            },
        )
    };

    match params.mode {
        Mode::Cut => return direct(f0, 0),
        Mode::Average => {
            let mut f = f0;
            match &sel {
                ChanSel::Labels(l) => {
                    for i in 0..n {
                        if free[i] != 0 {
                            f[i] = 0.5 * (srcs[0][i] + srcs[l[i] as usize][i]);
                        }
                    }
                }
                ChanSel::Weights(_) => {} // f0 already is the cross-fade
            }
            return direct(f, 0);
        }
        Mode::Gradient | Mode::Mixed => {}
    }

    let unknowns = free.iter().filter(|&&v| v != 0).count();
    if unknowns == 0 {
        return direct(f0, 0);
    }
    // A single source everywhere with its own gradients: the answer is that source.
    if let ChanSel::Labels(l) = &sel {
        let l0 = l[0];
        if params.mode == Mode::Gradient
            && l.iter().all(|&v| v == l0)
            && (params.wrap_guidance == WrapGuidance::Source || !g.periodic)
            && !matches!(params.topology, Topology::Rim { .. })
        {
            return direct(f0, unknowns);
        }
    }

    let (tx, ty) = guidance(&g, &srcs, &sel, params);
    let key = sel_channel;
    if cache.key != Some(key) || cache.hier.is_none() {
        let hier = Hierarchy::new(w, h, g.periodic, free.clone(), params.solver.coarsening);
        let bufs = SolveBuffers::new(&hier);
        cache.hier = Some((hier, bufs));
        cache.key = Some(key);
        cache.r = vec![0.0; n];
        cache.u = vec![0.0; n];
    }
    let (hier, bufs) = cache.hier.as_mut().unwrap();
    let hier = &*hier;
    let lv0 = &hier.levels[0];

    if unknowns == n {
        // Nothing fixed: an exact transform solve with the composite's mean.
        let bnorm = residual(&g, lv0, &f0, &free, &tx, &ty, None).bb.sqrt();
        let mean = f0.iter().map(|&v| v as f64).sum::<f64>() / n as f64;
        let b: Vec<f64> = (0..n).map(|i| -div(&g, &tx, &ty, i % w, i / w)).collect();
        let (sol, method) = if g.periodic {
            (solve_periodic(&b, w, h, mean), Method::Periodic)
        } else {
            (solve_neumann(&b, w, h, mean), Method::Neumann)
        };
        let f: Vec<f32> = sol.iter().map(|&v| v as f32).collect();
        let fin = residual(&g, lv0, &f, &free, &tx, &ty, None);
        let report = SolveReport {
            channel: c,
            method,
            unknowns,
            iterations: 0,
            residual: relative(fin.rr.sqrt(), bnorm),
            max_residual: fin.rmax,
            converged: true,
        };
        return (f, report);
    }

    // Masked solve for the correction u = f − f_start.
    let mut start = f0;
    if let Some(wm) = warm {
        let wp = wm.plane(c);
        for i in 0..n {
            if free[i] != 0 {
                start[i] = wp[i];
            }
        }
    }
    let r = &mut cache.r;
    let sums = residual(&g, lv0, &start, &free, &tx, &ty, Some(r));
    let bnorm = sums.bb.sqrt();
    let u = &mut cache.u;
    lv0.zero(u);
    let driver = match params.solver.kind {
        SolverKind::Mgpcg => Driver::Pcg,
        SolverKind::Multigrid => Driver::VCycles,
    };
    let cp = CycleParams { pre: params.solver.smooth, post: params.solver.smooth };
    let stop = params.solver.tol * if bnorm > 0.0 { bnorm } else { 1.0 };
    let stop_max = params.solver.max_tol * value_range(&srcs);
    let stop = Stop { norm: stop, max: stop_max, max_iter: params.solver.max_iter };
    let stats = multigrid::solve(hier, bufs, r, u, stop, driver, cp);
    let mut f = start;
    for i in 0..n {
        if free[i] != 0 {
            f[i] += u[i];
        }
    }
    let fin = residual(&g, lv0, &f, &free, &tx, &ty, None);
    let report = SolveReport {
        channel: c,
        method: if driver == Driver::Pcg { Method::Mgpcg } else { Method::Multigrid },
        unknowns,
        iterations: stats.iterations,
        residual: relative(fin.rr.sqrt(), bnorm),
        max_residual: fin.rmax,
        converged: stats.converged,
    };
    (f, report)
}

/// `max − min` over the sources' values (1 when they are constant): the scale that
/// `Solver::max_tol` is relative to.
fn value_range(srcs: &[&[f32]]) -> f64 {
    let (mut lo, mut hi) = (f32::MAX, f32::MIN);
    for s in srcs {
        for &v in s.iter() {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    let r = (hi - lo) as f64;
    if r > 0.0 {
        r
    } else {
        1.0
    }
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
                    let j = i as isize + d;
                    let j = if periodic {
                        j.rem_euclid(len as isize) as usize
                    } else if j < 0 || j >= len as isize {
                        continue;
                    } else {
                        j as usize
                    };
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
/// difference when either end is labelled 1. Row slices and a branch-free select keep the
/// loops vectorisable.
fn binary_insert_guidance(g: &Graph, a: &[f32], b: &[f32], l: &[u32], zero_wrap: bool) -> (Vec<f32>, Vec<f32>) {
    let (w, h) = (g.w, g.h);
    let mut tx = vec![0.0f32; w * h];
    let mut ty = vec![0.0f32; w * h];
    let pick = |lp: u32, lq: u32, da: f32, db: f32| if (lp | lq) != 0 { db } else { da };
    tx.par_chunks_mut(w).zip(ty.par_chunks_mut(w)).enumerate().with_min_len(8).for_each(|(y, (rx, ry))| {
        let row = y * w;
        let (ar, br, lr) = (&a[row..row + w], &b[row..row + w], &l[row..row + w]);
        for x in 0..w - 1 {
            rx[x] = pick(lr[x], lr[x + 1], ar[x + 1] - ar[x], br[x + 1] - br[x]);
        }
        if g.periodic {
            rx[w - 1] = if zero_wrap { 0.0 } else { pick(lr[w - 1], lr[0], ar[0] - ar[w - 1], br[0] - br[w - 1]) };
        }
        let next = if y + 1 < h {
            Some(row + w)
        } else if g.periodic && !zero_wrap {
            Some(0)
        } else {
            None
        };
        if let Some(nr) = next {
            let (an, bn, ln) = (&a[nr..nr + w], &b[nr..nr + w], &l[nr..nr + w]);
            for x in 0..w {
                ry[x] = pick(lr[x], ln[x], an[x] - ar[x], bn[x] - br[x]);
            }
        }
    });
    (tx, ty)
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
        let next = if y + 1 < h {
            Some(row + w)
        } else if g.periodic && !zero_wrap {
            Some(0)
        } else {
            None
        };
        if let Some(nr) = next {
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

/// Residual of the normal equations at the free pixels of `lv` (runs of `free`), in f64;
/// optionally stored (as f32) in `out`. Interior pixels use a branch-free stencil; the image
/// border goes through the graph's neighbour functions.
fn residual(
    g: &Graph,
    lv: &Level,
    f: &[f32],
    free: &[u8],
    tx: &[f32],
    ty: &[f32],
    out: Option<&mut [f32]>,
) -> ResidualSums {
    let w = g.w;
    let row_fn = |y: usize, mut orow: Option<&mut [f32]>| -> ResidualSums {
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
        let mut push = |x: usize, r: f64, b: f64, acc: &mut ResidualSums| {
            acc.rr += r * r;
            acc.rmax = acc.rmax.max(r.abs());
            acc.bb += b * b;
            if let Some(o) = orow.as_deref_mut() {
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
                    push(x, r, b, &mut acc);
                }
                continue;
            }
            let mut xs = x0;
            let mut xe = x1;
            if xs == 0 {
                let (r, b) = generic(0);
                push(0, r, b, &mut acc);
                xs = 1;
            }
            let last = xe == w && xe > xs;
            if last {
                xe -= 1;
            }
            for x in xs..xe {
                let p = row + x;
                let fp = f[p] as f64;
                let nb = [f[p - 1], f[p + 1], f[up + x], f[dn + x]];
                let fr = [free[p - 1], free[p + 1], free[up + x], free[dn + x]];
                let mut lap = -4.0 * fp;
                let mut fixed = 0.0f64;
                for k in 0..4 {
                    let v = nb[k] as f64;
                    lap += v;
                    if fr[k] == 0 {
                        fixed += v;
                    }
                }
                let dv = tx[p] as f64 - tx[p - 1] as f64 + ty[p] as f64 - ty[up + x] as f64;
                push(x, lap - dv, fixed - dv, &mut acc);
            }
            if last {
                let (r, b) = generic(w - 1);
                push(w - 1, r, b, &mut acc);
            }
        }
        acc
    };
    let merge =
        |a: ResidualSums, b: ResidualSums| ResidualSums { rr: a.rr + b.rr, rmax: a.rmax.max(b.rmax), bb: a.bb + b.bb };
    let parts: Vec<ResidualSums> = match out {
        Some(o) => o
            .par_chunks_mut(w * ROWS_PER_BLOCK)
            .enumerate()
            .map(|(bi, chunk)| {
                let mut acc = ResidualSums::default();
                for (dy, orow) in chunk.chunks_mut(w).enumerate() {
                    acc = merge(acc, row_fn(bi * ROWS_PER_BLOCK + dy, Some(orow)));
                }
                acc
            })
            .collect(),
        None => (0..g.h.div_ceil(ROWS_PER_BLOCK))
            .into_par_iter()
            .map(|bi| {
                let mut acc = ResidualSums::default();
                for y in bi * ROWS_PER_BLOCK..((bi + 1) * ROWS_PER_BLOCK).min(g.h) {
                    acc = merge(acc, row_fn(y, None));
                }
                acc
            })
            .collect(),
    };
    parts.into_iter().fold(ResidualSums::default(), merge)
}
