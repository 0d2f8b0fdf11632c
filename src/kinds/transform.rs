//! `transform`: a smooth sequence of frames from one texture to the next
//! [references: bourque §ch5], each key a `shader` declaration or a `match`. Written as a
//! record of its frames (`.toml`), a strip of the frames (`.png`) or one file per frame (an
//! output name holding `#`s: `walk/frame_###.png`).
//!
//! ```text
//! catalogues (shared with matches) ─┐                  ┌─► record
//! matches among the keys ───────────┴─► transform.path ─┼─► transform.frame × frames ─► strip, frame files
//!                                                        └─► strip (no `frames`: the whole path)
//! ```
//!
//! With `frames` set, each frame is one stage that the strip and the frame files share, so a
//! scene writing both renders a frame once.
//!
//! A match's shader is known only once it has run, so the path stage reads the catalogues of
//! every shader a key can turn out to be (a shader key's own, a match's candidates, the `via`
//! shaders) and computes the jump points between the shaders the keys turn out to use.

use serde::{Deserialize, Serialize};
use std::sync::Arc;

use super::matching::{arguments, metric, plan_catalogue, round, shader_list, Matched, ShaderCatalogue, METRICS};
use super::{Bytes, Encoded, FnStage, OutputFormat, Planner};
use crate::graph::{AnyHandle, Handle, In, Inputs, RunCx, StageError};
use crate::lang::schema::{Default, Extent, KindSpec, Naming, PropSpec, Range, Ty, Unit, Value};
use crate::lang::{Decl, Diagnostic, Val};
use crate::raster::Image;
use crate::synth::matching::transform::resample;
use crate::synth::matching::{
    jump_points, transform, Candidate, CatalogueConfig, JumpConfig, JumpSet, Key, Link, Metric, Probe, Space,
    TransformConfig, Transformation,
};
use crate::synth::shader::{self as lib, ShaderDef};

const fn prop(name: &'static str, ty: Ty, default: Default, doc: &'static str) -> PropSpec {
    PropSpec { name, ty, default, doc }
}

const UNIT_RANGE: Range = Range { min: 0.0, max: 1.0 };

pub static SPEC: KindSpec = KindSpec {
    name: "transform",
    doc: "A smooth transformation through key textures (Bourque 2005, ch. 5): from each key to the next, the path of least p-norm cost over the shaders' catalogue graphs (renders as vertices, `1 − S'` as edge lengths), switching shaders at jump points (pairs of renders of two shaders that look alike), then halved in parameter space until neighbouring frames of one shader are as alike as `tau`. Written as a record of the frames (`.toml`), a strip of the frames (`.png`) or one image per frame: an output whose name holds a run of `#` (`walk/frame_###.png`) writes `frames` files numbered from 0.",
    naming: Naming::Ident,
    produces: &[Value::Transform],
    settings: &[],
    extent: Extent::None,
    props: &[
        prop("keys", Ty::Refs(&[Value::Image, Value::Match]), Default::Required, "The key textures in order, at least two: `shader` declarations (their parameters exactly) or `match`es (the shader and parameters they found). The first frame is the first key and the last frame the last; each key appears once, in order."),
        prop("via", Ty::Str, Default::Absent, "Connective shaders the path may pass through besides the keys' own, by name (`\"superellipse\"`): a shader that can look like both ends links two that have no good jump (a rectangle to a circle through a super-ellipse)."),
        prop("exponent", Ty::Number(Unit::Plain, Range { min: 1.0, max: 64.0 }), Default::Text("3"), "n of the path cost (Σ eⁿ)^(1/n): 1 takes the fewest, largest steps; larger values take more, smaller ones."),
        prop("tau", Ty::Number(Unit::Plain, UNIT_RANGE), Default::Text("0.95"), "Calibrated similarity neighbouring frames of one shader should reach: midpoints are inserted until they do (or `depth` runs out; the record lists the gaps that stayed below)."),
        prop("depth", Ty::Int(0, 16), Default::Text("10"), "Halvings of one path edge at most."),
        prop("jump", Ty::Number(Unit::Plain, UNIT_RANGE), Default::Text("0.8"), "Calibrated similarity a jump point needs to be used: lower jumps look like cuts. Shaders without a jump this good are not linked (and a key that cannot be reached is an error)."),
        prop("presence", Ty::Number(Unit::Plain, UNIT_RANGE), Default::Text("0.25"), "Jump points must show something: renders whose spectral energy is below this fraction of their catalogue's median are not jump points (two flat images are identical, so without this most jumps pass through nothing). 0 allows plain-background jumps."),
        prop("coherence", Ty::Number(Unit::Plain, UNIT_RANGE), Default::Absent, "Also halve neighbouring frames while their pixels differ by more than this (root mean square luminance over a 32² thumbnail): stars and bricks move less from frame to frame (the thesis's spatially selective term)."),
        prop("frames", Ty::Int(2, 1000), Default::Absent, "Frames of the sequence, evenly spaced in perceptual time (the nearest frame of the path to each); absent, every frame of the path. Outputs of one file per frame need it."),
        prop("size", Ty::Int(16, 2048), Default::Text("128"), "Pixels across each frame of the strip and of frame files (the unit square of texture space)."),
        prop("metric", Ty::Enum(METRICS.names), Default::Text("power"), "How renders are compared, as for `match`."),
        prop("side", Ty::Int(16, 256), Default::Text("128"), "Pixels across the renders compared, as for `match`; catalogues are shared with matches of the same side, metric and size."),
        prop("catalogue", Ty::Int(8, 2000), Default::Text("160"), "Renders kept in each shader's catalogue, as for `match`."),
    ],
};

