//! Shadow maps for directional lights: the mesh seen from the light through an orthographic
//! view fitted to its bounding sphere, keeping the nearness of the nearest surface per texel;
//! looked up with a slope-scaled depth bias and 2×2 percentage-closer filtering (the four
//! nearest texels' comparisons, bilinearly weighted).

use super::camera::{Projection, ProjectionKind};
use super::tiles::{key_nearness, rasterize, Cull, EMPTY};
use glam::{Vec3, Vec4};
use rayon::prelude::*;

/// The nearest surface toward one light.
pub struct ShadowMap {
    projection: Projection,
    size: usize,
    /// Nearness (`far − distance along the light`) per texel, row-major, y down; 0 where
    /// nothing was drawn.
    nearness: Vec<f32>,
    /// World size of one texel.
    texel: f32,
}

impl ShadowMap {
    /// Renders the map of `size²` texels for the light direction `to_light` (towards the light).
    pub fn build(
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        center: Vec3,
        radius: f32,
        to_light: Vec3,
        size: usize,
    ) -> ShadowMap {
        let size = size.clamp(1, 1 << 14);
        let projection = Projection::fitted_ortho(center, radius * 1.01, -to_light);
        let clip: Vec<Vec4> = positions.par_iter().map(|&p| projection.clip(p)).collect();
        let tiles = rasterize(size, size, &clip, triangles, f32::NEG_INFINITY, Cull::None, |tile| {
            let d: Vec<f32> = tile.keys.iter().map(|&k| if k == EMPTY { 0.0 } else { key_nearness(k) }).collect();
            (tile.x0, tile.y0, tile.width, d)
        });
        let mut nearness = vec![0.0; size * size];
        for (x0, y0, w, d) in tiles {
            for (row, chunk) in d.chunks(w).enumerate() {
                let start = (y0 + row) * size + x0;
                nearness[start..start + w].copy_from_slice(chunk);
            }
        }
        let half = match projection.kind {
            ProjectionKind::Orthographic { half_w, .. } => half_w,
            ProjectionKind::Perspective { .. } => unreachable!("a fitted shadow view is orthographic"),
        };
        ShadowMap { projection, size, nearness, texel: 2.0 * half / size as f32 }
    }

    /// How lit a point is, in `[0, 1]`; `cos_theta` is the cosine between the surface's
    /// geometric normal and the direction to the light (it scales the bias at grazing angles).
    pub fn lit(&self, p: Vec3, cos_theta: f32) -> f32 {
        let c = self.projection.clip(p);
        let n = self.size as f32;
        let sx = (c.x * 0.5 + 0.5) * n - 0.5;
        let sy = (0.5 - c.y * 0.5) * n - 0.5;
        let cos = cos_theta.abs().clamp(0.05, 1.0);
        let tan = (1.0 - cos * cos).sqrt() / cos;
        let bias = self.texel * (1.0 + 1.5 * tan.min(20.0));
        let d = c.z + bias;
        let (fx, fy) = (sx.floor(), sy.floor());
        let (tx, ty) = (sx - fx, sy - fy);
        let (x0, y0) = (fx as i64, fy as i64);
        let at = |x: i64, y: i64| -> f32 {
            if x < 0 || y < 0 || x >= self.size as i64 || y >= self.size as i64 {
                return 1.0;
            }
            if self.nearness[y as usize * self.size + x as usize] > d {
                0.0
            } else {
                1.0
            }
        };
        let top = at(x0, y0) * (1.0 - tx) + at(x0 + 1, y0) * tx;
        let bottom = at(x0, y0 + 1) * (1.0 - tx) + at(x0 + 1, y0 + 1) * tx;
        top * (1.0 - ty) + bottom * ty
    }
}
