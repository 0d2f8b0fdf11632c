//! The watch loop's eyes: say when a file the last build read changes.
//!
//! Directories are watched, not files: editors often save by writing a new file and renaming
//! it over the old one, which ends a watch on the old inode. Events are filtered down to the
//! followed paths and debounced, so one save (often several events) gives one rebuild.
//!
//! A followed path need not exist, nor its directory: a scene may import a file in a
//! directory not created yet, and `git checkout` removes a directory and creates it again.
//! So each path is watched through its nearest existing ancestor directory, and that
//! directory's parent is watched too, so that the removal, rename or creation of any
//! directory on the way down to the path is an event here. Such an event re-arms the
//! watches from the file system as it is then. A directory armed anew may have been given
//! its files before its watch existed, so the followed files it holds count as changed;
//! arming repeats until the file system stops moving under it.
//!
//! The watcher never gives up: a directory that cannot be watched (no permission, the
//! system's limit on watches, no watching backend at all) has its followed files polled
//! instead, and the watch is tried again on each poll. A backend that reports lost events
//! (a queue overflow) makes everything count as changed.

use std::collections::{BTreeMap, BTreeSet, HashSet};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, Sender};
use std::time::{Duration, Instant, SystemTime};

use notify::event::{EventKind, ModifyKind};
use notify::RecursiveMode;

/// How often the files no watch covers are looked at (and their watches tried again).
const POLL: Duration = Duration::from_millis(500);
/// File systems stamp modification times from a clock coarser than `SystemTime::now`, so a
/// write just after a build started may carry a time just before it.
const SLACK: Duration = Duration::from_millis(250);
/// Arming rounds per re-arm: each round arms what the previous one found; a file system
/// still changing after this many is caught by the events of the directories already armed.
const ROUNDS: usize = 8;

/// What a path looked like: absent, or its size, modification time and identity.
type Stamp = Option<(u64, Option<SystemTime>, u64)>;

fn stamp(p: &Path) -> Stamp {
    let m = std::fs::metadata(p).ok()?;
    #[cfg(unix)]
    let id = std::os::unix::fs::MetadataExt::ino(&m);
    #[cfg(not(unix))]
    let id = 0;
    Some((m.len(), m.modified().ok(), id))
}

/// What the watcher needs of a notification backend (a trait so that tests can stand in
/// one that fails the way real ones do: no permission, the limit on watches).
trait Backend: Send {
    fn watch(&mut self, dir: &Path) -> notify::Result<()>;
    fn unwatch(&mut self, dir: &Path);
}

impl<W: notify::Watcher + Send> Backend for W {
    fn watch(&mut self, dir: &Path) -> notify::Result<()> {
        notify::Watcher::watch(self, dir, RecursiveMode::NonRecursive)
    }
    fn unwatch(&mut self, dir: &Path) {
        // Gone already (the backend drops watches of removed directories): nothing to do.
        let _ = notify::Watcher::unwatch(self, dir);
    }
}

type Events = notify::Result<notify::Event>;

/// How to judge a followed path whose covering directory was armed only now.
#[derive(Clone, Copy)]
enum Check {
    /// Nothing was built yet: nothing can be out of date.
    Nothing,
    /// The path was read by a build that started then: changed if modified since.
    Since(SystemTime),
    /// Its directory appeared or was replaced: whatever is there now is new.
    Exists,
}

impl Check {
    fn changed(self, p: &Path) -> bool {
        match self {
            Check::Nothing => false,
            Check::Exists => p.exists(),
            Check::Since(t) => {
                let since = t.checked_sub(SLACK).unwrap_or(t);
                std::fs::metadata(p).ok().and_then(|m| m.modified().ok()).is_some_and(|m| m >= since)
            }
        }
    }
}

pub struct Watcher {
    /// `None` when the system gave no watching backend: everything is polled.
    inner: Option<Box<dyn Backend>>,
    rx: Receiver<Events>,
    keep: Option<Sender<Events>>,
    /// The followed paths (files, or directories whose entries count).
    files: BTreeSet<PathBuf>,
    /// Every proper ancestor of a followed path: an event on one of these may move a path.
    above: HashSet<PathBuf>,
    /// The directories watched now.
    armed: HashSet<PathBuf>,
    /// Directories wanted but not watchable at the last arming.
    unarmed: BTreeSet<PathBuf>,
    /// Followed paths no watch covers, as they looked when last polled.
    polled: BTreeMap<PathBuf, Stamp>,
    /// Changes found while arming, reported by the next `wait`.
    pending: BTreeSet<PathBuf>,
    warnings: Vec<String>,
    warned: HashSet<PathBuf>,
}

