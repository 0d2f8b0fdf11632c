//! PTM 1.2 files (Malzbender's polynomial texture maps) as RTI viewers read them: the
//! uncompressed `PTM_FORMAT_RGB` and `PTM_FORMAT_LRGB`, written and read as bytes.
//!
//! Layout: ASCII lines `PTM_1.2`, the format, width and height, six scales, six biases, then
//! the payload. Coefficients are bytes, `c = scale·(byte − bias)`, in the order
//! `u², v², uv, u, v, 1`; rows are stored bottom to top. LRGB: all pixels' six luminance
//! coefficients, then all pixels' RGB bytes; a viewer shows `POLY / 255 · rgb`. RGB: three
//! blocks (R, G, B) of six coefficients per pixel; a viewer shows `POLY` per channel. Scale and
//! bias are shared by the three colour blocks.
//!
//! The viewers' light frame has y up on screen, the array frame y down the rows, so the y-odd
//! coefficients (`uv`, `v`) change sign on the way in and out; with the row flip a file
//! relights in a viewer as it does here.

use serde::{Deserialize, Serialize};

use super::represent::ptm_vector;
use crate::synth::relight::error::RelightError;
use crate::synth::relight::light::Light;

/// The two uncompressed formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PtmFormat {
    Rgb,
    Lrgb,
}

impl PtmFormat {
    fn name(self) -> &'static str {
        match self {
            PtmFormat::Rgb => "PTM_FORMAT_RGB",
            PtmFormat::Lrgb => "PTM_FORMAT_LRGB",
        }
    }

    /// Payload bytes per pixel.
    fn bytes_per_pixel(self) -> usize {
        match self {
            PtmFormat::Rgb => 18,
            PtmFormat::Lrgb => 9,
        }
    }
}

/// A decoded PTM in the array frame (rows top down, y-odd coefficients sign-flipped back),
/// intensities in `[0, 1]` units: for LRGB six luminance planes and three colour planes
/// (`rgb / 255`), relit as `lum(l) · colour`; for RGB eighteen planes (R's six, G's, B's),
/// relit per channel.
#[derive(Clone, Debug, PartialEq)]
pub struct PtmImage {
    pub width: usize,
    pub height: usize,
    pub format: PtmFormat,
    pub coefficients: Vec<f64>,
    pub colour: Option<Vec<f64>>,
}

/// The y-up frame's sign of each coefficient.
const FLIP: [f64; 6] = [1.0, 1.0, -1.0, 1.0, -1.0, 1.0];

/// Encodes PTM maps (six planes, array frame, intensities in `[0, 1]`) with an optional
/// chromaticity (three planes; none = grey). LRGB stores per pixel the chromaticity divided by
/// its largest component (so it fits a byte) and folds that component into the polynomial.
pub fn write_ptm(
    width: usize,
    height: usize,
    maps: &[f64],
    chroma: Option<&[f64]>,
    format: PtmFormat,
) -> Result<Vec<u8>, RelightError> {
    let m = width * height;
    if m == 0 || maps.len() != 6 * m || chroma.is_some_and(|c| c.len() != 3 * m) {
        return Err(RelightError::Size { what: "PTM maps", got: [maps.len(), m], expected: [6 * m, m] });
    }
    if let Some(j) = maps.iter().chain(chroma.unwrap_or(&[])).position(|v| !v.is_finite()) {
        return Err(RelightError::PtmFile(format!("value {j} of the maps or chromaticity is not finite")));
    }
    let chroma_at = |c: usize, j: usize| chroma.map_or(1.0, |ch| ch[c * m + j]);
    // Coefficient blocks in file units (0..255 intensity, y-up frame), pixel-interleaved.
    let blocks = if format == PtmFormat::Lrgb { 1 } else { 3 };
    let mut coef = vec![0.0f64; blocks * m * 6];
    let mut rgb = vec![0u8; if format == PtmFormat::Lrgb { 3 * m } else { 0 }];
    for y in 0..height {
        let fy = height - 1 - y;
        for x in 0..width {
            let j = y * width + x;
            let fj = fy * width + x;
            match format {
                PtmFormat::Lrgb => {
                    let k = (0..3).map(|c| chroma_at(c, j)).fold(0.0, f64::max);
                    let k = if k > 0.0 && k.is_finite() { k } else { 1.0 };
                    for c in 0..3 {
                        rgb[fj * 3 + c] = (255.0 * chroma_at(c, j) / k).round().clamp(0.0, 255.0) as u8;
                    }
                    for n in 0..6 {
                        coef[fj * 6 + n] = 255.0 * k * FLIP[n] * maps[n * m + j];
                    }
                }
                PtmFormat::Rgb => {
                    for c in 0..3 {
                        for n in 0..6 {
                            coef[(c * m + fj) * 6 + n] = 255.0 * chroma_at(c, j) * FLIP[n] * maps[n * m + j];
                        }
                    }
                }
            }
        }
    }
    let (scale, bias) = quantiser(&coef);
    let mut out = format!(
        "PTM_1.2\n{}\n{width}\n{height}\n{}\n{}\n",
        format.name(),
        scale.map(|s| s.to_string()).join(" "),
        bias.map(|b| b.to_string()).join(" ")
    )
    .into_bytes();
    out.reserve(coef.len() + rgb.len());
    for (i, &c) in coef.iter().enumerate() {
        let n = i % 6;
        out.push((c / scale[n] as f64 + bias[n] as f64).round().clamp(0.0, 255.0) as u8);
    }
    out.extend_from_slice(&rgb);
    Ok(out)
}

