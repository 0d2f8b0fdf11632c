//! The `appearance` kind through the CLI ([references: frasson §4]): cached stages that never
//! re-run the structure, determinism across thread counts, and the diagnostics of bad input.

mod common;

use common::{ran, repo, Project};

const PHOTO: &str = "samples/standins/wall_random_photo.png";
const STRUCTURE: &str = "samples/standins/wall_random.json";

/// A project holding the painted random wall and a scene using it.
fn project(scene: &str) -> Project {
    let p = Project::new(&[("scene.tess", scene)]);
    for f in [PHOTO, STRUCTURE, "samples/photos/paving.png"] {
        p.write_bytes(f.rsplit('/').next().unwrap(), &std::fs::read(repo().join(f)).expect("sample"));
    }
    p
}

const SCENE: &str = r#"
scene {
  seed = 3
  size = 192 x 128
}

sample stones {
  image = "wall_random_photo.png"
  structure = "wall_random.json"
}

surface wall {
  plane = 192 x 128
}

structure layout {
  from = stones
  on = wall
  scale = 0.6
}

appearance dressed {
  from = stones
  on = layout
}

output "wall.png" {
  from = dressed
}

output "labels.png" {
  from = layout
}
"#;

#[test]
fn a_new_appearance_photo_reruns_the_appearance_stages_and_never_the_structure() {
    let p = project(SCENE);
    p.build_report(&["scene.tess"]).0.ok();
    // Another photo of the drawing's size: the same one with its red and blue swapped.
    let img = image_variant(&p.read("wall_random_photo.png"));
    p.write_bytes("wall_random_photo.png", &img);
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    let ran = ran(&stages);
    assert!(ran.iter().all(|l| !l.starts_with("structure ")), "structure stages re-ran: {ran:?}");
    for stage in ["(interiors)", "(contours)", "(dress)", "(render)"] {
        assert!(
            ran.iter().any(|l| l.starts_with("appearance dressed") && l.ends_with(stage)),
            "{stage} did not re-run: {ran:?}"
        );
    }
}

/// The photo with its red and blue channels swapped, re-encoded.
fn image_variant(bytes: &[u8]) -> Vec<u8> {
    let img = tessera::raster::io::decode(bytes).expect("png");
    let swapped = tessera::raster::Image::from_fn(img.width, img.height, 3, |x, y, c| img.get(x, y, 2 - c));
    tessera::raster::io::encode_png(&swapped, 8).expect("png")
}

#[test]
fn appearance_outputs_do_not_depend_on_the_thread_count() {
    let a = project(SCENE);
    let b = project(SCENE);
    a.tessera(&["-j", "1", "build", "scene.tess"]).ok();
    b.tessera(&["-j", "2", "build", "scene.tess"]).ok();
    assert_eq!(a.read("out/scene/wall.png"), b.read("out/scene/wall.png"));
}

#[test]
fn a_dressing_made_from_cached_analyses_equals_one_made_from_fresh_ones() {
    // Cold: the analyses and the dressing run in one build. Warm: the analyses are cached by
    // a build dressing the sample itself, then the structure is dressed from the cache. The
    // contours' coordinates must come back from the cache bit for bit.
    let cold = project(SCENE);
    cold.tessera(&["build", "scene.tess"]).ok();
    let warm = project(&SCENE.replace("  on = layout\n", "  on = stones\n"));
    warm.tessera(&["build", "scene.tess"]).ok();
    warm.write("scene.tess", SCENE);
    let (run, stages) = warm.build_report(&["scene.tess"]);
    run.ok();
    let ran = ran(&stages);
    assert!(ran.iter().any(|l| l == "appearance dressed (dress)"), "{ran:?}");
    assert!(!ran.iter().any(|l| l == "appearance dressed (contours)"), "{ran:?}");
    assert_eq!(cold.read("out/scene/wall.png"), warm.read("out/scene/wall.png"));
}

/// Builds `scene`, expecting a failure, and returns its diagnostics.
fn fails(scene: &str) -> String {
    let p = project(scene);
    let run = p.tessera(&["build", "scene.tess"]);
    assert_ne!(run.code(), 0, "expected a failure:\n{}", run.stderr());
    run.stderr()
}

#[test]
fn an_appearance_sample_without_a_structure_is_diagnosed_at_from() {
    let scene = SCENE.replace(
        "appearance dressed {\n  from = stones",
        "sample bare {\n  image = \"wall_random_photo.png\"\n}\n\nappearance dressed {\n  from = bare",
    );
    let err = fails(&scene);
    assert!(err.contains("has no `structure` drawn on its image"), "{err}");
    assert!(err.contains("from = bare"), "the diagnostic points at `from`: {err}");
}

#[test]
fn an_appearance_sample_without_an_image_is_diagnosed() {
    let scene = SCENE.replace(
        "appearance dressed {\n  from = stones",
        "sample drawing {\n  structure = \"wall_random.json\"\n}\n\nappearance dressed {\n  from = drawing",
    );
    let err = fails(&scene);
    assert!(err.contains("no image to take appearance from"), "{err}");
}

#[test]
fn an_image_whose_size_does_not_match_its_structure_is_diagnosed() {
    let scene = SCENE.replace("image = \"wall_random_photo.png\"", "image = \"paving.png\"");
    let err = fails(&scene);
    assert!(err.contains("is 576x576 but its structure is drawn on 512x384"), "{err}");
}

#[test]
fn cluster_counts_outside_one_to_ten_are_diagnosed() {
    for k in ["0", "11", "-2"] {
        let scene = SCENE.replace("  on = layout\n}", &format!("  on = layout\n  clusters = {k}\n}}"));
        let err = fails(&scene);
        assert!(err.contains("clusters"), "{k}: {err}");
    }
    let scene = SCENE.replace("  on = layout\n}", "  on = layout\n  clusters = 2\n}");
    project(&scene).tessera(&["build", "scene.tess"]).ok();
}

#[test]
fn an_alpha_map_of_the_wrong_size_is_diagnosed() {
    let scene = SCENE.replace("  on = layout\n}", "  on = layout\n  alpha = \"paving.png\"\n}");
    let err = fails(&scene);
    assert!(err.contains("the alpha map is 576x576 but the contours sample is 512x384"), "{err}");
}

#[test]
fn a_valency_missing_from_the_atlas_is_a_warning_with_the_fallback() {
    // The painted random wall's drawing has no vertex of valency 4; the wall regrown in the
    // example scene has one, which takes the nearest valency's star.
    let p = Project::copy_of_repo();
    let run = p.tessera(&["build", "scenes/textured_wall.tess"]);
    run.ok();
    let err = run.stderr();
    assert!(err.contains("1 vertices of valency 4: no atlas star of that valency, used valency 3"), "{err}");
}

#[test]
fn a_drawing_without_an_image_can_be_dressed_in_place() {
    let scene = SCENE.replace(
        "appearance dressed {\n  from = stones\n  on = layout",
        "sample drawing {\n  structure = \"wall_random.json\"\n}\n\nappearance dressed {\n  from = stones\n  on = drawing",
    );
    let p = project(&scene);
    p.tessera(&["build", "scene.tess"]).ok();
    let png = tessera::raster::io::decode(&p.read("out/scene/wall.png")).expect("png");
    assert_eq!((png.width, png.height, png.channels), (512, 384, 4));
}
