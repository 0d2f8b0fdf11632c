//! Region maps: per-pixel values that follow the regions of a mesh, the maps texture artists
//! otherwise build by hand with flood fills (tessera's own; the thesis's regions are what they
//! follow, [references: frasson §3.1]): the region's id, a seeded random value per region, a
//! UV frame along the region's major axis, the distance to the region's edge, and the
//! direction of its major axis. Any layer can then use a structure as a guide, mask or
//! blend weight.

use rayon::prelude::*;

use crate::raster::Image;
use crate::synth::rng::derive_seed;
use crate::synth::structure::analysis::ellipse::{eigen, polygon_moments};
use crate::synth::structure::analysis::labels_import::rasterize_polygons;
use crate::synth::structure::{Mesh, Point, NO_REGION};

/// Which value a region map holds. Pixels outside every region are 0 (a zero vector for
/// `Axis`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum RegionField {
    /// `(i + 1) / n` for region `i` of `n`: distinct per region, 0 outside.
    Id,
    /// A uniform value in `[0, 1)` per region, from the seed and the region index.
    Random,
    /// Position along the region's major axis, 0 at one extreme of the region, 1 at the other.
    U,
    /// Position along the region's minor axis, 0 to 1 across the region.
    V,
    /// Distance to the region's boundary divided by the largest such distance in the region:
    /// 0 on the edge, 1 at the region's deepest pixel.
    Edge,
    /// Distance to the region's boundary in pixels of the map.
    EdgePixels,
    /// A 2-channel orientation field `(cos θ, sin θ)` of the region's major axis.
    Axis,
}

/// The region map of `mesh` (coordinates in a `domain = [w, h]` frame) at `width × height`
/// pixels: mesh coordinates are scaled to the map, so a map of another size than the
/// structure's surface follows the same regions.
pub fn region_map(mesh: &Mesh, domain: [f64; 2], width: usize, height: usize, field: RegionField, seed: u64) -> Image {
    let (sx, sy) = (width as f64 / domain[0].max(1e-9), height as f64 / domain[1].max(1e-9));
    let polygons: Vec<Vec<Point>> = mesh
        .regions
        .iter()
        .map(|r| r.iter().map(|&i| [mesh.vertices[i][0] * sx, mesh.vertices[i][1] * sy]).collect())
        .collect();
    let labels = rasterize_polygons(&polygons, width, height);
    let n = polygons.len();
    let frames: Vec<Frame> = polygons.iter().map(|p| Frame::of(p)).collect();
    let channels = if field == RegionField::Axis { 2 } else { 1 };
    let mut img = Image::new(width, height, channels);
    let plane = width * height;
    // Per pixel: the value, and for `Edge` the raw distance normalised afterwards.
    let values: Vec<[f32; 2]> = (0..plane)
        .into_par_iter()
        .map(|i| {
            let id = labels.data[i];
            if id == NO_REGION {
                return [0.0, 0.0];
            }
            let r = id as usize;
            let c = [(i % width) as f64 + 0.5, (i / width) as f64 + 0.5];
            match field {
                RegionField::Id => [((r + 1) as f64 / n as f64) as f32, 0.0],
                RegionField::Random => {
                    let s = derive_seed(seed, "region", &r.to_string());
                    [((s >> 40) as f64 / (1u64 << 24) as f64) as f32, 0.0]
                }
                RegionField::U => [frames[r].uv(c)[0] as f32, 0.0],
                RegionField::V => [frames[r].uv(c)[1] as f32, 0.0],
                RegionField::Edge | RegionField::EdgePixels => [edge_distance(&polygons[r], c) as f32, 0.0],
                RegionField::Axis => [frames[r].axis[0] as f32, frames[r].axis[1] as f32],
            }
        })
        .collect();
    if field == RegionField::Edge {
        let mut deepest = vec![0f32; n];
        for (i, v) in values.iter().enumerate() {
            let id = labels.data[i];
            if id != NO_REGION {
                deepest[id as usize] = deepest[id as usize].max(v[0]);
            }
        }
        for (i, v) in values.iter().enumerate() {
            let id = labels.data[i];
            if id != NO_REGION && deepest[id as usize] > 0.0 {
                img.data[i] = v[0] / deepest[id as usize];
            }
        }
        return img;
    }
    for (i, v) in values.iter().enumerate() {
        img.data[i] = v[0];
        if channels == 2 {
            img.data[plane + i] = v[1];
        }
    }
    img
}

/// A region's principal frame: its major-axis direction and the extent of its vertices
/// along both axes.
struct Frame {
    axis: Point,
    origin: Point,
    min: [f64; 2],
    span: [f64; 2],
}

impl Frame {
    fn of(poly: &[Point]) -> Frame {
        let (origin, theta) = match polygon_moments(poly) {
            Some(m) => (m.centroid, eigen(m.cov).2),
            None => (poly.first().copied().unwrap_or([0.0, 0.0]), 0.0),
        };
        let axis = [theta.cos(), theta.sin()];
        let (mut min, mut max) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in poly {
            let d = [p[0] - origin[0], p[1] - origin[1]];
            let uv = [d[0] * axis[0] + d[1] * axis[1], -d[0] * axis[1] + d[1] * axis[0]];
            for k in 0..2 {
                min[k] = min[k].min(uv[k]);
                max[k] = max[k].max(uv[k]);
            }
        }
        let span = [(max[0] - min[0]).max(1e-9), (max[1] - min[1]).max(1e-9)];
        Frame { axis, origin, min, span }
    }

