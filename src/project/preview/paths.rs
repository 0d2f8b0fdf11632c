//! Which files the preview server may send: those inside the project's output and golden
//! directories, and the files the last build read (its samples), nothing else. A request
//! names a path relative to the project root; it is decoded, refused if any part of it is
//! not a plain name (`..`, `.`, empty, a drive or root, a backslash, a NUL), then resolved as
//! the system would (links followed) and refused unless it lands inside an allowed place.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use percent_encoding::percent_decode_str;

use crate::graph::files;

/// The places a request may reach, resolved once (links followed) so a comparison is
/// between real paths.
#[derive(Clone, Debug, Default)]
pub struct Allowed {
    root: PathBuf,
    dirs: Vec<PathBuf>,
    files: HashSet<PathBuf>,
}

impl Allowed {
    /// `dirs` and `files` below `root`; anything outside the root is dropped.
    pub fn new(root: &Path, dirs: &[PathBuf], read: &[PathBuf]) -> Allowed {
        let root = files::resolve(root);
        let inside = |p: &PathBuf| p.starts_with(&root);
        Allowed {
            dirs: dirs.iter().map(|d| files::resolve(d)).filter(inside).collect(),
            files: read.iter().map(|f| files::resolve(f)).filter(|f| inside(f) && f.is_file()).collect(),
            root,
        }
    }

    /// The file a request for `rel` (percent-encoded, relative to the root) may read, or
    /// `None`.
    pub fn file(&self, rel: &str) -> Option<PathBuf> {
        let decoded = percent_decode_str(rel).decode_utf8().ok()?;
        if decoded.contains(['\\', '\0']) || decoded.is_empty() {
            return None;
        }
        let mut path = self.root.clone();
        for part in decoded.split('/') {
            // One plain name per part: `Path::components` would quietly drop a `.` or an
            // empty part, and a part with a `:` could be a drive on some systems.
            if part.is_empty() || part == "." || part == ".." || part.contains(':') {
                return None;
            }
            path.push(part);
        }
        let real = files::resolve(&path);
        let allowed = self.dirs.iter().any(|d| real.starts_with(d)) || self.files.contains(&real);
        (allowed && real.is_file()).then_some(real)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn project() -> (tempfile::TempDir, Allowed) {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path();
        for d in ["out/wall", "golden/wall", "samples", "secret"] {
            std::fs::create_dir_all(root.join(d)).unwrap();
        }
        for f in ["out/wall/a.png", "golden/wall/a.png", "samples/read.png", "samples/unread.png", "secret/key"] {
            std::fs::write(root.join(f), b"x").unwrap();
        }
        let allowed = Allowed::new(root, &[root.join("out"), root.join("golden")], &[root.join("samples/read.png")]);
        (dir, allowed)
    }

    #[test]
    fn outputs_goldens_and_read_samples_are_served() {
        let (_d, a) = project();
        assert!(a.file("out/wall/a.png").is_some());
        assert!(a.file("golden/wall/a.png").is_some());
        assert!(a.file("samples/read.png").is_some());
        assert!(a.file("out%2Fwall%2Fa.png").is_some(), "an encoded slash is a slash");
    }

    #[test]
    fn everything_else_is_refused() {
        let (_d, a) = project();
        for bad in [
            "samples/unread.png",
            "secret/key",
            "out/../secret/key",
            "out/%2e%2e/secret/key",
            "out/%2E%2E/secret/key",
            "out/wall/..%2f..%2fsecret/key",
            "out/./wall/a.png",
            "out//wall/a.png",
            "/etc/passwd",
            "%2fetc%2fpasswd",
            "out\\..\\secret\\key",
            "out/wall/a.png%00",
            "C:/Windows",
            "",
            "out",
            "out/wall",
            "%ff%fe",
        ] {
            assert!(a.file(bad).is_none(), "{bad:?} was served");
        }
    }

    #[cfg(unix)]
    #[test]
    fn a_link_out_of_an_allowed_directory_is_refused() {
        let (d, a) = project();
        std::os::unix::fs::symlink(d.path().join("secret"), d.path().join("out/escape")).unwrap();
        std::os::unix::fs::symlink(d.path().join("secret/key"), d.path().join("out/wall/key")).unwrap();
        assert!(a.file("out/escape/key").is_none());
        assert!(a.file("out/wall/key").is_none());
        // A link that stays inside is followed.
        std::os::unix::fs::symlink(d.path().join("out/wall/a.png"), d.path().join("out/wall/b.png")).unwrap();
        assert!(a.file("out/wall/b.png").is_some());
    }
}
