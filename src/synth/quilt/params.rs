//! Parameters, optional inputs and the error type of image quilting.

use std::fmt;

use crate::raster::Image;
use crate::synth::blend::BlendError;

/// Per-pixel distance used for block matching and for the boundary cut.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Metric {
    /// Sum of absolute differences (Dong's choice). Scored directly, O(overlap) per candidate.
    Sad,
    /// Sum of squared differences (Efros–Freeman, Frasson). Scored for every candidate at once by FFT
    /// correlation, then the shortlist is re-scored exactly.
    Ssd,
}

/// How channel ranges are made comparable before matching (Dong §6.2.3–6.2.5). Only the matching
/// sees rescaled values; the output always holds the raw sample values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Equalise {
    /// Raw values.
    None,
    /// Divide each channel by its range (max − min) over all samples; a constant channel keeps scale 1.
    MinMax,
    /// Divide each channel by its standard deviation over all samples; a constant channel keeps scale 1.
    ZScore,
}

/// The "next neighbour block" shortcut of Dong's thesis (Sec. 5.3.2, modification 1).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Coherence {
    /// Every block is searched.
    Off,
    /// When the already placed neighbours (left, upper-left, upper, upper-right — those that exist)
    /// all continue one sample offset, the block that completes the arrangement is copied without a
    /// search (its overlap error is then exactly 0; the candidate stride does not apply to it, and
    /// blocks that wrap around a tileable output always search). `forced_search` ∈ [0, 1] is the
    /// probability of searching anyway (0 = thesis).
    On { forced_search: f32 },
}

/// Weights of the three error terms of Frasson's Eq. 5.3 / E_new (Sec. 5.3.1).
///
/// Each term is normalised to a weighted mean per pixel and per channel (of equalised values), so the
/// weights are comparable: `E = overlap·O + guide·G + depth·D`. `O` covers the channels that are not
/// depth channels, `D` the depth channels, both over the already synthesised overlap; `G` compares the
/// candidate with the guide image over the whole block.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Terms {
    pub overlap: f32,
    pub guide: f32,
    pub depth: f32,
}

impl Terms {
    /// Overlap error only (plain quilting).
    pub const OVERLAP: Terms = Terms { overlap: 1.0, guide: 0.0, depth: 0.0 };

    /// `E = α·O + (1 − α)·G` (Frasson Eq. 5.3).
    pub fn guided(alpha: f32) -> Terms {
        Terms { overlap: alpha, guide: 1.0 - alpha, depth: 0.0 }
    }

    /// `E = α1·O + α2·G + α3·D` (Frasson Sec. 5.3.1); the thesis asks for `α1 + α2 + α3 = 1`.
    pub fn with_depth(alpha1: f32, alpha2: f32, alpha3: f32) -> Terms {
        Terms { overlap: alpha1, guide: alpha2, depth: alpha3 }
    }
}

/// The core quilting parameters.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct QuiltParams {
    /// Output size in pixels.
    pub width: usize,
    pub height: usize,
    /// Side of the square blocks, in pixels.
    pub block: usize,
    /// Overlap between neighbouring blocks (width of vertical overlaps = height of horizontal ones).
    /// Blocks are placed every `block − overlap` pixels.
    pub overlap: usize,
    /// Candidates with error ≤ (1 + tolerance)·min are eligible and one is drawn uniformly (seeded);
    /// 0 picks the minimum, ties broken by the lowest candidate index.
    pub tolerance: f32,
    pub metric: Metric,
    pub equalise: Equalise,
    /// Per-channel weights of the matching error (after equalisation); `None` = all 1.
    pub channel_weights: Option<Vec<f32>>,
    pub coherence: Coherence,
    /// Candidate top-left positions are the multiples of this stride (1 = every position).
    pub candidate_stride: usize,
    /// Output is a torus: the last row/column of blocks also matches the first one.
    pub tileable: bool,
    pub seed: u64,
}

/// The overlap of blocks when none is given: a sixth of the block (Efros & Freeman's choice),
/// at least one pixel.
pub fn default_overlap(block: usize) -> usize {
    (block / 6).max(1)
}

