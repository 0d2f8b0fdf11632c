//! Structure synthesis at the target sizes of [references: frasson §3.6]: flooding Voronoi on 1024² with 300
//! generators, and a full stage 1 (sampling + 50 Lloyd iterations, 300 regions, 1024²) at
//! full and at half Lloyd resolution. Target for stage 1: under 2 s on 2 cores.

use criterion::{criterion_group, criterion_main, Criterion};
use tessera::synth::rng::Rng;
use tessera::synth::structure::analysis::sample::analyse_sample;
use tessera::synth::structure::analysis::stats::StatsConfig;
use tessera::synth::structure::generation::synthesis::{
    statistical, CenterSource, EmpiricalSampler, ShapeSampling, StatisticalParams,
};
use tessera::synth::structure::mesh::polygonize::{polygonize, PolygonizeParams};
use tessera::synth::structure::relaxation::controls::Controls;
use tessera::synth::structure::relaxation::lloyd::{lloyd, LloydParams};
use tessera::synth::structure::relaxation::voronoi::{voronoi_ellipses, Domain, VoronoiMode, VoronoiParams};
use tessera::synth::structure::shapes::optimize::{optimize_shapes, ShapeParams};
use tessera::synth::structure::Ellipse;

const SIZE: usize = 1024;

/// 300 generators sampled from the wall_random stand-in, scaled so that N' = 300 on 1024².
fn generators() -> Vec<Ellipse> {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/samples/standins/wall_random.json"))
        .expect("stand-in");
    let sample = analyse_sample(&text, &StatsConfig::default()).expect("analysis");
    let originals: Vec<Ellipse> = sample.originals().into_iter().map(|(_, e)| e).collect();
    let mean = sample.model.mean_region_area;
    let scale = ((SIZE * SIZE) as f64 / (300.0 * mean)).sqrt();
    let params = StatisticalParams { scale, ..StatisticalParams::new(mean) };
    let mut sampler = EmpiricalSampler::new(&originals, ShapeSampling::Independent);
    let s =
        statistical(SIZE, SIZE, &Controls::default(), &mut sampler, CenterSource::Uniform, &params, &mut Rng::new(7))
            .expect("300 regions fit");
    assert_eq!(s.generators.len(), 300);
    s.generators
}

fn originals_at_scale() -> (Vec<Vec<[f64; 2]>>, f64) {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/samples/standins/wall_random.json"))
        .expect("stand-in");
    let sample = analyse_sample(&text, &StatsConfig::default()).expect("analysis");
    let scale = ((SIZE * SIZE) as f64 / (300.0 * sample.model.mean_region_area)).sqrt();
    (sample.originals().into_iter().map(|(p, _)| p).collect(), scale)
}

fn bench(c: &mut Criterion) {
    let gens = generators();
    let mut group = c.benchmark_group("structure");
    group.sample_size(10);
    group.bench_function("flooding_voronoi_1024_300", |b| {
        let domain = Domain { width: SIZE, height: SIZE, allowed: None, metric_map: None };
        let params = VoronoiParams { mode: VoronoiMode::Growth, ..VoronoiParams::default() };
        b.iter(|| voronoi_ellipses(&domain, &gens, &params))
    });
    for resolution in [1.0, 0.5] {
        group.bench_function(format!("stage1_1024_300_50iters_res{resolution}"), |b| {
            // Sampling included; tolerance 0 so that all 50 iterations run.
            b.iter(|| {
                let g = generators();
                let params = LloydParams { max_iters: 50, tol: 0.0, resolution, ..LloydParams::default() };
                lloyd(SIZE, SIZE, &g, None, &Controls::default(), &params)
            })
        });
    }
    let relaxed = lloyd(SIZE, SIZE, &gens, None, &Controls::default(), &LloydParams::default());
    group.bench_function("polygonize_1024_300", |b| {
        b.iter(|| polygonize(&relaxed.labels, &PolygonizeParams::default()))
    });
    // Stage 2 on the same mesh, against the sample's originals at the same scale.
    let mesh = polygonize(&relaxed.labels, &PolygonizeParams::default());
    let (originals, scale) = originals_at_scale();
    let originals: Vec<Vec<[f64; 2]>> =
        originals.iter().map(|p| p.iter().map(|v| [v[0] * scale, v[1] * scale]).collect()).collect();
    let params = ShapeParams::default();
    group.bench_function("stage2_1024_300", |b| {
        b.iter(|| {
            optimize_shapes(
                &mesh.mesh,
                &mesh.on_occupancy_border,
                &mesh.on_domain_border,
                (SIZE as f64, SIZE as f64),
                &originals,
                &[],
                &params,
            )
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
