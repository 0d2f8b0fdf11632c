//! `tessera check`: compare a build's outputs with the goldens, write diff images.

use std::path::PathBuf;

use serde::Serialize;

use super::{Built, Failed, Project};
use crate::golden::{self, Tolerance};
use crate::graph;
use crate::raster;

/// Default tolerance on numbers in text outputs (JSON, SVG), which are written rounded to 1e-6.
const TEXT_TOLERANCE: f64 = 2e-6;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CheckStatus {
    Pass,
    Fail,
    Missing,
}

#[derive(Clone, Debug, Serialize)]
pub struct CheckRow {
    pub scene: String,
    pub output: String,
    pub status: CheckStatus,
    pub max_abs: f32,
    pub failing_pixels: usize,
    pub total_pixels: usize,
    pub tolerance: f64,
    pub diff: Option<PathBuf>,
    pub note: Option<String>,
}

impl Project {
    pub fn check(&self, built: &Built) -> Result<Vec<CheckRow>, Failed> {
        let mut rows = Vec::new();
        for (o, bytes) in &built.outputs {
            let golden_path = self.golden_dir(&built.name).join(&o.name);
            let tol = Tolerance {
                max_abs: o.tolerance.unwrap_or(self.manifest.check.tolerance) as f32,
                max_fraction: if o.outliers > 0.0 { o.outliers } else { self.manifest.check.outliers } as f32,
            };
            let mut row = CheckRow {
                scene: built.name.clone(),
                output: o.name.clone(),
                status: CheckStatus::Missing,
                max_abs: 0.0,
                failing_pixels: 0,
                total_pixels: 0,
                tolerance: tol.max_abs as f64,
                diff: None,
                note: None,
            };
            let Ok(golden_bytes) = std::fs::read(&golden_path) else {
                row.note = Some(format!("no golden at {}; run `tessera bless`", golden_path.display()));
                rows.push(row);
                continue;
            };
            if o.format.is_text() {
                // Numbers in meshes and reports: rounded to 1e-6 when written.
                let tol = o.tolerance.unwrap_or(TEXT_TOLERANCE);
                let (actual, expected) = (String::from_utf8_lossy(&bytes.0), String::from_utf8_lossy(&golden_bytes));
                let cmp = golden::compare_text(&actual, &expected, tol);
                row.tolerance = tol;
                row.max_abs = cmp.max_abs as f32;
                row.failing_pixels = cmp.failing_numbers;
                row.total_pixels = cmp.numbers;
                row.note = cmp.mismatch;
                if !cmp.pass {
                    // A failed mesh also gets the geometry of the difference.
                    if let Some(m) = golden::mesh_difference(&actual, &expected) {
                        row.note = Some(match row.note.take() {
                            Some(n) => format!("{n}\n       {m}"),
                            None => m,
                        });
                    }
                }
                row.status = if cmp.pass { CheckStatus::Pass } else { CheckStatus::Fail };
                rows.push(row);
                continue;
            }
            let actual = raster::io::decode(&bytes.0);
            let expected = raster::io::decode(&golden_bytes);
            let (actual, expected) = match (actual, expected) {
                (Ok(a), Ok(e)) => (a, e),
                (Err(e), _) => {
                    row.status = CheckStatus::Fail;
                    row.note = Some(format!("output does not decode: {e}"));
                    rows.push(row);
                    continue;
                }
                (_, Err(e)) => {
                    row.status = CheckStatus::Fail;
                    row.note = Some(format!("golden does not decode: {e}"));
                    rows.push(row);
                    continue;
                }
            };
            let cmp = golden::compare(&actual, &expected, &tol);
            row.max_abs = cmp.max_abs;
            row.failing_pixels = cmp.failing_pixels;
            row.total_pixels = cmp.total_pixels;
            row.note = cmp.mismatch.clone();
            row.status = if cmp.pass { CheckStatus::Pass } else { CheckStatus::Fail };
            if !cmp.pass {
                let diff = golden::diff_image(&actual, &expected, &tol);
                let stem = std::path::Path::new(&o.name).with_extension("");
                let path = self.output_dir(&built.name).join(format!("{}.diff.png", stem.display()));
                let png = raster::io::encode_png(&diff, 8)
                    .map_err(|e| super::plain_error(format!("cannot encode a diff image: {e}")))?;
                graph::write_atomic(&path, &png)
                    .map_err(|e| super::plain_error(format!("cannot write `{}`: {e}", path.display())))?;
                row.diff = Some(path);
            }
            rows.push(row);
        }
        Ok(rows)
    }
}
