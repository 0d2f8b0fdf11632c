//! Tests of the representations against the checklist of Dong 2003 ([references: dong §checks]).

use glam::DVec3;
use nalgebra::DMatrix;

use super::*;
use crate::synth::quilt::{gather, quilt, Metric, QuiltParams};
use crate::synth::relight::error::RelightError;
use crate::synth::relight::evaluate::eta;
use crate::synth::relight::fixtures::{lights36, quantise, render, scenario, shade, Scenario};
use crate::synth::relight::light::grid;
use crate::synth::relight::light::Light;
use crate::synth::relight::stack::PhotoStack;
use crate::synth::rng::Rng;

const ALL: [Method; 5] = [Method::ThreeI, Method::Gradient, Method::Ptm, Method::Eigen(3), Method::Eigen(6)];

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

/// A random stack: random scaled normals (facing the camera) under the 36 lights plus noise,
/// so no method is exact and every least-squares inequality is tested on "any" data.
fn random_stack(seed: u64, n: usize) -> PhotoStack {
    let mut rng = Rng::new(seed);
    let lights = lights36();
    let m = n * n;
    let na: Vec<DVec3> =
        (0..m).map(|_| DVec3::new(rng.range(-0.3, 0.3), rng.range(-0.3, 0.3), rng.range(0.5, 1.0))).collect();
    let images = lights.iter().map(|l| na.iter().map(|v| v.dot(l.vector()) + 0.05 * rng.normal()).collect()).collect();
    PhotoStack::new(n, n, images, lights).unwrap()
}

fn frobenius(stack: &PhotoStack, method: Method) -> f64 {
    let rep = extract(stack, method).unwrap();
    let mut s = 0.0;
    for (k, l) in stack.lights.iter().enumerate() {
        let r = rep.relight(l).unwrap();
        s += r.iter().zip(&stack.images[k]).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
    }
    s.sqrt()
}

/// Dong `item 2`: the frame. A plane `s = 0.3x` lit at slant 45° is brighter from tilt 180°
/// (its normal leans to −x), and photometric stereo returns `p = 0.3`, `q = 0`.
#[test]
fn the_sign_convention_is_pinned_by_a_tilted_plane() {
    let n = 8;
    let lights = lights36();
    let images: Vec<Vec<f64>> =
        lights.iter().map(|l| vec![shade(0.3, 0.0, 0.5, l.vector(), 0.0, 1.0); n * n]).collect();
    let at = |t: f64| images[lights.iter().position(|l| l.same(&Light::new(t, 45.0))).unwrap()][0];
    assert!(at(180.0) > at(0.0));
    let stack = PhotoStack::new(n, n, images, lights).unwrap();
    let rep = extract(&stack, Method::Gradient).unwrap();
    assert!(rep.plane(0).iter().all(|p| (p - 0.3).abs() < 1e-9));
    assert!(rep.plane(1).iter().all(|q| q.abs() < 1e-9));
    assert!(rep.plane(2).iter().all(|a| (a - 0.5).abs() < 1e-9));
}

/// Dong `item 4`: for every method, relighting at the training lights is `M1 · M2` column by
/// column, with `M2` formed independently of the relighting code.
#[test]
fn relighting_at_the_training_lights_is_m1_times_m2() {
    let stack = scenario(Scenario::B).stack;
    let m = stack.pixels();
    for method in ALL {
        let rep = extract(&stack, method).unwrap();
        let r = rep.channels();
        // M1 as pixels × r; M2 column k from the basis.
        let m1 = DMatrix::from_fn(m, r, |j, c| rep.maps[c * m + j]);
        let m1 = match method {
            // Gradient's linear maps are the scaled normals al · normalise(−p, −q, 1).
            Method::Gradient => DMatrix::from_fn(m, 3, |j, c| {
                let v = DVec3::new(-m1[(j, 0)], -m1[(j, 1)], 1.0).normalize() * m1[(j, 2)];
                v[c]
            }),
            _ => m1,
        };
        for (k, l) in stack.lights.iter().enumerate() {
            let col: Vec<f64> = match (&rep.basis, method) {
                (Basis::Eigen(e), _) => (0..e.k).map(|c| e.m2[c * stack.len() + k]).collect(),
                (Basis::Ptm, _) => ptm_vector(l.vector()).to_vec(),
                (Basis::Gradient, _) => l.vector().to_array().to_vec(),
                (Basis::ThreeI { inverse, .. }, _) => {
                    let inv = DMatrix::from_fn(3, 3, |a, b| inverse[a][b]);
                    (inv * DMatrix::from_column_slice(3, 1, &l.vector().to_array())).iter().copied().collect()
                }
            };
            let want = &m1 * DMatrix::from_column_slice(r, 1, &col);
            let got = rep.relight(l).unwrap();
            let scale = want.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            assert!(max_abs_diff(&got, want.as_slice()) <= 1e-9 * scale, "{method:?} light {k}");
        }
    }
    // Eigen-n keeps every component: it reproduces the stack.
    let rep = extract(&stack, Method::Eigen(36)).unwrap();
    for (k, l) in stack.lights.iter().enumerate() {
        assert!(max_abs_diff(&rep.relight(l).unwrap(), &stack.images[k]) < 1e-9);
    }
}

