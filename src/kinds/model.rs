//! `model`: a mesh surface relieved by a depth map [references: frasson §5.3.2]: each coarse face
//! subdivided on its own grid and displaced along its normal by `scale·(g − 0.5)`, the gaps between
//! faces zipped by triangle strips, each strip textured from the two faces beside it (a seam
//! texture: both faces' edges unfolded into the gap and joined by a minimum-error cut), the result
//! drawn by the software renderer (`.png` outputs), written as OBJ or as glTF binary with its
//! texture (`.obj`, `.glb`). The model's texture is the colour texture with the seam textures'
//! atlas below it; its normal map (the residual relief the grid misses) and height map share
//! that layout.
//!
//! ```text
//! surface.mesh, depth, colour ─► model.displace ─► output.render (camera, lights)
//!                                              ├──► output.obj
//!                                              └──► output.glb
//! ```
//!
//! Changing the camera or the light re-runs only the render; the displaced mesh is cached.

use glam::{Vec3, Vec4};

use super::output::to_file_space;
use super::representation::Relightable;
use super::{Bytes, ColorSpace, FnStage, OutputFormat, Planner};
use crate::graph::{AnyHandle, Handle, In, Inputs, RunCx, StageError};
use crate::lang::schema::{Default, Extent, KindSpec, Naming, PropSpec, Range, Ty, Unit, Value};
use crate::lang::{Decl, Diagnostic};
use crate::raster::{self, Image};
use crate::synth::mesh::{self, displace, Mesh, TriMesh};
use crate::synth::relight::{Basis, Light};
use crate::synth::render;

pub static SPEC: KindSpec = KindSpec {
    name: "model",
    doc: "A mesh surface relieved by a depth map: displaced face by face, its seams zipped, drawn by the renderer (`.png` outputs at `azimuth`, `elevation` and `light`), written as `.obj` or as glTF binary (`.glb`) with its colour, its normal map (the relief finer than the displaced grid, which the renders shade too) and its height map (material `extras.heightTexture`).",
    naming: Naming::Ident,
    produces: &[Value::Model],
    settings: &[],
    extent: Extent::None,
    props: &[
        PropSpec { name: "on", ty: Ty::Ref(&[Value::Plane]), default: Default::Required, doc: "The mesh surface (a `surface` with `mesh`)." },
        PropSpec {
            name: "relief",
            ty: Ty::Ref(&[Value::Image]),
            default: Default::Absent,
            doc: "A relief layer: its colour is the texture, its depth the displacement.",
        },
        PropSpec {
            name: "texture",
            ty: Ty::Ref(&[Value::Image]),
            default: Default::Absent,
            doc: "Instead of `relief`: the colour texture, laid on through the mesh's UVs.",
        },
        PropSpec {
            name: "height",
            ty: Ty::Ref(&[Value::Map, Value::Image]),
            default: Default::Absent,
            doc: "Instead of `relief`: the depth (first channel, 0.5 = the surface).",
        },
        PropSpec {
            name: "relit",
            ty: Ty::Ref(&[Value::Image]),
            default: Default::Absent,
            doc: "A relightable surface (a `representation`, or a layer quilted from one) laid on through the mesh's UVs: the renders relight it per fragment, each light turned into the fragment's tangent frame. With it, `texture` defaults to the surface relit from straight above and `height` to none (the mesh is then not displaced).",
        },
        PropSpec {
            name: "scale",
            ty: Ty::Number(Unit::Plain, Range { min: -1e6, max: 1e6 }),
            default: Default::Text("0.05"),
            doc: "Displacement of depth 1 relative to 0.5, in mesh units: a vertex moves by scale·(g − 0.5) along its face's normal.",
        },
        PropSpec {
            name: "subdiv",
            ty: Ty::Int(0, 256),
            default: Default::Text("0"),
            doc: "Grid cells per face side; 0 follows the depth's resolution (half the face's longest UV edge in texels).",
        },
        PropSpec {
            name: "seam_reach",
            ty: Ty::Number(Unit::Plain, Range { min: 0.0, max: 10.0 }),
            default: Default::Text("0.75"),
            doc: "How far into each face the seam texture reads, relative to the widest gap the seam opens (d'/d).",
        },
        PropSpec {
            name: "seam_overlap",
            ty: Ty::Number(Unit::Fraction, Range { min: 0.0, max: 1.0 }),
            default: Default::Text("50 %"),
            doc: "How much of their width the two faces' bands share in a seam texture; the overlap is split by a minimum-error cut.",
        },
        PropSpec {
            name: "seam_feather",
            ty: Ty::Int(0, 16),
            default: Default::Text("2"),
            doc: "Texels over which the seam texture's cut is feathered (0: a hard cut).",
        },
    ],
};

