//! Tests of the renderer: coverage against analytic areas, watertight edges under the fill
//! rule, Lambert values, depth order, shadows, the tangent frame, near-plane clipping and
//! thread-count determinism.

use super::camera::Camera;
use super::material::{Albedo, DirectionalLight, Fragment, Material};
use super::tiles::{key_triangle, rasterize, Cull, EMPTY};
use super::{render, RenderOptions};
use crate::raster::Image;
use crate::synth::mesh::TriMesh;
use glam::{Vec2, Vec3, Vec4};

/// A material returning what a closure computes from the fragment.
struct Probe<F: Fn(&Fragment) -> [f32; 3] + Sync>(F);

impl<F: Fn(&Fragment) -> [f32; 3] + Sync> Material for Probe<F> {
    fn shade(&self, frag: &Fragment) -> [f32; 3] {
        (self.0)(frag)
    }
}

/// An axis-aligned square in the plane `z`, `[x0, x1] × [y0, y1]`, normal +z, uv = xy,
/// counter-clockwise seen from +z.
fn quad(x0: f32, y0: f32, x1: f32, y1: f32, z: f32) -> TriMesh {
    let positions = vec![Vec3::new(x0, y0, z), Vec3::new(x1, y0, z), Vec3::new(x1, y1, z), Vec3::new(x0, y1, z)];
    TriMesh {
        uvs: positions.iter().map(|p| Vec2::new(p.x, p.y)).collect(),
        normals: vec![Vec3::Z; 4],
        positions,
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    }
}

fn merge(a: &TriMesh, b: &TriMesh) -> TriMesh {
    let mut m = a.clone();
    let off = m.positions.len() as u32;
    m.positions.extend(&b.positions);
    m.normals.extend(&b.normals);
    m.uvs.extend(&b.uvs);
    m.triangles.extend(b.triangles.iter().map(|t| t.map(|i| i + off)));
    m
}

/// A displaced `n × n`-vertex grid over the unit square.
fn bumpy_grid(n: usize) -> TriMesh {
    let mut m = TriMesh::default();
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (i as f32 / (n - 1) as f32, j as f32 / (n - 1) as f32);
            let z = 0.08 * (x * 13.0).sin() * (y * 11.0).cos();
            m.positions.push(Vec3::new(x, y, z));
            m.normals.push(Vec3::new(-0.08 * 13.0 * (x * 13.0).cos() * (y * 11.0).cos(), 0.0, 1.0).normalize());
            m.uvs.push(Vec2::new(x * 2.0, y * 3.0));
        }
    }
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let v = (j * n + i) as u32;
            let n = n as u32;
            m.triangles.push([v, v + 1, v + n + 1]);
            m.triangles.push([v, v + n + 1, v + n]);
        }
    }
    m
}

fn white() -> Image {
    Image::filled(4, 4, 3, 1.0)
}

fn opts(width: usize, height: usize) -> RenderOptions {
    RenderOptions { width, height, background: [-1.0; 3], ..Default::default() }
}

fn covered(img: &Image) -> usize {
    img.plane(0).iter().filter(|&&v| v != -1.0).count()
}

#[test]
fn quad_coverage_matches_the_projected_area() {
    // Turned 17° about the view axis, so whole rows and columns of pixels do not come and go.
    let mut mesh = quad(-0.5, -0.5, 0.5, 0.5, 0.0);
    let rot = glam::Quat::from_rotation_z(17f32.to_radians());
    for p in &mut mesh.positions {
        *p = rot * *p;
    }
    let (d, fov) = (2.3f32, 50.0f32);
    let camera = Camera::perspective(Vec3::new(0.0, 0.0, d), Vec3::ZERO, Vec3::Y, fov);
    let (w, h) = (600, 400);
    let img = render(&mesh, None, &Probe(|_| [1.0; 3]), &camera, &[], &opts(w, h));
    let per_unit = h as f32 / (2.0 * d * (fov * 0.5).to_radians().tan());
    let area = per_unit * per_unit;
    let count = covered(&img) as f32;
    assert!((count - area).abs() / area < 0.01, "{count} pixels, expected {area}");
    // Centred: the centre pixels are covered, the corners are not.
    assert_ne!(img.get(w / 2, h / 2, 0), -1.0);
    assert_eq!(img.get(0, 0, 0), -1.0);
    assert_eq!(img.get(w - 1, h - 1, 0), -1.0);
}

