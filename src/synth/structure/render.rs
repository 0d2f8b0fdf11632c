//! Views of a structure for people and for golden files: label rasters (colour and 16-bit
//! ids), anti-aliased edge rasters, ellipse overlays, SVG drawings and mesh JSON.

use std::fmt::Write;

use rayon::prelude::*;

use super::relaxation::metric::MetricKind;
use super::relaxation::voronoi::{distance_field, Domain};
use super::validate::point_segment_distance;
use super::{Ellipse, Labels, Mesh, Point, NO_REGION};
use crate::raster::Image;

/// A stable, well-spread colour per region id (golden-ratio hue walk), black for none.
pub fn region_colour(id: u32) -> [f32; 3] {
    if id == NO_REGION {
        return [0.0, 0.0, 0.0];
    }
    let h = (id as f64 * 0.618_033_988_749_895).fract();
    let s = 0.45 + 0.25 * ((id as f64 * 0.371).fract());
    let v = 0.70 + 0.25 * ((id as f64 * 0.529).fract());
    hsv(h, s, v)
}

fn hsv(h: f64, s: f64, v: f64) -> [f32; 3] {
    let i = (h * 6.0).floor();
    let f = h * 6.0 - i;
    let (p, q, t) = (v * (1.0 - s), v * (1.0 - f * s), v * (1.0 - (1.0 - f) * s));
    let (r, g, b) = match i as i32 % 6 {
        0 => (v, t, p),
        1 => (q, v, p),
        2 => (p, v, t),
        3 => (p, q, v),
        4 => (t, p, v),
        _ => (v, p, q),
    };
    [r as f32, g as f32, b as f32]
}

/// Each region in its own colour.
pub fn labels_colour(labels: &Labels) -> Image {
    let (w, h) = (labels.width, labels.height);
    let mut img = Image::new(w, h, 3);
    for (i, &id) in labels.data.iter().enumerate() {
        let c = region_colour(id);
        for (ch, v) in c.iter().enumerate() {
            img.data[ch * w * h + i] = *v;
        }
    }
    img
}

/// Region ids as a one-channel image whose 16-bit PNG encoding holds the ids exactly
/// (`id / 65535`); unlabelled pixels are 65535. `None` when an id does not fit.
pub fn labels_u16(labels: &Labels) -> Option<Image> {
    let mut img = Image::new(labels.width, labels.height, 1);
    for (o, &id) in img.data.iter_mut().zip(&labels.data) {
        let v = if id == NO_REGION {
            65535
        } else if id < 65535 {
            id
        } else {
            return None;
        };
        *o = v as f32 / 65535.0;
    }
    Some(img)
}

/// The mesh's edges, each once, as index pairs in ascending order.
pub fn mesh_edges(mesh: &Mesh) -> Vec<[usize; 2]> {
    let mut edges: Vec<[usize; 2]> = mesh
        .regions
        .iter()
        .flat_map(|r| (0..r.len()).map(move |i| (r[i], r[(i + 1) % r.len()])))
        .map(|(a, b)| if a < b { [a, b] } else { [b, a] })
        .collect();
    edges.sort_unstable();
    edges.dedup();
    edges
}

/// White background, black edges `width` pixels wide, anti-aliased by distance to the
/// nearest segment (coverage = clamp(width/2 − d + 0.5)).
pub fn edges_raster(mesh: &Mesh, width: usize, height: usize, line_width: f64) -> Image {
    let segments: Vec<(Point, Point)> =
        mesh_edges(mesh).iter().map(|&[a, b]| (mesh.vertices[a], mesh.vertices[b])).collect();
    let coverage = rasterize_segments(&segments, width, height, line_width);
    let mut img = Image::new(width, height, 1);
    for (o, c) in img.data.iter_mut().zip(coverage) {
        *o = 1.0 - c;
    }
    img
}

/// Per-pixel coverage in [0, 1] of thick segments; each row is independent, so the result
/// does not depend on the thread count.
fn rasterize_segments(segments: &[(Point, Point)], width: usize, height: usize, line_width: f64) -> Vec<f32> {
    let half = line_width / 2.0;
    let reach = half + 1.0;
    // Bucket segments by the rows they can touch, so each row tests only its neighbours.
    let mut rows: Vec<Vec<usize>> = vec![Vec::new(); height];
    for (i, (a, b)) in segments.iter().enumerate() {
        let y0 = (a[1].min(b[1]) - reach).floor().max(0.0) as usize;
        let y1 = ((a[1].max(b[1]) + reach).ceil().max(0.0) as usize).min(height);
        for row in rows.iter_mut().take(y1).skip(y0) {
            row.push(i);
        }
    }
    let mut out = vec![0f32; width * height];
    out.par_chunks_mut(width.max(1)).enumerate().for_each(|(y, line)| {
        let py = y as f64 + 0.5;
        for &si in &rows[y] {
            let (a, b) = segments[si];
            let x0 = (a[0].min(b[0]) - reach).floor().max(0.0) as usize;
            let x1 = ((a[0].max(b[0]) + reach).ceil().max(0.0) as usize).min(width);
            for (x, o) in line.iter_mut().enumerate().take(x1).skip(x0) {
                let d = point_segment_distance([x as f64 + 0.5, py], a, b);
                let c = (half - d + 0.5).clamp(0.0, 1.0) as f32;
                if c > *o {
                    *o = c;
                }
            }
        }
    });
    out
}

