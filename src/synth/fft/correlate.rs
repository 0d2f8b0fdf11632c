//! 2-D FFT cross-correlation of small templates against whole samples, for quilting's SSD
//! candidate scoring.
//!
//! Every plane is real, so every spectrum is Hermitian and only its half `kx ∈ 0..=nx/2` is
//! kept (rows by real-to-complex transforms, then complex column transforms): the sum over
//! planes of `conj(T̂)·Ŝ` is then the half spectrum of a real correlation, whose inverse is a
//! complex-to-real transform of half the work of a complex one. The transform size is the
//! sample size rounded up to a 5-smooth length; candidate positions keep the block inside the
//! sample, so the circular correlation never wraps at a position that is read.
//!
//! Spectra are stored transposed (`kx * stride + ky`). A template covers only a block's rows,
//! so [`Plan::correlate`] works one column `kx` at a time: the templates' column transforms,
//! their products with the samples' columns and the inverse column transform of the sum all
//! stay in cache, and no template-sized spectrum is ever zeroed, written or read back; this
//! took the unified textures' quilting from being bound by memory traffic to being bound by
//! the transforms. Each column and each row is transformed by one task with a fixed
//! operation order, so results do not depend on the thread count.

use std::sync::Arc;

use rayon::prelude::*;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};

use super::rows::{min_len, transpose, PAD};

/// Floating type of the transforms. f64 keeps the rounding bound far below any error difference that
/// matters, so the exact re-scoring shortlist stays tiny.
pub(crate) type Real = f64;
pub(crate) type Cx = Complex<Real>;

const ZERO: Cx = Cx::new(0.0, 0.0);

/// Columns `kx` transformed per parallel task (a fixed split: scheduling, never results).
const COLUMNS_PER_TASK: usize = 8;

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
    /// Columns of a half spectrum, `nx/2 + 1`.
    half: usize,
    /// Stride of the transposed spectra (`ny + PAD`) and of the half-spectrum rows (`half + PAD`):
    /// power-of-two strides would make the transposes thrash.
    sy: usize,
    sh: usize,
    /// The column length split as `ny = m·l`, `l` the smallest divisor of `ny` at least a
    /// template's height (see [`Plan::correlate`]).
    l: usize,
    m: usize,
    /// `e^{−2πi·r·y/ny}` at `r·l + y`, `r < m`, `y < l`.
    twiddle: Vec<Cx>,
    r2c: Arc<dyn RealToComplex<Real>>,
    c2r: Arc<dyn ComplexToReal<Real>>,
    fwd_y: Arc<dyn Fft<Real>>,
    inv_y: Arc<dyn Fft<Real>>,
    fwd_l: Arc<dyn Fft<Real>>,
}

/// Buffers of [`Plan::correlate`] kept between calls (their contents never matter: every value
/// read is written first).
#[derive(Default)]
pub(crate) struct Scratch {
    cols_in: Vec<Cx>,
    spec: Vec<Cx>,
    rows: Vec<Cx>,
}

/// Grows `v` to at least `n` elements (new ones zero); never shrinks or clears it.
fn at_least(v: &mut Vec<Cx>, n: usize) -> &mut [Cx] {
    if v.len() < n {
        v.resize(n, ZERO);
    }
    &mut v[..n]
}

/// Per-task buffers of the row transforms.
struct RowScratch {
    line: Vec<Real>,
    fft: Vec<Cx>,
}

/// Per-task buffers of the column pass of [`Plan::correlate`].
struct ColumnScratch {
    col: Vec<Cx>,
    acc: Vec<Cx>,
    nat: Vec<Cx>,
    fft: Vec<Cx>,
}

impl Plan {
    /// A plan for samples up to `width × height` and templates up to `tall` rows.
    pub fn new(width: usize, height: usize, tall: usize) -> Plan {
        let nx = fast_len(width);
        let ny = fast_len(height);
        let half = nx / 2 + 1;
        let l = (tall.clamp(1, ny)..=ny).find(|d| ny % d == 0).unwrap_or(ny);
        let m = ny / l;
        let twiddle = (0..m)
            .flat_map(|r| {
                (0..l).map(move |y| {
                    let (sin, cos) = (-std::f64::consts::TAU * ((r * y) % ny) as f64 / ny as f64).sin_cos();
                    Cx::new(cos, sin)
                })
            })
            .collect();
        let mut real = RealFftPlanner::<Real>::new();
        let mut complex = FftPlanner::<Real>::new();
        Plan {
            nx,
            ny,
            half,
            sy: ny + PAD,
            sh: half + PAD,
            l,
            m,
            twiddle,
            r2c: real.plan_fft_forward(nx),
            c2r: real.plan_fft_inverse(nx),
            fwd_y: complex.plan_fft_forward(ny),
            inv_y: complex.plan_fft_inverse(ny),
            fwd_l: complex.plan_fft_forward(l),
        }
    }

