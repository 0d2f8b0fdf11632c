//! The schema of `structure` declarations : the parameters of [references: frasson §3].

use crate::lang::schema::{
    CallSpec, Default, Extent, KindSpec, Naming, PropSpec, Range, Ty, Unit, Value, ANY, POSITIVE, UNIT,
};

/// `mode`: how region shapes are drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Statistical,
    Trivial,
}

/// `layout`: whether a layered sample regrows course by course.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Layout {
    Auto,
    Courses,
    Statistical,
}

/// `centers`: where generators are placed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Centers {
    Uniform,
    Histogram,
}

/// `size_mode`: how the size map sets region sizes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SizeModeChoice {
    Scale,
    Fixed,
}

/// A two-way choice named by the property it belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Either {
    First,
    Second,
}

/// `metric`: the distance Lloyd's regions are grown with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MetricChoice {
    Elliptic,
    Manhattan,
    Chebyshev,
}

crate::choices!(pub MODES: Mode { "statistical" => Mode::Statistical, "trivial" => Mode::Trivial });
crate::choices!(pub LAYOUTS: Layout {
    "auto" => Layout::Auto, "courses" => Layout::Courses, "statistical" => Layout::Statistical
});
crate::choices!(pub CENTERS: Centers { "uniform" => Centers::Uniform, "histogram" => Centers::Histogram });
crate::choices!(
    /// `independent`: axes and angle drawn apart; `joint`: (axes, angle) triples together.
    pub SHAPE_SAMPLING: Either { "independent" => Either::First, "joint" => Either::Second }
);
crate::choices!(pub SIZE_MODES: SizeModeChoice { "scale" => SizeModeChoice::Scale, "fixed" => SizeModeChoice::Fixed });
crate::choices!(pub ORIENTATION_MODES: Either { "region" => Either::First, "center" => Either::Second });
crate::choices!(pub METRICS: MetricChoice {
    "elliptic" => MetricChoice::Elliptic, "manhattan" => MetricChoice::Manhattan, "chebyshev" => MetricChoice::Chebyshev
});
crate::choices!(pub OCCUPANCY_REMOVE: Either { "center" => Either::First, "any_overlap" => Either::Second });
crate::choices!(pub ELLIPSE_FITS: Either { "polygon" => Either::First, "pixels" => Either::Second });

const fn p(name: &'static str, ty: Ty, default: Default, doc: &'static str) -> PropSpec {
    PropSpec { name, ty, default, doc }
}

static LLOYD: &[PropSpec] = &[
    p("iterations", Ty::Int(0, 10_000), Default::Text("50"), "Most Lloyd iterations."),
    p(
        "tolerance",
        Ty::Number(Unit::Length, POSITIVE),
        Default::Text("0.25 px"),
        "Stop when the mean generator displacement of an iteration falls below this.",
    ),
    p(
        "rotate",
        Ty::Bool,
        Default::Text("false"),
        "Also turn each ellipse to its region's fitted angle (axis lengths never change).",
    ),
    p(
        "resolution",
        Ty::Number(Unit::Fraction, Range { min: 0.05, max: 1.0 }),
        Default::Text("1"),
        "Run the iterations on a raster this fraction of the target's size; the final labels are at full size.",
    ),
];

static POLYGONIZE: &[PropSpec] = &[
    p(
        "tolerance",
        Ty::Number(Unit::Length, POSITIVE),
        Default::Text("1 px"),
        "Douglas–Peucker tolerance for the boundary chains.",
    ),
    p("min_edge", Ty::Number(Unit::Length, POSITIVE), Default::Text("2 px"), "Shorter edges are collapsed."),
    p(
        "straight",
        Ty::Number(Unit::Angle, Range { min: 0.0, max: std::f64::consts::PI }),
        Default::Text("5 deg"),
        "Valency-2 vertices turning less than this are dropped.",
    ),
];

