//! Sticky clusters through the CLI ([references: frasson §4.1.3]): an appearance's cluster
//! table exported with `view = cluster_table`, pinned with `cluster_choice = sticky` and
//! `keep_clusters`, keeps every region's texture across an edit of the dressed drawing, so
//! only the regions near the edit change; and the diagnostics of a sticky choice without its
//! table, of a table that is missing, malformed or written for other clusters.

mod common;

use std::collections::{BTreeMap, BTreeSet};

use common::{repo, Project};
use tessera::synth::structure::analysis::labels_import::rasterize_polygons;
use tessera::synth::structure::analysis::sample::{analyse_sample, SampleStructure};
use tessera::synth::structure::analysis::stats::StatsConfig;
use tessera::synth::structure::NO_REGION;

const PHOTO: &str = "samples/standins/wall_random_photo.png";
const STRUCTURE: &str = "samples/standins/wall_random.json";
/// The hand-drawn target: the regular wall's drawing.
const TARGET: &str = "samples/standins/wall_regular.json";

/// The edit: this vertex of the target's file, moved by this much (px). Under the
/// closest-shape rule it changes the cluster of a region it bounds (checked below).
const EDIT_VERTEX: usize = 99;
const EDIT_BY: [f64; 2] = [0.0, 4.0];

const SCENE: &str = r#"
scene {
  seed = 3
  size = 512 x 384
}

sample stones {
  image = "wall_random_photo.png"
  structure = "wall_random.json"
}

sample target {
  structure = "target.json"
}

appearance dressed {
  from = stones
  on = target
  CHOICE
}

output "wall.png" {
  from = dressed
  view = albedo
}

output "clusters.json" {
  from = dressed
  view = cluster_table
}
"#;

fn scene(choice: &str) -> String {
    SCENE.replace("CHOICE", choice)
}

/// A project with the painted random wall and the target drawing.
fn project(scene: &str) -> Project {
    let p = Project::new(&[("scene.tess", scene)]);
    for f in [PHOTO, STRUCTURE] {
        p.write_bytes(f.rsplit('/').next().unwrap(), &std::fs::read(repo().join(f)).expect("sample"));
    }
    p.write_bytes("target.json", &std::fs::read(repo().join(TARGET)).expect("target"));
    p
}

/// The target's file with one vertex moved.
fn edited_target(v: usize, by: [f64; 2]) -> String {
    let text = std::fs::read_to_string(repo().join(TARGET)).expect("target");
    let mut json: serde_json::Value = serde_json::from_str(&text).expect("json");
    let p = &mut json["vertices"][v];
    for c in 0..2 {
        p[c] = serde_json::json!(p[c].as_f64().expect("coordinate") + by[c]);
    }
    serde_json::to_string_pretty(&json).expect("json")
}

/// A cluster table as region id → cluster.
fn table(bytes: &[u8]) -> BTreeMap<usize, usize> {
    let json: serde_json::Value = serde_json::from_slice(bytes).expect("a cluster table is JSON");
    json["regions"]
        .as_object()
        .expect("regions")
        .iter()
        .map(|(k, v)| (k.parse().expect("region id"), v.as_u64().expect("cluster") as usize))
        .collect()
}

fn analysed(text: &str) -> SampleStructure {
    analyse_sample(text, &StatsConfig::default()).expect("the target analyses")
}

/// The regions whose outline differs between two analyses of the same drawing.
fn moved_regions(a: &SampleStructure, b: &SampleStructure) -> BTreeSet<usize> {
    assert_eq!(a.polygons.len(), b.polygons.len(), "the edit keeps the regions");
    (0..a.polygons.len()).filter(|&r| a.polygons[r] != b.polygons[r]).collect()
}

/// `rs` and the regions sharing an edge with one of them.
fn grow_ring(s: &SampleStructure, rs: &BTreeSet<usize>) -> BTreeSet<usize> {
    let edges_of = |r: usize| -> BTreeSet<[usize; 2]> {
        let c = &s.mesh.regions[r];
        (0..c.len()).map(|i| [c[i].min(c[(i + 1) % c.len()]), c[i].max(c[(i + 1) % c.len()])]).collect()
    };
    let ring: BTreeSet<[usize; 2]> = rs.iter().flat_map(|&r| edges_of(r)).collect();
    (0..s.mesh.regions.len()).filter(|&r| rs.contains(&r) || !edges_of(r).is_disjoint(&ring)).collect()
}

/// The regions (of either drawing, by pixel centre) under a pixel that differs.
fn regions_under_changes(a: &[u8], b: &[u8], before: &SampleStructure, after: &SampleStructure) -> BTreeSet<usize> {
    let (a, b) = (tessera::raster::io::decode(a).expect("png"), tessera::raster::io::decode(b).expect("png"));
    assert_eq!((a.width, a.height), (b.width, b.height));
    let la = rasterize_polygons(&before.polygons, a.width, a.height);
    let lb = rasterize_polygons(&after.polygons, a.width, a.height);
    let n = a.width * a.height;
    let mut out = BTreeSet::new();
    for i in 0..n {
        if (0..a.channels).any(|c| a.data[c * n + i] != b.data[c * n + i]) {
            out.extend([la.data[i], lb.data[i]].into_iter().filter(|&id| id != NO_REGION).map(|id| id as usize));
        }
    }
    out
}

