//! The visibility-buffer rasteriser: triangles in clip space to, per pixel, the nearest
//! triangle's index.
//!
//! Triangles are binned by their screen bounding box into [`TILE`]² tiles; tiles are rasterised
//! in parallel, each into its own key buffer, and handed to the caller's per-tile function
//! (shading, or reading depths back for a shadow map) while still in cache.
//!
//! - **Coverage.** Vertices are snapped to 1/256 pixel and edge functions evaluated exactly in
//!   i64, incrementally, with the top-left fill rule: a pixel centre on an edge shared by two
//!   triangles belongs to exactly one of them, so meshes are drawn without gaps or overlaps.
//! - **Visibility.** Each sample keeps the smallest key `(!bits(D), triangle)`, where `D` is
//!   the nearness of the module doc of `camera` (positive, larger is nearer, so its bits order
//!   like its value). Depth ties go to the lower triangle index, and the result does not depend
//!   on the order in which triangles arrive, hence not on the rayon thread count.
//! - **Clipping.** A triangle with a vertex behind the near plane or far outside the image (the
//!   guard band, which keeps the fixed-point products within i64) is clipped in clip space
//!   against those planes and drawn as a fan under its own index; intersections are computed
//!   from the edge's endpoints in index order, so neighbours clipped on a shared edge agree.

use glam::Vec4;
use rayon::prelude::*;

/// Tile side in samples.
pub const TILE: usize = 64;
const SUB_BITS: u32 = 8;
const SUB: i64 = 1 << SUB_BITS;
/// The key of a sample no triangle covers.
pub const EMPTY: u64 = u64::MAX;
/// Triangles per binning chunk (fixed, so the chunking does not depend on the thread count).
const CHUNK: usize = 16384;
/// An entry of a tile's list with this bit set indexes the clipped sub-triangles.
const CLIPPED: u32 = 1 << 31;

/// Which triangles to draw by their orientation on screen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cull {
    /// Both sides.
    None,
    /// Skip triangles whose corners run clockwise as seen by the viewer (the back of a mesh
    /// wound counter-clockwise seen from outside).
    Back,
}

/// A vertex on screen: fixed-point position (1/256 pixel, y down) and nearness.
#[derive(Clone, Copy, Debug, Default)]
struct ScreenVertex {
    x: i64,
    y: i64,
    d: f32,
}

/// One tile's result: its sample rectangle and, row-major, the key of each sample.
pub struct Tile<'a> {
    pub x0: usize,
    pub y0: usize,
    pub width: usize,
    pub height: usize,
    pub keys: &'a [u64],
}

/// The triangle index of a key (valid unless the key is [`EMPTY`]).
#[inline]
pub fn key_triangle(key: u64) -> u32 {
    key as u32
}

/// The nearness `D` of a key.
#[inline]
pub fn key_nearness(key: u64) -> f32 {
    f32::from_bits(!((key >> 32) as u32))
}

#[inline]
fn make_key(d: f32, id: u32) -> u64 {
    // `max(0)` also turns a NaN into 0: the farthest value, never a garbage key.
    let bits = d.max(0.0).to_bits();
    ((!bits as u64) << 32) | id as u64
}

/// One binning chunk's result: per tile, the entries in triangle order; and the chunk's clipped
/// sub-triangles with the index of the triangle each came from.
type Bins = (Vec<Vec<u32>>, Vec<(u32, [ScreenVertex; 3])>);

/// Everything binning and rasterising share.
struct Setup {
    width: usize,
    height: usize,
    tiles_x: usize,
    tiles_y: usize,
    /// Guard band: `|cx|, |cy| ≤ guard · w` keeps fixed-point coordinates within ±2^23.
    guard: f32,
    near_w: f32,
    cull: Cull,
}

impl Setup {
    #[inline]
    fn inside(&self, c: Vec4) -> bool {
        c.w >= self.near_w && c.w > 0.0 && c.x.abs() <= self.guard * c.w && c.y.abs() <= self.guard * c.w && c.z >= 0.0
    }

