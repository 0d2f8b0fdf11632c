//! The on-disk artifact cache: content-addressed by stage key, written atomically,
//! verified on load, collected by `tessera gc`.
//!
//! Entry layout: `TSC2` magic, the entry's own key (32 bytes), blake3 of key and payload
//! (32 bytes), payload. An entry is trusted only when it names the key it was looked up by
//! and its hash matches, so a truncated write, a flipped bit or two entries swapped on disk
//! are each deleted and reported as a miss: the stage runs again instead of trusting them.
//!
//! The cache root holds a `CACHEDIR.TAG` written when tessera creates it (the convention
//! backup tools honour). Nothing is written into, or collected from, a directory without
//! one, unless every file in it is provably a cache entry; and `gc` deletes only files whose
//! names and headers are in the cache's own format.
//!
//! Two builds may write the same key at once: each writes a private temporary file and
//! renames it into place; rename is atomic and both payloads are identical, so whichever
//! lands last is as good as the first.

use std::collections::HashSet;
use std::io::{self, Read};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use super::files;
use super::key::Key;
use super::stats::Stats;

const MAGIC: &[u8; 4] = b"TSC2";
/// Entries of earlier versions: recognised (so `gc` may remove them), never trusted.
const OLD_MAGIC: &[u8; 4] = b"TSC1";
const HEADER: usize = 4 + 32 + 32;
pub const MARKER: &str = "CACHEDIR.TAG";
/// The hit counts of past builds (`Stats`), beside the marker.
pub const STATS: &str = "stats.json";
const MARKER_TEXT: &str = "Signature: 8a477f597d28d172789f06886806bc55\n\
# This file is a cache directory tag created by tessera: everything here can be rebuilt.\n\
# For information about cache directory tags, see https://bford.info/cachedir/\n";

pub struct Cache {
    dir: PathBuf,
    /// Whether the root is ours to write into, decided at the first write.
    claimed: OnceLock<Result<(), String>>,
}

#[derive(Debug, PartialEq, Eq)]
pub enum Lookup {
    Hit(Vec<u8>),
    Miss,
    /// The entry existed but failed verification; it has been removed.
    Corrupt,
}

#[derive(Debug, Default, PartialEq, Eq)]
pub struct GcReport {
    pub kept: usize,
    pub removed: usize,
    pub freed_bytes: u64,
    /// Files in the cache directory that are not cache entries; left alone.
    pub foreign: Vec<PathBuf>,
}

pub use files::write_atomic;

impl Cache {
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        Cache { dir: dir.into(), claimed: OnceLock::new() }
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    pub fn path(&self, key: &Key) -> PathBuf {
        let hex = key.hex();
        self.dir.join(&hex[..2]).join(&hex[2..])
    }

    pub fn contains(&self, key: &Key) -> bool {
        self.path(key).is_file()
    }

    pub fn get(&self, key: &Key) -> Lookup {
        let path = self.path(key);
        let data = match std::fs::read(&path) {
            Ok(d) => d,
            Err(_) => return Lookup::Miss,
        };
        if data.len() >= HEADER && &data[..4] == MAGIC && data[4..36] == key.0 {
            let payload = &data[HEADER..];
            if entry_hash(key, payload).as_bytes() == &data[36..68] {
                return Lookup::Hit(payload.to_vec());
            }
        }
        let _ = std::fs::remove_file(&path);
        Lookup::Corrupt
    }

    pub fn put(&self, key: &Key, payload: &[u8]) -> io::Result<()> {
        self.claim().map_err(|e| io::Error::new(io::ErrorKind::PermissionDenied, e))?;
        let mut data = Vec::with_capacity(payload.len() + HEADER);
        data.extend_from_slice(MAGIC);
        data.extend_from_slice(&key.0);
        data.extend_from_slice(entry_hash(key, payload).as_bytes());
        data.extend_from_slice(payload);
        files::write_atomic(&self.path(key), &data)
    }

