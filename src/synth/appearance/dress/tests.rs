//! Tests of S5–S8 and the renderer against the checklist (F23–F27), on hand-made appearance
//! data ([references: frasson §4.2.3]).

use std::f64::consts::{PI, TAU};

use crate::synth::appearance::color::{delta_e, lab_of_srgb};
use crate::synth::appearance::dress::geom::{add, dot, fan_is_valid, is_simple, mul, norm, signed_area, sub};
use crate::synth::appearance::dress::interiors::region_polygons;
use crate::synth::appearance::dress::interstices::{closest_length, interstices};
use crate::synth::appearance::dress::junctions::{atlas_branch, pick_by_colour, variant_tuple, Hit, JunctionIndex};
use crate::synth::appearance::dress::matching::{extent, relative_coords, MatchKind};
use crate::synth::appearance::dress::params::{ClusterChoice, DressHints, DressParams, FlipMode};
use crate::synth::appearance::dress::testkit::{
    appearance, grid_mesh, interstice_atlas, junction_atlas, unified, Band,
};
use crate::synth::appearance::dress::{dress, dress_stages, Stages};
use crate::synth::appearance::render::{render, RenderParams};
use crate::synth::appearance::types::{AppearanceData, Corner, Dressing, Layer, Mesh, Piece, TextureId};
use crate::synth::rng::Rng;
use crate::synth::structure::render::mesh_edges;
use crate::synth::structure::shapes::associate::associate;

const W: f64 = 6.0;

fn uv_area(piece: &Piece) -> f64 {
    piece.triangles.iter().map(|t| signed_area(&t.map(|c| c.uv)).abs()).sum()
}

fn pos_area(piece: &Piece) -> f64 {
    piece.triangles.iter().map(|t| signed_area(&t.map(|c| c.pos)).abs()).sum()
}

// ---- F23 interiors ---------------------------------------------------------------------------

#[test]
fn f23_interior_uvs_lie_inside_the_texture_at_one_texel_per_pixel() {
    let mesh = grid_mesh(8, 6, 30.0, 6.0, 3);
    let data = appearance(3, 128, W);
    for scale in [1.0, 2.0] {
        let params = DressParams { texel_scale: scale, ..DressParams::default() };
        let d = dress(&mesh, &data, &params, 11, &DressHints::default());
        let polys = region_polygons(&mesh);
        let interiors: Vec<&Piece> = d.pieces.iter().filter(|p| p.layer == Layer::Interior).collect();
        assert_eq!(interiors.len(), mesh.regions.len());
        for p in interiors {
            let TextureId::Unified(t) = p.texture else { panic!("interior texture") };
            assert_eq!(d.clusters[p.owner], Some(t));
            let im = &data.unified[t].image;
            for c in p.triangles.iter().flatten() {
                let (u, v) = (c.uv[0] / im.width as f64, c.uv[1] / im.height as f64);
                assert!((0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v), "uv {u} {v}");
            }
            let area = signed_area(&polys[p.owner]).abs();
            let texels = uv_area(p) / (scale * scale);
            assert!((texels - area).abs() <= 0.01 * area, "texels {texels} vs area {area}");
            assert!((pos_area(p) - area).abs() <= 1e-6 * area, "triangulation covers the region");
        }
    }
}

#[test]
fn f23_concave_regions_triangulate_to_their_area() {
    let mesh = Mesh {
        vertices: vec![[0.0, 0.0], [40.0, 0.0], [40.0, 40.0], [20.0, 15.0], [0.0, 40.0], [20.0, 0.0]],
        regions: vec![vec![0, 5, 1, 2, 3, 4]],
    };
    let data = appearance(1, 128, W);
    let d = dress(
        &mesh,
        &data,
        &DressParams { cluster_choice: ClusterChoice::Random, ..Default::default() },
        1,
        &DressHints::default(),
    );
    let p = &d.pieces[0];
    let area = signed_area(&region_polygons(&mesh)[0]).abs();
    assert!((pos_area(p) - area).abs() < 1e-9);
    assert!(p.triangles.iter().all(|t| signed_area(&t.map(|c| c.pos)) > 0.0));
}