    #[inline]
    fn to_screen(&self, c: Vec4) -> ScreenVertex {
        let inv = 1.0 / c.w;
        let sx = (c.x * inv * 0.5 + 0.5) * self.width as f32;
        let sy = (0.5 - c.y * inv * 0.5) * self.height as f32;
        ScreenVertex { x: (sx * SUB as f32).round() as i64, y: (sy * SUB as f32).round() as i64, d: c.z * inv }
    }

    /// Pixel bounds `(x0, y0, x1, y1)` (inclusive) of the sample centres a triangle may cover,
    /// clamped to the image; `None` when empty.
    #[inline]
    fn pixel_bounds(&self, v: &[ScreenVertex; 3]) -> Option<(i64, i64, i64, i64)> {
        let min_x = v[0].x.min(v[1].x).min(v[2].x);
        let max_x = v[0].x.max(v[1].x).max(v[2].x);
        let min_y = v[0].y.min(v[1].y).min(v[2].y);
        let max_y = v[0].y.max(v[1].y).max(v[2].y);
        let half = SUB / 2;
        let x0 = (min_x - half + SUB - 1).div_euclid(SUB).max(0);
        let y0 = (min_y - half + SUB - 1).div_euclid(SUB).max(0);
        let x1 = (max_x - half).div_euclid(SUB).min(self.width as i64 - 1);
        let y1 = (max_y - half).div_euclid(SUB).min(self.height as i64 - 1);
        (x0 <= x1 && y0 <= y1).then_some((x0, y0, x1, y1))
    }

    /// Signed doubled area on screen, positive for clockwise-on-screen corners (y down).
    #[inline]
    fn area2(v: &[ScreenVertex; 3]) -> i64 {
        (v[1].x - v[0].x) * (v[2].y - v[0].y) - (v[2].x - v[0].x) * (v[1].y - v[0].y)
    }

    /// Whether to draw a triangle of this signed area.
    #[inline]
    fn keeps(&self, area2: i64) -> bool {
        area2 != 0 && (self.cull == Cull::None || area2 < 0)
    }

    /// The sub-triangles of a triangle that crosses a clipping plane (empty if none remains).
    fn clip(&self, idx: [u32; 3], c: [Vec4; 3]) -> Vec<[ScreenVertex; 3]> {
        let g = self.guard;
        let near = self.near_w.max(f32::MIN_POSITIVE);
        let planes: [&dyn Fn(Vec4) -> f32; 6] =
            [&|v| v.w - near, &|v| g * v.w - v.x, &|v| g * v.w + v.x, &|v| g * v.w - v.y, &|v| g * v.w + v.y, &|v| v.z];
        // Polygon corners with a sort key per corner: (lowest, highest) original indices of the
        // edge it lies on, so an intersection is computed the same way from either side.
        let mut poly: Vec<(Vec4, (u32, u32))> = (0..3).map(|i| (c[i], (idx[i], idx[i]))).collect();
        for plane in planes {
            if poly.is_empty() {
                break;
            }
            let mut out = Vec::with_capacity(poly.len() + 1);
            for i in 0..poly.len() {
                let (a, ka) = poly[i];
                let (b, kb) = poly[(i + 1) % poly.len()];
                let (da, db) = (plane(a), plane(b));
                if da >= 0.0 {
                    out.push((a, ka));
                }
                if (da >= 0.0) != (db >= 0.0) {
                    // Interpolate from the endpoint with the smaller key, for symmetry.
                    let (p, q, dp, dq) = if ka <= kb { (a, b, da, db) } else { (b, a, db, da) };
                    let t = dp / (dp - dq);
                    let key = (ka.0.min(kb.0), ka.1.max(kb.1));
                    out.push((p + (q - p) * t, key));
                }
            }
            poly = out;
        }
        if poly.len() < 3 {
            return Vec::new();
        }
        let s: Vec<ScreenVertex> = poly.iter().map(|&(v, _)| self.to_screen(v)).collect();
        (1..s.len() - 1).map(|i| [s[0], s[i], s[i + 1]]).collect()
    }
}

