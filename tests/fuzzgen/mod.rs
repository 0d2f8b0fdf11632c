//! Structure-aware fuzzing of tessera on the stable toolchain.
//!
//! Cases are generated from a seed and an index, so any case can be regenerated from its
//! number alone: `scene` writes scene text from the kinds' real schemas (`kinds::registry()`),
//! `mutate` corrupts the bundled scenes token by token, `files` writes structure JSON, label
//! images, PNG and EXR inputs (valid, odd and corrupt) with a small scene that reads them.
//! `runner` drives each case through parse → resolve → plan → build → emit with the library
//! API, catching panics in-process and running the cases in child processes under an
//! address-space limit and a per-case watchdog, so an abort, a stack overflow, a hang or an
//! allocation past the budget is a finding rather than a dead run.
//!
//! Shared by `tests/fuzz.rs` (the bounded sample CI runs) and `examples/fuzz.rs` (the long
//! campaign); see `docs/fuzzing.md`.

#![allow(dead_code)]

pub mod files;
pub mod mutate;
pub mod runner;
pub mod scene;

/// splitmix64: tiny, fast, and good enough to drive generators deterministically.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed ^ 0x9E37_79B9_7F4A_7C15)
    }

    /// The generator of case `index` of a stream, independent of every other case.
    pub fn for_case(seed: u64, stream: u64, index: u64) -> Rng {
        let mut r = Rng::new(seed.wrapping_mul(0xA24B_AED4_963E_E407) ^ stream.rotate_left(32) ^ index);
        r.next();
        r
    }

    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }

    /// Uniform in `lo..=hi`.
    pub fn range(&mut self, lo: i64, hi: i64) -> i64 {
        lo + (self.next() % ((hi - lo) as u64 + 1)) as i64
    }

    /// True with probability `p`.
    pub fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }

    pub fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}