#[test]
fn f23_clusters_follow_the_mode() {
    let mesh = grid_mesh(6, 5, 30.0, 8.0, 5);
    let data = appearance(3, 128, W);
    let polys = region_polygons(&mesh);
    let originals: Vec<_> = data.originals.iter().map(|o| o.polygon.clone()).collect();
    let assoc = associate(&polys, &originals, &DressParams::default().associate);
    // Closest shape, searched.
    let d = dress(&mesh, &data, &DressParams::default(), 2, &DressHints::default());
    for (r, a) in assoc.associations.iter().enumerate() {
        assert_eq!(d.clusters[r], Some(data.originals[a.as_ref().expect("assoc").original].cluster));
    }
    // Closest shape, known associations (here: region r ↦ original r % 5).
    let known: Vec<Option<usize>> = (0..polys.len()).map(|r| Some(r % data.originals.len())).collect();
    let hints = DressHints { associations: Some(&known), previous_clusters: None };
    let d = dress(&mesh, &data, &DressParams::default(), 2, &hints);
    for r in 0..polys.len() {
        assert_eq!(d.clusters[r], Some(data.originals[r % data.originals.len()].cluster));
    }
    // Random: in range, seeded, not constant.
    let p = DressParams { cluster_choice: ClusterChoice::Random, ..Default::default() };
    let a = dress(&mesh, &data, &p, 9, &DressHints::default());
    assert!(a.clusters.iter().all(|c| c.is_some_and(|c| c < 3)));
    assert!(a.clusters.iter().any(|&c| c != a.clusters[0]));
    assert_eq!(a, dress(&mesh, &data, &p, 9, &DressHints::default()));
    // Sticky: the previous cluster where given, else the closest shape.
    let previous: Vec<Option<usize>> = (0..polys.len()).map(|r| (r % 2 == 0).then_some(2 - r % 3)).collect();
    let p = DressParams { cluster_choice: ClusterChoice::Sticky, ..Default::default() };
    let s = dress(&mesh, &data, &p, 2, &DressHints { associations: None, previous_clusters: Some(&previous) });
    for (r, prev) in previous.iter().enumerate() {
        let want = prev.unwrap_or(data.originals[assoc.associations[r].as_ref().expect("a").original].cluster);
        assert_eq!(s.clusters[r], Some(want));
    }
}

#[test]
fn f23_offsets_are_reproducible_from_the_seed() {
    let mesh = grid_mesh(5, 5, 30.0, 5.0, 1);
    let data = appearance(2, 128, W);
    let p = DressParams::default();
    let a = dress_stages(&mesh, &data, &p, 4, &DressHints::default());
    let b = dress_stages(&mesh, &data, &p, 4, &DressHints::default());
    let c = dress_stages(&mesh, &data, &p, 5, &DressHints::default());
    assert_eq!(a.interiors.offsets, b.interiors.offsets);
    assert_eq!(a.dressing, b.dressing);
    assert_ne!(a.interiors.offsets, c.interiors.offsets);
}

#[test]
fn f23_a_region_larger_than_every_texture_is_clamped_with_a_warning() {
    let mesh = grid_mesh(1, 1, 300.0, 0.0, 1);
    let data = appearance(2, 128, W);
    let d = dress(&mesh, &data, &DressParams::default(), 1, &DressHints::default());
    assert!(d.warnings.iter().any(|w| w.contains("larger than every unified texture")), "{:?}", d.warnings);
    for c in d.pieces[0].triangles.iter().flatten() {
        assert!(c.uv[0] >= 0.0 && c.uv[0] <= 128.0 && c.uv[1] >= 0.0 && c.uv[1] <= 128.0);
    }
}

// ---- F24 memory ------------------------------------------------------------------------------

