//! A sample with a `height` layer (and optionally a `mask`) is a patch [references: frasson §5.2]:
//! colour and height pixel-aligned, what `relief` layers draw their blocks from. The patch is a
//! stage of its own beside the image, so an edit to the height map re-runs neither the image
//! nor the layers that only quilt its colour.

use super::Prepare;
use crate::graph::{Handle, In, Inputs, RunCx, StageError};
use crate::kinds::{FnStage, Planner};
use crate::lang::{Decl, Diagnostic};
use crate::raster::Image;

/// The channels of a patch artifact: colour (as the sample's image, in its colour space), then
/// height, then the mask (1 = ignore; 0 everywhere without a mask layer).
pub const HEIGHT: usize = 3;
pub const MASK: usize = 4;

/// `height` and `mask` belong to an image sample, and `mask` to a patch.
pub(super) fn refuse_stray_layers(d: &Decl) -> Result<(), Diagnostic> {
    let props = &d.props;
    if let Some(span) = props.span("height").filter(|_| props.get("image").is_none()) {
        return Err(Diagnostic::error(format!("sample `{}` has a height layer but no `image`", d.name))
            .with_code("tessera::patch")
            .with_label(span, "a patch's height needs its colour layer")
            .with_help("give the sample the colour image as `image`"));
    }
    if let Some(span) = props.span("mask").filter(|_| props.get("height").is_none()) {
        return Err(Diagnostic::error(format!("sample `{}` has a mask layer but no `height`", d.name))
            .with_code("tessera::patch")
            .with_label(span, "a mask belongs to a patch")
            .with_help("give the sample its `height` layer, or remove the mask"));
    }
    Ok(())
}

/// Plans the patch stage of a sample with a `height`; records it as the part `patch`.
pub(super) fn plan(p: &mut Planner, d: &Decl, image: Handle<Image>, geometry: Prepare) -> Result<(), Diagnostic> {
    let props = &d.props;
    let Some(height) = props.path("height") else { return Ok(()) };
    let mut files = vec![(height.clone(), props.span("height").unwrap_or(d.name_span))];
    if let Some(mask) = props.path("mask") {
        files.push((mask.clone(), props.span("mask").unwrap_or(d.name_span)));
    }
    let mut inputs = Inputs::new();
    let colour = inputs.add(image);
    let layers = Layers { colour, geometry, mask: files.len() == 2 };
    let stage = FnStage::keyed("sample.patch", 1, layers, patch);
    let node = p.add(format!("sample {} (patch)", d.name), stage, inputs, files);
    p.set_part(d, "patch", node);
    Ok(())
}

/// The patch of `name`, or a diagnostic at `at` when the sample has no height layer.
pub fn patch_of(p: &Planner, name: &str, at: crate::lang::source::Span) -> Result<Handle<Image>, Diagnostic> {
    p.part::<Image>(name, "patch").ok_or_else(|| {
        Diagnostic::error(format!("`{name}` is not a patch: it has no height layer"))
            .with_code("tessera::patch")
            .with_label(at, "a patch is needed here")
            .with_help(format!("give sample `{name}` a `height = \"…\"` image of its size"))
    })
}

/// What the patch stage works from: the colour image, how the sample's files are cropped and
/// resized, and whether a mask file follows the height file.
#[derive(serde::Serialize)]
struct Layers {
    colour: In<Image>,
    geometry: Prepare,
    mask: bool,
}

fn patch(cx: &RunCx, l: &Layers) -> Result<Image, StageError> {
    let colour = cx.get(l.colour);
    let (w, h) = (colour.width, colour.height);
    let grey = |file: usize, prop: &'static str| -> Result<Image, StageError> {
        let img = super::super::decode_image(&cx.file(file)?, cx.budget())
            .map_err(|e| StageError::new(format!("cannot decode the {prop} layer: {e}")).in_file(file))?;
        if img.data.iter().any(|v| !v.is_finite()) {
            return Err(StageError::new(format!("the {prop} layer holds NaN or infinite values")).in_file(file));
        }
        let img = l.geometry.geometry(img, file)?;
        if (img.width, img.height) != (w, h) {
            return Err(StageError::new(format!(
                "the {prop} layer is {}x{} but the colour image is {w}x{h}: a patch's layers are pixel-aligned",
                img.width, img.height
            ))
            .at_prop(prop)
            .with_help("draw every layer of a patch at the colour image's size"));
        }
        // A grey file; RGB(A) is read as the mean of its colour channels.
        let used = if img.channels >= 3 { 3 } else { 1 };
        Ok(Image::from_fn(w, h, 1, |x, y, _| (0..used).map(|c| img.get(x, y, c)).sum::<f32>() / used as f32))
    };
    let height = grey(0, "height")?;
    let mask = if l.mask { Some(grey(1, "mask")?) } else { None };
    let rgb = |x: usize, y: usize, c: usize| match colour.channels {
        1 | 2 => colour.get(x, y, 0),
        _ => colour.get(x, y, c),
    };
    Ok(Image::from_fn(w, h, 5, |x, y, c| match c {
        0..=2 => rgb(x, y, c),
        HEIGHT => height.get(x, y, 0),
        _ => mask.as_ref().map_or(0.0, |m| if m.get(x, y, 0) > 0.5 { 1.0 } else { 0.0 }),
    }))
}
