//! PNG and OpenEXR decoding/encoding on byte buffers.
//!
//! Nothing here touches the file system: the caller reads and writes files through its
//! own content-hashing layer, so the codecs take `&[u8]` and return `Vec<u8>`.
//!
//! Both encoders use fixed settings (compression level, filter, block layout, line
//! order, no timestamps) so the same image always produces the same bytes; golden files
//! and cache keys depend on that.

use std::io::Cursor;

use exr::prelude as x;
use exr::prelude::traits::{ReadChannels as _, ReadLayers as _, WritableImage as _};
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::{DynamicImage, ExtendedColorType, ImageEncoder, ImageError, ImageFormat};

use super::check_layout;
use super::{Image, RasterError};

/// Largest number of samples (`width * height * channels`) a decoder will allocate:
/// 2^28 f32 values, i.e. 1 GiB, enough for an 8K RGBA texture. A hostile header that
/// claims more is rejected before any pixel memory is reserved.
pub const MAX_DECODE_SAMPLES: usize = 1 << 28;

const PNG_SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a];
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// The container formats [`decode`] recognises.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Png,
    Exr,
}

/// Identifies the format from the leading magic bytes, ignoring any file extension (a
/// mislabelled `.png` that is really an EXR still decodes correctly).
pub fn sniff(bytes: &[u8]) -> Option<Format> {
    if bytes.starts_with(&PNG_SIGNATURE) {
        Some(Format::Png)
    } else if bytes.starts_with(&EXR_MAGIC) {
        Some(Format::Exr)
    } else {
        None
    }
}

/// True when `bytes` start with the OpenEXR magic number. EXR data is conventionally
/// linear light, PNG data sRGB-encoded, so callers use this to pick the transfer curve.
pub fn is_exr(bytes: &[u8]) -> bool {
    sniff(bytes) == Some(Format::Exr)
}

/// Decodes a PNG or OpenEXR file held in memory.
///
/// * PNG: any bit depth and colour type the `image` crate expands (palette, 1/2/4/8/16-bit
///   gray, gray+alpha, RGB, RGBA); samples are mapped to `[0, 1]` and the channel count is
///   the stored one (1–4). No gamma or ICC conversion is applied: values are as stored.
/// * EXR: the first flat layer at full resolution; every channel becomes f32 (u32 samples
///   are converted, losing precision above 2^24). Channel order is R, G, B, Y, A, then the
///   rest by name (numeric suffixes in numeric order, so `C4` < `C10`). The data window
///   origin is ignored. NaN or infinite samples are refused with
///   [`RasterError::NonFinite`].
pub fn decode(bytes: &[u8]) -> Result<Image, RasterError> {
    match sniff(bytes) {
        Some(Format::Png) => decode_png(bytes),
        Some(Format::Exr) => decode_exr(bytes),
        None => Err(RasterError::UnknownFormat),
    }
}

// ---------------------------------------------------------------------------------------
// PNG

fn decode_png(bytes: &[u8]) -> Result<Image, RasterError> {
    check_png_header_size(bytes)?;
    let decoded = image::load_from_memory_with_format(bytes, ImageFormat::Png)
        .map_err(|e| RasterError::CorruptPng(png_error_message(&e)))?;
    let (w, h) = (decoded.width() as usize, decoded.height() as usize);
    let u8s = |v: &u8| f32::from(*v) / 255.0;
    let u16s = |v: &u16| f32::from(*v) / 65535.0;
    let img = match decoded {
        DynamicImage::ImageLuma8(b) => planar(w, h, 1, b.as_raw(), u8s),
        DynamicImage::ImageLumaA8(b) => planar(w, h, 2, b.as_raw(), u8s),
        DynamicImage::ImageRgb8(b) => planar(w, h, 3, b.as_raw(), u8s),
        DynamicImage::ImageRgba8(b) => planar(w, h, 4, b.as_raw(), u8s),
        DynamicImage::ImageLuma16(b) => planar(w, h, 1, b.as_raw(), u16s),
        DynamicImage::ImageLumaA16(b) => planar(w, h, 2, b.as_raw(), u16s),
        DynamicImage::ImageRgb16(b) => planar(w, h, 3, b.as_raw(), u16s),
        DynamicImage::ImageRgba16(b) => planar(w, h, 4, b.as_raw(), u16s),
        // The PNG decoder produces none of the float layouts today; convert rather than
        // fail if a future `image` version starts to.
        other => planar(w, h, 4, other.to_rgba32f().as_raw(), |v: &f32| *v),
    };
    Ok(img)
}

