//! tessera's image quilting against `texture-synthesis` 0.8 (Embark) on a real photo:
//! `samples/photos/tissue.png` (256 × 256 8-bit sRGB) → 512 × 512 RGB.
//!
//! 1. Criterion group `quilt_peer/tessera_512` (10 samples, flat sampling): tessera alone.
//! 2. Side by side, interleaved so that both see the same machine load: for seeds 1, 2, 3 one
//!    peer run and one tessera run, each timed (wall clock); each output is measured against the
//!    input with `tessera::synth::metrics` (parameters in `tessera_peer_bench::compare_params`).
//!    The table gives min / median times, the ratio of medians (peer / tessera) and every metric
//!    (mean over the three seeds) for both. Lower is better for every metric.
//! 3. Seed 1's outputs are written to `target/peer-bench/{tessera,peer}.png`.
//!
//! The peer takes ~20 s per run, so it is timed by this manual loop (3 runs) rather than by
//! Criterion; the whole bench takes about 2–3 minutes on 2 cores. Run as
//! `cargo bench -p tessera-peer-bench`. Without `--bench` (e.g. `cargo test --benches`) the
//! side-by-side part runs seed 1 only.

#[path = "../shared/peer.rs"]
mod peer;

use std::time::{Duration, Instant};

use criterion::{Criterion, SamplingMode};
use tessera::synth::metrics::Comparison;
use tessera_peer_bench::{load_sample, measure, run_tessera, tessera_params, write_png};

const OUT: usize = 512;

fn bench_tessera(c: &mut Criterion) {
    let sample = load_sample();
    let mut group = c.benchmark_group("quilt_peer");
    group.sample_size(10).sampling_mode(SamplingMode::Flat).measurement_time(Duration::from_secs(8));
    group.bench_function("tessera_512", |b| b.iter(|| run_tessera(&sample, OUT, OUT, 1)));
    group.finish();
}

fn load() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "n/a".into())
}

fn min_median(v: &[f64]) -> (f64, f64) {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    let med = if n % 2 == 1 { s[n / 2] } else { 0.5 * (s[n / 2 - 1] + s[n / 2]) };
    (s[0], med)
}

/// One measure of a [`Comparison`].
type Measure = fn(&Comparison) -> f64;

fn mean(ms: &[Comparison], f: impl Fn(&Comparison) -> f64) -> f64 {
    ms.iter().map(f).sum::<f64>() / ms.len() as f64
}

fn side_by_side(full: bool) {
    let sample = load_sample();
    let threads = rayon::current_num_threads();
    let seeds: &[u64] = if full { &[1, 2, 3] } else { &[1] };
    let p = tessera_params(OUT, OUT, 1);
    println!();
    println!("== tessera vs texture-synthesis 0.8: tissue.png 256x256 -> {OUT}x{OUT} RGB, {threads} threads ==");
    println!(
        "tessera: block {}, overlap {}, tolerance {}, {:?}, equalise {:?}, coherence {:?}, stride {}",
        p.block, p.overlap, p.tolerance, p.metric, p.equalise, p.coherence, p.candidate_stride
    );
    println!("peer: defaults (50 NN, 50 random locations, cauchy 1.0, backtrack 0.5 x 5 stages), threads {threads}");
    println!("load average before: {}", load());
    let (mut t_ours, mut t_peer) = (Vec::new(), Vec::new());
    let (mut m_ours, mut m_peer) = (Vec::new(), Vec::new());
    for &seed in seeds {
        let t = Instant::now();
        let peer_img = peer::run_peer(&sample, OUT, OUT, seed, threads);
        t_peer.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        let ours_img = run_tessera(&sample, OUT, OUT, seed);
        t_ours.push(t.elapsed().as_secs_f64());
        m_peer.push(measure(&peer_img, &sample));
        m_ours.push(measure(&ours_img, &sample));
        if seed == seeds[0] {
            let a = write_png(&ours_img, "tessera");
            let b = write_png(&peer_img, "peer");
            println!("wrote {} and {}", a.display(), b.display());
        }
        println!(
            "seed {seed}: peer {:.2} s, tessera {:.3} s (load {})",
            t_peer.last().unwrap(),
            t_ours.last().unwrap(),
            load()
        );
    }
    let (o_min, o_med) = min_median(&t_ours);
    let (p_min, p_med) = min_median(&t_peer);
    println!();
    println!("| {:<26} | {:>12} | {:>12} | {:>9} |", "measure (lower is better)", "tessera", "peer", "peer/ours");
    println!("|{:-<28}|{:-<14}|{:-<14}|{:-<11}|", "", "", "", "");
    println!("| {:<26} | {:>12.3} | {:>12.3} | {:>9.1} |", "time min [s]", o_min, p_min, p_min / o_min);
    println!("| {:<26} | {:>12.3} | {:>12.3} | {:>9.1} |", "time median [s]", o_med, p_med, p_med / o_med);
    let rows: [(&str, Measure); 5] = [
        ("coherence (7x7 RMS)", |m| m.coherence),
        ("completeness (7x7 RMS)", |m| m.completeness),
        ("pyramid distance", |m| m.pyramid),
        ("spectrum distance", |m| m.spectrum),
        ("colour distance", |m| m.colour),
    ];
    for (name, f) in rows {
        let (a, b) = (mean(&m_ours, f), mean(&m_peer, f));
        println!("| {:<26} | {:>12.5} | {:>12.5} | {:>9.2} |", name, a, b, b / a);
    }
    println!("(metrics: mean over seeds {seeds:?}; load average after: {})", load());
    let wins = |f: fn(&Comparison) -> f64| mean(&m_ours, f) <= mean(&m_peer, f);
    println!(
        "target: speed >= 10x: {}; coherence, completeness, pyramid no worse: {}",
        p_med / o_med >= 10.0,
        wins(|m| m.coherence) && wins(|m| m.completeness) && wins(|m| m.pyramid)
    );
}

fn main() {
    let full = std::env::args().any(|a| a == "--bench");
    let mut c = Criterion::default().configure_from_args();
    bench_tessera(&mut c);
    side_by_side(full);
    c.final_summary();
}
