//! Seeded lattice noise (value and gradient) summed over octaves (fBm), in `[0, 1]`.
//!
//! Lattice values and gradients come from a hash of `(seed, octave, lattice point)`, not
//! from a sequential generator, so each pixel is computed on its own: the result does not
//! depend on evaluation order, image size (outside tileable mode) or rayon's thread count.

use super::error::{check_positive, check_size, invalid, MapError};
use super::render::scalar_map;
use crate::raster::Image;

/// Most octaves accepted. Past ~16 the finest octave is far below a pixel at any sane
/// scale and only costs time.
pub const MAX_OCTAVES: u32 = 16;

/// Largest persistence accepted, so `persistence^(octaves-1)` stays finite in `f32`.
pub const MAX_PERSISTENCE: f32 = 16.0;

/// The lattice noise used for each octave.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoiseKind {
    /// Random values at lattice points, quintic-interpolated: blobby.
    Value,
    /// Perlin-style random gradients at lattice points: fewer grid artefacts, lower contrast.
    Gradient,
}

/// Parameters of an fBm noise map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseParams {
    pub kind: NoiseKind,
    /// Lattice cell size of the first (coarsest) octave, in pixels; each further octave
    /// halves it (lacunarity 2).
    pub scale_px: f32,
    /// Number of octaves, 1 to [`MAX_OCTAVES`].
    pub octaves: u32,
    /// Amplitude ratio between successive octaves (0.5 is the classic choice).
    pub persistence: f32,
    /// Makes the map periodic with the image size (seamless when tiled). The cell size is
    /// then adjusted per axis so a whole number of cells spans the image, which changes it
    /// slightly unless `scale_px` divides the size.
    pub tileable: bool,
}

impl NoiseParams {
    /// Non-tileable parameters with the given kind, scale, octaves and persistence.
    pub fn new(kind: NoiseKind, scale_px: f32, octaves: u32, persistence: f32) -> Self {
        NoiseParams { kind, scale_px, octaves, persistence, tileable: false }
    }
}

/// Value noise fBm in `[0, 1]`.
pub fn value_noise(
    width: usize,
    height: usize,
    seed: u64,
    scale_px: f32,
    octaves: u32,
    persistence: f32,
) -> Result<Image, MapError> {
    let params = NoiseParams::new(NoiseKind::Value, scale_px, octaves, persistence);
    noise(width, height, seed, &params)
}

/// Gradient (Perlin-style) noise fBm, remapped to `[0, 1]`.
pub fn gradient_noise(
    width: usize,
    height: usize,
    seed: u64,
    scale_px: f32,
    octaves: u32,
    persistence: f32,
) -> Result<Image, MapError> {
    let params = NoiseParams::new(NoiseKind::Gradient, scale_px, octaves, persistence);
    noise(width, height, seed, &params)
}

/// fBm noise with all options, including tileability.
pub fn noise(width: usize, height: usize, seed: u64, params: &NoiseParams) -> Result<Image, MapError> {
    check_size(width, height, 1)?;
    let fbm = Fbm::new(width, height, seed, params)?;
    Ok(scalar_map(width, height, |x, y| fbm.at(f64::from(x), f64::from(y))))
}

/// One octave's lattice: frequency per axis (cells per pixel), offset, period and seed.
#[derive(Clone, Debug)]
struct Octave {
    freq: [f64; 2],
    /// Shifts each octave's lattice so octaves do not all share a lattice point at the
    /// origin (where gradient noise is always 0.5).
    offset: [f64; 2],
    /// Lattice period per axis in tileable mode.
    period: Option<[i64; 2]>,
    seed: u64,
    /// Normalised amplitude: the weights of all octaves sum to 1.
    weight: f32,
}

/// A ready-to-sample fBm: validated parameters expanded into per-octave lattices.
#[derive(Clone, Debug)]
struct Fbm {
    kind: NoiseKind,
    octaves: Vec<Octave>,
}