/// A displaced model: the triangles (faces and seam strips), their tangents, and the maps they
/// read, all in one layout (the colour texture with the seam textures' atlas below it): the
/// colour, a tangent-space normal map of the relief finer than the mesh's grid, and the depth
/// that displaced it (flat, 0.5, on the seam atlas).
#[derive(Clone, Debug)]
pub struct Model {
    pub mesh: TriMesh,
    pub tangents: Vec<Vec4>,
    pub texture: Image,
    pub normal: Image,
    pub height: Image,
    /// A relightable surface in the same layout, which the renders shade instead of the
    /// colour and normal maps.
    pub relit: Option<RelitMaps>,
}

/// A relightable surface's maps (in the output frame) and chromaticity, in a model's layout.
#[derive(Clone, Debug)]
pub struct RelitMaps {
    pub maps: Image,
    pub chroma: Option<Image>,
    pub basis: Basis,
}

impl super::artifact::Encoded for Model {
    fn encode(&self) -> Vec<u8> {
        let mut images = vec![&self.texture, &self.normal, &self.height];
        let relit = self.relit.as_ref().map(|r| {
            images.push(&r.maps);
            images.extend(&r.chroma);
            (&r.basis, r.chroma.is_some())
        });
        super::artifact::pack(&(&self.mesh, &self.tangents, relit), &images)
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        type Head = (TriMesh, Vec<Vec4>, Option<(Basis, bool)>);
        let ((mesh, tangents, relit), images) = super::artifact::unpack::<Head>(bytes)?;
        let wanted = 3 + relit.as_ref().map_or(0, |&(_, chroma)| 1 + usize::from(chroma));
        if images.len() != wanted {
            return Err(format!("a model holds {wanted} maps, not {}", images.len()));
        }
        let mut images = images.into_iter();
        let mut next = || images.next().expect("counted");
        let (texture, normal, height) = (next(), next(), next());
        let relit = relit.map(|(basis, chroma)| RelitMaps { maps: next(), chroma: chroma.then(&mut next), basis });
        Ok(Model { mesh, tangents, texture, normal, height, relit })
    }
}

/// Most texels of seam textures one model makes (16 M: 192 MB of RGB while it is built).
const MAX_SEAM_TEXELS: u64 = 1 << 24;

/// Meshes with more vertices than this after displacement are refused (about 2 GB of model).
const MAX_VERTICES: usize = 20_000_000;

#[derive(serde::Serialize)]
struct Displacing {
    mesh: In<Mesh>,
    /// Absent for a relit model without a depth: the mesh keeps its shape.
    depth: Option<In<Image>>,
    /// Absent for a relit model without a texture: the surface relit from above.
    colour: Option<In<Image>>,
    relit: Option<In<Relightable>>,
    params: displace::DisplaceParams,
    seams: mesh::seam_texture::SeamTextureParams,
}

/// The light a relightable surface is shown under when it stands for a colour texture: straight
/// above, or for Eigen (whose coefficients exist only on its captured slants) the lowest slant
/// it was captured at.
fn overhead(basis: &Basis) -> Light {
    match basis {
        Basis::Eigen(e) => Light::new(0.0, e.lights.iter().map(|l| l.slant_deg).fold(f64::INFINITY, f64::min)),
        _ => Light::new(0.0, 0.0),
    }
}

