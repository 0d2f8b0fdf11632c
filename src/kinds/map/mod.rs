//! `map`: scalar maps (density, occupancy, size, masks) and orientation fields, from an
//! image or procedural, then operated on.
//!
//! Two stages: `map.source` makes the field, `map.ops` applies blur → threshold → invert →
//! remap. Editing an operation re-runs only the second.

use super::{FnStage, Planner};
use crate::graph::{AnyHandle, Handle, In, Inputs, RunCx, StageError};
use crate::lang::ir::Call;
use crate::lang::schema::{
    CallSpec, Default, Extent, KindSpec, Naming, PropSpec, Range, Ty, Unit, Value, ANY, NON_NEG, POSITIVE, UNIT,
};
use crate::lang::{Decl, Diagnostic, Val};
use crate::raster::{self, Image};
use crate::synth::map as m;
use crate::synth::structure::regionmaps::{region_map, RegionField};

use super::structure::codecs::Shaped;

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
                Ty::Enum(CHANNELS.names),
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
                Ty::Enum(FIELDS.names),
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
            arg("kind", Ty::Enum(NOISE_KINDS.names), Default::Text("gradient"), "Value (lattice) or gradient (Perlin) noise."),
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
            arg("a", Ty::Ref(&[Value::Map]), Default::Required, "First map."),
            arg("b", Ty::Ref(&[Value::Map]), Default::Required, "Second map."),
            arg(
                "op",
                Ty::Enum(OPS.names),
                Default::Text("multiply"),
                "How to combine; `mix` blends by `t`.",
            ),
            arg("t", Ty::Number(Unit::Fraction, UNIT), Default::Text("0.5"), "Weight of `b` for `mix`."),
        ],
    },
    CallSpec {
        name: "regions",
        doc: "A map that follows the regions of a structure: the maps artists build with flood fills, as guides, masks or blend weights.",
        args: &[
            arg("of", Ty::Ref(&[Value::Structure]), Default::Required, "The structure whose regions the map follows."),
            arg(
                "field",
                Ty::Enum(REGION_FIELDS.names),
                Default::Text("random"),
                "`id`: (i + 1)/n per region; `random`: a seeded value in [0, 1) per region; `u`, `v`: 0 to 1 along the region's major / minor axis; `edge`: distance to the region's edge, 1 at its deepest pixel; `edge_px`: the same in pixels; `axis`: orientation field of the major axis. 0 outside every region.",
            ),
            arg("seed", Ty::Int(0, 1 << 53), Default::Absent, "An explicit seed for `random` instead of the derived one."),
        ],
    },
];

crate::choices!(REGION_FIELDS: RegionField {
    "id" => RegionField::Id, "random" => RegionField::Random, "u" => RegionField::U, "v" => RegionField::V,
    "edge" => RegionField::Edge, "edge_px" => RegionField::EdgePixels, "axis" => RegionField::Axis
});

/// `channel` of `image(...)`: which channel becomes the map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Channel {
    Luminance,
    Index(usize),
    Vector,
}

/// `field` of `radial(...)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum RadialField {
    Distance,
    Radial,
    Tangential,
}

/// `op` of `combine(...)` (`mix` takes its weight from `t`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Op {
    Multiply,
    Add,
    Subtract,
    Min,
    Max,
    Mix,
    Screen,
}

crate::choices!(CHANNELS: Channel {
    "luminance" => Channel::Luminance, "r" => Channel::Index(0), "g" => Channel::Index(1), "b" => Channel::Index(2),
    "a" => Channel::Index(3), "vector" => Channel::Vector
});
crate::choices!(FIELDS: RadialField { "distance" => RadialField::Distance, "radial" => RadialField::Radial, "tangential" => RadialField::Tangential });
crate::choices!(NOISE_KINDS: m::NoiseKind { "value" => m::NoiseKind::Value, "gradient" => m::NoiseKind::Gradient });
crate::choices!(OPS: Op {
    "multiply" => Op::Multiply, "add" => Op::Add, "subtract" => Op::Subtract, "min" => Op::Min, "max" => Op::Max,
    "mix" => Op::Mix, "screen" => Op::Screen
});