impl Fbm {
    fn new(width: usize, height: usize, seed: u64, p: &NoiseParams) -> Result<Self, MapError> {
        check_positive("noise scale", p.scale_px)?;
        if !(1..=MAX_OCTAVES).contains(&p.octaves) {
            let expected = "a whole number of octaves from 1 to 16";
            return Err(invalid("octaves", p.octaves as f32, expected));
        }
        check_positive("persistence", p.persistence)?;
        if p.persistence > MAX_PERSISTENCE {
            return Err(invalid("persistence", p.persistence, "a number > 0 and <= 16"));
        }
        let amps: Vec<f64> = (0..p.octaves).map(|o| f64::from(p.persistence).powi(o as i32)).collect();
        let total: f64 = amps.iter().sum();
        let base = base_cells(width, height, p);
        let octaves = amps
            .iter()
            .enumerate()
            .map(|(o, amp)| octave(seed, o as u32, base, p.tileable, (amp / total) as f32))
            .collect();
        Ok(Fbm { kind: p.kind, octaves })
    }

    /// The noise value at a point in pixel coordinates.
    fn at(&self, x: f64, y: f64) -> f32 {
        let mut sum = 0.0f32;
        for o in &self.octaves {
            let p = [x * o.freq[0] + o.offset[0], y * o.freq[1] + o.offset[1]];
            let n = match self.kind {
                NoiseKind::Value => value_at(o, p),
                NoiseKind::Gradient => gradient_at(o, p),
            };
            sum += o.weight * n;
        }
        sum.clamp(0.0, 1.0)
    }
}

/// Octave-0 lattice frequency per axis. In tileable mode also the octave-0 cell counts.
fn base_cells(width: usize, height: usize, p: &NoiseParams) -> ([f64; 2], Option<[i64; 2]>) {
    let scale = f64::from(p.scale_px);
    if !p.tileable {
        return ([1.0 / scale; 2], None);
    }
    let cells = |size: usize| (size as f64 / scale).round().max(1.0) as i64;
    let (cx, cy) = (cells(width), cells(height));
    ([cx as f64 / width as f64, cy as f64 / height as f64], Some([cx, cy]))
}

fn octave(seed: u64, index: u32, (freq, cells): ([f64; 2], Option<[i64; 2]>), tileable: bool, weight: f32) -> Octave {
    let mult = f64::from(1u32 << index);
    let seed = mix(seed ^ u64::from(index + 1).wrapping_mul(0xD6E8_FEB8_6659_FD93));
    let h = mix(seed ^ 0x5851_F42D_4C95_7F2D);
    let offset = [unit_f64(h) * 256.0, unit_f64(mix(h)) * 256.0];
    let period = cells.filter(|_| tileable).map(|c| [c[0].saturating_mul(1 << index), c[1].saturating_mul(1 << index)]);
    Octave { freq: [freq[0] * mult, freq[1] * mult], offset, period, seed, weight }
}

/// Integer lattice corner and fractional position of `v`, with the corner wrapped to the
/// period (if any) so the lattice repeats.
fn cell(v: f64, period: Option<i64>) -> (i64, i64, f32) {
    let floor = v.floor();
    let i = floor as i64;
    let t = (v - floor) as f32;
    match period {
        Some(p) => (i.rem_euclid(p), i.wrapping_add(1).rem_euclid(p), t),
        None => (i, i.wrapping_add(1), t),
    }
}

/// Value noise of one octave in `[0, 1]`.
fn value_at(o: &Octave, p: [f64; 2]) -> f32 {
    let (x0, x1, tx) = cell(p[0], o.period.map(|q| q[0]));
    let (y0, y1, ty) = cell(p[1], o.period.map(|q| q[1]));
    let v = |ix, iy| unit_f32(hash(o.seed, ix, iy));
    let (sx, sy) = (quintic(tx), quintic(ty));
    let top = lerp(v(x0, y0), v(x1, y0), sx);
    let bottom = lerp(v(x0, y1), v(x1, y1), sx);
    lerp(top, bottom, sy)
}

