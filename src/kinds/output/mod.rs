//! `output "file" { from = ... }`: encodes a result to a file's bytes. The bytes are a
//! cached artifact; writing them to disk (atomically, only when changed) is the driver's job.

use super::{Bytes, ColorSpace, FnStage, Planner};
use crate::graph::{AnyHandle, Handle, In, Inputs, NodeId, StageError};
use crate::lang::schema::{Default, Extent, KindSpec, Naming, PropSpec, Range, Ty, Unit, Value, ANY, POSITIVE, UNIT};
use crate::lang::source::Span;
use crate::lang::{Decl, Diagnostic};
use crate::raster::{self, Image};
use crate::synth::relight::ptm_file::PtmFormat;
use crate::synth::surface::Plane;

pub static SPEC: KindSpec = KindSpec {
    name: "output",
    doc: "Writes a result to a file under the output directory (`out/<scene>/<name>`), checked against `golden/<scene>/<name>` by `tessera check`. The name is a relative path without `..`; a scene's outputs are written all at once or not at all.",
    naming: Naming::Path,
    produces: &[],
    settings: &[],
    extent: Extent::None,
    props: &[
        PropSpec {
            name: "from",
            ty: Ty::Ref(&[Value::Map, Value::Image, Value::Plane, Value::Structure, Value::Model, Value::Procedural, Value::Match, Value::Transform]),
            default: Default::Required,
            doc: "What to write. Maps are written as data; 2-channel orientation fields as RGB (x, y → R, G); samples and layers in sRGB (EXR: linear); surfaces as their occupancy; structures as `view` says. A `.json` output of a sample chosen by `similar(...)` writes the ranking.",
        },
        PropSpec {
            name: "view",
            ty: Ty::Enum(VIEWS.names),
            default: Default::Text("auto"),
            doc: "For structures: `labels` (a colour per region), `labels16` (region ids in a 16-bit PNG), `edges`, `ellipses` (over the labels), `distance` (to each region's generator), `closest` (associated original shapes), `mesh` (JSON), `svg`, `stats` (JSON report against the sample). `auto`: `mesh` for .json, `svg` for .svg, `labels` for images. For quilted layers: `seams` (the block seams) and `index` (where each pixel came from: sample x → red, y → green). For appearances: `albedo`, `alpha` (the render's coverage), `unified` (the unified textures), `interstices` and `junctions` (the atlases), `guides`, `clusters` (the sample's regions in their cluster's colour), and `cluster_table` (JSON: each region's cluster, as `keep_clusters` reads it; the `auto` view of a `.json` file). For representations and layers quilted from them: `auto` (relit at `light`), `albedo`, `normal` (tangent-space normal map), `height` (integrated from the gradients: Frankot–Chellappa on tileable layers, least squares otherwise; EXR keeps pixel units, PNG stretches to the full range), `maps` (the representation's channels, EXR only; for a layer grown under an orientation field rewritten into the image frame, which 3I, Gradient and PTM allow and Eigen does not) and, for representations, `report` (JSON: the η relighting error).",
        },
        PropSpec {
            name: "light",
            ty: Ty::Source { calls: crate::kinds::sample::capture::LIGHT, refs: &[] },
            default: Default::Absent,
            doc: "For relightable sources: the light of the relit image. Default `light(tilt = 0 deg, slant = 45 deg)`.",
        },
        PropSpec {
            name: "azimuth",
            ty: Ty::Number(Unit::Angle, ANY),
            default: Default::Text("30 deg"),
            doc: "Renders of a model: the camera's direction about the vertical (+y), from +z towards +x. The camera frames the whole model.",
        },
        PropSpec {
            name: "elevation",
            ty: Ty::Number(Unit::Angle, Range { min: -std::f64::consts::FRAC_PI_2, max: std::f64::consts::FRAC_PI_2 }),
            default: Default::Text("20 deg"),
            doc: "Renders of a model: the camera's height above the horizontal, −90° to 90°.",
        },
        PropSpec {
            name: "resolution",
            ty: Ty::Size,
            default: Default::Text("512 x 512"),
            doc: "Renders of a model: the image size. The model's `light` is a distant light, its slant from the vertical and its tilt about it like `azimuth`.",
        },
        PropSpec {
            name: "shadows",
            ty: Ty::Bool,
            default: Default::Text("false"),
            doc: "Renders of a model: cast shadows (a shadow map per light).",
        },
        PropSpec {
            name: "normals",
            ty: Ty::Enum(GREENS.names),
            default: Default::Text("opengl"),
            doc: "Green channel of `normal` views: `opengl` (+Y up: Blender, glTF) or `directx` (+Y down: Unreal).",
        },
        PropSpec {
            name: "edge_width",
            ty: Ty::Number(Unit::Length, POSITIVE),
            default: Default::Text("1 px"),
            doc: "Line width of `edges` and `svg` views.",
        },
        PropSpec {
            name: "format",
            ty: Ty::Enum(FORMATS.names),
            default: Default::Text("auto"),
            doc: "File format; `auto` picks from the extension (`.png` → 8-bit PNG, `.exr` → 32-bit float EXR, `.ptm` → `ptm_lrgb`). `.ptm` files are PTM 1.2 as RTI viewers read them, of a representation fitted with `method = ptm` or a layer quilted from one: `ptm_lrgb` (six luminance coefficients and an RGB colour per pixel) or `ptm_rgb` (six coefficients per colour channel).",
        },
        PropSpec {
            name: "tolerance",
            ty: Ty::Number(Unit::Fraction, UNIT),
            default: Default::Absent,
            doc: "Golden check: largest per-channel difference (in [0, 1] units) a pixel may have; default from tessera.toml. PNG outputs compare in whole code steps, this fraction rounded down (1/255 is one step of an 8-bit PNG, 257 of a 16-bit one). Identity views (`labels`, `labels16`, `index`, `cluster_table`) always compare exactly and refuse a tolerance.",
        },
        PropSpec {
            name: "outliers",
            ty: Ty::Number(Unit::Fraction, UNIT),
            default: Default::Text("0"),
            doc: "Golden check: fraction of pixels allowed beyond `tolerance`.",
        },
    ],
};

