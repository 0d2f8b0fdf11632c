//! `tessera.toml`: where a scene repository keeps its scenes, outputs, goldens and cache.
//! Found by walking up from the working directory, as cargo finds `Cargo.toml`; every
//! field has a default, so a bare directory works too.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::Deserialize;

use crate::lang::source::{SourceMap, Span};
use crate::lang::{Diagnostic, Diagnostics};

pub const FILE_NAME: &str = "tessera.toml";

#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct Manifest {
    pub paths: Paths,
    pub check: Check,
    pub limits: Limits,
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
        Size::Bytes(0) => Err(serde::de::Error::custom("max_memory must be positive")),
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
    let Ok(text) = std::fs::read_to_string(&path) else { return Ok(Manifest::default()) };
    let manifest: Manifest = toml::from_str(&text).map_err(|e| {
        let mut sources = SourceMap::default();
        let id = sources.add(path.clone(), FILE_NAME.into(), Arc::from(text.as_str()));
        let range = e.span().unwrap_or(0..0);
        let d = Diagnostic::error(format!("invalid {FILE_NAME}: {}", e.message()))
            .with_code("tessera::manifest")
            .with_label(Span::new(id, range.start, range.end), "here")
            .with_help("sections are [paths] (scenes, outputs, golden, cache), [check] (tolerance, outliers) and [limits] (max_memory)");
        Diagnostics::new(vec![d], sources)
    })?;
    if !(0.0..=1.0).contains(&manifest.check.tolerance) || !(0.0..=1.0).contains(&manifest.check.outliers) {
        return Err(Diagnostics::new(
            vec![Diagnostic::error(format!("invalid {FILE_NAME}: [check] tolerance and outliers lie in [0, 1]"))
                .with_code("tessera::manifest")],
            SourceMap::default(),
        ));
    }
    Ok(manifest)
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
