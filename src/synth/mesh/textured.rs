//! A displaced, zipped mesh as one textured triangle mesh: the faces keep their UVs into the
//! colour texture, each seam strip gets its own seam texture ([`super::seam_texture`]), and the
//! seam textures are packed into an atlas below the colour texture, so the result is one mesh
//! with one texture, as renderers and glTF want it.
//!
//! The strips' vertices are the faces' seam-edge vertices again, duplicated with the seam
//! texture's UVs (a UV seam, as in any textured mesh): positions stay identical, so the mesh is
//! closed by position where the zipped mesh was closed by index. The corner fans keep the faces'
//! vertices (they are a few texels wide).

use glam::{Vec2, Vec3};

use super::displace::{Displaced, DisplacedFace};
use super::meshes::TriMesh;
use super::seam::{Seams, Strip, VertexRef};
use super::seam_texture::{layout, pack, seam_texture, FaceSide, SeamQuad, SeamTextureParams};
use crate::raster::Image;

/// Why a mesh's seams could not be given seam textures (the seams then take their UVs from the
/// faces, as [`Displaced::to_trimesh`] does).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SeamTexturing {
    #[error("the faces' UVs leave [0, 1] (the texture repeats), so no atlas can sit beside it")]
    RepeatingUvs,
    #[error("the seam textures would need {needed} texels, more than the limit of {limit}")]
    TooLarge { needed: u64, limit: u64 },
    #[error("the colour texture is empty")]
    EmptyTexture,
}

/// The result: one mesh and one texture (the colour texture on top, the seam atlas below).
#[derive(Clone, Debug, PartialEq)]
pub struct Textured {
    pub mesh: TriMesh,
    pub texture: Image,
    /// Triangles `0..face_triangles` are the faces', then the strips' and the corner fans'.
    pub face_triangles: usize,
}

/// The side of a seam on `face`, whose edge `edge` runs from corner `edge` to `edge + 1`;
/// `reversed` when the seam walks it the other way (side B).
fn face_side(face: &DisplacedFace, edge: usize, reversed: bool) -> FaceSide {
    let k = face.corner_positions.len();
    let (mut i, mut j) = (edge, (edge + 1) % k);
    let apex = (edge + 2) % k;
    if reversed {
        std::mem::swap(&mut i, &mut j);
    }
    FaceSide {
        edge: [face.corner_positions[i], face.corner_positions[j]],
        edge_uv: [face.corner_uvs[i], face.corner_uvs[j]],
        apex: face.corner_positions[apex],
        apex_uv: face.corner_uvs[apex],
    }
}

/// The seam quad of a strip: its faces' sides and the displaced ends of the gap.
pub fn seam_quad(d: &Displaced, s: &Strip) -> SeamQuad {
    let (fa, fb) = (&d.faces[s.face_a as usize], &d.faces[s.face_b as usize]);
    let pa = |i: usize| fa.positions[s.side_a[i] as usize];
    let pb = |j: usize| fb.positions[s.side_b[j] as usize];
    SeamQuad {
        side_a: face_side(fa, s.edge_a as usize, false),
        side_b: face_side(fb, s.edge_b as usize, true),
        a: pa(0),
        b: pb(0),
        c: pb(s.side_b.len() - 1),
        d: pa(s.side_a.len() - 1),
    }
}

