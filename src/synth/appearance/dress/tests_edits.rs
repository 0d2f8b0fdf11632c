//! Checklist F28 on stand-ins: a structure from one sample dressed with the appearance of
//! others, painting into one unified texture, and local structure edits with and without
//! sticky clusters ([references: frasson §4.1.3]).
//!
//! The structure sample X is the regular wall's drawing (dressed in place, as `on = sample`
//! does); the interiors come from the painted random wall Y, the contours from Y or from a
//! painted layered wall Z whose mortar is brick red. Render comparisons are bit for bit; a
//! pixel counts as showing a region's interior when no contour piece covers any of it (its
//! contour-only coverage is 0) and the interior pieces of one cluster cover all of it.

use std::collections::BTreeSet;
use std::sync::OnceLock;

use crate::raster::Image;
use crate::synth::appearance::analysis::{self, ContourParams, Contours, Interiors};
use crate::synth::appearance::color::{delta_e, lab_of_srgb, mean_lab};
use crate::synth::appearance::dress::geom::{is_simple, signed_area};
use crate::synth::appearance::dress::interiors::region_polygons;
use crate::synth::appearance::dress::interstices::{closest_length, Strip};
use crate::synth::appearance::dress::junctions::Star;
use crate::synth::appearance::dress::params::{ClusterChoice, DressHints, DressParams};
use crate::synth::appearance::dress::{dress_stages, Stages};
use crate::synth::appearance::render::{render, RenderParams, Rendered};
use crate::synth::appearance::types::{AppearanceData, Dressing, Lab, Layer, Mesh, Piece, TextureId};
use crate::synth::appearance::unified::InteriorParams;
use crate::synth::structure::analysis::labels_import::rasterize_polygons;
use crate::synth::structure::analysis::sample::{analyse_subdivision, SampleStructure};
use crate::synth::structure::analysis::stats::StatsConfig;
use crate::synth::structure::fixtures::standins::{
    paint, wall_layered, wall_random, wall_regular, PaintParams, StandIn, WallLayeredParams, WallRandomParams,
    WallRegularParams,
};
use crate::synth::structure::shapes::associate::associate;
use crate::synth::structure::NO_REGION;

/// The mortar of Z: brick red, far from Y's light grey (ΔE ≈ 65).
const Z_MORTAR: Lab = [45.0, 45.0, 35.0];
const SEED: u64 = 3;

struct Fixture {
    /// The structure sample: its drawing is the dressed mesh.
    x: StandIn,
    y_interiors: Interiors,
    y_contours: Contours,
    z_contours: Contours,
}

fn analysed(s: &StandIn) -> SampleStructure {
    analyse_subdivision(&s.subdivision, Some([s.width as f64, s.height as f64]), &StatsConfig::default())
        .expect("a stand-in analyses")
}

fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let x = wall_regular(&WallRegularParams::default(), 7);
        let y = wall_random(&WallRandomParams::default(), 11);
        let y_photo = paint(&y, &PaintParams::default(), 11);
        let y_sample = analysed(&y);
        // Shrunk past the widest painted mortar, as F22 does, so no mortar reaches a texture.
        let interior = InteriorParams { shrink: PaintParams::default().half_width[1], ..InteriorParams::default() };
        let y_interiors = analysis::interiors(&y_photo.image, &y_sample, &interior, 11).expect("interiors");
        let y_contours = analysis::contours(&y_photo.image, &y_sample, &ContourParams::default(), None).expect("Y");
        let z = wall_layered(&WallLayeredParams::default(), 5);
        let z_paint = PaintParams {
            tints: vec![[40.0, -30.0, 20.0], [55.0, -20.0, -30.0]],
            mortar: Z_MORTAR,
            ..PaintParams::default()
        };
        let z_photo = paint(&z, &z_paint, 5);
        let z_contours = analysis::contours(&z_photo.image, &analysed(&z), &ContourParams::default(), None).expect("Z");
        Fixture { x, y_interiors, y_contours, z_contours }
    })
}

fn view(s: &StandIn) -> RenderParams {
    RenderParams { width: s.width, height: s.height, scale: 1.0, background: [0.0; 3] }
}