fn run_displace(cx: &RunCx, d: &Displacing) -> Result<Model, StageError> {
    let mesh = cx.get(d.mesh);
    let relit_error = |e: crate::synth::relight::RelightError| StageError::new(e.to_string()).at_prop("relit");
    let relightable = d.relit.map(|r| cx.get(r));
    let colour: Image = match (d.colour, &relightable) {
        (Some(c), _) => (*cx.get(c)).clone(),
        (None, Some(r)) => r.relit(&overhead(&r.basis)).map_err(relit_error)?,
        (None, None) => unreachable!("planned with a texture or a relightable surface"),
    };
    let depth = match d.depth {
        Some(depth) => {
            let depth = cx.get(depth);
            Image { width: depth.width, height: depth.height, channels: 1, data: depth.plane(0).to_vec() }
        }
        None => Image::filled(1, 1, 1, 0.5),
    };
    let displaced = displace::displace(&mesh, &depth, &d.params).map_err(|e| {
        let prop = match e {
            displace::DisplaceError::TooManyVertices { .. } => "subdiv",
            displace::DisplaceError::Params { .. } => "scale",
            _ => "on",
        };
        StageError::new(e.to_string()).at_prop(prop)
    })?;
    let seams = mesh::seam::zip(&displaced);
    // Faces displaced along their own normals cross each other where a seam strip turns inside
    // out: at a convex edge pushed in (or a concave one pushed out). A little of that is every
    // recess at an edge; it is a fault when the faces cross by a tenth of their edge or more.
    let crossed = crossed_seams(&displaced, &seams);
    if crossed > 0 || displaced.folded_triangles > 0 {
        cx.warn(format!(
            "the displaced faces cross each other at {crossed} seam(s) ({} folded triangle(s)): the surface intersects itself; lower `scale` or blur the depth",
            displaced.folded_triangles
        ));
    }
    // The maps at the colour texture's size, before the seam atlas joins it.
    let (w, h) = (colour.width, colour.height);
    let residual = mesh::detail::residual_height(&displaced, &depth, w, h);
    let normal = mesh::detail::normal_map(&residual, d.params.scale, mesh::detail::texel_size(&displaced, w, h));
    let height = Image::from_fn(w, h, 1, |x, y, _| {
        let uv = glam::Vec2::new((x as f32 + 0.5) / w as f32, 1.0 - (y as f32 + 0.5) / h as f32);
        displace::sample_bilinear(&depth, uv)
    });
    // A relightable surface rides along with the colour, channel for channel, so its seams
    // are cut where the colour's are and it lands in the same layout.
    let relit = match &relightable {
        Some(r) => {
            let maps = r.framed_maps().map_err(relit_error)?;
            Some((resampled(&maps, w, h), r.chroma.as_ref().map(|c| resampled(c, w, h)), r.basis.clone()))
        }
        None => None,
    };
    let mut layers = vec![&colour];
    if let Some((maps, chroma, _)) = &relit {
        layers.push(maps);
        layers.extend(chroma);
    }
    let stacked = Image::stacked(&layers);
    let counts: Vec<usize> = layers.iter().map(|l| l.channels).collect();
    let (tri, stacked) = match mesh::textured::texture_seams(&displaced, &seams, &stacked, &d.seams, MAX_SEAM_TEXELS) {
        Ok(t) => (t.mesh, t.texture),
        Err(e) => {
            cx.warn(format!("the seams are textured by interpolating the faces' UVs: {e}"));
            (displaced.to_trimesh(&seams.strips, &seams.corners), stacked)
        }
    };
    let mut planes = stacked.split(&counts).into_iter();
    let texture = planes.next().expect("the colour");
    let relit = relit.map(|(_, chroma, basis)| RelitMaps {
        maps: planes.next().expect("the maps"),
        chroma: chroma.and_then(|_| planes.next()),
        basis,
    });
    let tangents = triangle_tangents(&tri);
    let normal = mesh::textured::beside_seams(&normal, &texture, &[0.5, 0.5, 1.0]);
    let height = mesh::textured::beside_seams(&height, &texture, &[0.5]);
    Ok(Model { mesh: tri, tangents, texture, normal, height, relit })
}

/// `img` at `w × h` (bilinear, wrapping: maps are textures; unchanged at its own size).
fn resampled(img: &Image, w: usize, h: usize) -> Image {
    raster::resample::resize_with_edge(img, w, h, raster::Filter::Bilinear, raster::Edge::Wrap)
}

