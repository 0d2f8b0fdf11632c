//! The schema of `appearance` declarations: the parameters of [references: frasson §4].

use crate::lang::schema::{Default, Extent, KindSpec, Naming, PropSpec, Range, Ty, Unit, Value};

/// `cluster_choice`: which unified texture a generated region takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ClusterChoice {
    ClosestShape,
    Random,
    Sticky,
}

/// `interstice.flip`: which end of a strip goes to which end of an edge.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Flip {
    Random,
    None,
    BestColor,
}

crate::choices!(pub CLUSTER_CHOICES: ClusterChoice {
    "closest_shape" => ClusterChoice::ClosestShape, "random" => ClusterChoice::Random,
    "sticky" => ClusterChoice::Sticky
});
crate::choices!(pub FLIPS: Flip { "random" => Flip::Random, "none" => Flip::None, "best_color" => Flip::BestColor });

/// The largest quilting block of the unified textures, px.
pub const BLOCK_MAX: f64 = 256.0;

const fn p(name: &'static str, ty: Ty, default: Default, doc: &'static str) -> PropSpec {
    PropSpec { name, ty, default, doc }
}

static INTERSTICE: &[PropSpec] = &[
    p(
        "half_width",
        Ty::Number(Unit::Length, Range { min: 0.5, max: 64.0 }),
        Default::Text("6 px"),
        "Half the width of an interstice strip (the mortar band and some stone on each side), 0.5 to 64 px.",
    ),
    p(
        "extension",
        Ty::Number(Unit::Length, Range { min: 0.0, max: 64.0 }),
        Default::Absent,
        "How far a strip reaches past each end of its edge, 0 to 64 px; default `half_width`.",
    ),
    p(
        "flip",
        Ty::Enum(FLIPS.names),
        Default::Text("random"),
        "Which way round a strip is laid: `random` (seeded), `none`, or `best_color` (the end whose colour matches the neighbouring junctions).",
    ),
];

static JUNCTION: &[PropSpec] = &[
    p(
        "branch_length",
        Ty::Number(Unit::Length, Range { min: 0.5, max: 256.0 }),
        Default::Absent,
        "Length of a star's branches, 0.5 to 256 px (capped at 45 % of the edge); default twice the interstice half-width.",
    ),
    p(
        "candidates",
        Ty::Int(1, 64),
        Default::Text("5"),
        "Nearest junctions by angles among which the colour heuristic picks, 1 to 64.",
    ),
];

pub static SPEC: KindSpec = KindSpec {
    name: "appearance",
    doc: "Structured appearance from example: the regions, interstices and junctions of a structure textured from a photo and its drawn structure.",
    naming: Naming::Ident,
    produces: &[Value::Image],
    settings: &[],
    extent: Extent::None,
    props: &[
        p(
            "from",
            Ty::Ref(&[Value::Example]),
            Default::Required,
            "The appearance sample: an `image` with the `structure` drawn on it. Region interiors come from it.",
        ),
        p(
            "contours",
            Ty::Ref(&[Value::Example]),
            Default::Absent,
            "Another sample to take interstices and junctions from; default `from`.",
        ),
        p(
            "on",
            Ty::Ref(&[Value::Structure, Value::Example]),
            Default::Absent,
            "What to dress: a synthesised structure, or a sample's own drawn structure; default `from`'s.",
        ),
        p(
            "clusters",
            Ty::Int(1, 10),
            Default::Absent,
            "Number of colour clusters of regions (one unified texture each), 1 to 10; default automatic (best silhouette, at most 10).",
        ),
        p(
            "cluster_choice",
            Ty::Enum(CLUSTER_CHOICES.names),
            Default::Text("closest_shape"),
            "A region's texture: its closest original's cluster (thesis), a seeded random cluster, or `sticky`: the cluster `keep_clusters` gives the region, so that editing the structure does not re-texture regions whose closest original changed (regions the table leaves out take their closest original's).",
        ),
        p(
            "keep_clusters",
            Ty::Path,
            Default::Absent,
            "With `cluster_choice = sticky`, required: a cluster table (JSON, region id → cluster) as an output of this appearance with `view = cluster_table` writes it. A table written for another number of clusters, or naming a cluster the appearance does not have, is an error.",
        ),
        p(
            "shrink",
            Ty::Number(Unit::Length, Range { min: 0.0, max: 64.0 }),
            Default::Text("2 px"),
            "Regions are cut out of the photo this far inside their outline, so no mortar gets in; 0 to 64 px, and some region must be wider than twice it.",
        ),
        p(
            "texture_size",
            Ty::Pixels(Range { min: 16.0, max: 2048.0 }),
            Default::Absent,
            "Side of each unified texture, 16 to 2048 px; default from the cluster's area (128 to 256 px). A texture is quilted in at most 64 × 64 blocks, so a large one needs a large `block`.",
        ),
        p(
            "block",
            Ty::Pixels(Range { min: 8.0, max: BLOCK_MAX }),
            Default::Text("24 px"),
            "Quilting block of the unified textures, 8 to 256 px (16 to 32 px suit most photos); halved for a cluster whose regions hold no block that large.",
        ),
        p(
            "alpha",
            Ty::Path,
            Default::Absent,
            "A painted alpha map of the `contours` sample (white = mortar, black = stone), its size, instead of the automatic one.",
        ),
        p("interstice", Ty::Block(INTERSTICE), Default::Text("{}"), "Interstices: one strip per edge."),
        p("junction", Ty::Block(JUNCTION), Default::Text("{}"), "Junctions: one star per vertex."),
        p(
            "match",
            Ty::Bool,
            Default::Text("true"),
            "Line junction and interstice textures up where they meet.",
        ),
        p(
            "resolution",
            Ty::Number(Unit::Plain, Range { min: 0.0625, max: 16.0 }),
            Default::Text("1"),
            "Rendered pixels per structure pixel, 0.0625 to 16; the render is held to the memory budget.",
        ),
        p("seed", Ty::Int(0, 1 << 53), Default::Absent, "An explicit seed instead of the one derived from the scene's."),
    ],
};