/// Reads width, height and colour type from the IHDR chunk and refuses images above
/// [`MAX_DECODE_SAMPLES`] before the decoder allocates anything. Too-short input is left
/// for the decoder to report.
fn check_png_header_size(bytes: &[u8]) -> Result<(), RasterError> {
    match png_dimensions(bytes) {
        Some((width, height, channels)) => check_samples(width, height, channels),
        None => Ok(()),
    }
}

/// Width, height and (expanded) channel count from a PNG's IHDR chunk.
fn png_dimensions(bytes: &[u8]) -> Option<(usize, usize, usize)> {
    let ihdr = bytes.get(8..26)?;
    if &ihdr[4..8] != b"IHDR" {
        return None;
    }
    let be32 = |s: &[u8]| u32::from_be_bytes([s[0], s[1], s[2], s[3]]) as usize;
    let (width, height) = (be32(&ihdr[8..12]), be32(&ihdr[12..16]));
    let channels = match ihdr[17] {
        0 => 1,
        4 => 2,
        2 => 3,
        _ => 4, // RGBA, or palette which may expand to RGBA
    };
    Some((width, height, channels))
}

/// The bits per sample a PNG stores (1, 2, 4, 8 or 16), from its header; `None` for other
/// formats or an unreadable header.
pub fn png_bit_depth(bytes: &[u8]) -> Option<u8> {
    if sniff(bytes)? != Format::Png {
        return None;
    }
    let ihdr = bytes.get(8..26)?;
    (&ihdr[4..8] == b"IHDR").then_some(ihdr[16])
}

/// Width, height and channel count as the file's header states them, read without decoding
/// any pixels, so a caller can hold the decode to a memory budget. `None` when the header
/// cannot be read (the decoder then reports why).
pub fn decode_dimensions(bytes: &[u8]) -> Option<(usize, usize, usize)> {
    match sniff(bytes)? {
        Format::Png => png_dimensions(bytes),
        Format::Exr => {
            let meta = x::MetaData::read_from_buffered(Cursor::new(bytes), false).ok()?;
            let header = meta.headers.iter().find(|h| !h.deep)?;
            Some((header.layer_size.width(), header.layer_size.height(), header.channels.list.len()))
        }
    }
}

fn png_error_message(e: &ImageError) -> String {
    match e {
        ImageError::Decoding(d) => d.to_string(),
        ImageError::Limits(l) => format!("exceeds decoder limits ({l})"),
        other => other.to_string(),
    }
}

/// Deinterleaves `raw` (pixel-major, `channels` samples per pixel) into a planar image.
fn planar<T>(width: usize, height: usize, channels: usize, raw: &[T], convert: impl Fn(&T) -> f32) -> Image {
    debug_assert_eq!(raw.len(), width * height * channels);
    let mut img = Image::new(width, height, channels);
    for c in 0..channels {
        let plane = img.plane_mut(c);
        for (dst, src) in plane.iter_mut().zip(raw.iter().skip(c).step_by(channels)) {
            *dst = convert(src);
        }
    }
    img
}

