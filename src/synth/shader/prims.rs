//! The RenderMan-style building blocks the library's shaders are written with
//! [references: bourque §5.3]: seeded gradient noise and its sums (fBm, turbulence, ridges,
//! domain-distorted noise), smoothstep and mix, antialiased steps and pulse trains filtered
//! over a pixel's footprint, and the fixed plastic lighting of the thesis's renders.
//!
//! Noise is two-dimensional: the shaders are evaluated on the plane z = 0 of shader space
//! (the thesis's fixed setup), where three-dimensional noise would cost four times as much
//! for the same kind of pattern. Lattice gradients come from a hash of (seed, cell), so each
//! point is computed on its own, in any order, on any number of threads.

use std::f64::consts::FRAC_1_SQRT_2;

/// ⌊x⌋ for |x| < 2⁶³, inline: without SSE4.1 `f64::floor` is a call into libm, which cost a
/// third of a simple shader's time.
#[inline(always)]
pub fn floor(x: f64) -> f64 {
    let t = x as i64 as f64;
    if t > x {
        t - 1.0
    } else {
        t
    }
}

/// √(x² + y²). Not `f64::hypot`: libm's guards against overflow and underflow cost a tenth
/// of a matching run, and the shaders only measure distances of a few texture units.
#[inline(always)]
pub fn length(x: f64, y: f64) -> f64 {
    (x * x + y * y).sqrt()
}

/// x − ⌊x⌋.
#[inline(always)]
pub fn fract(x: f64) -> f64 {
    x - floor(x)
}

/// A 32-bit integer hash of a lattice cell and a seed (a multiply–xorshift finaliser).
#[inline]
pub fn hash(x: i64, y: i64, seed: u32) -> u32 {
    hash32(x as u32, y as u32, seed)
}

/// A uniform number in `[0, 1)` for a lattice cell.
#[inline]
pub fn cell_random(x: i64, y: i64, seed: u32) -> f64 {
    hash(x, y, seed) as f64 / 4_294_967_296.0
}

/// Sixteen unit gradients, 22.5° apart.
const GRADIENTS: [[f64; 2]; 16] = [
    [1.0, 0.0],
    [0.923_879_532_511_286_7, 0.382_683_432_365_089_8],
    [FRAC_1_SQRT_2, FRAC_1_SQRT_2],
    [0.382_683_432_365_089_8, 0.923_879_532_511_286_7],
    [0.0, 1.0],
    [-0.382_683_432_365_089_8, 0.923_879_532_511_286_7],
    [-FRAC_1_SQRT_2, FRAC_1_SQRT_2],
    [-0.923_879_532_511_286_7, 0.382_683_432_365_089_8],
    [-1.0, 0.0],
    [-0.923_879_532_511_286_7, -0.382_683_432_365_089_8],
    [-FRAC_1_SQRT_2, -FRAC_1_SQRT_2],
    [-0.382_683_432_365_089_8, -0.923_879_532_511_286_7],
    [0.0, -1.0],
    [0.382_683_432_365_089_8, -0.923_879_532_511_286_7],
    [FRAC_1_SQRT_2, -FRAC_1_SQRT_2],
    [0.923_879_532_511_286_7, -0.382_683_432_365_089_8],
];

/// Signed gradient noise (Perlin's, with a quintic fade) in about `[-1, 1]`, zero at lattice
/// points, mean zero: RenderMan's `snoise` on the plane.
#[inline]
pub fn snoise(x: f64, y: f64, seed: u32) -> f64 {
    let (fx, fy) = (floor(x), floor(y));
    gradient_noise(x, y, (fx, fx as i64 as u32), (fy, fy as i64 as u32), seed)
}

