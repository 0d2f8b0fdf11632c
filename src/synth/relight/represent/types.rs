//! The plain data of representations (methods, bases, maps) and the per-pixel solves the
//! methods share; what relights them lives beside the methods, in the parent module, so that
//! no two files import each other.

use glam::DVec3;
use nalgebra::DMatrix;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::synth::relight::light::Light;
use crate::synth::relight::stack::PhotoStack;

/// A representation method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Three raw images, `c = L3⁻¹ l` (Shashua).
    ThreeI,
    /// Photometric stereo `(p, q, albedo)`, Lambert relighting.
    Gradient,
    /// Malzbender's six polynomial coefficients.
    Ptm,
    /// The first `k` eigen base images, coefficients interpolated on the light grid.
    Eigen(usize),
}

impl Method {
    pub fn name(&self) -> String {
        match self {
            Method::ThreeI => "3I".into(),
            Method::Gradient => "Gradient".into(),
            Method::Ptm => "PTM".into(),
            Method::Eigen(k) => format!("Eigen{k}"),
        }
    }

    /// The number of maps (channels) the method produces.
    pub fn channels(&self) -> usize {
        match self {
            Method::ThreeI | Method::Gradient => 3,
            Method::Ptm => 6,
            Method::Eigen(k) => *k,
        }
    }
}

/// The global half of a representation: what turns a light into the per-pixel rule.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Basis {
    /// The three lights of the maps and `L3⁻¹` (row-major), so `c = L3⁻¹ l`.
    ThreeI { lights: [Light; 3], inverse: [[f64; 3]; 3] },
    /// Maps are `(p, q, albedo)`; relit by the Lambert formula.
    Gradient,
    /// Maps are `a1..a6` against `(l_x², l_y², l_x l_y, l_x, l_y, 1)`.
    Ptm,
    /// `M2` and the light grid it was sampled on.
    Eigen(EigenBasis),
}

/// The per-pixel rule for one light.
#[derive(Clone, Debug, PartialEq)]
pub enum Kernel {
    /// `i = Σ_c coef[c] · map_c`.
    Linear(Vec<f64>),
    /// `i = al · (−p l_x − q l_y + l_z) / sqrt(p² + q² + 1)` on maps `(p, q, al)`: equal to
    /// `N_a · l` with `N_a = al · normalise(−p, −q, 1)`.
    Lambert(DVec3),
}

/// Eigen's basis: `M2` (`k × n`, row-major: row `c` is component `c`'s coefficient in each
/// image), the images' lights, and every singular value of the stack (descending).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EigenBasis {
    pub k: usize,
    pub lights: Vec<Light>,
    pub m2: Vec<f64>,
    pub singular_values: Vec<f64>,
}

/// Per-pixel maps (planar f64, `channels` planes of `width × height`) and their basis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Representation {
    pub method: Method,
    pub width: usize,
    pub height: usize,
    pub maps: Vec<f64>,
    pub basis: Basis,
    /// The stack's chromaticity (three planes), carried along for colour relighting.
    pub chroma: Option<Vec<f64>>,
    /// Gradient only: pixels whose fitted normal had `n_z < NZ_MIN` (it points away from
    /// the camera or lies in the image plane), where `n_z` was raised to the guard.
    pub flagged: usize,
}

/// The stack's images as slices.
pub(super) fn planes(stack: &PhotoStack) -> Vec<&[f64]> {
    stack.images.iter().map(|v| v.as_slice()).collect()
}

/// `out_c[j] = Σ_k images_k[j] · pinv[k·r + c]`: the per-pixel least-squares solve against a
/// precomputed pseudoinverse (`n × r`, row-major), as `r` planes. Rows run in parallel, each
/// summing over the images in order.
pub(super) fn project(images: &[&[f64]], width: usize, pinv: &[f64], r: usize) -> Vec<f64> {
    let m = images[0].len();
    let h = m / width;
    let mut rows = vec![0.0f64; m * r];
    rows.par_chunks_mut(r * width).enumerate().with_min_len(4).for_each(|(y, buf)| {
        let s = y * width;
        for (k, img) in images.iter().enumerate() {
            let src = &img[s..s + width];
            for c in 0..r {
                let a = pinv[k * r + c];
                for (d, &v) in buf[c * width..(c + 1) * width].iter_mut().zip(src) {
                    *d += a * v;
                }
            }
        }
    });
    let mut out = vec![0.0f64; m * r];
    out.par_chunks_mut(m).enumerate().for_each(|(c, plane)| {
        for y in 0..h {
            plane[y * width..(y + 1) * width].copy_from_slice(&rows[(y * r + c) * width..(y * r + c + 1) * width]);
        }
    });
    out
}

/// The pseudoinverse of the `r × n` lighting matrix `l` (row-major), transposed so it is
/// `n × r` row-major, with the extreme singular values (for the rank checks).
pub(super) fn pinv_lights(l: &DMatrix<f64>) -> (Vec<f64>, f64, f64) {
    let svd = l.clone().svd(true, true);
    let smax = svd.singular_values.iter().cloned().fold(0.0, f64::max);
    let smin = svd.singular_values.iter().cloned().fold(f64::INFINITY, f64::min);
    let pinv = svd.pseudo_inverse(smax * 1e-12).expect("both factors were computed"); // n × r
    let (n, r) = pinv.shape();
    let mut out = vec![0.0; n * r];
    for k in 0..n {
        for c in 0..r {
            out[k * r + c] = pinv[(k, c)];
        }
    }
    (out, smin, smax)
}
