//! Procedural textures by example through the CLI [references: lagae §7]: a photo fitted once,
//! its parameter file written and read back, layers evaluated from it, what re-runs on an edit,
//! and the diagnostics of bad input.

mod common;

use common::{repo, Project};
use tessera::synth::noise::params::Procedural;

fn scene() -> String {
    std::fs::read_to_string(repo().join("scenes/noise_gravel.tess"))
        .expect("scene")
        .replace("../samples/photos/", "photos/")
}

fn project(scene: &str) -> Project {
    let p = Project::new(&[]);
    for f in ["gravel.png", "grass.png"] {
        std::fs::create_dir_all(p.path("photos")).unwrap();
        std::fs::copy(repo().join("samples/photos").join(f), p.path("photos").join(f)).unwrap();
    }
    p.write("scene.tess", scene);
    p
}

#[test]
fn a_photo_is_fitted_once_and_its_parameter_file_reads_back_as_the_same_texture() {
    let p = project(&scene());
    p.tessera(&["build", "scene.tess"]).ok();
    // 160² photo → its centred 128² square: bands 2..7, 10 knots per curve.
    let text = p.read_text("out/scene/gravel_fit.toml");
    let params = Procedural::from_toml(&text).expect("the file reads back");
    assert_eq!(params.sample_size, 128);
    assert_eq!(params.count(), 3 + 9 + 3 * 6 + 3 * 10);
    assert!(text.len() < 2048, "{} bytes", text.len());
    // Read back, under the same layer name (so the same noise seed), the file gives the same
    // pixels as the fit it came from.
    let wide = p.read("out/scene/wide.png");
    std::fs::copy(p.path("out/scene/gravel_fit.toml"), p.path("gravel.toml")).unwrap();
    let from_file = scene().replace("  from = gravel\n  histogram = on\n", "  params = \"gravel.toml\"\n");
    p.write("scene.tess", &from_file);
    p.tessera(&["build", "scene.tess"]).ok();
    assert_eq!(p.read("out/scene/wide.png"), wide);
}

#[test]
fn an_evaluation_edit_never_re_runs_the_analysis() {
    let p = project(&scene());
    p.tessera(&["build", "scene.tess"]).ok();
    p.write("scene.tess", &scene().replace("band_gain = [1, 1, 2.5, 1, 0.5, 0.5]", "band_gain = [1, 1, 1, 3]"));
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    assert_eq!(common::ran(&stages), ["layer coarse", "output coarse.png"]);
    // An analysis option re-runs that texture's fit and what reads it, not the other's.
    p.write("scene.tess", &scene().replacen("  histogram = on\n", "  histogram = on\n  estimator = nnls\n", 1));
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    let ran = common::ran(&stages);
    assert!(ran.contains(&"procedural gravel_fit".to_string()), "{ran:?}");
    assert!(!ran.contains(&"procedural grass_fit".to_string()), "{ran:?}");
}

#[test]
fn bad_procedural_input_is_a_diagnostic_at_its_span() {
    let base = scene();
    let p = project(&base.replace("  from = gravel\n  histogram = on\n", "  from = gravel\n  tile = 9\n"));
    p.refuses("the side must be even", "tile = 9");
    let p = project(&base.replace("band_gain = [1, 1, 2.5, 1, 0.5, 0.5]", "band_gain = [1, 1, 1, 1, 1, 1, 1, 1, 1]"));
    p.refuses("9 band gains for a texture of 6 bands", "band_gain = [1, 1, 1, 1, 1, 1, 1, 1, 1]");
    let p = project(&base.replace("  morph_by = ramp\n", ""));
    p.refuses("`morph` needs `morph_by`", "morph = grass_fit");
    let p = project(&base.replace("  zoom = 8\n", "  zoom = 0\n"));
    let run = p.tessera(&["build", "scene.tess"]);
    run.failed();
    assert!(run.stderr().contains("zoom = 0"), "{}", run.stderr());
    let p = project(&(base.clone() + "\nlayer grown {\n  quilt = gravel\n  zoom = 2\n}\n"));
    p.refuses("applies only to layers evaluated from a procedural texture", "zoom = 2");
    // A sample too small to have three bands.
    let p = project(&base);
    let tiny = tessera::raster::Image::filled(12, 12, 3, 0.4);
    p.write_bytes("photos/gravel.png", &common::png(&tiny));
    p.refuses("smaller than 16", "from = gravel");
    // A parameter file that is not one.
    let p = project(&base.replace("  from = gravel\n  histogram = on\n", "  params = \"broken.toml\"\n"));
    p.write("broken.toml", "noise_version = 1\nseed = \"x\"\n");
    let run = p.tessera(&["build", "scene.tess"]);
    run.failed();
    assert!(run.stderr().contains("parameter file"), "{}", run.stderr());
    // A parameter file from a newer tessera: a good file but for its version.
    let p = project(&base);
    p.tessera(&["build", "scene.tess"]).ok();
    let newer = p.read_text("out/scene/gravel_fit.toml").replacen("noise_version = 1", "noise_version = 99", 1);
    let p = project(&base.replace("  from = gravel\n  histogram = on\n", "  params = \"newer.toml\"\n"));
    p.write("newer.toml", &newer);
    p.refuses("noise_version 99", "params = \"newer.toml\"");
    // Curves on different abscissae have no knot-by-knot morph.
    let quantile = base.replacen("  histogram = on\n", "  histogram = on\n  abscissa = quantile\n", 1);
    let p = project(&quantile);
    p.refuses("abscissa", "morph = grass_fit");
}

#[test]
fn a_morph_between_textures_fitted_at_different_sizes_builds() {
    // Gravel fitted from 128² (bands 2..7), grass from its centred 64² with 5 knots (bands
    // 2..6): the in-between looks pad grass's missing finest band with zero and resample its
    // curves; the two ends are each texture.
    let p = project(
        &scene().replace("  from = grass\n  histogram = on\n", "  from = grass\n  histogram = on\n  knots = 5\n"),
    );
    let grass = image::open(repo().join("samples/photos/grass.png")).unwrap().to_rgb32f();
    let small = tessera::raster::Image::from_fn(64, 64, 3, |x, y, c| grass.get_pixel(x as u32 + 48, y as u32 + 48)[c]);
    p.write_bytes("photos/grass.png", &common::png(&small));
    let run = p.tessera(&["build", "scene.tess"]);
    run.ok();
    let morph = image::open(p.path("out/scene/morph.png")).unwrap().to_rgb8();
    assert_eq!(morph.dimensions(), (512, 128));
}

#[test]
fn an_anisotropic_sample_is_warned_about() {
    // Brick courses are anything but isotropic.
    let p = project(
        &scene()
            .replace("image = \"photos/gravel.png\"", "image = \"photos/brick.png\"")
            .replace("image = \"photos/grass.png\"", "image = \"photos/brick.png\""),
    );
    std::fs::copy(repo().join("samples/photos/brick.png"), p.path("photos/brick.png")).unwrap();
    let run = p.tessera(&["build", "scene.tess"]);
    run.ok();
    assert!(run.stderr().contains("not isotropic"), "{}", run.stderr());
}
