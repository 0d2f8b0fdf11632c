//! Unit tests of generator synthesis: trivial swaps (F9), region count and scale (F10),
//! statistical similarity (F11), and the density, occupancy, size, orientation and metric maps
//! (F12, F18, F19).

use super::*;
use crate::raster::Image;
use crate::synth::structure::fixtures::ellipses::*;
use crate::synth::structure::relaxation::controls::SizeMode;
use crate::synth::structure::relaxation::lloyd::{lloyd, LloydParams, LloydResult};
use crate::synth::structure::relaxation::metric::MetricKind;
use crate::synth::structure::relaxation::voronoi::region_sizes;
use crate::synth::structure::types::NO_REGION;

/// A relaxed "original" tiling and its interior regions' refitted ellipses and areas.
struct Example {
    ellipses: Vec<Ellipse>,
    areas: Vec<f64>,
}

fn example(seed: u64, w: usize, h: usize, n: usize, theta_mean: f64, theta_spread: f64) -> Example {
    let mut rng = Rng::new(seed);
    let gens: Vec<Ellipse> = (0..n)
        .map(|_| {
            let a = 12.0 * (rng.normal() * 0.25).exp();
            let b = a / rng.range(1.3, 2.5);
            let t = theta_mean + rng.normal() * theta_spread;
            canonical(Ellipse { center: [rng.range(0.0, w as f64), rng.range(0.0, h as f64)], a, b, theta: t })
        })
        .collect();
    let r = lloyd(w, h, &gens, None, &Controls::default(), &LloydParams::default());
    let fits = fit_regions(&r.labels, r.generators.len());
    let interior: Vec<Fit> = fits.into_iter().flatten().filter(|f| !f.border).collect();
    Example { ellipses: interior.iter().map(|f| f.ellipse).collect(), areas: interior.iter().map(|f| f.area).collect() }
}

fn relax(w: usize, h: usize, s: &Synthesized, controls: &Controls) -> LloydResult {
    lloyd(w, h, &s.generators, Some(&s.frozen), controls, &LloydParams::default())
}

fn interior_fits(r: &LloydResult) -> Vec<Fit> {
    fit_regions(&r.labels, r.generators.len()).into_iter().flatten().filter(|f| !f.border).collect()
}

/// F9: random region swaps + Lloyd: count unchanged, `(a, b)` multiset unchanged, every
/// generator inside its own region.
#[test]
fn f9_trivial_swap_synthesis() {
    let (w, h) = (320, 256);
    let mut rng = Rng::new(90);
    let gens = random_ellipses(&mut rng, 90, w, h, 8.0, 20.0, 2.5);
    let orig = lloyd(w, h, &gens, None, &Controls::default(), &LloydParams::default()).generators;
    let swapped = swap_regions(&orig, 60, &mut rng);
    let perturbed = perturb(&swapped, 2.0, 0.1, &mut rng);
    for input in [swapped, perturbed] {
        let params = LloydParams { drop_orphans: false, ..Default::default() };
        let r = lloyd(w, h, &input, None, &Controls::default(), &params);
        let sizes = region_sizes(&r.labels, r.generators.len());
        assert_eq!(sizes.iter().filter(|&&s| s > 0).count(), orig.len());
        let key = |v: &[Ellipse]| {
            let mut k: Vec<(u64, u64)> = v.iter().map(|e| (e.a.to_bits(), e.b.to_bits())).collect();
            k.sort_unstable();
            k
        };
        assert_eq!(key(&orig), key(&r.generators));
        for (g, e) in r.generators.iter().enumerate() {
            let (x, y) = (e.center[0].floor() as usize, e.center[1].floor() as usize);
            assert_eq!(r.labels.get(x.min(w - 1), y.min(h - 1)), g as u32, "generator {g} outside its region");
        }
    }
    eprintln!("F9: {} regions kept, (a,b) multiset identical, all generators inside their regions", orig.len());
}

