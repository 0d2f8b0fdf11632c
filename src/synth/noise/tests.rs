//! The analysis and evaluation together (checklist items 8–12, 16–23, 25, 27): textures made
//! from known parameters, fitted back, rendered again and measured.

use super::colour::ColourMode;
use super::eval::{self, Domain, Look, Noise};
use super::marginal::{ks_two_sample, Abscissa};
use super::params::{fit, fit_masked, Channel, Estimator, FitOptions, HistogramMode, Procedural, NOISE_VERSION};
use super::spectrum::{band_powers, BandPowers};
use crate::raster::Image;

const I3: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// A parameter set with the same weights in every channel, RGB independent, no curves.
fn known(weights: &[f64], n: usize, mean: f64) -> Procedural {
    let ch = || Channel { weights: weights.to_vec(), curve: None };
    Procedural {
        noise_version: NOISE_VERSION,
        seed: 0,
        tile: 256,
        sample_size: n,
        colour: ColourMode::RgbIndependent,
        mean: [mean; 3],
        u: I3,
        channels: [ch(), ch(), ch()],
    }
}

fn render_at(p: &Procedural, seed: u64, size: usize, pixel: f64, gains: &[f64]) -> Image {
    let noise = Noise::new(seed, p.tile, p.channels[0].weights.len(), p.colour, false).unwrap();
    let look = Look::new(p, gains);
    eval::render(&noise, size, size, Domain::Plane { origin: [0.0; 2], pixel }, |_, _| &look).unwrap()
}

fn plane(img: &Image, c: usize) -> Vec<f64> {
    img.plane(c).iter().map(|&v| f64::from(v)).collect()
}

fn powers(img: &Image, c: usize) -> BandPowers {
    band_powers(&plane(img, c), img.width).unwrap()
}

fn db(a: f64, b: f64) -> f64 {
    10.0 * (a / b).log10()
}

fn grey_opts() -> FitOptions {
    FitOptions { colour: ColourMode::RgbIndependent, histogram: HistogramMode::Off, ..FitOptions::default() }
}

#[test]
fn flat_weights_come_back_with_the_papers_biases() {
    // Item 8: flat weights at 256², 8 seeds: b ≥ 5 within [−5 %, +8 %], b = 4 within ±12 %,
    // b = 2 biased low by 10–40 %.
    let n = 256;
    let truth = known(&[1.0; 7], n, 0.5);
    let mut sum = [0.0; 7];
    for seed in 0..8 {
        let img = render_at(&truth, seed, n, 1.0 / n as f64, &[]);
        let got = fit(&img, &grey_opts()).unwrap().params;
        for (s, w) in sum.iter_mut().zip(&got.channels[0].weights) {
            *s += w / 8.0;
        }
    }
    let err: Vec<f64> = sum.iter().map(|w| w - 1.0).collect();
    for (k, e) in err.iter().enumerate() {
        let b = k + 2;
        match b {
            2 => assert!((-0.40..=-0.10).contains(e), "band 2: {e}"),
            4 => assert!(e.abs() <= 0.12, "band 4: {e}"),
            5.. => assert!((-0.05..=0.08).contains(e), "band {b}: {e}"),
            _ => {}
        }
    }
    eprintln!("flat weights, mean relative error by band 2..8: {err:?}");
}

#[test]
fn random_weights_round_trip_better_with_nnls() {
    // Item 9: U[0,1] weights; mean |ŵ − w| over bands ≥ 6 < 0.07 (eq. 9) and < 0.03 (NNLS).
    let n = 256;
    let mut rng = crate::synth::rng::Rng::new(9);
    let (mut paper, mut nnls, mut count) = (0.0, 0.0, 0);
    for seed in 0..4 {
        let w: Vec<f64> = (0..7).map(|_| rng.next_f64()).collect();
        let img = render_at(&known(&w, n, 0.5), 100 + seed, n, 1.0 / n as f64, &[]);
        let a = fit(&img, &grey_opts()).unwrap().params;
        let b = fit(&img, &FitOptions { estimator: Estimator::Nnls, ..grey_opts() }).unwrap().params;
        for (k, want) in w.iter().enumerate().skip(4) {
            paper += (a.channels[0].weights[k] - want).abs();
            nnls += (b.channels[0].weights[k] - want).abs();
            count += 1;
        }
    }
    let (paper, nnls) = (paper / count as f64, nnls / count as f64);
    eprintln!("random weights, mean |error| over bands 6..8: eq. 9 {paper:.4}, nnls {nnls:.4}");
    assert!(paper < 0.07, "eq. 9: {paper}");
    assert!(nnls < 0.03, "nnls: {nnls}");
}

/// A colour sample with strongly correlated channels: one noise, tinted, plus a little of a
/// second one on blue.
fn correlated_sample(n: usize) -> Image {
    let a = render_at(&known(&[0.3, 0.5, 0.6, 0.5, 0.4, 0.3], n / 2 * 2, 0.0), 7, n, 1.0 / n as f64, &[]);
    let b = render_at(&known(&[0.3, 0.5, 0.6, 0.5, 0.4, 0.3], n, 0.0), 8, n, 1.0 / n as f64, &[]);
    Image::from_fn(n, n, 3, |x, y, c| {
        let (s, t) = (a.get(x, y, 0), b.get(x, y, 0));
        match c {
            0 => 0.5 + 0.20 * s,
            1 => 0.4 + 0.15 * s + 0.02 * t,
            _ => 0.3 + 0.08 * s + 0.06 * t,
        }
    })
}

