//! Rendering every shader of the built-in library [references: bourque §5] at its defaults
//! over the unit square at 1024² (target: each under 50 ms on this machine).

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use tessera::synth::shader::{render_square, LIBRARY};

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("shader");
    group.sample_size(10);
    for def in LIBRARY {
        let values = def.defaults();
        group.bench_function(format!("{} 1024²", def.name), |b| {
            b.iter(|| render_square(def, black_box(&values), 7, 1024).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
