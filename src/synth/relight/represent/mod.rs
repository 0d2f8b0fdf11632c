//! The five per-pixel representations and the one relighting rule they share,
//! `i = M1 · c(light)` [references: dong §4.4.1]
//!
//! Every method factors the stack `I` (pixels × images) as `M1 · M2`: `M1` is a few maps per
//! pixel (the [`Representation`]'s maps), `M2` is global (the [`Basis`]). Relighting never
//! looks at a neighbour, so it commutes with anything that moves whole pixels (quilting's
//! gather) exactly.

mod eigen;
mod gradient;
mod ptm;
mod three_i;
mod types;

use nalgebra::DMatrix;
use rayon::prelude::*;

use crate::raster::Image;
use crate::synth::relight::error::RelightError;
use crate::synth::relight::light::Light;
use crate::synth::relight::stack::PhotoStack;

pub use eigen::information;
pub use gradient::{lambert, pq_from_scaled_normals, scaled_normals, NZ_MIN};
pub use ptm::ptm_vector;
pub use three_i::{closed_form_45, triple_for, DEFAULT_TRIPLE, LOO_TRIPLE};
use types::planes;
pub use types::{Basis, EigenBasis, Kernel, Method, Representation};

impl Basis {
    pub fn channels(&self) -> usize {
        match self {
            Basis::ThreeI { .. } | Basis::Gradient => 3,
            Basis::Ptm => 6,
            Basis::Eigen(e) => e.k,
        }
    }

    /// The per-pixel rule for `light`. Fails only for Eigen, when the light's slant is outside
    /// the captured range.
    pub fn kernel(&self, light: &Light) -> Result<Kernel, RelightError> {
        let l = light.vector();
        Ok(match self {
            Basis::ThreeI { inverse, .. } => Kernel::Linear(three_i::apply(inverse, l).to_vec()),
            Basis::Gradient => Kernel::Lambert(l),
            Basis::Ptm => Kernel::Linear(ptm_vector(l).to_vec()),
            Basis::Eigen(e) => Kernel::Linear(e.coefficients(light)?),
        })
    }

    /// The coefficient vector `c` of `i = M1 · c`. For Gradient this is `l` itself, the
    /// coefficients of the scaled normals `N_a` (which the `(p, q, al)` maps encode).
    pub fn coefficients(&self, light: &Light) -> Result<Vec<f64>, RelightError> {
        Ok(match self.kernel(light)? {
            Kernel::Linear(c) => c,
            Kernel::Lambert(l) => l.to_array().to_vec(),
        })
    }
}

impl Kernel {
    /// One pixel relit: `maps` holds its channels in order (as many as the basis has).
    #[inline]
    pub fn apply(&self, maps: &[f64]) -> f64 {
        match self {
            Kernel::Linear(coef) => coef.iter().zip(maps).map(|(c, v)| c * v).sum(),
            Kernel::Lambert(l) => lambert(maps[0], maps[1], maps[2], *l),
        }
    }
}

impl Representation {
    pub fn channels(&self) -> usize {
        self.basis.channels()
    }

    pub fn plane(&self, c: usize) -> &[f64] {
        let m = self.width * self.height;
        &self.maps[c * m..(c + 1) * m]
    }

    /// The relit luminance plane (unclamped).
    pub fn relight(&self, light: &Light) -> Result<Vec<f64>, RelightError> {
        let kernel = self.basis.kernel(light)?;
        let planes: Vec<&[f64]> = (0..self.channels()).map(|c| self.plane(c)).collect();
        Ok(relight_planes(&planes, self.width, &kernel))
    }

    /// The maps as an f32 image (for quilting and EXR).
    pub fn to_image(&self) -> Image {
        Image {
            width: self.width,
            height: self.height,
            channels: self.channels(),
            data: self.maps.iter().map(|&v| v as f32).collect(),
        }
    }

    /// The chromaticity as a 3-channel f32 image, if the stack had colour.
    pub fn chroma_image(&self) -> Option<Image> {
        self.chroma.as_ref().map(|c| Image {
            width: self.width,
            height: self.height,
            channels: 3,
            data: c.iter().map(|&v| v as f32).collect(),
        })
    }
}

/// Fits `method` to the stack. 3I takes the default triple (slant 45°, tilts 0°, 90°, 180°),
/// or failing that the best-conditioned triple ([`triple_for`]).
pub fn extract(stack: &PhotoStack, method: Method) -> Result<Representation, RelightError> {
    let mut rep = match method {
        Method::ThreeI => three_i::extract(stack, triple_for(&stack.lights, None)?),
        Method::Gradient => gradient::extract(stack),
        Method::Ptm => ptm::extract(stack),
        Method::Eigen(k) => eigen::extract(stack, k),
    }?;
    rep.chroma = stack.chroma.clone();
    Ok(rep)
}

