//! Row-parallel pixel loops shared by the map builders.
//!
//! Every pixel (or row) is computed independently from its own coordinates, so the result
//! does not depend on how rayon splits the rows across threads.

use rayon::prelude::*;

use crate::raster::Image;

/// Builds a 1-channel image row by row; `fill(y, row)` writes one row.
pub(super) fn rows_map(width: usize, height: usize, fill: impl Fn(usize, &mut [f32]) + Sync) -> Image {
    let mut img = Image::new(width, height, 1);
    img.data.par_chunks_mut(width).enumerate().for_each(|(y, row)| fill(y, row));
    img
}

/// Builds a 1-channel image from a function of the pixel centre `(x + 0.5, y + 0.5)`.
pub(super) fn scalar_map(width: usize, height: usize, f: impl Fn(f32, f32) -> f32 + Sync) -> Image {
    rows_map(width, height, |y, row| {
        let py = y as f32 + 0.5;
        for (x, v) in row.iter_mut().enumerate() {
            *v = f(x as f32 + 0.5, py);
        }
    })
}

/// Builds a 2-channel image from a function of the pixel centre returning `[c0, c1]`.
pub(super) fn vector_map(width: usize, height: usize, f: impl Fn(f32, f32) -> [f32; 2] + Sync) -> Image {
    let mut img = Image::new(width, height, 2);
    let (xs, ys) = img.data.split_at_mut(width * height);
    xs.par_chunks_mut(width).zip(ys.par_chunks_mut(width)).enumerate().for_each(|(y, (row_x, row_y))| {
        let py = y as f32 + 0.5;
        for (x, (vx, vy)) in row_x.iter_mut().zip(row_y.iter_mut()).enumerate() {
            [*vx, *vy] = f(x as f32 + 0.5, py);
        }
    });
    img
}

/// Applies `f` to every value of every channel.
pub(super) fn map_values(img: &Image, f: impl Fn(f32) -> f32 + Sync) -> Image {
    let mut out = img.clone();
    let row = img.width.max(1);
    out.data.par_chunks_mut(row).for_each(|chunk| {
        for v in chunk {
            *v = f(*v);
        }
    });
    out
}

/// Normalises each `(c0, c1)` pair of a 2-channel image in place; vectors too short to
/// have a meaningful direction become `(1, 0)` so the field stays unit length everywhere.
pub(super) fn normalize_field(img: &mut Image) {
    debug_assert_eq!(img.channels, 2);
    let n = img.plane_len();
    let row = img.width.max(1);
    let (xs, ys) = img.data.split_at_mut(n);
    xs.par_chunks_mut(row).zip(ys.par_chunks_mut(row)).for_each(|(row_x, row_y)| {
        for (vx, vy) in row_x.iter_mut().zip(row_y.iter_mut()) {
            [*vx, *vy] = unit_or_x(*vx, *vy);
        }
    });
}

/// Smallest vector length treated as a direction. Below it the direction is noise.
const MIN_LENGTH: f32 = 1e-6;

/// `(x, y)` scaled to unit length, or `(1, 0)` if it is (nearly) zero or not finite.
pub(super) fn unit_or_x(x: f32, y: f32) -> [f32; 2] {
    let len = x.hypot(y);
    if len > MIN_LENGTH && len.is_finite() {
        [x / len, y / len]
    } else {
        [1.0, 0.0]
    }
}
