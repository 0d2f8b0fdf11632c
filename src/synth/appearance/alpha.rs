//! Stone versus mortar: the alpha of interstices and junctions, automatic or user-given
//! (stage A2e/A2f input, V22). [references: frasson §4.2.4]
//!
//! The thesis cut the rock pixels out of its atlases by hand and only proposes cues for an
//! automatic extraction (the colour histogram's two peaks, the gradient, a user patch). Our
//! scheme, on the whole sample so that both atlases cut from one alpha image:
//!
//! 1. the **strip pixels** are the pixel centres within `band` px of a drawn edge (a side of
//!    a region polygon); every other pixel is interior and gets alpha 0;
//! 2. a 2-class k-means in CIELAB runs on the strip pixels: the stone class is seeded with
//!    the pixels of the region masks shrunk by `shrink` px, the mortar class with the strip
//!    pixels closer than `shrink` to an edge (the drawn line itself); classes keep their
//!    identity through the iterations;
//! 3. `P(mortar | Lab)` is the posterior of two axis-aligned Gaussians fitted to the final
//!    classes, with the class shares as priors;
//! 4. the score is `s = P(mortar | Lab) − λ_g·|∇L*|_normalised` (central differences;
//!    normalised by the 95th percentile over the strip pixels and clamped to `[0, 1]`), and
//!    `alpha = smoothstep(low, high, s)` with `λ_g = 0.3`, `low = 0.4`, `high = 0.6`.
//!
//! A user alpha image of the sample's size replaces the automatic one ([`alpha_override`],
//! [`sample_alpha`]); a size mismatch is an [`AlphaError`], which the kinds layer reports as a
//! diagnostic.
//!
//! Rows are scored in parallel and each pixel's value depends on its inputs only, so the
//! result is the same for any thread count.

use std::collections::BTreeSet;
use std::fmt;

use rayon::prelude::*;

use super::color::lab_of_srgb;
use super::types::{Lab, Point};
use crate::raster::Image;
use crate::synth::structure::analysis::labels_import::rasterize_polygons;
use crate::synth::structure::NO_REGION;

/// Parameters of the automatic alpha (V17, V22).
#[derive(Clone, Debug, PartialEq)]
pub struct AlphaParams {
    /// Region masks are shrunk by this many px to seed the stone class (V17: 2 px).
    pub shrink: f64,
    /// Pixels farther than this from every drawn edge are interior (alpha 0), px. It must
    /// cover the strips (`√2·w` with `extension = w`) and the stars' intermediate vertices
    /// (`w` from both edges), so the default is `2·w` for `w = 6`.
    pub band: f64,
    /// Weight of the normalised luminance gradient in the score (`λ_g`).
    pub lambda_g: f64,
    /// The score where alpha starts rising from 0.
    pub low: f64,
    /// The score where alpha reaches 1.
    pub high: f64,
    /// Largest number of k-means iterations (it stops earlier when no pixel changes class).
    pub iterations: usize,
}

impl Default for AlphaParams {
    fn default() -> Self {
        AlphaParams { shrink: 2.0, band: 12.0, lambda_g: 0.3, low: 0.4, high: 0.6, iterations: 30 }
    }
}

/// What the classifier found, for reports and tests.
#[derive(Clone, Debug, PartialEq)]
pub struct AlphaModel {
    /// Mean CIELAB of the mortar class.
    pub mortar: Lab,
    /// Mean CIELAB of the stone class.
    pub stone: Lab,
    /// Per-channel standard deviations of the two classes.
    pub mortar_sigma: Lab,
    pub stone_sigma: Lab,
    /// Share of the strip pixels in the mortar class.
    pub mortar_share: f64,
    /// The gradient magnitude (L* per px) that normalises to 1.
    pub gradient_ref: f64,
    /// Number of strip pixels.
    pub strip_pixels: usize,
    /// k-means iterations run.
    pub iterations: usize,
}

/// A user alpha image that cannot replace the automatic one.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum AlphaError {
    /// The override is not the sample's size (`[width, height]`).
    SizeMismatch { expected: [usize; 2], found: [usize; 2] },
    /// The override has no channel.
    NoChannel,
}

impl fmt::Display for AlphaError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AlphaError::SizeMismatch { expected, found } => write!(
                f,
                "the alpha override is {}×{} px but the sample is {}×{} px",
                found[0], found[1], expected[0], expected[1]
            ),
            AlphaError::NoChannel => write!(f, "the alpha override has no channel"),
        }
    }
}

impl std::error::Error for AlphaError {}