/// A key as the path stage reads it.
#[derive(Serialize)]
enum KeyInput {
    Shader { shader: &'static str, values: Vec<f64> },
    Match(In<Matched>),
}

#[derive(Serialize)]
struct PathKey {
    keys: Vec<KeyInput>,
    catalogues: Vec<(&'static str, In<ShaderCatalogue>)>,
    via: Vec<&'static str>,
    side: usize,
    metric: Metric,
    seed: u64,
    config: TransformConfig,
    jumps: JumpConfig,
    min_jump: f64,
}

/// A transformation with what its frames need to be rendered.
#[derive(Serialize, Deserialize)]
pub struct Transformed {
    pub shaders: Vec<String>,
    pub record: Transformation,
    /// Jump points between pairs of `shaders`, with the pair.
    pub jumps: Vec<(usize, usize, JumpSet)>,
    pub seed: u64,
}

impl Encoded for Transformed {
    fn encode(&self) -> Vec<u8> {
        serde_json::to_vec(self).expect("a transformation serialises")
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        serde_json::from_slice(bytes).map_err(|e| e.to_string())
    }
}

fn run_path(cx: &RunCx, k: &PathKey) -> Result<Transformed, StageError> {
    // The keys' shaders, then the connective ones.
    let mut keys: Vec<(&'static ShaderDef, Vec<f64>)> = Vec::new();
    for key in &k.keys {
        keys.push(match key {
            KeyInput::Shader { shader, values } => (lib::shader(shader).expect("library"), values.clone()),
            KeyInput::Match(h) => {
                let m = cx.get(*h);
                (lib::shader(&m.record.shader).expect("a match names a library shader"), m.record.values.clone())
            }
        });
    }
    let mut set: Vec<&'static ShaderDef> = Vec::new();
    for def in keys.iter().map(|(d, _)| *d).chain(k.via.iter().map(|n| lib::shader(n).expect("library"))) {
        if !set.iter().any(|d| d.name == def.name) {
            set.push(def);
        }
    }
    let spaces: Vec<Space> = set.iter().map(|d| Space::new(d)).collect();
    let catalogues: Vec<_> = set
        .iter()
        .map(|d| cx.get(k.catalogues.iter().find(|(n, _)| *n == d.name).expect("every possible shader's catalogue").1))
        .collect();
    let cands: Vec<Candidate> = spaces
        .iter()
        .zip(&catalogues)
        .map(|(space, c)| Candidate {
            probe: Probe { space, seed: k.seed, side: k.side, metric: k.metric },
            catalogue: &c.0,
        })
        .collect();
    let mut jumps = Vec::new();
    for a in 0..cands.len() {
        for b in a + 1..cands.len() {
            let mut j = jump_points(&cands[a], &cands[b], &k.jumps);
            j.points.retain(|p| p.score >= k.min_jump);
            jumps.push((a, b, j));
        }
    }
    let links: Vec<Link> = jumps.iter().map(|(a, b, j)| Link { a: *a, b: *b, jumps: j }).collect();
    let keys: Vec<Key> = keys
        .into_iter()
        .map(|(def, values)| Key { shader: set.iter().position(|d| d.name == def.name).expect("in the set"), values })
        .collect();
    let record = transform(&cands, &links, &keys, &k.config).map_err(|e| {
        StageError::new(e.to_string())
            .at_prop("keys")
            .with_help("lower `jump`, or name a connective shader in `via` that can look like both keys")
    })?;
    Ok(Transformed { shaders: set.iter().map(|d| d.name.to_string()).collect(), record, jumps, seed: k.seed })
}

/// What a key is.
#[derive(Clone, Copy, PartialEq)]
enum KeyKind {
    Shader,
    Match,
}

/// The key declarations: `shader`s and `match`es, at least two.
fn plan_keys(p: &Planner, d: &Decl) -> Result<Vec<(String, KeyKind)>, Diagnostic> {
    let span = d.props.span("keys").unwrap_or(d.name_span);
    let names = d.props.refs("keys");
    if names.len() < 2 {
        return Err(Diagnostic::error(format!("a transformation needs at least two keys, not {}", names.len()))
            .with_code("tessera::transform")
            .with_label(span, "here")
            .with_help("name where it starts and where it ends: `keys = [from, to]`"));
    }
    names
        .iter()
        .map(|n| {
            let kind = &p.decl(n).kind;
            if *kind == super::shader::SPEC.name {
                Ok((n.clone(), KeyKind::Shader))
            } else if *kind == super::matching::SPEC.name {
                Ok((n.clone(), KeyKind::Match))
            } else {
                Err(Diagnostic::error(format!("`{n}` is a {kind}: a key is a `shader` or a `match`"))
                    .with_code("tessera::transform")
                    .with_label(span, "here")
                    .with_help("match an image first (`match m { target = … }`) and name the match"))
            }
        })
        .collect()
}

/// The transform kind.
pub struct TransformKind;

impl super::Kind for TransformKind {
    fn spec(&self) -> &'static KindSpec {
        &SPEC
    }

    fn plan(&self, p: &mut Planner, d: &Decl) -> Result<Option<AnyHandle>, Diagnostic> {
        let props = &d.props;
        let keys = plan_keys(p, d)?;
        let side = props.int("side") as usize;
        let metric = metric(METRICS.get(props.enumeration("metric")));
        let catalogue = CatalogueConfig { cap: props.int("catalogue") as usize, ..CatalogueConfig::default() };
        let via = match props.get("via") {
            Some(Val::Str(text)) => shader_list(text, props.span("via").unwrap_or(d.name_span))?,
            _ => Vec::new(),
        };
        let mut inputs = Inputs::new();
        let mut key_inputs = Vec::new();
        let mut possible: Vec<&'static ShaderDef> = via.clone();
        for (name, kind) in &keys {
            let decl = p.decl(name);
            if *kind == KeyKind::Shader {
                let Some(Val::Call(call)) = decl.props.get("pattern") else {
                    unreachable!("the schema admits only calls")
                };
                let def = lib::shader(&call.name).expect("the schema admits only library shaders");
                key_inputs.push(KeyInput::Shader { shader: def.name, values: super::shader::values(def, call) });
                possible.push(def);
            } else {
                let m: Handle<Matched> = p.result(name);
                key_inputs.push(KeyInput::Match(inputs.add(m)));
                possible.extend(super::matching::candidate_shaders(decl)?);
            }
        }
        let mut catalogues = Vec::new();
        for def in possible {
            if catalogues.iter().any(|(n, _)| *n == def.name) {
                continue;
            }
            // A match's catalogues are planned under its own side, metric and size: the keys'
            // values are what is read from it, so the transformation's own settings decide.
            let h = plan_catalogue(p, def, side, metric, &catalogue, None);
            catalogues.push((def.name, inputs.add(h)));
        }
        let config = TransformConfig {
            exponent: props.num("exponent"),
            tau: props.num("tau"),
            depth: props.int("depth") as usize,
            coherence: props.opt_num("coherence"),
            ..TransformConfig::default()
        };
        let jumps = JumpConfig { presence: props.num("presence"), ..JumpConfig::default() };
        let key = PathKey {
            keys: key_inputs,
            catalogues,
            via: via.iter().map(|d| d.name).collect(),
            side,
            metric,
            seed: super::matching::catalogue_seed(p),
            config,
            jumps,
            min_jump: props.num("jump"),
        };
        let node: Handle<Transformed> =
            p.add(format!("transform {}", d.name), FnStage::keyed("transform.path", 1, key, run_path), inputs, vec![]);
        Ok(Some(node.erase()))
    }

    fn plan_output(&self, p: &mut Planner, out: &super::OutputRequest) -> Result<Option<super::ViewNode>, Diagnostic> {
        let d = out.decl;
        out.refuse_views("a transformation has no views: write its record (`.toml`), a strip of its frames (`.png`) or one file per frame (`frame_###.png`)")?;
        let src = p.decl(out.from);
        let frames = src.props.opt_int("frames").map(|n| n as usize);
        let size = src.props.int("size") as usize;
        // A scene's outputs are held until all are written: a sequence's frames together, a
        // strip whole (its frame count is known here only when `frames` is set).
        let count = if d.name.contains('#') { frames } else { frames.map(strip_frames) };
        if let Some(n) = count {
            p.check_pixels(src, src.props.span("size"), (size, size * n), BYTES_PER_PIXEL)?;
        }
        let transformed: Handle<Transformed> = p.result(out.from);
        // The inputs of a stage that reads the whole path.
        let on_path = || {
            let mut inputs = Inputs::new();
            let h = inputs.add(transformed);
            (inputs, h)
        };
        let hashes = d.name.matches('#').count();
        let format = out.format;
        let node = match format {
            OutputFormat::Toml if hashes == 0 => {
                let (inputs, h) = on_path();
                let stage = FnStage::keyed("output.transform_record", 1, (h, frames), |cx, &(h, frames)| {
                    Ok(Bytes(record_toml(&cx.get(h), frames).into_bytes()))
                });
                p.add(format!("output {}", d.name), stage, inputs, vec![])
            }
            OutputFormat::Png8 | OutputFormat::Png16 | OutputFormat::Exr if hashes == 0 => match frames {
                // The frame count known, the strip is made of the same frame stages as frame
                // files, so a scene writing both renders each frame once.
                Some(count) => {
                    let mut inputs = Inputs::new();
                    let shown: Vec<In<Image>> =
                        (0..count).map(|i| inputs.add(frame_stage(p, out.from, transformed, count, i, size))).collect();
                    let stage = FnStage::keyed(
                        "output.transform_strip_of_frames",
                        1,
                        (shown, size, format),
                        |cx, (shown, size, format)| {
                            let img = strip(shown.len(), *size, |k| Ok(cx.get(shown[k])))?;
                            super::output::encode_image(
                                &super::output::to_file_space(&img, super::ColorSpace::Srgb, *format),
                                *format,
                            )
                        },
                    );
                    p.add(format!("output {}", d.name), stage, inputs, vec![])
                }
                None => {
                    let (inputs, h) = on_path();
                    let stage =
                        FnStage::keyed("output.transform_strip", 2, (h, size, format), |cx, &(h, size, format)| {
                            let t = cx.get(h);
                            let frames = chosen(&t, None);
                            let img = strip(frames.len(), size, |k| render_frame(&t, frames[k], size).map(Arc::new))?;
                            super::output::encode_image(
                                &super::output::to_file_space(&img, super::ColorSpace::Srgb, format),
                                format,
                            )
                        });
                    p.add(format!("output {}", d.name), stage, inputs, vec![])
                }
            },
            OutputFormat::Png8 | OutputFormat::Png16 | OutputFormat::Exr => {
                let Some(count) = frames else {
                    return Err(Diagnostic::error("one file per frame needs the number of frames")
                        .with_code("tessera::output_format")
                        .with_label(d.name_span, "a `#` pattern")
                        .with_help(format!(
                            "set `frames` on `{}` (the path's own frame count is known only once it is built)",
                            out.from
                        )));
                };
                let run = d.name.find('#').expect("hashes > 0");
                let width = d.name[run..].chars().take_while(|&c| c == '#').count();
                if width != hashes {
                    return Err(Diagnostic::error("a frame pattern is one run of `#`s")
                        .with_code("tessera::output_name")
                        .with_label(d.name_span, "here"));
                }
                let mut files = Vec::new();
                for i in 0..count {
                    let name = format!("{}{:0width$}{}", &d.name[..run], i, &d.name[run + width..]);
                    let mut inputs = Inputs::new();
                    let frame = inputs.add(frame_stage(p, out.from, transformed, count, i, size));
                    let stage = FnStage::keyed("output.transform_frame", 2, (frame, format), |cx, &(frame, format)| {
                        super::output::encode_image(
                            &super::output::to_file_space(&cx.get(frame), super::ColorSpace::Srgb, format),
                            format,
                        )
                    });
                    files.push((name.clone(), p.add(format!("output {name}"), stage, inputs, vec![])));
                }
                let first = files[0].1;
                return Ok(Some(super::ViewNode { node: first, exact: false, more: files }));
            }
            _ => {
                return Err(Diagnostic::error(format!(
                    "a transformation is written as `.toml`, `.png` or `.exr`, not `.{}`",
                    out.ext
                ))
                .with_code("tessera::output_format")
                .with_label(d.name_span, "here"))
            }
        };
        Ok(Some(super::ViewNode { node, exact: false, more: Vec::new() }))
    }
}

/// The frames a sequence shows: all, or `frames` evenly spaced in time.
fn chosen(t: &Transformed, frames: Option<usize>) -> Vec<usize> {
    match frames {
        Some(n) => resample(&t.record.frames.iter().map(|f| f.t).collect::<Vec<_>>(), n),
        None => (0..t.record.frames.len()).collect(),
    }
}

/// The render of frame `i` of the `count` evenly spaced frames of `from`'s sequence: one stage
/// that a strip and the frame files of the same sequence share.
fn frame_stage(
    p: &mut Planner,
    from: &str,
    transformed: Handle<Transformed>,
    count: usize,
    i: usize,
    size: usize,
) -> Handle<Image> {
    p.shared(format!("transform frame {from} {count} {i} {size}"), |p| {
        let mut inputs = Inputs::new();
        let h = inputs.add(transformed);
        let stage = FnStage::keyed("transform.frame", 1, (h, count, i, size), |cx, &(h, count, i, size)| {
            let t = cx.get(h);
            render_frame(&t, chosen(&t, Some(count))[i], size)
        });
        p.add(format!("{from} frame {i}"), stage, inputs, vec![])
    })
}

fn render_frame(t: &Transformed, i: usize, size: usize) -> Result<Image, StageError> {
    let f = &t.record.frames[i];
    let def = lib::shader(&t.shaders[f.shader]).expect("a transformation names library shaders");
    lib::render_square(def, &f.values, t.seed, size).map_err(|e| StageError::new(e.to_string()))
}

/// Working memory per output pixel: the render and the encoded copy.
const BYTES_PER_PIXEL: f64 = 16.0;

/// Frames to a strip's row.
const PER_ROW: usize = 16;

/// The frames' worth of pixels a strip of `n` frames holds (a full last row).
fn strip_frames(n: usize) -> usize {
    n.div_ceil(PER_ROW) * PER_ROW.min(n)
}

/// `count` frames side by side, at most 16 to a row; `frame(k)` gives the k-th when its place
/// is filled, so a strip that renders its own frames holds one at a time.
fn strip(
    count: usize,
    size: usize,
    frame: impl Fn(usize) -> Result<Arc<Image>, StageError>,
) -> Result<Image, StageError> {
    let gap = (size / 32).max(2);
    let cols = count.clamp(1, PER_ROW);
    let rows = count.div_ceil(PER_ROW).max(1);
    let (w, h) = (cols * size + (cols - 1) * gap, rows * size + (rows - 1) * gap);
    let pixels = w as f64 * h as f64;
    if pixels > 64e6 {
        return Err(StageError::new(format!("a strip of {count} frames at {size} pixels is {w} x {h}: too large"))
            .at_prop("frames")
            .with_help("set fewer `frames` or a smaller `size`"));
    }
    let mut out = Image::filled(w, h, 3, 1.0);
    for k in 0..count {
        let img = frame(k)?;
        let (x0, y0) = ((k % PER_ROW) * (size + gap), (k / PER_ROW) * (size + gap));
        for y in 0..size {
            for x in 0..size {
                for c in 0..3 {
                    out.set(x0 + x, y0 + y, c, img.get(x, y, c));
                }
            }
        }
    }
    Ok(out)
}

/// The record: every frame of the path (or of the sequence, with `frames`), its time, its
/// similarity to the previous frame, the keys and jumps.
pub fn record_toml(t: &Transformed, frames: Option<usize>) -> String {
    let r = &t.record;
    let mut s = String::from("# tessera transformation record\n");
    s += &format!("shaders = [{}]\n", t.shaders.iter().map(|n| format!("\"{n}\"")).collect::<Vec<_>>().join(", "));
    s +=
        &format!("frames = {}\npath_frames = {}\ninserted = {}\n", chosen(t, frames).len(), r.frames.len(), r.inserted);
    s += &format!("costs = [{}]\n", r.costs.iter().map(|c| round(*c)).collect::<Vec<_>>().join(", "));
    s += &format!("below_tau = [{}]\n", r.failed.iter().map(|i| i.to_string()).collect::<Vec<_>>().join(", "));
    for (a, b, j) in &t.jumps {
        for p in &j.points {
            s += &format!(
                "\n[[jump]]\nfrom = \"{}\"\nto = \"{}\"\nscore = {}\n",
                t.shaders[*a],
                t.shaders[*b],
                round(p.score)
            );
        }
    }
    for i in chosen(t, frames) {
        let f = &r.frames[i];
        let def = lib::shader(&t.shaders[f.shader]).expect("library");
        s += &format!("\n[[frame]]\nshader = \"{}\"\nt = {}\nscore = {}\n", def.name, round(f.t), round(f.score));
        if let Some(k) = f.key {
            s += &format!("key = {k}\n");
        }
        if f.jump {
            s += "jump = true\n";
        }
        let args: Vec<String> = arguments(def, &f.values)
            .into_iter()
            .map(|(n, v)| format!("{n} = {}", v.trim_end_matches(" deg")))
            .collect();
        s += &format!("parameters = {{ {} }}\n", args.join(", "));
    }
    s
}
