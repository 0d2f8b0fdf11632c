//! Depth instanced through a structured appearance [references: frasson §5.4], through the CLI:
//! on the random wall stand-in rebuilt from its own drawing, whose mortar mask is ground truth,
//! a depth quilted per unified texture and per atlas keeps the mortar down and the stones up
//! better than the same quilting guided by the photo alone, and a new target (the structure
//! edited) draws the depth again without quilting anything.

mod common;

use common::{repo, Project};
use tessera::raster::{self, Image};
use tessera::synth::relief::{mean_abs_error, side_share};

const STONE: f32 = 0.75;
const MORTAR: f32 = 0.25;

fn decode(bytes: &[u8]) -> Image {
    raster::io::decode(bytes).expect("decodes")
}

/// The photo's `w × h` window at `(x, y)` and its true height (mortar 0.25, stone 0.75).
fn cut(photo: &Image, mortar: &Image, (x, y): (usize, usize), (w, h): (usize, usize)) -> (Image, Image) {
    let colour = Image::from_fn(w, h, 3, |i, j, c| photo.get(x + i, y + j, c));
    let height = Image::from_fn(w, h, 1, |i, j, _| if mortar.get(x + i, y + j, 0) > 0.5 { MORTAR } else { STONE });
    (colour, height)
}

/// Mortar share of a window.
fn share(mortar: &Image, (x, y): (usize, usize), (w, h): (usize, usize)) -> f64 {
    let mut n = 0usize;
    for j in y..y + h {
        for i in x..x + w {
            n += usize::from(mortar.get(i, j, 0) > 0.5);
        }
    }
    n as f64 / (w * h) as f64
}

/// The patches, cut where the mask says: a stone (a 32² window without mortar), a mortar joint
/// as the interstice atlas holds it (a 40 × 16 window with a horizontal joint along its middle
/// and stone above and below), and a piece of wall (the 48² window nearest 40 % mortar).
fn patches(p: &Project, photo: &Image, mortar: &Image) {
    let (w, h) = (photo.width, photo.height);
    let stones: Vec<(usize, usize)> = (0..h - 32)
        .step_by(4)
        .flat_map(|y| (0..w - 32).step_by(4).map(move |x| (x, y)))
        .filter(|&at| share(mortar, at, (32, 32)) == 0.0)
        .collect();
    assert!(!stones.is_empty(), "the wall has stones of 32 px");
    let stone = stones[stones.len() / 2];
    let joint_score = |at: (usize, usize)| {
        share(mortar, (at.0, at.1 + 6), (40, 4))
            - 0.5 * (share(mortar, at, (40, 3)) + share(mortar, (at.0, at.1 + 13), (40, 3)))
    };
    let windows = |size: usize, wide: usize| {
        (0..h - size).step_by(2).flat_map(move |y| (0..w - wide).step_by(2).map(move |x| (x, y)))
    };
    let joint = windows(16, 40).max_by(|&a, &b| joint_score(a).total_cmp(&joint_score(b))).expect("windows");
    assert!(joint_score(joint) > 0.9, "a horizontal joint: {}", joint_score(joint));
    let piece = windows(48, 48)
        .min_by(|&a, &b| (share(mortar, a, (48, 48)) - 0.4).abs().total_cmp(&(share(mortar, b, (48, 48)) - 0.4).abs()))
        .expect("windows");
    for (name, at, size) in [("stone", stone, (32, 32)), ("joint", joint, (40, 16)), ("piece", piece, (48, 48))] {
        let (colour, height) = cut(photo, mortar, at, size);
        p.write_bytes(&format!("{name}.png"), &common::png(&colour));
        p.write_bytes(&format!("{name}_height.png"), &common::png(&height));
    }
}

fn scene(structured: &str) -> String {
    let patch = |n: &str| format!("sample {n} {{\n  image = \"{n}.png\"\n  height = \"{n}_height.png\"\n}}\n\n");
    format!(
        "scene {{\n  seed = 13\n  size = 512 x 384\n}}\n\n\
         sample stones {{\n  image = \"s/wall_random_photo.png\"\n  structure = \"s/wall_random.json\"\n}}\n\n\
         {}{}{}\
         surface wall {{\n  plane = 512 x 384\n}}\n\n\
         structure layout {{\n  from = stones\n  on = wall\n  scale = 0.9\n}}\n\n\
         appearance rebuilt {{\n  from = stones\n}}\n\n\
         appearance dressed {{\n  from = stones\n  on = layout\n}}\n\n\
         {structured}\
         layer plain {{\n  relief = [stone, piece]\n  guide = stones\n  block = 12 px\n  overlap = 3 px\n}}\n\n\
         output \"structured.png\" {{\n  from = structured\n  view = height\n  format = png16\n}}\n\n\
         output \"plain.png\" {{\n  from = plain\n  view = height\n  format = png16\n}}\n\n\
         output \"colour.png\" {{\n  from = structured\n}}\n\n\
         output \"rebuilt.png\" {{\n  from = rebuilt\n}}\n",
        patch("stone"),
        patch("joint"),
        patch("piece"),
    )
}

