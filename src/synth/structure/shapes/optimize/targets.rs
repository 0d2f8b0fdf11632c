//! Algorithm 2 of stage 2: the regions associated with their closest originals, each vertex's
//! target on the placed original (closest vertex or matched corners), and the errors the
//! iterations minimise.

use super::params::{ShapeParams, TargetRule};
use crate::synth::structure::shapes::associate::{associate_one, AssocKind, Association, OriginalShapes, Prior};
use crate::synth::structure::types::Point;
use rayon::prelude::*;

/// An association in force during the iterations.
#[derive(Clone)]
pub(super) struct Active {
    /// `(vertex, target)` for the vertices of the region's current cycle.
    pub(super) targets: Vec<(usize, Point)>,
}

impl Active {
    /// Vertex `removed` was merged into `kept`: `kept` keeps its own target if it has one,
    /// otherwise it takes over the removed vertex's.
    pub(super) fn merge(&mut self, removed: usize, kept: usize) {
        let has_kept = self.targets.iter().any(|t| t.0 == kept);
        if has_kept {
            self.targets.retain(|t| t.0 != removed);
        } else {
            for t in &mut self.targets {
                if t.0 == removed {
                    t.0 = kept;
                }
            }
        }
    }
}

pub(super) struct Round {
    pub(super) associations: Vec<Option<Association>>,
    pub(super) fallbacks: usize,
    pub(super) failed: usize,
    pub(super) log: Vec<String>,
}

/// One association of a region's polygon, kept for reuse.
#[derive(Clone)]
struct Cached {
    poly: Vec<Point>,
    association: Option<Association>,
    msg: Option<String>,
}

/// Associates regions (Algorithm 2) against originals whose shapes are computed once. The
/// last two associations of every region are remembered: a region whose polygon is
/// unchanged (bit for bit) gets the same association again without a search (the
/// association is a pure function of the polygon), and a changed one starts its search at
/// its previous original, which only makes it faster.
pub(super) struct Associator {
    shapes: OriginalShapes,
    empty: bool,
    params: ShapeParams,
    /// Per region, the generator it was grown from (shorter than the regions: none).
    priors: Vec<Option<Prior>>,
    /// Per region, the most recent association first.
    cache: Vec<Vec<Cached>>,
}

impl Associator {
    pub(super) fn new(originals: &[Vec<Point>], priors: &[Option<Prior>], params: &ShapeParams) -> Self {
        Associator {
            shapes: OriginalShapes::new(originals),
            empty: originals.is_empty(),
            params: *params,
            priors: priors.to_vec(),
            cache: Vec::new(),
        }
    }

    /// Associates the eligible regions; others get `None`.
    pub(super) fn round(&mut self, verts: &[Point], regions: &[Vec<usize>], eligible: &[bool]) -> Round {
        let ids: Vec<usize> = (0..regions.len()).filter(|&r| eligible[r]).collect();
        let mut associations = vec![None; regions.len()];
        if self.empty || ids.is_empty() {
            return Round { associations, fallbacks: 0, failed: 0, log: Vec::new() };
        }
        if self.cache.len() < regions.len() {
            self.cache.resize(regions.len(), Vec::new());
        }
        let aparams = self.params.associate_params();
        let (shapes, cache, priors) = (&self.shapes, &self.cache, &self.priors);
        let fresh: Vec<(Vec<Point>, Option<Cached>)> = ids
            .par_iter()
            .map(|&r| {
                let poly: Vec<Point> = regions[r].iter().map(|&i| verts[i]).collect();
                if let Some(c) = cache[r].iter().find(|c| c.poly == poly) {
                    return (poly, Some(c.clone()));
                }
                let hint = cache[r].first().and_then(|c| c.association.as_ref()).map(|a| a.original);
                let (association, msg) =
                    associate_one(r, &poly, shapes, &aparams, hint, priors.get(r).copied().flatten());
                (poly, Some(Cached { poly: Vec::new(), association, msg }))
            })
            .collect();
        let (mut fallbacks, mut failed, mut log) = (0, 0, Vec::new());
        for (&r, (poly, c)) in ids.iter().zip(fresh) {
            let mut c = c.expect("computed or cached");
            c.poly = poly;
            match c.association.as_ref().map(|a| a.kind) {
                Some(AssocKind::Widened(_) | AssocKind::NearestArea) => fallbacks += 1,
                Some(AssocKind::Within) => {}
                None => failed += 1,
            }
            log.extend(c.msg.clone());
            associations[r] = c.association.clone();
            let slot = &mut self.cache[r];
            if let Some(k) = slot.iter().position(|x| x.poly == c.poly) {
                slot.remove(k);
            }
            slot.insert(0, c);
            slot.truncate(2);
        }
        Round { associations, fallbacks, failed, log }
    }

    /// Mean turning distance between each eligible region and its closest original (a fresh
    /// association).
    pub(super) fn error(&mut self, verts: &[Point], regions: &[Vec<usize>], eligible: &[bool]) -> f64 {
        mean_distance(&self.round(verts, regions, eligible).associations)
    }
}

/// The target of every vertex of `poly` on the placed original.
pub(super) fn vertex_targets(poly: &[Point], placed: &[Point], rule: TargetRule) -> Vec<Point> {
    match rule {
        TargetRule::ClosestVertex => poly
            .iter()
            .map(|p| {
                let mut best = (f64::INFINITY, *p);
                for q in placed {
                    let d = (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2);
                    if d < best.0 {
                        best = (d, *q);
                    }
                }
                best.1
            })
            .collect(),
        TargetRule::MatchedCorners => matched_corner_targets(poly, placed),
    }
}

/// Targets of [`TargetRule::MatchedCorners`] for the vertices of `poly`.
pub(super) fn matched_corner_targets(poly: &[Point], placed: &[Point]) -> Vec<Point> {
    let m = placed.len();
    let d2 = |a: Point, b: Point| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2);
    let corners: Vec<Point> = (0..m)
        .filter(|&k| {
            crate::synth::structure::analysis::stats::turn_angle(
                placed[(k + m - 1) % m],
                placed[k],
                placed[(k + 1) % m],
            )
            .abs()
                > 5f64.to_radians()
        })
        .map(|k| placed[k])
        .collect();
    let nearest = |p: Point, set: &[Point]| -> Option<usize> {
        let mut best: Option<(usize, f64)> = None;
        for (k, &q) in set.iter().enumerate() {
            let d = d2(p, q);
            if best.is_none_or(|b| d < b.1) {
                best = Some((k, d));
            }
        }
        best.map(|b| b.0)
    };
    poly.iter()
        .enumerate()
        .map(|(i, &p)| {
            if let Some(c) = nearest(p, &corners) {
                if nearest(corners[c], poly) == Some(i) {
                    return corners[c];
                }
            }
            // The closest point of the boundary.
            let mut best = (f64::INFINITY, p);
            for k in 0..m {
                let (a, b) = (placed[k], placed[(k + 1) % m]);
                let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
                let l2 = dx * dx + dy * dy;
                let t = if l2 > 0.0 { (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0) } else { 0.0 };
                let q = [a[0] + t * dx, a[1] + t * dy];
                let d = d2(p, q);
                if d < best.0 {
                    best = (d, q);
                }
            }
            best.1
        })
        .collect()
}

/// Mean turning distance of the associations (`0` if there are none).
pub(super) fn mean_distance(associations: &[Option<Association>]) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for a in associations.iter().flatten() {
        if a.distance.is_finite() {
            sum += a.distance;
            n += 1;
        }
    }
    if n == 0 {
        0.0
    } else {
        sum / n as f64
    }
}
