//! Relief layers through the CLI [references: frasson §5.3.1]: F31 on the Biot wall stand-in's
//! files, the mask layer, the patch checks and their diagnostics, and what an edit re-runs.

mod common;

use common::{flat, repo, Project};
use tessera::raster::{self, Image};
use tessera::synth::relief::fixtures::{self, class};
use tessera::synth::relief::side_share;

fn project(body: &str) -> Project {
    let p = Project::new(&[]);
    common::copy_dir(&repo().join("samples/relief/brick_foliage"), &p.path("bf"));
    p.write("scene.tess", &format!("scene {{\n  seed = 4\n  size = 256 x 192\n}}\n\n{body}"));
    p
}

const PATCHES: &str = "sample wall {\n  image = \"bf/wall.png\"\n}\n\n\
    sample bricks {\n  image = \"bf/patch_bricks.png\"\n  height = \"bf/patch_bricks_height.png\"\n}\n\n\
    sample foliage {\n  image = \"bf/patch_foliage.png\"\n  height = \"bf/patch_foliage_height.png\"\n}\n\n";

fn relief(extra: &str) -> String {
    format!(
        "{PATCHES}layer relief {{\n  relief = [bricks, foliage]\n  guide = wall\n  block = 16 px\n  overlap = 3 px\n{extra}}}\n\n\
         output \"colour.png\" {{\n  from = relief\n}}\n\n\
         output \"height.png\" {{\n  from = relief\n  view = height\n  format = png16\n}}\n"
    )
}

fn decode(bytes: &[u8]) -> Image {
    raster::io::decode(bytes).expect("decodes")
}

#[test]
fn f31_through_the_cli_puts_mortar_down_and_foliage_up() {
    let p = project(&relief(""));
    p.tessera(&["build", "scene.tess"]).ok();
    let depth = decode(&p.read("out/scene/height.png"));
    assert_eq!((depth.width, depth.height, depth.channels), (256, 192, 1));
    let truth = fixtures::brick_foliage(11);
    let share = |k: u8, above: bool| side_share(&depth, |i| truth.class[i] == k, 0.5, above).unwrap();
    let (mortar, foliage) = (share(class::MORTAR, false), share(class::FOLIAGE, true));
    println!("CLI F31: mortar below 0.5 on {:.1} %, foliage above on {:.1} %", 100.0 * mortar, 100.0 * foliage);
    assert!(mortar >= 0.9 && foliage >= 0.9);
    // The colour is the patches' colour, in their space (sRGB PNG in, sRGB PNG out).
    let colour = decode(&p.read("out/scene/colour.png"));
    assert_eq!((colour.width, colour.height, colour.channels), (256, 192, 3));
}

#[test]
fn the_depth_blur_reruns_only_the_depth() {
    let p = project(&relief(""));
    p.tessera(&["build", "scene.tess"]).ok();
    p.write(
        "scene.tess",
        &format!("scene {{\n  seed = 4\n  size = 256 x 192\n}}\n\n{}", relief("  depth_blur = 2 px\n")),
    );
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    let ran = common::ran(&stages);
    assert_eq!(ran, ["layer relief (depth)", "output height.png"], "no new search");
}

#[test]
fn masked_pixels_never_steer_the_choice() {
    // A patch whose bright square is masked: whatever the square holds, every block comes from
    // the same place (the index view is identical).
    let index_with = |value: f32| {
        let p = project("");
        let mut colour = decode(&p.read("bf/patch_bricks.png"));
        for y in 30..60 {
            for x in 20..50 {
                for c in 0..3 {
                    colour.set(x, y, c, value);
                }
            }
        }
        p.write_bytes("bf/patch_bricks.png", &common::png(&colour));
        let mask = Image::from_fn(100, 100, 1, |x, y, _| f32::from((20..50).contains(&x) && (30..60).contains(&y)));
        p.write_bytes("bf/mask.png", &common::png(&mask));
        let body = relief("").replace(
            "height = \"bf/patch_bricks_height.png\"\n",
            "height = \"bf/patch_bricks_height.png\"\n  mask = \"bf/mask.png\"\n",
        ) + "\noutput \"index.png\" {\n  from = relief\n  view = index\n}\n";
        p.write("scene.tess", &format!("scene {{\n  seed = 4\n  size = 256 x 192\n}}\n\n{body}"));
        p.tessera(&["build", "scene.tess"]).ok();
        p.read("out/scene/index.png")
    };
    assert_eq!(index_with(1.0), index_with(0.0));
}