    /// The warnings kept for the stage with `key` (none when it gave none, or its entry is
    /// gone or damaged).
    pub fn warnings(&self, key: &Key) -> Vec<String> {
        match self.get(&key.warnings()) {
            Lookup::Hit(bytes) => serde_json::from_slice(&bytes).unwrap_or_default(),
            Lookup::Miss | Lookup::Corrupt => Vec::new(),
        }
    }

    /// The counts of past builds (zero when none were kept, or the file is damaged).
    pub fn stats(&self) -> Stats {
        std::fs::read(self.dir.join(STATS)).ok().and_then(|b| serde_json::from_slice(&b).ok()).unwrap_or_default()
    }

    /// Adds a build's counts to the kept ones. Two builds finishing at once may lose one
    /// build's counts (the file is replaced whole, never torn): they are statistics.
    pub fn add_stats(&self, build: &Stats) -> io::Result<()> {
        self.claim().map_err(|e| io::Error::new(io::ErrorKind::PermissionDenied, e))?;
        let mut all = self.stats();
        all.add(build);
        let json = serde_json::to_vec_pretty(&all).map_err(io::Error::other)?;
        files::write_atomic(&self.dir.join(STATS), &json)
    }

    /// Entries and their bytes on disk (warnings entries included).
    pub fn size(&self) -> (u64, u64) {
        let (mut n, mut bytes) = (0, 0);
        for shard in std::fs::read_dir(&self.dir).into_iter().flatten().flatten() {
            if !is_shard(&shard) {
                continue;
            }
            for e in std::fs::read_dir(shard.path()).into_iter().flatten().flatten() {
                if e.file_type().is_ok_and(|t| t.is_file()) && is_entry_name(&e.file_name().to_string_lossy()) {
                    n += 1;
                    bytes += e.metadata().map(|m| m.len()).unwrap_or(0);
                }
            }
        }
        (n, bytes)
    }

    /// Makes sure the root is a tessera cache before the first write: creates it with its
    /// marker, or adopts an existing directory that is empty or holds only cache entries.
    fn claim(&self) -> Result<(), String> {
        self.claimed
            .get_or_init(|| {
                let marker = self.dir.join(MARKER);
                if is_marker(&marker) {
                    return Ok(());
                }
                if std::fs::symlink_metadata(&self.dir).is_err() {
                    std::fs::create_dir_all(&self.dir)
                        .map_err(|e| format!("cannot create the cache `{}`: {e}", self.dir.display()))?;
                } else if let Some(foreign) = self.first_foreign() {
                    // A build running at the same time may have just claimed it.
                    if !is_marker(&marker) {
                        return Err(not_a_cache(&self.dir, &foreign));
                    }
                    return Ok(());
                }
                files::write_atomic(&marker, MARKER_TEXT.as_bytes())
                    .map_err(|e| format!("cannot mark the cache `{}`: {e}", self.dir.display()))
            })
            .clone()
    }

    /// A file or directory below the root that is not in the cache's format, if any.
    fn first_foreign(&self) -> Option<PathBuf> {
        let entries = match std::fs::read_dir(&self.dir) {
            Ok(e) => e,
            Err(_) => return Some(self.dir.clone()),
        };
        for e in entries {
            let Ok(e) = e else { return Some(self.dir.clone()) };
            let name = e.file_name().to_string_lossy().into_owned();
            if name == MARKER || name == STATS || files::is_temporary(&name) {
                continue;
            }
            if !is_shard(&e) {
                return Some(e.path());
            }
            let Ok(inner) = std::fs::read_dir(e.path()) else { return Some(e.path()) };
            for f in inner {
                let Ok(f) = f else { return Some(e.path()) };
                let fname = f.file_name().to_string_lossy().into_owned();
                let ok = f.file_type().is_ok_and(|t| t.is_file()) && files::is_temporary(&fname) || is_entry(&f);
                if !ok {
                    return Some(f.path());
                }
            }
        }
        None
    }

