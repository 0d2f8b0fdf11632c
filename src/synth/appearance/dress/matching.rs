//! S8, junction–interstice matching ([references: frasson §4.2.3]; V25). Along the end
//! segment of every junction branch (the cross-line `tip_right → tip_left`, where the
//! interstice is cut), the extents where atlas alpha ≥ 0.5 are found in both textures,
//! sampled every half texel; the 1-D map `o' = σ·o + τ` that puts the junction's extent onto
//! the interstice's moves the branch tips, or, when `σ ∉ [1/2, 2]`, the inverse map moves the
//! interstice's corners at that end instead. The interstice quad is clipped to the part between
//! its two junctions' end segments. Intermediate vertices `M` keep their coordinates `(α, β)`
//! relative to their neighbours `M1 = tip_left_i`, `M2 = tip_right_{i+1}`:
//! `M = M1 + α·(M2 − M1) + β·perp(M2 − M1)` (a similarity). Edges shorter than
//! `short_edge · w` drop their interstice, and their two junctions meet at the edge's midpoint,
//! one matched onto the other.
//!
//! Offsets `o` are measured along the branch normal `n_j` from the branch axis.

use crate::raster::Image;
use crate::synth::appearance::dress::geom::{add, apply, cross, dot, fan_is_valid, is_simple, mul, norm, perp, sub};
use crate::synth::appearance::dress::interstices::Strip;
use crate::synth::appearance::dress::junctions::Star;
use crate::synth::appearance::dress::params::DressParams;
use crate::synth::appearance::types::{IntersticeAtlas, JunctionAtlas, Point};

/// What matching did on one branch.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MatchKind {
    /// The junction's tips moved onto the interstice's extent.
    Junction,
    /// `σ` out of range: the interstice's corners moved onto the junction's extent.
    Interstice,
    /// A very short edge: the interstice is skipped, the two junctions meet.
    JunctionToJunction,
    /// No extent on one side (no alpha ≥ threshold), or the star was restored because the
    /// matched outline was not valid.
    Unmatched,
}

/// One branch's matching.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BranchMatch {
    pub vertex: usize,
    pub branch: usize,
    pub edge: usize,
    pub kind: MatchKind,
    /// The cross-line: a point on the branch axis and the branch normal.
    pub origin: Point,
    pub normal: Point,
    /// Alpha extents (offsets along `normal`) before matching: junction, then the other side
    /// (the interstice, or the other junction for a short edge).
    pub junction: Option<[f64; 2]>,
    pub other: Option<[f64; 2]>,
    pub sigma: f64,
    pub tau: f64,
}

/// The relative coordinates an intermediate vertex keeps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Relative {
    pub vertex: usize,
    /// `M_i` of the star.
    pub index: usize,
    pub alpha: f64,
    pub beta: f64,
}

/// The result of S8.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MatchReport {
    pub branches: Vec<BranchMatch>,
    /// Edges that took the junction-to-junction path.
    pub short_edges: Vec<usize>,
    pub relative: Vec<Relative>,
    /// Stars whose matched outline was not simple or star-shaped, restored unmatched.
    pub restored_stars: Vec<usize>,
    /// Edges whose moved quad was not simple, restored to the clipped quad.
    pub restored_strips: Vec<usize>,
}

/// Bilinear alpha (channel 3; 1 for images without one) at a texture position (px).
pub fn alpha_at(img: &Image, uv: Point) -> f32 {
    if img.channels < 4 || img.width == 0 || img.height == 0 {
        return 1.0;
    }
    let x = uv[0] - 0.5;
    let y = uv[1] - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
    let cx = |i: f64| (i.max(0.0) as usize).min(img.width - 1);
    let cy = |j: f64| (j.max(0.0) as usize).min(img.height - 1);
    let (xa, xb, ya, yb) = (cx(x0), cx(x0 + 1.0), cy(y0), cy(y0 + 1.0));
    let a = |i, j| img.get(i, j, 3);
    (a(xa, ya) * (1.0 - fx) + a(xb, ya) * fx) * (1.0 - fy) + (a(xa, yb) * (1.0 - fx) + a(xb, yb) * fx) * fy
}

/// Where alpha ≥ `threshold` along the texture segment `uv_a → uv_b` (sampled every half
/// texel), as offsets between `o_a` and `o_b` (ascending); `None` when nowhere.
pub fn extent(img: &Image, uv_a: Point, uv_b: Point, o_a: f64, o_b: f64, threshold: f32) -> Option<[f64; 2]> {
    let n = (norm(sub(uv_b, uv_a)) / 0.5).ceil().max(1.0) as usize;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..=n {
        let t = i as f64 / n as f64;
        let uv = add(uv_a, mul(sub(uv_b, uv_a), t));
        if alpha_at(img, uv) >= threshold {
            let o = o_a + (o_b - o_a) * t;
            lo = lo.min(o);
            hi = hi.max(o);
        }
    }
    (lo <= hi).then_some([lo, hi])
}

