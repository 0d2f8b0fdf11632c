//! Stage 2 of the statistical structure synthesis: correcting region shapes
//! ("micro-positioning", digest 004 §2.9, Algorithms 2 and 3, V13–V15).
//!
//! **Association (Algorithm 2).** Every eligible region is associated with its closest
//! original shape ([`associate`]: smallest turning distance among the originals within
//! `±area_tol` of its area, widened up to `max_tol`, then nearest area). The original is
//! placed with its centroid on the region's centroid and, when allowed, rotated by the best
//! turning-function rotation; each region vertex then gets a *target* on the placed original:
//! * [`TargetRule::ClosestVertex`]: the closest vertex of the placed original (Algorithm 2
//!   verbatim);
//! * [`TargetRule::MatchedCorners`] (default): each corner of the placed original (turn
//!   above 5°) is the target of the region vertex closest to it, if that corner is also the
//!   vertex's closest corner; every other vertex targets the closest point of the placed
//!   original's boundary.
//!
//! The verbatim rule sends several vertices to one original vertex (they fold into zigzags,
//! which the turning distance punishes) and drags vertices that lie on a straight side of
//! the original (T-junctions of a brick wall) along that side to whatever original vertex is
//! nearest; on the `wall_regular` stand-in the error then rises after two iterations. The
//! default keeps the thesis's "closest vertex" for the corners that define the shape and
//! lets the other vertices settle on the original's outline.
//!
//! **Optimisation (Algorithm 3).** One iteration
//! 1. moves every vertex `v` by `step · D_m`, `D_m` the mean of the vectors from `v` to its
//!    targets (one per adjacent associated region);
//! 2. runs the *distribution check* (V15) on the structure's edges, i.e. the chains of the
//!    mesh between junctions (vertices with a valency other than 2, or pinned), since
//!    polygonisation leaves valency-2 vertices along every boundary: a chain whose chord is
//!    outside `[P1, P99]` of the original edge lengths has its ends pulled along the chord
//!    towards the nearest percentile by `step` times the length error (half each, or all of
//!    it on the only movable end), its inner vertices following linearly along the chain;
//! 3. collapses edges shorter than `min_edge` (`merge_each_iteration`, default on): the
//!    vertices sent to the same original vertex meet there.
//!
//! **Error and stopping (V14).** The mean shape error is the mean turning distance between
//! each associated region and its closest original (a fresh association, measured after
//! every iteration; the targets themselves are only recomputed every `reassociate_every`
//! iterations, as the thesis recomputes "from time to time"). An iteration that raises the
//! error is undone and the associations are recomputed at once; if the iteration had fresh
//! associations already, the optimisation stops ([`StopReason::NoDescent`]). Otherwise it
//! stops when the error falls below `tol`, when the relative improvement stays under
//! `stall_rel` for `stall_iters` kept iterations in a row, or after `max_iters` iterations
//! (kept and undone).
//!
//! **Constraints.**
//! * `fixed` vertices (occupancy borders, frozen vertices; F18) never move and are never
//!   merged away;
//! * `border` vertices (on the domain rectangle `[0, w] × [0, h]`) only slide along their
//!   side; corners, and border-flagged vertices on no side, do not move;
//! * validity guard: every single vertex move is checked against the current mesh: the
//!   regions around the vertex must keep a positive signed area, and the edges at the vertex
//!   must not cross, touch or overlap any other edge of those regions (edges away from the
//!   vertex do not move, so this keeps every polygon simple and the tiling free of overlaps
//!   and flips). An invalid move is retried with half the step, at most `max_halvings`
//!   times, then skipped ([`ShapeResult::rejected_moves`]). Merges are checked the same way.
//!
//! The mesh is therefore valid at every iteration, provided the input is.
//!
//! **Final clean-up.** Edges shorter than `min_edge` are collapsed (polygonisation's
//! `min_edge`: "merge vertices closer than `min_edge`"), then valency-2 vertices turning by
//! less than `straight_deg` are removed (polygonisation's `straight` rule; stage 2 lines
//! vertices up along the originals' sides). Only the two ends of an edge are merged; a
//! collapse is skipped if it would leave a region with fewer than 3 vertices, pinch a region
//! (visit a vertex twice), break validity or move a fixed vertex (two fixed ends: skipped; one
//! fixed end: the merged vertex stays on it; a border end keeps the merged vertex on the
//! border). The final mesh is associated once more for the "closest shape" view.
//!
//! Regions *cut* by the domain or an occupancy border (any vertex `border` or `fixed`) are not
//! associated by default (`include_border_regions = false`, as the statistics exclude border
//! regions, V30): their shape is an artefact of the cut. Their vertices still move when an
//! adjacent associated region gives them a target. Chains with both ends pinned are skipped by
//! the distribution check for the same reason.
//!
//! Determinism: targets, errors and associations are computed in parallel per item and
//! collected in order; moves, merges and removals are validated and applied sequentially in
//! index order. The result is bit-identical for any rayon thread count.

use crate::synth::structure::analysis::stats::percentile;
use crate::synth::structure::mesh::faces::signed_area;
use crate::synth::structure::shapes::associate::{associate, AssociateParams, Association};
use crate::synth::structure::types::{Mesh, Point};
use crate::synth::structure::validate::{point_segment_distance, segment_contact};
use rayon::prelude::*;
use std::collections::HashSet;