#[test]
fn a_pinned_cluster_table_keeps_the_appearance_of_regions_away_from_an_edit() {
    // Before the edit, closest shapes: the exported table and the render.
    let p = project(&scene("cluster_choice = closest_shape"));
    p.tessera(&["build", "scene.tess"]).ok();
    let pinned = p.read("out/scene/clusters.json");
    let before_table = table(&pinned);
    let before_png = p.read("out/scene/wall.png");
    let original = std::fs::read_to_string(repo().join(TARGET)).expect("target");
    let before = analysed(&original);
    assert_eq!(before_table.len(), before.polygons.len(), "every region is in the table");
    p.write_bytes("keep.json", &pinned);

    // The edit, under closest shapes: some region near it changes cluster.
    let text = edited_target(EDIT_VERTEX, EDIT_BY);
    p.write("target.json", &text);
    let after = analysed(&text);
    let ring1 = moved_regions(&before, &after);
    let ring2 = grow_ring(&before, &ring1);
    p.tessera(&["build", "scene.tess"]).ok();
    let free = table(&p.read("out/scene/clusters.json"));
    let reclustered: BTreeSet<usize> = free.iter().filter(|(r, c)| before_table[r] != **c).map(|(r, _)| *r).collect();
    let free_png = p.read("out/scene/wall.png");
    let free_changed = regions_under_changes(&before_png, &free_png, &before, &after);

    // The same edit with the table pinned.
    p.write("scene.tess", &scene("cluster_choice = sticky\n  keep_clusters = \"keep.json\""));
    p.tessera(&["build", "scene.tess"]).ok();
    let kept = table(&p.read("out/scene/clusters.json"));
    let kept_png = p.read("out/scene/wall.png");
    let kept_changed = regions_under_changes(&before_png, &kept_png, &before, &after);
    eprintln!(
        "sticky through the CLI: {} regions; the edit moves {ring1:?}, ring 2 holds {}; closest shape re-clusters \
         {reclustered:?} and changes pixels in {} regions; sticky changes pixels in {} regions {kept_changed:?}",
        before.polygons.len(),
        ring2.len(),
        free_changed.len(),
        kept_changed.len()
    );
    assert!(!reclustered.is_empty(), "the edit changes no closest-shape cluster: it tests nothing");
    assert_eq!(kept, before_table, "sticky keeps every region's cluster");
    assert!(!kept_changed.is_empty() && kept_changed.is_subset(&ring2), "{kept_changed:?} beyond {ring2:?}");
}

// ---- diagnostics -------------------------------------------------------------------------------

/// Builds `scene` with `extra` files, expecting a failure; its diagnostics.
fn fails(scene: &str, extra: &[(&str, &str)]) -> String {
    let p = project(scene);
    for (name, text) in extra {
        p.write(name, text);
    }
    let run = p.tessera(&["build", "scene.tess"]);
    run.failed();
    assert!(!p.path("out").exists(), "a failed build wrote outputs");
    run.stderr()
}

#[test]
fn sticky_without_a_table_is_diagnosed_at_cluster_choice() {
    let err = fails(&scene("cluster_choice = sticky"), &[]);
    insta::assert_snapshot!("sticky_without_table", err);
    assert!(err.contains("cluster_choice = sticky"), "{err}");
}

#[test]
fn a_table_without_sticky_is_diagnosed_at_keep_clusters() {
    let err = fails(&scene("keep_clusters = \"keep.json\""), &[("keep.json", r#"{ "regions": {} }"#)]);
    insta::assert_snapshot!("sticky_table_without_sticky", err);
}

#[test]
fn a_missing_table_is_diagnosed_at_its_name() {
    let err = fails(&scene("cluster_choice = sticky\n  keep_clusters = \"nope.json\""), &[]);
    insta::assert_snapshot!("sticky_missing_table", err);
}

#[test]
fn a_malformed_table_is_diagnosed_at_its_name() {
    for (name, text) in [
        ("sticky_malformed_table", r#"{ "regions": { "3": "two" } }"#),
        ("sticky_table_bad_region_id", r#"{ "regions": { "03": 1 } }"#),
    ] {
        let err = fails(&scene("cluster_choice = sticky\n  keep_clusters = \"keep.json\""), &[("keep.json", text)]);
        insta::assert_snapshot!(name, err);
    }
}

#[test]
fn a_table_for_other_clusters_is_an_error_at_its_name() {
    let sticky = "clusters = 2\n  cluster_choice = sticky\n  keep_clusters = \"keep.json\"";
    for (name, text) in [
        ("sticky_cluster_past_the_last", r#"{ "regions": { "0": 1, "5": 2 } }"#),
        ("sticky_table_of_another_count", r#"{ "clusters": 3, "regions": { "0": 1 } }"#),
    ] {
        let err = fails(&scene(sticky), &[("keep.json", text)]);
        insta::assert_snapshot!(name, err);
    }
    // The same scene with a table that fits builds; an entry for a region the drawing does
    // not have is a warning.
    let p = project(&scene(sticky));
    p.write("keep.json", r#"{ "clusters": 2, "regions": { "0": 1, "5": 0, "5000": 1 } }"#);
    let run = p.tessera(&["build", "scene.tess"]);
    run.ok();
    let err = run.stderr();
    assert!(
        err.contains("the cluster table names 1 regions the dressed structure does not have (it has 100)"),
        "{err}"
    );
    let t = table(&p.read("out/scene/clusters.json"));
    assert_eq!((t[&0], t[&5]), (1, 0));
    assert!(!t.contains_key(&5000));
}