/// Textures every seam of a zipped mesh from `texture` (any channel count) and gathers the
/// result into one mesh and one texture. At most `max_texels` texels of seam textures are made.
pub fn texture_seams(
    d: &Displaced,
    seams: &Seams,
    texture: &Image,
    params: &SeamTextureParams,
    max_texels: u64,
) -> Result<Textured, SeamTexturing> {
    let (w, h) = (texture.width, texture.height);
    if w == 0 || h == 0 || texture.channels == 0 {
        return Err(SeamTexturing::EmptyTexture);
    }
    let inside = |uv: &Vec2| (-1e-4..=1.0 + 1e-4).contains(&uv.x) && (-1e-4..=1.0 + 1e-4).contains(&uv.y);
    if !d.faces.iter().all(|f| f.corner_uvs.iter().all(inside)) {
        return Err(SeamTexturing::RepeatingUvs);
    }
    let quads: Vec<SeamQuad> = seams.strips.iter().map(|s| seam_quad(d, s)).collect();
    let needed = quads.iter().fold(0u64, |sum, q| {
        let l = layout(w, h, q, params);
        sum.saturating_add(((l.columns() + 2) * (l.rows + 2)) as u64)
    });
    if needed > max_texels {
        return Err(SeamTexturing::TooLarge { needed, limit: max_texels });
    }
    use rayon::prelude::*;
    let textures: Vec<_> =
        quads.par_iter().map(|q| seam_texture(texture, q, params).expect("the texture is not empty")).collect();
    let images: Vec<&Image> = textures.iter().map(|t| &t.image).collect();
    let (atlas, placements) = pack(&images, texture.channels, w.max(256));
    // The colour texture, a gutter row (and column) repeating its last texels so a lookup at
    // its border does not blend in the atlas, then the atlas.
    let (cw, ch) = (w.max(atlas.width), h + 1 + atlas.height);
    let mut combined = Image::new(cw, ch, texture.channels);
    for y in 0..=h {
        for x in 0..(w + 1).min(cw) {
            for c in 0..texture.channels {
                combined.set(x, y, c, texture.get(x.min(w - 1), y.min(h - 1), c));
            }
        }
    }
    for y in 0..atlas.height {
        for x in 0..atlas.width {
            for c in 0..texture.channels {
                combined.set(x, h + 1 + y, c, atlas.get(x, y, c));
            }
        }
    }
    // Texel coordinates (x right, y down) to UVs of the combined texture.
    let to_uv = |x: f32, y: f32| Vec2::new(x / cw as f32, 1.0 - y / ch as f32);
    let face_uv = |uv: Vec2| to_uv(uv.x * w as f32, (1.0 - uv.y) * h as f32);

    // The faces as the untextured mesh has them, their UVs moved into the combined texture.
    let mut mesh = d.to_trimesh(&[], &[]);
    for uv in &mut mesh.uvs {
        *uv = face_uv(*uv);
    }
    let face_triangles = mesh.triangles.len();
    for (((s, q), t), p) in seams.strips.iter().zip(&quads).zip(&textures).zip(&placements) {
        let (tw, th) = (t.image.width as f32, t.image.height as f32);
        let mut local: std::collections::BTreeMap<VertexRef, u32> = std::collections::BTreeMap::new();
        for tri in &s.triangles {
            let mapped = tri.map(|r| {
                *local.entry(r).or_insert_with(|| {
                    let f = &d.faces[r.face as usize];
                    let pos: Vec3 = f.positions[r.vertex as usize];
                    let uv = t.uv(r.face == s.face_a, q.along(pos));
                    let (x, y) = (p.x as f32 + uv.x * tw, (h + 1 + p.y) as f32 + (1.0 - uv.y) * th);
                    mesh.positions.push(pos);
                    mesh.normals.push(f.normals[r.vertex as usize]);
                    mesh.uvs.push(to_uv(x, y));
                    (mesh.positions.len() - 1) as u32
                })
            });
            mesh.triangles.push(mapped);
        }
    }
    let offsets = d.vertex_offsets();
    let global = |r: VertexRef| offsets[r.face as usize] + r.vertex;
    for t in seams.corners.iter().flat_map(|c| &c.triangles) {
        mesh.triangles.push(t.map(global));
    }
    Ok(Textured { mesh, texture: combined, face_triangles })
}

/// A map of the colour texture's size laid out as the combined texture of [`texture_seams`]
/// (`texture`): on top, its last row and column repeated once (the gutter), `flat` under the
/// seam atlas. Without an atlas (`texture` the colour texture itself) it is `map`.
pub fn beside_seams(map: &Image, texture: &Image, flat: &[f32]) -> Image {
    let (w, h) = (map.width, map.height);
    Image::from_fn(texture.width, texture.height, map.channels, |x, y, c| {
        if x <= w && y <= h && w > 0 && h > 0 {
            map.get(x.min(w - 1), y.min(h - 1), c)
        } else {
            flat[c]
        }
    })
}
