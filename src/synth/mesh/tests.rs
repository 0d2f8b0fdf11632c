//! Tests of displacement and seam zipping (Frasson Ch. 5, checklist F33 and F34): displacement
//! values against an independent height, the subdivision rule, strips that use only seam-edge
//! vertices with monotone links for `N1 ≠ N2` (down to `N1 = 2`), and a displaced cube that is
//! closed and consistently oriented once zipped.

use std::collections::BTreeMap;

use glam::{Vec2, Vec3};

use super::displace::{displace, face_vertex_count, subdivision_level, DisplaceParams, Displaced, Subdiv};
use super::meshes::{Face, Mesh, TriMesh};
use super::seam::{strip_triangles, zip, zip_links, Side, VertexRef};
use crate::raster::Image;

/// A quad in the plane z = 0 over `[x0, x1] × [0, 1]` with UVs over `[u0, u1] × [v0, v1]`.
fn quad_mesh(quads: &[([f32; 2], [f32; 4])]) -> Mesh {
    let mut m = Mesh::default();
    for &([x0, x1], [u0, v0, u1, v1]) in quads {
        let base = m.positions.len() as u32;
        let ubase = m.uvs.len() as u32;
        m.positions.extend([
            Vec3::new(x0, 0.0, 0.0),
            Vec3::new(x1, 0.0, 0.0),
            Vec3::new(x1, 1.0, 0.0),
            Vec3::new(x0, 1.0, 0.0),
        ]);
        m.uvs.extend([Vec2::new(u0, v0), Vec2::new(u1, v0), Vec2::new(u1, v1), Vec2::new(u0, v1)]);
        m.faces.push(Face { positions: (base..base + 4).collect(), uvs: (ubase..ubase + 4).collect() });
    }
    m
}

/// Welds positions shared by several quads of [`quad_mesh`] (same point, same index).
fn weld(mut m: Mesh) -> Mesh {
    let mut first: Vec<Vec3> = Vec::new();
    let remap: Vec<u32> = m
        .positions
        .iter()
        .map(|p| match first.iter().position(|q| q.distance(*p) < 1e-6) {
            Some(i) => i as u32,
            None => {
                first.push(*p);
                (first.len() - 1) as u32
            }
        })
        .collect();
    for f in &mut m.faces {
        for i in &mut f.positions {
            *i = remap[*i as usize];
        }
    }
    m.positions = first;
    m
}

fn params(scale: f32, subdiv: Subdiv) -> DisplaceParams {
    DisplaceParams { scale, subdiv, ..DisplaceParams::default() }
}

fn wavy(size: usize) -> Image {
    Image::from_fn(size, size, 1, |x, y, _| 0.5 + 0.35 * ((x as f32 * 0.37).sin() * (y as f32 * 0.23).cos()))
}

#[test]
fn grey_half_gives_zero_displacement() {
    let mesh = quad_mesh(&[([0.0, 1.0], [0.0, 0.0, 1.0, 1.0])]);
    let grey = Image::from_fn(32, 32, 1, |_, _, _| 0.5);
    let d = displace(&mesh, &grey, &params(3.0, Subdiv::Auto)).unwrap();
    let f = &d.faces[0];
    assert_eq!(f.n, 16);
    assert!(f.positions.iter().all(|p| p.z == 0.0), "grey 0.5 moved a vertex");
    assert_eq!(d.folded_triangles, 0);
}

#[test]
fn vertices_move_by_scale_times_height_minus_half_along_the_normal() {
    // Texel x holds (x + 0.5) / w, so the bilinear height at u is u itself (away from the
    // clamped half texel at each border): the expected displacement is known without the
    // sampler under test.
    let w = 64;
    let ramp = Image::from_fn(w, 4, 1, |x, _, _| (x as f32 + 0.5) / w as f32);
    // A tilted quad, so the normal is not an axis.
    let corners =
        [Vec3::new(0.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 1.0), Vec3::new(2.0, 1.0, 1.0), Vec3::new(0.0, 1.0, 0.0)];
    let mesh = Mesh {
        positions: corners.to_vec(),
        uvs: vec![Vec2::new(0.1, 0.2), Vec2::new(0.9, 0.2), Vec2::new(0.9, 0.8), Vec2::new(0.1, 0.8)],
        faces: vec![Face { positions: vec![0, 1, 2, 3], uvs: vec![0, 1, 2, 3] }],
    };
    let normal = Vec3::new(-1.0, 0.0, 2.0).normalize();
    let scale = 0.7;
    let flat = displace(&mesh, &ramp, &params(0.0, Subdiv::Fixed(9))).unwrap();
    let moved = displace(&mesh, &ramp, &params(scale, Subdiv::Fixed(9))).unwrap();
    let (flat, moved) = (&flat.faces[0], &moved.faces[0]);
    assert!(moved.normal.distance(normal) < 1e-6);
    assert_eq!(moved.positions.len(), 100);
    for ((p0, p), uv) in flat.positions.iter().zip(&moved.positions).zip(&moved.uvs) {
        let expected = *p0 + scale * (uv.x - 0.5) * normal;
        assert!(p.distance(expected) < 1e-5, "vertex at uv {uv}: {p} instead of {expected}");
    }
    // And the sample points are the bilinear grid of the corners.
    let at = |s: f32, t: f32| {
        corners[0] * (1.0 - s) * (1.0 - t)
            + corners[1] * s * (1.0 - t)
            + corners[2] * s * t
            + corners[3] * (1.0 - s) * t
    };
    assert!(flat.positions[10 * 3 + 4].distance(at(4.0 / 9.0, 3.0 / 9.0)) < 1e-6);
}