/// Options of [`optimize_shapes`] (`shapes.*`, `polygonize.min_edge`; digest §2.9 [PROPOSAL]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapeParams {
    /// Fraction of the mean target vector applied per iteration (`shapes.step`, 0.2).
    pub step: f64,
    /// Most iterations (`shapes.max_iters`, 50).
    pub max_iters: usize,
    /// Recompute the associations (and targets) after this many iterations (10; 0 = only
    /// when an iteration raised the error).
    pub reassociate_every: usize,
    /// Relative area tolerance of the association (`shapes.area_tol`, 0.2).
    pub area_tol: f64,
    /// Widening step and largest widened tolerance of the association fallback (V13).
    pub widen_step: f64,
    pub max_tol: f64,
    /// Rotate the placed originals by the best turning-function rotation
    /// (`shapes.allow_rotation`, true).
    pub allow_rotation: bool,
    /// Stop when the mean shape error is below this (`shapes.tol`, 0.05).
    pub tol: f64,
    /// Stall rule: stop when the relative improvement of the error stays below `stall_rel`
    /// (0.01) for `stall_iters` (5) kept iterations in a row (0 disables the rule).
    pub stall_rel: f64,
    pub stall_iters: usize,
    /// Step halvings tried before a move is skipped (3).
    pub max_halvings: u32,
    /// Run the edge-length distribution check (V15).
    pub distribution_check: bool,
    /// Percentiles of the original edge lengths bounding the accepted range (`[0.01, 0.99]`).
    pub edge_percentiles: [f64; 2],
    /// Edges shorter than this are collapsed after optimisation, and after every iteration
    /// with `merge_each_iteration` (`polygonize.min_edge`, 2 px).
    pub min_edge: f64,
    /// Associate (and so reshape) regions cut by the domain or occupancy border too.
    pub include_border_regions: bool,
    /// Also collapse edges shorter than `min_edge` at the end of every iteration (not only
    /// after the last one): vertices sent to the same original vertex meet there, and left
    /// apart they fold into zigzags that the turning distance punishes.
    pub merge_each_iteration: bool,
    /// How region vertices get their targets on the placed original.
    pub targets: TargetRule,
    /// At the end, remove valency-2 vertices turning by less than this (degrees;
    /// `polygonize.straight`, 5°; 0 keeps them).
    pub straight_deg: f64,
}

/// How the vertices of a generated region are linked to its placed original.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TargetRule {
    /// Algorithm 2 verbatim: every vertex goes to the closest vertex of the placed original.
    ClosestVertex,
    /// Each corner of the placed original (turn above 5°) pulls the closest region vertex if
    /// that vertex has it as its own closest corner (mutual nearest); every other vertex goes
    /// to the closest point of the placed original's boundary.
    MatchedCorners,
}

impl Default for ShapeParams {
    fn default() -> Self {
        ShapeParams {
            step: 0.2,
            max_iters: 50,
            reassociate_every: 10,
            area_tol: 0.2,
            widen_step: 0.1,
            max_tol: 0.5,
            allow_rotation: true,
            tol: 0.05,
            stall_rel: 0.01,
            stall_iters: 5,
            max_halvings: 3,
            distribution_check: true,
            edge_percentiles: [0.01, 0.99],
            min_edge: 2.0,
            include_border_regions: false,
            merge_each_iteration: true,
            targets: TargetRule::MatchedCorners,
            straight_deg: 5.0,
        }
    }
}

impl ShapeParams {
    fn associate_params(&self) -> AssociateParams {
        AssociateParams {
            area_tol: self.area_tol,
            widen_step: self.widen_step,
            max_tol: self.max_tol,
            allow_rotation: self.allow_rotation,
        }
    }
}

/// Why the iteration stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    /// The mean shape error fell below `tol`.
    Converged,
    /// The relative improvement stayed below `stall_rel` for `stall_iters` iterations.
    Stalled,
    /// `max_iters` iterations were run.
    MaxIters,
    /// An iteration run with freshly computed associations raised the error (it was undone).
    NoDescent,
    /// No region could be associated (nothing to optimise).
    NothingToDo,
}

/// The result of [`optimize_shapes`].
#[derive(Clone, Debug, PartialEq)]
pub struct ShapeResult {
    /// The optimised mesh. Regions keep their indices; merged vertices are removed and the
    /// vertices renumbered (see `vertex_map`).
    pub mesh: Mesh,
    /// For each input vertex, its vertex in `mesh` (merged vertices share one; `None` for
    /// straight valency-2 vertices removed at the end).
    pub vertex_map: Vec<Option<usize>>,
    /// Per output vertex: fixed, and on the domain border (merges combine the flags).
    pub fixed: Vec<bool>,
    pub border: Vec<bool>,
    /// The closest original of every region of the final mesh (`None`: not associated, e.g.
    /// a cut region when `include_border_regions` is off): original index, turning distance,
    /// how it was found, and the placed polygon (for a "closest shape" debug view).
    pub associations: Vec<Option<Association>>,
    /// Mean shape error (mean turning distance of the associated regions to their closest
    /// originals): `errors[0]` for the input mesh, then one value per kept iteration.
    pub errors: Vec<f64>,
    /// Mean shape error of the final (merged, re-associated) mesh.
    pub final_error: f64,
    /// Iterations run (kept and undone).
    pub iterations: usize,
    pub stop: StopReason,
    /// Association rounds that set targets (the initial one included, the final one for
    /// `associations` not).
    pub association_rounds: usize,
    /// Associations found with a widened tolerance or by nearest area, over all rounds
    /// (the final association included).
    pub fallback_associations: usize,
    /// Regions that could not be associated (degenerate), over all rounds.
    pub failed_associations: usize,
    /// Fallback and failure messages of all rounds.
    pub log: Vec<String>,
    /// Vertex moves skipped after `max_halvings` halvings (shape and distribution steps).
    pub rejected_moves: usize,
    /// Vertex moves accepted only after at least one halving.
    pub halved_moves: usize,
    /// Chain corrections requested by the distribution check, over all iterations (undone
    /// ones included).
    pub distribution_corrections: usize,
    /// Iterations undone because they raised the mean shape error.
    pub rolled_back: usize,
    /// Vertices removed by merges (during the iterations and at the end).
    pub merged_vertices: usize,
    /// Straight valency-2 vertices removed at the end.
    pub straightened_vertices: usize,
}

/// How a vertex may move.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Freedom {
    Free,
    /// Only coordinate `axis` may change; the other one stays at `value`.
    Slide {
        axis: usize,
        value: f64,
    },
    Locked,
}