/// The noise at (x, y) given ⌊x⌋ and ⌊y⌋ with their low 32 bits (all the hash reads of a
/// cell): the one body of [`snoise`] and [`snoise_lanes`], which find the floors differently.
#[inline(always)]
fn gradient_noise(x: f64, y: f64, (fx, ix): (f64, u32), (fy, iy): (f64, u32), seed: u32) -> f64 {
    let (dx, dy) = (x - fx, y - fy);
    // The hash's first step, x·A ^ y·B, for the cell and its neighbours: (x+1)·A = x·A + A in
    // wrapping arithmetic, so four corners take two multiplies rather than eight.
    let (hx0, hy0) = (ix.wrapping_mul(HASH_X), iy.wrapping_mul(HASH_Y));
    let (hx1, hy1) = (hx0.wrapping_add(HASH_X), hy0.wrapping_add(HASH_Y));
    let dot = |hx: u32, hy: u32, ox: f64, oy: f64| {
        let g = GRADIENTS[(finish_hash(seed ^ hx ^ hy) >> 28) as usize];
        g[0] * ox + g[1] * oy
    };
    let n00 = dot(hx0, hy0, dx, dy);
    let n10 = dot(hx1, hy0, dx - 1.0, dy);
    let n01 = dot(hx0, hy1, dx, dy - 1.0);
    let n11 = dot(hx1, hy1, dx - 1.0, dy - 1.0);
    let (sx, sy) = (fade(dx), fade(dy));
    let a = n00 + sx * (n10 - n00);
    let b = n01 + sx * (n11 - n01);
    // 2-D gradient noise peaks at ±√2/2; scaled to span about [-1, 1].
    std::f64::consts::SQRT_2 * (a + sy * (b - a))
}

/// 1.5·2⁵²: added to an f64 below 2⁵¹ in magnitude, it rounds it to a whole number held in the
/// low mantissa bits, so ⌊x⌋ and its low 32 bits need no float-to-integer conversion (which
/// has no vector form before AVX-512).
const ROUND: f64 = 6_755_399_441_055_744.0;

/// Where [`floor_lane`] is exact: far past any render's reach (the region's corners lie within
/// ±10⁹, octaves multiply that by at most 2¹³).
const LANE_LIMIT: f64 = (1u64 << 50) as f64;

/// ⌊x⌋ and its low 32 bits (two's complement) for |x| < 2⁵⁰: what [`floor`] and `as u32` give.
#[inline(always)]
fn floor_lane(x: f64) -> (f64, u32) {
    let near = (x + ROUND) - ROUND;
    let base = if near > x { near - 1.0 } else { near };
    (base, (base + ROUND).to_bits() as u32)
}

/// [`snoise`] at `N` points: lane by lane the same operations, so the same bits, in loops the
/// compiler runs in vector registers. Points past 2⁵⁰ go to `snoise` one by one.
#[inline(always)]
pub fn snoise_lanes<const N: usize>(x: [f64; N], y: [f64; N], seed: u32) -> [f64; N] {
    if !x.iter().chain(&y).all(|v| v.abs() < LANE_LIMIT) {
        return std::array::from_fn(|l| snoise(x[l], y[l], seed));
    }
    // A plain loop: written with `array::from_fn`, the compiler keeps the lanes apart (cyclone
    // at 1024²: 102 ms rather than 57).
    let mut out = [0.0; N];
    for l in 0..N {
        out[l] = gradient_noise(x[l], y[l], floor_lane(x[l]), floor_lane(y[l]), seed);
    }
    out
}

/// Where [`sin_cos_lanes`] reduces its argument itself: k·π/2 is exact in [`PIO2_HI`] while
/// |k| < 2²⁶; past it, and for NaN and infinities, a lane goes to `f64::sin_cos`.
const SIN_COS_LIMIT: f64 = 1.0e7;