/// Dong `item 5`: 3I. The closed form (*) equals `L3⁻¹ l`; an unshadowed Lambertian surface is
/// relit exactly at a fourth light; 12-bit inputs stay within 2e-3; coplanar triples are refused.
#[test]
fn three_i_is_exact_on_lambertian_data_and_matches_the_closed_form() {
    let lights = DEFAULT_TRIPLE.map(|(t, s)| Light::new(t, s));
    let inv = three_i::inverse(&lights).unwrap();
    let mut rng = Rng::new(11);
    for _ in 0..1000 {
        let l = Light::new(rng.range(0.0, 360.0), rng.range(0.0, 90.0));
        let a = three_i::apply(&inv, l.vector());
        let b = closed_form_45(&l);
        for i in 0..3 {
            assert!((a[i] - b[i]).abs() <= 1e-12, "{l:?}: {a:?} vs {b:?}");
        }
    }
    let cap = scenario(Scenario::A);
    let rep = extract(&cap.stack, Method::ThreeI).unwrap();
    let l4 = Light::new(60.0, 60.0);
    let truth: Vec<f64> =
        (0..cap.stack.pixels()).map(|j| shade(cap.p[j], cap.q[j], cap.albedo[j], l4.vector(), 0.0, 1.0)).collect();
    let e = eta(&[rep.relight(&l4).unwrap()], &[&truth]).eta;
    println!("3I at (60°, 60°) on scenario A: η = {e:.3e}");
    assert!(e <= 1e-9);
    // 12-bit inputs against the unquantised truth, at the training lights.
    let q = quantise(&cap.stack, 12);
    let originals: Vec<&[f64]> = cap.stack.images.iter().map(|v| v.as_slice()).collect();
    for method in [Method::ThreeI, Method::Gradient] {
        let rep = extract(&q, method).unwrap();
        let relit: Vec<Vec<f64>> = cap.stack.lights.iter().map(|l| rep.relight(l).unwrap()).collect();
        let e = eta(&relit, &originals).eta;
        println!("{} 12-bit reconstruction η = {e:.3e}", method.name());
        assert!(e <= 2e-3);
    }
    // Coplanar: three lights in the x–z plane.
    let flat = [Light::new(0.0, 0.0), Light::new(0.0, 30.0), Light::new(180.0, 60.0)];
    assert!(matches!(three_i::inverse(&flat), Err(RelightError::Degenerate { method: "3I", .. })));
    let st = PhotoStack::new(2, 2, vec![vec![0.5; 4]; 3], flat.to_vec()).unwrap();
    assert!(matches!(extract_three_i(&st, [0, 1, 2]), Err(RelightError::Degenerate { .. })));
    assert!(matches!(extract(&st, Method::Gradient), Err(RelightError::Degenerate { method: "Gradient", .. })));
}

/// Dong `item 6`: photometric stereo recovers the analytic p, q, ρ of scenario A; the
/// (p, q, al) ↔ N_a round trip; Gradient's reconstruction error ≤ 3I's on any data.
#[test]
fn gradient_recovers_the_surface_and_beats_three_i() {
    let cap = scenario(Scenario::A);
    let rep = extract(&cap.stack, Method::Gradient).unwrap();
    assert!(max_abs_diff(rep.plane(0), &cap.p) <= 1e-9);
    assert!(max_abs_diff(rep.plane(1), &cap.q) <= 1e-9);
    assert!(max_abs_diff(rep.plane(2), &cap.albedo) <= 1e-9);
    assert_eq!(rep.flagged, 0);
    let na = scaled_normals(&cap.stack).unwrap();
    let (pqa, _) = pq_from_scaled_normals(&na);
    let m = cap.stack.pixels();
    for j in 0..m {
        let v = DVec3::new(-pqa[j], -pqa[m + j], 1.0).normalize() * pqa[2 * m + j];
        assert!((v - DVec3::new(na[j], na[m + j], na[2 * m + j])).length() < 1e-12);
    }
    let (g, t) = (
        frobenius(&scenario(Scenario::B).stack, Method::Gradient),
        frobenius(&scenario(Scenario::B).stack, Method::ThreeI),
    );
    println!("scenario B reconstruction Frobenius: Gradient {g:.4}, 3I {t:.4}");
    assert!(g <= t);
    for seed in 0..3 {
        let st = random_stack(seed, 16);
        assert!(frobenius(&st, Method::Gradient) <= frobenius(&st, Method::ThreeI));
    }
}

