//! `tessera check`: compare a build's outputs with the goldens, write diff images.

use std::path::PathBuf;

use serde::Serialize;

use super::{Built, Failed, Project};
use crate::golden::{self, Tolerance};
use crate::graph;
use crate::kinds::OutputFormat;
use crate::lang::diag::{Diagnostic, Diagnostics};
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
    /// The tolerance as a fraction of the full range (0 when compared exactly).
    pub tolerance: f64,
    /// Bits per channel of an integer-coded image output; differences are then in steps.
    pub bits: Option<u32>,
    pub max_steps: Option<u64>,
    pub tolerance_steps: Option<u64>,
    /// Compared exactly (identities).
    pub exact: bool,
    pub diff: Option<PathBuf>,
    pub note: Option<String>,
}

impl Project {
    pub fn check(&self, built: &Built) -> Result<Vec<CheckRow>, Failed> {
        let mut rows = Vec::new();
        for (o, bytes) in &built.outputs {
            let golden_path = self.golden_dir(&built.name).join(&o.name);
            let diff_path = self.diff_path(&built.name, &o.name)?;
            let fraction = o.tolerance.unwrap_or(self.manifest.check.tolerance);
            // Integer-coded files compare in their own steps, the tolerance rounded down to
            // whole steps (1/255 is 1 step of an 8-bit PNG, 257 of a 16-bit one); identities
            // compare exactly.
            let bits = match o.format {
                OutputFormat::Png8 => Some(8u32),
                OutputFormat::Png16 => Some(16),
                _ => None,
            };
            let steps = bits.map(|b| if o.exact { 0 } else { steps_within(fraction, b) });
            let tol = match (steps, bits) {
                (Some(n), Some(b)) => Tolerance {
                    // Half a step of slack, so float noise in decoding never decides.
                    max_abs: ((n as f64 + 0.5) / ((1u64 << b) - 1) as f64) as f32,
                    max_fraction: if o.exact { 0.0 } else { outliers(o.outliers, self.manifest.check.outliers) },
                },
                _ if o.exact => Tolerance::EXACT,
                _ => Tolerance {
                    max_abs: fraction as f32,
                    max_fraction: outliers(o.outliers, self.manifest.check.outliers),
                },
            };
            let mut row = CheckRow {
                scene: built.name.clone(),
                output: o.name.clone(),
                status: CheckStatus::Missing,
                max_abs: 0.0,
                failing_pixels: 0,
                total_pixels: 0,
                tolerance: if o.exact { 0.0 } else { fraction },
                bits,
                max_steps: None,
                tolerance_steps: steps,
                exact: o.exact,
                diff: None,
                note: None,
            };
            let Ok(golden_bytes) = std::fs::read(&golden_path) else {
                row.note = Some(format!("no golden at {}; run `tessera bless`", golden_path.display()));
                rows.push(row);
                continue;
            };
            if o.format.is_text() || o.format == OutputFormat::Glb {
                // Numbers in meshes and reports: rounded to 1e-6 when written. A glTF binary is
                // compared as the numbers it holds (its JSON, accessors and texture codes).
                let tol = o.tolerance.unwrap_or(TEXT_TOLERANCE);
                let text = |b: &[u8]| match o.format {
                    OutputFormat::Glb => glb_text(b).unwrap_or_else(|e| format!("undecodable glb: {e}")),
                    _ => String::from_utf8_lossy(b).into_owned(),
                };
                let (actual, expected) = (text(&bytes.0), text(&golden_bytes));
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
            let decode = |b: &[u8]| match o.format {
                OutputFormat::Ptm(_) => ptm_planes(b),
                _ => raster::io::decode(b).map_err(|e| e.to_string()),
            };
            let (actual, expected) = (decode(&bytes.0), decode(&golden_bytes));
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
            row.max_steps = bits.map(|b| (cmp.max_abs as f64 * ((1u64 << b) - 1) as f64).round() as u64);
            row.failing_pixels = cmp.failing_pixels;
            row.total_pixels = cmp.total_pixels;
            row.note = cmp.mismatch.clone();
            row.status = if cmp.pass { CheckStatus::Pass } else { CheckStatus::Fail };
            if cmp.pass {
                // The diff of an earlier failure no longer says anything.
                let _ = std::fs::remove_file(&diff_path);
            } else {
                let diff = diff_picture(&actual, &expected, &tol, o.exact);
                let png = raster::io::encode_png(&diff, 8)
                    .map_err(|e| super::plain_error(format!("cannot encode a diff image: {e}")))?;
                graph::write_atomic(&diff_path, &png)
                    .map_err(|e| super::plain_error(format!("cannot write `{}`: {e}", diff_path.display())))?;
                row.diff = Some(diff_path);
            }
            rows.push(row);
        }
        Ok(rows)
    }
}

/// The rows of `built` that did not pass, as diagnostics at the names of the outputs they
/// check, so an editor (or a reader of the log) lands on the declaration that changed; `None`
/// when every output passed.
pub fn check_diagnostics(built: &Built, rows: &[CheckRow]) -> Option<Diagnostics> {
    let items: Vec<Diagnostic> = rows
        .iter()
        .filter(|r| r.scene == built.name && r.status != CheckStatus::Pass)
        .filter_map(|r| {
            let (o, _) = built.outputs.iter().find(|(o, _)| o.name == r.output)?;
            let d = match r.status {
                CheckStatus::Missing => Diagnostic::error(format!("output `{}` has no golden", r.output))
                    .with_code("tessera::check::missing")
                    .with_label(o.span, "this output")
                    .with_help(format!("`tessera bless {}` makes its output the golden", built.scene_path.display())),
                _ => {
                    let mut help = Vec::new();
                    help.extend(r.note.clone());
                    help.extend(r.diff.as_ref().map(|d| format!("diff image: {}", d.display())));
                    let d = Diagnostic::error(format!("output `{}` differs from its golden", r.output))
                        .with_code("tessera::check::differs")
                        .with_label(o.span, differs_by(r));
                    if help.is_empty() {
                        d
                    } else {
                        d.with_help(help.join("\n"))
                    }
                }
            };
            Some(d)
        })
        .collect();
    (!items.is_empty()).then(|| Diagnostics::new(items, built.scene.sources.clone()))
}

/// How far a failing output is off, in the terms of its comparison.
fn differs_by(r: &CheckRow) -> String {
    if r.total_pixels == 0 {
        return "does not compare with its golden".into();
    }
    let beyond = format!("{} of {} beyond the tolerance", r.failing_pixels, r.total_pixels);
    if r.exact {
        return format!("{} of {} differ; compared exactly", r.failing_pixels, r.total_pixels);
    }
    match (r.bits, r.max_steps, r.tolerance_steps) {
        (Some(bits), Some(steps), Some(tol)) => {
            format!("off by up to {steps} {bits}-bit steps, tolerance {tol}; {beyond}")
        }
        _ => format!("off by up to {:.3e}, tolerance {:.3e}; {beyond}", r.max_abs, r.tolerance),
    }
}

/// The diff image of a failing image output: identities (labels, index maps) show their
/// moved region boundaries and line art (nearly black and white: edges, seams) its removed
/// and added lines, in two colours over the faded golden; anything else shows how far each
/// pixel is off.
fn diff_picture(actual: &raster::Image, expected: &raster::Image, tol: &Tolerance, exact: bool) -> raster::Image {
    if exact {
        golden::two_colour_diff(actual, expected, golden::Marks::Boundaries)
    } else if golden::is_line_art(expected) && golden::is_line_art(actual) {
        golden::two_colour_diff(actual, expected, golden::Marks::Lines)
    } else {
        golden::diff_image(actual, expected, tol)
    }
}

/// A PTM file as an image of its planes (coefficients, then colour, in intensity units), so
/// that it compares like any float image.
fn ptm_planes(bytes: &[u8]) -> Result<raster::Image, String> {
    let ptm = crate::synth::relight::ptm_file::read_ptm(bytes).map_err(|e| e.to_string())?;
    let m = ptm.width * ptm.height;
    let data: Vec<f32> = ptm.coefficients.iter().chain(ptm.colour.iter().flatten()).map(|&v| v as f32).collect();
    let channels = data.len().checked_div(m).unwrap_or(0);
    Ok(raster::Image { width: ptm.width, height: ptm.height, channels, data })
}

/// A glTF binary as text: its JSON chunk, then every accessor's values, then every image's
/// 8-bit codes, so the golden check compares numbers within its tolerance.
fn glb_text(bytes: &[u8]) -> Result<String, String> {
    let u32_at = |at: usize| -> Result<usize, String> {
        let b = bytes.get(at..at + 4).ok_or("truncated")?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    if bytes.get(0..4) != Some(b"glTF") {
        return Err("not a glTF binary".into());
    }
    let json_len = u32_at(12)?;
    let json = bytes.get(20..20 + json_len).ok_or("truncated JSON chunk")?;
    let bin_at = 20 + json_len;
    let bin = match (u32_at(bin_at), bytes.get(bin_at + 8..)) {
        (Ok(len), Some(rest)) => rest.get(..len).ok_or("truncated BIN chunk")?,
        _ => &[],
    };
    let doc: serde_json::Value = serde_json::from_slice(json).map_err(|e| e.to_string())?;
    let mut out = String::from_utf8_lossy(json).into_owned();
    let view = |i: &serde_json::Value| -> Option<&[u8]> {
        let v = &doc["bufferViews"][i.as_u64()? as usize];
        let at = v["byteOffset"].as_u64().unwrap_or(0) as usize;
        bin.get(at..at + v["byteLength"].as_u64()? as usize)
    };
    for a in doc["accessors"].as_array().into_iter().flatten() {
        let Some(data) = view(&a["bufferView"]) else { continue };
        let data = &data[a["byteOffset"].as_u64().unwrap_or(0) as usize..];
        out.push('\n');
        for chunk in data.chunks_exact(4) {
            let raw = [chunk[0], chunk[1], chunk[2], chunk[3]];
            let text = match a["componentType"].as_u64() {
                Some(5126) => format!("{} ", f32::from_le_bytes(raw)),
                _ => format!("{} ", u32::from_le_bytes(raw)),
            };
            out.push_str(&text);
        }
    }
    for img in doc["images"].as_array().into_iter().flatten() {
        let Some(png) = view(&img["bufferView"]) else { continue };
        let image = raster::io::decode(png).map_err(|e| e.to_string())?;
        out.push_str(&format!("\nimage {} {} {}\n", image.width, image.height, image.channels));
        for v in &image.data {
            out.push_str(&format!("{} ", (v * 255.0).round()));
        }
    }
    Ok(out)
}

/// Whole steps of a `bits`-bit code within `fraction` of the full range, rounded down (with
/// a hair of slack so that 1/255 is exactly one 8-bit step).
fn steps_within(fraction: f64, bits: u32) -> u64 {
    (fraction * ((1u64 << bits) - 1) as f64 + 1e-9).floor().max(0.0) as u64
}

fn outliers(output: f64, manifest: f64) -> f32 {
    (if output > 0.0 { output } else { manifest }) as f32
}

#[cfg(test)]
mod tests {
    use super::steps_within;

    #[test]
    fn tolerances_round_down_to_whole_steps() {
        assert_eq!(steps_within(1.0 / 255.0, 8), 1);
        assert_eq!(steps_within(0.004, 8), 1);
        assert_eq!(steps_within(0.004, 16), 262);
        assert_eq!(steps_within(1.0 / 255.0, 16), 257);
        assert_eq!(steps_within(0.0, 16), 0);
    }
}
