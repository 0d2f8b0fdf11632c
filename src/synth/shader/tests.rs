//! Checks of the shader library [references: bourque §5]: schemas (F1, F5), determinism (F2),
//! resolution independence (F3), continuity in every float parameter (F4), filtered edges, the
//! noise, and the star at whole and broken numbers of points (F31).

use super::params::{flat_len, validate, ParamError};
use super::prims::{filtered_interval, filtered_pulse_train, floor, snoise};
use super::*;
use crate::synth::rng::Rng;

fn mean_abs_diff(a: &Image, b: &Image) -> f64 {
    assert_eq!((a.width, a.height, a.channels), (b.width, b.height, b.channels));
    a.data.iter().zip(&b.data).map(|(x, y)| (x - y).abs() as f64).sum::<f64>() / a.data.len() as f64
}

/// Bourque's power-spectrum similarity at default options.
fn s_f(a: &Image, b: &Image) -> f64 {
    use crate::synth::metrics::{power_feature, power_similarity, PowerParams};
    let p = PowerParams::default();
    power_similarity(&power_feature(a, &p).unwrap(), &power_feature(b, &p).unwrap()).unwrap()
}

/// Box-downsampling by an integer factor.
fn downsample(img: &Image, k: usize) -> Image {
    Image::from_fn(img.width / k, img.height / k, img.channels, |x, y, c| {
        let mut s = 0.0;
        for j in 0..k {
            for i in 0..k {
                s += img.get(x * k + i, y * k + j, c);
            }
        }
        s / (k * k) as f32
    })
}

/// A random parameter vector inside every range (integers whole).
fn random_values(def: &ShaderDef, rng: &mut Rng) -> Vec<f64> {
    let mut v = Vec::new();
    for p in def.params {
        let (lo, hi) = p.kind.bounds();
        for _ in 0..p.kind.width() {
            let x = lo + (hi - lo) * rng.next_f64();
            v.push(if matches!(p.kind, ParamKind::Int { .. }) { x.round() } else { x });
        }
    }
    v
}

#[test]
fn every_default_lies_inside_its_range_and_the_schema_round_trips() {
    // F1.
    assert_eq!(LIBRARY.len(), 13);
    for def in LIBRARY {
        validate(def.params, &def.defaults()).unwrap_or_else(|e| panic!("{}: {e}", def.name));
        for p in def.params {
            assert_eq!(p.default.len(), p.kind.width(), "{}.{}", def.name, p.name);
            let (lo, hi) = p.kind.bounds();
            assert!(lo < hi, "{}.{}", def.name, p.name);
        }
        let json = serde_json::to_string(def.params).unwrap();
        let kinds: Vec<serde_json::Value> = serde_json::from_str(&json).unwrap();
        for (p, k) in def.params.iter().zip(&kinds) {
            let back: ParamKind = serde_json::from_value(k["kind"].clone()).unwrap();
            assert_eq!(back, p.kind);
            assert_eq!(k["name"], p.name);
        }
        let mut names: Vec<_> = def.params.iter().map(|p| p.name).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), def.params.len(), "{}: duplicate parameter names", def.name);
    }
}

#[test]
fn the_library_has_the_thesis_shaders_and_their_known_parameters() {
    // F5: SH1–SH13, with the parameters the thesis names (§5, App. B, App. C, Fig. A-3).
    let expect: &[(&str, &[&str])] = &[
        ("bar", &["width"]),
        ("weave", &["frequency", "vertical", "horizontal", "orientation"]),
        ("brick", &["width", "height", "mortar"]),
        ("brick2", &["width", "height", "mortar", "alternate_colour"]),
        ("cyclone", &["Ka", "Kd", "max_radius", "twist", "scale", "offset", "omega", "octaves"]),
        (
            "eyeball",
            &[
                "Ka",
                "Kd",
                "Ks",
                "roughness",
                "specularcolor",
                "iriscolor",
                "irisoutercolor",
                "irisinnercolor",
                "eyeballcolor",
                "bloodcolor",
                "pupilcolor",
                "pupilsize",
                "irissize",
                "bloodshot",
                "veinfreq",
                "veinlevel",
                "index",
            ],
        ),
        ("clouds", &["cover"]),
        ("starfield", &["density"]),
        ("star", &["points"]),
        ("rectangle", &["width", "height"]),
        ("circle", &["radius"]),
        ("superellipse", &["a", "b", "exponent"]),
        (
            "hextile",
            &[
                "Ka",
                "Kd",
                "Ks",
                "roughness",
                "specularcolor",
                "tilecolor",
                "mortarcolor",
                "tileradius",
                "mortarwidth",
                "tilevary",
                "scuffing",
                "stains",
                "stainfrequency",
                "scufffrequency",
                "scuffcolor",
            ],
        ),
    ];
    for (name, params) in expect {
        let def = shader(name).unwrap_or_else(|| panic!("no shader `{name}`"));
        for p in *params {
            assert!(def.param(p).is_some(), "{name} lacks `{p}`");
        }
    }
    assert!(matches!(shader("star").unwrap().params[0].kind, ParamKind::Int { min: 2, .. }));
    // The thesis's matched eyeball and cyclone values are inside the ranges.
    let eyeball = shader("eyeball").unwrap();
    let mut v = eyeball.defaults();
    let at = params::offsets(eyeball.params);
    for (name, value) in
        [("pupilsize", 0.0), ("irissize", 0.0), ("bloodshot", 0.997141), ("veinfreq", 3.54332), ("veinlevel", 7.549)]
    {
        v[at[eyeball.param(name).unwrap()]] = value;
    }
    validate(eyeball.params, &v).unwrap();
}

