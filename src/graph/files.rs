//! Writing files without ever losing one: paths proven to lie inside their root, atomic
//! single writes, and output sets that change all at once or not at all.
//!
//! Every file tessera writes goes through this module. Temporary files carry a name of
//! their own format (`.tessera-tmp-<pid>-<n>`), never derived from the destination (so a
//! destination name at the file system's limit still has a temporary), and a later run
//! removes the ones a killed process left behind ([`sweep_stale`]).

use std::collections::BTreeMap;
use std::fmt;
use std::io::{self, Write};
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Prefix of every temporary or backup file tessera creates. Output names may not use it.
pub const RESERVED_PREFIX: &str = ".tessera-";
const TMP_PREFIX: &str = ".tessera-tmp-";
const OLD_PREFIX: &str = ".tessera-old-";
/// The longest file name component most file systems accept (ext4, APFS, NTFS: 255 bytes).
pub const NAME_MAX: usize = 255;

static COUNTER: AtomicU64 = AtomicU64::new(0);

fn unique_name(prefix: &str) -> String {
    format!("{prefix}{}-{}", std::process::id(), COUNTER.fetch_add(1, Ordering::Relaxed))
}

/// Why a relative path cannot name a file below a root.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PathProblem {
    Empty,
    Absolute,
    /// A `..` component.
    Parent,
    /// A component longer than [`NAME_MAX`] bytes.
    TooLong(String),
    /// A component that starts with [`RESERVED_PREFIX`].
    Reserved(String),
    /// A NUL byte, which no file system accepts.
    Nul,
    /// After resolving links, the path leaves its root.
    Escapes(PathBuf),
}

impl fmt::Display for PathProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PathProblem::Empty => write!(f, "the path is empty"),
            PathProblem::Absolute => write!(f, "the path is absolute"),
            PathProblem::Parent => write!(f, "the path has a `..` component"),
            PathProblem::TooLong(c) => {
                write!(f, "the name `{}…` is {} bytes long (at most {NAME_MAX})", truncate(c, 24), c.len())
            }
            PathProblem::Reserved(c) => write!(f, "names starting with `{RESERVED_PREFIX}` are tessera's own (`{c}`)"),
            PathProblem::Nul => write!(f, "the path holds a NUL byte"),
            PathProblem::Escapes(p) => {
                write!(f, "a link makes the path leave its directory (it resolves to `{}`)", p.display())
            }
        }
    }
}

fn truncate(s: &str, n: usize) -> &str {
    match s.char_indices().nth(n) {
        Some((i, _)) => &s[..i],
        None => s,
    }
}

/// A path's last component as text (empty for `..` or a root): how messages and tables name
/// a file.
pub fn name_of(path: &Path) -> String {
    path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
}

/// The normal form of a relative path that must stay below its root: `.` components and
/// doubled separators dropped; `..`, absolute paths, over-long and reserved names refused.
/// Two outputs are the same file exactly when their normal forms are equal.
pub fn normal_relative(rel: &str) -> Result<PathBuf, PathProblem> {
    if rel.contains('\0') {
        return Err(PathProblem::Nul);
    }
    let mut out = PathBuf::new();
    for c in Path::new(rel).components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => return Err(PathProblem::Parent),
            Component::RootDir | Component::Prefix(_) => return Err(PathProblem::Absolute),
            Component::Normal(n) => {
                let s = n.to_string_lossy();
                if s.len() > NAME_MAX {
                    return Err(PathProblem::TooLong(s.into_owned()));
                }
                if s.starts_with(RESERVED_PREFIX) {
                    return Err(PathProblem::Reserved(s.into_owned()));
                }
                out.push(n);
            }
        }
    }
    if out.as_os_str().is_empty() {
        return Err(PathProblem::Empty);
    }
    Ok(out)
}

/// `root/rel`, proven to lie below `root`: `rel` is normalised by [`normal_relative`], and the
/// deepest part of the result that exists already is resolved (links followed, as the
/// operating system would) and must still lie below the resolved root.
pub fn contained(root: &Path, rel: &str) -> Result<PathBuf, PathProblem> {
    let rel = normal_relative(rel)?;
    let path = root.join(&rel);
    check_links(root, &path)?;
    Ok(path)
}

/// Refuses `path` when an existing directory on the way to it is a link leading outside
/// `root`. The final component may be a link: writes replace it rather than follow it.
pub fn check_links(root: &Path, path: &Path) -> Result<(), PathProblem> {
    let Some(parent) = path.parent() else { return Ok(()) };
    let real = resolve(parent);
    if real.starts_with(resolve(root)) {
        Ok(())
    } else {
        Err(PathProblem::Escapes(real))
    }
}

