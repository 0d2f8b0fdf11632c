//! Courses in a sample: detecting a layered meta-structure (rows of regions sharing
//! near-horizontal boundaries) and measuring what course-by-course synthesis draws from —
//! course heights, brick lengths, and the stagger of head joints between consecutive courses.
//!
//! The thesis's statistics treat a brick wall as independent ellipses, which regrows it as
//! cobbles; this measurement is the meta-structure they miss [references: frasson §3.8.1]
//!
//! Only horizontal courses are looked for (walls are drawn upright); a sample whose courses
//! run another way is reported as not layered. Works on region bounding boxes, so painted
//! samples whose bricks are separated by a mortar region (gaps between the boxes) are
//! measured like tilings: a course's pitch and a brick's length include half the mortar on
//! either side.

use serde::{Deserialize, Serialize};

use crate::synth::structure::Point;

/// A course of the sample: a row of regions whose tops and bottoms line up.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Course {
    /// Median top and bottom of its regions, px (y down).
    pub top: f64,
    pub bottom: f64,
    /// Its regions (sample region indices), left to right.
    pub regions: Vec<usize>,
    /// Head-joint positions (between consecutive regions), px.
    pub joints: Vec<f64>,
}

/// The course measurement of a sample, and the detector's decision.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CourseAnalysis {
    /// The detector's decision: `score ≥ LAYERED_SCORE` over at least `MIN_COURSES` courses.
    pub layered: bool,
    /// Share of the interior regions that lie in a course (top and bottom within 15 % of
    /// the course height of the course's lines, in a course of at least two regions).
    pub score: f64,
    /// The courses, top to bottom.
    pub courses: Vec<Course>,
    /// Course heights (the pitch from one course's top to the next's; the last uncut course
    /// its own height plus the mean gap), px.
    pub heights: Vec<f64>,
    /// Brick lengths (interior aligned regions: width plus the course's mean head gap), px.
    pub lengths: Vec<f64>,
    /// Per course (same order as `courses`), its brick lengths.
    pub lengths_per_course: Vec<Vec<f64>>,
    /// Per head joint with a course above it: the distance to the nearest head joint of the
    /// course above, over the mean brick length (0 = a straight joint, 0.5 = running bond).
    pub stagger: Vec<f64>,
}

/// Score above which a sample is layered.
pub const LAYERED_SCORE: f64 = 0.75;
/// Fewest courses (of two regions or more) a layered sample has.
pub const MIN_COURSES: usize = 3;
/// How far (a fraction of the course height) a region's top or bottom may be from its
/// course's line and still lie in it.
pub const LINE_TOLERANCE: f64 = 0.15;
/// A head joint nearer than this (a fraction of the mean brick length) to one of the next
/// course's continues straight across it.
pub const STRAIGHT_JOINT: f64 = 0.1;

