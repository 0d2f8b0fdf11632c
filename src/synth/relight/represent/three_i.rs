//! 3I: three photometric images as the representation, relit by `i = I · L3⁻¹ l` (Shashua)
//! [references: dong §4.4.2]
//!
//! Exact for unshadowed Lambertian surfaces (`I = N_a L3`), any three non-coplanar lights.

use glam::DVec3;
use nalgebra::Matrix3;

use super::types::{Basis, Method, Representation};
use crate::synth::relight::error::RelightError;
use crate::synth::relight::light::Light;
use crate::synth::relight::stack::PhotoStack;

/// The thesis's triple: slant 45°, tilts 0°, 90°, 180° (as (tilt, slant)).
pub const DEFAULT_TRIPLE: [(f64, f64); 3] = [(0.0, 45.0), (90.0, 45.0), (180.0, 45.0)];
/// The leave-one-out triple when the left-out image is in the default one: tilts turned by 30°.
pub const LOO_TRIPLE: [(f64, f64); 3] = [(30.0, 45.0), (120.0, 45.0), (210.0, 45.0)];

fn find(lights: &[Light], want: &[(f64, f64); 3], exclude: Option<usize>) -> Option<[usize; 3]> {
    let mut out = [0; 3];
    for (slot, &(t, s)) in want.iter().enumerate() {
        let target = Light::new(t, s);
        out[slot] = (0..lights.len()).find(|&i| Some(i) != exclude && lights[i].same(&target))?;
    }
    Some(out)
}

/// The three images 3I uses: the default triple, else (when `exclude` is in it, or it is
/// missing) the triple turned by 30°, else the triple of the remaining lights whose matrix has
/// the largest smallest singular value (first found on ties). Errors when no three lights
/// span three directions.
pub fn triple_for(lights: &[Light], exclude: Option<usize>) -> Result<[usize; 3], RelightError> {
    if let Some(t) = find(lights, &DEFAULT_TRIPLE, exclude).or_else(|| find(lights, &LOO_TRIPLE, exclude)) {
        return Ok(t);
    }
    let idx: Vec<usize> = (0..lights.len()).filter(|&i| Some(i) != exclude).collect();
    if idx.len() < 3 {
        return Err(RelightError::TooFewImages { method: "3I", needed: 3, got: idx.len() });
    }
    let mut best: Option<([usize; 3], f64)> = None;
    for a in 0..idx.len() {
        for b in a + 1..idx.len() {
            for c in b + 1..idx.len() {
                let t = [idx[a], idx[b], idx[c]];
                let sv = matrix(&[lights[t[0]], lights[t[1]], lights[t[2]]]).singular_values();
                if best.is_none_or(|(_, s)| sv.min() > s) {
                    best = Some((t, sv.min()));
                }
            }
        }
    }
    match best {
        Some((t, s)) if s > 1e-6 => Ok(t),
        _ => Err(RelightError::NoTriple { reason: ": every triple of lights is coplanar" }),
    }
}

/// `L3`: the light vectors as columns.
fn matrix(lights: &[Light; 3]) -> Matrix3<f64> {
    let v: Vec<DVec3> = lights.iter().map(Light::vector).collect();
    Matrix3::new(v[0].x, v[1].x, v[2].x, v[0].y, v[1].y, v[2].y, v[0].z, v[1].z, v[2].z)
}

/// `L3⁻¹` (row-major), refusing coplanar triples (smallest / largest singular value below
/// 1e-9).
pub(super) fn inverse(lights: &[Light; 3]) -> Result<[[f64; 3]; 3], RelightError> {
    let m = matrix(lights);
    let sv = m.singular_values();
    if sv.min() <= 1e-9 * sv.max() {
        return Err(RelightError::Degenerate { method: "3I", smallest: sv.min(), largest: sv.max() });
    }
    let inv =
        m.try_inverse().ok_or(RelightError::Degenerate { method: "3I", smallest: sv.min(), largest: sv.max() })?;
    Ok([0, 1, 2].map(|r| [0, 1, 2].map(|c| inv[(r, c)])))
}

/// `c = L3⁻¹ l`.
pub(super) fn apply(inv: &[[f64; 3]; 3], l: DVec3) -> [f64; 3] {
    inv.map(|row| row[0] * l.x + row[1] * l.y + row[2] * l.z)
}

/// The closed form (*) for the default triple: `[c1, c2, c3]` multiply the 0°, 90° and 180°
/// images [references: dong §4.4.2]
pub fn closed_form_45(light: &Light) -> [f64; 3] {
    let (st, ct) = light.tilt_deg.to_radians().sin_cos();
    let (ss, cs) = light.slant_deg.to_radians().sin_cos();
    let (s45, c45) = 45f64.to_radians().sin_cos();
    [
        ct * ss / (2.0 * s45) - st * ss / (2.0 * s45) + cs / (2.0 * c45),
        st * ss / s45,
        cs / (2.0 * c45) - ct * ss / (2.0 * s45) - st * ss / (2.0 * s45),
    ]
}

pub(super) fn extract(stack: &PhotoStack, triple: [usize; 3]) -> Result<Representation, RelightError> {
    if let Some(&bad) = triple.iter().find(|&&i| i >= stack.len()) {
        return Err(RelightError::TooFewImages { method: "3I", needed: bad + 1, got: stack.len() });
    }
    let lights = triple.map(|i| stack.lights[i]);
    let inverse = inverse(&lights)?;
    let maps = triple.iter().flat_map(|&i| stack.images[i].iter().copied()).collect();
    Ok(Representation {
        method: Method::ThreeI,
        width: stack.width,
        height: stack.height,
        maps,
        basis: Basis::ThreeI { lights, inverse },
        chroma: None,
        flagged: 0,
    })
}