/// Rasterises `triangles` (indices into `clip`, the vertices in clip space) into a
/// `width × height` visibility buffer and calls `per_tile` on each tile; returns the results in
/// tile order (row-major over tiles, see [`tile_grid`]). `near_w` is the smallest `w` drawn.
pub fn rasterize<R: Send>(
    width: usize,
    height: usize,
    clip: &[Vec4],
    triangles: &[[u32; 3]],
    near_w: f32,
    cull: Cull,
    per_tile: impl Fn(&Tile) -> R + Sync,
) -> Vec<R> {
    assert!(width <= 1 << 14 && height <= 1 << 14, "image side above 16384");
    assert!(triangles.len() < CLIPPED as usize, "too many triangles");
    let (tiles_x, tiles_y) = tile_grid(width, height);
    let setup = Setup {
        width,
        height,
        tiles_x,
        tiles_y,
        guard: (1 << 14) as f32 / width.max(height).max(1) as f32,
        near_w,
        cull,
    };
    // Vertices outside the clipping planes keep the default position and are never read: their
    // triangles go through `Setup::clip`.
    let (screen, inside): (Vec<ScreenVertex>, Vec<bool>) = clip
        .par_iter()
        .map(|&c| if setup.inside(c) { (setup.to_screen(c), true) } else { (ScreenVertex::default(), false) })
        .unzip();

    // Binning: per chunk, a list per tile in triangle order, and the chunk's clipped pieces.
    let n_tiles = tiles_x * tiles_y;
    let chunks: Vec<Bins> = triangles
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(ci, chunk)| {
            let mut lists: Vec<Vec<u32>> = vec![Vec::new(); n_tiles];
            let mut clipped = Vec::new();
            for (k, t) in chunk.iter().enumerate() {
                let id = (ci * CHUNK + k) as u32;
                let [a, b, c] = t.map(|i| i as usize);
                if a >= clip.len() || b >= clip.len() || c >= clip.len() {
                    continue;
                }
                if inside[a] && inside[b] && inside[c] {
                    let v = [screen[a], screen[b], screen[c]];
                    if setup.keeps(Setup::area2(&v)) {
                        if let Some(bounds) = setup.pixel_bounds(&v) {
                            bin(&setup, &mut lists, bounds, id);
                        }
                    }
                } else {
                    for v in setup.clip(*t, [clip[a], clip[b], clip[c]]) {
                        if !setup.keeps(Setup::area2(&v)) {
                            continue;
                        }
                        if let Some(bounds) = setup.pixel_bounds(&v) {
                            bin(&setup, &mut lists, bounds, CLIPPED | clipped.len() as u32);
                            clipped.push((id, v));
                        }
                    }
                }
            }
            (lists, clipped)
        })
        .collect();
    let mut offsets = Vec::with_capacity(chunks.len());
    let mut pieces = Vec::new();
    for (_, clipped) in &chunks {
        offsets.push(pieces.len() as u32);
        pieces.extend_from_slice(clipped);
    }

    (0..n_tiles)
        .into_par_iter()
        .map(|t| {
            let (tx, ty) = (t % tiles_x, t / tiles_x);
            let (x0, y0) = (tx * TILE, ty * TILE);
            let (w, h) = (TILE.min(width - x0), TILE.min(height - y0));
            let mut keys = vec![EMPTY; w * h];
            let rect = (x0 as i64, y0 as i64, (x0 + w) as i64 - 1, (y0 + h) as i64 - 1);
            for (ci, (lists, _)) in chunks.iter().enumerate() {
                for &e in &lists[t] {
                    if e & CLIPPED == 0 {
                        let [a, b, c] = triangles[e as usize];
                        let v = [screen[a as usize], screen[b as usize], screen[c as usize]];
                        draw(&setup, &mut keys, w, rect, &v, e);
                    } else {
                        let (id, v) = &pieces[(offsets[ci] + (e & !CLIPPED)) as usize];
                        draw(&setup, &mut keys, w, rect, v, *id);
                    }
                }
            }
            per_tile(&Tile { x0, y0, width: w, height: h, keys: &keys })
        })
        .collect()
}