impl QuiltParams {
    /// Efros–Freeman defaults for an output of the given size: overlap = block/6, tolerance 0.1, SSD,
    /// min–max equalisation, no coherence shortcut, stride 1, not tileable.
    pub fn new(width: usize, height: usize, block: usize, seed: u64) -> Self {
        QuiltParams {
            width,
            height,
            block,
            overlap: default_overlap(block),
            tolerance: 0.1,
            metric: Metric::Ssd,
            equalise: Equalise::MinMax,
            channel_weights: None,
            coherence: Coherence::Off,
            candidate_stride: 1,
            tileable: false,
            seed,
        }
    }
}

/// A guide image steering the choice of blocks (Frasson Eq. 5.2).
#[derive(Clone, Copy, Debug)]
pub struct Guide<'a> {
    /// Output-sized image; its channel `i` is compared with sample channel `channels[i]`.
    pub image: &'a Image,
    /// Optional output-sized 1-channel weight map `w_g ∈ [0, ∞)` (0 = no guidance there).
    pub weights: Option<&'a Image>,
    /// Sample channel compared with each guide channel; `None` = channels `0..guide.channels`.
    pub channels: Option<&'a [usize]>,
}

/// How each block chooses among several samples (all samples must have the same channel count).
#[derive(Clone, Copy, Debug)]
pub enum SampleChoice<'a> {
    /// Every sample is searched for every block (Frasson's footnote: "all patches could be scored").
    All,
    /// Density mixing of exactly two samples A and B: an output-sized 1-channel map gives, at the block
    /// centre, the probability of taking B (0 → only A, 1 → only B); drawn per block from the seed.
    Density(&'a Image),
    /// Frasson's multi-patch rule (Sec. 5.3.1): the sample whose mean colour is nearest to the guide
    /// block's mean colour, over the guide channels (CIELAB from linear RGB when `lab` is set; needs 3
    /// guide channels). Requires a guide. Blocks without guide weight search all samples.
    NearestMean { lab: bool },
}

/// Local rotation of the sample by an orientation field.
#[derive(Clone, Copy, Debug)]
pub struct Orientation<'a> {
    /// Output-sized field: 2 channels `(cos θ, sin θ)` (the `synth::map` convention, θ from +x towards
    /// +y) or 1 channel holding θ in radians.
    pub field: &'a Image,
    /// Number of pre-rotated copies, at angles `2π·k/copies`; each block uses the copy nearest θ at
    /// its centre. Copies are the sample's size; pixels rotated in from outside are invalid and
    /// candidates must avoid them, so a copy whose valid area cannot hold a block is replaced by the
    /// nearest copy that can.
    pub copies: usize,
}

/// Optional inputs of [`quilt_with`](super::quilt_with). `Default` gives plain quilting.
#[derive(Clone, Debug)]
pub struct QuiltOptions<'a> {
    /// Output-sized 1-channel occupancy mask: pixels with value ≤ 0.5 are left empty (zero, index
    /// `EMPTY`) and never constrain matching.
    pub occupancy: Option<&'a Image>,
    pub guide: Option<Guide<'a>>,
    pub terms: Terms,
    /// Sample channels whose overlap error forms Frasson's depth term `D` instead of `O`. The boundary
    /// cut is computed on the other channels only ("the cut on the colour error").
    pub depth_channels: Vec<usize>,
    /// Used when more than one sample is given.
    pub choice: SampleChoice<'a>,
    pub orientation: Option<Orientation<'a>>,
    /// Per sample, an optional sample-sized 1-channel map of allowed top-left candidate positions
    /// (value > 0.5 = allowed), e.g. Frasson's "block pallet" restricted to region interiors.
    pub allowed: Vec<Option<&'a Image>>,
    /// Per sample, an optional sample-sized 1-channel mask of pixels to ignore (value > 0.5), such
    /// as Frasson's mask layer over shadows and highlights: ignored pixels weigh 0 in every error
    /// term, each term's weighted mean is taken over the pixels left, and candidate blocks more than
    /// half ignored are rejected [references: frasson §5.3.1]. Sources with a mask are scored by the
    /// direct sweep (both metrics), whose rounding bound holds for a ratio of non-negative sums.
    pub ignore: Vec<Option<&'a Image>>,
    /// Told the number of blocks placed after each wave.
    pub progress: crate::synth::Progress<'a>,
}

