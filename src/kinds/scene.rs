//! `scene { seed size }`: settings shared by every declaration.

use crate::lang::schema::{Default, Extent, KindSpec, Naming, PropSpec, Setting, Ty};

pub static SPEC: KindSpec = KindSpec {
    name: "scene",
    doc: "Scene-wide settings. At most one per scene (imports included).",
    naming: Naming::Anonymous,
    produces: &[],
    settings: &[(Setting::Seed, "seed"), (Setting::Size, "size")],
    extent: Extent::Scene,
    props: &[
        PropSpec {
            name: "seed",
            ty: Ty::Int(0, 1 << 53),
            default: Default::Text("0"),
            doc: "Seed of every random stream; each declaration derives its own stream from it and its name.",
        },
        PropSpec {
            name: "size",
            ty: Ty::Size,
            default: Default::Text("256 x 256"),
            doc: "Default size in pixels of maps and surfaces.",
        },
    ],
};

/// The scene kind: settings only, read by the language when it resolves the scene.
pub struct Scene;

impl super::Kind for Scene {
    fn spec(&self) -> &'static KindSpec {
        &SPEC
    }

    fn plan(
        &self,
        _p: &mut super::Planner,
        _d: &crate::lang::Decl,
    ) -> Result<Option<crate::graph::AnyHandle>, crate::lang::Diagnostic> {
        Ok(None)
    }
}