/// Unit gradients. Eight directions are enough for 2-D Perlin noise and keep the hashed
/// gradient free of trigonometry (whose last bits may vary between platforms' libm).
const GRADIENTS: [[f32; 2]; 8] = [
    [1.0, 0.0],
    [-1.0, 0.0],
    [0.0, 1.0],
    [0.0, -1.0],
    [std::f32::consts::FRAC_1_SQRT_2, std::f32::consts::FRAC_1_SQRT_2],
    [-std::f32::consts::FRAC_1_SQRT_2, std::f32::consts::FRAC_1_SQRT_2],
    [std::f32::consts::FRAC_1_SQRT_2, -std::f32::consts::FRAC_1_SQRT_2],
    [-std::f32::consts::FRAC_1_SQRT_2, -std::f32::consts::FRAC_1_SQRT_2],
];

/// Gradient noise of one octave, remapped from its range `±√½` to `[0, 1]`.
fn gradient_at(o: &Octave, p: [f64; 2]) -> f32 {
    let (x0, x1, tx) = cell(p[0], o.period.map(|q| q[0]));
    let (y0, y1, ty) = cell(p[1], o.period.map(|q| q[1]));
    let dot = |ix, iy, dx: f32, dy: f32| {
        let g = GRADIENTS[(hash(o.seed, ix, iy) >> 61) as usize];
        g[0] * dx + g[1] * dy
    };
    let (sx, sy) = (quintic(tx), quintic(ty));
    let top = lerp(dot(x0, y0, tx, ty), dot(x1, y0, tx - 1.0, ty), sx);
    let bottom = lerp(dot(x0, y1, tx, ty - 1.0), dot(x1, y1, tx - 1.0, ty - 1.0), sx);
    let n = lerp(top, bottom, sy);
    (0.5 + n * std::f32::consts::FRAC_1_SQRT_2).clamp(0.0, 1.0)
}

/// Quintic fade `6t^5 - 15t^4 + 10t^3`: zero first and second derivatives at the lattice
/// points, so octave sums show no grid-aligned creases.
fn quintic(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + (b - a) * t
}

