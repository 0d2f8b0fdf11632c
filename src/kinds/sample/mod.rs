//! `sample`: example material. An image (cropped, resized, in a chosen colour space), a
//! photometric capture (`capture`), and other files (structures) passed through to the
//! stages that read them.

pub(super) mod capture;
mod lp;
pub(super) mod patch;

use super::{Bytes, FnStage, Planner};
use crate::graph::{AnyHandle, Handle, In, Inputs, RunCx, StageError};
use crate::lang::schema::{Default, Extent, KindSpec, Naming, PropSpec, Ty, Unit, Value, ANY};
use crate::lang::source::Span;
use crate::lang::{Decl, Diagnostic, Val};
use crate::raster::{self, Image};

crate::choices!(FILTERS: raster::resample::Filter {
    "bilinear" => raster::resample::Filter::Bilinear, "bicubic" => raster::resample::Filter::Bicubic
});

pub static SPEC: KindSpec = KindSpec {
    name: "sample",
    doc: "Example material: a photo or painted image, and files that later stages read (a structure drawing).",
    naming: Naming::Ident,
    produces: &[Value::Image, Value::Example, Value::Capture, Value::Patch],
    settings: &[],
    extent: Extent::None,
    props: &[
        PropSpec {
            name: "image",
            ty: Ty::Path,
            default: Default::Absent,
            doc: "PNG (8/16-bit, taken as sRGB-encoded) or OpenEXR (taken as linear) image.",
        },
        PropSpec {
            name: "from",
            ty: Ty::Source { calls: super::library::SAMPLE_SOURCES, refs: &[] },
            default: Default::Absent,
            doc: "Instead of `image`: a library entry chosen by `similar(...)`. A `.json` output of the sample writes the ranking.",
        },
        PropSpec {
            name: "crop",
            ty: Ty::Numbers(Unit::Length, ANY),
            default: Default::Absent,
            doc: "`[x, y, w, h]` in pixels of the source image, applied before `resize`.",
        },
        PropSpec {
            name: "resize",
            ty: Ty::Size,
            default: Default::Absent,
            doc: "Resample to this size (after cropping).",
        },
        PropSpec {
            name: "filter",
            ty: Ty::Enum(FILTERS.names),
            default: Default::Text("bicubic"),
            doc: "Resampling filter for `resize`; resampling happens on linear values.",
        },
        PropSpec {
            name: "color",
            ty: Ty::Enum(super::COLOR_SPACES.names),
            default: Default::Text("srgb"),
            doc: "Colour space of the sample's pixels as later stages see them (`lab` needs an RGB image).",
        },
        PropSpec {
            name: "images",
            ty: Ty::Files(&["png", "exr"]),
            default: Default::Absent,
            doc: "A photometric capture: registered photographs of one surface from one camera, each under one distant light (`lights`), as a list or a pattern (`\"captures/rock_*.png\"`, sorted by name). Crop and resize apply to every image.",
        },
        PropSpec {
            name: "lights",
            ty: Ty::Calls(capture::LIGHT_CALLS),
            default: Default::Absent,
            doc: "With `images`: the light of each image, in order.",
        },
        PropSpec {
            name: "capture",
            ty: Ty::Path,
            default: Default::Absent,
            doc: "Instead of `images` + `lights`: a light-position file (`.lp`, as RTI capture tools write it: a count, then `filename x y z` per line, y up the image) naming the images, relative to itself.",
        },
        PropSpec {
            name: "bit_depth",
            ty: Ty::Int(1, 16),
            default: Default::Absent,
            doc: "Significant bits of a 16-bit PNG capture (12 for a 12-bit camera: full scale is 4095). Default: the files' own depth, recorded with the capture.",
        },
        PropSpec {
            name: "transfer",
            ty: Ty::Enum(capture::TRANSFERS.names),
            default: Default::Text("auto"),
            doc: "How a capture's values map to intensity: `auto` takes 8-bit PNGs as sRGB-encoded and 16-bit PNGs and EXRs as linear.",
        },
        PropSpec {
            name: "height",
            ty: Ty::Path,
            default: Default::Absent,
            doc: "With `image`: the height layer that makes the sample a patch for `relief` layers. A grey image of the image's size, read as stored (PNG codes over full scale, EXR values; no colour conversion), 0 lowest and 1 highest; `crop` and `resize` apply to it too.",
        },
        PropSpec {
            name: "mask",
            ty: Ty::Path,
            default: Default::Absent,
            doc: "With `height`: the patch's mask layer, pixels that matching ignores (white: shadows, highlights). Same size as the image.",
        },
        PropSpec {
            name: "structure",
            ty: Ty::Path,
            default: Default::Absent,
            doc: "The drawn structure that `structure` declarations learn from: a planar subdivision in JSON, or a painted label image (PNG or EXR, one flat colour per region).",
        },
    ],
};

