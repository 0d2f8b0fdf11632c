//! The relit material: a relightable representation (3I, Gradient, PTM or Eigen maps and their
//! basis) laid on a mesh through its UVs and lit per fragment, each light turned into the
//! fragment's tangent frame first [references: dong §7.3]
//!
//! The representation's array frame has x along increasing column (= u), y along increasing
//! row (= decreasing v, since rows grow downward) and z out of the surface. A fragment's tangent
//! frame has `t` along u, `b` along v and `n` out, so a light `(l_t, l_b, l_n)` there is the
//! array-frame light `(l_t, −l_b, l_n)`: on a flat quad whose UVs are its xy the material
//! reproduces the representation relit at the world light, and on a curved mesh each fragment
//! sees the light as its own patch of surface would.

use glam::{DVec3, Vec2};

use super::material::{sample_rgb, sample_wrap, Fragment, Material};
use crate::raster::Image;
use crate::synth::relight::{Basis, Kernel, Light, RelightError};

/// Most maps a representation has (Eigen's `components` is at most 64).
pub const MAX_MAPS: usize = 64;

/// A relightable representation as a material. `maps` has one channel per basis map, `chroma`
/// (if any) three: the colour a unit luminance has.
#[derive(Clone, Debug)]
pub struct Relit<'a> {
    maps: &'a Image,
    chroma: Option<&'a Image>,
    basis: &'a Basis,
    /// Eigen's coefficients exist only between the captured slants: lights are clamped there.
    slants: Option<(f64, f64)>,
    /// The rule for a light straight along the normal, which the ambient light scales.
    overhead: Kernel,
}

impl<'a> Relit<'a> {
    /// Fails when the maps do not match the basis, or the chromaticity the maps' size.
    pub fn new(maps: &'a Image, chroma: Option<&'a Image>, basis: &'a Basis) -> Result<Relit<'a>, RelightError> {
        if maps.channels != basis.channels() || maps.channels > MAX_MAPS {
            return Err(RelightError::Channels { got: maps.channels, expected: basis.channels() });
        }
        if let Some(c) = chroma {
            if (c.width, c.height) != (maps.width, maps.height) || c.channels != 3 {
                return Err(RelightError::Size {
                    what: "the chromaticity",
                    got: [c.width, c.height],
                    expected: [maps.width, maps.height],
                });
            }
        }
        let slants = match basis {
            Basis::Eigen(e) if !e.lights.is_empty() => {
                let lo = e.lights.iter().map(|l| l.slant_deg).fold(f64::INFINITY, f64::min);
                let hi = e.lights.iter().map(|l| l.slant_deg).fold(f64::NEG_INFINITY, f64::max);
                Some((lo, hi))
            }
            _ => None,
        };
        let mut relit = Relit { maps, chroma, basis, slants, overhead: Kernel::Linear(Vec::new()) };
        relit.overhead = relit.kernel(DVec3::Z)?;
        Ok(relit)
    }

    /// The per-texel rule for a light along `l` (array frame, unit, above the surface).
    fn kernel(&self, l: DVec3) -> Result<Kernel, RelightError> {
        let mut light = Light::from_vector(l);
        if let Some((lo, hi)) = self.slants {
            light = Light::new(light.tilt_deg, light.slant_deg.clamp(lo, hi));
        }
        self.basis.kernel(&light)
    }

    /// The luminance of the texel at `uv` under `kernel`, never negative (PTM and Eigen
    /// extrapolate below zero at grazing lights).
    fn luminance(&self, maps: &[f64], kernel: &Kernel) -> f32 {
        (kernel.apply(maps) as f32).max(0.0)
    }

    fn colour(&self, uv: Vec2) -> [f32; 3] {
        self.chroma.map_or([1.0; 3], |c| sample_rgb(c, uv))
    }
}

impl Material for Relit<'_> {
    fn shade(&self, frag: &Fragment) -> [f32; 3] {
        let mut maps = [0.0f64; MAX_MAPS];
        let k = self.maps.channels;
        for (c, m) in maps[..k].iter_mut().enumerate() {
            *m = f64::from(sample_wrap(self.maps, frag.uv, c));
        }
        let maps = &maps[..k];
        let base = self.luminance(maps, &self.overhead);
        let mut sum = frag.ambient.map(|a| a * base);
        for l in frag.lights {
            let t = l.tangent_direction.as_dvec3();
            if t.z <= 0.0 || l.shadow <= 0.0 {
                continue;
            }
            // Only Eigen can fail (a slant outside its grid), and its slants are clamped.
            let Ok(kernel) = self.kernel(DVec3::new(t.x, -t.y, t.z).normalize()) else { continue };
            let lum = self.luminance(maps, &kernel) * l.shadow;
            for (s, r) in sum.iter_mut().zip(l.radiance) {
                *s += r * lum;
            }
        }
        let c = self.colour(frag.uv);
        [c[0] * sum[0], c[1] * sum[1], c[2] * sum[2]]
    }
}