fn covariance(img: &Image) -> [[f64; 3]; 3] {
    let m = img.plane_len() as f64;
    let mean: [f64; 3] = std::array::from_fn(|c| img.plane(c).iter().map(|&v| f64::from(v)).sum::<f64>() / m);
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            img.plane(i)
                .iter()
                .zip(img.plane(j))
                .map(|(&a, &b)| (f64::from(a) - mean[i]) * (f64::from(b) - mean[j]))
                .sum::<f64>()
                / m
        })
    })
}

fn correlation(cov: &[[f64; 3]; 3], i: usize, j: usize) -> f64 {
    cov[i][j] / (cov[i][i] * cov[j][j]).sqrt()
}

#[test]
fn the_three_colour_modes_behave_as_figure_7() {
    // Item 12.
    let n = 128;
    let sample = correlated_sample(n);
    let want = covariance(&sample);
    assert!(correlation(&want, 0, 1) > 0.9);
    let out = |colour| {
        let opts = FitOptions { colour, histogram: HistogramMode::Off, ..FitOptions::default() };
        let p = fit(&sample, &opts).unwrap().params;
        covariance(&render_at(&p, 3, 256, 1.0 / n as f64, &[]))
    };
    let independent = out(ColourMode::RgbIndependent);
    let shared = out(ColourMode::RgbShared);
    let pca = out(ColourMode::Pca);
    for (i, j) in [(0, 1), (0, 2), (1, 2)] {
        assert!(correlation(&independent, i, j).abs() < 0.1, "independent {i}{j}: {}", correlation(&independent, i, j));
    }
    assert!(correlation(&shared, 0, 1) > 0.98, "shared: {}", correlation(&shared, 0, 1));
    let frob = |a: &[[f64; 3]; 3]| a.iter().flatten().map(|v| v * v).sum::<f64>().sqrt();
    let diff: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| pca[i][j] - want[i][j]));
    let rel = frob(&diff) / frob(&want);
    eprintln!("pca covariance error {rel:.4}");
    assert!(rel < 0.10, "pca covariance off by {rel}");
}

/// A skewed sample (lognormal, σ ≈ 0.5: skewness ≈ 1.7), for the histogram curve.
fn skewed_sample(n: usize) -> Image {
    let g = render_at(&known(&[0.2, 0.4, 0.6, 0.6, 0.5, 0.4, 0.3], n, 0.0), 21, n, 1.0 / n as f64, &[]);
    Image::from_fn(n, n, 3, |x, y, c| (0.1 + 0.15 * (0.8 * g.get(x, y, 0)).exp()) * [1.0, 0.8, 0.6][c])
}

#[test]
fn the_parameter_file_holds_66_numbers_and_reads_back_exactly() {
    // Items 16 and 27.
    let n = 512;
    let sample = skewed_sample(n);
    let opts = FitOptions { histogram: HistogramMode::On, ..FitOptions::default() };
    let p = fit(&sample, &opts).unwrap().params;
    assert_eq!(p.count(), 66);
    let text = p.to_toml();
    assert!(text.len() < 2048, "{} bytes", text.len());
    let back = Procedural::from_toml(&text).unwrap();
    assert_eq!(back, p, "the file reads back bit for bit");
    assert_eq!(back.to_toml(), text);
    // The same sample and options: the same bytes.
    assert_eq!(fit(&sample, &opts).unwrap().params.to_toml(), text);
    let off = fit(&sample, &FitOptions { histogram: HistogramMode::Off, ..FitOptions::default() }).unwrap().params;
    assert_eq!(off.count(), 36);
    eprintln!("parameter file: {} bytes\n{text}", text.len());
}

#[test]
fn a_hand_edited_file_is_checked() {
    let p = known(&[1.0; 7], 256, 0.5).to_toml();
    for (from, to, what) in [
        ("sample_size = 256", "sample_size = 300", "power of two"),
        ("tile = 256", "tile = 7", "even"),
        ("weights = [1.0, 1.0", "weights = [-1.0, 1.0", "weights"),
        ("weights = [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]", "weights = [1.0]", "weights"),
        ("noise_version = 1", "noise_version = 99", "noise_version"),
        ("colour = \"rgb_independent\"", "colour = \"cmyk\"", "colour"),
    ] {
        assert!(p.contains(from), "{from} in\n{p}");
        let e = Procedural::from_toml(&p.replacen(from, to, 1)).unwrap_err().to_string();
        assert!(e.contains(what), "{what}: {e}");
    }
}