/// Per-coefficient scale and bias mapping `[min, max]` onto bytes 0..255. The scale is an f32
/// (what viewers parse) and the bias an integer, so a coefficient decodes to within one scale
/// step. A constant coefficient gets a range that includes zero, so it stays exact-ish.
fn quantiser(coef: &[f64]) -> ([f32; 6], [i32; 6]) {
    let mut lo = [f64::INFINITY; 6];
    let mut hi = [f64::NEG_INFINITY; 6];
    for (i, &c) in coef.iter().enumerate() {
        lo[i % 6] = lo[i % 6].min(c);
        hi[i % 6] = hi[i % 6].max(c);
    }
    let mut scale = [1.0f32; 6];
    let mut bias = [0i32; 6];
    for n in 0..6 {
        let (mut a, mut b) = (lo[n], hi[n]);
        if b - a <= 1e-12 * a.abs().max(b.abs()) {
            a = a.min(0.0);
            b = b.max(0.0);
        }
        if b - a > 0.0 {
            scale[n] = ((b - a) / 255.0) as f32;
            bias[n] = (-a / scale[n] as f64).round() as i32;
        }
    }
    (scale, bias)
}

/// The next header line (at most 256 bytes), advancing `pos` past its newline.
fn next_line<'a>(bytes: &'a [u8], pos: &mut usize) -> Option<&'a [u8]> {
    let start = *pos;
    let end = start + bytes.get(start..)?.iter().take(256).position(|&b| b == b'\n')?;
    *pos = end + 1;
    Some(&bytes[start..end])
}

/// Reads an uncompressed PTM 1.2 (RGB or LRGB). Malformed input is an error, never a panic;
/// the payload size is checked against the bytes present before anything is allocated.
pub fn read_ptm(bytes: &[u8]) -> Result<PtmImage, RelightError> {
    let bad = |s: &str| RelightError::PtmFile(s.to_string());
    // The header is ASCII lines; its numbers may be split over lines, so it is read as tokens.
    let mut pos = 0;
    let version = next_line(bytes, &mut pos).ok_or_else(|| bad("no version line"))?;
    if version.trim_ascii() != b"PTM_1.2" {
        return Err(bad("the first line is not PTM_1.2"));
    }
    let format = match next_line(bytes, &mut pos).ok_or_else(|| bad("no format line"))?.trim_ascii() {
        b"PTM_FORMAT_RGB" => PtmFormat::Rgb,
        b"PTM_FORMAT_LRGB" => PtmFormat::Lrgb,
        other => {
            return Err(RelightError::PtmFile(format!(
                "unsupported format `{}` (only PTM_FORMAT_RGB and PTM_FORMAT_LRGB)",
                String::from_utf8_lossy(&other[..other.len().min(40)])
            )))
        }
    };
    let mut tokens: Vec<&str> = Vec::with_capacity(14);
    let mut i = pos;
    while tokens.len() < 14 {
        while i < bytes.len() && bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        let start = i;
        while i < bytes.len() && !bytes[i].is_ascii_whitespace() && i - start < 64 {
            i += 1;
        }
        if start == i {
            return Err(bad("the header ends before width, height, six scales and six biases"));
        }
        tokens.push(std::str::from_utf8(&bytes[start..i]).map_err(|_| bad("the header is not ASCII"))?);
    }
    let size = |t: &str| t.parse::<usize>().ok().filter(|&v| v > 0);
    let (width, height) = match (size(tokens[0]), size(tokens[1])) {
        (Some(w), Some(h)) => (w, h),
        _ => return Err(bad("width and height must be positive integers")),
    };
    let mut scale = [0.0f64; 6];
    let mut bias = [0.0f64; 6];
    for n in 0..6 {
        scale[n] = tokens[2 + n]
            .parse::<f64>()
            .ok()
            .filter(|s| s.is_finite())
            .ok_or_else(|| bad("a scale is not a number"))?;
        bias[n] = tokens[8 + n].parse::<i64>().map_err(|_| bad("a bias is not an integer"))? as f64;
    }
    let m = width.checked_mul(height).ok_or_else(|| bad("width × height overflows"))?;
    let need = m.checked_mul(format.bytes_per_pixel()).ok_or_else(|| bad("the payload size overflows"))?;
    // The payload is the file's last `need` bytes; what lies between the biases and it must be
    // whitespace (writers end the header with " \n" or "\n").
    if bytes.len() < i + need {
        return Err(RelightError::PtmFile(format!(
            "{width}x{height} needs {need} payload bytes, the file has {}",
            bytes.len().saturating_sub(i)
        )));
    }
    let start = bytes.len() - need;
    if !bytes[i..start].iter().all(|b| b.is_ascii_whitespace()) || start == i {
        return Err(bad("unexpected bytes between the header and the payload"));
    }
    let payload = &bytes[start..];
    let blocks = if format == PtmFormat::Lrgb { 1 } else { 3 };
    let mut coefficients = vec![0.0; blocks * 6 * m];
    for b in 0..blocks {
        for fy in 0..height {
            let y = height - 1 - fy;
            for x in 0..width {
                let src = (b * m + fy * width + x) * 6;
                for n in 0..6 {
                    let c = scale[n] * (payload[src + n] as f64 - bias[n]);
                    coefficients[(b * 6 + n) * m + y * width + x] = FLIP[n] * c / 255.0;
                }
            }
        }
    }
    let colour = (format == PtmFormat::Lrgb).then(|| {
        let rgb = &payload[6 * m..];
        let mut colour = vec![0.0; 3 * m];
        for fy in 0..height {
            let y = height - 1 - fy;
            for x in 0..width {
                for c in 0..3 {
                    colour[c * m + y * width + x] = rgb[(fy * width + x) * 3 + c] as f64 / 255.0;
                }
            }
        }
        colour
    });
    Ok(PtmImage { width, height, format, coefficients, colour })
}

