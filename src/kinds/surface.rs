//! `surface`: the target a layer is synthesised on.

use super::{FnStage, Planner};
use crate::graph::{AnyHandle, Handle, In, Inputs, RunCx, StageError};
use crate::lang::schema::{Default, Extent, KindSpec, Naming, PropSpec, Ty, Value};
use crate::lang::{Decl, Diagnostic};
use crate::raster::Image;
use crate::synth::surface::Plane;

pub static SPEC: KindSpec = KindSpec {
    name: "surface",
    doc: "A target surface. Today a plane: a rectangle of pixels, optionally with an occupancy map.",
    naming: Naming::Ident,
    produces: &[Value::Plane],
    settings: &[],
    extent: Extent::Prop("plane"),
    props: &[
        PropSpec { name: "plane", ty: Ty::Size, default: Default::SceneSize, doc: "Size of the plane in pixels." },
        PropSpec {
            name: "occupancy",
            ty: Ty::Ref(&[Value::Map]),
            default: Default::Absent,
            doc:
                "A scalar map: 1 where detail goes, 0 where it must not (windows, holes). Must match the plane's size.",
        },
    ],
};

pub fn plan(p: &mut Planner, d: &Decl) -> Result<Handle<Plane>, Diagnostic> {
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