/// Encodes 1–4 channels (gray, gray+alpha, RGB, RGBA) as an 8- or 16-bit PNG.
///
/// Values are clamped to `[0, 1]` (NaN becomes 0) and rounded to the nearest code, so a
/// decode/encode round trip is exact and the error is at most half a code step.
pub fn encode_png(img: &Image, bits: u8) -> Result<Vec<u8>, RasterError> {
    check_layout(img)?;
    let color = match (img.channels, bits) {
        (1, 8) => ExtendedColorType::L8,
        (2, 8) => ExtendedColorType::La8,
        (3, 8) => ExtendedColorType::Rgb8,
        (4, 8) => ExtendedColorType::Rgba8,
        (1, 16) => ExtendedColorType::L16,
        (2, 16) => ExtendedColorType::La16,
        (3, 16) => ExtendedColorType::Rgb16,
        (4, 16) => ExtendedColorType::Rgba16,
        (c, 8 | 16) => return Err(RasterError::PngChannels(c)),
        (_, b) => return Err(RasterError::PngBits(b)),
    };
    let (w, h) = dims_u32(img)?;

    let bytes_per_sample = usize::from(bits / 8);
    let stride = img.channels * bytes_per_sample;
    let mut buf = vec![0u8; img.data.len() * bytes_per_sample];
    for c in 0..img.channels {
        let plane = img.plane(c);
        let pixels = buf.chunks_exact_mut(stride).zip(plane);
        if bits == 8 {
            for (px, &v) in pixels {
                px[c] = quantize(v, 255.0) as u8;
            }
        } else {
            let at = c * 2;
            for (px, &v) in pixels {
                // `PngEncoder` expects native-endian 16-bit samples.
                let q = (quantize(v, 65535.0) as u16).to_ne_bytes();
                px[at..at + 2].copy_from_slice(&q);
            }
        }
    }

    let mut out = Vec::new();
    PngEncoder::new_with_quality(&mut out, CompressionType::Default, FilterType::Adaptive)
        .write_image(&buf, w, h, color)
        .map_err(|e| RasterError::Encode { format: "PNG", message: e.to_string() })?;
    Ok(out)
}

/// Maps `v` to the nearest integer code in `0..=max`, clamping out-of-range values.
fn quantize(v: f32, max: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        (v.clamp(0.0, 1.0) * max).round()
    }
}

fn dims_u32(img: &Image) -> Result<(u32, u32), RasterError> {
    if img.width == 0 || img.height == 0 || img.channels == 0 {
        return Err(RasterError::Empty { width: img.width, height: img.height, channels: img.channels });
    }
    let too_large = || RasterError::TooLarge {
        width: img.width,
        height: img.height,
        channels: img.channels,
        limit: u32::MAX as usize,
    };
    let w = u32::try_from(img.width).map_err(|_| too_large())?;
    let h = u32::try_from(img.height).map_err(|_| too_large())?;
    Ok((w, h))
}

fn check_samples(width: usize, height: usize, channels: usize) -> Result<(), RasterError> {
    let samples = width.checked_mul(height).and_then(|n| n.checked_mul(channels));
    match samples {
        Some(n) if n <= MAX_DECODE_SAMPLES => Ok(()),
        _ => Err(RasterError::TooLarge { width, height, channels, limit: MAX_DECODE_SAMPLES }),
    }
}

// ---------------------------------------------------------------------------------------
// OpenEXR

