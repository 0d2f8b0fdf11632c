//! Lights, the fragment a material shades, the [`Material`] trait and the textured Lambert
//! material [`Albedo`].
//!
//! A fragment carries each light's direction both in world space and in the fragment's
//! **tangent frame** `(t, b, n)` (`t` along increasing u, `b` along increasing v, `n` the
//! interpolated normal), so a material defined on the surface's texture space (a normal map,
//! a relightable photometric representation) can be lit without knowing the mesh.

use crate::raster::Image;
use glam::{Vec2, Vec3};

/// A light at infinity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionalLight {
    /// Direction **towards** the light, world space (normalised by the renderer).
    pub direction: Vec3,
    pub color: [f32; 3],
    pub intensity: f32,
}

impl DirectionalLight {
    /// A white light of intensity 1.
    pub fn white(direction: Vec3) -> DirectionalLight {
        DirectionalLight { direction, color: [1.0; 3], intensity: 1.0 }
    }

    /// `color · intensity`.
    pub fn radiance(&self) -> [f32; 3] {
        self.color.map(|c| c * self.intensity)
    }
}

/// One light as seen from one fragment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Unit direction towards the light in the fragment's tangent frame `(t, b, n)`.
    pub tangent_direction: Vec3,
    /// Unit direction towards the light, world space.
    pub world_direction: Vec3,
    /// `color · intensity` of the light.
    pub radiance: [f32; 3],
    /// 1 lit, 0 in shadow, in between at shadow edges (always 1 without shadows).
    pub shadow: f32,
}

/// A visible surface point, as handed to [`Material::shade`].
#[derive(Clone, Copy, Debug)]
pub struct Fragment<'a> {
    /// Texture coordinates, v up.
    pub uv: Vec2,
    pub position: Vec3,
    /// Interpolated unit normal.
    pub normal: Vec3,
    /// Unit tangent (orthogonal to `normal`) and bitangent of the tangent frame.
    pub tangent: Vec3,
    pub bitangent: Vec3,
    /// Index of the triangle in the mesh.
    pub triangle: u32,
    /// Unit direction from the surface toward the viewer.
    pub view: Vec3,
    /// The ambient light of the render.
    pub ambient: [f32; 3],
    /// One entry per light, in the order of the render's lights.
    pub lights: &'a [LightSample],
}

impl Fragment<'_> {
    /// A world vector in this fragment's tangent frame.
    pub fn to_tangent(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.tangent), v.dot(self.bitangent), v.dot(self.normal))
    }
}

/// What a surface looks like: linear RGB leaving a fragment toward the viewer.
pub trait Material: Sync {
    fn shade(&self, frag: &Fragment) -> [f32; 3];
}

/// Textured Lambert: `albedo · (ambient + Σ radiance · max(n·l, 0) · shadow)`, with `n` the
/// normal map's tangent-space normal (RGB in `[0, 1]` encoding `[-1, 1]`) or the interpolated
/// normal without one. Textures are sampled bilinearly with wrapping.
#[derive(Clone, Copy, Debug)]
pub struct Albedo<'a> {
    /// RGB (or single-channel grey) linear albedo.
    pub texture: &'a Image,
    pub normal_map: Option<&'a Image>,
}

impl Material for Albedo<'_> {
    fn shade(&self, frag: &Fragment) -> [f32; 3] {
        let albedo = sample_rgb(self.texture, frag.uv);
        let n = match self.normal_map {
            Some(map) => {
                let c = sample_rgb(map, frag.uv);
                Vec3::new(c[0] * 2.0 - 1.0, c[1] * 2.0 - 1.0, c[2] * 2.0 - 1.0).normalize_or(Vec3::Z)
            }
            None => Vec3::Z,
        };
        let mut sum = frag.ambient;
        for l in frag.lights {
            let k = n.dot(l.tangent_direction).max(0.0) * l.shadow;
            for (s, r) in sum.iter_mut().zip(l.radiance) {
                *s += r * k;
            }
        }
        [albedo[0] * sum[0], albedo[1] * sum[1], albedo[2] * sum[2]]
    }
}

/// The four texels and weights of a bilinear, wrapping lookup at `uv` (v up: texel row
/// `(1 − v) · height`): plane offsets `[top-left, top-right, bottom-left, bottom-right]` and
/// `(tx, ty)`.
#[inline]
fn taps(img: &Image, uv: Vec2) -> Option<([usize; 4], f32, f32)> {
    let (w, h) = (img.width, img.height);
    if w == 0 || h == 0 {
        return None;
    }
    let x = uv.x * w as f32 - 0.5;
    let y = (1.0 - uv.y) * h as f32 - 0.5;
    if !(x.is_finite() && y.is_finite()) {
        return None;
    }
    let (fx, fy) = (x.floor(), y.floor());
    let x0 = (fx as i64).rem_euclid(w as i64) as usize;
    let y0 = (fy as i64).rem_euclid(h as i64) as usize;
    let (x1, y1) = ((x0 + 1) % w, (y0 + 1) % h);
    Some(([y0 * w + x0, y0 * w + x1, y1 * w + x0, y1 * w + x1], x - fx, y - fy))
}

#[inline]
fn blend(p: &[f32], [a, b, c, d]: [usize; 4], tx: f32, ty: f32) -> f32 {
    let top = p[a] * (1.0 - tx) + p[b] * tx;
    let bottom = p[c] * (1.0 - tx) + p[d] * tx;
    top * (1.0 - ty) + bottom * ty
}

/// Bilinear, wrapping lookup of channel `c` at `uv` (v up: texel row `(1 − v) · height`); 0 for
/// an empty image or a non-finite `uv`.
pub fn sample_wrap(img: &Image, uv: Vec2, c: usize) -> f32 {
    taps(img, uv).map_or(0.0, |(t, tx, ty)| blend(img.plane(c), t, tx, ty))
}

/// The first three channels at `uv` ([`sample_wrap`]); a one- or two-channel image repeats its
/// first channel.
pub fn sample_rgb(img: &Image, uv: Vec2) -> [f32; 3] {
    let Some((t, tx, ty)) = taps(img, uv) else { return [0.0; 3] };
    match img.channels {
        0 => [0.0; 3],
        1 | 2 => [blend(img.plane(0), t, tx, ty); 3],
        _ => std::array::from_fn(|c| blend(img.plane(c), t, tx, ty)),
    }
}
