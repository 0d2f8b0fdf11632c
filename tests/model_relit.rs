//! Relightable surfaces on meshes through the CLI [references: dong §7.3]: a representation
//! (or a layer quilted from one) laid on a model and relit by the renderer fragment by
//! fragment, each light turned into the fragment's tangent frame.

mod common;

use common::{repo, Project};
use tessera::raster::{decode, Image};

fn project(scene: &str) -> Project {
    let p = Project::new(&[]);
    common::copy_dir(&repo().join("samples/capture/cobbles"), &p.path("cobbles"));
    common::copy_dir(&repo().join("samples/relief/brick_foliage"), &p.path("bf"));
    common::copy_dir(&repo().join("samples/meshes"), &p.path("meshes"));
    p.write("scene.tess", scene);
    p
}

fn relit_column() -> String {
    std::fs::read_to_string(repo().join("scenes/relit_column.tess"))
        .expect("scene")
        .replace("../samples/capture/cobbles/", "cobbles/")
        .replace("../samples/meshes/", "meshes/")
}

fn image(p: &Project, rel: &str) -> Image {
    decode(&p.read(rel)).expect("a png")
}

/// Mean luminance of the pixels that are not the background, in the left and right thirds of
/// the column's extent.
fn sides(img: &Image) -> (f32, f32) {
    let bg = [img.get(0, 0, 0), img.get(0, 0, 1), img.get(0, 0, 2)];
    let on = |x: usize, y: usize| (0..3).any(|c| (img.get(x, y, c) - bg[c]).abs() > 1e-3);
    let xs: Vec<usize> = (0..img.width).filter(|&x| (0..img.height).any(|y| on(x, y))).collect();
    let (lo, hi) = (xs[0], xs[xs.len() - 1]);
    let third = (hi - lo) / 3;
    let mean = |range: std::ops::Range<usize>| {
        let (mut sum, mut n) = (0.0, 0);
        for x in range {
            for y in 0..img.height {
                if on(x, y) {
                    sum += (0..3).map(|c| img.get(x, y, c)).sum::<f32>() / 3.0;
                    n += 1;
                }
            }
        }
        sum / n.max(1) as f32
    };
    (mean(lo..lo + third), mean(hi - third..hi + 1))
}

#[test]
fn a_relit_column_turns_each_light_into_each_fragments_frame() {
    let p = project(&relit_column());
    p.tessera(&["build", "scene.tess"]).ok();
    let (morning, evening) = (image(&p, "out/scene/pillar_morning.png"), image(&p, "out/scene/pillar_evening.png"));
    // The morning light comes from the camera's right, the evening light from its left: the
    // side facing the light is the brighter one, in each picture.
    let (ml, mr) = sides(&morning);
    let (el, er) = sides(&evening);
    assert!(mr > 1.15 * ml, "morning: left {ml}, right {mr}");
    assert!(el > 1.15 * er, "evening: left {el}, right {er}");
    let glb = p.read("out/scene/pillar.glb");
    assert_eq!(&glb[0..4], b"glTF");
    // Moving the light re-runs the render only: the relightable surface is not grown again.
    p.write("scene.tess", &relit_column().replace("tilt = 60 deg, slant = 50 deg", "tilt = 90 deg, slant = 50 deg"));
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    assert_eq!(common::ran(&stages), ["output pillar_morning.png"]);
}

#[test]
fn every_method_relights_on_a_mesh() {
    // The representation itself (96², not quilted) on the column, for each basis; Eigen's
    // coefficients exist only between its captured slants, so the lights are clamped there.
    for method in ["three_i", "ptm", "eigen"] {
        let scene = relit_column()
            .replace("method = gradient", &format!("method = {method}"))
            .replace("relit = grown", "relit = rock");
        let p = project(&scene);
        p.tessera(&["build", "scene.tess"]).ok();
        let img = image(&p, "out/scene/pillar_morning.png");
        assert!(img.data.iter().all(|v| v.is_finite()));
        let (l, r) = sides(&img);
        assert!(r > 1.15 * l && l > 0.05, "{method}: left {l}, right {r}");
    }
}

#[test]
fn a_relit_relief_keeps_the_relief_geometry() {
    // The relief column with the grown cobbles as its relightable surface: the relightable
    // maps ride in the colour's layout, so the displaced mesh (and its UVs) is the relief's.
    let relief = std::fs::read_to_string(repo().join("scenes/relief_column.tess"))
        .expect("scene")
        .replace("../samples/relief/brick_foliage/", "bf/")
        .replace("../samples/meshes/", "meshes/");
    let extra = "\nsample cobbles {\n  capture = \"cobbles/cobbles.lp\"\n}\n\nrepresentation rock {\n  from = cobbles\n}\n\nlayer grown {\n  quilt = rock\n  on = column\n  block = 32 px\n  overlap = 8 px\n}\n";
    let p = project(&relief);
    p.tessera(&["build", "scene.tess"]).ok();
    let (obj, png) = (p.read("out/scene/pillar.obj"), p.read("out/scene/pillar_morning.png"));
    p.write(
        "scene.tess",
        &format!(
            "{}{extra}",
            relief.replace("  relief = relief\n  scale", "  relief = relief\n  relit = grown\n  scale")
        ),
    );
    p.tessera(&["build", "scene.tess"]).ok();
    assert_eq!(p.read("out/scene/pillar.obj"), obj, "the geometry is the relief's");
    assert_ne!(p.read("out/scene/pillar_morning.png"), png, "the renders shade the cobbles");
}

#[test]
fn relit_takes_a_relightable_surface_only() {
    let scene =
        relit_column().replace("relit = grown", "relit = plain") + "\nsample plain {\n  image = \"bf/wall.png\"\n}\n";
    let p = project(&scene);
    p.refuses("`plain` is not relightable", "relit = plain");
    // Without `relit`, a model still needs its texture and depth.
    let p = project(&relit_column().replace("  relit = grown\n", ""));
    p.refuses("needs `relief`, or `texture` and `height`, or `relit`", "model pillar");
}
