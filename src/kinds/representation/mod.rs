//! `representation`: a relightable surface fitted to a photometric capture
//! [references: dong §4.4], and the views every relightable surface shares (a representation,
//! or a layer quilted from one): relit images, maps, albedo, normals, height, and the η report.
//!
//! Used as an image, a representation is its maps (so a layer can quilt them, channel for
//! channel); the layer then relights what it grew ([`plan_relit_layer`]).

mod codecs;

pub use codecs::{Fitted, Relightable};

use super::output::{OutputFormat, View, GREENS, VIEWS};
use super::sample::capture::Capture;
use super::{Bytes, FnStage, Planner};
use crate::graph::{AnyHandle, Handle, In, Inputs, RunCx, StageError};
use crate::lang::ir::Call;
use crate::lang::schema::{Default, Extent, KindSpec, Naming, PropSpec, Ty, Value};
use crate::lang::{Decl, Diagnostic};
use crate::raster::Image;
use crate::synth::quilt::QuiltResult;
use crate::synth::relight::ptm_file::{self, PtmFormat};
use crate::synth::relight::{self, export, height, Basis, Light, Method, PhotoStack, RelightError};

/// `method`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum MethodChoice {
    ThreeI,
    Gradient,
    Ptm,
    Eigen,
}

crate::choices!(METHODS: MethodChoice {
    "three_i" => MethodChoice::ThreeI, "gradient" => MethodChoice::Gradient, "ptm" => MethodChoice::Ptm,
    "eigen" => MethodChoice::Eigen
});

pub static SPEC: KindSpec = KindSpec {
    name: "representation",
    doc: "A relightable surface fitted to a photometric capture (Dong ch. 4): a few maps per pixel and a relight basis, so that the surface can be relit at any light. A layer can quilt it (`layer { quilt = … }`, every map cut and pasted together) and outputs write it relit (`light`), or as `albedo`, `normal`, `height`, `maps` (EXR) and `report` (JSON: the η relighting error in reconstruction and leave-one-out modes, f_indi and f_cumu).",
    naming: Naming::Ident,
    produces: &[Value::Image],
    settings: &[],
    extent: Extent::None,
    props: &[
        PropSpec { name: "from", ty: Ty::Ref(&[Value::Capture]), default: Default::Required, doc: "The photometric capture (a sample with `images` + `lights` or `capture`)." },
        PropSpec {
            name: "method",
            ty: Ty::Enum(METHODS.names),
            default: Default::Text("gradient"),
            doc: "`three_i`: three of the images, relit by `L₃⁻¹ l` (the three closest to slant 45°, tilts 0°, 90°, 180°); `gradient`: photometric stereo (p, q, albedo), relit by Lambert's law; `ptm`: six polynomial coefficients in (l_x, l_y); `eigen`: the first `components` eigen images, their coefficients interpolated bilinearly on the capture's (tilt, slant) grid.",
        },
        PropSpec {
            name: "components",
            ty: Ty::Int(1, 64),
            default: Default::Text("3"),
            doc: "With `method = eigen`: how many eigen images (3 = Eigen3, 6 = Eigen6); at most the number of images.",
        },
    ],
};

/// The representation kind.
pub struct Representation;

