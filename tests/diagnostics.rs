//! Every class of bad input gives a diagnostic with a span and, where one exists, a
//! suggestion; exit code 1; no panic; nothing written.

mod common;

use common::Project;

/// Builds `scene.tess` (plus extra files) and snapshots the diagnostic.
fn diagnose(name: &str, scene: &str, extra: &[(&str, &[u8])]) -> String {
    let err = common::failed_build(name, scene, extra);
    insta::assert_snapshot!(name, err);
    err
}

#[test]
fn syntax_error() {
    diagnose("syntax", "map a {\n  from = constant(1\n}\n", &[]);
}

#[test]
fn unknown_kind_with_suggestion() {
    let e = diagnose("unknown_kind", "mapp a { from = constant(1) }\n", &[]);
    assert!(e.contains("did you mean `map`?"));
}

#[test]
fn unknown_property_with_suggestion() {
    let e = diagnose("unknown_property", "map a {\n  from = constant(1)\n  invertt = true\n}\n", &[]);
    assert!(e.contains("did you mean `invert`?"));
}

#[test]
fn unknown_constructor_argument() {
    let e = diagnose("unknown_argument", "map a { from = radial(centre = [1, 2]) }\n", &[]);
    assert!(e.contains("did you mean `center`?"));
}

#[test]
fn unknown_name_with_suggestion() {
    let e = diagnose("unknown_name", "map density { from = constant(1) }\noutput \"a.png\" { from = densty }\n", &[]);
    assert!(e.contains("did you mean `density`?"));
}

#[test]
fn wrong_kind() {
    diagnose(
        "wrong_kind",
        "surface s {}\nmap m { from = constant(1) }\nsurface t { occupancy = s }\noutput \"m.png\" { from = m }\n",
        &[],
    );
}

#[test]
fn duplicate_name() {
    diagnose("duplicate_name", "map a { from = constant(1) }\nmap a { from = constant(2) }\n", &[]);
}

#[test]
fn duplicate_property() {
    diagnose("duplicate_property", "map a {\n  from = constant(1)\n  blur = 1\n  blur = 2\n}\n", &[]);
}

#[test]
fn import_cycle() {
    let p = Project::new(&[
        ("scene.tess", "import \"_a.tess\"\n"),
        ("_a.tess", "import \"_b.tess\"\n"),
        ("_b.tess", "import \"_a.tess\"\n"),
    ]);
    let run = p.tessera(&["build", "scene.tess"]);
    run.failed();
    insta::assert_snapshot!("import_cycle", run.stderr());
}

#[test]
fn missing_import() {
    diagnose("missing_import", "import \"nowhere.tess\"\n", &[]);
}

#[test]
fn reference_cycle() {
    diagnose(
        "reference_cycle",
        "map a { from = b }\nmap b { from = combine(a = c, b = c) }\nmap c { from = a }\noutput \"a.png\" { from = a }\n",
        &[],
    );
}

#[test]
fn type_mismatch() {
    diagnose("type_mismatch", "map a {\n  from = constant(1)\n  size = \"big\"\n}\n", &[]);
}

#[test]
fn wrong_unit() {
    let e = diagnose("wrong_unit", "map a {\n  from = constant(1)\n  blur = 3 deg\n}\n", &[]);
    assert!(e.contains("px"));
}

#[test]
fn out_of_range() {
    diagnose("out_of_range", "map a { from = noise(octaves = 40) }\n", &[]);
}

#[test]
fn unknown_enum_with_suggestion() {
    let e = diagnose("unknown_enum", "map a { from = noise(kind = gradiant) }\n", &[]);
    assert!(e.contains("did you mean `gradient`?"));
}

#[test]
fn missing_required_property() {
    diagnose("missing_required", "map a { blur = 1 }\n", &[]);
}

#[test]
fn unknown_set_param() {
    let p = Project::new(&[("scene.tess", "param scale = 1\n")]);
    let run = p.tessera(&["build", "--set", "sacle=2", "scene.tess"]);
    run.failed();
    assert!(run.stderr().contains("did you mean `scale`?"), "{}", run.stderr());
}

#[test]
fn missing_image_file() {
    diagnose("missing_file", "sample s { image = \"nope.png\" }\noutput \"s.png\" { from = s }\n", &[]);
}

