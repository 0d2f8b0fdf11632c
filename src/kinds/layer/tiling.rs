//! Layers made by histogram-preserving tiling and blending of a sample (Heitz & Neyret 2018, and
//! Mikkelsen's hexagonal tiles) [references: heitz-neyret]: for textures that are not isotropic
//! noise, the sample itself laid on a random triangle or hex lattice, each point evaluated on its
//! own, blended so that the sample's histogram survives.
//!
//! ```text
//! sample ─► layer.tiling_prepare (Gaussianised sample, lookup tables) ─► layer.tiling (lattice, seed, size)
//! ```

use super::quilt_size;
use super::spec::GRIDS;
use crate::graph::{Handle, In, Inputs, RunCx, StageError};
use crate::kinds::{Encoded, FnStage, Planner};
use crate::lang::{Decl, Diagnostic};
use crate::raster::Image;
use crate::synth::noise::tiling::{self, Prepared, TilingParams};

/// The properties that only a tiling layer reads.
pub const PROPS: &[&str] = &["grid", "cell", "contrast", "cell_rotation"];

impl Encoded for Prepared {
    fn encode(&self) -> Vec<u8> {
        serde_json::to_vec(self).expect("a prepared sample serialises")
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        serde_json::from_slice(bytes).map_err(|e| e.to_string())
    }
}

#[derive(serde::Serialize)]
struct Tiling {
    prepared: In<Prepared>,
    params: TilingParams,
    size: (usize, usize),
    /// Exemplar widths per layer pixel.
    pixel: f64,
    origin: [f64; 2],
}

/// Working memory per pixel.
const BYTES_PER_PIXEL: f64 = 24.0;

pub fn plan(p: &mut Planner, d: &Decl, sample: &str) -> Result<Handle<Image>, Diagnostic> {
    let props = &d.props;
    let (size, size_at) = quilt_size(p, d);
    p.check_pixels(d, size_at, size, BYTES_PER_PIXEL)?;
    let at = props.span("tiling").unwrap_or(d.name_span);
    let mut inputs = Inputs::new();
    let image = inputs.add(p.value::<Image>(sample, at)?);
    let stage = FnStage::keyed("layer.tiling_prepare", 1, image, |cx, &img| {
        tiling::prepare(&cx.get(img), false).map_err(|e| StageError::new(e.to_string()).at_prop("tiling"))
    });
    let prepared = p.add(format!("layer {} (prepared sample)", d.name), stage, inputs, vec![]);
    let mut inputs = Inputs::new();
    let params = TilingParams {
        grid: GRIDS.get(props.enumeration("grid")),
        scale: props.num("cell"),
        contrast: props.num("contrast"),
        rotation: props.num("cell_rotation"),
        seed: p.seed(d, "tiling"),
        ..TilingParams::default()
    };
    let tiling = Tiling {
        prepared: inputs.add(prepared),
        params,
        size,
        // One layer pixel per sample pixel at zoom 1 (the sample's width in pixels is known only
        // when the stage runs; the stage scales by it).
        pixel: 1.0 / props.num("zoom"),
        origin: props.vec2("origin"),
    };
    let stage = FnStage::keyed("layer.tiling", 4, tiling, run);
    Ok(p.add(format!("layer {}", d.name), stage, inputs, vec![]))
}

fn run(cx: &RunCx, t: &Tiling) -> Result<Image, StageError> {
    let prep = cx.get(t.prepared);
    let (w, h) = t.size;
    let texel = t.pixel / prep.width() as f64;
    let region = [t.origin[0], t.origin[1], t.origin[0] + w as f64 * texel, t.origin[1] + h as f64 * texel];
    tiling::render(&prep, &t.params, w, h, region).map_err(|e| {
        let prop = match e {
            tiling::TilingError::Scale(_) => "cell",
            tiling::TilingError::Contrast(_) => "contrast",
            tiling::TilingError::Rotation(_) => "cell_rotation",
            _ => "tiling",
        };
        StageError::new(e.to_string()).at_prop(prop)
    })
}