fn structured(guide: &str) -> String {
    format!(
        "layer structured {{\n  relief = [stone]\n  contour_relief = [joint]\n  guide = {guide}\n  block = 12 px\n  overlap = 3 px\n}}\n\n"
    )
}

fn project() -> Project {
    let p = Project::new(&[]);
    common::copy_dir(&repo().join("samples/standins"), &p.path("s"));
    let photo = decode(&p.read("s/wall_random_photo.png"));
    let mortar = decode(&p.read("s/wall_random_mortar.png"));
    patches(&p, &photo, &mortar);
    p
}

#[test]
fn depth_through_an_appearance_keeps_mortar_down_and_stones_up() {
    let p = project();
    p.write("scene.tess", &scene(&structured("rebuilt")));
    p.tessera(&["build", "scene.tess"]).ok();
    let mortar = decode(&p.read("s/wall_random_mortar.png"));
    let is_mortar = |i: usize| mortar.data[i] > 0.5;
    let truth = Image::from_fn(
        mortar.width,
        mortar.height,
        1,
        |x, y, _| {
            if mortar.get(x, y, 0) > 0.5 {
                MORTAR
            } else {
                STONE
            }
        },
    );
    let score = |file: &str| {
        let d = decode(&p.read(&format!("out/scene/{file}")));
        assert_eq!((d.width, d.height), (mortar.width, mortar.height));
        let down = side_share(&d, is_mortar, 0.5, false).unwrap();
        let up = side_share(&d, |i| !is_mortar(i), 0.5, true).unwrap();
        let mae = mean_abs_error(&d, &truth, |_| true).unwrap();
        println!("{file}: mortar below 0.5 on {:.1} %, stone above on {:.1} %, MAE {mae:.4}", 100.0 * down, 100.0 * up);
        (down, up, mae)
    };
    let (s_down, s_up, s_mae) = score("structured.png");
    let (p_down, p_up, p_mae) = score("plain.png");
    assert!(s_up >= 0.9, "the stones stand up");
    assert!(s_down > p_down && s_up > p_up && s_mae < p_mae, "the structure helps the depth on every count");
    // The colour is the appearance's own, untouched.
    let colour = decode(&p.read("out/scene/colour.png"));
    let rebuilt = decode(&p.read("out/scene/rebuilt.png"));
    assert_eq!((colour.width, colour.height, colour.channels), (rebuilt.width, rebuilt.height, 3));
    // Where the appearance covers the wall fully (its PNG keeps alpha), the pixels are the same.
    let mut covered = 0;
    for y in 0..colour.height {
        for x in 0..colour.width {
            if rebuilt.get(x, y, 3) == 1.0 {
                covered += 1;
                assert!(
                    (0..3).all(|c| colour.get(x, y, c) == rebuilt.get(x, y, c)),
                    "the layer's colour is the appearance's"
                );
            }
        }
    }
    assert!(covered > colour.width * colour.height / 2);
}

#[test]
fn a_new_target_draws_the_depth_again_without_quilting() {
    let p = project();
    p.write("scene.tess", &scene(&structured("dressed")));
    p.tessera(&["build", "scene.tess"]).ok();
    let before = p.read("out/scene/structured.png");
    p.write("scene.tess", &p.read_text("scene.tess").replace("scale = 0.9", "scale = 0.8"));
    let (run, stages) = p.build_report(&["scene.tess"]);
    run.ok();
    let ran = common::ran(&stages);
    assert!(ran.iter().any(|s| s == "layer structured (instanced depth)"), "{ran:?}");
    assert!(
        !ran.iter().any(|s| s.contains("relief textures") || s.contains("interiors") || s.contains("contours")),
        "{ran:?}"
    );
    assert_ne!(before, p.read("out/scene/structured.png"), "the new structure has its own depth");
}

#[test]
fn instanced_relief_properties_are_checked_at_their_span() {
    let p = project();
    p.write("scene.tess", &scene(&structured("rebuilt").replace("  block", "  on = wall\n  block")));
    p.refuses("`on` does not apply to a relief guided by an appearance", "on = wall");
    p.write("scene.tess", &scene(&structured("stones")));
    p.refuses("`contour_relief` serves the contour atlases of an appearance", "contour_relief = [joint]");
    p.write(
        "scene.tess",
        &scene(&structured("rebuilt").replace("contour_relief = [joint]", "contour_relief = [stones]")),
    );
    p.refuses("`stones` is not a patch", "contour_relief = [stones]");
    // A joint patch smaller than a block fails at the atlases' patches, not at the stones'.
    p.write("scene.tess", &scene(&structured("rebuilt").replace("block = 12 px", "block = 20 px")));
    let run = p.tessera(&["build", "scene.tess"]);
    run.failed();
    let err = run.stderr();
    assert!(err.contains("block size 20 does not fit"), "{err}");
    assert!(err.contains("contour_relief = [joint]") && !err.contains("panicked"), "{err}");
}