/// π/2 in three parts: the first with its 26 low mantissa bits clear, so k·`PIO2_HI` is exact
/// for |k| < 2²⁶ (Cody and Waite's reduction).
const PIO2_HI: f64 = f64::from_bits(std::f64::consts::FRAC_PI_2.to_bits() & !0x3ff_ffff);
const PIO2_MID: f64 = std::f64::consts::FRAC_PI_2 - PIO2_HI;
/// π/2 − `FRAC_PI_2`, the part of π/2 an f64 cannot hold.
const PIO2_LO: f64 = 6.123_233_995_736_766e-17;

/// sin r and cos r for |r| ≤ π/4 by their Taylor series to r¹⁷ and r¹⁸, whose next terms are
/// below 10⁻¹⁹ there, in Horner form (plain multiplies and adds: the same bits on any CPU).
#[inline(always)]
fn sin_cos_kernel(r: f64) -> (f64, f64) {
    const S: [f64; 8] = [
        -1.0 / 6.0,
        1.0 / 120.0,
        -1.0 / 5040.0,
        1.0 / 362_880.0,
        -1.0 / 39_916_800.0,
        1.0 / 6_227_020_800.0,
        -1.0 / 1_307_674_368_000.0,
        1.0 / 355_687_428_096_000.0,
    ];
    const C: [f64; 9] = [
        -1.0 / 2.0,
        1.0 / 24.0,
        -1.0 / 720.0,
        1.0 / 40_320.0,
        -1.0 / 3_628_800.0,
        1.0 / 479_001_600.0,
        -1.0 / 87_178_291_200.0,
        1.0 / 20_922_789_888_000.0,
        -1.0 / 6_402_373_705_728_000.0,
    ];
    let z = r * r;
    let mut s = S[7];
    for c in S[..7].iter().rev() {
        s = s * z + c;
    }
    let mut c = C[8];
    for k in C[..8].iter().rev() {
        c = c * z + k;
    }
    (r + r * z * s, 1.0 + z * c)
}

/// `x.sin_cos()` at `N` points, lane by lane the same operations in loops the compiler runs
/// in vector registers, where libm is a call per point (cyclone's swirl spent 15 % of its time
/// there). Within an ulp or two of libm, and, for |x| below 10⁷, the same bits
/// on every platform, which libm does not promise.
#[inline(always)]
pub fn sin_cos_lanes<const N: usize>(x: [f64; N]) -> ([f64; N], [f64; N]) {
    if !x.iter().all(|v| v.abs() < SIN_COS_LIMIT) {
        let pairs: [(f64, f64); N] = std::array::from_fn(|l| x[l].sin_cos());
        return (pairs.map(|p| p.0), pairs.map(|p| p.1));
    }
    let (mut sin, mut cos) = ([0.0; N], [0.0; N]);
    for l in 0..N {
        // k = x·2/π to the nearest whole number, its low bits the quadrant.
        let rounded = x[l] * std::f64::consts::FRAC_2_PI + ROUND;
        let quadrant = rounded.to_bits();
        let k = rounded - ROUND;
        let r = ((x[l] - k * PIO2_HI) - k * PIO2_MID) - k * PIO2_LO;
        let (s, c) = sin_cos_kernel(r);
        // Quadrant q turns (s, c) by q quarter turns: odd ones swap them, 1 and 2 negate the
        // sine, 2 and 3 the cosine.
        let odd = quadrant & 1 == 1;
        let (s, c) = if odd { (c, s) } else { (s, c) };
        sin[l] = f64::from_bits(s.to_bits() ^ ((quadrant & 2) << 62));
        cos[l] = f64::from_bits(c.to_bits() ^ (((quadrant + 1) & 2) << 62));
    }
    (sin, cos)
}

/// [`vl_noise`] at `N` points, lane by lane the same operations.
#[inline(always)]
pub fn vl_noise_lanes<const N: usize>(x: [f64; N], y: [f64; N], seed: u32) -> [f64; N] {
    let ox = snoise_lanes(x.map(|x| x + 0.5), y.map(|y| y + 0.5), seed ^ 0x9e37_79b9);
    let oy = snoise_lanes(x.map(|x| x - 3.7), y.map(|y| y + 1.3), seed ^ 0x7f4a_7c15);
    snoise_lanes(std::array::from_fn(|l| x[l] + ox[l]), std::array::from_fn(|l| y[l] + oy[l]), seed)
}

