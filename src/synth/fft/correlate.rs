//! 2-D FFT cross-correlation of a small template against a whole sample, for quilting's SSD
//! candidate scoring.
//!
//! Two real planes travel in one complex plane (`re + i·im`): for real `a, b, s, t`,
//! `Re(conj(a + i·b)·(s + i·t)) = a·s + b·t`, so the real part of the correlation of the packed template
//! with the packed sample is the sum of the two real correlations. The transform size is the sample
//! size rounded up to a 5-smooth length; candidate positions keep the block inside the sample, so the
//! circular correlation never wraps at a position that is read.
//!
//! Spectra are stored transposed (`kx * ny + ky`), which saves one transpose per block. Rows are
//! transformed independently (in parallel), so results do not depend on the thread count.

use std::sync::Arc;

use rayon::prelude::*;
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};

use super::rows::{fft_rows, min_len, transpose, PAD};

/// Floating type of the transforms. f64 keeps the rounding bound far below any error difference that
/// matters, so the exact re-scoring shortlist stays tiny.
pub(crate) type Real = f64;
pub(crate) type Cx = Complex<Real>;

/// Smallest `m ≥ n` whose prime factors are 2, 3 and 5.
pub(crate) fn fast_len(n: usize) -> usize {
    let mut m = n.max(1);
    loop {
        let mut r = m;
        for p in [2, 3, 5] {
            while r % p == 0 {
                r /= p;
            }
        }
        if r == 1 {
            return m;
        }
        m += 1;
    }
}

/// Transforms padded to the 5-smooth size `nx × ny` of the largest sample.
pub(crate) struct Plan {
    pub nx: usize,
    pub ny: usize,
    /// Row strides of the x-major scratch rows (`nx + PAD`) and of the transposed spectra (`ny + PAD`).
    sx: usize,
    sy: usize,
    fwd_x: Arc<dyn Fft<Real>>,
    fwd_y: Arc<dyn Fft<Real>>,
    inv_x: Arc<dyn Fft<Real>>,
    inv_y: Arc<dyn Fft<Real>>,
}

impl Plan {
    /// A plan for samples up to `width × height`.
    pub fn new(width: usize, height: usize) -> Plan {
        let nx = fast_len(width);
        let ny = fast_len(height);
        let mut planner = FftPlanner::<Real>::new();
        Plan {
            nx,
            ny,
            sx: nx + PAD,
            sy: ny + PAD,
            fwd_x: planner.plan_fft_forward(nx),
            fwd_y: planner.plan_fft_forward(ny),
            inv_x: planner.plan_fft_inverse(nx),
            inv_y: planner.plan_fft_inverse(ny),
        }
    }

    /// Length of a (padded, transposed) spectrum.
    pub fn len(&self) -> usize {
        self.nx * self.sy
    }

    /// Forward 2-D transform of a `w × h` complex plane placed at the origin of an `nx × ny` zero
    /// plane. `rows` is scratch; `out` (length [`Plan::len`]) receives the transposed spectrum.
    pub fn forward(&self, input: &[Cx], w: usize, h: usize, rows: &mut Vec<Cx>, out: &mut [Cx], par: bool) {
        let (nx, ny, sx, sy) = (self.nx, self.ny, self.sx, self.sy);
        debug_assert!(w <= nx && h <= ny && input.len() == w * h && out.len() == self.len());
        rows.resize(h * sx, Cx::new(0.0, 0.0));
        for (row, src) in rows.chunks_mut(sx).zip(input.chunks(w)) {
            row[..w].copy_from_slice(src);
            row[w..].fill(Cx::new(0.0, 0.0));
        }
        fft_rows(&self.fwd_x, &mut rows[..h * sx], nx, sx, par);
        transpose(rows, sx, h, nx, out, sy, par);
        out.par_chunks_mut(sy).with_min_len(min_len(par, 16)).for_each(|col| col[h..].fill(Cx::new(0.0, 0.0)));
        fft_rows(&self.fwd_y, out, ny, sy, par);
    }

