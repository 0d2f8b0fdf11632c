//! The memory budget of a build: how many bytes its stages may hold at once. Planning refuses
//! what its declared sizes imply beyond it, stages refuse what their inputs imply beyond it,
//! and the world refuses files larger than a quarter of it, each with a diagnostic instead
//! of an allocation that aborts the process.
//!
//! The default comes from the machine: half of its physical memory, lowered to half of the
//! process's address-space limit (`ulimit -v`) or of its cgroup's memory limit when those
//! are smaller, so that a refusal arrives before the allocator gives up.

use std::fmt;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Budget {
    pub bytes: u64,
}

/// Used when the machine does not say how much memory it has.
pub const FALLBACK_BYTES: u64 = 4 << 30;

impl Default for Budget {
    fn default() -> Self {
        Budget::from_machine()
    }
}

impl Budget {
    pub fn new(bytes: u64) -> Self {
        Budget { bytes }
    }

    /// Half of the smallest of physical memory, the address-space limit and the cgroup limit.
    pub fn from_machine() -> Self {
        let read = |p: &str| std::fs::read_to_string(p).ok();
        let limits = [
            read("/proc/meminfo").and_then(|t| meminfo_total(&t)),
            read("/proc/self/limits").and_then(|t| address_space_limit(&t)),
            read("/sys/fs/cgroup/memory.max").and_then(|t| t.trim().parse::<u64>().ok()),
        ];
        let least = limits.into_iter().flatten().min().map(|b| b / 2);
        Budget { bytes: least.unwrap_or(FALLBACK_BYTES) }
    }

    /// The largest file the world reads whole: a quarter of the budget, since a decoded file
    /// takes several times its encoded size.
    pub fn max_file(&self) -> u64 {
        self.bytes / 4
    }

    /// `Ok` when `bytes` fit; otherwise a sentence saying what was asked and what the budget is.
    pub fn check(&self, bytes: f64, what: &str) -> Result<(), String> {
        if bytes.is_finite() && bytes <= self.bytes as f64 {
            Ok(())
        } else {
            Err(format!("{what} needs about {} but the memory budget is {}", Bytes(bytes), Bytes(self.bytes as f64)))
        }
    }
}

/// A byte count for people: `1.5 GiB`.
pub struct Bytes(pub f64);

impl fmt::Display for Bytes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let b = self.0;
        if !b.is_finite() {
            return write!(f, "unboundedly many bytes");
        }
        const UNITS: [&str; 7] = ["bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
        let mut v = b;
        let mut u = 0;
        while v >= 1024.0 && u + 1 < UNITS.len() {
            v /= 1024.0;
            u += 1;
        }
        if u == 0 {
            write!(f, "{v:.0} bytes")
        } else if v >= 1024.0 {
            write!(f, "{v:.2e} {}", UNITS[u])
        } else {
            write!(f, "{v:.1} {}", UNITS[u])
        }
    }
}

/// Parses `4 GiB`, `512MB`, `1.5G`, `1000000` (bytes). Binary and decimal suffixes both
/// mean what they say (`GB` is 10⁹, `GiB` and `G` are 2³⁰).
pub fn parse_bytes(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let split = t.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let v: f64 = num.parse().map_err(|_| format!("`{s}` is not a size (e.g. `4 GiB`, `512 MiB`, `1000000`)"))?;
    let mult: f64 = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 1.0,
        "k" | "kib" => 1024.0,
        "kb" => 1e3,
        "m" | "mib" => 1024.0 * 1024.0,
        "mb" => 1e6,
        "g" | "gib" => 1024.0 * 1024.0 * 1024.0,
        "gb" => 1e9,
        "t" | "tib" => 1024.0f64.powi(4),
        "tb" => 1e12,
        u => return Err(format!("unknown size unit `{u}` in `{s}` (use B, KiB, MiB, GiB, TiB or KB, MB, GB, TB)")),
    };
    let bytes = v * mult;
    if !(1.0..=u64::MAX as f64).contains(&bytes) {
        return Err(format!("`{s}` is not a usable memory size"));
    }
    Ok(bytes as u64)
}

fn meminfo_total(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

fn address_space_limit(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("Max address space"))?;
    line["Max address space".len()..].split_whitespace().next()?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_sizes() {
        assert_eq!(parse_bytes("4 GiB"), Ok(4 << 30));
        assert_eq!(parse_bytes("512MiB"), Ok(512 << 20));
        assert_eq!(parse_bytes("1.5G"), Ok(3 << 29));
        assert_eq!(parse_bytes("2 GB"), Ok(2_000_000_000));
        assert_eq!(parse_bytes("1000000"), Ok(1_000_000));
        assert!(parse_bytes("0").is_err());
        assert!(parse_bytes("lots").is_err());
        assert!(parse_bytes("4 parsecs").is_err());
    }

    #[test]
    fn reads_the_machine() {
        assert_eq!(meminfo_total("MemTotal:       24683652 kB\nMemFree: 1 kB\n"), Some(24683652 * 1024));
        let limits = "Limit                     Soft Limit           Hard Limit           Units\n\
                      Max address space         3000000000           unlimited            bytes\n";
        assert_eq!(address_space_limit(limits), Some(3_000_000_000));
        assert_eq!(
            address_space_limit("Max address space         unlimited            unlimited            bytes\n"),
            None
        );
        assert!(Budget::from_machine().bytes > 0);
    }

    #[test]
    fn says_what_does_not_fit() {
        let b = Budget::new(1 << 30);
        assert!(b.check(1e9, "x").is_ok());
        let e = b.check(4e9, "the map").unwrap_err();
        assert!(e.contains("3.7 GiB") && e.contains("1.0 GiB"), "{e}");
        assert!(b.check(f64::INFINITY, "x").is_err());
        assert!(b.check(f64::NAN, "x").is_err());
    }
}
