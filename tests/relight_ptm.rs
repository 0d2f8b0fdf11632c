//! PTM 1.2 files of relightable surfaces through the CLI: written by `output "x.ptm"`, read back
//! by the PTM reader and relit as the EXR outputs of the same surface; golden checks of `.ptm`
//! files; and the surfaces that cannot be written as PTM.

mod common;

use common::{flat, repo, Project};
use tessera::raster::{self, Image};
use tessera::synth::relight::ptm_file::{read_ptm, PtmFormat};
use tessera::synth::relight::{represent::ptm_vector, Light};

fn project(body: &str) -> Project {
    let p = Project::new(&[]);
    common::copy_dir(&repo().join("samples/capture/cobbles"), &p.path("cobbles"));
    p.write("scene.tess", &format!("scene {{\n  seed = 4\n  size = 96 x 96\n}}\n\n{body}"));
    p
}

const LIGHTS: [(f64, f64); 3] = [(60.0, 60.0), (200.0, 35.0), (315.0, 50.0)];

fn head() -> String {
    "sample cobbles {\n  capture = \"cobbles/cobbles.lp\"\n}\n\n\
     representation rock {\n  from = cobbles\n  method = ptm\n}\n\n\
     map turn {\n  from = direction(angle = 30 deg)\n}\n\n\
     layer grown {\n  quilt = rock\n  block = 24 px\n  overlap = 6 px\n}\n\n\
     layer turned {\n  quilt = rock\n  block = 24 px\n  overlap = 6 px\n  orientation = turn\n  copies = 6\n}\n\n"
        .into()
}

/// The outputs of `from`: its `.ptm`, its maps, and its relit EXRs at [`LIGHTS`].
fn outputs(from: &str) -> String {
    let mut s = format!(
        "output \"{from}.ptm\" {{\n  from = {from}\n}}\n\noutput \"{from}_maps.exr\" {{\n  from = {from}\n  view = maps\n}}\n\n"
    );
    for (i, (t, sl)) in LIGHTS.iter().enumerate() {
        s += &format!(
            "output \"{from}_{i}.exr\" {{\n  from = {from}\n  light = light(tilt = {t} deg, slant = {sl} deg)\n}}\n\n"
        );
    }
    s
}

fn decode(bytes: &[u8]) -> Image {
    raster::io::decode(bytes).expect("decodes")
}

/// The decoded file relit at each light against the EXR relit by tessera, within one
/// quantisation step of each coefficient (PTM stores bytes with a scale per coefficient).
fn relights_like_the_exr(p: &Project, from: &str) {
    let ptm = read_ptm(&p.read(&format!("out/scene/{from}.ptm"))).expect("reads");
    assert_eq!(ptm.format, PtmFormat::Lrgb);
    let maps = decode(&p.read(&format!("out/scene/{from}_maps.exr")));
    assert_eq!((ptm.width, ptm.height), (maps.width, maps.height));
    let m = maps.width * maps.height;
    // A grey capture: every colour byte is 255.
    assert!(ptm.colour.as_ref().expect("LRGB has colour").iter().all(|&c| c == 1.0));
    let range: Vec<f64> = (0..6)
        .map(|n| {
            let plane = maps.plane(n);
            let (lo, hi) = plane.iter().fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
            f64::from(hi - lo)
        })
        .collect();
    for (i, &(t, s)) in LIGHTS.iter().enumerate() {
        let light = Light::new(t, s);
        let v = ptm_vector(light.vector());
        let bound = (0..6).map(|n| v[n].abs() * range[n] / 255.0).sum::<f64>() + 1e-5;
        let relit = ptm.relight(&light);
        let exr = decode(&p.read(&format!("out/scene/{from}_{i}.exr")));
        let worst = (0..m).map(|j| (relit[j] - f64::from(exr.data[j])).abs()).fold(0.0, f64::max);
        assert!(worst <= bound, "{from} at {light:?}: {worst} > {bound}");
        assert!(worst > 0.0, "8-bit coefficients cannot be exact");
    }
}