#[test]
fn subdivision_follows_the_depth_resolution() {
    // Longest UV edge in texels, halved, rounded, clamped to [1, 256].
    let square = [Vec2::new(0.0, 0.0), Vec2::new(0.5, 0.0), Vec2::new(0.5, 0.25), Vec2::new(0.0, 0.25)];
    assert_eq!(subdivision_level(&square, 128, 128, Subdiv::Auto), 32);
    assert_eq!(subdivision_level(&square, 128, 512, Subdiv::Auto), 64, "the v edge is 128 texels on a 512-high map");
    let tiny = [Vec2::ZERO, Vec2::new(0.001, 0.0), Vec2::new(0.0, 0.001)];
    assert_eq!(subdivision_level(&tiny, 64, 64, Subdiv::Auto), 1);
    let huge = [Vec2::ZERO, Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)];
    assert_eq!(subdivision_level(&huge, 4096, 4096, Subdiv::Auto), 256);
    assert_eq!(subdivision_level(&huge, 64, 64, Subdiv::Fixed(5)), 5);
    assert_eq!(subdivision_level(&huge, 64, 64, Subdiv::Fixed(0)), 1);

    // The grids built have the counts the rule predicts, for triangles, quads and a pentagon.
    let pentagon = Mesh {
        positions: (0..5).map(|k| Vec3::new((k as f32 * 1.2566).cos(), (k as f32 * 1.2566).sin(), 0.0)).collect(),
        uvs: (0..5)
            .map(|k| Vec2::new(0.5 + 0.25 * (k as f32 * 1.2566).cos(), 0.5 + 0.25 * (k as f32 * 1.2566).sin()))
            .collect(),
        faces: vec![
            Face { positions: vec![0, 1, 2, 3, 4], uvs: vec![0, 1, 2, 3, 4] },
            Face { positions: vec![0, 1, 2], uvs: vec![0, 1, 2] },
        ],
    };
    let d = displace(&pentagon, &wavy(64), &params(0.1, Subdiv::Auto)).unwrap();
    for (f, k) in d.faces.iter().zip([5, 3]) {
        assert_eq!(f.positions.len() as u64, face_vertex_count(k, f.n));
        assert_eq!(f.edges.len(), k);
        assert!(f.edges.iter().all(|e| e.len() == f.n as usize + 1));
    }
    assert_eq!(d.faces[0].n, 9, "pentagon edge 0.294 UV × 64 texels / 2");
}

#[test]
fn too_many_vertices_are_refused_before_anything_is_built() {
    let mesh = quad_mesh(&[([0.0, 1.0], [0.0, 0.0, 1.0, 1.0])]);
    let p = DisplaceParams { max_vertices: 1000, subdiv: Subdiv::Fixed(256), ..DisplaceParams::default() };
    assert!(matches!(
        displace(&mesh, &wavy(8), &p),
        Err(super::displace::DisplaceError::TooManyVertices { needed: 66049, .. })
    ));
}

