//! `sample`: example material. An image (cropped, resized, in a chosen colour space) and
//! other files (structures today; photometric sets and patches later) passed through to
//! the stages that read them.

use super::{Bytes, FnStage, Planner};
use crate::graph::{NodeId, StageError};
use crate::lang::schema::{Default, KindSpec, Naming, PropSpec, Ty, Unit};
use crate::lang::{Decl, Diagnostic};
use crate::raster;

pub static SPEC: KindSpec = KindSpec {
    name: "sample",
    doc: "Example material: a photo or painted image, and files that later stages read (a structure drawing).",
    naming: Naming::Ident,
    props: &[
        PropSpec {
            name: "image",
            ty: Ty::Path,
            default: Default::Absent,
            doc: "PNG (8/16-bit, taken as sRGB-encoded) or OpenEXR (taken as linear) image.",
        },
        PropSpec {
            name: "crop",
            ty: Ty::Numbers(Unit::Length),
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
            ty: Ty::Enum(&["bilinear", "bicubic"]),
            default: Default::Text("bicubic"),
            doc: "Resampling filter for `resize`; resampling happens on linear values.",
        },
        PropSpec {
            name: "color",
            ty: Ty::Enum(&["srgb", "linear", "lab"]),
            default: Default::Text("srgb"),
            doc: "Colour space of the sample's pixels as later stages see them (`lab` needs an RGB image).",
        },
        PropSpec {
            name: "structure",
            ty: Ty::Path,
            default: Default::Absent,
            doc: "A structure file (planar subdivision), passed through to `structure` declarations.",
        },
    ],
};

/// The node holding the sample's structure file, if any, is planned as a second stage so
/// that an edit to the photo does not invalidate structure analysis and vice versa.
pub fn plan(p: &mut Planner, d: &Decl) -> Result<NodeId, Diagnostic> {
    let props = &d.props;
    if let Some(path) = props.path("structure") {
        let stage = FnStage::new("sample.file", 1, String::new(), |cx| Ok(Bytes(cx.file(0)?.to_vec())));
        let span = props.span("structure").unwrap_or(d.name_span);
        p.add(format!("sample {} (structure)", d.name), stage, vec![], vec![(path.clone(), span)]);
    }
    let Some(path) = props.path("image").cloned() else {
        // A sample without an image: its result is the structure pass-through (or nothing).
        if props.path("structure").is_some() {
            return Ok(p.last());
        }
        return Err(Diagnostic::error(format!("sample `{}` names no file", d.name))
            .with_code("tessera::missing_property")
            .with_label(d.name_span, "give it an `image` or a `structure`"));
    };
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
    let filter = match props.enumeration("filter") {
        "bilinear" => raster::resample::Filter::Bilinear,
        _ => raster::resample::Filter::Bicubic,
    };
    let color = props.enumeration("color").to_string();
    let params = props.canonical();
    let stage = FnStage::new("sample.image", 1, params, move |cx| {
        let bytes = cx.file(0)?;
        let img = raster::io::decode(&bytes)
            .map_err(|e| StageError::new(format!("cannot decode the image: {e}")).in_file(0))?;
        let linear_source = raster::io::is_exr(&bytes);
        let mut img = if linear_source { img } else { raster::color::image_srgb_to_linear(&img) };
        if let Some([x, y, w, h]) = crop {
            img = raster::resample::crop(&img, x, y, w, h).map_err(|_| {
                StageError::new(format!(
                    "crop [{x}, {y}, {w}, {h}] reaches outside the {}x{} image",
                    img.width, img.height
                ))
                .at_prop("crop")
            })?;
        }
        if let Some((w, h)) = resize {
            img = raster::resample::resize(&img, w as usize, h as usize, filter);
        }
        match color.as_str() {
            "srgb" => Ok(raster::color::image_linear_to_srgb(&img)),
            "lab" if img.channels >= 3 => Ok(raster::color::image_linear_to_lab(&img)),
            "lab" => Err(StageError::new(format!(
                "`color = lab` needs an RGB image; this one has {} channel(s)",
                img.channels
            ))
            .at_prop("color")),
            _ => Ok(img),
        }
    });
    let span = props.span("image").unwrap_or(d.name_span);
    Ok(p.add(format!("sample {}", d.name), stage, vec![], vec![(path, span)]))
}