/// Rasterises each triangle alone (screen coordinates in pixels, y down) and returns, per
/// pixel, how many of them cover it.
fn coverage_counts(width: usize, height: usize, tris: &[[Vec2; 3]]) -> Vec<u32> {
    let mut counts = vec![0u32; width * height];
    for t in tris {
        let clip: Vec<Vec4> = t
            .iter()
            .map(|p| Vec4::new(p.x / width as f32 * 2.0 - 1.0, 1.0 - p.y / height as f32 * 2.0, 1.0, 1.0))
            .collect();
        let tiles = rasterize(width, height, &clip, &[[0, 1, 2]], f32::NEG_INFINITY, Cull::None, |tile| {
            let hits: Vec<(usize, usize)> = (0..tile.keys.len())
                .filter(|&i| tile.keys[i] != EMPTY)
                .map(|i| (tile.x0 + i % tile.width, tile.y0 + i / tile.width))
                .collect();
            hits
        });
        for (x, y) in tiles.into_iter().flatten() {
            counts[y * width + x] += 1;
        }
    }
    counts
}

#[test]
fn shared_edges_are_covered_exactly_once() {
    // A quad split along a diagonal through pixel centres, and one with arbitrary corners; the
    // quad corners are placed so no pixel centre lies on an outer edge.
    let v = |x: f32, y: f32| Vec2::new(x, y);
    let cases: Vec<Vec<[Vec2; 3]>> = vec![
        {
            // The diagonal runs through pixel centres, the outer edges between them.
            let (a, b, c, d) = (v(10.0, 10.0), v(91.0, 10.0), v(91.0, 91.0), v(10.0, 91.0));
            vec![[a, b, c], [a, c, d]]
        },
        {
            let (a, b, c, d) = (v(7.3, 12.9), v(101.7, 3.1), v(93.4, 88.2), v(15.1, 117.6));
            vec![[a, b, c], [a, c, d]]
        },
        // A fan of eight triangles around a vertex on a pixel centre.
        (0..8)
            .map(|k| {
                let ang = |k: i32| (k as f32 * 45.0 + 10.0).to_radians();
                let p = |k: i32| v(64.5 + 40.0 * ang(k).cos(), 64.5 + 40.0 * ang(k).sin());
                [v(64.5, 64.5), p(k), p(k + 1)]
            })
            .collect(),
    ];
    for tris in cases {
        let counts = coverage_counts(128, 128, &tris);
        assert!(counts.iter().all(|&c| c <= 1), "overlap");
        // Every pixel centre strictly inside the union (convex here) is covered.
        let inside = |p: Vec2| {
            let mut any = false;
            for t in &tris {
                let e = |a: Vec2, b: Vec2| (b - a).perp_dot(p - a);
                let (e0, e1, e2) = (e(t[0], t[1]), e(t[1], t[2]), e(t[2], t[0]));
                any |= (e0 >= 0.0 && e1 >= 0.0 && e2 >= 0.0) || (e0 <= 0.0 && e1 <= 0.0 && e2 <= 0.0);
            }
            any
        };
        for y in 0..128 {
            for x in 0..128 {
                let p = v(x as f32 + 0.5, y as f32 + 0.5);
                // Pixel centres on outer edges are avoided by construction; interior ones count.
                assert_eq!(counts[y * 128 + x] == 1, inside(p), "pixel ({x}, {y})");
            }
        }
    }
}

