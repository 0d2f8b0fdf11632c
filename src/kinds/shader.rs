//! `shader`: a built-in procedural shader of the library [references: bourque §5] rendered as
//! an image, with its parameters written as a call: `pattern = brick(width = 0.2, mortar =
//! 0.01)`. Each shader's parameters are checked by the schema like any property (range,
//! whole numbers, units), and the schema is made from the library's own tables, so the two
//! cannot drift.
//!
//! ```text
//! pattern(…), size, repeat, origin, seed ─► shader.render ─► image
//! ```

use std::sync::LazyLock;

use super::{ColorSpace, FnStage, Planner};
use crate::graph::{AnyHandle, Handle, Inputs, RunCx, StageError};
use crate::lang::ir::Call;
use crate::lang::schema::{CallSpec, Default, Extent, KindSpec, Naming, PropSpec, Range, Ty, Unit, Value};
use crate::lang::{Decl, Diagnostic, Val};
use crate::raster::Image;
use crate::synth::shader::{self as lib, ParamKind, ShaderDef};

/// Working memory per pixel: the planar RGB image and the copy an output encodes.
const BYTES_PER_PIXEL: f64 = 24.0;

/// Leaks a string built once for the process-wide schema.
fn leak(s: String) -> &'static str {
    Box::leak(s.into_boxed_str())
}

/// A number as the language reads it back exactly.
fn number(v: f64) -> String {
    format!("{v:?}")
}

/// The schema of one library shader's call: one argument per parameter.
fn call_spec(def: &'static ShaderDef) -> CallSpec {
    let args = def
        .params
        .iter()
        .map(|p| {
            let (ty, default) = match p.kind {
                ParamKind::Float { min, max } => (Ty::Number(Unit::Plain, Range { min, max }), number(p.default[0])),
                ParamKind::Angle { min, max } => {
                    (Ty::Number(Unit::Angle, Range { min, max }), format!("{} deg", number(p.default[0].to_degrees())))
                }
                ParamKind::Int { min, max } => (Ty::Int(min, max), format!("{}", p.default[0] as i64)),
                ParamKind::Colour => {
                    (Ty::Colour, format!("[{}]", p.default.iter().map(|&c| number(c)).collect::<Vec<_>>().join(", ")))
                }
            };
            let range = match p.kind {
                ParamKind::Float { min, max } => format!("In [{min}, {max}]."),
                ParamKind::Angle { min, max } => format!("In [{}, {}] deg.", min.to_degrees(), max.to_degrees()),
                ParamKind::Int { min, max } => format!("A whole number in [{min}, {max}]."),
                ParamKind::Colour => String::new(),
            };
            let doc = leak(format!("{} {range}", p.doc).trim_end().to_string());
            PropSpec { name: p.name, ty, default: Default::Text(leak(default)), doc }
        })
        .collect::<Vec<_>>();
    CallSpec { name: def.name, doc: def.doc, args: Box::leak(args.into_boxed_slice()) }
}

/// The schema of one library shader's search ranges in a `match`: one optional `[lo, hi]`
/// per parameter, inside the parameter's own range.
fn search_spec(def: &'static ShaderDef) -> CallSpec {
    let args = def
        .params
        .iter()
        .map(|p| {
            let (min, max) = p.kind.bounds();
            let unit = if matches!(p.kind, ParamKind::Angle { .. }) { Unit::Angle } else { Unit::Plain };
            let (range, each) = match p.kind {
                ParamKind::Angle { .. } => (format!("[{}, {}] deg", min.to_degrees(), max.to_degrees()), ""),
                ParamKind::Int { .. } => (format!("[{min}, {max}]"), ", whole numbers"),
                ParamKind::Colour => ("[0, 1]".into(), ", for each channel"),
                ParamKind::Float { .. } => (format!("[{min}, {max}]"), ""),
            };
            let searched = if p.search { "searched over its whole range" } else { "fixed at its default" };
            let doc = leak(format!(
                "{}: `[lo, hi]` inside {range}{each} (`[v, v]` fixes it at v). Left out: {searched}.",
                p.doc.trim_end_matches('.')
            ));
            PropSpec { name: p.name, ty: Ty::Numbers(unit, Range { min, max }), default: Default::Absent, doc }
        })
        .collect::<Vec<_>>();
    CallSpec { name: def.name, doc: def.doc, args: Box::leak(args.into_boxed_slice()) }
}

/// Every library shader's search-range call, for `match`'s `search`.
pub(super) static SEARCH_CALLS: LazyLock<&'static [CallSpec]> =
    LazyLock::new(|| Box::leak(lib::LIBRARY.iter().map(|d| search_spec(d)).collect::<Vec<_>>().into_boxed_slice()));

