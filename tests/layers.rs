//! Patch layers and texture libraries through the compiler: bad inputs, what re-runs after
//! an edit, and determinism.

mod common;

use common::{png, ran, texture, Project};
use tessera::raster::{io, Image};

/// Builds `scene.tess` (plus files) expecting failure; snapshots and returns stderr.
fn diagnose(name: &str, scene: &str, extra: &[(&str, Vec<u8>)]) -> String {
    let extra: Vec<(&str, &[u8])> = extra.iter().map(|(r, b)| (*r, b.as_slice())).collect();
    let err = common::failed_build(name, scene, &extra);
    insta::assert_snapshot!(name, err);
    err
}

const QUILT: &str = r#"scene { size = 64 x 64 }
sample s { image = "s.png" }
layer l {
  quilt = s
  block = 16 px
  overlap = 4 px
}
output "l.png" { from = l }
"#;

#[test]
fn block_larger_than_the_sample() {
    let e = diagnose(
        "layer_block_too_large",
        &QUILT.replace("block = 16 px", "block = 40 px"),
        &[("s.png", png(&texture(32, 24, 1)))],
    );
    assert!(e.contains("does not fit") && e.contains("block = 40 px"), "{e}");
}

#[test]
fn overlap_not_smaller_than_the_block() {
    let e = diagnose(
        "layer_overlap_too_large",
        &QUILT.replace("overlap = 4 px", "overlap = 16 px"),
        &[("s.png", png(&texture(32, 32, 1)))],
    );
    assert!(e.contains("must be smaller than the block") && e.contains("overlap = 16 px"), "{e}");
}

#[test]
fn guide_of_the_wrong_size() {
    let scene = QUILT.replace("  overlap = 4 px\n", "  overlap = 4 px\n  guide = g\n")
        + "map g { from = constant(0.5)  size = 48 x 64 }\n";
    let e = diagnose("layer_guide_size", &scene, &[("s.png", png(&texture(48, 48, 1)))]);
    assert!(e.contains("`guide` is 48x64 but the layer is 64x64"), "{e}");
}

const BLEND: &str = r#"scene { size = 64 x 64 }
map a { from = constant(0.2) }
map b { from = noise(scale = 8 px) }
map m { from = rect(at = [16, 16], size = [32, 32])  size = 64 x 64 }
layer mixed {
  blend = [a_layer, b_layer]
  mask = m
  threshold = 0.5
}
sample sa { image = "a.png" }
sample sb { image = "b.png" }
layer a_layer { quilt = sa  block = 16 px }
layer b_layer { quilt = sb  block = 16 px }
output "mixed.png" { from = mixed }
"#;

fn blend_files() -> Vec<(&'static str, Vec<u8>)> {
    vec![("a.png", png(&texture(40, 40, 1))), ("b.png", png(&texture(40, 40, 2)))]
}

#[test]
fn mask_of_the_wrong_size() {
    let e = diagnose(
        "layer_mask_size",
        &BLEND.replace("size = 64 x 64 }\nlayer", "size = 32 x 64 }\nlayer"),
        &blend_files(),
    );
    assert!(e.contains("`mask` is 32x64 but the layer is 64x64"), "{e}");
}

#[test]
fn nan_in_an_exr_sample() {
    let mut img = texture(32, 32, 3);
    img.data[5] = f32::NAN;
    img.data[77] = f32::INFINITY;
    let exr = io::encode_exr(&img).expect("encode exr");
    let e = diagnose("layer_nan_exr", &QUILT.replace("s.png", "s.exr"), &[("s.exr", exr)]);
    assert!(e.contains("2 NaN or infinite"), "{e}");
}

const LIBRARY: &str = r#"scene { size = 32 x 32 }
library lib { dir = "tex"  size = 32 }
sample q { image = "q.png" }
sample near { from = similar(lib, to = q, k = 2) }
output "near.json" { from = near }
output "near.png" { from = near }
"#;

#[test]
fn empty_library_directory() {
    let p = Project::new(&[("scene.tess", LIBRARY)]);
    p.write_bytes("q.png", &png(&texture(32, 32, 1)));
    p.write("tex/notes.txt", "no images here");
    let run = p.tessera(&["build", "scene.tess"]);
    run.failed();
    let e = run.stderr();
    insta::assert_snapshot!("library_empty_dir", e.replace(&p.path("tex").display().to_string(), "<tmp>/tex"));
    assert!(e.contains("holds no `.png`, `.exr` files"), "{e}");
}

#[test]
fn missing_library_directory() {
    let p = Project::new(&[("scene.tess", LIBRARY)]);
    let run = p.tessera(&["build", "scene.tess"]);
    run.failed();
    assert!(run.stderr().contains("cannot read the directory"), "{}", run.stderr());
}