impl Watcher {
    /// A watcher following nothing yet. Without a backend it polls, with a warning.
    pub fn new() -> Self {
        let (tx, rx) = channel();
        let backend = notify::recommended_watcher(move |ev| {
            let _ = tx.send(ev);
        });
        Self::with_backend(rx, backend.map(|w| Box::new(w) as Box<dyn Backend>))
    }

    fn with_backend(mut rx: Receiver<Events>, backend: notify::Result<Box<dyn Backend>>) -> Self {
        let mut warnings = Vec::new();
        let mut keep = None;
        let inner = match backend {
            Ok(w) => Some(w),
            Err(e) => {
                warnings
                    .push(format!("cannot watch files ({e}); looking at them every {} ms instead", POLL.as_millis()));
                let (tx, open) = channel();
                (rx, keep) = (open, Some(tx));
                None
            }
        };
        Watcher {
            inner,
            rx,
            keep,
            files: BTreeSet::new(),
            above: HashSet::new(),
            armed: HashSet::new(),
            unarmed: BTreeSet::new(),
            polled: BTreeMap::new(),
            pending: BTreeSet::new(),
            warnings,
            warned: HashSet::new(),
        }
    }

    /// Replaces the set of followed paths. `built` is when the build that read them started
    /// (`None` before the first build): a path whose directory only now gets a watch and that
    /// was modified since then is reported by the next `wait`, as the build may have read it
    /// before the change.
    pub fn follow(&mut self, files: impl IntoIterator<Item = PathBuf>, built: Option<SystemTime>) {
        self.files = files.into_iter().map(|f| absolute(&f)).collect();
        // A symlink is followed by its own name (so retargeting it is seen) and by what it
        // points to (so edits of the target are).
        let targets: Vec<PathBuf> = self
            .files
            .iter()
            .filter(|f| f.symlink_metadata().is_ok_and(|m| m.file_type().is_symlink()))
            .filter_map(|f| f.canonicalize().ok())
            .collect();
        self.files.extend(targets);
        self.above = self.files.iter().flat_map(|f| f.ancestors().skip(1).map(Path::to_path_buf)).collect();
        self.polled.retain(|p, _| self.files.contains(p));
        let check = built.map_or(Check::Nothing, Check::Since);
        let mut changed = BTreeSet::new();
        self.rearm(&[], check, &mut changed);
        self.pending.extend(changed);
    }

    pub fn files(&self) -> BTreeSet<PathBuf> {
        self.files.clone()
    }

    /// Messages about watches that could not be placed, since the last call.
    pub fn take_warnings(&mut self) -> Vec<String> {
        std::mem::take(&mut self.warnings)
    }

    /// Blocks until a followed path changes, then waits for `quiet` without further changes,
    /// and returns the changed paths. Events about other paths neither wake nor delay it.
    pub fn wait(&mut self, quiet: Duration) -> BTreeSet<PathBuf> {
        let mut changed = std::mem::take(&mut self.pending);
        let mut last = (!changed.is_empty()).then(Instant::now);
        loop {
            let polling = self.inner.is_none() || !self.polled.is_empty() || !self.unarmed.is_empty();
            // (A quiet time too long to add to an instant is a wait for ever.)
            let timeout = match last.map(|t| t.checked_add(quiet)) {
                Some(Some(end)) => Some(end.saturating_duration_since(Instant::now())),
                Some(None) | None => polling.then_some(POLL),
            };
            let got = match timeout {
                Some(t) => self.rx.recv_timeout(t),
                None => self.rx.recv().map_err(|_| RecvTimeoutError::Disconnected),
            };
            let before = changed.len();
            match got {
                Ok(ev) => self.collect(ev, &mut changed),
                Err(RecvTimeoutError::Timeout) => {
                    if last.is_some_and(|t| t.elapsed() >= quiet) {
                        return changed;
                    }
                    if polling {
                        self.poll(&mut changed);
                    }
                }
                Err(RecvTimeoutError::Disconnected) => {
                    // The backend's thread is gone: poll everything from now on.
                    self.warnings.push(format!(
                        "file watching stopped; looking at the files every {} ms instead",
                        POLL.as_millis()
                    ));
                    self.inner = None;
                    self.armed.clear();
                    // A channel that stays open, so the waits above time out instead.
                    let (tx, rx) = channel();
                    self.rx = rx;
                    self.keep = Some(tx);
                    self.rearm(&[], Check::Nothing, &mut changed);
                }
            }
            if changed.len() > before || (last.is_none() && !changed.is_empty()) {
                last = Some(Instant::now());
            }
        }
    }