fn freedom(p: Point, fixed: bool, border: bool, domain: [f64; 2], eps: f64) -> Freedom {
    if fixed {
        return Freedom::Locked;
    }
    if !border {
        return Freedom::Free;
    }
    let on_x = if p[0].abs() <= eps {
        Some(0.0)
    } else if (p[0] - domain[0]).abs() <= eps {
        Some(domain[0])
    } else {
        None
    };
    let on_y = if p[1].abs() <= eps {
        Some(0.0)
    } else if (p[1] - domain[1]).abs() <= eps {
        Some(domain[1])
    } else {
        None
    };
    match (on_x, on_y) {
        (Some(x), None) => Freedom::Slide { axis: 1, value: x },
        (None, Some(y)) => Freedom::Slide { axis: 0, value: y },
        // A corner, or flagged as border but on no side: it cannot slide.
        _ => Freedom::Locked,
    }
}

/// The position after displacing `p` by `d` under `f` (`None` if it cannot move).
fn constrained(p: Point, d: Point, f: Freedom, domain: [f64; 2]) -> Option<Point> {
    match f {
        Freedom::Free => Some([p[0] + d[0], p[1] + d[1]]),
        Freedom::Slide { axis, value } => {
            let mut q = [0.0; 2];
            q[axis] = (p[axis] + d[axis]).clamp(0.0, domain[axis]);
            q[1 - axis] = value;
            Some(q)
        }
        Freedom::Locked => None,
    }
}

/// Whether the edge `(v, u)` (`v` at its new position) conflicts with the edge `(a, b)`:
/// crossing, touching away from shared ends, or overlapping collinearly.
fn edges_conflict(pos: &impl Fn(usize) -> Point, v: usize, u: usize, a: usize, b: usize, eps: f64) -> bool {
    if (a == v && b == u) || (a == u && b == v) {
        return false;
    }
    let (pv, pu, pa, pb) = (pos(v), pos(u), pos(a), pos(b));
    // A shared end: the two segments only meet elsewhere by folding onto each other.
    let shared = if a == v || a == u {
        Some((a, b))
    } else if b == v || b == u {
        Some((b, a))
    } else {
        None
    };
    match shared {
        Some((s, o)) => {
            let eo = if s == v { pu } else { pv };
            let po = pos(o);
            let ps = pos(s);
            point_segment_distance(po, ps, eo) <= eps || point_segment_distance(eo, ps, po) <= eps
        }
        None => segment_contact(pv, pu, pa, pb, eps).is_some(),
    }
}

/// Validity of the star of `v` after a change that only touches edges at `v`: every cycle
/// has at least 3 distinct vertices and a positive signed area, and no edge at `v` conflicts
/// with any other edge of the cycles. `cycles` are all the regions containing `v`.
fn star_valid(pos: &impl Fn(usize) -> Point, cycles: &[&[usize]], v: usize, eps: f64) -> bool {
    let mut spokes: Vec<usize> = Vec::with_capacity(8);
    for c in cycles {
        let n = c.len();
        if n < 3 {
            return false;
        }
        let poly: Vec<Point> = c.iter().map(|&i| pos(i)).collect();
        if signed_area(&poly).is_nan() || signed_area(&poly) <= 0.0 {
            return false;
        }
        for k in 0..n {
            if c[k] == v {
                for u in [c[(k + n - 1) % n], c[(k + 1) % n]] {
                    if !spokes.contains(&u) {
                        spokes.push(u);
                    }
                }
            }
        }
    }
    for &u in &spokes {
        for c in cycles {
            let n = c.len();
            for k in 0..n {
                let (a, b) = (c[k], c[(k + 1) % n]);
                if edges_conflict(pos, v, u, a, b, eps) {
                    return false;
                }
            }
        }
    }
    true
}

/// The distinct vertex indices of a cycle.
fn distinct(c: &[usize]) -> bool {
    let mut s: Vec<usize> = c.to_vec();
    s.sort_unstable();
    s.windows(2).all(|w| w[0] != w[1])
}

/// An association in force during the iterations.
#[derive(Clone)]
struct Active {
    /// `(vertex, target)` for the vertices of the region's current cycle.
    targets: Vec<(usize, Point)>,
}

impl Active {
    /// Vertex `removed` was merged into `kept`: `kept` keeps its own target if it has one,
    /// otherwise it takes over the removed vertex's.
    fn merge(&mut self, removed: usize, kept: usize) {
        let has_kept = self.targets.iter().any(|t| t.0 == kept);
        if has_kept {
            self.targets.retain(|t| t.0 != removed);
        } else {
            for t in &mut self.targets {
                if t.0 == removed {
                    t.0 = kept;
                }
            }
        }
    }
}

struct Round {
    associations: Vec<Option<Association>>,
    fallbacks: usize,
    failed: usize,
    log: Vec<String>,
}

/// Associates the eligible regions (Algorithm 2); others get `None`.
fn associate_regions(
    verts: &[Point],
    regions: &[Vec<usize>],
    eligible: &[bool],
    originals: &[Vec<Point>],
    params: &ShapeParams,
) -> Round {
    let ids: Vec<usize> = (0..regions.len()).filter(|&r| eligible[r]).collect();
    let polys: Vec<Vec<Point>> = ids.iter().map(|&r| regions[r].iter().map(|&i| verts[i]).collect()).collect();
    let mut associations = vec![None; regions.len()];
    if originals.is_empty() || polys.is_empty() {
        return Round { associations, fallbacks: 0, failed: 0, log: Vec::new() };
    }
    let report = associate(&polys, originals, &params.associate_params());
    for (k, a) in report.associations.into_iter().enumerate() {
        associations[ids[k]] = a;
    }
    // Messages name the position in `polys`; rewrite them with region indices.
    let log = report
        .log
        .into_iter()
        .map(|m| match m.strip_prefix("region ").and_then(|rest| rest.split_once(':')) {
            Some((k, rest)) => match k.parse::<usize>() {
                Ok(k) if k < ids.len() => format!("region {}:{rest}", ids[k]),
                _ => m,
            },
            None => m,
        })
        .collect();
    Round { associations, fallbacks: report.widened + report.nearest_area, failed: report.failed, log }
}