/// The coverage of the pieces `keep` selects, alone.
fn coverage_of(d: &Dressing, data: &AppearanceData, rp: &RenderParams, keep: impl Fn(&Piece) -> bool) -> Image {
    let pieces = d.pieces.iter().filter(|p| keep(p)).cloned().collect();
    render(&Dressing { pieces, ..Dressing::default() }, data, rp).coverage
}

fn is_contour(p: &Piece) -> bool {
    p.layer != Layer::Interior
}

/// Whether pixel `i` differs at all (colour or coverage) between two renders.
fn pixel_changed(a: &Rendered, b: &Rendered, i: usize) -> bool {
    let n = a.coverage.data.len();
    a.coverage.data[i].to_bits() != b.coverage.data[i].to_bits()
        || (0..3).any(|c| a.color.data[c * n + i].to_bits() != b.color.data[c * n + i].to_bits())
}

fn lab_of_pixel(img: &Image, i: usize) -> Lab {
    let n = img.width * img.height;
    lab_of_srgb([img.data[i], img.data[n + i], img.data[2 * n + i]])
}

/// Every piece samples a texture of `data`, at texture positions inside it.
fn check_references(d: &Dressing, data: &AppearanceData) {
    for p in &d.pieces {
        let img = match p.texture {
            TextureId::Unified(t) => &data.unified.get(t).expect("a unified texture of the appearance").image,
            TextureId::Interstices => &data.interstices.image,
            TextureId::Junctions => &data.junctions.image,
        };
        for c in p.triangles.iter().flatten() {
            let (u, v) = (c.uv[0], c.uv[1]);
            assert!(
                (0.0..=img.width as f64).contains(&u) && (0.0..=img.height as f64).contains(&v),
                "{:?} piece {} samples ({u}, {v}) outside its {}x{} texture",
                p.texture,
                p.owner,
                img.width,
                img.height
            );
        }
    }
}

// ---- F28 (a): mixing sources -------------------------------------------------------------------

#[test]
fn f28_a_structure_from_one_sample_takes_the_textures_of_the_appearance_samples_only() {
    let f = fixture();
    let params = DressParams::default();
    let hints = DressHints::default();
    let yy = analysis::appearance_data(&f.y_interiors, &f.y_contours);
    let yz = analysis::appearance_data(&f.y_interiors, &f.z_contours);
    let a = dress_stages(&f.x.mesh, &yy, &params, SEED, &hints);
    let b = dress_stages(&f.x.mesh, &yz, &params, SEED, &hints);

    // Interiors: the cluster of the closest shape among Y's originals, whatever the contours.
    let polys = region_polygons(&f.x.mesh);
    let originals: Vec<_> = yy.originals.iter().map(|o| o.polygon.clone()).collect();
    let found = associate(&polys, &originals, &params.associate);
    for (r, assoc) in found.associations.iter().enumerate() {
        let o = assoc.as_ref().expect("every region of X has a closest original in Y").original;
        assert_eq!(a.dressing.clusters[r], Some(yy.originals[o].cluster), "region {r}");
    }
    assert_eq!(a.interiors, b.interiors, "the contours sample changed the interiors");

    // Every texture reference is into the appearance data, inside its texture; each strip is
    // the closest length of the contours sample's own atlas.
    for (s, data) in [(&a, &yy), (&b, &yz)] {
        check_references(&s.dressing, data);
        for strip in s.strips.iter().flatten() {
            assert_eq!(Some(strip.entry), closest_length(&data.interstices.entries, strip.length));
        }
    }

    // The render shows Y's cluster textures in the regions and the contours sample's mortar
    // on the edges.
    let rp = view(&f.x);
    let labels = rasterize_polygons(&polys, f.x.width, f.x.height);
    let y_mortar = PaintParams::default().mortar;
    for (s, data, mortar, other) in [(&a, &yy, y_mortar, Z_MORTAR), (&b, &yz, Z_MORTAR, y_mortar)] {
        let out = render(&s.dressing, data, &rp);
        let contour = coverage_of(&s.dressing, data, &rp, is_contour);
        let interior = coverage_of(&s.dressing, data, &rp, |p| !is_contour(p));
        let mut per_region: Vec<Vec<Lab>> = vec![Vec::new(); polys.len()];
        let mut on_edges = Vec::new();
        for (i, &id) in labels.data.iter().enumerate() {
            if contour.data[i] == 0.0 && interior.data[i] == 1.0 && id != NO_REGION {
                per_region[id as usize].push(lab_of_pixel(&out.color, i));
            } else if contour.data[i] == 1.0 {
                on_edges.push(lab_of_pixel(&out.color, i));
            }
        }
        let mut shown = 0;
        for (r, labs) in per_region.into_iter().enumerate() {
            if labs.is_empty() {
                continue;
            }
            let mean = mean_lab(labs);
            let own = s.dressing.clusters[r].expect("dressed");
            let d_own = delta_e(mean, data.unified[own].lab);
            let d_other = (0..data.unified.len())
                .filter(|&t| t != own)
                .map(|t| delta_e(mean, data.unified[t].lab))
                .fold(f64::INFINITY, f64::min);
            assert!(d_own < d_other, "region {r}: ΔE {d_own:.1} to its cluster's texture, {d_other:.1} to another");
            shown += 1;
        }
        assert_eq!(shown, polys.len(), "every region shows its interior somewhere");
        let edge = mean_lab(on_edges);
        let (d_mortar, d_other) = (delta_e(edge, mortar), delta_e(edge, other));
        eprintln!("F28 (a): edges ΔE {d_mortar:.1} to the contours sample's mortar, {d_other:.1} to the other's");
        assert!(d_mortar < d_other, "edges ΔE {d_mortar:.1} to their own mortar, {d_other:.1} to the other");
    }
}