#[test]
fn a_window_alone_is_the_same_window_of_a_larger_render_on_any_thread_count() {
    // Item 17.
    let p =
        fit(&skewed_sample(128), &FitOptions { histogram: HistogramMode::On, ..FitOptions::default() }).unwrap().params;
    let noise = Noise::new(4, p.tile, 6, p.colour, false).unwrap();
    let look = Look::new(&p, &[]);
    let pixel = 1.0 / 128.0;
    let big = eval::render(&noise, 512, 512, Domain::Plane { origin: [0.0; 2], pixel }, |_, _| &look).unwrap();
    let (x0, y0) = (200, 72);
    let origin = [x0 as f64 * pixel, y0 as f64 * pixel];
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| eval::render(&noise, 64, 64, Domain::Plane { origin, pixel }, |_, _| &look).unwrap())
    };
    let (one, two) = (run(1), run(2));
    assert_eq!(one, two);
    for c in 0..3 {
        for y in 0..64 {
            for x in 0..64 {
                assert_eq!(one.get(x, y, c).to_bits(), big.get(x0 + x, y0 + y, c).to_bits(), "({x}, {y}, {c})");
            }
        }
    }
    // A window too narrow to collapse rows goes point by point, and a point evaluated alone is
    // the pixel too: the same numbers by every path.
    let narrow = eval::render(&noise, 3, 64, Domain::Plane { origin, pixel }, |_, _| &look).unwrap();
    for y in 0..64 {
        for x in 0..3 {
            let at = [origin[0] + (x as f64 + 0.5) * pixel, origin[1] + (y as f64 + 0.5) * pixel];
            let alone = noise.eval(&look, at, pixel);
            for (c, alone) in alone.into_iter().enumerate() {
                assert_eq!(narrow.get(x, y, c).to_bits(), one.get(x, y, c).to_bits(), "narrow ({x}, {y}, {c})");
                assert_eq!((alone as f32).to_bits(), one.get(x, y, c).to_bits(), "alone ({x}, {y}, {c})");
            }
        }
    }
}

#[test]
fn a_render_at_the_sample_resolution_matches_its_band_powers() {
    // Item 18: b ≥ 5 within 1 dB (flat-ish spectrum); a 2× render box-downsampled matches the
    // 1× render within 0.5 dB.
    let n = 256;
    let sample = render_at(&known(&[0.8, 0.9, 1.0, 1.0, 0.9, 0.9, 0.8], n, 0.5), 31, n, 1.0 / n as f64, &[]);
    let p = fit(&sample, &grey_opts()).unwrap().params;
    let out = render_at(&p, 5, n, 1.0 / n as f64, &[]);
    let (a, b) = (powers(&sample, 0), powers(&out, 0));
    for k in 3..7 {
        let d = db(b.powers[k], a.powers[k]);
        assert!(d.abs() <= 1.0, "band {}: {d:.2} dB", k + 2);
    }
    let twice = render_at(&p, 5, 2 * n, 0.5 / n as f64, &[]);
    let down = Image::from_fn(n, n, 3, |x, y, c| {
        (twice.get(2 * x, 2 * y, c)
            + twice.get(2 * x + 1, 2 * y, c)
            + twice.get(2 * x, 2 * y + 1, c)
            + twice.get(2 * x + 1, 2 * y + 1, c))
            / 4.0
    });
    let d = powers(&down, 0);
    for k in 3..6 {
        let e = db(d.powers[k], b.powers[k]);
        assert!(e.abs() <= 0.5, "2× band {}: {e:.2} dB", k + 2);
    }
}

#[test]
fn clamping_keeps_power_out_of_frequencies_the_grid_cannot_show() {
    // Item 19: a render at footprint 4/N against a 4× supersampled render ideally low-passed
    // and decimated: band powers within 1 dB; footprints beyond every band give the mean.
    let n = 256;
    let p = known(&[0.6, 0.7, 0.8, 0.9, 1.0, 1.0, 1.0], n, 0.5);
    let coarse = render_at(&p, 2, 64, 4.0 / n as f64, &[]);
    let fine = render_at(&p, 2, 256, 1.0 / n as f64, &[]);
    // Ideal low-pass: keep |f| < 32 of the fine image's spectrum, decimate by 4.
    let spec = crate::synth::fft::fft_real(&plane(&fine, 0), 256, 256);
    let mut kept = vec![rustfft::num_complex::Complex64::new(0.0, 0.0); 64 * 64];
    for ky in 0..256usize {
        for kx in 0..256usize {
            let (fx, fy) = (
                if kx < 128 { kx as i64 } else { kx as i64 - 256 },
                if ky < 128 { ky as i64 } else { ky as i64 - 256 },
            );
            if fx.abs() < 32 && fy.abs() < 32 {
                let (x, y) = (fx.rem_euclid(64) as usize, fy.rem_euclid(64) as usize);
                kept[y * 64 + x] = spec[ky * 256 + kx] / 16.0;
            }
        }
    }
    let mut planner = rustfft::FftPlanner::<f64>::new();
    let inv = planner.plan_fft_inverse(64);
    for row in kept.chunks_mut(64) {
        inv.process(row);
    }
    let mut cols = vec![rustfft::num_complex::Complex64::new(0.0, 0.0); 64];
    for x in 0..64 {
        for y in 0..64 {
            cols[y] = kept[y * 64 + x];
        }
        inv.process(&mut cols);
        for y in 0..64 {
            kept[y * 64 + x] = cols[y];
        }
    }
    let reference: Vec<f64> = kept.iter().map(|c| c.re / (64.0 * 64.0)).collect();
    let (a, b) = (band_powers(&reference, 64).unwrap(), powers(&coarse, 0));
    for k in 2..5 {
        let d = db(b.powers[k], a.powers[k]);
        assert!(d.abs() <= 1.0, "band {}: {d:.2} dB", k + 2);
    }
    let far = render_at(&p, 2, 8, 4096.0 / n as f64, &[]);
    assert!(far.data.iter().all(|&v| (v - 0.5).abs() < 1e-6), "beyond every band the texture is its mean");
}

