//! Layers evaluated from a procedural texture [references: lagae §7]: every pixel computed on
//! its own from the fitted parameters (no sample needed), at any zoom, with band gains (the
//! paper's Fig. 11(d) edit), as a slice of the solid texture, or morphed toward a second
//! texture with a map as the morph parameter (Fig. 15, spatially varying).
//!
//! The stage keys on the parameters, not on the sample they came from: an analysis re-runs
//! only when the sample or an analysis option changes, and changing a gain, the seed or the
//! size re-runs this stage alone.

use super::quilt_size;
use crate::graph::{Handle, In, Inputs, RunCx, StageError};
use crate::kinds::{FnStage, Planner};
use crate::lang::{Decl, Diagnostic};
use crate::raster::Image;
use crate::synth::noise::eval::{self, morph_looks, morph_step, Domain, Look, Noise};
use crate::synth::noise::params::Procedural;
use crate::synth::noise::slice::SliceCorrection;
use crate::synth::noise::NoiseError;

/// The properties that only a procedural layer reads.
pub const PROPS: &[&str] = &["zoom", "origin", "band_gain", "solid", "slice", "correct_slice", "morph", "morph_by"];

#[derive(serde::Serialize)]
struct Evaluating {
    params: In<Procedural>,
    morph: Option<(In<Procedural>, In<Image>)>,
    seed: u64,
    size: (usize, usize),
    zoom: f64,
    origin: [f64; 2],
    gains: Vec<f64>,
    solid: bool,
    slice: f64,
    correct_slice: bool,
}

/// Working memory per pixel (the RGB result in f64 rows, then the image).
const BYTES_PER_PIXEL: f64 = 40.0;

pub fn plan(p: &mut Planner, d: &Decl, texture: &str) -> Result<Handle<Image>, Diagnostic> {
    let props = &d.props;
    let (size, size_at) = quilt_size(p, d);
    p.check_pixels(d, size_at, size, BYTES_PER_PIXEL)?;
    let mut inputs = Inputs::new();
    let params = inputs.add(p.result::<Procedural>(texture));
    let morph =
        match (props.reference("morph"), props.reference("morph_by")) {
            (Some(b), Some(map)) => {
                let at = props.span("morph_by").unwrap_or(d.name_span);
                Some((inputs.add(p.result::<Procedural>(b)), inputs.add(p.value::<Image>(map, at)?)))
            }
            (None, None) => None,
            (Some(_), None) => return Err(Diagnostic::error(
                "`morph` needs `morph_by`: the map whose value is the morph parameter (0: this texture, 1: the other)",
            )
            .with_code("tessera::layer")
            .with_label(props.span("morph").unwrap_or(d.name_span), "here")),
            (None, Some(_)) => {
                return Err(Diagnostic::error("`morph_by` needs `morph`: the texture to morph toward")
                    .with_code("tessera::layer")
                    .with_label(props.span("morph_by").unwrap_or(d.name_span), "here"))
            }
        };
    let evaluating = Evaluating {
        params,
        morph,
        seed: p.seed(d, "noise"),
        size,
        zoom: props.num("zoom"),
        origin: props.vec2("origin"),
        gains: props.opt_numbers("band_gain").map(<[f64]>::to_vec).unwrap_or_default(),
        solid: props.bool("solid"),
        slice: props.num("slice"),
        correct_slice: props.bool("correct_slice"),
    };
    for key in ["slice", "correct_slice"] {
        if let (Some(span), false) = (props.span(key), evaluating.solid) {
            return Err(Diagnostic::error(format!("`{key}` applies only to the solid texture"))
                .with_code("tessera::layer")
                .with_label(span, "this needs `solid = true`"));
        }
    }
    let stage = FnStage::keyed("layer.procedural", 4, evaluating, run);
    Ok(p.add(format!("layer {}", d.name), stage, inputs, vec![]))
}