impl PtmImage {
    /// Planar RGB relit at `light`, in `[0, 1]` units, unclamped.
    pub fn relight(&self, light: &Light) -> Vec<f64> {
        let m = self.width * self.height;
        let v = ptm_vector(light.vector());
        let poly =
            |block: usize, j: usize| (0..6).map(|n| self.coefficients[(block * 6 + n) * m + j] * v[n]).sum::<f64>();
        let mut out = vec![0.0; 3 * m];
        for j in 0..m {
            for c in 0..3 {
                out[c * m + j] = match &self.colour {
                    Some(col) => poly(0, j) * col[c * m + j],
                    None => poly(c, j),
                };
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::relight::fixtures::{scenario, Scenario};
    use crate::synth::relight::{extract, Method, PhotoStack};

    fn colour_stack() -> PhotoStack {
        let cap = scenario(Scenario::B);
        let m = cap.stack.pixels();
        let tint = |c: usize, j: usize| [0.9, 0.6, 0.3][c] * (1.0 + 0.2 * ((j * 7 + c) % 5) as f64 / 5.0);
        let rgb: Vec<Vec<f64>> =
            cap.stack.images.iter().map(|img| (0..3 * m).map(|i| img[i % m] * tint(i / m, i % m)).collect()).collect();
        PhotoStack::from_rgb(cap.n, cap.n, &rgb, cap.stack.lights.clone()).unwrap()
    }

    /// Write → read → relight matches the representation's colour relight within the
    /// quantisation error of one byte step per coefficient (and per colour byte).
    #[test]
    fn ptm_files_round_trip_within_quantisation() {
        for format in [PtmFormat::Lrgb, PtmFormat::Rgb] {
            for colour in [false, true] {
                let stack = if colour { colour_stack() } else { scenario(Scenario::D).stack };
                let rep = extract(&stack, Method::Ptm).unwrap();
                let bytes = write_ptm(rep.width, rep.height, &rep.maps, rep.chroma.as_deref(), format).unwrap();
                let head = String::from_utf8_lossy(&bytes[..40]).to_string();
                assert!(head.starts_with(&format!("PTM_1.2\n{}\n32\n32\n", format.name())), "{head}");
                let back = read_ptm(&bytes).unwrap();
                assert_eq!((back.width, back.height, back.format), (32, 32, format));
                // The bound: Σ_n scale_n/255 · |v_n| (coefficients) + ½/255 · |lum| (colour bytes).
                let m = rep.width * rep.height;
                let (scale, _) = {
                    let text = String::from_utf8_lossy(&bytes[..200]).to_string();
                    let nums: Vec<f64> = text.split_whitespace().skip(4).take(6).map(|t| t.parse().unwrap()).collect();
                    (nums, ())
                };
                for light in [Light::new(60.0, 60.0), Light::new(200.0, 20.0), Light::new(300.0, 45.0)] {
                    let lum = rep.relight(&light).unwrap();
                    let want = match &rep.chroma {
                        Some(ch) => crate::synth::relight::represent::colourise(&lum, ch),
                        None => (0..3 * m).map(|i| lum[i % m]).collect(),
                    };
                    let got = back.relight(&light);
                    let v = ptm_vector(light.vector());
                    let coef_err: f64 = (0..6).map(|n| scale[n] / 255.0 * v[n].abs()).sum();
                    let kmax = rep.chroma.as_ref().map_or(1.0, |c| c.iter().cloned().fold(0.0, f64::max));
                    for i in 0..3 * m {
                        let bound =
                            kmax * coef_err + (0.5 / 255.0) * (lum[i % m].abs() * kmax + coef_err * kmax) + 1e-9;
                        assert!(
                            (got[i] - want[i]).abs() <= bound,
                            "{format:?} colour={colour}: {} vs {}",
                            got[i],
                            want[i]
                        );
                    }
                }
            }
        }
    }

    /// The file's frame: rows bottom-up and y up. A pixel in our top row is the file's last
    /// row, and a light from +y here is a light from −v there.
    #[test]
    fn ptm_files_are_stored_bottom_up_in_the_y_up_frame() {
        let (w, h) = (2, 3);
        let m = w * h;
        let mut maps = vec![0.0; 6 * m];
        // Pixel (0, 0) (top-left here) brightens toward +y: a4 = 0.5; everything has a5 = 0.25.
        maps[4 * m] = 0.5;
        for j in 0..m {
            maps[5 * m + j] = 0.25;
        }
        let bytes = write_ptm(w, h, &maps, None, PtmFormat::Lrgb).unwrap();
        let payload = &bytes[bytes.len() - 9 * m..];
        let text = String::from_utf8_lossy(&bytes[..bytes.len() - 9 * m]).to_string();
        let nums: Vec<f64> = text.split_whitespace().skip(4).map(|t| t.parse().unwrap()).collect();
        let (scale4, bias4) = (nums[4], nums[10]);
        // Top-left here = file row h−1, column 0; its v coefficient is −0.5 · 255.
        let byte = payload[((h - 1) * w) * 6 + 4] as f64;
        assert!((scale4 * (byte - bias4) + 0.5 * 255.0).abs() <= scale4 + 1e-9);
        // Every other pixel's v coefficient decodes to 0.
        let byte = payload[4] as f64;
        assert!((scale4 * (byte - bias4)).abs() <= scale4 + 1e-9);
    }

    #[test]
    fn malformed_ptm_files_are_errors_not_panics() {
        let rep = extract(&scenario(Scenario::A).stack, Method::Ptm).unwrap();
        let good = write_ptm(rep.width, rep.height, &rep.maps, None, PtmFormat::Lrgb).unwrap();
        assert!(read_ptm(&good).is_ok());
        let cases: Vec<Vec<u8>> = vec![
            vec![],
            b"PTM_1.1\nPTM_FORMAT_LRGB\n".to_vec(),
            b"PTM_1.2\nPTM_FORMAT_JPEG_LRGB\n1 1\n".to_vec(),
            b"PTM_1.2\nPTM_FORMAT_LRGB\n4000000000 4000000000\n1 1 1 1 1 1\n0 0 0 0 0 0\n\0\0".to_vec(),
            b"PTM_1.2\nPTM_FORMAT_LRGB\n18446744073709551615 3\n1 1 1 1 1 1\n0 0 0 0 0 0\n".to_vec(),
            b"PTM_1.2\nPTM_FORMAT_LRGB\n1 1\n1 1 1 nan 1 1\n0 0 0 0 0 0\n123456789".to_vec(),
            b"PTM_1.2\nPTM_FORMAT_LRGB\n1 1\n1 1 1 1 1 1\n0 0 0 0 0\n".to_vec(),
            b"PTM_1.2\nPTM_FORMAT_LRGB\n0 1\n1 1 1 1 1 1\n0 0 0 0 0 0\n".to_vec(),
            good[..good.len() - 1].to_vec(),
            [&good[..60], &[0xff; 3][..], &good[60..]].concat(),
        ];
        for (i, c) in cases.iter().enumerate() {
            assert!(read_ptm(c).is_err(), "case {i} was accepted");
        }
        // Every truncation of a small file is an error or a smaller valid image, never a panic.
        let small = write_ptm(2, 1, &[0.1; 12], None, PtmFormat::Rgb).unwrap();
        for cut in 0..small.len() {
            let _ = read_ptm(&small[..cut]);
        }
    }
}
