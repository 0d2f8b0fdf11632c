//! Photometric samples: registered photographs of one surface, each under one known distant
//! light [references: dong §3.3]. Named by `images` + `lights` or by a light-position file
//! (`capture`); loaded into one [`Capture`] artifact of linear intensities.

use std::path::PathBuf;

use super::lp;
use super::Prepare;
use crate::graph::{Handle, Inputs, RunCx, StageError};
use crate::kinds::artifact::{pack, unpack};
use crate::kinds::{Encoded, FnStage, Planner};
use crate::lang::ir::Call;
use crate::lang::schema::{CallSpec, Default, PropSpec, Range, Ty, Unit, ANY};
use crate::lang::{Decl, Diagnostic, Val};
use crate::raster::{self, Image};

const LIGHT_DOC: &str =
    "One distant light: tilt (from the image's x axis towards its rows, which run down) and slant (from the surface normal).";

/// Slants run from overhead to grazing (angles are held in radians).
const SLANTS: Range = Range { min: 0.0, max: std::f64::consts::FRAC_PI_2 };

const LIGHT_ARGS: &[PropSpec] = &[
    PropSpec {
        name: "tilt",
        ty: Ty::Number(Unit::Angle, ANY),
        default: Default::Required,
        doc: "Angle of the light's projection from the x axis.",
    },
    PropSpec {
        name: "slant",
        ty: Ty::Number(Unit::Angle, SLANTS),
        default: Default::Required,
        doc: "Angle from the surface normal (0 = overhead, 90 = grazing).",
    },
];

/// The `light(...)` constructor of a relit output or layer.
pub static LIGHT: &[CallSpec] = &[CallSpec { name: "light", doc: LIGHT_DOC, args: LIGHT_ARGS }];

/// The `light(...)` and `grid(...)` constructors of `lights`.
pub static LIGHT_CALLS: &[CallSpec] = &[
    CallSpec { name: "light", doc: LIGHT_DOC, args: LIGHT_ARGS },
    CallSpec {
        name: "grid",
        doc: "Every slant with every tilt, slant by slant: `grid(slants = [30, 45, 60], tilts = [0, 30, …])` is 3 × 12 lights.",
        args: &[
            PropSpec {
                name: "slants",
                ty: Ty::Numbers(Unit::Angle, SLANTS),
                default: Default::Required,
                doc: "The slants, in degrees.",
            },
            PropSpec { name: "tilts", ty: Ty::Numbers(Unit::Angle, ANY), default: Default::Required, doc: "The tilts, in degrees." },
        ],
    },
];

/// How a capture's pixel values map to intensities.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Transfer {
    /// 8-bit PNG: sRGB-encoded; 16-bit PNG and EXR: linear (what capture tools write).
    Auto,
    Srgb,
    Linear,
}

crate::choices!(pub TRANSFERS: Transfer { "auto" => Transfer::Auto, "srgb" => Transfer::Srgb, "linear" => Transfer::Linear });

/// A photometric capture: images of one size and channel count (1 or 3), linear, with the
/// light of each as `(tilt, slant)` in degrees.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Capture {
    #[serde(skip)]
    pub images: Vec<Image>,
    pub lights: Vec<[f64; 2]>,
    /// Bits per sample of the files (32 for EXR), or the `bit_depth` the scene gave.
    pub bit_depth: u32,
}

impl Encoded for Capture {
    fn encode(&self) -> Vec<u8> {
        pack(self, &self.images.iter().collect::<Vec<_>>())
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let (mut c, images): (Capture, Vec<Image>) = unpack(bytes)?;
        if images.len() != c.lights.len() {
            return Err("capture artifact: image and light counts differ".into());
        }
        c.images = images;
        Ok(c)
    }
}

/// What `sample.capture` works from; the files are the images, in light order.
#[derive(Clone, serde::Serialize)]
struct Loading {
    lights: Vec<[f64; 2]>,
    bit_depth: Option<u32>,
    transfer: Transfer,
    prep: Prepare,
}

/// Whether a sample declaration names a photometric capture.
pub fn is_capture(d: &Decl) -> bool {
    d.props.get("images").is_some() || d.props.get("capture").is_some()
}