#[test]
fn lambert_at_sixty_degrees() {
    let mesh = quad(-1.0, -1.0, 1.0, 1.0, 0.0);
    let texture = Image::filled(8, 8, 3, 0.8);
    let material = Albedo { texture: &texture, normal_map: None };
    let camera = Camera::framing(mesh.bounds().unwrap(), -90.0, 90.0, 40.0);
    let a = 60f32.to_radians();
    let light = DirectionalLight::white(Vec3::new(a.sin(), 0.0, a.cos()));
    let img = render(&mesh, None, &material, &camera, &[light], &opts(64, 64));
    for c in 0..3 {
        let v = img.get(32, 32, c);
        assert!((v - 0.8 * a.cos()).abs() < 1e-4, "{v}");
    }
}

#[test]
fn the_nearer_triangle_wins_in_any_order() {
    let far = quad(-1.0, -1.0, 1.0, 1.0, 0.0);
    let near = quad(-0.5, -0.5, 0.5, 0.5, 0.3);
    let camera = Camera::perspective(Vec3::new(0.2, 0.1, 4.0), Vec3::ZERO, Vec3::Y, 45.0);
    let probe = Probe(|f| [f.position.z, 0.0, 0.0]);
    for mesh in [merge(&far, &near), merge(&near, &far)] {
        let img = render(&mesh, None, &probe, &camera, &[], &opts(96, 96));
        assert!((img.get(48, 48, 0) - 0.3).abs() < 1e-5);
        assert!(img.get(24, 48, 0).abs() < 1e-5, "{}", img.get(24, 48, 0));
    }
    // Coplanar overlap: the lower triangle index wins, whatever the order of the list.
    let a = quad(-1.0, -1.0, 1.0, 1.0, 0.0);
    let mut mesh = merge(&a, &a);
    let probe = Probe(|f| [f.triangle as f32, 0.0, 0.0]);
    let first = render(&mesh, None, &probe, &camera, &[], &opts(64, 64));
    mesh.triangles.reverse();
    let second = render(&mesh, None, &probe, &camera, &[], &opts(64, 64));
    let ids = |img: &Image| img.plane(0).iter().map(|&v| if v < 0.0 { -1 } else { (v as i32) % 4 }).collect::<Vec<_>>();
    // Either way the two lowest indices win (in the reversed list they hold the second copy).
    let (f, s) = (ids(&first), ids(&second));
    assert!(f.iter().filter(|&&i| i >= 0).count() > 1000);
    assert!(f.iter().all(|&i| i < 2), "{f:?}");
    assert!(s.iter().all(|&i| i < 2), "{s:?}");
}

#[test]
fn a_small_quad_casts_a_shadow_on_a_plane() {
    let plane = quad(-1.0, -1.0, 1.0, 1.0, 0.0);
    let blocker = quad(-0.25, -0.25, 0.25, 0.25, 0.5);
    let mesh = merge(&plane, &blocker);
    let texture = white();
    let material = Albedo { texture: &texture, normal_map: None };
    let camera = Camera::orthographic(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 2.5);
    let light = DirectionalLight::white(Vec3::new(1.0, 0.0, 1.0));
    let o = RenderOptions { ambient: [0.1; 3], shadows: true, shadow_map_size: 512, ..opts(250, 250) };
    let img = render(&mesh, None, &material, &camera, &[light], &o);
    let at = |x: f32, y: f32| img.get((125.0 + 100.0 * x) as usize, (125.0 - 100.0 * y) as usize, 0);
    let lit = 0.1 + std::f32::consts::FRAC_1_SQRT_2;
    assert!((at(-0.5, 0.0) - 0.1).abs() < 1e-4, "shadow: {}", at(-0.5, 0.0));
    assert!((at(-0.4, 0.1) - 0.1).abs() < 1e-4);
    for (x, y) in [(0.5, 0.0), (-0.5, 0.6), (-0.9, 0.0), (0.0, -0.8), (0.0, 0.0)] {
        assert!((at(x, y) - lit).abs() < 1e-4, "lit at ({x}, {y}): {}", at(x, y));
    }
    let no_shadows = render(&mesh, None, &material, &camera, &[light], &RenderOptions { shadows: false, ..o });
    assert!((no_shadows.get(75, 125, 0) - lit).abs() < 1e-4);
}

