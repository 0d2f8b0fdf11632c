//! Colour-space conversions: sRGB transfer curve, CIELAB (D65) and luminance.
//!
//! Synthesis error metrics behave much better in linear light or in a perceptual space
//! than on gamma-encoded PNG values, so stages convert on the way in and out. Images are
//! treated as gray (1 channel), gray + alpha (2), or RGB followed by alpha / extra
//! channels (3 or more); only the colour channels are ever converted.

use rayon::prelude::*;

use super::{Image, RasterError};

/// Elements per rayon task: large enough to amortise scheduling, small enough to spread
/// a typical texture over both cores.
const CHUNK: usize = 1 << 14;

/// Decodes one sRGB-encoded value to linear light using the exact piecewise IEC 61966-2-1
/// curve (not the 2.2 power approximation). Values outside `[0, 1]` follow the same
/// formulas (negative values use the linear segment).
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Encodes one linear value with the exact piecewise sRGB curve; inverse of
/// [`srgb_to_linear`].
pub fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// How many leading channels hold colour: 1 for gray (± alpha), 3 for RGB(A…).
fn colour_channels(img: &Image) -> usize {
    if img.channels >= 3 {
        3
    } else {
        img.channels.min(1)
    }
}

/// Applies `f` to every sample of the colour channels, leaving alpha and extra channels.
fn map_colour_samples(img: &Image, f: fn(f32) -> f32) -> Image {
    let mut out = img.clone();
    let end = (colour_channels(img) * img.plane_len()).min(out.data.len());
    out.data[..end].par_chunks_mut(CHUNK).for_each(|chunk| {
        for v in chunk {
            *v = f(*v);
        }
    });
    out
}

/// [`srgb_to_linear`] on the colour channels (channel 0 of gray / gray+alpha images,
/// channels 0–2 otherwise); alpha and extra channels are copied unchanged.
pub fn image_srgb_to_linear(img: &Image) -> Image {
    map_colour_samples(img, srgb_to_linear)
}

/// [`linear_to_srgb`] on the colour channels; alpha and extra channels are unchanged.
pub fn image_linear_to_srgb(img: &Image) -> Image {
    map_colour_samples(img, linear_to_srgb)
}

/// A picture of linear values for a screen (previews of EXR outputs). Values in `[0, 1]`
/// are linear light and are sRGB-encoded; brighter ones are compressed first by the
/// extended Reinhard curve `v (1 + v / w²) / (1 + v)` with the brightest value as white `w`,
/// so nothing clips; an image with negative values is data (a height, a signed offset) and is
/// stretched from its smallest to its largest value instead. Not-a-numbers show as 0; alpha
/// and extra channels are unchanged.
pub fn tone_map_preview(img: &Image) -> Image {
    let end = (colour_channels(img) * img.plane_len()).min(img.data.len());
    let finite = || img.data[..end].iter().copied().filter(|v| v.is_finite());
    let lo = finite().fold(0.0f32, f32::min);
    let hi = finite().fold(0.0f32, f32::max);
    let mut out = img.clone();
    for v in &mut out.data[..end] {
        let x = if v.is_finite() { *v } else { 0.0 };
        *v = if lo < 0.0 {
            (x - lo) / (hi - lo).max(f32::MIN_POSITIVE)
        } else if hi > 1.0 {
            linear_to_srgb(x * (1.0 + x / (hi * hi)) / (1.0 + x))
        } else {
            linear_to_srgb(x)
        };
    }
    out
}

/// Linear sRGB (D65) to CIE XYZ, rows X, Y, Z (Lindbloom's values for IEC 61966-2-1).
const RGB_TO_XYZ: [[f64; 3]; 3] = [
    [0.412_456_4, 0.357_576_1, 0.180_437_5],
    [0.212_672_9, 0.715_152_2, 0.072_175_0],
    [0.019_333_9, 0.119_192_0, 0.950_304_1],
];

/// Inverse of [`RGB_TO_XYZ`].
const XYZ_TO_RGB: [[f64; 3]; 3] = [
    [3.240_454_2, -1.537_138_5, -0.498_531_4],
    [-0.969_266_0, 1.876_010_8, 0.041_556_0],
    [0.055_643_4, -0.204_025_9, 1.057_225_2],
];

/// The D65 reference white as the image of linear RGB (1, 1, 1) under [`RGB_TO_XYZ`]
/// (≈ 0.95047, 1.0, 1.08883). Deriving it from the same matrix, summed in the same order
/// as [`mul`], makes white map to exactly L* = 100, a* = b* = 0.
fn white() -> [f64; 3] {
    mul(&RGB_TO_XYZ, [1.0, 1.0, 1.0])
}

