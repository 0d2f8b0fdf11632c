//! The watch loop: rebuild when a file the last build read changes.
//!
//! It watches the parent directories of those files rather than the files themselves:
//! editors often save by writing a new file and renaming it over the old one, which ends
//! a watch on the old inode. Events are filtered down to the files of interest and
//! debounced, so one save (often several events) gives one rebuild.

use std::collections::{BTreeSet, HashSet};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError};
use std::time::Duration;

use notify::{RecommendedWatcher, RecursiveMode, Watcher as _};

pub struct Watcher {
    inner: RecommendedWatcher,
    rx: Receiver<notify::Result<notify::Event>>,
    dirs: HashSet<PathBuf>,
    files: HashSet<PathBuf>,
}

impl Watcher {
    pub fn new() -> notify::Result<Self> {
        let (tx, rx) = channel();
        let inner = notify::recommended_watcher(move |ev| {
            let _ = tx.send(ev);
        })?;
        Ok(Watcher { inner, rx, dirs: HashSet::new(), files: HashSet::new() })
    }

    /// Replaces the set of watched files.
    pub fn follow(&mut self, files: impl IntoIterator<Item = PathBuf>) -> notify::Result<()> {
        let files: HashSet<PathBuf> = files.into_iter().map(|f| absolute(&f)).collect();
        // A followed directory (a library) is watched itself: any entry changing counts.
        let dirs: HashSet<PathBuf> = files
            .iter()
            .filter_map(|f| if f.is_dir() { Some(f.clone()) } else { f.parent().map(Path::to_path_buf) })
            .filter(|d| d.is_dir())
            .collect();
        for gone in self.dirs.difference(&dirs) {
            let _ = self.inner.unwatch(gone);
        }
        for new in dirs.difference(&self.dirs) {
            self.inner.watch(new, RecursiveMode::NonRecursive)?;
        }
        self.dirs = dirs;
        self.files = files;
        Ok(())
    }

    pub fn files(&self) -> BTreeSet<PathBuf> {
        self.files.iter().cloned().collect()
    }

    /// Blocks until a watched file changes, then waits for `quiet` without further
    /// events, and returns the changed files. `None` when the watcher has shut down.
    pub fn wait(&self, quiet: Duration) -> Option<BTreeSet<PathBuf>> {
        let mut changed = BTreeSet::new();
        loop {
            let ev = self.rx.recv().ok()?;
            self.collect(ev, &mut changed);
            if !changed.is_empty() {
                break;
            }
        }
        loop {
            match self.rx.recv_timeout(quiet) {
                Ok(ev) => self.collect(ev, &mut changed),
                Err(RecvTimeoutError::Timeout) => return Some(changed),
                Err(RecvTimeoutError::Disconnected) => return None,
            }
        }
    }

    fn collect(&self, ev: notify::Result<notify::Event>, changed: &mut BTreeSet<PathBuf>) {
        let Ok(ev) = ev else { return };
        if matches!(ev.kind, notify::EventKind::Access(_)) {
            return;
        }
        for p in ev.paths {
            let p = absolute(&p);
            if self.files.contains(&p) || p.parent().is_some_and(|d| self.files.contains(d)) {
                changed.insert(p);
            }
        }
    }
}

fn absolute(p: &Path) -> PathBuf {
    let p = if p.is_absolute() {
        p.to_path_buf()
    } else {
        std::env::current_dir().map(|d| d.join(p)).unwrap_or_else(|_| p.to_path_buf())
    };
    // Resolve symlinked directories (e.g. /tmp on some systems) so events match.
    match (p.parent().and_then(|d| d.canonicalize().ok()), p.file_name()) {
        (Some(d), Some(n)) => d.join(n),
        _ => p,
    }
}