static CALLS: LazyLock<&'static [CallSpec]> =
    LazyLock::new(|| Box::leak(lib::LIBRARY.iter().map(|d| call_spec(d)).collect::<Vec<_>>().into_boxed_slice()));

pub static SPEC: LazyLock<KindSpec> = LazyLock::new(|| {
    KindSpec {
    name: "shader",
    doc: "A built-in procedural shader (Bourque's library) rendered as an image: a pattern computed at every pixel from a few typed parameters, at any size and resolution, with its edges antialiased. The unit square of texture space is one period of the repeating patterns.",
    naming: Naming::Ident,
    produces: &[Value::Image],
    settings: &[],
    extent: Extent::Prop("size"),
    props: Box::leak(
        vec![
            PropSpec {
                name: "pattern",
                ty: Ty::Source { calls: *CALLS, refs: &[] },
                default: Default::Required,
                doc: "The shader and its parameters, as a call: `brick(width = 0.2)`. Parameters left out take their defaults.",
            },
            PropSpec { name: "size", ty: Ty::Size, default: Default::SceneSize, doc: "Size in pixels." },
            PropSpec {
                name: "repeat",
                ty: Ty::Number(Unit::Plain, Range { min: 1e-3, max: 1e4 }),
                default: Default::Text("1"),
                doc: "Texture units across the image's width (the height follows with square pixels): 1 shows the unit square once across, 4 shows four periods.",
            },
            PropSpec {
                name: "origin",
                ty: Ty::Vec2(Unit::Plain),
                default: Default::Text("[0, 0]"),
                doc: "Texture coordinates of the image's top-left corner (any window of the infinite texture).",
            },
        ]
        .into_boxed_slice(),
    ),
}
});

/// What a render stage reads: the shader (with its version, so a change to its code is a new
/// key), the checked parameter vector, the seed, the size and the texture region.
#[derive(serde::Serialize)]
struct Render {
    shader: &'static str,
    version: u32,
    values: Vec<f64>,
    seed: u64,
    size: (usize, usize),
    region: [f64; 4],
}

/// The flat parameter vector of a checked call (the schema has checked ranges, whole numbers
/// and colours).
pub fn values(def: &ShaderDef, call: &Call) -> Vec<f64> {
    let mut values = Vec::with_capacity(lib::params::flat_len(def.params));
    for p in def.params {
        match p.kind {
            ParamKind::Colour => values.extend_from_slice(call.args.numbers(p.name)),
            ParamKind::Int { .. } => values.push(call.args.int(p.name) as f64),
            _ => values.push(call.args.num(p.name)),
        }
    }
    values
}

pub fn plan(p: &mut Planner, d: &Decl) -> Result<Handle<Image>, Diagnostic> {
    let (w, h) = d.props.size("size");
    let (w, h) = (w as usize, h as usize);
    p.check_pixels(d, d.props.span("size"), (w, h), BYTES_PER_PIXEL)?;
    let Some(Val::Call(call)) = d.props.get("pattern") else { unreachable!("the schema admits only calls") };
    let def = lib::shader(&call.name).expect("the schema admits only library shaders");
    let values = values(def, call);
    let repeat = d.props.num("repeat");
    let [u0, v0] = d.props.vec2("origin");
    let region = [u0, v0, u0 + repeat, v0 + repeat * h as f64 / w as f64];
    let render =
        Render { shader: def.name, version: def.version, values, seed: p.seed(d, "shader"), size: (w, h), region };
    let stage = FnStage::keyed("shader.render", 1, render, run);
    Ok(p.add(format!("shader {}", d.name), stage, Inputs::new(), vec![]))
}

fn run(_: &RunCx, r: &Render) -> Result<Image, StageError> {
    let def = lib::shader(r.shader).expect("planned from the library");
    lib::render(def, &r.values, r.seed, r.size.0, r.size.1, r.region).map_err(|e| {
        let prop = if matches!(e, lib::ShaderError::Region(_)) { "origin" } else { "pattern" };
        StageError::new(e.to_string()).at_prop(prop)
    })
}

/// The shader kind.
pub struct ShaderKind;

impl super::Kind for ShaderKind {
    fn spec(&self) -> &'static KindSpec {
        &SPEC
    }

    fn plan(&self, p: &mut Planner, d: &Decl) -> Result<Option<AnyHandle>, Diagnostic> {
        let node = plan(p, d)?.erase();
        // Shaders compute display colours, as the thesis's renderers wrote them.
        p.export(d).image = Some(ColorSpace::Srgb);
        Ok(Some(node))
    }
}