fn mul(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

const DELTA: f64 = 6.0 / 29.0;

fn lab_f(t: f64) -> f64 {
    if t > DELTA * DELTA * DELTA {
        t.cbrt()
    } else {
        t / (3.0 * DELTA * DELTA) + 4.0 / 29.0
    }
}

fn lab_f_inv(t: f64) -> f64 {
    if t > DELTA {
        t * t * t
    } else {
        3.0 * DELTA * DELTA * (t - 4.0 / 29.0)
    }
}

/// Converts linear sRGB to CIELAB (D65 white, L* in 0–100). Computed in f64 so a round
/// trip through [`lab_to_linear_rgb`] is accurate to f32 precision.
pub fn linear_rgb_to_lab(rgb: [f32; 3]) -> [f32; 3] {
    let xyz = mul(&RGB_TO_XYZ, rgb.map(f64::from));
    let w = white();
    let fx = lab_f(xyz[0] / w[0]);
    let fy = lab_f(xyz[1] / w[1]);
    let fz = lab_f(xyz[2] / w[2]);
    [(116.0 * fy - 16.0) as f32, (500.0 * (fx - fy)) as f32, (200.0 * (fy - fz)) as f32]
}

/// Converts CIELAB (D65) back to linear sRGB. Out-of-gamut colours give values outside
/// `[0, 1]`; they are not clipped.
pub fn lab_to_linear_rgb(lab: [f32; 3]) -> [f32; 3] {
    let [l, a, b] = lab.map(f64::from);
    let fy = (l + 16.0) / 116.0;
    let fx = fy + a / 500.0;
    let fz = fy - b / 200.0;
    let w = white();
    let xyz = [w[0] * lab_f_inv(fx), w[1] * lab_f_inv(fy), w[2] * lab_f_inv(fz)];
    mul(&XYZ_TO_RGB, xyz).map(|v| v as f32)
}

/// Applies a per-pixel transform of channels 0–2 in parallel; other channels are copied.
/// The caller guarantees at least 3 channels.
fn map_rgb_pixels(img: &Image, f: fn([f32; 3]) -> [f32; 3]) -> Image {
    let mut out = img.clone();
    let n = img.plane_len();
    if img.channels < 3 || out.data.len() < 3 * n {
        return out;
    }
    let (p0, rest) = out.data.split_at_mut(n);
    let (p1, rest) = rest.split_at_mut(n);
    let p2 = &mut rest[..n];
    p0.par_chunks_mut(CHUNK).zip(p1.par_chunks_mut(CHUNK)).zip(p2.par_chunks_mut(CHUNK)).for_each(|((a, b), c)| {
        for ((x, y), z) in a.iter_mut().zip(b.iter_mut()).zip(c.iter_mut()) {
            [*x, *y, *z] = f([*x, *y, *z]);
        }
    });
    out
}

/// CIE L* of a linear gray value (relative luminance, white = 1): the lightness an RGB
/// pixel `(v, v, v)` gets from [`linear_rgb_to_lab`].
pub fn linear_to_lightness(y: f32) -> f32 {
    (116.0 * lab_f(f64::from(y)) - 16.0) as f32
}

/// Inverse of [`linear_to_lightness`].
pub fn lightness_to_linear(l: f32) -> f32 {
    lab_f_inv((f64::from(l) + 16.0) / 116.0) as f32
}

/// Converts a linear image to CIELAB: channels 0–2 become L*, a*, b* for images with 3
/// or more channels; for gray and gray + alpha images channel 0 becomes L* (a gray pixel
/// has a* = b* = 0, so nothing is lost). Alpha and extra channels are copied unchanged.
/// Use [`image_linear_rgb_to_lab`] to insist on colour input.
pub fn image_linear_to_lab(img: &Image) -> Image {
    if img.channels >= 3 {
        map_rgb_pixels(img, linear_rgb_to_lab)
    } else {
        map_colour_samples(img, linear_to_lightness)
    }
}

/// Inverse of [`image_linear_to_lab`]: L*a*b* (or L* alone for 1–2 channels) back to
/// linear values; other channels unchanged.
pub fn image_lab_to_linear(img: &Image) -> Image {
    if img.channels >= 3 {
        map_rgb_pixels(img, lab_to_linear_rgb)
    } else {
        map_colour_samples(img, lightness_to_linear)
    }
}

fn require_rgb(img: &Image, operation: &'static str) -> Result<(), RasterError> {
    if img.channels < 3 {
        return Err(RasterError::TooFewChannels { operation, needed: 3, got: img.channels });
    }
    Ok(())
}

/// [`linear_rgb_to_lab`] on channels 0–2, refusing images with fewer than 3 channels;
/// channels beyond the third (alpha, masks) are kept unchanged.
pub fn image_linear_rgb_to_lab(img: &Image) -> Result<Image, RasterError> {
    require_rgb(img, "conversion to CIELAB")?;
    Ok(map_rgb_pixels(img, linear_rgb_to_lab))
}

/// [`lab_to_linear_rgb`] on channels 0–2, refusing images with fewer than 3 channels;
/// channels beyond the third are kept unchanged.
pub fn image_lab_to_linear_rgb(img: &Image) -> Result<Image, RasterError> {
    require_rgb(img, "conversion from CIELAB")?;
    Ok(map_rgb_pixels(img, lab_to_linear_rgb))
}

/// Rec. 709 / sRGB luminance weights, valid on linear values.
pub const REC709: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// A one-channel luminance image: Rec. 709 weights on channels 0–2 for 3 or more
/// channels (expects linear values), a copy of the only channel for gray, and channel 0
/// (gray, ignoring alpha) for two channels. An image without channels gives zeros.
pub fn luminance(img: &Image) -> Image {
    let n = img.plane_len();
    let mut out = Image::new(img.width, img.height, 1);
    match img.channels {
        0 => {}
        1 | 2 => out.data.copy_from_slice(img.plane(0)),
        _ => {
            let (r, g, b) = (img.plane(0), img.plane(1), img.plane(2));
            out.data.par_chunks_mut(CHUNK).enumerate().for_each(|(k, chunk)| {
                let start = k * CHUNK;
                for (i, v) in chunk.iter_mut().enumerate() {
                    let j = start + i;
                    *v = REC709[0] * r[j] + REC709[1] * g[j] + REC709[2] * b[j];
                }
            });
        }
    }
    debug_assert_eq!(out.data.len(), n);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32, eps: f32) -> bool {
        (a - b).abs() <= eps
    }

    #[test]
    fn previews_encode_light_compress_highlights_and_stretch_signed_data() {
        let img = |v: Vec<f32>| {
            let mut i = Image::new(2, 1, 1);
            i.data = v;
            i
        };
        let light = tone_map_preview(&img(vec![0.0, 0.214_041_14]));
        assert!(close(light.data[1], 0.5, 1e-5));
        let hdr = tone_map_preview(&img(vec![0.5, 8.0]));
        assert!(close(hdr.data[1], 1.0, 1e-6), "the brightest is white");
        assert!(hdr.data[0] > 0.0 && hdr.data[0] < linear_to_srgb(0.5));
        let signed = tone_map_preview(&img(vec![-2.0, 2.0]));
        assert_eq!(signed.data, vec![0.0, 1.0]);
        let nan = tone_map_preview(&img(vec![f32::NAN, f32::INFINITY]));
        assert_eq!(nan.data, vec![0.0, 0.0]);
    }

    #[test]
    fn srgb_known_values() {
        assert!(close(srgb_to_linear(0.5), 0.214_04, 1e-5), "{}", srgb_to_linear(0.5));
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!(close(srgb_to_linear(1.0), 1.0, 1e-6));
        assert!(close(linear_to_srgb(0.214_041_14), 0.5, 1e-5));
        // Linear segment below the knee.
        assert!(close(srgb_to_linear(0.04), 0.04 / 12.92, 1e-9));
        assert!(close(linear_to_srgb(0.001), 0.012_92, 1e-9));
    }

    #[test]
    fn srgb_round_trip_and_monotonic() {
        let mut prev = -1.0;
        for i in 0..=1000 {
            let v = i as f32 / 1000.0;
            let lin = srgb_to_linear(v);
            assert!(lin > prev || i == 0);
            prev = lin;
            assert!(close(linear_to_srgb(lin), v, 2e-6), "v = {v}");
        }
    }

    #[test]
    fn lab_known_values() {
        assert_eq!(linear_rgb_to_lab([1.0, 1.0, 1.0]), [100.0, 0.0, 0.0]);
        let black = linear_rgb_to_lab([0.0, 0.0, 0.0]);
        assert!(black.iter().all(|v| v.abs() < 1e-5), "{black:?}");
        // sRGB red (linear 1,0,0) is about L 53.24, a 80.09, b 67.20.
        let red = linear_rgb_to_lab([1.0, 0.0, 0.0]);
        for (got, want) in red.iter().zip([53.24, 80.09, 67.20]) {
            assert!(close(*got, want, 0.02), "{red:?}");
        }
        // Middle gray: L* of 18% reflectance is about 49.5, neutral.
        let gray = linear_rgb_to_lab([0.18; 3]);
        assert!(close(gray[0], 49.496, 0.01) && close(gray[1], 0.0, 1e-4) && close(gray[2], 0.0, 1e-4));
    }

    #[test]
    fn lab_round_trip() {
        for r in 0..=8 {
            for g in 0..=8 {
                for b in 0..=8 {
                    let rgb = [r as f32 / 8.0, g as f32 / 8.0, b as f32 / 8.0];
                    let back = lab_to_linear_rgb(linear_rgb_to_lab(rgb));
                    for (x, y) in rgb.iter().zip(back) {
                        assert!(close(*x, y, 1e-5), "{rgb:?} -> {back:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn image_srgb_conversions_leave_alpha_and_extras() {
        let img = Image::from_fn(5, 4, 5, |x, y, c| (x + y + c) as f32 / 16.0);
        let lin = image_srgb_to_linear(&img);
        for c in 0..5 {
            for (i, (a, b)) in img.plane(c).iter().zip(lin.plane(c)).enumerate() {
                let want = if c < 3 { srgb_to_linear(*a) } else { *a };
                assert_eq!(*b, want, "c={c} i={i}");
            }
        }
        let back = image_linear_to_srgb(&lin);
        assert!(img.data.iter().zip(&back.data).all(|(a, b)| close(*a, *b, 2e-6)));

        let gray_alpha = Image::from_fn(3, 3, 2, |x, _, _| x as f32 / 2.0);
        let out = image_srgb_to_linear(&gray_alpha);
        assert_eq!(out.plane(1), gray_alpha.plane(1));
        assert_eq!(out.plane(0)[1], srgb_to_linear(0.5));
    }

    #[test]
    fn image_lab_requires_three_channels_and_keeps_extras() {
        let err = image_linear_rgb_to_lab(&Image::new(2, 2, 2)).unwrap_err();
        assert_eq!(err.to_string(), "conversion to CIELAB needs at least 3 channels, the image has 2");
        // Big enough to span several rayon chunks.
        let img = Image::from_fn(200, 190, 4, |x, y, c| ((x * 3 + y * 5 + c) % 17) as f32 / 16.0);
        let lab = image_linear_rgb_to_lab(&img).unwrap();
        assert_eq!(lab.plane(3), img.plane(3));
        let px = [img.get(77, 101, 0), img.get(77, 101, 1), img.get(77, 101, 2)];
        let want = linear_rgb_to_lab(px);
        assert_eq!([lab.get(77, 101, 0), lab.get(77, 101, 1), lab.get(77, 101, 2)], want);
        let back = image_lab_to_linear_rgb(&lab).unwrap();
        assert!(img.data.iter().zip(&back.data).all(|(a, b)| close(*a, *b, 1e-5)));
    }

    #[test]
    fn infallible_lab_handles_gray_as_lightness() {
        let rgb = Image::from_fn(9, 4, 3, |x, y, c| (x * 4 + y + c) as f32 / 40.0);
        assert_eq!(image_linear_to_lab(&rgb), image_linear_rgb_to_lab(&rgb).unwrap());
        let gray_alpha = Image::from_fn(5, 2, 2, |x, _, c| if c == 0 { x as f32 / 4.0 } else { 0.5 });
        let lab = image_linear_to_lab(&gray_alpha);
        assert_eq!(lab.plane(1), gray_alpha.plane(1));
        // Same lightness a neutral RGB pixel of that value gets.
        let want = linear_rgb_to_lab([0.5; 3])[0];
        assert!(close(lab.get(2, 0, 0), want, 1e-4), "{} vs {want}", lab.get(2, 0, 0));
        assert!(close(lab.get(4, 1, 0), 100.0, 1e-4));
        let back = image_lab_to_linear(&lab);
        assert!(gray_alpha.data.iter().zip(&back.data).all(|(a, b)| close(*a, *b, 1e-6)));
    }

    #[test]
    fn luminance_by_channel_count() {
        let rgb = Image::from_fn(300, 70, 3, |x, y, c| [0.2, 0.5, 0.9][c] * (x + y) as f32 / 400.0);
        let l = luminance(&rgb);
        assert_eq!(l.channels, 1);
        let (x, y) = (250, 60);
        let want = 0.2126 * rgb.get(x, y, 0) + 0.7152 * rgb.get(x, y, 1) + 0.0722 * rgb.get(x, y, 2);
        assert_eq!(l.get(x, y, 0), want);
        assert!(close(luminance(&Image::filled(2, 2, 4, 1.0)).data[0], 1.0, 1e-6));

        let gray = Image::from_fn(4, 3, 1, |x, y, _| (x * y) as f32);
        assert_eq!(luminance(&gray), gray);
        let gray_alpha = Image::from_fn(4, 3, 2, |x, _, c| if c == 0 { x as f32 } else { 9.0 });
        assert_eq!(luminance(&gray_alpha).data, gray_alpha.plane(0));
        assert_eq!(luminance(&Image::new(2, 2, 0)), Image::new(2, 2, 1));
    }
}