/// The output properties only renders of a model read.
const RENDER_PROPS: [&str; 4] = ["azimuth", "elevation", "resolution", "shadows"];

/// The `view` property: which view of its source an output writes. Which views a source
/// has is its kind's to say ([`Kind::plan_output`](super::Kind::plan_output)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum View {
    Auto,
    Labels,
    Labels16,
    Edges,
    Ellipses,
    Distance,
    Closest,
    Mesh,
    Svg,
    Stats,
    Seams,
    Index,
    Albedo,
    Alpha,
    Unified,
    Interstices,
    Junctions,
    Guides,
    Clusters,
    ClusterTable,
    Normal,
    Height,
    Maps,
    Report,
}

crate::choices!(
    /// The `view` property of outputs.
    pub VIEWS: View {
        "auto" => View::Auto, "labels" => View::Labels, "labels16" => View::Labels16, "edges" => View::Edges,
        "ellipses" => View::Ellipses, "distance" => View::Distance, "closest" => View::Closest,
        "mesh" => View::Mesh, "svg" => View::Svg, "stats" => View::Stats, "seams" => View::Seams,
        "index" => View::Index, "albedo" => View::Albedo, "alpha" => View::Alpha, "unified" => View::Unified,
        "interstices" => View::Interstices, "junctions" => View::Junctions, "guides" => View::Guides,
        "clusters" => View::Clusters, "cluster_table" => View::ClusterTable, "normal" => View::Normal,
        "height" => View::Height, "maps" => View::Maps, "report" => View::Report,
    }
);

crate::choices!(
    /// `normals`: the green channel's convention of normal maps.
    pub GREENS: crate::synth::relight::export::GreenAxis {
        "opengl" => crate::synth::relight::export::GreenAxis::OpenGl,
        "directx" => crate::synth::relight::export::GreenAxis::DirectX
    }
);

/// The `format` property as written: a format, or the one the extension implies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Auto,
    Png8,
    Png16,
    Exr,
    PtmLrgb,
    PtmRgb,
}

crate::choices!(FORMATS: Format {
    "auto" => Format::Auto, "png8" => Format::Png8, "png16" => Format::Png16, "exr" => Format::Exr,
    "ptm_lrgb" => Format::PtmLrgb, "ptm_rgb" => Format::PtmRgb
});

#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum OutputFormat {
    Png8,
    Png16,
    Exr,
    Json,
    Svg,
    /// A PTM 1.2 file (relightable surfaces fitted by PTM).
    Ptm(PtmFormat),
    /// Wavefront OBJ text (models).
    Obj,
    /// glTF 2.0 binary (models).
    Glb,
    /// TOML text (a procedural texture's parameters, a match record).
    Toml,
    /// A tessera scene declaration (a match as a `shader`).
    Tess,
}

impl OutputFormat {
    /// Text formats are compared number by number, not pixel by pixel.
    pub fn is_text(self) -> bool {
        matches!(
            self,
            OutputFormat::Json | OutputFormat::Svg | OutputFormat::Obj | OutputFormat::Toml | OutputFormat::Tess
        )
    }
}