#[test]
fn unreadable_file_in_a_library() {
    let e = diagnose(
        "library_unreadable_file",
        LIBRARY,
        &[
            ("q.png", png(&texture(32, 32, 1))),
            ("tex/a.png", png(&texture(32, 32, 2))),
            ("tex/broken.png", b"\x89PNG\r\n\x1a\nnot really".to_vec()),
        ],
    );
    assert!(e.contains("cannot decode `broken.png`"), "{e}");
}

#[test]
fn a_mask_threshold_change_reruns_the_blend_not_the_quilting() {
    let p = Project::new(&[("scene.tess", BLEND)]);
    for (rel, bytes) in blend_files() {
        p.write_bytes(rel, &bytes);
    }
    p.build_report(&["scene.tess"]).0.ok();
    p.write("scene.tess", &BLEND.replace("threshold = 0.5", "threshold = 0.6"));
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    assert_eq!(ran(&stages), vec!["layer mixed (blend)", "output mixed.png"]);
}

#[test]
fn touching_one_library_file_recomputes_its_features_and_the_query() {
    let p = Project::new(&[("scene.tess", LIBRARY)]);
    p.write_bytes("q.png", &png(&texture(32, 32, 1)));
    for i in 0..4 {
        p.write_bytes(&format!("tex/t{i}.png"), &png(&texture(32, 32, 10 + i)));
    }
    p.build_report(&["scene.tess"]).0.ok();
    p.write_bytes("tex/t2.png", &png(&texture(32, 32, 1)));
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    let ran = ran(&stages);
    assert!(ran.contains(&"library lib (t2.png)".to_string()), "{ran:?}");
    assert!(!ran.iter().any(|s| s.contains("t0.png") || s.contains("t1.png") || s.contains("t3.png")), "{ran:?}");
    assert!(ran.contains(&"library lib".to_string()) && ran.contains(&"sample near (query)".to_string()), "{ran:?}");
    // The copy of the target is now the nearest entry, at distance 0.
    let ranking: serde_json::Value = serde_json::from_slice(&p.read("out/scene/near.json")).unwrap();
    assert_eq!(ranking["candidates"][0]["name"], "t2.png");
    assert!(ranking["candidates"][0]["distance"].as_f64().unwrap() < 1e-6, "{ranking}");
}

#[test]
fn a_new_library_file_is_picked_up() {
    let p = Project::new(&[("scene.tess", LIBRARY)]);
    p.write_bytes("q.png", &png(&texture(32, 32, 1)));
    p.write_bytes("tex/t0.png", &png(&texture(32, 32, 7)));
    p.build_report(&["scene.tess"]).0.ok();
    p.write_bytes("tex/t1.png", &png(&texture(32, 32, 1)));
    p.build_report(&["scene.tess"]).0.ok();
    let ranking: serde_json::Value = serde_json::from_slice(&p.read("out/scene/near.json")).unwrap();
    assert_eq!(ranking["candidates"][0]["name"], "t1.png");
}

#[test]
fn similar_prints_a_ranked_table() {
    let p = Project::new(&[]);
    p.write_bytes("q.png", &png(&texture(32, 32, 1)));
    for i in 0..3 {
        p.write_bytes(&format!("tex/t{i}.png"), &png(&texture(32, 32, 5 + i)));
    }
    p.write_bytes("tex/copy.png", &png(&texture(32, 32, 1)));
    let run = p.tessera(&["similar", "tex", "q.png", "-k", "3", "--size", "32"]);
    run.ok();
    let out = run.stdout();
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 4, "{out}");
    assert!(lines[0].starts_with("rank") && lines[0].contains("colour") && lines[0].contains("fourier.reim"), "{out}");
    assert!(lines[1].starts_with("1") && lines[1].contains("copy.png") && lines[1].contains("0.0000"), "{out}");
    // Bad input: an empty directory is a clear error, not a panic.
    std::fs::create_dir_all(p.path("empty")).unwrap();
    let run = p.tessera(&["similar", "empty", "q.png"]);
    run.failed();
    assert!(run.stderr().contains("holds no `.png` or `.exr` files"), "{}", run.stderr());
}

#[test]
fn compare_prints_every_measure() {
    let p = Project::new(&[]);
    p.write_bytes("a.png", &png(&texture(48, 48, 1)));
    p.write_bytes("b.png", &png(&texture(48, 48, 2)));
    let same = p.tessera(&["compare", "a.png", "a.png"]);
    same.ok();
    for name in ["spectrum", "pyramid", "colour", "coherence", "completeness"] {
        let line = same.stdout().lines().find(|l| l.starts_with(name)).unwrap_or_default().to_string();
        let v: f64 = line.split_whitespace().nth(1).unwrap().parse().unwrap();
        assert!(v.abs() < 1e-9, "{name} of an image against itself: {line}");
    }
    let diff = p.tessera(&["compare", "a.png", "b.png"]);
    diff.ok();
    let coherence: f64 = diff
        .stdout()
        .lines()
        .find(|l| l.starts_with("coherence"))
        .unwrap()
        .split_whitespace()
        .nth(1)
        .unwrap()
        .parse()
        .unwrap();
    assert!(coherence > 0.0);
    p.tessera(&["compare", "a.png", "missing.png"]).failed();
}

