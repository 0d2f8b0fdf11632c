//! Per-sample features: colour histogram, normalised DFT, radial profile, orientation.

use rustfft::num_complex::Complex64;
use serde::{Deserialize, Serialize};

use super::error::LibraryError;
use crate::raster::Image;
use crate::synth::blend::mask::Luma;
use crate::synth::fft::fft_real;

/// How features are computed. Features computed with different settings do not compare.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FeatureParams {
    /// Histogram bins per RGB axis (32 in the thesis: 32³ = 32,768 bins).
    pub bins: usize,
    /// Side of the square power-of-two analysis image for the DFT (128, [references: welsman-dinelle §4.3]).
    pub size: usize,
    /// Box-resample every image to `size × size` (else only square power-of-two images are
    /// accepted, analysed at their own size).
    pub resample: bool,
    /// Grey formula for the Fourier features (thesis: plain intensity).
    pub luma: Luma,
    /// Angular step of the orientation estimate, in degrees.
    pub angle_step_deg: f64,
}

impl Default for FeatureParams {
    fn default() -> Self {
        FeatureParams { bins: 32, size: 128, resample: true, luma: Luma::Mean, angle_step_deg: 1.0 }
    }
}

/// The Chandra (1998) orientation estimate: amplitude summed along rays from the DFT
/// origin, per direction of the frequency vector (0° = along +x, 90° = along +y, y down).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Orientation {
    /// Direction of maximum summed amplitude, in `[0, 180)` degrees: the stripes' normal.
    pub angle_deg: f32,
    /// That maximum (sum of `|F|` along the ray).
    pub energy: f32,
    /// Maximum over mean of the angular profile (≈ 1 for isotropic textures).
    pub peakedness: f32,
}

/// Features of one sample, computed once and cached by the caller. Every float is an
/// f32, which JSON (serde_json's shortest representation) round-trips exactly, so cached
/// and fresh features rank identically.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Features {
    pub width: usize,
    pub height: usize,
    /// Pixels counted in the histogram (`width · height`).
    pub pixels: u64,
    pub bins: usize,
    /// Sparse histogram: `(bin, count)` with `bin = (r·bins + g)·bins + b`, sorted by bin.
    pub histogram: Vec<(u32, u32)>,
    /// Analysis side `n` of the spectrum.
    pub size: usize,
    /// `F(k, l) = (1/n²) Σ f e^{−2πi(kx + ly)/n}` of the grey analysis image, row-major
    /// (`l·n + k`), as `[re, im]`, values on the `[0, 1]` intensity scale.
    pub spectrum: Vec<[f32; 2]>,
    /// Mean `|F|` per integer frequency radius `0..=n/2` (ring 0 is the DC term).
    pub radial: Vec<f32>,
    pub orientation: Orientation,
}

/// Grey intensity of `img` in f64 (see [`Luma`]; 1–2 channel images use channel 0).
pub fn grey(img: &Image, luma: Luma) -> Vec<f64> {
    let n = img.plane_len();
    if img.channels < 3 {
        return img.plane(0).iter().map(|&v| v as f64).collect();
    }
    let (r, g, b) = (img.plane(0), img.plane(1), img.plane(2));
    let k = luma.weights();
    (0..n)
        .map(|i| match luma {
            Luma::Mean => (r[i] as f64 + g[i] as f64 + b[i] as f64) / 3.0,
            _ => k[0] as f64 * r[i] as f64 + k[1] as f64 * g[i] as f64 + k[2] as f64 * b[i] as f64,
        })
        .collect()
}

