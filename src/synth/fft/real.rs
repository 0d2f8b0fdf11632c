//! Real-input transforms: the half-spectrum 2-D FFT and the 2-D DCT.

use std::sync::Arc;

use rayon::prelude::*;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use rustdct::{DctPlanner, TransformType2And3};
use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftPlanner};

use super::rows::{fft_rows, for_rows, transpose, PAD};

const ZERO: Complex64 = Complex64::new(0.0, 0.0);

/// A planned 2-D FFT of a real `width × height` row-major plane.
///
/// The spectrum of real data is Hermitian (`X(−k) = conj X(k)`), so only columns
/// `kx ∈ 0..=width/2` are computed: each row by a real-to-complex FFT (half the work of a
/// complex one), then each of those columns by a complex FFT. The spectrum is stored transposed:
/// `kx * stride() + ky`, with `ky < height` (the rest of each row is padding).
pub struct RealFft2 {
    width: usize,
    height: usize,
    /// Columns of the half spectrum, `width/2 + 1`.
    half: usize,
    stride: usize,
    r2c: Arc<dyn RealToComplex<f64>>,
    c2r: Arc<dyn ComplexToReal<f64>>,
    col_fwd: Arc<dyn Fft<f64>>,
    col_inv: Arc<dyn Fft<f64>>,
}

impl RealFft2 {
    pub fn new(width: usize, height: usize) -> Self {
        let mut real = RealFftPlanner::<f64>::new();
        let mut complex = FftPlanner::<f64>::new();
        RealFft2 {
            width,
            height,
            half: width / 2 + 1,
            stride: height + PAD,
            r2c: real.plan_fft_forward(width.max(1)),
            c2r: real.plan_fft_inverse(width.max(1)),
            col_fwd: complex.plan_fft_forward(height.max(1)),
            col_inv: complex.plan_fft_inverse(height.max(1)),
        }
    }

    /// Columns `kx` of the half spectrum: `0..half_width()`.
    pub fn half_width(&self) -> usize {
        self.half
    }

    /// Distance between consecutive `kx` in the (transposed) spectrum.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// Index of frequency `(kx, ky)`, `kx < half_width()`, in the spectrum.
    pub fn index(&self, kx: usize, ky: usize) -> usize {
        kx * self.stride + ky
    }

    /// Forward transform, unnormalised: `X(k, l) = Σ x(m, n) e^{-2πi(km/W + ln/H)}` for
    /// `k < half_width()`, as a transposed spectrum (see the type's documentation).
    pub fn forward(&self, plane: &[f64]) -> Vec<Complex64> {
        let (w, h, half) = (self.width, self.height, self.half);
        assert_eq!(plane.len(), w * h, "RealFft2: plane size");
        let mut spec = vec![ZERO; half * self.stride];
        if w == 0 || h == 0 {
            return spec;
        }
        let mut rows = vec![ZERO; h * half];
        let scratch_len = self.r2c.get_scratch_len();
        // realfft destroys its input, so each row goes through a per-task copy.
        rows.par_chunks_mut(half).zip(plane.par_chunks(w)).with_min_len(8).for_each_init(
            || (vec![0.0; w], vec![ZERO; scratch_len]),
            |(line, scratch), (out, row)| {
                line.copy_from_slice(row);
                self.r2c.process_with_scratch(line, out, scratch).expect("RealFft2: row lengths");
            },
        );
        transpose(&rows, half, h, half, &mut spec, self.stride, true);
        fft_rows(&self.col_fwd, &mut spec, h, self.stride, true);
        spec
    }

    /// Inverse of [`RealFft2::forward`], unnormalised (divide by `W·H` for the true inverse).
    /// `spec` is destroyed. The imaginary parts that a Hermitian spectrum cannot carry (at
    /// `kx = 0` and, for even widths, `kx = W/2`, after the column transforms) are dropped.
    pub fn inverse(&self, spec: &mut [Complex64]) -> Vec<f64> {
        let (w, h, half) = (self.width, self.height, self.half);
        assert_eq!(spec.len(), half * self.stride, "RealFft2: spectrum size");
        let mut out = vec![0.0; w * h];
        if w == 0 || h == 0 {
            return out;
        }
        fft_rows(&self.col_inv, spec, h, self.stride, true);
        let mut rows = vec![ZERO; h * half];
        transpose(spec, self.stride, half, h, &mut rows, half, true);
        let scratch_len = self.c2r.get_scratch_len();
        out.par_chunks_mut(w).zip(rows.par_chunks_mut(half)).with_min_len(8).for_each_init(
            || vec![ZERO; scratch_len],
            |scratch, (out, row)| {
                row[0].im = 0.0;
                if w % 2 == 0 {
                    row[half - 1].im = 0.0;
                }
                self.c2r.process_with_scratch(row, out, scratch).expect("RealFft2: row lengths");
            },
        );
        out
    }
}

/// Forward 2-D DFT of a real plane (unnormalised), as the full row-major complex spectrum
/// `ky * width + kx`; the columns beyond the half spectrum are its Hermitian mirror.
pub fn fft_real(plane: &[f64], width: usize, height: usize) -> Vec<Complex64> {
    let fft = RealFft2::new(width, height);
    let spec = fft.forward(plane);
    let mut out = vec![ZERO; width * height];
    out.par_chunks_mut(width.max(1)).enumerate().for_each(|(ky, row)| {
        for (kx, v) in row.iter_mut().enumerate() {
            *v = if kx < fft.half {
                spec[fft.index(kx, ky)]
            } else {
                spec[fft.index(width - kx, (height - ky) % height)].conj()
            };
        }
    });
    out
}

