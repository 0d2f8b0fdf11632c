//! Compact binary serialisation of [`Image`] for the on-disk stage cache.
//!
//! Layout (all little-endian): magic `b"TSIM"`, format version `u32`, width `u32`,
//! height `u32`, channels `u32`, then `width * height * channels` `f32` samples in the
//! image's planar order. No compression: a cache hit on the no-op rebuild path should cost
//! about one memcpy, and the caller already hashes the bytes for integrity.

use super::{Image, RasterError};

const MAGIC: [u8; 4] = *b"TSIM";
/// Bump when the layout changes; older entries then fail to load and are rebuilt.
pub const VERSION: u32 = 1;
const HEADER_LEN: usize = 20;

/// Serialises `img`. The result always starts with a 20-byte header.
///
/// Dimensions above `u32::MAX` (impossible in practice: the data alone would exceed
/// 16 GiB) are saturated, which makes [`from_bytes`] reject the blob instead of
/// misreading it.
pub fn to_bytes(img: &Image) -> Vec<u8> {
    let dim = |v: usize| u32::try_from(v).unwrap_or(u32::MAX).to_le_bytes();
    let mut out = vec![0u8; HEADER_LEN + img.data.len() * 4];
    let (header, body) = out.split_at_mut(HEADER_LEN);
    header[0..4].copy_from_slice(&MAGIC);
    header[4..8].copy_from_slice(&VERSION.to_le_bytes());
    header[8..12].copy_from_slice(&dim(img.width));
    header[12..16].copy_from_slice(&dim(img.height));
    header[16..20].copy_from_slice(&dim(img.channels));
    // A fixed-size chunk loop over a preallocated buffer compiles to a straight copy on
    // little-endian targets (no per-element capacity checks as with `extend`).
    for (dst, v) in body.chunks_exact_mut(4).zip(&img.data) {
        dst.copy_from_slice(&v.to_le_bytes());
    }
    out
}

/// Parses a blob written by [`to_bytes`], validating magic, version and exact length.
/// Any malformed input yields [`RasterError::CorruptCache`], never a panic or an
/// allocation larger than the input.
pub fn from_bytes(bytes: &[u8]) -> Result<Image, RasterError> {
    let corrupt = |msg: String| RasterError::CorruptCache(msg);
    let header =
        bytes.get(..HEADER_LEN).ok_or_else(|| corrupt(format!("{} bytes is shorter than the header", bytes.len())))?;
    let word = |i: usize| u32::from_le_bytes([header[i], header[i + 1], header[i + 2], header[i + 3]]);
    if header[0..4] != MAGIC {
        return Err(corrupt("bad magic number".into()));
    }
    let version = word(4);
    if version != VERSION {
        return Err(corrupt(format!("format version {version}, expected {VERSION}")));
    }
    let (width, height, channels) = (word(8) as usize, word(12) as usize, word(16) as usize);
    let body = &bytes[HEADER_LEN..];
    let expected = width.checked_mul(height).and_then(|n| n.checked_mul(channels)).and_then(|n| n.checked_mul(4));
    if expected != Some(body.len()) {
        return Err(corrupt(format!(
            "{width}x{height}x{channels} image needs {} data bytes, found {}",
            expected.map_or_else(|| "too many".to_string(), |n| n.to_string()),
            body.len()
        )));
    }
    let data = body.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
    Ok(Image { width, height, channels, data })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_is_bit_exact() {
        let mut img = Image::from_fn(7, 5, 3, |x, y, c| x as f32 * 0.1 - y as f32 * 3.0 + c as f32);
        img.data[3] = f32::NAN;
        img.data[4] = -0.0;
        img.data[5] = f32::INFINITY;
        let bytes = to_bytes(&img);
        assert_eq!(bytes.len(), 20 + 7 * 5 * 3 * 4);
        let back = from_bytes(&bytes).unwrap();
        assert_eq!((back.width, back.height, back.channels), (7, 5, 3));
        let bits = |i: &Image| i.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back), bits(&img));
    }

    #[test]
    fn empty_images_round_trip() {
        for (w, h, c) in [(0, 0, 0), (0, 4, 3), (5, 0, 1), (3, 3, 0)] {
            let img = Image::new(w, h, c);
            assert_eq!(from_bytes(&to_bytes(&img)).unwrap(), img);
        }
    }

    #[test]
    fn layout_is_little_endian_and_stable() {
        let img = Image { width: 1, height: 1, channels: 1, data: vec![1.0] };
        assert_eq!(
            to_bytes(&img),
            [b'T', b'S', b'I', b'M', 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0x80, 0x3f]
        );
    }

    #[test]
    fn rejects_truncation_extension_and_bad_headers() {
        let bytes = to_bytes(&Image::filled(3, 2, 2, 0.5));
        for len in 0..bytes.len() {
            assert!(matches!(from_bytes(&bytes[..len]), Err(RasterError::CorruptCache(_))));
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(from_bytes(&longer).is_err());
        let mut magic = bytes.clone();
        magic[0] = b'X';
        assert!(from_bytes(&magic).unwrap_err().to_string().contains("magic"));
        let mut version = bytes.clone();
        version[4] = 2;
        assert!(from_bytes(&version).unwrap_err().to_string().contains("version 2"));
    }

    #[test]
    fn huge_claimed_dimensions_do_not_allocate_or_overflow() {
        let mut bytes = to_bytes(&Image::new(1, 1, 1));
        bytes[8..20].copy_from_slice(&[0xff; 12]);
        assert!(matches!(from_bytes(&bytes), Err(RasterError::CorruptCache(_))));
    }

    #[test]
    fn garbage_never_panics() {
        let mut s = 0x1234_5678_9abc_def1u64;
        for len in 0..300 {
            let junk: Vec<u8> = (0..len)
                .map(|_| {
                    s ^= s << 13;
                    s ^= s >> 7;
                    s ^= s << 17;
                    s as u8
                })
                .collect();
            let _ = from_bytes(&junk);
            let mut framed = to_bytes(&Image::new(2, 2, 1))[..20].to_vec();
            framed.extend_from_slice(&junk);
            assert_eq!(from_bytes(&framed).is_ok(), len == 16);
        }
    }
}