/// `p` made absolute and resolved as the operating system would: the longest part that
/// exists has its links and `..` resolved; the rest is taken as written (`.` dropped, `..`
/// going up).
pub fn resolve(p: &Path) -> PathBuf {
    let p = if p.is_absolute() { p.to_path_buf() } else { std::env::current_dir().unwrap_or_default().join(p) };
    let mut existing = p.clone();
    let mut rest: Vec<std::ffi::OsString> = Vec::new();
    loop {
        if let Ok(real) = existing.canonicalize() {
            let mut out = real;
            for c in rest.iter().rev() {
                match c.to_str() {
                    Some("..") => {
                        out.pop();
                    }
                    Some(".") => {}
                    _ => out.push(c),
                }
            }
            return out;
        }
        let Some(last) = existing.components().next_back().map(|c| c.as_os_str().to_os_string()) else { return p };
        rest.push(last);
        if !existing.pop() {
            return p;
        }
    }
}

/// Writes `bytes` to `path` atomically: a temporary file in the same directory, flushed to
/// disk, then renamed over the destination. Readers see the old file or the new one, never a
/// part, and after a crash the file is one of the two.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let dir = parent_dir(path);
    std::fs::create_dir_all(dir)?;
    let tmp = dir.join(unique_name(TMP_PREFIX));
    let result = write_synced(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    } else {
        sync_dir(dir);
    }
    result
}

fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

fn write_synced(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut f = std::fs::OpenOptions::new().write(true).create_new(true).open(path)?;
    f.write_all(bytes)?;
    f.sync_all()
}

/// Makes a rename in `dir` durable. Best effort: not every platform can open a directory.
fn sync_dir(dir: &Path) {
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
}

/// Whether a file name is one of tessera's temporaries or backups, and the process that
/// made it.
fn own_temporary(name: &str) -> Option<u32> {
    let rest = name.strip_prefix(TMP_PREFIX).or_else(|| name.strip_prefix(OLD_PREFIX))?;
    let (pid, n) = rest.split_once('-')?;
    if pid.is_empty() || n.is_empty() || !n.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    pid.parse().ok()
}

/// Whether a process that left a temporary may still be writing it. Where that cannot be
/// known (no `/proc`), a temporary counts as live unless it is a day old.
fn may_be_live(pid: u32, path: &Path) -> bool {
    if pid == std::process::id() {
        return true;
    }
    let proc = Path::new("/proc");
    if proc.join("self").exists() {
        return proc.join(pid.to_string()).exists();
    }
    let age = std::fs::symlink_metadata(path).and_then(|m| m.modified()).ok().and_then(|t| t.elapsed().ok());
    age.is_none_or(|a| a < std::time::Duration::from_secs(24 * 3600))
}

/// Removes the temporaries that killed tessera processes left in `dir` (not recursive).
/// Only files of tessera's own temporary format whose process is gone are touched.
pub fn sweep_stale(dir: &Path) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else { return 0 };
    let mut removed = 0;
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(pid) = own_temporary(&name.to_string_lossy()) else { continue };
        let path = e.path();
        if e.file_type().is_ok_and(|t| t.is_file()) && !may_be_live(pid, &path) && std::fs::remove_file(&path).is_ok() {
            removed += 1;
        }
    }
    removed
}

/// Whether `name` is a tessera temporary (for a cache that must account for every file).
pub fn is_temporary(name: &str) -> bool {
    own_temporary(name).is_some()
}

/// A set of files that is written all at once or not at all.
///
/// [`OutputSet::commit`] first validates every destination (a directory where a file must
/// go, a file where a directory must be, an unwritable directory), then writes each new
/// file to a temporary beside its destination and flushes it to disk, and only then renames
/// them into place, keeping a hard link to each file it replaces so that a failed rename
/// puts every earlier one back. Files whose bytes are unchanged are not touched.
#[derive(Default)]
pub struct OutputSet {
    files: BTreeMap<PathBuf, Vec<u8>>,
}

/// What a committed set did to each of its files.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Written {
    pub path: PathBuf,
    pub changed: bool,
}

#[derive(Debug)]
pub struct CommitError {
    pub path: PathBuf,
    pub error: io::Error,
}

impl fmt::Display for CommitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "cannot write `{}`: {}", self.path.display(), self.error)
    }
}

struct Staged {
    dest: PathBuf,
    tmp: PathBuf,
    backup: Option<PathBuf>,
    renamed: bool,
}

impl OutputSet {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn add(&mut self, path: PathBuf, bytes: Vec<u8>) {
        self.files.insert(path, bytes);
    }