// ---- F28 (b): painting into a unified texture --------------------------------------------------

#[test]
fn f28_b_painting_into_one_unified_texture_changes_exactly_the_regions_mapped_to_it() {
    let f = fixture();
    let data = analysis::appearance_data(&f.y_interiors, &f.y_contours);
    let s = dress_stages(&f.x.mesh, &data, &DressParams::default(), SEED, &DressHints::default());
    let d = &s.dressing;
    let k = data.unified.len();
    let mut counts = vec![0usize; k];
    for c in d.clusters.iter().flatten() {
        counts[*c] += 1;
    }
    // The most used cluster, which must leave regions to the others.
    let c = (0..k).max_by_key(|&t| (counts[t], std::cmp::Reverse(t))).expect("clusters");
    assert!(counts[c] > 0 && counts[c] < d.clusters.len(), "cluster use {counts:?}");

    // Moss over the whole of texture c.
    let moss = [0.33f32, 0.42, 0.18];
    let mut mossy = data.clone();
    let img = &mut mossy.unified[c].image;
    let n = img.width * img.height;
    for (plane, m) in img.data.chunks_mut(n).zip(moss) {
        for v in plane {
            *v = 0.5 * *v + 0.5 * m;
        }
    }

    let rp = view(&f.x);
    let before = render(d, &data, &rp);
    let after = render(d, &mossy, &rp);
    let contour = coverage_of(d, &data, &rp, is_contour);
    let by_cluster: Vec<Image> =
        (0..k).map(|t| coverage_of(d, &data, &rp, |p| p.texture == TextureId::Unified(t))).collect();
    let labels = rasterize_polygons(&region_polygons(&f.x.mesh), f.x.width, f.x.height);
    let (mut changed_regions, mut shown_regions) = (BTreeSet::new(), BTreeSet::new());
    let (mut untouched, mut shown_c) = (0usize, 0usize);
    for (i, &id) in labels.data.iter().enumerate() {
        let changed = pixel_changed(&before, &after, i);
        // No piece of cluster c reaches the pixel: it is the same, bit for bit, whatever lies
        // over it.
        if by_cluster[c].data[i] == 0.0 {
            assert!(!changed, "pixel {i} changed, though no region of cluster {c} covers it");
            untouched += 1;
        }
        // Where one cluster's interior is the top layer, the pixel changes exactly when that
        // cluster is c.
        let Some(t) = (0..k).find(|&t| by_cluster[t].data[i] == 1.0) else { continue };
        if contour.data[i] != 0.0 {
            continue;
        }
        assert_eq!(changed, t == c, "pixel {i} showing cluster {t}");
        if id != NO_REGION {
            assert_eq!(d.clusters[id as usize], Some(t), "pixel {i}: its region's cluster covers it");
            shown_regions.insert(id as usize);
            if changed {
                changed_regions.insert(id as usize);
            }
        }
        shown_c += usize::from(t == c);
    }
    let mapped: BTreeSet<usize> = (0..d.clusters.len()).filter(|&r| d.clusters[r] == Some(c)).collect();
    eprintln!(
        "F28 (b): cluster {c}: {} of {} regions mapped to it, {} regions changed ({} pixels showing it changed, \
         {untouched} pixels out of its reach unchanged)",
        mapped.len(),
        d.clusters.len(),
        changed_regions.len(),
        shown_c
    );
    assert_eq!(shown_regions.len(), d.clusters.len(), "every region shows its interior somewhere");
    assert_eq!(changed_regions, mapped);
}