#[derive(Clone, Debug)]
pub struct PlannedOutput {
    /// The path under the scene's output directory, normalised: two outputs are one file
    /// exactly when their names are equal.
    pub name: String,
    pub node: NodeId,
    pub format: OutputFormat,
    /// Its values are identities (region ids, label colours, source coordinates): the golden
    /// check compares them exactly, whatever the tolerance.
    pub exact: bool,
    pub tolerance: Option<f64>,
    pub outliers: f64,
    pub span: Span,
}

/// What an encode stage works from.
#[derive(serde::Serialize)]
struct Encoding {
    format: OutputFormat,
    pixels: Pixels,
}

fn encode(cx: &crate::graph::RunCx, &Encoding { format, pixels }: &Encoding) -> Result<Bytes, StageError> {
    let img: Image = match pixels {
        Pixels::Plane(plane) => cx.get(plane).occupancy.clone(),
        Pixels::Image { space, image } => to_file_space(&cx.get(image), space, format),
        Pixels::Data(map) => {
            let img = cx.get(map);
            if img.channels == 2 && format != OutputFormat::Exr {
                vector_view(&img)
            } else {
                (*img).clone()
            }
        }
    };
    encode_image(&img, format)
}

/// How the source's pixels become file pixels.
#[derive(Clone, Copy, serde::Serialize)]
#[serde(rename_all = "lowercase")]
enum Pixels {
    /// Values written as they are (maps; 2-channel fields as RGB).
    Data(In<Image>),
    /// An image in a colour space, converted to the file's (PNG: sRGB, EXR: linear).
    Image { space: ColorSpace, image: In<Image> },
    /// A surface's occupancy.
    Plane(In<Plane>),
}

pub fn plan(p: &mut Planner, d: &Decl) -> Result<Handle<Bytes>, Diagnostic> {
    let ext = std::path::Path::new(&d.name).extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let written = d.props.enumeration("format");
    let format = match (FORMATS.get(written), ext.as_str()) {
        (Format::Auto | Format::Png8, "png") => OutputFormat::Png8,
        (Format::Png16, "png") => OutputFormat::Png16,
        (Format::Auto | Format::Exr, "exr") => OutputFormat::Exr,
        (Format::Auto, "json") => OutputFormat::Json,
        (Format::Auto, "svg") => OutputFormat::Svg,
        (Format::Auto | Format::PtmLrgb, "ptm") => OutputFormat::Ptm(PtmFormat::Lrgb),
        (Format::PtmRgb, "ptm") => OutputFormat::Ptm(PtmFormat::Rgb),
        (Format::Auto, "obj") => OutputFormat::Obj,
        (Format::Auto, "glb") => OutputFormat::Glb,
        (Format::Auto, "toml") => OutputFormat::Toml,
        (Format::Auto, "tess") => OutputFormat::Tess,
        (f, e) => {
            let span = d.props.span("format").unwrap_or(d.name_span);
            return Err(Diagnostic::error(if f == Format::Auto {
                format!("tessera cannot write `.{e}` files")
            } else {
                format!("format `{written}` does not match the extension `.{e}`")
            })
            .with_code("tessera::output_format")
            .with_label(span, "here")
            .with_help(
                "outputs are `.png` (8- or 16-bit), `.exr`, `.json`, `.svg`, `.ptm`, `.obj`, `.glb`, `.toml` or `.tess` files",
            ));
        }
    };
    let name = crate::graph::files::normal_relative(&d.name).map_err(|problem| {
        Diagnostic::error(format!("`{}` cannot name an output: {problem}", d.name.escape_debug()))
            .with_code("tessera::output_name")
            .with_label(d.name_span, "here")
            .with_help("output names are relative paths inside the scene's output directory")
    })?;
    let name = name.to_string_lossy().into_owned();
    let from = d.props.reference("from").expect("required");
    let view = VIEWS.get(d.props.enumeration("view"));
    if matches!(format, OutputFormat::Ptm(_)) && !p.has_part(from, "relightable") {
        return Err(Diagnostic::error(format!(
            "`{from}` is not relightable: a `.ptm` file holds a surface fitted by PTM"
        ))
        .with_code("tessera::output_format")
        .with_label(d.props.span("from").unwrap_or(d.name_span), "not a representation")
        .with_help("write a `representation` with `method = ptm`, or a layer quilted from one"));
    }
    // What a model's reference yields is what only a model renders from.
    if !super::kind(p.decl(from).kind).spec().produces.contains(&Value::Model) {
        if let Some((key, span)) = RENDER_PROPS.iter().find_map(|k| Some((*k, d.props.span(k)?))) {
            return Err(Diagnostic::error(format!(
                "`{key}` applies to renders of a model, not to a {}",
                p.decl(from).kind
            ))
            .with_code("tessera::output_view")
            .with_label(span, "remove this")
            .with_help("`azimuth`, `elevation`, `resolution` and `shadows` place the camera of a `model`'s render"));
        }
    }
    let request = super::OutputRequest { decl: d, from, format, view, ext: &ext };
    if let Some(v) = super::kind(p.decl(from).kind).plan_output(p, &request)? {
        if v.more.is_empty() {
            p.outputs.push(planned(d, &name, v.node.node(), format, v.exact)?);
        }
        for (more, node) in &v.more {
            let more =
                crate::graph::files::normal_relative(more).expect("a frame name is the output's name with digits");
            p.outputs.push(planned(d, &more.to_string_lossy(), node.node(), format, v.exact)?);
        }
        return Ok(v.node);
    }
    let src = p.decl(from);
    request.refuse_views(format!("`view` applies to structures and layers, not to a {}", src.kind))?;
    if format.is_text() {
        return Err(Diagnostic::error(format!("a {} is written as an image, not as `.{ext}`", src.kind))
            .with_code("tessera::output_format")
            .with_label(d.name_span, "use `.png` or `.exr`"));
    }
    // The generic views, by what the source exports.
    let exports = p.exports(from);
    let at = d.props.span("from").unwrap_or(d.name_span);
    let mut inputs = Inputs::new();
    let pixels = match (exports.image, exports.plane) {
        (Some(space), _) => Pixels::Image { space, image: inputs.add(p.value(from, at)?) },
        (None, Some(_)) => Pixels::Plane(inputs.add(p.value(from, at)?)),
        (None, None) => Pixels::Data(inputs.add(p.value(from, at)?)),
    };
    let stage = FnStage::keyed("output.encode", 3, Encoding { format, pixels }, encode);
    let node = p.add(format!("output {}", d.name), stage, inputs, vec![]);
    p.outputs.push(planned(d, &name, node.node(), format, false)?);
    Ok(node)
}

