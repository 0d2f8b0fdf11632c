//! The peer: `texture-synthesis` 0.8 (Embark), included by the bench and the quality test with
//! `#[path]` so that the library of this crate does not depend on it.

use tessera::raster::Image;
use tessera_peer_bench::{from_rgb8, to_rgb8};
use texture_synthesis as ts;

/// Synthesises `width × height` from `sample` with the peer's default parameters (its advertised
/// quality: 50 nearest neighbours, 50 random sample locations, Cauchy dispersion 1, backtracking
/// 50 % over 5 stages), the given seed and at most `threads` threads. The peer is deterministic
/// only with 1 thread (its documentation); the bench gives it tessera's pool size instead.
pub fn run_peer(sample: &Image, width: usize, height: usize, seed: u64, threads: usize) -> Image {
    let rgb = ts::image::RgbImage::from_raw(sample.width as u32, sample.height as u32, to_rgb8(sample))
        .expect("RGB8 buffer of the sample's size");
    let session = ts::Session::builder()
        .add_example(ts::image::DynamicImage::ImageRgb8(rgb))
        .output_size(ts::Dims::new(width as u32, height as u32))
        .seed(seed)
        .max_thread_count(threads)
        .build()
        .expect("texture-synthesis session");
    let out = session.run(None).into_image().to_rgba8();
    from_rgb8(width, height, out.as_raw(), 4)
}