pub static SPEC: KindSpec = KindSpec {
    name: "map",
    doc: "A scalar map (density, occupancy, size, mask) or a 2-channel orientation field. Operations apply in the order blur, threshold, invert, remap.",
    naming: Naming::Ident,
    produces: &[Value::Map],
    settings: &[],
    extent: Extent::Prop("size"),
    props: &[
        PropSpec {
            name: "from",
            ty: Ty::Source { calls: SOURCES, refs: &[Value::Map] },
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

pub fn plan(p: &mut Planner, d: &Decl) -> Result<Handle<Image>, Diagnostic> {
    let (w, h) = d.props.size("size");
    let (w, h) = (w as usize, h as usize);
    p.check_pixels(d, d.props.span("size"), (w, h), MAP_BYTES_PER_PIXEL)?;
    let source = match d.props.get("from").expect("required") {
        Val::Ref(other) => {
            // Another map: resampled to this map's size if needed, by the ops stage.
            p.result(other)
        }
        Val::Call(call) => plan_source(p, d, call, w, h),
        v => unreachable!("checked source {v:?}"),
    };
    let mut inputs = Inputs::new();
    let ops = Ops {
        source: inputs.add(source),
        w,
        h,
        blur: d.props.num("blur") as f32,
        threshold: d.props.opt_num("threshold").map(|t| t as f32),
        invert: d.props.bool("invert"),
        remap: d.props.opt_numbers("remap").map(|r| [r[0] as f32, r[1] as f32]),
    };
    let is_ref = matches!(d.props.get("from"), Some(Val::Ref(_)));
    if !is_ref && ops.blur == 0.0 && ops.threshold.is_none() && !ops.invert && ops.remap.is_none() {
        return Ok(source);
    }
    let stage = FnStage::keyed("map.ops", 2, ops, apply_ops);
    Ok(p.add(format!("map {} (ops)", d.name), stage, inputs, vec![]))
}

/// What the ops stage works from: the source map, the size to fit it to, and the ops in
/// the order they apply.
#[derive(serde::Serialize)]
struct Ops {
    source: In<Image>,
    w: usize,
    h: usize,
    blur: f32,
    threshold: Option<f32>,
    invert: bool,
    remap: Option<[f32; 2]>,
}

fn apply_ops(cx: &RunCx, o: &Ops) -> Result<Image, StageError> {
    let mut img = fit(&cx.get(o.source), o.w, o.h);
    if o.blur > 0.0 {
        img = m::blur(&img, o.blur).map_err(|e| StageError::new(e.to_string()).at_prop("blur"))?;
    }
    if let Some(t) = o.threshold {
        img = m::threshold(&img, t);
    }
    if o.invert {
        img = m::invert(&img);
    }
    if let Some(r) = o.remap {
        img = m::remap(&img, [0.0, 1.0], r).map_err(|e| StageError::new(e.to_string()).at_prop("remap"))?;
    }
    Ok(img)
}

/// What a map source stage works from: the constructor call, the map's size and seed, and
/// the maps `combine` reads.
#[derive(serde::Serialize)]
struct Source {
    call: Call,
    w: usize,
    h: usize,
    seed: u64,
    operands: Option<[In<Image>; 2]>,
    /// `regions(...)`: the structure's final mesh and the size of its surface (absent from
    /// the key of other sources, so their cache entries stay valid).
    #[serde(skip_serializing_if = "Option::is_none")]
    regions: Option<(In<Shaped>, [f64; 2])>,
}

fn plan_source(p: &mut Planner, d: &Decl, call: &Call, w: usize, h: usize) -> Handle<Image> {
    let a = &call.args;
    let mut inputs = Inputs::new();
    let mut files = Vec::new();
    let seed = match a.get("seed") {
        Some(Val::Int(s)) => *s as u64,
        _ if call.name == "regions" => p.seed(d, "map.regions"),
        _ => p.seed(d, "map.noise"),
    };
    let mut operands = None;
    let mut regions = None;
    match call.name.as_str() {
        "image" => files.push((a.path("path").expect("required").clone(), a.span("path").unwrap_or(d.name_span))),
        "combine" => operands = Some([inputs.add(p.result(a.str("a"))), inputs.add(p.result(a.str("b")))]),
        "regions" => {
            let structure = a.str("of");
            let mesh = p.part(structure, "mesh").expect("structures plan a mesh stage");
            let ((sw, sh), _) = p.plane(p.decl(structure).props.reference("on").expect("required"));
            regions = Some((inputs.add(mesh), [sw as f64, sh as f64]));
        }
        _ => {}
    }
    let source = Source { call: call.clone(), w, h, seed, operands, regions };
    let stage = FnStage::keyed("map.source", 2, source, |cx, s| {
        evaluate(s, cx).map_err(|e| match e.prop {
            // Parameter errors from the algorithms name a `from(...)` argument.
            None if e.file.is_none() => e.at_prop("from"),
            _ => e,
        })
    });
    p.add(format!("map {}", d.name), stage, inputs, files)
}

fn evaluate(s: &Source, cx: &RunCx) -> Result<Image, StageError> {
    let (call, w, h, seed) = (&s.call, s.w, s.h, s.seed);
    let a = &call.args;
    let f32s = |v: [f64; 2]| [v[0] as f32, v[1] as f32];
    let center =
        || a.opt_numbers("center").map(|c| [c[0] as f32, c[1] as f32]).unwrap_or([w as f32 / 2.0, h as f32 / 2.0]);
    let map_err = |e: m::MapError| StageError::new(e.to_string());
    match call.name.as_str() {
        "image" => {
            let bytes = cx.file(0)?;
            let img = super::decode_image(&bytes, cx.budget())
                .map_err(|e| StageError::new(format!("cannot decode the image: {e}")).in_file(0))?;
            let field = match CHANNELS.get(a.enumeration("channel")) {
                Channel::Vector => m::from_image_vector(&img),
                Channel::Luminance => m::from_image_scalar(&img, m::ChannelSel::Luminance),
                Channel::Index(i) => m::from_image_scalar(&img, m::ChannelSel::Index(i)),
            }
            .map_err(|e| StageError::new(e.to_string()).in_file(0))?;
            Ok(fit(&field, w, h))
        }
        "constant" => m::constant(w, h, a.num("value") as f32).map_err(map_err),
        "linear" => m::linear(w, h, f32s(a.vec2("from")), f32s(a.vec2("to"))).map_err(map_err),
        "radial" => {
            let radius = a.opt_num("radius").map(|r| r as f32).unwrap_or(w.min(h) as f32 / 2.0);
            match FIELDS.get(a.enumeration("field")) {
                RadialField::Radial => m::radial_orientation(w, h, center(), m::RadialMode::Radial),
                RadialField::Tangential => m::radial_orientation(w, h, center(), m::RadialMode::Tangential),
                RadialField::Distance => m::radial(w, h, center(), radius),
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
            let kind = NOISE_KINDS.get(a.enumeration("kind"));
            let mut params =
                m::NoiseParams::new(kind, a.num("scale") as f32, a.int("octaves") as u32, a.num("persistence") as f32);
            params.tileable = a.bool("tileable");
            m::noise(w, h, seed, &params).map_err(map_err)
        }
        "combine" => {
            let [x, y] = s.operands.expect("`combine` reads two maps").map(|i| fit(&cx.get(i), w, h));
            let op = match OPS.get(a.enumeration("op")) {
                Op::Multiply => m::CombineOp::Multiply,
                Op::Add => m::CombineOp::Add,
                Op::Subtract => m::CombineOp::Subtract,
                Op::Min => m::CombineOp::Min,
                Op::Max => m::CombineOp::Max,
                Op::Mix => m::CombineOp::Mix(a.num("t") as f32),
                Op::Screen => m::CombineOp::Screen,
            };
            m::combine(&x, &y, op).map_err(map_err)
        }
        "regions" => {
            let (mesh, domain) = s.regions.expect("`regions` reads a structure");
            let field = REGION_FIELDS.get(a.enumeration("field"));
            Ok(region_map(&cx.get(mesh).mesh, domain, w, h, field, seed))
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

/// The map kind: density, orientation, occupancy and size maps.
pub struct Map;

impl super::Kind for Map {
    fn spec(&self) -> &'static crate::lang::KindSpec {
        &SPEC
    }

    fn plan(&self, p: &mut Planner, d: &Decl) -> Result<Option<AnyHandle>, Diagnostic> {
        plan(p, d).map(|h| Some(h.erase()))
    }
}
