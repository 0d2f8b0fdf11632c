//! The views an `output` may write of a structure: labels (colour and 16-bit ids), edges,
//! ellipses, distance, closest shapes, the mesh as JSON or SVG, and the statistics report.
//! The pixels are drawn by `synth::structure::render`; this module wires them to stages.

use super::super::output::{encode_image, View, VIEWS};
use super::super::{Bytes, FnStage, OutputFormat, Planner};
use super::codecs::{Relaxed, Shaped};
use super::metric_kind;
use crate::graph::{Handle, In, Inputs, RunCx, StageError};
use crate::lang::{Decl, Diagnostic};
use crate::synth::structure::analysis::labels_import::rasterize_polygons;
use crate::synth::structure::analysis::report;
use crate::synth::structure::analysis::sample::{analyse_subdivision, SampleStructure};
use crate::synth::structure::mesh::faces::mesh_to_subdivision;
use crate::synth::structure::relaxation::metric::MetricKind;
use crate::synth::structure::{render, Mesh, Point};

/// The file a view is written to.
#[derive(Clone, Copy, PartialEq)]
enum Wants {
    Json,
    Svg,
    Png16,
    Image,
}

/// What a view stage draws, in what size and format, from which inputs. The structure's
/// size is its surface's, fixed when planned: mesh views need not load the label raster
/// to learn it.
#[derive(serde::Serialize)]
struct Drawing<I> {
    view: View,
    format: OutputFormat,
    edge_width: f64,
    w: usize,
    h: usize,
    input: I,
}

/// The stage writing one view of a structure to an output file.
pub fn plan_output(
    p: &mut Planner,
    d: &Decl,
    structure: &str,
    format: OutputFormat,
    view: View,
    edge_width: f64,
) -> Result<Handle<Bytes>, Diagnostic> {
    let view = match (view, format) {
        (View::Auto, OutputFormat::Json) => View::Mesh,
        (View::Auto, OutputFormat::Svg) => View::Svg,
        (View::Auto, _) => View::Labels,
        (v, _) => v,
    };
    let ours = [
        View::Labels,
        View::Labels16,
        View::Edges,
        View::Ellipses,
        View::Distance,
        View::Closest,
        View::Mesh,
        View::Svg,
        View::Stats,
    ];
    if !ours.contains(&view) {
        return Err(Diagnostic::error(format!("a structure has no `{}` view", VIEWS.name(view)))
            .with_code("tessera::output_view")
            .with_label(d.props.span("view").unwrap_or(d.name_span), "this view")
            .with_help("its views are labels, labels16, edges, ellipses, distance, closest, mesh, svg and stats"));
    }
    let wants = match view {
        View::Mesh | View::Stats => Wants::Json,
        View::Svg => Wants::Svg,
        View::Labels16 => Wants::Png16,
        _ => Wants::Image,
    };
    let fits = match wants {
        Wants::Json => format == OutputFormat::Json,
        Wants::Svg => format == OutputFormat::Svg,
        Wants::Png16 => format == OutputFormat::Png16 || format == OutputFormat::Exr,
        Wants::Image => !format.is_text(),
    };
    if !fits {
        let hint = match wants {
            Wants::Json => "a `.json` file",
            Wants::Svg => "an `.svg` file",
            Wants::Png16 => "a `.png` with `format = png16` (or `.exr`)",
            Wants::Image => "a `.png` or `.exr` file",
        };
        return Err(Diagnostic::error(format!("the `{}` view is written to {hint}", VIEWS.name(view)))
            .with_code("tessera::output_view")
            .with_label(d.props.span("view").unwrap_or(d.name_span), "this view")
            .with_label(d.name_span, "this file"));
    }
    let decl = p.decl(structure);
    let metric = metric_kind(decl.props.enumeration("metric"));
    let ((w, h), _) = p.plane(decl.props.reference("on").expect("required"));
    let label = format!("output {}", d.name);
    let mut inputs = Inputs::new();
    let node = match view {
        // Views of the relaxed generators and their label raster.
        View::Ellipses | View::Distance => {
            let lloyd = inputs.add(p.part(structure, "lloyd").expect("structures plan a Lloyd stage"));
            let drawing = Drawing { view, format, edge_width, w, h, input: (lloyd, metric) };
            p.add(label, FnStage::keyed("structure.view", 2, drawing, relaxed_view), inputs, vec![])
        }
        // The synthesised structure's statistics against the sample's.
        View::Stats => {
            let mesh = inputs.add(p.part(structure, "mesh").expect("structures plan a mesh stage"));
            let analysis = inputs.add(p.part(structure, "analysis").expect("structures plan an analysis"));
            let drawing = Drawing { view, format, edge_width, w, h, input: (mesh, analysis) };
            p.add(label, FnStage::keyed("structure.view", 2, drawing, stats_view), inputs, vec![])
        }
        // Views of the final mesh.
        _ => {
            let mesh = inputs.add(p.part(structure, "mesh").expect("structures plan a mesh stage"));
            let drawing = Drawing { view, format, edge_width, w, h, input: mesh };
            p.add(label, FnStage::keyed("structure.view", 2, drawing, mesh_view), inputs, vec![])
        }
    };
    Ok(node)
}

