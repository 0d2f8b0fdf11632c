//! The shaders built on noise [references: bourque §5]: SH5 Musgrave's cyclone, SH6 Gritz's
//! eyeball veins, SH7 clouds, SH8 a star field and SH13 Gritz's hexagonal tiles. Their noise is
//! seeded, so a target from another seed is matched by similarity, not by equal parameters.

use super::def::{Pattern, ShaderDef};
use super::params::{Args, ParamDef as P};
use super::prims::{
    cell_random, coverage, fbm_lanes, floor, length, mix, octave_count, octave_weight, plastic, scale, sin_cos_lanes,
    smoothstep, snoise_lanes, turbulence, turbulence_lanes, vl_noise_lanes,
};

pub static CYCLONE: ShaderDef = ShaderDef {
    name: "cyclone",
    doc: "Musgrave's KMCyclone (the thesis's App. B): clouds of domain-distorted fBm swirled about a calm eye at the centre of the unit square. On the thesis's plane the swirl was a constant turn (|normalize(P).xy| = 1 at z = 0); here the radius is measured from the square's centre, so `max_radius` and `twist` shape a real vortex.",
    params: &[
        P::float("Ka", 0.0, 1.0, &[0.5], "Ambient coefficient.").fixed(),
        P::float("Kd", 0.0, 1.0, &[0.75], "Diffuse coefficient.").fixed(),
        P::float("max_radius", 0.05, 2.0, &[1.0], "Radius of the vortex, in texture units; outside it the clouds thin out."),
        P::float("twist", -1.0, 1.0, &[0.5], "Turns of the swirl from the rim to the eye."),
        P::float("scale", 0.0, 2.0, &[0.7], "Amplitude of the cloud noise."),
        P::float("offset", 0.0, 1.0, &[0.5], "Cloud density added everywhere."),
        P::float("omega", 0.0, 1.0, &[0.675], "Gain from one octave to the next."),
        P::float("octaves", 1.0, 9.0, &[4.0], "Octaves of noise; a fraction weights the last one."),
        P::float("frequency", 1.0, 16.0, &[4.0], "Noise lattice cells per texture unit in the first octave (tessera's: the shader space of the thesis's plane)."),
        P::colour("colour", &[1.0, 1.0, 1.0], "The clouds (the surface colour Cs)."),
        P::colour("background", &[0.0, 0.0, 0.0], "Behind them."),
    ],
    stochastic: true,
    version: 3,
    build: |v, seed| {
        let mut a = Args::new(v);
        let (ka, kd) = (a.f(), a.f());
        Box::new(Cyclone {
            max_radius: a.f(),
            twist: a.f(),
            scale: a.f(),
            offset: a.f(),
            omega: a.f(),
            octaves: a.f(),
            frequency: a.f(),
            colour: plastic(a.c(), ka, kd, 0.0, [0.0; 3]),
            background: a.c(),
            seed,
        })
    },
};

struct Cyclone {
    max_radius: f64,
    twist: f64,
    scale: f64,
    offset: f64,
    omega: f64,
    octaves: f64,
    frequency: f64,
    colour: [f32; 3],
    background: [f32; 3],
    seed: u32,
}