impl super::Kind for Representation {
    fn spec(&self) -> &'static KindSpec {
        &SPEC
    }

    fn plan(&self, p: &mut Planner, d: &Decl) -> Result<Option<AnyHandle>, Diagnostic> {
        let capture_name = d.props.reference("from").expect("required");
        let mut inputs = Inputs::new();
        let capture = inputs.add(p.result::<Capture>(capture_name));
        let method = match METHODS.get(d.props.enumeration("method")) {
            MethodChoice::ThreeI => Method::ThreeI,
            MethodChoice::Gradient => Method::Gradient,
            MethodChoice::Ptm => Method::Ptm,
            MethodChoice::Eigen => Method::Eigen(d.props.int("components") as usize),
        };
        if d.props.span("components").is_some() && !matches!(method, Method::Eigen(_)) {
            return Err(Diagnostic::error("`components` applies to `method = eigen` only")
                .with_code("tessera::representation")
                .with_label(d.props.span("components").unwrap_or(d.name_span), "remove this"));
        }
        let stage = FnStage::keyed("representation.fit", 1, Fitting { capture, method }, fit);
        let fitted = p.add(format!("representation {} (fit)", d.name), stage, inputs, vec![]);
        p.set_part(d, "fit", fitted);
        p.set_part(d, "capture", p.result::<Capture>(capture_name));
        let mut inputs = Inputs::new();
        let f = inputs.add(fitted);
        let stage = FnStage::keyed("representation.relightable", 2, f, |cx, &f| Ok(cx.get(f).relightable()));
        let surface = p.add(format!("representation {} (relightable)", d.name), stage, inputs, vec![]);
        p.set_part(d, "relightable", surface);
        let mut inputs = Inputs::new();
        let f = inputs.add(fitted);
        let stage = FnStage::keyed("representation.maps", 1, f, |cx, &f| Ok(cx.get(f).maps_image()));
        let maps = p.add(format!("representation {}", d.name), stage, inputs, vec![]);
        p.export(d).image = Some(super::ColorSpace::Linear);
        Ok(Some(maps.erase()))
    }

    fn plan_output(&self, p: &mut Planner, out: &super::OutputRequest) -> Result<Option<super::ViewNode>, Diagnostic> {
        if out.view == View::Report {
            return plan_report(p, out).map(Some);
        }
        let surface = p.part::<Relightable>(out.from, "relightable").expect("planned with its parts");
        plan_view(p, out, surface).map(Some)
    }
}

#[derive(serde::Serialize)]
struct Fitting {
    capture: In<Capture>,
    method: Method,
}

/// The capture as the algorithms take it: f64 luminance planes (and chromaticity for colour).
fn stack_of(c: &Capture) -> Result<PhotoStack, StageError> {
    let first = c.images.first().ok_or_else(|| StageError::new("the capture has no images"))?;
    let (w, h) = (first.width, first.height);
    let lights: Vec<Light> = c.lights.iter().map(|&[tilt, slant]| Light::new(tilt, slant)).collect();
    let planes: Vec<Vec<f64>> = c.images.iter().map(|img| img.data.iter().map(|&v| f64::from(v)).collect()).collect();
    let stack = if first.channels == 3 {
        PhotoStack::from_rgb(w, h, &planes, lights)
    } else {
        PhotoStack::new(w, h, planes, lights)
    };
    stack.map_err(|e| relight_error(e, "from"))
}

/// A relighting error pointed at the property that can fix it (`fallback` otherwise).
fn relight_error(e: RelightError, fallback: &'static str) -> StageError {
    let prop = match &e {
        RelightError::EigenRank { .. } => "components",
        RelightError::Degenerate { .. } | RelightError::SingleSlant { .. } | RelightError::NoTriple { .. } => "method",
        RelightError::TooFewImages { .. } => "method",
        _ => fallback,
    };
    let help = match &e {
        RelightError::SingleSlant { .. } => Some("capture at two or more slants, or use `method = gradient`"),
        RelightError::Degenerate { .. } => Some("the lights must not lie in one plane through the surface"),
        RelightError::SlantOutsideGrid { .. } => Some("Eigen relights only between the slants it was captured at"),
        _ => None,
    };
    let err = StageError::new(e.to_string()).at_prop(prop);
    match help {
        Some(h) => err.with_help(h),
        None => err,
    }
}

/// [`relight_error`], where a surface grown under an orientation field cannot rewrite its maps.
fn rotation_error(e: RelightError, fallback: &'static str) -> StageError {
    if e == RelightError::NoRotation {
        return StageError::new(format!("this layer was grown under an orientation field: {e}"))
            .at_prop(fallback)
            .with_help("write the relit, `normal`, `height` or `albedo` views, which relight each pixel in its own frame, or fit `method = ptm` or `gradient`");
    }
    relight_error(e, fallback)
}

fn fit(cx: &RunCx, f: &Fitting) -> Result<Fitted, StageError> {
    let stack = stack_of(&cx.get(f.capture))?;
    let rep = relight::extract(&stack, f.method).map_err(|e| relight_error(e, "from"))?;
    Ok(Fitted(rep))
}

