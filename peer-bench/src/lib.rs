//! Shared set-up of the side-by-side comparison of tessera's image quilting with the
//! `texture-synthesis` crate (Embark, 0.8): the input, tessera's chosen quilting parameters,
//! the quality-metric parameters and the RGB8 conversions used to hand images to the peer.
//!
//! The peer itself is a dev-dependency only (used by `benches/quilt_peer.rs` and
//! `tests/quality.rs`), so nothing here depends on it.
//!
//! **Quilting parameters** ([`tessera_params`]): `QuiltParams::new` defaults with block 48
//! (overlap 8 = block / 6, tolerance 0.1, SSD, min–max equalisation, no coherence shortcut,
//! stride 1). README.md of this crate records the sweep (block 16–64, overlap block/6–block/3,
//! tolerance 0–0.3, SSD/SAD) that chose the block: every block ≥ 32 at the defaults already
//! beats the peer on coherence, completeness and pyramid distance; 48 is best balanced, and
//! SAD, though slightly more coherent, is 5–15× slower.
//!
//! **Metric parameters** ([`compare_params`]): images are compared as stored (8-bit sRGB
//! codes mapped to `[0, 1]`, no linearisation). Bidirectional patch similarity on 7 × 7 RGB
//! patches, query grid stride 2, 6 PatchMatch rounds; pyramid, spectrum and colour distances
//! at their defaults (64 bins over ±0.5, levels ≥ 4 px; 32 rings, Hann window; 16³ bins).

use std::path::PathBuf;

use tessera::raster::Image;
use tessera::synth::metrics::{compare_with, CompareParams, Comparison, PatchParams};
use tessera::synth::quilt::{quilt, QuiltParams};

/// `samples/photos/tissue.png` of the tessera repository: a 256 × 256 8-bit sRGB photo.
pub fn sample_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../samples/photos/tissue.png")
}

/// The input photo as a planar 3-channel image in `[0, 1]` (sRGB-encoded values).
pub fn load_sample() -> Image {
    let bytes = std::fs::read(sample_path()).expect("read samples/photos/tissue.png");
    let img = tessera::raster::io::decode(&bytes).expect("decode tissue.png");
    assert_eq!(img.channels, 3, "tissue.png is RGB");
    img
}

/// The centred `size × size` crop of `img` (the small variant keeps the photo's scale).
pub fn centre_crop(img: &Image, size: usize) -> Image {
    assert!(size <= img.width && size <= img.height);
    let (x0, y0) = ((img.width - size) / 2, (img.height - size) / 2);
    Image::from_fn(size, size, img.channels, |x, y, c| img.get(x0 + x, y0 + y, c))
}

/// Block side of [`tessera_params`].
pub const BLOCK: usize = 48;

/// tessera's quilting parameters for this comparison: `QuiltParams::new` defaults (overlap
/// block / 6 = 8, tolerance 0.1, SSD, min–max equalisation, no coherence shortcut, stride 1)
/// with a 48-pixel block (see the crate documentation).
pub fn tessera_params(width: usize, height: usize, seed: u64) -> QuiltParams {
    QuiltParams::new(width, height, BLOCK, seed)
}

/// Quilts `sample` to `width × height` with [`tessera_params`].
pub fn run_tessera(sample: &Image, width: usize, height: usize, seed: u64) -> Image {
    quilt(sample, &tessera_params(width, height, seed)).expect("quilting").image
}

/// The metric parameters (see the crate documentation).
pub fn compare_params() -> CompareParams {
    CompareParams {
        patches: PatchParams { size: 7, stride: 2, iterations: 6, seed: 0x5eed },
        ..CompareParams::default()
    }
}

/// Every measure of `output` against `sample` with [`compare_params`].
pub fn measure(output: &Image, sample: &Image) -> Comparison {
    compare_with(output, sample, &compare_params())
}

/// Pixel-interleaved 8-bit RGB bytes of a 3-channel image (values rounded, clamped to `[0, 1]`).
pub fn to_rgb8(img: &Image) -> Vec<u8> {
    assert_eq!(img.channels, 3);
    let n = img.plane_len();
    let mut out = Vec::with_capacity(3 * n);
    for i in 0..n {
        for c in 0..3 {
            out.push((img.data[c * n + i].clamp(0.0, 1.0) * 255.0).round() as u8);
        }
    }
    out
}

/// A planar 3-channel image in `[0, 1]` from pixel-interleaved RGB8 (`stride` bytes per pixel,
/// 3 for RGB, 4 for RGBA whose alpha is dropped).
pub fn from_rgb8(width: usize, height: usize, raw: &[u8], stride: usize) -> Image {
    assert!(stride >= 3 && raw.len() == width * height * stride);
    Image::from_fn(width, height, 3, |x, y, c| f32::from(raw[(y * width + x) * stride + c]) / 255.0)
}

/// Writes `img` as an 8-bit PNG under `<target>/peer-bench/<name>.png` and returns the path.
pub fn write_png(img: &Image, name: &str) -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target"));
    let dir = target.join("peer-bench");
    std::fs::create_dir_all(&dir).expect("create target/peer-bench");
    let path = dir.join(format!("{name}.png"));
    let png = tessera::raster::io::encode_png(img, 8).expect("encode png");
    std::fs::write(&path, png).expect("write png");
    path
}