/// The target of every vertex of `poly` on the placed original.
fn vertex_targets(poly: &[Point], placed: &[Point], rule: TargetRule) -> Vec<Point> {
    match rule {
        TargetRule::ClosestVertex => poly
            .iter()
            .map(|p| {
                let mut best = (f64::INFINITY, *p);
                for q in placed {
                    let d = (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2);
                    if d < best.0 {
                        best = (d, *q);
                    }
                }
                best.1
            })
            .collect(),
        TargetRule::MatchedCorners => matched_corner_targets(poly, placed),
    }
}

/// Targets of [`TargetRule::MatchedCorners`] for the vertices of `poly`.
fn matched_corner_targets(poly: &[Point], placed: &[Point]) -> Vec<Point> {
    let m = placed.len();
    let d2 = |a: Point, b: Point| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2);
    let corners: Vec<Point> = (0..m)
        .filter(|&k| {
            crate::synth::structure::analysis::stats::turn_angle(
                placed[(k + m - 1) % m],
                placed[k],
                placed[(k + 1) % m],
            )
            .abs()
                > 5f64.to_radians()
        })
        .map(|k| placed[k])
        .collect();
    let nearest = |p: Point, set: &[Point]| -> Option<usize> {
        let mut best: Option<(usize, f64)> = None;
        for (k, &q) in set.iter().enumerate() {
            let d = d2(p, q);
            if best.is_none_or(|b| d < b.1) {
                best = Some((k, d));
            }
        }
        best.map(|b| b.0)
    };
    poly.iter()
        .enumerate()
        .map(|(i, &p)| {
            if let Some(c) = nearest(p, &corners) {
                if nearest(corners[c], poly) == Some(i) {
                    return corners[c];
                }
            }
            // The closest point of the boundary.
            let mut best = (f64::INFINITY, p);
            for k in 0..m {
                let (a, b) = (placed[k], placed[(k + 1) % m]);
                let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
                let l2 = dx * dx + dy * dy;
                let t = if l2 > 0.0 { (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0) } else { 0.0 };
                let q = [a[0] + t * dx, a[1] + t * dy];
                let d = d2(p, q);
                if d < best.0 {
                    best = (d, q);
                }
            }
            best.1
        })
        .collect()
}

/// Mean turning distance between each eligible region and its closest original (a fresh
/// association).
fn closest_error(
    verts: &[Point],
    regions: &[Vec<usize>],
    eligible: &[bool],
    originals: &[Vec<Point>],
    params: &ShapeParams,
) -> f64 {
    mean_distance(&associate_regions(verts, regions, eligible, originals, params).associations)
}

/// Mean turning distance of the associations (`0` if there are none).
fn mean_distance(associations: &[Option<Association>]) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for a in associations.iter().flatten() {
        if a.distance.is_finite() {
            sum += a.distance;
            n += 1;
        }
    }
    if n == 0 {
        0.0
    } else {
        sum / n as f64
    }
}

/// `[P_lo, P_hi]` of the original edge lengths (edges shared by two originals counted once).
fn edge_length_range(originals: &[Vec<Point>], q: [f64; 2]) -> Option<[f64; 2]> {
    let mut seen: HashSet<[u64; 4]> = HashSet::new();
    let mut lengths = Vec::new();
    for poly in originals {
        let n = poly.len();
        for k in 0..n {
            let (a, b) = (poly[k], poly[(k + 1) % n]);
            let (ka, kb) = ([a[0].to_bits(), a[1].to_bits()], [b[0].to_bits(), b[1].to_bits()]);
            let key = if ka <= kb { [ka[0], ka[1], kb[0], kb[1]] } else { [kb[0], kb[1], ka[0], ka[1]] };
            if seen.insert(key) {
                let l = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
                if l > 0.0 && l.is_finite() {
                    lengths.push(l);
                }
            }
        }
    }
    if lengths.is_empty() {
        return None;
    }
    lengths.sort_by(f64::total_cmp);
    Some([percentile(&lengths, q[0]), percentile(&lengths, q[1])])
}

/// The distinct edges of the cycles, sorted.
fn mesh_edges(regions: &[Vec<usize>]) -> Vec<[usize; 2]> {
    let mut e: Vec<[usize; 2]> = Vec::new();
    for c in regions {
        for k in 0..c.len() {
            let (a, b) = (c[k], c[(k + 1) % c.len()]);
            if a != b {
                e.push([a.min(b), a.max(b)]);
            }
        }
    }
    e.sort_unstable();
    e.dedup();
    e
}

/// Mutable optimisation state.
#[derive(Clone)]
struct State<'a> {
    verts: Vec<Point>,
    regions: Vec<Vec<usize>>,
    /// Per vertex: the regions containing it and the vertex's position in each cycle.
    incidence: Vec<Vec<(usize, usize)>>,
    freedom: Vec<Freedom>,
    domain: [f64; 2],
    eps: f64,
    params: &'a ShapeParams,
    rejected: usize,
    halved: usize,
}