    pub fn commit(self) -> Result<Vec<Written>, CommitError> {
        let mut report = Vec::new();
        let mut todo = Vec::new();
        for (path, bytes) in &self.files {
            let same = std::fs::metadata(path).is_ok_and(|m| m.is_file() && m.len() == bytes.len() as u64)
                && std::fs::read(path).is_ok_and(|b| &b == bytes);
            report.push(Written { path: path.clone(), changed: !same });
            if !same {
                validate_destination(path).map_err(|error| CommitError { path: path.clone(), error })?;
                todo.push((path, bytes));
            }
        }
        if todo.is_empty() {
            return Ok(report);
        }
        let mut created_dirs = Vec::new();
        let mut staged: Vec<Staged> = Vec::new();
        let result = (|| {
            for (path, bytes) in &todo {
                let dir = parent_dir(path);
                create_dirs(dir, &mut created_dirs).map_err(|error| CommitError { path: dir.to_path_buf(), error })?;
                let tmp = dir.join(unique_name(TMP_PREFIX));
                let s = Staged { dest: path.to_path_buf(), tmp: tmp.clone(), backup: None, renamed: false };
                let written = write_synced(&tmp, bytes);
                staged.push(s);
                written.map_err(|error| CommitError { path: path.to_path_buf(), error })?;
            }
            for s in &mut staged {
                if std::fs::symlink_metadata(&s.dest).is_ok() {
                    let backup = parent_dir(&s.dest).join(unique_name(OLD_PREFIX));
                    keep_old(&s.dest, &backup).map_err(|error| CommitError { path: s.dest.clone(), error })?;
                    s.backup = Some(backup);
                }
            }
            for s in &mut staged {
                std::fs::rename(&s.tmp, &s.dest).map_err(|error| CommitError { path: s.dest.clone(), error })?;
                s.renamed = true;
            }
            Ok(())
        })();
        match result {
            Ok(()) => {
                let mut dirs: Vec<&Path> = staged.iter().map(|s| parent_dir(&s.dest)).collect();
                dirs.sort();
                dirs.dedup();
                for d in dirs {
                    sync_dir(d);
                }
                for s in &staged {
                    if let Some(b) = &s.backup {
                        let _ = std::fs::remove_file(b);
                    }
                }
                Ok(report)
            }
            Err(e) => {
                // Put back what was replaced, newest first, then remove what was added.
                for s in staged.iter().rev() {
                    match (&s.backup, s.renamed) {
                        (Some(b), true) => {
                            let _ = std::fs::rename(b, &s.dest);
                        }
                        (Some(b), false) => {
                            let _ = std::fs::remove_file(b);
                        }
                        (None, true) => {
                            let _ = std::fs::remove_file(&s.dest);
                        }
                        (None, false) => {}
                    }
                    let _ = std::fs::remove_file(&s.tmp);
                }
                for d in created_dirs.iter().rev() {
                    let _ = std::fs::remove_dir(d);
                }
                Err(e)
            }
        }
    }
}

/// A second name for the file about to be replaced (a hard link, so nothing is copied), or
/// a copy where the file system has no links.
fn keep_old(dest: &Path, backup: &Path) -> io::Result<()> {
    match std::fs::hard_link(dest, backup) {
        Ok(()) => Ok(()),
        Err(_) => std::fs::copy(dest, backup).map(|_| ()),
    }
}

