//! The relighting evaluation through the language: the committed stand-in captures of the
//! synthetic scenarios (`samples/capture/scenario_*`, 16-bit linear PNGs and a light-position
//! file) fitted by the five methods, their `view = report` JSON held to the reference
//! prototype's table and to the orderings the thesis reports [references: dong §4.5.1]; and a
//! 12-bit capture in 16-bit files read with `bit_depth = 12` [references: dong §3.3].
//!
//! The prototype ran on the f64 renders; the files hold them rounded to 16 bits (full scale =
//! the capture's largest value), which η, being scale invariant, sees only as that rounding.

mod common;

use common::{repo, Project};
use tessera::raster::{self, Image};
use tessera::synth::relight::evaluate::{evaluate, Evaluation};
use tessera::synth::relight::fixtures::{self, meets_prototype, Scenario, PROTOTYPE, PROTOTYPE_METHODS};
use tessera::synth::relight::Light;

/// The five representations of the prototype's table, as `(name, method properties)`.
const METHODS: [(&str, &str); 5] = [
    ("three_i", "method = three_i"),
    ("gradient", "method = gradient"),
    ("ptm", "method = ptm"),
    ("eigen3", "method = eigen\n  components = 3"),
    ("eigen6", "method = eigen\n  components = 6"),
];

/// `(reconstruction η, prediction η, reconstruction Frobenius error)` of each method, in the
/// order of [`METHODS`], read from the reports a build of scenario `s`'s capture writes.
fn reports(s: Scenario) -> Vec<(f64, f64, f64)> {
    let name = format!("scenario_{}", format!("{s:?}").to_lowercase());
    let p = Project::new(&[]);
    common::copy_dir(&repo().join("samples/capture").join(&name), &p.path(&name));
    let mut scene = format!(
        "scene {{\n  seed = 1\n  size = 32 x 32\n}}\n\n\
         sample capture {{\n  capture = \"{name}/{name}.lp\"\n  transfer = linear\n}}\n"
    );
    for (rep, props) in METHODS {
        scene.push_str(&format!(
            "\nrepresentation {rep} {{\n  from = capture\n  {props}\n}}\n\n\
             output \"{rep}.json\" {{\n  from = {rep}\n  view = report\n}}\n"
        ));
    }
    p.write("scene.tess", &scene);
    p.tessera(&["build", "scene.tess", "-q"]).ok();
    METHODS
        .iter()
        .zip(PROTOTYPE_METHODS)
        .map(|((rep, _), method)| {
            let text = String::from_utf8(p.read(&format!("out/scene/{rep}.json"))).expect("utf-8");
            let ev: Evaluation = serde_json::from_str(&text).expect("an evaluation report");
            assert_eq!((ev.width, ev.height, ev.images), (32, 32, 36));
            assert_eq!(ev.methods.len(), 1);
            let m = &ev.methods[0];
            assert_eq!(m.method, method, "{rep}");
            let pred = m.prediction.as_ref().expect("a leave-one-out mode").eta;
            (m.reconstruction.eta, pred, m.reconstruction.frobenius)
        })
        .collect()
}

/// The capture's files divide every image by the render's largest value: the factor between
/// the files' Frobenius errors and the prototype's.
fn file_scale(s: Scenario) -> f64 {
    1.0 / fixtures::scenario(s).stack.images.iter().flatten().cloned().fold(0.0, f64::max)
}