fn decode_exr(bytes: &[u8]) -> Result<Image, RasterError> {
    // Read only the headers first so an absurd data window is refused before the
    // decoder allocates sample storage for it.
    let meta = x::MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(exr_error)?;
    let header = meta
        .headers
        .iter()
        .find(|h| !h.deep)
        .ok_or_else(|| RasterError::UnsupportedExr("deep data is not supported".into()))?;
    let (width, height) = (header.layer_size.width(), header.layer_size.height());
    check_samples(width, height, header.channels.list.len())?;
    if let Some(ch) = header.channels.list.iter().find(|c| c.sampling != x::Vec2(1, 1)) {
        return Err(RasterError::UnsupportedExr(format!("channel `{}` is subsampled", ch.name)));
    }

    let exr_image = x::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        // Decoding happens inside the caller's own rayon jobs; a private thread pool per
        // file would only oversubscribe the cores.
        .non_parallel()
        .from_buffered(Cursor::new(bytes))
        .map_err(exr_error)?;
    let layer = exr_image.layer_data;
    let (width, height) = (layer.size.width(), layer.size.height());
    let n = width * height;

    let mut channels: Vec<&x::AnyChannel<x::FlatSamples>> = layer.channel_data.list.iter().collect();
    channels.sort_by_cached_key(|c| channel_sort_key(&c.name.to_string()));
    if channels.is_empty() {
        return Err(RasterError::UnsupportedExr("the layer has no channels".into()));
    }

    let mut img = Image::new(width, height, channels.len());
    let mut non_finite = 0usize;
    for (c, channel) in channels.iter().enumerate() {
        if channel.sample_data.len() != n {
            return Err(RasterError::UnsupportedExr(format!(
                "channel `{}` has {} samples, expected {n}",
                channel.name,
                channel.sample_data.len()
            )));
        }
        let plane = img.plane_mut(c);
        match &channel.sample_data {
            x::FlatSamples::F16(v) => {
                for (d, s) in plane.iter_mut().zip(v) {
                    *d = s.to_f32();
                }
            }
            x::FlatSamples::F32(v) => plane.copy_from_slice(v.as_slice()),
            x::FlatSamples::U32(v) => {
                for (d, s) in plane.iter_mut().zip(v) {
                    *d = *s as f32;
                }
            }
        }
        non_finite += plane.iter().filter(|v| !v.is_finite()).count();
    }
    if non_finite > 0 {
        return Err(RasterError::NonFinite { count: non_finite });
    }
    Ok(img)
}

/// Sort key giving R, G, B, Y, A first, then the remaining names in natural order
/// (`C4` before `C10`, so [`encode_exr`]'s extra channels come back in their order).
fn channel_sort_key(name: &str) -> (usize, String, usize, String, String) {
    let rank = ["R", "G", "B", "Y", "A"].iter().position(|n| *n == name).unwrap_or(5);
    let stem = name.trim_end_matches(|c: char| c.is_ascii_digit());
    let digits = name[stem.len()..].trim_start_matches('0');
    (rank, stem.to_string(), digits.len(), digits.to_string(), name.to_string())
}

fn exr_error(e: x::Error) -> RasterError {
    match e {
        x::Error::NotSupported(msg) => RasterError::UnsupportedExr(msg.into_owned()),
        x::Error::Invalid(msg) => RasterError::CorruptExr(msg.into_owned()),
        x::Error::Io(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            RasterError::CorruptExr("file is truncated".into())
        }
        other => RasterError::CorruptExr(other.to_string()),
    }
}

/// EXR channel names for an image with `channels` channels: `Y` for one, `R`,`G` for
/// two, `R`,`G`,`B`(,`A`) for three or four, and `C4`, `C5`… for any beyond the fourth.
pub fn exr_channel_names(channels: usize) -> Vec<String> {
    match channels {
        0 => Vec::new(),
        1 => vec!["Y".to_string()],
        n => {
            ["R", "G", "B", "A"].iter().map(|s| s.to_string()).chain((4..n).map(|i| format!("C{i}"))).take(n).collect()
        }
    }
}

