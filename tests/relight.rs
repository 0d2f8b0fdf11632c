//! Relightable surfaces from the language (issue 14): photometric captures named by images
//! and lights or by a light-position file, representations, relit quilted layers, and the
//! diagnostics of captures and methods that cannot work.

mod common;

use common::{flat, ran, repo, Project};
use tessera::raster::{self, Image};

/// A project holding the synthetic cobbles capture (`samples/capture/cobbles`) in `cobbles/`
/// and `scene.tess` with `body` after a 96² scene block.
fn project(body: &str) -> Project {
    let p = Project::new(&[]);
    common::copy_dir(&repo().join("samples/capture/cobbles"), &p.path("cobbles"));
    p.write("scene.tess", &format!("scene {{\n  seed = 2\n  size = 96 x 96\n}}\n\n{body}"));
    p
}

const GRID: &str = "grid(slants = [30 deg, 45 deg, 60 deg], tilts = [0 deg, 30 deg, 60 deg, 90 deg, 120 deg, 150 deg, 180 deg, 210 deg, 240 deg, 270 deg, 300 deg, 330 deg])";

fn decode(bytes: &[u8]) -> Image {
    raster::io::decode(bytes).expect("decodes")
}

/// RMS of `a − b` over the population standard deviation of `b` (Dong's per-image η term).
fn eta(a: &Image, b: &Image) -> f64 {
    let n = b.data.len() as f64;
    let mean = b.data.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
    let var = b.data.iter().map(|&v| (f64::from(v) - mean).powi(2)).sum::<f64>() / n;
    let sq = a.data.iter().zip(&b.data).map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2)).sum::<f64>() / n;
    sq.sqrt() / var.sqrt()
}

#[test]
fn a_capture_relights_like_its_photographs() {
    let p = project(&format!(
        "sample cobbles {{\n  images = \"cobbles/cobbles_s*.png\"\n  lights = {GRID}\n}}\n\n\
         representation rock {{\n  from = cobbles\n  method = eigen\n  components = 6\n}}\n\n\
         representation stereo {{\n  from = cobbles\n}}\n\n\
         output \"eigen.exr\" {{\n  from = rock\n  light = light(tilt = 60 deg, slant = 45 deg)\n}}\n\n\
         output \"gradient.exr\" {{\n  from = stereo\n  light = light(tilt = 60 deg, slant = 45 deg)\n}}\n"
    ));
    p.tessera(&["build", "scene.tess", "-q"]).ok();
    let truth = decode(&p.read("cobbles/cobbles_s45_t060.png"));
    let eigen = decode(&p.read("out/scene/eigen.exr"));
    let gradient = decode(&p.read("out/scene/gradient.exr"));
    let (e6, eg) = (eta(&eigen, &truth), eta(&gradient, &truth));
    // A captured light, so this is reconstruction: Eigen6 holds the highlights and shadows
    // that Lambert's law (Gradient) cannot.
    assert!(e6 < 0.1, "Eigen6 η {e6}");
    assert!(eg < 0.45 && e6 < eg, "Gradient η {eg}, Eigen6 η {e6}");
}

