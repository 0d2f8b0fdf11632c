//! `tessera similar` and `tessera compare`: texture tools run on image files outside any
//! scene. `similar` is a library query planned from the `library` kind's own stages and
//! run through the project's executor and cache, so a second run on one directory loads
//! the features instead of computing them, and scenes share them; `compare` reads its two
//! files directly.

use std::path::Path;
use std::time::Instant;

use super::Project;
use crate::graph::{Graph, Report};
use crate::kinds::{self, Standalone};
use crate::raster::{self, Image};
use crate::synth::library::{Axis, FourierMode, Normalise};
use crate::synth::metrics;

/// Options of `tessera similar`.
#[derive(Clone, Debug)]
pub struct SimilarOptions {
    pub k: usize,
    pub randomness: f64,
    pub seed: u64,
    pub colour: bool,
    /// `None`: no Fourier axis.
    pub fourier: Option<Fourier>,
    pub orientation: bool,
    /// Scale axes by fixed bounds instead of this query's largest distance.
    pub fixed: bool,
    pub bins: usize,
    pub size: usize,
}

/// How `similar` compares spectra.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fourier {
    /// Real and imaginary parts (the thesis).
    ReIm,
    Modulus,
    /// Magnitude only: shift invariant.
    Magnitude,
    /// Radial profile: rotation robust.
    Radial,
}

/// A ranking as `tessera similar` prints it, and how its stages ran.
pub struct Similar {
    pub table: String,
    pub report: Report,
    pub millis: f64,
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

/// Ranks the library in `dir` against `target` and renders the table `tessera similar` prints.
pub fn similar(p: &Project, dir: &Path, target: &Path, o: &SimilarOptions) -> Result<Similar, String> {
    let files = kinds::library_entries(&p.world, dir)
        .map_err(|e| format!("cannot read the directory `{}`: {e}", dir.display()))?;
    if files.is_empty() {
        return Err(format!("the directory `{}` holds no `.png` or `.exr` files", dir.display()));
    }
    let mut axes = Vec::new();
    if o.colour {
        axes.push(Axis::Colour);
    }
    if let Some(m) = o.fourier {
        axes.push(Axis::Fourier(match m {
            Fourier::ReIm => FourierMode::ReIm,
            Fourier::Modulus => FourierMode::Modulus,
            Fourier::Magnitude => FourierMode::Magnitude,
            Fourier::Radial => FourierMode::Radial,
        }));
    }
    if o.orientation {
        axes.push(Axis::Orientation);
    }
    let compares_nothing = axes.is_empty();
    let names: Vec<String> = files.iter().map(|f| crate::graph::files::name_of(f)).collect();
    let mut graph = Graph::default();
    let query = kinds::plan_standalone(
        &mut graph,
        Standalone {
            files,
            target: target.to_path_buf(),
            bins: o.bins,
            size: o.size,
            axes,
            normalise: if o.fixed { Normalise::Fixed } else { Normalise::PerQueryMax },
            k: o.k,
            randomness: o.randomness,
            seed: o.seed,
        },
    );
    // With every axis off the command has always read every file first, so an unreadable
    // one is still the error it reports.
    let targets = if compares_nothing { graph.nodes[query.node()].inputs.clone() } else { vec![query.node()] };
    let start = Instant::now();
    let outcome = p.executor().run(&graph, &targets).map_err(|(f, _)| f.error.message)?;
    let millis = start.elapsed().as_secs_f64() * 1000.0;
    if compares_nothing {
        return Err("every axis is off: enable colour, fourier or orientation".into());
    }
    let ranking = outcome.get(query).expect("the query ran");
    let width = names.iter().map(|n| n.len()).max().unwrap_or(5).max(5);
    let mut out = format!("{:<4}  {:<width$}  {:>8}", "rank", "entry", "distance");
    for a in &ranking.axes {
        out.push_str(&format!("  {a:>12}"));
    }
    out.push('\n');
    for (i, c) in ranking.candidates.iter().enumerate() {
        out.push_str(&format!("{:<4}  {:<width$}  {:>8.4}", i + 1, c.name, c.distance));
        for v in &c.axes {
            out.push_str(&format!("  {v:>12.4}"));
        }
        out.push('\n');
    }
    Ok(Similar { table: out, report: outcome.report, millis })
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
