//! `tessera gallery`: the preview page written as static files, for a CI artefact or a
//! README. `out/.gallery/index.html` holds the page with its state inside; every file it
//! shows is copied below `out/.gallery/files/` (an EXR as its tone-mapped PNG), at its path
//! in the project, so the directory can be moved or uploaded as a whole.

use std::path::{Path, PathBuf};

use super::{converted, link_path, page, picture_bytes, relative, Links, PageState, SceneView, Use};
use crate::graph::files;
use crate::project::{plain_error, Failed, Project};

/// Where the gallery goes, below the outputs directory (which tessera owns).
const DIR: &str = ".gallery";

/// Writes the page of `scenes` (made with [`GalleryLinks`] from [`Project::gallery_links`]);
/// returns the page's path.
pub fn write_gallery(project: &Project, scenes: Vec<SceneView>) -> Result<PathBuf, Failed> {
    let index = gallery_path(project, "index.html")?;
    let state = PageState { generation: 1, live: false, scenes };
    files::write_atomic(&index, page(Some(&state)).as_bytes())
        .map_err(|e| plain_error(format!("cannot write `{}`: {e}", index.display())))?;
    Ok(index)
}

fn gallery_path(project: &Project, rel: &str) -> Result<PathBuf, Failed> {
    let root = project.root.join(&project.manifest.paths.outputs).join(DIR);
    files::contained(&root, rel).map_err(|p| plain_error(format!("cannot place `{rel}` in the gallery: {p}")))
}

impl Project {
    /// Links that copy each file into the gallery.
    pub fn gallery_links(&self) -> GalleryLinks<'_> {
        GalleryLinks { project: self, error: None }
    }
}

/// Copies every linked file into the gallery; the first failure is kept for [`finish`].
///
/// [`finish`]: GalleryLinks::finish
pub struct GalleryLinks<'a> {
    project: &'a Project,
    error: Option<Failed>,
}

impl GalleryLinks<'_> {
    /// The first copy that failed, if any.
    pub fn finish(self) -> Result<(), Failed> {
        self.error.map_or(Ok(()), Err)
    }

    fn copy(&self, path: &Path, how: Use) -> Result<String, Failed> {
        let rel = relative(&self.project.root, path)
            .ok_or_else(|| plain_error(format!("`{}` is outside the project", path.display())))?;
        let picture = how == Use::Picture && converted(path);
        let suffix = if picture { ".png" } else { "" };
        let inside = format!("files/{}{suffix}", rel.to_string_lossy().replace('\\', "/"));
        let dest = gallery_path(self.project, &inside)?;
        let bytes = std::fs::read(path).map_err(|e| plain_error(format!("cannot read `{}`: {e}", path.display())))?;
        let bytes = if picture {
            picture_bytes(path, bytes)
                .map_err(|e| plain_error(format!("cannot draw `{}` for the gallery: {e}", path.display())))?
        } else {
            bytes
        };
        files::write_atomic(&dest, &bytes)
            .map_err(|e| plain_error(format!("cannot write `{}`: {e}", dest.display())))?;
        Ok(format!("files/{}", link_path(&rel, suffix)))
    }
}

impl Links for GalleryLinks<'_> {
    fn link(&mut self, path: &Path, how: Use) -> Option<String> {
        match self.copy(path, how) {
            Ok(link) => Some(link),
            Err(e) => {
                self.error.get_or_insert(e);
                None
            }
        }
    }
}
