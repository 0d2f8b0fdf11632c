//! Multi-patch depth quilting [references: frasson §5.3.1] at the size of the thesis-scale
//! anchor: a 512² guide, two 100² patches (bricks, foliage over bricks), block 16, overlap 3,
//! exhaustive candidates, strict minimum, α = (0.3, 0.5, 0.2), CIELAB patch choice. Target:
//! under 1 s (the anchor is 10 s).

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use tessera::raster::Image;
use tessera::synth::quilt::{quilt_multipatch, Equalise, Guide, QuiltParams, Terms};
use tessera::synth::relief::fixtures::{brick_foliage_patches, brick_wall, BrickParams};

fn bench(c: &mut Criterion) {
    let foliage = vec![(120.0, 260.0, 90.0), (380.0, 300.0, 76.0), (300.0, 80.0, 60.0), (60.0, 450.0, 50.0)];
    let p = BrickParams { foliage, light_mortar: Some([0.72, 0.0, 1.0, 0.3]), ..BrickParams::default() };
    let wall = brick_wall(512, 512, &p, 11);
    let patches: Vec<Image> = brick_foliage_patches(12).iter().map(|r| r.patch()).collect();
    let refs: Vec<&Image> = patches.iter().collect();
    let mut params = QuiltParams::new(512, 512, 16, 13);
    params.overlap = 3;
    params.tolerance = 0.0;
    params.equalise = Equalise::MinMax;
    let mut group = c.benchmark_group("relief");
    group.sample_size(10);
    group.bench_function("multipatch_depth_512_two_100_patches_block16", |b| {
        b.iter(|| {
            quilt_multipatch(
                black_box(&refs),
                Guide { image: &wall.colour, weights: None, channels: Some(&[0, 1, 2]) },
                &[3],
                Terms::with_depth(0.3, 0.5, 0.2),
                true,
                &params,
            )
            .unwrap()
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