    /// Removes every entry whose key is not in `keep`, and temporaries of killed builds.
    /// Only files in the cache's own format are removed; anything else is reported in
    /// `foreign` and left alone. A root that is not a tessera cache is an error.
    pub fn gc(&self, keep: &HashSet<Key>) -> Result<GcReport, String> {
        let mut report = GcReport::default();
        if std::fs::symlink_metadata(&self.dir).is_err() {
            return Ok(report);
        }
        if !is_marker(&self.dir.join(MARKER)) {
            // An unmarked directory is collected only when all of it is provably ours.
            if let Some(foreign) = self.first_foreign() {
                return Err(not_a_cache(&self.dir, &foreign));
            }
        }
        files::sweep_stale(&self.dir);
        // A stage's warnings live and die with its entry.
        let keep_hex: HashSet<String> = keep.iter().flat_map(|k| [k.hex(), k.warnings().hex()]).collect();
        let shards = std::fs::read_dir(&self.dir).map_err(|e| format!("cannot list `{}`: {e}", self.dir.display()))?;
        for shard in shards.flatten() {
            let prefix = shard.file_name().to_string_lossy().into_owned();
            if prefix == MARKER || prefix == STATS || files::is_temporary(&prefix) {
                continue;
            }
            if !is_shard(&shard) {
                report.foreign.push(shard.path());
                continue;
            }
            files::sweep_stale(&shard.path());
            let Ok(inner) = std::fs::read_dir(shard.path()) else {
                report.foreign.push(shard.path());
                continue;
            };
            for entry in inner.flatten() {
                let name = entry.file_name().to_string_lossy().into_owned();
                if files::is_temporary(&name) {
                    continue; // a live build's
                }
                let path = entry.path();
                if !is_entry(&entry) {
                    report.foreign.push(path);
                    continue;
                }
                if keep_hex.contains(&format!("{prefix}{name}")) {
                    report.kept += 1;
                    continue;
                }
                let len = entry.metadata().map(|m| m.len()).unwrap_or(0);
                if std::fs::remove_file(&path).is_ok() {
                    report.removed += 1;
                    report.freed_bytes += len;
                }
            }
            let _ = std::fs::remove_dir(shard.path()); // only succeeds when empty
        }
        report.foreign.sort();
        Ok(report)
    }
}

fn entry_hash(key: &Key, payload: &[u8]) -> blake3::Hash {
    let mut h = blake3::Hasher::new();
    h.update(&key.0);
    h.update(payload);
    h.finalize()
}

fn not_a_cache(dir: &Path, foreign: &Path) -> String {
    format!(
        "`{}` is not a tessera cache: it has no {MARKER} and holds `{}`, which is not a cache entry; \
         tessera neither writes nor deletes there (check `[paths] cache` in tessera.toml)",
        dir.display(),
        foreign.display()
    )
}

fn is_marker(path: &Path) -> bool {
    std::fs::read(path).is_ok_and(|b| b.starts_with(b"Signature: 8a477f597d28d172789f06886806bc55"))
}

/// A shard directory of the cache's own format: two hex digits.
fn is_shard(e: &std::fs::DirEntry) -> bool {
    is_shard_name(&e.file_name().to_string_lossy()) && e.file_type().is_ok_and(|t| t.is_dir())
}

/// An entry of the cache's own format: a file named by 62 hex digits with an entry header.
fn is_entry(e: &std::fs::DirEntry) -> bool {
    e.file_type().is_ok_and(|t| t.is_file())
        && is_entry_name(&e.file_name().to_string_lossy())
        && has_entry_header(&e.path())
}

fn is_hex(s: &str) -> bool {
    s.bytes().all(|b| matches!(b, b'0'..=b'9' | b'a'..=b'f'))
}

fn is_shard_name(s: &str) -> bool {
    s.len() == 2 && is_hex(s)
}

fn is_entry_name(s: &str) -> bool {
    s.len() == 62 && is_hex(s)
}