/// Scenario `s` through the CLI against the prototype: every η within ±2 % (≤ 1e-6 where 0),
/// the Frobenius errors where given (after undoing the files' scale); returns the misses.
fn against_prototype(s: Scenario) -> (Vec<(f64, f64, f64)>, Vec<String>) {
    let got = reports(s);
    let want = PROTOTYPE.iter().find(|p| p.scenario == s).expect("a prototype row");
    let scale = file_scale(s);
    let mut bad = Vec::new();
    for (i, &(recon, pred, frob)) in got.iter().enumerate() {
        let m = PROTOTYPE_METHODS[i].name();
        println!(
            "{s:?} {m:8} recon η {recon:.6} (prototype {:.4})  pred η {pred:.6} (prototype {:.4})",
            want.recon[i], want.pred[i]
        );
        if !meets_prototype(recon, want.recon[i]) {
            bad.push(format!("{s:?} recon {m}: {recon} vs {}", want.recon[i]));
        }
        if !meets_prototype(pred, want.pred[i]) {
            bad.push(format!("{s:?} pred {m}: {pred} vs {}", want.pred[i]));
        }
        if let Some(f) = want.frobenius {
            println!("{s:?} {m:8} recon ‖·‖_F {:.4} (prototype {})", frob / scale, f[i]);
            if !meets_prototype(frob / scale, f[i]) {
                bad.push(format!("{s:?} Frobenius {m}: {} vs {}", frob / scale, f[i]));
            }
        }
    }
    (got, bad)
}

/// [`fixtures::assert_thesis_orderings`] on the (recon, pred, Frobenius) triples of a report.
fn assert_thesis_orderings(s: Scenario, got: &[(f64, f64, f64)]) {
    let recon: Vec<f64> = got.iter().map(|g| g.0).collect();
    let pred: Vec<f64> = got.iter().map(|g| g.1).collect();
    fixtures::assert_thesis_orderings(s, &recon, &pred);
}

/// Dong `item 12`, scenario B (specular, unshadowed) from its files.
#[test]
fn scenario_b_reports_the_prototype_table() {
    let (got, bad) = against_prototype(Scenario::B);
    assert!(bad.is_empty(), "not reproduced:\n{}", bad.join("\n"));
    assert_thesis_orderings(Scenario::B, &got);
}

/// Dong `item 12`, scenario C (a weaker highlight) from its files.
#[test]
fn scenario_c_reports_the_prototype_table() {
    let (got, bad) = against_prototype(Scenario::C);
    assert!(bad.is_empty(), "not reproduced:\n{}", bad.join("\n"));
    assert_thesis_orderings(Scenario::C, &got);
}

/// Dong `item 12`, scenario D (attached shadows) from its files: the table only (the thesis's
/// orderings are not expected here: Eigen prediction loses to PTM).
#[test]
fn scenario_d_reports_the_prototype_table() {
    let (_, bad) = against_prototype(Scenario::D);
    assert!(bad.is_empty(), "not reproduced:\n{}", bad.join("\n"));
}

/// Dong `item 12`, scenario A (unshadowed Lambertian) from its 16-bit files: PTM in both
/// modes and Eigen prediction (the entries that are not 0) within ±2 % of the prototype. The
/// entries that are 0 on f64 data (3I, Gradient, Eigen reconstruction, 3I and Gradient
/// prediction) are not 0 on these files: every linear method is exact on the f64 renders, so
/// all that is left is the files' 16-bit rounding, about 3e-5 to 5e-5 here, beyond the
/// prototype's 1e-6. This test shows that is all it is: those entries equal the library's
/// evaluation of the render rounded to 16 bits (`fixtures::quantise`), and the next test meets
/// the 1e-6 from f32 files.
#[test]
fn scenario_a_from_16_bit_files_differs_from_the_prototype_by_the_rounding_only() {
    let s = Scenario::A;
    let got = reports(s);
    let want = PROTOTYPE.iter().find(|p| p.scenario == s).expect("a prototype row");
    let rounded = fixtures::quantise(&fixtures::scenario(s).stack, 16);
    let library = evaluate(&rounded, &PROTOTYPE_METHODS, true).expect("evaluates");
    for (i, &(recon, pred, _)) in got.iter().enumerate() {
        let m = PROTOTYPE_METHODS[i].name();
        let lib = &library.methods[i];
        let lib_pred = lib.prediction.as_ref().expect("prediction").eta;
        println!(
            "A {m:8} recon η {recon:.3e} (16-bit in the library {:.3e}, prototype {})  pred η {pred:.3e} (library {lib_pred:.3e}, prototype {})",
            lib.reconstruction.eta, want.recon[i], want.pred[i]
        );
        for (mode, v, proto, lib) in
            [("recon", recon, want.recon[i], lib.reconstruction.eta), ("pred", pred, want.pred[i], lib_pred)]
        {
            if proto == 0.0 {
                assert!(
                    v < 1e-4 && ((v - lib) / lib).abs() < 0.01,
                    "A {mode} {m}: {v}, the 16-bit rounding gives {lib}"
                );
            } else {
                assert!(meets_prototype(v, proto), "A {mode} {m}: {v} vs {proto}");
            }
        }
    }
}