impl<'a> State<'a> {
    fn new(mesh: &Mesh, fixed: &[bool], border: &[bool], domain: [f64; 2], params: &'a ShapeParams) -> State<'a> {
        let nv = mesh.vertices.len();
        let eps = 1e-9 * (domain[0].abs() + domain[1].abs()).max(1.0);
        let freedom: Vec<Freedom> =
            (0..nv).map(|v| freedom(mesh.vertices[v], fixed[v], border[v], domain, eps)).collect();
        let mut incidence: Vec<Vec<(usize, usize)>> = vec![Vec::new(); nv];
        for (r, c) in mesh.regions.iter().enumerate() {
            for (k, &v) in c.iter().enumerate() {
                incidence[v].push((r, k));
            }
        }
        State {
            verts: mesh.vertices.clone(),
            regions: mesh.regions.clone(),
            incidence,
            freedom,
            domain,
            eps,
            params,
            rejected: 0,
            halved: 0,
        }
    }

    /// Tries to move `v` by `d` (constrained), halving up to `max_halvings` times.
    fn try_move(&mut self, v: usize, d: Point) {
        if d[0] == 0.0 && d[1] == 0.0 {
            return;
        }
        let f = self.freedom[v];
        let p = self.verts[v];
        let mut scale = 1.0;
        for attempt in 0..=self.params.max_halvings {
            let Some(q) = constrained(p, [d[0] * scale, d[1] * scale], f, self.domain) else {
                return;
            };
            if q == p {
                return;
            }
            if self.valid_at(v, q) {
                self.verts[v] = q;
                if attempt > 0 {
                    self.halved += 1;
                }
                return;
            }
            scale *= 0.5;
        }
        self.rejected += 1;
    }

    fn valid_at(&self, v: usize, q: Point) -> bool {
        let e = self.eps;
        if !(q[0] >= -e && q[1] >= -e && q[0] <= self.domain[0] + e && q[1] <= self.domain[1] + e) {
            return false;
        }
        let verts = &self.verts;
        let pos = |i: usize| if i == v { q } else { verts[i] };
        let cycles: Vec<&[usize]> = self.incidence[v].iter().map(|&(r, _)| self.regions[r].as_slice()).collect();
        star_valid(&pos, &cycles, v, e)
    }
}

/// Stage-2 shape optimisation (digest §2.9) of a valid mesh tiling (part of) the domain
/// `[0, width] × [0, height]`. `fixed[v]`: the vertex never moves; `border[v]`: the vertex is
/// on the domain border and may only slide along it. `originals` are the sample's region
/// polygons, already scaled by the structure's scale.
///
/// # Panics
/// If `fixed` or `border` does not have one entry per mesh vertex.
pub fn optimize_shapes(
    mesh: &Mesh,
    fixed: &[bool],
    border: &[bool],
    domain: (f64, f64),
    originals: &[Vec<Point>],
    params: &ShapeParams,
) -> ShapeResult {
    optimize_shapes_observed(mesh, fixed, border, domain, originals, params, |_, _, _| {})
}

/// [`optimize_shapes`], calling `observe(k, vertices, regions)` with the mesh of the input
/// (`k = 0`) and after every iteration `k` (vertex indices are those of the input; merged
/// vertices no longer appear in the cycles). The final merge happens after the last call.
pub fn optimize_shapes_observed(
    mesh: &Mesh,
    fixed: &[bool],
    border: &[bool],
    domain: (f64, f64),
    originals: &[Vec<Point>],
    params: &ShapeParams,
    mut observe: impl FnMut(usize, &[Point], &[Vec<usize>]),
) -> ShapeResult {
    let nv = mesh.vertices.len();
    assert_eq!(fixed.len(), nv, "one `fixed` flag per vertex");
    assert_eq!(border.len(), nv, "one `border` flag per vertex");
    let eligible: Vec<bool> = mesh
        .regions
        .iter()
        .map(|c| c.len() >= 3 && (params.include_border_regions || c.iter().all(|&v| !fixed[v] && !border[v])))
        .collect();
    let mut st = State::new(mesh, fixed, border, [domain.0, domain.1], params);
    let range = if params.distribution_check { edge_length_range(originals, params.edge_percentiles) } else { None };

    let mut fallbacks = 0;
    let mut failed = 0;
    let mut log = Vec::new();
    let mut rounds = 0;
    let mut active: Vec<Option<Active>> = Vec::new();
    let mut reassociate = |st: &State, active: &mut Vec<Option<Active>>| {
        let round = associate_regions(&st.verts, &st.regions, &eligible, originals, params);
        fallbacks += round.fallbacks;
        failed += round.failed;
        log.extend(round.log);
        *active = round
            .associations
            .into_iter()
            .enumerate()
            .map(|(r, a)| {
                a.map(|a| {
                    let poly: Vec<Point> = st.regions[r].iter().map(|&v| st.verts[v]).collect();
                    let targets =
                        st.regions[r].iter().copied().zip(vertex_targets(&poly, &a.placed, params.targets)).collect();
                    Active { targets }
                })
            })
            .collect();
    };
    reassociate(&st, &mut active);
    rounds += 1;
    let mut errors = vec![closest_error(&st.verts, &st.regions, &eligible, originals, params)];
    observe(0, &st.verts, &st.regions);
    let mut fixed_out: Vec<bool> = fixed.to_vec();
    let mut border_out: Vec<bool> = border.to_vec();
    let mut merged_into: Vec<Option<usize>> = vec![None; nv];
    let mut stop = StopReason::MaxIters;
    let mut iterations = 0;
    let mut stall = 0;
    let mut corrections = 0;
    let mut rolled_back = 0;
    if active.iter().all(|a| a.is_none()) {
        stop = StopReason::NothingToDo;
    } else if errors[0] < params.tol {
        stop = StopReason::Converged;
    } else {
        // Iterations since the targets were last computed.
        let mut since = 0;
        for it in 1..=params.max_iters {
            if params.reassociate_every > 0 && since >= params.reassociate_every {
                reassociate(&st, &mut active);
                rounds += 1;
                since = 0;
            }
            let saved = (st.clone(), active.clone(), fixed_out.clone(), border_out.clone(), merged_into.clone());
            // Algorithm 3: the mean vector to the targets of the adjacent associated regions.
            let disp: Vec<Point> = (0..nv)
                .into_par_iter()
                .map(|v| {
                    if st.freedom[v] == Freedom::Locked {
                        return [0.0, 0.0];
                    }
                    let p = st.verts[v];
                    let (mut sx, mut sy, mut n) = (0.0, 0.0, 0usize);
                    for &(r, _) in &st.incidence[v] {
                        if let Some(&(_, t)) = active[r].as_ref().and_then(|a| a.targets.iter().find(|t| t.0 == v)) {
                            sx += t[0] - p[0];
                            sy += t[1] - p[1];
                            n += 1;
                        }
                    }
                    if n == 0 {
                        [0.0, 0.0]
                    } else {
                        [params.step * sx / n as f64, params.step * sy / n as f64]
                    }
                })
                .collect();
            for (v, d) in disp.into_iter().enumerate() {
                st.try_move(v, d);
            }
            // Distribution check (V15), on the structure's edges: chains between junctions.
            if let Some(range) = range {
                let pinned: Vec<bool> = (0..nv).map(|v| fixed_out[v] || border_out[v]).collect();
                let (pull, n) = distribution_pulls(&st, &pinned, range, params.step);
                corrections += n;
                if n > 0 {
                    for (v, d) in pull.into_iter().enumerate() {
                        st.try_move(v, d);
                    }
                }
            }
            if params.merge_each_iteration {
                for (removed, kept) in merge_short_edges(&mut st, &mut fixed_out, &mut border_out, params.min_edge) {
                    merged_into[removed] = Some(kept);
                    for a in active.iter_mut().flatten() {
                        a.merge(removed, kept);
                    }
                }
            }
            iterations = it;
            since += 1;
            let e = closest_error(&st.verts, &st.regions, &eligible, originals, params);
            let prev = *errors.last().expect("initial error");
            if e > prev {
                // The targets no longer lower the error: undo the iteration and recompute
                // the associations; if they were fresh already, no descent is left.
                let (rejected, halved) = (st.rejected, st.halved);
                (st, active, fixed_out, border_out, merged_into) = saved;
                (st.rejected, st.halved) = (rejected, halved);
                rolled_back += 1;
                if since == 1 {
                    stop = StopReason::NoDescent;
                    break;
                }
                reassociate(&st, &mut active);
                rounds += 1;
                since = 0;
                continue;
            }
            errors.push(e);
            observe(errors.len() - 1, &st.verts, &st.regions);
            if e < params.tol {
                stop = StopReason::Converged;
                break;
            }
            let rel = if prev > 0.0 { (prev - e) / prev } else { 0.0 };
            stall = if rel < params.stall_rel { stall + 1 } else { 0 };
            if params.stall_iters > 0 && stall >= params.stall_iters {
                stop = StopReason::Stalled;
                break;
            }
        }
    }

    // Final merge of vertices closer than `min_edge`.
    for (removed, kept) in merge_short_edges(&mut st, &mut fixed_out, &mut border_out, params.min_edge) {
        merged_into[removed] = Some(kept);
    }
    // Resolve chains (a vertex merged into one that was merged later).
    for v in 0..nv {
        let mut t = v;
        while let Some(n) = merged_into[t] {
            t = n;
        }
        if t != v {
            merged_into[v] = Some(t);
        }
    }
    let dropped = drop_straight(&mut st, &fixed_out, params.straight_deg.to_radians());
    let (out_mesh, vertex_map, fixed_c, border_c) = compact(&st, &merged_into, &dropped, &fixed_out, &border_out);

    // The closest shapes of the final mesh.
    let round = associate_regions(&out_mesh.vertices, &out_mesh.regions, &eligible, originals, params);
    fallbacks += round.fallbacks;
    failed += round.failed;
    log.extend(round.log);
    let final_error = mean_distance(&round.associations);
    ShapeResult {
        mesh: out_mesh,
        vertex_map,
        fixed: fixed_c,
        border: border_c,
        associations: round.associations,
        errors,
        final_error,
        iterations,
        stop,
        association_rounds: rounds,
        fallback_associations: fallbacks,
        failed_associations: failed,
        log,
        rejected_moves: st.rejected,
        halved_moves: st.halved,
        distribution_corrections: corrections,
        rolled_back,
        merged_vertices: merged_into.iter().filter(|m| m.is_some()).count(),
        straightened_vertices: dropped.iter().filter(|&&d| d).count(),
    }
}

/// The structure's edges: maximal paths of the mesh graph whose inner vertices have exactly
/// two neighbours and are not pinned, from junction to junction (polygonisation leaves such
/// valency-2 vertices along the boundary between two regions). Closed loops without a
/// junction are skipped. Each chain is listed once, from its smaller end.
fn chains(regions: &[Vec<usize>], nv: usize, pinned: &[bool]) -> Vec<Vec<usize>> {
    let mut nbrs: Vec<Vec<usize>> = vec![Vec::new(); nv];
    for [a, b] in mesh_edges(regions) {
        nbrs[a].push(b);
        nbrs[b].push(a);
    }
    let junction = |v: usize| nbrs[v].len() != 2 || pinned[v];
    let mut out = Vec::new();
    for a in 0..nv {
        if nbrs[a].is_empty() || !junction(a) {
            continue;
        }
        for &first in &nbrs[a] {
            let mut path = vec![a, first];
            let (mut prev, mut cur) = (a, first);
            while !junction(cur) {
                let next = if nbrs[cur][0] == prev { nbrs[cur][1] } else { nbrs[cur][0] };
                prev = cur;
                cur = next;
                path.push(cur);
                if path.len() > nv + 1 {
                    break;
                }
            }
            let last = *path.last().expect("non-empty");
            // List each chain once: from its smaller end (ties: smaller second vertex).
            let second_last = path[path.len() - 2];
            if (a, first) < (last, second_last) {
                out.push(path);
            }
        }
    }
    out
}

/// The distribution-check displacements: every chain with both ends not pinned, or one,
/// whose chord length lies outside `[lo, hi]` has its ends pulled along the chord towards
/// the nearest bound by `step` times the length error (half each, or all of it on the only
/// movable end); the inner vertices follow by linear interpolation along the chain's arc
/// length. Returns the displacements and the number of chains corrected.
fn distribution_pulls(st: &State, pinned: &[bool], range: [f64; 2], step: f64) -> (Vec<Point>, usize) {
    let nv = st.verts.len();
    let mut pull = vec![[0.0f64; 2]; nv];
    let mut n = 0;
    for path in chains(&st.regions, nv, pinned) {
        let (a, b) = (path[0], *path.last().expect("non-empty"));
        if a == b || (pinned[a] && pinned[b]) {
            continue;
        }
        let (pa, pb) = (st.verts[a], st.verts[b]);
        let (dx, dy) = (pb[0] - pa[0], pb[1] - pa[1]);
        let len = (dx * dx + dy * dy).sqrt();
        if len.is_nan() || len <= 0.0 || (len >= range[0] && len <= range[1]) {
            continue;
        }
        let goal = if len < range[0] { range[0] } else { range[1] };
        let change = step * (goal - len);
        let (ma, mb) = (st.freedom[a] != Freedom::Locked, st.freedom[b] != Freedom::Locked);
        let share = match (ma, mb) {
            (true, true) => 0.5,
            (true, false) | (false, true) => 1.0,
            (false, false) => continue,
        };
        let (ux, uy) = (dx / len, dy / len);
        let da = if ma { [-ux * change * share, -uy * change * share] } else { [0.0, 0.0] };
        let db = if mb { [ux * change * share, uy * change * share] } else { [0.0, 0.0] };
        // Arc-length fractions of the chain's vertices.
        let mut acc = vec![0.0; path.len()];
        for k in 1..path.len() {
            let (p, q) = (st.verts[path[k - 1]], st.verts[path[k]]);
            acc[k] = acc[k - 1] + ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2)).sqrt();
        }
        let total = acc[path.len() - 1];
        for (k, &v) in path.iter().enumerate() {
            let f = if total > 0.0 { acc[k] / total } else { k as f64 / (path.len() - 1) as f64 };
            if st.freedom[v] == Freedom::Locked {
                continue;
            }
            pull[v][0] += (1.0 - f) * da[0] + f * db[0];
            pull[v][1] += (1.0 - f) * da[1] + f * db[1];
        }
        n += 1;
    }
    (pull, n)
}