/// The sample's alpha: the user's override when given (checked by [`alpha_override`]),
/// otherwise [`auto_alpha`].
pub fn sample_alpha(
    image: &Image,
    polygons: &[Vec<Point>],
    params: &AlphaParams,
    user: Option<&Image>,
) -> Result<Image, AlphaError> {
    match user {
        Some(u) => alpha_override(u, image.width, image.height),
        None => Ok(auto_alpha(image, polygons, params)),
    }
}

/// A user alpha image as a 1-channel alpha of the sample's `width × height`: one channel is
/// taken as is, two or four channels give their last (alpha) channel, three channels (a grey
/// mask saved as RGB) their mean. Values are clamped to `[0, 1]`.
pub fn alpha_override(user: &Image, width: usize, height: usize) -> Result<Image, AlphaError> {
    if user.width != width || user.height != height {
        return Err(AlphaError::SizeMismatch { expected: [width, height], found: [user.width, user.height] });
    }
    let n = user.plane_len();
    let data: Vec<f32> = match user.channels {
        0 => return Err(AlphaError::NoChannel),
        1 => user.data[..n].to_vec(),
        3 => (0..n).map(|i| (user.data[i] + user.data[n + i] + user.data[2 * n + i]) / 3.0).collect(),
        c => user.plane(c - 1).to_vec(),
    };
    let data = data.into_iter().map(|v| if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) }).collect();
    Ok(Image { width, height, channels: 1, data })
}

/// The automatic alpha of a sample: a 1-channel image of the sample's size, 1 = mortar
/// (interstice), 0 = stone (interior). `polygons` are the sample's region outlines; their
/// sides are the drawn edges.
pub fn auto_alpha(image: &Image, polygons: &[Vec<Point>], params: &AlphaParams) -> Image {
    auto_alpha_with_model(image, polygons, params).0
}

/// [`auto_alpha`] and the model it fitted (`None` when there is no strip pixel, or no pixel
/// to seed one of the classes: then alpha is 0 everywhere).
pub fn auto_alpha_with_model(
    image: &Image,
    polygons: &[Vec<Point>],
    params: &AlphaParams,
) -> (Image, Option<AlphaModel>) {
    let (w, h) = (image.width, image.height);
    let mut alpha = Image::new(w, h, 1);
    if w == 0 || h == 0 || image.channels < 3 {
        return (alpha, None);
    }
    let dist = edge_distance(polygons, w, h, params.band + 1.0);
    let labels = rasterize_polygons(polygons, w, h);
    let band = params.band as f32;
    let shrink = params.shrink as f32;
    let n = w * h;
    let lab: Vec<Lab> = (0..n)
        .into_par_iter()
        .map(|i| {
            if dist[i] <= band + 1.5 {
                lab_of_srgb([image.data[i], image.data[n + i], image.data[2 * n + i]])
            } else {
                [0.0; 3]
            }
        })
        .collect();
    let strip: Vec<usize> = (0..n).filter(|&i| dist[i] <= band).collect();
    if strip.is_empty() {
        return (alpha, None);
    }
    // Seeds: 0 = stone (shrunk region masks), 1 = mortar (the drawn lines).
    let mut class: Vec<u8> =
        strip.iter().map(|&i| if labels.data[i] != NO_REGION && dist[i] >= shrink { 0 } else { 1 }).collect();
    if !class.contains(&0) || !class.contains(&1) {
        return (alpha, None);
    }
    let mut centres = class_means(&strip, &class, &lab);
    let mut iterations = 0;
    for _ in 0..params.iterations {
        iterations += 1;
        let mut changed = false;
        for (k, &i) in strip.iter().enumerate() {
            let c = nearest_centre(lab[i], &centres);
            if c != class[k] {
                class[k] = c;
                changed = true;
            }
        }
        if !class.contains(&0) || !class.contains(&1) {
            return (alpha, None);
        }
        centres = class_means(&strip, &class, &lab);
        if !changed {
            break;
        }
    }
    // Axis-aligned Gaussians of the two classes, with a floor of 1 ΔE on each σ.
    let mut var = [[0.0f64; 3]; 2];
    let mut count = [0usize; 2];
    for (k, &i) in strip.iter().enumerate() {
        let c = class[k] as usize;
        count[c] += 1;
        for ((v, x), m) in var[c].iter_mut().zip(lab[i]).zip(centres[c]) {
            *v += (x - m).powi(2);
        }
    }
    let sigma: [Lab; 2] =
        std::array::from_fn(|c| std::array::from_fn(|ch| (var[c][ch] / count[c] as f64).sqrt().max(1.0)));
    let share = count[1] as f64 / strip.len() as f64;
    let log_norm: [f64; 2] = std::array::from_fn(|c| {
        let prior = if c == 1 { share } else { 1.0 - share };
        prior.ln() - sigma[c].iter().map(|s| s.ln()).sum::<f64>()
    });
    let log_like = |x: Lab, c: usize| -> f64 {
        log_norm[c] - (0..3).map(|ch| ((x[ch] - centres[c][ch]) / sigma[c][ch]).powi(2)).sum::<f64>() / 2.0
    };
    // Luminance gradient by central differences (one-sided at the borders).
    let grad = |i: usize| -> f64 {
        let (x, y) = (i % w, i / w);
        let (xa, xb) = (x.saturating_sub(1), (x + 1).min(w - 1));
        let (ya, yb) = (y.saturating_sub(1), (y + 1).min(h - 1));
        let gx = if xb > xa { (lab[y * w + xb][0] - lab[y * w + xa][0]) / (xb - xa) as f64 } else { 0.0 };
        let gy = if yb > ya { (lab[yb * w + x][0] - lab[ya * w + x][0]) / (yb - ya) as f64 } else { 0.0 };
        (gx * gx + gy * gy).sqrt()
    };
    let mut grads: Vec<f64> = strip.par_iter().map(|&i| grad(i)).collect();
    let q = ((grads.len() - 1) as f64 * 0.95).round() as usize;
    let gradient_ref = *grads.select_nth_unstable_by(q, f64::total_cmp).1;
    let gradient_ref = gradient_ref.max(1e-6);
    let (lambda, low, high) = (params.lambda_g, params.low, params.high);
    alpha.data.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, a) in row.iter_mut().enumerate() {
            let i = y * w + x;
            if dist[i] > band {
                continue;
            }
            let d = log_like(lab[i], 0) - log_like(lab[i], 1);
            let p = 1.0 / (1.0 + d.clamp(-700.0, 700.0).exp());
            let g = (grad(i) / gradient_ref).min(1.0);
            *a = smoothstep(low, high, p - lambda * g) as f32;
        }
    });
    let model = AlphaModel {
        mortar: centres[1],
        stone: centres[0],
        mortar_sigma: sigma[1],
        stone_sigma: sigma[0],
        mortar_share: share,
        gradient_ref,
        strip_pixels: strip.len(),
        iterations,
    };
    (alpha, Some(model))
}