/// The η report of the representation's method on its capture, reconstruction and
/// leave-one-out.
fn plan_report(p: &mut Planner, out: &super::OutputRequest) -> Result<super::ViewNode, Diagnostic> {
    if out.format != OutputFormat::Json {
        return Err(view_error(out, "the `report` view is JSON: name the output `….json`"));
    }
    let capture = p.part::<Capture>(out.from, "capture").expect("planned with its parts");
    let fitted = p.part::<Fitted>(out.from, "fit").expect("planned with its parts");
    let mut inputs = Inputs::new();
    let reporting = Reporting { capture: inputs.add(capture), fitted: inputs.add(fitted) };
    let stage = FnStage::keyed("representation.report", 1, reporting, report);
    let node = p.add(format!("output {}", out.decl.name), stage, inputs, vec![]);
    Ok(super::ViewNode { node, exact: false, more: Vec::new() })
}

#[derive(serde::Serialize)]
struct Reporting {
    capture: In<Capture>,
    fitted: In<Fitted>,
}

fn report(cx: &RunCx, r: &Reporting) -> Result<Bytes, StageError> {
    let stack = stack_of(&cx.get(r.capture))?;
    let method = cx.get(r.fitted).0.method;
    let eval = relight::evaluate::evaluate(&stack, &[method], stack.len() > 3).map_err(|e| relight_error(e, "from"))?;
    let mut text = serde_json::to_string_pretty(&eval).map_err(|e| StageError::new(e.to_string()))?;
    text.push('\n');
    Ok(Bytes(text.into_bytes()))
}

fn view_error(out: &super::OutputRequest, msg: &str) -> Diagnostic {
    Diagnostic::error(msg.to_string())
        .with_code("tessera::output_view")
        .with_label(out.decl.props.span("view").unwrap_or(out.decl.name_span), "here")
        .with_help("a relightable surface's views are `auto` (relit at `light`), `albedo`, `normal`, `height`, `maps` and, for representations, `report`")
}

/// The light a declaration asks for: its `light(...)`, or tilt 0°, slant 45°.
fn light_in(props: &crate::lang::Props) -> Light {
    match props.get("light") {
        Some(crate::lang::Val::Call(c)) => light_call(c),
        _ => Light::new(0.0, 45.0),
    }
}

/// A `light(tilt, slant)` call as a light.
pub fn light_call(c: &Call) -> Light {
    let [tilt, slant] = super::sample::capture::degrees(c.args.num("tilt"), c.args.num("slant"));
    Light::new(tilt, slant)
}

/// The views of a relightable surface.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
enum Look {
    Relit,
    Albedo,
    Normal(export::GreenAxis),
    Height,
    Maps,
}

#[derive(serde::Serialize)]
struct Viewing {
    surface: In<Relightable>,
    look: Look,
    light: [f64; 2],
    format: OutputFormat,
}

/// Plans `out`, a view of the relightable `surface`.
pub fn plan_view(
    p: &mut Planner,
    out: &super::OutputRequest,
    surface: Handle<Relightable>,
) -> Result<super::ViewNode, Diagnostic> {
    if out.format.is_text() {
        return Err(view_error(out, &format!("a relightable surface is written as an image, not as `.{}`", out.ext)));
    }
    if let OutputFormat::Ptm(format) = out.format {
        return plan_ptm(p, out, surface, format);
    }
    let look = match out.view {
        View::Auto => Look::Relit,
        View::Albedo => Look::Albedo,
        View::Normal => Look::Normal(GREENS.get(out.decl.props.enumeration("normals"))),
        View::Height => Look::Height,
        View::Maps => Look::Maps,
        v => return Err(view_error(out, &format!("a relightable surface has no `{}` view", VIEWS.name(v)))),
    };
    if out.decl.props.span("light").is_some() && look != Look::Relit {
        return Err(Diagnostic::error("`light` applies to the relit view (`view = auto`)")
            .with_code("tessera::output_view")
            .with_label(out.decl.props.span("light").unwrap_or(out.decl.name_span), "remove this"));
    }
    let light = light_in(&out.decl.props);
    let mut inputs = Inputs::new();
    let viewing =
        Viewing { surface: inputs.add(surface), look, light: [light.tilt_deg, light.slant_deg], format: out.format };
    let stage = FnStage::keyed("output.relightable", 1, viewing, draw);
    let node = p.add(format!("output {}", out.decl.name), stage, inputs, vec![]);
    Ok(super::ViewNode { node, exact: false, more: Vec::new() })
}

