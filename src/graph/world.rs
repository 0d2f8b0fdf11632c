//! The one door to files. Every read of a scene, sample or map goes through `World`, which
//! hashes what it reads and records it: keys use those hashes, and watch mode watches
//! exactly the recorded files.
//!
//! Within a build the bytes that were hashed are the bytes a stage gets, so a file that
//! changes mid-build cannot put a result under the wrong key. Across builds (watch mode)
//! only hashes are kept, revalidated by size and modification time.

use std::collections::{BTreeSet, HashMap};
use std::io;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::SystemTime;

pub type Hash = [u8; 32];

#[derive(Clone)]
struct Entry {
    len: u64,
    mtime: Option<SystemTime>,
    hash: Hash,
    bytes: Option<Arc<[u8]>>,
}

#[derive(Default)]
pub struct World {
    entries: Mutex<HashMap<PathBuf, Entry>>,
    accessed: Mutex<BTreeSet<PathBuf>>,
}

impl World {
    pub fn new() -> Self {
        Self::default()
    }

    /// Starts a new build: forgets what was read, drops held bytes, keeps hashes.
    pub fn begin_build(&self) {
        self.accessed.lock().expect("world lock").clear();
        for e in self.entries.lock().expect("world lock").values_mut() {
            e.bytes = None;
        }
    }

    /// Every file read since `begin_build`.
    pub fn accessed(&self) -> Vec<PathBuf> {
        self.accessed.lock().expect("world lock").iter().cloned().collect()
    }

    fn stat(path: &Path) -> io::Result<(u64, Option<SystemTime>)> {
        let m = std::fs::metadata(path)?;
        if m.is_dir() {
            return Err(io::Error::new(io::ErrorKind::InvalidInput, "is a directory, not a file"));
        }
        Ok((m.len(), m.modified().ok()))
    }

    /// The file's bytes, read at most once per build.
    pub fn read(&self, path: &Path) -> io::Result<Arc<[u8]>> {
        self.accessed.lock().expect("world lock").insert(path.to_path_buf());
        let (_, mtime) = Self::stat(path)?;
        if let Some(b) = self.entries.lock().expect("world lock").get(path).and_then(|e| e.bytes.clone()) {
            return Ok(b);
        }
        let bytes: Arc<[u8]> = std::fs::read(path)?.into();
        let hash = *blake3::hash(&bytes).as_bytes();
        self.entries
            .lock()
            .expect("world lock")
            .insert(path.to_path_buf(), Entry { len: bytes.len() as u64, mtime, hash, bytes: Some(bytes.clone()) });
        Ok(bytes)
    }

    /// The files in a directory (not recursive). The directory counts as read, so watch mode
    /// follows files being added to or removed from it.
    pub fn list(&self, dir: &Path) -> io::Result<Vec<PathBuf>> {
        self.accessed.lock().expect("world lock").insert(dir.to_path_buf());
        let mut out = Vec::new();
        for e in std::fs::read_dir(dir)? {
            let e = e?;
            if e.file_type()?.is_file() {
                out.push(e.path());
            }
        }
        out.sort();
        Ok(out)
    }

    pub fn read_text(&self, path: &Path) -> io::Result<Arc<str>> {
        let bytes = self.read(path)?;
        let s = std::str::from_utf8(&bytes)
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, format!("not UTF-8 text: {e}")))?;
        Ok(Arc::from(s))
    }

    /// The content hash of a file. Uses the size + mtime fast path when the file was
    /// hashed before and has not changed since.
    pub fn hash(&self, path: &Path) -> io::Result<Hash> {
        self.accessed.lock().expect("world lock").insert(path.to_path_buf());
        let (len, mtime) = Self::stat(path)?;
        if let Some(e) = self.entries.lock().expect("world lock").get(path) {
            if e.bytes.is_some() || (e.len == len && e.mtime == mtime && mtime.is_some()) {
                return Ok(e.hash);
            }
        }
        self.read(path)?;
        Ok(self.entries.lock().expect("world lock")[path].hash)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_reads_and_hashes_consistently() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        std::fs::write(&p, "hello").unwrap();
        let w = World::new();
        let h1 = w.hash(&p).unwrap();
        assert_eq!(&*w.read(&p).unwrap(), b"hello");
        assert_eq!(w.accessed(), vec![p.clone()]);
        w.begin_build();
        assert!(w.accessed().is_empty());
        std::fs::write(&p, "hello, world").unwrap();
        let h2 = w.hash(&p).unwrap();
        assert_ne!(h1, h2);
        assert!(w.read(dir.path().join("missing").as_path()).is_err());
    }
}
