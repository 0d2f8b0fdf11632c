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
    project_with(scene, &["gravel.png", "grass.png"])
}

/// A project holding `scene` and these photos of `samples/photos` under `photos/`.
fn project_with(scene: &str, photos: &[&str]) -> Project {
    let p = Project::new(&[]);
    for f in photos {
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
    // So far out that f64 keeps no fraction of the finest band's cells.
    let p = project(&base.replace("  zoom = 8\n", "  zoom = 8\n  origin = [1e30, 0]\n"));
    p.refuses("no precision left", "origin = [1e30, 0]");
    let p = project(&(base.clone() + "\nlayer grown {\n  quilt = gravel\n  zoom = 2\n}\n"));
    p.refuses("applies only to layers evaluated from a procedural texture", "zoom = 2");
    let p = project(&base.replace("  band_gain = [1, 1, 2.5", "  correct_slice = true\n  band_gain = [1, 1, 2.5"));
    p.refuses("applies only to the solid texture", "correct_slice = true");
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
fn a_corrected_slice_is_another_picture_and_takes_gains_and_morphs() {
    // The scene's slice refits its solid weights; without the correction it is the plain slice.
    let p = project(&scene());
    p.tessera(&["build", "scene.tess"]).ok();
    let corrected = p.read("out/scene/slice.png");
    p.write("scene.tess", &scene().replace("  correct_slice = true\n", ""));
    p.tessera(&["build", "scene.tess"]).ok();
    assert_ne!(p.read("out/scene/slice.png"), corrected);
    // A corrected slice with band gains, morphed into grass by the ramp.
    let morphing =
        "layer morphing {\n  procedural = gravel_fit\n  morph = grass_fit\n  morph_by = ramp\n  on = strip\n}";
    let solid = "layer morphing {\n  procedural = gravel_fit\n  morph = grass_fit\n  morph_by = ramp\n  on = strip\n  \
                 solid = true\n  correct_slice = true\n  band_gain = [1, 1, 2]\n}";
    assert!(scene().contains(morphing));
    p.write("scene.tess", &scene().replace(morphing, solid));
    p.tessera(&["build", "scene.tess"]).ok();
    let morph = image::open(p.path("out/scene/morph.png")).unwrap().to_rgb8();
    assert_eq!(morph.dimensions(), (512, 128));
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

/// A small scene: a fit of the gravel photo and one layer under test, 32² so each case is quick.
fn hostile_scene(procedural: &str, layer: &str) -> String {
    format!(
        "scene {{\n  seed = 3\n  size = 32 x 32\n}}\n\nsample gravel {{\n  image = \"photos/gravel.png\"\n}}\n\n\
         procedural fit {{\n  from = gravel\n  histogram = on\n{procedural}}}\n\n\
         layer under_test {{\n{layer}}}\n\noutput \"out.png\" {{\n  from = under_test\n}}\n"
    )
}

#[test]
fn hostile_numbers_in_noise_and_tiling_properties_build_or_are_diagnostics() {
    // Every new property at 0, negative, tiny, huge and overflowing (which the language refuses
    // for every number), and at the extremes it lets through (which reach the algorithms): the
    // build either succeeds or exits 1 with a diagnostic that names the property, never a panic
    // or a hang.
    let reals = [
        "0", "-1", "1e-300", "1e300", "1e999", "-1e300", "1e-30", "-1e-30", "0.0001", "0.001", "0.999999", "1000",
        "1000000", "1e30", "3e38", "-3e38",
    ];
    let mut cases: Vec<(String, String, &str)> = Vec::new();
    for v in reals {
        let noise = |extra: String| ("".to_string(), format!("  procedural = fit\n{extra}"));
        for (prop, line) in [
            ("zoom", format!("  zoom = {v}\n")),
            ("origin", format!("  origin = [{v}, 0]\n")),
            ("origin", format!("  origin = [0, {v}]\n")),
            ("band_gain", format!("  band_gain = [1, {v}]\n")),
            ("slice", format!("  solid = true\n  slice = {v}\n")),
            ("slice", format!("  solid = true\n  correct_slice = true\n  slice = {v}\n")),
        ] {
            let (p, l) = noise(line);
            cases.push((p, l, prop));
        }
        for (prop, line) in [
            ("cell", format!("  cell = {v}\n")),
            ("contrast", format!("  grid = hex\n  contrast = {v}\n")),
            ("cell_rotation", format!("  cell_rotation = {v} deg\n")),
        ] {
            cases.push(("".to_string(), format!("  tiling = gravel\n{line}"), prop));
        }
    }
    for v in ["0", "-1", "1", "3", "257", "1000000", "99999999999999999999"] {
        cases.push((format!("  knots = {v}\n"), "  procedural = fit\n".to_string(), "knots"));
        cases.push((format!("  tile = {v}\n"), "  procedural = fit\n".to_string(), "tile"));
    }
    let (mut built, mut refused) = (0, 0);
    for (procedural, layer, prop) in &cases {
        let p = project(&hostile_scene(procedural, layer));
        let run = p.tessera(&["build", "scene.tess"]);
        let err = run.stderr();
        assert!(!err.contains("panicked"), "{prop} in\n{procedural}{layer}:\n{err}");
        match run.code() {
            0 => built += 1,
            1 => {
                assert!(err.contains(prop), "the diagnostic names `{prop}` for\n{procedural}{layer}:\n{err}");
                assert!(!p.path("out/scene").exists(), "nothing is written");
                refused += 1;
            }
            code => panic!("exit {code} for {prop} in\n{procedural}{layer}:\n{err}"),
        }
    }
    eprintln!("{} hostile cases: {built} built, {refused} refused with a diagnostic", cases.len());
}

/// Every number of a parameter file, in order.
fn numbers(p: &Procedural) -> Vec<f64> {
    let mut all: Vec<f64> = p.mean.iter().chain(p.u.iter().flatten()).copied().collect();
    for c in &p.channels {
        all.extend(&c.weights);
        if let Some(curve) = &c.curve {
            all.extend(curve.knots.iter().chain([&curve.min, &curve.max]));
        }
    }
    all
}

#[test]
fn sixteen_bit_png_and_exr_samples_fit_like_the_8_bit_photo_and_layers_write_exr() {
    // The same gravel as a 16-bit PNG (each 8-bit value v stored as 257·v, the same fraction of
    // full scale) and as a linear-light EXR (the photo's sRGB values decoded to linear): all three
    // are one image once the sample has read them, so all three fit the same texture.
    let p = project(&scene());
    p.tessera(&["build", "scene.tess"]).ok();
    let eight = Procedural::from_toml(&p.read_text("out/scene/gravel_fit.toml")).expect("8-bit fit");
    let one = tessera::raster::io::decode(&p.read("out/scene/one.png")).expect("PNG output");
    let photo = image::open(repo().join("samples/photos/gravel.png")).unwrap().to_rgb8();
    let (w, h) = (photo.width() as usize, photo.height() as usize);
    let encoded =
        tessera::raster::Image::from_fn(w, h, 3, |x, y, c| photo.get_pixel(x as u32, y as u32)[c] as f32 / 255.0);
    let sixteen = tessera::raster::io::encode_png(&encoded, 16).expect("16-bit PNG");
    assert_eq!(tessera::raster::io::png_bit_depth(&sixteen), Some(16));
    let linear = tessera::raster::color::image_srgb_to_linear(&encoded);
    let exr = tessera::raster::io::encode_exr(&linear).expect("EXR");
    for (file, bytes) in [("photos/gravel16.png", sixteen), ("photos/gravel.exr", exr)] {
        p.write_bytes(file, &bytes);
        let text = scene().replace("photos/gravel.png", file).replace("output \"one.png\"", "output \"one.exr\"");
        p.write("scene.tess", &text);
        p.tessera(&["build", "scene.tess"]).ok();
        let fitted = Procedural::from_toml(&p.read_text("out/scene/gravel_fit.toml")).expect("fit");
        assert_eq!(fitted.sample_size, eight.sample_size, "{file}");
        let (a, b) = (numbers(&eight), numbers(&fitted));
        assert_eq!(a.len(), b.len(), "{file}");
        let worst = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
        eprintln!("{file}: largest parameter difference from the 8-bit fit {worst:.2e}");
        assert!(worst < 1e-4, "{file}: parameters differ by up to {worst}");
        // The 1× layer as EXR: linear light, the same picture as the PNG once encoded.
        let out = tessera::raster::io::decode(&p.read("out/scene/one.exr")).expect("EXR output");
        assert_eq!((out.width, out.height, out.channels), (128, 128, 3));
        let shown = tessera::raster::color::image_linear_to_srgb(&out);
        let off = shown.data.iter().zip(&one.data).map(|(a, b)| (a - b).abs()).fold(0f32, f32::max);
        assert!(off <= 1.5 / 255.0, "{file}: the EXR layer differs from the 8-bit PNG one by {off}");
    }
}

#[test]
fn a_masked_fit_takes_one_region_class_and_a_bad_mask_is_a_diagnostic() {
    let regions = std::fs::read_to_string(repo().join("scenes/noise_regions.tess"))
        .expect("scene")
        .replace("../samples/photos/", "photos/");
    let with = |scene: &str| project_with(scene, &["paving.png"]);
    let p = with(&regions);
    let run = p.tessera(&["build", "scene.tess"]);
    run.ok();
    // The whole photo is cropped to 512² (and warned about); the stones' mask is not a crop.
    assert!(run.stderr().contains("procedural whole: the sample is 576 x 576"), "{}", run.stderr());
    assert!(!run.stderr().contains("procedural granite: the sample"), "{}", run.stderr());
    let granite = Procedural::from_toml(&p.read_text("out/scene/granite.toml")).unwrap();
    // The setts hold a 32² square at most: four bands, their grey mean (blue well above the
    // mossy whole's).
    assert_eq!(granite.sample_size, 32);
    assert_eq!(granite.channels[0].weights.len(), 4);
    assert!(granite.mean[2] > 0.5, "{:?}", granite.mean);

    // Each edit of the scene, the message and the span it is refused at.
    for (from, to, message, span) in [
        // A mask is an analysis option: a parameter file is already fitted.
        (
            "  from = paving\n  mask = setts\n",
            "  params = \"granite.toml\"\n  mask = setts\n",
            "`mask` is an analysis option",
            "mask = setts",
        ),
        (
            "  from = paving\n  mask = joints\n",
            "  params = \"granite.toml\"\n",
            "`mask_spectrum` is an analysis option",
            "mask_spectrum = masked",
        ),
        // Hardly any pixel is that blue: no 16² square for the setts' spectrum (the joints,
        // measured by the masked periodogram, still fit).
        ("  threshold = 0.42\n", "  threshold = 0.9\n", "no 16 x 16 square", "mask = setts"),
        // The masked periodogram needs a mask.
        ("  mask = joints\n", "", "applies only to a fit with a `mask`", "mask_spectrum = masked"),
        // An orientation field is no mask.
        ("channel = b)", "channel = vector)", "must be scalar", "mask = setts"),
    ] {
        with(&regions.replace(from, to)).refuses(message, span);
    }
}
