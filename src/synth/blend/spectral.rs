//! Exact Poisson solves of whole domains by fast transforms (see `synth::fft`).
//!
//! On the torus the 5-point Laplacian is diagonalised by the 2-D DFT; on the grid graph with a
//! free (Neumann) border by the 2-D DCT-II. Both inputs are real, so the periodic solve uses the
//! half spectrum of a real FFT and the Neumann one a real DCT: no complex work on real data.

use rayon::prelude::*;
use rustfft::num_complex::Complex64;

use crate::synth::fft::{Dct2, RealFft2};

/// `2 − 2 cos(π·k·step)` for `k < count`: the eigenvalues of the 1-D second difference, with
/// `step = 2/n` on a cycle of `n` (DFT) and `step = 1/n` on a path of `n` (DCT-II).
fn eigen_1d(count: usize, step: f64) -> Vec<f64> {
    (0..count).map(|k| 2.0 - 2.0 * (std::f64::consts::PI * k as f64 * step).cos()).collect()
}

/// Solves `L f = b` on the `w × h` torus exactly (to round-off) and returns the solution
/// whose mean is `mean`, where `L f = 4 f_p − Σ_q f_q`. The component of `b` along the
/// constants (its mean) is ignored: the periodic operator annihilates constants, so a
/// consistent `b` sums to zero.
pub fn solve_periodic(b: &[f64], w: usize, h: usize, mean: f64) -> Vec<f64> {
    let fft = RealFft2::new(w, h);
    let mut spec = fft.forward(b);
    let n = (w * h) as f64;
    let ex = eigen_1d(fft.half_width(), 2.0 / w as f64);
    let ey = eigen_1d(h, 2.0 / h as f64);
    spec.par_chunks_mut(fft.stride()).zip(ex).enumerate().for_each(|(k, (col, ex))| {
        for (l, (v, ey)) in col.iter_mut().zip(&ey).enumerate() {
            // The inverse transform's 1/(W·H) is folded in here, saving a pass over the plane.
            *v = if k == 0 && l == 0 { Complex64::new(mean, 0.0) } else { *v / ((ex + ey) * n) };
        }
    });
    fft.inverse(&mut spec)
}

/// Solves the Neumann (free boundary) problem `L f = b` on the `w × h` grid graph, where
/// `L` is the graph Laplacian (degree minus neighbours, no wrap), with solution mean `mean`.
///
/// The DCT-II basis `cos(π(m + ½)k/W)·cos(π(n + ½)l/H)` is mirror-symmetric about the half
/// samples outside the border, where a cell sees itself across the mirror, which cancels its
/// missing neighbour: so it diagonalises the grid-graph Laplacian with eigenvalues
/// `(2 − 2 cos(πk/W)) + (2 − 2 cos(πl/H))`. The DCT-III brings the solution back.
pub fn solve_neumann(b: &[f64], w: usize, h: usize, mean: f64) -> Vec<f64> {
    let dct = Dct2::new(w, h);
    let mut coef = dct.forward(b);
    let n = (w * h) as f64;
    let ex = eigen_1d(w, 1.0 / w as f64);
    let ey = eigen_1d(h, 1.0 / h as f64);
    coef.par_chunks_mut(dct.stride()).zip(ex).enumerate().for_each(|(k, (col, ex))| {
        for (l, (v, ey)) in col.iter_mut().zip(&ey).enumerate() {
            // DCT-III after DCT-II multiplies by W·H/4: the 4/(W·H) is folded in here.
            *v = if k == 0 && l == 0 { mean * 4.0 } else { *v * 4.0 / ((ex + ey) * n) };
        }
    });
    dct.inverse(&mut coef)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn apply(f: &[f64], w: usize, h: usize, periodic: bool) -> Vec<f64> {
        let mut out = vec![0.0; w * h];
        for y in 0..h {
            for x in 0..w {
                let mut s = 0.0;
                let mut deg = 0.0;
                let mut add = |xx: isize, yy: isize| {
                    let (xx, yy) = if periodic {
                        (xx.rem_euclid(w as isize), yy.rem_euclid(h as isize))
                    } else if xx < 0 || yy < 0 || xx >= w as isize || yy >= h as isize {
                        return;
                    } else {
                        (xx, yy)
                    };
                    s += f[yy as usize * w + xx as usize];
                    deg += 1.0;
                };
                let (xi, yi) = (x as isize, y as isize);
                add(xi - 1, yi);
                add(xi + 1, yi);
                add(xi, yi - 1);
                add(xi, yi + 1);
                out[y * w + x] = deg * f[y * w + x] - s;
            }
        }
        out
    }

    #[test]
    fn periodic_and_neumann_solves_are_exact() {
        for &(w, h) in &[(8usize, 8usize), (12, 7), (1, 5)] {
            for periodic in [true, false] {
                let f: Vec<f64> = (0..w * h).map(|i| ((i * 13 % 17) as f64 * 0.3).cos()).collect();
                let mean = f.iter().sum::<f64>() / (w * h) as f64;
                let b = apply(&f, w, h, periodic);
                let g = if periodic { solve_periodic(&b, w, h, mean) } else { solve_neumann(&b, w, h, mean) };
                for (p, q) in f.iter().zip(&g) {
                    assert!((p - q).abs() < 1e-9, "{w}x{h} periodic={periodic}: {p} vs {q}");
                }
            }
        }
    }
}