/// Which side(s) of the domain a vertex lies on: bit 0 `x = 0`, 1 `x = w`, 2 `y = 0`,
/// 3 `y = h`.
fn sides(p: Point, domain: [f64; 2], eps: f64) -> u8 {
    let mut s = 0;
    if p[0].abs() <= eps {
        s |= 1;
    }
    if (p[0] - domain[0]).abs() <= eps {
        s |= 2;
    }
    if p[1].abs() <= eps {
        s |= 4;
    }
    if (p[1] - domain[1]).abs() <= eps {
        s |= 8;
    }
    s
}

/// Collapses edges shorter than `min_edge`, shortest first (ties: lower indices), until none
/// can be collapsed. Returns the merges `(removed, kept)` in order.
fn merge_short_edges(st: &mut State, fixed: &mut [bool], border: &mut [bool], min_edge: f64) -> Vec<(usize, usize)> {
    let nv = st.verts.len();
    let mut pairs = Vec::new();
    if min_edge.is_nan() || min_edge <= 0.0 {
        return pairs;
    }
    let len = |v: &[Point], a: usize, b: usize| ((v[b][0] - v[a][0]).powi(2) + (v[b][1] - v[a][1]).powi(2)).sqrt();
    loop {
        let mut short: Vec<(f64, [usize; 2])> = mesh_edges(&st.regions)
            .into_iter()
            .map(|[a, b]| (len(&st.verts, a, b), [a, b]))
            .filter(|(l, _)| *l < min_edge)
            .collect();
        short.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let mut done = false;
        let mut touched = vec![false; nv];
        for (_, [a, b]) in short {
            if touched[a] || touched[b] {
                continue;
            }
            if try_merge(st, fixed, border, a, b) {
                pairs.push((b, a));
            } else if try_merge(st, fixed, border, b, a) {
                pairs.push((a, b));
            } else {
                continue;
            }
            touched[a] = true;
            touched[b] = true;
            done = true;
        }
        if !done {
            break;
        }
    }
    pairs
}

