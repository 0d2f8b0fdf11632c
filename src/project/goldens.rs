//! The golden files of a scene beyond `check`: blessing some outputs only, finding goldens
//! whose output the scene no longer declares or whose scene is gone, and removing those
//! (`bless --prune`).

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use super::{plain_error, Built, Failed, Project};
use crate::graph::files;
use crate::lang::diag::suggest;

/// Extensions of the files an output can be (PNG, EXR, JSON, SVG, PTM): nothing else below a
/// golden directory is ever taken for a golden.
const GOLDEN_EXTENSIONS: [&str; 7] = ["png", "exr", "json", "svg", "ptm", "obj", "glb"];

impl Project {
    /// Writes the current outputs named by `names` (every output when `None`) as goldens, as
    /// one set. A name the scene does not declare is an error naming it, and nothing is written.
    pub fn bless_outputs(&self, built: &Built, names: Option<&[String]>) -> Result<Vec<PathBuf>, Failed> {
        let Some(names) = names else { return self.bless(built) };
        let chosen = chosen_outputs(built, names)?;
        let root = self.golden_root();
        let keep = |o: &crate::kinds::PlannedOutput| chosen.contains(&o.name);
        Ok(self.commit_some(built, &root, "goldens", &keep)?.into_iter().map(|e| e.path).collect())
    }

    /// Goldens of `built`'s scene that no output of it declares any more: regular files
    /// (never links) below its golden directory, reached without following a link, named as
    /// an output can be (`.png`, `.exr`, `.json`, `.svg`, no leading `.`), outside the golden
    /// directory of any other scene in `scenes` (`golden/sub/s/` belongs to `sub/s`, not `sub`).
    pub fn stale_goldens(&self, built: &Built, scenes: &[String]) -> Vec<PathBuf> {
        let dir = self.golden_dir(&built.name);
        let is_dir = std::fs::symlink_metadata(&dir).is_ok_and(|m| m.is_dir());
        if !is_dir {
            return Vec::new();
        }
        let declared: HashSet<PathBuf> = built.outputs.iter().map(|(o, _)| PathBuf::from(&o.name)).collect();
        let mut found = Vec::new();
        walk_goldens(&dir, Path::new(""), &built.name, scenes, &mut found);
        found.sort();
        found
            .into_iter()
            .filter(|rel| !declared.contains(rel))
            .filter_map(|rel| files::contained(&self.golden_root(), &format!("{}/{}", built.name, rel.display())).ok())
            .collect()
    }

    /// Removes `stale` goldens (as [`Project::stale_goldens`] found them), each proven again to
    /// be a regular file inside the golden directory, then the directories that held only
    /// them and the diff images a failed check left for them. Returns the files removed.
    pub fn prune_goldens(&self, built: &Built, stale: &[PathBuf]) -> Result<Vec<PathBuf>, Failed> {
        let scene_dir = self.golden_dir(&built.name);
        let mut removed = Vec::new();
        for path in stale {
            if let Some(rel) = self.remove_golden(path, &scene_dir, "stale")? {
                self.remove_diff(&built.name, rel);
                removed.push(path.clone());
            }
        }
        Ok(removed)
    }

    /// Golden directories of scenes that no longer exist, each with the golden files below
    /// it: directories of the golden root that are no scene's (`scenes` holds every scene's
    /// name) nor on the way to one (`golden/sub/` leads to the scene `sub/s`). Files directly
    /// in the golden root are nobody's golden and never listed; links are never followed.
    pub fn orphan_goldens(&self, scenes: &[String]) -> Vec<(PathBuf, Vec<PathBuf>)> {
        let root = self.golden_root();
        let mut found = Vec::new();
        orphans_below(&root, Path::new(""), scenes, &mut found);
        found.sort();
        found
            .into_iter()
            .filter_map(|(dir, rels)| {
                let dir = files::contained(&root, &dir.to_string_lossy()).ok()?;
                let rels = rels.iter().filter_map(|r| files::contained(&root, &r.to_string_lossy()).ok()).collect();
                Some((dir, rels))
            })
            .collect()
    }

    /// Removes the golden files of [`Project::orphan_goldens`], each proven again to be a
    /// regular file inside the golden root, then the directories they leave empty. Returns
    /// the files removed.
    pub fn prune_orphans(&self, orphans: &[(PathBuf, Vec<PathBuf>)]) -> Result<Vec<PathBuf>, Failed> {
        let root = self.golden_root();
        let mut removed = Vec::new();
        for path in orphans.iter().flat_map(|(_, paths)| paths) {
            if self.remove_golden(path, &root, "orphan")?.is_some() {
                removed.push(path.clone());
            }
        }
        Ok(removed)
    }