/// Encodes any image with at least one channel as a 32-bit float OpenEXR file.
///
/// ZIP (16-line blocks) is lossless, so decoding gives back the exact bits; line order is
/// fixed to increasing and compression runs on this thread, so output bytes do not
/// depend on scheduling. Channel names follow [`exr_channel_names`].
pub fn encode_exr(img: &Image) -> Result<Vec<u8>, RasterError> {
    check_layout(img)?;
    dims_u32(img)?;
    let names = exr_channel_names(img.channels);
    let list: x::SmallVec<[x::AnyChannel<x::FlatSamples>; 4]> = names
        .into_iter()
        .enumerate()
        .map(|(c, name)| x::AnyChannel::new(name.as_str(), x::FlatSamples::F32(img.plane(c).to_vec())))
        .collect();
    let encoding = x::Encoding {
        compression: x::Compression::ZIP16,
        blocks: x::Blocks::ScanLines,
        line_order: x::LineOrder::Increasing,
    };
    let layer =
        x::Layer::new((img.width, img.height), x::LayerAttributes::default(), encoding, x::AnyChannels::sort(list));
    let mut out = Cursor::new(Vec::new());
    x::Image::from_layer(layer)
        .write()
        .non_parallel()
        .to_buffered(&mut out)
        .map_err(|e| RasterError::Encode { format: "EXR", message: e.to_string() })?;
    Ok(out.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient(w: usize, h: usize, c: usize) -> Image {
        Image::from_fn(w, h, c, |x, y, c| ((x * 7 + y * 13 + c * 29) % 101) as f32 / 100.0)
    }

    fn max_diff(a: &Image, b: &Image) -> f32 {
        assert_eq!((a.width, a.height, a.channels), (b.width, b.height, b.channels));
        a.data.iter().zip(&b.data).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max)
    }

    #[test]
    fn png_round_trip_8_and_16_bit_all_channel_counts() {
        for c in 1..=4 {
            let img = Image::from_fn(13, 7, c, |x, y, c| ((x * 31 + y * 17 + c * 5) as f32 * 0.0123).sin().abs());
            for (bits, step) in [(8u8, 255.0f32), (16, 65535.0)] {
                let bytes = encode_png(&img, bits).unwrap();
                assert_eq!(sniff(&bytes), Some(Format::Png));
                assert!(!is_exr(&bytes));
                let back = decode(&bytes).unwrap();
                assert_eq!(back.channels, c);
                let err = max_diff(&img, &back);
                assert!(err <= 0.5 / step + 1e-7, "c={c} bits={bits} err={err}");
                // Re-encoding the decoded image reproduces the same file.
                assert_eq!(encode_png(&back, bits).unwrap(), bytes);
            }
        }
    }

    #[test]
    fn png_clamps_and_rounds() {
        let img = Image { width: 4, height: 1, channels: 1, data: vec![-1.0, 2.0, f32::NAN, 0.6 / 255.0] };
        let back = decode(&encode_png(&img, 8).unwrap()).unwrap();
        assert_eq!(back.data, vec![0.0, 1.0, 0.0, 1.0 / 255.0]);
    }

    #[test]
    fn png_encoding_is_deterministic() {
        let img = gradient(40, 30, 3);
        assert_eq!(encode_png(&img, 8).unwrap(), encode_png(&img, 8).unwrap());
        assert_eq!(encode_png(&img, 16).unwrap(), encode_png(&img, 16).unwrap());
    }

    #[test]
    fn png_rejects_bad_channel_counts_bits_and_empty() {
        let five = Image::new(2, 2, 5);
        let err = encode_png(&five, 8).unwrap_err();
        assert_eq!(err.to_string(), "cannot write 5 channels to PNG");
        assert_eq!(encode_png(&Image::new(2, 2, 3), 12).unwrap_err(), RasterError::PngBits(12));
        assert!(matches!(encode_png(&Image::new(0, 2, 3), 8), Err(RasterError::Empty { .. })));
        let bad = Image { width: 2, height: 2, channels: 1, data: vec![0.0; 3] };
        assert!(matches!(encode_png(&bad, 8), Err(RasterError::BadLayout { .. })));
    }

    /// Hand-assembles a PNG from raw scanlines (each prefixed with filter byte 0), for the
    /// layouts our encoder never writes: palette and sub-byte bit depths.
    fn raw_png(w: u32, h: u32, depth: u8, color: u8, extra: &[(&[u8; 4], &[u8])], raw: &[u8]) -> Vec<u8> {
        fn crc32(data: &[u8]) -> u32 {
            let mut crc = 0xffff_ffffu32;
            for &b in data {
                crc ^= u32::from(b);
                for _ in 0..8 {
                    crc = if crc & 1 != 0 { (crc >> 1) ^ 0xedb8_8320 } else { crc >> 1 };
                }
            }
            !crc
        }
        fn adler32(data: &[u8]) -> u32 {
            let (mut a, mut b) = (1u32, 0u32);
            for &d in data {
                a = (a + u32::from(d)) % 65521;
                b = (b + a) % 65521;
            }
            (b << 16) | a
        }
        fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
            out.extend_from_slice(&(data.len() as u32).to_be_bytes());
            let mut body = kind.to_vec();
            body.extend_from_slice(data);
            out.extend_from_slice(&body);
            out.extend_from_slice(&crc32(&body).to_be_bytes());
        }
        // zlib stream holding one uncompressed ("stored") deflate block.
        let len = raw.len() as u16;
        let mut zlib = vec![0x78, 0x01, 0x01];
        zlib.extend_from_slice(&len.to_le_bytes());
        zlib.extend_from_slice(&(!len).to_le_bytes());
        zlib.extend_from_slice(raw);
        zlib.extend_from_slice(&adler32(raw).to_be_bytes());
        let mut ihdr = Vec::new();
        ihdr.extend_from_slice(&w.to_be_bytes());
        ihdr.extend_from_slice(&h.to_be_bytes());
        ihdr.extend_from_slice(&[depth, color, 0, 0, 0]);
        let mut out = PNG_SIGNATURE.to_vec();
        chunk(&mut out, b"IHDR", &ihdr);
        for (kind, data) in extra {
            chunk(&mut out, kind, data);
        }
        chunk(&mut out, b"IDAT", &zlib);
        chunk(&mut out, b"IEND", &[]);
        out
    }

    #[test]
    fn png_one_bit_gray_expands_to_unit_range() {
        let img = decode(&raw_png(8, 1, 1, 0, &[], &[0, 0b1011_0001])).unwrap();
        assert_eq!((img.width, img.height, img.channels), (8, 1, 1));
        assert_eq!(img.data, vec![1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
        // 2-bit gray: codes 0..=3 map to 0, 1/3, 2/3, 1.
        let img = decode(&raw_png(4, 1, 2, 0, &[], &[0, 0b0001_1011])).unwrap();
        let expect = [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0];
        assert!(img.data.iter().zip(expect).all(|(a, b)| (a - b).abs() < 1e-6), "{:?}", img.data);
    }

    #[test]
    fn png_palette_expands_to_rgb_or_rgba() {
        let plte: &[u8] = &[255, 0, 0, 0, 0, 255];
        let rgb = decode(&raw_png(2, 1, 8, 3, &[(b"PLTE", plte)], &[0, 1, 0])).unwrap();
        assert_eq!(rgb.channels, 3);
        assert_eq!(rgb.data, vec![0.0, 1.0, 0.0, 0.0, 1.0, 0.0]);
        let trns: &[u8] = &[51];
        let rgba = decode(&raw_png(2, 1, 8, 3, &[(b"PLTE", plte), (b"tRNS", trns)], &[0, 1, 0])).unwrap();
        assert_eq!(rgba.channels, 4);
        assert_eq!(rgba.plane(3), [1.0, 0.2]);
    }

    #[test]
    fn exr_round_trip_is_exact_for_any_channel_count() {
        for c in [1, 2, 3, 4, 5, 12] {
            let img = Image::from_fn(9, 6, c, |x, y, c| (x as f32 - 3.3) * 1.7e3 + y as f32 * 1e-4 - c as f32 * 0.123);
            let bytes = encode_exr(&img).unwrap();
            assert_eq!(sniff(&bytes), Some(Format::Exr));
            assert!(is_exr(&bytes));
            let back = decode(&bytes).unwrap();
            assert_eq!(back, img, "channels = {c}");
            assert_eq!(encode_exr(&img).unwrap(), bytes, "deterministic, channels = {c}");
        }
    }

    #[test]
    fn exr_channel_names_follow_convention() {
        assert_eq!(exr_channel_names(1), ["Y"]);
        assert_eq!(exr_channel_names(2), ["R", "G"]);
        assert_eq!(exr_channel_names(4), ["R", "G", "B", "A"]);
        assert_eq!(exr_channel_names(6), ["R", "G", "B", "A", "C4", "C5"]);
    }

    #[test]
    fn exr_channel_order_puts_colour_first_then_natural_order() {
        let mut names = vec!["Z", "A", "C10", "B", "C4", "Y", "R", "G", "depth"];
        names.sort_by_key(|n| channel_sort_key(n));
        assert_eq!(names, ["R", "G", "B", "Y", "A", "C4", "C10", "Z", "depth"]);
    }

    fn exr_with(channels: Vec<(&str, x::FlatSamples)>, w: usize, h: usize) -> Vec<u8> {
        let list: x::SmallVec<[x::AnyChannel<x::FlatSamples>; 4]> =
            channels.into_iter().map(|(n, s)| x::AnyChannel::new(n, s)).collect();
        let layer = x::Layer::new(
            (w, h),
            x::LayerAttributes::default(),
            x::Encoding::FAST_LOSSLESS,
            x::AnyChannels::sort(list),
        );
        let mut out = Cursor::new(Vec::new());
        x::Image::from_layer(layer).write().non_parallel().to_buffered(&mut out).unwrap();
        out.into_inner()
    }

    #[test]
    fn exr_reads_f16_and_u32_and_orders_channels() {
        let h = |v: f32| x::f16::from_f32(v);
        let bytes = exr_with(
            vec![
                ("A", x::FlatSamples::F16(vec![h(1.0), h(0.5)])),
                ("Y", x::FlatSamples::F16(vec![h(0.25), h(2.0)])),
                ("id", x::FlatSamples::U32(vec![7, 9])),
            ],
            2,
            1,
        );
        let img = decode(&bytes).unwrap();
        assert_eq!(img.channels, 3);
        assert_eq!(img.plane(0), [0.25, 2.0]); // Y
        assert_eq!(img.plane(1), [1.0, 0.5]); // A
        assert_eq!(img.plane(2), [7.0, 9.0]); // id
    }

    #[test]
    fn exr_with_non_finite_values_is_rejected_with_count() {
        let bytes = exr_with(
            vec![
                ("R", x::FlatSamples::F32(vec![0.0, f32::NAN, 1.0, f32::INFINITY])),
                ("G", x::FlatSamples::F32(vec![f32::NEG_INFINITY, 0.0, 0.0, 0.0])),
            ],
            2,
            2,
        );
        let err = decode(&bytes).unwrap_err();
        assert_eq!(err, RasterError::NonFinite { count: 3 });
        assert_eq!(err.to_string(), "EXR contains 3 NaN or infinite values");
        // Our own encoder writes them faithfully; it is reading that refuses them.
        let img = Image { width: 1, height: 1, channels: 1, data: vec![f32::NAN] };
        assert_eq!(decode(&encode_exr(&img).unwrap()), Err(RasterError::NonFinite { count: 1 }));
    }

    #[test]
    fn unknown_format_and_short_input() {
        assert_eq!(decode(b""), Err(RasterError::UnknownFormat));
        assert_eq!(decode(b"GIF89a......"), Err(RasterError::UnknownFormat));
        assert_eq!(decode(&PNG_SIGNATURE[..5]), Err(RasterError::UnknownFormat));
        assert_eq!(RasterError::UnknownFormat.to_string(), "not a PNG or OpenEXR file");
    }

    #[test]
    fn truncated_png_is_an_error_at_every_length() {
        let bytes = encode_png(&gradient(24, 17, 4), 16).unwrap();
        for len in 0..bytes.len() {
            // Lengths that cut only the IEND chunk may still decode; anything else errs.
            match decode(&bytes[..len]) {
                Ok(img) => assert!(len + 12 >= bytes.len(), "len {len} decoded to {img:?}"),
                Err(e) => {
                    let msg = e.to_string();
                    assert!(len < 8 || msg.starts_with("corrupt PNG: "), "len {len}: {msg}");
                }
            }
        }
    }

    #[test]
    fn truncated_exr_is_an_error_at_every_length() {
        let bytes = encode_exr(&gradient(21, 19, 3)).unwrap();
        for len in 0..bytes.len() {
            assert!(decode(&bytes[..len]).is_err(), "len {len} of {}", bytes.len());
        }
    }

    /// Tiny deterministic PRNG (xorshift) so the garbage tests need no extra dependency.
    fn garbage(seed: u64, len: usize) -> Vec<u8> {
        let mut s = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
        (0..len)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                (s >> 24) as u8
            })
            .collect()
    }

    #[test]
    fn random_garbage_never_panics() {
        for seed in 0..200 {
            let junk = garbage(seed, (seed as usize * 37) % 600);
            assert!(decode(&junk).is_err());
            let mut png = PNG_SIGNATURE.to_vec();
            png.extend_from_slice(&junk);
            assert!(decode(&png).is_err());
            let mut exr = EXR_MAGIC.to_vec();
            exr.extend_from_slice(&junk);
            assert!(decode(&exr).is_err());
        }
    }

    #[test]
    fn corrupted_bytes_inside_valid_files_never_panic() {
        let png = encode_png(&gradient(16, 16, 3), 8).unwrap();
        let exr = encode_exr(&gradient(16, 16, 4)).unwrap();
        for (i, file) in [png, exr].iter().enumerate() {
            for seed in 0..300u64 {
                let mut bytes = file.clone();
                let noise = garbage(seed + 1000 * i as u64, 4);
                let at = (seed as usize * 7919) % bytes.len();
                bytes[at] ^= noise[0] | 1;
                let at2 = (seed as usize * 104_729 + 13) % bytes.len();
                bytes[at2] = noise[1];
                let _ = decode(&bytes); // any result is fine; panicking is not
            }
        }
    }

    #[test]
    fn oversized_exr_header_is_refused_before_allocation() {
        let mut bytes = encode_exr(&Image::new(2, 2, 3)).unwrap();
        let key = b"dataWindow\0box2i\0";
        let at = bytes.windows(key.len()).position(|w| w == key).unwrap() + key.len() + 4;
        bytes[at + 8..at + 12].copy_from_slice(&99_999i32.to_le_bytes()); // xMax
        bytes[at + 12..at + 16].copy_from_slice(&99_999i32.to_le_bytes()); // yMax
        assert!(matches!(decode(&bytes), Err(RasterError::TooLarge { .. })), "{:?}", decode(&bytes));
    }

    #[test]
    fn oversized_png_header_is_refused_before_allocation() {
        let mut bytes = encode_png(&Image::new(1, 1, 4), 8).unwrap();
        bytes[16..20].copy_from_slice(&100_000u32.to_be_bytes());
        bytes[20..24].copy_from_slice(&100_000u32.to_be_bytes());
        assert!(matches!(decode(&bytes), Err(RasterError::TooLarge { .. })));
    }
}

