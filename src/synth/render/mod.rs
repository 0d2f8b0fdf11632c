//! A deterministic CPU renderer for previews and golden images: a [`TriMesh`] seen through a
//! [`Camera`], lit by [`DirectionalLight`]s (optionally shadowed), shaded by a caller-chosen
//! [`Material`]: textured Lambert ([`Albedo`]) or a relightable representation ([`Relit`]).
//!
//! **Design.** A visibility buffer: triangles are rasterised in tiles (`tiles`) keeping, per
//! sample, only the nearest triangle's index; each visible sample is then shaded exactly once,
//! from the exact intersection of its primary ray with that triangle (perspective-correct
//! barycentrics whatever clipping did on screen). With 4 samples per pixel the image is
//! rendered at twice the resolution on a 2×2 ordered grid and box-filtered.
//!
//! **Determinism.** Every sample is computed on its own and a pixel's samples are averaged in
//! a fixed order; visibility is independent of triangle order (depth ties go to the lower
//! index). The image is bit-identical for any rayon thread count.
//!
//! **Conventions.** UVs have v up; the tangent frame of a fragment has `t` along increasing u,
//! `b` along increasing v. Per-vertex tangents follow glTF (`xyz` the tangent, `w = ±1` with
//! bitangent `w · cross(n, t)`); without them each triangle's tangent and handedness come from
//! its UV derivatives. Without vertex normals (or UVs) the face normal (or uv 0) is used.

pub mod camera;
pub mod material;
pub mod relit;
pub mod shadow;
pub mod tiles;

#[cfg(test)]
mod tests;

pub use camera::{Camera, Projection, ProjectionKind};
pub use material::{sample_rgb, sample_wrap, Albedo, DirectionalLight, Fragment, LightSample, Material};
pub use relit::Relit;
pub use shadow::ShadowMap;

use crate::raster::Image;
use crate::synth::mesh::TriMesh;
use glam::{DVec3, Vec2, Vec3, Vec4};
use rayon::prelude::*;

/// How to render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    pub width: usize,
    pub height: usize,
    /// Linear RGB where no surface is seen.
    pub background: [f32; 3],
    /// Ambient light handed to the material ([`Fragment::ambient`]).
    pub ambient: [f32; 3],
    /// One shadow map per light.
    pub shadows: bool,
    /// Side of each shadow map, in texels.
    pub shadow_map_size: usize,
    /// 1, or 4 (2×2 ordered-grid supersampling); other values are read as the nearest of both.
    pub samples_per_pixel: usize,
    /// Skip triangles facing away from the camera (counter-clockwise seen from outside is the
    /// front).
    pub cull_backfaces: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 512,
            height: 512,
            background: [0.0; 3],
            ambient: [0.0; 3],
            shadows: false,
            shadow_map_size: 2048,
            samples_per_pixel: 1,
            cull_backfaces: false,
        }
    }
}