    fn collect(&mut self, ev: Events, changed: &mut BTreeSet<PathBuf>) {
        let ev = match ev {
            Ok(ev) if !ev.need_rescan() => ev,
            // Events were lost (or the backend failed): anything may have happened.
            other => {
                if let Err(e) = other {
                    self.warnings.push(format!("file watching: {e}; watching everything again"));
                }
                let all: Vec<PathBuf> = self.armed.iter().cloned().collect();
                self.rearm(&all, Check::Nothing, changed);
                changed.extend(self.files.iter().cloned());
                return;
            }
        };
        if matches!(ev.kind, EventKind::Access(_)) {
            return;
        }
        let mut force = Vec::new();
        let mut rearm = false;
        for p in &ev.paths {
            if self.files.contains(p) || p.parent().is_some_and(|d| self.files.contains(d)) {
                changed.insert(p.clone());
            }
            if !(self.above.contains(p) || self.armed.contains(p)) {
                continue;
            }
            // A directory on the way to followed paths (or a watched one) changed.
            rearm = true;
            if matches!(ev.kind, EventKind::Modify(ModifyKind::Metadata(_) | ModifyKind::Data(_))) {
                continue; // permissions may have changed: arming again is enough
            }
            // It was created, removed or renamed: the watches below it are on directories
            // that are gone, or on the wrong ones, and must be placed afresh.
            force.extend(self.armed.iter().filter(|d| d.starts_with(p)).cloned());
            if !matches!(ev.kind, EventKind::Create(_)) {
                changed.extend(self.files.iter().filter(|f| f.starts_with(p)).cloned());
            }
        }
        if rearm {
            self.rearm(&force, Check::Exists, changed);
        }
    }

    /// Looks at the paths no watch covers, and tries their watches again.
    fn poll(&mut self, changed: &mut BTreeSet<PathBuf>) {
        for (p, was) in self.polled.iter_mut() {
            let now = stamp(p);
            if now != *was {
                *was = now;
                changed.insert(p.clone());
            }
        }
        if self.inner.is_some() {
            self.rearm(&[], Check::Exists, changed);
        }
    }

    /// Brings the watches in line with the followed paths and the file system as it is now.
    /// `force` are watched directories to drop and place again (they may have been replaced).
    fn rearm(&mut self, force: &[PathBuf], check: Check, changed: &mut BTreeSet<PathBuf>) {
        for d in force {
            if self.armed.remove(d) {
                if let Some(w) = &mut self.inner {
                    w.unwatch(d);
                }
            }
        }
        for _ in 0..ROUNDS {
            let (want, cover) = wanted(&self.files);
            for d in self.armed.iter().filter(|d| !want.contains(*d)).cloned().collect::<Vec<_>>() {
                self.armed.remove(&d);
                if let Some(w) = &mut self.inner {
                    w.unwatch(&d);
                }
            }
            let mut newly = HashSet::new();
            self.unarmed.clear();
            let missing: Vec<PathBuf> = want.iter().filter(|d| !self.armed.contains(*d)).cloned().collect();
            for d in &missing {
                let placed = match &mut self.inner {
                    Some(w) => w.watch(d).map_err(describe),
                    None => Err(String::new()),
                };
                match placed {
                    Ok(()) => {
                        self.armed.insert(d.clone());
                        newly.insert(d.clone());
                    }
                    Err(why) => {
                        if self.inner.is_some() && self.warned.insert(d.clone()) {
                            self.warnings.push(format!(
                                "cannot watch `{}` ({why}); looking at the files there every {} ms instead",
                                d.display(),
                                POLL.as_millis()
                            ));
                        }
                        self.unarmed.insert(d.clone());
                    }
                }
            }
            for (f, d) in &cover {
                let covered = d.as_ref().is_some_and(|d| self.armed.contains(d));
                if covered {
                    // Watched only from now on: it may have changed while nothing watched it.
                    let was_polled = self.polled.remove(f).is_some();
                    if (was_polled || d.as_ref().is_some_and(|d| newly.contains(d))) && check.changed(f) {
                        changed.insert(f.clone());
                    }
                } else if !self.polled.contains_key(f) {
                    if check.changed(f) {
                        changed.insert(f.clone());
                    }
                    self.polled.insert(f.clone(), stamp(f));
                }
            }
            if newly.is_empty() {
                break;
            }
        }
    }
}