/// The multipliers of a cell's x and y in [`hash32`].
const HASH_X: u32 = 0x27d4_eb2d;
const HASH_Y: u32 = 0x1656_67b1;

/// [`hash`] of a cell given by the low 32 bits of its coordinates (all of them `hash` reads).
#[inline(always)]
fn hash32(x: u32, y: u32, seed: u32) -> u32 {
    finish_hash(seed ^ x.wrapping_mul(HASH_X) ^ y.wrapping_mul(HASH_Y))
}

/// The multiply–xorshift finaliser of [`hash32`].
#[inline(always)]
fn finish_hash(mut h: u32) -> u32 {
    h ^= h >> 15;
    h = h.wrapping_mul(0x2c1b_3c6d);
    h ^= h >> 12;
    h = h.wrapping_mul(0x297a_2d39);
    h ^= h >> 15;
    h
}

#[inline]
fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// RenderMan's `noise`: gradient noise mapped to about `[0, 1]`, centred on 0.5.
#[inline]
pub fn noise(x: f64, y: f64, seed: u32) -> f64 {
    0.5 + 0.5 * snoise(x, y, seed)
}

/// How much of an octave of lattice frequency `freq` survives at a pixel `fw` wide: 1 while
/// a lattice cell spans four pixels or more, fading to 0 at two (the Nyquist limit), so a
/// render at any resolution drops what it cannot show instead of aliasing it.
#[inline]
pub fn octave_weight(freq: f64, fw: f64) -> f64 {
    1.0 - smoothstep(0.25, 0.5, freq * fw)
}

/// The octaves of a sum: `octaves` may be fractional, the last one weighted by the fraction
/// (Musgrave's remainder), so the sum is continuous in it.
#[inline]
pub(super) fn octave_count(octaves: f64) -> (usize, f64) {
    let whole = floor(octaves).max(0.0);
    (whole as usize, octaves - whole)
}

/// Fractional Brownian motion: Σ gainⁱ · snoise(2ⁱ·p), each octave faded by its footprint.
pub fn fbm(x: f64, y: f64, octaves: f64, gain: f64, fw: f64, seed: u32) -> f64 {
    fbm_lanes([x], [y], octaves, gain, fw, seed)[0]
}

/// Turbulence: Σ gainⁱ · |snoise(2ⁱ·p)|.
pub fn turbulence(x: f64, y: f64, octaves: f64, gain: f64, fw: f64, seed: u32) -> f64 {
    turbulence_lanes([x], [y], octaves, gain, fw, seed)[0]
}

/// Domain-distorted ("variable lacunarity") noise: snoise of the point displaced by a vector
/// noise, Musgrave's `VLNoise` at scale 1.
#[inline]
pub fn vl_noise(x: f64, y: f64, seed: u32) -> f64 {
    vl_noise_lanes([x], [y], seed)[0]
}

/// [`fbm`] at `N` points, lane by lane the same operations.
#[inline(always)]
pub fn fbm_lanes<const N: usize>(x: [f64; N], y: [f64; N], octaves: f64, gain: f64, fw: f64, seed: u32) -> [f64; N] {
    sum_octaves_lanes(x, y, octaves, gain, fw, seed, |n| n)
}

/// [`turbulence`] at `N` points, lane by lane the same operations.
#[inline(always)]
pub fn turbulence_lanes<const N: usize>(
    x: [f64; N],
    y: [f64; N],
    octaves: f64,
    gain: f64,
    fw: f64,
    seed: u32,
) -> [f64; N] {
    sum_octaves_lanes(x, y, octaves, gain, fw, seed, f64::abs)
}

