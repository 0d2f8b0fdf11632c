//! Models through the CLI [references: frasson §5.3.2]: a relief layer displacing a mesh
//! surface, rendered, written as OBJ and glTF; the mesh checks and their diagnostics.

mod common;

use common::{flat, repo, Project};
use tessera::synth::mesh::{edge_uses, read_obj};

fn project(scene: &str) -> Project {
    let p = Project::new(&[]);
    common::copy_dir(&repo().join("samples/relief/brick_foliage"), &p.path("bf"));
    common::copy_dir(&repo().join("samples/meshes"), &p.path("meshes"));
    p.write("scene.tess", scene);
    p
}

fn column() -> String {
    std::fs::read_to_string(repo().join("scenes/relief_column.tess"))
        .expect("scene")
        .replace("../samples/relief/brick_foliage/", "bf/")
        .replace("../samples/meshes/", "meshes/")
}

#[test]
fn the_column_is_displaced_zipped_drawn_and_exported() {
    let p = project(&column());
    p.tessera(&["build", "scene.tess"]).ok();
    // The displaced mesh is closed but for the column's open foot.
    let obj = read_obj(&p.read("out/scene/pillar.obj")).expect("the OBJ reads back");
    let polys: Vec<&[u32]> = obj.faces.iter().map(|f| f.positions.as_slice()).collect();
    let uses = edge_uses(polys);
    let mut border = 0;
    for (&(a, b), &n) in &uses {
        assert!(n <= 2, "edge {a}-{b} used {n} times");
        if n == 1 {
            border += 1;
            let (pa, pb) = (obj.positions[a as usize], obj.positions[b as usize]);
            assert!(pa.y.abs() < 0.1 && pb.y.abs() < 0.1, "a border edge off the foot: {pa} {pb}");
        }
    }
    assert!(border >= 12, "the foot is the border");
    // Two lights, two different pictures of one model.
    let (a, b) = (p.read("out/scene/pillar_morning.png"), p.read("out/scene/pillar_evening.png"));
    assert_ne!(a, b);
    // glTF binary: magic and version.
    let glb = p.read("out/scene/pillar.glb");
    assert_eq!(&glb[0..4], b"glTF");
    assert_eq!(u32::from_le_bytes([glb[4], glb[5], glb[6], glb[7]]), 2);
    // Moving the light re-runs the render only.
    p.write("scene.tess", &column().replace("tilt = 60 deg, slant = 50 deg", "tilt = 90 deg, slant = 50 deg"));
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    assert_eq!(common::ran(&stages), ["output pillar_morning.png"]);
}

const CUBE_HEAD: &str =
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n";

fn mesh_scene(obj: &str) -> Project {
    let p = project(&column().replace("meshes/column.obj", "meshes/bad.obj"));
    p.write("meshes/bad.obj", obj);
    p
}

#[test]
fn bad_meshes_are_diagnostics_at_the_mesh() {
    // No UVs.
    let p = mesh_scene("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n");
    let err = p.refuses("face 0 (line 4): 3 corners but 0 texture coordinates", "mesh = \"meshes/bad.obj\"");
    assert!(flat(&err).contains("unwrap the mesh"), "{err}");
    // Three faces on one edge.
    let p = mesh_scene(&format!("{CUBE_HEAD}f 1/1 2/2 3/3\nf 2/1 1/2 5/3\nf 1/1 2/2 8/3\n"));
    p.refuses("used by 3 faces", "mesh = \"meshes/bad.obj\"");
    // A face whose UVs enclose no area.
    let p = mesh_scene(&format!("{CUBE_HEAD}f 1/1 2/2 3/2\n"));
    p.refuses("face 0 (line 13): its texture coordinates enclose no area", "mesh = \"meshes/bad.obj\"");
    // Not an OBJ at all.
    let p = mesh_scene("\u{0}\u{1}garbage\nf x y z\n");
    p.refuses("the mesh is not usable", "mesh = \"meshes/bad.obj\"");
}

