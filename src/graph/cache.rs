//! The on-disk artifact cache: content-addressed by stage key, written atomically,
//! verified on load, collected by `tessera gc`.
//!
//! Entry layout: `TSC1` magic, blake3 of the payload (32 bytes), payload. An entry whose
//! payload does not match its hash (a truncated write, a flipped bit) is deleted and
//! reported as a miss, so the stage runs again instead of trusting it.
//!
//! Two builds may write the same key at once: each writes a private temporary file and
//! renames it into place; rename is atomic and both payloads are identical, so whichever
//! lands last is as good as the first.

use std::collections::HashSet;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use super::key::Key;

const MAGIC: &[u8; 4] = b"TSC1";

pub struct Cache {
    dir: PathBuf,
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
}

static TMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes `bytes` to `path` atomically: a temporary file in the same directory, then a
/// rename. Readers see the old file or the new one, never a part.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = dir.join(format!(".{name}.{}.{}.tmp", std::process::id(), TMP_COUNTER.fetch_add(1, Ordering::Relaxed)));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.flush()?;
        drop(f);
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

impl Cache {
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        Cache { dir: dir.into() }
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
        if data.len() >= 36 && &data[..4] == MAGIC {
            let payload = &data[36..];
            if blake3::hash(payload).as_bytes() == &data[4..36] {
                return Lookup::Hit(payload.to_vec());
            }
        }
        let _ = std::fs::remove_file(&path);
        Lookup::Corrupt
    }

    pub fn put(&self, key: &Key, payload: &[u8]) -> io::Result<()> {
        let mut data = Vec::with_capacity(payload.len() + 36);
        data.extend_from_slice(MAGIC);
        data.extend_from_slice(blake3::hash(payload).as_bytes());
        data.extend_from_slice(payload);
        write_atomic(&self.path(key), &data)
    }

    /// Removes every entry whose key is not in `keep`, and stray temporary files.
    pub fn gc(&self, keep: &HashSet<Key>) -> io::Result<GcReport> {
        let keep_hex: HashSet<String> = keep.iter().map(|k| k.hex()).collect();
        let mut report = GcReport::default();
        let Ok(shards) = std::fs::read_dir(&self.dir) else { return Ok(report) };
        for shard in shards {
            let shard = shard?;
            if !shard.file_type()?.is_dir() {
                continue;
            }
            let prefix = shard.file_name().to_string_lossy().into_owned();
            for entry in std::fs::read_dir(shard.path())? {
                let entry = entry?;
                let name = entry.file_name().to_string_lossy().into_owned();
                if keep_hex.contains(&format!("{prefix}{name}")) {
                    report.kept += 1;
                    continue;
                }
                let len = entry.metadata().map(|m| m.len()).unwrap_or(0);
                if std::fs::remove_file(entry.path()).is_ok() {
                    report.removed += 1;
                    report.freed_bytes += len;
                }
            }
            let _ = std::fs::remove_dir(shard.path()); // only succeeds when empty
        }
        Ok(report)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::key::KeyBuilder;

    #[test]
    fn round_trips_and_rejects_corruption() {
        let dir = tempfile::tempdir().unwrap();
        let c = Cache::new(dir.path());
        let k = KeyBuilder::new("t", 1).finish();
        assert_eq!(c.get(&k), Lookup::Miss);
        c.put(&k, b"payload").unwrap();
        assert_eq!(c.get(&k), Lookup::Hit(b"payload".to_vec()));
        // Truncate the entry: it must be detected and removed.
        let p = c.path(&k);
        let data = std::fs::read(&p).unwrap();
        std::fs::write(&p, &data[..data.len() - 2]).unwrap();
        assert_eq!(c.get(&k), Lookup::Corrupt);
        assert!(!p.exists());
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
}
