//! Seam textures (Frasson Ch. 5, "seam texturing" [references: frasson §5.3.2]): the texture of
//! the strip that zips a seam, made from the two faces' own textures so that each face's edge
//! continues into the gap and the two meet along a minimum-error cut.
//!
//! For a seam between faces `P1` (side A) and `P2` (side B), with `A, D` its ends on `P1` and
//! `B, C` on `P2` after displacement:
//! 1. `d = max(|AB|, |CD|)`, the widest the gap opens, and `d' = reach · d` (`reach` 0.75);
//! 2. on each face, the band of width `d'` along the seam edge is read from the face's texture
//!    through the face's UVs (the band's corners are the paper's `P1 … P4`);
//! 3. each band is unfolded across the edge (mirrored, so the face's edge texels are the seam
//!    texture's border columns and the face's texture continues into the gap);
//! 4. the two unfolded bands overlap by `overlap` (50 %) of their width, and the overlap is
//!    split by the minimum-error boundary cut along the seam, feathered over `feather` texels
//!    (2) — our addition: in rows where the bands differ all across the overlap no cut avoids a
//!    jump, and a hard cut would jump twice as far as a 50/50 cross-fade there;
//! 5. each strip vertex gets a UV in the seam texture: across from its side (A's border column
//!    or B's), along from its position between the seam's ends.
//!
//! With the defaults the two bands span `(2 − 0.5) · 0.75 d = 1.125 d ≥ d`: the gap is covered.
//! A seam whose gap is a few texels or less still gets bands of two texels, which the cut
//! blends as two thin strips. [`pack`] gathers the seam textures of a mesh into one atlas.

use glam::{Vec2, Vec3};

use super::displace::sample_channel;
use crate::raster::Image;
use crate::synth::quilt::min_cut_vertical;

/// Seam texture settings.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SeamTextureParams {
    /// `d' / d`: how far into each face its band reaches, relative to the widest gap.
    pub reach: f32,
    /// The fraction of a band's width the two bands share.
    pub overlap: f32,
    /// Most texels across one band (a gap far wider than the texture's detail is not worth more).
    pub max_band: usize,
    /// Most texels along one seam.
    pub max_length: usize,
    pub blend: SeamBlend,
    /// Texels over which the cut is feathered (0: a hard cut). Where the two bands differ all
    /// across the overlap no cut avoids a jump; a short ramp across the cut spreads it.
    pub feather: usize,
}

impl Default for SeamTextureParams {
    fn default() -> Self {
        Self { reach: 0.75, overlap: 0.5, max_band: 64, max_length: 2048, blend: SeamBlend::MinCut, feather: 2 }
    }
}

/// How the two bands are joined where they overlap.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum SeamBlend {
    /// The minimum-error boundary cut (the method).
    MinCut,
    /// A 50/50 average over the overlap (the naive baseline the cut is measured against).
    CrossFade,
}

/// One face along a seam, undisplaced: what maps a point near the seam edge to the face's UVs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceSide {
    /// The seam edge's ends on this face, in the seam's direction (start, end).
    pub edge: [Vec3; 2],
    pub edge_uv: [Vec2; 2],
    /// A corner of the face off the seam edge, and its UV: with the edge it fixes the face's
    /// (affine) map from 3-D to UV.
    pub apex: Vec3,
    pub apex_uv: Vec2,
}

impl FaceSide {
    /// The unit direction in the face's plane, perpendicular to the edge, into the face.
    pub fn inward(&self) -> Vec3 {
        let along = (self.edge[1] - self.edge[0]).normalize_or_zero();
        let to_apex = self.apex - self.edge[0];
        (to_apex - along * along.dot(to_apex)).normalize_or_zero()
    }