/// Plans the loading of a capture named by `capture = "x.lp"` or `images` + `lights`.
pub fn plan(p: &mut Planner, d: &Decl) -> Result<Handle<Capture>, Diagnostic> {
    let props = &d.props;
    let at = |name: &str| props.span(name).unwrap_or(d.name_span);
    for other in ["image", "from"] {
        if props.get(other).is_some() {
            return Err(Diagnostic::error(format!(
                "sample `{}` is a photometric capture and has an `{other}`",
                d.name
            ))
            .with_code("tessera::sample")
            .with_label(at(other), "remove this, or make it another sample"));
        }
    }
    let (files, lights) = match props.path("capture") {
        Some(path) => {
            for other in ["images", "lights"] {
                if props.get(other).is_some() {
                    return Err(Diagnostic::error(format!(
                        "the light-position file names the images and lights; `{other}` repeats it"
                    ))
                    .with_code("tessera::sample")
                    .with_label(at(other), "remove this")
                    .with_label(at("capture"), "the light-position file"));
                }
            }
            from_lp(p, path, at("capture"))?
        }
        None => {
            let (images, spans) = props.files("images").expect("a capture without a file names images");
            let Some(Val::Calls(calls)) = props.get("lights") else {
                return Err(Diagnostic::error(format!("sample `{}` has `images` but no `lights`", d.name))
                    .with_code("tessera::missing_property")
                    .with_label(at("images"), "one light per image is needed")
                    .with_help("add `lights = [light(tilt = 0 deg, slant = 45 deg), …]` or `lights = grid(slants = […], tilts = […])`"));
            };
            let lights = expand(calls);
            if lights.len() != images.len() {
                return Err(Diagnostic::error(format!("{} light(s) for {} image(s)", lights.len(), images.len()))
                    .with_code("tessera::capture")
                    .with_label(at("lights"), format!("{} light(s)", lights.len()))
                    .with_label(at("images"), format!("{} image(s)", images.len()))
                    .with_help("every image needs exactly one light, in the same order"));
            }
            (images.iter().cloned().zip(spans.iter().copied()).collect(), lights)
        }
    };
    let prep = Prepare::of(d)?;
    let loading = Loading {
        lights,
        bit_depth: props.get("bit_depth").map(|_| props.int("bit_depth") as u32),
        transfer: TRANSFERS.get(props.enumeration("transfer")),
        prep,
    };
    let stage = FnStage::keyed("sample.capture", 3, loading, load);
    Ok(p.add(format!("sample {}", d.name), stage, Inputs::new(), files))
}

/// The lights of `light(...)` and `grid(...)` calls, in order, as `(tilt, slant)` in degrees.
fn expand(calls: &[Call]) -> Vec<[f64; 2]> {
    let mut out = Vec::new();
    for c in calls {
        if c.name == "grid" {
            for &slant in c.args.numbers("slants") {
                for &tilt in c.args.numbers("tilts") {
                    out.push(degrees(tilt, slant));
                }
            }
        } else {
            out.push(degrees(c.args.num("tilt"), c.args.num("slant")));
        }
    }
    out
}

/// `(tilt, slant)` in degrees, tilt in [0, 360), from the language's radians.
pub fn degrees(tilt: f64, slant: f64) -> [f64; 2] {
    [tilt.to_degrees().rem_euclid(360.0), slant.to_degrees()]
}

/// Reads the light-position file at plan time: it decides which image files the stage reads.
#[allow(clippy::type_complexity)]
fn from_lp(
    p: &Planner,
    path: &std::path::Path,
    span: crate::lang::source::Span,
) -> Result<(Vec<(PathBuf, crate::lang::source::Span)>, Vec<[f64; 2]>), Diagnostic> {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let text = p.read_text(path).map_err(|e| {
        Diagnostic::error(format!("cannot read the light-position file `{name}`: {e}"))
            .with_code("tessera::io")
            .with_label(span, "this file")
    })?;
    let entries = lp::parse(&text).map_err(|e| {
        Diagnostic::error(format!("line {} of `{name}`: {}", e.line, e.message))
            .with_code("tessera::light_positions")
            .with_label(span, "this light-position file")
            .with_help("a light-position file is a count of images, then `filename x y z` per line")
    })?;
    let dir = path.parent().map(PathBuf::from).unwrap_or_default();
    let mut files = Vec::with_capacity(entries.len());
    let mut lights = Vec::with_capacity(entries.len());
    for e in entries {
        if e.file.contains("..") || e.file.starts_with('/') {
            return Err(Diagnostic::error(format!(
                "line {} of `{name}` names `{}`, outside the capture's directory",
                e.line, e.file
            ))
            .with_code("tessera::light_positions")
            .with_label(span, "this light-position file"));
        }
        files.push((crate::lang::normalize(&dir.join(&e.file)), span));
        let [x, y, z] = e.direction;
        let l = crate::synth::relight::Light::from_rti_direction(x, y, z);
        lights.push([l.tilt_deg, l.slant_deg]);
    }
    Ok((files, lights))
}