/// Area-weighted (box) resampling of a plane to `nw × nh`: each output pixel is the mean of
/// the source area it covers.
pub fn box_resample(plane: &[f64], w: usize, h: usize, nw: usize, nh: usize) -> Vec<f64> {
    let weights = |n: usize, m: usize| -> Vec<Vec<(usize, f64)>> {
        // Output cell i covers [i·n/m, (i+1)·n/m) in source units.
        (0..m)
            .map(|i| {
                let (a, b) = (i as f64 * n as f64 / m as f64, (i + 1) as f64 * n as f64 / m as f64);
                let mut v = Vec::new();
                let mut s = a.floor() as usize;
                while (s as f64) < b && s < n {
                    let overlap = (b.min(s as f64 + 1.0) - a.max(s as f64)).max(0.0);
                    if overlap > 0.0 {
                        v.push((s, overlap / (b - a)));
                    }
                    s += 1;
                }
                v
            })
            .collect()
    };
    let (wx, wy) = (weights(w, nw), weights(h, nh));
    let mut tmp = vec![0.0f64; h * nw];
    for y in 0..h {
        for (i, list) in wx.iter().enumerate() {
            tmp[y * nw + i] = list.iter().map(|&(x, wt)| wt * plane[y * w + x]).sum();
        }
    }
    let mut out = vec![0.0f64; nw * nh];
    for (j, list) in wy.iter().enumerate() {
        for i in 0..nw {
            out[j * nw + i] = list.iter().map(|&(y, wt)| wt * tmp[y * nw + i]).sum();
        }
    }
    out
}

/// The thesis's DFT (Eq. 4.3): `F = (1/n²) · FFT(f)` of an `n × n` plane.
pub fn dft(plane: &[f64], n: usize) -> Vec<Complex64> {
    let scale = 1.0 / (n * n) as f64;
    fft_real(plane, n, n).into_iter().map(|c| c * scale).collect()
}

/// Chandra orientation of a spectrum stored as `|F|` (row-major `n × n`, DC at index 0).
pub fn orientation(mag: &[f64], n: usize, step_deg: f64) -> Orientation {
    let step = if step_deg > 0.0 { step_deg } else { 1.0 };
    let count = (180.0 / step).round().max(1.0) as usize;
    let at = |x: f64, y: f64| {
        // Bilinear on the periodic spectrum.
        let (x0, y0) = (x.floor(), y.floor());
        let (tx, ty) = (x - x0, y - y0);
        let idx = |xx: f64, yy: f64| {
            let (xi, yi) = ((xx as i64).rem_euclid(n as i64) as usize, (yy as i64).rem_euclid(n as i64) as usize);
            mag[yi * n + xi]
        };
        (1.0 - tx) * (1.0 - ty) * idx(x0, y0)
            + tx * (1.0 - ty) * idx(x0 + 1.0, y0)
            + (1.0 - tx) * ty * idx(x0, y0 + 1.0)
            + tx * ty * idx(x0 + 1.0, y0 + 1.0)
    };
    let rmax = (n / 2).saturating_sub(1).max(1);
    let profile: Vec<f64> = (0..count)
        .map(|a| {
            let th = (a as f64 * step).to_radians();
            let (c, s) = (th.cos(), th.sin());
            (1..=rmax).map(|r| at(r as f64 * c, r as f64 * s)).sum()
        })
        .collect();
    let (mut best, mut energy) = (0usize, f64::MIN);
    for (i, &e) in profile.iter().enumerate() {
        if e > energy {
            best = i;
            energy = e;
        }
    }
    let mean = profile.iter().sum::<f64>() / profile.len() as f64;
    Orientation {
        angle_deg: (best as f64 * step) as f32,
        energy: energy as f32,
        peakedness: if mean > 0.0 { (energy / mean) as f32 } else { 0.0 },
    }
}

