//! Displacement and seam zipping of a 10,000-face mesh at depth resolution 64 (target: under
//! 1 s on two cores): a 100 × 100 grid of quads on a rippled sheet, so neighbouring faces have
//! different normals and every seam opens a gap. Each face reads a 64² depth map through its
//! own UVs, half of them (in a checkerboard) through half of it, so the faces are subdivided 32
//! and 16 cells per side (the rule: depth resolution / 2) and most seams join sides of 33 and 17
//! vertices. Also timed: gathering the result into one triangle mesh.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use glam::{Vec2, Vec3};
use tessera::raster::Image;
use tessera::synth::mesh::displace::{displace, DisplaceParams, Subdiv};
use tessera::synth::mesh::seam::zip;
use tessera::synth::mesh::{Face, Mesh};

fn rippled_grid(n: usize) -> Mesh {
    let mut m = Mesh::default();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (i as f32 / n as f32, j as f32 / n as f32);
            m.positions.push(Vec3::new(x, y, 0.02 * (x * 37.0).sin() + 0.02 * (y * 29.0).cos()));
        }
    }
    m.uvs = vec![
        Vec2::new(0.0, 0.0),
        Vec2::new(1.0, 0.0),
        Vec2::new(1.0, 1.0),
        Vec2::new(0.0, 1.0),
        Vec2::new(0.5, 0.0),
        Vec2::new(0.5, 0.5),
        Vec2::new(0.0, 0.5),
    ];
    let at = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    for j in 0..n {
        for i in 0..n {
            let uvs = if (i + j) % 2 == 0 { vec![0, 1, 2, 3] } else { vec![0, 4, 5, 6] };
            m.faces.push(Face { positions: vec![at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)], uvs });
        }
    }
    m
}

fn bench(c: &mut Criterion) {
    let mesh = rippled_grid(100);
    assert_eq!(mesh.faces.len(), 10_000);
    let depth = Image::from_fn(64, 64, 1, |x, y, _| 0.5 + 0.4 * ((x as f32 * 0.3).sin() * (y as f32 * 0.21).cos()));
    let params = DisplaceParams { scale: 0.004, subdiv: Subdiv::Auto, ..DisplaceParams::default() };
    let displaced = displace(&mesh, &depth, &params).unwrap();
    let levels: std::collections::BTreeSet<u32> = displaced.faces.iter().map(|f| f.n).collect();
    assert_eq!(levels.into_iter().collect::<Vec<_>>(), vec![16, 32]);
    let seams = zip(&displaced);
    assert_eq!(seams.strips.len(), 2 * 100 * 99);
    eprintln!(
        "{} faces -> {} vertices, {} face triangles, {} strips, {} corner fans",
        mesh.faces.len(),
        displaced.vertex_count(),
        displaced.faces.iter().map(|f| f.triangles.len()).sum::<usize>(),
        seams.strips.len(),
        seams.corners.len()
    );

    let mut group = c.benchmark_group("displace");
    group.sample_size(10);
    group.bench_function("displace_and_zip_10k_faces_res64", |b| {
        b.iter(|| {
            let d = displace(black_box(&mesh), &depth, &params).unwrap();
            let s = zip(&d);
            (d.faces.len(), s.strips.len())
        })
    });
    group.bench_function("displace_10k_faces_res64", |b| {
        b.iter(|| displace(black_box(&mesh), &depth, &params).unwrap().faces.len())
    });
    group.bench_function("zip_10k_faces_res64", |b| b.iter(|| zip(black_box(&displaced)).strips.len()));
    group.bench_function("to_trimesh_10k_faces_res64", |b| {
        b.iter(|| black_box(&displaced).to_trimesh(&seams.strips, &seams.corners).triangles.len())
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