// ---- F28 (c, d): local structure edits ---------------------------------------------------------

/// Regions having vertex `v`.
fn regions_of(mesh: &Mesh, v: usize) -> BTreeSet<usize> {
    (0..mesh.regions.len()).filter(|&r| mesh.regions[r].contains(&v)).collect()
}

/// Vertices of the regions `rs`.
fn vertices_of(mesh: &Mesh, rs: &BTreeSet<usize>) -> BTreeSet<usize> {
    rs.iter().flat_map(|&r| mesh.regions[r].iter().copied()).collect()
}

/// `rs` and the regions sharing an edge with one of them.
fn grow_ring(mesh: &Mesh, rs: &BTreeSet<usize>) -> BTreeSet<usize> {
    let edges_of = |r: usize| -> BTreeSet<[usize; 2]> {
        let c = &mesh.regions[r];
        (0..c.len()).map(|i| [c[i].min(c[(i + 1) % c.len()]), c[i].max(c[(i + 1) % c.len()])]).collect()
    };
    let ring: BTreeSet<[usize; 2]> = rs.iter().flat_map(|&r| edges_of(r)).collect();
    (0..mesh.regions.len()).filter(|&r| rs.contains(&r) || !edges_of(r).is_disjoint(&ring)).collect()
}

/// `mesh` with vertex `v` moved by `by`, if every region keeps a simple outline of positive
/// area.
fn moved(mesh: &Mesh, v: usize, by: [f64; 2]) -> Option<Mesh> {
    let mut out = mesh.clone();
    out.vertices[v] = [mesh.vertices[v][0] + by[0], mesh.vertices[v][1] + by[1]];
    let polys = region_polygons(&out);
    regions_of(mesh, v).iter().all(|&r| is_simple(&polys[r]) && signed_area(&polys[r]) > 0.0).then_some(out)
}

/// Interior vertices of valency ≥ 3 (not on the sample's border), nearest the centre first.
fn edit_candidates(s: &StandIn) -> Vec<usize> {
    let border = s.border_regions();
    let mut valency = vec![0usize; s.mesh.vertices.len()];
    let mut on_border = vec![false; s.mesh.vertices.len()];
    for (r, c) in s.mesh.regions.iter().enumerate() {
        for &v in c {
            valency[v] += 1;
            on_border[v] |= border[r];
        }
    }
    let centre = [s.width as f64 / 2.0, s.height as f64 / 2.0];
    let mut vs: Vec<usize> = (0..valency.len()).filter(|&v| valency[v] >= 3 && !on_border[v]).collect();
    let dist = |v: usize| {
        let p = s.mesh.vertices[v];
        (p[0] - centre[0]).hypot(p[1] - centre[1])
    };
    vs.sort_by(|&a, &b| dist(a).total_cmp(&dist(b)).then(a.cmp(&b)));
    vs
}

/// What changed between two dressings of meshes with the same topology.
struct Changes {
    /// Regions whose interior piece, cluster or texture offset changed.
    interiors: BTreeSet<usize>,
    clusters: BTreeSet<usize>,
    /// Edges whose interstice changed (its quad, texture map or atlas entry).
    strips: BTreeSet<usize>,
    /// Vertices whose junction changed.
    stars: BTreeSet<usize>,
    /// Regions under a rendered pixel that changed (by pixel centre).
    pixels_in: BTreeSet<usize>,
    /// Changed pixels no changed piece (before or after) covers.
    stray_pixels: usize,
}