/// Creates `dir` and its missing parents, recording the ones it created (outermost first).
fn create_dirs(dir: &Path, created: &mut Vec<PathBuf>) -> io::Result<()> {
    let mut missing = Vec::new();
    let mut d = dir;
    while std::fs::symlink_metadata(d).is_err() {
        missing.push(d.to_path_buf());
        match d.parent() {
            Some(p) if !p.as_os_str().is_empty() => d = p,
            _ => break,
        }
    }
    for m in missing.into_iter().rev() {
        match std::fs::create_dir(&m) {
            Ok(()) => created.push(m),
            // Another build made it meanwhile: it is not ours to remove on a rollback.
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists && m.is_dir() => {}
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// Fails before anything is written when `path` cannot become a file: it is a directory, or
/// something on its way that exists is not a directory, or a name is too long.
fn validate_destination(path: &Path) -> io::Result<()> {
    for c in path.components() {
        if let Component::Normal(n) = c {
            if n.len() > NAME_MAX {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidInput,
                    format!("a name is longer than {NAME_MAX} bytes"),
                ));
            }
        }
    }
    if std::fs::metadata(path).is_ok_and(|m| m.is_dir()) {
        return Err(io::Error::new(io::ErrorKind::IsADirectory, "a directory is in the way"));
    }
    let mut a = path.parent();
    while let Some(d) = a {
        if d.as_os_str().is_empty() {
            break;
        }
        match std::fs::metadata(d) {
            Ok(m) if m.is_dir() => {
                if m.permissions().readonly() {
                    return Err(io::Error::new(
                        io::ErrorKind::PermissionDenied,
                        format!("`{}` is read-only", d.display()),
                    ));
                }
                break;
            }
            Ok(_) => {
                return Err(io::Error::new(
                    io::ErrorKind::NotADirectory,
                    format!("`{}` is a file, where a directory is needed", d.display()),
                ))
            }
            Err(_) => a = d.parent(),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths_normalise_or_are_refused() {
        assert_eq!(normal_relative("./a//b.png").unwrap(), PathBuf::from("a/b.png"));
        assert_eq!(normal_relative("a..b.png").unwrap(), PathBuf::from("a..b.png"));
        assert_eq!(normal_relative("a/../b.png"), Err(PathProblem::Parent));
        assert_eq!(normal_relative("/etc/x"), Err(PathProblem::Absolute));
        assert_eq!(normal_relative(""), Err(PathProblem::Empty));
        assert_eq!(normal_relative("./"), Err(PathProblem::Empty));
        assert!(matches!(normal_relative(".tessera-tmp-1-2"), Err(PathProblem::Reserved(_))));
        assert!(matches!(normal_relative(&"x".repeat(256)), Err(PathProblem::TooLong(_))));
        assert_eq!(normal_relative("a\0b"), Err(PathProblem::Nul));
    }

    #[cfg(unix)]
    #[test]
    fn a_link_out_of_the_root_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("out");
        let elsewhere = dir.path().join("elsewhere");
        std::fs::create_dir_all(&root).unwrap();
        std::fs::create_dir_all(&elsewhere).unwrap();
        std::os::unix::fs::symlink(&elsewhere, root.join("s")).unwrap();
        assert!(matches!(contained(&root, "s/x.png"), Err(PathProblem::Escapes(_))));
        std::os::unix::fs::symlink(root.join("inner"), root.join("t")).unwrap();
        std::fs::create_dir_all(root.join("inner")).unwrap();
        assert!(contained(&root, "t/x.png").is_ok());
        assert!(contained(&root, "new/dir/x.png").is_ok());
    }

    #[test]
    fn a_failed_set_changes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.png");
        std::fs::write(&a, b"old").unwrap();
        std::fs::write(dir.path().join("f"), b"a file").unwrap();
        let mut set = OutputSet::new();
        set.add(a.clone(), b"new".to_vec());
        set.add(dir.path().join("f/x.png"), b"x".to_vec());
        let e = set.commit().unwrap_err();
        assert!(e.path.ends_with("f/x.png"), "{e}");
        assert_eq!(std::fs::read(&a).unwrap(), b"old");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names.len(), 2, "{names:?}");
    }

    #[test]
    fn a_set_writes_only_what_changed() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.png");
        let b = dir.path().join("sub/b.png");
        std::fs::write(&a, b"same").unwrap();
        let mut set = OutputSet::new();
        set.add(a.clone(), b"same".to_vec());
        set.add(b.clone(), b"new".to_vec());
        let w = set.commit().unwrap();
        assert_eq!(w.iter().map(|w| w.changed).collect::<Vec<_>>(), [false, true]);
        assert_eq!(std::fs::read(&b).unwrap(), b"new");
        assert_eq!(std::fs::read_dir(dir.path().join("sub")).unwrap().count(), 1);
    }

    #[test]
    fn two_sets_creating_one_directory_both_succeed() {
        // Two builds of one scene at once both create `out/<scene>/`.
        for round in 0..20 {
            let dir = tempfile::tempdir().unwrap();
            let target = dir.path().join(format!("out/s{round}/sub"));
            std::thread::scope(|s| {
                for t in 0..2u8 {
                    let target = target.clone();
                    s.spawn(move || {
                        let mut set = OutputSet::new();
                        set.add(target.join("a.png"), vec![t]);
                        set.commit().unwrap();
                    });
                }
            });
            assert!(target.join("a.png").is_file());
        }
    }

    #[test]
    fn stale_temporaries_of_dead_processes_are_swept() {
        let dir = tempfile::tempdir().unwrap();
        // Pid 0 never names a user process; the current one is live.
        let dead = dir.path().join(".tessera-tmp-4194304999-3");
        let live = dir.path().join(format!(".tessera-tmp-{}-9", std::process::id()));
        let user = dir.path().join(".tessera-tmp-notes");
        for p in [&dead, &live, &user] {
            std::fs::write(p, b"x").unwrap();
        }
        assert_eq!(sweep_stale(dir.path()), 1);
        assert!(!dead.exists() && live.exists() && user.exists());
    }
}
