//! The schema of `layer` declarations.

use crate::lang::schema::{
    Default, Extent, KindSpec, Naming, PropSpec, Range, Ty, Unit, Value, NON_NEG, POSITIVE, UNIT,
};
use crate::synth::{blend, quilt};

/// Whether quilting seams are kept or removed in the gradient domain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SeamRemoval {
    Keep,
    Gradient,
}

/// Which pixels a blend solves for (`band` takes its radius from `band`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DomainChoice {
    Mask,
    Band,
    Whole,
}

crate::choices!(pub SOLVER_KINDS: blend::SolverKind { "mgpcg" => blend::SolverKind::Mgpcg, "multigrid" => blend::SolverKind::Multigrid });
crate::choices!(pub METRICS: quilt::Metric { "ssd" => quilt::Metric::Ssd, "sad" => quilt::Metric::Sad });
crate::choices!(pub EQUALISE: quilt::Equalise {
    "minmax" => quilt::Equalise::MinMax, "zscore" => quilt::Equalise::ZScore, "none" => quilt::Equalise::None
});
crate::choices!(pub SEAMS: SeamRemoval { "keep" => SeamRemoval::Keep, "gradient" => SeamRemoval::Gradient });
crate::choices!(pub MODES: blend::Mode {
    "gradient" => blend::Mode::Gradient, "mixed" => blend::Mode::Mixed, "average" => blend::Mode::Average, "cut" => blend::Mode::Cut
});
crate::choices!(pub TOPOLOGIES: blend::Topology {
    "torus" => blend::Topology::Torus, "rim" => blend::Topology::Rim { source: 0 }, "open" => blend::Topology::Open
});
crate::choices!(pub DOMAINS: DomainChoice { "mask" => DomainChoice::Mask, "band" => DomainChoice::Band, "whole" => DomainChoice::Whole });
crate::choices!(pub SEAM_GUIDANCE: blend::Seam {
    "insert" => blend::Seam::Insert, "average" => blend::Seam::Average, "zero" => blend::Seam::Zero
});

crate::choices!(
    /// `grid` of a tiling layer.
    pub GRIDS: crate::synth::noise::tiling::Grid {
        "triangle" => crate::synth::noise::tiling::Grid::Triangle, "hex" => crate::synth::noise::tiling::Grid::Hex
    }
);

const fn prop(name: &'static str, ty: Ty, default: Default, doc: &'static str) -> PropSpec {
    PropSpec { name, ty, default, doc }
}

static SOLVER: &[PropSpec] = &[
    prop(
        "kind",
        Ty::Enum(SOLVER_KINDS.names),
        Default::Text("mgpcg"),
        "Iterative solver for masked domains: multigrid-preconditioned conjugate gradients, or multigrid V-cycles alone. Whole-domain blends are solved exactly by FFT/DCT.",
    ),
    prop(
        "tol",
        Ty::Number(Unit::Plain, Range { min: 1e-12, max: 1.0 }),
        Default::Text("1e-6"),
        "Stop at this relative residual ‖b − Lf‖₂ / ‖b‖₂.",
    ),
    prop("max_iter", Ty::Int(1, 10_000), Default::Text("200"), "Iteration cap; reaching it is reported as a warning."),
];

