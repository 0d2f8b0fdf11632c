//! The built-in procedural shader library of Bourque's matching [references: bourque §5]:
//! native, deterministic, antialiased and resolution-independent functions of texture
//! coordinates and a typed parameter vector, p(u, v, x).
//!
//! A shader is a [`ShaderDef`]: a name, a parameter table ([`params`]) and a constructor that
//! turns a checked parameter vector and a seed into a [`Pattern`], which shades one point
//! given the width of the pixel there. Every shader filters its own edges and drops the noise
//! octaves finer than a pixel, so a render at 1024² box-downsampled to 256² looks like the
//! 256² render, and every float parameter changes the image continuously (local search needs
//! both).
//!
//! ```text
//! ShaderDef + values + seed ─► Pattern ─► render (rows in parallel) ─► Image (RGB)
//! ```

mod def;
mod geometric;
mod natural;
pub mod params;
pub mod prims;

use rayon::prelude::*;

pub use def::{Pattern, ShaderDef};
pub use geometric::star_pattern;
pub use params::{ParamDef, ParamError, ParamKind};

use crate::raster::Image;

/// Every built-in shader, in the order `explain` lists them.
pub static LIBRARY: &[&ShaderDef] = &[
    &geometric::BAR,
    &geometric::WEAVE,
    &geometric::BRICK,
    &geometric::BRICK2,
    &natural::CYCLONE,
    &natural::EYEBALL,
    &natural::CLOUDS,
    &natural::STARFIELD,
    &geometric::STAR,
    &geometric::RECTANGLE,
    &geometric::CIRCLE,
    &geometric::SUPERELLIPSE,
    &natural::HEXTILE,
];

/// The shader called `name`.
pub fn shader(name: &str) -> Option<&'static ShaderDef> {
    LIBRARY.iter().copied().find(|s| s.name == name)
}

/// Why a render cannot be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ShaderError {
    #[error(transparent)]
    Param(#[from] ParamError),
    #[error("a render needs at least one pixel, not {0} x {1}")]
    Size(usize, usize),
    #[error("the texture region {0:?} is empty or too far out (its corners must lie within ±1e9)")]
    Region([f64; 4]),
}

/// Renders `values` of `shader` into a `w × h` RGB image covering the texture region
/// `[u0, v0, u1, v1]` (v grows downward, as image rows do); the unit square is one period of
/// the repeating shaders. The same arguments give the same bits on any number of threads.
pub fn render(
    shader: &ShaderDef,
    values: &[f64],
    seed: u64,
    w: usize,
    h: usize,
    region: [f64; 4],
) -> Result<Image, ShaderError> {
    if w == 0 || h == 0 {
        return Err(ShaderError::Size(w, h));
    }
    let [u0, v0, u1, v1] = region;
    if !(region.iter().all(|c| c.is_finite() && c.abs() < 1e9) && u1 > u0 && v1 > v0) {
        return Err(ShaderError::Region(region));
    }
    let pattern = shader.pattern(values, seed)?;
    let du = (u1 - u0) / w as f64;
    let dv = (v1 - v0) / h as f64;
    let fw = du.max(dv);
    let mut image = Image::new(w, h, 3);
    let (r, rest) = image.data.split_at_mut(w * h);
    let (g, b) = rest.split_at_mut(w * h);
    let rows = r.par_chunks_mut(w).zip(g.par_chunks_mut(w)).zip(b.par_chunks_mut(w));
    rows.enumerate().for_each_init(
        || vec![[0f32; 3]; w],
        |colours, (y, ((r, g), b))| {
            let v = v0 + (y as f64 + 0.5) * dv;
            pattern.shade_row(u0, du, v, fw, colours);
            for (x, c) in colours.iter().enumerate() {
                // A NaN (which `clamp` would keep) becomes 0.
                let [cr, cg, cb] = c.map(|v| if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) });
                (r[x], g[x], b[x]) = (cr, cg, cb);
            }
        },
    );
    Ok(image)
}

/// [`render`] of the unit square at `size × size`, the thesis's canonical plane.
pub fn render_square(shader: &ShaderDef, values: &[f64], seed: u64, size: usize) -> Result<Image, ShaderError> {
    render(shader, values, seed, size, size, [0.0, 0.0, 1.0, 1.0])
}

#[cfg(test)]
mod tests;