/// A planned separable 2-D DCT of a real `width × height` row-major plane.
///
/// DCT-II: `C(k, l) = Σ x(m, n) cos(π(m + ½)k/W) cos(π(n + ½)l/H)`; DCT-III is its inverse up
/// to the factor `W·H/4`. Coefficients are stored transposed: `k * stride() + l`.
pub struct Dct2 {
    width: usize,
    height: usize,
    /// Row strides of the padded x-major rows and of the transposed coefficients.
    sx: usize,
    stride: usize,
    row: Arc<dyn TransformType2And3<f64>>,
    col: Arc<dyn TransformType2And3<f64>>,
}

impl Dct2 {
    pub fn new(width: usize, height: usize) -> Self {
        let mut planner = DctPlanner::new();
        Dct2 {
            width,
            height,
            sx: width + PAD,
            stride: height + PAD,
            row: planner.plan_dct2(width.max(1)),
            col: planner.plan_dct2(height.max(1)),
        }
    }

    /// Distance between consecutive `k` in the (transposed) coefficients.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// DCT-II along both axes, as transposed coefficients.
    pub fn forward(&self, plane: &[f64]) -> Vec<f64> {
        let (w, h) = (self.width, self.height);
        assert_eq!(plane.len(), w * h, "Dct2: plane size");
        let mut coef = vec![0.0; w * self.stride];
        if w == 0 || h == 0 {
            return coef;
        }
        let mut rows = vec![0.0; h * self.sx];
        for (row, src) in rows.chunks_mut(self.sx).zip(plane.chunks(w)) {
            row[..w].copy_from_slice(src);
        }
        dct_rows(&self.row, &mut rows, w, self.sx, false);
        transpose(&rows, self.sx, h, w, &mut coef, self.stride, true);
        dct_rows(&self.col, &mut coef, h, self.stride, false);
        coef
    }

    /// DCT-III along both axes of transposed coefficients (destroyed): `W·H/4` times the inverse
    /// of [`Dct2::forward`].
    pub fn inverse(&self, coef: &mut [f64]) -> Vec<f64> {
        let (w, h) = (self.width, self.height);
        assert_eq!(coef.len(), w * self.stride, "Dct2: coefficients size");
        let mut out = vec![0.0; w * h];
        if w == 0 || h == 0 {
            return out;
        }
        dct_rows(&self.col, coef, h, self.stride, true);
        let mut rows = vec![0.0; h * self.sx];
        transpose(coef, self.stride, w, h, &mut rows, self.sx, true);
        dct_rows(&self.row, &mut rows, w, self.sx, true);
        for (dst, row) in out.chunks_mut(w).zip(rows.chunks(self.sx)) {
            dst.copy_from_slice(&row[..w]);
        }
        out
    }
}

/// DCT-II (or, with `inverse`, DCT-III) of every row (`n` values at the start of each
/// `stride`-long row), in place and in parallel.
fn dct_rows(dct: &Arc<dyn TransformType2And3<f64>>, data: &mut [f64], n: usize, stride: usize, inverse: bool) {
    let scratch_len = dct.get_scratch_len();
    for_rows(
        data,
        stride,
        true,
        || vec![0.0; scratch_len],
        |scratch, row| {
            if inverse {
                dct.process_dct3_with_scratch(&mut row[..n], scratch);
            } else {
                dct.process_dct2_with_scratch(&mut row[..n], scratch);
            }
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    fn naive_dft(x: &[f64], w: usize, h: usize) -> Vec<Complex64> {
        let mut out = vec![ZERO; w * h];
        for l in 0..h {
            for k in 0..w {
                let mut s = ZERO;
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
    fn real_fft_matches_naive_dft_and_inverts() {
        for &(w, h) in &[(6usize, 5usize), (7, 4), (1, 3), (8, 1)] {
            let x: Vec<f64> = (0..w * h).map(|i| ((i * 37 % 11) as f64).sin()).collect();
            let a = fft_real(&x, w, h);
            let b = naive_dft(&x, w, h);
            for (p, q) in a.iter().zip(&b) {
                assert!((p - q).norm() < 1e-9, "{w}x{h}: {p} vs {q}");
            }
            let fft = RealFft2::new(w, h);
            let mut spec = fft.forward(&x);
            let back = fft.inverse(&mut spec);
            for (p, q) in back.iter().zip(&x) {
                assert!((p / (w * h) as f64 - q).abs() < 1e-12, "{w}x{h}: {p} vs {q}");
            }
        }
    }

    #[test]
    fn dct_matches_definition_and_inverts() {
        let (w, h) = (5usize, 4usize);
        let x: Vec<f64> = (0..w * h).map(|i| ((i * 7 % 13) as f64 * 0.4).cos()).collect();
        let dct = Dct2::new(w, h);
        let mut coef = dct.forward(&x);
        let pi = std::f64::consts::PI;
        for l in 0..h {
            for k in 0..w {
                let mut s = 0.0;
                for n in 0..h {
                    for m in 0..w {
                        s += x[n * w + m]
                            * (pi * (m as f64 + 0.5) * k as f64 / w as f64).cos()
                            * (pi * (n as f64 + 0.5) * l as f64 / h as f64).cos();
                    }
                }
                assert!((coef[k * dct.stride() + l] - s).abs() < 1e-9, "({k}, {l})");
            }
        }
        let back = dct.inverse(&mut coef);
        for (p, q) in back.iter().zip(&x) {
            assert!((p * 4.0 / (w * h) as f64 - q).abs() < 1e-12);
        }
    }
}
