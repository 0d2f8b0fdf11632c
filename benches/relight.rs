//! Relighting at 1024²: extraction from 36 images (targets: PTM and Gradient under 0.5 s each,
//! Eigen6 under 1.5 s), Frankot–Chellappa integration (under 100 ms), and relighting one
//! megapixel at one light (under 10 ms), next to a copy of the maps' bytes, which is the
//! memory-bandwidth floor for touching them once; and relighting a surface grown under an
//! orientation field, each pixel in its own frame.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use rayon::prelude::*;
use tessera::raster::Image;
use tessera::synth::relight::fixtures::{lights36, render, Scenario};
use tessera::synth::relight::frame::relight_rotated;
use tessera::synth::relight::height::frankot_chellappa;
use tessera::synth::relight::{extract, relight_image, Light, Method};

const SIZE: usize = 1024;

fn bench(c: &mut Criterion) {
    let cap = render(Scenario::B, SIZE, &lights36());
    let stack = &cap.stack;
    let light = Light::new(60.0, 50.0);

    let mut group = c.benchmark_group("relight");
    group.sample_size(10);
    for method in [Method::Gradient, Method::Ptm, Method::Eigen(3), Method::Eigen(6)] {
        group.bench_function(format!("extract_{}_36x1024", method.name()), |b| {
            b.iter(|| extract(black_box(stack), method).unwrap())
        });
    }
    group.bench_function("frankot_chellappa_1024", |b| {
        b.iter(|| frankot_chellappa(black_box(&cap.p), &cap.q, SIZE, SIZE))
    });

    for method in [Method::Gradient, Method::Eigen(3), Method::Ptm, Method::Eigen(6)] {
        let rep = extract(stack, method).unwrap();
        let maps = rep.to_image();
        let bytes = maps.data.len() * 4;
        group.bench_function(format!("relight_{}_f32_1mpx", method.name()), |b| {
            b.iter(|| relight_image(black_box(&maps), &rep.basis, &light).unwrap())
        });
        // The floor: read the same bytes and write them once (2 threads, like relighting).
        let mut dst = vec![0.0f32; maps.data.len()];
        group.bench_function(format!("copy_{}_maps_{}MB", method.name(), bytes >> 20), |b| {
            b.iter(|| {
                dst.par_chunks_mut(1 << 16).zip(maps.data.par_chunks(1 << 16)).for_each(|(d, s)| d.copy_from_slice(s));
                black_box(&dst);
            })
        });
        group.bench_function(format!("relight_{}_f64_1mpx", method.name()), |b| {
            b.iter(|| rep.relight(black_box(&light)).unwrap())
        });
        // Grown under an orientation field: 32² blocks from 12 rotated copies, each pixel relit
        // in its copy's frame.
        let angles = Image::from_fn(SIZE, SIZE, 1, |x, y, _| {
            ((x / 32 * 7 + y / 32 * 5) % 12) as f32 * std::f32::consts::FRAC_PI_6
        });
        group.bench_function(format!("relight_{}_rotated_1mpx", method.name()), |b| {
            b.iter(|| relight_rotated(black_box(&maps), &rep.basis, &light, &angles).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
