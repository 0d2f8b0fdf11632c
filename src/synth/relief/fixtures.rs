//! Seeded stand-ins for the relief examples of [references: frasson §5.3.3]: colour photos with
//! their true height and a class per pixel, and the small patches an artist would cut for them.
//! The thesis's photographs are not available; these keep what each example exercises:
//!
//! - `brick_foliage` (the Biot wall): red bricks, recessed dark mortar, **protruding dark
//!   foliage** (one patch cannot map dark to both depths), and a corner of light mortar close in
//!   colour to light bricks, the trap the thesis reports.
//! - `door`: wood planks with recessed grooves and raised light studs (two patches beat the
//!   greyscale baseline).
//! - `chip`: many colour classes, each at its own depth (too many for a few patches).
//! - `block`: unstructured rock whose brightness follows its height (the stone block's faces).
//! - `plate`: almond bumps of the base's own colour: colour cannot predict depth (the failure).
//!
//! Colours are linear RGB; heights are in `[0, 1]`, 0.5 the surface's rest level.

use crate::raster::color::lab_to_linear_rgb;
use crate::raster::Image;
use crate::synth::map::value_noise;
use crate::synth::rng::Rng;

/// What each pixel of a stand-in is.
pub mod class {
    pub const BRICK: u8 = 0;
    pub const MORTAR: u8 = 1;
    pub const LIGHT_MORTAR: u8 = 2;
    pub const FOLIAGE: u8 = 3;
    pub const WOOD: u8 = 4;
    pub const GROOVE: u8 = 5;
    pub const STUD: u8 = 6;
    pub const BASE: u8 = 7;
    pub const BUMP: u8 = 8;
    pub const ROCK: u8 = 9;
    /// Chip colour classes are `CHIP + k`.
    pub const CHIP: u8 = 16;
}

/// A stand-in: colour, true height and classes, all of one size.
#[derive(Clone, Debug)]
pub struct Relief {
    pub colour: Image,
    pub height: Image,
    pub class: Vec<u8>,
}

impl Relief {
    pub fn width(&self) -> usize {
        self.colour.width
    }

    pub fn height_px(&self) -> usize {
        self.colour.height
    }

    /// The patch image quilting takes: colour channels then height.
    pub fn patch(&self) -> Image {
        let (c, h) = (&self.colour, &self.height);
        Image::from_fn(c.width, c.height, 4, |x, y, k| if k < 3 { c.get(x, y, k) } else { h.get(x, y, 0) })
    }
}

fn noise(w: usize, h: usize, seed: u64, scale: f32, octaves: u32) -> Image {
    value_noise(w, h, seed, scale, octaves, 0.5).expect("valid noise parameters")
}

fn build(w: usize, h: usize, f: impl Fn(usize, usize) -> ([f32; 3], f32, u8)) -> Relief {
    let mut colour = Image::new(w, h, 3);
    let mut height = Image::new(w, h, 1);
    let mut class = vec![0u8; w * h];
    for y in 0..h {
        for x in 0..w {
            let (lab, z, k) = f(x, y);
            let rgb = lab_to_linear_rgb(lab);
            for (c, v) in rgb.iter().enumerate() {
                colour.set(x, y, c, v.clamp(0.0, 1.0));
            }
            height.set(x, y, 0, z.clamp(0.0, 1.0));
            class[y * w + x] = k;
        }
    }
    Relief { colour, height, class }
}

/// Disc centres and radii, drawn from the seed.
fn discs(w: usize, h: usize, count: usize, radius: (f64, f64), rng: &mut Rng) -> Vec<(f64, f64, f64)> {
    (0..count).map(|_| (rng.range(0.0, w as f64), rng.range(0.0, h as f64), rng.range(radius.0, radius.1))).collect()
}

/// Parameters of the brick wall.
#[derive(Clone, Debug)]
pub struct BrickParams {
    /// Course height and brick length, mortar included, and the mortar width, in pixels.
    pub course: usize,
    pub brick: usize,
    pub mortar: usize,
    /// Foliage blobs: explicit `(x, y, r)` discs (the edge made irregular by noise).
    pub foliage: Vec<(f64, f64, f64)>,
    /// The rectangle `[x0, y0, x1, y1]` (fractions of the size) whose mortar is light.
    pub light_mortar: Option<[f64; 4]>,
}

