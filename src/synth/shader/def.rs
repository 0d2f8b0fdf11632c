//! What a shader of the library is: its definition (name, parameter table, constructor) and
//! the pattern it builds, which shades one point (apart from the library's module, so that
//! the shader files and the library list do not import each other).

use serde::Serialize;

use super::params::{self, ParamDef, ParamError};

/// What a shader makes at one point: an RGB colour in `[0, 1]` (display values).
pub trait Pattern: Send + Sync {
    /// The colour of the pixel centred at `(u, v)`, `fw` wide in texture units.
    fn shade(&self, u: f64, v: f64, fw: f64) -> [f32; 3];

    /// The colours of the pixels centred at `u0 + (x + ½)·du` for `x` in `0..out.len()`, on
    /// the row at `v`: [`Pattern::shade`] at each, bit for bit. Shaders whose points cost less
    /// side by side (the noise ones) override it.
    fn shade_row(&self, u0: f64, du: f64, v: f64, fw: f64, out: &mut [[f32; 3]]) {
        for (x, c) in out.iter_mut().enumerate() {
            *c = self.shade(u0 + (x as f64 + 0.5) * du, v, fw);
        }
    }
}

/// One shader of the library.
#[derive(Serialize)]
pub struct ShaderDef {
    pub name: &'static str,
    pub doc: &'static str,
    pub params: &'static [ParamDef],
    /// Whether it draws from noise: matched by similarity, never by parameter equality.
    pub stochastic: bool,
    /// Bumped whenever the same parameters would render differently (cache keys hold it).
    pub version: u32,
    #[serde(skip)]
    pub(super) build: fn(&[f64], u32) -> Box<dyn Pattern>,
}

impl ShaderDef {
    /// The pattern of checked `values` with noise seeded by `seed`.
    pub fn pattern(&self, values: &[f64], seed: u64) -> Result<Box<dyn Pattern>, ParamError> {
        params::validate(self.params, values)?;
        // Noise lattices hash 32-bit seeds: fold the 64-bit stream seed.
        Ok((self.build)(values, (seed ^ (seed >> 32)) as u32))
    }

    pub fn defaults(&self) -> Vec<f64> {
        params::defaults(self.params)
    }

    /// The index of the parameter `name` in the table.
    pub fn param(&self, name: &str) -> Option<usize> {
        self.params.iter().position(|p| p.name == name)
    }
}