pub static SPEC: KindSpec = KindSpec {
    name: "layer",
    doc: "A synthesised image layer: a sample grown onto a surface by image quilting (`quilt = ...`), colour and depth grown from patches under a guide (`relief = [...]`), layers blended under a mask in the gradient domain (`blend = [...]`), or a procedural texture evaluated (`procedural = …`), or a sample tiled and blended with its histogram kept (`tiling = …`). Give exactly one of `quilt`, `relief`, `blend`, `procedural` and `tiling`.",
    naming: Naming::Ident,
    produces: &[Value::Image],
    settings: &[],
    extent: Extent::Ref("on"),
    props: &[
        // Procedural textures (Lagae et al.).
        prop("procedural", Ty::Ref(&[Value::Procedural]), Default::Absent, "Evaluate this procedural texture (a `procedural`): every pixel on its own, at any size, no sample needed."),
        prop("zoom", Ty::Number(Unit::Plain, Range { min: 1e-4, max: 1e6 }), Default::Text("1"), "With `procedural`: layer pixels per sample pixel (8: the texture seen 8× closer, 0.125: 8× farther, antialiased by dropping the bands finer than a pixel)."),
        prop("origin", Ty::Vec2(Unit::Plain), Default::Text("[0, 0]"), "With `procedural`: where the layer's top-left corner lies, in sample widths (any window of the infinite texture)."),
        prop("band_gain", Ty::Numbers(Unit::Plain, Range { min: 0.0, max: 1000.0 }), Default::Absent, "With `procedural`: a gain per band from band 2 (the coarsest) upward, multiplying its weight in every channel; missing bands keep gain 1 (the paper's Fig. 11(d) edit)."),
        prop("solid", Ty::Bool, Default::Text("false"), "With `procedural`: evaluate the solid texture (3-D noise bands), sliced by the plane at depth `slice`: for surfaces without UVs."),
        prop("slice", Ty::Number(Unit::Plain, Range { min: -1e6, max: 1e6 }), Default::Text("0"), "With `solid`: the depth of the slice, in sample widths."),
        prop("correct_slice", Ty::Bool, Default::Text("false"), "With `solid`: refit the solid weights so the slice has the band powers of the 2-D texture (non-negative least squares against a simulated slice leakage matrix; a slice of a 3-D band leaks about 1/7 of its power into the octaves below). Costs a fraction of a second a render."),
        prop("morph", Ty::Ref(&[Value::Procedural]), Default::Absent, "With `procedural`: a second procedural texture to morph toward (PCA axes matched and slerped, weights and curves interpolated; fitted at another sample size, the smaller one's missing finest bands count as zero, and a curve with fewer knots is resampled at the other's)."),
        prop("morph_by", Ty::Ref(&[Value::Map]), Default::Absent, "With `morph`: the map whose value is the morph parameter at each pixel (0: `procedural`, 1: `morph`), read at the same relative position."),
        // Histogram-preserving tiling and blending (Heitz & Neyret; Mikkelsen's hex tiles).
        prop("tiling", Ty::Ref(&[Value::Image]), Default::Absent, "Lay this sample on a random lattice of cells, each showing it at a random offset, blended so that the sample's histogram survives (Heitz & Neyret 2018): every pixel on its own, no visible period, for textures that are not isotropic noise. `zoom` and `origin` apply as with `procedural`."),
        prop("grid", Ty::Enum(GRIDS.names), Default::Text("triangle"), "With `tiling`: `triangle` (Heitz & Neyret's simplex lattice, three cells blended at each point) or `hex` (Mikkelsen's hexagonal tiles, sharper blends)."),
        prop("cell", Ty::Number(Unit::Plain, Range { min: 1e-3, max: 1e3 }), Default::Text("0.25"), "With `tiling`: the lattice spacing, in sample widths."),
        prop("contrast", Ty::Number(Unit::Fraction, Range { min: 0.0, max: 1.0 }), Default::Text("0.5"), "With `grid = hex`: how sharply neighbouring tiles blend (Mikkelsen's contrast; 0 and 1 excluded)."),
        prop("cell_rotation", Ty::Number(Unit::Angle, Range { min: 0.0, max: 3.2 }), Default::Text("0 deg"), "With `tiling`: each cell turns its sample by a random angle up to this."),
        // Quilting (Efros–Freeman, with Dong's and Frasson's extensions).
        prop("quilt", Ty::Ref(&[Value::Image]), Default::Absent, "Grow this image (a sample, another layer, or a `representation`, whose maps are cut and pasted together and relit) by image quilting."),
        prop(
            "on",
            Ty::Ref(&[Value::Plane]),
            Default::Absent,
            "Target surface: its size, and its occupancy (pixels ≤ 0.5 stay empty). Default: the scene size, all occupied.",
        ),
        prop(
            "block",
            Ty::Pixels(Range { min: 2.0, max: 4096.0 }),
            Default::Text("32 px"),
            "Side of the square blocks copied from the sample.",
        ),
        prop(
            "overlap",
            Ty::Pixels(NON_NEG),
            Default::Absent,
            "Overlap between neighbouring blocks; must be smaller than `block`. Default block / 6.",
        ),
        prop(
            "tolerance",
            Ty::Number(Unit::Plain, NON_NEG),
            Default::Absent,
            "Candidates within (1 + tolerance) × the best error are eligible; one is drawn (seeded). 0 takes the best. Default 0.1; relief layers 0.",
        ),
        prop(
            "metric",
            Ty::Enum(METRICS.names),
            Default::Text("ssd"),
            "Block error: sum of squared (Efros–Freeman) or absolute (Dong) differences.",
        ),
        prop(
            "equalise",
            Ty::Enum(EQUALISE.names),
            Default::Text("minmax"),
            "Per-channel scaling before matching (by range or standard deviation), so channels of different units compare.",
        ),
        prop(
            "weights",
            Ty::Numbers(Unit::Plain, NON_NEG),
            Default::Absent,
            "Per-channel weights of the matching error (one per sample channel). Default all 1.",
        ),
        prop(
            "coherence",
            Ty::Bool,
            Default::Text("false"),
            "Dong's shortcut: when the placed neighbours continue one sample offset, copy the block that completes it without a search.",
        ),
        prop(
            "forced_search",
            Ty::Number(Unit::Fraction, UNIT),
            Default::Text("0"),
            "With `coherence`, the probability of searching anyway.",
        ),
        prop(
            "stride",
            Ty::Int(1, 64),
            Default::Text("1"),
            "Candidate block positions are multiples of this (1 = every position).",
        ),
        prop("tileable", Ty::Bool, Default::Text("false"), "The output wraps around (torus): it tiles seamlessly."),
        prop(
            "light",
            Ty::Source { calls: crate::kinds::sample::capture::LIGHT, refs: &[] },
            Default::Absent,
            "For a layer quilted from a `representation`: the light its image is relit at (default `light(tilt = 0 deg, slant = 45 deg)`); outputs may relight it at others.",
        ),
        prop(
            "orientation",
            Ty::Ref(&[Value::Map]),
            Default::Absent,
            "An orientation field: blocks come from copies of the sample rotated to the field's angle at the block centre. A layer quilted from a representation relights each pixel in the frame of its copy (the light turned by the copy's angle).",
        ),
        prop("copies", Ty::Int(1, 64), Default::Text("8"), "Number of pre-rotated sample copies for `orientation`."),
        prop(
            "mix",
            Ty::Ref(&[Value::Image]),
            Default::Absent,
            "A second image, mixed with the first by `density` (a soft choice per block).",
        ),
        prop(
            "density",
            Ty::Ref(&[Value::Map]),
            Default::Absent,
            "With `mix`: per block, the probability of taking the second sample (0 → only `quilt`, 1 → only `mix`).",
        ),
        prop(
            "guide",
            Ty::Ref(&[Value::Map, Value::Image]),
            Default::Absent,
            "A guide image of the output's size; its channel i is compared with sample channel i (Frasson Eq. 5.2). A relief layer may name an `appearance` instead: a depth is quilted per unified texture and per contour atlas and drawn through the appearance's own UVs (Frasson Sec. 5.4), so the depth never crosses a region border and a new target costs no synthesis.",
        ),
        prop(
            "guide_weight",
            Ty::Ref(&[Value::Map]),
            Default::Absent,
            "Where the guide counts (0 = not at all); default everywhere.",
        ),
        prop(
            "alpha",
            Ty::Number(Unit::Fraction, UNIT),
            Default::Text("0.5"),
            "With `guide`: E = alpha·overlap error + (1 − alpha)·guide error.",
        ),
        prop(
            "seams",
            Ty::Enum(SEAMS.names),
            Default::Text("keep"),
            "After quilting, `gradient` removes the block seams by a Poisson solve in a band around them.",
        ),
        prop(
            "seam_band",
            Ty::Pixels(Range { min: 1.0, max: 256.0 }),
            Default::Text("4 px"),
            "Half-width of the band solved by `seams = gradient`.",
        ),
        // Relief (Frasson Sec. 5.3.1).
        prop(
            "relief",
            Ty::Refs(&[Value::Patch]),
            Default::Absent,
            "Synthesise colour and depth together from these patches (samples with a `height`) under `guide`: each block comes from the patch nearest in mean CIELAB colour to the guide block, scored by `terms`. The layer's image is the colour; `view = height` writes the depth.",
        ),
        prop(
            "contour_relief",
            Ty::Refs(&[Value::Patch]),
            Default::Absent,
            "With `guide` an appearance: the patches its contour atlases (interstices and junctions) are quilted from, while `relief` serves its unified textures (Frasson Sec. 5.4: one patch per texture). Absent: `relief` serves all.",
        ),
        prop(
            "terms",
            Ty::Numbers(Unit::Plain, UNIT),
            Default::Text("[0.3, 0.5, 0.2]"),
            "Relief: the weights [α1, α2, α3] of E = α1·overlap colour error + α2·guide error + α3·overlap depth error, summing to 1; each term is a mean over its pixels.",
        ),
        prop(
            "depth_blur",
            Ty::Number(Unit::Length, Range { min: 0.0, max: 256.0 }),
            Default::Text("0 px"),
            "Relief: Gaussian σ softening the depth's block steps (0 = off).",
        ),
        // Blending (Welsman-Dinelle, after Pérez et al.).
        prop(
            "blend",
            Ty::Refs(&[Value::Image]),
            Default::Absent,
            "Blend these (same size): the first is the background, the mask selects the second. With more than two, the mask value v picks source round(v·(n − 1)).",
        ),
        prop(
            "mask",
            Ty::Ref(&[Value::Map]),
            Default::Absent,
            "Which source each pixel takes; must match the sources' size.",
        ),
        prop(
            "threshold",
            Ty::Number(Unit::Plain, UNIT),
            Default::Absent,
            "Binarise the mask at this cutoff (≥ cutoff selects the second source). Without it a two-source mask is soft: a weight per pixel.",
        ),
        prop(
            "mode",
            Ty::Enum(MODES.names),
            Default::Text("gradient"),
            "`gradient`: Poisson blend of the selected sources' gradients; `mixed`: the stronger gradient per edge; `average`: mean (soft: cross-fade) without a solve; `cut`: the hard composite.",
        ),
        prop(
            "topology",
            Ty::Enum(TOPOLOGIES.names),
            Default::Text("torus"),
            "`torus`: opposite edges are neighbours (tileable output); `rim`: the border is fixed to the background averaged over opposite sides; `open`: free border.",
        ),
        prop(
            "domain",
            Ty::Enum(DOMAINS.names),
            Default::Text("mask"),
            "Pixels solved for: where the mask selects a non-background source (the thesis), a band around mask edges, or every pixel.",
        ),
        prop(
            "band",
            Ty::Pixels(POSITIVE),
            Default::Text("8 px"),
            "Half-width of the band for `domain = band`.",
        ),
        prop(
            "seam",
            Ty::Enum(SEAM_GUIDANCE.names),
            Default::Text("insert"),
            "Guidance on edges between two sources: the inserted (higher) source's gradient, the mean of both, or zero.",
        ),
        prop("solver", Ty::Block(SOLVER), Default::Text("{}"), "Solver settings."),
    ],
};
