//! The views an `output` may write of a structure: labels (colour and 16-bit ids), edges,
//! ellipses, distance, closest shapes, the mesh as JSON or SVG, and the statistics report.
//! The pixels are drawn by `synth::structure::render`; this module wires them to stages.

use super::super::output::encode_image;
use super::super::{Bytes, FnStage, OutputFormat, Planner};
use super::codecs::{Relaxed, Shaped};
use super::metric_kind;
use crate::graph::{NodeId, StageError};
use crate::lang::{Decl, Diagnostic};
use crate::synth::structure::analysis::labels_import::rasterize_polygons;
use crate::synth::structure::analysis::report;
use crate::synth::structure::analysis::sample::{analyse_subdivision, SampleStructure};
use crate::synth::structure::mesh::faces::mesh_to_subdivision;
use crate::synth::structure::{render, Mesh, Point};

/// The stage writing one view of a structure to an output file.
pub fn plan_output(
    p: &mut Planner,
    d: &Decl,
    structure: &str,
    format: OutputFormat,
    view: &str,
    edge_width: f64,
) -> Result<NodeId, Diagnostic> {
    let view = match (view, format) {
        ("auto", OutputFormat::Json) => "mesh",
        ("auto", OutputFormat::Svg) => "svg",
        ("auto", _) => "labels",
        (v, _) => v,
    };
    let wants = match view {
        "mesh" | "stats" => "json",
        "svg" => "svg",
        "labels16" => "png16",
        _ => "image",
    };
    let fits = match wants {
        "json" => format == OutputFormat::Json,
        "svg" => format == OutputFormat::Svg,
        "png16" => format == OutputFormat::Png16 || format == OutputFormat::Exr,
        _ => !format.is_text(),
    };
    if !fits {
        let hint = match wants {
            "json" => "a `.json` file",
            "svg" => "an `.svg` file",
            "png16" => "a `.png` with `format = png16` (or `.exr`)",
            _ => "a `.png` or `.exr` file",
        };
        return Err(Diagnostic::error(format!("the `{view}` view is written to {hint}"))
            .with_code("tessera::output_view")
            .with_label(d.props.span("view").unwrap_or(d.name_span), "this view")
            .with_label(d.name_span, "this file"));
    }
    let lloyd = p.part(structure, "lloyd").expect("structures plan a Lloyd stage");
    let mesh = p.part(structure, "mesh").expect("structures plan a mesh stage");
    let view_name = view.to_string();
    let decl = p.decl(structure);
    let metric = metric_kind(decl.props.enumeration("metric"));
    // The structure's size is its surface's, fixed when planned: mesh views need not load
    // the label raster to learn it.
    let ((w, h), _) = p.plane(decl.props.reference("on").expect("required"));
    let params =
        serde_json::json!({ "view": view, "format": format!("{format:?}"), "edge_width": edge_width, "w": w, "h": h })
            .to_string();
    let label = format!("output {}", d.name);
    let node = match view {
        // Views of the relaxed generators and their label raster.
        "ellipses" | "distance" => {
            let stage = FnStage::new("structure.view", 1, params, move |cx| {
                let r = cx.input::<Relaxed>(0);
                let img = match view_name.as_str() {
                    "ellipses" => render::ellipses_overlay(&r.labels, &r.sized),
                    _ => render::distance(&r.labels, &r.sized, metric),
                };
                encode_image(&img, format)
            });
            p.add(label, stage, vec![lloyd], vec![])
        }
        // The synthesised structure's statistics against the sample's.
        "stats" => {
            let analysis = p.part(structure, "analysis").expect("structures plan an analysis");
            let stage = FnStage::new("structure.view", 1, params, move |cx| {
                let m = cx.input::<Shaped>(0);
                let sample = cx.input::<SampleStructure>(1);
                let size = [w as f64, h as f64];
                let generated = analyse_subdivision(&mesh_to_subdivision(&m.mesh), Some(size), &sample.model.config)
                    .map_err(|e| StageError::new(format!("the synthesised mesh does not analyse: {e}")))?;
                let report = report::compare(&sample.model, &generated.model);
                Ok(Bytes(report::to_json(&report).into_bytes()))
            });
            p.add(label, stage, vec![mesh, analysis], vec![])
        }
        // Views of the final mesh.
        _ => {
            let stage = FnStage::new("structure.view", 1, params, move |cx| {
                let m = cx.input::<Shaped>(0);
                if view_name == "closest" {
                    return encode_image(&render::closest(&m.mesh, &m.placed, w, h, edge_width), format);
                }
                mesh_view(&view_name, &m.mesh, w, h, edge_width, format)
            });
            p.add(label, stage, vec![mesh], vec![])
        }
    };
    Ok(node)
}

fn mesh_view(
    view: &str,
    mesh: &Mesh,
    w: usize,
    h: usize,
    edge_width: f64,
    format: OutputFormat,
) -> Result<Bytes, StageError> {
    let polygons =
        || -> Vec<Vec<Point>> { mesh.regions.iter().map(|r| r.iter().map(|&i| mesh.vertices[i]).collect()).collect() };
    let img = match view {
        "mesh" => return Ok(Bytes(render::mesh_json(mesh, w, h).into_bytes())),
        "svg" => return Ok(Bytes(render::mesh_svg(mesh, w, h, edge_width).into_bytes())),
        "edges" => render::edges_raster(mesh, w, h, edge_width),
        "labels" => render::labels_colour(&rasterize_polygons(&polygons(), w, h)),
        "labels16" => render::labels_u16(&rasterize_polygons(&polygons(), w, h))
            .ok_or_else(|| StageError::new("more than 65534 regions do not fit a 16-bit PNG"))?,
        other => return Err(StageError::new(format!("the `{other}` view is not available yet"))),
    };
    encode_image(&img, format)
}
