//! `map`: scalar maps (density, occupancy, size, masks) and orientation fields, from an
//! image or procedural, then operated on.
//!
//! Two stages: `map.source` makes the field, `map.ops` applies blur → threshold → invert →
//! remap. Editing an operation re-runs only the second.

use std::sync::Arc;

use super::{FnStage, Planner};
use crate::graph::{NodeId, RunCx, StageError};
use crate::lang::ir::Call;
use crate::lang::schema::{
    CallSpec, Default, KindSpec, Naming, PropSpec, Range, Ty, Unit, ANY, NON_NEG, POSITIVE, UNIT,
};
use crate::lang::{Decl, Diagnostic, Val};
use crate::raster::{self, Image};
use crate::synth::map as m;

const fn arg(name: &'static str, ty: Ty, default: Default, doc: &'static str) -> PropSpec {
    PropSpec { name, ty, default, doc }
}

static SOURCES: &[CallSpec] = &[
    CallSpec {
        name: "image",
        doc: "A map read from a PNG or EXR file; values are taken as data (no sRGB decoding) and resampled bilinearly to the map's size.",
        args: &[
            arg("path", Ty::Path, Default::Required, "The image file, relative to this scene file."),
            arg(
                "channel",
                Ty::Enum(&["luminance", "r", "g", "b", "a", "vector"]),
                Default::Text("luminance"),
                "Which channel makes the scalar map; `vector` reads R and G as an orientation field ([0,1] → [-1,1]).",
            ),
        ],
    },
    CallSpec {
        name: "constant",
        doc: "The same value everywhere.",
        args: &[arg("value", Ty::Number(Unit::Plain, ANY), Default::Required, "The value.")],
    },
    CallSpec {
        name: "linear",
        doc: "A linear ramp: 0 at `from`, 1 at `to`, clamped beyond.",
        args: &[
            arg("from", Ty::Vec2(Unit::Length), Default::Required, "Where the ramp is 0, in pixels."),
            arg("to", Ty::Vec2(Unit::Length), Default::Required, "Where the ramp is 1, in pixels."),
        ],
    },
    CallSpec {
        name: "radial",
        doc: "Distance from a centre (scalar, 0 at the centre and 1 at `radius`), or a radial / tangential orientation field.",
        args: &[
            arg("center", Ty::Vec2(Unit::Length), Default::Absent, "Centre in pixels; default the middle of the map."),
            arg("radius", Ty::Number(Unit::Length, POSITIVE), Default::Absent, "Radius in pixels; default half the shorter side."),
            arg(
                "field",
                Ty::Enum(&["distance", "radial", "tangential"]),
                Default::Text("distance"),
                "`distance`: scalar map; `radial`: unit vectors pointing away from the centre; `tangential`: perpendicular to them (counter-clockwise on screen).",
            ),
        ],
    },
    CallSpec {
        name: "direction",
        doc: "A constant orientation field.",
        args: &[arg("angle", Ty::Number(Unit::Angle, ANY), Default::Required, "Angle from +x towards +y (down).")],
    },
    CallSpec {
        name: "rect",
        doc: "An anti-aliased rectangle mask: 1 inside, 0 outside.",
        args: &[
            arg("at", Ty::Vec2(Unit::Length), Default::Required, "Top-left corner in pixels."),
            arg("size", Ty::Vec2(Unit::Length), Default::Required, "Width and height in pixels."),
        ],
    },
    CallSpec {
        name: "ellipse",
        doc: "An anti-aliased ellipse mask.",
        args: &[
            arg("center", Ty::Vec2(Unit::Length), Default::Required, "Centre in pixels."),
            arg("radii", Ty::Vec2(Unit::Length), Default::Required, "Semi-axes in pixels."),
            arg("angle", Ty::Number(Unit::Angle, ANY), Default::Text("0 deg"), "Rotation of the first axis."),
        ],
    },
    CallSpec {
        name: "polygon",
        doc: "An anti-aliased polygon mask (even-odd fill).",
        args: &[arg("points", Ty::Points, Default::Required, "At least three vertices `[[x, y], ...]` in pixels.")],
    },
    CallSpec {
        name: "noise",
        doc: "Seeded fractal noise in [0, 1]. The seed derives from the scene seed and the map's name unless given.",
        args: &[
            arg("kind", Ty::Enum(&["value", "gradient"]), Default::Text("gradient"), "Value (lattice) or gradient (Perlin) noise."),
            arg("scale", Ty::Number(Unit::Length, POSITIVE), Default::Text("32 px"), "Size of the coarsest octave's cells."),
            arg("octaves", Ty::Int(1, 16), Default::Text("4"), "Number of octaves, each twice as fine."),
            arg("persistence", Ty::Number(Unit::Plain, Range { min: 0.01, max: 16.0 }), Default::Text("0.5"), "Amplitude ratio between octaves."),
            arg("tileable", Ty::Bool, Default::Text("false"), "Periodic with the map size."),
            arg("seed", Ty::Int(0, 1 << 53), Default::Absent, "An explicit seed instead of the derived one."),
        ],
    },
    CallSpec {
        name: "combine",
        doc: "Combines two maps pixel by pixel.",
        args: &[
            arg("a", Ty::Ref(&["map"]), Default::Required, "First map."),
            arg("b", Ty::Ref(&["map"]), Default::Required, "Second map."),
            arg(
                "op",
                Ty::Enum(&["multiply", "add", "subtract", "min", "max", "mix", "screen"]),
                Default::Text("multiply"),
                "How to combine; `mix` blends by `t`.",
            ),
            arg("t", Ty::Number(Unit::Fraction, UNIT), Default::Text("0.5"), "Weight of `b` for `mix`."),
        ],
    },
];

