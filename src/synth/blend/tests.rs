//! Checks of [references: welsman-dinelle §4.2]: blending core (items 1–14) and optional items 29, 30, 32.
//!
//! Fixtures are synthetic and tileable unless stated. Thresholds quoted by the checks are on
//! the 0..255 scale; fixtures that test them are built on that scale too (the blend is
//! linear, so the scale only matters for the absolute tolerances).

use super::*;
use crate::synth::rng::Rng;

const TOL_255: f64 = 1e-3;

/// Tileable smooth noise in `[lo, hi]`: white noise box-blurred `passes` times on the torus.
fn noise(w: usize, h: usize, ch: usize, seed: u64, passes: usize, lo: f32, hi: f32) -> Image {
    let mut rng = Rng::new(seed);
    let mut img = Image::new(w, h, ch);
    for v in img.data.iter_mut() {
        *v = rng.next_f32();
    }
    for _ in 0..passes {
        let src = img.clone();
        for c in 0..ch {
            for y in 0..h {
                for x in 0..w {
                    let g = |dx: isize, dy: isize| {
                        src.get(
                            (x as isize + dx).rem_euclid(w as isize) as usize,
                            (y as isize + dy).rem_euclid(h as isize) as usize,
                            c,
                        )
                    };
                    img.set(x, y, c, (g(0, 0) + g(1, 0) + g(-1, 0) + g(0, 1) + g(0, -1)) / 5.0);
                }
            }
        }
    }
    // Stretch to [lo, hi].
    let (mn, mx) = img.data.iter().fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    for v in img.data.iter_mut() {
        *v = lo + (hi - lo) * (*v - mn) / (mx - mn);
    }
    img
}

fn disc(w: usize, h: usize, cx: f64, cy: f64, r: f64) -> Image {
    Image::from_fn(w, h, 1, |x, y, _| {
        let (dx, dy) = (x as f64 + 0.5 - cx, y as f64 + 0.5 - cy);
        if dx * dx + dy * dy <= r * r {
            1.0
        } else {
            0.0
        }
    })
}

/// Two blobs, one crossing the wrap seams (tests the torus).
fn blobs(w: usize, h: usize) -> Image {
    let a = disc(w, h, w as f64 * 0.35, h as f64 * 0.4, w as f64 * 0.2);
    Image::from_fn(w, h, 1, |x, y, _| {
        let (dx, dy) = (x as f64 + 0.5, y as f64 + 0.5);
        // A disc centred on the corner (wraps to all four corners).
        let ddx = dx.min(w as f64 - dx);
        let ddy = dy.min(h as f64 - dy);
        if a.get(x, y, 0) > 0.5 || ddx * ddx + ddy * ddy <= (w as f64 * 0.15).powi(2) {
            1.0
        } else {
            0.0
        }
    })
}

fn params() -> BlendParams {
    BlendParams::default()
}

/// Independent residual of the thesis's equations (item 4) on the torus, f64:
/// for p ∈ Ω, `r_p = (4B_p − ΣB_q) − (4f_p − Σf_q)`. Returns (‖r‖/‖b‖, max |r|).
fn torus_residual(f: &[f32], a: &[f32], b: &[f32], m: &[f32], w: usize, h: usize) -> (f64, f64) {
    let (mut rr, mut bb, mut mx) = (0.0f64, 0.0f64, 0.0f64);
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            if m[p] < 0.5 {
                continue;
            }
            let nb = [y * w + (x + w - 1) % w, y * w + (x + 1) % w, ((y + h - 1) % h) * w + x, ((y + 1) % h) * w + x];
            let mut lf = 4.0 * f[p] as f64;
            let mut lb = 4.0 * b[p] as f64;
            let mut rhs = lb;
            for &q in &nb {
                lf -= f[q] as f64;
                lb -= b[q] as f64;
                if m[q] < 0.5 {
                    rhs += a[q] as f64;
                }
            }
            rhs -= 4.0 * b[p] as f64;
            let _ = rhs;
            // b of the normal equations: Σ_{q∉Ω} A_q + Σ_q (B_p − B_q).
            let mut bp = lb;
            for &q in &nb {
                if m[q] < 0.5 {
                    bp += a[q] as f64;
                }
            }
            let r = lb - lf;
            rr += r * r;
            bb += bp * bp;
            mx = mx.max(r.abs());
        }
    }
    (rr.sqrt() / bb.sqrt(), mx)
}

// ---------------------------------------------------------------------------------------
// Item 1: validation

