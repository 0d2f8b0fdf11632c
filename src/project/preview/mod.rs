//! The preview page: every output of a build, its golden, the difference and its numbers,
//! the stage timings and the diagnostics of a failed build, as one web page. `server`
//! serves it live in watch mode (pushed on every rebuild); `gallery` writes it as static
//! files. Both fill the page from the same [`PageState`], and differ only in how a file
//! becomes a link ([`Links`]).

mod gallery;
mod paths;
mod server;

use std::path::{Path, PathBuf};

use percent_encoding::{utf8_percent_encode, AsciiSet, CONTROLS};
use serde::Serialize;

pub use gallery::{write_gallery, GalleryLinks};
pub use paths::Allowed;
pub use server::Preview;

use super::{Built, CheckRow, CheckStatus, Failed, Project};
use crate::graph::Status;
use crate::kinds::OutputFormat;

/// The page, with an empty state slot a static gallery fills and a live page leaves empty.
const PAGE: &str = include_str!("page.html");

/// What the page shows.
#[derive(Clone, Debug, Default, Serialize)]
pub struct PageState {
    /// Counts builds shown (successful or failed); the page tags itself with it once every
    /// picture of that build has loaded.
    pub generation: u64,
    /// Served by `watch --serve` (rather than written as a gallery).
    pub live: bool,
    pub scenes: Vec<SceneView>,
}

#[derive(Clone, Debug, Serialize)]
pub struct SceneView {
    pub name: String,
    pub path: String,
    /// The diagnostics of the last build when it failed, drawn as on a terminal without
    /// colour; the outputs are then those of the last good build.
    pub diagnostics: Option<String>,
    pub millis: f64,
    pub outputs: Vec<OutputView>,
    pub stages: Vec<StageView>,
}

#[derive(Clone, Debug, Serialize)]
pub struct OutputView {
    pub name: String,
    pub format: &'static str,
    /// How the page shows it: `image`, `text` or `file` (a link).
    pub view: &'static str,
    /// The file as written.
    pub file: String,
    /// What a browser can draw of it (an EXR tone-mapped to a PNG), and of its golden and
    /// diff image.
    pub image: Option<String>,
    pub golden_image: Option<String>,
    pub diff_image: Option<String>,
    pub width: Option<u32>,
    pub height: Option<u32>,
    /// A text output's text (up to 256 KiB): a static page opened from disk
    /// may not fetch files beside it.
    pub text: Option<String>,
    pub compare: Option<CompareView>,
}

/// Largest text output held in the page's state.
const TEXT_INLINE: usize = 256 * 1024;

#[derive(Clone, Debug, Serialize)]
pub struct CompareView {
    pub status: CheckStatus,
    pub max_abs: f32,
    pub max_steps: Option<u64>,
    pub failing: usize,
    pub total: usize,
    pub tolerance: f64,
    /// Compared number by number (a text format) rather than pixel by pixel.
    pub text: bool,
    pub note: Option<String>,
}

#[derive(Clone, Debug, Serialize)]
pub struct StageView {
    pub label: String,
    /// `ran`, or `cached` (from memory or disk, or not needed).
    pub status: &'static str,
    pub millis: f64,
}

/// What a link on the page is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Use {
    /// The file itself.
    File,
    /// A picture a browser can draw (an EXR becomes a tone-mapped PNG).
    Picture,
}

/// How a file of the project becomes a link on the page: a URL of the server, or a copy
/// beside a static page. `None` when it cannot be offered.
pub trait Links {
    fn link(&mut self, path: &Path, how: Use) -> Option<String>;
}

impl Project {
    /// What the preview may serve after the last build: the output and golden directories,
    /// and the samples the build read (the files it read, scene sources aside).
    pub fn preview_files(&self) -> Allowed {
        let dirs = [self.root.join(&self.manifest.paths.outputs), self.root.join(&self.manifest.paths.golden)];
        let samples: Vec<PathBuf> =
            self.world.accessed().into_iter().filter(|f| f.extension().is_none_or(|e| e != "tess")).collect();
        Allowed::new(&self.root, &dirs, &samples)
    }

    /// The page's view of a successful build of `built`, its outputs checked in `rows`.
    pub fn scene_view(&self, built: &Built, rows: &[CheckRow], links: &mut dyn Links) -> SceneView {
        let dir = self.output_dir(&built.name);
        let golden = self.golden_dir(&built.name);
        let outputs = built
            .outputs
            .iter()
            .map(|(o, bytes)| {
                let (format, view) = shown_as(o.format);
                let path = dir.join(&o.name);
                let row = rows.iter().find(|r| r.scene == built.name && r.output == o.name);
                let golden_path = golden.join(&o.name);
                let has_golden = row.is_some_and(|r| r.status != CheckStatus::Missing);
                let dims = if view == "image" { dimensions(o.format, &bytes.0) } else { None };
                OutputView {
                    name: o.name.clone(),
                    format,
                    view,
                    file: links.link(&path, Use::File).unwrap_or_default(),
                    image: (view == "image").then(|| links.link(&path, Use::Picture)).flatten(),
                    golden_image: (view == "image" && has_golden)
                        .then(|| links.link(&golden_path, Use::Picture))
                        .flatten(),
                    diff_image: row
                        .and_then(|r| r.diff.as_ref())
                        .filter(|_| view == "image")
                        .and_then(|d| links.link(d, Use::Picture)),
                    width: dims.map(|d| d.0),
                    height: dims.map(|d| d.1),
                    text: (view == "text" && bytes.0.len() <= TEXT_INLINE)
                        .then(|| String::from_utf8(bytes.0.clone()).ok())
                        .flatten(),
                    compare: row.map(|r| CompareView {
                        status: r.status,
                        max_abs: r.max_abs,
                        max_steps: r.max_steps,
                        failing: r.failing_pixels,
                        total: r.total_pixels,
                        tolerance: r.tolerance,
                        text: o.format.is_text() || o.format == OutputFormat::Glb,
                        note: r.note.clone(),
                    }),
                }
            })
            .collect();
        SceneView {
            name: built.name.clone(),
            path: built.scene_path.display().to_string(),
            diagnostics: None,
            millis: built.millis,
            outputs,
            stages: built
                .report
                .stages
                .iter()
                .map(|s| StageView {
                    label: s.label.clone(),
                    status: match s.status {
                        Status::Ran | Status::Rebuilt => "ran",
                        Status::Fresh | Status::Hit | Status::Remote | Status::Memory => "cached",
                    },
                    millis: s.millis,
                })
                .collect(),
        }
    }
}