/// The node holding the sample's structure file, if any, is planned as a second stage so
/// that an edit to the photo does not invalidate structure analysis and vice versa.
pub fn plan(p: &mut Planner, d: &Decl) -> Result<AnyHandle, Diagnostic> {
    let props = &d.props;
    patch::refuse_stray_layers(d)?;
    if capture::is_capture(d) {
        return capture::plan(p, d).map(Handle::erase);
    }
    if let Some(span) = props.span("lights").or(props.span("bit_depth")).or(props.span("transfer")) {
        return Err(Diagnostic::error(format!("sample `{}` is not a photometric capture", d.name))
            .with_code("tessera::sample")
            .with_label(span, "only for captures")
            .with_help("name the capture's images with `images`, or its light-position file with `capture`"));
    }
    let structure = props.path("structure").map(|path| {
        let stage = FnStage::keyed("sample.file", 2, (), |cx, ()| Ok(Bytes(cx.file(0)?.to_vec())));
        let span = props.span("structure").unwrap_or(d.name_span);
        p.add(format!("sample {} (structure)", d.name), stage, Inputs::new(), vec![(path.clone(), span)])
    });
    let similar = match props.get("from") {
        Some(Val::Call(call)) => Some(call),
        _ => None,
    };
    if let (Some(_), Some(_)) = (props.path("image"), similar) {
        return Err(Diagnostic::error(format!("sample `{}` has both an `image` and a `from`", d.name))
            .with_code("tessera::sample")
            .with_label(props.span("from").unwrap_or(d.name_span), "remove one"));
    }
    let path = match (props.path("image").cloned(), similar) {
        (Some(path), _) => path,
        (None, Some(call)) => return plan_similar(p, d, call).map(Handle::erase),
        (None, None) => {
            // A sample without an image: its result is the structure pass-through (or nothing).
            if let Some(structure) = structure {
                return Ok(structure.erase());
            }
            return Err(Diagnostic::error(format!("sample `{}` names no file", d.name))
                .with_code("tessera::missing_property")
                .with_label(d.name_span, "give it an `image`, a `from` or a `structure`"));
        }
    };
    let prep = Prepare::of(d)?;
    if let Some((w, h)) = prep.resize {
        p.check_pixels(d, d.props.span("resize"), (w as usize, h as usize), RESIZE_BYTES_PER_PIXEL)?;
    }
    let geometry = prep.clone();
    let stage = FnStage::keyed("sample.image", 2, prep, |cx, prep| prep.apply(&cx.file(0)?, 0, cx.budget()));
    let span = props.span("image").unwrap_or(d.name_span);
    let image = p.add(format!("sample {}", d.name), stage, Inputs::new(), vec![(path, span)]);
    patch::plan(p, d, image, geometry)?;
    Ok(image.erase())
}

fn plan_similar(p: &mut Planner, d: &Decl, call: &crate::lang::ir::Call) -> Result<Handle<Image>, Diagnostic> {
    let (query, files) = super::library::plan_similar(p, d, call)?;
    p.set_part(d, "ranking", query);
    let prep = Prepare::of(d)?;
    if let Some((w, h)) = prep.resize {
        p.check_pixels(d, d.props.span("resize"), (w as usize, h as usize), RESIZE_BYTES_PER_PIXEL)?;
    }
    let span = d.props.span("from").unwrap_or(d.name_span);
    let mut inputs = Inputs::new();
    let picking = Picking { ranking: inputs.add(query), pick: call.args.int("pick") as usize, prep };
    let stage = FnStage::keyed("sample.pick", 2, picking, pick);
    let files = files.into_iter().map(|f| (f, span)).collect();
    Ok(p.add(format!("sample {}", d.name), stage, inputs, files))
}