/// The same capture named by a pattern and a grid, or by its light-position file (directions to
/// six decimals, as RTI tools write them, so each light lands about 1e-4° off the grid): every
/// method relights it the same, and the grid lookups of 3I and Eigen still find their lights.
#[test]
fn a_light_position_file_loads_the_same_capture() {
    let body = |sample: &str| {
        format!(
            "sample cobbles {{\n{sample}}}\n\n\
             representation ptm {{\n  from = cobbles\n  method = ptm\n}}\n\n\
             representation eigen {{\n  from = cobbles\n  method = eigen\n  components = 6\n}}\n\n\
             representation three {{\n  from = cobbles\n  method = three_i\n}}\n\n\
             output \"ptm.exr\" {{\n  from = ptm\n  light = light(tilt = 100 deg, slant = 40 deg)\n}}\n\n\
             output \"eigen.exr\" {{\n  from = eigen\n  light = light(tilt = 100 deg, slant = 40 deg)\n}}\n\n\
             output \"three.exr\" {{\n  from = three\n  light = light(tilt = 100 deg, slant = 40 deg)\n}}\n\n\
             output \"eigen.json\" {{\n  from = eigen\n  view = report\n}}\n"
        )
    };
    let a = project(&body(&format!("  images = \"cobbles/cobbles_s*.png\"\n  lights = {GRID}\n")));
    let b = project(&body("  capture = \"cobbles/cobbles.lp\"\n"));
    a.tessera(&["build", "scene.tess", "-q"]).ok();
    b.tessera(&["build", "scene.tess", "-q"]).ok();
    for file in ["ptm.exr", "eigen.exr", "three.exr"] {
        let (x, y) = (decode(&a.read(&format!("out/scene/{file}"))), decode(&b.read(&format!("out/scene/{file}"))));
        let worst = x.data.iter().zip(&y.data).map(|(p, q)| (p - q).abs()).fold(0f32, f32::max);
        assert!(worst < 1e-3, "{file}: largest difference {worst}");
    }
    // Leave-one-out finds each held-out light on the grid: the same η either way.
    let report =
        |p: &Project| -> serde_json::Value { serde_json::from_slice(&p.read("out/scene/eigen.json")).unwrap() };
    let (va, vb) = (report(&a), report(&b));
    let mut diffs = Vec::new();
    numbers(&va, &vb, &mut diffs);
    let worst = diffs.iter().copied().fold(0.0, f64::max);
    assert!(!diffs.is_empty() && worst < 1e-3, "report numbers differ by up to {worst}");
}

/// Relative differences of every pair of numbers at the same place in two JSON values.
fn numbers(a: &serde_json::Value, b: &serde_json::Value, out: &mut Vec<f64>) {
    use serde_json::Value as V;
    match (a, b) {
        (V::Number(x), V::Number(y)) => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            out.push((x - y).abs() / x.abs().max(y.abs()).max(1e-12));
        }
        (V::Array(x), V::Array(y)) => x.iter().zip(y).for_each(|(x, y)| numbers(x, y, out)),
        (V::Object(x), V::Object(y)) => x.iter().for_each(|(k, v)| numbers(v, &y[k], out)),
        _ => {}
    }
}

#[test]
fn a_quilted_representation_relights_as_its_gathered_sample() {
    let p = project(
        "sample cobbles {\n  capture = \"cobbles/cobbles.lp\"\n}\n\n\
         representation rock {\n  from = cobbles\n}\n\n\
         layer grown {\n  quilt = rock\n  block = 24 px\n  overlap = 6 px\n  metric = sad\n  light = light(tilt = 120 deg, slant = 60 deg)\n}\n\n\
         output \"grown.exr\" {\n  from = grown\n}\n\n\
         output \"index.png\" {\n  from = grown\n  view = index\n}\n\n\
         output \"sample.exr\" {\n  from = rock\n  light = light(tilt = 120 deg, slant = 60 deg)\n}\n\n\
         output \"normal.png\" {\n  from = grown\n  view = normal\n}\n\n\
         output \"height.exr\" {\n  from = grown\n  view = height\n}\n",
    );
    p.tessera(&["build", "scene.tess", "-q"]).ok();
    let grown = decode(&p.read("out/scene/grown.exr"));
    let sample = decode(&p.read("out/scene/sample.exr"));
    let index = decode(&p.read("out/scene/index.png"));
    // Relighting is per pixel: the relit layer is the relit sample gathered through the
    // index map (the index view holds the pixel centres `(x + ½) / w`, `(y + ½) / h`).
    let (sw, sh) = (sample.width as f32, sample.height as f32);
    let mut worst = 0f32;
    for y in 0..grown.height {
        for x in 0..grown.width {
            let sx = (index.get(x, y, 0) * sw - 0.5).round() as usize;
            let sy = (index.get(x, y, 1) * sh - 0.5).round() as usize;
            worst = worst.max((grown.get(x, y, 0) - sample.get(sx, sy, 0)).abs());
        }
    }
    assert!(worst < 1e-5, "relit layer vs gathered relit sample: {worst}");
    let normal = decode(&p.read("out/scene/normal.png"));
    assert_eq!((normal.width, normal.height, normal.channels), (96, 96, 3));
    let height = decode(&p.read("out/scene/height.exr"));
    assert_eq!(height.channels, 1);
}

