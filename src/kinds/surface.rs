//! `surface`: the target a layer is synthesised on: a plane of pixels, or a mesh read from an OBJ
//! file whose texture space is that plane (layers on it are synthesised in its UV space).

use super::{FnStage, Planner};
use crate::graph::{AnyHandle, Handle, In, Inputs, RunCx, StageError};
use crate::lang::schema::{Default, Extent, KindSpec, Naming, PropSpec, Ty, Value};
use crate::lang::{Decl, Diagnostic};
use crate::raster::Image;
use crate::synth::mesh::{self, Mesh};
use crate::synth::surface::Plane;

pub static SPEC: KindSpec = KindSpec {
    name: "surface",
    doc: "A target surface: a plane of pixels (optionally with an occupancy map), or a mesh with texture coordinates (`mesh`), whose texture space is the plane: layers on it are synthesised at the plane's size and laid on the mesh through its UVs.",
    naming: Naming::Ident,
    produces: &[Value::Plane],
    settings: &[],
    extent: Extent::Prop("plane"),
    props: &[
        PropSpec { name: "plane", ty: Ty::Size, default: Default::SceneSize, doc: "Size of the plane in pixels." },
        PropSpec {
            name: "mesh",
            ty: Ty::Path,
            default: Default::Absent,
            doc: "An OBJ file (positions, texture coordinates, polygon faces; materials ignored). Checked: every face has a UV per corner, no degenerate face, no face with zero UV area, every edge shared by at most two faces wound the same way.",
        },
        PropSpec {
            name: "occupancy",
            ty: Ty::Ref(&[Value::Map]),
            default: Default::Absent,
            doc:
                "A scalar map: 1 where detail goes, 0 where it must not (windows, holes). Must match the plane's size.",
        },
    ],
};

/// Plans the mesh stage of a surface with a `mesh`, recorded as the part `mesh`.
fn plan_mesh(p: &mut Planner, d: &Decl) {
    let Some(path) = d.props.path("mesh") else { return };
    let span = d.props.span("mesh").unwrap_or(d.name_span);
    let stage = FnStage::keyed("surface.mesh", 1, (), read_mesh);
    let node = p.add(format!("surface {} (mesh)", d.name), stage, Inputs::new(), vec![(path.clone(), span)]);
    p.set_part(d, "mesh", node);
}

/// Reads and checks the OBJ file: a mesh relief can displace, or the first problem, naming the
/// face and its line.
fn read_mesh(cx: &RunCx, _: &()) -> Result<Mesh, StageError> {
    let bytes = cx.file(0)?;
    let obj = mesh::read_obj_with_lines(&bytes).map_err(|e| mesh_error(&e))?;
    obj.validate().map_err(|e| mesh_error(&e))?;
    Ok(obj.mesh)
}

fn mesh_error(e: &mesh::MeshError) -> StageError {
    let help = match e {
        mesh::MeshError::MissingUvs { .. } => "unwrap the mesh (give every corner a `vt`) before exporting it",
        mesh::MeshError::ZeroUvArea { .. } => "the face's UVs collapse to a line or a point; unwrap it again",
        mesh::MeshError::NonManifoldEdge { .. } => {
            "an edge shared by more than two faces has no single surface to displace; split it"
        }
        mesh::MeshError::InconsistentWinding { .. } => {
            "recalculate the normals (all faces counter-clockwise seen from outside)"
        }
        mesh::MeshError::DegenerateFace { .. } => "remove the face or merge its corners",
        _ => "export the mesh again as OBJ with UVs",
    };
    StageError::new(format!("the mesh is not usable: {e}")).in_file(0).with_help(help)
}

pub fn plan(p: &mut Planner, d: &Decl) -> Result<Handle<Plane>, Diagnostic> {
    plan_mesh(p, d);
    let (w, h) = d.props.size("plane");
    let (w, h) = (w as usize, h as usize);
    // The occupancy plane (f32), and the copy the stage makes of its map.
    p.check_pixels(d, d.props.span("plane"), (w, h), 8.0)?;
    let mut inputs = Inputs::new();
    let occupancy = d.props.reference("occupancy").map(|m| inputs.add(p.result::<Image>(m)));
    let stage = FnStage::keyed("surface.plane", 3, PlaneOf { w, h, occupancy }, plane);
    Ok(p.add(format!("surface {}", d.name), stage, inputs, Vec::new()))
}

/// What the plane stage works from: its size and occupancy map (if any).
#[derive(serde::Serialize)]
struct PlaneOf {
    w: usize,
    h: usize,
    occupancy: Option<In<Image>>,
}

fn plane(cx: &RunCx, &PlaneOf { w, h, occupancy }: &PlaneOf) -> Result<Plane, StageError> {
    let Some(occupancy) = occupancy else {
        return Ok(Plane::full(w, h));
    };
    let occ = cx.get(occupancy);
    if occ.width != w || occ.height != h {
        return Err(StageError::new(format!(
            "the occupancy map is {}x{} but the plane is {w}x{h}",
            occ.width, occ.height
        ))
        .at_prop("occupancy")
        .with_help("give the map `size` the plane's size"));
    }
    if occ.channels != 1 {
        return Err(StageError::new("the occupancy map must be scalar, not an orientation field").at_prop("occupancy"));
    }
    Ok(Plane { occupancy: (*occ).clone() })
}

/// The surface kind: a target plane and its occupancy.
pub struct Surface;

impl super::Kind for Surface {
    fn spec(&self) -> &'static crate::lang::KindSpec {
        &SPEC
    }

    fn plan(&self, p: &mut Planner, d: &Decl) -> Result<Option<AnyHandle>, Diagnostic> {
        let node = plan(p, d)?;
        let (w, h) = d.props.size("plane");
        p.export(d).plane = Some(((w as usize, h as usize), d.props.span("plane")));
        Ok(Some(node.erase()))
    }
}

impl super::artifact::Encoded for Mesh {
    fn encode(&self) -> Vec<u8> {
        serde_json::to_vec(self).expect("a mesh serialises")
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        serde_json::from_slice(bytes).map_err(|e| e.to_string())
    }
}