#[test]
fn models_refuse_what_they_cannot_be() {
    // A plane surface.
    let p = project(&column().replace("  mesh = \"meshes/column.obj\"\n", ""));
    p.refuses("surface `column` is a plane, not a mesh", "a mesh surface is needed here");
    // A layer that is not a relief.
    let p = project(&column().replace("  relief = relief\n  scale", "  relief = wall\n  scale"));
    p.refuses("`wall` is not a relief layer", "relief = wall");
    // An export extension tessera does not write.
    let p = project(&column().replace("pillar.glb", "pillar.fbx"));
    p.refuses("tessera cannot write `.fbx` files", "\"pillar.fbx\"");
    // Camera properties on an output of something that is not a model.
    let p = project(&format!("{}\noutput \"flat.png\" {{\n  from = relief\n  shadows = true\n}}\n", column()));
    p.refuses("`shadows` applies to renders of a model, not to a layer", "shadows = true");
    // Hostile numbers at their property.
    for (from, to, at) in [
        ("scale = 0.06", "scale = 1e300", "1e300"),
        ("scale = 0.06", "scale = nan", "nan"),
        ("azimuth = 20 deg", "azimuth = 1e400 deg", "1e400"),
        ("elevation = 15 deg", "elevation = 120 deg", "120 deg"),
        ("resolution = 320 x 320", "resolution = 0 x 320", "0 x 320"),
        ("subdiv = 16", "subdiv = 16\n  seam_reach = -1", "-1"),
        ("subdiv = 16", "subdiv = 16\n  seam_overlap = 150 %", "150 %"),
        ("subdiv = 16", "subdiv = 16\n  seam_feather = 99", "99"),
        ("subdiv = 16", "subdiv = 16\n  seam_reach = nan", "nan"),
        ("subdiv = 16", "subdiv = 16\n  seam_overlap = inf", "inf"),
        ("subdiv = 16", "subdiv = 16\n  seam_feather = -1", "-1"),
    ] {
        let p = project(&column().replacen(from, to, 1));
        let run = p.tessera(&["build", "scene.tess"]);
        run.failed();
        assert!(run.stderr().contains(at), "{to}:\n{}", run.stderr());
        assert!(!run.stderr().contains("panicked"), "{}", run.stderr());
    }
}

#[test]
fn seams_are_textured_from_their_faces_at_any_setting() {
    let p = project(&column());
    p.tessera(&["build", "scene.tess"]).ok();
    // The strips' vertices are the faces' seam-edge vertices again, with seam-texture UVs: more
    // texture coordinates than positions, positions still shared.
    let obj = String::from_utf8(p.read("out/scene/pillar.obj")).unwrap();
    let (v, vt) =
        (obj.lines().filter(|l| l.starts_with("v ")).count(), obj.lines().filter(|l| l.starts_with("vt ")).count());
    assert!(vt > v, "{vt} texture coordinates for {v} positions");
    // Editing the seam texture settings re-runs the model and its outputs, not the relief.
    p.write("scene.tess", &column().replace("subdiv = 16", "subdiv = 16\n  seam_feather = 0"));
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    let ran = common::ran(&stages);
    assert!(ran.contains(&"model pillar".to_string()) && !ran.iter().any(|s| s.starts_with("layer")), "{ran:?}");
    // The extremes of every setting build.
    for extra in [
        "seam_reach = 0\n  seam_overlap = 0 %\n  seam_feather = 0",
        "seam_reach = 10\n  seam_overlap = 100 %\n  seam_feather = 16",
    ] {
        let p = project(&column().replace("subdiv = 16", &format!("subdiv = 16\n  {extra}")));
        p.tessera(&["build", "scene.tess"]).ok();
    }
}

#[test]
fn a_scale_that_folds_the_surface_is_a_warning() {
    let p = project(&column().replace("scale = 0.06", "scale = -40"));
    let run = p.tessera(&["build", "scene.tess"]);
    run.ok();
    assert!(flat(&run.stderr()).contains("the surface intersects itself"), "{}", run.stderr());
}