fn changes(meshes: [&Mesh; 2], pre: &Stages, post: &Stages, data: &AppearanceData, rp: &RenderParams) -> Changes {
    let mesh = meshes[0];
    assert_eq!(pre.edges, post.edges, "the edit keeps the topology");
    let piece_of =
        |s: &Stages, r: usize| s.dressing.pieces.iter().find(|p| p.layer == Layer::Interior && p.owner == r).cloned();
    let n = mesh.regions.len();
    let interiors: BTreeSet<usize> = (0..n)
        .filter(|&r| {
            piece_of(pre, r) != piece_of(post, r)
                || pre.interiors.clusters[r] != post.interiors.clusters[r]
                || pre.interiors.offsets[r] != post.interiors.offsets[r]
        })
        .collect();
    let clusters: BTreeSet<usize> = (0..n).filter(|&r| pre.dressing.clusters[r] != post.dressing.clusters[r]).collect();
    let strip = |s: &Option<Strip>| s.as_ref().map(|s| (s.entry, s.flipped, s.to_uv, s.polygon));
    let strips: BTreeSet<usize> =
        (0..pre.strips.len()).filter(|&e| strip(&pre.strips[e]) != strip(&post.strips[e])).collect();
    let star = |s: &Option<Star>| s.as_ref().map(Star::piece);
    let stars: BTreeSet<usize> =
        (0..pre.stars.len()).filter(|&v| star(&pre.stars[v]) != star(&post.stars[v])).collect();

    let (a, b) = (render(&pre.dressing, data, rp), render(&post.dressing, data, rp));
    let touched = |s: &Stages| {
        coverage_of(&s.dressing, data, rp, |p| match p.layer {
            Layer::Interior => interiors.contains(&p.owner),
            Layer::Interstice => strips.contains(&p.owner),
            Layer::Junction => stars.contains(&p.owner),
        })
    };
    let (ta, tb) = (touched(pre), touched(post));
    // Pixels are attributed to the region under their centre, in the mesh before the edit
    // and after it.
    let before = rasterize_polygons(&region_polygons(meshes[0]), rp.width, rp.height);
    let after = rasterize_polygons(&region_polygons(meshes[1]), rp.width, rp.height);
    let mut pixels_in = BTreeSet::new();
    let mut stray_pixels = 0;
    for i in 0..before.data.len() {
        if !pixel_changed(&a, &b, i) {
            continue;
        }
        for id in [before.data[i], after.data[i]] {
            if id != NO_REGION {
                pixels_in.insert(id as usize);
            }
        }
        if ta.data[i] == 0.0 && tb.data[i] == 0.0 {
            stray_pixels += 1;
        }
    }
    Changes { interiors, clusters, strips, stars, pixels_in, stray_pixels }
}

fn fmt(s: &BTreeSet<usize>) -> String {
    format!("{} {s:?}", s.len())
}

