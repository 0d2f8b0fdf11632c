//! The 2-D renderer of a dressing ([references: frasson §4.2.3]): textured triangles drawn in
//! layer order (interiors, interstices, junctions) with atlas alpha, into an RGB image and a
//! one-channel coverage image of any size (`scale` output pixels per mesh pixel).
//!
//! Anti-aliasing is 4×4 supersampled coverage with per-sample compositing: each pixel keeps
//! sixteen transmittances, triangles are visited front to back, a triangle shades once per
//! pixel (bilinear texture sample at the pixel centre through its affine map) and adds
//! `alpha · colour` weighted by the transmittance of the samples it covers.
//!
//! Textures with alpha (the interstice and junction atlases) are filtered **premultiplied**:
//! the four texels are weighted by their own alpha as well as their bilinear weights, so a
//! transparent texel adds nothing, whatever colour it carries. The atlases keep the photo's
//! stone colour (strips) or black (padding, outside a star) under alpha 0; filtering them
//! straight would mix that colour into every texel at the edge of the mortar and show it as a
//! fringe along the strips and stars. Samples exactly on
//! a shared edge belong to one side only (a tie rule antisymmetric in the edge's direction), so
//! pieces that tile the plane leave no seam. Rows are rendered in bands in parallel; each
//! pixel's arithmetic is in a fixed order, so the image is bit-identical for any thread count.

use rayon::prelude::*;

use crate::raster::Image;
use crate::synth::appearance::types::{AppearanceData, Dressing, TextureId};

/// Output size and view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderParams {
    pub width: usize,
    pub height: usize,
    /// Output pixels per mesh pixel.
    pub scale: f64,
    /// RGB shown where nothing covers a sample.
    pub background: [f32; 3],
}

/// The rendered albedo (RGB over the background) and coverage (1 − mean transmittance).
#[derive(Clone, Debug, PartialEq)]
pub struct Rendered {
    pub color: Image,
    pub coverage: Image,
}

const TILE: usize = 8;
const OFF: [f64; 4] = [-0.375, -0.125, 0.125, 0.375];

struct Tri {
    /// Edge functions `a·x + b·y + c`, positive inside.
    edges: [[f64; 3]; 3],
    /// Whether a sample with `E = 0` is inside (antisymmetric in the edge direction).
    tie: [bool; 3],
    verts: [[f64; 2]; 3],
    uv: [[f64; 3]; 2],
    tex: usize,
    rows: [usize; 2],
}

/// Renders `dressing` with the textures of `data`.
pub fn render(dressing: &Dressing, data: &AppearanceData, params: &RenderParams) -> Rendered {
    render_with(
        dressing,
        |t| match t {
            TextureId::Unified(i) => data.unified.get(i).map(|u| &u.image),
            TextureId::Interstices => Some(&data.interstices.image),
            TextureId::Junctions => Some(&data.junctions.image),
        },
        params,
    )
}

/// Renders `dressing`, looking its textures up with `texture` (RGB or RGBA; pieces whose
/// texture is missing or empty are skipped).
pub fn render_with<'a>(
    dressing: &Dressing,
    texture: impl Fn(TextureId) -> Option<&'a Image>,
    params: &RenderParams,
) -> Rendered {
    let (w, h) = (params.width, params.height);
    let mut order: Vec<usize> = (0..dressing.pieces.len()).collect();
    order.sort_by_key(|&i| dressing.pieces[i].layer);
    let mut textures: Vec<(TextureId, &Image)> = Vec::new();
    let mut tris: Vec<Tri> = Vec::new();
    for &pi in &order {
        let piece = &dressing.pieces[pi];
        let Some(img) = texture(piece.texture).filter(|i| i.width > 0 && i.height > 0 && i.channels >= 3) else {
            continue;
        };
        let tex = match textures.iter().position(|t| t.0 == piece.texture) {
            Some(t) => t,
            None => {
                textures.push((piece.texture, img));
                textures.len() - 1
            }
        };
        for t in &piece.triangles {
            let mut v = t.map(|c| [c.pos[0] * params.scale, c.pos[1] * params.scale]);
            let mut uv = t.map(|c| c.uv);
            let area = (v[1][0] - v[0][0]) * (v[2][1] - v[0][1]) - (v[1][1] - v[0][1]) * (v[2][0] - v[0][0]);
            if area.abs() < 1e-12 || !area.is_finite() {
                continue;
            }
            if area < 0.0 {
                v.swap(1, 2);
                uv.swap(1, 2);
            }
            let Some(map) = affine(v, uv) else { continue };
            let mut edges = [[0.0; 3]; 3];
            let mut tie = [false; 3];
            for k in 0..3 {
                let (a, b) = (v[k], v[(k + 1) % 3]);
                let (ea, eb) = (-(b[1] - a[1]), b[0] - a[0]);
                edges[k] = [ea, eb, -(ea * a[0] + eb * a[1])];
                tie[k] = ea > 0.0 || (ea == 0.0 && eb > 0.0);
            }
            let ymin = v.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
            let ymax = v.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max);
            if ymax <= 0.0 || ymin >= h as f64 {
                continue;
            }
            let rows = [ymin.floor().max(0.0) as usize, (ymax.ceil().max(0.0) as usize).min(h)];
            tris.push(Tri { edges, tie, verts: v, uv: map, tex, rows });
        }
    }
    let tiles = h.div_ceil(TILE);
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); tiles];
    for (i, t) in tris.iter().enumerate() {
        for bin in bins.iter_mut().take(t.rows[1].div_ceil(TILE)).skip(t.rows[0] / TILE) {
            bin.push(i as u32);
        }
    }
    let images: Vec<&Image> = textures.iter().map(|t| t.1).collect();
    let bands: Vec<(Vec<[f32; 3]>, Vec<f32>)> = (0..tiles)
        .into_par_iter()
        .map(|tile| render_band(tile, &bins[tile], &tris, &images, w, h, params.background))
        .collect();
    let mut color = Image::new(w, h, 3);
    let mut coverage = Image::new(w, h, 1);
    let plane = w * h;
    for (tile, (rgb, cov)) in bands.into_iter().enumerate() {
        let start = tile * TILE * w;
        for (i, (c, a)) in rgb.iter().zip(&cov).enumerate() {
            for (ch, &value) in c.iter().enumerate() {
                color.data[ch * plane + start + i] = value;
            }
            coverage.data[start + i] = *a;
        }
    }
    Rendered { color, coverage }
}

