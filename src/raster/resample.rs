//! Point sampling, resizing and cropping.
//!
//! Coordinates are continuous with pixel centres at `i + 0.5`, so sampling at a centre
//! returns that pixel exactly for every filter, and resizing maps the image's outer edges
//! onto each other (no half-pixel shift between scales).
//!
//! Resizing is separable and precomputes one weight table per axis. Each output value is
//! produced by one thread with a fixed summation order, so results are bit-identical
//! whatever the rayon thread count.

use rayon::prelude::*;

use super::{Image, RasterError};

/// Reconstruction filter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Filter {
    /// The pixel containing the point; never blends values, so it is the one to use for
    /// label or index maps.
    Nearest,
    /// Linear interpolation between the four nearest centres.
    Bilinear,
    /// Keys cubic convolution with a = -0.5 (Catmull-Rom): interpolating and exact on
    /// quadratics; may overshoot slightly at sharp edges (results are not clamped).
    Bicubic,
}

/// What lies beyond the image border.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Edge {
    /// Repeat the border pixels.
    #[default]
    Clamp,
    /// Wrap around, for tileable textures: the pixel left of column 0 is column `w - 1`.
    Wrap,
}

/// Up to four taps of a 1-D kernel: source indices (before edge handling) and weights.
#[derive(Clone, Copy, Debug)]
struct Taps {
    index: [i64; 4],
    weight: [f32; 4],
    len: usize,
}

impl Taps {
    /// Kernel taps for continuous coordinate `x` (pixel centres at `i + 0.5`).
    fn at(x: f32, filter: Filter) -> Taps {
        // `as i64` saturates (and maps NaN to 0), so absurd coordinates stay panic-free.
        match filter {
            Filter::Nearest => Taps { index: [x.floor() as i64, 0, 0, 0], weight: [1.0, 0.0, 0.0, 0.0], len: 1 },
            Filter::Bilinear => {
                let u = x - 0.5;
                let f = u.floor();
                let (i, t) = (f as i64, u - f);
                Taps { index: [i, i.saturating_add(1), 0, 0], weight: [1.0 - t, t, 0.0, 0.0], len: 2 }
            }
            Filter::Bicubic => {
                let u = x - 0.5;
                let f = u.floor();
                let (i, t) = (f as i64, u - f);
                Taps {
                    index: [i.saturating_sub(1), i, i.saturating_add(1), i.saturating_add(2)],
                    weight: [keys(1.0 + t), keys(t), keys(1.0 - t), keys(2.0 - t)],
                    len: 4,
                }
            }
        }
    }

    fn iter(&self) -> impl Iterator<Item = (i64, f32)> + '_ {
        // Zero weights are skipped so an infinite neighbour cannot turn an exact hit
        // into NaN (0 * inf).
        self.index[..self.len].iter().copied().zip(self.weight[..self.len].iter().copied()).filter(|&(_, w)| w != 0.0)
    }
}

/// Keys cubic kernel, a = -0.5, for distance `d` ≥ 0.
fn keys(d: f32) -> f32 {
    let d = d.abs();
    if d <= 1.0 {
        (1.5 * d - 2.5) * d * d + 1.0
    } else if d < 2.0 {
        ((-0.5 * d + 2.5) * d - 4.0) * d + 2.0
    } else {
        0.0
    }
}

/// Maps a possibly out-of-range index into `0..n` (`n > 0`).
fn resolve(i: i64, n: usize, edge: Edge) -> usize {
    let n = n as i64;
    let r = match edge {
        Edge::Clamp => i.clamp(0, n - 1),
        Edge::Wrap => i.rem_euclid(n),
    };
    r as usize
}

/// Samples channel `c` at continuous position `(x, y)` with clamp-to-edge borders.
/// See [`sample_with_edge`].
pub fn sample(img: &Image, x: f32, y: f32, c: usize, filter: Filter) -> f32 {
    sample_with_edge(img, x, y, c, filter, Edge::Clamp)
}

