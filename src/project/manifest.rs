//! `tessera.toml`: where a scene repository keeps its scenes, outputs, goldens and cache.
//! Found by walking up from the working directory, as cargo finds `Cargo.toml`; every
//! field has a default, so a bare directory works too.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::Deserialize;

use crate::lang::source::{SourceMap, Span};
use crate::lang::{Diagnostic, Diagnostics};

pub const FILE_NAME: &str = "tessera.toml";

/// A manifest is a few lines; anything near this size is not one.
const MAX_MANIFEST_BYTES: u64 = 1 << 20;

#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct Manifest {
    pub paths: Paths,
    pub check: Check,
    pub limits: Limits,
    pub cache: CacheSection,
}

/// `[cache]`: a shared remote cache under the local one (Bazel's HTTP remote-cache protocol).
/// Credentials never go here: they come from `TESSERA_REMOTE_CACHE_TOKEN` (a bearer token)
/// or `TESSERA_REMOTE_CACHE_BASIC` (`user:password`).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct CacheSection {
    /// `http://host:port/prefix` or `https://…`.
    #[serde(deserialize_with = "remote_url")]
    pub remote: Option<String>,
    /// `"read-write"` (the default) or `"read-only"`: read from the remote, never upload.
    pub mode: RemoteMode,
    /// Seconds any request, or the wait for uploads after a build, may take (default 10).
    #[serde(deserialize_with = "timeout_seconds")]
    pub timeout: f64,
    /// The largest blob sent or fetched (`"256 MiB"` or a byte count; default 256 MiB).
    #[serde(deserialize_with = "blob_size")]
    pub max_blob: u64,
    /// Seconds a remote that faulted rests before a build asks it again (default 60; 0: the
    /// next build).
    #[serde(deserialize_with = "retry_seconds")]
    pub retry: f64,
}

#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum RemoteMode {
    #[default]
    ReadWrite,
    ReadOnly,
}

impl Default for CacheSection {
    fn default() -> Self {
        CacheSection { remote: None, mode: RemoteMode::ReadWrite, timeout: 10.0, max_blob: 256 << 20, retry: 60.0 }
    }
}

fn remote_url<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<String>, D::Error> {
    let s = String::deserialize(d)?;
    crate::graph::remote::parse_url(&s).map(Some).map_err(serde::de::Error::custom)
}

fn timeout_seconds<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    // Below a millisecond every request would time out before it was sent.
    seconds(d, "timeout", 0.001..=3600.0)
}

fn retry_seconds<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    seconds(d, "retry", 0.0..=86_400.0)
}

/// A number of seconds in `range` (NaN is in none).
fn seconds<'de, D: serde::Deserializer<'de>>(
    d: D,
    name: &str,
    range: std::ops::RangeInclusive<f64>,
) -> Result<f64, D::Error> {
    let t = f64::deserialize(d)?;
    if range.contains(&t) {
        Ok(t)
    } else {
        Err(serde::de::Error::custom(format!("{name} is a number of seconds in [{}, {}]", range.start(), range.end())))
    }
}

fn blob_size<'de, D: serde::Deserializer<'de>>(d: D) -> Result<u64, D::Error> {
    match memory_size(d)? {
        Some(b) => Ok(b),
        None => Err(serde::de::Error::custom("max_blob must be positive")),
    }
}

#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct Limits {
    /// The memory budget of a build (`"4 GiB"` or a byte count); default: from the machine
    /// (see `graph::budget`).
    #[serde(deserialize_with = "memory_size")]
    pub max_memory: Option<u64>,
}

fn memory_size<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<u64>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Size {
        Bytes(u64),
        Text(String),
    }
    match Size::deserialize(d)? {
        Size::Bytes(0) => Err(serde::de::Error::custom("a size must be positive")),
        Size::Bytes(b) => Ok(Some(b)),
        Size::Text(t) => crate::graph::budget::parse_bytes(&t).map(Some).map_err(serde::de::Error::custom),
    }
}

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct Paths {
    pub scenes: PathBuf,
    pub outputs: PathBuf,
    pub golden: PathBuf,
    pub cache: PathBuf,
}

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct Check {
    /// Default largest per-channel difference, in [0, 1] units.
    pub tolerance: f64,
    /// Default fraction of pixels allowed beyond the tolerance.
    pub outliers: f64,
}

impl Default for Paths {
    fn default() -> Self {
        Paths {
            scenes: "scenes".into(),
            outputs: "out".into(),
            golden: "golden".into(),
            cache: ".tessera/cache".into(),
        }
    }
}