fn texture_bytes(data: &AppearanceData) -> usize {
    let img = |i: &crate::raster::Image| i.data.len() * std::mem::size_of::<f32>();
    data.unified.iter().map(|u| img(&u.image)).sum::<usize>()
        + img(&data.interstices.image)
        + img(&data.junctions.image)
}

fn textures_used(d: &Dressing) -> std::collections::BTreeSet<TextureId> {
    d.pieces.iter().map(|p| p.texture).collect()
}

#[test]
fn f24_texture_memory_does_not_grow_with_the_target() {
    let data = appearance(4, 128, W);
    let small = grid_mesh(10, 8, 32.0, 5.0, 2);
    let large = grid_mesh(20, 16, 32.0, 5.0, 2);
    let bytes = texture_bytes(&data);
    let ds = dress(&small, &data, &DressParams::default(), 3, &DressHints::default());
    let dl = dress(&large, &data, &DressParams::default(), 3, &DressHints::default());
    assert_eq!(texture_bytes(&data), bytes);
    let ratio = dl.pieces.len() as f64 / ds.pieces.len() as f64;
    assert!((3.5..=4.5).contains(&ratio), "piece ratio {ratio}");
    for d in [&ds, &dl] {
        let used = textures_used(d);
        assert!(used.len() <= 12);
        for t in used {
            match t {
                TextureId::Unified(i) => assert!(i < data.unified.len()),
                TextureId::Interstices | TextureId::Junctions => {}
            }
        }
        // Only polygons and texture coordinates: the serialised dressing is pieces of
        // corners, the cluster list and words.
        let json = serde_json::to_value(d).expect("json");
        let keys: Vec<&String> = json.as_object().expect("object").keys().collect();
        assert_eq!(keys, ["clusters", "pieces", "warnings"]);
    }
}

// ---- F25 interstices -------------------------------------------------------------------------

#[test]
fn f25_length_lookup_equals_brute_force() {
    let data = appearance(1, 64, W);
    let entries = &data.interstices.entries;
    let mut rng = Rng::new(8);
    for _ in 0..1000 {
        let l = rng.range(0.0, 120.0);
        let got = closest_length(entries, l).expect("entries");
        let best = (0..entries.len())
            .min_by(|&a, &b| (entries[a].length - l).abs().total_cmp(&(entries[b].length - l).abs()).then(a.cmp(&b)))
            .expect("entries");
        assert_eq!((entries[got].length - l).abs(), (entries[best].length - l).abs());
    }
}

#[test]
fn f25_every_edge_gets_one_quad_of_half_width_w() {
    let mesh = grid_mesh(7, 5, 30.0, 6.0, 4);
    let data = appearance(2, 128, W);
    let p = DressParams { match_contours: false, ..Default::default() };
    let d = dress(&mesh, &data, &p, 1, &DressHints::default());
    let edges = mesh_edges(&mesh);
    let quads: Vec<&Piece> = d.pieces.iter().filter(|p| p.layer == Layer::Interstice).collect();
    assert_eq!(quads.len(), edges.len());
    let mut seen = vec![0; edges.len()];
    for q in quads {
        seen[q.owner] += 1;
        let [a, b] = edges[q.owner];
        let (pa, pb) = (mesh.vertices[a], mesh.vertices[b]);
        let d = mul(sub(pb, pa), 1.0 / norm(sub(pb, pa)));
        for c in q.triangles.iter().flatten() {
            let off = (d[0] * (c.pos[1] - pa[1]) - d[1] * (c.pos[0] - pa[0])).abs();
            assert!((off - W).abs() < 1e-9, "half-width {off}");
        }
    }
    assert!(seen.iter().all(|&n| n == 1));
    // Flip modes are seeded / fixed.
    for flip in [FlipMode::None, FlipMode::BestColor, FlipMode::Random] {
        let p = DressParams { flip, ..Default::default() };
        let a = interstices(&mesh, &edges, &data.interstices, &p, 3);
        assert_eq!(a, interstices(&mesh, &edges, &data.interstices, &p, 3));
        if flip == FlipMode::None {
            assert!(a.iter().flatten().all(|s| !s.flipped));
        }
        if flip == FlipMode::Random {
            assert!(a.iter().flatten().any(|s| s.flipped) && a.iter().flatten().any(|s| !s.flipped));
        }
    }
}