fn relaxed_view(cx: &RunCx, v: &Drawing<(In<Relaxed>, MetricKind)>) -> Result<Bytes, StageError> {
    let (lloyd, metric) = v.input;
    let r = cx.get(lloyd);
    let img = match v.view {
        View::Ellipses => render::ellipses_overlay(&r.labels, &r.sized),
        _ => render::distance(&r.labels, &r.sized, metric),
    };
    encode_image(&img, v.format)
}

fn stats_view(cx: &RunCx, v: &Drawing<(In<Shaped>, In<SampleStructure>)>) -> Result<Bytes, StageError> {
    let m = cx.get(v.input.0);
    let sample = cx.get(v.input.1);
    let size = [v.w as f64, v.h as f64];
    let generated = analyse_subdivision(&mesh_to_subdivision(&m.mesh), Some(size), &sample.model.config)
        .map_err(|e| StageError::new(format!("the synthesised mesh does not analyse: {e}")))?;
    let report = report::compare(&sample.model, &generated.model);
    Ok(Bytes(report::to_json(&report).into_bytes()))
}

fn mesh_view(cx: &RunCx, v: &Drawing<In<Shaped>>) -> Result<Bytes, StageError> {
    let m = cx.get(v.input);
    if v.view == View::Closest {
        return encode_image(&render::closest(&m.mesh, &m.placed, v.w, v.h, v.edge_width), v.format);
    }
    draw_mesh(v.view, &m.mesh, v.w, v.h, v.edge_width, v.format)
}

fn draw_mesh(
    view: View,
    mesh: &Mesh,
    w: usize,
    h: usize,
    edge_width: f64,
    format: OutputFormat,
) -> Result<Bytes, StageError> {
    let polygons =
        || -> Vec<Vec<Point>> { mesh.regions.iter().map(|r| r.iter().map(|&i| mesh.vertices[i]).collect()).collect() };
    let img = match view {
        View::Mesh => return Ok(Bytes(render::mesh_json(mesh, w, h).into_bytes())),
        View::Svg => return Ok(Bytes(render::mesh_svg(mesh, w, h, edge_width).into_bytes())),
        View::Edges => render::edges_raster(mesh, w, h, edge_width),
        View::Labels => render::labels_colour(&rasterize_polygons(&polygons(), w, h)),
        View::Labels16 => render::labels_u16(&rasterize_polygons(&polygons(), w, h))
            .ok_or_else(|| StageError::new("more than 65534 regions do not fit a 16-bit PNG"))?,
        other => unreachable!("`{}` is not a mesh view (planned as another stage)", VIEWS.name(other)),
    };
    encode_image(&img, format)
}
