//! PTM: six polynomial coefficients per pixel against `(l_x², l_y², l_x l_y, l_x, l_y, 1)`,
//! fitted by least squares over all lights (Malzbender) [references: dong §4.4.3]
//!
//! The order is the PTM file format's (`a0 u² + a1 v² + a2 uv + a3 u + a4 v + a5`), so maps
//! go to files without reordering (only the y-up frame flip, `ptm_file`).

use glam::DVec3;
use nalgebra::DMatrix;

use super::types::{pinv_lights, planes, project, Basis, Method, Representation};
use crate::synth::relight::error::RelightError;
use crate::synth::relight::stack::PhotoStack;

/// The PTM lighting vector of a unit light.
pub fn ptm_vector(l: DVec3) -> [f64; 6] {
    [l.x * l.x, l.y * l.y, l.x * l.y, l.x, l.y, 1.0]
}

pub(super) fn extract(stack: &PhotoStack) -> Result<Representation, RelightError> {
    let n = stack.len();
    if n < 6 {
        return Err(RelightError::TooFewImages { method: "PTM", needed: 6, got: n });
    }
    let vecs: Vec<[f64; 6]> = stack.lights.iter().map(|l| ptm_vector(l.vector())).collect();
    let l = DMatrix::from_fn(6, n, |r, k| vecs[k][r]);
    let (pinv, smin, smax) = pinv_lights(&l);
    // At a single slant `l_x² + l_y²` is the constant column times sin²σ: rank 5.
    if smin <= 1e-9 * smax {
        return Err(RelightError::SingleSlant { smallest: smin, largest: smax });
    }
    Ok(Representation {
        method: Method::Ptm,
        width: stack.width,
        height: stack.height,
        maps: project(&planes(stack), stack.width, &pinv, 6),
        basis: Basis::Ptm,
        chroma: None,
        flagged: 0,
    })
}