impl Cyclone {
    /// The colours at `N` points of one row, one point per lane: the swirl point by point, the
    /// octaves of noise side by side (every point has the same octaves).
    #[inline(always)]
    fn shade_lanes<const N: usize>(&self, u: [f64; N], v: f64, fw: f64) -> [[f32; 3]; N] {
        let r = self.max_radius;
        let (mut angle, mut weight) = ([0.0; N], [0.0; N]);
        for l in 0..N {
            let radius = length(u[l] - 0.5, v - 0.5);
            // The swirl: a turn that grows toward the eye; the rim and the eye fade out smoothly.
            let dist = (r - radius).max(0.0).powi(3);
            angle[l] = std::f64::consts::PI + self.twist * std::f64::consts::TAU * (r - dist) / r;
            weight[l] = smoothstep(0.05 * r, 0.1 * r, radius) * (1.0 - smoothstep(0.9 * r, r, radius));
        }
        let (sin, cos) = sin_cos_lanes(angle);
        let (mut px, mut py) = ([0.0; N], [0.0; N]);
        for l in 0..N {
            let (x, y) = (u[l] - 0.5, v - 0.5);
            px[l] = (cos[l] * x - sin[l] * y) * self.frequency;
            py[l] = (sin[l] * x + cos[l] * y) * self.frequency;
        }
        // Outside the vortex there is no cloud to compute (catalogues sample small vortices).
        if weight.iter().all(|&w| w == 0.0) {
            return [self.background; N];
        }
        let (whole, frac) = octave_count(self.octaves);
        let mut sum = [0.0; N];
        let mut o = 1.0;
        let mut l = 1.0;
        for i in 0..=whole {
            let w = if i < whole { 1.0 } else { frac };
            let fade = octave_weight(l * self.frequency, fw);
            // (The thesis also stopped below an octave weight of 0.001, a jump in `omega`.)
            if w == 0.0 || fade == 0.0 {
                break;
            }
            let n = vl_noise_lanes(px.map(|p| p * l), py.map(|p| p * l), self.seed.wrapping_add(i as u32));
            for (s, n) in sum.iter_mut().zip(n) {
                *s += w * fade * o * n;
            }
            l *= 2.0;
            o *= self.omega;
        }
        std::array::from_fn(|k| {
            if weight[k] == 0.0 {
                return self.background;
            }
            let value = (weight[k] * (self.offset + self.scale * sum[k])).abs();
            mix(self.background, self.colour, value.min(1.0))
        })
    }
}

/// Points a row of a noise shader evaluates side by side: sixteen fill AVX2's eight 32-bit
/// lanes with hashes and four registers with f64s (cyclone at 1024²: 34 ms, against 40 with
/// eight points).
const ROW_LANES: usize = 16;

/// The rows and points of a shader that has `shade_lanes::<N>(u, v, fw)`: a row by chunks of
/// [`ROW_LANES`] points (compiled for AVX2 too, and run so where the CPU has it: the same
/// operations on wider registers, so the same bits, as Rust never fuses a multiply and an
/// add on its own), its remainder and single points as one lane.
macro_rules! lane_pattern {
    ($t:ty) => {
        impl $t {
            #[inline(always)]
            fn row(&self, u0: f64, du: f64, v: f64, fw: f64, out: &mut [[f32; 3]]) {
                let mut chunks = out.chunks_exact_mut(ROW_LANES);
                let mut x = 0;
                for chunk in &mut chunks {
                    let u = std::array::from_fn(|l| u0 + ((x + l) as f64 + 0.5) * du);
                    chunk.copy_from_slice(&self.shade_lanes::<ROW_LANES>(u, v, fw));
                    x += ROW_LANES;
                }
                for c in chunks.into_remainder() {
                    *c = self.shade(u0 + (x as f64 + 0.5) * du, v, fw);
                    x += 1;
                }
            }

            /// `row` compiled for AVX2.
            ///
            /// # Safety
            /// The CPU must have AVX2.
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx2")]
            unsafe fn row_avx2(&self, u0: f64, du: f64, v: f64, fw: f64, out: &mut [[f32; 3]]) {
                self.row(u0, du, v, fw, out)
            }
        }

        impl Pattern for $t {
            fn shade(&self, u: f64, v: f64, fw: f64) -> [f32; 3] {
                self.shade_lanes::<1>([u], v, fw)[0]
            }

            fn shade_row(&self, u0: f64, du: f64, v: f64, fw: f64, out: &mut [[f32; 3]]) {
                #[cfg(target_arch = "x86_64")]
                if std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU has AVX2.
                    return unsafe { self.row_avx2(u0, du, v, fw, out) };
                }
                self.row(u0, du, v, fw, out)
            }
        }
    };
}

lane_pattern!(Cyclone);

