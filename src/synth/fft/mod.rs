//! Two-dimensional FFTs (f64, rustfft) shared by blending, metrics, the library and quilting.
//!
//! - [`RealFft2`]: real-to-complex transform of a `w × h` plane and its inverse (realfft along
//!   rows, so only the half spectrum `w/2 + 1` wide is computed, then complex column transforms).
//! - [`fft_real`]: the full complex spectrum of a real plane (Hermitian completion of the half one).
//! - [`Dct2`]: separable DCT-II / DCT-III (rustdct), which diagonalises Neumann problems.
//! - `correlate`: zero-padded half-spectrum transforms of real planes and the summed
//!   correlations of small templates with them, for quilting's SSD cross-correlation.
//!
//! Every transform is separable: rows, a cache-tiled transpose, rows again. Spectra stay
//! transposed (`kx * stride + ky`), which saves the transpose back between a forward and an
//! inverse transform. Each row is transformed by one thread with its own scratch and each
//! transposed value is written by one task, so results do not depend on the thread count.

pub(crate) mod correlate;
mod real;
mod rows;

pub use real::{fft_real, Dct2, RealFft2};