pub static SPEC: KindSpec = KindSpec {
    name: "map",
    doc: "A scalar map (density, occupancy, size, mask) or a 2-channel orientation field. Operations apply in the order blur, threshold, invert, remap.",
    naming: Naming::Ident,
    props: &[
        PropSpec {
            name: "from",
            ty: Ty::Source { calls: SOURCES, refs: &["map"] },
            default: Default::Required,
            doc: "Where the values come from: a constructor or another map.",
        },
        PropSpec { name: "size", ty: Ty::Size, default: Default::SceneSize, doc: "Size in pixels." },
        PropSpec {
            name: "blur",
            ty: Ty::Number(Unit::Length, NON_NEG),
            default: Default::Text("0 px"),
            doc: "Gaussian blur, standard deviation in pixels (vectors are renormalised).",
        },
        PropSpec {
            name: "threshold",
            ty: Ty::Number(Unit::Plain, ANY),
            default: Default::Absent,
            doc: "Values at or above become 1, below 0.",
        },
        PropSpec { name: "invert", ty: Ty::Bool, default: Default::Text("false"), doc: "1 − v (vectors are negated)." },
        PropSpec {
            name: "remap",
            ty: Ty::Vec2(Unit::Plain),
            default: Default::Absent,
            doc: "`[lo, hi]`: maps [0, 1] linearly onto [lo, hi].",
        },
    ],
};

/// Working memory of a map per pixel: an orientation field's two f32 channels, held by the
/// source and the ops stage, and the resampling or blur scratch beside them (measured: a
/// blurred 2048² noise map peaks at ≈ 21 bytes per pixel).
const MAP_BYTES_PER_PIXEL: f64 = 24.0;

pub fn plan(p: &mut Planner, d: &Decl) -> Result<NodeId, Diagnostic> {
    let (w, h) = d.props.size("size");
    let (w, h) = (w as usize, h as usize);
    p.check_pixels(d, d, "size", (w, h), MAP_BYTES_PER_PIXEL)?;
    let source = match d.props.get("from").expect("required") {
        Val::Ref(other) => {
            // Another map: resampled to this map's size if needed, by the ops stage.
            p.result(other)
        }
        Val::Call(call) => plan_source(p, d, call, w, h),
        v => unreachable!("checked source {v:?}"),
    };
    let blur = d.props.num("blur") as f32;
    let threshold = d.props.opt_num("threshold").map(|t| t as f32);
    let invert = d.props.bool("invert");
    let remap = d.props.opt_numbers("remap").map(|r| [r[0] as f32, r[1] as f32]);
    let is_ref = matches!(d.props.get("from"), Some(Val::Ref(_)));
    if !is_ref && blur == 0.0 && threshold.is_none() && !invert && remap.is_none() {
        return Ok(source);
    }
    let params =
        serde_json::json!({ "w": w, "h": h, "blur": blur, "threshold": threshold, "invert": invert, "remap": remap })
            .to_string();
    let stage = FnStage::new("map.ops", 1, params, move |cx| {
        let mut img = fit(&cx.input::<Image>(0), w, h);
        if blur > 0.0 {
            img = m::blur(&img, blur).map_err(|e| StageError::new(e.to_string()).at_prop("blur"))?;
        }
        if let Some(t) = threshold {
            img = m::threshold(&img, t);
        }
        if invert {
            img = m::invert(&img);
        }
        if let Some(r) = remap {
            img = m::remap(&img, [0.0, 1.0], r).map_err(|e| StageError::new(e.to_string()).at_prop("remap"))?;
        }
        Ok(img)
    });
    Ok(p.add(format!("map {} (ops)", d.name), stage, vec![source], vec![]))
}