/// Merges `b` into `keep` if allowed and valid; see the module documentation.
fn try_merge(st: &mut State, fixed: &mut [bool], border: &mut [bool], keep: usize, b: usize) -> bool {
    let (pk, pb) = (st.verts[keep], st.verts[b]);
    // The merged position.
    let p = match (fixed[keep], fixed[b]) {
        (true, true) => return false,
        (true, false) => pk,
        (false, true) => return false, // tried the other way round
        (false, false) => match (border[keep], border[b]) {
            (false, false) => [(pk[0] + pb[0]) / 2.0, (pk[1] + pb[1]) / 2.0],
            (true, false) => pk,
            (false, true) => return false,
            (true, true) => {
                let (sk, sb) = (sides(pk, st.domain, st.eps), sides(pb, st.domain, st.eps));
                if sk.count_ones() >= 2 || sb == 0 {
                    // `keep` is a corner (or `b` is a border vertex on no side): stay at `keep`.
                    pk
                } else if sb.count_ones() >= 2 {
                    return false;
                } else if sk == sb {
                    let mut m = [(pk[0] + pb[0]) / 2.0, (pk[1] + pb[1]) / 2.0];
                    // Stay exactly on the side.
                    if sk & 1 != 0 {
                        m[0] = 0.0;
                    }
                    if sk & 2 != 0 {
                        m[0] = st.domain[0];
                    }
                    if sk & 4 != 0 {
                        m[1] = 0.0;
                    }
                    if sk & 8 != 0 {
                        m[1] = st.domain[1];
                    }
                    m
                } else {
                    return false;
                }
            }
        },
    };
    // Trial cycles of the regions containing `keep` or `b`.
    let mut rids: Vec<usize> = st.incidence[keep].iter().chain(&st.incidence[b]).map(|&(r, _)| r).collect();
    rids.sort_unstable();
    rids.dedup();
    let mut trial: Vec<Vec<usize>> = Vec::with_capacity(rids.len());
    for &r in &rids {
        let mut c: Vec<usize> = Vec::with_capacity(st.regions[r].len());
        for &v in &st.regions[r] {
            let v = if v == b { keep } else { v };
            if c.last() != Some(&v) {
                c.push(v);
            }
        }
        while c.len() > 1 && c.first() == c.last() {
            c.pop();
        }
        if c.len() < 3 || !distinct(&c) {
            return false;
        }
        trial.push(c);
    }
    let verts = &st.verts;
    let pos = |i: usize| if i == keep { p } else { verts[i] };
    let cycles: Vec<&[usize]> = trial.iter().map(|c| c.as_slice()).collect();
    if !star_valid(&pos, &cycles, keep, st.eps) {
        return false;
    }
    // Commit.
    st.verts[keep] = p;
    for (&r, c) in rids.iter().zip(trial) {
        st.regions[r] = c;
    }
    rebuild_incidence(st, &rids, &[b]);
    fixed[keep] |= fixed[b];
    border[keep] |= border[b];
    st.freedom[b] = Freedom::Locked;
    true
}