/// Samples channel `c` at continuous position `(x, y)` (pixel centres at `i + 0.5`).
///
/// Returns 0 for an image without pixels. Panics if `c >= img.channels` (a programming
/// error, like indexing out of bounds).
pub fn sample_with_edge(img: &Image, x: f32, y: f32, c: usize, filter: Filter, edge: Edge) -> f32 {
    assert!(c < img.channels, "channel {c} out of range for {} channels", img.channels);
    let (w, h) = (img.width, img.height);
    if w == 0 || h == 0 {
        return 0.0;
    }
    let plane = img.plane(c);
    let (tx, ty) = (Taps::at(x, filter), Taps::at(y, filter));
    let mut acc = 0.0f32;
    let mut first = true;
    for (iy, wy) in ty.iter() {
        let row = &plane[resolve(iy, h, edge) * w..][..w];
        let mut line = 0.0f32;
        let mut first_x = true;
        for (ix, wx) in tx.iter() {
            let term = wx * row[resolve(ix, w, edge)];
            line = if first_x { term } else { line + term };
            first_x = false;
        }
        let term = wy * line;
        acc = if first { term } else { acc + term };
        first = false;
    }
    acc
}

/// Sparse weight matrix for one axis: output `i` reads `index[offsets[i]..offsets[i+1]]`.
#[derive(Debug)]
struct Table {
    offsets: Vec<usize>,
    index: Vec<usize>,
    weight: Vec<f32>,
}

impl Table {
    fn taps(&self, i: usize) -> impl Iterator<Item = (usize, f32)> + '_ {
        let range = self.offsets[i]..self.offsets[i + 1];
        self.index[range.clone()].iter().copied().zip(self.weight[range].iter().copied())
    }

    /// Weights for resampling an axis of `src` pixels to `dst` pixels (both > 0).
    fn new(src: usize, dst: usize, filter: Filter, edge: Edge) -> Table {
        let scale = src as f64 / dst as f64;
        let mut table = Table { offsets: Vec::with_capacity(dst + 1), index: Vec::new(), weight: Vec::new() };
        table.offsets.push(0);
        for i in 0..dst {
            if filter != Filter::Nearest && scale > 2.0 {
                table.push_area(i, scale, src);
            } else {
                let x = ((i as f64 + 0.5) * scale) as f32;
                for (j, w) in Taps::at(x, filter).iter() {
                    table.index.push(resolve(j, src, edge));
                    table.weight.push(w);
                }
            }
            table.offsets.push(table.index.len());
        }
        table
    }

    /// Exact box (area) average of the source interval covered by output pixel `i`: the
    /// anti-aliasing prefilter for reductions beyond 2×, where a 2- or 4-tap kernel
    /// would skip source pixels entirely.
    fn push_area(&mut self, i: usize, scale: f64, src: usize) {
        let lo = i as f64 * scale;
        let hi = ((i + 1) as f64 * scale).min(src as f64);
        let first = lo.floor() as usize;
        let last = (hi.ceil() as usize).clamp(first + 1, src);
        let start = self.index.len();
        let mut total = 0.0f64;
        let mut weights = Vec::with_capacity(last - first);
        for j in first..last {
            let overlap = (hi.min((j + 1) as f64) - lo.max(j as f64)).max(0.0);
            if overlap > 0.0 {
                weights.push((j, overlap));
                total += overlap;
            }
        }
        for (j, overlap) in weights {
            self.index.push(j);
            self.weight.push((overlap / total) as f32);
        }
        if self.index.len() == start {
            // Degenerate interval (cannot happen for scale > 2, kept for safety).
            self.index.push(first.min(src - 1));
            self.weight.push(1.0);
        }
    }
}

/// Resizes to `width` × `height` with clamp-to-edge borders. See [`resize_with_edge`].
pub fn resize(img: &Image, width: usize, height: usize, filter: Filter) -> Image {
    resize_with_edge(img, width, height, filter, Edge::Clamp)
}