pub static EYEBALL: ShaderDef = ShaderDef {
    name: "eyeball",
    doc: "Gritz's LGEyeBall (the thesis's App. C) on the plane: an iris and pupil at the centre of the unit square (the sphere's pole), and a white of ridged-noise blood veins. With `irissize` and `pupilsize` 0 and black blood it is a vein network on white, which matched a Brodatz texture in the thesis (Fig. 4-18(d)).",
    params: &[
        P::float("Ka", 0.0, 1.0, &[0.75], "Ambient coefficient.").fixed(),
        P::float("Kd", 0.0, 1.0, &[0.75], "Diffuse coefficient.").fixed(),
        P::float("Ks", 0.0, 1.0, &[0.4], "Specular coefficient.").fixed(),
        P::float("roughness", 0.01, 1.0, &[0.1], "Specular roughness (no effect under the fixed frontal light; kept for the thesis's parameter list).").fixed(),
        P::colour("specularcolor", &[1.0, 1.0, 1.0], "Highlight colour."),
        P::colour("iriscolor", &[0.135, 0.084, 0.372], "Iris fibres."),
        P::colour("irisoutercolor", &[0.404, 0.344, 0.683], "Iris rim."),
        P::colour("irisinnercolor", &[0.065, 0.041, 0.179], "Iris near the pupil."),
        P::colour("eyeballcolor", &[1.0, 1.0, 1.0], "The white of the eye."),
        P::colour("bloodcolor", &[0.8, 0.05, 0.05], "Veins."),
        P::colour("pupilcolor", &[0.0, 0.0, 0.0], "Pupil."),
        P::float("pupilsize", 0.0, 0.5, &[0.05], "Pupil radius, in texture units."),
        P::float("irissize", 0.0, 0.5, &[0.12], "Iris radius, in texture units."),
        P::float("bloodshot", 0.0, 1.0, &[1.0], "How strongly veins show."),
        P::float("veinfreq", 1.0, 16.0, &[8.0], "Vein noise lattice cells per texture unit in the first level."),
        P::float("veinlevel", 1.0, 10.0, &[4.0], "Levels of veins, each twice as fine; a fraction weights the last."),
        P::int("index", 0, 1000, &[0.0], "Which vein network (offsets the noise; a search leaves it alone: any network looks alike).").fixed(),
    ],
    stochastic: true,
    version: 3,
    build: |v, seed| {
        let mut a = Args::new(v);
        let (ka, kd, ks, _roughness) = (a.f(), a.f(), a.f(), a.f());
        Box::new(Eyeball {
            ka,
            kd,
            ks,
            specular: a.c(),
            iris: a.c(),
            iris_outer: a.c(),
            iris_inner: a.c(),
            ball: a.c(),
            blood: a.c(),
            pupil: a.c(),
            pupil_size: a.f(),
            iris_size: a.f(),
            bloodshot: a.f(),
            vein_freq: a.f(),
            vein_level: a.f(),
            seed: seed.wrapping_add((a.f() as u32).wrapping_mul(0x9e37_79b9)),
        })
    },
};

struct Eyeball {
    ka: f64,
    kd: f64,
    ks: f64,
    specular: [f32; 3],
    iris: [f32; 3],
    iris_outer: [f32; 3],
    iris_inner: [f32; 3],
    ball: [f32; 3],
    blood: [f32; 3],
    pupil: [f32; 3],
    pupil_size: f64,
    iris_size: f64,
    bloodshot: f64,
    vein_freq: f64,
    vein_level: f64,
    seed: u32,
}

impl Eyeball {
    #[inline(always)]
    fn shade_lanes<const N: usize>(&self, u: [f64; N], v: f64, fw: f64) -> [[f32; 3]; N] {
        // Veins: ridged noise, each level twice as fine, shown where the levels above were
        // ridges too (Gritz's loop, with its `turb > 0.1` early exit, taken lane by lane: a
        // lane that has left keeps its values).
        let mut displayed = [0.0; N];
        let mut turb = [1f64; N];
        let mut freq = self.vein_freq;
        let (whole, frac) = octave_count(self.vein_level);
        for i in 0..=whole {
            let w = if i < whole { 1.0 } else { frac };
            let fade = octave_weight(freq, fw);
            // A NaN stays, as it did when the test was `turb <= 0.1` to leave.
            let live = turb.map(|t| t > 0.1 || t.is_nan());
            if w == 0.0 || fade == 0.0 || !live.contains(&true) {
                break;
            }
            let s = self.seed.wrapping_add(i as u32);
            let noise = snoise_lanes(u.map(|u| u * freq), [v * freq + 20.0 * freq; N], s);
            // A ridge thinner than a pixel is drawn a pixel wide and as much fainter (the same
            // integral over |noise|), so renders at any resolution agree after filtering.
            let width = (RIDGE_WIDTH_PER_PIXEL * freq * fw).max(0.15);
            for k in (0..N).filter(|&k| live[k]) {
                let new_turb = 1.0 - noise[k].abs();
                let new_disp = (0.15 / width) * smoothstep(1.0 - width, 1.0, new_turb).powi(10);
                displayed[k] += w * fade * (1.0 - displayed[k]) * new_disp * smoothstep(0.1, 0.85, turb[k] * turb[k]);
                turb[k] *= new_turb;
            }
            freq *= 2.0;
        }
        std::array::from_fn(|k| {
            let u = u[k];
            // `tt`, the distance from the pole, is the distance from the square's centre.
            let tt = length(u - 0.5, v - 0.5);
            let twidth = fw.max(1e-4);
            let iris_stat = smoothstep(self.iris_size, self.iris_size + twidth, tt);
            let pupil_stat = smoothstep(self.pupil_size, self.pupil_size + twidth, tt);
            let bloody = self.bloodshot
                * if self.iris_size > 0.0 { smoothstep(-self.iris_size, 2.5 * self.iris_size, tt) } else { 1.0 };
            let ball = mix(self.ball, self.blood, smoothstep(0.0, 0.75, bloody * displayed[k]));
            // The iris (where it shows): fibres of turbulence starting at frequency 30, between
            // its inner and outer colours.
            let iris = if iris_stat < 1.0 {
                let fibres = turbulence(u * 30.0, v * 30.0, 4.0, 0.5, fw, self.seed ^ 0x5bd1_e995);
                let ring =
                    mix(self.iris_inner, self.iris_outer, smoothstep(self.pupil_size, self.iris_size.max(1e-9), tt));
                mix(ring, self.iris, smoothstep(0.1, 0.6, fibres))
            } else {
                ball
            };
            let ct = mix(self.pupil, mix(iris, ball, iris_stat), pupil_stat);
            plastic(ct, self.ka, self.kd, self.ks, self.specular)
        })
    }
}

