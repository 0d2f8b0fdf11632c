//! Appearance synthesis at the target size of [references: frasson §4.2.3]: S5–S8 for a
//! 1 000-region mesh (a centroidal Voronoi stand-in on 2048²) and the 2-D render of the
//! dressing at 2048². Target (digest §7.2): S5–S8 plus the render under 1 s on 2 cores.
//! Interiors are benched with the associations known (the structure's stage 2 gives them)
//! and with the closest-shape search over 300 originals.

use criterion::{criterion_group, criterion_main, Criterion};
use std::f64::consts::TAU;
use tessera::synth::appearance::dress::testkit::{interstice_atlas, junction_atlas, unified, Band};
use tessera::synth::appearance::dress::{dress, DressHints, DressParams};
use tessera::synth::appearance::render::{render, RenderParams};
use tessera::synth::appearance::types::{AppearanceData, Mesh, Original};
use tessera::synth::rng::Rng;
use tessera::synth::structure::fixtures::standins::{cells_iso, CellsIsoParams};

const SIZE: usize = 2048;
const W: f64 = 5.0;

fn mesh(count: usize, seed: u64) -> Mesh {
    let p = CellsIsoParams { width: SIZE, height: SIZE, count, lloyd_iterations: 6, triangle_fraction: 0.0 };
    cells_iso(&p, seed).mesh
}

fn data() -> AppearanceData {
    let mut rng = Rng::new(1);
    let lengths: Vec<f64> = (0..600).map(|_| rng.range(8.0, 110.0)).collect();
    let tuples: Vec<Vec<f64>> = (0..400)
        .map(|i| {
            if i % 10 == 0 {
                let a = rng.range(2.4, 3.9);
                vec![a, TAU - a]
            } else {
                let a = rng.range(1.5, 2.7);
                let b = rng.range(1.5, 2.7);
                vec![a, b, TAU - a - b]
            }
        })
        .collect();
    let sample = mesh(300, 99);
    let originals = sample
        .regions
        .iter()
        .enumerate()
        .map(|(i, r)| Original {
            region: i,
            polygon: r.iter().map(|&v| sample.vertices[v]).collect(),
            cluster: i % 6,
            lab: [50.0, 0.0, 0.0],
        })
        .collect();
    AppearanceData {
        unified: unified(6, 512, true),
        originals,
        interstices: interstice_atlas(&lengths, W, W, Band { center: 0.5, half: 2.0 }, [0.6, 0.58, 0.55], [0.3; 3]),
        junctions: junction_atlas(&tuples, W, 2.0 * W, Band { center: 0.0, half: 2.8 }, &[[0.6, 0.58, 0.55]], [0.3; 3]),
    }
}

fn bench(c: &mut Criterion) {
    let target = mesh(1000, 7);
    assert!(target.regions.len() >= 1000);
    let data = data();
    let known: Vec<Option<usize>> = (0..target.regions.len()).map(|r| Some(r % data.originals.len())).collect();
    let hints = DressHints { associations: Some(&known), previous_clusters: None };
    let params = DressParams::default();
    let rp = RenderParams { width: SIZE, height: SIZE, scale: 1.0, background: [0.0; 3] };
    let dressing = dress(&target, &data, &params, 3, &hints);
    let mut g = c.benchmark_group("appearance_dress");
    g.sample_size(10);
    g.bench_function("s5_s8_known_associations_1000", |b| b.iter(|| dress(&target, &data, &params, 3, &hints)));
    g.bench_function("s5_s8_closest_shape_1000_over_300", |b| {
        b.iter(|| dress(&target, &data, &params, 3, &DressHints::default()))
    });
    g.bench_function("render_2048", |b| b.iter(|| render(&dressing, &data, &rp)));
    g.bench_function("s5_s8_and_render_2048", |b| {
        b.iter(|| {
            let d = dress(&target, &data, &params, 3, &hints);
            render(&d, &data, &rp)
        })
    });
    g.finish();
    // The machine is shared: wall times above include waiting for cores. CPU time per run
    // (all threads) / 2 is the wall time on two free cores.
    let cpu = || {
        let mut u: libc::rusage = unsafe { std::mem::zeroed() };
        unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut u) };
        let t = |v: libc::timeval| v.tv_sec as f64 + v.tv_usec as f64 * 1e-6;
        t(u.ru_utime) + t(u.ru_stime)
    };
    let runs = 5;
    for (name, known) in [("known associations", true), ("closest-shape search", false)] {
        let t0 = cpu();
        for _ in 0..runs {
            let h = if known { hints } else { DressHints::default() };
            let d = dress(&target, &data, &params, 3, &h);
            std::hint::black_box(render(&d, &data, &rp));
        }
        let per = (cpu() - t0) / runs as f64;
        println!("S5–S8 + render 2048², {name}: {per:.3} s CPU per run ({:.3} s on 2 free cores)", per / 2.0);
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