/// A build that fails with `message`, pointing at `snippet`; returns stderr.
#[track_caller]
fn refused(body: &str, message: &str, snippet: &str) -> String {
    project(body).refuses(message, snippet)
}

fn twelve_at_45() -> String {
    "  images = \"cobbles/cobbles_s45_*.png\"\n  lights = grid(slants = [45 deg], tilts = [0 deg, 30 deg, 60 deg, 90 deg, 120 deg, 150 deg, 180 deg, 210 deg, 240 deg, 270 deg, 300 deg, 330 deg])\n".into()
}

#[test]
fn methods_that_cannot_work_are_refused_at_the_property() {
    let rep = |sample: &str, props: &str| {
        format!(
            "sample cobbles {{\n{sample}}}\n\nrepresentation rock {{\n  from = cobbles\n{props}}}\n\n\
             output \"r.png\" {{\n  from = rock\n}}\n"
        )
    };
    refused(&rep(&twelve_at_45(), "  method = ptm\n"), "PTM needs lights at two or more slants", "method = ptm");
    let coplanar = "  images = [\"cobbles/cobbles_s30_t000.png\", \"cobbles/cobbles_s45_t000.png\", \"cobbles/cobbles_s60_t000.png\"]\n  lights = [light(tilt = 0 deg, slant = 30 deg), light(tilt = 0 deg, slant = 45 deg), light(tilt = 0 deg, slant = 60 deg)]\n";
    refused(&rep(coplanar, "  method = gradient\n"), "coplanar or degenerate", "method = gradient");
    refused(&rep(coplanar, "  method = three_i\n"), "every triple of lights is coplanar", "method = three_i");
    refused(
        &rep(&twelve_at_45(), "  method = eigen\n  components = 20\n"),
        "Eigen-20 needs k between 1 and the number of images (12)",
        "components = 20",
    );
    refused(
        "sample cobbles {\n  capture = \"cobbles/cobbles.lp\"\n}\n\nrepresentation rock {\n  from = cobbles\n  method = eigen\n}\n\n\
         output \"r.png\" {\n  from = rock\n  light = light(tilt = 0 deg, slant = 80 deg)\n}\n",
        "outside the captured slant range",
        "light = light(tilt = 0 deg, slant = 80 deg)",
    );
}

#[test]
fn bad_captures_are_refused_at_the_file() {
    let rep = "representation rock {\n  from = cobbles\n}\n\noutput \"r.png\" {\n  from = rock\n}\n";
    // A missing light: 36 images, 35 lights.
    let short = GRID.replace(", 330 deg]", "]");
    refused(
        &format!("sample cobbles {{\n  images = \"cobbles/cobbles_s*.png\"\n  lights = {short}\n}}\n\n{rep}"),
        "33 light(s) for 36 image(s)",
        "lights = grid",
    );
    // Images of different sizes.
    let p = project(&format!("sample cobbles {{\n  images = \"cobbles/*.png\"\n  lights = {GRID}\n}}\n\n{rep}"));
    let small = Image::filled(48, 48, 1, 0.5);
    p.write_bytes("cobbles/zz_small.png", &raster::io::encode_png(&small, 16).unwrap());
    for f in ["cobbles/truth_height.png", "cobbles/truth_albedo.png"] {
        std::fs::remove_file(p.path(f)).unwrap();
    }
    p.write(
        "scene.tess",
        &format!("scene {{\n  seed = 2\n  size = 96 x 96\n}}\n\nsample cobbles {{\n  images = \"cobbles/*.png\"\n  lights = [{GRID}, light(tilt = 0 deg, slant = 10 deg)]\n}}\n\n{rep}"),
    );
    let run = p.tessera(&["build", "scene.tess"]);
    run.failed();
    let err = flat(&run.stderr());
    assert!(err.contains("`zz_small.png` is 48 x 48") && err.contains("must be registered"), "{err}");
    // A light-position file with a malformed line, and one naming a missing image.
    let p = project(&format!("sample cobbles {{\n  capture = \"cobbles/bad.lp\"\n}}\n\n{rep}"));
    p.write("cobbles/bad.lp", "2\ncobbles_s30_t000.png 0.5 0 0.866\ncobbles_s30_t030.png 0.4 zero 0.8\n");
    let run = p.tessera(&["build", "scene.tess"]);
    run.failed();
    let err = flat(&run.stderr());
    assert!(err.contains("line 3 of `bad.lp`: `zero` is not a number"), "{err}");
    assert!(run.stderr().contains("capture = \"cobbles/bad.lp\""), "{}", run.stderr());
    p.write("cobbles/bad.lp", "2\ncobbles_s30_t000.png 0.5 0 0.866\nnot_there.png 0.4 0 0.8\n");
    let run = p.tessera(&["build", "scene.tess"]);
    run.failed();
    let err = flat(&run.stderr());
    assert!(err.contains("not_there.png"), "{err}");
    assert!(run.stderr().contains("capture = \"cobbles/bad.lp\""), "{}", run.stderr());
    // NaN in an EXR image.
    let p = project(&format!(
        "sample cobbles {{\n  images = [\"a.exr\", \"cobbles/cobbles_s45_t000.png\", \"cobbles/cobbles_s45_t090.png\"]\n  lights = [light(tilt = 0 deg, slant = 30 deg), light(tilt = 0 deg, slant = 45 deg), light(tilt = 90 deg, slant = 45 deg)]\n}}\n\n{rep}"
    ));
    let mut nan = Image::filled(96, 96, 1, 0.5);
    nan.data[5 * 96 + 7] = f32::NAN;
    p.write_bytes("a.exr", &raster::io::encode_exr(&nan).unwrap());
    let run = p.tessera(&["build", "scene.tess"]);
    run.failed();
    let err = flat(&run.stderr());
    assert!(
        err.contains("a.exr") && (err.contains("NaN") || err.contains("not finite") || err.contains("non-finite")),
        "{err}"
    );
    assert!(run.stderr().contains("\"a.exr\""), "{}", run.stderr());
}