#[test]
fn bit_identical_for_any_thread_count() {
    let mesh = bumpy_grid(90);
    let texture = Image::from_fn(32, 32, 3, |x, y, c| ((x * 7 + y * 3 + c) % 11) as f32 / 10.0);
    let normal_map = Image::from_fn(16, 16, 3, |x, y, c| match c {
        0 => 0.5 + 0.2 * ((x as f32) * 0.7).sin(),
        1 => 0.5 + 0.2 * ((y as f32) * 0.5).cos(),
        _ => 0.9,
    });
    let material = Albedo { texture: &texture, normal_map: Some(&normal_map) };
    let camera = Camera::framing(mesh.bounds().unwrap(), -60.0, 35.0, 40.0);
    let lights = [
        DirectionalLight::white(Vec3::new(0.4, -0.5, 0.7)),
        DirectionalLight { direction: Vec3::new(-0.6, 0.2, 0.4), color: [1.0, 0.8, 0.6], intensity: 0.5 },
    ];
    let o = RenderOptions {
        ambient: [0.05; 3],
        shadows: true,
        shadow_map_size: 300,
        samples_per_pixel: 4,
        ..opts(150, 110)
    };
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| render(&mesh, None, &material, &camera, &lights, &o))
    };
    let one = run(1);
    assert!(covered(&one) > 2000, "{} pixels covered", covered(&one));
    for threads in [2, 3] {
        let other = run(threads);
        assert!(one.data.iter().zip(&other.data).all(|(a, b)| a.to_bits() == b.to_bits()), "{threads} threads");
    }
}

#[test]
fn tangent_space_light_of_a_plane_with_uv_xy_is_the_world_light() {
    let mesh = quad(-1.0, -1.0, 1.0, 1.0, 0.0);
    let l = Vec3::new(0.3, -0.5, 0.8).normalize();
    let probe = Probe(|f| f.lights[0].tangent_direction.to_array());
    let camera = Camera::perspective(Vec3::new(0.3, -0.4, 3.0), Vec3::ZERO, Vec3::Y, 50.0);
    let tangents = [Vec4::new(1.0, 0.0, 0.0, 1.0); 4];
    for t in [None, Some(&tangents[..])] {
        let img = render(&mesh, t, &probe, &camera, &[DirectionalLight::white(l)], &opts(40, 40));
        let (x, y) = (20, 20);
        let got = Vec3::new(img.get(x, y, 0), img.get(x, y, 1), img.get(x, y, 2));
        assert!((got - l).length() < 1e-5, "{got} vs {l}");
    }
    // Mirrored u: the derived frame flips its tangent and keeps b along +v (= +y).
    let mut mirrored = mesh.clone();
    for uv in &mut mirrored.uvs {
        uv.x = -uv.x;
    }
    let img = render(&mirrored, None, &probe, &camera, &[DirectionalLight::white(l)], &opts(40, 40));
    let got = Vec3::new(img.get(20, 20, 0), img.get(20, 20, 1), img.get(20, 20, 2));
    assert!((got - Vec3::new(-l.x, l.y, l.z)).length() < 1e-5, "{got}");
}

#[test]
fn triangles_crossing_the_near_plane_are_clipped() {
    // A large ground plane, the camera just above it looking along it: part of each triangle
    // is behind the camera.
    let mesh = quad(-100.0, -100.0, 100.0, 100.0, 0.0);
    let camera = Camera::perspective(Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 10.0, 0.5), Vec3::Z, 60.0);
    let probe = Probe(|f| [f.position.y, f.position.x, 1.0]);
    let img = render(&mesh, None, &probe, &camera, &[], &opts(64, 64));
    assert!(img.data.iter().all(|v| v.is_finite()));
    // Below the horizon everything is ground in front of the camera; the top row is sky.
    for x in 0..64 {
        assert_eq!(img.get(x, 0, 2), -1.0);
        assert_eq!(img.get(x, 63, 2), 1.0);
        assert!(img.get(x, 63, 0) > 0.0);
    }
    // The same view of a finely subdivided ground agrees on what is covered.
    let fine = {
        let mut m = TriMesh::default();
        let n = 41;
        for j in 0..n {
            for i in 0..n {
                let p = Vec3::new(
                    -100.0 + 200.0 * i as f32 / (n - 1) as f32,
                    -100.0 + 200.0 * j as f32 / (n - 1) as f32,
                    0.0,
                );
                m.positions.push(p);
                m.normals.push(Vec3::Z);
                m.uvs.push(Vec2::ZERO);
            }
        }
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let v = (j * n + i) as u32;
                m.triangles.push([v, v + 1, v + n as u32 + 1]);
                m.triangles.push([v, v + n as u32 + 1, v + n as u32]);
            }
        }
        m
    };
    let other = render(&fine, None, &probe, &camera, &[], &opts(64, 64));
    let differ = img.plane(2).iter().zip(other.plane(2)).filter(|(a, b)| a != b).count();
    assert!(differ <= 64, "{differ} pixels differ");
}