/// Axis-aligned box `[x0, y0, x1, y1]` of a polygon.
pub fn bbox(poly: &[Point]) -> [f64; 4] {
    let mut b = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
    for p in poly {
        b = [b[0].min(p[0]), b[1].min(p[1]), b[2].max(p[0]), b[3].max(p[1])];
    }
    b
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return 0.0;
    }
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// Detects courses among the regions (`polygons`, with `border` and `interior` flags: a
/// region used by the statistics is interior) of a `size` sample.
pub fn detect_courses(polygons: &[Vec<Point>], border: &[bool], interior: &[bool], size: [f64; 2]) -> CourseAnalysis {
    let boxes: Vec<[f64; 4]> = polygons.iter().map(|p| bbox(p)).collect();
    let height = |r: usize| boxes[r][3] - boxes[r][1];
    let sized: Vec<usize> = (0..boxes.len()).filter(|&r| height(r) > 0.5 && boxes[r][2] - boxes[r][0] > 0.5).collect();
    // A region far taller than the typical one (painted mortar around every brick, whose box
    // is the sample's) would join every row: it is no brick.
    let typical = median(&mut sized.iter().map(|&r| height(r)).collect::<Vec<_>>());
    let usable: Vec<usize> = sized.into_iter().filter(|&r| height(r) <= 2.5 * typical).collect();
    // Rows: regions whose vertical extents overlap by ≥ 70 % of the smaller one.
    let mut parent: Vec<usize> = (0..boxes.len()).collect();
    for (i, &a) in usable.iter().enumerate() {
        for &b in &usable[i + 1..] {
            let (ba, bb) = (boxes[a], boxes[b]);
            let overlap = ba[3].min(bb[3]) - ba[1].max(bb[1]);
            let smaller = (ba[3] - ba[1]).min(bb[3] - bb[1]);
            if overlap >= 0.7 * smaller {
                let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
                if ra != rb {
                    parent[ra.max(rb)] = ra.min(rb);
                }
            }
        }
    }
    let mut rows: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for &r in &usable {
        let root = find(&mut parent, r);
        rows.entry(root).or_default().push(r);
    }
    let mut courses: Vec<Course> = Vec::new();
    let mut aligned = vec![false; boxes.len()];
    for members in rows.values() {
        if members.len() < 2 {
            continue;
        }
        let top = median(&mut members.iter().map(|&r| boxes[r][1]).collect::<Vec<_>>());
        let bottom = median(&mut members.iter().map(|&r| boxes[r][3]).collect::<Vec<_>>());
        let tol = (LINE_TOLERANCE * (bottom - top)).max(1.5);
        let mut inside: Vec<usize> = members
            .iter()
            .copied()
            .filter(|&r| {
                let b = boxes[r];
                // A region cut by the sample's top or bottom border keeps the line it has.
                let top_ok = (b[1] - top).abs() <= tol || (b[1] <= 0.5 && top <= 0.5);
                let bottom_ok = (b[3] - bottom).abs() <= tol || (b[3] >= size[1] - 0.5 && bottom >= size[1] - 0.5);
                top_ok && bottom_ok
            })
            .collect();
        if inside.len() < 2 {
            continue;
        }
        inside.sort_by(|&a, &b| boxes[a][0].total_cmp(&boxes[b][0]).then(a.cmp(&b)));
        for &r in &inside {
            aligned[r] = true;
        }
        let joints = inside.windows(2).map(|p| 0.5 * (boxes[p[0]][2] + boxes[p[1]][0])).collect();
        courses.push(Course { top, bottom, regions: inside, joints });
    }
    courses.sort_by(|a, b| a.top.total_cmp(&b.top));
    let n_interior = interior.iter().filter(|&&i| i).count();
    let n_aligned = (0..boxes.len()).filter(|&r| interior[r] && aligned[r]).count();
    let score = if n_interior == 0 { 0.0 } else { n_aligned as f64 / n_interior as f64 };

    // Heights: course pitch between consecutive courses (gap included); the last course's
    // own height plus the mean gap when the sample's border does not cut it.
    let cut_top = |c: &Course| c.top <= 0.5;
    let cut_bottom = |c: &Course| c.bottom >= size[1] - 0.5;
    let gaps: Vec<f64> = courses.windows(2).map(|p| (p[1].top - p[0].bottom).max(0.0)).collect();
    let mean_gap = if gaps.is_empty() { 0.0 } else { gaps.iter().sum::<f64>() / gaps.len() as f64 };
    let mut heights = Vec::new();
    for (k, c) in courses.iter().enumerate() {
        if cut_top(c) {
            continue;
        }
        match courses.get(k + 1) {
            Some(next) => heights.push(next.top - c.top),
            None if !cut_bottom(c) => heights.push(c.bottom - c.top + mean_gap),
            None => {}
        }
    }
    // Lengths: interior regions of a course, their width plus the course's mean head gap.
    let mut lengths = Vec::new();
    let mut lengths_per_course = Vec::new();
    for c in &courses {
        let heads: Vec<f64> = c.regions.windows(2).map(|p| (boxes[p[1]][0] - boxes[p[0]][2]).max(0.0)).collect();
        let head_gap = heads.iter().sum::<f64>() / heads.len().max(1) as f64;
        let l: Vec<f64> = c
            .regions
            .iter()
            .filter(|&&r| !border[r] && interior[r])
            .map(|&r| boxes[r][2] - boxes[r][0] + head_gap)
            .collect();
        lengths.extend(&l);
        lengths_per_course.push(l);
    }
    let mean_length = lengths.iter().sum::<f64>() / lengths.len().max(1) as f64;
    // Stagger: each head joint against the course above, when the two courses touch.
    let mut stagger = Vec::new();
    if mean_length > 0.0 {
        for p in courses.windows(2) {
            let (above, below) = (&p[0], &p[1]);
            let pitch = below.top - above.top;
            if below.top - above.bottom > 0.5 * pitch || above.joints.is_empty() {
                continue;
            }
            for &j in &below.joints {
                let d = above.joints.iter().map(|&a| (a - j).abs()).fold(f64::INFINITY, f64::min);
                stagger.push(d / mean_length);
            }
        }
    }
    let layered = score >= LAYERED_SCORE && courses.len() >= MIN_COURSES && !heights.is_empty() && !lengths.is_empty();
    CourseAnalysis { layered, score, courses, heights, lengths, lengths_per_course, stagger }
}