/// Renders `mesh` (with optional glTF-style per-vertex `tangents`) into a 3-channel linear RGB
/// image of `opts.width × opts.height`.
pub fn render(
    mesh: &TriMesh,
    tangents: Option<&[Vec4]>,
    material: &dyn Material,
    camera: &Camera,
    lights: &[DirectionalLight],
    opts: &RenderOptions,
) -> Image {
    let (w, h) = (opts.width, opts.height);
    let mut out = Image::new(w, h, 3);
    for (c, &b) in opts.background.iter().enumerate() {
        out.plane_mut(c).fill(b);
    }
    let Some((lo, hi)) = mesh.bounds() else { return out };
    if w == 0 || h == 0 || mesh.triangles.is_empty() {
        return out;
    }
    let s = if opts.samples_per_pixel >= 3 { 2 } else { 1 };
    let (iw, ih) = (w * s, h * s);
    let center = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-6);
    let (_, _, forward) = camera.basis();
    let far = (center - camera.eye).dot(forward) + radius * 2.0 + 1.0;
    let proj = camera.projection(iw as f32 / ih as f32, far);
    let near_w = proj.near_w(radius * 1e-5);

    let light_dirs: Vec<Vec3> = lights.iter().map(|l| l.direction.normalize_or(Vec3::Z)).collect();
    let shadow_maps: Vec<ShadowMap> = if opts.shadows {
        light_dirs
            .iter()
            .map(|&d| ShadowMap::build(&mesh.positions, &mesh.triangles, center, radius, d, opts.shadow_map_size))
            .collect()
    } else {
        Vec::new()
    };
    let shading = Shading {
        mesh,
        tangents: tangents.filter(|t| t.len() == mesh.positions.len()),
        material,
        proj,
        lights,
        light_dirs,
        shadow_maps,
        ambient: opts.ambient,
        background: opts.background,
        inv_size: Vec2::new(1.0 / iw as f32, 1.0 / ih as f32),
    };

    let clip: Vec<Vec4> = mesh.positions.par_iter().map(|&p| proj.clip(p)).collect();
    let cull = if opts.cull_backfaces { tiles::Cull::Back } else { tiles::Cull::None };
    let shaded = tiles::rasterize(iw, ih, &clip, &mesh.triangles, near_w, cull, |tile| {
        let mut lights = Vec::with_capacity(shading.lights.len());
        let samples: Vec<[f32; 3]> = (0..tile.keys.len())
            .map(|i| {
                let (x, y) = (tile.x0 + i % tile.width, tile.y0 + i / tile.width);
                shading.sample(tile.keys[i], x, y, &mut lights)
            })
            .collect();
        // Box-filter the samples to pixels (tiles have an even side when s = 2).
        let (pw, ph) = (tile.width / s, tile.height / s);
        let mut pixels = Vec::with_capacity(pw * ph);
        for py in 0..ph {
            for px in 0..pw {
                if s == 1 {
                    pixels.push(samples[py * tile.width + px]);
                } else {
                    let at = |dx: usize, dy: usize| samples[(py * 2 + dy) * tile.width + px * 2 + dx];
                    let (a, b, c, d) = (at(0, 0), at(1, 0), at(0, 1), at(1, 1));
                    pixels.push(std::array::from_fn(|k| (a[k] + b[k] + c[k] + d[k]) * 0.25));
                }
            }
        }
        (tile.x0 / s, tile.y0 / s, pw, pixels)
    });
    let plane = w * h;
    for (x0, y0, pw, pixels) in shaded {
        for (i, p) in pixels.iter().enumerate() {
            let at = (y0 + i / pw) * w + x0 + i % pw;
            out.data[at] = p[0];
            out.data[plane + at] = p[1];
            out.data[2 * plane + at] = p[2];
        }
    }
    out
}

/// Everything shading a sample needs.
struct Shading<'a> {
    mesh: &'a TriMesh,
    tangents: Option<&'a [Vec4]>,
    material: &'a dyn Material,
    proj: Projection,
    lights: &'a [DirectionalLight],
    light_dirs: Vec<Vec3>,
    shadow_maps: Vec<ShadowMap>,
    ambient: [f32; 3],
    background: [f32; 3],
    inv_size: Vec2,
}

