//! Depth instanced through a structured appearance [references: frasson §5.4]: one depth
//! texture quilted per unified texture and per contour atlas, then drawn through the very
//! triangles and UVs that draw the colour, so a region's depth is read from the same window as
//! its colour. The depth never crosses a region border, and a new target (another structure
//! dressed with the same appearance) costs a render, not a synthesis.

use crate::raster::Image;
use crate::synth::appearance::render::{render_with, RenderParams};
use crate::synth::appearance::types::{Dressing, TextureId};
use crate::synth::quilt::{quilt_with, Guide, QuiltError, QuiltOptions, QuiltParams};

/// One depth per texture of an appearance, in the textures' own layout: grey RGB (the
/// renderer's input), with the atlas's alpha as a fourth channel for the two atlases.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthTextures {
    pub unified: Vec<Image>,
    pub interstices: Image,
    pub junctions: Image,
}

/// The seed of texture `i`'s quilt: a stream per texture, all from the layer's seed.
pub fn texture_seed(seed: u64, i: usize) -> u64 {
    seed ^ (i as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15)
}

/// The depth of one texture: `patches` (linear RGB + depth in channel `depth_channel`) quilted
/// under `guide` (linear RGB) at its size, with `params`' block, search and seed and `options`'
/// terms, choice and masks; grey RGB, with `alpha` (the atlas's coverage) as a fourth channel
/// when given.
pub fn quilt_depth(
    guide: &Image,
    alpha: Option<&[f32]>,
    patches: &[&Image],
    depth_channel: usize,
    params: &QuiltParams,
    options: &QuiltOptions,
) -> Result<Image, QuiltError> {
    let params = QuiltParams { width: guide.width, height: guide.height, ..params.clone() };
    let mut opts = options.clone();
    opts.guide = Some(Guide { image: guide, weights: None, channels: Some(&[0, 1, 2]) });
    let quilted = quilt_with(patches, &params, &opts)?;
    let depth = quilted.image.plane(depth_channel);
    let w = guide.width;
    Ok(match alpha {
        Some(a) => Image::from_fn(w, guide.height, 4, |x, y, c| if c < 3 { depth[y * w + x] } else { a[y * w + x] }),
        None => Image::from_fn(w, guide.height, 3, |x, y, _| depth[y * w + x]),
    })
}

/// The depth of a dressed structure at `width × height` (`scale` pixels per mesh pixel): the
/// dressing drawn with the depth textures in place of the colour ones. Uncovered pixels (an
/// opening, the outside) are at the surface, 0.5.
pub fn render_depth(dressing: &Dressing, depths: &DepthTextures, width: usize, height: usize, scale: f64) -> Image {
    let params = RenderParams { width, height, scale, background: [0.5; 3] };
    let r = render_with(
        dressing,
        |t| match t {
            TextureId::Unified(i) => depths.unified.get(i),
            TextureId::Interstices => Some(&depths.interstices),
            TextureId::Junctions => Some(&depths.junctions),
        },
        &params,
    );
    Image { width, height, channels: 1, data: r.color.plane(0).to_vec() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::appearance::types::{Corner, Layer, Piece};

    fn square(x0: f64, x1: f64, texture: TextureId, layer: Layer) -> Piece {
        let c = |x: f64, y: f64| Corner { pos: [x, y], uv: [x - x0, y] };
        Piece {
            layer,
            texture,
            owner: 0,
            triangles: vec![[c(x0, 0.0), c(x1, 0.0), c(x1, 8.0)], [c(x0, 0.0), c(x1, 8.0), c(x0, 8.0)]],
        }
    }

    #[test]
    fn depth_is_read_through_the_colour_uvs_and_atlas_alpha() {
        // Two regions side by side on two unified textures, an interstice strip over the border
        // whose alpha covers only its left half: each pixel takes the depth of the texture its
        // colour comes from.
        let flat = |v: f32, w: usize| Image::from_fn(w, 8, 3, move |_, _, _| v);
        let strip = Image::from_fn(4, 8, 4, |x, _, c| if c == 3 { f32::from(u8::from(x < 2)) } else { 0.1 });
        let depths = DepthTextures {
            unified: vec![flat(0.8, 8), flat(0.6, 8)],
            interstices: strip,
            junctions: Image::new(1, 1, 4),
        };
        let dressing = Dressing {
            pieces: vec![
                square(0.0, 8.0, TextureId::Unified(0), Layer::Interior),
                square(8.0, 16.0, TextureId::Unified(1), Layer::Interior),
                square(6.0, 10.0, TextureId::Interstices, Layer::Interstice),
            ],
            clusters: vec![],
            warnings: vec![],
        };
        let d = render_depth(&dressing, &depths, 20, 8, 1.0);
        let at = |x: usize| d.get(x, 4, 0);
        assert!((at(2) - 0.8).abs() < 1e-6 && (at(13) - 0.6).abs() < 1e-6);
        // The strip's opaque half is mortar; its transparent half shows the region beneath.
        assert!((at(6) - 0.1).abs() < 1e-6 && (at(9) - 0.6).abs() < 1e-6, "{} {}", at(6), at(9));
        assert!((at(18) - 0.5).abs() < 1e-6, "uncovered pixels lie on the surface");
    }
}