#[test]
fn minification_keeps_the_mean_colour_with_a_histogram_curve() {
    // Item 20 (proposal 14): the mean at footprint 64/N equals the mean at 1/N within 1 % of
    // the range, histogram matching on.
    let n = 256;
    let sample = skewed_sample(n);
    let p = fit(&sample, &FitOptions { histogram: HistogramMode::On, ..FitOptions::default() }).unwrap().params;
    let near = render_at(&p, 6, 512, 1.0 / n as f64, &[]);
    let far = render_at(&p, 6, 64, 64.0 / n as f64, &[]);
    for c in 0..3 {
        let mean = |img: &Image| img.plane(c).iter().map(|&v| f64::from(v)).sum::<f64>() / img.plane_len() as f64;
        let (lo, hi) = sample.plane(c).iter().fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        let range = f64::from(hi - lo);
        let d = (mean(&near) - mean(&far)).abs() / range;
        assert!(d < 0.01, "channel {c}: {d:.4} of the range");
    }
}

#[test]
fn the_mean_is_stored_exactly_and_reproduced_over_a_large_render() {
    // Item 10: the output mean over a large render (32 × 32 sample widths) is within 0.5 % of
    // the range of the sample mean.
    let n = 256;
    let sample = skewed_sample(n);
    let p = fit(
        &sample,
        &FitOptions { colour: ColourMode::RgbIndependent, histogram: HistogramMode::On, ..FitOptions::default() },
    )
    .unwrap()
    .params;
    let wide = render_at(&p, 6, 1024, 8.0 / n as f64, &[]);
    for c in 0..3 {
        let mean = |img: &Image| img.plane(c).iter().map(|&v| f64::from(v)).sum::<f64>() / img.plane_len() as f64;
        let (lo, hi) = sample.plane(c).iter().fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        let range = f64::from(hi - lo);
        let s = mean(&sample);
        assert!((p.mean[c] - s).abs() < 1e-12 * s.abs().max(1.0), "stored mean {} vs {s}", p.mean[c]);
        let d = (mean(&wide) - s).abs() / range;
        eprintln!("channel {c}: output mean off by {d:.5} of the range");
        assert!(d < 0.005, "channel {c}: mean {} vs {s}", mean(&wide));
    }
}

#[test]
fn a_solid_slice_looks_like_the_plane() {
    // Item 21: marginal KS < 0.03 and band powers (b ≥ 5) within 2 dB of the 2-D output.
    let n = 256;
    let p = known(&[0.5, 0.6, 0.7, 0.8, 0.8, 0.8, 0.8], n, 0.5);
    let noise = Noise::new(8, 256, 7, p.colour, true).unwrap();
    let look = Look::new(&p, &[]);
    let pixel = 1.0 / n as f64;
    let flat = eval::render(&noise, n, n, Domain::Plane { origin: [0.0; 2], pixel }, |_, _| &look).unwrap();
    let slice = eval::render(
        &noise,
        n,
        n,
        Domain::Slice { origin: [0.0, 0.0, 0.37], u: [0.6, 0.8, 0.0], v: [0.0, 0.0, 1.0], pixel },
        |_, _| &look,
    )
    .unwrap();
    let ks = ks_two_sample(&plane(&flat, 0), &plane(&slice, 0));
    assert!(ks < 0.03, "KS {ks}");
    let (a, b) = (powers(&flat, 0), powers(&slice, 0));
    for k in 3..7 {
        let d = db(b.powers[k], a.powers[k]);
        assert!(d.abs() <= 2.0, "band {}: {d:.2} dB", k + 2);
    }
}

#[test]
fn a_band_gain_scales_that_bands_power() {
    // Item 22: gain k on band 6 multiplies what band 6 puts in its annulus by k², so the
    // annulus's power becomes Σ_j K[6][j] g_j² w_j² over Σ_j K[6][j] w_j² (K the simulated
    // leakage matrix), within 3σ of the periodogram (§3.3); the other annuli change by no
    // more than the leakage of band 6 into them allows.
    let n = 256;
    let p = known(&[0.5; 7], n, 0.5);
    let base = powers(&render_at(&p, 12, n, 1.0 / n as f64, &[]), 0);
    let gains = [1.0, 1.0, 1.0, 1.0, 2.0, 1.0, 1.0];
    let edited = powers(&render_at(&p, 12, n, 1.0 / n as f64, &gains), 0);
    let tile = eval::noise_tile(2, 256, 5).unwrap();
    let k = super::params::leakage(&tile, n, 5).unwrap();
    let expected = |row: usize| {
        let with: f64 = (0..7).map(|j| k[row][j] * gains[j] * gains[j]).sum();
        let without: f64 = (0..7).map(|j| k[row][j]).sum();
        with / without
    };
    for row in 0..7 {
        let ratio = edited.powers[row] / base.powers[row];
        let sd = (2.0 / base.counts[row] as f64).sqrt();
        let want = expected(row);
        eprintln!("band {}: power ×{ratio:.4}, leakage predicts ×{want:.4}", row + 2);
        if row >= 3 {
            assert!((ratio / want - 1.0).abs() < 3.0 * sd.max(0.01), "band {}: ×{ratio} vs ×{want}", row + 2);
        }
    }
}