#[test]
fn corrupt_png() {
    let mut png = tessera::raster::io::encode_png(&tessera::raster::Image::filled(32, 32, 3, 0.5), 8).unwrap();
    png.truncate(png.len() / 2);
    diagnose("corrupt_png", "sample s { image = \"bad.png\" }\noutput \"s.png\" { from = s }\n", &[("bad.png", &png)]);
}

#[test]
fn corrupt_exr() {
    let mut exr = tessera::raster::io::encode_exr(&tessera::raster::Image::filled(32, 32, 3, 0.5)).unwrap();
    exr.truncate(exr.len() / 2);
    diagnose(
        "corrupt_exr",
        "map m { from = image(\"bad.exr\") }\noutput \"m.png\" { from = m }\n",
        &[("bad.exr", &exr)],
    );
}

#[test]
fn not_an_image() {
    diagnose(
        "not_an_image",
        "sample s { image = \"notes.png\" }\noutput \"s.png\" { from = s }\n",
        &[("notes.png", b"just some text")],
    );
}

#[test]
fn map_size_mismatch() {
    diagnose(
        "map_size_mismatch",
        "map m {\n  from = constant(1)\n  size = 32 x 32\n}\nsurface s {\n  plane = 64 x 64\n  occupancy = m\n}\noutput \"s.png\" { from = s }\n",
        &[],
    );
}

#[test]
fn crop_outside_image() {
    let png = tessera::raster::io::encode_png(&tessera::raster::Image::filled(16, 16, 3, 0.5), 8).unwrap();
    diagnose(
        "crop_outside",
        "sample s {\n  image = \"a.png\"\n  crop = [8, 8, 16, 16]\n}\noutput \"s.png\" { from = s }\n",
        &[("a.png", &png)],
    );
}

#[test]
fn unsupported_output_extension() {
    diagnose("output_extension", "map m { from = constant(1) }\noutput \"m.jpg\" { from = m }\n", &[]);
}

#[test]
fn polygon_too_small() {
    diagnose(
        "polygon_points",
        "map m { from = polygon(points = [[0, 0], [1, 1]]) }\noutput \"m.png\" { from = m }\n",
        &[],
    );
}

#[test]
fn invalid_manifest() {
    let p = Project::new(&[("scene.tess", "map m { from = constant(1) }\n")]);
    p.write("tessera.toml", "[paths]\nscenez = \"x\"\n");
    let run = p.tessera(&["build", "scene.tess"]);
    run.failed();
    insta::assert_snapshot!("invalid_manifest", run.stderr());
}

#[test]
fn missing_scene_path() {
    let p = Project::new(&[]);
    let run = p.tessera(&["build", "nothing.tess"]);
    run.failed();
    assert!(run.stderr().contains("nothing.tess"));
}

#[test]
fn garbage_never_panics() {
    // A spread of malformed inputs: each must fail cleanly, never panic.
    let cases = [
        "",
        "{",
        "map",
        "map a",
        "map a {",
        "map a { from = }",
        "map a { from = constant() }",
        "map a { from = constant(1, 2) }",
        "map a { from = constant(value = 1, 2) }",
        "map a { from = rect(at = [1], size = [1, 2, 3]) }",
        "map a { from = polygon(points = [1, 2, 3]) }",
        "map a { from = image(\"\") }",
        "map a { from = a }",
        "map a { from = constant(1) size = 0 x 5 }",
        "map a { from = constant(1) size = 1.5 x 5 }",
        "map a { from = constant(1) remap = [1] }",
        "output \"x.png\" { from = nothing }",
        "output x { from = nothing }",
        "scene a { }",
        "scene { seed = -1 }",
        "scene { seed = 1.5 }",
        "scene {} scene {}",
        "param p = p\nmap a { from = constant(p) }",
        "map a { from = constant(1e999) }",
        "map a { from = noise(scale = 0) }",
        "map a { from = linear(from = [0, 0], to = [0, 0]) }\noutput \"a.png\" { from = a }",
        "map a { from = radial(radius = -1) }",
        "sample s { crop = [0, 0, 1, 1] }",
        "\u{feff}map a { from = constant(1) }\u{0}",
    ];
    for (i, scene) in cases.iter().enumerate() {
        let p = Project::new(&[("scene.tess", scene)]);
        let run = p.tessera(&["build", "scene.tess"]);
        assert!(!run.stderr().contains("panicked"), "case {i} panicked: {scene:?}\n{}", run.stderr());
        // Scenes without outputs may legitimately build; everything else must fail with 1.
        assert!(run.code() == 0 || run.code() == 1, "case {i}: exit {} for {scene:?}", run.code());
    }
}