/// Σ gainⁱ · shape(snoise(2ⁱ·p)) at `N` points, each octave faded by its footprint and the last
/// weighted by the fraction of `octaves`: the octaves are the same for every point.
#[inline(always)]
fn sum_octaves_lanes<const N: usize>(
    x: [f64; N],
    y: [f64; N],
    octaves: f64,
    gain: f64,
    fw: f64,
    seed: u32,
    shape: impl Fn(f64) -> f64,
) -> [f64; N] {
    let (whole, frac) = octave_count(octaves);
    let mut sum = [0.0; N];
    let mut amp = 1.0;
    let mut freq = 1.0;
    for i in 0..=whole {
        let w = if i < whole { 1.0 } else { frac };
        let fade = octave_weight(freq, fw);
        if w == 0.0 || fade == 0.0 {
            break;
        }
        // Each octave its own lattice: a different seed, so octaves do not line up at the origin.
        let s = seed.wrapping_add((i as u32).wrapping_mul(0x68e3_1da4));
        let n = snoise_lanes(x.map(|x| x * freq), y.map(|y| y * freq), s);
        for (sum, n) in sum.iter_mut().zip(n) {
            *sum += w * fade * amp * shape(n);
        }
        amp *= gain;
        freq *= 2.0;
    }
    sum
}

/// The cubic step RenderMan shaders use: the one appearance alpha already had.
pub use crate::synth::appearance::alpha::smoothstep;

#[inline]
pub fn mix(a: [f32; 3], b: [f32; 3], t: f64) -> [f32; 3] {
    let t = t as f32;
    [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t]
}

#[inline]
pub fn scale(c: [f32; 3], k: f64) -> [f32; 3] {
    let k = k as f32;
    [c[0] * k, c[1] * k, c[2] * k]
}

/// The fraction of `[x − w/2, x + w/2]` inside `[a, b]`: a box-filtered interval, exact for a
/// pixel `w` wide and continuous in `a`, `b` and `x`.
#[inline]
pub fn filtered_interval(x: f64, w: f64, a: f64, b: f64) -> f64 {
    if b <= a {
        return 0.0;
    }
    if w <= 0.0 {
        return f64::from((a..b).contains(&x));
    }
    let lo = x - 0.5 * w;
    let hi = x + 0.5 * w;
    ((hi.clamp(a, b) - lo.clamp(a, b)) / w).clamp(0.0, 1.0)
}

/// The fraction of `[x − w/2, x + w/2]` covered by a pulse train of period 1 whose pulses fill
/// `[a, b] + k` (with `0 ≤ a ≤ b ≤ 1`): Apodaca and Gritz's filtered pulse train, through the
/// train's antiderivative.
#[inline]
pub fn filtered_pulse_train(x: f64, w: f64, a: f64, b: f64) -> f64 {
    let width = b - a;
    if width <= 0.0 {
        return 0.0;
    }
    if w <= 0.0 {
        let f = fract(x);
        return f64::from(a <= f && f < b);
    }
    let integral = |t: f64| {
        let f = floor(t);
        f * width + (t - f).clamp(a, b) - a
    };
    ((integral(x + 0.5 * w) - integral(x - 0.5 * w)) / w).clamp(0.0, 1.0)
}

/// Coverage of a pixel `w` wide by the inside (`d < 0`) of a shape with signed distance `d`.
#[inline]
pub fn coverage(d: f64, w: f64) -> f64 {
    if w <= 0.0 {
        return f64::from(d < 0.0);
    }
    (0.5 - d / w).clamp(0.0, 1.0)
}

