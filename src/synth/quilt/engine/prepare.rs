//! Per-channel statistics of the inputs that the sources and guide are prepared with: the
//! equalisation pooled over all samples, and weighted mean colours for nearest-mean choice.

use crate::raster::color::linear_rgb_to_lab;
use crate::raster::Image;
use crate::synth::quilt::params::Equalise;

/// Per-channel `(offset, scale)` of the equalisation, pooled over all samples, leaving out the
/// pixels each sample's mask (`ignore`, value > 0.5) says to ignore.
pub(super) fn equalisation(samples: &[&Image], ignore: &[Option<&Image>], mode: Equalise) -> Vec<(f64, f64)> {
    let channels = samples[0].channels;
    let kept = |si: usize, i: usize| ignore.get(si).copied().flatten().is_none_or(|m| m.data[i] <= 0.5);
    (0..channels)
        .map(|c| {
            let values = || {
                samples.iter().enumerate().flat_map(move |(si, s)| {
                    s.plane(c).iter().enumerate().filter(move |&(i, _)| kept(si, i)).map(|(_, &v)| f64::from(v))
                })
            };
            match mode {
                Equalise::None => (0.0, 1.0),
                Equalise::MinMax if values().next().is_none() => (0.0, 1.0),
                Equalise::ZScore if values().next().is_none() => (0.0, 1.0),
                Equalise::MinMax => {
                    let lo = values().fold(f64::INFINITY, f64::min);
                    let hi = values().fold(f64::NEG_INFINITY, f64::max);
                    (lo, if hi > lo { 1.0 / (hi - lo) } else { 1.0 })
                }
                Equalise::ZScore => {
                    let n = values().count() as f64;
                    let mean = values().sum::<f64>() / n;
                    let var = values().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
                    (mean, if var > 0.0 { 1.0 / var.sqrt() } else { 1.0 })
                }
            }
        })
        .collect()
}

pub(super) fn equalise_planes(img: &Image, eq: &[(f64, f64)], map: &[usize]) -> Vec<f32> {
    let plane = img.plane_len();
    let mut out = vec![0.0f32; plane * map.len()];
    for (i, &c) in map.iter().enumerate() {
        let (off, s) = eq[c];
        for (o, &v) in out[i * plane..(i + 1) * plane].iter_mut().zip(img.plane(i)) {
            *o = ((f64::from(v) - off) * s) as f32;
        }
    }
    out
}

/// Mean colour over the given channels (CIELAB from linear RGB when `lab`), weighted.
pub(super) fn mean_colour(
    img: &Image,
    channels: &[usize],
    lab: bool,
    pixels: impl Iterator<Item = (usize, f64)>,
) -> Option<Vec<f64>> {
    let plane = img.plane_len();
    let mut sum = vec![0.0f64; channels.len()];
    let mut wsum = 0.0;
    for (p, w) in pixels {
        if w <= 0.0 {
            continue;
        }
        let v: Vec<f32> = channels.iter().map(|&c| img.data[c * plane + p]).collect();
        let v = if lab { linear_rgb_to_lab([v[0], v[1], v[2]]).to_vec() } else { v };
        for (s, x) in sum.iter_mut().zip(v) {
            *s += w * f64::from(x);
        }
        wsum += w;
    }
    (wsum > 0.0).then(|| sum.into_iter().map(|s| s / wsum).collect())
}
