//! Gradient: photometric stereo. `N_a = I L⁺` (least squares over all lights), then albedo
//! `al = |N_a|`, `n = N_a / al`, `p = −n_x / n_z`, `q = −n_y / n_z` [references: dong §4.4.2]

use glam::DVec3;
use nalgebra::DMatrix;
use rayon::prelude::*;

use super::types::{pinv_lights, planes, project, Basis, Method, Representation};
use crate::synth::relight::error::RelightError;
use crate::synth::relight::stack::PhotoStack;

/// The smallest `n_z` a fitted normal may have: below it (a normal lying in the image plane or
/// facing away from the camera, which the Lambertian fit of noisy or shadowed data can give)
/// `(p, q)` would blow up, so `n_z` is raised to this and the pixel counted as flagged.
pub const NZ_MIN: f64 = 1e-3;

/// `i = al · (−p l_x − q l_y + l_z) / sqrt(p² + q² + 1)`.
#[inline]
pub fn lambert(p: f64, q: f64, al: f64, l: DVec3) -> f64 {
    al * (-p * l.x - q * l.y + l.z) / (p * p + q * q + 1.0).sqrt()
}

/// The scaled normals `N_a = I L⁺`, three planes (x, y, z). Needs three or more lights that
/// are not coplanar.
pub fn scaled_normals(stack: &PhotoStack) -> Result<Vec<f64>, RelightError> {
    let n = stack.len();
    if n < 3 {
        return Err(RelightError::TooFewImages { method: "Gradient", needed: 3, got: n });
    }
    let l = DMatrix::from_fn(3, n, |r, k| stack.lights[k].vector()[r]);
    let (pinv, smin, smax) = pinv_lights(&l);
    if smin <= 1e-9 * smax {
        return Err(RelightError::Degenerate { method: "Gradient", smallest: smin, largest: smax });
    }
    Ok(project(&planes(stack), stack.width, &pinv, 3))
}

/// `(p, q, al)` planes from scaled normals, and how many pixels hit the `n_z` guard.
pub fn pq_from_scaled_normals(na: &[f64]) -> (Vec<f64>, usize) {
    let m = na.len() / 3;
    let mut out = vec![0.0; 3 * m];
    let (p, rest) = out.split_at_mut(m);
    let (q, al) = rest.split_at_mut(m);
    let flagged: usize = p
        .par_iter_mut()
        .zip(q.par_iter_mut())
        .zip(al.par_iter_mut())
        .enumerate()
        .map(|(j, ((p, q), al))| {
            let v = DVec3::new(na[j], na[m + j], na[2 * m + j]);
            let a = v.length();
            *al = a;
            if a == 0.0 {
                *p = 0.0;
                *q = 0.0;
                return 0;
            }
            let n = v / a;
            let (nz, flag) = if n.z < NZ_MIN { (NZ_MIN, 1) } else { (n.z, 0) };
            *p = -n.x / nz;
            *q = -n.y / nz;
            flag
        })
        .sum();
    (out, flagged)
}

pub(super) fn extract(stack: &PhotoStack) -> Result<Representation, RelightError> {
    let na = scaled_normals(stack)?;
    let (maps, flagged) = pq_from_scaled_normals(&na);
    Ok(Representation {
        method: Method::Gradient,
        width: stack.width,
        height: stack.height,
        maps,
        basis: Basis::Gradient,
        chroma: None,
        flagged,
    })
}