#[test]
fn bad_parameter_vectors_are_refused() {
    let star = shader("star").unwrap();
    let mut v = star.defaults();
    v[0] = 4.5;
    assert_eq!(validate(star.params, &v), Err(ParamError::NotInteger { name: "points", value: 4.5 }));
    v[0] = 40.0;
    assert!(matches!(validate(star.params, &v), Err(ParamError::Range { name: "points", .. })));
    v[0] = f64::NAN;
    assert!(matches!(validate(star.params, &v), Err(ParamError::Range { .. })));
    assert!(matches!(validate(star.params, &v[1..]), Err(ParamError::Length { .. })));
    let bar = shader("bar").unwrap();
    assert!(render_square(bar, &[0.3; 7], 0, 0).is_err());
    assert!(render(bar, &bar.defaults(), 0, 4, 4, [0.0, 0.0, f64::NAN, 1.0]).is_err());
    assert!(render(bar, &bar.defaults(), 0, 4, 4, [1.0, 0.0, 1.0, 1.0]).is_err());
    assert_eq!(flat_len(bar.params), 7);
}

#[test]
fn renders_are_deterministic_and_independent_of_the_thread_count() {
    // F2.
    for def in LIBRARY {
        let v = def.defaults();
        let a = render_square(def, &v, 11, 96).unwrap();
        let b = render_square(def, &v, 11, 96).unwrap();
        assert_eq!(a.data, b.data, "{}", def.name);
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let c = one.install(|| render_square(def, &v, 11, 96).unwrap());
        assert_eq!(a.data, c.data, "{} on one thread", def.name);
        assert!(a.data.iter().all(|x| (0.0..=1.0).contains(x)), "{}", def.name);
        // Stochastic shaders depend on the seed; deterministic ones do not.
        let other = render_square(def, &v, 12, 96).unwrap();
        assert_eq!(a.data == other.data, !def.stochastic, "{}", def.name);
    }
}

#[test]
fn a_fine_render_box_downsampled_looks_like_the_coarse_render() {
    // F3: 1024² box-downsampled to 256² against the 256² render, mean absolute difference
    // ≤ 0.02 and S_F ≥ 0.99 (the resolution-independence claim), for every shader at its defaults.
    for def in LIBRARY {
        let v = def.defaults();
        let fine = downsample(&render_square(def, &v, 5, 1024).unwrap(), 4);
        let coarse = render_square(def, &v, 5, 256).unwrap();
        let d = mean_abs_diff(&fine, &coarse);
        assert!(d <= 0.02, "{}: mean |Δ| = {d:.4}", def.name);
        let s = s_f(&fine, &coarse);
        assert!(s >= 0.99, "{}: S_F = {s:.5}", def.name);
    }
}

#[test]
fn every_float_parameter_changes_the_image_continuously() {
    // F4: a step of 1e-4 of a parameter's range keeps S_F ≥ 0.999 and changes the 128² render
    // by a mean of at most 1e-3 (or proportionally less for a ten times smaller step), at 10
    // random points of every shader's space.
    let mut rng = Rng::new(99);
    for def in LIBRARY {
        let at = params::offsets(def.params);
        for _ in 0..10 {
            let x = random_values(def, &mut rng);
            let base = render_square(def, &x, 3, 128).unwrap();
            for (p, &i) in def.params.iter().zip(&at) {
                let (lo, hi) = p.kind.bounds();
                if matches!(p.kind, ParamKind::Int { .. }) {
                    continue;
                }
                for k in 0..p.kind.width() {
                    let mut y = x.clone();
                    let step = 1e-4 * (hi - lo);
                    y[i + k] = if y[i + k] + step <= hi { y[i + k] + step } else { y[i + k] - step };
                    let moved = render_square(def, &y, 3, 128).unwrap();
                    // F4 as Bourque's checklist states it: S_F ≥ 0.999.
                    let s = s_f(&base, &moved);
                    assert!(s >= 0.999, "{}.{} at {x:?}: S_F = {s}", def.name, p.name);
                    let d = mean_abs_diff(&base, &moved);
                    if d <= 1e-3 {
                        continue;
                    }
                    // A lever (an orientation turning a fine grid): still continuous if a ten
                    // times smaller step changes the image at most a fifth as much (a jump
                    // would not shrink with the step).
                    y[i + k] = x[i + k] + (y[i + k] - x[i + k]) / 10.0;
                    let d10 = mean_abs_diff(&base, &render_square(def, &y, 3, 128).unwrap());
                    assert!(
                        d10 <= d / 5.0,
                        "{}.{} at {x:?}: mean |Δ| = {d}, {d10} at a tenth of the step",
                        def.name,
                        p.name
                    );
                }
            }
        }
    }
}

