//! Example-based image quilting (Efros & Freeman 2001) for any number of channels, with the
//! extensions of Dong (2003, Ch. 5–6) and Frasson (2005, Sec. 5.3).
//!
//! - **Core** ([`quilt`]): square blocks of side `block` are placed every `block − overlap` pixels in
//!   raster order; each block is the sample block whose error over the already synthesised overlap is
//!   within `(1 + tolerance)·min` (a seeded uniform choice; `tolerance = 0` takes the minimum, ties to
//!   the lowest candidate index). Blocks are joined by minimum-error boundary cuts (vertical,
//!   horizontal, L-shaped; [`min_cut_vertical`]). All channels are matched together (summed, after
//!   optional per-channel equalisation and weights) and pasted together through one cut, so a single
//!   index map drives every channel (Dong Sec. 6.2.1).
//! - **Dong's modifications**: SAD as well as SSD ([`Metric`]); the "next neighbour block" coherence
//!   shortcut ([`Coherence`]); a candidate stride.
//! - **Guided and multi-patch quilting** ([`quilt_with`], [`Guide`], [`Terms`], [`SampleChoice`]):
//!   `E = α1·O + α2·G + α3·D` with a guide image and weight map, several samples ("patches") chosen per
//!   block by nearest mean colour (Frasson Eqs. 5.1–5.4), depth channels whose overlap error forms `D`
//!   and which follow the colour cut.
//! - **Layout controls**: tileable (torus) output, an occupancy mask, an orientation field (pre-rotated
//!   sample copies), and a density map mixing two samples.
//! - **Seam removal** ([`remove_seams`]): a band-Dirichlet Poisson solve around block boundaries
//!   with each block's own source gradients ([references: welsman-dinelle §4.2]); block interiors stay bit-exact.
//! - **Baseline**: Dong's pixel-based multiresolution method ([`pixel_synthesis`], Sec. 5.3.1), for the
//!   Table 5.3.3 comparison only.
//!
//! The result carries the index map (for every output pixel: source, x, y) and a seam mask, so any
//! other channel registered with the sample can be gathered later with [`gather`].
//!
//! **Speed.** Every candidate position is scored in bulk: SSD by FFT cross-correlation (`f64`, the
//! samples' half spectra computed once, each block's templates transformed column by column in
//! cache), SAD by an `f32` sweep; each
//! with a rounding bound that selects the shortlist re-scored exactly in `f64`, so the choice never
//! depends on bulk rounding. Blocks whose footprints do not overlap (a wavefront over the grid) are
//! computed in parallel; when a wave has fewer blocks than threads, the work inside a block is split.
//!
//! **Determinism.** Each block draws from its own random stream, derived from the seed and its grid
//! index; a wave's blocks read only pixels written by earlier waves and are pasted in raster order, so
//! the result equals the plain raster-order result. Parallel work is per element with a fixed
//! operation order, and selection reduces by `(error, index)`, so results are bit-identical for any
//! rayon thread count.

mod cut;
mod engine;
mod params;
mod pixel;
mod result;
mod rotate;
mod seams;
mod search;
#[cfg(test)]
mod tests;

pub use cut::{min_cut_horizontal, min_cut_vertical};
pub use params::{
    default_overlap, Coherence, Equalise, Guide, Input, Metric, Orientation, QuiltError, QuiltOptions, QuiltParams,
    SampleChoice, Terms,
};
pub use pixel::{pixel_synthesis, PixelParams, PixelResult};
pub use result::{BlockRecord, IndexMap, QuiltResult, SourceInfo};
pub use rotate::rotate_sample;
pub use seams::{remove_seams, Deseamed, SeamParams};

use crate::raster::Image;

/// Plain quilting of one sample.
pub fn quilt(sample: &Image, params: &QuiltParams) -> Result<QuiltResult, QuiltError> {
    quilt_with(&[sample], params, &QuiltOptions::default())
}

/// Quilting with every option: several samples, guide, error terms, occupancy, orientation, density.
pub fn quilt_with(samples: &[&Image], params: &QuiltParams, options: &QuiltOptions) -> Result<QuiltResult, QuiltError> {
    engine::run(samples, params, options, None)
}

/// Guided quilting, `E = α·O + (1 − α)·G` (Frasson Eq. 5.3).
pub fn quilt_guided(sample: &Image, guide: Guide, alpha: f32, params: &QuiltParams) -> Result<QuiltResult, QuiltError> {
    let options = QuiltOptions { guide: Some(guide), terms: Terms::guided(alpha), ..QuiltOptions::default() };
    quilt_with(&[sample], params, &options)
}

/// Frasson's multi-patch depth synthesis (Sec. 5.3.1): each patch is one image holding its colour
/// channels and its depth channel(s) `depth_channels`; each block draws from the patch whose mean colour
/// (CIELAB when `lab`) is nearest the guide block's, scored by `α1·O + α2·G + α3·D`. The result's image
/// holds colour and depth, assembled through the same cuts (computed on the colour error).
pub fn quilt_multipatch(
    patches: &[&Image],
    guide: Guide,
    depth_channels: &[usize],
    terms: Terms,
    lab: bool,
    params: &QuiltParams,
) -> Result<QuiltResult, QuiltError> {
    let options = QuiltOptions {
        guide: Some(guide),
        terms,
        depth_channels: depth_channels.to_vec(),
        choice: SampleChoice::NearestMean { lab },
        ..QuiltOptions::default()
    };
    quilt_with(patches, params, &options)
}

/// Gathers `other` (registered with the single input sample) through the result's index map,
/// rotating it like the sample when an orientation field was used. Gathering the sample itself
/// reproduces `result.image` exactly.
pub fn gather(result: &QuiltResult, other: &Image) -> Result<Image, QuiltError> {
    gather_many(result, &[other])
}

/// [`gather`] for results built from several samples: `others[i]` is registered with sample `i` (same
/// size as that sample). Empty pixels are 0.
pub fn gather_many(result: &QuiltResult, others: &[&Image]) -> Result<Image, QuiltError> {
    let needed = result.sources.iter().map(|s| s.sample + 1).max().unwrap_or(0);
    if others.len() < needed || others.is_empty() {
        return Err(QuiltError::SampleCount { got: others.len(), expected: "one image per input sample" });
    }
    let channels = others[0].channels;
    let mut rotated: Vec<Image> = Vec::with_capacity(result.sources.len());
    for s in &result.sources {
        let o = others[s.sample];
        params::check_size(Input::Gathered, o, s.width, s.height)?;
        if o.channels != channels {
            return Err(QuiltError::ChannelMismatch {
                what: Input::GatheredImages,
                expected: channels,
                got: o.channels,
            });
        }
        params::check_finite_image(Input::Gathered, o)?;
        rotated.push(if s.angle == 0.0 { o.clone() } else { rotate_sample(o, s.angle).0 });
    }
    let refs: Vec<&Image> = rotated.iter().collect();
    Ok(result.index.gather_sources(&refs))
}