/// The method of the representation behind `name`: a representation, or a layer quilted from
/// one (however many layers deep).
fn method_behind(p: &Planner, name: &str) -> Option<MethodChoice> {
    let mut name = name;
    for _ in 0..=p.scene.decls.len() {
        let d = p.decl(name);
        if p.has_part(name, "fit") {
            return Some(METHODS.get(d.props.enumeration("method")));
        }
        name = d.props.reference("quilt")?;
    }
    None
}

/// A PTM 1.2 file of a surface fitted by PTM.
fn plan_ptm(
    p: &mut Planner,
    out: &super::OutputRequest,
    surface: Handle<Relightable>,
    format: PtmFormat,
) -> Result<super::ViewNode, Diagnostic> {
    if out.view != View::Auto {
        return Err(view_error(out, "a `.ptm` file holds the relightable surface itself: remove `view`"));
    }
    for prop in ["light", "normals"] {
        if let Some(span) = out.decl.props.span(prop) {
            return Err(Diagnostic::error(format!(
                "`{prop}` does not apply to a `.ptm` file: the viewer chooses the light"
            ))
            .with_code("tessera::output_view")
            .with_label(span, "remove this"));
        }
    }
    if let Some(m) = method_behind(p, out.from).filter(|&m| m != MethodChoice::Ptm) {
        return Err(Diagnostic::error(format!(
            "a `.ptm` file holds PTM coefficients, but `{}` is fitted with `method = {}`",
            out.from,
            METHODS.name(m)
        ))
        .with_code("tessera::output_format")
        .with_label(out.decl.props.span("from").unwrap_or(out.decl.name_span), "not a PTM surface")
        .with_help("fit the representation with `method = ptm`, or write this surface as `.exr` / `.png`"));
    }
    let mut inputs = Inputs::new();
    let writing = PtmWriting { surface: inputs.add(surface), format };
    let stage = FnStage::keyed("output.ptm", 1, writing, write_ptm);
    let node = p.add(format!("output {}", out.decl.name), stage, inputs, vec![]);
    Ok(super::ViewNode { node, exact: false, more: Vec::new() })
}

#[derive(serde::Serialize)]
struct PtmWriting {
    surface: In<Relightable>,
    format: PtmFormat,
}

fn write_ptm(cx: &RunCx, w: &PtmWriting) -> Result<Bytes, StageError> {
    let s = cx.get(w.surface);
    if s.basis != Basis::Ptm {
        return Err(StageError::new(
            "a `.ptm` file holds PTM coefficients: fit the representation with `method = ptm`",
        )
        .at_prop("from"));
    }
    let maps = s.framed_maps().map_err(|e| rotation_error(e, "from"))?;
    let planes: Vec<f64> = maps.data.iter().map(|&v| f64::from(v)).collect();
    let chroma = s.chroma_planes();
    ptm_file::write_ptm(maps.width, maps.height, &planes, chroma.as_deref(), w.format)
        .map(Bytes)
        .map_err(|e| relight_error(e, "from"))
}

fn draw(cx: &RunCx, v: &Viewing) -> Result<Bytes, StageError> {
    let s = cx.get(v.surface);
    let img = match v.look {
        Look::Relit => {
            let light = Light::new(v.light[0], v.light[1]);
            let lit = s.relit(&light).map_err(|e| relight_error(e, "light"))?;
            super::output::to_file_space(&lit, super::ColorSpace::Linear, v.format)
        }
        Look::Albedo => {
            let (_, _, al) = s.gradients().map_err(|e| relight_error(e, "from"))?;
            let img = export::albedo_image(&al, s.chroma_planes().as_deref(), s.maps.width, s.maps.height);
            super::output::to_file_space(&img, super::ColorSpace::Linear, v.format)
        }
        Look::Normal(green) => {
            let (pp, q, _) = s.gradients().map_err(|e| relight_error(e, "from"))?;
            export::normal_map(&pp, &q, s.maps.width, s.maps.height, green)
        }
        Look::Height => {
            let (pp, q, _) = s.gradients().map_err(|e| relight_error(e, "from"))?;
            let (w, h) = (s.maps.width, s.maps.height);
            let z = if s.periodic {
                height::frankot_chellappa(&pp, &q, w, h)
            } else {
                height::integrate_least_squares(&pp, &q, w, h)
            };
            let plane = export::plane_image(&z, w, h);
            if v.format == OutputFormat::Exr {
                plane
            } else {
                normalised(&plane)
            }
        }
        Look::Maps => {
            if v.format != OutputFormat::Exr {
                return Err(StageError::new("the `maps` view holds signed values: write it as `.exr`").at_prop("view"));
            }
            (*s.framed_maps().map_err(|e| rotation_error(e, "view"))?).clone()
        }
    };
    super::output::encode_image(&img, v.format)
}