/// Seams whose strip turns inside out (a triangle facing against the mean of the two faces'
/// normals) with its two sides more than a tenth of the coarse edge apart there.
fn crossed_seams(d: &displace::Displaced, seams: &mesh::seam::Seams) -> usize {
    let at = |r: mesh::seam::VertexRef| d.faces[r.face as usize].positions[r.vertex as usize];
    seams
        .strips
        .iter()
        .filter(|s| {
            let (fa, fb) = (&d.faces[s.face_a as usize], &d.faces[s.face_b as usize]);
            let out = fa.normal + fb.normal;
            let k = s.edge_a as usize;
            let edge = fa.corner_positions[k].distance(fa.corner_positions[(k + 1) % fa.corner_positions.len()]);
            s.triangles.iter().any(|t| {
                let [a, b, c] = t.map(at);
                let inside_out = (b - a).cross(c - a).dot(out) < 0.0;
                let across = t.iter().filter(|r| r.face == s.face_a).map(|&r| at(r)).fold(0.0f32, |m, p| {
                    t.iter().filter(|r| r.face == s.face_b).map(|&r| p.distance(at(r))).fold(m, f32::max)
                });
                inside_out && across > 0.1 * edge
            })
        })
        .count()
}

/// Per-vertex tangents (glTF convention: xyz along +u, w the handedness), accumulated from the
/// triangles' UV derivatives and made orthogonal to the vertex normal.
fn triangle_tangents(m: &TriMesh) -> Vec<Vec4> {
    let mut t = vec![Vec3::ZERO; m.positions.len()];
    let mut b = vec![Vec3::ZERO; m.positions.len()];
    for tri in &m.triangles {
        let [i, j, k] = tri.map(|v| v as usize);
        let (e1, e2) = (m.positions[j] - m.positions[i], m.positions[k] - m.positions[i]);
        let (d1, d2) = (m.uvs[j] - m.uvs[i], m.uvs[k] - m.uvs[i]);
        let det = d1.x * d2.y - d2.x * d1.y;
        if det.abs() < 1e-20 {
            continue;
        }
        let tu = (e1 * d2.y - e2 * d1.y) / det;
        let tv = (e2 * d1.x - e1 * d2.x) / det;
        for v in [i, j, k] {
            t[v] += tu;
            b[v] += tv;
        }
    }
    m.normals
        .iter()
        .enumerate()
        .map(|(v, &n)| {
            let mut tan = t[v] - n * n.dot(t[v]);
            if tan.length_squared() < 1e-20 {
                tan = n.any_orthonormal_vector();
            }
            let tan = tan.normalize();
            let w = if n.cross(tan).dot(b[v]) < 0.0 { -1.0 } else { 1.0 };
            tan.extend(w)
        })
        .collect()
}

/// The model kind.
pub struct ModelKind;