impl Shading<'_> {
    fn sample(&self, key: u64, x: usize, y: usize, lights: &mut Vec<LightSample>) -> [f32; 3] {
        if key == tiles::EMPTY {
            return self.background;
        }
        let id = tiles::key_triangle(key);
        let mesh = self.mesh;
        let [ia, ib, ic] = mesh.triangles[id as usize].map(|i| i as usize);
        let (p0, p1, p2) = (mesh.positions[ia], mesh.positions[ib], mesh.positions[ic]);
        let ndc_x = (x as f32 + 0.5) * self.inv_size.x * 2.0 - 1.0;
        let ndc_y = 1.0 - (y as f32 + 0.5) * self.inv_size.y * 2.0;
        let (origin, dir) = self.proj.ray(ndc_x, ndc_y);
        let [b0, b1, b2] = barycentrics(origin, dir, p0, p1, p2);
        let position = p0 * b0 + p1 * b1 + p2 * b2;
        let face = (p1 - p0).cross(p2 - p0).normalize_or(Vec3::Z);
        let n = mesh.normals.len() == mesh.positions.len();
        let normal = if n {
            (mesh.normals[ia] * b0 + mesh.normals[ib] * b1 + mesh.normals[ic] * b2).normalize_or(face)
        } else {
            face
        };
        let has_uv = mesh.uvs.len() == mesh.positions.len();
        let (u0, u1, u2) =
            if has_uv { (mesh.uvs[ia], mesh.uvs[ib], mesh.uvs[ic]) } else { (Vec2::ZERO, Vec2::ZERO, Vec2::ZERO) };
        let uv = u0 * b0 + u1 * b1 + u2 * b2;
        let (tangent, bitangent) = match self.tangents {
            Some(t) => {
                let (t0, t1, t2) = (t[ia], t[ib], t[ic]);
                let tw = t0 * b0 + t1 * b1 + t2 * b2;
                let handed = if t0.w < 0.0 { -1.0 } else { 1.0 };
                frame(normal, tw.truncate(), None, handed)
            }
            None => {
                let (e1, e2) = (p1 - p0, p2 - p0);
                let (d1, d2) = (u1 - u0, u2 - u0);
                let r = d1.x * d2.y - d2.x * d1.y;
                if r.abs() > 1e-20 {
                    let t = (e1 * d2.y - e2 * d1.y) / r;
                    let b = (e2 * d1.x - e1 * d2.x) / r;
                    frame(normal, t, Some(b), 1.0)
                } else {
                    frame(normal, Vec3::ZERO, None, 1.0)
                }
            }
        };
        lights.clear();
        for (i, light) in self.lights.iter().enumerate() {
            let l = self.light_dirs[i];
            let shadow = match self.shadow_maps.get(i) {
                Some(map) => map.lit(position, face.dot(l)),
                None => 1.0,
            };
            lights.push(LightSample {
                tangent_direction: Vec3::new(l.dot(tangent), l.dot(bitangent), l.dot(normal)),
                world_direction: l,
                radiance: light.radiance(),
                shadow,
            });
        }
        let frag = Fragment {
            uv,
            position,
            normal,
            tangent,
            bitangent,
            triangle: id,
            view: (-dir).normalize_or(Vec3::Z),
            ambient: self.ambient,
            lights: lights.as_slice(),
        };
        self.material.shade(&frag)
    }
}

/// An orthonormal `(t, b)` for the unit normal `n`: `t` is `tangent` made orthogonal to `n`;
/// `b = h · cross(n, t)`, the handedness `h` read from `bitangent` when given (else `handed`).
/// A degenerate tangent falls back to any vector orthogonal to `n`.
fn frame(n: Vec3, tangent: Vec3, bitangent: Option<Vec3>, handed: f32) -> (Vec3, Vec3) {
    let t = (tangent - n * n.dot(tangent)).try_normalize().unwrap_or_else(|| n.any_orthonormal_vector());
    let c = n.cross(t);
    let h = match bitangent {
        Some(b) if c.dot(b) < 0.0 => -1.0,
        Some(_) => 1.0,
        None => handed,
    };
    (t, c * h)
}

/// Barycentric coordinates of the point where the line `origin + s · dir` meets the plane of the
/// triangle (Möller–Trumbore in f64); the centroid for a triangle seen edge-on.
fn barycentrics(origin: Vec3, dir: Vec3, p0: Vec3, p1: Vec3, p2: Vec3) -> [f32; 3] {
    let (o, d) = (origin.as_dvec3(), dir.as_dvec3());
    let v0 = p0.as_dvec3();
    let (e1, e2): (DVec3, DVec3) = (p1.as_dvec3() - v0, p2.as_dvec3() - v0);
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    if det.abs() <= 1e-300 || !det.is_finite() {
        return [1.0 / 3.0; 3];
    }
    let tv = o - v0;
    let u = tv.dot(pv) / det;
    let v = d.dot(tv.cross(e1)) / det;
    [(1.0 - u - v) as f32, u as f32, v as f32]
}
