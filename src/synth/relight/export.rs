//! Maps a renderer reads: a tangent-space normal map and albedo [references: dong §7.3]
//!
//! The normal of gradients `(p, q)` is `normalise(−p, −q, 1)`, encoded `(n + 1) / 2`. Tangent
//! space has +Y up in the displayed texture in the OpenGL convention and down in DirectX's;
//! the array frame's y grows down the rows, so OpenGL's green is `(1 − n_y) / 2` and DirectX's
//! `(1 + n_y) / 2`.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::raster::Image;

/// Which way the normal map's green channel points.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GreenAxis {
    /// +Y up (OpenGL, Blender, glTF).
    OpenGl,
    /// +Y down (DirectX, Unreal).
    DirectX,
}

/// The unit normal of gradient `(p, q)` in the array frame.
pub fn normal(p: f64, q: f64) -> DVec3 {
    DVec3::new(-p, -q, 1.0).normalize()
}

/// A 3-channel normal map in `[0, 1]` from `p` and `q` planes.
pub fn normal_map(p: &[f64], q: &[f64], width: usize, height: usize, green: GreenAxis) -> Image {
    let m = width * height;
    let mut img = Image::new(width, height, 3);
    for j in 0..m {
        let n = normal(p[j], q[j]);
        let g = match green {
            GreenAxis::OpenGl => -n.y,
            GreenAxis::DirectX => n.y,
        };
        img.data[j] = ((n.x + 1.0) * 0.5) as f32;
        img.data[m + j] = ((g + 1.0) * 0.5) as f32;
        img.data[2 * m + j] = ((n.z + 1.0) * 0.5) as f32;
    }
    img
}

/// Albedo as an image: one channel, or three (chromaticity × albedo) for a colour stack.
pub fn albedo_image(albedo: &[f64], chroma: Option<&[f64]>, width: usize, height: usize) -> Image {
    match chroma {
        None => Image { width, height, channels: 1, data: albedo.iter().map(|&v| v as f32).collect() },
        Some(c) => {
            let m = width * height;
            Image { width, height, channels: 3, data: (0..3 * m).map(|i| (c[i] * albedo[i % m]) as f32).collect() }
        }
    }
}

/// A plane (height, a relit image) as a one-channel f32 image.
pub fn plane_image(plane: &[f64], width: usize, height: usize) -> Image {
    Image { width, height, channels: 1, data: plane.iter().map(|&v| v as f32).collect() }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Dong `item 24`: the exported normal equals `normalise(−p, −q, 1)`, and the two
    /// conventions differ only in green.
    #[test]
    fn normal_maps_encode_the_gradient_normal() {
        let (p, q) = (vec![0.3, 0.0], vec![0.0, -0.4]);
        let gl = normal_map(&p, &q, 2, 1, GreenAxis::OpenGl);
        let dx = normal_map(&p, &q, 2, 1, GreenAxis::DirectX);
        for j in 0..2 {
            let n = normal(p[j], q[j]);
            assert!((gl.get(j, 0, 0) as f64 - (n.x + 1.0) / 2.0).abs() < 1e-7);
            assert!((gl.get(j, 0, 2) as f64 - (n.z + 1.0) / 2.0).abs() < 1e-7);
            assert!((gl.get(j, 0, 1) as f64 - (1.0 - n.y) / 2.0).abs() < 1e-7);
            assert!((dx.get(j, 0, 1) as f64 - (1.0 + n.y) / 2.0).abs() < 1e-7);
            assert_eq!(gl.get(j, 0, 0), dx.get(j, 0, 0));
        }
        // A surface rising toward the top row (q < 0) faces down the image: OpenGL green < ½.
        assert!(gl.get(1, 0, 1) < 0.5);
        // A slope rising toward +x (p > 0) faces −x: red < ½.
        assert!(gl.get(0, 0, 0) < 0.5);
    }
}