    /// Inverse of a transposed spectrum (destroyed): `out[y * cols + x] = Re(·)/(nx·ny) + add` for
    /// `x < cols, y < rows_out`.
    #[allow(clippy::too_many_arguments)]
    pub fn inverse_real(
        &self,
        spec: &mut [Cx],
        cols: usize,
        rows_out: usize,
        add: Real,
        rows: &mut Vec<Cx>,
        out: &mut Vec<Real>,
        par: bool,
    ) {
        let (nx, ny, sx, sy) = (self.nx, self.ny, self.sx, self.sy);
        debug_assert!(cols <= nx && rows_out <= ny);
        fft_rows(&self.inv_y, spec, ny, sy, par);
        rows.resize(rows_out.max(1) * sx, Cx::new(0.0, 0.0));
        transpose(spec, sy, nx, rows_out, rows, sx, par);
        fft_rows(&self.inv_x, &mut rows[..rows_out * sx], nx, sx, par);
        let scale = 1.0 / (nx * ny) as Real;
        out.resize(rows_out * cols, 0.0);
        out.par_chunks_mut(cols).with_min_len(min_len(par, 16)).zip(rows.par_chunks(sx)).for_each(|(o, r)| {
            for (v, c) in o.iter_mut().zip(r) {
                *v = c.re * scale + add;
            }
        });
    }
}

/// `acc[i] (+)= conj(t[i]) · s[i]` (assigns when `first`), in parallel chunks; each element has a
/// fixed operation order.
pub(crate) fn mul_conj_acc(acc: &mut [Cx], t: &[Cx], s: &[Cx], first: bool, par: bool) {
    acc.par_chunks_mut(4096).with_min_len(min_len(par, 1)).zip(t.par_chunks(4096)).zip(s.par_chunks(4096)).for_each(
        |((a, t), s)| {
            if first {
                for ((a, t), s) in a.iter_mut().zip(t).zip(s) {
                    *a = t.conj() * s;
                }
            } else {
                for ((a, t), s) in a.iter_mut().zip(t).zip(s) {
                    *a += t.conj() * s;
                }
            }
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_len_is_5_smooth() {
        assert_eq!(fast_len(1), 1);
        assert_eq!(fast_len(7), 8);
        assert_eq!(fast_len(97), 100);
        assert_eq!(fast_len(256), 256);
        assert_eq!(fast_len(257), 270);
    }

    #[test]
    fn packed_correlation_matches_direct_sum() {
        // Sample 13x11 (non-smooth sizes), template 4x3, two real planes each.
        let (sw, sh, tw, th) = (13usize, 11usize, 4usize, 3usize);
        let f = |x: usize, y: usize, k: usize| ((x * 7 + y * 13 + k * 5) % 17) as Real / 17.0 - 0.3;
        let plan = Plan::new(sw, sh);
        let sample: Vec<Cx> = (0..sh).flat_map(|y| (0..sw).map(move |x| Cx::new(f(x, y, 0), f(x, y, 1)))).collect();
        let tmpl: Vec<Cx> =
            (0..th).flat_map(|y| (0..tw).map(move |x| Cx::new(f(x + 3, y, 2), f(x, y + 5, 3)))).collect();
        let mut rows = Vec::new();
        let mut ss = vec![Cx::new(0.0, 0.0); plan.len()];
        let mut ts = vec![Cx::new(0.0, 0.0); plan.len()];
        plan.forward(&sample, sw, sh, &mut rows, &mut ss, true);
        plan.forward(&tmpl, tw, th, &mut rows, &mut ts, false);
        let mut acc = vec![Cx::new(0.0, 0.0); plan.len()];
        mul_conj_acc(&mut acc, &ts, &ss, true, true);
        let (cols, rws) = (sw - tw + 1, sh - th + 1);
        let mut out = Vec::new();
        plan.inverse_real(&mut acc, cols, rws, 0.0, &mut rows, &mut out, false);
        for qy in 0..rws {
            for qx in 0..cols {
                let mut d = 0.0;
                for py in 0..th {
                    for px in 0..tw {
                        let t = tmpl[py * tw + px];
                        let s = sample[(qy + py) * sw + qx + px];
                        d += t.re * s.re + t.im * s.im;
                    }
                }
                assert!((out[qy * cols + qx] - d).abs() < 1e-12, "{qx},{qy}: {} vs {d}", out[qy * cols + qx]);
            }
        }
    }
}
