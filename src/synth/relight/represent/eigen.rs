//! Eigen-k: the first `k` uncentred singular components of the stack (Epstein), relit by
//! interpolating their mixing coefficients over the captured light grid
//! [references: dong §4.4.4]
//!
//! The SVD of the tall `pixels × n` matrix comes from the `n × n` Gram matrix `IᵀI`: its
//! eigenvectors are `V`, its eigenvalues `w²`, and `M1 = I V_k = U_k W_k`. With `n` around 36
//! the Gram matrix is one pass over the data and a tiny eigenproblem; in f64 the top
//! components are accurate far beyond what relighting needs (squaring the condition number only
//! touches the components near the noise floor, which rank `k` drops).

use nalgebra::{DMatrix, SymmetricEigen};
use rayon::prelude::*;

use super::types::{planes, project, Basis, EigenBasis, Method, Representation};
use crate::synth::relight::error::RelightError;
use crate::synth::relight::light::{Light, SAME_DEG};
use crate::synth::relight::stack::PhotoStack;

impl EigenBasis {
    fn column(&self, i: usize) -> impl Iterator<Item = f64> + '_ {
        let n = self.lights.len();
        (0..self.k).map(move |c| self.m2[c * n + i])
    }

    /// Weights over the captured lights for `light` (4.4.16): linear in slant between the two
    /// grid slants around it, and within each of those slants linear in tilt between the
    /// nearest captured tilts on either side (periodic, so 345° lies between 330° and 0°).
    /// Brackets are the nearest *available* nodes, so a light whose own node is missing (left
    /// out) is the tilt-mean of its neighbours. Slants outside the grid are an error.
    pub fn weights(&self, light: &Light) -> Result<Vec<(usize, f64)>, RelightError> {
        let mut slants: Vec<f64> = self.lights.iter().map(|l| l.slant_deg).collect();
        slants.sort_by(f64::total_cmp);
        slants.dedup_by(|a, b| (*a - *b).abs() < SAME_DEG);
        let (lo, hi) = (slants[0], slants[slants.len() - 1]);
        let s = light.slant_deg;
        if !(s > lo - SAME_DEG && s < hi + SAME_DEG) {
            return Err(RelightError::SlantOutsideGrid { slant_deg: s, min_deg: lo, max_deg: hi });
        }
        let j = slants.iter().rposition(|&g| g <= s + SAME_DEG).unwrap_or(0);
        let rows: Vec<(f64, f64)> = if (s - slants[j]).abs() < SAME_DEG || j + 1 == slants.len() {
            vec![(slants[j], 1.0)]
        } else {
            let t2 = (s - slants[j]) / (slants[j + 1] - slants[j]);
            vec![(slants[j], 1.0 - t2), (slants[j + 1], t2)]
        };
        let mut out = Vec::new();
        for (row_slant, wrow) in rows {
            let mut nodes: Vec<(f64, usize)> = (0..self.lights.len())
                .filter(|&i| (self.lights[i].slant_deg - row_slant).abs() < SAME_DEG)
                .map(|i| (self.lights[i].tilt_deg, i))
                .collect();
            nodes.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            for (i, w) in tilt_weights(&nodes, light.tilt_deg, row_slant.abs() < SAME_DEG) {
                out.push((i, wrow * w));
            }
        }
        Ok(out)
    }

    /// The interpolated coefficient vector `c` for `light`.
    pub fn coefficients(&self, light: &Light) -> Result<Vec<f64>, RelightError> {
        let mut c = vec![0.0; self.k];
        for (i, w) in self.weights(light)? {
            for (a, v) in c.iter_mut().zip(self.column(i)) {
                *a += w * v;
            }
        }
        Ok(c)
    }
}

/// Periodic linear weights over the sorted `(tilt, index)` nodes of one slant row. At slant 0
/// every tilt is the same direction: the row's nodes are averaged.
fn tilt_weights(nodes: &[(f64, usize)], tilt: f64, overhead: bool) -> Vec<(usize, f64)> {
    if overhead {
        let w = 1.0 / nodes.len() as f64;
        return nodes.iter().map(|&(_, i)| (i, w)).collect();
    }
    if let Some(&(_, i)) = nodes.iter().find(|(t, _)| {
        let d = (t - tilt).rem_euclid(360.0);
        d.min(360.0 - d) < SAME_DEG
    }) {
        return vec![(i, 1.0)];
    }
    if nodes.len() == 1 {
        return vec![(nodes[0].1, 1.0)];
    }
    // The first node above the tilt, cyclically; its predecessor is below.
    let up = nodes.iter().position(|(t, _)| *t > tilt).unwrap_or(0);
    let down = (up + nodes.len() - 1) % nodes.len();
    let (t_lo, t_hi) = (nodes[down].0, nodes[up].0);
    let span = (t_hi - t_lo).rem_euclid(360.0);
    let t1 = (tilt - t_lo).rem_euclid(360.0) / span;
    vec![(nodes[down].1, 1.0 - t1), (nodes[up].1, t1)]
}