// ---- F26 junction search ---------------------------------------------------------------------

#[test]
fn f26_the_thesis_tuple_has_six_variants() {
    let a = [175f64, 85.0, 100.0].map(f64::to_radians);
    let mut got: Vec<Vec<i64>> = Vec::new();
    for mirror in [false, true] {
        for shift in 0..3 {
            got.push(variant_tuple(&a, shift, mirror).iter().map(|x| x.to_degrees().round() as i64).collect());
        }
    }
    got.sort();
    let mut want = vec![
        vec![175, 85, 100],
        vec![100, 85, 175],
        vec![85, 100, 175],
        vec![175, 100, 85],
        vec![100, 175, 85],
        vec![85, 175, 100],
    ];
    want.sort();
    assert_eq!(got, want);
}

#[test]
fn f26_rotated_and_mirrored_queries_find_their_star_at_distance_zero() {
    let tuples = vec![
        vec![1.0, 2.0, TAU - 3.0],
        vec![0.7, 1.5, 2.0, TAU - 4.2],
        vec![2.5, TAU - 2.5],
        vec![1.2, 1.9, TAU - 3.1],
    ];
    let atlas = junction_atlas(&tuples, W, 2.0 * W, Band { center: 0.0, half: 3.0 }, &[[0.5, 0.5, 0.5]], [0.0; 3]);
    let index = JunctionIndex::new(&atlas);
    // 2v tuples per star, fewer only for duplicates (a 2-tuple's mirror is one of its shifts).
    assert_eq!((index.len(2), index.len(3), index.len(4)), (2, 12, 8));
    for (i, e) in atlas.entries.iter().enumerate() {
        let v = e.angles.len();
        for mirror in [false, true] {
            for shift in 0..v {
                let q = variant_tuple(&e.angles, shift, mirror);
                let hits = index.query(&q, 5);
                assert!(hits.windows(2).all(|w| w[0].distance <= w[1].distance));
                let h = hits[0];
                assert_eq!(h.entry, i);
                assert!(h.distance < 1e-12);
                assert_eq!(variant_tuple(&e.angles, h.shift, h.mirror), q);
                if v >= 3 {
                    assert_eq!((h.shift, h.mirror), (shift, mirror), "asymmetric tuples have one variant");
                }
            }
        }
    }
}

#[test]
fn f26_a_generated_copy_of_an_atlas_star_maps_rigidly() {
    // Target vertex whose branches are an atlas star's, mirrored and rotated: its texture map
    // must be an isometry (pairwise distances kept).
    let tuples = vec![vec![1.0, 2.0, TAU - 3.0]];
    let atlas = junction_atlas(&tuples, W, 2.0 * W, Band { center: 0.0, half: 3.0 }, &[[0.5, 0.5, 0.5]], [0.0; 3]);
    let e = &atlas.entries[0];
    let c = [100.0, 100.0];
    let rot = 0.8;
    let dirs: Vec<f64> = e.directions.iter().map(|d| (rot - d).rem_euclid(TAU)).collect();
    let mut vertices = vec![c];
    for d in &dirs {
        vertices.push(add(c, [40.0 * d.cos(), 40.0 * d.sin()]));
    }
    // One triangle fan region per pair of consecutive branches is enough to give the edges.
    let mut order: Vec<usize> = (1..=3).collect();
    order.sort_by(|&a, &b| dirs[a - 1].total_cmp(&dirs[b - 1]));
    let regions = (0..3).map(|k| vec![0, order[k], order[(k + 1) % 3]]).collect();
    let mesh = Mesh { vertices, regions };
    let data = AppearanceData {
        unified: unified(1, 64, false),
        originals: Vec::new(),
        interstices: interstice_atlas(&[40.0], W, W, Band { center: 0.0, half: 2.0 }, [0.5; 3], [0.0; 3]),
        junctions: atlas.clone(),
    };
    let s = dress_stages(
        &mesh,
        &data,
        &DressParams { match_contours: false, ..Default::default() },
        1,
        &DressHints::default(),
    );
    let star = s.stars[0].as_ref().expect("star");
    assert!(star.hit.mirror);
    assert!(star.hit.distance < 1e-9);
    let mut pts = vec![star.center];
    pts.extend(&star.outline);
    let mut uvs = vec![star.center_uv];
    uvs.extend(&star.uvs);
    for i in 0..pts.len() {
        for j in 0..pts.len() {
            let (a, b) = (norm(sub(pts[i], pts[j])), norm(sub(uvs[i], uvs[j])));
            assert!((a - b).abs() < 1e-9, "{i} {j}: {a} vs {b}");
        }
    }
    let _ = atlas_branch(0, 3, 0, false);
}

