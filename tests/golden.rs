//! Golden checks: the committed goldens pass; a golden changed beyond tolerance fails with a
//! diff image and a non-zero exit; `bless` accepts the current outputs.

mod common;

use common::Project;
use tessera::raster::{self, Image};

#[test]
fn committed_goldens_pass() {
    let p = Project::copy_of_repo();
    let run = p.tessera(&["check", "scenes"]);
    run.ok();
    assert!(run.stdout().contains(" 0 failed"), "{}", run.stdout());
}

#[test]
fn one_changed_pixel_beyond_tolerance_fails_with_a_diff_image() {
    let p = Project::copy_of_repo();
    let golden = "golden/masks/density.png";
    let mut img: Image = raster::io::decode(&p.read(golden)).expect("decode golden");
    let v = img.get(10, 10, 0);
    img.set(10, 10, 0, if v > 0.5 { v - 0.05 } else { v + 0.05 });
    p.write_bytes(golden, &raster::io::encode_png(&img, 8).expect("encode"));

    let run = p.tessera(&["check", "scenes"]);
    run.failed();
    let out = run.stdout();
    assert!(out.contains("FAIL") && out.contains("density.png") && out.contains("1/49152"), "{out}");
    let diff = p.path("out/.diff/masks/density.png.diff.png");
    assert!(diff.exists(), "no diff image:\n{out}");
    let d = raster::io::decode(&std::fs::read(diff).expect("read diff")).expect("decode diff");
    assert_eq!((d.width, d.height), (256, 192));
}

#[test]
fn a_change_within_tolerance_passes() {
    let p = Project::copy_of_repo();
    let golden = "golden/masks/density.exr";
    let mut img: Image = raster::io::decode(&p.read(golden)).expect("decode golden");
    let v = img.get(5, 5, 0);
    img.set(5, 5, 0, v + 0.00005);
    p.write_bytes(golden, &raster::io::encode_exr(&img).expect("encode"));
    p.tessera(&["check", "scenes/masks.tess"]).ok();
}

#[test]
fn missing_golden_fails_and_bless_fixes_it() {
    let p = Project::copy_of_repo();
    std::fs::remove_file(p.path("golden/fields/grain.png")).expect("remove");
    let run = p.tessera(&["check", "scenes/fields.tess"]);
    run.failed();
    assert!(run.stdout().contains("MISS"), "{}", run.stdout());
    p.tessera(&["bless", "scenes/fields.tess"]).ok();
    p.tessera(&["check", "scenes/fields.tess"]).ok();
}

#[test]
fn a_changed_mesh_fails_with_its_hausdorff_distance() {
    let p = Project::copy_of_repo();
    let golden = "golden/wall_regular/mesh.json";
    let text = String::from_utf8(p.read(golden)).expect("utf-8");
    // Move a vertex of the left border 2 px to the right.
    assert!(text.contains("[0, 119]"), "pick another vertex of the golden");
    let text = text.replacen("[0, 119]", "[2, 119]", 1);
    p.write_bytes(golden, text.as_bytes());
    let run = p.tessera(&["check", "scenes/wall_regular.tess"]);
    run.failed();
    let out = run.stdout();
    assert!(out.contains("FAIL") && out.contains("mesh.json"), "{out}");
    let line = out.lines().find(|l| l.contains("Hausdorff distance")).unwrap_or_else(|| panic!("no mesh note:\n{out}"));
    let d: f64 = line.split("edge sets ").nth(1).and_then(|t| t.split(' ').next()).expect("distance").parse().unwrap();
    assert!((1.75..=2.0).contains(&d), "{line}");
    assert!(line.contains("reached near (0.0, 119.0)") || line.contains("reached near (2.0, 119.0)"), "{line}");
}
