//! The built-in shader library as a declaration kind [references: bourque §5]: scenes that
//! render shaders, and bad parameters refused at their span.

mod common;

use common::Project;

fn scene(pattern: &str, extra: &str) -> String {
    format!(
        "scene {{\n  seed = 2\n  size = 48 x 32\n}}\n\nshader s {{\n  pattern = {pattern}\n{extra}}}\n\n\
         output \"s.png\" {{\n  from = s\n}}\n"
    )
}

#[test]
fn a_shader_renders_at_its_size_and_its_noise_follows_the_seed() {
    let p = Project::new(&[("scene.tess", &scene("clouds(cover = 0.6)", "  repeat = 2\n"))]);
    p.tessera(&["build", "scene.tess"]).ok();
    let img = image::open(p.path("out/scene/s.png")).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (48, 32));
    let first = p.read("out/scene/s.png");
    p.write("scene.tess", &scene("clouds(cover = 0.6)", "  repeat = 2\n").replace("seed = 2", "seed = 3"));
    p.tessera(&["build", "scene.tess"]).ok();
    assert_ne!(p.read("out/scene/s.png"), first, "the clouds are seeded by the scene");
    // A window of the texture further along is another picture; the same window is the same.
    p.write("scene.tess", &scene("clouds(cover = 0.6)", "  repeat = 2\n  origin = [0.5, 0]\n"));
    p.tessera(&["build", "scene.tess"]).ok();
    assert_ne!(p.read("out/scene/s.png"), first);
}

#[test]
fn bad_shader_parameters_are_diagnostics_at_their_span() {
    let cases: &[(&str, &str, &str, &str)] = &[
        // (pattern, extra properties, message, labelled text)
        ("bar(width = 1.5)", "", "1.5", "1.5"),
        ("bar(width = -0.1)", "", "-0.1", "-0.1"),
        ("star(points = 4.5)", "", "integer", "4.5"),
        ("star(points = 40)", "", "40", "40"),
        ("star(points = 1)", "", "points", "1"),
        ("circle(colour = [1, 0])", "", "three numbers `[r, g, b]`, not 2", "[1, 0]"),
        ("circle(colour = 0.5)", "", "colour", "0.5"),
        ("circle(colour = [1, 0, 2])", "", "2", "[1, 0, 2]"),
        ("circle(radius = 0.2, radius = 0.3)", "", "radius", "radius"),
        ("checker(size = 2)", "", "checker", "checker"),
        ("brick(widht = 0.2)", "", "widht", "widht"),
        ("weave(orientation = 270 deg)", "", "orientation", "270 deg"),
        ("cyclone(octaves = 1e300)", "", "1e300", "1e300"),
        ("bar()", "  repeat = 0\n", "repeat", "repeat = 0"),
        ("bar()", "  repeat = -2\n", "repeat", "repeat = -2"),
        ("bar()", "  size = 0 x 10\n", "size", "0 x 10"),
        ("bar()", "  size = 100000 x 100000\n", "whole numbers of pixels", "100000 x 100000"),
    ];
    for (pattern, extra, message, label) in cases {
        let p = Project::new(&[("scene.tess", &scene(pattern, extra))]);
        let err = p.refuses(message, label);
        assert!(!err.contains("panicked"), "{pattern}: {err}");
    }
}

#[test]
fn hostile_windows_build_or_are_refused_but_never_hang() {
    // Far origins and huge repeats: the star field, which visits neighbouring cells, stays
    // bounded when a pixel spans thousands of them.
    for extra in ["  repeat = 10000\n", "  origin = [1e8, -1e8]\n", "  repeat = 0.001\n"] {
        for pattern in ["starfield(density = 64, radius = 0.02)", "hextile(tileradius = 0.02)", "weave(frequency = 32)"]
        {
            let p = Project::new(&[("scene.tess", &scene(pattern, extra))]);
            let (run, took) =
                common::run_within(p.dir.path(), &["build", "scene.tess"], std::time::Duration::from_secs(60));
            assert!(took.as_secs() < 60, "{pattern} {extra}: took {took:?}");
            let err = run.stderr();
            assert!(!err.contains("panicked"), "{pattern} {extra}: {err}");
        }
    }
    let p = Project::new(&[("scene.tess", &scene("bar()", "  origin = [1e30, 0]\n"))]);
    p.refuses("region", "origin = [1e30, 0]");
}