#[test]
fn item01_size_mismatch_is_an_error_with_details() {
    let a = Image::new(16, 16, 3);
    let b = Image::new(16, 12, 3);
    let m = Image::new(16, 16, 1);
    let e = blend_two(&a, &b, &m, &params()).unwrap_err();
    assert_eq!(e, BlendError::SizeMismatch { what: "source 1".into(), expected: (16, 16), found: (16, 12) });
    assert_eq!(e.to_string(), "source 1 is 16x12 but the sources are 16x16; blending needs equal sizes");
    let m2 = Image::new(8, 16, 1);
    let e = blend_two(&a, &a, &m2, &params()).unwrap_err();
    assert!(matches!(e, BlendError::SizeMismatch { ref what, found: (8, 16), .. } if what == "mask"));
    // Other refusals.
    assert_eq!(blend(&[], Selector::Labels(&[]), &params()).unwrap_err(), BlendError::NoSources);
    let e = blend_two(&a, &a, &Image::new(16, 16, 2), &params()).unwrap_err();
    assert!(matches!(e, BlendError::ChannelMismatch { expected: 3, found: 2, .. }));
    let mut nan = a.clone();
    nan.set(3, 4, 1, f32::NAN);
    let e = blend_two(&a, &nan, &m, &params()).unwrap_err();
    assert_eq!(e, BlendError::NonFinite { what: "source 1".into(), x: 3, y: 4, channel: 1 });
    let mut inf = m.clone();
    inf.set(0, 1, 0, f32::INFINITY);
    assert!(matches!(blend_two(&a, &a, &inf, &params()).unwrap_err(), BlendError::NonFinite { .. }));
    let e = blend_two(&Image::new(0, 4, 3), &Image::new(0, 4, 3), &Image::new(0, 4, 1), &params()).unwrap_err();
    assert!(matches!(e, BlendError::Empty { .. }));
    let labels = vec![2u32; 16 * 16];
    let e = blend(&[&a, &a], Selector::Labels(&labels), &params()).unwrap_err();
    assert!(matches!(e, BlendError::LabelOutOfRange { label: 2, sources: 2, .. }));
    let e = blend(&[&a, &a, &a], Selector::Binary(&m), &params()).unwrap_err();
    assert_eq!(e, BlendError::SourceCount { expected: 2, found: 3 });
    let mut p = params();
    p.solver.tol = 0.0;
    assert!(matches!(blend_two(&a, &a, &m, &p).unwrap_err(), BlendError::BadParameter { name: Param::Tol, .. }));
    p = params();
    p.topology = Topology::Rim { source: 5 };
    assert!(matches!(blend_two(&a, &a, &m, &p).unwrap_err(), BlendError::BadParameter { .. }));
    for e in [BlendError::NoSources, BlendError::Empty { what: "x".into() }] {
        assert!(!e.to_string().is_empty());
    }
}

// ---------------------------------------------------------------------------------------
// Item 2: per-channel independence

#[test]
fn item02_channels_are_independent() {
    let (w, h) = (48, 40);
    let a = noise(w, h, 3, 1, 2, 0.0, 255.0);
    let b = noise(w, h, 3, 2, 2, 0.0, 255.0);
    let m = blobs(w, h);
    let out = blend_two(&a, &b, &m, &params()).unwrap().image;
    let perm = [2usize, 0, 1];
    let permute = |img: &Image| {
        let mut o = img.clone();
        for (dst, &src) in perm.iter().enumerate() {
            o.plane_mut(dst).copy_from_slice(img.plane(src));
        }
        o
    };
    let outp = blend_two(&permute(&a), &permute(&b), &m, &params()).unwrap().image;
    assert_eq!(outp, permute(&out), "permuting input channels must permute outputs bitwise");
    for c in 0..3 {
        let one = |img: &Image| Image { width: w, height: h, channels: 1, data: img.plane(c).to_vec() };
        let single = blend_two(&one(&a), &one(&b), &m, &params()).unwrap().image;
        let d = single.data.iter().zip(out.plane(c)).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
        assert!(d <= 1e-6, "channel {c}: {d}");
    }
}

// ---------------------------------------------------------------------------------------
// Items 3, 4, 5: retention, Poisson equation, maximum principle