/// F10: N' exact, orphans ≤ 1 %, s = 0.5 gives ≈ 4× as many regions (±5 %).
#[test]
fn f10_region_count_and_scale() {
    let (w, h) = (400, 300);
    let ex = example(100, 300, 300, 120, 0.3, 0.3);
    let rbar = mean_area(&ex.areas);
    let occ: Vec<f32> = (0..w * h).map(|i| if (i % w) < 60 && (i / w) < 100 { 0.0 } else { 1.0 }).collect();
    let controls = Controls { occupancy: Some(&occ), ..Default::default() };
    let allowed_px = (w * h - 60 * 100) as f64;
    let mut counts = Vec::new();
    for scale in [1.0, 0.5] {
        let mut sampler = EmpiricalSampler::new(&ex.ellipses, ShapeSampling::Joint);
        let params = StatisticalParams { scale, ..StatisticalParams::new(rbar) };
        let s = statistical(w, h, &controls, &mut sampler, CenterSource::Density, &params, &mut Rng::new(101)).unwrap();
        let expected = (allowed_px / (scale * scale * rbar)).round() as usize;
        assert_eq!(s.target_count, expected);
        assert_eq!(s.generators.len(), expected);
        let r = relax(w, h, &s, &controls);
        let nonempty = region_sizes(&r.labels, r.generators.len()).iter().filter(|&&c| c > 0).count();
        let orphan_share = r.orphans.len() as f64 / expected as f64;
        eprintln!(
            "F10 s={scale}: N' = {expected} (r̄ = {rbar:.1}), non-empty {nonempty}, orphans {} ({:.2} %)",
            r.orphans.len(),
            100.0 * orphan_share
        );
        assert_eq!(nonempty, expected - r.orphans.len());
        assert!(orphan_share <= 0.01);
        counts.push(nonempty as f64);
    }
    let ratio = counts[1] / counts[0];
    eprintln!("F10 region ratio s=0.5 / s=1: {ratio:.4}");
    assert!((ratio / 4.0 - 1.0).abs() <= 0.05, "ratio {ratio}");
}

/// F11: statistical similarity of stage 1 with a simple (bootstrap) sampler, 3 seeds.
#[test]
fn f11_statistical_similarity() {
    let ex = example(110, 400, 400, 220, 0.5, 0.25);
    let rbar = mean_area(&ex.areas);
    let ex_ratio: Vec<f64> = ex.ellipses.iter().map(|e| e.a / e.b).collect();
    let ex_area: Vec<f64> = ex.areas.iter().map(|a| a / rbar).collect();
    let ex_theta: Vec<f64> = ex.ellipses.iter().map(|e| e.theta).collect();
    let mean_ratio = ex_ratio.iter().sum::<f64>() / ex_ratio.len() as f64;
    for seed in [111, 112, 113] {
        let (w, h) = (480, 400);
        for mode in [ShapeSampling::Independent, ShapeSampling::Joint] {
            let mut sampler = EmpiricalSampler::new(&ex.ellipses, mode);
            let s = statistical(
                w,
                h,
                &Controls::default(),
                &mut sampler,
                CenterSource::Density,
                &StatisticalParams::new(rbar),
                &mut Rng::new(seed),
            )
            .unwrap();
            let r = relax(w, h, &s, &Controls::default());
            let fits = interior_fits(&r);
            let gbar = fits.iter().map(|f| f.area).sum::<f64>() / fits.len() as f64;
            let ratio: Vec<f64> = fits.iter().map(|f| f.ellipse.a / f.ellipse.b).collect();
            let area: Vec<f64> = fits.iter().map(|f| f.area / gbar).collect();
            let theta: Vec<f64> = fits.iter().map(|f| f.ellipse.theta).collect();
            let d_ratio = ks(&ex_ratio, &ratio);
            let d_area = ks(&ex_area, &area);
            let d_theta = ks(&ex_theta, &theta);
            let dmean = axial_diff(axial_mean(&ex_theta), axial_mean(&theta)).to_degrees();
            eprintln!(
                "F11 seed {seed} {mode:?}: {} regions, KS a/b {d_ratio:.3}, KS area {d_area:.3}, KS θ {d_theta:.3}, Δ mean θ {dmean:.2}° (sample mean a/b {mean_ratio:.2})",
                fits.len()
            );
            assert!(d_ratio < 0.2 && d_area < 0.2 && dmean < 10.0);
            if mean_ratio > 1.3 {
                assert!(d_theta < 0.25);
            }
        }
    }
}

/// Banded density map: dark (dense) bands centred on `y = period/2 + k·period`.
fn bands(w: usize, h: usize, period: f64) -> Vec<f32> {
    (0..w * h)
        .map(|i| {
            let y = (i / w) as f64 + 0.5;
            (0.5 - 0.5 * (2.0 * std::f64::consts::PI * (y - period / 2.0) / period).cos()) as f32
        })
        .collect()
}