/// `0` below `low`, `1` above `high`, the cubic `t²(3 − 2t)` between.
pub fn smoothstep(low: f64, high: f64, s: f64) -> f64 {
    if s <= low {
        return 0.0;
    }
    if s >= high {
        return 1.0;
    }
    let t = (s - low) / (high - low);
    t * t * (3.0 - 2.0 * t)
}

/// Distance of every pixel centre to the nearest polygon side, row-major, capped at `cap`
/// (pixels farther than `cap` from every side read `cap`). A side shared by two polygons is
/// measured once.
pub fn edge_distance(polygons: &[Vec<Point>], width: usize, height: usize, cap: f64) -> Vec<f32> {
    let mut sides: BTreeSet<[[u64; 2]; 2]> = BTreeSet::new();
    for poly in polygons {
        for k in 0..poly.len() {
            let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
            let (a, b) = ([a[0].to_bits(), a[1].to_bits()], [b[0].to_bits(), b[1].to_bits()]);
            sides.insert(if (a[0], a[1]) <= (b[0], b[1]) { [a, b] } else { [b, a] });
        }
    }
    let mut d2 = vec![(cap * cap) as f32; width * height];
    for [a, b] in sides {
        let p = [f64::from_bits(a[0]), f64::from_bits(a[1])];
        let q = [f64::from_bits(b[0]), f64::from_bits(b[1])];
        let x0 = (p[0].min(q[0]) - cap).floor().max(0.0) as usize;
        let x1 = ((p[0].max(q[0]) + cap).ceil().max(0.0) as usize).min(width);
        let y0 = (p[1].min(q[1]) - cap).floor().max(0.0) as usize;
        let y1 = ((p[1].max(q[1]) + cap).ceil().max(0.0) as usize).min(height);
        let d = [q[0] - p[0], q[1] - p[1]];
        let len2 = d[0] * d[0] + d[1] * d[1];
        for y in y0..y1 {
            for x in x0..x1 {
                let c = [x as f64 + 0.5 - p[0], y as f64 + 0.5 - p[1]];
                let t = if len2 > 0.0 { ((c[0] * d[0] + c[1] * d[1]) / len2).clamp(0.0, 1.0) } else { 0.0 };
                let e = [c[0] - t * d[0], c[1] - t * d[1]];
                let v = (e[0] * e[0] + e[1] * e[1]) as f32;
                let o = &mut d2[y * width + x];
                if v < *o {
                    *o = v;
                }
            }
        }
    }
    d2.into_iter().map(f32::sqrt).collect()
}

