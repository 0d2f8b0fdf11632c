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
    let diff = p.path("out/masks/density.diff.png");
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
