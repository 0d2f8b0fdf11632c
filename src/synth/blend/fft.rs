//! Two-dimensional complex FFTs (rustfft, f64) and the exact Poisson solves built on them.
//!
//! Also used by `synth::metrics` (power spectra) and `synth::library` (Fourier features), so
//! the 2-D transform lives here once.
//!
//! Rows are transformed in parallel, then columns (through a transpose); every output value
//! is computed by one thread in a fixed order, so results do not depend on the thread count.

use std::sync::Arc;

use rayon::prelude::*;
use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftPlanner};

/// A planned 2-D FFT for `width × height` row-major complex data.
pub struct Fft2 {
    width: usize,
    height: usize,
    row_fwd: Arc<dyn Fft<f64>>,
    row_inv: Arc<dyn Fft<f64>>,
    col_fwd: Arc<dyn Fft<f64>>,
    col_inv: Arc<dyn Fft<f64>>,
}

impl Fft2 {
    pub fn new(width: usize, height: usize) -> Self {
        let mut planner = FftPlanner::new();
        Fft2 {
            width,
            height,
            row_fwd: planner.plan_fft_forward(width.max(1)),
            row_inv: planner.plan_fft_inverse(width.max(1)),
            col_fwd: planner.plan_fft_forward(height.max(1)),
            col_inv: planner.plan_fft_inverse(height.max(1)),
        }
    }

    /// Forward transform in place, unnormalised: `X(k, l) = Σ x(m, n) e^{-2πi(km/W + ln/H)}`.
    pub fn forward(&self, data: &mut [Complex64]) {
        self.run(data, &self.row_fwd, &self.col_fwd);
    }

    /// Inverse transform in place, unnormalised (divide by `W·H` for the true inverse).
    pub fn inverse(&self, data: &mut [Complex64]) {
        self.run(data, &self.row_inv, &self.col_inv);
    }

    fn run(&self, data: &mut [Complex64], row: &Arc<dyn Fft<f64>>, col: &Arc<dyn Fft<f64>>) {
        let (w, h) = (self.width, self.height);
        assert_eq!(data.len(), w * h, "Fft2: buffer size");
        if w == 0 || h == 0 {
            return;
        }
        transform_rows(data, w, row);
        let mut t = transpose(data, w, h);
        transform_rows(&mut t, h, col);
        let back = transpose(&t, h, w);
        data.copy_from_slice(&back);
    }
}

fn transform_rows(data: &mut [Complex64], len: usize, fft: &Arc<dyn Fft<f64>>) {
    let scratch_len = fft.get_inplace_scratch_len();
    data.par_chunks_mut(len).with_min_len(8).for_each_init(
        || vec![Complex64::new(0.0, 0.0); scratch_len],
        |scratch, row| fft.process_with_scratch(row, scratch),
    );
}

/// Transposes a `w × h` row-major buffer into an `h × w` one.
fn transpose(src: &[Complex64], w: usize, h: usize) -> Vec<Complex64> {
    let mut out = vec![Complex64::new(0.0, 0.0); w * h];
    out.par_chunks_mut(h).enumerate().for_each(|(x, col)| {
        for (y, v) in col.iter_mut().enumerate() {
            *v = src[y * w + x];
        }
    });
    out
}

/// Forward 2-D DFT of a real plane (unnormalised), as complex values.
pub fn fft_real(plane: &[f64], width: usize, height: usize) -> Vec<Complex64> {
    let mut data: Vec<Complex64> = plane.iter().map(|&v| Complex64::new(v, 0.0)).collect();
    Fft2::new(width, height).forward(&mut data);
    data
}

/// Eigenvalue of the periodic 5-point operator `L f = 4 f_p − Σ_q f_q` at frequency `(k, l)`.
#[inline]
fn periodic_eigen(k: usize, l: usize, w: usize, h: usize) -> f64 {
    let cx = (std::f64::consts::TAU * k as f64 / w as f64).cos();
    let cy = (std::f64::consts::TAU * l as f64 / h as f64).cos();
    4.0 - 2.0 * cx - 2.0 * cy
}