/// Dong `item 7`: PTM recovers random coefficients exactly and refuses a single slant.
#[test]
fn ptm_recovers_coefficients_and_refuses_one_slant() {
    let mut rng = Rng::new(3);
    let (n, lights) = (6, lights36());
    let m = n * n;
    let coef: Vec<f64> = (0..6 * m).map(|_| rng.range(-1.0, 1.0)).collect();
    let images = lights
        .iter()
        .map(|l| {
            let v = ptm_vector(l.vector());
            (0..m).map(|j| (0..6).map(|c| coef[c * m + j] * v[c]).sum()).collect()
        })
        .collect();
    let rep = extract(&PhotoStack::new(n, n, images, lights).unwrap(), Method::Ptm).unwrap();
    assert!(max_abs_diff(&rep.maps, &coef) <= 1e-9);
    let one = grid(&[45.0], &(0..12).map(|k| k as f64 * 30.0).collect::<Vec<_>>());
    let st = PhotoStack::new(2, 2, vec![vec![0.5; 4]; 12], one).unwrap();
    assert!(matches!(extract(&st, Method::Ptm), Err(RelightError::SingleSlant { .. })));
}

/// Dong `items 8 and 9`: Eigen's spectrum, the information measures, and Eckart–Young.
#[test]
fn eigen_is_the_best_low_rank_fit() {
    let cap = scenario(Scenario::A);
    let rep = extract(&cap.stack, Method::Eigen(6)).unwrap();
    let Basis::Eigen(e) = &rep.basis else { panic!("eigen basis") };
    assert!(e.singular_values.windows(2).all(|w| w[0] >= w[1]));
    let (indi, cumu) = information(&e.singular_values);
    assert!((cumu[2] - 1.0).abs() <= 1e-9, "f_cumu(3) = {}", cumu[2]);
    assert!((indi.iter().map(|f| f * f).sum::<f64>() - 1.0).abs() < 1e-12);
    assert!(cumu.windows(2).all(|w| w[0] <= w[1] + 1e-15));
    assert!((cumu[cumu.len() - 1] - 1.0).abs() < 1e-12);
    // The sign convention: each M2 row's largest-magnitude entry is positive.
    for c in 0..6 {
        let row = &e.m2[c * 36..(c + 1) * 36];
        let big = row.iter().cloned().fold(0.0f64, |a, v| if v.abs() > a.abs() { v } else { a });
        assert!(big > 0.0);
    }
    let mut stacks: Vec<PhotoStack> = Scenario::ALL.iter().map(|&s| scenario(s).stack).collect();
    stacks.extend((0..3).map(|s| random_stack(100 + s, 16)));
    for st in &stacks {
        let f = |m| frobenius(st, m);
        let (e3, e6, g, p) = (f(Method::Eigen(3)), f(Method::Eigen(6)), f(Method::Gradient), f(Method::Ptm));
        assert!(e3 <= g * (1.0 + 1e-12) + 1e-12, "Eigen3 {e3} > Gradient {g}");
        assert!(e6 <= p * (1.0 + 1e-12) + 1e-12, "Eigen6 {e6} > PTM {p}");
        assert!(e6 <= e3 * (1.0 + 1e-12) + 1e-12, "Eigen6 {e6} > Eigen3 {e3}");
    }
    let st = scenario(Scenario::A).stack;
    assert_eq!(extract(&st, Method::Eigen(37)).unwrap_err(), RelightError::EigenRank { k: 37, n: 36 });
    assert_eq!(extract(&st, Method::Eigen(0)).unwrap_err(), RelightError::EigenRank { k: 0, n: 36 });
}

/// Dong `item 10`: bilinear interpolation on the (tilt, slant) grid, periodic in tilt.
#[test]
fn eigen_interpolates_on_the_light_grid() {
    let st = scenario(Scenario::B).stack;
    let rep = extract(&st, Method::Eigen(6)).unwrap();
    let node = |t: f64, s: f64| rep.relight(&Light::new(t, s)).unwrap();
    // At a node: that node's rank-k reconstruction, M1 · M2_k.
    let Basis::Eigen(e) = &rep.basis else { panic!() };
    let k = st.lights.iter().position(|l| l.same(&Light::new(60.0, 45.0))).unwrap();
    let col: Vec<f64> = (0..6).map(|c| e.m2[c * 36 + k]).collect();
    let planes: Vec<&[f64]> = (0..6).map(|c| rep.plane(c)).collect();
    let want = relight_planes(&planes, st.width, &Kernel::Linear(col));
    assert!(max_abs_diff(&node(60.0, 45.0), &want) < 1e-12);
    let mean = |a: Vec<f64>, b: Vec<f64>| a.iter().zip(&b).map(|(x, y)| 0.5 * (x + y)).collect::<Vec<_>>();
    assert!(max_abs_diff(&node(75.0, 45.0), &mean(node(60.0, 45.0), node(90.0, 45.0))) < 1e-12);
    assert!(max_abs_diff(&node(345.0, 30.0), &mean(node(330.0, 30.0), node(0.0, 30.0))) < 1e-12);
    assert!(max_abs_diff(&node(60.0, 37.5), &mean(node(60.0, 30.0), node(60.0, 45.0))) < 1e-12);
    // Bilinear in both.
    let four = mean(mean(node(60.0, 30.0), node(90.0, 30.0)), mean(node(60.0, 45.0), node(90.0, 45.0)));
    assert!(max_abs_diff(&node(75.0, 37.5), &four) < 1e-12);
    for s in [10.0, 75.0] {
        assert!(matches!(
            rep.relight(&Light::new(0.0, s)),
            Err(RelightError::SlantOutsideGrid { min_deg: 30.0, max_deg: 60.0, .. })
        ));
    }
}