/// Resizes to `width` × `height`.
///
/// Output pixel centres map to source positions `(i + 0.5) * src / dst`. When an axis
/// shrinks by more than 2× and the filter is not `Nearest`, that axis uses an exact area
/// average instead of the kernel, which avoids aliasing (and equals bilinear at exactly
/// 2×). An axis whose size does not change is copied exactly. An image without pixels
/// (or whose `data` length disagrees with its dimensions) resizes to zeros.
pub fn resize_with_edge(img: &Image, width: usize, height: usize, filter: Filter, edge: Edge) -> Image {
    let (sw, sh, ch) = (img.width, img.height, img.channels);
    if width == 0 || height == 0 || ch == 0 || sw == 0 || sh == 0 {
        return Image::new(width, height, ch);
    }
    if img.data.len() != sw * sh * ch {
        // Inconsistent hand-built image: refuse to read out of bounds.
        return Image::new(width, height, ch);
    }
    let horizontal =
        if width == sw { img.clone() } else { resize_rows(img, width, &Table::new(sw, width, filter, edge)) };
    if height == sh {
        horizontal
    } else {
        resize_columns(&horizontal, height, &Table::new(sh, height, filter, edge))
    }
}

/// Horizontal pass: every row of every channel is independent.
fn resize_rows(img: &Image, width: usize, table: &Table) -> Image {
    let mut out = Image::new(width, img.height, img.channels);
    out.data.par_chunks_mut(width).zip(img.data.par_chunks(img.width)).for_each(|(dst, src)| {
        for (x, d) in dst.iter_mut().enumerate() {
            let mut taps = table.taps(x);
            if let Some((j, w)) = taps.next() {
                *d = taps.fold(w * src[j], |acc, (j, w)| acc + w * src[j]);
            }
        }
    });
    out
}

/// Vertical pass: each output row is a weighted sum of whole source rows, which keeps
/// memory access sequential.
fn resize_columns(img: &Image, height: usize, table: &Table) -> Image {
    let w = img.width;
    let mut out = Image::new(w, height, img.channels);
    out.data.par_chunks_mut(w).enumerate().for_each(|(r, dst)| {
        let (c, y) = (r / height, r % height);
        let plane = img.plane(c);
        let mut taps = table.taps(y);
        if let Some((j, wt)) = taps.next() {
            let src = &plane[j * w..][..w];
            for (d, s) in dst.iter_mut().zip(src) {
                *d = wt * s;
            }
        }
        for (j, wt) in taps {
            let src = &plane[j * w..][..w];
            for (d, s) in dst.iter_mut().zip(src) {
                *d += wt * s;
            }
        }
    });
    out
}