    /// Length of a (half, transposed) spectrum.
    pub fn len(&self) -> usize {
        self.half * self.sy
    }

    fn row_scratch(&self) -> RowScratch {
        let fft = self.r2c.get_scratch_len().max(self.c2r.get_scratch_len());
        RowScratch { line: vec![0.0; self.nx], fft: vec![ZERO; fft] }
    }

    /// Real-to-complex transforms of the `h` rows of a `w`-wide plane, each zero-padded to `nx`,
    /// into rows of `out` (stride `sh`).
    fn forward_rows(&self, plane: &[Real], w: usize, h: usize, out: &mut [Cx], par: bool) {
        out[..h * self.sh]
            .par_chunks_mut(self.sh)
            .zip(plane.par_chunks(w))
            .with_min_len(min_len(par, 8))
            .for_each_init(
                || self.row_scratch(),
                |s, (dst, src)| {
                    s.line[..w].copy_from_slice(src);
                    s.line[w..].fill(0.0);
                    self.r2c.process_with_scratch(&mut s.line, &mut dst[..self.half], &mut s.fft).expect("row lengths");
                },
            );
    }

    /// Forward 2-D transform of a real `w × h` plane placed at the origin of an `nx × ny` zero
    /// plane: `out` (length [`Plan::len`]) receives the transposed half spectrum, each column in
    /// the order [`Plan::correlate`] reads (frequency `m·k + r` at `r·l + k`).
    pub fn forward(&self, plane: &[Real], w: usize, h: usize, out: &mut [Cx], par: bool) {
        let (ny, sy, half, l, m) = (self.ny, self.sy, self.half, self.l, self.m);
        debug_assert!(w <= self.nx && h <= ny && plane.len() == w * h && out.len() == self.len());
        let mut rows = vec![ZERO; h * self.sh];
        self.forward_rows(plane, w, h, &mut rows, par);
        transpose(&rows, self.sh, h, half, out, sy, par);
        let scratch = self.fwd_y.get_inplace_scratch_len();
        out.par_chunks_mut(sy).with_min_len(min_len(par, COLUMNS_PER_TASK)).for_each_init(
            || (vec![ZERO; scratch], vec![ZERO; ny]),
            |(s, nat), col| {
                col[h..ny].fill(ZERO);
                self.fwd_y.process_with_scratch(&mut col[..ny], s);
                nat.copy_from_slice(&col[..ny]);
                for r in 0..m {
                    for k in 0..l {
                        col[r * l + k] = nat[m * k + r];
                    }
                }
            },
        );
    }