impl Default for Check {
    fn default() -> Self {
        // Half a step of 8-bit quantisation either way: stable across platforms' float
        // rounding, yet one changed 8-bit level in a golden is caught.
        Check { tolerance: 1.0 / 255.0, outliers: 0.0 }
    }
}

/// Walks up from `start` to the nearest directory holding `tessera.toml`.
pub fn find_root(start: &Path) -> Option<PathBuf> {
    start.ancestors().find(|d| d.join(FILE_NAME).is_file()).map(Path::to_path_buf)
}

/// Reads the manifest in `root`, or the defaults when there is none.
pub fn load(root: &Path) -> Result<Manifest, Diagnostics> {
    let path = root.join(FILE_NAME);
    if !path.exists() {
        return Ok(Manifest::default());
    }
    let text = crate::graph::world::read_regular_text(&path, MAX_MANIFEST_BYTES).map_err(|e| {
        Diagnostics::new(
            vec![Diagnostic::error(format!("cannot read {}: {e}", path.display())).with_code("tessera::manifest")],
            SourceMap::default(),
        )
    })?;
    let manifest: Manifest = toml::from_str(&text).map_err(|e| {
        let mut sources = SourceMap::default();
        let id = sources.add(path.clone(), FILE_NAME.into(), Arc::from(text.as_str()));
        let range = e.span().unwrap_or(0..0);
        if e.message().contains("holds credentials") {
            // Showing the line would repeat the secret: name the line instead.
            let line = text[..range.start.min(text.len())].lines().count().max(1);
            let d = Diagnostic::error(format!("invalid {FILE_NAME} (line {line}, [cache] remote): {}", e.message()))
                .with_code("tessera::manifest");
            return Diagnostics::new(vec![d], SourceMap::default());
        }
        let d = Diagnostic::error(format!("invalid {FILE_NAME}: {}", e.message()))
            .with_code("tessera::manifest")
            .with_label(Span::new(id, range.start, range.end), "here")
            .with_help("sections are [paths] (scenes, outputs, golden, cache), [check] (tolerance, outliers), [limits] (max_memory) and [cache] (remote, mode, timeout, max_blob, retry)");
        Diagnostics::new(vec![d], sources)
    })?;
    check_paths(root, &path, &text)?;
    if !(0.0..=1.0).contains(&manifest.check.tolerance) || !(0.0..=1.0).contains(&manifest.check.outliers) {
        return Err(Diagnostics::new(
            vec![Diagnostic::error(format!("invalid {FILE_NAME}: [check] tolerance and outliers lie in [0, 1]"))
                .with_code("tessera::manifest")],
            SourceMap::default(),
        ));
    }
    Ok(manifest)
}

/// The `[paths]` values with their spans, for diagnostics.
#[derive(Deserialize, Default)]
struct SpannedManifest {
    #[serde(default)]
    paths: SpannedPaths,
}

#[derive(Deserialize, Default)]
struct SpannedPaths {
    scenes: Option<toml::Spanned<PathBuf>>,
    outputs: Option<toml::Spanned<PathBuf>>,
    golden: Option<toml::Spanned<PathBuf>>,
    cache: Option<toml::Spanned<PathBuf>>,
}