static SHAPES: &[PropSpec] = &[
    p("enabled", Ty::Bool, Default::Text("true"), "Run stage 2: move vertices towards the closest original shapes."),
    p("iterations", Ty::Int(0, 10_000), Default::Text("50"), "Most optimisation sweeps."),
    p(
        "step",
        Ty::Number(Unit::Fraction, UNIT),
        Default::Text("20%"),
        "Fraction of the mean displacement applied per sweep.",
    ),
    p(
        "area_tolerance",
        Ty::Number(Unit::Fraction, UNIT),
        Default::Text("20%"),
        "An associated original's area must be within this of its region's (widened in 10 % steps to 50 % if needed).",
    ),
    p("allow_rotation", Ty::Bool, Default::Text("true"), "Rotate originals to fit; `false` keeps their orientation."),
    p(
        "ellipse_weight",
        Ty::Number(Unit::Plain, Range { min: 0.0, max: 1000.0 }),
        Default::Text("8"),
        "Weight of the mismatch between a region's generator ellipse and an original's fitted ellipse in the association cost, beside the turning distance (0: the turning distance alone, as in the thesis).",
    ),
    p("reassociate", Ty::Int(1, 10_000), Default::Text("10"), "Recompute the associations every this many sweeps."),
    p(
        "tolerance",
        Ty::Number(Unit::Plain, ANY),
        Default::Text("0.05"),
        "Stop when the mean turning distance falls below this.",
    ),
];

static EDITS: &[CallSpec] = &[
    CallSpec {
        name: "insert",
        doc: "Adds a region: an ellipse at a position (Lloyd then makes room for it).",
        args: &[
            p("at", Ty::Vec2(Unit::Length), Default::Required, "Centre in pixels."),
            p("a", Ty::Number(Unit::Length, POSITIVE), Default::Required, "Semi-major axis."),
            p("b", Ty::Number(Unit::Length, POSITIVE), Default::Required, "Semi-minor axis."),
            p("angle", Ty::Number(Unit::Angle, ANY), Default::Text("0 deg"), "Major-axis angle."),
        ],
    },
    CallSpec {
        name: "delete",
        doc: "Removes a region, by id or the one nearest a point.",
        args: &[
            p("id", Ty::Int(0, 1 << 31), Default::Absent, "Region id (as in the label outputs)."),
            p("at", Ty::Vec2(Unit::Length), Default::Absent, "Remove the generator nearest this point."),
        ],
    },
    CallSpec {
        name: "freeze",
        doc: "Keeps a region's generator where it is during Lloyd.",
        args: &[p("id", Ty::Int(0, 1 << 31), Default::Required, "Region id.")],
    },
    CallSpec {
        name: "move",
        doc: "Moves a region (delete + insert with the same ellipse).",
        args: &[
            p("id", Ty::Int(0, 1 << 31), Default::Required, "Region id."),
            p("to", Ty::Vec2(Unit::Length), Default::Required, "New centre in pixels."),
        ],
    },
    CallSpec {
        name: "set",
        doc: "Changes a region's ellipse.",
        args: &[
            p("id", Ty::Int(0, 1 << 31), Default::Required, "Region id."),
            p("a", Ty::Number(Unit::Length, POSITIVE), Default::Absent, "New semi-major axis."),
            p("b", Ty::Number(Unit::Length, POSITIVE), Default::Absent, "New semi-minor axis."),
            p("angle", Ty::Number(Unit::Angle, ANY), Default::Absent, "New angle."),
        ],
    },
];