#[test]
fn f26_colour_heuristic_equals_brute_force() {
    let tuples: Vec<Vec<f64>> = (0..12).map(|i| vec![PI - 0.05 * i as f64, PI + 0.05 * i as f64]).collect();
    let colours: Vec<[f32; 3]> = (0..12).map(|i| [0.1 + 0.07 * i as f32, 0.5, 0.9 - 0.06 * i as f32]).collect();
    let atlas = junction_atlas(&tuples, W, 2.0 * W, Band { center: 0.0, half: 3.0 }, &colours, [0.0; 3]);
    let index = JunctionIndex::new(&atlas);
    let mut rng = Rng::new(3);
    for _ in 0..200 {
        let a = rng.range(2.0, 4.0);
        let hits = index.query(&[a, TAU - a], 5);
        assert_eq!(hits.len(), 5);
        let target = lab_of_srgb([rng.range_f32(0.0, 1.0), rng.range_f32(0.0, 1.0), rng.range_f32(0.0, 1.0)]);
        let got = pick_by_colour(&hits, &atlas, Some(target)).expect("hit");
        let best = hits.iter().map(|h| delta_e(atlas.entries[h.entry].lab, target)).fold(f64::INFINITY, f64::min);
        assert_eq!(delta_e(atlas.entries[got.entry].lab, target), best);
    }
    let none: Vec<Hit> = Vec::new();
    assert!(pick_by_colour(&none, &atlas, None).is_none());
}

#[test]
fn f26_missing_valencies_fall_back_with_a_warning() {
    // No valency-2 star: the grid's corners use the nearest valency present.
    let tuples = vec![vec![PI / 2.0, PI / 2.0, PI], vec![PI / 2.0; 4]];
    let mut data = appearance(1, 128, W);
    data.junctions = junction_atlas(&tuples, W, 2.0 * W, Band { center: 0.0, half: 3.0 }, &[[0.5; 3]], [0.0; 3]);
    let mesh = grid_mesh(3, 3, 30.0, 0.0, 1);
    let s = dress_stages(&mesh, &data, &DressParams::default(), 1, &DressHints::default());
    assert!(s.dressing.warnings.iter().any(|w| w.contains("4 vertices of valency 2")), "{:?}", s.dressing.warnings);
    assert_eq!(s.stars.iter().flatten().count(), mesh.vertices.len());
}

// ---- F27 matching ----------------------------------------------------------------------------

