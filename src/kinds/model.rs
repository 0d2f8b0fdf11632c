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

use super::output::{to_file_space, View};
use super::{Bytes, ColorSpace, FnStage, OutputFormat, Planner};
use crate::graph::{AnyHandle, Handle, In, Inputs, RunCx, StageError};
use crate::lang::schema::{Default, Extent, KindSpec, Naming, PropSpec, Range, Ty, Unit, Value};
use crate::lang::{Decl, Diagnostic};
use crate::raster::{self, Image};
use crate::synth::mesh::{self, displace, Mesh, TriMesh};
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
}

impl super::artifact::Encoded for Model {
    fn encode(&self) -> Vec<u8> {
        super::artifact::pack(&(&self.mesh, &self.tangents), &[&self.texture, &self.normal, &self.height])
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let ((mesh, tangents), images) = super::artifact::unpack::<(TriMesh, Vec<Vec4>)>(bytes)?;
        let [texture, normal, height]: [Image; 3] =
            images.try_into().map_err(|_| "a model holds three maps".to_string())?;
        Ok(Model { mesh, tangents, texture, normal, height })
    }
}

/// Most texels of seam textures one model makes (16 M: 192 MB of RGB while it is built).
const MAX_SEAM_TEXELS: u64 = 1 << 24;

/// Meshes with more vertices than this after displacement are refused (about 2 GB of model).
const MAX_VERTICES: usize = 20_000_000;

#[derive(serde::Serialize)]
struct Displacing {
    mesh: In<Mesh>,
    depth: In<Image>,
    colour: In<Image>,
    params: displace::DisplaceParams,
    seams: mesh::seam_texture::SeamTextureParams,
}

fn run_displace(cx: &RunCx, d: &Displacing) -> Result<Model, StageError> {
    let mesh = cx.get(d.mesh);
    let depth = cx.get(d.depth);
    let depth = Image { width: depth.width, height: depth.height, channels: 1, data: depth.plane(0).to_vec() };
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
    let colour = cx.get(d.colour);
    // The maps at the colour texture's size, before the seam atlas joins it.
    let (w, h) = (colour.width, colour.height);
    let residual = mesh::detail::residual_height(&displaced, &depth, w, h);
    let normal = mesh::detail::normal_map(&residual, d.params.scale, mesh::detail::texel_size(&displaced, w, h));
    let height = Image::from_fn(w, h, 1, |x, y, _| {
        let uv = glam::Vec2::new((x as f32 + 0.5) / w as f32, 1.0 - (y as f32 + 0.5) / h as f32);
        displace::sample_bilinear(&depth, uv)
    });
    let (tri, texture) = match mesh::textured::texture_seams(&displaced, &seams, &colour, &d.seams, MAX_SEAM_TEXELS) {
        Ok(t) => (t.mesh, t.texture),
        Err(e) => {
            cx.warn(format!("the seams are textured by interpolating the faces' UVs: {e}"));
            (displaced.to_trimesh(&seams.strips, &seams.corners), (*colour).clone())
        }
    };
    let tangents = triangle_tangents(&tri);
    let normal = beside_seams(&normal, &texture, &[0.5, 0.5, 1.0]);
    let height = beside_seams(&height, &texture, &[0.5]);
    Ok(Model { mesh: tri, tangents, texture, normal, height })
}

/// A map of the colour texture's size laid out as the model's texture: on top, its last row
/// and column repeated once (the gutter), `flat` under the seam atlas.
fn beside_seams(map: &Image, texture: &Image, flat: &[f32]) -> Image {
    let (w, h) = (map.width, map.height);
    Image::from_fn(texture.width, texture.height, map.channels, |x, y, c| {
        if x <= w && y <= h && w > 0 && h > 0 {
            map.get(x.min(w - 1), y.min(h - 1), c)
        } else {
            flat[c]
        }
    })
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
        let (colour, depth) = match (props.reference("relief"), props.reference("texture"), props.reference("height")) {
            (Some(r), None, None) => {
                let at = props.span("relief").unwrap_or(d.name_span);
                let Some(depth) = p.part::<Image>(r, "depth") else {
                    return Err(Diagnostic::error(format!("`{r}` is not a relief layer: it has no depth"))
                        .with_code("tessera::model")
                        .with_label(at, "a `layer` with `relief = [...]` is needed here")
                        .with_help("or give the texture and the depth apart: `texture = …` and `height = …`"));
                };
                ((p.value::<Image>(r, at)?, p.color_space(r)), depth)
            }
            (None, Some(t), Some(h)) => {
                let tat = props.span("texture").unwrap_or(d.name_span);
                let hat = props.span("height").unwrap_or(d.name_span);
                ((p.value::<Image>(t, tat)?, p.color_space(t)), p.value::<Image>(h, hat)?)
            }
            _ => {
                return Err(Diagnostic::error(format!("model `{}` needs `relief`, or `texture` and `height`", d.name))
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
            depth: inputs.add(depth),
            colour: inputs.add(colour.0),
            params,
            seams,
        };
        let stage = FnStage::keyed("model.displace", 4, displacing, run_displace);
        let node: Handle<Model> = p.add(format!("model {}", d.name), stage, inputs, vec![]);
        p.export(d).image = Some(colour.1);
        Ok(Some(node.erase()))
    }

    fn plan_output(&self, p: &mut Planner, out: &super::OutputRequest) -> Result<Option<super::ViewNode>, Diagnostic> {
        let d = out.decl;
        if out.view != View::Auto {
            return Err(Diagnostic::error("a model has no views: its outputs are renders (`.png`), `.obj` and `.glb`")
                .with_code("tessera::output_view")
                .with_label(d.props.span("view").unwrap_or(d.name_span), "remove this"));
        }
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
                let stage = FnStage::keyed("output.render", 4, (model, space, view), draw);
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
        Ok(Some(super::ViewNode { node, exact: false }))
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
    let material = render::material::Albedo { texture: &texture, normal_map: Some(&m.normal) };
    let img = render::render(&m.mesh, Some(&m.tangents), &material, &camera, &[light], &options);
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
