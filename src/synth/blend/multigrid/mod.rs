//! Geometric multigrid for the masked Poisson problem, standalone (V-cycles) or as the
//! preconditioner of conjugate gradients (MGPCG), solving the channels of one blend (which
//! share the free-cell pattern) together.
//!
//! The unknowns are the *free* cells of a `w × h` grid; every other cell is fixed and its
//! value already moved into the right-hand side, so on each level the operator is
//! `(L u)_p = deg_p u_p − Σ_{q ∈ N_p} u_q` with `u = 0` on fixed cells. `N_p` is the
//! 4-neighbourhood, wrapped on a torus (`periodic`) or clipped at the grid edge (then
//! `deg_p` counts the neighbours that exist: Neumann at the image border).
//!
//! Design, after McAdams, Sifakis & Teran (2010), "A parallel multigrid Poisson solver for
//! fluids simulation on large grids":
//! - cell-centred coarsening by 2 × 2; a coarse cell is free only when all its children are
//!   free ("Dirichlet dominant"). [references: welsman-dinelle §4.2] has the opposite rule ("free if any
//!   child is free"); both are offered ([`Coarsening`]), and the Dirichlet-dominant one is the
//!   default because it keeps every coarse operator non-singular (a level with a fixed cell
//!   has no constant null space) and measured fewer iterations on the disc benchmark.
//! - prolongation: cell-centred bilinear (weights 3/4, 1/4 per axis), restricted to free
//!   cells; restriction is its exact transpose, so the V-cycle is a symmetric operator.
//! - red-black Gauss–Seidel smoothing, pre-smoothing red→black, post-smoothing black→red
//!   (the adjoint; the order inside one colour does not matter, as a colour only reads the
//!   other one), which keeps the preconditioner SPD for CG.
//! - boundary smoothing (also McAdams et al.): the free cells within a few cells of a fixed
//!   one get extra red-black sweeps after the pre-smoothing and before the post-smoothing
//!   (in the adjoint order), where the rediscretised coarse correction is least accurate.
//!   The band is thin, so this is cheap, and it cut the CG iterations on the half-image disc
//!   from 8 to 5 (see [`BAND_RADIUS`]).
//! - coarse operator: the same 5-point stencil rediscretised on the coarse mask.
//! - coarsest level (min side ≤ 8): conjugate gradients in f64 to 1e-12.
//!
//! Lanes: storage is f32 on full-size planes (zero on fixed cells) of [`Lanes`] cells, one
//! lane per channel (`f32` for one channel, four SSE lanes otherwise), so one pass over
//! memory serves every channel and each level is traversed once. Lanes never mix: each lane
//! sees exactly the operations (and rounding) of a one-lane solve, with its own CG scalars
//! and its own stopping test; a lane that has stopped keeps its values (step length 0).
//!
//! Memory traffic: the solve is bandwidth-bound, so passes are fused. All half-sweeps of one
//! smoothing phase (and, after the coarse correction, the prolongation) run as one
//! *wavefront* over the rows (row y gets stage k while row y + 1 gets stage k − 1), so u and
//! b stream through the cache once per phase instead of once per half-sweep; the CG residual
//! · preconditioned residual product is taken as rows receive their last post-smoothing
//! update; `L p` is recomputed where needed instead of stored. The solver's planes come from
//! a small scratch pool (`lanes::Pool`): first-touch page faults of fresh planes cost more
//! than several V-cycles.
//!
//! Determinism: every reduction is summed per row, in a fixed order, then over rows in row
//! order; a red (black) half-sweep only reads black (red) cells, so rows can be updated in
//! parallel without changing any value. A parallel wavefront runs in blocks of rows:
//! each block first does the stage/row pairs whose inputs lie inside the block (stage k
//! skips k rows at either end), then the pairs near each block boundary are done in stage
//! order. Every cell receives exactly the update of the unfused, sequential sweep, so the
//! result is bit-identical for any number of rayon threads and any blocking. The one case
//! where a colour couples to itself across the wrap (periodic with odd height) is swept
//! sequentially, one half-sweep at a time.
//!
//! Files: `level` (a level's free-cell runs, boundary band and row helpers), `smooth` (red-black
//! sweeps and the fused wavefront), `transfer` (prolongation and the restriction tables), `ops`
//! (the operator and the CG reductions and updates), `hierarchy` (coarsening), `cycle` (one
//! V-cycle) and `driver` (PCG or plain V-cycles on top of it).

mod cycle;
mod driver;
mod hierarchy;
mod level;
mod ops;
mod smooth;
mod transfer;

pub(crate) use cycle::CycleParams;
pub(crate) use driver::{solve, Driver, SolveBuffers, Stop};
pub use hierarchy::Coarsening;
pub(crate) use hierarchy::Hierarchy;
pub(crate) use level::{wrap_or_skip, Level};