impl super::Kind for ModelKind {
    fn spec(&self) -> &'static KindSpec {
        &SPEC
    }

    fn plan(&self, p: &mut Planner, d: &Decl) -> Result<Option<AnyHandle>, Diagnostic> {
        let props = &d.props;
        let on = props.reference("on").expect("required");
        let on_span = props.span("on").unwrap_or(d.name_span);
        let Some(mesh) = p.part::<Mesh>(on, "mesh") else {
            return Err(Diagnostic::error(format!("surface `{on}` is a plane, not a mesh"))
                .with_code("tessera::model")
                .with_label(on_span, "a mesh surface is needed here")
                .with_help(format!("give surface `{on}` a `mesh = \"file.obj\"`")));
        };
        let relit = match props.reference("relit") {
            Some(r) => {
                let at = props.span("relit").unwrap_or(d.name_span);
                let Some(surface) = p.part::<Relightable>(r, "relightable") else {
                    return Err(Diagnostic::error(format!("`{r}` is not relightable"))
                        .with_code("tessera::model")
                        .with_label(at, "a `representation`, or a layer quilted from one, is needed here"));
                };
                Some(surface)
            }
            None => None,
        };
        let given = |name: &str| -> Result<Option<(Handle<Image>, ColorSpace)>, Diagnostic> {
            match props.reference(name) {
                Some(r) => Ok(Some((p.value::<Image>(r, props.span(name).unwrap_or(d.name_span))?, p.color_space(r)))),
                None => Ok(None),
            }
        };
        let (colour, depth) = match (props.reference("relief"), given("texture")?, given("height")?) {
            (Some(r), None, None) => {
                let at = props.span("relief").unwrap_or(d.name_span);
                let Some(depth) = p.part::<Image>(r, "depth") else {
                    return Err(Diagnostic::error(format!("`{r}` is not a relief layer: it has no depth"))
                        .with_code("tessera::model")
                        .with_label(at, "a `layer` with `relief = [...]` is needed here")
                        .with_help("or give the texture and the depth apart: `texture = …` and `height = …`"));
                };
                (Some((p.value::<Image>(r, at)?, p.color_space(r))), Some(depth))
            }
            (None, Some(t), Some(h)) => (Some(t), Some(h.0)),
            (None, t, h) if relit.is_some() => (t, h.map(|h| h.0)),
            _ => {
                return Err(Diagnostic::error(format!(
                    "model `{}` needs `relief`, or `texture` and `height`, or `relit`",
                    d.name
                ))
                .with_code("tessera::model")
                .with_label(props.span("relief").or(props.span("texture")).unwrap_or(d.name_span), "here")
                .with_help("`relief = LAYER` takes both from a relief layer"))
            }
        };
        let subdiv = match props.int("subdiv") {
            0 => displace::Subdiv::Auto,
            n => displace::Subdiv::Fixed(n as u32),
        };
        let params =
            displace::DisplaceParams { scale: props.num("scale") as f32, mid: 0.5, subdiv, max_vertices: MAX_VERTICES };
        let seams = mesh::seam_texture::SeamTextureParams {
            reach: props.num("seam_reach") as f32,
            overlap: props.num("seam_overlap") as f32,
            feather: props.int("seam_feather") as usize,
            ..mesh::seam_texture::SeamTextureParams::default()
        };
        let mut inputs = Inputs::new();
        let displacing = Displacing {
            mesh: inputs.add(mesh),
            depth: depth.map(|h| inputs.add(h)),
            colour: colour.map(|c| inputs.add(c.0)),
            relit: relit.map(|r| inputs.add(r)),
            params,
            seams,
        };
        let stage = FnStage::keyed("model.displace", 5, displacing, run_displace);
        let node: Handle<Model> = p.add(format!("model {}", d.name), stage, inputs, vec![]);
        // A texture relit from the relightable surface is linear, as relit images are.
        p.export(d).image = Some(colour.map_or(ColorSpace::Linear, |c| c.1));
        Ok(Some(node.erase()))
    }

    fn plan_output(&self, p: &mut Planner, out: &super::OutputRequest) -> Result<Option<super::ViewNode>, Diagnostic> {
        let d = out.decl;
        out.refuse_views("a model has no views: its outputs are renders (`.png`), `.obj` and `.glb`")?;
        let model: Handle<Model> = p.result(out.from);
        let space = p.color_space(out.from);
        let mut inputs = Inputs::new();
        let model = inputs.add(model);
        let node = match out.format {
            OutputFormat::Obj => {
                let stage = FnStage::keyed("output.obj", 2, model, |cx, &m| {
                    Ok(Bytes(mesh::obj::write_obj(&cx.get(m).mesh).into_bytes()))
                });
                p.add(format!("output {}", d.name), stage, inputs, vec![])
            }
            OutputFormat::Glb => {
                let stage = FnStage::keyed("output.glb", 3, (model, space), glb);
                p.add(format!("output {}", d.name), stage, inputs, vec![])
            }
            OutputFormat::Png8 | OutputFormat::Png16 | OutputFormat::Exr => {
                let view = camera_of(d, out.format);
                let stage = FnStage::keyed("output.render", 5, (model, space, view), draw);
                p.add(format!("output {}", d.name), stage, inputs, vec![])
            }
            _ => {
                return Err(Diagnostic::error(format!(
                    "a model is written as `.png`, `.exr`, `.obj` or `.glb`, not `.{}`",
                    out.ext
                ))
                .with_code("tessera::output_format")
                .with_label(d.name_span, "here"))
            }
        };
        Ok(Some(super::ViewNode { node, exact: false, more: Vec::new() }))
    }
}

/// How a render output looks at its model.
#[derive(Clone, Copy, serde::Serialize)]
struct Shot {
    azimuth_deg: f64,
    elevation_deg: f64,
    light_tilt_deg: f64,
    light_slant_deg: f64,
    width: usize,
    height: usize,
    shadows: bool,
    format: OutputFormat,
}

