//! Cache hit counts kept across builds (`<cache>/stats.json`), for `tessera cache stats`.

use serde::{Deserialize, Serialize};

/// What builds took from where, added up since the cache was made (or the file removed).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct Stats {
    pub builds: u64,
    /// Stages a build needed: those it loaded or ran (not those it could skip).
    pub needed: u64,
    /// Loaded from the local cache, on disk or in memory.
    pub local_hits: u64,
    /// Loaded from the remote cache.
    pub remote_hits: u64,
    /// Ran (including over damaged entries).
    pub computed: u64,
    /// Action-cache lookups sent to a remote cache.
    pub remote_lookups: u64,
    pub bytes_down: u64,
    pub bytes_up: u64,
    /// Builds in which the remote failed and was turned off.
    pub remote_faults: u64,
}

impl Stats {
    pub fn add(&mut self, o: &Stats) {
        self.builds += o.builds;
        self.needed += o.needed;
        self.local_hits += o.local_hits;
        self.remote_hits += o.remote_hits;
        self.computed += o.computed;
        self.remote_lookups += o.remote_lookups;
        self.bytes_down += o.bytes_down;
        self.bytes_up += o.bytes_up;
        self.remote_faults += o.remote_faults;
    }

    /// `part` as a percentage of `whole` (0 when there is no whole).
    pub fn percent(part: u64, whole: u64) -> f64 {
        if whole == 0 {
            0.0
        } else {
            100.0 * part as f64 / whole as f64
        }
    }
}
