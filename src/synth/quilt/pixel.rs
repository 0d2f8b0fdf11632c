//! Dong's rejected "Approach 1" (Sec. 5.3.1): pixel-based multiresolution synthesis after Wei & Levoy
//! 2000, with the "next column neighbour pixel" shortcut. Kept as the baseline of the Table 5.3.3
//! comparison (pixel method vs quilting); far slower than quilting by design (O(sample) per pixel).
//!
//! Both the sample and the result get a Gaussian pyramid (binomial 5-tap blur, decimation by 2).
//! Levels are synthesised coarsest first, in raster order. A pixel's neighbourhood is the causal
//! (already synthesised) part of an `n × n` window at its level plus the full 3×3 window around its
//! parent at the next coarser level (none at the coarsest level). Matching is SAD, exhaustive, and the
//! best match (lowest index on ties) is copied. After result pixel `(m, n)` took sample `(k, l)`, pixel
//! `(m + 1, n)` takes `(k + 1, l)` without search, except when it is in the randomly pre-selected set
//! of pixels forced to search (probability `search_rate`), starts a row, or `(k + 1, l)` is outside
//! the sample.

use rayon::prelude::*;

use super::params::{check_finite_image, check_range, Input, QuiltError};
use crate::raster::Image;
use crate::synth::rng::Rng;

/// Parameters of the pixel-based method.
#[derive(Clone, Debug, PartialEq)]
pub struct PixelParams {
    pub width: usize,
    pub height: usize,
    /// Side of the square causal window (odd, ≥ 3); Dong gives none, 5 is tessera's ([references: dong §5.3.1]).
    pub neighbourhood: usize,
    /// Pyramid levels above the finest; `None` = `floor(log2(min(sample side) / 8))`.
    pub levels: Option<usize>,
    /// Fraction of pixels forced to search, in [0, 1]; 1 = the original exhaustive algorithm.
    pub search_rate: f32,
    pub seed: u64,
}

/// Result of the pixel-based method.
#[derive(Clone, Debug)]
pub struct PixelResult {
    pub image: Image,
    /// Source pixel of every output pixel at the finest level (row-major `(x, y)`).
    pub source: Vec<(u32, u32)>,
    /// Pixels synthesised over all levels, and how many of them ran the exhaustive search.
    pub pixels: usize,
    pub searches: usize,
    /// Searches forced by the random pre-selection, and by row starts or the sample edge.
    pub random_searches: usize,
    pub edge_searches: usize,
}

/// Binomial blur then decimation by 2 (edges clamped).
fn downsample(img: &Image) -> Image {
    let (w, h) = (img.width, img.height);
    let k = [1.0f32, 4.0, 6.0, 4.0, 1.0];
    let clamp = |v: i64, n: usize| v.clamp(0, n as i64 - 1) as usize;
    let blur_x = Image::from_fn(w, h, img.channels, |x, y, c| {
        (0..5).map(|i| k[i] * img.get(clamp(x as i64 + i as i64 - 2, w), y, c)).sum::<f32>() / 16.0
    });
    Image::from_fn(w.div_ceil(2), h.div_ceil(2), img.channels, |x, y, c| {
        (0..5).map(|i| k[i] * blur_x.get(2 * x, clamp(2 * y as i64 + i as i64 - 2, h), c)).sum::<f32>() / 16.0
    })
}

