//! Distant point lights given by tilt and slant, and the unit vector they point along.
//!
//! `l = (cos τ sin σ, sin τ sin σ, cos σ)` with the tilt τ measured from +x (increasing column)
//! toward +y (increasing row) and the slant σ from +z (toward the camera) [references: dong §4.4.2]

use glam::DVec3;
use serde::{Deserialize, Serialize};

/// Angles closer than this (degrees) name one light, one slant row or one tilt node of a grid.
/// Light-position files give directions to six decimals, which moves a grid light by about
/// 1e-4°; no capture puts two lights this close on purpose.
pub const SAME_DEG: f64 = 1e-2;

/// A distant light: tilt and slant in degrees. The tilt is kept in `[0, 360)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Light {
    pub tilt_deg: f64,
    pub slant_deg: f64,
}

impl Light {
    /// A light with its tilt wrapped into `[0, 360)` (so 360° and −30° name 0° and 330°).
    pub fn new(tilt_deg: f64, slant_deg: f64) -> Light {
        let mut t = tilt_deg.rem_euclid(360.0);
        // rem_euclid of a tiny negative can round up to exactly 360.
        if t >= 360.0 {
            t = 0.0;
        }
        Light { tilt_deg: t, slant_deg }
    }

    /// The unit vector toward the light, in the array frame (x = column, y = row, z toward the
    /// camera).
    pub fn vector(&self) -> DVec3 {
        let (st, ct) = self.tilt_deg.to_radians().sin_cos();
        let (ss, cs) = self.slant_deg.to_radians().sin_cos();
        DVec3::new(ct * ss, st * ss, cs)
    }

    /// The light pointing along `v` (any length but zero): the inverse of [`Light::vector`].
    pub fn from_vector(v: DVec3) -> Light {
        let v = v.normalize();
        let slant = v.z.clamp(-1.0, 1.0).acos().to_degrees();
        let tilt = if v.x == 0.0 && v.y == 0.0 { 0.0 } else { v.y.atan2(v.x).to_degrees() };
        Light::new(tilt, slant)
    }

    /// A light from a direction in the frame of RTI light-position (`.lp`) files and PTM
    /// viewers: x right, y *up* in the displayed image, z toward the camera. That frame is the
    /// array frame with y negated, since rows grow downward when shown.
    pub fn from_rti_direction(x: f64, y: f64, z: f64) -> Light {
        Light::from_vector(DVec3::new(x, -y, z))
    }

    /// The direction in the RTI/PTM frame (y up): the inverse of [`Light::from_rti_direction`].
    pub fn rti_direction(&self) -> DVec3 {
        let v = self.vector();
        DVec3::new(v.x, -v.y, v.z)
    }

    /// Whether two lights are the same direction: tilt and slant within `SAME_DEG`.
    pub fn same(&self, other: &Light) -> bool {
        let dt = (self.tilt_deg - other.tilt_deg).rem_euclid(360.0);
        let dt = dt.min(360.0 - dt);
        (self.slant_deg - other.slant_deg).abs() < SAME_DEG && (dt < SAME_DEG || self.slant_deg.abs() < SAME_DEG)
    }
}

/// Every (slant, tilt) pair, slant-major: `grid(&[30, 45, 60], &[0, 30, …, 330])` is the
/// 36-light set the thesis is assumed to use.
pub fn grid(slants_deg: &[f64], tilts_deg: &[f64]) -> Vec<Light> {
    slants_deg.iter().flat_map(|&s| tilts_deg.iter().map(move |&t| Light::new(t, s))).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::rng::Rng;

    /// Dong `item 1`: the light direction model.
    #[test]
    fn light_vectors_follow_the_tilt_slant_model() {
        let v = Light::new(0.0, 0.0).vector();
        assert!((v - DVec3::Z).length() < 1e-15);
        let v = Light::new(90.0, 45.0).vector();
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!((v - DVec3::new(0.0, h, h)).length() < 1e-12, "{v}");
        let mut rng = Rng::new(5);
        for _ in 0..1000 {
            let l = Light::new(rng.next_f64() * 720.0 - 360.0, rng.next_f64() * 90.0);
            assert!((l.vector().length() - 1.0).abs() < 1e-12);
            assert!((0.0..360.0).contains(&l.tilt_deg));
            let back = Light::from_vector(l.vector());
            assert!(back.same(&l), "{l:?} vs {back:?}");
            let rti = l.rti_direction();
            assert!(Light::from_rti_direction(rti.x, rti.y, rti.z).same(&l));
        }
        assert_eq!(Light::new(370.0, 30.0).tilt_deg, 10.0);
        assert_eq!(Light::new(-30.0, 30.0).tilt_deg, 330.0);
        assert!((Light::new(360.0, 30.0).vector() - Light::new(0.0, 30.0).vector()).length() < 1e-15);
        let g = grid(&[30.0, 45.0, 60.0], &(0..12).map(|k| k as f64 * 30.0).collect::<Vec<_>>());
        assert_eq!(g.len(), 36);
        assert_eq!(g[13], Light::new(30.0, 45.0));
    }
}