#[test]
fn a_morph_starts_and_ends_at_its_textures() {
    // Item 23: ends bit-exact; U(t) a rotation; band powers monotone from flat to steep.
    let n = 128;
    let a = fit(&correlated_sample(n), &FitOptions { histogram: HistogramMode::On, ..FitOptions::default() })
        .unwrap()
        .params;
    let b =
        fit(&skewed_sample(n), &FitOptions { histogram: HistogramMode::On, ..FitOptions::default() }).unwrap().params;
    assert_eq!(a.morph(&b, 0.0).unwrap(), a);
    let end = a.morph(&b, 1.0).unwrap();
    assert_eq!(end.channels.iter().map(|c| c.weights.len()).sum::<usize>(), 18);
    for k in 0..=20 {
        let u = a.morph(&b, f64::from(k) / 20.0).unwrap().u;
        for i in 0..3 {
            for j in 0..3 {
                let d: f64 = (0..3).map(|r| u[i][r] * u[j][r]).sum();
                assert!((d - f64::from(u8::from(i == j))).abs() < 1e-9);
            }
        }
    }
    let flat = known(&[1.0; 7], 256, 0.5);
    let steep = known(&[1.0, 0.7, 0.5, 0.35, 0.25, 0.18, 0.12], 256, 0.5);
    let mut last = f64::INFINITY;
    for k in 0..=4 {
        let m = flat.morph(&steep, f64::from(k) / 4.0).unwrap();
        let top = powers(&render_at(&m, 3, 256, 1.0 / 256.0, &[]), 0).powers[6];
        assert!(top < last, "top band power must fall: {top} after {last}");
        last = top;
    }
    assert_eq!(flat.morph(&steep, 1.0).unwrap(), steep);
}

#[test]
fn a_morph_between_different_sample_sizes_and_knot_counts_pads_and_resamples() {
    // Issue 16, bad input: the paper morphs textures of one size. A 128² fit (bands 2..7, 17
    // knots) into a 64² one (bands 2..6, 5 knots): the smaller has no finest band, as it renders.
    let histogram = |knots| FitOptions { histogram: HistogramMode::On, knots, ..FitOptions::default() };
    let a = fit(&correlated_sample(128), &histogram(17)).unwrap().params;
    let b = fit(&skewed_sample(64), &histogram(5)).unwrap().params;
    assert_eq!((a.channels[0].weights.len(), b.channels[0].weights.len()), (6, 5));
    assert_eq!(a.morph(&b, 0.0).unwrap(), a);
    let end = a.morph(&b, 1.0).unwrap();
    assert_eq!((end.sample_size, end.channels[0].weights.len()), (64, 5));
    let half = a.morph(&b, 0.5).unwrap();
    assert_eq!(half.sample_size, 128);
    for (c, ch) in half.channels.iter().enumerate() {
        assert_eq!(ch.weights.len(), 6);
        assert_eq!(ch.weights[5], a.channels[c].weights[5] * 0.5, "band 7 halfway to none");
        assert_eq!(ch.curve.as_ref().unwrap().knots.len(), 17);
    }
    // The other way round: the in-between sets take the larger sample's size and bands.
    let back = b.morph(&a, 0.25).unwrap();
    assert_eq!((back.sample_size, back.channels[0].weights.len()), (128, 6));
    // The end set rendered with the larger noise (6 bands) is the 5-band texture, bit for bit:
    // the extra band adds nothing.
    let (n6, n5) = (
        Noise::new(3, end.tile, 6, end.colour, false).unwrap(),
        Noise::new(3, end.tile, 5, end.colour, false).unwrap(),
    );
    let look = Look::new(&end, &[]);
    let domain = Domain::Plane { origin: [0.0; 2], pixel: 1.0 / 128.0 };
    let six = eval::render(&n6, 128, 128, domain, |_, _| &look).unwrap();
    let five = eval::render(&n5, 128, 128, domain, |_, _| &look).unwrap();
    assert_eq!(
        six.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        five.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    );
    // Resampling keeps the curve: at its own knot count it is itself, at 2K − 1 knots its old
    // knots are every other one.
    let curve = a.channels[0].curve.clone().unwrap();
    assert_eq!(curve.resampled(17), curve);
    let fine = curve.resampled(33);
    for (j, &k) in curve.knots.iter().enumerate() {
        assert!((fine.knots[2 * j] - k).abs() <= 1e-12 * (1.0 + k.abs()), "knot {j}: {} vs {k}", fine.knots[2 * j]);
    }
    assert!(fine.knots.windows(2).all(|w| w[0] <= w[1]));
    // Curves on different abscissae stay an error (there is no knot-by-knot correspondence).
    let quantile =
        fit(&skewed_sample(64), &FitOptions { abscissa: Abscissa::Quantile, ..histogram(5) }).unwrap().params;
    assert!(a.morph(&quantile, 0.5).is_err());
}

#[test]
fn samples_are_cropped_to_a_power_of_two_and_tiny_ones_refused() {
    // Item 25.
    let sample = skewed_sample(128);
    let odd = Image::from_fn(100, 70, 3, |x, y, c| sample.get(x, y, c));
    let f = fit(&odd, &FitOptions::default()).unwrap();
    assert_eq!(f.cropped_from, Some((100, 70)));
    assert_eq!(f.params.sample_size, 64);
    let tiny = Image::filled(15, 40, 3, 0.5);
    assert!(fit(&tiny, &FitOptions::default()).is_err());
    let nan = Image::from_fn(32, 32, 3, |x, _, _| if x == 3 { f32::NAN } else { 0.5 });
    assert!(fit(&nan, &FitOptions::default()).is_err());
    // A grey, flat sample fits (nothing to match) without failing.
    let flat = fit(&Image::filled(32, 32, 1, 0.5), &FitOptions::default()).unwrap().params;
    assert!(flat.channels.iter().all(|c| c.weights.iter().all(|&w| w == 0.0)));
}

