//! Rendering at 1024²: a displaced 709×709-vertex grid (1,002,528 triangles) under one light,
//! textured Lambert, without shadows (target: under 300 ms on two cores) and with a 2048²
//! shadow map; also with 4 samples per pixel.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use glam::{Vec2, Vec3};
use tessera::raster::Image;
use tessera::synth::mesh::TriMesh;
use tessera::synth::render::{render, Albedo, Camera, DirectionalLight, RenderOptions};

/// A `n × n`-vertex grid over the unit square, displaced along z by a few sine bumps.
fn displaced_grid(n: usize) -> TriMesh {
    let height = |x: f32, y: f32| 0.03 * (x * 19.0).sin() * (y * 23.0).cos() + 0.02 * ((x + y) * 41.0).sin();
    let mut mesh = TriMesh::default();
    let step = 1.0 / (n - 1) as f32;
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (i as f32 * step, j as f32 * step);
            let z = height(x, y);
            let e = 1e-3;
            let dx = (height(x + e, y) - height(x - e, y)) / (2.0 * e);
            let dy = (height(x, y + e) - height(x, y - e)) / (2.0 * e);
            mesh.positions.push(Vec3::new(x, y, z));
            mesh.normals.push(Vec3::new(-dx, -dy, 1.0).normalize());
            mesh.uvs.push(Vec2::new(x, y));
        }
    }
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let v = (j * n + i) as u32;
            let (a, b, c, d) = (v, v + 1, v + n as u32 + 1, v + n as u32);
            mesh.triangles.push([a, b, c]);
            mesh.triangles.push([a, c, d]);
        }
    }
    mesh
}

fn bench(c: &mut Criterion) {
    let mesh = displaced_grid(709);
    assert!(mesh.triangles.len() > 1_000_000);
    let texture =
        Image::from_fn(1024, 1024, 3, |x, y, ch| 0.3 + 0.2 * ((x / 32 + y / 32) % 2) as f32 + 0.1 * ch as f32);
    let material = Albedo { texture: &texture, normal_map: None };
    let camera = Camera::framing(mesh.bounds().unwrap(), -90.0, 55.0, 35.0);
    let lights = [DirectionalLight::white(Vec3::new(0.5, -0.3, 0.8))];
    let opts = RenderOptions { width: 1024, height: 1024, ambient: [0.1; 3], ..Default::default() };

    let mut group = c.benchmark_group("render");
    group.sample_size(10);
    group.bench_function("grid_1m_tris_1024", |b| {
        b.iter(|| render(black_box(&mesh), None, &material, &camera, &lights, &opts))
    });
    let shadowed = RenderOptions { shadows: true, shadow_map_size: 2048, ..opts };
    group.bench_function("grid_1m_tris_1024_shadows_2048", |b| {
        b.iter(|| render(black_box(&mesh), None, &material, &camera, &lights, &shadowed))
    });
    let supersampled = RenderOptions { samples_per_pixel: 4, ..opts };
    group.bench_function("grid_1m_tris_1024_4spp", |b| {
        b.iter(|| render(black_box(&mesh), None, &material, &camera, &lights, &supersampled))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
