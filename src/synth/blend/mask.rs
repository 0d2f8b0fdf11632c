//! Masks from images ([references: welsman-dinelle §4.1]): greyscale intensity, then a cutoff.

use serde::{Deserialize, Serialize};

use crate::raster::Image;

/// Greyscale formula.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Luma {
    /// `(R + G + B) / 3`: plain intensity, the thesis's (faithful default).
    #[default]
    Mean,
    /// Rec. 601 weights (0.299, 0.587, 0.114).
    Rec601,
    /// Rec. 709 weights (0.2126, 0.7152, 0.0722).
    Rec709,
}

impl Luma {
    pub fn weights(self) -> [f32; 3] {
        match self {
            Luma::Mean => [1.0 / 3.0; 3],
            Luma::Rec601 => [0.299, 0.587, 0.114],
            Luma::Rec709 => [0.2126, 0.7152, 0.0722],
        }
    }
}

/// One-channel greyscale of `img`: the formula over channels 0–2 for 3 or more channels
/// (alpha ignored), channel 0 for 1 or 2 channels. `Mean` divides the sum by 3 (not a
/// multiplication by 1/3) so that equal channels give that value exactly.
pub fn grey(img: &Image, luma: Luma) -> Image {
    let n = img.plane_len();
    let mut out = Image::new(img.width, img.height, 1);
    if img.channels == 0 {
        return out;
    }
    if img.channels < 3 {
        out.data.copy_from_slice(img.plane(0));
        return out;
    }
    let (r, g, b) = (img.plane(0), img.plane(1), img.plane(2));
    let k = luma.weights();
    for i in 0..n {
        out.data[i] = match luma {
            Luma::Mean => (r[i] + g[i] + b[i]) / 3.0,
            _ => k[0] * r[i] + k[1] * g[i] + k[2] * b[i],
        };
    }
    out
}

/// Binary mask from a greyscale image: white (1) where `v ≥ cutoff`, else black (0), with
/// `cutoff ∈ [0, 1]` on `[0, 1]` data (the thesis's `I ≥ 255·c` on 8-bit values). `c = 0`
/// makes every non-negative pixel white; `c > 1` makes `[0, 1]` data all black.
pub fn threshold(grey: &Image, cutoff: f32) -> Image {
    let mut out = grey.clone();
    for v in &mut out.data {
        *v = if *v >= cutoff { 1.0 } else { 0.0 };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn item15_greyscale_formulas() {
        let img = Image::from_fn(2, 1, 3, |x, _, c| [[0.2f32, 0.4, 0.9], [1.0, 0.0, 0.5]][x][c]);
        let g = grey(&img, Luma::Mean);
        assert_eq!(g.data, vec![(0.2f32 + 0.4 + 0.9) / 3.0, (1.0f32 + 0.0 + 0.5) / 3.0]);
        for (luma, k) in [(Luma::Rec601, [0.299f64, 0.587, 0.114]), (Luma::Rec709, [0.2126, 0.7152, 0.0722])] {
            let g = grey(&img, luma);
            for x in 0..2 {
                let want: f64 = (0..3).map(|c| k[c] * img.get(x, 0, c) as f64).sum();
                assert!((g.data[x] as f64 - want).abs() <= 1e-6, "{luma:?}");
            }
        }
        // Equal channels give that value exactly; gray images pass through.
        let flat = Image::filled(3, 3, 3, 0.7);
        assert!(grey(&flat, Luma::Mean).data.iter().all(|&v| v == 0.7));
        let one = Image::filled(2, 2, 1, 0.3);
        assert_eq!(grey(&one, Luma::Rec709).data, one.data);
    }

    #[test]
    fn item16_cutoff() {
        let g = Image::from_fn(16, 16, 1, |x, y, _| ((y * 16 + x) as f32) / 255.0);
        assert!(threshold(&g, 0.0).data.iter().all(|&v| v == 1.0));
        assert!(threshold(&g, 1.0001).data.iter().all(|&v| v == 0.0));
        let mut last = usize::MAX;
        for k in 0..=100 {
            let white = threshold(&g, k as f32 / 100.0).data.iter().filter(|&&v| v == 1.0).count();
            assert!(white <= last);
            last = white;
        }
        // Goldens at the thesis's cutoffs (cf. Fig 4.8): white iff I ≥ 255·c on 8-bit data,
        // i.e. for codes 0..=255 exactly the codes ≥ ⌈255·c⌉.
        for (c, first_white) in [(0.25f32, 64usize), (0.5, 128), (0.75, 192)] {
            let m = threshold(&g, c);
            for code in 0..256 {
                let v = m.data[code];
                assert_eq!(v == 1.0, code >= first_white, "cutoff {c}, code {code}");
            }
        }
    }
}