/// 3I from an explicit triple of image indices.
pub fn extract_three_i(stack: &PhotoStack, triple: [usize; 3]) -> Result<Representation, RelightError> {
    let mut rep = three_i::extract(stack, triple)?;
    rep.chroma = stack.chroma.clone();
    Ok(rep)
}

/// Relights planes (any storage that widens to f64) row by row in parallel. Each pixel's sum
/// runs over the channels in order, so the result is independent of the thread count and of
/// where the pixel sits: a gathered input gives the gathered output, bit for bit.
pub fn relight_planes<T: Copy + Into<f64> + Sync>(planes: &[&[T]], width: usize, kernel: &Kernel) -> Vec<f64> {
    let m = planes.first().map_or(0, |p| p.len());
    let mut out = vec![0.0f64; m];
    relight_into(planes, width, kernel, &mut out, |v| v);
    out
}

/// Relights an f32 map image (a quilted layer) at `light`: f64 arithmetic, f32 output.
pub fn relight_image(maps: &Image, basis: &Basis, light: &Light) -> Result<Image, RelightError> {
    if maps.channels != basis.channels() {
        return Err(RelightError::Channels { got: maps.channels, expected: basis.channels() });
    }
    let kernel = basis.kernel(light)?;
    let planes: Vec<&[f32]> = (0..maps.channels).map(|c| maps.plane(c)).collect();
    let mut out = Image::new(maps.width, maps.height, 1);
    relight_into(&planes, maps.width, &kernel, &mut out.data, |v| v as f32);
    Ok(out)
}

/// Chromaticity × relit luminance: planar RGB.
pub fn colourise(lum: &[f64], chroma: &[f64]) -> Vec<f64> {
    let m = lum.len();
    (0..3 * m).map(|i| chroma[i] * lum[i % m]).collect()
}

fn relight_into<T, O>(planes: &[&[T]], width: usize, kernel: &Kernel, out: &mut [O], put: impl Fn(f64) -> O + Sync)
where
    T: Copy + Into<f64> + Sync,
    O: Send,
{
    if width == 0 || out.is_empty() {
        return;
    }
    match kernel {
        Kernel::Linear(coef) => {
            out.par_chunks_mut(width).enumerate().with_min_len(8).for_each_init(
                || vec![0.0f64; width],
                |acc, (y, row)| {
                    let acc = &mut acc[..row.len()];
                    acc.fill(0.0);
                    let s = y * width;
                    for (plane, &c) in planes.iter().zip(coef) {
                        for (a, &v) in acc.iter_mut().zip(&plane[s..s + row.len()]) {
                            *a += c * v.into();
                        }
                    }
                    for (o, &a) in row.iter_mut().zip(acc.iter()) {
                        *o = put(a);
                    }
                },
            );
        }
        Kernel::Lambert(l) => {
            let (p, q, al) = (planes[0], planes[1], planes[2]);
            out.par_chunks_mut(width).enumerate().with_min_len(8).for_each(|(y, row)| {
                let s = y * width;
                for (x, o) in row.iter_mut().enumerate() {
                    *o = put(lambert(p[s + x].into(), q[s + x].into(), al[s + x].into(), *l));
                }
            });
        }
    }
}

/// The stack's Gram matrix `IᵀI` (row-major `n × n`).
pub fn gram_of(stack: &PhotoStack) -> Vec<f64> {
    eigen::gram(&planes(stack))
}

/// Eigen-k from a known Gram matrix of `stack` (leave-one-out reuses the full stack's).
pub fn extract_eigen_with_gram(stack: &PhotoStack, k: usize, gram: &[f64]) -> Result<Representation, RelightError> {
    let mut rep = eigen::extract_with_gram(stack, k, gram)?;
    rep.chroma = stack.chroma.clone();
    Ok(rep)
}

/// Every singular value of the stack, descending.
pub fn singular_values(stack: &PhotoStack) -> Vec<f64> {
    let n = stack.len();
    let eig = nalgebra::SymmetricEigen::new(DMatrix::from_row_slice(n, n, &gram_of(stack)));
    let mut w: Vec<f64> = eig.eigenvalues.iter().map(|&l| l.max(0.0).sqrt()).collect();
    w.sort_by(|a, b| b.total_cmp(a));
    w
}

#[cfg(test)]
mod tests;