fn check_matching(s: &Stages, data: &AppearanceData) -> usize {
    let mut checked = 0;
    for b in &s.matching.branches {
        if !matches!(b.kind, MatchKind::Junction | MatchKind::Interstice) {
            continue;
        }
        let star = s.stars[b.vertex].as_ref().expect("star");
        let j = b.branch;
        let o = |p| dot(sub(p, b.origin), b.normal);
        let (tr, tl) = (star.outline[3 * j], star.outline[3 * j + 1]);
        let ej =
            extent(&data.junctions.image, star.uvs[3 * j], star.uvs[3 * j + 1], o(tr), o(tl), 0.5).expect("junction");
        let strip = s.strips[b.edge].as_ref().expect("strip");
        let poly = strip.polygon.expect("quad");
        let (cm, cp) = if strip.ends[0] == b.vertex { (0, 3) } else { (2, 1) };
        let ei = extent(&data.interstices.image, poly[cm].uv, poly[cp].uv, o(poly[cm].pos), o(poly[cp].pos), 0.5)
            .expect("interstice");
        assert!(
            (ej[0] - ei[0]).abs() <= 1.0 && (ej[1] - ei[1]).abs() <= 1.0,
            "vertex {} branch {j}: junction {ej:?} vs interstice {ei:?} ({:?})",
            b.vertex,
            b.kind
        );
        // The tips and the moved corners stay on the cross-line.
        for p in [tr, tl, poly[cm].pos, poly[cp].pos] {
            let along = dot(sub(p, b.origin), [b.normal[1], -b.normal[0]]);
            assert!(along.abs() < 1e-9);
        }
        checked += 1;
    }
    for r in &s.matching.relative {
        let star = s.stars[r.vertex].as_ref().expect("star");
        let v = star.directions.len();
        let k = r.index;
        let (a, b) =
            relative_coords(star.outline[3 * k + 2], star.outline[3 * k + 1], star.outline[(3 * k + 3) % (3 * v)]);
        assert!((a - r.alpha).abs() < 1e-9 && (b - r.beta).abs() < 1e-9);
    }
    for star in s.stars.iter().flatten() {
        assert!(is_simple(&star.outline) && fan_is_valid(star.center, &star.outline), "star {}", star.vertex);
    }
    for strip in s.strips.iter().flatten() {
        if let Some(p) = strip.polygon {
            let pos: Vec<_> = p.iter().map(|c| c.pos).collect();
            assert!(is_simple(&pos) && signed_area(&pos) > 0.0, "strip {}", strip.edge);
        }
    }
    checked
}

fn matching_data(strip_band: Band, star_band: Band) -> AppearanceData {
    let lengths: Vec<f64> = (0..30).map(|i| 12.0 + 2.0 * i as f64).collect();
    let mortar = [0.75, 0.72, 0.66];
    AppearanceData {
        unified: unified(2, 256, false),
        originals: crate::synth::appearance::dress::testkit::originals(2),
        interstices: interstice_atlas(&lengths, W, W, strip_band, mortar, [0.9, 0.1, 0.1]),
        junctions: junction_atlas(
            &crate::synth::appearance::dress::testkit::typical_tuples(),
            W,
            2.0 * W,
            star_band,
            &[mortar],
            [0.1, 0.9, 0.1],
        ),
    }
}

#[test]
fn f27_extents_coincide_after_matching_and_outlines_stay_simple() {
    let mesh = grid_mesh(8, 6, 36.0, 7.0, 6);
    for (strip_band, star_band, moved) in [
        (Band { center: 1.0, half: 2.0 }, Band { center: 0.0, half: 3.5 }, MatchKind::Junction),
        (Band { center: -0.5, half: 1.2 }, Band { center: 0.5, half: 4.5 }, MatchKind::Interstice),
    ] {
        let data = matching_data(strip_band, star_band);
        let s = dress_stages(&mesh, &data, &DressParams::default(), 7, &DressHints::default());
        assert!(s.matching.restored_stars.is_empty() && s.matching.restored_strips.is_empty());
        let n = check_matching(&s, &data);
        let all = s.matching.branches.len();
        assert_eq!(n, all, "every branch matched");
        assert!(s.matching.branches.iter().all(|b| b.kind == moved), "{moved:?}");
    }
}