    /// The UV of a 3-D point in the face's plane, by the affine map of the triangle (edge, apex).
    pub fn uv_at(&self, p: Vec3) -> Vec2 {
        let (e1, e2) = (self.edge[1] - self.edge[0], self.apex - self.edge[0]);
        let x = p - self.edge[0];
        let (a11, a12, a22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let det = a11 * a22 - a12 * a12;
        if det.abs() <= f32::EPSILON * a11 * a22 || !det.is_finite() {
            return self.edge_uv[0];
        }
        let (b1, b2) = (x.dot(e1), x.dot(e2));
        let s = (b1 * a22 - b2 * a12) / det;
        let t = (a11 * b2 - a12 * b1) / det;
        self.edge_uv[0] + (self.edge_uv[1] - self.edge_uv[0]) * s + (self.apex_uv - self.edge_uv[0]) * t
    }

    /// Texels of a `width × height` texture per unit of 3-D length along the edge.
    fn density(&self, width: usize, height: usize) -> f32 {
        let texels = ((self.edge_uv[1] - self.edge_uv[0]) * Vec2::new(width as f32, height as f32)).length();
        let len = self.edge[0].distance(self.edge[1]);
        if len > 0.0 && texels.is_finite() {
            texels / len
        } else {
            0.0
        }
    }
}

/// A seam to texture: its two faces and the displaced ends of the gap, `A, D` on side A and
/// `B, C` on side B (`A, B` at the seam's start).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeamQuad {
    pub side_a: FaceSide,
    pub side_b: FaceSide,
    pub a: Vec3,
    pub b: Vec3,
    pub c: Vec3,
    pub d: Vec3,
}

impl SeamQuad {
    /// `d`, the widest the gap opens.
    pub fn gap(&self) -> f32 {
        self.a.distance(self.b).max(self.d.distance(self.c))
    }

