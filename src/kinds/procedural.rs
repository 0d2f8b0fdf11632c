//! `procedural`: a texture fitted by example [references: lagae §7]: a photo of an isotropic
//! stochastic texture analysed once into a compact parameter set (wavelet-noise band weights,
//! PCA colour, inverse-CDF curves), or such a set read back from its file. Layers evaluate it
//! (`layer { procedural = … }`); an output writes the parameter file (`.toml`) or a render at
//! the sample's own size (`.png`, `.exr`).
//!
//! ```text
//! sample ─► procedural.fit (analysis; the options) ─► layer.procedural (seed, zoom, gains, …)
//! params.toml ─► procedural.read ──────────────────┘
//! ```
//!
//! The analysis keys on the sample and the analysis options only: weights, seeds and targets
//! touch only the evaluation.

use super::{Bytes, ColorSpace, FnStage, OutputFormat, Planner};
use crate::graph::{AnyHandle, Handle, In, Inputs, RunCx, StageError};
use crate::lang::schema::{Default, Extent, KindSpec, Naming, PropSpec, Ty, Value};
use crate::lang::{Decl, Diagnostic};
use crate::raster::Image;
use crate::synth::noise::colour::ColourMode;
use crate::synth::noise::marginal::Abscissa;
use crate::synth::noise::params::{self, Estimator, FitOptions, HistogramMode, MaskSpectrum, Procedural};
use crate::synth::noise::spectrum::{Border, ANISOTROPY_LIMIT};
use crate::synth::noise::NoiseError;

crate::choices!(COLOURS: ColourMode {
    "pca" => ColourMode::Pca, "rgb_independent" => ColourMode::RgbIndependent, "rgb_shared" => ColourMode::RgbShared
});
crate::choices!(HISTOGRAMS: HistogramMode { "auto" => HistogramMode::Auto, "on" => HistogramMode::On, "off" => HistogramMode::Off });
crate::choices!(ABSCISSAS: Abscissa { "gaussian" => Abscissa::Gaussian, "quantile" => Abscissa::Quantile });
crate::choices!(ESTIMATORS: Estimator { "paper" => Estimator::Paper, "nnls" => Estimator::Nnls });
crate::choices!(MASK_SPECTRA: MaskSpectrum { "square" => MaskSpectrum::Square, "masked" => MaskSpectrum::Masked });
crate::choices!(BORDERS: Border { "none" => Border::None, "periodic_smooth" => Border::PeriodicSmooth });

pub static SPEC: KindSpec = KindSpec {
    name: "procedural",
    doc: "A procedural texture fitted by example (Lagae et al. 2009): the photo of an isotropic stochastic texture (gravel, sand, asphalt, concrete) analysed into multiresolution wavelet-noise band weights, its mean, a PCA colour transform and an inverse-CDF curve per channel (66 numbers for a 512² RGB sample), evaluated by layers at any resolution with no photo needed. `from` fits a sample (cropped to its largest centred power-of-two square, with a warning; a sample that is not isotropic is warned about); `params` reads a parameter file back instead (as written by a `.toml` output, edited by hand or not).",
    naming: Naming::Ident,
    produces: &[Value::Procedural],
    settings: &[],
    extent: Extent::None,
    props: &[
        PropSpec { name: "from", ty: Ty::Ref(&[Value::Image]), default: Default::Absent, doc: "The sample to fit (values as the sample holds them: encoded sRGB for a photo)." },
        PropSpec { name: "params", ty: Ty::Path, default: Default::Absent, doc: "Instead of `from`: a parameter file (`.toml`) to read. Its values are taken as sRGB." },
        PropSpec { name: "mask", ty: Ty::Ref(&[Value::Map]), default: Default::Absent, doc: "With `from`: fit only the sample's pixels where this map is at least ½ (resampled to the sample's size): one region class of a structured sample, e.g. its stones without their joints. The mean, colour and histograms come from every masked pixel, the band weights as `mask_spectrum` says." },
        PropSpec { name: "mask_spectrum", ty: Ty::Enum(MASK_SPECTRA.names), default: Default::Text("square"), doc: "With `mask`: where the band weights are measured. `square`: the largest power-of-two square inside the mask (only the class's pixels; the mask must hold a 16 x 16 square); `masked`: the whole sample's centred square with the unmasked pixels at the class's mean, its powers divided by the masked fraction (any shape, thin joints included, but approximate: the mask's edges leak power between bands)." },
        PropSpec { name: "colour", ty: Ty::Enum(COLOURS.names), default: Default::Text("pca"), doc: "`pca`: channels decorrelated by PCA, each with its own noise (the paper's method); `rgb_independent`: R, G, B apart (false colours); `rgb_shared`: R, G, B on one noise (no colour variation)." },
        PropSpec { name: "histogram", ty: Ty::Enum(HISTOGRAMS.names), default: Default::Text("auto"), doc: "Match each channel's intensity distribution through an inverse-CDF curve: `on`, `off`, or `auto` (on where the channel is measurably not Gaussian: KS > 0.03, |skewness| > 0.3 or |excess kurtosis| > 0.5)." },
        PropSpec { name: "knots", ty: Ty::Int(2, 256), default: Default::Text("10"), doc: "Knots of each inverse-CDF curve." },
        PropSpec { name: "abscissa", ty: Ty::Enum(ABSCISSAS.names), default: Default::Text("gaussian"), doc: "Where the knots lie: `gaussian` (uniform in z over [−3, 3], clamped at the end knots: the same count of numbers, a far closer fit of skewed channels, and their mean kept) or `quantile` (uniform in probability, the paper's: its end intervals misplace a skewed tail, which moves the mean colour by a few percent of the range)." },
        PropSpec { name: "estimator", ty: Ty::Enum(ESTIMATORS.names), default: Default::Text("paper"), doc: "Band weights from band powers: `paper` (eq. 9, each band alone) or `nnls` (least squares against the simulated leakage between bands: closer for spectra that fall steeply)." },
        PropSpec { name: "border", ty: Ty::Enum(BORDERS.names), default: Default::Text("none"), doc: "`none` (the paper) or `periodic_smooth` (Moisan's decomposition: the sample's borders leak no power along the axes)." },
        PropSpec { name: "tile", ty: Ty::Int(8, 1024), default: Default::Text("256"), doc: "Side of the noise tile (even): a band repeats every tile / 2^b sample widths." },
        PropSpec { name: "extrapolate_bands", ty: Ty::Int(0, 4), default: Default::Text("0"), doc: "Bands finer than the sample's pixels, added on the line log₂ w_b follows over the top four fitted bands: detail in renders magnified past the sample's resolution (each band doubles it), where the fit alone looks blurred. The parameter file lists them after the fitted weights." },
    ],
};