impl Default for QuiltOptions<'_> {
    fn default() -> Self {
        QuiltOptions {
            occupancy: None,
            guide: None,
            terms: Terms::OVERLAP,
            depth_channels: Vec::new(),
            choice: SampleChoice::All,
            orientation: None,
            allowed: Vec::new(),
            ignore: Vec::new(),
            progress: crate::synth::Progress::none(),
        }
    }
}

/// Invalid quilting inputs. Messages are written for scene authors.
/// Which input or parameter of a quilt an error is about: callers point at the place to
/// fix from this, never from the message text.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Input {
    Output,
    Block,
    Sample,
    Samples,
    SampleChannels,
    ChannelWeights,
    ChannelWeight,
    DepthChannel,
    Occupancy,
    Guide,
    GuideWeights,
    GuideWeight,
    GuideChannelMap,
    GuideChannelIndex,
    GuideChannels,
    LabGuide,
    Density,
    Orientation,
    OrientationCopies,
    AllowedPositions,
    IgnoreMask,
    Gathered,
    GatheredImages,
    QuiltResult,
    IndexMap,
    IndexMapEntry,
    Tolerance,
    ForcedSearch,
    CandidateStride,
    OverlapWeight,
    DepthWeight,
    TermWeights,
    SearchRate,
    Neighbourhood,
}

impl Input {
    /// How messages name it.
    pub fn text(self) -> &'static str {
        match self {
            Input::Output => "output",
            Input::Block => "block",
            Input::Sample => "sample",
            Input::Samples => "samples",
            Input::SampleChannels => "sample channel counts",
            Input::ChannelWeights => "channel weights",
            Input::ChannelWeight => "channel weight",
            Input::DepthChannel => "depth channel index",
            Input::Occupancy => "occupancy mask",
            Input::Guide => "guide image",
            Input::GuideWeights => "guide weights",
            Input::GuideWeight => "guide weight",
            Input::GuideChannelMap => "guide channel map",
            Input::GuideChannelIndex => "guide channel index",
            Input::GuideChannels => "guide channels",
            Input::LabGuide => "Lab guide",
            Input::Density => "density map",
            Input::Orientation => "orientation field",
            Input::OrientationCopies => "orientation copies",
            Input::AllowedPositions => "allowed-position map",
            Input::IgnoreMask => "mask",
            Input::Gathered => "gathered image",
            Input::GatheredImages => "gathered images",
            Input::QuiltResult => "quilt result",
            Input::IndexMap => "index map",
            Input::IndexMapEntry => "index map entry",
            Input::Tolerance => "tolerance",
            Input::ForcedSearch => "forced_search",
            Input::CandidateStride => "candidate_stride",
            Input::OverlapWeight => "overlap weight",
            Input::DepthWeight => "depth weight",
            Input::TermWeights => "error term weights",
            Input::SearchRate => "search_rate",
            Input::Neighbourhood => "neighbourhood",
        }
    }
}