    /// Where `p` lies along the seam, 0 at `AB` and 1 at `DC` (clamped).
    pub fn along(&self, p: Vec3) -> f32 {
        let (start, end) = ((self.a + self.b) * 0.5, (self.d + self.c) * 0.5);
        let axis = end - start;
        let len2 = axis.length_squared();
        if len2 > 0.0 {
            ((p - start).dot(axis) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }
}

/// A seam's texture: `columns` across (side A's band from the left, side B's from the right),
/// `rows` along the seam from its start; `cut[r]` is the first column of row `r` taken from B.
#[derive(Clone, Debug, PartialEq)]
pub struct SeamTexture {
    pub image: Image,
    /// Texels across each band, and how many of them the bands share.
    pub band: usize,
    pub overlap: usize,
    /// The band's reach into each face, in 3-D units (`d'`).
    pub reach: f32,
    pub cut: Vec<usize>,
}

impl SeamTexture {
    /// The UV (v up, over this texture alone) of a strip vertex at `along` ∈ [0, 1] on side A
    /// (`on_a`) or B: texel centres of the border columns, so A's vertices read A's edge texels.
    pub fn uv(&self, on_a: bool, along: f32) -> Vec2 {
        let (w, h) = (self.image.width as f32, self.image.height as f32);
        let x = if on_a { 0.5 } else { w - 0.5 };
        let y = 0.5 + along.clamp(0.0, 1.0) * (h - 1.0);
        Vec2::new(x / w, 1.0 - y / h)
    }
}

/// Bilinear lookup of all channels at `uv` (v up), clamped at the borders: seam textures are
/// made for atlases (UVs inside [0, 1]), where the texel beyond a border belongs to nothing.
fn sample(img: &Image, uv: Vec2, out: &mut [f32]) {
    let uv = if uv.is_finite() { uv } else { Vec2::ZERO };
    for (c, o) in out.iter_mut().enumerate() {
        *o = sample_channel(img, uv, c);
    }
}

/// The size of a seam's texture, before any texel is read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layout {
    /// Texels along the seam: the longer of the two faces' edges, in texels (at least 2).
    pub rows: usize,
    /// Texels across each band (at least 2), and how many of them the bands share (at least 1,
    /// at most `band − 1`, so each border column is one face's alone).
    pub band: usize,
    pub overlap: usize,
    /// `d'`, each band's reach into its face, in 3-D units.
    pub reach: f32,
}

impl Layout {
    pub fn columns(&self) -> usize {
        2 * self.band - self.overlap
    }
}

/// The layout of a seam's texture on a `width × height` texture.
pub fn layout(width: usize, height: usize, seam: &SeamQuad, params: &SeamTextureParams) -> Layout {
    let (sa, sb) = (&seam.side_a, &seam.side_b);
    let size = Vec2::new(width as f32, height as f32);
    let edge_texels =
        ((sa.edge_uv[1] - sa.edge_uv[0]) * size).length().max(((sb.edge_uv[1] - sb.edge_uv[0]) * size).length());
    let max_length = params.max_length.max(2);
    let rows = if edge_texels.is_finite() { (edge_texels.round() as usize).clamp(2, max_length) } else { 2 };
    let reach = params.reach.max(0.0) * seam.gap();
    let density = sa.density(width, height).max(sb.density(width, height));
    let band_f = (reach * density).ceil();
    let max_band = params.max_band.max(2);
    let band = if band_f.is_nan() { 2 } else { band_f.clamp(2.0, max_band as f32) as usize };
    // A band capped at `max_band` texels reaches that far, not the whole gap.
    let reach = if density > 0.0 { reach.min(band as f32 / density) } else { reach };
    let reach = if reach.is_finite() { reach } else { 0.0 };
    let overlap = ((params.overlap.clamp(0.0, 1.0) * band as f32).round() as usize).clamp(1, band - 1);
    Layout { rows, band, overlap, reach }
}

/// The texture of one seam, read from `texture` (both faces' UVs index it). `None` for an empty
/// texture.
pub fn seam_texture(texture: &Image, seam: &SeamQuad, params: &SeamTextureParams) -> Option<SeamTexture> {
    let (tw, th, ch) = (texture.width, texture.height, texture.channels);
    if tw == 0 || th == 0 || ch == 0 {
        return None;
    }
    let (sa, sb) = (&seam.side_a, &seam.side_b);
    let Layout { rows, band, overlap, reach } = layout(tw, th, seam, params);
    let columns = 2 * band - overlap;
    // Distance into the face of band column k (0 = the edge).
    let step = reach / (band - 1) as f32;
    let band_of = |side: &FaceSide, r: usize| -> Vec<f32> {
        let t = r as f32 / (rows - 1) as f32;
        let on_edge = side.edge[0].lerp(side.edge[1], t);
        let inward = side.inward();
        let mut out = vec![0.0; band * ch];
        for k in 0..band {
            let uv = side.uv_at(on_edge + inward * (k as f32 * step));
            sample(texture, uv, &mut out[k * ch..(k + 1) * ch]);
        }
        out
    };
    let bands: Vec<(Vec<f32>, Vec<f32>)> = (0..rows).map(|r| (band_of(sa, r), band_of(sb, r))).collect();
    // Column x of the seam texture reads A's band at k = x and B's at k = columns − 1 − x.
    let first_shared = band - overlap;
    let mut err = vec![0.0f64; overlap * rows];
    for (r, (a, b)) in bands.iter().enumerate() {
        for o in 0..overlap {
            let x = first_shared + o;
            let (ka, kb) = (x, columns - 1 - x);
            err[r * overlap + o] = (0..ch).map(|c| f64::from(a[ka * ch + c] - b[kb * ch + c]).powi(2)).sum();
        }
    }
    // The feather must fit in the overlap: every column it mixes has both bands.
    let mut feather = params.feather.min(overlap.saturating_sub(1));
    let cuts = loop {
        let ok = |c: usize| {
            let lo = (c as i64 - feather as i64 - 1).max(0) as usize;
            (lo..=c + feather + 1).all(|x| {
                let wb = weight_b(x, c, feather);
                (wb <= 0.0 || x >= first_shared) && (wb >= 1.0 || x < band)
            })
        };
        let valid: Vec<usize> = (first_shared..band).filter(|&c| ok(c)).collect();
        if !valid.is_empty() || feather == 0 {
            break valid;
        }
        feather -= 1;
    };
    let (lo, hi) = (cuts[0], cuts[cuts.len() - 1] + 1);
    let cut: Vec<usize> = match params.blend {
        SeamBlend::MinCut => {
            let width = hi - lo;
            let sub: Vec<f64> = (0..rows)
                .flat_map(|r| err[r * overlap + lo - first_shared..r * overlap + hi - first_shared].iter().copied())
                .collect();
            min_cut_vertical(&sub, width, rows).0.into_iter().map(|o| lo + o).collect()
        }
        SeamBlend::CrossFade => vec![first_shared; rows],
    };
    let mut image = Image::new(columns, rows, ch);
    for (r, (a, b)) in bands.iter().enumerate() {
        for x in 0..columns {
            for c in 0..ch {
                let from_a = (x < band).then(|| a[x * ch + c]);
                let from_b = (x + band >= columns).then(|| b[(columns - 1 - x) * ch + c]);
                let v = match (from_a, from_b, params.blend) {
                    (Some(va), Some(vb), SeamBlend::CrossFade) => 0.5 * (va + vb),
                    (Some(va), Some(vb), SeamBlend::MinCut) => {
                        let w = weight_b(x, cut[r], feather);
                        va * (1.0 - w) + vb * w
                    }
                    (Some(v), None, _) | (None, Some(v), _) => v,
                    (None, None, _) => unreachable!("the bands cover every column"),
                };
                image.set(x, r, c, v);
            }
        }
    }
    Some(SeamTexture { image, band, overlap, reach, cut })
}

/// The weight of band B at column `x` for a cut at column `cut` (the first column that is mostly
/// B's) feathered over `feather` texels: a ramp of `feather + 1` equal steps centred on the cut,
/// 0 and 1 beyond it (a hard cut for `feather` 0).
fn weight_b(x: usize, cut: usize, feather: usize) -> f32 {
    let t = (x as f32 - cut as f32 + 0.5) / (feather as f32 + 1.0) + 0.5;
    t.clamp(0.0, 1.0)
}

/// Where each seam texture sits in an atlas: its top-left texel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Placement {
    pub x: usize,
    pub y: usize,
}