fn class_means(strip: &[usize], class: &[u8], lab: &[Lab]) -> [Lab; 2] {
    let mut s = [[0.0f64; 3]; 2];
    let mut n = [0usize; 2];
    for (k, &i) in strip.iter().enumerate() {
        let c = class[k] as usize;
        n[c] += 1;
        for (a, x) in s[c].iter_mut().zip(lab[i]) {
            *a += x;
        }
    }
    std::array::from_fn(|c| std::array::from_fn(|ch| s[c][ch] / n[c].max(1) as f64))
}

/// The class of the nearer centre (ties to stone).
fn nearest_centre(x: Lab, centres: &[Lab; 2]) -> u8 {
    let d = |c: &Lab| (0..3).map(|ch| (x[ch] - c[ch]).powi(2)).sum::<f64>();
    u8::from(d(&centres[1]) < d(&centres[0]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::structure::fixtures::standins::{paint, wall_random, PaintParams, WallRandomParams};

    /// F25 (whole image): alpha is exactly 0 on ≥ 95 % of the ground-truth stone pixels and
    /// exactly 1 on ≥ 90 % of the ground-truth mortar pixels of a painted `wall_random`.
    #[test]
    fn f25_alpha_rates_on_painted_wall_random() {
        for seed in [11u64, 12, 13] {
            let s = wall_random(&WallRandomParams::default(), seed);
            let painted = paint(&s, &PaintParams::default(), seed);
            let (alpha, model) = auto_alpha_with_model(&painted.image, &s.polygons(), &AlphaParams::default());
            let model = model.expect("a model");
            let (mut stone, mut stone0, mut mortar, mut mortar1) = (0usize, 0usize, 0usize, 0usize);
            let (mut band_stone, mut band_stone0) = (0usize, 0usize);
            let dist = edge_distance(&s.polygons(), s.width, s.height, 13.0);
            for (i, &a) in alpha.data.iter().enumerate() {
                if painted.mortar[i] {
                    mortar += 1;
                    mortar1 += usize::from(a == 1.0);
                } else if painted.labels[i] != NO_REGION {
                    stone += 1;
                    stone0 += usize::from(a == 0.0);
                    if dist[i] <= 12.0 {
                        band_stone += 1;
                        band_stone0 += usize::from(a == 0.0);
                    }
                }
            }
            let rs = stone0 as f64 / stone as f64;
            let rm = mortar1 as f64 / mortar as f64;
            let rb = band_stone0 as f64 / band_stone as f64;
            println!("seed {seed}: stone→0 {rs:.4} (band {rb:.4}), mortar→1 {rm:.4}; {model:?}");
            assert!(rs >= 0.95 && rb >= 0.95, "stone rate {rs} (band {rb})");
            assert!(rm >= 0.90, "mortar rate {rm}");
        }
    }

    #[test]
    fn override_replaces_and_checks_the_size() {
        let img = Image::filled(8, 6, 3, 0.5);
        let user = Image::from_fn(8, 6, 4, |x, _, c| if c == 3 { x as f32 / 4.0 } else { 0.2 });
        let a = sample_alpha(&img, &[], &AlphaParams::default(), Some(&user)).unwrap();
        assert_eq!(a.channels, 1);
        assert_eq!(a.get(2, 3, 0), 0.5);
        assert_eq!(a.get(7, 0, 0), 1.0);
        let bad = Image::new(7, 6, 1);
        assert_eq!(
            sample_alpha(&img, &[], &AlphaParams::default(), Some(&bad)),
            Err(AlphaError::SizeMismatch { expected: [8, 6], found: [7, 6] })
        );
        // No structure: nothing to classify, alpha 0.
        let a = sample_alpha(&img, &[], &AlphaParams::default(), None).unwrap();
        assert!(a.data.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn smoothstep_ends_and_middle() {
        assert_eq!(smoothstep(0.4, 0.6, 0.4), 0.0);
        assert_eq!(smoothstep(0.4, 0.6, 0.6), 1.0);
        assert!((smoothstep(0.4, 0.6, 0.5) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn same_bytes_for_one_and_two_threads() {
        let s = wall_random(&WallRandomParams::default(), 5);
        let painted = paint(&s, &PaintParams::default(), 5);
        let run = |t: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(t).build().unwrap();
            pool.install(|| auto_alpha(&painted.image, &s.polygons(), &AlphaParams::default()))
        };
        let (a, b) = (run(1), run(2));
        assert!(a.data.iter().zip(&b.data).all(|(x, y)| x.to_bits() == y.to_bits()));
    }
}
