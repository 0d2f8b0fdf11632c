//! Hand-made appearance data for tests and benches ([references: frasson §4]): plain unified
//! textures, an interstice atlas whose strips carry an alpha band, a junction atlas of stars
//! built with the synthesis's own star geometry, and jittered-grid meshes. Compiled for tests
//! and with the `fixtures` feature only.

use std::f64::consts::{PI, TAU};

use crate::raster::Image;
use crate::synth::appearance::color::lab_of_srgb;
use crate::synth::appearance::dress::geom::{dot, perp, sub};
use crate::synth::appearance::dress::junctions::star_outline;
use crate::synth::appearance::types::{
    AppearanceData, IntersticeAtlas, IntersticeEntry, JunctionAtlas, JunctionEntry, Mesh, Original, Point,
    UnifiedTexture,
};
use crate::synth::rng::Rng;

/// An alpha band across a strip or along a branch: offsets `o` (along the normal) with
/// `|o − center| ≤ half` are mortar (alpha 1, with a one-pixel ramp).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Band {
    pub center: f64,
    pub half: f64,
}

impl Band {
    pub fn alpha(&self, o: f64) -> f32 {
        (self.half - (o - self.center).abs() + 0.5).clamp(0.0, 1.0) as f32
    }
}

/// `n` unified textures of `size²`; texture `i` has a flat colour, plus a faint texel
/// pattern when `pattern`.
pub fn unified(n: usize, size: usize, pattern: bool) -> Vec<UnifiedTexture> {
    (0..n)
        .map(|i| {
            let base = [0.25 + 0.5 * ((i * 37) % 11) as f32 / 11.0, 0.3 + 0.1 * (i % 3) as f32, 0.2 + 0.05 * i as f32];
            let base = base.map(|c| c.min(0.9));
            let image = Image::from_fn(size, size, 3, |x, y, c| {
                let p = if pattern { 0.08 * (((x * 7 + y * 13 + c * 5) % 17) as f32 / 17.0 - 0.5) } else { 0.0 };
                base[c] + p
            });
            UnifiedTexture { image, lab: lab_of_srgb(base) }
        })
        .collect()
}

/// A strip atlas: one strip per length (sorted), stacked with 2 px padding.
pub fn interstice_atlas(
    lengths: &[f64],
    w: f64,
    ext: f64,
    band: Band,
    mortar: [f32; 3],
    stone: [f32; 3],
) -> IntersticeAtlas {
    let mut order: Vec<usize> = (0..lengths.len()).collect();
    order.sort_by(|&a, &b| lengths[a].total_cmp(&lengths[b]).then(a.cmp(&b)));
    let h = (2.0 * w).ceil() as usize;
    let mut entries = Vec::new();
    let mut y = 2;
    let mut width = 4;
    for &i in &order {
        let sw = (lengths[i] + 2.0 * ext).ceil() as usize;
        entries.push(IntersticeEntry { edge: i, length: lengths[i], rect: [2, y, sw, h], lab: lab_of_srgb(mortar) });
        y += h + 2;
        width = width.max(sw + 4);
    }
    let mut image = Image::new(width, y, 4);
    for e in &entries {
        let [x0, y0, sw, sh] = e.rect;
        for j in y0..y0 + sh {
            let o = w - (j - y0) as f64 - 0.5;
            let a = band.alpha(o);
            for i in x0..x0 + sw {
                let c = if a > 0.0 { mortar } else { stone };
                for (ch, &value) in c.iter().enumerate() {
                    image.set(i, j, ch, value);
                }
                image.set(i, j, 3, a);
            }
        }
    }
    IntersticeAtlas { image, entries, half_width: w, extension: ext }
}