/// `f_indi(k) = w_k / sqrt(Σ w²)` and `f_cumu(k) = sqrt(Σ_{i≤k} w_i² / Σ w²)` (4.4.12/13)
/// [references: dong §4.4.4]
pub fn information(singular_values: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let total: f64 = singular_values.iter().map(|w| w * w).sum();
    if total <= 0.0 {
        return (vec![0.0; singular_values.len()], vec![0.0; singular_values.len()]);
    }
    let indi = singular_values.iter().map(|w| (w * w / total).sqrt()).collect();
    let mut acc = 0.0;
    let cumu = singular_values
        .iter()
        .map(|w| {
            acc += w * w;
            (acc / total).sqrt()
        })
        .collect();
    (indi, cumu)
}

/// Pixels per chunk of the Gram sum: the chunk's 36 image slices (2.4 MB) stay in cache
/// while all pairs are formed.
const CHUNK: usize = 8192;

/// `IᵀI` (row-major `n × n`), summed over fixed pixel chunks in chunk order.
pub(crate) fn gram(images: &[&[f64]]) -> Vec<f64> {
    let n = images.len();
    let m = images[0].len();
    let partial: Vec<Vec<f64>> = (0..m.div_ceil(CHUNK))
        .into_par_iter()
        .map(|ch| {
            let r = ch * CHUNK..((ch + 1) * CHUNK).min(m);
            let mut g = vec![0.0; n * n];
            for a in 0..n {
                for b in a..n {
                    g[a * n + b] = dot(&images[a][r.clone()], &images[b][r.clone()]);
                }
            }
            g
        })
        .collect();
    let mut g = vec![0.0; n * n];
    for p in &partial {
        for (a, v) in g.iter_mut().zip(p) {
            *a += v;
        }
    }
    for a in 0..n {
        for b in 0..a {
            g[a * n + b] = g[b * n + a];
        }
    }
    g
}

/// A dot product with four fixed partial sums (vectorises; the order is fixed).
fn dot(x: &[f64], y: &[f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    let (xc, yc) = (x.chunks_exact(4), y.chunks_exact(4));
    let (xr, yr) = (xc.remainder(), yc.remainder());
    for (a, b) in xc.zip(yc) {
        for i in 0..4 {
            acc[i] += a[i] * b[i];
        }
    }
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for (a, b) in xr.iter().zip(yr) {
        s += a * b;
    }
    s
}

/// Eigen-k of a stack whose Gram matrix is known (leave-one-out reuses the full one).
pub(crate) fn extract_with_gram(stack: &PhotoStack, k: usize, g: &[f64]) -> Result<Representation, RelightError> {
    let n = stack.len();
    if k == 0 || k > n {
        return Err(RelightError::EigenRank { k, n });
    }
    let eig = SymmetricEigen::new(DMatrix::from_row_slice(n, n, g));
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]).then(a.cmp(&b)));
    let singular_values: Vec<f64> = order.iter().map(|&i| eig.eigenvalues[i].max(0.0).sqrt()).collect();
    // M2 rows = the first k eigenvectors, each signed so its largest-magnitude entry (first on
    // ties) is positive: the SVD leaves the sign free, goldens need one.
    let mut m2 = vec![0.0; k * n];
    for (c, &i) in order.iter().take(k).enumerate() {
        let v = eig.eigenvectors.column(i);
        let big = (0..n).fold(0, |best, r| if v[r].abs() > v[best].abs() { r } else { best });
        let sign = if v[big] < 0.0 { -1.0 } else { 1.0 };
        for r in 0..n {
            m2[c * n + r] = sign * v[r];
        }
    }
    // M1 = I V_k: V_k is n × k row-major = M2 transposed.
    let vk: Vec<f64> = (0..n * k).map(|i| m2[(i % k) * n + i / k]).collect();
    let maps = project(&planes(stack), stack.width, &vk, k);
    Ok(Representation {
        method: Method::Eigen(k),
        width: stack.width,
        height: stack.height,
        maps,
        basis: Basis::Eigen(EigenBasis { k, lights: stack.lights.clone(), m2, singular_values }),
        chroma: None,
        flagged: 0,
    })
}

pub(super) fn extract(stack: &PhotoStack, k: usize) -> Result<Representation, RelightError> {
    if k == 0 || k > stack.len() {
        return Err(RelightError::EigenRank { k, n: stack.len() });
    }
    extract_with_gram(stack, k, &gram(&planes(stack)))
}