#[test]
fn back_faces_are_culled_on_request() {
    let mesh = quad(-1.0, -1.0, 1.0, 1.0, 0.0);
    let probe = Probe(|_| [1.0; 3]);
    let o = RenderOptions { cull_backfaces: true, ..opts(32, 32) };
    let front = Camera::perspective(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y, 60.0);
    let back = Camera::perspective(Vec3::new(0.0, 0.0, -3.0), Vec3::ZERO, Vec3::Y, 60.0);
    assert!(covered(&render(&mesh, None, &probe, &front, &[], &o)) > 100);
    assert_eq!(covered(&render(&mesh, None, &probe, &back, &[], &o)), 0);
    assert!(covered(&render(&mesh, None, &probe, &back, &[], &opts(32, 32))) > 100);
}

#[test]
fn triangle_keys_are_indices() {
    let clip = [Vec4::new(-1.0, -1.0, 1.0, 1.0), Vec4::new(1.0, -1.0, 1.0, 1.0), Vec4::new(-1.0, 1.0, 1.0, 1.0)];
    let ids = rasterize(8, 8, &clip, &[[0, 1, 2], [0, 1, 2]], f32::NEG_INFINITY, Cull::None, |t| {
        t.keys.iter().filter(|&&k| k != EMPTY).map(|&k| key_triangle(k)).collect::<Vec<_>>()
    });
    let ids: Vec<u32> = ids.into_iter().flatten().collect();
    assert!(!ids.is_empty() && ids.iter().all(|&i| i == 0));
}

/// Uniform Gradient maps `(p, q, al)` on a mesh, relit: each fragment's light goes into its
/// tangent frame, array y being −v.
fn gradient_maps(p: f32, q: f32, al: f32) -> Image {
    Image::from_fn(4, 4, 3, |_, _, c| [p, q, al][c])
}

#[test]
fn relit_flat_quad_with_uv_xy_is_the_representation_relit_at_the_world_light() {
    use crate::synth::relight::{Basis, Light};
    let mesh = quad(-1.0, -1.0, 1.0, 1.0, 0.0);
    let camera = Camera::perspective(Vec3::new(0.2, 0.1, 3.0), Vec3::ZERO, Vec3::Y, 40.0);
    let l = Vec3::new(0.5, 0.3, 0.8).normalize();
    // PTM: an arbitrary polynomial, not symmetric in x and y, so a frame error shows.
    let coef = [0.1f32, -0.2, 0.3, 0.25, -0.4, 0.6];
    let maps = Image::from_fn(4, 4, 6, |_, _, c| coef[c]);
    let basis = Basis::Ptm;
    let material = super::Relit::new(&maps, None, &basis).unwrap();
    let img = render(&mesh, None, &material, &camera, &[DirectionalLight::white(l)], &opts(40, 40));
    // The array frame: rows grow downward, so the light's y flips.
    let light = Light::from_vector(glam::DVec3::new(l.x.into(), (-l.y).into(), l.z.into()));
    let want = basis.kernel(&light).unwrap().apply(&coef.map(f64::from)) as f32;
    let got = img.get(20, 20, 0);
    assert!((got - want).abs() < 1e-5, "{got} vs {want}");
    // A light below the surface adds nothing; the ambient light scales the overhead relighting.
    let below = DirectionalLight::white(Vec3::new(0.3, 0.2, -0.9));
    let img = render(&mesh, None, &material, &camera, &[below], &RenderOptions { ambient: [0.5; 3], ..opts(40, 40) });
    let overhead = basis.kernel(&Light::new(0.0, 0.0)).unwrap().apply(&coef.map(f64::from)) as f32;
    assert!((img.get(20, 20, 0) - 0.5 * overhead).abs() < 1e-5);
}