/// Hash of a lattice point: two rounds of the SplitMix64 finaliser.
fn hash(seed: u64, ix: i64, iy: i64) -> u64 {
    let h = mix(seed ^ (ix as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    mix(h ^ (iy as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F))
}

fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Top 24 bits as a float in `[0, 1)`.
fn unit_f32(h: u64) -> f32 {
    (h >> 40) as f32 / (1u64 << 24) as f32
}

/// Top 53 bits as a float in `[0, 1)`.
fn unit_f64(h: u64) -> f64 {
    (h >> 11) as f64 / (1u64 << 53) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mean(img: &Image) -> f64 {
        img.data.iter().map(|&v| f64::from(v)).sum::<f64>() / img.data.len() as f64
    }

    fn kinds() -> [NoiseKind; 2] {
        [NoiseKind::Value, NoiseKind::Gradient]
    }

    #[test]
    fn same_seed_identical_different_seed_differs() {
        for kind in kinds() {
            let p = NoiseParams::new(kind, 16.0, 4, 0.5);
            let a = noise(64, 48, 1, &p).unwrap();
            let b = noise(64, 48, 1, &p).unwrap();
            let c = noise(64, 48, 2, &p).unwrap();
            assert_eq!(a, b);
            assert_ne!(a, c);
        }
    }

    #[test]
    fn range_and_mean() {
        for kind in kinds() {
            for octaves in [1, 5] {
                let p = NoiseParams::new(kind, 8.0, octaves, 0.5);
                let img = noise(256, 256, 99, &p).unwrap();
                assert!(img.data.iter().all(|v| (0.0..=1.0).contains(v)));
                let m = mean(&img);
                assert!((m - 0.5).abs() < 0.05, "{kind:?} {octaves}: mean {m}");
                // Not constant: real variation.
                let lo = img.data.iter().copied().fold(1.0f32, f32::min);
                let hi = img.data.iter().copied().fold(0.0f32, f32::max);
                assert!(hi - lo > 0.3, "{kind:?}: range {lo}..{hi}");
            }
        }
    }

    #[test]
    fn extreme_persistence_stays_in_range() {
        for kind in kinds() {
            let p = NoiseParams::new(kind, 4.0, MAX_OCTAVES, MAX_PERSISTENCE);
            let img = noise(32, 32, 5, &p).unwrap();
            assert!(img.data.iter().all(|v| (0.0..=1.0).contains(v)));
        }
    }

    #[test]
    fn value_noise_is_smooth_at_large_scale() {
        let img = value_noise(64, 64, 3, 32.0, 1, 0.5).unwrap();
        for y in 0..64 {
            for x in 1..64 {
                assert!((img.get(x, y, 0) - img.get(x - 1, y, 0)).abs() < 0.1);
            }
        }
    }

    #[test]
    fn wrappers_match_params() {
        let p = NoiseParams::new(NoiseKind::Gradient, 10.0, 3, 0.6);
        assert_eq!(gradient_noise(20, 10, 4, 10.0, 3, 0.6).unwrap(), noise(20, 10, 4, &p).unwrap());
    }

    #[test]
    fn tileable_repeats_with_the_image_size() {
        for kind in kinds() {
            let mut p = NoiseParams::new(kind, 12.0, 3, 0.5);
            p.tileable = true;
            let (w, h) = (50usize, 40usize);
            let fbm = Fbm::new(w, h, 8, &p).unwrap();
            for (x, y) in [(0.5, 0.5), (3.25, 17.5), (49.5, 39.5)] {
                let v = fbm.at(x, y);
                assert!((v - fbm.at(x + w as f64, y)).abs() < 1e-4);
                assert!((v - fbm.at(x, y + h as f64)).abs() < 1e-4);
            }
            // Matches the rendered map.
            let img = noise(w, h, 8, &p).unwrap();
            assert_eq!(img.get(3, 17, 0), fbm.at(3.5, 17.5));
        }
    }

    #[test]
    fn rejects_bad_parameters() {
        assert!(value_noise(8, 8, 0, 0.0, 1, 0.5).is_err());
        assert!(value_noise(8, 8, 0, -3.0, 1, 0.5).is_err());
        assert!(value_noise(8, 8, 0, f32::NAN, 1, 0.5).is_err());
        assert!(value_noise(8, 8, 0, 4.0, 0, 0.5).is_err());
        assert!(value_noise(8, 8, 0, 4.0, 17, 0.5).is_err());
        assert!(value_noise(8, 8, 0, 4.0, 16, 0.5).is_ok());
        assert!(gradient_noise(8, 8, 0, 4.0, 2, 0.0).is_err());
        assert!(gradient_noise(8, 8, 0, 4.0, 2, 17.0).is_err());
        assert!(gradient_noise(0, 8, 0, 4.0, 2, 0.5).is_err());
        // Absurd but finite scales must not panic.
        assert!(value_noise(4, 4, 0, 1e-30, 16, 0.5).is_ok());
        let mut p = NoiseParams::new(NoiseKind::Value, 1e-30, 16, 0.5);
        p.tileable = true;
        assert!(noise(4, 4, 0, &p).is_ok());
    }

    #[test]
    fn thread_count_does_not_change_output() {
        let build = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| kinds().map(|kind| noise(97, 83, 12, &NoiseParams::new(kind, 7.0, 6, 0.55)).unwrap()))
        };
        assert_eq!(build(1), build(2));
        assert_eq!(build(1), build(3));
    }
}
