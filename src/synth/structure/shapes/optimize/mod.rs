//! Stage 2 of the statistical structure synthesis: correcting region shapes
//! ("micro-positioning", [references: frasson §3.5.4], Algorithms 2 and 3, V13–V15).
//!
//! **Association (Algorithm 2).** Every eligible region is associated with its closest
//! original shape (`associate`: smallest turning distance among the originals within
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
//! 3. runs the *area check* (`area`, `area_step`): every region's area is pulled back
//!    towards its stage-1 area (a first-order correction along the area gradient, in full
//!    by default, and three more after the last iteration). The associated originals are up to `area_tol` larger or
//!    smaller than their regions and pulling vertices towards them drifts the sizes; without
//!    this the relative-area distribution gets further from the sample's (KS 0.32 → 0.38 on
//!    `scales_diag`, 0.04 → 0.15 on `wall_regular`) while the thesis never scales a region
//!    ("size can be an important feature");
//! 4. collapses edges shorter than `min_edge` (`merge_each_iteration`, default on): the
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
//!
//! Files: `params` (options and result), `moves` (vertex freedom and the validity guard),
//! `state` (the iteration state), `targets` (association and targets), `distribution`
//! (the edge-length check), `area` (the area check), `merge` (merges and straightening); this file runs the
//! iterations.

use crate::synth::structure::mesh::faces::signed_area;
use crate::synth::structure::types::{Mesh, Point};
use rayon::prelude::*;

mod area;
mod distribution;
mod merge;
mod moves;
mod params;
mod state;
mod targets;

pub use crate::synth::structure::shapes::associate::{Association, Prior};
use area::*;
use distribution::*;
use merge::*;
use moves::*;
pub use params::{ShapeParams, ShapeResult, StopReason, TargetRule};
use state::*;
use targets::*;

/// Stage-2 shape optimisation ([references: frasson §3.5.4]) of a valid mesh tiling (part of) the domain
/// `[0, width] × [0, height]`. `fixed[v]`: the vertex never moves; `border[v]`: the vertex is
/// on the domain border and may only slide along it. `originals` are the sample's region
/// polygons, already scaled by the structure's scale. `priors[r]`: the generator region `r`
/// was grown from, if known (empty: none; see [`crate::synth::structure::shapes::associate`]).
///
/// # Panics
/// If `fixed` or `border` does not have one entry per mesh vertex.
pub fn optimize_shapes(
    mesh: &Mesh,
    fixed: &[bool],
    border: &[bool],
    domain: (f64, f64),
    originals: &[Vec<Point>],
    priors: &[Option<Prior>],
    params: &ShapeParams,
) -> ShapeResult {
    optimize_shapes_observed(mesh, fixed, border, domain, originals, priors, params, |_, _, _| {})
}

/// The closest original of every region of `mesh` without moving anything (what
/// [`optimize_shapes`] reports for its final mesh, for a structure whose stage 2 is off).
/// Regions touching a `fixed` or `border` vertex are left out unless
/// `params.include_border_regions`, as in the optimisation.
pub fn associate_mesh(
    mesh: &Mesh,
    fixed: &[bool],
    border: &[bool],
    originals: &[Vec<Point>],
    priors: &[Option<Prior>],
    params: &ShapeParams,
) -> Vec<Option<Association>> {
    let eligible = eligible_regions(mesh, fixed, border, params);
    Associator::new(originals, priors, params).round(&mesh.vertices, &mesh.regions, &eligible).associations
}

fn eligible_regions(mesh: &Mesh, fixed: &[bool], border: &[bool], params: &ShapeParams) -> Vec<bool> {
    mesh.regions
        .iter()
        .map(|c| c.len() >= 3 && (params.include_border_regions || c.iter().all(|&v| !fixed[v] && !border[v])))
        .collect()
}

/// [`optimize_shapes`], calling `observe(k, vertices, regions)` with the mesh of the input
/// (`k = 0`) and after every iteration `k` (vertex indices are those of the input; merged
/// vertices no longer appear in the cycles). The final merge happens after the last call.
#[allow(clippy::too_many_arguments)] // the inputs of `optimize_shapes` plus the observer
pub fn optimize_shapes_observed(
    mesh: &Mesh,
    fixed: &[bool],
    border: &[bool],
    domain: (f64, f64),
    originals: &[Vec<Point>],
    priors: &[Option<Prior>],
    params: &ShapeParams,
    mut observe: impl FnMut(usize, &[Point], &[Vec<usize>]),
) -> ShapeResult {
    let nv = mesh.vertices.len();
    assert_eq!(fixed.len(), nv, "one `fixed` flag per vertex");
    assert_eq!(border.len(), nv, "one `border` flag per vertex");
    let eligible = eligible_regions(mesh, fixed, border, params);
    let mut st = State::new(mesh, fixed, border, [domain.0, domain.1], params);
    let range = if params.distribution_check { edge_length_range(originals, params.edge_percentiles) } else { None };
    // The area check's targets: the regions' stage-1 areas.
    let area_targets = region_areas(&mesh.vertices, &mesh.regions);

    let mut fallbacks = 0;
    let mut failed = 0;
    let mut log = Vec::new();
    let mut rounds = 0;
    let mut active: Vec<Option<Active>> = Vec::new();
    let mut associator = Associator::new(originals, priors, params);
    let mut reassociate = |st: &State, active: &mut Vec<Option<Active>>, associator: &mut Associator| {
        let round = associator.round(&st.verts, &st.regions, &eligible);
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
    reassociate(&st, &mut active, &mut associator);
    rounds += 1;
    let mut errors = vec![associator.error(&st.verts, &st.regions, &eligible)];
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
                reassociate(&st, &mut active, &mut associator);
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
            // Area check: region sizes back towards their stage-1 areas.
            if params.area_step > 0.0 {
                for (v, d) in area_pulls(&st, &area_targets, params.area_step).into_iter().enumerate() {
                    st.try_move(v, d);
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
            let e = associator.error(&st.verts, &st.regions, &eligible);
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
                reassociate(&st, &mut active, &mut associator);
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

    // The area check once more, in full, on the kept mesh.
    if params.area_step > 0.0 && iterations > 0 {
        for _ in 0..3 {
            for (v, d) in area_pulls(&st, &area_targets, 1.0).into_iter().enumerate() {
                st.try_move(v, d);
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
    let round = associator.round(&out_mesh.vertices, &out_mesh.regions, &eligible);
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