lane_pattern!(Eyeball);

/// How far |noise| moves across one pixel, per lattice cell of the pixel's width (gradient
/// noise's gradient is about this steep).
const RIDGE_WIDTH_PER_PIXEL: f64 = 1.5;

pub static CLOUDS: ShaderDef = ShaderDef {
    name: "clouds",
    doc: "A day sky (the thesis's cloud shader, Fig. 4-19): fBm clouds over a blue sky, with their cover and softness.",
    params: &[
        P::float("frequency", 0.5, 16.0, &[3.0], "Noise lattice cells per texture unit in the first octave."),
        P::float("octaves", 1.0, 9.0, &[6.0], "Octaves of noise; a fraction weights the last one."),
        P::float("gain", 0.1, 0.9, &[0.5], "Amplitude ratio from one octave to the next."),
        P::float("cover", 0.0, 1.0, &[0.5], "How much of the sky is cloud."),
        P::float("softness", 0.01, 1.0, &[0.4], "Width of the cloud edges, in noise units."),
        P::colour("sky", &[0.25, 0.45, 0.85], "Clear sky."),
        P::colour("cloud", &[1.0, 1.0, 1.0], "Clouds."),
    ],
    stochastic: true,
    version: 1,
    build: |v, seed| {
        let mut a = Args::new(v);
        Box::new(Clouds {
            frequency: a.f(),
            octaves: a.f(),
            gain: a.f(),
            cover: a.f(),
            softness: a.f(),
            sky: a.c(),
            cloud: a.c(),
            seed,
        })
    },
};

struct Clouds {
    frequency: f64,
    octaves: f64,
    gain: f64,
    cover: f64,
    softness: f64,
    sky: [f32; 3],
    cloud: [f32; 3],
    seed: u32,
}

impl Clouds {
    #[inline(always)]
    fn shade_lanes<const N: usize>(&self, u: [f64; N], v: f64, fw: f64) -> [[f32; 3]; N] {
        let f = self.frequency;
        let n = fbm_lanes(u.map(|u| u * f), [v * f; N], self.octaves, self.gain, fw * f, self.seed);
        n.map(|n| {
            // fBm is centred on 0 with a spread near 0.5: cover 0.5 clouds half the sky.
            let edge = 0.5 - self.cover;
            let density = smoothstep(edge - 0.5 * self.softness, edge + 0.5 * self.softness, n);
            mix(self.sky, self.cloud, density)
        })
    }
}

lane_pattern!(Clouds);