/// Checks F34 on one zipped seam: strip triangles on seam-edge vertices only, every side vertex
/// used, links monotone and one step apart.
fn check_strip(d: &Displaced, strip: &super::seam::Strip) {
    let on_a: std::collections::BTreeSet<u32> = strip.side_a.iter().copied().collect();
    let on_b: std::collections::BTreeSet<u32> = strip.side_b.iter().copied().collect();
    let mut used = std::collections::BTreeSet::new();
    for t in &strip.triangles {
        for r in t {
            let ok = (r.face == strip.face_a && on_a.contains(&r.vertex))
                || (r.face == strip.face_b && on_b.contains(&r.vertex));
            assert!(ok, "strip vertex {r:?} is not on the seam");
            used.insert(*r);
        }
    }
    for &v in &strip.side_a {
        assert!(used.contains(&VertexRef { face: strip.face_a, vertex: v }), "E1 vertex {v} unused");
    }
    for &v in &strip.side_b {
        assert!(used.contains(&VertexRef { face: strip.face_b, vertex: v }), "E2 vertex {v} unused");
    }
    let (n1, n2) = (strip.side_a.len() as u32, strip.side_b.len() as u32);
    assert_eq!(strip.links.first(), Some(&(0, 0)));
    assert_eq!(strip.links.last(), Some(&(n1 - 1, n2 - 1)));
    for w in strip.links.windows(2) {
        let (di, dj) = (w[1].0 - w[0].0, w[1].1 - w[0].1);
        assert!(matches!((di, dj), (1, 0) | (0, 1) | (1, 1)), "links {:?} -> {:?} cross or skip", w[0], w[1]);
    }
    assert!(strip.triangles.len() as u32 >= n1 + n2 - 2);
    let _ = d;
}

/// Undirected edge uses and directed edge counts of a triangle mesh.
type EdgeCounts = BTreeMap<(u32, u32), u32>;

fn edge_counts(m: &TriMesh) -> (EdgeCounts, EdgeCounts) {
    let mut undirected = BTreeMap::new();
    let mut directed = BTreeMap::new();
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *undirected.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            *directed.entry((a, b)).or_insert(0) += 1;
        }
    }
    (undirected, directed)
}

#[test]
fn two_faces_with_different_levels_zip_into_one_watertight_sheet() {
    // Face A's seam has N1 = 2 vertices (n = 1), face B's N2 = 9 (n = 8); then the other way.
    for (ua, ub) in [(0.03, 0.25), (0.25, 0.03), (0.1, 0.1)] {
        let mesh = weld(quad_mesh(&[([0.0, 1.0], [0.0, 0.0, ua, ua]), ([1.0, 2.0], [0.5, 0.5, 0.5 + ub, 0.5 + ub])]));
        let d = displace(&mesh, &wavy(64), &params(0.2, Subdiv::Auto)).unwrap();
        let seams = zip(&d);
        assert_eq!(seams.strips.len(), 1);
        let s = &seams.strips[0];
        assert_eq!(
            (s.side_a.len(), s.side_b.len()),
            (d.faces[s.face_a as usize].n as usize + 1, d.faces[s.face_b as usize].n as usize + 1)
        );
        check_strip(&d, s);
        let m = d.to_trimesh(&seams.strips, &seams.corners);
        let (undirected, directed) = edge_counts(&m);
        assert!(undirected.values().all(|&c| c <= 2), "an edge is used by 3 triangles");
        assert!(directed.values().all(|&c| c == 1), "two triangles run an edge the same way");
        // The border: the sheet's outline, a single loop of edges used once.
        let border: Vec<(u32, u32)> =
            directed.keys().copied().filter(|&(a, b)| !directed.contains_key(&(b, a))).collect();
        let next: BTreeMap<u32, u32> = border.iter().copied().collect();
        assert_eq!(next.len(), border.len(), "the border branches");
        let mut at = border[0].0;
        for _ in 0..border.len() {
            at = next[&at];
        }
        assert_eq!(at, border[0].0);
        let cycle_len = {
            let (mut k, mut v) = (1, next[&border[0].0]);
            while v != border[0].0 {
                v = next[&v];
                k += 1;
            }
            k
        };
        assert_eq!(cycle_len, border.len(), "more than one border loop");
        // Outline: each face's three outer sides (n cells each) plus the strip's two end links.
        assert_eq!(border.len() as u32, 3 * (d.faces[0].n + d.faces[1].n) + 2);
    }
}

