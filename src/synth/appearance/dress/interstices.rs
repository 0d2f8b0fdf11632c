//! S6, interstices ([references: frasson §4.2.1]): every target edge takes the atlas strip of
//! the closest original length (binary search on the length-sorted entries) and gets one quad
//! `p − ext·d ± w·n … q + ext·d ± w·n` mapped onto the strip's rectangle; which end of the
//! strip goes where is `random`, `none` or `best_color` (V23).
//!
//! Strip frame (the atlas contract): `u` runs along the edge from the strip's first vertex,
//! starting `ext` before it; the strip's top row is the `+n` side, `n = perp(d)` (the left of
//! `d` in the y-up reading, the mesh's region orientation). A flipped strip is turned by 180°.

use rayon::prelude::*;

use crate::raster::Image;
use crate::synth::appearance::color::{delta_e, lab_of_srgb, mean_lab};
use crate::synth::appearance::dress::geom::{add, dot, mul, norm, perp, sub, Affine};
use crate::synth::appearance::dress::params::{item_seed, DressParams, FlipMode};
use crate::synth::appearance::types::{
    Corner, IntersticeAtlas, IntersticeEntry, Lab, Layer, Mesh, Piece, Point, TextureId,
};
use crate::synth::rng::{derive_seed, Rng};

/// One target edge dressed with an atlas strip.
#[derive(Clone, Debug, PartialEq)]
pub struct Strip {
    /// Index in `mesh_edges(mesh)`.
    pub edge: usize,
    /// The edge's vertices (ascending); `p` is `ends[0]`.
    pub ends: [usize; 2],
    /// Index into `IntersticeAtlas::entries`.
    pub entry: usize,
    pub flipped: bool,
    pub p: Point,
    pub q: Point,
    /// Unit direction `p → q` and its normal `perp(d)`.
    pub dir: Point,
    pub normal: Point,
    pub length: f64,
    pub half_width: f64,
    pub extension: f64,
    /// The strip's texture map of the unclipped quad (target px → atlas px).
    pub to_uv: Affine,
    /// The quad, counter-clockwise in raw coordinates: `−n` side from `p` to `q`, then the
    /// `+n` side back; `None` when matching skipped the interstice (a very short edge).
    pub polygon: Option<[Corner; 4]>,
}

impl Strip {
    /// The piece of this strip (two triangles `(0, 1, 2)`, `(0, 2, 3)`), if it is drawn.
    pub fn piece(&self) -> Option<Piece> {
        let c = self.polygon?;
        Some(Piece {
            layer: Layer::Interstice,
            texture: TextureId::Interstices,
            owner: self.edge,
            triangles: vec![[c[0], c[1], c[2]], [c[0], c[2], c[3]]],
        })
    }
}

/// Index of the entry whose length is closest to `length` (ties: the shorter, then the lower
/// index), by binary search; `None` for an empty atlas.
pub fn closest_length(entries: &[IntersticeEntry], length: f64) -> Option<usize> {
    if entries.is_empty() {
        return None;
    }
    let i = entries.partition_point(|e| e.length < length);
    if i == 0 {
        return Some(0);
    }
    if i == entries.len() {
        // The first entry of the longest length run (ties: lower index).
        let l = entries[i - 1].length;
        return Some(entries.partition_point(|e| e.length < l));
    }
    let (below, above) = (length - entries[i - 1].length, entries[i].length - length);
    if below <= above {
        let l = entries[i - 1].length;
        Some(entries.partition_point(|e| e.length < l))
    } else {
        Some(i)
    }
}

/// The texture map of a quad on `p → q` showing `entry`.
pub fn strip_map(p: Point, q: Point, entry: &IntersticeEntry, atlas: &IntersticeAtlas, flipped: bool) -> Affine {
    let d = mul(sub(q, p), 1.0 / norm(sub(q, p)));
    let n = perp(d);
    let (w, ext) = (atlas.half_width, atlas.extension);
    let total = norm(sub(q, p)) + 2.0 * ext;
    let ku = (entry.length + 2.0 * ext) / total;
    let (x0, y0) = (entry.rect[0] as f64, entry.rect[1] as f64);
    let (dp, np) = (dot(d, p), dot(n, p));
    if !flipped {
        [[ku * d[0], ku * d[1], x0 + ku * (ext - dp)], [-n[0], -n[1], y0 + w + np]]
    } else {
        [[-ku * d[0], -ku * d[1], x0 + ku * (total - ext + dp)], [n[0], n[1], y0 + w - np]]
    }
}

/// The quad of a strip (see [`Strip::polygon`]).
pub fn strip_quad(p: Point, q: Point, w: f64, ext: f64, to_uv: &Affine) -> [Corner; 4] {
    let d = mul(sub(q, p), 1.0 / norm(sub(q, p)));
    let n = perp(d);
    let a = sub(p, mul(d, ext));
    let b = add(q, mul(d, ext));
    let pos = [sub(a, mul(n, w)), sub(b, mul(n, w)), add(b, mul(n, w)), add(a, mul(n, w))];
    pos.map(|pos| Corner { pos, uv: crate::synth::appearance::dress::geom::apply(to_uv, pos) })
}