/// Refuses directory layouts in which a write or a `gc` could reach a user's files: the
/// directories tessera writes (outputs, goldens, cache) must each be a directory of their
/// own, not the project root or one of its parents, not one another's, and not holding the
/// scenes.
fn check_paths(root: &Path, file: &Path, text: &str) -> Result<(), Diagnostics> {
    let spanned: SpannedManifest = toml::from_str(text).unwrap_or_default();
    let defaults = Paths::default();
    let abs_root = crate::graph::files::resolve(root);
    let entry = |name: &'static str, value: &Option<toml::Spanned<PathBuf>>, default: &PathBuf| {
        let (path, span) = match value {
            Some(v) => (v.get_ref().clone(), Some(v.span())),
            None => (default.clone(), None),
        };
        (name, crate::graph::files::resolve(&abs_root.join(&path)), path, span)
    };
    let written = [
        entry("outputs", &spanned.paths.outputs, &defaults.outputs),
        entry("golden", &spanned.paths.golden, &defaults.golden),
        entry("cache", &spanned.paths.cache, &defaults.cache),
    ];
    let scenes = entry("scenes", &spanned.paths.scenes, &defaults.scenes);
    let own = |abs: &PathBuf, path: &PathBuf| {
        if path.as_os_str().is_empty() {
            Some("is empty".to_string())
        } else if abs_root.starts_with(abs) {
            Some(format!("`{}` is the project root or holds it", path.display()))
        } else if scenes.1.starts_with(abs) {
            Some(format!("`{}` holds the scenes directory", path.display()))
        } else {
            None
        }
    };
    let mut problems = Vec::new();
    for (i, (name, abs, path, span)) in written.iter().enumerate() {
        // Overlaps are reported between directories that are otherwise sound.
        let why = own(abs, path).or_else(|| {
            written
                .iter()
                .enumerate()
                .find(|(j, w)| *j != i && own(&w.1, &w.2).is_none() && (abs.starts_with(&w.1) || w.1.starts_with(abs)))
                .map(|(_, (other, _, other_path, _))| {
                    format!("`{}` overlaps `{other}` (`{}`)", path.display(), other_path.display())
                })
        });
        if let Some(why) = why {
            problems.push((
                format!("[paths] {name} {why}; tessera writes and deletes there, so it must be a directory of its own"),
                span.clone(),
            ));
        }
    }
    if problems.is_empty() {
        return Ok(());
    }
    let mut sources = SourceMap::default();
    let id = sources.add(file.to_path_buf(), FILE_NAME.into(), Arc::from(text));
    let items = problems
        .into_iter()
        .map(|(message, span)| {
            let d = Diagnostic::error(format!("invalid {FILE_NAME}: {message}"))
                .with_code("tessera::manifest_paths")
                .with_help("e.g. outputs = \"out\", golden = \"golden\", cache = \".tessera/cache\"");
            match span {
                Some(r) => d.with_label(Span::new(id, r.start, r.end), "here"),
                None => d,
            }
        })
        .collect();
    Err(Diagnostics::new(items, sources))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_and_partial_files() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(load(dir.path()).unwrap(), Manifest::default());
        std::fs::write(dir.path().join(FILE_NAME), "[check]\ntolerance = 0.01\n").unwrap();
        let m = load(dir.path()).unwrap();
        assert_eq!(m.check.tolerance, 0.01);
        assert_eq!(m.paths, Paths::default());
        let sub = dir.path().join("a/b");
        std::fs::create_dir_all(&sub).unwrap();
        assert_eq!(find_root(&sub).as_deref(), Some(dir.path()));
    }

    #[test]
    fn written_directories_may_not_hold_the_project() {
        let dir = tempfile::tempdir().unwrap();
        for (text, bad) in [
            ("[paths]\ncache = \"\"\n", "cache"),
            ("[paths]\ncache = \".\"\n", "cache"),
            ("[paths]\ncache = \"..\"\n", "cache"),
            ("[paths]\noutputs = \"./\"\n", "outputs"),
            ("[paths]\ngolden = \"out\"\n", "golden"),
            ("[paths]\ncache = \"out/cache\"\n", "outputs"),
            ("[paths]\noutputs = \"data\"\nscenes = \"data/scenes\"\n", "outputs"),
        ] {
            std::fs::write(dir.path().join(FILE_NAME), text).unwrap();
            let e = load(dir.path()).unwrap_err();
            assert!(e.items.iter().any(|d| d.message.contains(&format!("[paths] {bad}"))), "{text}: {:?}", e.items);
        }
        std::fs::write(dir.path().join(FILE_NAME), "[paths]\ncache = \"../shared-cache\"\n").unwrap();
        assert!(load(dir.path()).is_ok());
    }

    #[test]
    fn unknown_fields_are_errors_with_a_span() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join(FILE_NAME), "[paths]\nscenez = \"x\"\n").unwrap();
        let e = load(dir.path()).unwrap_err();
        assert!(e.items[0].message.contains("scenez"), "{}", e.items[0].message);
        assert!(!e.items[0].labels.is_empty());
    }

    #[test]
    fn memory_limits() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join(FILE_NAME), "[limits]\nmax_memory = \"2 GiB\"\n").unwrap();
        assert_eq!(load(dir.path()).unwrap().limits.max_memory, Some(2 << 30));
        std::fs::write(dir.path().join(FILE_NAME), "[limits]\nmax_memory = 1000\n").unwrap();
        assert_eq!(load(dir.path()).unwrap().limits.max_memory, Some(1000));
        std::fs::write(dir.path().join(FILE_NAME), "[limits]\nmax_memory = \"lots\"\n").unwrap();
        let e = load(dir.path()).unwrap_err();
        assert!(e.items[0].message.contains("not a size"), "{}", e.items[0].message);
        assert!(!e.items[0].labels.is_empty());
    }
}
