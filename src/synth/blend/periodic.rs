//! Making a non-tileable image periodic, and measuring how tileable an image is.

use super::spectral::solve_periodic;
use crate::raster::Image;

/// The periodic component of the periodic-plus-smooth decomposition (Moisan 2011,
/// "Periodic plus smooth image decomposition"): `u = p + s` where `s` is the smooth image
/// whose periodic Laplacian equals the jump of `u` across its wrap edges, so `p` has no wrap
/// seam while keeping the interior gradients of `u` exactly. One FFT Poisson solve per
/// channel; the mean of each channel is kept.
pub fn make_periodic(img: &Image) -> Image {
    let (w, h) = (img.width, img.height);
    let mut out = img.clone();
    if w == 0 || h == 0 {
        return out;
    }
    for c in 0..img.channels {
        let u = img.plane(c);
        // v = Δ_periodic u − Δ_interior u: only the wrap edges contribute.
        let mut v = vec![0.0f64; w * h];
        for y in 0..h {
            let (a, b) = (u[y * w] as f64, u[y * w + w - 1] as f64);
            v[y * w] += b - a;
            v[y * w + w - 1] += a - b;
        }
        for x in 0..w {
            let (a, b) = (u[x] as f64, u[(h - 1) * w + x] as f64);
            v[x] += b - a;
            v[(h - 1) * w + x] += a - b;
        }
        // Δ s = v with L = −Δ, mean 0.
        let b: Vec<f64> = v.iter().map(|x| -x).collect();
        let s = solve_periodic(&b, w, h, 0.0);
        for (o, (&ui, si)) in out.plane_mut(c).iter_mut().zip(u.iter().zip(&s)) {
            *o = (ui as f64 - si) as f32;
        }
    }
    out
}

/// Tileability statistic (Welsman-Dinelle item 9c): the mean absolute difference across the wrap
/// seams (column W−1 to 0 and row H−1 to 0) divided by the mean absolute difference between
/// interior neighbours (both directions), over all channels. About 1 for a tileable texture;
/// large when the wrap is a visible seam. Returns 0 for images without interior differences.
pub fn wrap_seam_ratio(img: &Image) -> f64 {
    let (w, h) = (img.width, img.height);
    if w < 2 || h < 2 {
        return 0.0;
    }
    let (mut wrap, mut nw, mut inner, mut ni) = (0.0f64, 0usize, 0.0f64, 0usize);
    for c in 0..img.channels {
        let p = img.plane(c);
        for y in 0..h {
            for x in 0..w {
                let v = p[y * w + x] as f64;
                let right = p[y * w + (x + 1) % w] as f64;
                let down = p[((y + 1) % h) * w + x] as f64;
                if x + 1 == w {
                    wrap += (right - v).abs();
                    nw += 1;
                } else {
                    inner += (right - v).abs();
                    ni += 1;
                }
                if y + 1 == h {
                    wrap += (down - v).abs();
                    nw += 1;
                } else {
                    inner += (down - v).abs();
                    ni += 1;
                }
            }
        }
    }
    let inner = inner / ni as f64;
    if inner == 0.0 {
        return 0.0;
    }
    (wrap / nw as f64) / inner
}