    /// Removes `path` once it is proven again to be a regular file (never a link) inside the
    /// golden root, then the directories it leaves empty below `top`. Returns its path below
    /// the root when it was removed; `what` names it in the error.
    fn remove_golden<'p>(&self, path: &'p Path, top: &Path, what: &str) -> Result<Option<&'p Path>, Failed> {
        let root = self.golden_root();
        let Ok(rel) = path.strip_prefix(&root) else { return Ok(None) };
        let proven = files::contained(&root, &rel.to_string_lossy()).is_ok()
            && std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_file());
        if !proven {
            return Ok(None);
        }
        std::fs::remove_file(path)
            .map_err(|e| plain_error(format!("cannot remove the {what} golden `{}`: {e}", path.display())))?;
        remove_empty_parents(path, top);
        Ok(Some(rel))
    }

    /// Removes the diff image of a pruned golden (`rel` below the golden root, so it starts
    /// with the scene's name), if a failed check left one.
    fn remove_diff(&self, scene: &str, rel: &Path) {
        let Ok(output) = rel.strip_prefix(scene) else { return };
        if let Ok(diff) = self.diff_path(scene, &output.to_string_lossy()) {
            if std::fs::symlink_metadata(&diff).is_ok_and(|m| m.file_type().is_file()) {
                let _ = std::fs::remove_file(&diff);
            }
        }
    }
}

/// The names of `built`'s outputs that `names` selects, each normalised; an unknown name is
/// an error naming the scene and the name, with the closest output name as a suggestion.
fn chosen_outputs(built: &Built, names: &[String]) -> Result<HashSet<String>, Failed> {
    let declared: Vec<&str> = built.outputs.iter().map(|(o, _)| o.name.as_str()).collect();
    let mut chosen = HashSet::new();
    for name in names {
        let normal = files::normal_relative(name).map(|p| p.to_string_lossy().into_owned()).unwrap_or_default();
        if !declared.contains(&normal.as_str()) {
            let hint = match suggest(name, declared.iter().copied()) {
                Some(s) => format!("; did you mean `{s}`?"),
                None => format!(
                    "; its outputs are {}",
                    declared.iter().map(|d| format!("`{d}`")).collect::<Vec<_>>().join(", ")
                ),
            };
            return Err(plain_error(format!(
                "the scene `{}` has no output `{name}`{hint}",
                built.scene_path.display()
            )));
        }
        chosen.insert(normal);
    }
    Ok(chosen)
}

fn walk_goldens(dir: &Path, rel: &Path, scene: &str, scenes: &[String], out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir.join(rel)) else { return };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(name) = name.to_str() else { continue };
        let rel = rel.join(name);
        // `file_type` does not follow links: a link is neither a directory nor a file here.
        let Ok(kind) = entry.file_type() else { continue };
        if kind.is_dir() {
            let nested = format!("{scene}/{}", rel.display());
            if !name.starts_with('.') && !scenes.contains(&nested) {
                walk_goldens(dir, &rel, scene, scenes, out);
            }
        } else if kind.is_file() && is_golden_name(name) && files::normal_relative(&rel.to_string_lossy()).is_ok() {
            out.push(rel);
        }
    }
}

/// Below `root/rel`: each directory that is no scene's and leads to none, with the golden
/// files under it (relative to `root`); directories that lead to a scene are searched on.
fn orphans_below(root: &Path, rel: &Path, scenes: &[String], out: &mut Vec<(PathBuf, Vec<PathBuf>)>) {
    let Ok(entries) = std::fs::read_dir(root.join(rel)) else { return };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(name) = name.to_str() else { continue };
        if name.starts_with('.') || !entry.file_type().is_ok_and(|k| k.is_dir()) {
            continue;
        }
        let dir = rel.join(name);
        let scene = dir.to_string_lossy().replace('\\', "/");
        if scenes.contains(&scene) {
            continue;
        }
        if scenes.iter().any(|s| s.starts_with(&format!("{scene}/"))) {
            orphans_below(root, &dir, scenes, out);
            continue;
        }
        let mut found = Vec::new();
        walk_goldens(root, &dir, &scene, &[], &mut found);
        if !found.is_empty() {
            found.sort();
            out.push((dir, found));
        }
    }
}

fn is_golden_name(name: &str) -> bool {
    let ext = Path::new(name).extension().and_then(|e| e.to_str()).unwrap_or("");
    !name.starts_with('.') && GOLDEN_EXTENSIONS.iter().any(|g| ext.eq_ignore_ascii_case(g))
}

/// Removes the now empty directories between `path` and `top` (exclusive).
fn remove_empty_parents(path: &Path, top: &Path) {
    let mut dir = path.parent();
    while let Some(d) = dir {
        if d == top || !d.starts_with(top) || std::fs::remove_dir(d).is_err() {
            break;
        }
        dir = d.parent();
    }
}