#[test]
fn items03_04_05_retention_equation_and_max_principle() {
    let (w, h) = (96, 80);
    let a = noise(w, h, 3, 3, 3, 0.0, 255.0);
    let b = noise(w, h, 3, 4, 3, 0.0, 255.0);
    let m = blobs(w, h);
    let out = blend_two(&a, &b, &m, &params()).unwrap();
    for r in &out.reports {
        assert_eq!(r.method, Method::Mgpcg);
        assert!(r.converged && r.residual <= 1e-6, "{r:?}");
        assert!(r.max_residual <= TOL_255, "{r:?}");
    }
    for c in 0..3 {
        let (f, ap, bp, mp) = (out.image.plane(c), a.plane(c), b.plane(c), m.plane(0));
        // Item 3: bitwise retention outside Ω.
        for i in 0..w * h {
            if mp[i] < 0.5 {
                assert_eq!(f[i].to_bits(), ap[i].to_bits());
            }
        }
        // Item 4: independent residual check.
        let (rel, mx) = torus_residual(f, ap, bp, mp, w, h);
        assert!(rel <= 1e-6 && mx <= TOL_255, "channel {c}: rel {rel:e} max {mx:e}");
        // Item 5: h = f − B lies between the extremes of A − B on ∂Ω.
        let (mut lo, mut hi) = (f64::MAX, f64::MIN);
        for y in 0..h {
            for x in 0..w {
                let p = y * w + x;
                if mp[p] >= 0.5 {
                    continue;
                }
                let touches =
                    [(x + 1) % w + y * w, (x + w - 1) % w + y * w, x + ((y + 1) % h) * w, x + ((y + h - 1) % h) * w]
                        .iter()
                        .any(|&q| mp[q] >= 0.5);
                if touches {
                    let d = ap[p] as f64 - bp[p] as f64;
                    lo = lo.min(d);
                    hi = hi.max(d);
                }
            }
        }
        for i in 0..w * h {
            if mp[i] >= 0.5 {
                let hv = f[i] as f64 - bp[i] as f64;
                assert!(hv >= lo - TOL_255 && hv <= hi + TOL_255, "h = {hv} outside [{lo}, {hi}]");
            }
        }
    }
    // After 8-bit export the outside pixels equal A's 8-bit values.
    let to01 = |img: &Image| Image { data: img.data.iter().map(|v| v / 255.0).collect(), ..img.clone() };
    let a8 = crate::raster::decode(&crate::raster::encode_png(&to01(&a), 8).unwrap()).unwrap();
    let f8 = crate::raster::decode(&crate::raster::encode_png(&to01(&out.image), 8).unwrap()).unwrap();
    for c in 0..3 {
        for i in 0..w * h {
            if m.data[i] < 0.5 {
                assert_eq!(a8.plane(c)[i], f8.plane(c)[i]);
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// Item 6: energy optimality

fn energy(f: &[f64], b: &[f32], m: &[f32], w: usize, h: usize) -> f64 {
    let mut e = 0.0;
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            for q in [y * w + (x + 1) % w, ((y + 1) % h) * w + x] {
                if m[p] >= 0.5 || m[q] >= 0.5 {
                    let d = f[p] - f[q] - (b[p] as f64 - b[q] as f64);
                    e += d * d;
                }
            }
        }
    }
    e
}

#[test]
fn item06_energy_is_minimal() {
    let (w, h) = (64, 64);
    let a = noise(w, h, 1, 5, 2, 0.0, 255.0);
    let b = noise(w, h, 1, 6, 2, 0.0, 255.0);
    let m = blobs(w, h);
    let f = blend_two(&a, &b, &m, &params()).unwrap().image;
    let f64v: Vec<f64> = f.data.iter().map(|&v| v as f64).collect();
    let e = energy(&f64v, &b.data, &m.data, w, h);
    let cut: Vec<f64> = (0..w * h).map(|i| if m.data[i] >= 0.5 { b.data[i] } else { a.data[i] } as f64).collect();
    let e_cut = energy(&cut, &b.data, &m.data, w, h);
    assert!(e <= e_cut, "{e} vs cut {e_cut}");
    let mut rng = Rng::new(99);
    let eps = 1e-2;
    for _ in 0..20 {
        let g: Vec<f64> = (0..w * h)
            .map(|i| if m.data[i] >= 0.5 { f64v[i] + eps * (2.0 * rng.next_f64() - 1.0) } else { f64v[i] })
            .collect();
        let eg = energy(&g, &b.data, &m.data, w, h);
        assert!(e <= eg, "{e} vs perturbed {eg}");
    }
}

// ---------------------------------------------------------------------------------------
// Item 7: identities

#[test]
fn item07_identities() {
    let (w, h) = (64, 48);
    let a = noise(w, h, 3, 7, 2, 0.0, 200.0);
    let b = noise(w, h, 3, 8, 2, 0.0, 200.0);
    let black = Image::new(w, h, 1);
    let white = Image::filled(w, h, 1, 1.0);
    assert_eq!(blend_two(&a, &b, &black, &params()).unwrap().image, a);
    assert_eq!(blend_two(&a, &b, &white, &params()).unwrap().image, b);
    let m = blobs(w, h);
    let same = blend_two(&a, &a, &m, &params()).unwrap().image;
    let d = same.data.iter().zip(&a.data).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
    assert!(d <= 1e-4, "A = B: {d}");
    let shifted = Image { data: a.data.iter().map(|v| v + 37.0).collect(), ..a.clone() };
    // Tolerance tuned: the identity holds to the solver's tolerance, and at the default
    // (relative 1e-6) the error measured 2.4e-4 (≈ 1e-6 of values near 200), above the
    // check's 1e-4. At 1e-8 (8 iterations; the f32 floor) it is within 1e-4.
    let mut p = params();
    p.solver.tol = 1e-8;
    let out = blend_two(&a, &shifted, &m, &p).unwrap();
    let d = out.image.data.iter().zip(&a.data).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
    assert!(d <= 1e-4, "B = A + 37: {d}");
}

// ---------------------------------------------------------------------------------------
// Item 8: affinity

#[test]
fn item08_affine_equivariance() {
    let (w, h) = (64, 64);
    let a = noise(w, h, 2, 9, 2, 0.0, 255.0);
    let b = noise(w, h, 2, 10, 2, 0.0, 255.0);
    let m = blobs(w, h);
    let (alpha, beta) = (0.5f32, 10.0f32);
    let t = |img: &Image| Image { data: img.data.iter().map(|v| alpha * v + beta).collect(), ..img.clone() };
    let f = blend_two(&a, &b, &m, &params()).unwrap().image;
    let g = blend_two(&t(&a), &t(&b), &m, &params()).unwrap().image;
    let d = g.data.iter().zip(&f.data).map(|(gv, fv)| (gv - (alpha * fv + beta)).abs()).fold(0.0f32, f32::max);
    assert!(d <= 1e-4, "{d}");
}

// ---------------------------------------------------------------------------------------
// Item 9: tileability

fn roll(img: &Image, dx: usize, dy: usize) -> Image {
    let (w, h) = (img.width, img.height);
    Image::from_fn(w, h, img.channels, |x, y, c| img.get((x + w - dx) % w, (y + h - dy) % h, c))
}

fn tile2(img: &Image) -> Image {
    let (w, h) = (img.width, img.height);
    Image::from_fn(2 * w, 2 * h, img.channels, |x, y, c| img.get(x % w, y % h, c))
}

#[test]
fn item09_torus_tileability() {
    let (w, h) = (64, 48);
    let a = noise(w, h, 1, 11, 3, 0.0, 255.0);
    let b = noise(w, h, 1, 12, 3, 0.0, 255.0);
    let m = blobs(w, h);
    let f = blend_two(&a, &b, &m, &params()).unwrap().image;
    // (a) equivariance under circular shifts.
    let g = blend_two(&roll(&a, 17, 5), &roll(&b, 17, 5), &roll(&m, 17, 5), &params()).unwrap().image;
    let d = g.data.iter().zip(&roll(&f, 17, 5).data).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
    assert!(d <= 1e-3, "roll: {d}");
    // (b) the 2 × 2 tiling satisfies items 3 and 4 on the internal seams (plain stencil).
    let (ft, at, bt, mt) = (tile2(&f), tile2(&a), tile2(&b), tile2(&m));
    let (tw, th) = (2 * w, 2 * h);
    let mut checked = 0;
    for y in 1..th - 1 {
        for x in 1..tw - 1 {
            let seam = x == w - 1 || x == w || y == h - 1 || y == h;
            if !seam {
                continue;
            }
            let p = y * tw + x;
            if mt.data[p] < 0.5 {
                assert_eq!(ft.data[p], at.data[p]);
                continue;
            }
            let lap =
                |v: &[f32]| 4.0 * v[p] as f64 - v[p - 1] as f64 - v[p + 1] as f64 - v[p - tw] as f64 - v[p + tw] as f64;
            let r = lap(&bt.data) - lap(&ft.data);
            assert!(r.abs() <= 1e-3, "seam residual {r} at ({x}, {y})");
            checked += 1;
        }
    }
    assert!(checked > 20, "the fixture's mask must cross the seams ({checked})");
    // (c) statistical: wrap differences look like interior ones.
    let ratio = wrap_seam_ratio(&f);
    assert!((0.5..=2.0).contains(&ratio), "{ratio}");
}

// ---------------------------------------------------------------------------------------
// Item 10: rim mode

#[test]
fn item10_rim_mode_matches_opposite_edges_bitwise() {
    let (w, h) = (56, 40);
    let a = noise(w, h, 3, 13, 2, 0.0, 255.0);
    let b = noise(w, h, 3, 14, 2, 0.0, 255.0);
    let m = blobs(w, h);
    for domain in [Domain::Mask, Domain::Whole] {
        let mut p = params();
        p.topology = Topology::Rim { source: 0 };
        p.domain = domain;
        let out = blend_two(&a, &b, &m, &p).unwrap();
        let f = &out.image;
        for c in 0..3 {
            for y in 0..h {
                assert_eq!(f.get(0, y, c).to_bits(), f.get(w - 1, y, c).to_bits());
            }
            for x in 0..w {
                assert_eq!(f.get(x, 0, c).to_bits(), f.get(x, h - 1, c).to_bits());
            }
        }
        for r in &out.reports {
            assert!(r.converged && r.residual <= 1e-6 && r.max_residual <= TOL_255, "{domain:?} {r:?}");
        }
    }
}

// ---------------------------------------------------------------------------------------
// Item 11: solver agreement and mesh independence

/// Reference: SOR in f64 on the masked torus problem, iterated until the largest update
/// is below 1e-12.
fn sor_reference(a: &[f32], b: &[f32], m: &[f32], w: usize, h: usize) -> Vec<f64> {
    let mut f: Vec<f64> = (0..w * h).map(|i| if m[i] >= 0.5 { b[i] } else { a[i] } as f64).collect();
    let omega = 2.0 / (1.0 + (std::f64::consts::PI / w.max(h) as f64).sin());
    for _ in 0..200_000 {
        let mut change = 0.0f64;
        for y in 0..h {
            for x in 0..w {
                let p = y * w + x;
                if m[p] < 0.5 {
                    continue;
                }
                let nb =
                    [y * w + (x + w - 1) % w, y * w + (x + 1) % w, ((y + h - 1) % h) * w + x, ((y + 1) % h) * w + x];
                let mut s = 0.0;
                for &q in &nb {
                    s += f[q] + (b[p] as f64 - b[q] as f64);
                }
                let new = f[p] + omega * (s / 4.0 - f[p]);
                change = change.max((new - f[p]).abs());
                f[p] = new;
            }
        }
        if change < 1e-12 {
            break;
        }
    }
    f
}

#[test]
fn item11_solvers_agree_with_reference() {
    for n in [32usize, 64] {
        let a = noise(n, n, 1, 15, 2, 0.0, 255.0);
        let b = noise(n, n, 1, 16, 2, 0.0, 255.0);
        let m = blobs(n, n);
        let reference = sor_reference(&a.data, &b.data, &m.data, n, n);
        for kind in [SolverKind::Mgpcg, SolverKind::Multigrid] {
            let mut p = params();
            p.solver.kind = kind;
            let out = blend_two(&a, &b, &m, &p).unwrap();
            assert!(out.reports[0].converged && out.reports[0].iterations <= 30, "{:?}", out.reports[0]);
            // Tolerance tuned: a relative residual of 1e-6 bounds the error only to about
            // 1e-6 of the values (measured 3.3e-4 for MGPCG on the 64² fixture, 9.4e-4 for
            // V-cycles on 32²), above the check's 1e-4 agreement. Agreement is therefore
            // checked at 1e-8, where f32 rounding is the limit (≤ 8e-5 measured).
            p.solver.tol = 1e-8;
            let out = blend_two(&a, &b, &m, &p).unwrap();
            let d = out.image.data.iter().zip(&reference).map(|(x, y)| (*x as f64 - y).abs()).fold(0.0, f64::max);
            assert!(d <= 1e-4, "{n}² {kind:?}: {d}");
            assert!(out.reports[0].iterations <= 30, "{:?}", out.reports[0]);
        }
        // The other coarsening rule and the band domain agree too.
        let mut p = params();
        p.solver.coarsening = Coarsening::AnyChild;
        // Same tuning as for V-cycles: 3.5e-4 at the default tolerance, well within at 1e-8.
        p.solver.tol = 1e-8;
        let out = blend_two(&a, &b, &m, &p).unwrap();
        let d = out.image.data.iter().zip(&reference).map(|(x, y)| (*x as f64 - y).abs()).fold(0.0, f64::max);
        assert!(d <= 1e-4, "{n}² any-child: {d}");
    }
}

#[test]
fn converged_means_the_returned_image_meets_the_bound() {
    // The f32 solve is refined until the f64 residual of the f32 result meets `tol`; a
    // tolerance below f32 precision cannot be met and must say so rather than claim it.
    let (w, h) = (160, 128);
    let a = noise(w, h, 3, 31, 2, 0.0, 255.0);
    let b = noise(w, h, 3, 32, 2, 0.0, 255.0);
    let m = disc(w, h, 80.0, 64.0, 50.0);
    for topology in [Topology::Torus, Topology::Rim { source: 0 }] {
        for (tol, reachable) in [(1e-6, true), (1e-9, false)] {
            let mut p = params();
            p.topology = topology;
            p.solver.tol = tol;
            p.solver.max_iter = 40;
            for r in blend_two(&a, &b, &m, &p).unwrap().reports {
                assert_eq!(r.converged, reachable, "{topology:?} tol {tol:e}: {r:?}");
                if reachable {
                    assert!(r.residual <= tol && r.max_residual <= TOL_255, "{r:?}");
                }
            }
        }
    }
}

#[test]
fn item11_iterations_are_mesh_independent() {
    let mut counts = Vec::new();
    for n in [128usize, 256, 512, 1024] {
        let a = noise(n, n, 1, 17, 2, 0.0, 255.0);
        let b = noise(n, n, 1, 18, 2, 0.0, 255.0);
        let m = disc(n, n, n as f64 / 2.0, n as f64 / 2.0, n as f64 * 0.4);
        let out = blend_two(&a, &b, &m, &params()).unwrap();
        let r = out.reports[0];
        assert!(r.converged && r.iterations <= 30, "{n}: {r:?}");
        counts.push(r.iterations);
    }
    assert!(counts[3] <= counts[0] + 5, "iterations 128² → 1024²: {counts:?}");
}

// ---------------------------------------------------------------------------------------
// Item 12: determinism

fn with_threads<T: Send>(n: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap().install(f)
}

#[test]
fn item12_bit_identical_across_runs_and_thread_counts() {
    // Large enough for the parallel code paths (≥ 32k free pixels); odd sizes and a label
    // map exercise the sequential odd-wrap path and the general guidance.
    let cases: Vec<(usize, usize)> = vec![(320, 256), (301, 217)];
    for (w, h) in cases {
        let a = noise(w, h, 2, 19, 1, 0.0, 255.0);
        let b = noise(w, h, 2, 20, 1, 0.0, 255.0);
        let c = noise(w, h, 2, 21, 1, 0.0, 255.0);
        let m = disc(w, h, w as f64 / 2.0, h as f64 / 2.0, w.min(h) as f64 * 0.45);
        let labels: Vec<u32> = (0..w * h).map(|i| (((i % w) / 40 + (i / w) / 50) % 3) as u32).collect();
        let run = || {
            let one = blend_two(&a, &b, &m, &params()).unwrap().image;
            let mut p = params();
            p.seam = Seam::Average;
            p.domain = Domain::Band { radius: 6 };
            let two = blend(&[&a, &b, &c], Selector::Labels(&labels), &p).unwrap().image;
            p.domain = Domain::Whole;
            let three = blend(&[&a, &b, &c], Selector::Labels(&labels), &p).unwrap().image;
            (one, two, three)
        };
        let r1 = with_threads(1, run);
        let r2 = with_threads(2, run);
        let r3 = with_threads(3, run);
        let again = with_threads(2, run);
        assert!(r1 == r2 && r2 == r3 && r2 == again, "{w}x{h}: results differ across thread counts");
    }
}

// ---------------------------------------------------------------------------------------
// Item 13: export clamps in PNG, keeps floats in EXR

#[test]
fn item13_overshoot_clamped_in_png_kept_in_exr() {
    let (w, h) = (48, 48);
    // [0, 1] data: dark-ish A, B with a bright spot well above its surroundings.
    let a = Image::filled(w, h, 3, 200.0 / 255.0);
    let b = Image::from_fn(w, h, 3, |x, y, _| {
        let d = (x as f32 - 24.0).hypot(y as f32 - 24.0);
        if d < 4.0 {
            250.0 / 255.0
        } else {
            100.0 / 255.0
        }
    });
    let m = disc(w, h, 24.0, 24.0, 12.0);
    let f = blend_two(&a, &b, &m, &params()).unwrap().image;
    let peak = f.get(24, 24, 0);
    assert!(peak > 1.2, "fixture must overshoot: {peak}");
    let png = crate::raster::decode(&crate::raster::encode_png(&f, 8).unwrap()).unwrap();
    assert_eq!(png.get(24, 24, 0), 1.0, "PNG clamps to 255");
    let exr = crate::raster::decode(&crate::raster::encode_exr(&f).unwrap()).unwrap();
    let d = f.data.iter().zip(&exr.data).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
    assert!(d <= 1e-3 / 255.0, "EXR keeps the float values: {d}");
    assert!(exr.get(24, 24, 0) > 1.2);
}

// ---------------------------------------------------------------------------------------
// Item 14: baselines

/// Mean |f_p − f_q − (g_p − g_q)| over edges crossing ∂Ω (torus).
fn seam_metric(f: &Image, g: &Image, m: &Image) -> f64 {
    let (w, h) = (f.width, f.height);
    let (mut s, mut n) = (0.0, 0);
    for c in 0..f.channels {
        for y in 0..h {
            for x in 0..w {
                let p = (x, y);
                for q in [((x + 1) % w, y), (x, (y + 1) % h)] {
                    if (m.get(p.0, p.1, 0) >= 0.5) != (m.get(q.0, q.1, 0) >= 0.5) {
                        let df = f.get(p.0, p.1, c) - f.get(q.0, q.1, c);
                        let dg = g.get(p.0, p.1, c) - g.get(q.0, q.1, c);
                        s += (df - dg).abs() as f64;
                        n += 1;
                    }
                }
            }
        }
    }
    s / n as f64
}

#[test]
fn item14_gradient_beats_cut_on_offset_fixture() {
    let (w, h) = (64, 64);
    let a = noise(w, h, 3, 22, 2, 0.0, 200.0);
    let b = Image { data: a.data.iter().map(|v| v + 40.0).collect(), ..a.clone() };
    let m = blobs(w, h);
    let mut p = params();
    let grad = blend_two(&a, &b, &m, &p).unwrap().image;
    p.mode = Mode::Cut;
    let cut = blend_two(&a, &b, &m, &p).unwrap().image;
    p.mode = Mode::Average;
    let avg = blend_two(&a, &b, &m, &p).unwrap().image;
    let (sg, sc, sa) = (seam_metric(&grad, &b, &m), seam_metric(&cut, &b, &m), seam_metric(&avg, &b, &m));
    assert!(sg < 0.1 * sc, "gradient {sg} vs cut {sc}");
    assert!(sa > 0.0 && sa < sc, "average {sa} vs cut {sc}");
    // Cut is the composite; average is the mean inside Ω.
    for i in 0..w * h {
        let inside = m.data[i] >= 0.5;
        assert_eq!(cut.data[i], if inside { b.data[i] } else { a.data[i] });
        let want = if inside { 0.5 * (a.data[i] + b.data[i]) } else { a.data[i] };
        assert_eq!(avg.data[i], want);
    }
}

// ---------------------------------------------------------------------------------------
// Mixed gradients, label maps, open topology

#[test]
fn mixed_mode_keeps_the_stronger_texture() {
    let (w, h) = (64, 64);
    let a = noise(w, h, 1, 23, 0, 0.0, 255.0); // strong texture
    let b = Image::filled(w, h, 1, 128.0); // flat
    let m = disc(w, h, 32.0, 32.0, 20.0);
    let mut p = params();
    p.mode = Mode::Mixed;
    let f = blend_two(&a, &b, &m, &p).unwrap();
    assert!(f.reports[0].converged);
    // With B flat, mixing keeps A's gradients inside Ω: the result stays (close to) A.
    let d = f.image.data.iter().zip(&a.data).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
    assert!(d < 1e-2, "{d}");
    p.mode = Mode::Gradient;
    let g = blend_two(&a, &b, &m, &p).unwrap().image;
    let var = |img: &Image| {
        let inside: Vec<f32> = (0..w * h).filter(|&i| m.data[i] >= 0.5).map(|i| img.data[i]).collect();
        let mean = inside.iter().sum::<f32>() / inside.len() as f32;
        inside.iter().map(|v| (v - mean).powi(2)).sum::<f32>() / inside.len() as f32
    };
    assert!(var(&g) < 0.1 * var(&f.image), "gradient mode flattens the inside");
}

#[test]
fn label_map_band_and_whole_domains() {
    let (w, h) = (96, 64);
    let s: Vec<Image> = (0..3).map(|k| noise(w, h, 1, 30 + k, 2, 50.0 * k as f32, 50.0 * k as f32 + 100.0)).collect();
    let refs: Vec<&Image> = s.iter().collect();
    let labels: Vec<u32> = (0..w * h).map(|i| ((i % w) * 3 / w) as u32).collect();
    for seam in [Seam::Average, Seam::Insert, Seam::Zero] {
        for domain in [Domain::Band { radius: 4 }, Domain::Mask, Domain::Whole] {
            for topology in [Topology::Torus, Topology::Open] {
                let p = BlendParams { seam, domain, topology, ..params() };
                let out = blend(&refs, Selector::Labels(&labels), &p).unwrap();
                let r = out.reports[0];
                assert!(r.converged && r.max_residual <= TOL_255, "{seam:?} {domain:?} {topology:?}: {r:?}");
                if domain == Domain::Whole {
                    let want = if topology == Topology::Torus { Method::Periodic } else { Method::Neumann };
                    assert_eq!(r.method, want);
                    assert!(r.residual <= 1e-6, "{r:?}");
                }
                if let Domain::Band { radius } = domain {
                    // Far from seams the composite is kept exactly.
                    for y in 0..h {
                        for x in 0..w {
                            let near = (0..3).any(|k| {
                                let b = k * w / 3;
                                let d = (x as isize - b as isize).rem_euclid(w as isize) as usize;
                                d.min(w - d) <= radius + 1
                            });
                            if !near && topology == Topology::Torus {
                                let i = y * w + x;
                                assert_eq!(out.image.data[i], s[labels[i] as usize].data[i]);
                            }
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn warm_start_converges_to_the_same_result() {
    let (w, h) = (80, 80);
    let a = noise(w, h, 1, 40, 2, 0.0, 255.0);
    let b = noise(w, h, 1, 41, 2, 0.0, 255.0);
    let m = blobs(w, h);
    let cold = blend_two(&a, &b, &m, &params()).unwrap();
    let warm =
        blend_with(&[&a, &b], Selector::Binary(&m), &params(), &Run { warm: Some(&cold.image), ..Run::default() })
            .unwrap();
    assert!(warm.reports[0].iterations <= 1, "{:?}", warm.reports[0]);
    let d = warm.image.data.iter().zip(&cold.image.data).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
    assert!(d <= 1e-3, "{d}");
}

// ---------------------------------------------------------------------------------------
// Items 29, 30, 32

#[test]
fn item29_soft_masks() {
    let (w, h) = (64, 48);
    let a = noise(w, h, 1, 50, 2, 0.0, 255.0);
    let b = noise(w, h, 1, 51, 2, 0.0, 255.0);
    // m ≡ 0.5 over the whole torus: Δf = ½(ΔA + ΔB).
    let half = Image::filled(w, h, 1, 0.5);
    let p = BlendParams { domain: Domain::Whole, ..params() };
    let out = blend(&[&a, &b], Selector::Soft(&half), &p).unwrap();
    assert_eq!(out.reports[0].method, Method::Periodic);
    let lap = |v: &[f32], x: usize, y: usize| {
        let g = |xx: usize, yy: usize| v[(yy % h) * w + xx % w] as f64;
        4.0 * g(x, y) - g(x + 1, y) - g(x + w - 1, y) - g(x, y + 1) - g(x, y + h - 1)
    };
    let mut mx = 0.0f64;
    for y in 0..h {
        for x in 0..w {
            let want = 0.5 * (lap(&a.data, x, y) + lap(&b.data, x, y));
            mx = mx.max((lap(&out.image.data, x, y) - want).abs());
        }
    }
    assert!(mx <= TOL_255, "{mx}");
    // A binary soft mask reproduces the binary blend (Dirichlet variant).
    let m = blobs(w, h);
    let soft = blend(&[&a, &b], Selector::Soft(&m), &params()).unwrap().image;
    let hard = blend_two(&a, &b, &m, &params()).unwrap().image;
    let d = soft.data.iter().zip(&hard.data).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
    assert!(d <= 1e-4, "{d}");
}

#[test]
fn item30_per_channel_masks() {
    let (w, h) = (64, 48);
    let a = noise(w, h, 3, 52, 2, 0.0, 255.0);
    let b = noise(w, h, 3, 53, 2, 0.0, 255.0);
    let m1 = blobs(w, h);
    let mut m3 = Image::new(w, h, 3);
    m3.plane_mut(0).copy_from_slice(&m1.data);
    let f = blend_two(&a, &b, &m3, &params()).unwrap().image;
    let rgb = blend_two(&a, &b, &m1, &params()).unwrap().image;
    assert_eq!(f.plane(0), rgb.plane(0), "red takes B's gradients");
    assert_eq!(f.plane(1), a.plane(1));
    assert_eq!(f.plane(2), a.plane(2));
}

#[test]
fn item32_make_periodic_removes_the_wrap_seam() {
    let (w, h) = (96, 64);
    // Photo-like and not tileable: a ramp (large wrap jump) plus texture.
    let t = noise(w, h, 3, 54, 1, 0.0, 60.0);
    let img = Image::from_fn(w, h, 3, |x, y, c| t.get(x, y, c) + 1.5 * x as f32 + 0.8 * y as f32 + 10.0 * c as f32);
    let before = wrap_seam_ratio(&img);
    let p = make_periodic(&img);
    let after = wrap_seam_ratio(&p);
    assert!(before > 3.0, "fixture must have a seam: {before}");
    assert!(after <= 1.2, "{before} → {after}");
    // Interior gradients are nearly kept: the smooth component is smooth.
    let mean = |v: &Image| v.data.iter().map(|&x| x as f64).sum::<f64>() / v.data.len() as f64;
    assert!((mean(&img) - mean(&p)).abs() < 1e-3);
}

// ---------------------------------------------------------------------------------------
// Solver edge cases

#[test]
fn tiny_and_odd_sizes_converge() {
    for (w, h) in [(3usize, 5usize), (9, 9), (17, 33), (64, 1), (65, 63)] {
        let a = noise(w, h, 1, 60, 1, 0.0, 255.0);
        let b = noise(w, h, 1, 61, 1, 0.0, 255.0);
        let m = Image::from_fn(w, h, 1, |x, y, _| if (x + 2 * y) % 5 < 3 { 1.0 } else { 0.0 });
        for topology in [Topology::Torus, Topology::Open] {
            let p = BlendParams { topology, ..params() };
            let out = blend_two(&a, &b, &m, &p).unwrap();
            let r = out.reports[0];
            assert!(r.converged && r.max_residual <= TOL_255, "{w}x{h} {topology:?}: {r:?}");
        }
    }
}

#[test]
fn batched_channels_match_single_channel_solves_bitwise() {
    // Channels are solved together (up to four lanes per batch); each must get exactly the
    // one-channel result: five channels (a batch of four and one alone), both topologies,
    // an odd size (odd wrap) and one large enough for the parallel paths.
    for (w, h, topology) in [(61, 47, Topology::Torus), (64, 48, Topology::Open), (300, 260, Topology::Torus)] {
        let a = noise(w, h, 5, 70, 1, 0.0, 255.0);
        let b = noise(w, h, 5, 71, 1, 0.0, 255.0);
        let m = disc(w, h, w as f64 / 2.0, h as f64 / 2.0, w.min(h) as f64 * 0.4);
        let p = BlendParams { topology, ..params() };
        let all = blend_two(&a, &b, &m, &p).unwrap();
        for c in 0..5 {
            let one = |img: &Image| Image { width: w, height: h, channels: 1, data: img.plane(c).to_vec() };
            let single = blend_two(&one(&a), &one(&b), &m, &p).unwrap();
            assert_eq!(single.image.data, all.image.plane(c), "{w}x{h} {topology:?} channel {c}");
            assert_eq!(single.reports[0].iterations, all.reports[c].iterations);
            assert!(all.reports[c].converged && all.reports[c].residual <= 1e-6, "{:?}", all.reports[c]);
        }
    }
}

#[test]
fn progress_counts_solver_iterations_and_changes_nothing() {
    let (w, h) = (80, 80);
    let a = noise(w, h, 1, 42, 2, 0.0, 255.0);
    let b = noise(w, h, 1, 43, 2, 0.0, 255.0);
    let m = blobs(w, h);
    let seen = std::sync::Mutex::new(Vec::new());
    let report = |done, total| seen.lock().unwrap().push((done, total));
    let run = Run { progress: crate::synth::Progress::new(&report), ..Run::default() };
    let with = blend_with(&[&a, &b], Selector::Binary(&m), &params(), &run).unwrap();
    let without = blend_two(&a, &b, &m, &params()).unwrap();
    assert_eq!(with.image.data, without.image.data, "reporting changed the result");
    let seen = seen.into_inner().unwrap();
    let iterations = with.reports[0].iterations as u64;
    assert!(iterations > 0);
    let max_iter = params().solver.max_iter as u64;
    assert!(seen.iter().all(|&(_, total)| total == max_iter), "{seen:?}");
    // One report per iteration of each solve (refinement rounds start again from 1).
    assert_eq!(seen.len() as u64, iterations, "{seen:?}");
    assert!(seen.windows(2).all(|p| p[1].0 == p[0].0 + 1 || p[1].0 == 1), "{seen:?}");
}