fn planned(d: &Decl, name: &str, node: NodeId, format: OutputFormat, exact: bool) -> Result<PlannedOutput, Diagnostic> {
    for prop in ["tolerance", "outliers"] {
        if let (true, Some(span)) = (exact, d.props.span(prop)) {
            return Err(Diagnostic::error(format!(
                "`{name}` holds identities (region ids, labels, source positions): it is compared exactly"
            ))
            .with_code("tessera::output_exact")
            .with_label(span, "a tolerance does not apply here")
            .with_help("an id off by one is a different region; remove this property"));
        }
    }
    Ok(PlannedOutput {
        name: name.to_string(),
        node,
        format,
        exact,
        tolerance: d.props.opt_num("tolerance"),
        outliers: d.props.num("outliers"),
        span: d.name_span,
    })
}

/// Encodes an image output in the output's (image) format.
pub(crate) fn encode_image(img: &Image, format: OutputFormat) -> Result<Bytes, StageError> {
    match format {
        OutputFormat::Png8 => raster::io::encode_png(img, 8),
        OutputFormat::Png16 => raster::io::encode_png(img, 16),
        OutputFormat::Exr => raster::io::encode_exr(img),
        OutputFormat::Json
        | OutputFormat::Svg
        | OutputFormat::Ptm(_)
        | OutputFormat::Obj
        | OutputFormat::Glb
        | OutputFormat::Toml
        | OutputFormat::Tess => {
            return Err(StageError::new("this output is not an image file: name it `.png` or `.exr`"))
        }
    }
    .map(Bytes)
    .map_err(|e| StageError::new(format!("cannot encode the output: {e}")))
}

/// Images are stored in their declared colour space; PNGs hold sRGB and EXRs linear.
pub(crate) fn to_file_space(img: &Image, space: ColorSpace, format: OutputFormat) -> Image {
    let linear = match space {
        ColorSpace::Linear => img.clone(),
        ColorSpace::Srgb => raster::color::image_srgb_to_linear(img),
        ColorSpace::Lab => raster::color::image_lab_to_linear(img),
    };
    match format {
        OutputFormat::Exr => linear,
        _ => raster::color::image_linear_to_srgb(&linear),
    }
}

/// An orientation field as a viewable picture: x → red, y → green, mid-grey blue.
fn vector_view(img: &Image) -> Image {
    Image::from_fn(img.width, img.height, 3, |x, y, c| match c {
        0 | 1 => 0.5 + 0.5 * img.get(x, y, c),
        _ => 0.5,
    })
}

/// The output kind: writes a view of another declaration to a file.
pub struct Output;

impl super::Kind for Output {
    fn spec(&self) -> &'static KindSpec {
        &SPEC
    }

    fn plan(&self, p: &mut Planner, d: &Decl) -> Result<Option<AnyHandle>, Diagnostic> {
        plan(p, d).map(|h| Some(h.erase()))
    }
}