#[test]
fn gaussian_abscissa_curves_fit_more_closely() {
    let n = 128;
    let sample = skewed_sample(n);
    let ks = |abscissa| {
        let opts = FitOptions { histogram: HistogramMode::On, abscissa, ..FitOptions::default() };
        let p = fit(&sample, &opts).unwrap().params;
        let out = render_at(&p, 2, 256, 1.0 / n as f64, &[]);
        ks_two_sample(&plane(&sample, 0), &plane(&out, 0))
    };
    let (q, g) = (ks(Abscissa::Quantile), ks(Abscissa::Gaussian));
    eprintln!("output marginal KS: quantile knots {q:.4}, gaussian knots {g:.4}");
    assert!(g < q && g < 0.05, "quantile {q}, gaussian {g}");
}

#[test]
fn the_curve_table_stays_within_a_sixteen_bit_step_of_the_exact_map() {
    // A render maps through `CurveLut`; its linear interpolation must not be visible in a 16-bit
    // output: within 2⁻¹⁶ of the curve's range of the exact map, for both abscissae, sharp
    // and smoothed, over the whole range the table covers (and exact beyond it).
    use super::marginal::{CurveTable, LUT_POINTS, LUT_RANGE};
    // Skewed, with the channels shifted apart so each principal channel has a real histogram.
    let n = 256;
    let skewed = skewed_sample(n);
    let sample = Image::from_fn(n, n, 3, |x, y, c| skewed.get((x + 37 * c) % n, (y + 11 * c) % n, c));
    for abscissa in [Abscissa::Quantile, Abscissa::Gaussian] {
        for knots in [17, 64, 256] {
            let opts = FitOptions { histogram: HistogramMode::On, abscissa, knots, ..FitOptions::default() };
            let p = fit(&sample, &opts).unwrap().params;
            // What an output sees: errors against the widest channel's range.
            let range = p
                .channels
                .iter()
                .map(|ch| ch.curve.as_ref().map_or(0.0, |c| c.knots.last().unwrap() - c.knots[0]))
                .fold(0.0, f64::max);
            for ch in &p.channels {
                let curve = ch.curve.as_ref().unwrap();
                let table: CurveTable = curve.table();
                let sigma_m = (super::SIGMA_N2 * ch.weights.iter().map(|w| w * w).sum::<f64>()).sqrt();
                for sigma_d in [0.0, 0.05 * sigma_m, 0.5 * sigma_m] {
                    // A Gaussian-abscissa curve smoothed wider than its knots needs no table.
                    let Some(lut) = curve.lut(sigma_m, sigma_d) else {
                        assert_eq!(abscissa, Abscissa::Gaussian);
                        continue;
                    };
                    let mut worst: f64 = 0.0;
                    for i in 0..=20_000 {
                        let g = (i as f64 / 10_000.0 - 1.0) * (LUT_RANGE + 1.0) * sigma_m;
                        let exact = curve.map_smoothed_with(g, sigma_m, sigma_d, &table);
                        let got = lut.map(curve, &table, g);
                        if i % 97 == 0 {
                            // Kept points, points worked out at each read, points read again.
                            let unkept = curve.lut_unkept(sigma_m, sigma_d).unwrap();
                            assert_eq!(unkept.map(curve, &table, g).to_bits(), got.to_bits(), "unkept at {g}");
                            assert_eq!(lut.map(curve, &table, g).to_bits(), got.to_bits(), "read again at {g}");
                        }
                        if g.abs() > LUT_RANGE * sigma_m && abscissa == Abscissa::Quantile {
                            assert_eq!(got.to_bits(), exact.to_bits(), "beyond the table at {g}");
                        }
                        worst = worst.max((got - exact).abs() / range);
                    }
                    assert!(lut.kept() > LUT_POINTS / 2, "{} points kept", lut.kept());
                    eprintln!(
                        "{abscissa:?} K={knots} σd/σM={:.2}: worst {worst:.2e} of the range {range:.3e}",
                        sigma_d / sigma_m
                    );
                    assert!(worst < 1.0 / 65536.0, "{abscissa:?} K={knots}: {worst:.2e}");
                }
            }
        }
    }
}

#[test]
fn extrapolated_bands_continue_the_top_bands_line() {
    // Item 6: log₂ w_b on a line over the top bands continues on it; no line (fewer than two
    // weighted bands) adds zeros; a rising line is capped at the file's bound.
    let mut w: Vec<f64> = (2..8).map(|b| (-0.5 * b as f64).exp2()).collect();
    super::params::extrapolate(&mut w, 2);
    assert_eq!(w.len(), 8);
    for (k, &v) in w.iter().enumerate().skip(6) {
        let want = (-0.5 * (k + 2) as f64).exp2();
        assert!((v / want - 1.0).abs() < 1e-12, "band {}: {v} against {want}", k + 2);
    }
    let mut lone = vec![0.0, 0.0, 0.0, 0.5];
    super::params::extrapolate(&mut lone, 3);
    assert_eq!(lone, [0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0]);
    let mut rising: Vec<f64> = (0..6).map(|b| 1e5 * (4.0f64).powi(b)).collect();
    super::params::extrapolate(&mut rising, 1);
    assert_eq!(rising[6], 1e6);
}