pub static STARFIELD: ShaderDef = ShaderDef {
    name: "starfield",
    doc: "A night sky (the thesis's star-field shader, Fig. 4-19): stars at random places in a lattice of cells, each cell holding at most one, of random brightness. A star smaller than a pixel keeps its energy, spread over the pixel.",
    params: &[
        P::float("density", 2.0, 64.0, &[16.0], "Cells per texture unit (at most one star each)."),
        P::float("probability", 0.0, 1.0, &[0.5], "Chance that a cell holds a star."),
        P::float("radius", 0.0005, 0.02, &[0.004], "Star radius, in texture units."),
        P::float("twinkle", 0.0, 1.0, &[0.5], "Spread of star brightness (0: all equal)."),
        P::colour("sky", &[0.01, 0.01, 0.04], "The night."),
        P::colour("star", &[1.0, 0.97, 0.85], "The stars."),
    ],
    stochastic: true,
    version: 3,
    build: |v, seed| {
        let mut a = Args::new(v);
        Box::new(Starfield {
            density: a.f(),
            probability: a.f(),
            radius: a.f(),
            twinkle: a.f(),
            sky: a.c(),
            star: a.c(),
            seed,
        })
    },
};

struct Starfield {
    density: f64,
    probability: f64,
    radius: f64,
    twinkle: f64,
    sky: [f32; 3],
    star: [f32; 3],
    seed: u32,
}

impl Starfield {
    /// The light at `(x, y)` (cell units) of the star of cell `(i, j)`, drawn `drawn` wide.
    fn star_light(&self, i: i64, j: i64, x: f64, y: f64, drawn: f64, w: f64) -> f64 {
        // A star fades in as `probability` passes its cell's draw, so the image is continuous
        // in `probability` (local search needs that).
        let presence = ((self.probability - cell_random(i, j, self.seed)) / 0.02).clamp(0.0, 1.0);
        if presence == 0.0 {
            return 0.0;
        }
        let sx = i as f64 + cell_random(i, j, self.seed ^ 0x85eb_ca6b);
        let sy = j as f64 + cell_random(i, j, self.seed ^ 0xc2b2_ae35);
        let brightness = presence * (1.0 - self.twinkle * cell_random(i, j, self.seed ^ 0x27d4_eb2f));
        brightness * coverage(length(x - sx, y - sy) - drawn, w)
    }
}

impl Pattern for Starfield {
    fn shade(&self, u: f64, v: f64, fw: f64) -> [f32; 3] {
        let (x, y) = (u * self.density, v * self.density);
        // In cell units; a star drawn bigger than its true size (under a pixel) is dimmed by
        // the ratio of areas, so its energy does not depend on the resolution.
        let r = self.radius * self.density;
        let w = fw * self.density;
        let drawn = r.max(0.5 * w);
        let energy = (r / drawn).powi(2);
        // Past a few cells per pixel the stars are a haze: their expected light per cell
        // (presence × brightness × disc area) stands in, blended in from 2 to 4 cells a pixel
        // so the image stays continuous in `density`, and the cells visited stay bounded.
        let haze = smoothstep(2.0, 4.0, w);
        let expected = self.probability * (1.0 - 0.5 * self.twinkle) * std::f64::consts::PI * r * r;
        let mut light: f64 = 0.0;
        if haze < 1.0 {
            // Only cells whose star could reach the pixel: a star lies in its cell, and lights
            // the pixel only within `drawn + w / 2` of its centre.
            let reach = drawn + w;
            let (i0, i1) = (floor(x - reach) as i64, floor(x + reach) as i64);
            let (j0, j1) = (floor(y - reach) as i64, floor(y + reach) as i64);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    light += self.star_light(i, j, x, y, drawn, w) * energy;
                }
            }
        }
        let light = light + haze * (expected - light);
        mix(self.sky, self.star, light.min(1.0))
    }
}