/// Points on an ellipse's outline, for drawing.
pub fn ellipse_outline(e: &Ellipse, segments: usize) -> Vec<Point> {
    let (s, c) = e.theta.sin_cos();
    (0..segments)
        .map(|i| {
            let t = i as f64 / segments as f64 * std::f64::consts::TAU;
            let (u, v) = (e.a * t.cos(), e.b * t.sin());
            [e.center[0] + u * c - v * s, e.center[1] + u * s + v * c]
        })
        .collect()
}

/// The label colour view with each ellipse drawn over it (black outline, white centre dot).
pub fn ellipses_overlay(labels: &Labels, ellipses: &[Ellipse]) -> Image {
    let mut img = labels_colour(labels);
    let (w, h) = (labels.width, labels.height);
    let mut segments = Vec::new();
    for e in ellipses {
        let pts = ellipse_outline(e, 48);
        for i in 0..pts.len() {
            segments.push((pts[i], pts[(i + 1) % pts.len()]));
        }
    }
    let outline = rasterize_segments(&segments, w, h, 1.5);
    let dots: Vec<(Point, Point)> = ellipses.iter().map(|e| (e.center, e.center)).collect();
    let centres = rasterize_segments(&dots, w, h, 3.0);
    for i in 0..w * h {
        for ch in 0..3 {
            let v = &mut img.data[ch * w * h + i];
            *v *= 1.0 - outline[i];
            *v = *v * (1.0 - centres[i]) + centres[i];
        }
    }
    img
}

/// Rounds to 1e-6 for stable text output (F39).
fn r6(v: f64) -> f64 {
    let r = (v * 1e6).round() / 1e6;
    if r == 0.0 {
        0.0 // no "-0"
    } else {
        r
    }
}

/// The mesh as JSON: vertices rounded to 1e-6, regions as vertex cycles.
pub fn mesh_json(mesh: &Mesh, width: usize, height: usize) -> String {
    let mut s = String::new();
    let _ = write!(s, "{{\n  \"units\": \"px\",\n  \"size\": [{width}, {height}],\n  \"vertices\": [");
    for (i, v) in mesh.vertices.iter().enumerate() {
        let _ = write!(s, "{}[{}, {}]", if i == 0 { "\n    " } else { ",\n    " }, r6(v[0]), r6(v[1]));
    }
    s.push_str("\n  ],\n  \"edges\": [");
    for (i, [a, b]) in mesh_edges(mesh).iter().enumerate() {
        let _ = write!(s, "{}[{a}, {b}]", if i == 0 { "\n    " } else { ",\n    " });
    }
    s.push_str("\n  ],\n  \"regions\": [");
    for (i, r) in mesh.regions.iter().enumerate() {
        let ids: Vec<String> = r.iter().map(|v| v.to_string()).collect();
        let _ = write!(s, "{}[{}]", if i == 0 { "\n    " } else { ",\n    " }, ids.join(", "));
    }
    s.push_str("\n  ]\n}\n");
    s
}

/// The mesh as an SVG drawing: filled regions in their label colours, edges on top.
pub fn mesh_svg(mesh: &Mesh, width: usize, height: usize, stroke: f64) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{height}\" viewBox=\"0 0 {width} {height}\">"
    );
    let _ = writeln!(s, "<g stroke=\"#202020\" stroke-width=\"{}\" stroke-linejoin=\"round\">", r6(stroke));
    for (id, r) in mesh.regions.iter().enumerate() {
        let c = region_colour(id as u32);
        let hex = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        let mut d = String::new();
        for (i, &v) in r.iter().enumerate() {
            let p = mesh.vertices[v];
            let _ = write!(d, "{}{} {} ", if i == 0 { "M" } else { "L" }, r6(p[0]), r6(p[1]));
        }
        d.push('Z');
        let _ = writeln!(s, "<path fill=\"#{:02x}{:02x}{:02x}\" d=\"{d}\"/>", hex(c[0]), hex(c[1]), hex(c[2]));
    }
    s.push_str("</g>\n</svg>\n");
    s
}