/// The thesis's fixed lighting on a plane [references: bourque §9]: ambient 0.2 and one
/// distant light of intensity 0.8 along the normal, seen along the normal, so plastic shading
/// is a constant scale of the surface colour plus a constant highlight.
#[inline]
pub fn plastic(ct: [f32; 3], ka: f64, kd: f64, ks: f64, specular: [f32; 3]) -> [f32; 3] {
    let k = (ka * 0.2 + kd * 0.8) as f32;
    let s = (ks * 0.8) as f32;
    [ct[0] * k + s * specular[0], ct[1] * k + s * specular[1], ct[2] * k + s * specular[2]]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lanes' sine and cosine are libm's within two ulps (of 1 where they are below it)
    /// over the swirl's range and beyond, both signs, quadrant edges, and fall back to libm
    /// past the reduction's limit, for NaN and for infinities.
    #[test]
    fn sin_cos_lanes_is_libm_within_two_ulps() {
        let ulp = |v: f64| f64::EPSILON * v.abs().max(1.0);
        let mut points: Vec<f64> = (-40_000..=40_000).map(|i| i as f64 * 1.234_567e-3).collect();
        for k in -64..=64 {
            let edge = k as f64 * std::f64::consts::FRAC_PI_4;
            // The neighbouring f64s (`next_up` is newer than the MSRV).
            let step = f64::EPSILON * edge.abs();
            points.extend([edge, edge + step, edge - step]);
        }
        points.extend([0.0, -0.0, 1e-300, 123_456.789, 9.9e6, 2.0e7, 1e300, -1e300]);
        for chunk in points.chunks_exact(4) {
            let x: [f64; 4] = chunk.try_into().expect("four");
            let (sin, cos) = sin_cos_lanes(x);
            for l in 0..4 {
                let (s, c) = x[l].sin_cos();
                assert!((sin[l] - s).abs() <= 2.0 * ulp(s), "sin {}: {} vs {}", x[l], sin[l], s);
                assert!((cos[l] - c).abs() <= 2.0 * ulp(c), "cos {}: {} vs {}", x[l], cos[l], c);
            }
        }
        let (sin, cos) = sin_cos_lanes([f64::NAN, f64::INFINITY, 1.0, 2.0]);
        assert!(sin[0].is_nan() && cos[1].is_nan());
        assert_eq!((sin[2], cos[3]), (1.0f64.sin(), 2.0f64.cos()));
    }

    /// The noise with its corners' hashes sharing multiplies is the noise with each corner
    /// hashed on its own, bit for bit, across cells of both signs and the wrap of 32 bits.
    #[test]
    fn shared_hash_multiplies_change_no_bit() {
        let reference = |x: f64, y: f64, seed: u32| {
            let (fx, fy) = (floor(x), floor(y));
            let (ix, iy) = (fx as i64, fy as i64);
            let (dx, dy) = (x - fx, y - fy);
            let dot = |cx: i64, cy: i64, ox: f64, oy: f64| {
                let g = GRADIENTS[(hash(cx, cy, seed) >> 28) as usize];
                g[0] * ox + g[1] * oy
            };
            let n00 = dot(ix, iy, dx, dy);
            let n10 = dot(ix + 1, iy, dx - 1.0, dy);
            let n01 = dot(ix, iy + 1, dx, dy - 1.0);
            let n11 = dot(ix + 1, iy + 1, dx - 1.0, dy - 1.0);
            let (sx, sy) = (fade(dx), fade(dy));
            let a = n00 + sx * (n10 - n00);
            let b = n01 + sx * (n11 - n01);
            std::f64::consts::SQRT_2 * (a + sy * (b - a))
        };
        for i in 0..5000 {
            let t = i as f64;
            let (x, y) = ((t * 0.37).sin() * 60.0 + t * 1e-3, (t * 0.11).cos() * 45.0 - 3.0);
            for (x, y) in [(x, y), (x + 4_294_967_295.0, y - 4_294_967_296.5)] {
                for seed in [0, 11, 0xdead_beef] {
                    assert_eq!(snoise(x, y, seed).to_bits(), reference(x, y, seed).to_bits(), "({x}, {y})");
                }
            }
        }
    }
}