#[test]
fn capture_properties_belong_to_captures() {
    refused(
        "sample s {\n  image = \"cobbles/truth_albedo.png\"\n  lights = [light(tilt = 0 deg, slant = 30 deg)]\n}\n\noutput \"s.png\" {\n  from = s\n}\n",
        "is not a photometric capture",
        "lights = [light(tilt = 0 deg, slant = 30 deg)]",
    );
    refused(
        "sample cobbles {\n  capture = \"cobbles/cobbles.lp\"\n}\n\nlayer l {\n  quilt = cobbles\n}\n\noutput \"l.png\" {\n  from = l\n}\n",
        "is a photometric capture, not an image",
        "quilt = cobbles",
    );
    refused(
        "sample s {\n  image = \"cobbles/truth_albedo.png\"\n}\n\nlayer l {\n  quilt = s\n  light = light(tilt = 0 deg, slant = 30 deg)\n}\n\noutput \"l.png\" {\n  from = l\n}\n",
        "does not grow a representation",
        "light = light(tilt = 0 deg, slant = 30 deg)",
    );
    refused(
        "sample cobbles {\n  images = \"cobbles/nothing_*.png\"\n  lights = [light(tilt = 0 deg, slant = 30 deg)]\n}\n\nrepresentation r {\n  from = cobbles\n}\n\noutput \"r.png\" {\n  from = r\n}\n",
        "matches `nothing_*.png`",
        "\"cobbles/nothing_*.png\"",
    );
}

#[test]
fn an_overlap_outside_a_sixth_to_a_third_of_the_block_is_a_warning() {
    let scene = |overlap: &str| {
        format!(
            "sample cobbles {{\n  capture = \"cobbles/cobbles.lp\"\n}}\n\nrepresentation rock {{\n  from = cobbles\n}}\n\n\
             layer grown {{\n  quilt = rock\n  block = 24 px\n  overlap = {overlap}\n}}\n\noutput \"g.png\" {{\n  from = grown\n}}\n"
        )
    };
    let run = project(&scene("2 px")).tessera(&["build", "scene.tess"]);
    run.ok();
    assert!(
        flat(&run.stderr()).contains("the overlap (2 px) is outside 1/6–1/3 of the block (24 px)"),
        "{}",
        run.stderr()
    );
    let run = project(&scene("6 px")).tessera(&["build", "scene.tess"]);
    run.ok();
    assert!(!run.stderr().contains("outside 1/6"), "{}", run.stderr());
}