pub static HEXTILE: ShaderDef = ShaderDef {
    name: "hextile",
    doc: "Gritz's hexagonal tiles (the thesis's parameter view, Fig. A-3): hexagons of one colour with per-tile variation, mortar between them, stains and scuffs of noise.",
    params: &[
        P::float("Ka", 0.0, 1.0, &[0.5], "Ambient coefficient.").fixed(),
        P::float("Kd", 0.0, 1.0, &[0.5], "Diffuse coefficient.").fixed(),
        P::float("Ks", 0.0, 1.0, &[0.2], "Specular coefficient.").fixed(),
        P::float("roughness", 0.01, 1.0, &[0.1], "Specular roughness (no effect under the fixed frontal light; kept for the thesis's parameter list).").fixed(),
        P::colour("specularcolor", &[1.0, 1.0, 1.0], "Highlight colour."),
        P::colour("tilecolor", &[0.55, 0.0, 0.0], "Tiles."),
        P::colour("mortarcolor", &[0.5, 0.5, 0.5], "Mortar."),
        P::float("tileradius", 0.02, 1.0, &[0.2], "Distance from a tile's centre to its corners, in texture units."),
        P::float("mortarwidth", 0.0, 0.2, &[0.02], "Mortar between tiles, in texture units."),
        P::float("tilevary", 0.0, 0.3, &[0.15], "Random brightness change per tile."),
        P::float("scuffing", 0.0, 1.0, &[0.5], "How much of the tiles is scuffed."),
        P::float("stains", 0.0, 1.0, &[0.4], "How dark the stains are."),
        P::float("stainfrequency", 0.0, 5.0, &[2.0], "Stain noise cells per texture unit."),
        P::float("scufffrequency", 0.0, 8.0, &[4.0], "Scuff noise cells per texture unit."),
        P::colour("scuffcolor", &[0.05, 0.05, 0.05], "Scuffs."),
    ],
    stochastic: true,
    version: 1,
    build: |v, seed| {
        let mut a = Args::new(v);
        let (ka, kd, ks, _roughness) = (a.f(), a.f(), a.f(), a.f());
        Box::new(Hextile {
            ka,
            kd,
            ks,
            specular: a.c(),
            tile: a.c(),
            mortar: a.c(),
            radius: a.f(),
            mortar_width: a.f(),
            vary: a.f(),
            scuffing: a.f(),
            stains: a.f(),
            stain_freq: a.f(),
            scuff_freq: a.f(),
            scuff: a.c(),
            seed,
        })
    },
};

struct Hextile {
    ka: f64,
    kd: f64,
    ks: f64,
    specular: [f32; 3],
    tile: [f32; 3],
    mortar: [f32; 3],
    radius: f64,
    mortar_width: f64,
    vary: f64,
    scuffing: f64,
    stains: f64,
    stain_freq: f64,
    scuff_freq: f64,
    scuff: [f32; 3],
    seed: u32,
}

const SQRT3: f64 = 1.732_050_807_568_877_2; // √3

impl Hextile {
    /// The tile holding `(x, y)` (axial coordinates of pointy-top hexagons of circumradius
    /// `radius`) and the distance from the point to that tile's nearest edge.
    fn cell(&self, x: f64, y: f64) -> ((i64, i64), f64) {
        let r = self.radius;
        let q = (SQRT3 / 3.0 * x - y / 3.0) / r;
        let s = (2.0 / 3.0 * y) / r;
        // Cube rounding.
        let (cx, cz) = (q, s);
        let cy = -cx - cz;
        let (mut rx, ry, mut rz) = (floor(cx + 0.5), floor(cy + 0.5), floor(cz + 0.5));
        let (dx, dy, dz) = ((rx - cx).abs(), (ry - cy).abs(), (rz - cz).abs());
        if dx > dy && dx > dz {
            rx = -ry - rz;
        } else if dy <= dz {
            rz = -rx - ry;
        }
        let centre = [r * SQRT3 * (rx + 0.5 * rz), r * 1.5 * rz];
        let (px, py) = (x - centre[0], y - centre[1]);
        // Pointy-top hexagons have edge normals at 0° and ±60°.
        let reach = px.abs().max((0.5 * px + 0.5 * SQRT3 * py).abs()).max((0.5 * px - 0.5 * SQRT3 * py).abs());
        ((rx as i64, rz as i64), 0.5 * SQRT3 * r - reach)
    }
}

impl Hextile {
    #[inline(always)]
    fn shade_lanes<const N: usize>(&self, u: [f64; N], v: f64, fw: f64) -> [[f32; 3]; N] {
        let sf = self.stain_freq;
        let stain = fbm_lanes(u.map(|u| u * sf + 13.1), [v * sf + 7.7; N], 3.0, 0.5, fw * sf, self.seed ^ 0x1b87_3593);
        let cf = self.scuff_freq;
        let scuffs = turbulence_lanes(u.map(|u| u * cf), [v * cf; N], 4.0, 0.5, fw * cf, self.seed ^ 0xcc9e_2d51);
        std::array::from_fn(|k| {
            let ((i, j), edge) = self.cell(u[k], v);
            let in_tile = coverage(0.5 * self.mortar_width - edge, fw);
            let mut tile = scale(self.tile, 1.0 + self.vary * (2.0 * cell_random(i, j, self.seed) - 1.0));
            tile = scale(tile, 1.0 - self.stains * smoothstep(0.0, 0.6, stain[k]));
            tile = mix(tile, self.scuff, self.scuffing * smoothstep(0.35, 0.9, scuffs[k]));
            let ct = mix(self.mortar, tile, in_tile);
            plastic(ct, self.ka, self.kd, self.ks, self.specular)
        })
    }
}