#[test]
fn zip_links_for_unequal_sides() {
    let line =
        |n: usize, z: f32| -> Vec<Vec3> { (0..n).map(|i| Vec3::new(i as f32 / (n - 1) as f32, 0.0, z)).collect() };
    for (n1, n2) in [(2, 2), (2, 9), (9, 2), (5, 17), (17, 5), (3, 3), (2, 3)] {
        let (e1, e2) = (line(n1, 0.0), line(n2, 0.1));
        let links = zip_links(&e1, &e2);
        assert_eq!(links.first(), Some(&(0, 0)));
        assert_eq!(links.last(), Some(&((n1 - 1) as u32, (n2 - 1) as u32)));
        assert_eq!(links.len(), n1 + n2 - 1 - links.windows(2).filter(|w| w[1].0 > w[0].0 && w[1].1 > w[0].1).count());
        let tris = strip_triangles(&e1, &e2, &links);
        // A strip between two chains is a triangulated polygon of n1 + n2 vertices.
        assert_eq!(tris.len(), n1 + n2 - 2, "({n1}, {n2})");
        for t in &tris {
            assert!(t.iter().any(|s| matches!(s, Side::A(_))) && t.iter().any(|s| matches!(s, Side::B(_))));
        }
        // Nearest matching: with uniform sides, every link spans at most half the coarser step.
        let half = 0.5 / (n1.min(n2) - 1) as f32;
        for &(i, j) in &links {
            assert!((e1[i as usize].x - e2[j as usize].x).abs() <= half + 1e-6, "({n1}, {n2}): link ({i}, {j})");
        }
    }
    assert!(zip_links(&[], &[Vec3::ZERO]).is_empty());
}

/// A unit cube of six quads, outward, each with its own UV square of side `sizes[k]`.
fn cube(sizes: [f32; 6]) -> Mesh {
    let p = |i: u32| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32);
    let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let mut m = Mesh { positions: (0..8).map(p).collect(), ..Mesh::default() };
    for (k, q) in quads.iter().enumerate() {
        let s = sizes[k];
        let (u0, v0) = ((k % 3) as f32 / 3.0, (k / 3) as f32 / 2.0);
        let base = m.uvs.len() as u32;
        m.uvs.extend([Vec2::new(u0, v0), Vec2::new(u0 + s, v0), Vec2::new(u0 + s, v0 + s), Vec2::new(u0, v0 + s)]);
        m.faces.push(Face { positions: q.to_vec(), uvs: (base..base + 4).collect() });
    }
    m
}

#[test]
fn a_displaced_cube_zips_closed_and_consistently_oriented() {
    let mesh = cube([0.03, 0.1, 0.16, 0.25, 0.3, 0.2]);
    for f in &mesh.faces {
        let ps: Vec<Vec3> = f.positions.iter().map(|&i| mesh.positions[i as usize]).collect();
        let centre = ps.iter().copied().sum::<Vec3>() / 4.0;
        let n = super::displace::newell_normal(&ps).unwrap();
        assert!(n.dot(centre - Vec3::splat(0.5)) > 0.0, "test cube faces must face out");
    }
    let d = displace(&mesh, &wavy(64), &params(0.08, Subdiv::Auto)).unwrap();
    let levels: Vec<u32> = d.faces.iter().map(|f| f.n).collect();
    assert_eq!(levels, vec![1, 3, 5, 8, 10, 6]);
    let seams = zip(&d);
    assert_eq!(seams.strips.len(), 12, "one strip per cube edge");
    assert_eq!(seams.corners.len(), 8, "one fan per cube corner");
    assert!(seams.corners.iter().all(|c| c.corners.len() == 3 && c.triangles.len() == 1));
    for s in &seams.strips {
        check_strip(&d, s);
    }
    let m = d.to_trimesh(&seams.strips, &seams.corners);
    let (undirected, directed) = edge_counts(&m);
    assert!(undirected.values().all(|&c| c == 2), "a border or non-manifold edge in a closed cube");
    assert!(directed.values().all(|&c| c == 1), "inconsistent orientation");
    assert!(directed.keys().all(|&(a, b)| directed.contains_key(&(b, a))));
    // Euler characteristic of a sphere.
    let (v, e, f) = (m.positions.len() as i64, undirected.len() as i64, m.triangles.len() as i64);
    assert_eq!(v - e + f, 2);
    // Outward: positive enclosed volume, near the unit cube's (the wavy relief averages out).
    let volume: f32 = m
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            a.dot(b.cross(c)) / 6.0
        })
        .sum();
    assert!((volume - 1.0).abs() < 0.1, "volume {volume}");
}

