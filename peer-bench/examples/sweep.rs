//! The parameter sweep recorded in README.md:
//! `cargo run --release -p tessera-peer-bench --example sweep -- [tessera|peer] [small] [blocks]`.
//!
//! `tessera` (default): for each block (default 16,24,32,48,64), overlap block/6, /4, /3, tolerance
//! 0, 0.1, 0.3 and SSD/SAD, the mean over seeds 1–3 of the time and every metric. `peer`: the peer
//! at its defaults for seeds 1–3 (`PEER_THREADS`, default tessera's pool size). `small` uses the
//! 128² centre crop → 256² of `tests/quality.rs` instead of 256² → 512².

#[path = "../shared/peer.rs"]
mod peer;

use std::time::Instant;

use tessera::synth::metrics::Comparison;
use tessera::synth::quilt::{quilt, Metric, QuiltParams};
use tessera_peer_bench::{centre_crop, load_sample, measure};

fn line(m: &[Comparison], t: f64) -> String {
    let avg = |f: fn(&Comparison) -> f64| m.iter().map(f).sum::<f64>() / m.len() as f64;
    format!(
        "t {t:.3}s coh {:.4} comp {:.4} pyr {:.4} spec {:.4} col {:.4}",
        avg(|c| c.coherence),
        avg(|c| c.completeness),
        avg(|c| c.pyramid),
        avg(|c| c.spectrum),
        avg(|c| c.colour)
    )
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let has = |w: &str| args.iter().any(|a| a == w);
    let full = load_sample();
    let (sample, out) = if has("small") { (centre_crop(&full, 128), 256) } else { (full, 512) };
    let seeds = [1u64, 2, 3];
    if has("peer") {
        let threads = std::env::var("PEER_THREADS").ok().and_then(|v| v.parse().ok());
        let threads = threads.unwrap_or_else(rayon::current_num_threads);
        let (mut ms, mut tt) = (Vec::new(), 0.0);
        for seed in seeds {
            let t = Instant::now();
            let img = peer::run_peer(&sample, out, out, seed, threads);
            tt += t.elapsed().as_secs_f64();
            ms.push(measure(&img, &sample));
            println!("peer seed {seed}: {}", line(&ms[ms.len() - 1..], t.elapsed().as_secs_f64()));
        }
        println!("peer mean ({threads} threads): {}", line(&ms, tt / seeds.len() as f64));
        return;
    }
    let blocks: Vec<usize> = args
        .iter()
        .find(|a| a.contains(',') || a.parse::<usize>().is_ok())
        .map(|s| s.split(',').map(|v| v.parse().expect("block list")).collect())
        .unwrap_or_else(|| vec![16, 24, 32, 48, 64]);
    for &block in &blocks {
        for div in [6usize, 4, 3] {
            for tolerance in [0.0f32, 0.1, 0.3] {
                for metric in [Metric::Ssd, Metric::Sad] {
                    let overlap = (block / div).max(1);
                    let (mut ms, mut tt) = (Vec::new(), 0.0);
                    for seed in seeds {
                        let p = QuiltParams { overlap, tolerance, metric, ..QuiltParams::new(out, out, block, seed) };
                        let t = Instant::now();
                        let img = quilt(&sample, &p).expect("quilting").image;
                        tt += t.elapsed().as_secs_f64();
                        ms.push(measure(&img, &sample));
                    }
                    let t = tt / seeds.len() as f64;
                    println!("b{block:3} ov{overlap:3} tol{tolerance:.1} {metric:?}: {}", line(&ms, t));
                }
            }
        }
    }
}