/// Shelf-packs `textures` (all with `channels` channels) into one atlas at most `max_width` wide
/// (wider only for a texture that is wider alone), in order, each with a one-texel border that
/// repeats its edge texels so bilinear lookups never bleed between neighbours. Returns the atlas
/// and each texture's placement (of its first texel, inside the border).
pub fn pack(textures: &[&Image], channels: usize, max_width: usize) -> (Image, Vec<Placement>) {
    let mut placements = Vec::with_capacity(textures.len());
    let (mut x, mut y, mut shelf, mut width) = (0usize, 0usize, 0usize, 0usize);
    for t in textures {
        let (w, h) = (t.width + 2, t.height + 2);
        if x > 0 && x + w > max_width {
            x = 0;
            y += shelf;
            shelf = 0;
        }
        placements.push(Placement { x: x + 1, y: y + 1 });
        x += w;
        width = width.max(x);
        shelf = shelf.max(h);
    }
    let height = y + shelf;
    let mut atlas = Image::new(width, height, channels);
    for (t, p) in textures.iter().zip(&placements) {
        for yy in 0..t.height + 2 {
            let sy = yy.saturating_sub(1).min(t.height - 1);
            for xx in 0..t.width + 2 {
                let sx = xx.saturating_sub(1).min(t.width - 1);
                for c in 0..channels {
                    atlas.set(p.x - 1 + xx, p.y - 1 + yy, c, t.get(sx, sy, c.min(t.channels - 1)));
                }
            }
        }
    }
    (atlas, placements)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lab(rgb: &[f32]) -> [f32; 3] {
        crate::raster::color::linear_rgb_to_lab([rgb[0], rgb[1], rgb[2]])
    }

    fn delta_e(a: &[f32], b: &[f32]) -> f32 {
        let (p, q) = (lab(a), lab(b));
        ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
    }

    fn px(img: &Image, x: usize, y: usize) -> Vec<f32> {
        (0..img.channels).map(|c| img.get(x, y, c)).collect()
    }

    /// A stone-like texture: cells of different colours with mortar lines and fine grain.
    fn stones(w: usize, h: usize) -> Image {
        let hash = |a: i64, b: i64| {
            let mut z = (a as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (b as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
            z ^= z >> 29;
            z = z.wrapping_mul(0xBF58_476D_1CE4_E5B9);
            ((z >> 40) as f32) / (1u64 << 24) as f32
        };
        Image::from_fn(w, h, 3, |x, y, c| {
            let (row, col) = (y as i64 / 12, (x as i64 + (y as i64 / 12) * 9) / 21);
            let mortar = y % 12 == 0 || (x as i64 + (y as i64 / 12) * 9) % 21 == 0;
            let base = if mortar { 0.55 } else { 0.15 + 0.3 * hash(row, col) };
            let tint = [1.0, 0.85, 0.7][c];
            (base * tint + 0.04 * hash(x as i64 * 7 + c as i64, y as i64)).clamp(0.0, 1.0)
        })
    }

    /// Two faces of a box meeting at the vertical edge x = 1, z = 0: A in the plane z = 0 (inside
    /// towards −x), B in the plane x = 1 (inside towards −z), textured from two regions of one
    /// texture; displacement moved A by `gap` along +z and B along +x, opening the gap.
    fn box_seam(gap: f32) -> SeamQuad {
        box_seam_at(gap, 0.55)
    }

    /// [`box_seam`] with face B's edge from v = `b_v` to `b_v + 0.4`.
    fn box_seam_at(gap: f32, b_v: f32) -> SeamQuad {
        let (e0, e1) = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0));
        let side_a = FaceSide {
            edge: [e0, e1],
            edge_uv: [Vec2::new(0.45, 0.05), Vec2::new(0.45, 0.45)],
            apex: Vec3::new(0.0, 0.0, 0.0),
            apex_uv: Vec2::new(0.05, 0.05),
        };
        let side_b = FaceSide {
            edge: [e0, e1],
            edge_uv: [Vec2::new(0.55, b_v), Vec2::new(0.55, b_v + 0.4)],
            apex: Vec3::new(1.0, 0.0, -1.0),
            apex_uv: Vec2::new(0.95, b_v),
        };
        SeamQuad {
            side_a,
            side_b,
            a: e0 + Vec3::new(0.0, 0.0, gap),
            b: e0 + Vec3::new(gap, 0.0, 0.0),
            c: e1 + Vec3::new(gap, 0.0, 0.0),
            d: e1 + Vec3::new(0.0, 0.0, gap),
        }
    }

    #[test]
    fn defaults_are_three_quarters_reach_and_half_overlap() {
        let p = SeamTextureParams::default();
        assert_eq!((p.reach, p.overlap, p.blend), (0.75, 0.5, SeamBlend::MinCut));
        let tex = stones(256, 256);
        let seam = box_seam(0.1);
        let s = seam_texture(&tex, &seam, &p).unwrap();
        assert!((seam.gap() - 0.1 * 2f32.sqrt()).abs() < 1e-6);
        assert!((s.reach - 0.75 * seam.gap()).abs() < 1e-6);
        // The face's 0.4 UV over one unit of edge is 102.4 texels per unit: 0.106 units of
        // reach are 11 texels, 50 % of which (6) are shared.
        assert_eq!((s.band, s.overlap), (11, 6));
        assert_eq!(s.image.width, 16);
        assert_eq!(s.image.height, 102);
        // Two bands of 0.75 d overlapping by half cover 1.125 d.
        assert!((2.0 - p.overlap) * p.reach >= 1.0);
    }

    #[test]
    fn border_columns_are_the_faces_edge_texels() {
        let tex = stones(256, 256);
        for gap in [0.003, 0.05, 0.3] {
            let seam = box_seam(gap);
            let s = seam_texture(&tex, &seam, &SeamTextureParams::default()).unwrap();
            let (w, h) = (s.image.width, s.image.height);
            let mut worst = 0.0f32;
            for r in 0..h {
                let t = r as f32 / (h - 1) as f32;
                let mut a = [0.0; 3];
                let mut b = [0.0; 3];
                sample(&tex, seam.side_a.edge_uv[0].lerp(seam.side_a.edge_uv[1], t), &mut a);
                sample(&tex, seam.side_b.edge_uv[0].lerp(seam.side_b.edge_uv[1], t), &mut b);
                worst = worst.max(delta_e(&px(&s.image, 0, r), &a)).max(delta_e(&px(&s.image, w - 1, r), &b));
            }
            assert!(worst < 2.0, "gap {gap}: border ΔE {worst}");
            // And the strip's UVs land on those columns' texel centres.
            assert!(s.uv(true, 0.0).distance(Vec2::new(0.5 / w as f32, 1.0 - 0.5 / h as f32)) < 1e-6);
            assert!(s.uv(false, 1.0).distance(Vec2::new(1.0 - 0.5 / w as f32, 0.5 / h as f32)) < 1e-6);
        }
    }

    #[test]
    fn the_band_unfolds_the_face_across_its_edge() {
        // Column k of A's band is the face's texel k·step inside the edge.
        let tex = stones(256, 256);
        let seam = box_seam(0.2);
        let s = seam_texture(&tex, &seam, &SeamTextureParams::default()).unwrap();
        let step = s.reach / (s.band - 1) as f32;
        let r = 40;
        let t = r as f32 / (s.image.height - 1) as f32;
        for k in 0..s.band - s.overlap {
            let p = seam.side_a.edge[0].lerp(seam.side_a.edge[1], t) + seam.side_a.inward() * (k as f32 * step);
            let mut want = [0.0; 3];
            sample(&tex, seam.side_a.uv_at(p), &mut want);
            assert!(delta_e(&px(&s.image, k, r), &want) < 1e-3);
        }
        // The inward direction of side A is −x, of side B −z (the faces' interiors).
        assert!(seam.side_a.inward().distance(-Vec3::X) < 1e-6);
        assert!(seam.side_b.inward().distance(-Vec3::Z) < 1e-6);
        assert!(seam.side_a.uv_at(Vec3::new(0.5, 0.5, 0.0)).distance(Vec2::new(0.25, 0.25)) < 1e-6);
    }

    /// Texel `k` (0 at the edge) of a side's band in row `r` of a seam texture `s`.
    fn band_texel(tex: &Image, side: &FaceSide, s: &SeamTexture, r: usize, k: usize) -> Vec<f32> {
        let t = r as f32 / (s.image.height - 1) as f32;
        let p = side.edge[0].lerp(side.edge[1], t) + side.inward() * (k as f32 * s.reach / (s.band - 1) as f32);
        let mut out = vec![0.0; tex.channels];
        sample(tex, side.uv_at(p), &mut out);
        out
    }

    /// The discontinuity a join introduces, largest and mean over the rows: at each step from
    /// column `x − 1` to `x`, the change of B's weight times the ΔE between the two bands there
    /// (a hard cut switches all of ΔE(A, B) at once, a 50/50 cross-fade half of it at each end,
    /// a feathered cut a fraction at each of its steps). The texture's own edges do not count.
    fn introduced(tex: &Image, seam: &SeamQuad, s: &SeamTexture, weight: impl Fn(usize, usize) -> f32) -> [f32; 2] {
        let columns = s.image.width;
        let (mut worst, mut sum) = (0.0f32, 0.0f32);
        for r in 0..s.image.height {
            let mut row = 0.0f32;
            for x in s.band - s.overlap..=s.band {
                let dw = (weight(r, x) - weight(r, x - 1)).abs();
                let at = if x < s.band { x } else { x - 1 };
                let (a, b) =
                    (band_texel(tex, &seam.side_a, s, r, at), band_texel(tex, &seam.side_b, s, r, columns - 1 - at));
                row = row.max(dw * delta_e(&a, &b));
            }
            worst = worst.max(row);
            sum += row;
        }
        [worst, sum / s.image.height as f32]
    }

    #[test]
    fn the_cut_joins_the_bands_more_smoothly_than_a_cross_fade() {
        // Three layouts of the two faces in the texture: separate islands with courses at the
        // same height, islands with courses offset, and one unwrapped sheet (B's edge is A's).
        let tex = stones(256, 256);
        type Layout = (&'static str, fn(f32) -> SeamQuad);
        let layouts: [Layout; 3] = [
            ("aligned", |g| box_seam_at(g, 0.05)),
            ("offset", |g| box_seam_at(g, 0.55)),
            ("unwrapped", |g| {
                let mut seam = box_seam_at(g, 0.05);
                seam.side_b.edge_uv = seam.side_a.edge_uv;
                seam.side_b.apex_uv = Vec2::new(0.85, 0.05);
                seam
            }),
        ];
        for (name, make) in layouts {
            for gap in [0.05, 0.1, 0.2, 0.3] {
                let seam = make(gap);
                let p = SeamTextureParams::default();
                let cut = seam_texture(&tex, &seam, &p).unwrap();
                let hard = seam_texture(&tex, &seam, &SeamTextureParams { feather: 0, ..p }).unwrap();
                let fade = seam_texture(&tex, &seam, &SeamTextureParams { blend: SeamBlend::CrossFade, ..p }).unwrap();
                let (first, band) = (fade.band - fade.overlap, fade.band);
                let ic = introduced(&tex, &seam, &cut, |r, x| weight_b(x, cut.cut[r], p.feather));
                let ih = introduced(&tex, &seam, &hard, |r, x| weight_b(x, hard.cut[r], 0));
                let ifade = introduced(&tex, &seam, &fade, |_, x| match x {
                    x if x < first => 0.0,
                    x if x < band => 0.5,
                    _ => 1.0,
                });
                eprintln!(
                    "{name} gap {gap}: max, mean ΔE introduced: cut {ic:?}, hard cut {ih:?}, cross-fade {ifade:?}"
                );
                assert!(
                    ic[0] < ifade[0],
                    "{name} gap {gap}: max ΔE across the cut {} vs cross-fade {}",
                    ic[0],
                    ifade[0]
                );
                assert!(ic[1] < ifade[1]);
                // The image is what the weights say.
                let (r, x) = (cut.image.height / 2, cut.cut[cut.image.height / 2]);
                let (a, b) = (
                    band_texel(&tex, &seam.side_a, &cut, r, x),
                    band_texel(&tex, &seam.side_b, &cut, r, cut.image.width - 1 - x),
                );
                let w = weight_b(x, x, p.feather);
                for c in 0..3 {
                    assert!((cut.image.get(x, r, c) - (a[c] * (1.0 - w) + b[c] * w)).abs() < 1e-4);
                }
            }
        }
    }

    #[test]
    fn the_cut_stays_in_the_overlap_and_is_connected() {
        let tex = stones(128, 128);
        let s = seam_texture(&tex, &box_seam(0.25), &SeamTextureParams::default()).unwrap();
        let first = s.band - s.overlap;
        assert!(s.cut.iter().all(|&c| c >= first && c < s.band));
        assert!(s.cut.windows(2).all(|w| w[0].abs_diff(w[1]) <= 1));
    }

    #[test]
    fn hostile_seams_stay_bounded() {
        let tex = stones(64, 64);
        let mut seam = box_seam(0.1);
        // A gap far wider than the face: the band is capped.
        seam.c = Vec3::splat(1e30);
        let s = seam_texture(&tex, &seam, &SeamTextureParams::default()).unwrap();
        assert_eq!(s.band, 64);
        // A collapsed edge and a non-finite one: two texels, no panic.
        let mut flat = box_seam(0.0);
        flat.side_a.edge[1] = flat.side_a.edge[0];
        flat.side_a.edge_uv[1] = flat.side_a.edge_uv[0];
        flat.side_b.edge_uv[1] = Vec2::NAN;
        let s = seam_texture(&tex, &flat, &SeamTextureParams::default()).unwrap();
        assert_eq!((s.band, s.image.height), (2, 2));
        assert!(s.image.data.iter().all(|v| v.is_finite()));
        assert!(seam_texture(&Image::new(0, 0, 3), &box_seam(0.1), &SeamTextureParams::default()).is_none());
    }

    #[test]
    fn packing_keeps_textures_apart_with_repeated_borders() {
        let a = Image::from_fn(3, 5, 1, |x, y, _| (x + 10 * y) as f32);
        let b = Image::from_fn(4, 2, 1, |_, _, _| 100.0);
        let c = Image::from_fn(2, 2, 1, |_, _, _| 200.0);
        let (atlas, at) = pack(&[&a, &b, &c], 1, 12);
        assert_eq!(at, vec![Placement { x: 1, y: 1 }, Placement { x: 6, y: 1 }, Placement { x: 1, y: 8 }]);
        assert_eq!((atlas.width, atlas.height), (11, 11));
        for y in 0..5 {
            for x in 0..3 {
                assert_eq!(atlas.get(1 + x, 1 + y, 0), a.get(x, y, 0));
            }
        }
        assert_eq!(atlas.get(0, 0, 0), a.get(0, 0, 0), "corner border repeats the corner");
        assert_eq!(atlas.get(4, 6, 0), a.get(2, 4, 0));
        assert_eq!(atlas.get(5, 0, 0), 100.0);
        assert_eq!(atlas.get(0, 10, 0), 200.0);
    }
}