#[test]
fn textured_seams_keep_the_cube_closed_by_position_and_read_the_faces_edges() {
    use super::seam_texture::SeamTextureParams;
    use super::textured::{texture_seams, SeamTexturing};
    let mesh = cube([0.03, 0.1, 0.16, 0.25, 0.3, 0.2]);
    // Nowhere grey: no vertex stays put, so the faces' vertices never coincide.
    let relief = Image::from_fn(64, 64, 1, |x, y, _| 0.7 + 0.2 * ((x as f32 * 0.37).sin() * (y as f32 * 0.23).cos()));
    let d = displace(&mesh, &relief, &params(0.08, Subdiv::Auto)).unwrap();
    let seams = zip(&d);
    let colour = Image::from_fn(96, 64, 3, |x, y, c| ((x * 7 + y * 3 + c * 5) % 23) as f32 / 23.0);
    let t = texture_seams(&d, &seams, &colour, &SeamTextureParams::default(), 1 << 24).unwrap();
    let closed = d.to_trimesh(&seams.strips, &seams.corners);
    assert_eq!(t.mesh.triangles.len(), closed.triangles.len());
    // Weld by exact position: the same closed, consistently oriented surface.
    let mut id: BTreeMap<[u32; 3], u32> = BTreeMap::new();
    let welded = TriMesh {
        triangles: t
            .mesh
            .triangles
            .iter()
            .map(|tri| {
                tri.map(|v| {
                    let key = t.mesh.positions[v as usize].to_array().map(f32::to_bits);
                    let n = id.len() as u32;
                    *id.entry(key).or_insert(n)
                })
            })
            .collect(),
        ..TriMesh::default()
    };
    let (undirected, directed) = edge_counts(&welded);
    assert!(undirected.values().all(|&c| c == 2));
    assert!(directed.values().all(|&c| c == 1));
    // The colour texture sits unchanged on top of the combined texture.
    assert!(t.texture.width >= colour.width && t.texture.height > colour.height);
    for (x, y) in [(0, 0), (95, 63), (40, 17)] {
        assert_eq!(t.texture.get(x, y, 1), colour.get(x, y, 1));
    }
    // Face vertices point at the same texel as before; strip vertices read, in the seam atlas,
    // the colour of the face vertex they duplicate (their border column is the face's edge).
    let smooth =
        Image::from_fn(96, 64, 3, |x, y, c| 0.5 + 0.4 * ((x as f32 * 0.05 + c as f32).sin() * (y as f32 * 0.07).cos()));
    let t = texture_seams(&d, &seams, &smooth, &SeamTextureParams::default(), 1 << 24).unwrap();
    let offsets = d.vertex_offsets();
    let texel = |uv: Vec2, w: usize, h: usize| Vec2::new(uv.x * w as f32, (1.0 - uv.y) * h as f32);
    for (k, f) in d.faces.iter().enumerate() {
        for (i, &uv) in f.uvs.iter().enumerate() {
            let now = t.mesh.uvs[offsets[k] as usize + i];
            assert!(texel(uv, 96, 64).distance(texel(now, t.texture.width, t.texture.height)) < 1e-3);
        }
    }
    let at = |img: &Image, uv: Vec2| -> Vec3 {
        Vec3::from_array([0, 1, 2].map(|c| super::displace::sample_channel(img, uv, c)))
    };
    let mut worst: f32 = 0.0;
    let mut strip_vertices = 0;
    for tri in &t.mesh.triangles[t.face_triangles..] {
        for &v in tri {
            if (v as usize) < d.vertex_count() {
                continue; // a corner fan's
            }
            strip_vertices += 1;
            let uv = t.mesh.uvs[v as usize];
            assert!(texel(uv, t.texture.width, t.texture.height).y >= 65.0, "strip vertex {v} outside the seam atlas");
            // The face vertex at the same position.
            let p = t.mesh.positions[v as usize];
            let twins: Vec<usize> = (0..d.vertex_count()).filter(|&u| t.mesh.positions[u] == p).collect();
            assert_eq!(twins.len(), 1, "the test's relief leaves no two faces' vertices on one point");
            let twin = twins[0];
            worst = worst.max(at(&t.texture, uv).distance(at(&t.texture, t.mesh.uvs[twin])));
        }
    }
    assert!(strip_vertices > 0);
    assert!(worst < 0.05, "a strip vertex reads {worst} away from its face's edge");
    // A repeating texture has no room for an atlas: refused, for the caller to fall back.
    let mut tiled = mesh.clone();
    tiled.uvs[0].x = 2.5;
    let d = displace(&tiled, &wavy(64), &params(0.08, Subdiv::Fixed(4))).unwrap();
    assert_eq!(
        texture_seams(&d, &zip(&d), &colour, &SeamTextureParams::default(), 1 << 24),
        Err(SeamTexturing::RepeatingUvs)
    );
    assert!(matches!(
        texture_seams(&d, &zip(&d), &colour, &SeamTextureParams::default(), 10),
        Err(SeamTexturing::RepeatingUvs | SeamTexturing::TooLarge { .. })
    ));
}