fn has_entry_header(path: &Path) -> bool {
    let mut magic = [0u8; 4];
    std::fs::File::open(path).and_then(|mut f| f.read_exact(&mut magic)).is_ok()
        && (&magic == MAGIC || &magic == OLD_MAGIC)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::key::KeyBuilder;

    #[test]
    fn round_trips_and_rejects_corruption() {
        let dir = tempfile::tempdir().unwrap();
        let c = Cache::new(dir.path().join("c"));
        let k = KeyBuilder::new("t", 1).finish();
        assert_eq!(c.get(&k), Lookup::Miss);
        c.put(&k, b"payload").unwrap();
        assert!(is_marker(&dir.path().join("c").join(MARKER)));
        assert_eq!(c.get(&k), Lookup::Hit(b"payload".to_vec()));
        // Truncate the entry: it must be detected and removed.
        let p = c.path(&k);
        let data = std::fs::read(&p).unwrap();
        std::fs::write(&p, &data[..data.len() - 2]).unwrap();
        assert_eq!(c.get(&k), Lookup::Corrupt);
        assert!(!p.exists());
    }

    #[test]
    fn swapped_entries_are_not_trusted() {
        let dir = tempfile::tempdir().unwrap();
        let c = Cache::new(dir.path());
        let a = KeyBuilder::new("a", 1).finish();
        let b = KeyBuilder::new("b", 1).finish();
        c.put(&a, b"result of a").unwrap();
        c.put(&b, b"result of b").unwrap();
        let (pa, pb) = (c.path(&a), c.path(&b));
        let (da, db) = (std::fs::read(&pa).unwrap(), std::fs::read(&pb).unwrap());
        std::fs::write(&pa, db).unwrap();
        std::fs::write(&pb, da).unwrap();
        assert_eq!(c.get(&a), Lookup::Corrupt);
        assert_eq!(c.get(&b), Lookup::Corrupt);
    }

    #[test]
    fn gc_keeps_only_live_keys() {
        let dir = tempfile::tempdir().unwrap();
        let c = Cache::new(dir.path());
        let a = KeyBuilder::new("a", 1).finish();
        let b = KeyBuilder::new("b", 1).finish();
        c.put(&a, b"a").unwrap();
        c.put(&b, b"bb").unwrap();
        let r = c.gc(&[a].into_iter().collect()).unwrap();
        assert_eq!((r.kept, r.removed), (1, 1));
        assert!(c.contains(&a) && !c.contains(&b));
    }

    #[test]
    fn gc_never_touches_what_is_not_an_entry() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("src")).unwrap();
        std::fs::write(dir.path().join("src/main.rs"), b"fn main() {}").unwrap();
        let c = Cache::new(dir.path());
        let e = c.gc(&HashSet::new()).unwrap_err();
        assert!(e.contains("not a tessera cache"), "{e}");
        let k = KeyBuilder::new("a", 1).finish();
        assert!(c.put(&k, b"a").is_err(), "no writes into a foreign directory");
        assert!(dir.path().join("src/main.rs").exists());

        // A marked cache with a stray file: the stray file stays, and is reported.
        let dir = tempfile::tempdir().unwrap();
        let c = Cache::new(dir.path());
        c.put(&k, b"a").unwrap();
        let stray = c.path(&k).with_file_name("notes.txt");
        std::fs::write(&stray, b"mine").unwrap();
        let lookalike = c.path(&k).with_file_name("0".repeat(62));
        std::fs::write(&lookalike, b"not an entry").unwrap();
        let r = c.gc(&HashSet::new()).unwrap();
        assert_eq!(r.removed, 1);
        assert_eq!(r.foreign.len(), 2);
        assert!(stray.exists() && lookalike.exists());
    }

    #[test]
    fn an_unmarked_cache_of_entries_is_adopted() {
        let dir = tempfile::tempdir().unwrap();
        let c = Cache::new(dir.path());
        let k = KeyBuilder::new("a", 1).finish();
        c.put(&k, b"a").unwrap();
        std::fs::remove_file(dir.path().join(MARKER)).unwrap();
        let c = Cache::new(dir.path());
        assert_eq!(c.gc(&HashSet::new()).unwrap().removed, 1);
    }
}