impl fmt::Display for Input {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.text())
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum QuiltError {
    /// No sample was given, or more than the choice rule accepts.
    SampleCount { got: usize, expected: &'static str },
    /// Output, block or sample without pixels or channels.
    Empty { what: Input },
    /// The block does not fit in a sample (or in a rotated copy's valid area).
    BlockTooLarge { block: usize, sample: usize, width: usize, height: usize },
    /// Overlap must be smaller than the block.
    OverlapTooLarge { overlap: usize, block: usize },
    /// A tileable output needs overlaps to wrap around.
    TileableZeroOverlap,
    /// A tileable output must be at least one block wide and high.
    TileableTooSmall { block: usize, width: usize, height: usize },
    /// An image that must match another's size does not.
    SizeMismatch { what: Input, expected: [usize; 2], got: [usize; 2] },
    /// Channel counts disagree (between samples, with a map, or a channel index out of range).
    ChannelMismatch { what: Input, expected: usize, got: usize },
    /// NaN or infinity in an input image.
    NonFinite { what: Input, count: usize },
    /// A numeric parameter outside its range (or not finite).
    Invalid { name: Input, value: f64, expected: &'static str },
    /// No candidate block position is allowed in some sample.
    NoCandidates { sample: usize },
    /// Seam removal needs every output pixel filled (no occupancy mask yet).
    SeamsNeedFullCoverage { empty: usize },
    /// The samples given for seam removal do not reproduce the quilt (`pixels` differ).
    SampleContentMismatch { pixels: usize },
    /// The Poisson blend behind seam removal refused its inputs.
    Blend(BlendError),
}

impl fmt::Display for QuiltError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            QuiltError::SampleCount { got, expected } => {
                write!(f, "quilting got {got} sample(s), expected {expected}")
            }
            QuiltError::Empty { what } => write!(f, "the {what} is empty"),
            QuiltError::BlockTooLarge { block, sample, width, height } => write!(
                f,
                "block size {block} does not fit in sample {sample} ({width}x{height}): use a smaller block \
                 or a larger sample"
            ),
            QuiltError::OverlapTooLarge { overlap, block } => {
                write!(f, "overlap {overlap} must be smaller than the block size {block}")
            }
            QuiltError::TileableZeroOverlap => write!(f, "a tileable output needs an overlap of at least 1"),
            QuiltError::TileableTooSmall { block, width, height } => {
                write!(f, "a tileable {width}x{height} output must be at least one block ({block}) wide and high")
            }
            QuiltError::SizeMismatch { what, expected, got } => {
                write!(f, "the {what} is {}x{} but must be {}x{}", got[0], got[1], expected[0], expected[1])
            }
            QuiltError::ChannelMismatch { what, expected, got } => {
                write!(f, "{what}: expected {expected} channel(s), got {got}")
            }
            QuiltError::NonFinite { what, count } => {
                write!(f, "the {what} contains {count} NaN or infinite value(s)")
            }
            QuiltError::Invalid { name, value, expected } => {
                write!(f, "invalid {name} = {value}: expected {expected}")
            }
            QuiltError::NoCandidates { sample } => {
                write!(f, "sample {sample} has no allowed block position")
            }
            QuiltError::SeamsNeedFullCoverage { empty } => write!(
                f,
                "seam removal does not support occupancy masks yet: {empty} output pixel(s) are empty; quilt \
                 without an occupancy mask to remove seams"
            ),
            QuiltError::SampleContentMismatch { pixels } => write!(
                f,
                "the samples given for seam removal are not the ones the result was quilted from ({pixels} \
                 pixel(s) differ)"
            ),
            QuiltError::Blend(e) => write!(f, "seam removal failed: {e}"),
        }
    }
}

impl std::error::Error for QuiltError {}

pub(super) fn check_finite_image(what: Input, img: &Image) -> Result<(), QuiltError> {
    let count = img.data.iter().filter(|v| !v.is_finite()).count();
    if count > 0 {
        return Err(QuiltError::NonFinite { what, count });
    }
    if img.data.len() != img.width * img.height * img.channels {
        return Err(QuiltError::ChannelMismatch {
            what,
            expected: img.width * img.height * img.channels,
            got: img.data.len(),
        });
    }
    Ok(())
}

pub(super) fn check_size(what: Input, img: &Image, width: usize, height: usize) -> Result<(), QuiltError> {
    if img.width != width || img.height != height {
        return Err(QuiltError::SizeMismatch { what, expected: [width, height], got: [img.width, img.height] });
    }
    Ok(())
}

pub(super) fn check_range(name: Input, value: f32, lo: f32, hi: f32, expected: &'static str) -> Result<(), QuiltError> {
    if !(value >= lo && value <= hi) {
        return Err(QuiltError::Invalid { name, value: f64::from(value), expected });
    }
    Ok(())
}