#[test]
fn f28_c_a_local_edit_changes_only_the_regions_whose_mesh_or_association_changed() {
    let f = fixture();
    let data = analysis::appearance_data(&f.y_interiors, &f.y_contours);
    let params = DressParams::default();
    let hints = DressHints::default();
    let mesh = &f.x.mesh;
    let v = edit_candidates(&f.x)[0];
    let edited = moved(mesh, v, [3.0, -2.0]).expect("a small move keeps the regions simple");
    let pre = dress_stages(mesh, &data, &params, SEED, &hints);
    let post = dress_stages(&edited, &data, &params, SEED, &hints);

    let moved_regions = regions_of(mesh, v);
    let originals: Vec<_> = data.originals.iter().map(|o| o.polygon.clone()).collect();
    let of = |m: &Mesh| -> Vec<Option<usize>> {
        associate(&region_polygons(m), &originals, &params.associate)
            .associations
            .iter()
            .map(|a| a.as_ref().map(|a| a.original))
            .collect()
    };
    let (assoc_pre, assoc_post) = (of(mesh), of(&edited));
    let reassociated: BTreeSet<usize> = (0..mesh.regions.len()).filter(|&r| assoc_pre[r] != assoc_post[r]).collect();
    let allowed: BTreeSet<usize> = moved_regions.union(&reassociated).copied().collect();
    let near = vertices_of(mesh, &allowed);

    let c = changes([mesh, &edited], &pre, &post, &data, &view(&f.x));
    eprintln!(
        "F28 (c): vertex {v} moved by (3, -2): mesh changed in {}, association in {}; interiors changed: {}, \
         clusters: {}, interstices: {} of {}, junctions: {} of {}, regions under changed pixels: {}",
        fmt(&moved_regions),
        fmt(&reassociated),
        fmt(&c.interiors),
        fmt(&c.clusters),
        c.strips.len(),
        pre.edges.len(),
        c.stars.len(),
        pre.stars.len(),
        fmt(&c.pixels_in)
    );
    assert_eq!(c.interiors, moved_regions, "exactly the regions the vertex moved are re-dressed");
    assert!(c.clusters.is_subset(&allowed));
    // Contour pieces that changed touch the changed regions: a junction at one of their
    // vertices, an interstice with an end at one.
    assert!(c.stars.contains(&v) && c.stars.is_subset(&near), "junctions {:?}", c.stars);
    for &e in &c.strips {
        let [a, b] = pre.edges[e];
        assert!(near.contains(&a) || near.contains(&b), "interstice {e} ({a}, {b}) is away from the edit");
    }
    // No pixel changed that no changed piece covers; the unchanged regions kept their texture
    // offsets (their random streams are their own).
    assert_eq!(c.stray_pixels, 0);
    for r in (0..mesh.regions.len()).filter(|r| !allowed.contains(r)) {
        assert_eq!(pre.interiors.offsets[r], post.interiors.offsets[r], "region {r}");
    }
}

#[test]
fn f28_d_with_sticky_clusters_an_edit_changes_at_most_the_regions_within_two_rings() {
    let f = fixture();
    let data = analysis::appearance_data(&f.y_interiors, &f.y_contours);
    let closest = DressParams::default();
    let hints = DressHints::default();
    let mesh = &f.x.mesh;
    let pre = dress_stages(mesh, &data, &closest, SEED, &hints);
    // The first edit (nearest the centre, a few pixels) that changes a cluster under the
    // closest-shape rule, so that there is something for sticky to keep.
    let steps = [[4.0, 0.0], [0.0, 4.0], [-4.0, 0.0], [0.0, -4.0], [6.0, 6.0], [-6.0, 6.0], [6.0, -6.0], [-6.0, -6.0]];
    let (v, by, edited, free) = edit_candidates(&f.x)
        .into_iter()
        .flat_map(|v| steps.iter().map(move |&by| (v, by)))
        .find_map(|(v, by)| {
            let edited = moved(mesh, v, by)?;
            let post = dress_stages(&edited, &data, &closest, SEED, &hints);
            (post.dressing.clusters != pre.dressing.clusters).then_some((v, by, edited, post))
        })
        .expect("an edit of a few pixels that changes a closest-shape cluster");
    let sticky = DressParams { cluster_choice: ClusterChoice::Sticky, ..DressParams::default() };
    let previous = DressHints { associations: None, previous_clusters: Some(&pre.dressing.clusters) };
    let kept = dress_stages(&edited, &data, &sticky, SEED, &previous);

    let ring1 = regions_of(mesh, v);
    let ring2 = grow_ring(mesh, &ring1);
    let rp = view(&f.x);
    let without = changes([mesh, &edited], &pre, &free, &data, &rp);
    let with = changes([mesh, &edited], &pre, &kept, &data, &rp);
    eprintln!(
        "F28 (d): vertex {v} moved by {by:?}; ring 1: {}, ring 2: {}; closest shape: clusters changed in {}, \
         regions under changed pixels {}; sticky: clusters changed in {}, interiors {}, regions under changed \
         pixels {}",
        fmt(&ring1),
        fmt(&ring2),
        fmt(&without.clusters),
        fmt(&without.pixels_in),
        fmt(&with.clusters),
        fmt(&with.interiors),
        fmt(&with.pixels_in)
    );
    assert!(with.clusters.is_empty(), "sticky kept every cluster: {:?}", with.clusters);
    assert!(with.interiors.is_subset(&ring2), "interiors {:?}", with.interiors);
    assert!(with.pixels_in.is_subset(&ring2), "changed pixels lie in {:?}", with.pixels_in);
    assert_eq!(with.stray_pixels, 0);
}
