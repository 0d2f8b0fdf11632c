//! The quality claim of `benches/quilt_peer.rs`, checked by a command on a small variant:
//! the centred 128 × 128 crop of `samples/photos/tissue.png` → 256 × 256, tessera (parameters of
//! `tessera_peer_bench::tessera_params`) against `texture-synthesis` 0.8 at its defaults, for
//! seeds 1–4. tessera's mean coherence, completeness and pyramid distance must be no worse
//! than the peer's, to within 1 %. The peer runs on 1 thread, the only setting in which it is
//! deterministic, so the test is reproducible (tessera is bit-identical for any thread count).
//! No speed assertion: timings are printed only.

#[path = "../shared/peer.rs"]
mod peer;

use std::time::Instant;

use tessera::synth::metrics::Comparison;
use tessera_peer_bench::{centre_crop, load_sample, measure, run_tessera};

const IN: usize = 128;
const OUT: usize = 256;
const SEEDS: [u64; 4] = [1, 2, 3, 4];

/// One measure of a [`Comparison`].
type Measure = fn(&Comparison) -> f64;

fn mean(ms: &[Comparison], f: impl Fn(&Comparison) -> f64) -> f64 {
    ms.iter().map(f).sum::<f64>() / ms.len() as f64
}

#[test]
fn tessera_quality_no_worse_than_texture_synthesis() {
    let sample = centre_crop(&load_sample(), IN);
    let (mut ours, mut theirs) = (Vec::new(), Vec::new());
    for seed in SEEDS {
        let t = Instant::now();
        let a = run_tessera(&sample, OUT, OUT, seed);
        let ta = t.elapsed();
        let t = Instant::now();
        let b = peer::run_peer(&sample, OUT, OUT, seed, 1);
        let tb = t.elapsed();
        println!("seed {seed}: tessera {ta:.2?}, peer {tb:.2?}");
        ours.push(measure(&a, &sample));
        theirs.push(measure(&b, &sample));
    }
    let checks: [(&str, Measure); 3] =
        [("coherence", |m| m.coherence), ("completeness", |m| m.completeness), ("pyramid", |m| m.pyramid)];
    for (name, f) in checks {
        let (a, b) = (mean(&ours, f), mean(&theirs, f));
        println!("{name:<13} tessera {a:.5}  peer {b:.5}");
        assert!(a <= b * 1.01, "{name}: tessera {a:.5} is worse than texture-synthesis {b:.5} by more than 1 %");
    }
    let reported: [(&str, Measure); 2] = [("spectrum", |m| m.spectrum), ("colour", |m| m.colour)];
    for (name, f) in reported {
        println!("{name:<13} tessera {:.5}  peer {:.5} (not asserted)", mean(&ours, f), mean(&theirs, f));
    }
}
