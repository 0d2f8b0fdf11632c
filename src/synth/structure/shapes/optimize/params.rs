//! What shape optimisation takes and gives: its options, the target rule, why it stopped and
//! the result with its counters.

use crate::synth::structure::shapes::associate::{AssociateParams, Association};
use crate::synth::structure::types::Mesh;

/// Options of `optimize_shapes` (`shapes.*`, `polygonize.min_edge`; [references: frasson §3.5.4], tessera's choice).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
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
    /// Weight of the generator-ellipse mismatch in the association cost
    /// (`shapes.ellipse_weight`, 8; see `associate`).
    pub ellipse_weight: f64,
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
    /// Fraction of the first-order area correction applied per iteration by the area check,
    /// which pulls every region back towards its input (stage-1) area (1; 0 disables it);
    /// three more full corrections run before the final merge.
    pub area_step: f64,
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
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
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
            ellipse_weight: 8.0,
            tol: 0.05,
            stall_rel: 0.01,
            stall_iters: 5,
            max_halvings: 3,
            distribution_check: true,
            area_step: 1.0,
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
    pub(super) fn associate_params(&self) -> AssociateParams {
        AssociateParams {
            area_tol: self.area_tol,
            widen_step: self.widen_step,
            max_tol: self.max_tol,
            allow_rotation: self.allow_rotation,
            ellipse_weight: self.ellipse_weight,
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

/// The result of `optimize_shapes`.
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
