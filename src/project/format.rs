//! `tessera fmt` on disk. A scene is rewritten where its bytes live: through a symbolic
//! link to the link's target (replacing the link by a regular file would fork the scene
//! from the file it names), with the file's permissions kept; a read-only file is refused,
//! since the rename that makes the rewrite atomic would otherwise replace it regardless.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

static TMP_COUNTER: AtomicUsize = AtomicUsize::new(0);

/// Replaces the contents of the scene file `path` (or of the file it links to) by `text`.
pub fn rewrite_scene(path: &Path, text: &str) -> Result<(), String> {
    let target: PathBuf =
        std::fs::canonicalize(path).map_err(|e| format!("cannot resolve `{}`: {e}", path.display()))?;
    let meta = std::fs::metadata(&target).map_err(|e| format!("cannot read `{}`: {e}", path.display()))?;
    if !meta.is_file() {
        return Err(format!("`{}` is not a regular file", path.display()));
    }
    if meta.permissions().readonly() {
        let shown = if target.as_path() == path { String::new() } else { format!(" (`{}`)", target.display()) };
        return Err(format!(
            "`{}`{shown} is read-only: not rewriting it (make it writable, or use `tessera fmt --check`)",
            path.display()
        ));
    }
    let dir = target.parent().unwrap_or(Path::new("."));
    let name = crate::graph::files::name_of(&target);
    let tmp = dir.join(format!(".{name}.{}.{}.tmp", std::process::id(), TMP_COUNTER.fetch_add(1, Ordering::Relaxed)));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(text.as_bytes())?;
        f.set_permissions(meta.permissions())?;
        f.sync_all()?;
        drop(f);
        std::fs::rename(&tmp, &target)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(|e| format!("cannot write `{}`: {e}", path.display()))
}