impl Default for Watcher {
    fn default() -> Self {
        Self::new()
    }
}

/// The directories to watch for the followed paths, and for each path the directory whose
/// events cover it (itself when a directory, else its nearest existing ancestor; `None` when
/// not even `/` exists, which cannot happen but is not worth a panic).
fn wanted(files: &BTreeSet<PathBuf>) -> (BTreeSet<PathBuf>, Vec<(PathBuf, Option<PathBuf>)>) {
    let mut want = BTreeSet::new();
    let mut cover = Vec::with_capacity(files.len());
    for f in files {
        let near = f.ancestors().skip(1).find(|a| a.is_dir()).map(Path::to_path_buf);
        if let Some(a) = &near {
            want.insert(a.clone());
            // Its parent sees it removed, renamed or replaced.
            if let Some(g) = a.parent() {
                want.insert(g.to_path_buf());
            }
        }
        if f.is_dir() {
            want.insert(f.clone());
            cover.push((f.clone(), Some(f.clone())));
        } else {
            cover.push((f.clone(), near));
        }
    }
    (want, cover)
}

fn describe(e: notify::Error) -> String {
    match e.kind {
        notify::ErrorKind::MaxFilesWatch => "the system's limit on file watches is reached".to_string(),
        notify::ErrorKind::Io(e) => e.to_string(),
        _ => e.to_string(),
    }
}