fn plan_source(p: &mut Planner, d: &Decl, call: &Call, w: usize, h: usize) -> NodeId {
    let a = &call.args;
    let mut inputs = Vec::new();
    let mut files = Vec::new();
    let seed = match a.get("seed") {
        Some(Val::Int(s)) => *s as u64,
        _ => p.seed(d, "map.noise"),
    };
    match call.name.as_str() {
        "image" => files.push((a.path("path").expect("required").clone(), a.span("path").unwrap_or(d.name_span))),
        "combine" => {
            inputs.push(p.result(a.str("a")));
            inputs.push(p.result(a.str("b")));
        }
        _ => {}
    }
    let params = serde_json::json!({ "call": call, "w": w, "h": h, "seed": seed }).to_string();
    let call = Arc::new(call.clone());
    let budget = p.budget;
    let stage = FnStage::new("map.source", 1, params, move |cx| {
        evaluate(&call, w, h, seed, budget, cx).map_err(|e| match e.prop {
            // Parameter errors from the algorithms name a `from(...)` argument.
            None if e.file.is_none() => e.at_prop("from"),
            _ => e,
        })
    });
    p.add(format!("map {}", d.name), stage, inputs, files)
}

fn evaluate(
    call: &Call,
    w: usize,
    h: usize,
    seed: u64,
    budget: crate::graph::Budget,
    cx: &RunCx,
) -> Result<Image, StageError> {
    let a = &call.args;
    let f32s = |v: [f64; 2]| [v[0] as f32, v[1] as f32];
    let center =
        || a.opt_numbers("center").map(|c| [c[0] as f32, c[1] as f32]).unwrap_or([w as f32 / 2.0, h as f32 / 2.0]);
    let map_err = |e: m::MapError| StageError::new(e.to_string());
    match call.name.as_str() {
        "image" => {
            let bytes = cx.file(0)?;
            let img = super::decode_image(&bytes, budget)
                .map_err(|e| StageError::new(format!("cannot decode the image: {e}")).in_file(0))?;
            let field = match a.enumeration("channel") {
                "vector" => m::from_image_vector(&img),
                "luminance" => m::from_image_scalar(&img, m::ChannelSel::Luminance),
                ch => {
                    let i = ["r", "g", "b", "a"].iter().position(|c| c == &ch).unwrap_or(0);
                    m::from_image_scalar(&img, m::ChannelSel::Index(i))
                }
            }
            .map_err(|e| StageError::new(e.to_string()).in_file(0))?;
            Ok(fit(&field, w, h))
        }
        "constant" => m::constant(w, h, a.num("value") as f32).map_err(map_err),
        "linear" => m::linear(w, h, f32s(a.vec2("from")), f32s(a.vec2("to"))).map_err(map_err),
        "radial" => {
            let radius = a.opt_num("radius").map(|r| r as f32).unwrap_or(w.min(h) as f32 / 2.0);
            match a.enumeration("field") {
                "radial" => m::radial_orientation(w, h, center(), m::RadialMode::Radial),
                "tangential" => m::radial_orientation(w, h, center(), m::RadialMode::Tangential),
                _ => m::radial(w, h, center(), radius),
            }
            .map_err(map_err)
        }
        "direction" => m::linear_orientation(w, h, a.num("angle") as f32).map_err(map_err),
        "rect" => m::rect(w, h, f32s(a.vec2("at")), f32s(a.vec2("size"))).map_err(map_err),
        "ellipse" => {
            m::ellipse(w, h, f32s(a.vec2("center")), f32s(a.vec2("radii")), a.num("angle") as f32).map_err(map_err)
        }
        "polygon" => {
            let pts: Vec<[f32; 2]> = a.points("points").iter().map(|p| f32s(*p)).collect();
            m::polygon(w, h, &pts).map_err(map_err)
        }
        "noise" => {
            let kind = if a.enumeration("kind") == "value" { m::NoiseKind::Value } else { m::NoiseKind::Gradient };
            let mut params =
                m::NoiseParams::new(kind, a.num("scale") as f32, a.int("octaves") as u32, a.num("persistence") as f32);
            params.tileable = a.bool("tileable");
            m::noise(w, h, seed, &params).map_err(map_err)
        }
        "combine" => {
            let (x, y) = (fit(&cx.input::<Image>(0), w, h), fit(&cx.input::<Image>(1), w, h));
            let op = match a.enumeration("op") {
                "add" => m::CombineOp::Add,
                "subtract" => m::CombineOp::Subtract,
                "min" => m::CombineOp::Min,
                "max" => m::CombineOp::Max,
                "mix" => m::CombineOp::Mix(a.num("t") as f32),
                "screen" => m::CombineOp::Screen,
                _ => m::CombineOp::Multiply,
            };
            m::combine(&x, &y, op).map_err(map_err)
        }
        other => unreachable!("constructor `{other}` is in the schema but not evaluated"),
    }
}

/// The map at the requested size: itself when it fits, else resampled bilinearly.
pub(crate) fn fit(img: &Image, w: usize, h: usize) -> Image {
    if img.width == w && img.height == h {
        img.clone()
    } else {
        raster::resample::resize(img, w, h, raster::resample::Filter::Bilinear)
    }
}
