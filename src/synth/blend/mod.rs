//! Gradient-domain (Poisson) blending of two or more sources ([references: welsman-dinelle §4.2], after
//! [references: perez]).
//!
//! A *selector* says which source each pixel comes from: a binary mask (white = source 1,
//! the thesis's "second texture", merged into source 0), a soft mask (weight of source 1),
//! or a label map over any number of sources (patch layers, Voronoi cells). The output is
//! the function whose 4-neighbour differences best match a *guidance field* built per edge
//! from the sources ([references: welsman-dinelle §4.2]):
//!
//! - edge inside one label: that source's difference;
//! - edge across a seam: [`Seam::Insert`] (the higher label's source: for a binary mask the
//!   inserted source, as in the thesis and Pérez's seamless cloning), [`Seam::Average`]
//!   (mean of the two sources' differences) or [`Seam::Zero`];
//! - soft masks: `(1 − w)·ΔA + w·ΔB` with the edge weight `w = max(m_p, m_q)` under
//!   `Insert` (so a 0/1 soft mask reproduces the binary result) and the mean otherwise.
//!
//! [`Mode`] picks `Gradient` (that field), `Mixed` (per edge the larger-magnitude difference
//! among the two labels' sources and the background source 0, Pérez's mixing gradients),
//! `Average` (no solve: ½(background + source) inside the domain, a cross-fade for soft masks)
//! or `Cut` (no solve: the hard composite).
//!
//! [`Domain`] picks the unknowns: `Mask` (the thesis's formulation: pixels of label ≠ 0 or
//! weight > 0 are solved, every other pixel keeps the composite's value, which acts as the
//! Dirichlet boundary), `Band` (pixels within a radius of a label seam: the band-Dirichlet
//! seam removal) or `Whole` (every pixel: the global variant).
//! [`Topology`] picks the grid graph: `Torus` (wrap edges, tileable output; default), `Rim`
//! (no wrap; the outer rim is fixed to a source's values averaged over opposite edges, so
//! column 0 equals column W−1 and row 0 equals row H−1: the literal reading T2) or `Open`
//! (no wrap, Neumann at the image border).
//!
//! Solvers: `Whole` on `Torus` is solved exactly by a real FFT (periodic), on `Open` by the
//! DCT (Neumann; both in `spectral`, on `synth::fft`); everything else by multigrid-
//! preconditioned conjugate gradients (default) or plain multigrid V-cycles on the free
//! pixels (see `multigrid`).
//! The masked solvers work on the correction `u = f − f₀` from the composite `f₀`, which is
//! smooth, and stop at `‖b − L f‖₂ ≤ tol·‖b‖₂` ([references: welsman-dinelle §4.2]); each channel's
//! [`SolveReport`] gives the iterations and the *true* final residual of the returned f32
//! image, recomputed in f64.
//!
//! Values are processed as given (the thesis works on encoded values; callers wanting a
//! linear-light blend decode first). Output floats are never clamped here: clamping and
//! rounding belong to 8-bit export. Channels are independent: the channels that share a
//! selector are solved together (one SIMD lane each, one multigrid hierarchy, one pass over
//! memory for all of them), each lane with exactly the arithmetic of a one-channel solve, so
//! a channel's result does not depend on the others. Every solve is parallel inside and
//! every reduction has a fixed order, so the output is bit-identical for any rayon thread
//! count.

mod lanes;
pub mod mask;
mod multigrid;
mod params;
mod periodic;
mod setup;
mod spectral;

use crate::raster::Image;

pub use multigrid::Coarsening;
pub use params::*;
pub use periodic::{make_periodic, wrap_seam_ratio};
// Relighting integrates gradient fields with the same exact Neumann solve.
pub(crate) use spectral::solve_neumann;

/// Two-source blend under a binary mask (the thesis's operation with the given parameters).
pub fn blend_two(a: &Image, b: &Image, mask: &Image, params: &BlendParams) -> Result<Blended, BlendError> {
    blend(&[a, b], Selector::Binary(mask), params)
}

/// Blends `sources` under `selector`. See the module documentation for the semantics.
pub fn blend(sources: &[&Image], selector: Selector<'_>, params: &BlendParams) -> Result<Blended, BlendError> {
    blend_with(sources, selector, params, &Run::default())
}

/// [`blend`] with a warm start or a progress callback.
pub fn blend_with(
    sources: &[&Image],
    selector: Selector<'_>,
    params: &BlendParams,
    run: &Run<'_>,
) -> Result<Blended, BlendError> {
    setup::validate(sources, &selector, params, run.warm)?;
    let (image, reports) = setup::blend_all(sources, &selector, params, run);
    Ok(Blended { image, reports })
}

#[cfg(test)]
mod tests;