/// Dong `item 21`: relighting commutes with quilting, bit for bit, for all five methods
/// (one index map drives every channel; the relit sample is gathered through it).
#[test]
fn relighting_commutes_with_quilting() {
    let st = scenario(Scenario::C).stack;
    for (i, method) in ALL.into_iter().enumerate() {
        let rep = extract(&st, method).unwrap();
        let maps = rep.to_image();
        let mut params = QuiltParams::new(56, 48, 12, 7 + i as u64);
        params.metric = Metric::Sad;
        let q = quilt(&maps, &params).unwrap();
        assert_eq!(gather(&q, &maps).unwrap(), q.image);
        for light in [Light::new(60.0, 60.0), Light::new(120.0, 60.0), Light::new(200.0, 40.0)] {
            let quilted_then_relit = relight_image(&q.image, &rep.basis, &light).unwrap();
            let relit_then_gathered = gather(&q, &relight_image(&maps, &rep.basis, &light).unwrap()).unwrap();
            assert_eq!(quilted_then_relit.data, relit_then_gathered.data, "{method:?} at {light:?}");
        }
    }
}

/// Dong `item 22`: on an exactly Lambertian surface (scenario A) 3I and Gradient are the same
/// surface, so one index map driving both gives the same relit images at (60°, 60°) and
/// (120°, 60°).
#[test]
fn three_i_and_gradient_agree_on_lambertian_data_through_one_index_map() {
    let st = scenario(Scenario::A).stack;
    let three = extract(&st, Method::ThreeI).unwrap();
    let grad = extract(&st, Method::Gradient).unwrap();
    let mut params = QuiltParams::new(56, 48, 12, 3);
    params.metric = Metric::Sad;
    let q = quilt(&three.to_image(), &params).unwrap();
    let grad_maps = gather(&q, &grad.to_image()).unwrap();
    for light in [Light::new(60.0, 60.0), Light::new(120.0, 60.0)] {
        let a = relight_image(&q.image, &three.basis, &light).unwrap();
        let b = relight_image(&grad_maps, &grad.basis, &light).unwrap();
        let worst = a.data.iter().zip(&b.data).map(|(x, y)| (x - y).abs()).fold(0f32, f32::max);
        assert!(worst < 1e-6, "3I vs Gradient at {light:?}: {worst}");
    }
}

/// The same relit image whatever the number of threads.
#[test]
fn relighting_does_not_depend_on_the_thread_count() {
    let st = render(Scenario::B, 48, &lights36());
    let l = Light::new(100.0, 50.0);
    for method in ALL {
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| extract(&st.stack, method).unwrap().relight(&l).unwrap())
        };
        assert_eq!(run(1), run(3), "{method:?}");
    }
}

/// A colour relight is the chromaticity times the relit luminance.
#[test]
fn colour_stacks_relight_as_chroma_times_luminance() {
    let cap = scenario(Scenario::A);
    let m = cap.stack.pixels();
    let tint = [0.9, 0.5, 0.2];
    let rgb: Vec<Vec<f64>> =
        cap.stack.images.iter().map(|img| (0..3 * m).map(|i| img[i % m] * tint[i / m]).collect()).collect();
    let st = PhotoStack::from_rgb(cap.n, cap.n, &rgb, cap.stack.lights.clone()).unwrap();
    let rep = extract(&st, Method::Gradient).unwrap();
    let l = Light::new(60.0, 60.0);
    let out = colourise(&rep.relight(&l).unwrap(), rep.chroma.as_ref().unwrap());
    for j in 0..m {
        let truth = shade(cap.p[j], cap.q[j], cap.albedo[j], l.vector(), 0.0, 1.0);
        for c in 0..3 {
            assert!((out[c * m + j] - truth * tint[c]).abs() < 1e-9);
        }
    }
}