/// Share of head joints (of `joints` per course, top to bottom) that do not continue
/// straight into the next course: farther than `STRAIGHT_JOINT × mean_length` from every
/// head joint of the course below. `None` without a pair of courses with joints.
pub fn staggered_share(joints: &[Vec<f64>], mean_length: f64) -> Option<f64> {
    let (mut total, mut staggered) = (0usize, 0usize);
    for p in joints.windows(2) {
        if p[1].is_empty() {
            continue;
        }
        for &j in &p[0] {
            total += 1;
            let d = p[1].iter().map(|&b| (b - j).abs()).fold(f64::INFINITY, f64::min);
            if d > STRAIGHT_JOINT * mean_length {
                staggered += 1;
            }
        }
    }
    (total > 0).then(|| staggered as f64 / total as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<Point> {
        vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
    }

    /// A running bond of 40 × 16 px bricks on 200 × 96 px.
    fn running_bond() -> (Vec<Vec<Point>>, Vec<bool>) {
        let mut polys = Vec::new();
        for k in 0..6 {
            let y = 16.0 * k as f64;
            let mut x: f64 = if k % 2 == 0 { 0.0 } else { -20.0 };
            while x < 200.0 {
                polys.push(rect(x.max(0.0), y, (x + 40.0).min(200.0), y + 16.0));
                x += 40.0;
            }
        }
        let border = polys.iter().map(|p| {
            let b = bbox(p);
            b[0] <= 0.0 || b[1] <= 0.0 || b[2] >= 200.0 || b[3] >= 96.0
        });
        (polys.clone(), border.collect())
    }

    #[test]
    fn a_running_bond_is_layered_with_half_brick_stagger() {
        let (polys, border) = running_bond();
        let interior: Vec<bool> = border.iter().map(|b| !b).collect();
        let c = detect_courses(&polys, &border, &interior, [200.0, 96.0]);
        assert!(c.layered, "{c:?}");
        assert_eq!(c.courses.len(), 6);
        assert!((c.score - 1.0).abs() < 1e-9);
        assert!(c.heights.iter().all(|h| (h - 16.0).abs() < 1e-9), "{:?}", c.heights);
        assert!(c.lengths.iter().all(|l| (l - 40.0).abs() < 1e-9), "{:?}", c.lengths);
        assert!(c.stagger.iter().all(|s| (s - 0.5).abs() < 1e-9), "{:?}", c.stagger);
        let joints: Vec<Vec<f64>> = c.courses.iter().map(|c| c.joints.clone()).collect();
        assert_eq!(staggered_share(&joints, 40.0), Some(1.0));
    }

    #[test]
    fn stacked_bond_joints_continue_straight() {
        let joints = vec![vec![40.0, 80.0], vec![40.5, 80.0], vec![60.0]];
        // Two straight joints above, two staggered ones below.
        assert_eq!(staggered_share(&joints, 40.0), Some(0.5));
    }
}
