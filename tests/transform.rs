//! The `transform` kind [references: bourque §ch5]: frames between key textures are written as
//! a record, a strip and one file per frame, the first and last frames are the keys, matches
//! can be keys, and bad input is refused at its span.

mod common;

use common::{ran, Project};

fn scene(keys: &str, props: &str, outputs: &str) -> String {
    format!(
        "scene {{\n  seed = 2\n  size = 64 x 64\n}}\n\n\
         shader thin {{\n  pattern = bar(width = 0.1)\n}}\n\n\
         shader wide {{\n  pattern = bar(width = 0.8)\n}}\n\n\
         transform t {{\n  keys = {keys}\n  side = 32\n  catalogue = 40\n  size = 32\n{props}}}\n\n{outputs}"
    )
}

const OUTPUTS: &str = "output \"t.toml\" {\n  from = t\n}\n\noutput \"t.png\" {\n  from = t\n}\n\n\
output \"frames/f_##.png\" {\n  from = t\n}\n";

#[test]
fn a_transformation_writes_its_record_strip_and_frames() {
    let p = Project::new(&[("scene.tess", &scene("[thin, wide]", "  frames = 5\n", OUTPUTS))]);
    p.tessera(&["build", "scene.tess"]).ok();
    let record = String::from_utf8(p.read("out/scene/t.toml")).unwrap();
    assert!(record.contains("frames = 5"), "{record}");
    let frames: Vec<&str> = record.split("[[frame]]").skip(1).collect();
    assert_eq!(frames.len(), 5);
    // F35: the first and last frames are the keys, exactly.
    assert!(frames[0].contains("key = 0") && frames[0].contains("width = 0.1,"), "{}", frames[0]);
    assert!(frames[4].contains("key = 1") && frames[4].contains("width = 0.8,"), "{}", frames[4]);
    let strip = image::open(p.path("out/scene/t.png")).unwrap().to_rgb8();
    assert_eq!(strip.dimensions(), (5 * 32 + 4 * 2, 32));
    for i in 0..5 {
        let f = image::open(p.path(&format!("out/scene/frames/f_{i:02}.png"))).unwrap().to_rgb8();
        assert_eq!(f.dimensions(), (32, 32));
        // The strip shows the same frames.
        let x0 = i * 34;
        assert_eq!(f.get_pixel(16, 16), strip.get_pixel(x0 as u32 + 16, 16));
    }
    assert!(!p.path("out/scene/frames/f_##.png").exists());
    // Rebuilt from the cache.
    let run = p.tessera(&["build", "scene.tess"]);
    run.ok();
    assert!(format!("{}{}", run.stdout(), run.stderr()).contains(" 0 ran"));
}

#[test]
fn a_strip_and_frame_files_of_one_sequence_render_each_frame_once() {
    let p = Project::new(&[("scene.tess", &scene("[thin, wide]", "  frames = 5\n", OUTPUTS))]);
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    let frames: Vec<&str> = stages.iter().filter(|s| s.kind == "transform.frame").map(|s| s.label.as_str()).collect();
    assert_eq!(frames, ["t frame 0", "t frame 1", "t frame 2", "t frame 3", "t frame 4"], "{stages:?}");
    // Without `frames` the strip shows the whole path, whose length is known only once built:
    // it renders its own frames, and still shows the keys at its ends.
    let p = Project::new(&[("scene.tess", &scene("[thin, wide]", "", "output \"t.png\" {\n  from = t\n}\n"))]);
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    assert!(stages.iter().all(|s| s.kind != "transform.frame"), "{stages:?}");
    let strip = image::open(p.path("out/scene/t.png")).unwrap().to_rgb8();
    // Whole frames of 32 pixels with gaps of 2, at least the two keys.
    let (w, h) = strip.dimensions();
    assert!((w + 2) % 34 == 0 && (h + 2) % 34 == 0 && w >= 2 * 34 - 2, "{w} x {h}");
}

#[test]
fn a_match_can_be_a_key_and_an_edit_reruns_only_what_follows() {
    // F46: a match's shader is found at run time; editing one key re-runs only its path.
    let text = scene(
        "[m, wide]",
        "",
        "match m {\n  target = thin\n  candidates = \"bar\"\n  side = 32\n  catalogue = 40\n}\n\n\
         output \"t.toml\" {\n  from = t\n}\n",
    );
    let p = Project::new(&[("scene.tess", &text)]);
    let (run, first) = p.build_report(&["scene.tess"]);
    run.ok();
    assert_eq!(first.iter().filter(|s| s.kind == "match.catalogue").count(), 1, "shared: {first:?}");
    let record = String::from_utf8(p.read("out/scene/t.toml")).unwrap();
    assert!(record.contains("shaders = [\"bar\"]"), "{record}");
    p.write("scene.tess", &text.replace("width = 0.8", "width = 0.7"));
    let (run, second) = p.build_report(&["scene.tess"]);
    run.ok();
    assert_eq!(ran(&second), vec!["output t.toml", "transform t"]);
}