#[test]
fn extrapolated_bands_add_detail_to_a_magnified_render() {
    // A 128² sample of a spectrum falling half an octave of weight per band, fitted with and
    // without two extrapolated bands, rendered 4× magnified: the added bands (finer than the
    // sample's pixels) put back power in the render's finest octaves, which the fit alone leaves
    // blurred; at the sample's own resolution they are clamped away and change nothing visible.
    let n = 128;
    let truth = known(&(2..10).map(|b| (-0.4 * b as f64).exp2()).collect::<Vec<_>>(), 4 * n, 0.5);
    let sample = render_at(&truth, 5, n, 1.0 / n as f64, &[]);
    let plain = fit(&sample, &grey_opts()).unwrap().params;
    let extra = fit(&sample, &FitOptions { extrapolate: 2, ..grey_opts() }).unwrap().params;
    assert_eq!(extra.channels[0].weights.len(), plain.channels[0].weights.len() + 2);
    assert_eq!(extra.channels[0].weights[..6], plain.channels[0].weights[..]);
    // Read back from its file, with the bands after the fitted ones.
    assert_eq!(Procedural::from_toml(&extra.to_toml()).unwrap(), extra);
    let zoom = 4.0;
    let pixel = 1.0 / (n as f64 * zoom);
    let (a, b) = (render_at(&plain, 9, 256, pixel, &[]), render_at(&extra, 9, 256, pixel, &[]));
    let (pa, pb) = (powers(&a, 0), powers(&b, 0));
    let pt = powers(&render_at(&truth, 9, 256, pixel, &[]), 0);
    // Render bands 7 and 8 (256² at 4 pixels per sample pixel) are sample bands 9 and 10: only the
    // extrapolated weights reach them.
    for band in [7, 8] {
        let (x, y) = (pa.powers[band - 2], pb.powers[band - 2]);
        let t = pt.powers[band - 2];
        eprintln!(
            "magnified 4×, render band {band}: {:.1} dB more with extrapolation; {:.1} dB from the truth (without: {:.1} dB)",
            db(y, x),
            db(y, t),
            db(x, t)
        );
        assert!(db(y, x) > 3.0, "band {band}: {x} without, {y} with");
        assert!(db(y, t).abs() < 3.0, "band {band}: {y} with extrapolation, {t} in the truth");
    }
    let at_sample = |p: &Procedural| render_at(p, 9, n, 1.0 / n as f64, &[]);
    let (c, d) = (at_sample(&plain), at_sample(&extra));
    let off = c.data.iter().zip(&d.data).map(|(x, y)| (x - y).abs()).fold(0f32, f32::max);
    assert!(off < 1e-3, "at the sample's resolution the extra bands change a pixel by {off}");
}

#[test]
fn a_file_with_too_many_bands_is_refused() {
    let mut p = known(&[0.5; 6], 128, 0.5);
    for c in &mut p.channels {
        c.weights.extend([0.1; super::params::MAX_EXTRAPOLATED]);
    }
    assert!(Procedural::from_toml(&p.to_toml()).is_ok());
    p.channels[1].weights.push(0.1);
    assert!(Procedural::from_toml(&p.to_toml()).is_err(), "channels of different band counts");
    for c in &mut p.channels[..] {
        c.weights.truncate(6 + super::params::MAX_EXTRAPOLATED);
        c.weights.push(0.1);
    }
    assert!(Procedural::from_toml(&p.to_toml()).unwrap_err().to_string().contains("extrapolated"));
}

#[test]
fn a_corrected_slice_keeps_the_planes_band_powers() {
    // Item 21 with `correct_slice`: slice band powers (b ≥ 5) within 1 dB of the 2-D output, on
    // flat, rising, steeply rising and falling spectra; without the correction the rising ones
    // are more than 1 dB off (a slice's finest band is weak, and strong bands leak down).
    let n = 256;
    let pixel = 1.0 / n as f64;
    let origin = [0.0, 0.0, 0.37];
    for (weights, off_without) in [
        (vec![0.5, 0.6, 0.7, 0.8, 0.8, 0.8, 0.8], true),
        (vec![0.2, 0.3, 0.45, 0.7, 1.0, 1.5, 2.2], true),
        (vec![0.1, 0.2, 0.4, 0.8, 1.6, 3.2, 6.4], true),
        (vec![1.6, 1.2, 0.9, 0.6, 0.35, 0.2, 0.1], false),
    ] {
        let p = known(&weights, n, 0.5);
        let noise = Noise::new(8, 256, 7, p.colour, true).unwrap();
        let look = Look::new(&p, &[]);
        let flat =
            powers(&eval::render(&noise, n, n, Domain::Plane { origin: [0.0; 2], pixel }, |_, _| &look).unwrap(), 0);
        let slice_of = |p: &Procedural| {
            let look = Look::new(p, &[]);
            let domain = Domain::Slice { origin, u: [1.0, 0.0, 0.0], v: [0.0, 1.0, 0.0], pixel };
            powers(&eval::render(&noise, n, n, domain, |_, _| &look).unwrap(), 0)
        };
        let correction = super::slice::SliceCorrection::new(&noise, 7, origin, 3).unwrap();
        let corrected = correction.corrected(&p, &[]).unwrap();
        let off = |s: &BandPowers| (3..7).map(|k| db(s.powers[k], flat.powers[k]).abs()).fold(0.0, f64::max);
        let (without, with) = (off(&slice_of(&p)), off(&slice_of(&corrected)));
        eprintln!("weights {weights:?}: slice off by up to {without:.2} dB, {with:.2} dB corrected");
        assert!(with <= 1.0, "corrected slice {with:.2} dB off");
        assert_eq!(without > 1.0, off_without, "{without:.2} dB without the correction");
    }
}