#[test]
fn filtered_edges_integrate_the_pixel_exactly() {
    // A pixel straddling an edge is covered by the fraction inside.
    assert!((filtered_interval(0.5, 0.2, 0.45, 2.0) - 0.75).abs() < 1e-12);
    assert!((filtered_pulse_train(3.5, 0.2, 0.45, 0.55) - 0.5).abs() < 1e-12);
    // A pixel wider than the period sees the duty cycle.
    assert!((filtered_pulse_train(0.3, 10.0, 0.2, 0.5) - 0.3).abs() < 1e-12);
    // The antialiased bar of width ω covers ω of the square, at any resolution.
    let bar = shader("bar").unwrap();
    for size in [7, 64, 255] {
        let img = render_square(bar, &[0.37, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0], 0, size).unwrap();
        let covered = 1.0 - img.plane(0).iter().map(|&v| v as f64).sum::<f64>() / (size * size) as f64;
        assert!((covered - 0.37).abs() < 1e-5, "{size}: {covered}");
    }
}

#[test]
fn noise_is_bounded_zero_on_the_lattice_and_centred() {
    assert_eq!(snoise(3.0, -7.0, 5), 0.0);
    let mut sum = 0.0;
    let n = 200_000;
    for i in 0..n {
        let (x, y) = (i as f64 * 0.0137, (i % 977) as f64 * 0.031);
        let v = snoise(x, y, 9);
        assert!(v.abs() <= 1.0 + 1e-9);
        sum += v;
    }
    assert!((sum / n as f64).abs() < 0.02, "{}", sum / n as f64);
    for x in [-2.5, -1.0, -0.0, 0.3, 1e6 + 0.5, -1e9 - 0.25] {
        assert_eq!(floor(x), x.floor());
    }
}

#[test]
fn the_star_takes_whole_points_and_a_fraction_breaks_it() {
    // F31's documentation image: at 4.5 points the last wedge is cut short, so the picture is
    // not a star (no 4-fold symmetry); at 4 it is.
    let render_at = |points: f64| {
        let p = star_pattern(points, 0.12, 0.35);
        Image::from_fn(64, 64, 1, |x, y, _| p.shade((x as f64 + 0.5) / 64.0, (y as f64 + 0.5) / 64.0, 1.0 / 64.0)[1])
    };
    let rot90 = |img: &Image| Image::from_fn(64, 64, 1, |x, y, _| img.get(y, 63 - x, 0));
    let four = render_at(4.0);
    assert!(mean_abs_diff(&four, &rot90(&four)) < 1e-6);
    let broken = render_at(4.5);
    assert!(mean_abs_diff(&broken, &rot90(&broken)) > 0.01);
}

/// Every shader's row (side by side, with AVX2 where the CPU has it) is its points one by one,
/// bit for bit, at widths that leave a remainder of the lanes and at pixel sizes that cut
/// octaves short.
#[test]
fn every_row_equals_its_points_bit_for_bit() {
    for def in LIBRARY {
        let pattern = def.pattern(&def.defaults(), 11).expect("defaults are valid");
        for (width, fw) in [(29, 1.0 / 29.0), (256, 1.0 / 256.0), (3, 0.4)] {
            let du = 1.0 / width as f64;
            for v in [0.02, 0.5, 0.93] {
                let mut row = vec![[0f32; 3]; width];
                pattern.shade_row(-0.25, du, v, fw, &mut row);
                for (x, c) in row.iter().enumerate() {
                    let one = pattern.shade(-0.25 + (x as f64 + 0.5) * du, v, fw);
                    assert_eq!(c.map(f32::to_bits), one.map(f32::to_bits), "{} pixel {x} of {width}", def.name);
                }
            }
        }
    }
}