/// Dong `item 12`, scenario A through the language from f32 EXR files (written here from the
/// same renders, not committed): every entry within the prototype's tolerance, the zeros
/// within 1e-6.
#[test]
fn scenario_a_from_f32_files_reports_the_prototype_table() {
    let s = Scenario::A;
    let c = fixtures::scenario(s);
    let top = c.stack.images.iter().flatten().cloned().fold(0.0, f64::max);
    let p = Project::new(&[]);
    let mut lp = format!("{}\n", c.stack.len());
    for (k, (img, light)) in c.stack.images.iter().zip(&c.stack.lights).enumerate() {
        let data = img.iter().map(|v| (v / top) as f32).collect();
        let exr = raster::io::encode_exr(&Image { width: c.n, height: c.n, channels: 1, data }).expect("exr");
        p.write_bytes(&format!("a/a_{k:02}.exr"), &exr);
        let d = light.rti_direction();
        lp.push_str(&format!("a_{k:02}.exr {:.15} {:.15} {:.15}\n", d.x, d.y, d.z));
    }
    p.write("a/a.lp", &lp);
    let mut scene =
        String::from("scene {\n  seed = 1\n  size = 32 x 32\n}\n\nsample capture {\n  capture = \"a/a.lp\"\n}\n");
    for (rep, props) in METHODS {
        scene.push_str(&format!(
            "\nrepresentation {rep} {{\n  from = capture\n  {props}\n}}\n\noutput \"{rep}.json\" {{\n  from = {rep}\n  view = report\n}}\n"
        ));
    }
    p.write("scene.tess", &scene);
    p.tessera(&["build", "scene.tess", "-q"]).ok();
    let mut bad = Vec::new();
    for (i, (rep, _)) in METHODS.iter().enumerate() {
        let text = String::from_utf8(p.read(&format!("out/scene/{rep}.json"))).expect("utf-8");
        let ev: Evaluation = serde_json::from_str(&text).expect("an evaluation report");
        let m = &ev.methods[0];
        let (recon, pred) = (m.reconstruction.eta, m.prediction.as_ref().expect("prediction").eta);
        println!(
            "A (f32) {:8} recon η {recon:.3e} (prototype {})  pred η {pred:.3e} (prototype {})",
            m.name,
            want(i).0,
            want(i).1
        );
        if !meets_prototype(recon, want(i).0) {
            bad.push(format!("A recon {}: {recon} vs {}", m.name, want(i).0));
        }
        if !meets_prototype(pred, want(i).1) {
            bad.push(format!("A pred {}: {pred} vs {}", m.name, want(i).1));
        }
    }
    assert!(bad.is_empty(), "not reproduced:\n{}", bad.join("\n"));

    fn want(i: usize) -> (f64, f64) {
        let row = PROTOTYPE.iter().find(|p| p.scenario == Scenario::A).expect("a prototype row");
        (row.recon[i], row.pred[i])
    }
}