/// `previous` (the last good view of the scene, if any) with the diagnostics of a failed
/// build: the page keeps showing the last good outputs under them.
pub fn failed_view(scene: &Path, previous: Option<SceneView>, failed: &Failed) -> SceneView {
    let drawn = failed.diagnostics.draw(miette::GraphicalTheme::unicode_nocolor(), 100).join("\n");
    let mut view = previous.unwrap_or_else(|| SceneView {
        name: scene.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(),
        path: scene.display().to_string(),
        diagnostics: None,
        millis: 0.0,
        outputs: Vec::new(),
        stages: Vec::new(),
    });
    view.diagnostics = Some(if drawn.is_empty() { "the build failed".to_string() } else { drawn });
    view
}

/// The page with `state` in its state slot (a static gallery), or with the slot empty (a
/// live page, which asks the server).
pub fn page(state: Option<&PageState>) -> String {
    let json = state.map(|s| {
        // Inside a <script> element, `</` would end it early: JSON allows `<\/`.
        serde_json::to_string(s).expect("the page state serialises").replace("</", "<\\/")
    });
    PAGE.replace("__STATE__", json.as_deref().unwrap_or(""))
}

/// The format's name and how the page shows it.
fn shown_as(format: OutputFormat) -> (&'static str, &'static str) {
    match format {
        OutputFormat::Png8 | OutputFormat::Png16 => ("png", "image"),
        OutputFormat::Exr => ("exr", "image"),
        OutputFormat::Svg => ("svg", "image"),
        OutputFormat::Json => ("json", "text"),
        OutputFormat::Toml => ("toml", "text"),
        OutputFormat::Tess => ("tess", "text"),
        OutputFormat::Obj => ("obj", "text"),
        OutputFormat::Glb => ("glb", "file"),
        OutputFormat::Ptm(_) => ("ptm", "file"),
    }
}

/// Width and height of an image output, from its header.
fn dimensions(format: OutputFormat, bytes: &[u8]) -> Option<(u32, u32)> {
    match format {
        OutputFormat::Png8 | OutputFormat::Png16 => {
            let r = image::ImageReader::with_format(std::io::Cursor::new(bytes), image::ImageFormat::Png);
            r.into_dimensions().ok()
        }
        OutputFormat::Exr => crate::raster::io::decode(bytes).ok().map(|i| (i.width as u32, i.height as u32)),
        _ => None,
    }
}

/// The content type of a file served or linked, by its extension.
pub(crate) fn content_type(path: &Path) -> &'static str {
    match extension(path).as_deref() {
        Some("png") => "image/png",
        Some("svg") => "image/svg+xml",
        Some("json") => "application/json",
        Some("html") => "text/html; charset=utf-8",
        Some("toml" | "tess" | "obj" | "txt") => "text/plain; charset=utf-8",
        Some("exr") => "image/x-exr",
        Some("glb") => "model/gltf-binary",
        _ => "application/octet-stream",
    }
}

/// A picture of an image file a browser can draw: PNG and SVG as they are; anything else
/// the raster layer decodes (EXR), tone-mapped to an 8-bit PNG.
pub(crate) fn picture_bytes(path: &Path, bytes: Vec<u8>) -> Result<Vec<u8>, String> {
    if !converted(path) {
        return Ok(bytes);
    }
    let img = crate::raster::io::decode(&bytes).map_err(|e| e.to_string())?;
    crate::raster::io::encode_png(&crate::raster::color::tone_map_preview(&img), 8).map_err(|e| e.to_string())
}

/// Whether `path` names a picture that [`picture_bytes`] converts (its link gets a `.png`).
pub(crate) fn converted(path: &Path) -> bool {
    !matches!(extension(path).as_deref(), Some("png" | "svg"))
}

/// The lower-cased extension of `path`, if it has one.
fn extension(path: &Path) -> Option<String> {
    path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase())
}

/// `path` below the project root, if it is.
pub(crate) fn relative(root: &Path, path: &Path) -> Option<PathBuf> {
    path.strip_prefix(root).ok().map(Path::to_path_buf)
}

/// Characters escaped in a path segment of a link.
const SEGMENT: &AsciiSet = &CONTROLS.add(b' ').add(b'"').add(b'#').add(b'%').add(b'<').add(b'>').add(b'?').add(b'`');

/// A relative path as a link (segments escaped, joined by `/`), `suffix` added to its name.
pub(crate) fn link_path(rel: &Path, suffix: &str) -> String {
    let parts: Vec<String> = rel.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
    let joined = parts.join("/") + suffix;
    joined.split('/').map(|p| utf8_percent_encode(p, SEGMENT).to_string()).collect::<Vec<_>>().join("/")
}
