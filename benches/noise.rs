//! Noise by example (Lagae et al. 2009), the paper's anchors: the analysis of a 512² RGB sample
//! (paper: under 1 s; target under 100 ms on two cores) and the evaluation of 8 bands in RGB
//! at 512² and 2048² (target under 300 ms), with a solid slice beside it; and
//! histogram-preserving tiling of a 128² sample into 512² and 4096² on both grids (target under
//! 300 ms).

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use tessera::raster::Image;
use tessera::synth::noise::eval::{render, Domain, Look, Noise};
use tessera::synth::noise::params::{fit, FitOptions, HistogramMode};
use tessera::synth::noise::tiling::{self, Grid, TilingParams};

/// A 512² colour sample: fractal value noise with correlated channels (the analysis's cost does
/// not depend on what the pixels show).
fn sample(n: usize) -> Image {
    let mut rng = tessera::synth::rng::Rng::new(3);
    let lattice: Vec<f32> = (0..65 * 65).map(|_| rng.next_f32()).collect();
    let at = |x: f32, y: f32| {
        let (i, j) = ((x as usize) % 64, (y as usize) % 64);
        let (fx, fy) = (x.fract(), y.fract());
        let v = |a: usize, b: usize| lattice[b * 65 + a];
        let top = v(i, j) * (1.0 - fx) + v(i + 1, j) * fx;
        let bottom = v(i, j + 1) * (1.0 - fx) + v(i + 1, j + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    };
    Image::from_fn(n, n, 3, |x, y, c| {
        let (x, y) = (x as f32, y as f32);
        let g = at(x / 32.0, y / 32.0) * 0.5 + at(x / 8.0, y / 8.0) * 0.3 + at(x / 2.0, y / 2.0) * 0.2;
        g * [0.9, 0.7, 0.5][c] + 0.05 * c as f32
    })
}

fn bench(c: &mut Criterion) {
    let img = sample(512);
    let opts = FitOptions { histogram: HistogramMode::On, ..FitOptions::default() };
    let mut g = c.benchmark_group("noise");
    g.sample_size(10);
    g.bench_function("analysis 512² RGB (histograms on)", |b| b.iter(|| black_box(fit(&img, &opts).unwrap())));
    let params = fit(&img, &opts).unwrap().params;
    let noise = Noise::new(1, params.tile, params.channels[0].weights.len(), params.colour, true).unwrap();
    let look = Look::new(&params, &[]);
    // At the sample's own resolution every band is evaluated (none is clamped away).
    let pixel = 1.0 / 512.0;
    g.bench_function("evaluation 512² RGB, 8 bands", |b| {
        b.iter(|| black_box(render(&noise, 512, 512, Domain::Plane { origin: [0.0; 2], pixel }, |_, _| &look).unwrap()))
    });
    g.bench_function("evaluation 2048² RGB, 8 bands", |b| {
        b.iter(|| {
            black_box(render(&noise, 2048, 2048, Domain::Plane { origin: [0.0; 2], pixel }, |_, _| &look).unwrap())
        })
    });
    let slice = Domain::Slice { origin: [0.0, 0.0, 0.3], u: [1.0, 0.0, 0.0], v: [0.0, 1.0, 0.0], pixel };
    g.bench_function("solid slice 512² RGB, 8 bands", |b| {
        b.iter(|| black_box(render(&noise, 512, 512, slice, |_, _| &look).unwrap()))
    });
    let small = sample(128);
    let prep = tiling::prepare(&small, false).unwrap();
    for grid in [Grid::Triangle, Grid::Hex] {
        let p = TilingParams { grid, ..TilingParams::default() };
        g.bench_function(format!("tiling {grid:?} 128² → 512²"), |b| {
            b.iter(|| black_box(tiling::render(&prep, &p, 512, 512, [0.0, 0.0, 4.0, 4.0]).unwrap()))
        });
    }
    g.sample_size(10);
    for grid in [Grid::Triangle, Grid::Hex] {
        let p = TilingParams { grid, ..TilingParams::default() };
        g.bench_function(format!("tiling {grid:?} 128² → 4096²"), |b| {
            b.iter(|| black_box(tiling::render(&prep, &p, 4096, 4096, [0.0, 0.0, 32.0, 32.0]).unwrap()))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