/// A star atlas: one star per angle tuple (first branch at `start`), each in its own square
/// cell; alpha is the band along every branch axis; star `i` has colour `colours[i % len]`.
pub fn junction_atlas(
    tuples: &[Vec<f64>],
    w: f64,
    branch_len: f64,
    band: Band,
    colours: &[[f32; 3]],
    stone: [f32; 3],
) -> JunctionAtlas {
    let reach = branch_len.max(3.0 * w) + 2.0;
    let cell = (2.0 * reach).ceil() as usize + 4;
    let cols = (tuples.len() as f64).sqrt().ceil().max(1.0) as usize;
    let rows = tuples.len().div_ceil(cols).max(1);
    let mut image = Image::new(cols * cell, rows * cell, 4);
    let mut entries = Vec::new();
    for (i, angles) in tuples.iter().enumerate() {
        let (cx, cy) = ((i % cols) * cell, (i / cols) * cell);
        let center = [cx as f64 + cell as f64 / 2.0, cy as f64 + cell as f64 / 2.0];
        let start = 0.3 + 0.7 * i as f64;
        let mut directions = Vec::new();
        let mut a = start;
        for t in angles {
            directions.push(a.rem_euclid(TAU));
            a += t;
        }
        // Rotate so the directions are ascending from the smallest.
        let k = (0..directions.len()).min_by(|&x, &y| directions[x].total_cmp(&directions[y])).unwrap_or(0);
        directions.rotate_left(k);
        let mut angles = angles.clone();
        angles.rotate_left(k);
        let lengths = vec![branch_len; directions.len()];
        let (star, _) = star_outline(center, &directions, &lengths, w);
        let colour = colours[i % colours.len()];
        for y in cy..cy + cell {
            for x in cx..cx + cell {
                let p = sub([x as f64 + 0.5, y as f64 + 0.5], center);
                let mut al = 0.0f32;
                for &dir in &directions {
                    let d = [dir.cos(), dir.sin()];
                    let t = dot(p, d);
                    if t >= -w && t <= branch_len + 3.0 {
                        al = al.max(band.alpha(dot(p, perp(d))));
                    }
                }
                let c = if al > 0.0 { colour } else { stone };
                for (ch, &value) in c.iter().enumerate() {
                    image.set(x, y, ch, value);
                }
                image.set(x, y, 3, al);
            }
        }
        entries.push(JunctionEntry { vertex: i, center, star, directions, angles, lab: lab_of_srgb(colour) });
    }
    JunctionAtlas { image, entries, half_width: w, branch_len }
}

/// The angle tuples of a typical junction atlas: bends, T-junctions, Y-junctions, crosses,
/// with small variations.
pub fn typical_tuples() -> Vec<Vec<f64>> {
    let q = PI / 2.0;
    vec![
        vec![PI, PI],
        vec![q, 3.0 * q],
        vec![2.0 * PI / 3.0, 4.0 * PI / 3.0],
        vec![q, q, PI],
        vec![q * 0.9, q * 1.1, PI],
        vec![TAU / 3.0, TAU / 3.0, TAU / 3.0],
        vec![1.9, 2.1, TAU - 4.0],
        vec![q, q, q, q],
        vec![q * 0.8, q * 1.2, q * 0.9, q * 1.1],
    ]
}

/// A jittered `nx × ny` grid of quads of side `cell`, regions in positive raw orientation.
pub fn grid_mesh(nx: usize, ny: usize, cell: f64, jitter: f64, seed: u64) -> Mesh {
    let mut rng = Rng::new(seed);
    let mut vertices = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            let inner = i > 0 && j > 0 && i < nx && j < ny;
            let (dx, dy) = if inner { (rng.range(-jitter, jitter), rng.range(-jitter, jitter)) } else { (0.0, 0.0) };
            vertices.push([i as f64 * cell + dx, j as f64 * cell + dy]);
        }
    }
    let id = |i: usize, j: usize| j * (nx + 1) + i;
    let mut regions = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            regions.push(vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    Mesh { vertices, regions }
}

/// Originals: squares and rectangles of a few sizes, cluster `i % clusters`.
pub fn originals(clusters: usize) -> Vec<Original> {
    let shapes: Vec<Vec<Point>> = vec![
        vec![[0.0, 0.0], [30.0, 0.0], [30.0, 30.0], [0.0, 30.0]],
        vec![[0.0, 0.0], [60.0, 0.0], [60.0, 20.0], [0.0, 20.0]],
        vec![[0.0, 0.0], [40.0, 0.0], [20.0, 30.0]],
        vec![[0.0, 0.0], [50.0, 0.0], [50.0, 50.0], [0.0, 50.0]],
        vec![[0.0, 0.0], [20.0, 0.0], [30.0, 15.0], [20.0, 30.0], [0.0, 30.0], [-10.0, 15.0]],
    ];
    shapes
        .into_iter()
        .enumerate()
        .map(|(i, polygon)| Original { region: i, polygon, cluster: i % clusters.max(1), lab: [50.0, 0.0, 0.0] })
        .collect()
}

/// A complete appearance: `clusters` textures of `size²`, strips of lengths 10–80 px with an
/// off-centre band, the typical stars with a centred, wider band.
pub fn appearance(clusters: usize, size: usize, w: f64) -> AppearanceData {
    let lengths: Vec<f64> = (0..36).map(|i| 10.0 + 2.0 * i as f64).collect();
    AppearanceData {
        unified: unified(clusters, size, true),
        originals: originals(clusters),
        interstices: interstice_atlas(
            &lengths,
            w,
            w,
            Band { center: 1.0, half: 0.35 * w },
            [0.62, 0.6, 0.55],
            [0.3, 0.1, 0.1],
        ),
        junctions: junction_atlas(
            &typical_tuples(),
            w,
            2.0 * w,
            Band { center: 0.0, half: 0.6 * w },
            &[[0.62, 0.6, 0.55], [0.55, 0.58, 0.62], [0.7, 0.66, 0.6]],
            [0.1, 0.3, 0.1],
        ),
    }
}