/// An absolute path whose existing part is canonical, so that it matches the paths events
/// carry (which are built from the canonical directories watched). The final component is
/// kept as named: a symlinked file is followed by its own name.
fn absolute(p: &Path) -> PathBuf {
    let p = if p.is_absolute() {
        p.to_path_buf()
    } else {
        std::env::current_dir().map(|d| d.join(p)).unwrap_or_else(|_| p.to_path_buf())
    };
    let Some(name) = p.file_name() else { return p };
    let parent = p.parent().unwrap_or(Path::new("/"));
    // The nearest ancestor that exists is canonicalised; the missing rest is appended.
    for a in parent.ancestors() {
        if let Ok(c) = a.canonicalize() {
            let rest = parent.strip_prefix(a).unwrap_or(Path::new(""));
            return c.join(rest).join(name);
        }
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;

    /// A backend that refuses directories the way the system does when `refuse` says so.
    type Refuse = Box<dyn Fn(&Path) -> Option<notify::Error> + Send>;
    type Watched = Arc<std::sync::Mutex<Vec<PathBuf>>>;

    struct Refusing {
        refuse: Refuse,
        watched: Watched,
    }

    impl Backend for Refusing {
        fn watch(&mut self, dir: &Path) -> notify::Result<()> {
            match (self.refuse)(dir) {
                Some(e) => Err(e),
                None => {
                    self.watched.lock().unwrap().push(dir.to_path_buf());
                    Ok(())
                }
            }
        }
        fn unwatch(&mut self, _: &Path) {}
    }

    fn refusing(refuse: impl Fn(&Path) -> Option<notify::Error> + Send + 'static) -> (Box<dyn Backend>, Watched) {
        let watched = Arc::new(std::sync::Mutex::new(Vec::new()));
        (Box::new(Refusing { refuse: Box::new(refuse), watched: watched.clone() }), watched)
    }

    #[test]
    fn the_limit_on_watches_falls_back_to_polling() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("a.txt");
        std::fs::write(&f, "one").unwrap();
        let (_tx, rx) = channel();
        let (backend, _) = refusing(|_| Some(notify::Error::new(notify::ErrorKind::MaxFilesWatch)));
        let mut w = Watcher::with_backend(rx, Ok(backend));
        w.follow([f.clone()], None);
        let warnings = w.take_warnings().join("\n");
        assert!(warnings.contains("limit on file watches"), "{warnings}");
        std::fs::write(&f, "two, longer").unwrap();
        assert!(w.wait(Duration::from_millis(10)).contains(&absolute(&f)));
    }

    #[test]
    fn a_directory_refused_is_polled_and_watched_once_it_can_be() {
        let dir = tempfile::tempdir().unwrap();
        let sub = dir.path().join("locked");
        std::fs::create_dir(&sub).unwrap();
        let f = sub.join("a.txt");
        std::fs::write(&f, "one").unwrap();
        let sub = absolute(&sub.join("x")).parent().unwrap().to_path_buf();
        let refused = Arc::new(AtomicBool::new(true));
        let (r, s) = (refused.clone(), sub.clone());
        let (backend, watched) = refusing(move |d| {
            (r.load(Ordering::SeqCst) && d == s)
                .then(|| notify::Error::io(std::io::Error::from(std::io::ErrorKind::PermissionDenied)))
        });
        let (_tx, rx) = channel();
        let mut w = Watcher::with_backend(rx, Ok(backend));
        w.follow([f.clone()], None);
        let warnings = w.take_warnings().join("\n");
        assert!(warnings.contains("locked"), "{warnings}");
        assert!(!watched.lock().unwrap().contains(&sub));
        std::fs::write(&f, "two, longer").unwrap();
        assert!(w.wait(Duration::from_millis(10)).contains(&absolute(&f)));
        // Allowed now: the next poll places the watch.
        refused.store(false, Ordering::SeqCst);
        std::fs::write(&f, "three, longer still").unwrap();
        assert!(w.wait(Duration::from_millis(10)).contains(&absolute(&f)));
        assert!(watched.lock().unwrap().contains(&sub), "the watch was not tried again");
        assert!(w.take_warnings().is_empty(), "a refusal is reported once");
    }

    #[test]
    fn no_backend_at_all_polls_everything() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("a.txt");
        let (_tx, rx) = channel();
        let mut w = Watcher::with_backend(rx, Err(notify::Error::generic("no inotify instances left")));
        assert!(w.take_warnings().join("\n").contains("no inotify instances left"));
        // Followed before it exists; its creation is seen.
        w.follow([f.clone()], None);
        std::fs::write(&f, "one").unwrap();
        assert!(w.wait(Duration::from_millis(10)).contains(&absolute(&f)));
    }

    #[test]
    fn lost_events_and_backend_errors_count_as_everything_changed() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.txt"), dir.path().join("sub/b.txt"));
        std::fs::write(&a, "a").unwrap();
        let (tx, rx) = channel();
        let (backend, _) = refusing(|_| None);
        let mut w = Watcher::with_backend(rx, Ok(backend));
        w.follow([a.clone(), b.clone()], None);
        let all: BTreeSet<PathBuf> = [absolute(&a), absolute(&b)].into();
        tx.send(Ok(notify::Event::new(EventKind::Other).set_flag(notify::event::Flag::Rescan))).unwrap();
        assert_eq!(w.wait(Duration::from_millis(10)), all);
        tx.send(Err(notify::Error::generic("read failed"))).unwrap();
        assert_eq!(w.wait(Duration::from_millis(10)), all);
        assert!(w.take_warnings().join("\n").contains("read failed"));
    }

    #[test]
    fn events_about_other_paths_do_not_delay_a_rebuild() {
        let dir = tempfile::tempdir().unwrap();
        let a = absolute(&dir.path().join("a.txt"));
        let (tx, rx) = channel();
        let (backend, _) = refusing(|_| None);
        let mut w = Watcher::with_backend(rx, Ok(backend));
        w.follow([a.clone()], None);
        let noise = dir.path().join("noise.log");
        let stop = Arc::new(AtomicBool::new(false));
        let (s, t) = (stop.clone(), tx.clone());
        let noisy = std::thread::spawn(move || {
            while !s.load(Ordering::SeqCst) {
                let _ = t.send(Ok(notify::Event::new(EventKind::Modify(ModifyKind::Any)).add_path(noise.clone())));
                std::thread::sleep(Duration::from_millis(1));
            }
        });
        tx.send(Ok(notify::Event::new(EventKind::Create(notify::event::CreateKind::File)).add_path(a.clone())))
            .unwrap();
        assert_eq!(w.wait(Duration::from_millis(50)), [a].into());
        stop.store(true, Ordering::SeqCst);
        noisy.join().unwrap();
    }
}