#[test]
fn relit_quad_with_rotated_uvs_turns_the_light_with_them() {
    use crate::synth::relight::represent::lambert;
    use crate::synth::relight::Basis;
    // uv = (y, −x): t = +y, b = −x, so a world light (x, y, z) is (y, −x, z) in the tangent
    // frame and (y, x, z) in the array frame.
    let mut mesh = quad(-1.0, -1.0, 1.0, 1.0, 0.0);
    for (uv, p) in mesh.uvs.iter_mut().zip(&mesh.positions) {
        *uv = Vec2::new(p.y, -p.x);
    }
    let camera = Camera::perspective(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y, 40.0);
    let (p, q, al) = (0.7f32, -0.3f32, 0.8f32);
    let maps = gradient_maps(p, q, al);
    let basis = Basis::Gradient;
    let material = super::Relit::new(&maps, None, &basis).unwrap();
    for l in [Vec3::new(0.6, 0.1, 0.8), Vec3::new(-0.2, 0.7, 0.6), Vec3::new(0.1, -0.5, 0.9)] {
        let l = l.normalize();
        let img = render(&mesh, None, &material, &camera, &[DirectionalLight::white(l)], &opts(32, 32));
        let array = glam::DVec3::new(l.y.into(), l.x.into(), l.z.into());
        let want = lambert(p.into(), q.into(), al.into(), array).max(0.0) as f32;
        assert!((img.get(16, 16, 0) - want).abs() < 1e-5, "{l}: {} vs {want}", img.get(16, 16, 0));
    }
}

#[test]
fn relit_gradient_maps_shade_as_the_equivalent_normal_map_on_a_curved_mesh() {
    use crate::synth::relight::Basis;
    // Gradient maps (p, q, al) are the array-frame normal normalise(−p, −q, 1), which is the
    // tangent-frame normal normalise(−p, q, 1): the Lambert material with that normal map
    // must agree fragment for fragment, on a mesh whose frames turn everywhere.
    let mesh = bumpy_grid(24);
    let camera = Camera::framing(mesh.bounds().unwrap(), -30.0, 50.0, 40.0);
    let light = DirectionalLight::white(Vec3::new(0.2, -0.3, 0.9));
    for (p, q) in [(0.0f32, 0.0f32), (0.5, -0.2), (-0.4, 0.6)] {
        let al = 0.7;
        let maps = gradient_maps(p, q, al);
        let basis = Basis::Gradient;
        let relit = super::Relit::new(&maps, None, &basis).unwrap();
        let n = Vec3::new(-p, q, 1.0).normalize();
        let normal_map = Image::from_fn(4, 4, 3, |_, _, c| n[c] * 0.5 + 0.5);
        let texture = Image::filled(4, 4, 3, al);
        let lambert = Albedo { texture: &texture, normal_map: Some(&normal_map) };
        let o = opts(64, 64);
        let a = render(&mesh, None, &relit, &camera, &[light], &o);
        let b = render(&mesh, None, &lambert, &camera, &[light], &o);
        assert!(covered(&a) > 1000);
        let worst = a.data.iter().zip(&b.data).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
        assert!(worst < 1e-4, "({p}, {q}): worst difference {worst}");
    }
}

#[test]
fn relit_refuses_maps_that_do_not_match_the_basis() {
    use crate::synth::relight::Basis;
    let maps = Image::filled(4, 4, 3, 0.5);
    assert!(super::Relit::new(&maps, None, &Basis::Ptm).is_err());
    let chroma = Image::filled(3, 4, 3, 1.0);
    assert!(super::Relit::new(&maps, Some(&chroma), &Basis::Gradient).is_err());
}