/// Solves `L f = b` on the `w × h` torus exactly (to round-off) and returns the solution
/// whose mean is `mean`. The component of `b` along the constants (its mean) is ignored:
/// the periodic operator annihilates constants, so a consistent `b` sums to zero.
pub fn solve_periodic(b: &[f64], w: usize, h: usize, mean: f64) -> Vec<f64> {
    let fft = Fft2::new(w, h);
    let mut data: Vec<Complex64> = b.iter().map(|&v| Complex64::new(v, 0.0)).collect();
    fft.forward(&mut data);
    let n = (w * h) as f64;
    data.par_chunks_mut(w).enumerate().for_each(|(l, row)| {
        for (k, v) in row.iter_mut().enumerate() {
            if k == 0 && l == 0 {
                *v = Complex64::new(mean * n, 0.0);
            } else {
                *v /= periodic_eigen(k, l, w, h);
            }
        }
    });
    fft.inverse(&mut data);
    data.iter().map(|c| c.re / n).collect()
}

/// Solves the Neumann (free boundary) problem `L f = b` on the `w × h` grid graph, where
/// `L` is the graph Laplacian (degree minus neighbours, no wrap), with solution mean `mean`.
///
/// The half-sample even extension of `b` to `2w × 2h` turns the grid-graph Laplacian into
/// the periodic one restricted to mirror-symmetric fields (a cell on the edge sees itself
/// across the mirror, which cancels its missing neighbour), so one periodic solve on the
/// extension, cropped, is the exact Neumann solution: the DCT-II diagonalisation done through
/// an FFT of twice the size. Costs four times a periodic solve of the same image.
pub fn solve_neumann(b: &[f64], w: usize, h: usize, mean: f64) -> Vec<f64> {
    let (w2, h2) = (2 * w, 2 * h);
    let mut ext = vec![0.0; w2 * h2];
    for y in 0..h2 {
        let sy = if y < h { y } else { h2 - 1 - y };
        for x in 0..w2 {
            let sx = if x < w { x } else { w2 - 1 - x };
            ext[y * w2 + x] = b[sy * w + sx];
        }
    }
    let full = solve_periodic(&ext, w2, h2, mean);
    let mut out = vec![0.0; w * h];
    for y in 0..h {
        out[y * w..(y + 1) * w].copy_from_slice(&full[y * w2..y * w2 + w]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn naive_dft(x: &[f64], w: usize, h: usize) -> Vec<Complex64> {
        let mut out = vec![Complex64::new(0.0, 0.0); w * h];
        for l in 0..h {
            for k in 0..w {
                let mut s = Complex64::new(0.0, 0.0);
                for n in 0..h {
                    for m in 0..w {
                        let a =
                            -std::f64::consts::TAU * (k as f64 * m as f64 / w as f64 + l as f64 * n as f64 / h as f64);
                        s += Complex64::new(a.cos(), a.sin()) * x[n * w + m];
                    }
                }
                out[l * w + k] = s;
            }
        }
        out
    }

    #[test]
    fn fft_matches_naive_dft_on_non_square_sizes() {
        let (w, h) = (6, 5);
        let x: Vec<f64> = (0..w * h).map(|i| ((i * 37 % 11) as f64).sin()).collect();
        let a = fft_real(&x, w, h);
        let b = naive_dft(&x, w, h);
        for (p, q) in a.iter().zip(&b) {
            assert!((p - q).norm() < 1e-9);
        }
        let mut back = a.clone();
        Fft2::new(w, h).inverse(&mut back);
        for (p, q) in back.iter().zip(&x) {
            assert!((p.re / (w * h) as f64 - q).abs() < 1e-12);
        }
    }

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