lane_pattern!(Hextile);

#[cfg(test)]
mod lane_tests {
    use super::*;
    use crate::synth::shader::prims::{snoise, vl_noise};

    /// The lane noise is the one-point noise bit for bit: negative and positive cells, lattice
    /// points, cell borders, far points (2⁴⁹ and past 2⁵⁰, where the lanes fall back), NaN.
    #[test]
    fn lane_noise_equals_point_noise_bit_for_bit() {
        let mut points = Vec::new();
        for i in 0..4000 {
            let t = i as f64;
            points.push(((t * 0.37).sin() * 40.0 + t * 1e-3, (t * 0.11).cos() * 25.0 - 3.0));
        }
        points.extend([(0.0, 0.0), (-1.0, 1.0), (3.0, -7.0), (-0.0, 2.5), (1e-300, -1e-300)]);
        points.extend([(5.6e14, -5.6e14), (2f64.powi(50), 1.5), (-2f64.powi(50) - 2.0, 0.25), (1e18, 3.0)]);
        points.extend([(f64::NAN, 0.5), (0.5, f64::INFINITY)]);
        for chunk in points.chunks_exact(8) {
            let x: [f64; 8] = std::array::from_fn(|l| chunk[l].0);
            let y: [f64; 8] = std::array::from_fn(|l| chunk[l].1);
            for seed in [0, 7, 0xdead_beef] {
                let lanes = snoise_lanes(x, y, seed);
                let vl = vl_noise_lanes(x, y, seed);
                for l in 0..8 {
                    assert_eq!(lanes[l].to_bits(), snoise(x[l], y[l], seed).to_bits(), "({}, {})", x[l], y[l]);
                    assert_eq!(vl[l].to_bits(), vl_noise(x[l], y[l], seed).to_bits(), "({}, {})", x[l], y[l]);
                }
            }
        }
    }

    /// A row shaded side by side (with AVX2 where the CPU has it, and without) is the row
    /// shaded point by point, bit for bit, at widths that leave a remainder and parameters
    /// that cut octaves short or leave the eye and the rim.
    #[test]
    fn a_cyclone_row_equals_its_points_bit_for_bit() {
        let mut settings = vec![CYCLONE.defaults()];
        let mut v = CYCLONE.defaults();
        v[2] = 0.3; // max_radius: most of the square outside the vortex
        v[7] = 6.5; // octaves: a fractional last one
        settings.push(v);
        let mut v = CYCLONE.defaults();
        v[3] = -0.8;
        v[8] = 13.0;
        settings.push(v);
        for values in settings {
            let pattern = CYCLONE.pattern(&values, 42).expect("valid");
            for (width, fw) in [(37, 1.0 / 37.0), (64, 1.0 / 64.0), (1000, 1.0 / 1000.0), (5, 0.2)] {
                let du = 1.0 / width as f64;
                for v in [0.013, 0.5, 0.77] {
                    let mut row = vec![[0f32; 3]; width];
                    pattern.shade_row(0.0, du, v, fw, &mut row);
                    let mut plain = vec![[0f32; 3]; width];
                    let cyclone = Cyclone {
                        max_radius: values[2],
                        twist: values[3],
                        scale: values[4],
                        offset: values[5],
                        omega: values[6],
                        octaves: values[7],
                        frequency: values[8],
                        colour: [1.0, 0.9, 0.8],
                        background: [0.1, 0.2, 0.3],
                        seed: 9,
                    };
                    cyclone.row(0.0, du, v, fw, &mut plain);
                    for x in 0..width {
                        let u = (x as f64 + 0.5) * du;
                        let one = pattern.shade(u, v, fw);
                        assert_eq!(row[x].map(f32::to_bits), one.map(f32::to_bits), "pixel {x} of {width} at v {v}");
                        assert_eq!(plain[x].map(f32::to_bits), cyclone.shade(u, v, fw).map(f32::to_bits));
                    }
                }
            }
        }
    }
}