/// A layer grown under an orientation field relights each pixel in the frame of the rotated
/// copy it came from (`τ → τ − θ`): with a constant quarter turn every copy is an exact
/// permutation of the sample, so the relit layer must be the sample relit at the turned light,
/// turned, and gathered; its maps, rewritten into the image frame, have `(p, q)` turned too.
#[test]
fn a_layer_grown_under_an_orientation_field_relights_in_each_pixels_frame() {
    let p = project(
        "sample cobbles {\n  capture = \"cobbles/cobbles.lp\"\n}\n\n\
         representation rock {\n  from = cobbles\n}\n\n\
         map turn {\n  from = direction(angle = 90 deg)\n}\n\n\
         layer grown {\n  quilt = rock\n  block = 24 px\n  overlap = 6 px\n  orientation = turn\n  copies = 4\n  light = light(tilt = 120 deg, slant = 60 deg)\n}\n\n\
         output \"grown.exr\" {\n  from = grown\n}\n\n\
         output \"maps.exr\" {\n  from = grown\n  view = maps\n}\n\n\
         output \"index.png\" {\n  from = grown\n  view = index\n}\n\n\
         output \"turned.exr\" {\n  from = rock\n  light = light(tilt = 30 deg, slant = 60 deg)\n}\n\n\
         output \"sample_maps.exr\" {\n  from = rock\n  view = maps\n}\n",
    );
    p.tessera(&["build", "scene.tess", "-q"]).ok();
    let grown = decode(&p.read("out/scene/grown.exr"));
    let maps = decode(&p.read("out/scene/maps.exr"));
    let turned = decode(&p.read("out/scene/turned.exr"));
    let sample_maps = decode(&p.read("out/scene/sample_maps.exr"));
    let index = decode(&p.read("out/scene/index.png"));
    let n = turned.width;
    let (mut worst_lit, mut worst_pq) = (0f32, 0f32);
    for y in 0..grown.height {
        for x in 0..grown.width {
            let cx = (index.get(x, y, 0) * n as f32 - 0.5).round() as usize;
            let cy = (index.get(x, y, 1) * n as f32 - 0.5).round() as usize;
            // Pixel (cx, cy) of the quarter-turned copy is pixel (cy, n − 1 − cx) of the sample.
            let (sx, sy) = (cy, n - 1 - cx);
            worst_lit = worst_lit.max((grown.get(x, y, 0) - turned.get(sx, sy, 0)).abs());
            // R(90°)·(p, q) = (−q, p); the albedo is unchanged.
            let (sp, sq, sa) = (sample_maps.get(sx, sy, 0), sample_maps.get(sx, sy, 1), sample_maps.get(sx, sy, 2));
            for (got, want) in [(maps.get(x, y, 0), -sq), (maps.get(x, y, 1), sp), (maps.get(x, y, 2), sa)] {
                worst_pq = worst_pq.max((got - want).abs());
            }
        }
    }
    assert!(worst_lit < 1e-5, "relit layer vs turned relit sample: {worst_lit}");
    assert!(worst_pq < 1e-5, "maps in the image frame: {worst_pq}");
}

#[test]
fn eigen_maps_of_a_layer_grown_rotated_are_refused() {
    refused(
        "sample cobbles {\n  capture = \"cobbles/cobbles.lp\"\n}\n\n\
         representation rock {\n  from = cobbles\n  method = eigen\n}\n\n\
         map turn {\n  from = direction(angle = 30 deg)\n}\n\n\
         layer grown {\n  quilt = rock\n  block = 24 px\n  overlap = 6 px\n  orientation = turn\n}\n\n\
         output \"maps.exr\" {\n  from = grown\n  view = maps\n}\n",
        "no per-pixel linear map turns its maps",
        "view = maps",
    );
}