#[test]
fn patch_layers_of_different_sizes_are_refused_at_the_layer() {
    let p = project(&relief(""));
    p.write_bytes("bf/small.png", &common::png(&Image::filled(90, 100, 1, 0.5)));
    p.write("scene.tess", &p.read_text("scene.tess").replace("bf/patch_bricks_height.png", "bf/small.png"));
    let err = p.refuses("the height layer is 90x100 but the colour image is 100x100", "\"bf/small.png\"");
    assert!(flat(&err).contains("pixel-aligned"), "{err}");
    // A mask of another size, likewise at the mask.
    let p = project(&relief("").replace(
        "height = \"bf/patch_bricks_height.png\"\n",
        "height = \"bf/patch_bricks_height.png\"\n  mask = \"bf/small.png\"\n",
    ));
    p.write_bytes("bf/small.png", &common::png(&Image::filled(90, 100, 1, 0.5)));
    p.refuses("the mask layer is 90x100", "mask = \"bf/small.png\"");
}

#[test]
fn relief_inputs_that_are_not_patches_are_diagnostics() {
    // A sample without a height.
    let p = project(&relief("").replace("relief = [bricks, foliage]", "relief = [bricks, wall]"));
    p.refuses("`wall` is not a patch: it has no height layer", "relief = [bricks, wall]");
    // A mask without a height, a height without an image.
    let p = project(&format!("{PATCHES}sample odd {{\n  image = \"bf/wall.png\"\n  mask = \"bf/wall.png\"\n}}\n"));
    p.refuses("sample `odd` has a mask layer but no `height`", "mask = \"bf/wall.png\"");
    let p = project("sample odd {\n  height = \"bf/wall_height.png\"\n}\n");
    p.refuses("sample `odd` has a height layer but no `image`", "height = \"bf/wall_height.png\"");
    // No guide.
    let p = project(&relief("").replace("  guide = wall\n", ""));
    p.refuses("relief layer `relief` has no `guide`", "relief = [bricks, foliage]");
    // A guide of another size than the layer.
    let p = project(&relief("").replace("size = 256 x 192", "size = 128 x 96"));
    p.write("scene.tess", &p.read_text("scene.tess").replace("size = 256 x 192", "size = 128 x 96"));
    p.refuses("256x192", "guide = wall");
}

#[test]
fn hostile_relief_numbers_are_refused_at_their_property() {
    for (extra, message, at) in [
        ("  terms = [0.3, 0.5, 0.3]\n", "sum to 1.1", "terms = [0.3, 0.5, 0.3]"),
        ("  terms = [0.5, 0.5]\n", "the three weights", "terms = [0.5, 0.5]"),
        ("  terms = [-0.2, 0.6, 0.6]\n", "", "-0.2"),
        ("  terms = [1e300, 0, 0]\n", "", "1e300"),
        ("  depth_blur = -1 px\n", "", "-1 px"),
        ("  depth_blur = 1e9 px\n", "", "1e9 px"),
        ("  tolerance = -1\n", "", "-1"),
        ("  mix = wall\n", "`mix` is not a property of relief layers", "mix = wall"),
    ] {
        let p = project(&relief(extra));
        let run = p.tessera(&["build", "scene.tess"]);
        run.failed();
        let err = run.stderr();
        assert!(flat(&err).contains(message), "{extra}: expected `{message}` in\n{err}");
        assert!(err.contains(at), "{extra}: expected the label on `{at}`:\n{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    // A block larger than the patches.
    let p = project(&relief("").replace("block = 16 px", "block = 128 px").replace("overlap = 3 px", "overlap = 8 px"));
    p.refuses("", "block = 128 px");
    // Every numeric edge that is valid builds: terms all on depth, a zero-overlap block.
    let p = project(&relief("  terms = [0, 0, 1]\n"));
    p.tessera(&["build", "scene.tess"]).ok();
}

#[test]
fn relief_properties_on_a_quilted_layer_are_refused() {
    for (prop, at) in [("terms", "terms = [0.3, 0.5, 0.2]"), ("depth_blur", "depth_blur = 2 px")] {
        let p = project(&format!(
            "{PATCHES}layer q {{\n  quilt = bricks\n  {at}\n}}\n\noutput \"q.png\" {{\n  from = q\n}}\n"
        ));
        p.refuses(&format!("`{prop}` applies only to relief layers"), at);
    }
}
