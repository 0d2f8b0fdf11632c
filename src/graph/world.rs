//! The one door to files. Every read of a scene, sample or map goes through `World`, which
//! hashes what it reads and records it: keys use those hashes, and watch mode watches
//! exactly the recorded files.
//!
//! Within a build the bytes that were hashed are the bytes a stage gets, so a file that
//! changes mid-build cannot put a result under the wrong key. Across builds (watch mode)
//! only hashes are kept, revalidated by size and modification time.
//!
//! Only regular files are read, and none larger than `max_file` bytes (a quarter of the
//! memory budget): a FIFO, a device such as `/dev/zero` or a huge file named as an input is
//! an error saying so, never a read that blocks or fills memory.

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

pub struct World {
    entries: Mutex<HashMap<PathBuf, Entry>>,
    accessed: Mutex<BTreeSet<PathBuf>>,
    max_file: u64,
}

impl Default for World {
    fn default() -> Self {
        World::with_max_file(super::Budget::from_machine().max_file())
    }
}

impl World {
    pub fn new() -> Self {
        Self::default()
    }

    /// A world that refuses files larger than `max_file` bytes.
    pub fn with_max_file(max_file: u64) -> Self {
        World { entries: Mutex::default(), accessed: Mutex::default(), max_file }
    }

    pub fn set_max_file(&mut self, max_file: u64) {
        self.max_file = max_file;
    }

    pub fn max_file(&self) -> u64 {
        self.max_file
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

    fn stat(&self, path: &Path) -> io::Result<(u64, Option<SystemTime>)> {
        let m = std::fs::metadata(path)?;
        self.admit(&m)?;
        Ok((m.len(), m.modified().ok()))
    }

    /// Refuses what is not a regular file of at most `max_file` bytes.
    fn admit(&self, m: &std::fs::Metadata) -> io::Result<()> {
        admit(m, self.max_file)
    }

    fn read_capped(&self, path: &Path) -> io::Result<Vec<u8>> {
        read_regular(path, self.max_file)
    }

    /// The file's bytes, read at most once per build.
    pub fn read(&self, path: &Path) -> io::Result<Arc<[u8]>> {
        self.accessed.lock().expect("world lock").insert(path.to_path_buf());
        // Checked before opening: opening a FIFO would wait for a writer.
        let (_, mtime) = self.stat(path)?;
        if let Some(b) = self.entries.lock().expect("world lock").get(path).and_then(|e| e.bytes.clone()) {
            return Ok(b);
        }
        let bytes: Arc<[u8]> = self.read_capped(path)?.into();
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
        let (len, mtime) = self.stat(path)?;
        if let Some(e) = self.entries.lock().expect("world lock").get(path) {
            if e.bytes.is_some() || (e.len == len && e.mtime == mtime && mtime.is_some()) {
                return Ok(e.hash);
            }
        }
        self.read(path)?;
        Ok(self.entries.lock().expect("world lock")[path].hash)
    }
}

/// Refuses what is not a regular file of at most `max_file` bytes.
fn admit(m: &std::fs::Metadata, max_file: u64) -> io::Result<()> {
    let ft = m.file_type();
    if ft.is_dir() {
        return Err(io::Error::new(io::ErrorKind::InvalidInput, "is a directory, not a file"));
    }
    if !ft.is_file() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            "is not a regular file (a device, FIFO or socket); tessera reads only regular files",
        ));
    }
    if m.len() > max_file {
        return Err(too_large(Some(m.len()), max_file));
    }
    Ok(())
}

fn too_large(len: Option<u64>, max_file: u64) -> io::Error {
    let size = len.map(|l| format!(" ({})", super::budget::Bytes(l as f64))).unwrap_or_default();
    io::Error::new(
        io::ErrorKind::InvalidInput,
        format!(
            "is too large{size}: input files may hold at most {}, a quarter of the memory budget (raise it with `--max-memory` or `[limits] max_memory` in tessera.toml)",
            super::budget::Bytes(max_file as f64)
        ),
    )
}

/// Reads a whole regular file, never more than `max_file` bytes of it (the file may grow
/// between the check and the read). For the few reads that are not build inputs (the
/// manifest, `fmt`, the texture tools); build inputs go through [`World::read`].
pub fn read_regular(path: &Path, max_file: u64) -> io::Result<Vec<u8>> {
    use std::io::Read;
    // Checked before opening: opening a FIFO would wait for a writer.
    admit(&std::fs::metadata(path)?, max_file)?;
    let file = std::fs::File::open(path)?;
    let m = file.metadata()?;
    admit(&m, max_file)?;
    let mut bytes = Vec::with_capacity(m.len() as usize);
    file.take(max_file.saturating_add(1)).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_file {
        return Err(too_large(None, max_file));
    }
    Ok(bytes)
}

/// [`read_regular`] for UTF-8 text.
pub fn read_regular_text(path: &Path, max_file: u64) -> io::Result<String> {
    String::from_utf8(read_regular(path, max_file)?)
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, format!("not UTF-8 text: {}", e.utf8_error())))
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

    #[test]
    fn refuses_devices_and_large_files() {
        let w = World::with_max_file(8);
        let e = w.read(Path::new("/dev/zero")).unwrap_err();
        assert!(e.to_string().contains("not a regular file"), "{e}");
        assert!(w.hash(Path::new("/dev/null")).is_err());
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("big");
        std::fs::write(&p, [0u8; 9]).unwrap();
        let e = w.read_text(&p).unwrap_err();
        assert!(e.to_string().contains("too large"), "{e}");
        std::fs::write(&p, [b'a'; 8]).unwrap();
        assert_eq!(&*w.read_text(&p).unwrap(), "aaaaaaaa");
    }
}