#[cfg(test)]
mod fuzz {
    use super::*;

    /// Longer mutation run than the default suite; `cargo test --release -- --ignored`.
    #[test]
    #[ignore]
    fn extended_mutation_fuzz() {
        let files = [
            encode_png(&Image::from_fn(33, 17, 4, |x, y, c| ((x ^ y) + c) as f32 / 40.0), 16).unwrap(),
            encode_png(&Image::from_fn(20, 20, 1, |x, y, _| ((x * y) % 7) as f32 / 7.0), 8).unwrap(),
            encode_exr(&Image::from_fn(33, 40, 3, |x, y, c| (x + y * c) as f32)).unwrap(),
            encode_exr(&Image::from_fn(5, 5, 7, |x, y, c| (x + y * c) as f32)).unwrap(),
        ];
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        let mut ok = 0;
        for round in 0..200_000 {
            let mut bytes = files[round % files.len()].clone();
            let flips = 1 + (next() % 6) as usize;
            // Half the time aim at the header region, where the interesting parsing is.
            let span = if next() % 2 == 0 { bytes.len().min(400) } else { bytes.len() };
            for _ in 0..flips {
                let at = (next() as usize) % span;
                bytes[at] = next() as u8;
            }
            if next() % 4 == 0 {
                let keep = (next() as usize) % bytes.len();
                bytes.truncate(keep);
            }
            if decode(&bytes).is_ok() {
                ok += 1;
            }
        }
        eprintln!("{ok} mutated files still decoded");
    }
}