/// F12: the density map pulls regions into the dark bands.
#[test]
fn f12_density_map() {
    let (w, h) = (480, 480);
    let period = 96.0;
    let density = bands(w, h, period);
    let mut rng = Rng::new(120);
    let shapes: Vec<Ellipse> = (0..50)
        .map(|_| {
            let a = rng.range(7.0, 11.0);
            Ellipse { center: [0.0, 0.0], a, b: a / rng.range(1.0, 1.6), theta: rng.range(0.0, std::f64::consts::PI) }
        })
        .collect();
    let rbar = 150.0;
    let dparams = crate::synth::structure::relaxation::controls::DensityParams::default();
    let weight_at = |p: Point| {
        let l = crate::synth::structure::relaxation::controls::sample_bilinear(&density, w, h, p) as f32;
        crate::synth::structure::relaxation::controls::density_weight(l, &dparams) as f64
    };
    let mut results = Vec::new();
    for with_map in [false, true] {
        let controls = Controls { density: with_map.then_some(&density[..]), ..Default::default() };
        let mut sampler = EmpiricalSampler::new(&shapes, ShapeSampling::Joint);
        let s = statistical(
            w,
            h,
            &controls,
            &mut sampler,
            CenterSource::Density,
            &StatisticalParams::new(rbar),
            &mut Rng::new(121),
        )
        .unwrap();
        let r = relax(w, h, &s, &controls);
        let fits: Vec<Fit> = fit_regions(&r.labels, r.generators.len()).into_iter().flatten().collect();
        let mean_w = fits.iter().map(|f| weight_at(f.ellipse.center)).sum::<f64>() / fits.len() as f64;
        // Folded y histogram of centroids: 8 bins over one period.
        let mut hist = [0usize; 8];
        for f in &fits {
            let phase = (f.ellipse.center[1] / period).fract();
            hist[((phase * 8.0) as usize).min(7)] += 1;
        }
        results.push((mean_w, hist, r.iterations.len()));
    }
    let (w0, _, _) = results[0];
    let (w1, hist, iters) = results[1];
    let gain = w1 / w0 - 1.0;
    // Band centre = phase 0.5 → bins 3, 4; trough = phase 0 → bins 7, 0.
    let peak = (hist[3] + hist[4]) as f64;
    let trough = (hist[7] + hist[0]).max(1) as f64;
    eprintln!("F12: mean weight without {w0:.3}, with {w1:.3} (+{:.1} %); folded histogram {hist:?}, peak/trough {:.2}; {iters} iterations", 100.0 * gain, peak / trough);
    assert!(gain >= 0.25, "gain {gain}");
    assert!(peak / trough >= 2.0);
}

/// F18: occupancy map: nothing in forbidden pixels, forbidden pixels never reach a
/// centroid (probe), N' from the allowed area.
#[test]
fn f18_occupancy() {
    let (w, h) = (400, 320);
    // A window rectangle and a round arch top.
    let occ: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
            let window = (150.0..250.0).contains(&x) && (120.0..260.0).contains(&y);
            let arch = (x - 200.0).hypot(y - 120.0) < 50.0;
            if window || arch {
                0.0
            } else {
                1.0
            }
        })
        .collect();
    let allowed = allowed_from_occupancy(&occ);
    let allowed_px = allowed.iter().filter(|&&a| a).count() as f64;
    let mut rng = Rng::new(180);
    let shapes = random_ellipses(&mut rng, 40, 10, 10, 8.0, 14.0, 2.0);
    let controls = Controls { occupancy: Some(&occ), ..Default::default() };
    let rbar = 260.0;
    let mut sampler = EmpiricalSampler::new(&shapes, ShapeSampling::Joint);
    let s = statistical(
        w,
        h,
        &controls,
        &mut sampler,
        CenterSource::Density,
        &StatisticalParams::new(rbar),
        &mut Rng::new(181),
    )
    .unwrap();
    assert_eq!(s.target_count, (allowed_px / rbar).round() as usize);
    let r = relax(w, h, &s, &controls);
    let mut labelled_forbidden = 0;
    for (&ok, &l) in allowed.iter().zip(&r.labels.data) {
        if !ok && l != NO_REGION {
            labelled_forbidden += 1;
        }
        if ok {
            assert_ne!(l, NO_REGION);
        }
    }
    let gens_forbidden = r.generators.iter().filter(|e| !point_allowed(Some(&allowed), w, h, e.center)).count();
    eprintln!("F18: N' = {} from {allowed_px} allowed px; labelled forbidden px {labelled_forbidden}; generators in forbidden px {gens_forbidden}; orphans {}", s.target_count, r.orphans.len());
    assert_eq!(labelled_forbidden, 0);
    assert_eq!(gens_forbidden, 0);
    // Probe: density maps that differ only inside the forbidden area give bit-identical
    // results, so forbidden pixels never contribute to a centroid.
    let dens_a: Vec<f32> = (0..w * h).map(|i| (i % w) as f32 / w as f32).collect();
    let mut dens_b = dens_a.clone();
    for i in 0..w * h {
        if !allowed[i] {
            dens_b[i] = if (i / w) % 2 == 0 { 0.0 } else { 1.0 };
        }
    }
    // Sampled at half resolution too, the probe must hold for the full-resolution run
    // (bilinear resampling would mix pixels across the border).
    let params = LloydParams { max_iters: 10, ..Default::default() };
    let ca = Controls { density: Some(&dens_a), ..controls };
    let cb = Controls { density: Some(&dens_b), ..controls };
    let ra = lloyd(w, h, &s.generators, None, &ca, &params);
    let rb = lloyd(w, h, &s.generators, None, &cb, &params);
    assert_eq!(ra, rb);
    // Reduced resolution: the same guarantees hold at full resolution.
    let half = lloyd(w, h, &s.generators, None, &controls, &LloydParams { resolution: 0.5, ..Default::default() });
    let bad_px = half.labels.data.iter().zip(&allowed).filter(|(&l, &ok)| !ok && l != NO_REGION).count();
    let bad_gen = half.generators.iter().filter(|e| !point_allowed(Some(&allowed), w, h, e.center)).count();
    eprintln!(
        "F18 resolution 0.5: labelled forbidden px {bad_px}, generators in forbidden px {bad_gen}, orphans {}",
        half.orphans.len()
    );
    assert_eq!((bad_px, bad_gen, half.orphans.len()), (0, 0, 0));
    let moved = ra.generators.iter().zip(&s.generators).filter(|(a, b)| a.center != b.center).count();
    assert!(moved > s.generators.len() / 2);
    eprintln!("F18 probe: forbidden-pixel density changes leave all {} generators bit-identical", ra.generators.len());
}

