//! S5, region interiors ([references: frasson §4.1.3]): each target region takes a cluster
//! (closest original shape, random or sticky), and its polygon is projected by translation
//! only at a seeded random offset into that cluster's unified texture, one texel per
//! structure pixel times `texel_scale` (V21).

use rayon::prelude::*;

use crate::synth::appearance::dress::geom::triangulate;
use crate::synth::appearance::dress::params::{item_seed, ClusterChoice, DressHints, DressParams};
use crate::synth::appearance::types::{AppearanceData, Corner, Layer, Mesh, Piece, Point, TextureId};
use crate::synth::rng::{derive_seed, Rng};
use crate::synth::structure::shapes::associate::associate;

/// The result of S5.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Interiors {
    /// One piece per dressed region, in region order.
    pub pieces: Vec<Piece>,
    /// Per region: the unified texture it samples (`None` when not dressed).
    pub clusters: Vec<Option<usize>>,
    /// Per region: the texture position of its bounding box's top-left corner.
    pub offsets: Vec<Option<Point>>,
    pub warnings: Vec<String>,
}

/// The mesh's region polygons.
pub fn region_polygons(mesh: &Mesh) -> Vec<Vec<Point>> {
    mesh.regions.iter().map(|r| r.iter().map(|&i| mesh.vertices[i]).collect()).collect()
}

/// Chooses each region's cluster (before any size fallback).
pub fn choose_clusters(
    polys: &[Vec<Point>],
    data: &AppearanceData,
    params: &DressParams,
    seed: u64,
    hints: &DressHints,
    warnings: &mut Vec<String>,
) -> Vec<Option<usize>> {
    let n = polys.len();
    let k = data.unified.len();
    if k == 0 {
        return vec![None; n];
    }
    let base = derive_seed(seed, "dress.interiors", "cluster");
    let random = |r: usize| Rng::new(item_seed(base, r)).below(k);
    let known = |r: usize| -> Option<usize> {
        let o = hints.associations?.get(r).copied().flatten()?;
        data.originals.get(o).map(|o| o.cluster)
    };
    let mut out: Vec<Option<usize>> = vec![None; n];
    let mut search = Vec::new();
    for (r, slot) in out.iter_mut().enumerate() {
        let previous = hints.previous_clusters.and_then(|p| p.get(r).copied().flatten());
        *slot = match params.cluster_choice {
            ClusterChoice::Random => Some(random(r)),
            ClusterChoice::Sticky if previous.is_some() => previous,
            _ => known(r),
        };
        if slot.is_none() {
            search.push(r);
        }
    }
    if !search.is_empty() {
        let originals: Vec<Vec<Point>> = data.originals.iter().map(|o| o.polygon.clone()).collect();
        let generated: Vec<Vec<Point>> = search.iter().map(|&r| polys[r].clone()).collect();
        let found = if originals.is_empty() {
            vec![None; search.len()]
        } else {
            associate(&generated, &originals, &params.associate).associations
        };
        let mut failed = 0;
        for (&r, a) in search.iter().zip(found) {
            out[r] = match a {
                Some(a) => Some(data.originals[a.original].cluster),
                None => {
                    failed += 1;
                    Some(random(r))
                }
            };
        }
        if failed > 0 {
            warnings.push(format!("{failed} regions had no closest original: random cluster"));
        }
    }
    let mut wrapped = 0;
    for c in out.iter_mut().flatten() {
        if *c >= k {
            *c %= k;
            wrapped += 1;
        }
    }
    if wrapped > 0 {
        warnings.push(format!("{wrapped} regions named a cluster past the {k} unified textures: wrapped"));
    }
    out
}

/// S5: one textured polygon per region.
pub fn interiors(mesh: &Mesh, data: &AppearanceData, params: &DressParams, seed: u64, hints: &DressHints) -> Interiors {
    let polys = region_polygons(mesh);
    let mut warnings = Vec::new();
    if data.unified.is_empty() {
        warnings.push("no unified texture: region interiors are not dressed".to_string());
        return Interiors {
            pieces: Vec::new(),
            clusters: vec![None; polys.len()],
            offsets: vec![None; polys.len()],
            warnings,
        };
    }
    let chosen = choose_clusters(&polys, data, params, seed, hints, &mut warnings);
    let s = params.texel_scale;
    let largest = (0..data.unified.len())
        .max_by_key(|&i| (data.unified[i].image.width * data.unified[i].image.height, std::cmp::Reverse(i)))
        .unwrap_or(0);
    let base = derive_seed(seed, "dress.interiors", "offset");
    // (piece, texture, offset, fallback: 0 none, 1 largest texture, 2 clamped)
    let placed: Vec<Option<(Piece, usize, Point, u8)>> = polys
        .par_iter()
        .enumerate()
        .map(|(r, poly)| {
            let mut t = chosen[r]?;
            if poly.len() < 3 {
                return None;
            }
            let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
            for p in poly {
                for c in 0..2 {
                    lo[c] = lo[c].min(p[c]);
                    hi[c] = hi[c].max(p[c]);
                }
            }
            let size = [(hi[0] - lo[0]) * s, (hi[1] - lo[1]) * s];
            let fits = |t: usize| {
                let im = &data.unified[t].image;
                size[0] <= im.width as f64 && size[1] <= im.height as f64
            };
            let mut fallback = 0u8;
            if !fits(t) {
                t = largest;
                fallback = if fits(t) { 1 } else { 2 };
            }
            let im = &data.unified[t].image;
            let dims = [im.width as f64, im.height as f64];
            let mut rng = Rng::new(item_seed(base, r));
            let mut off = [0.0; 2];
            for c in 0..2 {
                let room = dims[c] - size[c];
                let u = rng.next_f64();
                off[c] = if room > 0.0 { (u * room).min(room) } else { 0.0 };
            }
            let uv = |p: &Point| -> Point {
                let mut q = [0.0; 2];
                for c in 0..2 {
                    q[c] = ((p[c] - lo[c]) * s + off[c]).clamp(0.0, dims[c]);
                }
                q
            };
            let triangles = triangulate(poly)
                .into_iter()
                .map(|tri| tri.map(|i| Corner { pos: poly[i], uv: uv(&poly[i]) }))
                .collect();
            let piece = Piece { layer: Layer::Interior, texture: TextureId::Unified(t), owner: r, triangles };
            Some((piece, t, off, fallback))
        })
        .collect();
    let mut out = Interiors {
        pieces: Vec::with_capacity(polys.len()),
        clusters: vec![None; polys.len()],
        offsets: vec![None; polys.len()],
        warnings,
    };
    let (mut larger, mut clamped) = (0, 0);
    for (r, p) in placed.into_iter().enumerate() {
        if let Some((piece, t, off, fallback)) = p {
            match fallback {
                1 => larger += 1,
                2 => clamped += 1,
                _ => {}
            }
            out.pieces.push(piece);
            out.clusters[r] = Some(t);
            out.offsets[r] = Some(off);
        }
    }
    if larger > 0 {
        out.warnings.push(format!("{larger} regions larger than their cluster's texture: used the largest texture"));
    }
    if clamped > 0 {
        out.warnings.push(format!("{clamped} regions larger than every unified texture: texture coordinates clamped"));
    }
    out
}