pub static SPEC: KindSpec = KindSpec {
    name: "structure",
    doc: "A synthesised planar subdivision (stones, cells, scales) grown from a sample's drawn structure onto a surface, steered by control maps.",
    naming: Naming::Ident,
    produces: &[Value::Structure],
    settings: &[],
    extent: Extent::Ref("on"),
    props: &[
        p("from", Ty::Ref(&[Value::Example]), Default::Required, "The sample whose `structure` file is analysed."),
        p("on", Ty::Ref(&[Value::Plane]), Default::Required, "The target surface; its occupancy map forbids regions."),
        p(
            "mode",
            Ty::Enum(MODES.names),
            Default::Text("statistical"),
            "`statistical`: sample new ellipses from the statistics; `trivial`: perturb and swap the sample's own regions.",
        ),
        p(
            "layout",
            Ty::Enum(LAYOUTS.names),
            Default::Text("auto"),
            "`courses`: regrow the sample course by course (course heights, brick lengths and head-joint stagger drawn from the sample's; no Lloyd, no shape optimisation; the density, size and orientation maps do not steer it, edits relax the bricks with Lloyd) — an error if the sample has no courses; `statistical`: never, `mode` decides; `auto`: courses when the analysis finds the sample layered and `mode = statistical`.",
        ),
        p("scale", Ty::Number(Unit::Plain, POSITIVE), Default::Text("1"), "Linear size of regions relative to the sample."),
        p(
            "centers",
            Ty::Enum(CENTERS.names),
            Default::Text("uniform"),
            "Where initial generators go: `uniform` over the allowed pixels, drawn in proportion to the `density` map's weight when there is one (so the map places regions from the start, not only through Lloyd); `histogram`: from the sample's centre histogram, its box mapped onto the target.",
        ),
        p(
            "shape_sampling",
            Ty::Enum(SHAPE_SAMPLING.names),
            Default::Text("independent"),
            "`independent`: axes and angle from separate histograms (the thesis); `joint`: whole (a, b, θ) triples with jitter.",
        ),
        p("perturb", Ty::Number(Unit::Length, ANY), Default::Text("0 px"), "Trivial mode: noise on generator centres (std. dev.)."),
        p("swaps", Ty::Number(Unit::Fraction, UNIT), Default::Text("0%"), "Trivial mode: fraction of regions swapped at random."),
        p("density", Ty::Ref(&[Value::Map]), Default::Absent, "Density map: dark pixels weigh more in centroids."),
        p("density_eps", Ty::Number(Unit::Plain, UNIT), Default::Text("0.01"), "Smallest density weight."),
        p("density_gamma", Ty::Number(Unit::Plain, POSITIVE), Default::Text("1"), "Exponent of the density weight."),
        p("size", Ty::Ref(&[Value::Map]), Default::Absent, "Size map: darker means smaller regions."),
        p(
            "size_mode",
            Ty::Enum(SIZE_MODES.names),
            Default::Text("scale"),
            "`scale`: ellipses shrink with the size map down to `size_min` at black; `fixed`: inside its dark half (< 0.5) every ellipse gets the mean radius `size_fixed`, keeping its aspect ratio.",
        ),
        p("size_min", Ty::Number(Unit::Fraction, UNIT), Default::Text("0.3"), "`scale` mode: size factor at black in the size map."),
        p(
            "size_fixed",
            Ty::Number(Unit::Length, POSITIVE),
            Default::Text("6 px"),
            "`fixed` mode: mean radius `√(ab)` of the ellipses in the marked area.",
        ),
        p("orientation", Ty::Ref(&[Value::Map]), Default::Absent, "Orientation field (2-channel map) turning the ellipses."),
        p(
            "orientation_mode",
            Ty::Enum(ORIENTATION_MODES.names),
            Default::Text("region"),
            "Angle from the axial mean over the region, or sampled at its centre.",
        ),
        p(
            "metric",
            Ty::Enum(METRICS.names),
            Default::Text("elliptic"),
            "Distance used by the Voronoi step, on `(u/a, v/b)` in each ellipse's frame: `elliptic` (the thesis's, rounded cells), `manhattan` (L1: Lloyd makes square tiles turned 45° from the ellipse axes), `chebyshev` (L∞).",
        ),
        p(
            "metric_map",
            Ty::Ref(&[Value::Map]),
            Default::Absent,
            "Per-pixel metric: values below 1/3 elliptic, below 2/3 Manhattan, else Chebyshev.",
        ),
        p(
            "occupancy_remove",
            Ty::Enum(OCCUPANCY_REMOVE.names),
            Default::Text("center"),
            "Which sampled ellipses the occupancy map removes.",
        ),
        p(
            "ellipse_fit",
            Ty::Enum(ELLIPSE_FITS.names),
            Default::Text("polygon"),
            "Fit ellipses to the sample's regions by polygon moments or by their pixels.",
        ),
        p(
            "exclude_border_regions",
            Ty::Bool,
            Default::Text("true"),
            "Leave regions cut by the sample's border out of the statistics.",
        ),
        p("lloyd", Ty::Block(LLOYD), Default::Text("{}"), "Anisotropic Lloyd relaxation."),
        p("polygonize", Ty::Block(POLYGONIZE), Default::Text("{}"), "Label raster → polygon mesh."),
        p("shapes", Ty::Block(SHAPES), Default::Text("{}"), "Stage 2: shape optimisation."),
        p("edits", Ty::Calls(EDITS), Default::Text("[]"), "Edits applied to the generators before Lloyd runs again."),
        p("seed", Ty::Int(0, 1 << 53), Default::Absent, "An explicit seed instead of the one derived from the scene's."),
    ],
};