/// Peak bytes per pixel and image while loading: the decoded file (up to four f32 channels)
/// and its linear copy.
pub const LOAD_BYTES_PER_PIXEL: f64 = 32.0;

fn load(cx: &RunCx, l: &Loading) -> Result<Capture, StageError> {
    let n = cx.file_count();
    let mut images: Vec<Image> = Vec::with_capacity(n);
    let mut depth: Option<u32> = None;
    for i in 0..n {
        let bytes = cx.file(i)?;
        let name = cx.file_name(i);
        if let Some((w, h, c)) = raster::io::decode_dimensions(&bytes) {
            let held = images.iter().map(|m| m.data.len() as f64 * 4.0).sum::<f64>();
            cx.budget()
                .check(
                    held + w as f64 * h as f64 * c as f64 * LOAD_BYTES_PER_PIXEL / 4.0,
                    &format!("the capture up to `{name}`"),
                )
                .map_err(|m| StageError::new(m).in_file(i))?;
        }
        let img = crate::kinds::decode_image(&bytes, cx.budget())
            .map_err(|e| StageError::new(format!("cannot decode `{name}`: {e}")).in_file(i))?;
        if let Some(bad) = img.data.iter().position(|v| !v.is_finite()) {
            let px = bad % img.plane_len();
            return Err(StageError::new(format!(
                "`{name}` holds a NaN or infinite value at pixel ({}, {})",
                px % img.width,
                px / img.width
            ))
            .in_file(i)
            .with_help("photometric images must be finite everywhere"));
        }
        let exr = raster::io::is_exr(&bytes);
        let file_depth = if exr { 32 } else { raster::io::png_bit_depth(&bytes).map_or(8, u32::from) };
        if let Some(d) = depth.filter(|&d| d != file_depth) {
            return Err(StageError::new(format!(
                "`{name}` has {file_depth}-bit samples, the first image {d}-bit: a capture's images come from one camera"
            ))
            .in_file(i));
        }
        depth = Some(file_depth);
        // Colour (or grey) without alpha: intensities only.
        let keep = match img.channels {
            1 | 2 => 1,
            _ => 3,
        };
        let mut img = if keep == img.channels { img } else { first_channels(&img, keep) };
        if let Some(bits) = l.bit_depth {
            if !exr && file_depth > 8 {
                // A 12-bit camera in a 16-bit container: full scale is 2^bits − 1, not 65535.
                // The decoder gave `code / 65535`; the code comes back exactly in f64 and is
                // divided once, so a value is `code / 4095` correctly rounded (rescaling the
                // f32 instead rounds twice and is one ulp off for most codes).
                let (stored, full) = (((1u64 << file_depth) - 1) as f64, ((1u64 << bits) - 1) as f64);
                let top = img.data.iter().fold(0f32, |a, &v| a.max(v));
                let code = (f64::from(top) * stored).round();
                if code > full {
                    return Err(StageError::new(format!(
                        "`{name}` holds the code {code}, more than {bits} bits can hold ({full})"
                    ))
                    .at_prop("bit_depth")
                    .with_help("`bit_depth` is the camera's depth: every code of the files must fit in it"));
                }
                img.data.iter_mut().for_each(|v| *v = ((f64::from(*v) * stored).round() / full) as f32);
            }
        }
        let srgb = match l.transfer {
            Transfer::Auto => !exr && file_depth <= 8,
            Transfer::Srgb => true,
            Transfer::Linear => false,
        };
        if srgb {
            img = raster::color::image_srgb_to_linear(&img);
        }
        let img = l.prep.geometry(img, i)?;
        if let Some(first) = images.first() {
            if !img.same_size(first) || img.channels != first.channels {
                return Err(StageError::new(format!(
                    "`{name}` is {} x {} with {} channel(s), the first image {} x {} with {}: a capture's images must be registered",
                    img.width, img.height, img.channels, first.width, first.height, first.channels
                ))
                .in_file(i));
            }
        }
        images.push(img);
    }
    let bit_depth = l.bit_depth.unwrap_or(depth.unwrap_or(8));
    Ok(Capture { images, lights: l.lights.clone(), bit_depth })
}

fn first_channels(img: &Image, keep: usize) -> Image {
    let mut out = Image::new(img.width, img.height, keep);
    for c in 0..keep {
        out.plane_mut(c).copy_from_slice(img.plane(c));
    }
    out
}