/// Computes a sample's features (see the module documentation).
pub fn features(img: &Image, params: &FeatureParams) -> Result<Features, LibraryError> {
    let (w, h) = (img.width, img.height);
    if w == 0 || h == 0 || img.channels == 0 {
        return Err(LibraryError::Empty);
    }
    let b = params.bins;
    if !(1..=256).contains(&b) {
        return Err(LibraryError::BadParameter { name: "bins", reason: format!("{b} is not in 1..=256") });
    }
    if params.resample && !(params.size.is_power_of_two() && params.size >= 2) {
        return Err(LibraryError::BadParameter {
            name: "size",
            reason: format!("{} is not a power of two ≥ 2", params.size),
        });
    }
    // Histogram on 8-bit codes (values are [0, 1] floats from the decoder).
    let code = |v: f32| ((v.clamp(0.0, 1.0) * 255.0).round() as usize * b / 256) as u32;
    let mut counts = vec![0u32; b * b * b];
    let n = img.plane_len();
    let planes: [&[f32]; 3] =
        if img.channels >= 3 { [img.plane(0), img.plane(1), img.plane(2)] } else { [img.plane(0); 3] };
    let bu = b as u32;
    for ((&r, &g), &bl) in planes[0].iter().zip(planes[1]).zip(planes[2]) {
        let bin = (code(r) * bu + code(g)) * bu + code(bl);
        counts[bin as usize] += 1;
    }
    let histogram: Vec<(u32, u32)> =
        counts.iter().enumerate().filter(|(_, &c)| c > 0).map(|(i, &c)| (i as u32, c)).collect();

    // Fourier features on the grey analysis image.
    let g = grey(img, params.luma);
    let (size, plane) = if params.resample {
        let s = params.size;
        if w == s && h == s {
            (s, g)
        } else {
            (s, box_resample(&g, w, h, s, s))
        }
    } else if w == h && w.is_power_of_two() {
        (w, g)
    } else {
        return Err(LibraryError::NotPowerOfTwo { width: w, height: h });
    };
    let f = dft(&plane, size);
    let spectrum: Vec<[f32; 2]> = f.iter().map(|c| [c.re as f32, c.im as f32]).collect();
    let mag: Vec<f64> = f.iter().map(|c| c.norm()).collect();
    let half = size / 2;
    let mut ring = vec![(0.0f64, 0usize); half + 1];
    for l in 0..size {
        let fy = if l <= half { l as f64 } else { l as f64 - size as f64 };
        for k in 0..size {
            let fx = if k <= half { k as f64 } else { k as f64 - size as f64 };
            let r = (fx * fx + fy * fy).sqrt().round() as usize;
            if r <= half {
                ring[r].0 += mag[l * size + k];
                ring[r].1 += 1;
            }
        }
    }
    let radial = ring.iter().map(|&(s, c)| if c > 0 { (s / c as f64) as f32 } else { 0.0 }).collect();
    let orientation = orientation(&mag, size, params.angle_step_deg);
    Ok(Features { width: w, height: h, pixels: n as u64, bins: b, histogram, size, spectrum, radial, orientation })
}

/// Which part of the DFT [`dft_image`] shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum DftPart {
    Re,
    Im,
}

/// The thesis's DFT display ([references: welsman-dinelle §4.3.2]): the real or imaginary part, centred (DC at
/// `(n/2, n/2)`), log-scaled: `pixel = log(1 + |v|) / max log(1 + |v|)` with `v` on the 8-bit
/// scale (`255 · F`, F normalised by 1/n² as in Eq. 4.3). A 1-channel `n × n` image in
/// `[0, 1]`; all zero when the part is zero everywhere.
pub fn dft_image(f: &Features, part: DftPart) -> Image {
    let n = f.size;
    let vals: Vec<f64> = f
        .spectrum
        .iter()
        .map(|c| {
            let v = if part == DftPart::Re { c[0] } else { c[1] } as f64;
            (1.0 + 255.0 * v.abs()).ln()
        })
        .collect();
    let mx = vals.iter().cloned().fold(0.0f64, f64::max);
    Image::from_fn(n, n, 1, |x, y, _| {
        if mx <= 1e-9 {
            return 0.0;
        }
        let (k, l) = ((x + n / 2) % n, (y + n / 2) % n);
        (vals[l * n + k] / mx) as f32
    })
}