    /// The correlations of real `bw × bh` templates with samples, summed:
    /// `out[qy * cols + qx] = Σ_k Σ_p t_k(p)·s_k(q + p) + add` for `qx < cols, qy < rows_out`,
    /// where each `(t_k, Ŝ_k)` is a template (row-major) and the [`Plan::forward`] spectrum of its
    /// sample. Computed to rounding (about `ε·log(nx·ny)` relative to the templates' and
    /// samples' norms).
    ///
    /// A template column holds at most `bh ≤ l` values, so its transform splits into `m`
    /// transforms of length `l`: `X(m·k + r) = Σ_y x(y)·e^{−2πi·r·y/ny}·e^{−2πi·k·y/l}`, about
    /// `log l / log ny` of the work of a whole column, with no zeros to pad. Its values come out
    /// in that split order, which is why [`Plan::forward`] stores the samples' columns so; the
    /// sum of products is put back in frequency order for the inverse.
    #[allow(clippy::too_many_arguments)]
    pub fn correlate(
        &self,
        templates: &[(&[Real], &[Cx])],
        bw: usize,
        bh: usize,
        cols: usize,
        rows_out: usize,
        add: Real,
        out: &mut Vec<Real>,
        scratch: &mut Scratch,
        par: bool,
    ) {
        let (nx, ny, sy, sh, half, l, m) = (self.nx, self.ny, self.sy, self.sh, self.half, self.l, self.m);
        assert!(bw <= nx && bh <= l && cols <= nx && rows_out <= ny, "template or output larger than planned");
        // Row transforms of each template, transposed to `kx * bh + y` so a column's inputs lie
        // together.
        let rows = at_least(&mut scratch.rows, bh.max(rows_out) * sh);
        let cols_in = at_least(&mut scratch.cols_in, templates.len() * half * bh);
        for ((t, _), dst) in templates.iter().zip(cols_in.chunks_mut(half * bh)) {
            debug_assert!(t.len() == bw * bh);
            self.forward_rows(t, bw, bh, rows, false);
            transpose(rows, sh, bh, half, dst, bh, false);
        }
        let cols_in = &*cols_in;
        // Column by column: the templates' column spectra, times the samples', summed, and back.
        let spec = at_least(&mut scratch.spec, half * sy);
        let fft_len = self.fwd_l.get_inplace_scratch_len().max(self.inv_y.get_inplace_scratch_len());
        spec.par_chunks_mut(sy).enumerate().with_min_len(min_len(par, COLUMNS_PER_TASK)).for_each_init(
            || ColumnScratch {
                col: vec![ZERO; ny],
                acc: vec![ZERO; ny],
                nat: vec![ZERO; ny],
                fft: vec![ZERO; fft_len],
            },
            |s, (kx, dst)| {
                for (k, (_, spectrum)) in templates.iter().enumerate() {
                    let input = &cols_in[(k * half + kx) * bh..][..bh];
                    for (chunk, tw) in s.col.chunks_mut(l).zip(self.twiddle.chunks(l)) {
                        for ((c, &x), &w) in chunk.iter_mut().zip(input).zip(tw) {
                            *c = x * w;
                        }
                        chunk[bh..].fill(ZERO);
                    }
                    self.fwd_l.process_with_scratch(&mut s.col, &mut s.fft);
                    let sample = &spectrum[kx * sy..][..ny];
                    if k == 0 {
                        for ((a, t), v) in s.acc.iter_mut().zip(&s.col).zip(sample) {
                            *a = t.conj() * v;
                        }
                    } else {
                        for ((a, t), v) in s.acc.iter_mut().zip(&s.col).zip(sample) {
                            *a += t.conj() * v;
                        }
                    }
                }
                if templates.is_empty() {
                    s.acc.fill(ZERO);
                }
                for r in 0..m {
                    for k in 0..l {
                        s.nat[m * k + r] = s.acc[r * l + k];
                    }
                }
                self.inv_y.process_with_scratch(&mut s.nat, &mut s.fft);
                dst[..rows_out].copy_from_slice(&s.nat[..rows_out]);
            },
        );
        // Rows back to real values (a Hermitian row's end values are real; rounding is dropped).
        let rows = &mut rows[..rows_out * sh];
        transpose(spec, sy, half, rows_out, rows, sh, par);
        let scale = 1.0 / (nx * ny) as Real;
        out.resize(rows_out * cols, 0.0);
        out.par_chunks_mut(cols.max(1)).zip(rows.par_chunks_mut(sh)).with_min_len(min_len(par, 8)).for_each_init(
            || self.row_scratch(),
            |s, (o, row)| {
                row[0].im = 0.0;
                if nx % 2 == 0 {
                    row[half - 1].im = 0.0;
                }
                self.c2r.process_with_scratch(&mut row[..half], &mut s.line, &mut s.fft).expect("row lengths");
                for (v, &c) in o.iter_mut().zip(&s.line) {
                    *v = c * scale + add;
                }
            },
        );
    }
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
    fn summed_correlations_match_direct_sums() {
        // Samples 13x11 (non-smooth sizes, an odd transform width), templates 4x3.
        let (sw, sh, tw, th) = (13usize, 11usize, 4usize, 3usize);
        for tall in [th, 5, 12] {
            check_correlation(sw, sh, tw, th, tall);
        }
    }

    /// One plan, `tall` deciding how template columns split (`l` = 3, 6 or the whole 12).
    fn check_correlation(sw: usize, sh: usize, tw: usize, th: usize, tall: usize) {
        let f = |x: usize, y: usize, k: usize| ((x * 7 + y * 13 + k * 5) % 17) as Real / 17.0 - 0.3;
        let plan = Plan::new(sw, sh, tall);
        let samples: Vec<Vec<Real>> =
            (0..3).map(|k| (0..sh).flat_map(|y| (0..sw).map(move |x| f(x, y, k))).collect()).collect();
        let tmpls: Vec<Vec<Real>> =
            (0..3).map(|k| (0..th).flat_map(|y| (0..tw).map(move |x| f(x + 3, y + k, k + 2))).collect()).collect();
        let spectra: Vec<Vec<Cx>> = samples
            .iter()
            .map(|s| {
                let mut out = vec![ZERO; plan.len()];
                plan.forward(s, sw, sh, &mut out, true);
                out
            })
            .collect();
        let (cols, rws) = (sw - tw + 1, sh - th + 1);
        for par in [false, true] {
            let pairs: Vec<(&[Real], &[Cx])> =
                tmpls.iter().zip(&spectra).map(|(t, s)| (t.as_slice(), s.as_slice())).collect();
            let (mut out, mut scratch) = (Vec::new(), Scratch::default());
            plan.correlate(&pairs, tw, th, cols, rws, 0.5, &mut out, &mut scratch, par);
            for qy in 0..rws {
                for qx in 0..cols {
                    let mut d = 0.5;
                    for (t, s) in tmpls.iter().zip(&samples) {
                        for py in 0..th {
                            for px in 0..tw {
                                d += t[py * tw + px] * s[(qy + py) * sw + qx + px];
                            }
                        }
                    }
                    assert!((out[qy * cols + qx] - d).abs() < 1e-12, "{qx},{qy}: {} vs {d}", out[qy * cols + qx]);
                }
            }
        }
    }
}