/// Dong `items 3 and 5`: a 12-bit capture (codes 0…4095 in 16-bit PNGs, PhoTex-style) read
/// with `bit_depth = 12` loads as exactly `code / 4095`: the 3I maps, which are the three
/// images themselves, equal it bit for bit in f32; and 3I relit at a fourth light is within
/// η ≤ 2e-3 of the unquantised truth.
#[test]
fn a_twelve_bit_capture_round_trips_through_the_language() {
    let n = 32;
    let triple = [Light::new(0.0, 45.0), Light::new(90.0, 45.0), Light::new(180.0, 45.0)];
    let fourth = Light::new(60.0, 60.0);
    // Full scale is the largest value of the 36-light capture, as a camera's exposure would
    // be set for the whole set.
    let full = fixtures::scenario(Scenario::A);
    let top = full.stack.images.iter().flatten().cloned().fold(0.0, f64::max);
    let lit = fixtures::render(Scenario::A, n, &[triple[0], triple[1], triple[2], fourth]);
    let p = Project::new(&[]);
    let mut lp = String::from("3\n");
    let mut codes: Vec<Vec<u16>> = Vec::new();
    for (k, light) in triple.iter().enumerate() {
        let c: Vec<u16> = lit.stack.images[k].iter().map(|v| (v / top * 4095.0).round() as u16).collect();
        assert!(c.iter().all(|&v| v <= 4095) && c.iter().any(|&v| v > 2048));
        let data = c.iter().map(|&v| f32::from(v) / 65535.0).collect();
        let png = raster::io::encode_png(&Image { width: n, height: n, channels: 1, data }, 16).expect("png");
        // The container holds the 12-bit code itself, not the code scaled to 16 bits.
        let back = raster::io::decode(&png).expect("decodes");
        assert!(back.data.iter().zip(&c).all(|(&v, &code)| (v * 65535.0).round() as u16 == code));
        let file = format!("twelve_{k}.png");
        p.write_bytes(&format!("twelve/{file}"), &png);
        let d = light.rti_direction();
        lp.push_str(&format!("{file} {:.15} {:.15} {:.15}\n", d.x, d.y, d.z));
        codes.push(c);
    }
    p.write("twelve/twelve.lp", &lp);
    p.write(
        "scene.tess",
        "scene {\n  seed = 1\n  size = 32 x 32\n}\n\n\
         sample twelve {\n  capture = \"twelve/twelve.lp\"\n  bit_depth = 12\n  transfer = linear\n}\n\n\
         representation three {\n  from = twelve\n  method = three_i\n}\n\n\
         output \"maps.exr\" {\n  from = three\n  view = maps\n}\n\n\
         output \"relit.exr\" {\n  from = three\n  light = light(tilt = 60 deg, slant = 60 deg)\n}\n",
    );
    p.tessera(&["build", "scene.tess", "-q"]).ok();
    let maps = raster::io::decode(&p.read("out/scene/maps.exr")).expect("decodes");
    assert_eq!((maps.width, maps.height, maps.channels), (n, n, 3));
    for (k, c) in codes.iter().enumerate() {
        let off: Vec<(usize, f32, f32)> = maps
            .plane(k)
            .iter()
            .zip(c)
            .enumerate()
            .filter(|(_, (&v, &code))| v.to_bits() != (f32::from(code) / 4095.0).to_bits())
            .map(|(j, (&v, &code))| (j, v, f32::from(code) / 4095.0))
            .collect();
        assert!(
            off.is_empty(),
            "image {k}: {} of {} values are not code / 4095, e.g. {:?}",
            off.len(),
            n * n,
            &off[..off.len().min(3)]
        );
    }
    // The fourth light against the unquantised truth, on the same scale (1 = the capture's
    // largest value).
    let relit = raster::io::decode(&p.read("out/scene/relit.exr")).expect("decodes");
    let truth: Vec<f64> = lit.stack.images[3].iter().map(|v| v / top).collect();
    let m = truth.len() as f64;
    let mean = truth.iter().sum::<f64>() / m;
    let sd = (truth.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / m).sqrt();
    let rms = (relit.data.iter().zip(&truth).map(|(&r, t)| (f64::from(r) - t).powi(2)).sum::<f64>() / m).sqrt();
    let eta = rms / sd;
    println!("12-bit 3I η at (60°, 60°) against the unquantised truth: {eta:.3e}");
    assert!(eta <= 2e-3, "η {eta}");
}