#[test]
fn bad_transform_input_is_a_diagnostic_at_its_span() {
    let cases: &[(&str, &str, &str, &str)] = &[
        // (keys, properties, message, labelled text)
        ("[thin]", "", "at least two keys", "[thin]"),
        ("[thin, photo]", "", "a key is a `shader` or a `match`", "[thin, photo]"),
        ("[thin, wide]", "  via = \"bar, checker\"\n", "no shader `checker`", "\"bar, checker\""),
        ("[thin, wide]", "  exponent = 0.5\n", "0.5", "0.5"),
        ("[thin, wide]", "  tau = 2\n", "2", "2"),
        ("[thin, wide]", "  depth = -1\n", "-1", "-1"),
        ("[thin, wide]", "  frames = 1\n", "1", "1"),
        ("[thin, nowhere]", "", "nowhere", "nowhere"),
        ("[thin, wide]", "  jump = -0.1\n", "-0.1", "-0.1"),
        ("[thin, wide]", "  jump = 1.5\n", "1.5", "1.5"),
        ("[thin, wide]", "  presence = 2\n", "2", "2"),
        ("[thin, wide]", "  coherence = -1\n", "-1", "-1"),
        ("[thin, wide]", "  size = 0\n", "0", "0"),
        ("[thin, wide]", "  size = 4096\n", "4096", "4096"),
        ("[thin, wide]", "  side = 8\n", "8", "8"),
        ("[thin, wide]", "  catalogue = 0\n", "0", "0"),
        ("[thin, wide]", "  metric = fourier\n", "`fourier` is not one of `power`", "fourier"),
    ];
    for (keys, props, message, label) in cases {
        let text = scene(keys, props, "output \"t.toml\" {\n  from = t\n}\n")
            .replace("transform t", "sample photo {\n  image = \"p.png\"\n}\n\ntransform t");
        let p = Project::new(&[("scene.tess", &text)]);
        let err = p.refuses(message, label);
        assert!(!err.contains("panicked"), "{props}: {err}");
    }
}

#[test]
fn frame_files_need_a_frame_count_and_transformations_have_no_views() {
    let p = Project::new(&[("scene.tess", &scene("[thin, wide]", "", "output \"f_#.png\" {\n  from = t\n}\n"))]);
    p.refuses("number of frames", "\"f_#.png\"");
    let p = Project::new(&[(
        "scene.tess",
        &scene("[thin, wide]", "  frames = 3\n", "output \"f_#_#.png\" {\n  from = t\n}\n"),
    )]);
    p.refuses("one run of `#`s", "\"f_#_#.png\"");
    let p = Project::new(&[("scene.tess", &scene("[thin, wide]", "", "output \"t.tess\" {\n  from = t\n}\n"))]);
    p.refuses("`.toml`, `.png` or `.exr`", "\"t.tess\"");
    let view = "output \"t.png\" {\n  from = t\n  view = edges\n}\n";
    let p = Project::new(&[("scene.tess", &scene("[thin, wide]", "", view))]);
    p.refuses("a transformation has no views", "edges");
    let matched = "match m {\n  target = thin\n  candidates = \"bar\"\n}\n\n\
                   output \"m.png\" {\n  from = m\n  view = edges\n}\n";
    let p = Project::new(&[("scene.tess", &scene("[thin, wide]", "", matched))]);
    p.refuses("a match has no views", "edges");
}

#[test]
fn keys_no_jump_can_join_are_a_diagnostic() {
    let text = "scene {\n  size = 64 x 64\n}\n\nshader a {\n  pattern = bar(width = 0.3)\n}\n\n\
shader b {\n  pattern = circle(radius = 0.3)\n}\n\n\
transform t {\n  keys = [a, b]\n  jump = 1\n  side = 32\n  catalogue = 40\n}\n\noutput \"t.toml\" {\n  from = t\n}\n";
    let p = Project::new(&[("scene.tess", text)]);
    p.refuses("no path joins key 0 to key 1", "[a, b]");
}

#[test]
fn frames_do_not_depend_on_the_thread_count() {
    let text = scene("[thin, wide]", "  frames = 4\n", OUTPUTS);
    let one = Project::new(&[("scene.tess", &text)]);
    one.tessera(&["build", "-j", "1", "scene.tess"]).ok();
    let two = Project::new(&[("scene.tess", &text)]);
    two.tessera(&["build", "-j", "2", "scene.tess"]).ok();
    for f in ["t.toml", "t.png", "frames/f_00.png", "frames/f_03.png"] {
        assert!(one.read(&format!("out/scene/{f}")) == two.read(&format!("out/scene/{f}")), "{f} differs");
    }
}

#[test]
fn absurd_settings_stay_bounded() {
    // τ = 1 is never reached: every gap halves to the depth cap and the frame budget, and the
    // record says which gaps stayed below.
    let text =
        scene("[thin, wide]", "  tau = 1\n  depth = 16\n  exponent = 64\n", "output \"t.toml\" {\n  from = t\n}\n");
    let p = Project::new(&[("scene.tess", &text)]);
    p.tessera(&["build", "scene.tess"]).ok();
    let record = String::from_utf8(p.read("out/scene/t.toml")).unwrap();
    let inserted: usize = record.lines().find_map(|l| l.strip_prefix("inserted = ")).unwrap().parse().unwrap();
    assert!(inserted <= 2000, "{inserted}");
    assert!(!record.contains("below_tau = []"), "{record}");
    // The edges of every unit range are legal and bounded: no jump floor, no presence floor,
    // coherence demanding identical neighbours (halving stops at the budget).
    for props in ["  jump = 0\n  presence = 0\n  coherence = 0\n", "  jump = 1\n  presence = 1\n  tau = 0\n"] {
        let text = scene("[thin, wide]", props, "output \"t.toml\" {\n  from = t\n}\n");
        let p = Project::new(&[("scene.tess", &text)]);
        p.tessera(&["build", "scene.tess"]).ok();
        let record = String::from_utf8(p.read("out/scene/t.toml")).unwrap();
        let inserted: usize = record.lines().find_map(|l| l.strip_prefix("inserted = ")).unwrap().parse().unwrap();
        assert!(inserted <= 2000, "{props}: {inserted}");
    }
    // A thousand frames of 2048² are refused before anything is rendered.
    let text = scene("[thin, wide]", "  frames = 1000\n  size = 2048\n", OUTPUTS).replace("  size = 32\n", "");
    let p = Project::new(&[("scene.tess", &text)]);
    p.refuses("memory", "2048");
}