/// What `sample.pick` works from: the ranking of the library (whose files are the stage's
/// files, in the library's order), which candidate to take, and how to prepare it.
#[derive(serde::Serialize)]
struct Picking {
    ranking: In<super::library::Ranking>,
    pick: usize,
    prep: Prepare,
}

fn pick(cx: &RunCx, s: &Picking) -> Result<Image, StageError> {
    let ranking = cx.get(s.ranking);
    let (bytes, index) = super::library::pick_bytes(cx, &ranking, s.pick)?;
    s.prep.apply(&bytes, index, cx.budget())
}

/// Peak bytes per pixel of a resized sample: up to four f32 channels held as the source's
/// column pass and the result, and the colour conversion's copy.
const RESIZE_BYTES_PER_PIXEL: f64 = 48.0;

/// How an image file becomes a sample: decode, linearise, crop, resize, colour space.
#[derive(Clone, serde::Serialize)]
struct Prepare {
    crop: Option<[usize; 4]>,
    resize: Option<(u32, u32)>,
    filter: raster::resample::Filter,
    color: super::ColorSpace,
}

impl Prepare {
    fn of(d: &Decl) -> Result<Prepare, Diagnostic> {
        let props = &d.props;
        let crop = match props.opt_numbers("crop") {
            None => None,
            Some(c) => {
                let ok = c.len() == 4 && c.iter().all(|v| v.fract() == 0.0 && *v >= 0.0) && c[2] >= 1.0 && c[3] >= 1.0;
                if !ok {
                    return Err(Diagnostic::error(
                        "`crop` is `[x, y, w, h]`: four whole numbers, width and height at least 1",
                    )
                    .with_code("tessera::type")
                    .with_label(props.span("crop").unwrap_or(d.name_span), "invalid crop"));
                }
                Some([c[0] as usize, c[1] as usize, c[2] as usize, c[3] as usize])
            }
        };
        let resize = props.opt_size("resize");
        let filter = FILTERS.get(props.enumeration("filter"));
        let color = super::COLOR_SPACES.get(props.enumeration("color"));
        Ok(Prepare { crop, resize, filter, color })
    }

    /// Crop, then resize: what a capture's every image goes through too.
    pub(super) fn geometry(&self, img: Image, file: usize) -> Result<Image, StageError> {
        let mut img = img;
        if let Some([x, y, w, h]) = self.crop {
            img = raster::resample::crop(&img, x, y, w, h).map_err(|_| {
                StageError::new(format!(
                    "crop [{x}, {y}, {w}, {h}] reaches outside the {}x{} image",
                    img.width, img.height
                ))
                .at_prop("crop")
            })?;
        }
        // The decoded values are finite; resampling and colour conversion can still take
        // extreme ones (an EXR of ±3e38) past f32. Say so, rather than let a later stage
        // find "NaN or infinite" values the file does not hold.
        let largest = img.data.iter().fold(0f32, |m, v| m.max(v.abs()));
        let overflow = |what: &str| {
            StageError::new(format!("the image's values (up to ±{largest:.1e}) overflow 32-bit floats when {what}"))
                .in_file(file)
                .with_help("scale the file's values into a usual range (EXR samples are taken as linear light)")
        };
        if let Some((w, h)) = self.resize {
            img = raster::resample::resize(&img, w as usize, h as usize, self.filter);
            if img.data.iter().any(|v| !v.is_finite()) {
                return Err(overflow("resized"));
            }
        }
        Ok(img)
    }