/// A plane stretched to [0, 1] for an 8/16-bit file (EXR keeps the heights in pixels).
fn normalised(img: &Image) -> Image {
    let (lo, hi) = img.data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    let span = (hi - lo).max(f32::MIN_POSITIVE);
    Image { data: img.data.iter().map(|&v| (v - lo) / span).collect(), ..img.clone() }
}

/// A layer quilted from a representation: its relightable surface (the quilted maps with the
/// representation's basis, the chromaticity gathered through the same index map) and its
/// image, relit at the layer's `light`.
pub fn plan_relit_layer(
    p: &mut Planner,
    d: &Decl,
    rep: &str,
    quilt: Handle<QuiltResult>,
    maps: Handle<Image>,
) -> Result<Handle<Image>, Diagnostic> {
    let fitted = p.part::<Fitted>(rep, "fit").expect("planned with its parts");
    let mut inputs = Inputs::new();
    let growing = Growing {
        fitted: inputs.add(fitted),
        quilt: inputs.add(quilt),
        maps: inputs.add(maps),
        tileable: d.props.bool("tileable"),
        block: d.props.pixels("block"),
        overlap: d.props.opt_pixels("overlap").unwrap_or(crate::synth::quilt::default_overlap(d.props.pixels("block"))),
    };
    let stage = FnStage::keyed("layer.relightable", 2, growing, grow);
    let surface = p.add(format!("layer {} (relightable)", d.name), stage, inputs, vec![]);
    p.set_part(d, "relightable", surface);
    let light = light_in(&d.props);
    let mut inputs = Inputs::new();
    let lighting = Lighting { surface: inputs.add(surface), light: [light.tilt_deg, light.slant_deg] };
    let stage = FnStage::keyed("layer.relit", 1, lighting, |cx, l| {
        cx.get(l.surface).relit(&Light::new(l.light[0], l.light[1])).map_err(|e| relight_error(e, "light"))
    });
    Ok(p.add(format!("layer {}", d.name), stage, inputs, vec![]))
}

#[derive(serde::Serialize)]
struct Growing {
    fitted: In<Fitted>,
    quilt: In<QuiltResult>,
    maps: In<Image>,
    tileable: bool,
    block: usize,
    overlap: usize,
}

#[derive(serde::Serialize)]
struct Lighting {
    surface: In<Relightable>,
    light: [f64; 2],
}

fn grow(cx: &RunCx, g: &Growing) -> Result<Relightable, StageError> {
    if g.overlap * 6 < g.block || g.overlap * 3 > g.block {
        cx.warn(format!(
            "the overlap ({} px) is outside 1/6–1/3 of the block ({} px): too small or too large an overlap leaves discontinuities in relit stochastic surfaces (Dong §5.4)",
            g.overlap, g.block
        ));
    }
    let fitted = cx.get(g.fitted);
    let quilt = cx.get(g.quilt);
    let maps = cx.get(g.maps);
    let chroma = match fitted.0.chroma_image() {
        Some(c) => Some(crate::synth::quilt::gather(&quilt, &c).map_err(|e| StageError::new(e.to_string()))?),
        None => None,
    };
    Ok(Relightable {
        maps: std::sync::Arc::new((*maps).clone()),
        chroma,
        basis: fitted.0.basis.clone(),
        periodic: g.tileable,
        angles: quilt.rotated().then(|| quilt.angle_map()),
    })
}

/// Whether a declaration named as a layer's `quilt` is a representation.
pub fn is_representation(p: &Planner, name: &str) -> bool {
    p.part::<Fitted>(name, "fit").is_some()
}