    fn uv(&self, p: Point) -> [f64; 2] {
        let d = [p[0] - self.origin[0], p[1] - self.origin[1]];
        let u = d[0] * self.axis[0] + d[1] * self.axis[1];
        let v = -d[0] * self.axis[1] + d[1] * self.axis[0];
        [((u - self.min[0]) / self.span[0]).clamp(0.0, 1.0), ((v - self.min[1]) / self.span[1]).clamp(0.0, 1.0)]
    }
}

/// Distance from `c` to the nearest edge of the closed polygon.
fn edge_distance(poly: &[Point], c: Point) -> f64 {
    let mut best = f64::INFINITY;
    for k in 0..poly.len() {
        let (p, q) = (poly[k], poly[(k + 1) % poly.len()]);
        let d = [q[0] - p[0], q[1] - p[1]];
        let e = [c[0] - p[0], c[1] - p[1]];
        let t = ((e[0] * d[0] + e[1] * d[1]) / (d[0] * d[0] + d[1] * d[1]).max(1e-18)).clamp(0.0, 1.0);
        let f = [e[0] - t * d[0], e[1] - t * d[1]];
        best = best.min(f[0] * f[0] + f[1] * f[1]);
    }
    best.sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two rectangles side by side: a wide one (major axis along x) and a tall one.
    fn two_boxes() -> Mesh {
        Mesh {
            vertices: vec![[0.0, 0.0], [40.0, 0.0], [40.0, 20.0], [0.0, 20.0], [50.0, 0.0], [50.0, 20.0]],
            regions: vec![vec![0, 1, 2, 3], vec![1, 4, 5, 2]],
        }
    }

    fn at(img: &Image, x: usize, y: usize, c: usize) -> f32 {
        img.data[c * img.plane_len() + y * img.width + x]
    }

    #[test]
    fn id_and_random_are_constant_per_region_and_distinct() {
        let m = two_boxes();
        let id = region_map(&m, [50.0, 20.0], 50, 20, RegionField::Id, 1);
        assert_eq!(at(&id, 5, 5, 0), 0.5);
        assert_eq!(at(&id, 45, 5, 0), 1.0);
        let r = region_map(&m, [50.0, 20.0], 50, 20, RegionField::Random, 1);
        assert_eq!(at(&r, 2, 2, 0), at(&r, 38, 17, 0));
        assert_ne!(at(&r, 2, 2, 0), at(&r, 45, 5, 0));
        assert_ne!(r, region_map(&m, [50.0, 20.0], 50, 20, RegionField::Random, 2));
    }

    #[test]
    fn uv_follows_the_major_axis_and_edge_distance_peaks_inside() {
        let m = two_boxes();
        let u = region_map(&m, [50.0, 20.0], 50, 20, RegionField::U, 0);
        // The wide box's u runs along x (either direction): its ends are near 0 and 1.
        let (a, b) = (at(&u, 0, 10, 0), at(&u, 39, 10, 0));
        assert!((a - b).abs() > 0.95, "{a} {b}");
        let v = region_map(&m, [50.0, 20.0], 50, 20, RegionField::V, 0);
        assert!((at(&v, 20, 0, 0) - at(&v, 20, 19, 0)).abs() > 0.9);
        // The tall box's axis is vertical.
        let axis = region_map(&m, [50.0, 20.0], 50, 20, RegionField::Axis, 0);
        assert!(at(&axis, 45, 10, 1).abs() > 0.99 && at(&axis, 20, 10, 0).abs() > 0.99);
        let e = region_map(&m, [50.0, 20.0], 50, 20, RegionField::Edge, 0);
        assert_eq!(e.data.iter().cloned().fold(0f32, f32::max), 1.0);
        assert!(at(&e, 20, 10, 0) > 0.9 && at(&e, 0, 10, 0) < 0.1);
        let px = region_map(&m, [50.0, 20.0], 50, 20, RegionField::EdgePixels, 0);
        assert_eq!(at(&px, 20, 10, 0), 9.5);
    }

    #[test]
    fn a_larger_map_follows_the_same_regions_and_threads_do_not_matter() {
        let m = two_boxes();
        let small = region_map(&m, [50.0, 20.0], 50, 20, RegionField::Id, 0);
        let big = region_map(&m, [50.0, 20.0], 100, 40, RegionField::Id, 0);
        assert_eq!(at(&small, 45, 5, 0), at(&big, 90, 10, 0));
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let one = pool.install(|| region_map(&m, [50.0, 20.0], 64, 32, RegionField::Edge, 3));
        assert_eq!(one, region_map(&m, [50.0, 20.0], 64, 32, RegionField::Edge, 3));
    }
}
