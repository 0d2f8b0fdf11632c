//! Joint colour histogram distance.

use serde::{Deserialize, Serialize};

use crate::raster::Image;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HistogramParams {
    /// Bins per channel over `[0, 1]` (values outside are clamped).
    pub bins: usize,
}

impl Default for HistogramParams {
    fn default() -> Self {
        HistogramParams { bins: 16 }
    }
}

/// Normalised joint histogram of channels 0–2 (`bins³` entries; `bins` for 1–2 channel
/// images, which use channel 0), summing to 1.
pub fn colour_histogram(img: &Image, params: &HistogramParams) -> Vec<f64> {
    let b = params.bins.max(1);
    let n = img.plane_len();
    let dims = if img.channels >= 3 { 3 } else { 1 };
    let mut hist = vec![0.0f64; b.pow(dims as u32)];
    if n == 0 || img.channels == 0 {
        return hist;
    }
    let bin = |v: f32| ((v.clamp(0.0, 1.0) * b as f32) as usize).min(b - 1);
    let inc = 1.0 / n as f64;
    if dims == 3 {
        let (r, g, bl) = (img.plane(0), img.plane(1), img.plane(2));
        for i in 0..n {
            hist[(bin(r[i]) * b + bin(g[i])) * b + bin(bl[i])] += inc;
        }
    } else {
        for &v in img.plane(0) {
            hist[bin(v)] += inc;
        }
    }
    hist
}

/// Total variation between the normalised joint colour histograms, `½ Σ |h_a − h_b|` in
/// `[0, 1]`. Images with 3+ and fewer channels are compared on channel 0's 1-D histogram.
pub fn colour_distance(a: &Image, b: &Image, params: &HistogramParams) -> f64 {
    let (a1, b1);
    let (a, b) = if (a.channels >= 3) != (b.channels >= 3) {
        a1 = Image { channels: 1, data: a.plane(0).to_vec(), ..a.clone() };
        b1 = Image { channels: 1, data: b.plane(0).to_vec(), ..b.clone() };
        (&a1, &b1)
    } else {
        (a, b)
    };
    let (ha, hb) = (colour_histogram(a, params), colour_histogram(b, params));
    0.5 * ha.iter().zip(&hb).map(|(x, y)| (x - y).abs()).sum::<f64>()
}