#[test]
fn f27_very_short_edges_match_junction_to_junction() {
    // A column of the grid squeezed to 8 px (< 2w): those edges lose their interstice.
    let mut mesh = grid_mesh(4, 4, 40.0, 0.0, 1);
    for v in mesh.vertices.iter_mut() {
        if v[0] > 50.0 {
            v[0] -= 32.0;
        }
    }
    let data = matching_data(Band { center: 1.0, half: 2.0 }, Band { center: 0.0, half: 3.5 });
    let s = dress_stages(&mesh, &data, &DressParams::default(), 7, &DressHints::default());
    let edges = mesh_edges(&mesh);
    let short: Vec<usize> = (0..edges.len())
        .filter(|&e| norm(sub(mesh.vertices[edges[e][1]], mesh.vertices[edges[e][0]])) < 2.0 * W)
        .collect();
    assert_eq!(short.len(), 5);
    assert_eq!(s.matching.short_edges, short);
    for &e in &short {
        assert!(s.strips[e].as_ref().expect("strip").polygon.is_none());
        assert!(!s.dressing.pieces.iter().any(|p| p.layer == Layer::Interstice && p.owner == e));
        let bs: Vec<_> = s.matching.branches.iter().filter(|b| b.edge == e).collect();
        assert_eq!(bs.len(), 2);
        assert!(bs.iter().all(|b| b.kind == MatchKind::JunctionToJunction));
        // The two junctions' alpha extents coincide along their common end segment.
        let (a, b) = (bs[0], bs[1]);
        let ext = |m: &crate::synth::appearance::dress::matching::BranchMatch| {
            let star = s.stars[m.vertex].as_ref().expect("star");
            let j = m.branch;
            let o = |p| dot(sub(p, a.origin), a.normal);
            let (tr, tl) = (star.outline[3 * j], star.outline[3 * j + 1]);
            extent(&data.junctions.image, star.uvs[3 * j], star.uvs[3 * j + 1], o(tr), o(tl), 0.5).expect("extent")
        };
        let (ea, eb) = (ext(a), ext(b));
        assert!((ea[0] - eb[0]).abs() <= 1.0 && (ea[1] - eb[1]).abs() <= 1.0, "{ea:?} {eb:?}");
    }
    check_matching(&s, &data);
}

/// Mean ΔE between the render just inside the junction and just inside the interstice, along
/// every branch end segment of the unmatched stars (not on short edges).
fn border_jump(img: &crate::raster::Image, s: &Stages) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    let px = |p: [f64; 2]| -> [f32; 3] {
        let (x, y) = (p[0].floor() as usize, p[1].floor() as usize);
        [img.get(x, y, 0), img.get(x, y, 1), img.get(x, y, 2)]
    };
    for star in s.stars.iter().flatten() {
        for (j, &dir) in star.directions.iter().enumerate() {
            let d = [dir.cos(), dir.sin()];
            let nrm = [-d[1], d[0]];
            let origin = add(star.center, mul(d, star.lengths[j]));
            let mut o = -W + 0.25;
            while o < W {
                let a = add(add(origin, mul(d, -1.5)), mul(nrm, o));
                let b = add(add(origin, mul(d, 1.5)), mul(nrm, o));
                sum += delta_e(lab_of_srgb(px(a)), lab_of_srgb(px(b)));
                n += 1;
                o += 0.5;
            }
        }
    }
    sum / n as f64
}

#[test]
fn f27_matching_halves_the_colour_jump_at_junction_borders() {
    let mesh = grid_mesh(8, 6, 36.0, 7.0, 6);
    let data = matching_data(Band { center: 1.0, half: 2.0 }, Band { center: 0.0, half: 3.5 });
    let rp = RenderParams { width: 300, height: 230, scale: 1.0, background: [0.0; 3] };
    let hints = DressHints::default();
    let raw = dress_stages(&mesh, &data, &DressParams { match_contours: false, ..Default::default() }, 7, &hints);
    let matched = dress_stages(&mesh, &data, &DressParams::default(), 7, &hints);
    let before = border_jump(&render(&raw.dressing, &data, &rp).color, &raw);
    let after = border_jump(&render(&matched.dressing, &data, &rp).color, &raw);
    eprintln!(
        "F27 border ΔE: {before:.2} unmatched, {after:.2} matched ({:.0} % drop)",
        100.0 * (1.0 - after / before)
    );
    assert!(after <= 0.5 * before, "ΔE {before} → {after}");
}