/// What each edit re-runs [references: dong §4.4]: a light only its relight, the block the
/// quilting and what follows it (never the fit), one photograph everything downstream of it.
#[test]
fn edits_re_run_only_the_stages_they_change() {
    let scene = |light: &str, block: &str| {
        format!(
            "sample cobbles {{\n  images = \"cobbles/cobbles_s*.png\"\n  lights = {GRID}\n}}\n\n\
             representation rock {{\n  from = cobbles\n  method = ptm\n}}\n\n\
             layer grown {{\n  quilt = rock\n  block = {block}\n  overlap = 6 px\n  light = light(tilt = {light} deg, slant = 60 deg)\n}}\n\n\
             output \"grown.exr\" {{\n  from = grown\n}}\n\n\
             output \"side.exr\" {{\n  from = grown\n  light = light(tilt = {light} deg, slant = 30 deg)\n}}\n"
        )
    };
    let p = project(&scene("60", "24 px"));
    let (run, first) = p.build_report(&["scene.tess"]);
    run.ok();
    let all = ran(&first);
    for stage in ["sample cobbles", "representation rock (fit)", "layer grown (quilt)", "layer grown"] {
        assert!(all.contains(&stage.to_string()), "{stage} missing from {all:?}");
    }
    let body =
        |light: &str, block: &str| format!("scene {{\n  seed = 2\n  size = 96 x 96\n}}\n\n{}", scene(light, block));
    p.write("scene.tess", &body("150", "24 px"));
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    assert_eq!(ran(&stages), vec!["layer grown", "output grown.exr", "output side.exr"], "a new light");
    p.write("scene.tess", &body("150", "20 px"));
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    assert_eq!(
        ran(&stages),
        vec![
            "layer grown",
            "layer grown (maps)",
            "layer grown (quilt)",
            "layer grown (relightable)",
            "output grown.exr",
            "output side.exr"
        ],
        "a new block"
    );
    // One photograph changes: the capture, the fit and everything after them.
    let mut img = decode(&p.read("cobbles/cobbles_s45_t090.png"));
    img.data[0] = 1.0 - img.data[0];
    p.write_bytes("cobbles/cobbles_s45_t090.png", &raster::io::encode_png(&img, 16).unwrap());
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    let again = ran(&stages);
    for stage in
        ["sample cobbles", "representation rock (fit)", "layer grown (quilt)", "layer grown", "output grown.exr"]
    {
        assert!(again.contains(&stage.to_string()), "{stage} did not re-run after an image changed: {again:?}");
    }
}

/// Numbers at their hostile values: out of range, beyond the capture, too large to hold, or a
/// bit depth the files' codes overflow, each a diagnostic at its property, nothing written.
#[test]
fn hostile_numbers_are_refused_at_the_property() {
    let scene = |sample: &str, rep: &str, out: &str| {
        format!(
            "sample cobbles {{\n  capture = \"cobbles/cobbles.lp\"\n{sample}}}\n\n\
             representation rock {{\n  from = cobbles\n  method = eigen\n{rep}}}\n\n\
             output \"o.exr\" {{\n  from = rock\n{out}}}\n"
        )
    };
    for (sample, rep, out, message, snippet) in [
        ("", "  components = 0\n", "", "expected an integer from 1 to 64, found 0", "components = 0"),
        ("", "  components = -3\n", "", "found -3", "components = -3"),
        ("", "  components = 1000000000000\n", "", "found 1000000000000", "components = 1000000000000"),
        ("", "  components = 37\n", "", "Eigen-37 needs k between 1 and the number of images (36)", "components = 37"),
        ("  bit_depth = 0\n", "", "", "expected an integer from 1 to 16, found 0", "bit_depth = 0"),
        ("  bit_depth = 17\n", "", "", "found 17", "bit_depth = 17"),
        ("  bit_depth = 4\n", "", "", "more than 4 bits can hold (15)", "bit_depth = 4"),
        ("", "", "  light = light(tilt = 0 deg, slant = -10 deg)\n", "must be from 0 deg to 90 deg", "-10 deg"),
        ("", "", "  light = light(tilt = 0 deg, slant = 95 deg)\n", "must be from 0 deg to 90 deg", "95 deg"),
        ("", "", "  light = light(tilt = 1e300 deg, slant = 45 deg)\n", "is too large", "1e300"),
        ("", "", "  light = light(tilt = 0 deg, slant = 1e-7 deg)\n", "outside the captured slant range", "light ="),
    ] {
        project(&scene(sample, rep, out)).refuses(message, snippet);
    }
}
