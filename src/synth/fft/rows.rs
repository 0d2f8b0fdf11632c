//! The passes every transform is made of: parallel row transforms with a fixed work split,
//! and cache-tiled transposes; and the row padding that keeps those transposes from thrashing.

use std::sync::Arc;

use rayon::prelude::*;
use rustfft::num_complex::Complex;
use rustfft::Fft;

/// Rows per parallel task; fixed so the work split never depends on the thread count (the results
/// would not either, but this keeps scheduling predictable).
const ROWS_PER_TASK: usize = 8;

/// Row padding (elements): power-of-two row strides would map a column's elements to the same cache
/// set and make the transposes thrash.
pub(super) const PAD: usize = 4;

/// Side of the square tiles of the cache-blocked transposes.
const TILE: usize = 32;

/// Minimum items per rayon task: `n` when parallel, "never split" otherwise (sequential, no overhead).
pub(super) fn min_len(par: bool, n: usize) -> usize {
    if par {
        n
    } else {
        usize::MAX
    }
}

/// Applies `op` to every `stride`-long row of `data`, with per-task state from `init`.
pub(super) fn for_rows<T, S>(
    data: &mut [T],
    stride: usize,
    par: bool,
    init: impl Fn() -> S + Sync + Send,
    op: impl Fn(&mut S, &mut [T]) + Sync + Send,
) where
    T: Send,
{
    if data.is_empty() {
        return;
    }
    data.par_chunks_mut(stride * ROWS_PER_TASK).with_min_len(min_len(par, 1)).for_each_init(init, |state, chunk| {
        for row in chunk.chunks_mut(stride) {
            op(state, row);
        }
    });
}

/// Complex-transforms every row (`n` values at the start of each `stride`-long row) in place.
pub(super) fn fft_rows(fft: &Arc<dyn Fft<f64>>, data: &mut [Complex<f64>], n: usize, stride: usize, par: bool) {
    let scratch_len = fft.get_inplace_scratch_len();
    for_rows(
        data,
        stride,
        par,
        || vec![Complex::new(0.0, 0.0); scratch_len],
        |scratch, row| fft.process_with_scratch(&mut row[..n], scratch),
    );
}

/// `dst[c * dst_stride + r] = src[r * src_stride + c]` for `r < rows, c < cols`, tiled; parallel over
/// bands of destination rows (each destination element written once, by one task).
pub(super) fn transpose<T: Copy + Send + Sync>(
    src: &[T],
    src_stride: usize,
    rows: usize,
    cols: usize,
    dst: &mut [T],
    dst_stride: usize,
    par: bool,
) {
    dst[..cols * dst_stride].par_chunks_mut(TILE * dst_stride).with_min_len(min_len(par, 1)).enumerate().for_each(
        |(band, out)| {
            let c0 = band * TILE;
            let c1 = (c0 + TILE).min(cols);
            for r0 in (0..rows).step_by(TILE) {
                let r1 = (r0 + TILE).min(rows);
                for c in c0..c1 {
                    let o = &mut out[(c - c0) * dst_stride..];
                    for r in r0..r1 {
                        o[r] = src[r * src_stride + c];
                    }
                }
            }
        },
    );
}
