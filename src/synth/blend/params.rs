//! What a blend takes and gives: its mode, topology, seam and domain, the solver settings,
//! the selector of sources, the per-solve reports, and its errors. Apart from the entry
//! points so that the solver modules can use these types without importing the module that
//! calls them.

use std::fmt;

use serde::{Deserialize, Serialize};

use super::multigrid::Coarsening;
use crate::raster::Image;

/// How the blended values are produced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Mode {
    /// Poisson blending with the selected sources' gradients (the thesis).
    #[default]
    Gradient,
    /// Poisson blending with, per edge, the larger-magnitude gradient (Pérez's mixing).
    Mixed,
    /// No solve: ½(background + source) inside the domain; cross-fade for soft masks.
    Average,
    /// No solve: the hard composite (direct layering).
    Cut,
}

/// The grid graph and its boundary.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Topology {
    /// Periodic: opposite sides are neighbours (T1, tileable output).
    #[default]
    Torus,
    /// No wrap; the outer rim is fixed to source `source`'s values averaged over opposite
    /// sides (corners: the mean of the four corners), so the output's column 0 equals column
    /// W−1 and row 0 equals row H−1 bitwise (T2, compatibility mode).
    Rim { source: usize },
    /// No wrap; free (Neumann) boundary at the image border.
    Open,
}

/// Guidance on the torus's wrap edges (between column W−1 and 0, row H−1 and 0).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum WrapGuidance {
    /// The sources' own wrap differences (right for tileable sources).
    #[default]
    Source,
    /// Zero: treats the wrap seam of non-tileable sources as flat.
    Zero,
}

/// Guidance on edges whose two pixels come from different sources.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Seam {
    /// The higher label's source (binary masks: the inserted source; the thesis).
    #[default]
    Insert,
    /// The mean of the two sources' differences.
    Average,
    /// Zero difference.
    Zero,
}

/// Which pixels are solved for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Domain {
    /// Pixels of label ≠ 0 (mask white) or weight > 0; all others keep the composite.
    #[default]
    Mask,
    /// Pixels within Chebyshev distance `radius` of a seam pixel (a pixel whose label, or
    /// mask weight, differs from a 4-neighbour's).
    Band { radius: usize },
    /// Every pixel (the mean is fixed to the composite's mean where nothing is fixed).
    Whole,
}

/// Iterative solver for masked domains.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum SolverKind {
    /// Conjugate gradients preconditioned by one multigrid V-cycle.
    #[default]
    Mgpcg,
    /// Multigrid V-cycles alone.
    Multigrid,
}

/// Solver settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Solver {
    pub kind: SolverKind,
    /// Stop when `‖b − L f‖₂ ≤ tol · ‖b‖₂` ...
    pub tol: f64,
    /// ... and `max |b − L f| ≤ max_tol · range`, where `range` is max − min over the
    /// sources' values ([references: welsman-dinelle §4.2]: "converged" is relative residual ≤ 1e-6 and max |r| ≤
    /// 1e-3 on the 0..255 scale, hence the default 1e-3/255 of the range).
    pub max_tol: f64,
    /// Iteration cap (CG iterations or V-cycles) of each solve; reaching it sets
    /// `converged = false`. Both bounds are checked on the f64 residual of the returned f32
    /// image; when the f32 solve misses them there, up to two refinement solves follow, and a
    /// bound below f32 precision (about 3e-7 relative) reports `converged = false`.
    pub max_iter: usize,
    /// Red-black Gauss–Seidel sweeps before and after each coarse correction.
    pub smooth: usize,
    pub coarsening: Coarsening,
}

impl Default for Solver {
    fn default() -> Self {
        Solver {
            kind: SolverKind::Mgpcg,
            tol: 1e-6,
            max_tol: 1e-3 / 255.0,
            max_iter: 50,
            smooth: 2,
            coarsening: Coarsening::AllChildren,
        }
    }
}

/// Everything that shapes a blend besides its inputs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BlendParams {
    pub mode: Mode,
    pub topology: Topology,
    pub wrap_guidance: WrapGuidance,
    pub seam: Seam,
    pub domain: Domain,
    pub solver: Solver,
}