/// Tiles across and down for an image.
pub fn tile_grid(width: usize, height: usize) -> (usize, usize) {
    (width.div_ceil(TILE).max(1), height.div_ceil(TILE).max(1))
}

#[inline]
fn bin(setup: &Setup, lists: &mut [Vec<u32>], (x0, y0, x1, y1): (i64, i64, i64, i64), entry: u32) {
    let t = TILE as i64;
    let (tx0, ty0, tx1, ty1) = (x0 / t, y0 / t, x1 / t, y1 / t);
    debug_assert!((tx1 as usize) < setup.tiles_x && (ty1 as usize) < setup.tiles_y);
    for ty in ty0..=ty1 {
        for tx in tx0..=tx1 {
            lists[ty as usize * setup.tiles_x + tx as usize].push(entry);
        }
    }
}

/// Whether an edge `a → b` of a triangle with positive [`Setup::area2`] is a top or a left edge
/// (y down).
#[inline]
fn top_left(a: &ScreenVertex, b: &ScreenVertex) -> bool {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    dy < 0 || (dy == 0 && dx > 0)
}

/// Draws one (sub-)triangle into a tile's keys; `rect` is the tile's pixel rectangle
/// (inclusive).
#[inline]
fn draw(setup: &Setup, keys: &mut [u64], stride: usize, rect: (i64, i64, i64, i64), v: &[ScreenVertex; 3], id: u32) {
    let area = Setup::area2(v);
    if !setup.keeps(area) {
        return;
    }
    let v = if area < 0 { [v[0], v[2], v[1]] } else { *v };
    let area = area.abs();
    let Some((bx0, by0, bx1, by1)) = setup.pixel_bounds(&v) else { return };
    let (x0, y0) = (bx0.max(rect.0), by0.max(rect.1));
    let (x1, y1) = (bx1.min(rect.2), by1.min(rect.3));
    if x0 > x1 || y0 > y1 {
        return;
    }
    // Edge i is opposite vertex i: E_i(p) = (b − a) × (p − a) for the edge (a, b).
    let edges = [(1, 2), (2, 0), (0, 1)];
    let (px, py) = (x0 * SUB + SUB / 2, y0 * SUB + SUB / 2);
    let mut row = [0i64; 3];
    let mut step_x = [0i64; 3];
    let mut step_y = [0i64; 3];
    for (i, &(ia, ib)) in edges.iter().enumerate() {
        let (a, b) = (&v[ia], &v[ib]);
        let bias = if top_left(a, b) { 0 } else { -1 };
        row[i] = (b.x - a.x) * (py - a.y) - (b.y - a.y) * (px - a.x) + bias;
        step_x[i] = -(b.y - a.y) * SUB;
        step_y[i] = (b.x - a.x) * SUB;
    }
    let inv = 1.0 / area as f32;
    let (d0, d1, d2) = (v[0].d * inv, v[1].d * inv, v[2].d * inv);
    for y in y0..=y1 {
        let mut e = row;
        let base = (y - rect.1) as usize * stride;
        for x in x0..=x1 {
            if (e[0] | e[1] | e[2]) >= 0 {
                let d = e[0] as f32 * d0 + e[1] as f32 * d1 + e[2] as f32 * d2;
                let key = make_key(d, id);
                let slot = &mut keys[base + (x - rect.0) as usize];
                if key < *slot {
                    *slot = key;
                }
            }
            e[0] += step_x[0];
            e[1] += step_x[1];
            e[2] += step_x[2];
        }
        row[0] += step_y[0];
        row[1] += step_y[1];
        row[2] += step_y[2];
    }
}
