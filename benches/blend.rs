//! Gradient-domain blending at 1024² RGB: the masked MGPCG solve on a centred disc covering
//! half the image (target: median under 150 ms on 2 cores, every channel converged to a
//! relative residual ≤ 1e-6), and the whole-torus exact FFT solve for reference.

use criterion::{criterion_group, criterion_main, Criterion};
use tessera::raster::Image;
use tessera::synth::blend::{blend_two, BlendParams, Domain};
use tessera::synth::rng::Rng;

const SIZE: usize = 1024;

/// Periodic box blur of one plane, radius `r`, along rows then columns (running sums).
fn box_blur(p: &mut [f32], w: usize, h: usize, r: usize) {
    let norm = 1.0 / (2 * r + 1) as f32;
    let mut line = vec![0.0f32; w.max(h)];
    for y in 0..h {
        let row = &mut p[y * w..(y + 1) * w];
        line[..w].copy_from_slice(row);
        let mut s: f32 = (0..=2 * r).map(|d| line[(d + w - r) % w]).sum();
        for x in 0..w {
            row[x] = s * norm;
            s += line[(x + r + 1) % w] - line[(x + w - r) % w];
        }
    }
    for x in 0..w {
        for y in 0..h {
            line[y] = p[y * w + x];
        }
        let mut s: f32 = (0..=2 * r).map(|d| line[(d + h - r) % h]).sum();
        for y in 0..h {
            p[y * w + x] = s * norm;
            s += line[(y + r + 1) % h] - line[(y + h - r) % h];
        }
    }
}

/// Tileable smooth noise on the 0..255 scale: white noise blurred at two scales.
fn smooth_noise(seed: u64) -> Image {
    let mut rng = Rng::new(seed);
    let mut img = Image::new(SIZE, SIZE, 3);
    for c in 0..3 {
        let mut coarse: Vec<f32> = (0..SIZE * SIZE).map(|_| rng.next_f32()).collect();
        let mut fine: Vec<f32> = (0..SIZE * SIZE).map(|_| rng.next_f32()).collect();
        for _ in 0..3 {
            box_blur(&mut coarse, SIZE, SIZE, 24);
            box_blur(&mut fine, SIZE, SIZE, 2);
        }
        let stretch = |v: &[f32]| {
            let (lo, hi) = v.iter().fold((f32::MAX, f32::MIN), |(a, b), &x| (a.min(x), b.max(x)));
            v.iter().map(|&x| (x - lo) / (hi - lo)).collect::<Vec<f32>>()
        };
        let (coarse, fine) = (stretch(&coarse), stretch(&fine));
        for (o, (a, b)) in img.plane_mut(c).iter_mut().zip(coarse.iter().zip(&fine)) {
            *o = 30.0 + 170.0 * a + 50.0 * b + 10.0 * c as f32;
        }
    }
    img
}

/// Tileable diagonal stripes with a little grain, different per channel.
fn stripes(seed: u64) -> Image {
    let mut rng = Rng::new(seed);
    let grain: Vec<f32> = (0..3 * SIZE * SIZE).map(|_| rng.next_f32()).collect();
    Image::from_fn(SIZE, SIZE, 3, |x, y, c| {
        let t = std::f32::consts::TAU * (x as f32 * 12.0 + y as f32 * 5.0) / SIZE as f32;
        let band = 0.5 + 0.5 * (t + c as f32).sin();
        40.0 + 150.0 * band + 20.0 * grain[(c * SIZE + y) * SIZE + x] + 15.0 * c as f32
    })
}

/// A centred disc covering half the image.
fn half_disc() -> Image {
    let r = (0.5 * (SIZE * SIZE) as f64 / std::f64::consts::PI).sqrt();
    let c = SIZE as f64 / 2.0;
    Image::from_fn(SIZE, SIZE, 1, |x, y, _| {
        let (dx, dy) = (x as f64 + 0.5 - c, y as f64 + 0.5 - c);
        if dx * dx + dy * dy <= r * r {
            1.0
        } else {
            0.0
        }
    })
}

fn bench(c: &mut Criterion) {
    let a = smooth_noise(11);
    let b = stripes(12);
    let mask = half_disc();
    let params = BlendParams::default();
    let whole = BlendParams { domain: Domain::Whole, ..BlendParams::default() };

    let out = blend_two(&a, &b, &mask, &params).expect("blend");
    for r in &out.reports {
        println!(
            "blend_1024_rgb_disc_half: channel {} {:?} unknowns {} iterations {} residual {:.3e} max {:.3e}",
            r.channel, r.method, r.unknowns, r.iterations, r.residual, r.max_residual
        );
        assert!(r.converged && r.residual <= 1e-6, "channel {} did not converge: {r:?}", r.channel);
    }
    let out = blend_two(&a, &b, &mask, &whole).expect("blend");
    for r in &out.reports {
        println!("blend_1024_rgb_whole_torus_fft: channel {} {:?} residual {:.3e}", r.channel, r.method, r.residual);
    }

    let mut group = c.benchmark_group("blend");
    group.sample_size(10);
    group.bench_function("blend_1024_rgb_disc_half", |bn| bn.iter(|| blend_two(&a, &b, &mask, &params).unwrap()));
    group.bench_function("blend_1024_rgb_whole_torus_fft", |bn| bn.iter(|| blend_two(&a, &b, &mask, &whole).unwrap()));
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