/// `(α, β)` of `m` relative to `m1, m2`.
pub fn relative_coords(m: Point, m1: Point, m2: Point) -> (f64, f64) {
    let e = sub(m2, m1);
    let l2 = dot(e, e);
    let r = sub(m, m1);
    (dot(r, e) / l2, dot(r, perp(e)) / l2)
}

/// The point with relative coordinates `(α, β)` to `m1, m2`.
pub fn from_relative(alpha: f64, beta: f64, m1: Point, m2: Point) -> Point {
    let e = sub(m2, m1);
    add(add(m1, mul(e, alpha)), mul(perp(e), beta))
}

/// The 1-D map putting extent `from` onto extent `to`, `None` when either is a point.
fn fit(from: [f64; 2], to: [f64; 2]) -> Option<(f64, f64)> {
    let (wf, wt) = (from[1] - from[0], to[1] - to[0]);
    if wf <= 1e-9 || wt <= 1e-9 {
        return None;
    }
    let s = wt / wf;
    Some((s, to[0] - s * from[0]))
}

/// S8 on the stars and strips of S6–S7 (see the module doc).
pub fn match_contours(
    stars: &mut [Option<Star>],
    strips: &mut [Option<Strip>],
    interstices: &IntersticeAtlas,
    junctions: &JunctionAtlas,
    params: &DressParams,
) -> MatchReport {
    let mut report = MatchReport::default();
    let thr = params.alpha_threshold;
    let (lo_s, hi_s) = (1.0 / params.max_scale, params.max_scale);
    let in_range = |s: f64| s >= lo_s && s <= hi_s;
    let originals: Vec<Option<Vec<Point>>> = stars.iter().map(|s| s.as_ref().map(|s| s.outline.clone())).collect();
    let branch_of = |stars: &[Option<Star>], v: usize, e: usize| -> Option<usize> {
        stars.get(v)?.as_ref()?.edges.iter().position(|&x| x == e)
    };
    // Cross-line of a star's branch: axis point and normal.
    let line = |s: &Star, j: usize| -> (Point, Point) {
        let d = [s.directions[j].cos(), s.directions[j].sin()];
        (add(s.center, mul(d, s.lengths[j])), perp(d))
    };
    let junction_extent = |s: &Star, j: usize| -> Option<[f64; 2]> {
        let w = s.widths[j];
        extent(&junctions.image, s.uvs[3 * j], s.uvs[3 * j + 1], -w, w, thr)
    };
    for slot in strips.iter_mut() {
        let Some(strip) = slot.as_ref() else { continue };
        let (e, ends) = (strip.edge, strip.ends);
        let w = strip.half_width;
        let ja = branch_of(stars, ends[0], e);
        let jb = branch_of(stars, ends[1], e);
        // Very short edge: junction to junction.
        if let (Some(ja), Some(jb)) = (ja, jb) {
            if strip.length < params.short_edge * w {
                let mid = mul(add(strip.p, strip.q), 0.5);
                let (sa, sb) = (stars[ends[0]].as_ref().expect("star"), stars[ends[1]].as_ref().expect("star"));
                let na = line(sa, ja).1;
                let (ea, eb) = (junction_extent(sa, ja), junction_extent(sb, jb));
                let (wa, wb) = (sa.widths[ja], sb.widths[jb]);
                // Star b's offsets along n_a are the negatives of its own.
                let eb_a = eb.map(|x| [-x[1], -x[0]]);
                let mut ta = [-wa, wa];
                let mut tb = [wb, -wb]; // b's (right, left) tips in a's frame
                let mut kind = MatchKind::Unmatched;
                let (mut sigma, mut tau) = (1.0, 0.0);
                if let (Some(ea), Some(ebx)) = (ea, eb_a) {
                    if let Some((s, t)) = fit(ebx, ea) {
                        kind = MatchKind::JunctionToJunction;
                        if in_range(s) {
                            tb = tb.map(|o| s * o + t);
                        } else {
                            let (s2, t2) = fit(ea, ebx).expect("both wide");
                            ta = ta.map(|o| s2 * o + t2);
                        }
                        (sigma, tau) = (s, t);
                    }
                }
                let sa = stars[ends[0]].as_mut().expect("star");
                sa.outline[3 * ja] = add(mid, mul(na, ta[0]));
                sa.outline[3 * ja + 1] = add(mid, mul(na, ta[1]));
                let sb = stars[ends[1]].as_mut().expect("star");
                sb.outline[3 * jb] = add(mid, mul(na, tb[0]));
                sb.outline[3 * jb + 1] = add(mid, mul(na, tb[1]));
                for (v, j, other, n) in
                    [(ends[0], ja, eb_a, na), (ends[1], jb, ea.map(|x| [-x[1], -x[0]]), mul(na, -1.0))]
                {
                    let s = stars[v].as_ref().expect("star");
                    report.branches.push(BranchMatch {
                        vertex: v,
                        branch: j,
                        edge: e,
                        kind,
                        origin: mid,
                        normal: n,
                        junction: junction_extent(s, j),
                        other,
                        sigma,
                        tau,
                    });
                }
                report.short_edges.push(e);
                slot.as_mut().expect("strip").polygon = None;
                continue;
            }
        }
        // Clip the quad to the end segments of its junctions, then match each end.
        let mut poly = strip.polygon.expect("unmatched strips have quads");
        let to_uv = strip.to_uv;
        for (end, j) in [(0usize, ja), (1usize, jb)] {
            let Some(j) = j else { continue };
            let s = stars[ends[end]].as_ref().expect("star");
            let (origin, n) = line(s, j);
            // Corner indices at this end, as (offset −w, offset +w) in the branch frame.
            let (cm, cp) = if end == 0 { (0, 3) } else { (2, 1) };
            for (c, o) in [(cm, -w), (cp, w)] {
                let pos = add(origin, mul(n, o));
                poly[c].pos = pos;
                poly[c].uv = apply(&to_uv, pos);
            }
            let ej = junction_extent(s, j);
            let ei = extent(&interstices.image, poly[cm].uv, poly[cp].uv, -w, w, thr);
            let mut m = BranchMatch {
                vertex: ends[end],
                branch: j,
                edge: e,
                kind: MatchKind::Unmatched,
                origin,
                normal: n,
                junction: ej,
                other: ei,
                sigma: 1.0,
                tau: 0.0,
            };
            if let (Some(ej), Some(ei)) = (ej, ei) {
                if let Some((sg, t)) = fit(ej, ei) {
                    (m.sigma, m.tau) = (sg, t);
                    if in_range(sg) {
                        m.kind = MatchKind::Junction;
                        let wj = s.widths[j];
                        let s = stars[ends[end]].as_mut().expect("star");
                        s.outline[3 * j] = add(origin, mul(n, -sg * wj + t));
                        s.outline[3 * j + 1] = add(origin, mul(n, sg * wj + t));
                    } else {
                        m.kind = MatchKind::Interstice;
                        let (s2, t2) = fit(ei, ej).expect("both wide");
                        poly[cm].pos = add(origin, mul(n, -s2 * w + t2));
                        poly[cp].pos = add(origin, mul(n, s2 * w + t2));
                    }
                }
            }
            report.branches.push(m);
        }
        let pos: Vec<Point> = poly.iter().map(|c| c.pos).collect();
        let ok = is_simple(&pos)
            && cross(sub(pos[1], pos[0]), sub(pos[2], pos[0])) > 0.0
            && cross(sub(pos[2], pos[0]), sub(pos[3], pos[0])) > 0.0;
        if !ok {
            // Restore the clipped, unmoved quad (positions on the end segments at ±w).
            for (end, j) in [(0usize, ja), (1usize, jb)] {
                let Some(j) = j else { continue };
                let s = stars[ends[end]].as_ref().expect("star");
                let (origin, n) = line(s, j);
                let (cm, cp) = if end == 0 { (0, 3) } else { (2, 1) };
                poly[cm].pos = add(origin, mul(n, -w));
                poly[cp].pos = add(origin, mul(n, w));
            }
            report.restored_strips.push(e);
        }
        slot.as_mut().expect("strip").polygon = Some(poly);
    }
    // Intermediate vertices follow their neighbours (similarity rule); invalid stars restored.
    for (vi, star) in stars.iter_mut().enumerate() {
        let Some(star) = star.as_mut() else { continue };
        let orig = originals[vi].as_ref().expect("star");
        let v = star.directions.len();
        let mut rel = Vec::with_capacity(v);
        for k in 0..v {
            let (m1, m2) = (3 * k + 1, (3 * k + 3) % (3 * v));
            let (a, b) = relative_coords(orig[3 * k + 2], orig[m1], orig[m2]);
            star.outline[3 * k + 2] = from_relative(a, b, star.outline[m1], star.outline[m2]);
            rel.push(Relative { vertex: vi, index: k, alpha: a, beta: b });
        }
        if star.outline != *orig && !(is_simple(&star.outline) && fan_is_valid(star.center, &star.outline)) {
            star.outline = orig.clone();
            report.restored_stars.push(vi);
            for b in report.branches.iter_mut().filter(|b| b.vertex == vi) {
                b.kind = MatchKind::Unmatched;
            }
        } else {
            report.relative.extend(rel);
        }
    }
    report
}