impl super::Encoded for Procedural {
    fn encode(&self) -> Vec<u8> {
        self.to_toml().into_bytes()
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let text = std::str::from_utf8(bytes).map_err(|e| e.to_string())?;
        Procedural::from_toml(text).map_err(|e| e.to_string())
    }
}

#[derive(serde::Serialize)]
struct Fitting {
    sample: In<Image>,
    mask: Option<In<Image>>,
    options: FitOptions,
}

fn run_fit(cx: &RunCx, f: &Fitting) -> Result<Procedural, StageError> {
    let sample = cx.get(f.sample);
    let mask = match f.mask {
        Some(m) => {
            let map = cx.get(m);
            if map.channels != 1 {
                return Err(StageError::new("the mask must be scalar, not an orientation field").at_prop("mask"));
            }
            let map = super::map::fit(&map, sample.width, sample.height);
            Some(map.data.iter().map(|&v| v >= 0.5).collect::<Vec<bool>>())
        }
        None => None,
    };
    let fitted = params::fit_masked(&sample, mask.as_deref(), &f.options).map_err(|e| {
        let at = if matches!(e, NoiseError::Mask(_)) { "mask" } else { "from" };
        StageError::new(e.to_string()).at_prop(at)
    })?;
    if let Some((w, h)) = fitted.cropped_from {
        let n = fitted.params.sample_size;
        cx.warn(format!("the sample is {w} x {h}: its centred {n} x {n} square is fitted (the analysis needs a power-of-two square)"));
    }
    if fitted.anisotropy > ANISOTROPY_LIMIT {
        cx.warn(format!(
            "the sample is not isotropic (its power varies {:.1}× with direction): the fitted noise keeps its spectrum per octave but not its orientation",
            fitted.anisotropy
        ));
    }
    Ok(fitted.params)
}

fn read_params(cx: &RunCx, _: &()) -> Result<Procedural, StageError> {
    let bytes = cx.file(0)?;
    let text =
        std::str::from_utf8(&bytes).map_err(|_| StageError::new("the parameter file is not UTF-8 text").in_file(0))?;
    Procedural::from_toml(text).map_err(|e| StageError::new(e.to_string()).in_file(0))
}

/// The colour space of a procedural texture's values: its sample's, or sRGB for a file.
pub fn color_space(p: &Planner, name: &str) -> ColorSpace {
    match p.decl(name).props.reference("from") {
        Some(from) => p.color_space(from),
        None => ColorSpace::Srgb,
    }
}

/// The procedural kind.
pub struct ProceduralKind;