/// Copies the `w` × `h` rectangle whose top-left pixel is `(x, y)`, keeping all channels.
/// Errors if the rectangle reaches outside the image; empty rectangles inside it are fine.
pub fn crop(img: &Image, x: usize, y: usize, w: usize, h: usize) -> Result<Image, RasterError> {
    let fits = |start: usize, len: usize, size: usize| start.checked_add(len).is_some_and(|end| end <= size);
    if !fits(x, w, img.width) || !fits(y, h, img.height) {
        return Err(RasterError::CropOutOfBounds { x, y, w, h, width: img.width, height: img.height });
    }
    super::check_layout(img)?;
    let mut out = Image::new(w, h, img.channels);
    if w == 0 {
        return Ok(out);
    }
    for c in 0..img.channels {
        let src = img.plane(c);
        for (row, dst) in out.plane_mut(c).chunks_exact_mut(w).enumerate() {
            let start = (y + row) * img.width + x;
            dst.copy_from_slice(&src[start..start + w]);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    const FILTERS: [Filter; 3] = [Filter::Nearest, Filter::Bilinear, Filter::Bicubic];

    fn pattern(w: usize, h: usize, c: usize) -> Image {
        Image::from_fn(w, h, c, |x, y, c| ((x * 37 + y * 91 + c * 13) % 23) as f32 / 22.0)
    }

    #[test]
    fn sampling_at_pixel_centres_is_exact() {
        let img = pattern(6, 5, 2);
        for filter in FILTERS {
            for edge in [Edge::Clamp, Edge::Wrap] {
                for y in 0..5 {
                    for x in 0..6 {
                        for c in 0..2 {
                            let v = sample_with_edge(&img, x as f32 + 0.5, y as f32 + 0.5, c, filter, edge);
                            assert_eq!(v, img.get(x, y, c), "{filter:?} {edge:?} ({x},{y},{c})");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn exact_hit_next_to_infinity_is_not_nan() {
        let img = Image { width: 3, height: 1, channels: 1, data: vec![1.0, f32::INFINITY, 2.0] };
        for filter in FILTERS {
            assert_eq!(sample(&img, 0.5, 0.5, 0, filter), 1.0);
            assert_eq!(sample(&img, 2.5, 0.5, 0, filter), 2.0);
        }
    }

    #[test]
    fn clamp_and_wrap_borders() {
        let img = Image::from_fn(4, 1, 1, |x, _, _| x as f32);
        // Centre of the pixel left of column 0.
        assert_eq!(sample(&img, -0.5, 0.5, 0, Filter::Bilinear), 0.0);
        assert_eq!(sample_with_edge(&img, -0.5, 0.5, 0, Filter::Bilinear, Edge::Wrap), 3.0);
        // Halfway between the last and (wrapped) first pixel.
        assert_eq!(sample_with_edge(&img, 4.0, 0.5, 0, Filter::Bilinear, Edge::Wrap), 1.5);
        assert_eq!(sample(&img, 4.0, 0.5, 0, Filter::Bilinear), 3.0);
        assert_eq!(sample_with_edge(&img, 5.2, 0.5, 0, Filter::Nearest, Edge::Wrap), 1.0);
        // Wild coordinates neither panic nor produce garbage indices.
        for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30, -1e30] {
            for filter in FILTERS {
                let _ = sample(&img, v, v, 0, filter);
                let _ = sample_with_edge(&img, v, 0.5, 0, filter, Edge::Wrap);
            }
        }
        assert_eq!(sample(&Image::new(0, 0, 1), 0.5, 0.5, 0, Filter::Bicubic), 0.0);
    }

    #[test]
    fn linear_ramp_is_reproduced_by_bilinear_and_bicubic_sampling() {
        let img = Image::from_fn(10, 10, 1, |x, y, _| 2.0 * x as f32 - 0.5 * y as f32);
        for filter in [Filter::Bilinear, Filter::Bicubic] {
            for k in 0..40 {
                let (x, y) = (2.0 + k as f32 * 0.13, 2.0 + k as f32 * 0.11);
                let want = 2.0 * (x - 0.5) - 0.5 * (y - 0.5);
                let got = sample(&img, x, y, 0, filter);
                assert!((got - want).abs() < 1e-4, "{filter:?} at ({x},{y}): {got} vs {want}");
            }
        }
    }

    #[test]
    fn resize_of_constant_stays_constant() {
        let img = Image::filled(37, 23, 2, 0.7);
        for filter in FILTERS {
            for edge in [Edge::Clamp, Edge::Wrap] {
                for (w, h) in [(100, 50), (37, 10), (5, 3), (1, 1), (74, 23), (12, 70)] {
                    let out = resize_with_edge(&img, w, h, filter, edge);
                    assert_eq!((out.width, out.height, out.channels), (w, h, 2));
                    for v in &out.data {
                        assert!((v - 0.7).abs() < 1e-6, "{filter:?} {w}x{h}: {v}");
                    }
                }
            }
        }
    }

    #[test]
    fn identity_resize_is_exact() {
        let mut img = pattern(13, 9, 3);
        img.data[5] = f32::INFINITY;
        for filter in FILTERS {
            assert_eq!(resize(&img, 13, 9, filter), img);
        }
    }

    #[test]
    fn bilinear_upscale_preserves_linear_ramp_in_the_interior() {
        let img = Image::from_fn(16, 4, 1, |x, _, _| 0.25 * x as f32 + 1.0);
        let out = resize(&img, 40, 4, Filter::Bilinear);
        let scale = 16.0 / 40.0;
        for x in 0..40 {
            let u = (x as f32 + 0.5) * scale - 0.5;
            if (0.0..=15.0).contains(&u) {
                let want = 0.25 * u + 1.0;
                for y in 0..4 {
                    assert!((out.get(x, y, 0) - want).abs() < 1e-5, "x={x}");
                }
            }
        }
    }

    #[test]
    fn integer_upscale_then_downscale_returns_the_original_nearest() {
        let img = pattern(7, 5, 1);
        let up = resize(&img, 21, 15, Filter::Nearest);
        assert_eq!(up.get(4, 7, 0), img.get(1, 2, 0));
        assert_eq!(resize(&up, 7, 5, Filter::Nearest), img);
    }

    #[test]
    fn large_downscale_area_averages() {
        let img = Image::from_fn(8, 1, 1, |x, _, _| x as f32);
        let out = resize(&img, 2, 1, Filter::Bicubic);
        assert_eq!(out.data, vec![1.5, 5.5]);
        // A fine checkerboard must average to gray, not alias to black or white.
        let checker = Image::from_fn(64, 64, 1, |x, y, _| ((x + y) % 2) as f32);
        for filter in [Filter::Bilinear, Filter::Bicubic] {
            let small = resize(&checker, 7, 5, filter);
            assert!(small.data.iter().all(|v| (v - 0.5).abs() < 0.05), "{filter:?}: {:?}", small.data);
        }
        // Nearest never blends (label maps stay labels).
        let labels = Image::from_fn(40, 40, 1, |x, y, _| ((x / 3 + y / 5) % 4) as f32);
        let small = resize(&labels, 9, 7, Filter::Nearest);
        assert!(small.data.iter().all(|v| v.fract() == 0.0));
    }

    #[test]
    fn resize_handles_empty_images() {
        assert_eq!(resize(&Image::new(0, 0, 3), 4, 2, Filter::Bilinear), Image::new(4, 2, 3));
        assert_eq!(resize(&pattern(4, 4, 1), 0, 3, Filter::Bicubic), Image::new(0, 3, 1));
    }

    #[test]
    fn resize_is_identical_across_thread_counts() {
        let img = pattern(301, 157, 3);
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                FILTERS.iter().flat_map(|&f| [resize(&img, 97, 410, f), resize(&img, 1000, 33, f)]).collect::<Vec<_>>()
            })
        };
        let bits = |imgs: &[Image]| imgs.iter().flat_map(|i| i.data.iter().map(|v| v.to_bits())).collect::<Vec<_>>();
        assert_eq!(bits(&run(1)), bits(&run(3)));
    }

    #[test]
    fn crop_copies_and_checks_bounds() {
        let img = pattern(10, 8, 2);
        let out = crop(&img, 3, 2, 4, 5).unwrap();
        assert_eq!((out.width, out.height, out.channels), (4, 5, 2));
        for (x, y, c) in [(0, 0, 0), (3, 4, 1), (2, 1, 0)] {
            assert_eq!(out.get(x, y, c), img.get(x + 3, y + 2, c));
        }
        assert_eq!(crop(&img, 0, 0, 10, 8).unwrap(), img);
        assert_eq!(crop(&img, 10, 8, 0, 0).unwrap(), Image::new(0, 0, 2));
        let err = crop(&img, 7, 0, 4, 1).unwrap_err();
        assert_eq!(err.to_string(), "crop of 4x1 at (7, 0) does not fit in the 10x8 image");
        assert!(crop(&img, 0, 5, 1, 4).is_err());
        assert!(crop(&img, usize::MAX, 0, 2, 1).is_err());
    }
}