    /// `file` is the index of the file the bytes came from, for blame.
    fn apply(&self, bytes: &[u8], file: usize, budget: crate::graph::Budget) -> Result<Image, StageError> {
        let img = super::decode_image(bytes, budget)
            .map_err(|e| StageError::new(format!("cannot decode the image: {e}")).in_file(file))?;
        let bad = img.data.iter().filter(|v| !v.is_finite()).count();
        if bad > 0 {
            return Err(StageError::new(format!("the image holds {bad} NaN or infinite value(s)"))
                .in_file(file)
                .with_help("samples must be finite everywhere; fix or crop the file"));
        }
        let linear_source = raster::io::is_exr(bytes);
        let img = if linear_source { img } else { raster::color::image_srgb_to_linear(&img) };
        let img = self.geometry(img, file)?;
        let largest = img.data.iter().fold(0f32, |m, v| m.max(v.abs()));
        let overflow = |what: &str| {
            StageError::new(format!("the image's values (up to ±{largest:.1e}) overflow 32-bit floats when {what}"))
                .in_file(file)
                .with_help("scale the file's values into a usual range (EXR samples are taken as linear light)")
        };
        use super::ColorSpace;
        let img = match self.color {
            ColorSpace::Srgb => raster::color::image_linear_to_srgb(&img),
            ColorSpace::Lab if img.channels >= 3 => raster::color::image_linear_to_lab(&img),
            ColorSpace::Lab => {
                return Err(StageError::new(format!(
                    "`color = lab` needs an RGB image; this one has {} channel(s)",
                    img.channels
                ))
                .at_prop("color"))
            }
            ColorSpace::Linear => img,
        };
        if img.data.iter().any(|v| !v.is_finite()) {
            return Err(overflow(&format!("converted to `color = {}`", super::COLOR_SPACES.name(self.color))));
        }
        Ok(img)
    }
}

/// The sample kind: an image file, a structure file, or an entry chosen from a library.
pub struct Sample;

impl super::Kind for Sample {
    fn spec(&self) -> &'static crate::lang::KindSpec {
        &SPEC
    }

    fn plan(&self, p: &mut Planner, d: &Decl) -> Result<Option<AnyHandle>, Diagnostic> {
        let node = plan(p, d)?;
        if let Some(path) = d.props.path("structure") {
            p.export(d).example = Some((path.clone(), d.props.span("structure").unwrap_or(d.name_span)));
        }
        if has_image(d) {
            p.export(d).image = Some(super::COLOR_SPACES.get(d.props.enumeration("color")));
        }
        Ok(Some(node))
    }

    fn refuse_value(&self, d: &Decl, at: Span) -> Option<Diagnostic> {
        if capture::is_capture(d) {
            return Some(
                Diagnostic::error(format!("sample `{}` is a photometric capture, not an image", d.name))
                    .with_code("tessera::sample_image")
                    .with_label(at, "an image is needed here")
                    .with_help("fit a `representation` to the capture and use that, or give another sample an `image`"),
            );
        }
        (!has_image(d)).then(|| {
            Diagnostic::error(format!("sample `{}` holds only a structure file, not an image", d.name))
                .with_code("tessera::sample_image")
                .with_label(at, "an image is needed here")
                .with_help("give the sample an `image`, or use it as a structure's `from`")
        })
    }

    fn plan_output(&self, p: &mut Planner, out: &super::OutputRequest) -> Result<Option<super::ViewNode>, Diagnostic> {
        // A sample chosen by `similar(...)` written as JSON: its ranking.
        let Some(query) = p.part(out.from, "ranking").filter(|_| out.format == super::OutputFormat::Json) else {
            return Ok(None);
        };
        let mut inputs = Inputs::new();
        let ranking = inputs.add(query);
        let stage = FnStage::keyed("output.ranking", 2, ranking, |cx, &ranking| {
            Ok(super::library::ranking_json(&cx.get(ranking)))
        });
        let node = p.add(format!("output {}", out.decl.name), stage, inputs, vec![]);
        Ok(Some(super::ViewNode { node, exact: false, more: Vec::new() }))
    }
}

fn has_image(d: &Decl) -> bool {
    d.props.get("image").is_some() || d.props.get("from").is_some()
}