/// Drops merged vertices and renumbers; returns the mesh, the input → output vertex map and
/// the flags of the output vertices.
fn compact(
    st: &State,
    merged: &[Option<usize>],
    dropped: &[bool],
    fixed: &[bool],
    border: &[bool],
) -> (Mesh, Vec<Option<usize>>, Vec<bool>, Vec<bool>) {
    let nv = st.verts.len();
    let mut new_id = vec![None; nv];
    let mut vertices = Vec::new();
    let (mut f, mut b) = (Vec::new(), Vec::new());
    for v in 0..nv {
        if merged[v].is_none() && !dropped[v] {
            new_id[v] = Some(vertices.len());
            vertices.push(st.verts[v]);
            f.push(fixed[v]);
            b.push(border[v]);
        }
    }
    let map: Vec<Option<usize>> = (0..nv).map(|v| new_id[merged[v].unwrap_or(v)]).collect();
    let regions =
        st.regions.iter().map(|c| c.iter().map(|&v| map[v].expect("cycle vertices are kept")).collect()).collect();
    (Mesh { vertices, regions }, map, f, b)
}

/// Rebuilds the incidence lists of the vertices of regions `rids` (and of `extra`) after
/// their cycles changed.
fn rebuild_incidence(st: &mut State, rids: &[usize], extra: &[usize]) {
    let mut touched: Vec<usize> = rids.iter().flat_map(|&r| st.regions[r].iter().copied()).collect();
    touched.extend_from_slice(extra);
    touched.sort_unstable();
    touched.dedup();
    for &v in &touched {
        st.incidence[v].retain(|&(r, _)| !rids.contains(&r));
    }
    for &r in rids {
        for (k, &v) in st.regions[r].iter().enumerate() {
            st.incidence[v].push((r, k));
        }
    }
    for &v in &touched {
        st.incidence[v].sort_unstable();
    }
}

/// Removes valency-2 vertices (not fixed) whose turn is below `straight` radians, when the
/// result stays valid (polygonisation's `straight` rule: stage 2 lines vertices up along
/// the originals' sides). Returns the removed vertices.
fn drop_straight(st: &mut State, fixed: &[bool], straight: f64) -> Vec<bool> {
    let nv = st.verts.len();
    let mut dropped = vec![false; nv];
    if straight.is_nan() || straight <= 0.0 {
        return dropped;
    }
    loop {
        let mut any = false;
        for v in 0..nv {
            if dropped[v] || fixed[v] || st.incidence[v].is_empty() {
                continue;
            }
            // The neighbours of v over all its regions.
            let mut nb: Vec<usize> = Vec::with_capacity(4);
            for &(r, k) in &st.incidence[v] {
                let c = &st.regions[r];
                let n = c.len();
                for u in [c[(k + n - 1) % n], c[(k + 1) % n]] {
                    if !nb.contains(&u) {
                        nb.push(u);
                    }
                }
            }
            if nb.len() != 2 {
                continue;
            }
            let (a, b) = (nb[0], nb[1]);
            if crate::synth::structure::analysis::stats::turn_angle(st.verts[a], st.verts[v], st.verts[b]).abs()
                >= straight
            {
                continue;
            }
            let rids: Vec<usize> = st.incidence[v].iter().map(|&(r, _)| r).collect();
            let trial: Vec<Vec<usize>> =
                rids.iter().map(|&r| st.regions[r].iter().copied().filter(|&u| u != v).collect()).collect();
            if trial.iter().any(|c| c.len() < 3) {
                continue;
            }
            // The new edge (a, b) against every edge of the regions around a and b.
            let mut around: Vec<usize> =
                st.incidence[a].iter().chain(&st.incidence[b]).map(|&(r, _)| r).filter(|r| !rids.contains(r)).collect();
            around.sort_unstable();
            around.dedup();
            let verts = &st.verts;
            let pos = |i: usize| verts[i];
            let mut cycles: Vec<&[usize]> = trial.iter().map(|c| c.as_slice()).collect();
            cycles.extend(around.iter().map(|&r| st.regions[r].as_slice()));
            let ok = trial.iter().all(|c| signed_area(&c.iter().map(|&i| verts[i]).collect::<Vec<_>>()) > 0.0)
                && cycles.iter().all(|c| {
                    let n = c.len();
                    (0..n).all(|k| !edges_conflict(&pos, a, b, c[k], c[(k + 1) % n], st.eps))
                });
            if !ok {
                continue;
            }
            for (&r, c) in rids.iter().zip(trial) {
                st.regions[r] = c;
            }
            rebuild_incidence(st, &rids, &[v]);
            dropped[v] = true;
            any = true;
        }
        if !any {
            return dropped;
        }
    }
}

/// Checks a mesh: every region has at least 3 distinct vertices, a positive signed area and
/// a simple boundary, and no two edges of the mesh cross, touch away from shared ends or
/// overlap. Returns the first problem found.
pub fn check_mesh(mesh: &Mesh) -> Result<(), String> {
    for (r, c) in mesh.regions.iter().enumerate() {
        if c.len() < 3 || !distinct(c) {
            return Err(format!("region {r}: fewer than 3 distinct vertices or a repeated vertex"));
        }
        let poly: Vec<Point> = c.iter().map(|&i| mesh.vertices[i]).collect();
        let a = signed_area(&poly);
        if a.is_nan() || a <= 0.0 {
            return Err(format!("region {r}: signed area {a} is not positive"));
        }
    }
    let sub = crate::synth::structure::mesh::faces::mesh_to_subdivision(mesh);
    if let Some(c) = crate::synth::structure::validate::find_crossings_limited(&sub, 1).first() {
        return Err(format!("edges {:?} meet at {:?}", c.edges.map(|e| sub.edges[e]), c.point));
    }
    Ok(())
}

#[cfg(test)]
mod tests_support;

#[cfg(test)]
mod tests;