/// The mesh's edges in black with each region's associated original (`placed`, one per
/// region), placed on it, in red: the thesis's Fig. 3.20 view.
pub fn closest(mesh: &Mesh, placed: &[Option<Vec<Point>>], w: usize, h: usize, edge_width: f64) -> Image {
    let edges = edges_raster(mesh, w, h, edge_width);
    let mut vertices = Vec::new();
    let mut regions = Vec::new();
    for poly in placed.iter().flatten() {
        let start = vertices.len();
        vertices.extend_from_slice(poly);
        regions.push((start..vertices.len()).collect());
    }
    let originals = edges_raster(&Mesh { vertices, regions }, w, h, edge_width);
    let n = w * h;
    let mut img = Image::new(w, h, 3);
    for i in 0..n {
        let (e, o) = (edges.data[i], originals.data[i]);
        img.data[i] = e;
        img.data[n + i] = e * o;
        img.data[2 * n + i] = e * o;
    }
    img
}

/// Distance of each pixel to its region's generator (`sized`, as the final Voronoi step
/// saw them), 0 (black) at the generator and 1 at the farthest labelled pixel: the thesis's
/// Fig. 3.14 view.
pub fn distance(labels: &Labels, sized: &[Ellipse], metric: MetricKind) -> Image {
    let (w, h) = (labels.width, labels.height);
    let domain = Domain { width: w, height: h, allowed: None, metric_map: None };
    let d = distance_field(&domain, sized, labels, metric);
    let max = d.iter().copied().filter(|v| v.is_finite()).fold(0.0f64, f64::max).max(1e-12);
    let mut img = Image::new(w, h, 1);
    for (o, v) in img.data.iter_mut().zip(d) {
        *o = if v.is_finite() { (v / max) as f32 } else { 1.0 };
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_squares() -> Mesh {
        Mesh {
            vertices: vec![[2.0, 2.0], [10.0, 2.0], [18.0, 2.0], [18.0, 10.0], [10.0, 10.0], [2.0, 10.0]],
            regions: vec![vec![0, 5, 4, 1], vec![1, 4, 3, 2]],
        }
    }

    #[test]
    fn shared_edges_are_listed_once() {
        assert_eq!(mesh_edges(&two_squares()).len(), 7);
    }

    #[test]
    fn edge_raster_marks_edges_only() {
        let img = edges_raster(&two_squares(), 20, 12, 1.0);
        // A 1 px line along the boundary x = 10 covers half of each pixel beside it.
        assert!((img.get(9, 6, 0) - 0.5).abs() < 1e-6 && (img.get(10, 6, 0) - 0.5).abs() < 1e-6);
        assert!(img.get(6, 6, 0) > 0.99, "a region interior stays white");
        let wide = edges_raster(&two_squares(), 20, 12, 3.0);
        let ink = |i: &Image| i.data.iter().map(|v| 1.0 - v).sum::<f32>();
        assert!(ink(&wide) > 2.0 * ink(&img), "a wider line puts more ink down");
    }

    #[test]
    fn u16_labels_round_trip_through_png16() {
        let labels = Labels { width: 3, height: 1, data: vec![0, 4321, NO_REGION] };
        let img = labels_u16(&labels).expect("fits");
        let png = crate::raster::io::encode_png(&img, 16).expect("encode");
        let back = crate::raster::io::decode(&png).expect("decode");
        let ids: Vec<u32> = back.data.iter().map(|v| (v * 65535.0).round() as u32).collect();
        assert_eq!(ids, vec![0, 4321, 65535]);
        assert!(labels_u16(&Labels { width: 1, height: 1, data: vec![70000] }).is_none());
    }

    #[test]
    fn text_outputs_are_stable_and_rounded() {
        let mut m = two_squares();
        m.vertices[0] = [2.000_000_04, -0.000_000_01];
        let json = mesh_json(&m, 20, 12);
        assert!(json.contains("[2, 0]"), "{json}");
        assert_eq!(json, mesh_json(&m, 20, 12));
        let svg = mesh_svg(&m, 20, 12, 1.0);
        assert!(svg.starts_with("<svg") && svg.matches("<path").count() == 2);
    }

    #[test]
    fn ellipse_outline_lies_on_the_ellipse() {
        let e = Ellipse { center: [5.0, 7.0], a: 4.0, b: 2.0, theta: 0.5 };
        for p in ellipse_outline(&e, 16) {
            let (s, c) = e.theta.sin_cos();
            let (dx, dy) = (p[0] - 5.0, p[1] - 7.0);
            let (u, v) = (dx * c + dy * s, -dx * s + dy * c);
            assert!(((u / 4.0).powi(2) + (v / 2.0).powi(2) - 1.0).abs() < 1e-12);
        }
    }
}