// ---- renderer --------------------------------------------------------------------------------

fn square(x0: f64, y0: f64, side: f64, uv0: [f64; 2], texture: TextureId, layer: Layer) -> Piece {
    let p = [[x0, y0], [x0 + side, y0], [x0 + side, y0 + side], [x0, y0 + side]];
    let c = p.map(|q| Corner { pos: q, uv: [q[0] - x0 + uv0[0], q[1] - y0 + uv0[1]] });
    Piece { layer, texture, owner: 0, triangles: vec![[c[0], c[1], c[2]], [c[0], c[2], c[3]]] }
}

#[test]
fn render_a_textured_square_shows_its_texture_one_to_one() {
    let data = appearance(1, 64, W);
    let d = Dressing {
        pieces: vec![square(10.0, 12.0, 32.0, [5.0, 7.0], TextureId::Unified(0), Layer::Interior)],
        ..Default::default()
    };
    let out = render(&d, &data, &RenderParams { width: 64, height: 64, scale: 1.0, background: [0.0; 3] });
    let tex = &data.unified[0].image;
    for j in 0..32 {
        for i in 0..32 {
            assert_eq!(out.coverage.get(10 + i, 12 + j, 0), 1.0);
            for c in 0..3 {
                let (a, b) = (out.color.get(10 + i, 12 + j, c), tex.get(5 + i, 7 + j, c));
                assert!((a - b).abs() < 1e-5, "{i} {j} {c}: {a} vs {b}");
            }
        }
    }
    assert_eq!(out.coverage.get(9, 20, 0), 0.0);
    assert_eq!(out.coverage.get(42, 20, 0), 0.0);
}

#[test]
fn render_edges_are_antialiased_and_shared_edges_leave_no_seam() {
    let data = appearance(1, 64, W);
    let a = square(10.3, 10.6, 20.0, [0.0, 0.0], TextureId::Unified(0), Layer::Interior);
    let b = square(30.3, 10.6, 20.0, [0.0, 0.0], TextureId::Unified(0), Layer::Interior);
    let d = Dressing { pieces: vec![a, b], ..Default::default() };
    let out = render(&d, &data, &RenderParams { width: 64, height: 64, scale: 1.0, background: [0.0; 3] });
    let left = out.coverage.get(10, 20, 0);
    assert!(left > 0.0 && left < 1.0, "fractional coverage {left}");
    let top = out.coverage.get(20, 10, 0);
    assert!(top > 0.0 && top < 1.0, "fractional coverage {top}");
    for y in 12..30 {
        assert_eq!(out.coverage.get(30, y, 0), 1.0, "seam at the shared edge, row {y}");
    }
    // Scale 2: the same square covers four times the pixels.
    let out2 = render(&d, &data, &RenderParams { width: 128, height: 128, scale: 2.0, background: [0.0; 3] });
    let s1: f32 = out.coverage.data.iter().sum();
    let s2: f32 = out2.coverage.data.iter().sum();
    assert!((s2 / s1 - 4.0).abs() < 0.01, "{s1} {s2}");
    assert!((s1 - 800.0).abs() < 2.0, "{s1}");
}

#[test]
fn dressing_and_render_do_not_depend_on_the_thread_count() {
    let mesh = grid_mesh(10, 8, 30.0, 6.0, 9);
    let data = appearance(3, 128, W);
    let rp = RenderParams { width: 320, height: 260, scale: 1.0, background: [0.2; 3] };
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
        pool.install(|| {
            let d = dress(&mesh, &data, &DressParams::default(), 5, &DressHints::default());
            let r = render(&d, &data, &rp);
            (d, r)
        })
    };
    let (d1, r1) = run(1);
    let (d3, r3) = run(3);
    assert_eq!(d1, d3);
    assert!(r1.color.data.iter().zip(&r3.color.data).all(|(a, b)| a.to_bits() == b.to_bits()));
    assert!(r1.coverage.data.iter().zip(&r3.coverage.data).all(|(a, b)| a.to_bits() == b.to_bits()));
}
