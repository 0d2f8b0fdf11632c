//! The relief checks on the stand-ins: F31's sign test on the Biot wall against the greyscale
//! baseline, the door's two-patch gain, the chip's many colours and the plate's recorded failure
//! [references: frasson §5.3.3].

use super::fixtures::{self, class, Relief};
use super::{greyscale_depth, mean_abs_error, side_share};
use crate::raster::Image;
use crate::synth::quilt::{quilt_multipatch, Equalise, Guide, QuiltParams, Terms};

/// Multi-patch depth synthesis with the defaults of the `relief` layer: block 16, overlap 3
/// (≈ 1/6), exhaustive candidates, strict minimum, α = (0.3, 0.5, 0.2), CIELAB means, and each
/// channel scaled by its measured range (`equalise = minmax`): dark linear colours differ by
/// little, and on their nominal [0, 1] range the depth term outweighed the guide, so one block
/// that missed the mortar carried the miss on through every overlap. Returns the depth.
pub(super) fn relief_depth(guide: &Relief, patches: &[Relief], seed: u64) -> Image {
    let imgs: Vec<Image> = patches.iter().map(Relief::patch).collect();
    let refs: Vec<&Image> = imgs.iter().collect();
    let mut p = QuiltParams::new(guide.width(), guide.height_px(), 16, seed);
    p.overlap = 3;
    p.tolerance = 0.0;
    p.equalise = Equalise::MinMax;
    let r = quilt_multipatch(
        &refs,
        Guide { image: &guide.colour, weights: None, channels: Some(&[0, 1, 2]) },
        &[3],
        Terms::with_depth(0.3, 0.5, 0.2),
        true,
        &p,
    )
    .expect("valid relief inputs");
    Image { width: r.image.width, height: r.image.height, channels: 1, data: r.image.plane(3).to_vec() }
}

fn of(r: &Relief, k: u8) -> impl Fn(usize) -> bool + '_ {
    move |i| r.class[i] == k
}

#[test]
fn f31_brick_foliage_depth_has_the_right_sign_where_the_greyscale_baseline_fails() {
    let wall = fixtures::brick_foliage(11);
    let depth = relief_depth(&wall, &fixtures::brick_foliage_patches(12), 13);
    let mortar = side_share(&depth, of(&wall, class::MORTAR), 0.5, false).unwrap();
    let foliage = side_share(&depth, of(&wall, class::FOLIAGE), 0.5, true).unwrap();
    let light = side_share(&depth, of(&wall, class::LIGHT_MORTAR), 0.5, false).unwrap();
    let grey = greyscale_depth(&wall.colour);
    let grey_mortar = side_share(&grey, of(&wall, class::MORTAR), 0.5, false).unwrap();
    let grey_foliage = side_share(&grey, of(&wall, class::FOLIAGE), 0.5, true).unwrap();
    println!(
        "F31 brick+foliage: mortar below 0.5 on {:.1} %, foliage above on {:.1} % (light mortar {:.1} %); \
         greyscale baseline: mortar {:.1} %, foliage {:.1} %",
        100.0 * mortar,
        100.0 * foliage,
        100.0 * light,
        100.0 * grey_mortar,
        100.0 * grey_foliage
    );
    assert!(mortar >= 0.9 && foliage >= 0.9, "mortar {mortar}, foliage {foliage}");
    assert!(grey_foliage < 0.5, "the baseline must get the dark foliage wrong: {grey_foliage}");
}

#[test]
fn door_two_patches_beat_the_greyscale_baseline() {
    let door = fixtures::door(160, 160, 40, 21);
    let patches = [fixtures::door(100, 100, 0, 22), fixtures::door(100, 100, 24, 23)];
    let depth = relief_depth(&door, &patches, 24);
    let all = |_| true;
    let ours = mean_abs_error(&depth, &door.height, all).unwrap();
    let grey = mean_abs_error(&greyscale_depth(&door.colour), &door.height, all).unwrap();
    let studs = side_share(&depth, of(&door, class::STUD), 0.5, true).unwrap();
    let grooves = side_share(&depth, of(&door, class::GROOVE), 0.5, false).unwrap();
    println!("door: depth MAE {ours:.4} with 2 patches vs {grey:.4} greyscale; studs up {studs:.3}, grooves down {grooves:.3}");
    assert!(ours < 0.5 * grey, "two patches {ours} vs baseline {grey}");
    assert!(studs >= 0.8 && grooves >= 0.8);
}

#[test]
fn chip_colours_missing_from_every_patch_take_a_wrong_depth() {
    // Six colour classes, each at its own depth; the one patch holds only the first two.
    let chip = fixtures::chip(160, 160, 6, 31);
    let depth = relief_depth(&chip, &[fixtures::chip(100, 100, 2, 32)], 33);
    let covered = |i: usize| chip.class[i] == class::CHIP || chip.class[i] == class::CHIP + 1;
    let missing = |i: usize| chip.class[i] > class::CHIP + 1;
    let covered = mean_abs_error(&depth, &chip.height, covered).unwrap();
    let missing = mean_abs_error(&depth, &chip.height, missing).unwrap();
    println!("chip: depth MAE {covered:.4} on the colours the patch holds, {missing:.4} on the four it lacks");
    assert!(covered < 0.5 * missing, "{covered} vs {missing}");
}

#[test]
fn block_depth_follows_the_rock() {
    let rock = fixtures::block(128, 128, 41);
    let depth = relief_depth(&rock, &[fixtures::block(100, 100, 42)], 43);
    let r = correlation(&depth, &rock.height);
    let grey = correlation(&greyscale_depth(&rock.colour), &rock.height);
    println!("block: correlation of depth with the true height {r:.3} (greyscale baseline {grey:.3})");
    assert!(r > 0.6, "{r}");
}

#[test]
fn f36_the_plate_failure_is_recorded() {
    // Bumps of the base's own colour: colour cannot say where they are.
    let plate = fixtures::plate(160, 160, 8, 51);
    let depth = relief_depth(&plate, &[fixtures::plate(100, 100, 4, 52)], 53);
    let bumps = side_share(&depth, of(&plate, class::BUMP), 0.6, true).unwrap();
    let false_bumps = side_share(&depth, of(&plate, class::BASE), 0.6, true).unwrap();
    let err = mean_abs_error(&depth, &plate.height, of(&plate, class::BUMP)).unwrap();
    println!(
        "F36 plate: {:.1} % of true bump pixels raised above 0.6, {:.1} % of base pixels raised; MAE on bumps {err:.3}",
        100.0 * bumps,
        100.0 * false_bumps
    );
    // The known limitation: bumps are found no better than by chance. A shape layer that fixes
    // this must change this test on purpose.
    assert!(bumps < 0.5, "bumps found on {bumps}: the plate no longer fails; update the record");
    assert!(err > 0.1, "{err}");
}

fn correlation(a: &Image, b: &Image) -> f64 {
    let n = a.data.len() as f64;
    let ma = a.data.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
    let mb = b.data.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (&x, &y) in a.data.iter().zip(&b.data) {
        let (x, y) = (f64::from(x) - ma, f64::from(y) - mb);
        sab += x * y;
        saa += x * x;
        sbb += y * y;
    }
    sab / (saa * sbb).sqrt()
}