fn affine(v: [[f64; 2]; 3], uv: [[f64; 2]; 3]) -> Option<[[f64; 3]; 2]> {
    let e1 = [v[1][0] - v[0][0], v[1][1] - v[0][1]];
    let e2 = [v[2][0] - v[0][0], v[2][1] - v[0][1]];
    let det = e1[0] * e2[1] - e1[1] * e2[0];
    if det.abs() < 1e-12 {
        return None;
    }
    let mut a = [[0.0; 3]; 2];
    for r in 0..2 {
        let (f1, f2) = (uv[1][r] - uv[0][r], uv[2][r] - uv[0][r]);
        a[r][0] = (f1 * e2[1] - f2 * e1[1]) / det;
        a[r][1] = (f2 * e1[0] - f1 * e2[0]) / det;
        a[r][2] = uv[0][r] - a[r][0] * v[0][0] - a[r][1] * v[0][1];
    }
    Some(a)
}

/// Bilinear sample (pixel centres at +0.5, edges clamped), premultiplied: the colour times
/// alpha, and alpha (1 without an alpha channel, when the colour is the plain bilinear mean).
/// Each texel's colour is weighted by its alpha (clamped to `[0, 1]`) before the texels are
/// summed, so transparent texels lend no colour to their neighbours.
#[inline]
fn sample(img: &Image, u: f64, v: f64) -> [f32; 4] {
    let x = u - 0.5;
    let y = v - 0.5;
    let floor = |z: f64| {
        let i = z as isize;
        if (i as f64) > z {
            i - 1
        } else {
            i
        }
    };
    let (x0, y0) = (floor(x), floor(y));
    let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
    let (wm, hm) = (img.width as isize - 1, img.height as isize - 1);
    let xa = x0.clamp(0, wm) as usize;
    let xb = (x0 + 1).clamp(0, wm) as usize;
    let ya = y0.clamp(0, hm) as usize;
    let yb = (y0 + 1).clamp(0, hm) as usize;
    let plane = img.width * img.height;
    let (i00, i10, i01, i11) = (ya * img.width + xa, ya * img.width + xb, yb * img.width + xa, yb * img.width + xb);
    let (mut w00, mut w10, mut w01, mut w11) = ((1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy);
    let mut out = [1.0f32; 4];
    if img.channels >= 4 {
        // Premultiply: fold each texel's alpha into its weight.
        let a = &img.data[3 * plane..4 * plane];
        let al = |i: usize| a[i].clamp(0.0, 1.0);
        (w00, w10, w01, w11) = (w00 * al(i00), w10 * al(i10), w01 * al(i01), w11 * al(i11));
        out[3] = w00 + w10 + w01 + w11;
    }
    for (c, o) in out.iter_mut().enumerate().take(3) {
        let p = &img.data[c * plane..(c + 1) * plane];
        *o = p[i00] * w00 + p[i10] * w10 + p[i01] * w01 + p[i11] * w11;
    }
    out
}

/// The x-range (pixel columns) of a triangle within the row band `[y, y + 1)`.
fn span(t: &Tri, y: f64, width: usize) -> Option<[usize; 2]> {
    let (y0, y1) = (y, y + 1.0);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for k in 0..3 {
        let (a, b) = (t.verts[k], t.verts[(k + 1) % 3]);
        if a[1] >= y0 && a[1] <= y1 {
            lo = lo.min(a[0]);
            hi = hi.max(a[0]);
        }
        for yy in [y0, y1] {
            if (a[1] - yy) * (b[1] - yy) < 0.0 {
                let x = a[0] + (b[0] - a[0]) * (yy - a[1]) / (b[1] - a[1]);
                lo = lo.min(x);
                hi = hi.max(x);
            }
        }
    }
    if lo > hi || hi < 0.0 || lo >= width as f64 {
        return None;
    }
    Some([lo.floor().max(0.0) as usize, (hi.ceil().max(0.0) as usize).min(width)])
}

fn render_band(
    tile: usize,
    bin: &[u32],
    tris: &[Tri],
    images: &[&Image],
    w: usize,
    h: usize,
    background: [f32; 3],
) -> (Vec<[f32; 3]>, Vec<f32>) {
    let r0 = tile * TILE;
    let r1 = (r0 + TILE).min(h);
    let n = (r1 - r0) * w;
    // Transmittance: one value while a pixel's samples agree, sixteen once an edge splits it.
    let mut uniform = vec![1.0f32; n];
    let mut slot = vec![u32::MAX; n];
    let mut split: Vec<[f32; 16]> = Vec::new();
    let mut acc = vec![[0.0f32; 3]; n];
    let mut opaque = vec![false; n];
    for &ti in bin.iter().rev() {
        let t = &tris[ti as usize];
        let img = images[t.tex];
        // Per edge: the sixteen sample offsets `a·dx + b·dy` and the full/empty margin.
        let mut offs = [[0.0f64; 16]; 3];
        let mut margin = [0.0f64; 3];
        for k in 0..3 {
            for j in 0..4 {
                for i in 0..4 {
                    offs[k][j * 4 + i] = t.edges[k][0] * OFF[i] + t.edges[k][1] * OFF[j];
                }
            }
            margin[k] = 0.375 * (t.edges[k][0].abs() + t.edges[k][1].abs());
        }
        for y in t.rows[0].max(r0)..t.rows[1].min(r1) {
            let Some([x0, x1]) = span(t, y as f64, w) else { continue };
            let cy = y as f64 + 0.5;
            let row = (y - r0) * w;
            let base = [
                t.edges[0][1] * cy + t.edges[0][2],
                t.edges[1][1] * cy + t.edges[1][2],
                t.edges[2][1] * cy + t.edges[2][2],
            ];
            for x in x0..x1 {
                let p = row + x;
                if opaque[p] {
                    continue;
                }
                let cx = x as f64 + 0.5;
                let ec = [t.edges[0][0] * cx + base[0], t.edges[1][0] * cx + base[1], t.edges[2][0] * cx + base[2]];
                if ec[0] < -margin[0] || ec[1] < -margin[1] || ec[2] < -margin[2] {
                    continue;
                }
                let mask: u32 = if ec[0] > margin[0] && ec[1] > margin[1] && ec[2] > margin[2] {
                    0xFFFF
                } else {
                    let mut m = 0xFFFFu32;
                    for k in 0..3 {
                        let mut mk = 0u32;
                        if t.tie[k] {
                            for (s, o) in offs[k].iter().enumerate() {
                                mk |= ((ec[k] + o >= 0.0) as u32) << s;
                            }
                        } else {
                            for (s, o) in offs[k].iter().enumerate() {
                                mk |= ((ec[k] + o > 0.0) as u32) << s;
                            }
                        }
                        m &= mk;
                    }
                    m
                };
                if mask == 0 {
                    continue;
                }
                let u = t.uv[0][0] * cx + t.uv[0][1] * cy + t.uv[0][2];
                let v = t.uv[1][0] * cx + t.uv[1][1] * cy + t.uv[1][2];
                if slot[p] == u32::MAX && mask == 0xFFFF {
                    let tp = uniform[p];
                    // Premultiplied: `c` is already colour × alpha.
                    let c = sample(img, u, v);
                    let a = c[3].clamp(0.0, 1.0);
                    if a <= 0.0 {
                        continue;
                    }
                    acc[p][0] += tp * c[0];
                    acc[p][1] += tp * c[1];
                    acc[p][2] += tp * c[2];
                    uniform[p] = tp * (1.0 - a);
                    if uniform[p] <= 0.0 {
                        opaque[p] = true;
                    }
                    continue;
                }
                if slot[p] == u32::MAX {
                    slot[p] = split.len() as u32;
                    split.push([uniform[p]; 16]);
                }
                let tr = &mut split[slot[p] as usize];
                let mut bits = [0.0f32; 16];
                let mut tsum = 0.0f32;
                for s in 0..16 {
                    bits[s] = ((mask >> s) & 1) as f32;
                    tsum += tr[s] * bits[s];
                }
                if tsum <= 0.0 {
                    continue;
                }
                let c = sample(img, u, v);
                let a = c[3].clamp(0.0, 1.0);
                if a <= 0.0 {
                    continue;
                }
                let k = tsum * (1.0 / 16.0);
                acc[p][0] += k * c[0];
                acc[p][1] += k * c[1];
                acc[p][2] += k * c[2];
                let mut left = 0.0f32;
                for s in 0..16 {
                    tr[s] *= 1.0 - a * bits[s];
                    left += tr[s];
                }
                if left <= 0.0 {
                    opaque[p] = true;
                }
            }
        }
    }
    let mut rgb = Vec::with_capacity(n);
    let mut cov = Vec::with_capacity(n);
    for p in 0..n {
        let tm =
            if slot[p] == u32::MAX { uniform[p] } else { split[slot[p] as usize].iter().sum::<f32>() * (1.0 / 16.0) };
        rgb.push([acc[p][0] + tm * background[0], acc[p][1] + tm * background[1], acc[p][2] + tm * background[2]]);
        cov.push(1.0 - tm);
    }
    (rgb, cov)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::appearance::types::{Corner, Layer, Piece};

    /// A square of `side` output pixels at the origin showing the texture `uv_per_px` texels
    /// per pixel.
    fn square(side: f64, uv_per_px: f64) -> Piece {
        let p = [[0.0, 0.0], [side, 0.0], [side, side], [0.0, side]];
        let c = p.map(|q| Corner { pos: q, uv: [q[0] * uv_per_px, q[1] * uv_per_px] });
        Piece {
            layer: Layer::Interstice,
            texture: TextureId::Interstices,
            owner: 0,
            triangles: vec![[c[0], c[1], c[2]], [c[0], c[2], c[3]]],
        }
    }

    /// A strip whose transparent texels carry a bright red (as the atlases carry the photo's
    /// stone under alpha 0) lends none of it to the composite: across the edge between
    /// transparent and opaque grey texels, every pixel is the grey over the background by
    /// the filtered alpha. Straight bilinear filtering mixed the red into the edge texels.
    #[test]
    fn transparent_texels_lend_no_colour_to_the_composite() {
        let tex = Image::from_fn(4, 4, 4, |x, _, c| match (x < 2, c) {
            (true, 0) => 1.0,
            (true, _) => 0.0,
            (false, 3) => 1.0,
            (false, _) => 0.5,
        });
        let d = Dressing { pieces: vec![square(32.0, 0.125)], ..Default::default() };
        let params = RenderParams { width: 32, height: 32, scale: 1.0, background: [0.0, 0.0, 1.0] };
        let out = render_with(&d, |_| Some(&tex), &params);
        let mut edge = 0;
        for y in 0..32 {
            for x in 0..32 {
                let a = out.coverage.get(x, y, 0);
                let [r, g, b] = [0, 1, 2].map(|c| out.color.get(x, y, c));
                edge += usize::from(a > 0.01 && a < 0.99);
                assert!((r - g).abs() < 1e-6, "red leaks at ({x}, {y}): {r} {g} {b}, alpha {a}");
                assert!((r - 0.5 * a).abs() < 1e-5, "({x}, {y}): {r} for alpha {a}");
                assert!((b - (0.5 * a + (1.0 - a))).abs() < 1e-5, "({x}, {y}): {b} for alpha {a}");
            }
        }
        assert!(edge >= 32, "the test crosses the alpha edge ({edge} partial pixels)");
    }

    /// Premultiplying changes nothing where the texels are opaque: a fully opaque RGBA texture
    /// renders as its RGB channels (to rounding: its filtered alpha sums four weights).
    #[test]
    fn opaque_rgba_renders_as_its_rgb() {
        let rgb = Image::from_fn(5, 5, 3, |x, y, c| ((x * 7 + y * 3 + c) % 11) as f32 / 10.0);
        let rgba = Image::from_fn(5, 5, 4, |x, y, c| if c == 3 { 1.0 } else { rgb.get(x, y, c) });
        let d = Dressing { pieces: vec![square(20.0, 0.23)], ..Default::default() };
        let params = RenderParams { width: 24, height: 24, scale: 1.0, background: [0.1, 0.2, 0.3] };
        let a = render_with(&d, |_| Some(&rgb), &params);
        let b = render_with(&d, |_| Some(&rgba), &params);
        for (x, y) in a.color.data.iter().zip(&b.color.data).chain(a.coverage.data.iter().zip(&b.coverage.data)) {
            assert!((x - y).abs() < 1e-6, "{x} vs {y}");
        }
    }
}