impl super::Kind for ProceduralKind {
    fn spec(&self) -> &'static KindSpec {
        &SPEC
    }

    fn plan(&self, p: &mut Planner, d: &Decl) -> Result<Option<AnyHandle>, Diagnostic> {
        let props = &d.props;
        let node: Handle<Procedural> = match (props.reference("from"), props.path("params")) {
            (Some(from), None) => {
                let at = props.span("from").unwrap_or(d.name_span);
                let mut inputs = Inputs::new();
                let options = FitOptions {
                    colour: COLOURS.get(props.enumeration("colour")),
                    histogram: HISTOGRAMS.get(props.enumeration("histogram")),
                    knots: props.int("knots") as usize,
                    abscissa: ABSCISSAS.get(props.enumeration("abscissa")),
                    estimator: ESTIMATORS.get(props.enumeration("estimator")),
                    border: BORDERS.get(props.enumeration("border")),
                    tile: tile_side(d)?,
                    seed: p.seed(d, "analysis"),
                    extrapolate: props.int("extrapolate_bands") as usize,
                    mask_spectrum: MASK_SPECTRA.get(props.enumeration("mask_spectrum")),
                };
                if let (None, Some(span)) = (props.reference("mask"), props.span("mask_spectrum")) {
                    return Err(Diagnostic::error("`mask_spectrum` applies only to a fit with a `mask`")
                        .with_code("tessera::procedural")
                        .with_label(span, "remove this, or add `mask = MAP`"));
                }
                let sample = inputs.add(p.value::<Image>(from, at)?);
                let mask = props.reference("mask").map(|m| inputs.add(p.result::<Image>(m)));
                let fitting = Fitting { sample, mask, options };
                let stage = FnStage::keyed("procedural.fit", 1, fitting, run_fit);
                p.add(format!("procedural {}", d.name), stage, inputs, vec![])
            }
            (None, Some(path)) => {
                for key in [
                    "mask",
                    "mask_spectrum",
                    "colour",
                    "histogram",
                    "knots",
                    "abscissa",
                    "estimator",
                    "border",
                    "tile",
                    "extrapolate_bands",
                ] {
                    if let Some(span) = props.span(key) {
                        return Err(Diagnostic::error(format!(
                            "`{key}` is an analysis option: a parameter file is already fitted"
                        ))
                        .with_code("tessera::procedural")
                        .with_label(span, "remove this"));
                    }
                }
                let span = props.span("params").unwrap_or(d.name_span);
                let stage = FnStage::keyed("procedural.read", 1, (), read_params);
                p.add(format!("procedural {} (file)", d.name), stage, Inputs::new(), vec![(path.clone(), span)])
            }
            (Some(_), Some(_)) => {
                return Err(Diagnostic::error(format!("procedural `{}` both fits a sample and reads a file", d.name))
                    .with_code("tessera::procedural")
                    .with_label(props.span("params").unwrap_or(d.name_span), "remove `params` or `from`"))
            }
            (None, None) => {
                return Err(Diagnostic::error(format!(
                    "procedural `{}` needs `from = SAMPLE` or `params = \"file.toml\"`",
                    d.name
                ))
                .with_code("tessera::missing_property")
                .with_label(d.name_span, "here"))
            }
        };
        Ok(Some(node.erase()))
    }

    fn plan_output(&self, p: &mut Planner, out: &super::OutputRequest) -> Result<Option<super::ViewNode>, Diagnostic> {
        let d = out.decl;
        out.refuse_views(
            "a procedural texture has no views: write its parameters (`.toml`) or a render (`.png`, `.exr`)",
        )?;
        let params: Handle<Procedural> = p.result(out.from);
        let mut inputs = Inputs::new();
        let params = inputs.add(params);
        let node = match out.format {
            OutputFormat::Toml => {
                let stage =
                    FnStage::keyed("output.params", 2, params, |cx, &h| Ok(Bytes(cx.get(h).to_toml().into_bytes())));
                p.add(format!("output {}", d.name), stage, inputs, vec![])
            }
            OutputFormat::Png8 | OutputFormat::Png16 | OutputFormat::Exr => {
                let space = color_space(p, out.from);
                let seed = p.seed(d, "noise");
                let format = out.format;
                let stage = FnStage::keyed(
                    "output.procedural",
                    2,
                    (params, space, seed, format),
                    |cx, &(h, space, seed, format)| {
                        let img = super::layer::procedural::render_sample_size(&cx.get(h), seed)?;
                        super::output::encode_image(&super::output::to_file_space(&img, space, format), format)
                    },
                );
                p.add(format!("output {}", d.name), stage, inputs, vec![])
            }
            _ => {
                return Err(Diagnostic::error(format!(
                    "a procedural texture is written as `.toml`, `.png` or `.exr`, not `.{}`",
                    out.ext
                ))
                .with_code("tessera::output_format")
                .with_label(d.name_span, "here"))
            }
        };
        Ok(Some(super::ViewNode { node, exact: false, more: Vec::new() }))
    }
}

/// `tile`, which must be even.
fn tile_side(d: &Decl) -> Result<usize, Diagnostic> {
    let n = d.props.int("tile");
    if n % 2 != 0 {
        return Err(Diagnostic::error(format!("a noise tile of {n} cells: the side must be even"))
            .with_code("tessera::procedural")
            .with_label(d.props.span("tile").unwrap_or(d.name_span), "here")
            .with_help("the even/odd fix pairs each coefficient with one half a tile away"));
    }
    Ok(n as usize)
}
