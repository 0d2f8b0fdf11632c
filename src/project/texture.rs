//! `tessera similar` and `tessera compare`: texture tools that read image files directly,
//! outside any scene.

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::raster::{self, Image};
use crate::synth::blend::mask::Luma;
use crate::synth::library::{self, Axis, FeatureParams, FourierMode, HistogramNorm, Normalise, QueryParams};
use crate::synth::metrics;

/// Options of `tessera similar`.
#[derive(Clone, Debug)]
pub struct SimilarOptions {
    pub k: usize,
    pub randomness: f64,
    pub seed: u64,
    pub colour: bool,
    /// `None`: no Fourier axis.
    pub fourier: Option<FourierMode>,
    pub orientation: bool,
    pub normalise: Normalise,
    pub bins: usize,
    pub size: usize,
}

/// Reads an image as texture tools compare it: encoded (sRGB-like) values, all finite.
/// EXR files hold linear values and are encoded first.
pub fn read_texture(path: &Path) -> Result<Image, String> {
    let budget = crate::graph::Budget::from_machine();
    let bytes = crate::graph::world::read_regular(path, budget.max_file())
        .map_err(|e| format!("cannot read `{}`: {e}", path.display()))?;
    let img =
        crate::kinds::decode_image(&bytes, budget).map_err(|e| format!("cannot decode `{}`: {e}", path.display()))?;
    Ok(if raster::io::is_exr(&bytes) { raster::color::image_linear_to_srgb(&img) } else { img })
}

/// The image files of a library directory, sorted by name.
pub fn library_files(dir: &Path) -> Result<Vec<PathBuf>, String> {
    let entries = std::fs::read_dir(dir).map_err(|e| format!("cannot read the directory `{}`: {e}", dir.display()))?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_file()
                && p.extension()
                    .and_then(|e| e.to_str())
                    .is_some_and(|e| e.eq_ignore_ascii_case("png") || e.eq_ignore_ascii_case("exr"))
        })
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(format!("the directory `{}` holds no `.png` or `.exr` files", dir.display()));
    }
    Ok(files)
}

/// Ranks the library in `dir` against `target` and renders the table `tessera similar` prints.
pub fn similar(dir: &Path, target: &Path, o: &SimilarOptions) -> Result<String, String> {
    let files = library_files(dir)?;
    let params =
        FeatureParams { bins: o.bins, size: o.size, resample: true, luma: Luma::Mean, ..FeatureParams::default() };
    let features = files
        .par_iter()
        .map(|f| {
            let img = read_texture(f)?;
            library::features(&img, &params).map_err(|e| format!("`{}`: {e}", f.display()))
        })
        .collect::<Result<Vec<_>, String>>()?;
    let query_img = read_texture(target)?;
    let query = library::features(&query_img, &params).map_err(|e| format!("`{}`: {e}", target.display()))?;
    let mut axes = Vec::new();
    if o.colour {
        axes.push(Axis::Colour);
    }
    if let Some(m) = o.fourier {
        axes.push(Axis::Fourier(m));
    }
    if o.orientation {
        axes.push(Axis::Orientation);
    }
    if axes.is_empty() {
        return Err("every axis is off: enable colour, fourier or orientation".into());
    }
    let qp =
        QueryParams { axes: axes.clone(), normalise: o.normalise, histogram: HistogramNorm::Fraction, exclude: None };
    let chosen = library::query(&features, &query, &qp, o.k, o.randomness, o.seed).map_err(|e| e.to_string())?;
    let names: Vec<String> =
        files.iter().map(|f| f.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()).collect();
    let width = names.iter().map(|n| n.len()).max().unwrap_or(5).max(5);
    let mut out = format!("{:<4}  {:<width$}  {:>8}", "rank", "entry", "distance");
    for a in &axes {
        out.push_str(&format!("  {:>12}", crate::kinds::axis_name(a)));
    }
    out.push('\n');
    for (i, c) in chosen.iter().enumerate() {
        out.push_str(&format!("{:<4}  {:<width$}  {:>8.4}", i + 1, names[c.index], c.distance));
        for v in &c.axes {
            out.push_str(&format!("  {v:>12.4}"));
        }
        out.push('\n');
    }
    Ok(out)
}

/// Every texture measure of `a` against `b`, as the table `tessera compare` prints.
pub fn compare(a: &Path, b: &Path) -> Result<String, String> {
    let (ia, ib) = (read_texture(a)?, read_texture(b)?);
    for (img, p) in [(&ia, a), (&ib, b)] {
        if img.data.iter().any(|v| !v.is_finite()) {
            return Err(format!("`{}` holds NaN or infinite values", p.display()));
        }
    }
    let c = metrics::compare(&ia, &ib);
    let rows = [
        ("spectrum", c.spectrum, "radially averaged power spectrum distance (log power)"),
        ("pyramid", c.pyramid, "Laplacian-pyramid histogram distance, 0..1"),
        ("colour", c.colour, "colour histogram distance, 0..1"),
        ("coherence", c.coherence, "mean RMS distance of A's patches to their nearest in B"),
        ("completeness", c.completeness, "mean RMS distance of B's patches to their nearest in A"),
    ];
    let mut out = String::new();
    for (name, v, what) in rows {
        out.push_str(&format!("{name:<13} {v:>10.6}  {what}\n"));
    }
    Ok(out)
}
