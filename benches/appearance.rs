//! The appearance analysis of a sample [references: frasson §4], as an `appearance`
//! declaration runs it (`synth::appearance::analysis::{interiors, contours}` with the
//! language's defaults): region extraction with shrink, CIELAB means, adaptive k-means,
//! guiding textures, unified textures by guided quilting (A2a–d), then the automatic alpha
//! and the interstice and junction atlases (A2e–f). Two samples: a painted 512² `wall_random`
//! stand-in (100 regions, 3 tints) and the segmented ambientCG paving photograph (576²).
//! Project target (issue 13): under 2 s each on 2 cores. The structure analysis of the
//! sample (its own cached stage, shared with `structure`) is done once, outside the timing.

use criterion::{criterion_group, criterion_main, Criterion};
use tessera::raster::Image;
use tessera::synth::appearance::analysis::{contours, interiors, ContourParams};
use tessera::synth::appearance::unified::InteriorParams;
use tessera::synth::structure::analysis::sample::{analyse_label_image, analyse_sample, SampleStructure};
use tessera::synth::structure::analysis::stats::StatsConfig;
use tessera::synth::structure::fixtures::standins::{paint, wall_random, PaintParams, WallRandomParams};
use tessera::synth::structure::format::to_json_sized;

/// The painted stand-in and its structure, analysed as a sample's drawing is.
fn standin() -> (Image, SampleStructure) {
    let s = wall_random(&WallRandomParams { width: 512, height: 512, ..WallRandomParams::default() }, 1);
    let painted = paint(&s, &PaintParams::default(), 1);
    let text = to_json_sized(&s.subdivision, [s.width as f64, s.height as f64]);
    let sample = analyse_sample(&text, &StatsConfig::default()).expect("stand-in analyses");
    (painted.image, sample)
}

/// The paving photograph (RGB) and its painted label image, analysed as a sample's is.
fn paving() -> (Image, SampleStructure) {
    let repo = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let read = |rel: &str| {
        let bytes = std::fs::read(repo.join(rel)).expect("sample file");
        tessera::raster::io::decode(&bytes).expect("png")
    };
    let photo = read("samples/photos/paving.png");
    let photo = Image::from_fn(photo.width, photo.height, 3, |x, y, c| photo.get(x, y, c.min(photo.channels - 1)));
    let labels = read("samples/photos/paving_structure.png");
    let (w, h) = (labels.width, labels.height);
    let n = w * h;
    let mut ids_of = std::collections::HashMap::new();
    let ids: Vec<u32> = (0..n)
        .map(|i| {
            let key = (0..labels.channels.min(3))
                .fold(0u32, |k, c| k << 8 | (labels.data[c * n + i].clamp(0.0, 1.0) * 255.0).round() as u32);
            let next = ids_of.len() as u32;
            *ids_of.entry(key).or_insert(next)
        })
        .collect();
    let sample = analyse_label_image(&ids, w, h, 1.0, &StatsConfig::default()).expect("paving analyses");
    (photo, sample)
}

fn analysis(c: &mut Criterion) {
    let interior = InteriorParams::default();
    let contour = ContourParams::default();
    let mut group = c.benchmark_group("appearance");
    group.sample_size(10);
    let samples = [("512", standin()), ("paving", paving())];
    for (name, (image, sample)) in &samples {
        group.bench_function(format!("interiors_{name}"), |b| {
            b.iter(|| interiors(image, sample, &interior, 1).expect("interiors"))
        });
        group.bench_function(format!("contours_{name}"), |b| {
            b.iter(|| contours(image, sample, &contour, None).expect("contours"))
        });
        group.bench_function(format!("full_{name}"), |b| {
            b.iter(|| {
                let i = interiors(image, sample, &interior, 1).expect("interiors");
                let c = contours(image, sample, &contour, None).expect("contours");
                (i, c)
            })
        });
    }
    group.finish();
    // The machine is shared: wall times above include waiting for cores. CPU time per run
    // (all threads) says what the analysis costs whatever else runs; half of it is the wall
    // time on two free cores if both were kept busy.
    let cpu = || {
        let mut u: libc::rusage = unsafe { std::mem::zeroed() };
        unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut u) };
        let t = |v: libc::timeval| v.tv_sec as f64 + v.tv_usec as f64 * 1e-6;
        t(u.ru_utime) + t(u.ru_stime)
    };
    let runs = 3;
    for (name, (image, sample)) in &samples {
        let (t0, w0) = (cpu(), std::time::Instant::now());
        for _ in 0..runs {
            let i = interiors(image, sample, &interior, 1).expect("interiors");
            std::hint::black_box((i, contours(image, sample, &contour, None).expect("contours")));
        }
        let (per, wall) = ((cpu() - t0) / runs as f64, w0.elapsed().as_secs_f64() / runs as f64);
        println!("full analysis {name}: {per:.3} s CPU per run ({:.3} s over 2 cores), {wall:.3} s wall", per / 2.0);
    }
}

criterion_group!(benches, analysis);
criterion_main!(benches);