/// Which source each pixel takes.
#[derive(Clone, Copy, Debug)]
pub enum Selector<'a> {
    /// Exactly two sources; a 1-channel mask (shared) or one with the sources' channel
    /// count (per-channel masks). Values ≥ 0.5 select source 1.
    Binary(&'a Image),
    /// Exactly two sources; weight of source 1 in `[0, 1]` (values are clamped), 1 or C
    /// channels.
    Soft(&'a Image),
    /// Any number of sources; `labels[y·w + x]` indexes `sources`. Label 0 is the
    /// background for `Domain::Mask` and `Mode::Average`.
    Labels(&'a [u32]),
}

/// Which method produced a channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Method {
    /// Nothing to solve (no free pixel, a single source, or a no-solve mode).
    Direct,
    /// Exact FFT solve on the torus.
    Periodic,
    /// Exact DCT (even-extension FFT) solve with Neumann boundary.
    Neumann,
    /// Multigrid-preconditioned conjugate gradients.
    Mgpcg,
    /// Multigrid V-cycles.
    Multigrid,
}

/// What the solve of one channel did.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SolveReport {
    pub channel: usize,
    pub method: Method,
    /// Free pixels (unknowns).
    pub unknowns: usize,
    /// CG iterations or V-cycles (0 for exact and direct methods).
    pub iterations: usize,
    /// `‖b − L f‖₂ / ‖b‖₂` of the returned image, recomputed in f64 (the absolute norm
    /// when `b = 0`).
    pub residual: f64,
    /// `max |b − L f|` over free pixels, in the images' units.
    pub max_residual: f64,
    /// False when an iterative solve hit `max_iter` before `tol`.
    pub converged: bool,
}

/// A blend result: the image (unclamped floats) and one report per channel.
#[derive(Clone, Debug, PartialEq)]
pub struct Blended {
    pub image: Image,
    pub reports: Vec<SolveReport>,
}

/// Why a blend was refused.
#[derive(Clone, Debug, PartialEq)]
pub enum BlendError {
    /// No sources were given.
    NoSources,
    /// The selector needs a different number of sources.
    SourceCount { expected: usize, found: usize },
    /// An input has zero width, height or channels.
    Empty { what: String },
    /// An input's size differs from source 0's.
    SizeMismatch { what: String, expected: (usize, usize), found: (usize, usize) },
    /// An input's channel count is not allowed.
    ChannelMismatch { what: String, expected: usize, found: usize },
    /// An input holds NaN or an infinity.
    NonFinite { what: String, x: usize, y: usize, channel: usize },
    /// A label map names a source that does not exist.
    LabelOutOfRange { x: usize, y: usize, label: u32, sources: usize },
    /// A parameter is out of its range.
    BadParameter { name: Param, reason: String },
}

/// Which blend parameter an error is about: callers point at the place to fix from this,
/// never from the message text.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Param {
    Labels,
    Tol,
    MaxTol,
    MaxIter,
    Smooth,
    RimSource,
}

impl Param {
    /// How messages name it.
    pub fn text(self) -> &'static str {
        match self {
            Param::Labels => "labels",
            Param::Tol => "tol",
            Param::MaxTol => "max_tol",
            Param::MaxIter => "max_iter",
            Param::Smooth => "smooth",
            Param::RimSource => "rim source",
        }
    }
}

impl fmt::Display for Param {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.text())
    }
}

impl fmt::Display for BlendError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BlendError::NoSources => write!(f, "blend needs at least one source"),
            BlendError::SourceCount { expected, found } => {
                write!(f, "this mask blends exactly {expected} sources, but {found} were given")
            }
            BlendError::Empty { what } => write!(f, "{what} is empty (zero width, height or channels)"),
            BlendError::SizeMismatch { what, expected, found } => write!(
                f,
                "{what} is {}x{} but the sources are {}x{}; blending needs equal sizes",
                found.0, found.1, expected.0, expected.1
            ),
            BlendError::ChannelMismatch { what, expected, found } => {
                write!(f, "{what} has {found} channels; expected 1 or {expected}")
            }
            BlendError::NonFinite { what, x, y, channel } => {
                write!(f, "{what} holds a NaN or infinite value at ({x}, {y}), channel {channel}")
            }
            BlendError::LabelOutOfRange { x, y, label, sources } => {
                write!(f, "label {label} at ({x}, {y}) names a source, but only {sources} were given")
            }
            BlendError::BadParameter { name, reason } => write!(f, "invalid `{name}`: {reason}"),
        }
    }
}

impl std::error::Error for BlendError {}

/// How a blend runs, apart from what it computes.
#[derive(Clone, Copy, Debug, Default)]
pub struct Run<'a> {
    /// A warm start: inside the domain the iterative solvers start from it (e.g. the
    /// previous result while a cutoff is edited). The converged result differs from a cold
    /// start by less than the tolerance, not bitwise.
    pub warm: Option<&'a Image>,
    /// Told the iterations of each iterative solve, out of `max_iter`.
    pub progress: crate::synth::Progress<'a>,
}