#[test]
fn a_masked_fit_sees_only_its_region() {
    // Two textures side by side, as two region classes of one sample (§9.3).
    let (a, b) = (correlated_sample(64), skewed_sample(64));
    let both = Image::from_fn(128, 64, 3, |x, y, c| if x < 64 { a.get(x, y, c) } else { b.get(x - 64, y, c) });
    let opts = FitOptions { histogram: HistogramMode::On, ..FitOptions::default() };
    let half = |left: bool| -> Vec<bool> { (0..128 * 64).map(|i| (i % 128 < 64) == left).collect() };
    // A half mask holds exactly one texture's pixels, in their order, and its 64² square: the fit
    // is that texture's own, number for number.
    let left = fit_masked(&both, Some(&half(true)), &opts).unwrap();
    let right = fit_masked(&both, Some(&half(false)), &opts).unwrap();
    assert_eq!(left.params, fit(&a, &opts).unwrap().params);
    assert_eq!(right.params, fit(&b, &opts).unwrap().params);
    assert_eq!(left.cropped_from, None);
    // Unmasked, the centred square straddles both and its mean is neither texture's.
    let mixed = fit(&both, &opts).unwrap().params.mean;
    let gap = |m: [f64; 3], n: [f64; 3]| (0..3).map(|c| (m[c] - n[c]).abs()).fold(0.0, f64::max);
    assert!(gap(mixed, left.params.mean) > 0.05 && gap(mixed, right.params.mean) > 0.05, "{mixed:?}");

    // A disc: the colour from every pixel in it, the spectrum from the 32² square inside it.
    let disc: Vec<bool> =
        (0..128 * 64).map(|i| ((i % 128) as f64 - 31.5).hypot((i / 128) as f64 - 31.5) < 28.0).collect();
    let fitted = fit_masked(&both, Some(&disc), &opts).unwrap();
    assert_eq!(fitted.params.sample_size, 32);
    assert_eq!(fitted.params.channels[0].weights.len(), 4);
    let inside: Vec<usize> = (0..128 * 64).filter(|&i| disc[i]).collect();
    for c in 0..3 {
        let mean = inside.iter().map(|&i| f64::from(both.get(i % 128, i / 128, c))).sum::<f64>() / inside.len() as f64;
        assert!((fitted.params.mean[c] - mean).abs() < 1e-12, "channel {c}: {} vs {mean}", fitted.params.mean[c]);
    }

    // Too little masked, or a mask of the wrong size: errors, not panics.
    let thin: Vec<bool> = (0..128 * 64).map(|i| i / 128 < 15).collect();
    assert!(fit_masked(&both, Some(&thin), &opts).unwrap_err().to_string().contains("16 x 16"));
    assert!(fit_masked(&both, Some(&[true; 10]), &opts).is_err());
}

#[test]
fn a_masked_periodogram_measures_thin_classes() {
    use super::params::MaskSpectrum;
    // A known texture, and a mask of thin "joints": 6-pixel lines every 32 pixels, no 16² square.
    let n = 128;
    let img = render_at(&known(&[0.2, 0.4, 0.6, 0.6, 0.5, 0.4], n, 0.5), 31, n, 1.0 / n as f64, &[]);
    let joints: Vec<bool> = (0..n * n).map(|i| (i % n) % 32 < 6 || (i / n) % 32 < 6).collect();
    let opts = FitOptions { mask_spectrum: MaskSpectrum::Masked, ..grey_opts() };
    let square = FitOptions { mask_spectrum: MaskSpectrum::Square, ..grey_opts() };
    assert!(fit_masked(&img, Some(&joints), &square).unwrap_err().to_string().contains("mask_spectrum = masked"));
    let whole = fit(&img, &grey_opts()).unwrap();
    let thin = fit_masked(&img, Some(&joints), &opts).unwrap();
    let off: Vec<f64> =
        (0..whole.powers[0].powers.len()).map(|b| db(thin.powers[0].powers[b], whole.powers[0].powers[b])).collect();
    // Measured: −5.7, −1.1, −1.1, +0.7, +0.9, +1.3 dB for bands 2–7. The mean fill takes the
    // coarsest band's power where the class is thin; the finer bands stay within 1.5 dB.
    assert!(off[1..].iter().all(|d| d.abs() < 1.5), "{off:?}");
    assert!(off[0] < 0.0 && off[0] > -8.0, "{off:?}");
    // A mask of every pixel is the unmasked fit, number for number.
    let all = vec![true; n * n];
    let same = fit_masked(&img, Some(&all), &opts).unwrap();
    assert_eq!(same.params, whole.params);
}