/// A sample whose brightness varies a lot from block to block, so a guide can steer it.
fn patchy(w: usize, h: usize) -> Image {
    Image::from_fn(w, h, 3, |x, y, _| {
        let cell = ((x / 12) * 7 + (y / 12) * 13) % 5;
        (0.1 + 0.2 * cell as f32 + 0.03 * ((x as f32 * 0.9).sin() + (y as f32 * 0.7).cos())).clamp(0.0, 1.0)
    })
}

#[test]
fn a_guide_steers_quilting_and_occupancy_leaves_pixels_empty() {
    let scene = r#"scene { size = 96 x 64 }
sample s { image = "s.png"  color = linear }
map ramp { from = linear(from = [0, 0], to = [96, 0]) }
map hole { from = rect(at = [60, 8], size = [24, 24])  invert = true }
surface plane { plane = 96 x 64  occupancy = hole }
layer guided {
  quilt = s
  block = 12 px
  overlap = 3 px
  guide = ramp
  alpha = 0.1
}
layer holed {
  quilt = s
  on = plane
  block = 12 px
  overlap = 3 px
}
output "guided.exr" { from = guided }
output "holed.exr" { from = holed }
output "index.png" {
  from = guided
  view = index
}
"#;
    let p = Project::new(&[("scene.tess", scene)]);
    p.write_bytes("s.png", &png(&patchy(64, 64)));
    p.tessera(&["build", "scene.tess"]).ok();
    let g = io::decode(&p.read("out/scene/guided.exr")).unwrap();
    let mean = |x0: usize, x1: usize| {
        let mut s = 0.0;
        for y in 0..64 {
            for x in x0..x1 {
                s += g.get(x, y, 0);
            }
        }
        s / ((x1 - x0) * 64) as f32
    };
    let (left, right) = (mean(0, 24), mean(72, 96));
    assert!(right > left + 0.2, "the guide did not steer: left {left}, right {right}");
    let h = io::decode(&p.read("out/scene/holed.exr")).unwrap();
    assert_eq!(h.get(70, 18, 0), 0.0, "a pixel outside the occupancy was filled");
    assert!(h.get(10, 50, 0) > 0.0);
    let index = io::decode(&p.read("out/scene/index.png")).unwrap();
    assert_eq!((index.width, index.height, index.channels), (96, 64, 3));
}

#[test]
fn seam_removal_reruns_only_after_the_quilting_and_flattens_the_seams() {
    let scene = r#"scene { size = 80 x 80 }
sample s { image = "s.png"  color = linear }
layer l {
  quilt = s
  block = 20 px
  overlap = 4 px
  tolerance = 1
  seams = keep
}
output "l.exr" { from = l }
output "seams.png" {
  from = l
  view = seams
}
"#;
    let p = Project::new(&[("scene.tess", scene)]);
    p.write_bytes("s.png", &png(&patchy(48, 48)));
    p.tessera(&["build", "scene.tess"]).ok();
    let before = io::decode(&p.read("out/scene/l.exr")).unwrap();
    let seams = io::decode(&p.read("out/scene/seams.png")).unwrap();
    assert!(seams.data.iter().any(|&v| v > 0.5));
    // Mean jump across vertical seam edges.
    let jump = |img: &Image| {
        let (mut sum, mut n) = (0.0, 0);
        for y in 0..80 {
            for x in 0..79 {
                if seams.get(x, y, 0) > 0.5 && seams.get(x + 1, y, 0) > 0.5 {
                    sum += (img.get(x + 1, y, 0) - img.get(x, y, 0)).abs();
                    n += 1;
                }
            }
        }
        sum / n.max(1) as f32
    };
    let with = scene.replace("seams = keep", "seams = gradient");
    p.write("scene.tess", &with);
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    assert_eq!(ran(&stages), vec!["layer l (seams)", "output l.exr"], "the quilting re-ran");
    let after = io::decode(&p.read("out/scene/l.exr")).unwrap();
    let (a, b) = (jump(&before), jump(&after));
    eprintln!("mean jump across seams: {a:.4} → {b:.4}");
    assert!(b < 0.8 * a, "seam removal did not flatten the seams: {a} → {b}");
    // The band width is a parameter of the seam stage only.
    p.write("scene.tess", &with.replace("  seams = gradient\n", "  seams = gradient\n  seam_band = 6 px\n"));
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    assert_eq!(ran(&stages), vec!["layer l (seams)", "output l.exr"]);
}