impl Default for BrickParams {
    fn default() -> Self {
        BrickParams { course: 24, brick: 52, mortar: 4, foliage: Vec::new(), light_mortar: None }
    }
}

/// A brick wall with mortar, optional foliage and a light-mortar corner.
pub fn brick_wall(w: usize, h: usize, p: &BrickParams, seed: u64) -> Relief {
    let grain = noise(w, h, seed ^ 1, 3.0, 3);
    let leaves = noise(w, h, seed ^ 2, 4.0, 3);
    let edge = noise(w, h, seed ^ 3, 12.0, 2);
    let (course, len, m) = (p.course, p.brick, p.mortar);
    let tint = |row: usize, col: usize| {
        let mut r = Rng::new(seed ^ ((row as u64) << 32 | col as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        [r.range(43.0, 50.0) as f32, r.range(20.0, 26.0) as f32, r.range(16.0, 22.0) as f32]
    };
    build(w, h, |x, y| {
        let n = grain.get(x, y, 0) - 0.5;
        let in_foliage = p.foliage.iter().any(|&(cx, cy, r)| {
            let d = ((x as f64 - cx).powi(2) + (y as f64 - cy).powi(2)).sqrt();
            d < r * (0.8 + 0.4 * f64::from(edge.get(x, y, 0)))
        });
        if in_foliage {
            let l = leaves.get(x, y, 0);
            return ([20.0 + 16.0 * l, -26.0 + 6.0 * n, 20.0 + 6.0 * n], 0.74 + 0.2 * l, class::FOLIAGE);
        }
        let row = y / course;
        let yy = y % course;
        let offset = if row % 2 == 1 { len / 2 } else { 0 };
        let xx = (x + offset) % len;
        let col = (x + offset) / len;
        if yy < m || xx < m {
            let light = p.light_mortar.is_some_and(|[x0, y0, x1, y1]| {
                let (fx, fy) = (x as f64 / w as f64, y as f64 / h as f64);
                (x0..x1).contains(&fx) && (y0..y1).contains(&fy)
            });
            return if light {
                ([54.0 + 4.0 * n, 16.0, 17.0], 0.2 + 0.06 * n, class::LIGHT_MORTAR)
            } else {
                ([24.0 + 4.0 * n, 1.0, 4.0], 0.2 + 0.06 * n, class::MORTAR)
            };
        }
        let [l, a, b] = tint(row, col);
        // Distance to the brick's edge: faces bevel down towards the mortar.
        let d = (yy - m).min(course - 1 - yy).min(xx - m).min(len - 1 - xx) as f32;
        let bevel = (d / 2.0).min(1.0);
        ([l + 6.0 * n, a, b], 0.5 + (0.12 + 0.08 * n) * bevel, class::BRICK)
    })
}

/// The Biot wall stand-in: a 256 × 192 wall with three foliage blobs and a light-mortar corner.
pub fn brick_foliage(seed: u64) -> Relief {
    let p = BrickParams {
        foliage: vec![(60.0, 130.0, 46.0), (190.0, 150.0, 38.0), (150.0, 40.0, 30.0)],
        light_mortar: Some([0.72, 0.0, 1.0, 0.3]),
        ..BrickParams::default()
    };
    brick_wall(256, 192, &p, seed)
}

/// The two patches of the Biot wall: bricks with dark mortar, and foliage over bricks.
pub fn brick_foliage_patches(seed: u64) -> [Relief; 2] {
    let bricks = brick_wall(100, 100, &BrickParams::default(), seed ^ 0x100);
    let foliage = brick_wall(
        100,
        100,
        &BrickParams { foliage: vec![(50.0, 50.0, 44.0)], ..BrickParams::default() },
        seed ^ 0x200,
    );
    [bricks, foliage]
}

/// A plank door: vertical planks with recessed grooves, and raised light studs at `studs`
/// spacing (0 = none).
pub fn door(w: usize, h: usize, studs: usize, seed: u64) -> Relief {
    let grain = noise(w, h, seed ^ 4, 2.0, 3);
    let streak = noise(w, h.div_ceil(12).max(1), seed ^ 5, 2.0, 2);
    let plank = 20;
    build(w, h, |x, y| {
        let n = grain.get(x, y, 0) - 0.5;
        let s = streak.get(x, (y / 12).min(streak.height - 1), 0) - 0.5;
        if let (Some(i), Some(j)) = (x.checked_div(studs), y.checked_div(studs)) {
            let (cx, cy) = (i * studs + studs / 2, j * studs + studs / 2);
            let d = ((x as f32 - cx as f32).powi(2) + (y as f32 - cy as f32).powi(2)).sqrt();
            if d < 5.0 {
                let dome = 1.0 - (d / 5.0).powi(2);
                return ([70.0 + 6.0 * dome, 0.0, 2.0], 0.6 + 0.32 * dome, class::STUD);
            }
        }
        if x % plank < 3 {
            return ([20.0 + 3.0 * n, 8.0, 12.0], 0.15, class::GROOVE);
        }
        ([46.0 + 8.0 * s + 3.0 * n, 12.0, 30.0], 0.5 + 0.04 * n, class::WOOD)
    })
}

/// A chip: blobs of `classes` colours over a grey base, each class at its own depth.
pub fn chip(w: usize, h: usize, classes: usize, seed: u64) -> Relief {
    const TINTS: [[f32; 3]; 6] = [
        [45.0, 55.0, 40.0],
        [40.0, 10.0, -50.0],
        [85.0, -5.0, 75.0],
        [50.0, -45.0, 35.0],
        [92.0, 0.0, 2.0],
        [30.0, 40.0, -30.0],
    ];
    let mut rng = Rng::new(seed);
    let blobs: Vec<(f64, f64, f64, usize)> = discs(w, h, 6 * classes, (8.0, 16.0), &mut rng)
        .into_iter()
        .enumerate()
        .map(|(i, (x, y, r))| (x, y, r, i % classes.min(TINTS.len())))
        .collect();
    let grain = noise(w, h, seed ^ 6, 2.0, 2);
    build(w, h, |x, y| {
        let n = grain.get(x, y, 0) - 0.5;
        let hit = blobs.iter().rev().find(|&&(cx, cy, r, _)| (x as f64 - cx).powi(2) + (y as f64 - cy).powi(2) < r * r);
        match hit {
            Some(&(_, _, _, k)) => {
                let [l, a, b] = TINTS[k];
                ([l + 3.0 * n, a, b], 0.2 + 0.65 * k as f32 / (TINTS.len() - 1) as f32, class::CHIP + k as u8)
            }
            None => ([60.0 + 2.0 * n, 0.0, 0.0], 0.5, class::BASE),
        }
    })
}

/// Rock: brightness follows height (hollows are dark), as on the old stone block.
pub fn block(w: usize, h: usize, seed: u64) -> Relief {
    let z = noise(w, h, seed ^ 7, 14.0, 4);
    let grain = noise(w, h, seed ^ 8, 2.0, 2);
    build(w, h, |x, y| {
        let v = z.get(x, y, 0);
        let n = grain.get(x, y, 0) - 0.5;
        ([30.0 + 45.0 * v + 3.0 * n, 3.0, 10.0 + 4.0 * v], v, class::ROCK)
    })
}

/// A metal plate: a grey base with almond-shaped bumps of the base's own colour.
pub fn plate(w: usize, h: usize, bumps: usize, seed: u64) -> Relief {
    let mut rng = Rng::new(seed);
    let almonds: Vec<(f64, f64, f64)> = (0..bumps)
        .map(|_| {
            (rng.range(12.0, w as f64 - 12.0), rng.range(12.0, h as f64 - 12.0), rng.range(0.0, std::f64::consts::PI))
        })
        .collect();
    let grain = noise(w, h, seed ^ 9, 2.0, 2);
    build(w, h, |x, y| {
        let n = grain.get(x, y, 0) - 0.5;
        let colour = [55.0 + 2.0 * n, 0.0, 2.0];
        for &(cx, cy, t) in &almonds {
            // An almond: the lens of two discs of radius 14 whose centres are 20 px apart.
            let (dx, dy) = (x as f64 - cx, y as f64 - cy);
            let (u, v) = (dx * t.cos() + dy * t.sin(), -dx * t.sin() + dy * t.cos());
            let (r, c) = (14.0, 10.0);
            let inside = (u * u + (v - c).powi(2) < r * r) && (u * u + (v + c).powi(2) < r * r);
            if inside {
                let half = (r * r - c * c).sqrt();
                let bump = (1.0 - 0.5 * (v / half).powi(2) - 0.5 * (u / (r - c)).powi(2)) as f32;
                return (colour, 0.5 + 0.4 * bump.max(0.0), class::BUMP);
            }
        }
        (colour, 0.5, class::BASE)
    })
}
