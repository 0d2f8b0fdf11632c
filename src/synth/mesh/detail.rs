//! The relief a displaced mesh leaves out, as a normal map [references: frasson §5.3.2]: the
//! mesh carries the depth only at its grid vertices and linearly between them, so a normal map
//! built from the whole depth would count the large shapes twice (once in the geometry, once in
//! the shading). This one is built from the residual: the depth minus its linear interpolation
//! over the displaced triangle that covers each texel.

use glam::{Vec2, Vec3};

use super::displace::{sample_bilinear, Displaced};
use crate::raster::Image;

/// At each texel of a `width × height` texture laid on through the faces' UVs (v up): the depth
/// minus the depth the displaced mesh holds there (linear over the triangle covering the texel
/// centre, from its vertices' depths); 0 where no face covers the texel.
pub fn residual_height(d: &Displaced, depth: &Image, width: usize, height: usize) -> Image {
    let mut out = Image::new(width, height, 1);
    if width == 0 || height == 0 || depth.width == 0 || depth.height == 0 {
        return out;
    }
    let texel = |uv: Vec2| Vec2::new(uv.x * width as f32, (1.0 - uv.y) * height as f32);
    for f in &d.faces {
        let g: Vec<f32> = f.uvs.iter().map(|&uv| sample_bilinear(depth, uv)).collect();
        for t in &f.triangles {
            let [a, b, c] = t.map(|i| texel(f.uvs[i as usize]));
            let area = (b - a).perp_dot(c - a);
            if area.abs() < 1e-12 || !area.is_finite() {
                continue;
            }
            let lo = a.min(b).min(c).max(Vec2::ZERO);
            let hi = a.max(b).max(c).min(Vec2::new(width as f32, height as f32));
            for y in (lo.y.floor() as usize)..(hi.y.ceil() as usize).min(height) {
                for x in (lo.x.floor() as usize)..(hi.x.ceil() as usize).min(width) {
                    let p = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                    let (wa, wb) = ((c - b).perp_dot(p - b) / area, (a - c).perp_dot(p - c) / area);
                    let wc = 1.0 - wa - wb;
                    if wa < -1e-5 || wb < -1e-5 || wc < -1e-5 {
                        continue;
                    }
                    let mesh = wa * g[t[0] as usize] + wb * g[t[1] as usize] + wc * g[t[2] as usize];
                    let uv = Vec2::new(p.x / width as f32, 1.0 - p.y / height as f32);
                    out.set(x, y, 0, sample_bilinear(depth, uv) - mesh);
                }
            }
        }
    }
    out
}

/// Mesh units per texel of a `width × height` texture on `d`'s undisplaced faces: the square
/// root of the faces' area over their UV area in texels (1 when the UVs have no area).
pub fn texel_size(d: &Displaced, width: usize, height: usize) -> f32 {
    let (mut world, mut texels) = (0.0f64, 0.0f64);
    for f in &d.faces {
        let (p, uv) = (&f.corner_positions, &f.corner_uvs);
        for k in 1..p.len().saturating_sub(1) {
            world += f64::from((p[k] - p[0]).cross(p[k + 1] - p[0]).length()) * 0.5;
            let (e1, e2) = (uv[k] - uv[0], uv[k + 1] - uv[0]);
            texels += f64::from(e1.perp_dot(e2).abs()) * 0.5 * (width * height) as f64;
        }
    }
    if texels > 0.0 && world > 0.0 {
        (world / texels).sqrt() as f32
    } else {
        1.0
    }
}

/// A tangent-space normal map (RGB in [0, 1], +Y along increasing v, i.e. up in the image) of
/// the surface `scale · h` over texels `texel` mesh units wide; central differences, clamped at
/// the border.
pub fn normal_map(h: &Image, scale: f32, texel: f32) -> Image {
    let (w, ht) = (h.width, h.height);
    let at = |x: isize, y: isize| h.get(x.clamp(0, w as isize - 1) as usize, y.clamp(0, ht as isize - 1) as usize, 0);
    let k = scale / (2.0 * texel.max(f32::MIN_POSITIVE));
    Image::from_fn(w, ht, 3, |x, y, c| {
        let (x, y) = (x as isize, y as isize);
        let dx = (at(x + 1, y) - at(x - 1, y)) * k;
        // Image rows grow down, v grows up.
        let dv = (at(x, y - 1) - at(x, y + 1)) * k;
        let n = Vec3::new(-dx, -dv, 1.0).normalize();
        n[c] * 0.5 + 0.5
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::mesh::displace::{displace, DisplaceParams, Subdiv};
    use crate::synth::mesh::Mesh;

    fn quad() -> Mesh {
        Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
            faces: vec![crate::synth::mesh::Face { positions: vec![0, 1, 2, 3], uvs: vec![0, 1, 2, 3] }],
        }
    }

    fn params(n: u32) -> DisplaceParams {
        DisplaceParams { scale: 0.1, mid: 0.5, subdiv: Subdiv::Fixed(n), max_vertices: 1 << 20 }
    }

    #[test]
    fn a_ramp_the_mesh_holds_leaves_no_residual_and_a_flat_normal_map() {
        let ramp = Image::from_fn(64, 64, 1, |x, _, _| x as f32 / 63.0);
        let d = displace(&quad(), &ramp, &params(4)).unwrap();
        let r = residual_height(&d, &ramp, 64, 64);
        // Away from the outer cells, where the sampler clamps at the border and the depth stops
        // being linear in u.
        let worst =
            (0..64).flat_map(|y| (16..48).map(move |x| (x, y))).fold(0.0f32, |m, (x, y)| m.max(r.get(x, y, 0).abs()));
        assert!(worst < 1e-4, "linear depth is all in the mesh: {worst}");
        let n = normal_map(&r, 0.1, texel_size(&d, 64, 64));
        for (x, y) in [(10, 10), (40, 50)] {
            assert!((n.get(x, y, 2) - 1.0).abs() < 1e-3);
        }
    }

    #[test]
    fn detail_finer_than_the_grid_stays_in_the_normal_map() {
        // A bump 8 texels wide on a grid of 4 cells (16 texels each): the mesh misses most of it.
        let bump = Image::from_fn(64, 64, 1, |x, y, _| {
            let r2 = ((x as f32 - 24.5).powi(2) + (y as f32 - 24.5).powi(2)) / 16.0;
            0.5 + 0.4 * (-r2).exp()
        });
        let coarse = displace(&quad(), &bump, &params(4)).unwrap();
        let fine = displace(&quad(), &bump, &params(64)).unwrap();
        let energy = |d: &Displaced| residual_height(d, &bump, 64, 64).data.iter().map(|v| v * v).sum::<f32>();
        let whole = bump.data.iter().map(|v| (v - 0.5) * (v - 0.5)).sum::<f32>();
        assert!(energy(&coarse) > 0.3 * whole, "{} of {whole}", energy(&coarse));
        assert!(energy(&coarse) > 20.0 * energy(&fine), "{} vs {}", energy(&coarse), energy(&fine));
        // The bump's left flank faces −x (red below 0.5), its top flank (smaller rows, larger v)
        // faces +v (green above 0.5).
        let r = residual_height(&coarse, &bump, 64, 64);
        let n = normal_map(&r, 0.1, texel_size(&coarse, 64, 64));
        assert!(n.get(21, 24, 0) < 0.5 && n.get(28, 24, 0) > 0.5);
        assert!(n.get(24, 21, 1) > 0.5 && n.get(24, 28, 1) < 0.5);
        assert!((texel_size(&coarse, 64, 64) - 1.0 / 64.0).abs() < 1e-6);
    }
}