/// F19: size map (dark half small) and orientation map (constant 45°).
#[test]
fn f19_size_and_orientation_maps() {
    let (w, h) = (480, 360);
    let mut rng = Rng::new(190);
    let shapes: Vec<Ellipse> = (0..60)
        .map(|_| {
            let a = rng.range(10.0, 16.0);
            Ellipse { center: [0.0; 2], a, b: a / rng.range(1.2, 2.2), theta: rng.range(0.0, std::f64::consts::PI) }
        })
        .collect();
    let rbar = 500.0;
    // Size map: left half black (k = k_min = 0.3), right half white (k = 1).
    let size: Vec<f32> = (0..w * h).map(|i| if (i % w) < w / 2 { 0.0 } else { 1.0 }).collect();
    let controls = Controls { size: Some(&size), size_mode: SizeMode::Scale { k_min: 0.3 }, ..Default::default() };
    let mut sampler = EmpiricalSampler::new(&shapes, ShapeSampling::Joint);
    let s = statistical(
        w,
        h,
        &controls,
        &mut sampler,
        CenterSource::Density,
        &StatisticalParams::new(rbar),
        &mut Rng::new(191),
    )
    .unwrap();
    let r = relax(w, h, &s, &controls);
    let fits = interior_fits(&r);
    let (mut dark, mut light) = (Vec::new(), Vec::new());
    for f in &fits {
        if f.ellipse.center[0] < w as f64 / 2.0 {
            dark.push(f.area)
        } else {
            light.push(f.area)
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let ratio = mean(&dark) / mean(&light);
    eprintln!(
        "F19 size: {} generators, dark mean area {:.1} ({}), light {:.1} ({}), ratio {ratio:.3}",
        s.generators.len(),
        mean(&dark),
        dark.len(),
        mean(&light),
        light.len()
    );
    assert!(ratio <= 0.7);

    // Orientation: constant 45° field.
    let t45 = std::f64::consts::FRAC_PI_4;
    let field = Image::from_fn(w, h, 2, |_, _, c| if c == 0 { t45.cos() as f32 } else { t45.sin() as f32 });
    let mut spreads = Vec::new();
    for with_map in [false, true] {
        let controls = Controls { orientation: with_map.then_some(&field), ..Default::default() };
        let mut sampler = EmpiricalSampler::new(&shapes, ShapeSampling::Independent);
        let s = statistical(
            w,
            h,
            &controls,
            &mut sampler,
            CenterSource::Density,
            &StatisticalParams::new(rbar),
            &mut Rng::new(192),
        )
        .unwrap();
        let r = relax(w, h, &s, &controls);
        let theta: Vec<f64> =
            interior_fits(&r).iter().filter(|f| f.anisotropy >= 1.02).map(|f| f.ellipse.theta).collect();
        let m = axial_mean(&theta);
        let conc = axial_concentration(&theta);
        eprintln!(
            "F19 orientation (map {with_map}): mean θ {:.2}°, concentration {conc:.3} over {} regions",
            m.to_degrees(),
            theta.len()
        );
        if with_map {
            assert!(axial_diff(m, t45).to_degrees() < 5.0);
        }
        spreads.push(conc);
    }
    assert!(spreads[1] > spreads[0], "spread not smaller with the map");
}

/// Squareness of every interior region: over box orientations φ in 1° steps, the largest
/// `area / (4·max|u|·max|v|)` with `(u, v)` the pixel centres relative to the region's
/// centroid in the frame turned by φ, with `max|u| / max|v|` in that frame and φ (a square
/// gives 1 and 1 in its own frame; a disc π/4, a regular hexagon 3/4).
fn squareness(r: &LloydResult) -> Vec<(f64, f64, f64)> {
    let fits = fit_regions(&r.labels, r.generators.len());
    let w = r.labels.width;
    let mut pixels: Vec<Vec<[f64; 2]>> = vec![Vec::new(); fits.len()];
    for (i, &g) in r.labels.data.iter().enumerate() {
        if let Some(Some(f)) = fits.get(g as usize) {
            let c = f.ellipse.center;
            pixels[g as usize].push([(i % w) as f64 + 0.5 - c[0], (i / w) as f64 + 0.5 - c[1]]);
        }
    }
    let best = |px: &[[f64; 2]], area: f64| {
        (0..90)
            .map(|deg| {
                let (sn, cs) = (deg as f64).to_radians().sin_cos();
                let (mut eu, mut ev) = (0.0f64, 0.0f64);
                for &[dx, dy] in px {
                    eu = eu.max((dx * cs + dy * sn).abs() + 0.5);
                    ev = ev.max((-dx * sn + dy * cs).abs() + 0.5);
                }
                (area / (4.0 * eu * ev), eu / ev, deg as f64)
            })
            .fold((0.0, 0.0, 0.0), |a, b| if b.0 > a.0 { b } else { a })
    };
    fits.iter().zip(&pixels).filter_map(|(f, px)| f.as_ref().filter(|f| !f.border).map(|f| best(px, f.area))).collect()
}

/// F19: a Manhattan metric map makes square tiles. From random round generators, Lloyd
/// under the elliptic metric gives roughly hexagonal cells; under `|u/a| + |v/b|` the cells
/// become squares turned 45° from the ellipse axes (the diamond of the L1 unit ball): they
/// fill more of their best box, that box sits near 45°, and its two extents are within 15 %.
#[test]
fn f19_metric_map_makes_square_tiles() {
    let (w, h) = (320, 320);
    let mut rng = Rng::new(193);
    let gens: Vec<Ellipse> = (0..256)
        .map(|_| Ellipse { center: [rng.range(0.0, w as f64), rng.range(0.0, h as f64)], a: 10.0, b: 10.0, theta: 0.0 })
        .collect();
    let manhattan = vec![MetricKind::Manhattan; w * h];
    let mut fills = Vec::new();
    for map in [None, Some(&manhattan[..])] {
        let controls = Controls { metric: map, ..Default::default() };
        let r = lloyd(w, h, &gens, None, &controls, &LloydParams::default());
        let sq = squareness(&r);
        let mean = |f: &dyn Fn(&(f64, f64, f64)) -> f64| sq.iter().map(f).sum::<f64>() / sq.len() as f64;
        let (fill, ratio) = (mean(&|x| x.0), mean(&|x| x.1));
        let diamonds = mean(&|x| f64::from((x.2 - 45.0).abs() <= 10.0));
        eprintln!(
            "F19 metric map {}: {} regions, box fill {fill:.3}, extent ratio {ratio:.3}, box within 10° of 45°: {:.0} %",
            if map.is_some() { "Manhattan" } else { "none" },
            sq.len(),
            diamonds * 100.0
        );
        if map.is_some() {
            assert!((ratio - 1.0).abs() <= 0.15, "extent ratio {ratio}");
            assert!(diamonds >= 0.6, "only {diamonds} of the boxes sit near 45°");
        }
        fills.push(fill);
    }
    assert!(fills[1] >= fills[0] + 0.05, "Manhattan regions are not squarer: {fills:?}");
}