fn camera_of(d: &Decl, format: OutputFormat) -> Shot {
    let props = &d.props;
    let light = match props.get("light") {
        Some(crate::lang::Val::Call(c)) => super::representation::light_call(c),
        _ => crate::synth::relight::Light::new(45.0, 45.0),
    };
    let (w, h) = props.size("resolution");
    Shot {
        azimuth_deg: props.num("azimuth").to_degrees(),
        elevation_deg: props.num("elevation").to_degrees(),
        light_tilt_deg: light.tilt_deg,
        light_slant_deg: light.slant_deg,
        width: w as usize,
        height: h as usize,
        shadows: props.bool("shadows"),
        format,
    }
}

/// The colour texture as linear RGB.
fn linear_texture(img: &Image, space: ColorSpace) -> Image {
    let rgb = Image::from_fn(img.width, img.height, 3, |x, y, c| img.get(x, y, c.min(img.channels - 1)));
    to_file_space(&rgb, space, OutputFormat::Exr)
}

/// Directions in the model's frame, y up (as OBJ and glTF): `azimuth` turns about +y from +z
/// towards +x, `elevation` rises from the horizontal plane; a light's slant is its angle from +y.
fn direction(azimuth_deg: f64, elevation_deg: f64) -> Vec3 {
    let (a, e) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
    Vec3::new((e.cos() * a.sin()) as f32, e.sin() as f32, (e.cos() * a.cos()) as f32)
}

fn draw(cx: &RunCx, &(model, space, s): &(In<Model>, ColorSpace, Shot)) -> Result<Bytes, StageError> {
    let m = cx.get(model);
    let texture = linear_texture(&m.texture, space);
    let Some((lo, hi)) = m.mesh.bounds() else {
        return Err(StageError::new("the model has no triangles to draw"));
    };
    let centre = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-6);
    let fov = 35.0f32;
    let distance = radius / (fov.to_radians() * 0.5).sin();
    let eye = centre + direction(s.azimuth_deg, s.elevation_deg) * distance;
    let camera = render::camera::Camera::perspective(eye, centre, Vec3::Y, fov);
    let light = render::material::DirectionalLight::white(direction(s.light_tilt_deg, 90.0 - s.light_slant_deg));
    let options = render::RenderOptions {
        width: s.width,
        height: s.height,
        shadows: s.shadows,
        samples_per_pixel: 4,
        // A little sky light, so the side away from the sun reads as shape, not as a hole.
        ambient: [0.12, 0.12, 0.14],
        background: [0.18, 0.19, 0.21],
        ..render::RenderOptions::default()
    };
    let img = match &m.relit {
        // The relightable surface holds the relief finer than the mesh itself: the normal map
        // would count it twice.
        Some(r) => {
            let material = render::Relit::new(&r.maps, r.chroma.as_ref(), &r.basis)
                .map_err(|e| StageError::new(e.to_string()).at_prop("relit"))?;
            render::render(&m.mesh, Some(&m.tangents), &material, &camera, &[light], &options)
        }
        None => {
            let material = render::material::Albedo { texture: &texture, normal_map: Some(&m.normal) };
            render::render(&m.mesh, Some(&m.tangents), &material, &camera, &[light], &options)
        }
    };
    super::output::encode_image(&to_file_space(&img, ColorSpace::Linear, s.format), s.format)
}

fn glb(cx: &RunCx, &(model, space): &(In<Model>, ColorSpace)) -> Result<Bytes, StageError> {
    let m = cx.get(model);
    let texture = linear_texture(&m.texture, space);
    let png = raster::io::encode_png(&raster::color::image_linear_to_srgb(&texture), 8)
        .map_err(|e| StageError::new(format!("cannot encode the texture: {e}")))?;
    // The normal map holds vectors, not colours: stored as is (glTF reads it linear).
    let normal = raster::io::encode_png(&m.normal, 8)
        .map_err(|e| StageError::new(format!("cannot encode the normal map: {e}")))?;
    let height = raster::io::encode_png(&m.height, 16)
        .map_err(|e| StageError::new(format!("cannot encode the height map: {e}")))?;
    let textures = mesh::GlbTextures {
        base_color_png: Some(png),
        normal_png: Some(normal),
        occlusion_png: None,
        height_png: Some(height),
    };
    Ok(Bytes(mesh::write_glb(&m.mesh, Some(&m.tangents), &textures)))
}
