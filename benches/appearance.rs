//! Region-interior analysis of a painted 512² `wall_random` stand-in (100 regions, 3 tints):
//! extraction, clustering, guides and unified textures with the default parameters (project
//! target: under 2 s on 2 cores).

use criterion::{criterion_group, criterion_main, Criterion};
use tessera::synth::appearance::unified::{analyse_interiors, InteriorParams};
use tessera::synth::structure::fixtures::standins::{paint, wall_random, PaintParams, WallRandomParams};

fn interiors(c: &mut Criterion) {
    let s = wall_random(&WallRandomParams { width: 512, height: 512, ..WallRandomParams::default() }, 1);
    let painted = paint(&s, &PaintParams::default(), 1);
    let polys = s.polygons();
    let regions: Vec<usize> = (0..polys.len()).collect();
    let params = InteriorParams::default();
    let mut group = c.benchmark_group("appearance");
    group.sample_size(10);
    group.bench_function("interiors_512", |b| {
        b.iter(|| analyse_interiors(&painted.image, &polys, &regions, &params, 1).expect("interiors"))
    });
    group.finish();
}

criterion_group!(benches, interiors);
criterion_main!(benches);