fn run(cx: &RunCx, e: &Evaluating) -> Result<Image, StageError> {
    let params = cx.get(e.params);
    let other = e.morph.map(|(other, map)| (cx.get(other), cx.get(map)));
    // A morph from or to a texture fitted at a larger sample reaches its finer bands.
    let bands = params.channels[0].weights.len().max(other.as_ref().map_or(0, |(o, _)| o.channels[0].weights.len()));
    if e.gains.len() > bands {
        return Err(StageError::new(format!(
            "{} band gains for a texture of {bands} bands (2 to {})",
            e.gains.len(),
            bands + 1
        ))
        .at_prop("band_gain"));
    }
    let noise =
        Noise::new(e.seed, params.tile, bands, params.colour, e.solid).map_err(|e| StageError::new(e.to_string()))?;
    let pixel = 1.0 / (params.sample_size as f64 * e.zoom);
    let (w, h) = e.size;
    // The finest band's lattice is 2^(bands+1) cells per sample width; far out, f64 keeps no
    // fraction of a cell and every pixel would read the same taps.
    let limit = 2f64.powi(40) / 2f64.powi(bands as i32 + 1);
    let reach = |at: f64, extent: usize| at.abs() + extent as f64 * pixel;
    for (prop, r) in [
        ("origin", reach(e.origin[0], w).max(reach(e.origin[1], h))),
        ("slice", if e.solid { e.slice.abs() } else { 0.0 }),
    ] {
        if r.is_nan() || r > limit {
            return Err(StageError::new(format!(
                "{prop} reaches {r:.3e} sample widths: beyond {limit:.3e} the finest band has no precision left (f64 keeps no fraction of its lattice cells)"
            ))
            .at_prop(prop));
        }
    }
    let domain = if e.solid {
        Domain::Slice { origin: [e.origin[0], e.origin[1], e.slice], u: [1.0, 0.0, 0.0], v: [0.0, 1.0, 0.0], pixel }
    } else {
        Domain::Plane { origin: e.origin, pixel }
    };
    // With `correct_slice`, the gains go into the corrected weights (a morph's looks are
    // linear in the weights, so correcting both ends and interpolating keeps the gains).
    let (params, other, gains) = if e.solid && e.correct_slice {
        let at = |e: NoiseError| StageError::new(e.to_string()).at_prop("correct_slice");
        let correction =
            SliceCorrection::new(&noise, bands, [e.origin[0], e.origin[1], e.slice], e.seed).map_err(at)?;
        let params = correction.corrected(&params, &e.gains).map_err(at)?;
        let other = match other {
            Some((o, map)) => Some((std::sync::Arc::new(correction.corrected(&o, &e.gains).map_err(at)?), map)),
            None => None,
        };
        (std::sync::Arc::new(params), other, Vec::new())
    } else {
        (params, other, e.gains.clone())
    };
    let out = match other {
        None => {
            let look = Look::new(&params, &gains);
            eval::render(&noise, w, h, domain, |_, _| &look)
        }
        Some((other, map)) => {
            let looks =
                morph_looks(&params, &other, &gains).map_err(|e| StageError::new(e.to_string()).at_prop("morph"))?;
            // The map is read at the same relative position, whatever its size.
            let (mw, mh) = (map.width.max(1), map.height.max(1));
            let at = |i: usize, j: usize| {
                if map.width == 0 || map.height == 0 {
                    return &looks[0];
                }
                let (x, y) = ((i * mw / w.max(1)).min(mw - 1), (j * mh / h.max(1)).min(mh - 1));
                &looks[morph_step(map.get(x, y, 0))]
            };
            eval::render(&noise, w, h, domain, at)
        }
    };
    out.map_err(|e| StageError::new(e.to_string()))
}

/// A render of a parameter set at its sample's own size and scale (a procedural output).
pub fn render_sample_size(params: &Procedural, seed: u64) -> Result<Image, StageError> {
    let n = params.sample_size;
    let noise = Noise::new(seed, params.tile, params.channels[0].weights.len(), params.colour, false)
        .map_err(|e| StageError::new(e.to_string()))?;
    let look = Look::new(params, &[]);
    eval::render(&noise, n, n, Domain::Plane { origin: [0.0; 2], pixel: 1.0 / n as f64 }, |_, _| &look)
        .map_err(|e| StageError::new(e.to_string()))
}