#[test]
fn ptm_files_relight_like_the_surface_they_hold() {
    let p = project(&format!("{}{}{}{}", head(), outputs("rock"), outputs("grown"), outputs("turned")));
    p.tessera(&["build", "scene.tess", "-q"]).ok();
    for from in ["rock", "grown", "turned"] {
        relights_like_the_exr(&p, from);
    }
}

#[test]
fn ptm_rgb_files_hold_six_coefficients_per_channel() {
    let p = project(&format!("{}output \"rgb.ptm\" {{\n  from = rock\n  format = ptm_rgb\n}}\n", head()));
    p.tessera(&["build", "scene.tess", "-q"]).ok();
    let ptm = read_ptm(&p.read("out/scene/rgb.ptm")).expect("reads");
    assert_eq!(ptm.format, PtmFormat::Rgb);
    assert!(ptm.colour.is_none());
    let lit = ptm.relight(&Light::new(60.0, 60.0));
    let m = ptm.width * ptm.height;
    // Grey: the three channels relight alike.
    let worst = (0..m).map(|j| (lit[j] - lit[m + j]).abs().max((lit[j] - lit[2 * m + j]).abs())).fold(0.0, f64::max);
    assert!(worst < 1e-9, "channels differ by {worst}");
}

#[test]
fn the_golden_check_compares_ptm_files() {
    let p = project(&format!("{}output \"rock.ptm\" {{\n  from = rock\n}}\n", head()));
    p.tessera(&["bless", "scene.tess", "-q"]).ok();
    p.tessera(&["check", "scene.tess"]).ok();
    // One coefficient byte of the golden changed by a lot: the check fails and says where.
    let mut golden = p.read("golden/scene/rock.ptm");
    let at = golden.len() - 1000;
    golden[at] = golden[at].wrapping_add(128);
    p.write_bytes("golden/scene/rock.ptm", &golden);
    let run = p.tessera(&["check", "scene.tess"]);
    run.failed();
    assert!(run.stdout().contains("rock.ptm"), "{}", run.stdout());
    // A golden that is not a PTM file at all.
    p.write_bytes("golden/scene/rock.ptm", b"PTM_1.2\nnonsense\n");
    let run = p.tessera(&["check", "scene.tess"]);
    run.failed();
    assert!(flat(&format!("{}{}", run.stdout(), run.stderr())).contains("golden does not decode"));
    // A `.ptm` golden no output writes any more is stale: pruning removes it.
    p.write_bytes("golden/scene/old.ptm", &p.read("out/scene/rock.ptm"));
    p.tessera(&["bless", "scene.tess", "--prune", "-q"]).ok();
    assert!(!p.path("golden/scene/old.ptm").exists(), "the stale PTM golden was kept");
    assert!(p.path("golden/scene/rock.ptm").exists());
}

#[track_caller]
fn refused(body: &str, message: &str, snippet: &str) {
    project(&format!("{}{body}", head())).refuses(message, snippet);
}

#[test]
fn surfaces_that_are_not_ptm_are_refused_at_the_span() {
    refused(
        "representation stereo {\n  from = cobbles\n  method = gradient\n}\n\noutput \"s.ptm\" {\n  from = stereo\n}\n",
        "a `.ptm` file holds PTM coefficients, but `stereo` is fitted with `method = gradient`",
        "from = stereo",
    );
    refused(
        "representation e {\n  from = cobbles\n  method = eigen\n}\n\nlayer g {\n  quilt = e\n  block = 24 px\n}\n\noutput \"g.ptm\" {\n  from = g\n}\n",
        "is fitted with `method = eigen`",
        "from = g",
    );
    refused("output \"m.ptm\" {\n  from = turn\n}\n", "`turn` is not relightable", "from = turn");
    refused(
        "output \"r.ptm\" {\n  from = rock\n  light = light(tilt = 0 deg, slant = 30 deg)\n}\n",
        "`light` does not apply to a `.ptm` file",
        "light = light",
    );
    refused("output \"r.ptm\" {\n  from = rock\n  format = png16\n}\n", "format `png16` does not match", "png16");
    refused("output \"r.png\" {\n  from = rock\n  format = ptm_rgb\n}\n", "format `ptm_rgb` does not match", "ptm_rgb");
}