/// Mean Lab of the mortar pixels (alpha ≥ 0.5, else all) of the first and last quarter of
/// an entry's rectangle.
pub fn end_colours(image: &Image, entry: &IntersticeEntry) -> [Lab; 2] {
    let [x, y, w, h] = entry.rect;
    let quarter = (w / 4).max(1);
    let range = |x0: usize, x1: usize| -> Lab {
        let mut mortar = Vec::new();
        let mut all = Vec::new();
        for j in y..(y + h).min(image.height) {
            for i in x0..x1.min(image.width) {
                let rgb = [image.get(i, j, 0), image.get(i, j, 1), image.get(i, j, 2)];
                let lab = lab_of_srgb(rgb);
                if image.channels < 4 || image.get(i, j, 3) >= 0.5 {
                    mortar.push(lab);
                }
                all.push(lab);
            }
        }
        mean_lab(if mortar.is_empty() { all } else { mortar })
    };
    [range(x, x + quarter), range((x + w).saturating_sub(quarter), x + w)]
}

/// S6: one strip per edge of `edges` (`None` for a zero-length edge or an empty atlas).
pub fn interstices(
    mesh: &Mesh,
    edges: &[[usize; 2]],
    atlas: &IntersticeAtlas,
    params: &DressParams,
    seed: u64,
) -> Vec<Option<Strip>> {
    let base = derive_seed(seed, "dress.interstices", "flip");
    let mut strips: Vec<Option<Strip>> = edges
        .par_iter()
        .enumerate()
        .map(|(e, &[a, b])| {
            let (p, q) = (mesh.vertices[a], mesh.vertices[b]);
            let length = norm(sub(q, p));
            if length <= 1e-12 {
                return None;
            }
            let entry = closest_length(&atlas.entries, length)?;
            let flipped = match params.flip {
                FlipMode::Random => Rng::new(item_seed(base, e)).next_u64() >> 63 == 1,
                FlipMode::None | FlipMode::BestColor => false,
            };
            Some(make_strip(e, [a, b], p, q, entry, flipped, atlas))
        })
        .collect();
    if params.flip == FlipMode::BestColor {
        best_colour_flips(&mut strips, mesh.vertices.len(), atlas);
    }
    strips
}

fn make_strip(
    edge: usize,
    ends: [usize; 2],
    p: Point,
    q: Point,
    entry: usize,
    flipped: bool,
    atlas: &IntersticeAtlas,
) -> Strip {
    let length = norm(sub(q, p));
    let dir = mul(sub(q, p), 1.0 / length);
    let to_uv = strip_map(p, q, &atlas.entries[entry], atlas, flipped);
    Strip {
        edge,
        ends,
        entry,
        flipped,
        p,
        q,
        dir,
        normal: perp(dir),
        length,
        half_width: atlas.half_width,
        extension: atlas.extension,
        to_uv,
        polygon: Some(strip_quad(p, q, atlas.half_width, atlas.extension, &to_uv)),
    }
}

/// Greedy `best_color`: in edge order, the orientation whose end colours are closest (ΔE
/// summed over both ends) to the mean end colour of the strips already placed at each vertex.
fn best_colour_flips(strips: &mut [Option<Strip>], vertices: usize, atlas: &IntersticeAtlas) {
    let mut used: Vec<usize> = strips.iter().flatten().map(|s| s.entry).collect();
    used.sort_unstable();
    used.dedup();
    let colours: Vec<(usize, [Lab; 2])> =
        used.par_iter().map(|&i| (i, end_colours(&atlas.image, &atlas.entries[i]))).collect();
    let colour_of = |i: usize| colours[colours.binary_search_by_key(&i, |c| c.0).expect("used entry")].1;
    let mut sums = vec![([0.0f64; 3], 0usize); vertices];
    for s in strips.iter_mut().flatten() {
        let ends = colour_of(s.entry);
        let cost = |flipped: bool| -> f64 {
            let at = if flipped { [ends[1], ends[0]] } else { ends };
            (0..2)
                .filter_map(|k| {
                    let (sum, n) = sums[s.ends[k]];
                    (n > 0).then(|| delta_e(at[k], [sum[0] / n as f64, sum[1] / n as f64, sum[2] / n as f64]))
                })
                .sum()
        };
        let flipped = cost(true) < cost(false);
        if flipped != s.flipped {
            *s = make_strip(s.edge, s.ends, s.p, s.q, s.entry, flipped, atlas);
        }
        let at = if flipped { [ends[1], ends[0]] } else { ends };
        for k in 0..2 {
            let (sum, n) = &mut sums[s.ends[k]];
            for c in 0..3 {
                sum[c] += at[k][c];
            }
            *n += 1;
        }
    }
}