/// Pixel-based synthesis of a `width × height` image from `sample`.
pub fn pixel_synthesis(sample: &Image, p: &PixelParams) -> Result<PixelResult, QuiltError> {
    check_finite_image(Input::Sample, sample)?;
    if sample.width == 0 || sample.height == 0 || sample.channels == 0 {
        return Err(QuiltError::Empty { what: Input::Sample });
    }
    if p.width == 0 || p.height == 0 {
        return Err(QuiltError::Empty { what: Input::Output });
    }
    if p.neighbourhood < 3 || p.neighbourhood % 2 == 0 {
        return Err(QuiltError::Invalid {
            name: Input::Neighbourhood,
            value: p.neighbourhood as f64,
            expected: "an odd size ≥ 3",
        });
    }
    check_range(Input::SearchRate, p.search_rate, 0.0, 1.0, "a fraction in [0, 1]")?;
    let levels = p.levels.unwrap_or_else(|| (sample.width.min(sample.height) / 8).max(1).ilog2() as usize);
    let mut spyr = vec![sample.clone()];
    for _ in 0..levels {
        let next = downsample(spyr.last().expect("non-empty"));
        spyr.push(next);
    }
    let mut rsize = vec![(p.width, p.height)];
    for l in 0..levels {
        let (w, h) = rsize[l];
        rsize.push((w.div_ceil(2), h.div_ceil(2)));
    }
    let mut rpyr: Vec<Image> = rsize.iter().map(|&(w, h)| Image::new(w, h, sample.channels)).collect();
    let half = (p.neighbourhood / 2) as i64;
    let causal: Vec<(i64, i64)> = (-half..=0)
        .flat_map(|dy| (-half..=half).map(move |dx| (dx, dy)))
        .filter(|&(dx, dy)| dy < 0 || dx < 0)
        .collect();
    let mut rng = Rng::new(p.seed);
    let (mut pixels, mut searches, mut random_searches, mut edge_searches) = (0, 0, 0, 0);
    let mut source = Vec::new();
    for l in (0..=levels).rev() {
        let s = &spyr[l];
        let sp = spyr.get(l + 1);
        let (rw, rh) = rsize[l];
        let (sw, sh) = (s.width, s.height);
        let mut src: Vec<(u32, u32)> = vec![(0, 0); rw * rh];
        for y in 0..rh {
            for x in 0..rw {
                pixels += 1;
                let forced = rng.next_f32() < p.search_rate;
                let prev = (x > 0).then(|| src[y * rw + x - 1]);
                let next = prev.map(|(k, m)| (k + 1, m)).filter(|&(k, _)| (k as usize) < sw);
                let pick = match (forced, next) {
                    (false, Some(n)) => n,
                    _ => {
                        searches += 1;
                        if forced {
                            random_searches += 1;
                        } else {
                            edge_searches += 1;
                        }
                        // Neighbourhood of the result pixel: causal offsets inside the result, and the
                        // parent window (clamped) at the coarser result level.
                        let r = &rpyr[l];
                        let offs: Vec<(i64, i64)> = causal
                            .iter()
                            .copied()
                            .filter(|&(dx, dy)| {
                                let (xx, yy) = (x as i64 + dx, y as i64 + dy);
                                xx >= 0 && yy >= 0 && xx < rw as i64
                            })
                            .collect();
                        let rp = rpyr.get(l + 1);
                        let clampi = |v: i64, n: usize| v.clamp(0, n as i64 - 1) as usize;
                        let mut target: Vec<f32> = Vec::new();
                        for c in 0..s.channels {
                            for &(dx, dy) in &offs {
                                target.push(r.get((x as i64 + dx) as usize, (y as i64 + dy) as usize, c));
                            }
                            if let Some(rp) = rp {
                                for dy in -1..=1 {
                                    for dx in -1..=1 {
                                        let (px, py) =
                                            (clampi(x as i64 / 2 + dx, rp.width), clampi(y as i64 / 2 + dy, rp.height));
                                        target.push(rp.get(px, py, c));
                                    }
                                }
                            }
                        }
                        // Exhaustive SAD over every sample pixel, (error, index) minimum.
                        let best = (0..sw * sh)
                            .into_par_iter()
                            .map(|i| {
                                let (k, m) = ((i % sw) as i64, (i / sw) as i64);
                                let mut e = 0.0f64;
                                let mut t = target.iter();
                                for c in 0..s.channels {
                                    for &(dx, dy) in &offs {
                                        let v = s.get(clampi(k + dx, sw), clampi(m + dy, sh), c);
                                        e += f64::from((v - t.next().expect("same length")).abs());
                                    }
                                    if let Some(sp) = sp {
                                        for dy in -1..=1 {
                                            for dx in -1..=1 {
                                                let v = sp.get(
                                                    clampi(k / 2 + dx, sp.width),
                                                    clampi(m / 2 + dy, sp.height),
                                                    c,
                                                );
                                                e += f64::from((v - t.next().expect("same length")).abs());
                                            }
                                        }
                                    }
                                }
                                (e, i)
                            })
                            .reduce(
                                || (f64::INFINITY, usize::MAX),
                                |a, b| if b.0 < a.0 || (b.0 == a.0 && b.1 < a.1) { b } else { a },
                            );
                        ((best.1 % sw) as u32, (best.1 / sw) as u32)
                    }
                };
                src[y * rw + x] = pick;
                for c in 0..s.channels {
                    let v = s.get(pick.0 as usize, pick.1 as usize, c);
                    rpyr[l].set(x, y, c, v);
                }
            }
        }
        source = src;
    }
    let image = rpyr.swap_remove(0);
    Ok(PixelResult { image, source, pixels, searches, random_searches, edge_searches })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Image {
        let mut rng = Rng::new(60);
        let base: Vec<f32> = (0..32 * 32).map(|_| rng.next_f32()).collect();
        Image::from_fn(32, 32, 2, |x, y, c| 0.5 * base[y * 32 + x] + 0.5 * (((x + 2 * y + 5 * c) % 9) as f32 / 9.0))
    }

    fn params(rate: f32) -> PixelParams {
        PixelParams { width: 40, height: 36, neighbourhood: 5, levels: Some(2), search_rate: rate, seed: 61 }
    }

    // Dong checklist item 18.
    #[test]
    fn exhaustive_rate_searches_every_pixel() {
        let s = sample();
        let r = pixel_synthesis(&s, &params(1.0)).unwrap();
        let total = 40 * 36 + 20 * 18 + 10 * 9;
        assert_eq!((r.pixels, r.searches, r.random_searches), (total, total, total));
        // Every output pixel is a copy of its source pixel.
        for y in 0..36 {
            for x in 0..40 {
                let (sx, sy) = r.source[y * 40 + x];
                for c in 0..2 {
                    assert_eq!(r.image.get(x, y, c), s.get(sx as usize, sy as usize, c));
                }
            }
        }
    }

    #[test]
    fn partial_rate_searches_the_selected_fraction_plus_forced_cases() {
        let s = sample();
        let r = pixel_synthesis(&s, &params(0.4)).unwrap();
        assert_eq!(r.searches, r.random_searches + r.edge_searches);
        // Binomial(pixels, 0.4): within 4 standard deviations.
        let (n, a) = (r.pixels as f64, 0.4);
        let sd = (n * a * (1.0 - a)).sqrt();
        assert!((r.random_searches as f64 - a * n).abs() < 4.0 * sd, "{} vs {}", r.random_searches, a * n);
        // Forced cases: at least every row start that was not randomly selected.
        let rows = 36 + 18 + 9;
        assert!(r.edge_searches >= (0.5 * rows as f64) as usize && r.edge_searches < r.pixels / 4);
        println!(
            "pixel method at 40%: {} searches of {} pixels ({} random, {} forced)",
            r.searches, r.pixels, r.random_searches, r.edge_searches
        );
        // Without a search the pixel continues its left neighbour's source.
        let none = pixel_synthesis(&s, &params(0.0)).unwrap();
        assert_eq!(none.random_searches, 0);
        for y in 0..36 {
            for x in 1..40 {
                let (a, b) = (none.source[y * 40 + x - 1], none.source[y * 40 + x]);
                assert!(b == (a.0 + 1, a.1) || a.0 as usize + 1 == 32, "({x},{y})");
            }
        }
    }
}
