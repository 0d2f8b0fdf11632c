//! Courses in a sample: detecting a layered meta-structure (rows of regions sharing
//! near-horizontal boundaries) and measuring what course-by-course synthesis draws from —
//! course heights, brick lengths, and the stagger of head joints between consecutive courses.
//!
//! The thesis's statistics treat a brick wall as independent ellipses, which regrows it as
//! cobbles; this measurement is the meta-structure they miss [references: frasson §3.8.1]
//!
//! Only near-horizontal courses are looked for (walls are drawn upright); a sample whose
//! courses run another way is reported as not layered. A region's top and bottom lines are
//! the medians of its upper and lower outline over the middle of its width (so a stone's
//! rounded corners, a bulge or a segmentation spur do not move them, as they would its
//! bounding box). Courses are chains of side-by-side regions whose lines agree with their
//! neighbour's: a rough course whose stones vary in height, or a course that tilts or bends
//! slowly, is still one chain, while a region's neighbours in an irregular wall rarely share
//! both lines. Course heights are pitches measured region against region between a course
//! and the one laid on it, so they hold for tilted or curved courses too. Painted samples
//! whose bricks are separated by a mortar region (gaps between the regions) are measured like
//! tilings: a course's pitch and a brick's length include half the mortar on either side.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::synth::structure::mesh::faces::point_in_polygon;
use crate::synth::structure::Point;

/// A course of the sample: a row of regions whose tops and bottoms line up.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Course {
    /// Median top and bottom lines of its regions, px (y down).
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
    /// Share of the interior regions that lie in a course: a chain of at least
    /// `MIN_COURSE_REGIONS` side-by-side regions, each sharing its top and bottom lines with
    /// its neighbour within `LINE_TOLERANCE` of their height.
    pub score: f64,
    /// The courses, top to bottom (a row broken by a misfit region may be two courses).
    pub courses: Vec<Course>,
    /// Course heights: the pitch from a course's top line to that of the course laid on it
    /// (the median over the regions of that course and the regions they sit on); a course
    /// nothing is found laid on, and that the sample's border does not cut, gives its own
    /// height plus the mean bed gap. In whole pixels (the sample is drawn on pixels, and a
    /// regrown wall is laid on them).
    pub heights: Vec<f64>,
    /// Brick lengths (interior regions of the courses: width plus the mean of the head gaps on
    /// either side, so from head joint to head joint), in whole pixels.
    pub lengths: Vec<f64>,
    /// Per course (same order as `courses`), its brick lengths.
    pub lengths_per_course: Vec<Vec<f64>>,
    /// Per head joint with a course above it: the distance to the nearest head joint of the
    /// course above, over the mean brick length (0 = a straight joint, 0.5 = running bond).
    pub stagger: Vec<f64>,
}

/// Score above which a sample is layered.
pub const LAYERED_SCORE: f64 = 0.75;
/// Fewest courses a layered sample has.
pub const MIN_COURSES: usize = 3;
/// Fewest regions in a course (two stones side by side line up by chance in an irregular
/// wall, three rarely do).
pub const MIN_COURSE_REGIONS: usize = 3;
/// How far (a fraction of their mean height) the top lines, and the bottom lines, of two
/// neighbours in a course may be apart.
pub const LINE_TOLERANCE: f64 = 0.15;
/// Widest head gap (a fraction of the typical region height) between neighbours in a course.
pub const HEAD_GAP: f64 = 0.5;
/// A head joint nearer than this (a fraction of the mean brick length) to one of the next
/// course's continues straight across it.
pub const STRAIGHT_JOINT: f64 = 0.1;

/// Samples of a region's outline taken across its width for its top and bottom lines, and
/// the share of the width left out at either end (rounded corners).
const OUTLINE_SAMPLES: usize = 16;
const OUTLINE_MARGIN: f64 = 0.15;
/// How far (px) an outline's median line may lie inside its box's edge and still be that edge.
const SNAP: f64 = 1.0;
/// How far (px) beyond a region's line another region is looked for.
const PROBE: f64 = 1.5;

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

/// A region's top and bottom lines: the medians of its upper and lower outline, sampled on
/// `OUTLINE_SAMPLES` verticals across the middle of its box `b` (a rectangle's are its box's
/// top and bottom).
pub fn outline_lines(poly: &[Point], b: [f64; 4]) -> (f64, f64) {
    let (mut tops, mut bottoms) = (Vec::with_capacity(OUTLINE_SAMPLES), Vec::with_capacity(OUTLINE_SAMPLES));
    for i in 0..OUTLINE_SAMPLES {
        let t = OUTLINE_MARGIN + (1.0 - 2.0 * OUTLINE_MARGIN) * (i as f64 + 0.5) / OUTLINE_SAMPLES as f64;
        let x = b[0] + (b[2] - b[0]) * t;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (k, p) in poly.iter().enumerate() {
            let q = poly[(k + 1) % poly.len()];
            if (p[0] <= x) != (q[0] <= x) {
                let y = p[1] + (x - p[0]) * (q[1] - p[1]) / (q[0] - p[0]);
                lo = lo.min(y);
                hi = hi.max(y);
            }
        }
        if lo <= hi {
            tops.push(lo);
            bottoms.push(hi);
        }
    }
    if tops.is_empty() {
        return (b[1], b[3]);
    }
    // A straight edge traced on pixels (or simplified) wobbles by a pixel: within `SNAP` of
    // its box's edge, the line is that edge.
    let (top, bottom) = (median(&mut tops), median(&mut bottoms));
    (b[1] + (top - b[1] - SNAP).max(0.0), b[3] - (b[3] - bottom - SNAP).max(0.0))
}

/// Whether any region but `skip` covers the point `p`.
fn covered(p: Point, polygons: &[Vec<Point>], boxes: &[[f64; 4]], skip: &[usize]) -> bool {
    (0..polygons.len()).any(|c| {
        let b = boxes[c];
        !skip.contains(&c)
            && b[0] <= p[0]
            && p[0] <= b[2]
            && b[1] <= p[1]
            && p[1] <= b[3]
            && point_in_polygon(p, &polygons[c])
    })
}

/// Detects courses among the regions (`polygons`, with `border` and `interior` flags: a
/// region used by the statistics is interior) of a `size` sample.
pub fn detect_courses(polygons: &[Vec<Point>], border: &[bool], interior: &[bool], size: [f64; 2]) -> CourseAnalysis {
    let n = polygons.len();
    let boxes: Vec<[f64; 4]> = polygons.iter().map(|p| bbox(p)).collect();
    let width = |r: usize| boxes[r][2] - boxes[r][0];
    let lines: Vec<(f64, f64)> = (0..n)
        .map(|r| {
            let b = boxes[r];
            if b[2] - b[0] > 0.5 && b[3] - b[1] > 0.5 {
                outline_lines(&polygons[r], b)
            } else {
                (b[1], b[3])
            }
        })
        .collect();
    let top = |r: usize| lines[r].0;
    let bottom = |r: usize| lines[r].1;
    let height = |r: usize| bottom(r) - top(r);
    let sized: Vec<usize> = (0..n).filter(|&r| height(r) > 0.5 && width(r) > 0.5).collect();
    // A region far taller than the typical one (painted mortar around every brick, whose
    // outline spans the sample) is no brick.
    let typical = median(&mut sized.iter().map(|&r| height(r)).collect::<Vec<_>>());
    let usable: Vec<usize> = sized.into_iter().filter(|&r| height(r) <= 2.5 * typical).collect();
    // Open sides: no region beyond a region's top (or bottom) line, across the middle of its
    // width — the sample's border, or an opening that cut the region; that line says nothing
    // about its course.
    let open = |r: usize, y: f64| {
        let b = boxes[r];
        [0.3, 0.5, 0.7].iter().all(|t| !covered([b[0] + t * (b[2] - b[0]), y], polygons, &boxes, &[r]))
    };
    let mut open_top = vec![false; n];
    let mut open_bottom = vec![false; n];
    for &r in &usable {
        open_top[r] = open(r, top(r) - PROBE);
        open_bottom[r] = open(r, bottom(r) + PROBE);
    }
    // Chains: side-by-side neighbours (a head gap under `HEAD_GAP` of the typical height, or
    // one no region fills, as an opening; overlapping by under half the narrower) whose top
    // lines and bottom lines agree — or one of them, when the other is open on either.
    let mut parent: Vec<usize> = (0..n).collect();
    for (i, &a) in usable.iter().enumerate() {
        for &b in &usable[i + 1..] {
            let tol = LINE_TOLERANCE * 0.5 * (height(a) + height(b));
            let tops = (top(a) - top(b)).abs() <= tol;
            let bottoms = (bottom(a) - bottom(b)).abs() <= tol;
            let lined = (tops || open_top[a] || open_top[b]) && (bottoms || open_bottom[a] || open_bottom[b]);
            if !lined || !(tops || bottoms) {
                continue;
            }
            let (ba, bb) = (boxes[a], boxes[b]);
            let gap = ba[0].max(bb[0]) - ba[2].min(bb[2]);
            if -gap > 0.5 * width(a).min(width(b)) {
                continue;
            }
            if gap > HEAD_GAP * typical {
                // Across an opening: no region on their centre line between them.
                let y = 0.5 * (top(a).max(top(b)) + bottom(a).min(bottom(b)));
                let x0 = ba[2].min(bb[2]);
                let k = ((gap / (0.5 * typical)).ceil() as usize).max(3);
                if (0..k).any(|i| covered([x0 + gap * (i as f64 + 0.5) / k as f64, y], polygons, &boxes, &[a, b])) {
                    continue;
                }
            }
            let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
            if ra != rb {
                parent[ra.max(rb)] = ra.min(rb);
            }
        }
    }
    let mut rows: BTreeMap<usize, Vec<usize>> = Default::default();
    for &r in &usable {
        let root = find(&mut parent, r);
        rows.entry(root).or_default().push(r);
    }
    let mut courses: Vec<Course> = Vec::new();
    for mut members in rows.into_values() {
        if members.len() < MIN_COURSE_REGIONS {
            continue;
        }
        members.sort_by(|&a, &b| boxes[a][0].total_cmp(&boxes[b][0]).then(a.cmp(&b)));
        let joints = members.windows(2).map(|p| 0.5 * (boxes[p[0]][2] + boxes[p[1]][0])).collect();
        courses.push(Course {
            top: median(&mut members.iter().map(|&r| top(r)).collect::<Vec<_>>()),
            bottom: median(&mut members.iter().map(|&r| bottom(r)).collect::<Vec<_>>()),
            regions: members,
            joints,
        });
    }
    courses.sort_by(|a, b| a.top.total_cmp(&b.top).then(boxes[a.regions[0]][0].total_cmp(&boxes[b.regions[0]][0])));
    let mut course_of: Vec<Option<usize>> = vec![None; n];
    for (k, c) in courses.iter().enumerate() {
        for &r in &c.regions {
            course_of[r] = Some(k);
        }
    }
    let n_interior = interior.iter().filter(|&&i| i).count();
    let n_aligned = (0..n).filter(|&r| interior[r] && course_of[r].is_some()).count();
    let score = if n_interior == 0 { 0.0 } else { n_aligned as f64 / n_interior as f64 };

    // Which course lies on which: each region of a course sits on the nearest region above it
    // (overlapping it by a quarter of the narrower, its bottom line at most `LINE_TOLERANCE`
    // below this one's top line); when that region is in a course and the bed gap between them
    // is under half its height, the two courses are stacked, and the difference of their top
    // lines is a sample of the pitch.
    let mut pitches: BTreeMap<(usize, usize), Vec<f64>> = Default::default();
    for (j, c) in courses.iter().enumerate() {
        for &b in &c.regions {
            let mut below_of: Option<usize> = None;
            for &a in &usable {
                if course_of[a] == Some(j) {
                    continue;
                }
                let overlap = boxes[a][2].min(boxes[b][2]) - boxes[a][0].max(boxes[b][0]);
                if overlap <= 0.25 * width(a).min(width(b)) || bottom(a) > top(b) + LINE_TOLERANCE * height(a) {
                    continue;
                }
                if below_of.is_none_or(|o| bottom(a) > bottom(o)) {
                    below_of = Some(a);
                }
            }
            let Some(a) = below_of else { continue };
            let Some(i) = course_of[a] else { continue };
            if top(b) - bottom(a) <= 0.5 * height(a) {
                pitches.entry((i, j)).or_default().push(top(b) - top(a));
            }
        }
    }
    let stacked: Vec<((usize, usize), f64)> = pitches.into_iter().map(|(k, mut v)| (k, median(&mut v))).collect();
    let gaps: Vec<f64> = stacked.iter().map(|&((i, j), _)| (courses[j].top - courses[i].bottom).max(0.0)).collect();
    let mean_gap = if gaps.is_empty() { 0.0 } else { gaps.iter().sum::<f64>() / gaps.len() as f64 };

    // Heights: the pitches to the courses laid on each course; a course with none its own
    // height plus the mean gap, unless the sample's border cuts it.
    let mut heights = Vec::new();
    for (k, c) in courses.iter().enumerate() {
        if c.top <= 0.5 {
            continue;
        }
        let on: Vec<f64> = stacked.iter().filter(|&&((i, _), _)| i == k).map(|&(_, p)| p).collect();
        if !on.is_empty() {
            heights.extend(on.iter().map(|h| h.round()));
        } else if c.bottom < size[1] - 0.5 {
            heights.push((c.bottom - c.top + mean_gap).round());
        }
    }
    // Lengths: interior regions of a course, from head joint to head joint (their width plus
    // the mean of the head gaps on either side; negative where outlines interlock).
    let mut lengths = Vec::new();
    let mut lengths_per_course = Vec::new();
    for c in &courses {
        let heads: Vec<f64> = c.regions.windows(2).map(|p| boxes[p[1]][0] - boxes[p[0]][2]).collect();
        let mean_head = heads.iter().sum::<f64>() / heads.len().max(1) as f64;
        let l: Vec<f64> = c
            .regions
            .iter()
            .enumerate()
            .filter(|&(_, &r)| !border[r] && interior[r])
            .map(|(k, &r)| {
                let sides: Vec<f64> =
                    [k.checked_sub(1).map(|p| heads[p]), heads.get(k).copied()].into_iter().flatten().collect();
                let head = if sides.is_empty() { mean_head } else { sides.iter().sum::<f64>() / sides.len() as f64 };
                (width(r) + head).round()
            })
            .collect();
        lengths.extend(&l);
        lengths_per_course.push(l);
    }
    let mean_length = lengths.iter().sum::<f64>() / lengths.len().max(1) as f64;
    // Stagger: each head joint against the head joints of the courses it is laid on, within
    // their extent.
    let mut stagger = Vec::new();
    if mean_length > 0.0 {
        for (j, below) in courses.iter().enumerate() {
            let above: Vec<&Course> =
                stacked.iter().filter(|&&((_, b), _)| b == j).map(|&((a, _), _)| &courses[a]).collect();
            let joints: Vec<f64> = above.iter().flat_map(|c| c.joints.iter().copied()).collect();
            if joints.is_empty() {
                continue;
            }
            let extents: Vec<(f64, f64)> = above
                .iter()
                .map(|c| {
                    (boxes[c.regions[0]][0], c.regions.iter().map(|&r| boxes[r][2]).fold(f64::NEG_INFINITY, f64::max))
                })
                .collect();
            for &x in &below.joints {
                if !extents.iter().any(|&(x0, x1)| x0 <= x && x <= x1) {
                    continue;
                }
                let d = joints.iter().map(|&a| (a - x).abs()).fold(f64::INFINITY, f64::min);
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

    /// A rough running bond on 480 × 330 px: 8 courses whose lines tilt (1 in 25) and bend
    /// (±4 px), bricks 40–60 px long whose tops and bottoms each sit up to ±3 px off the line
    /// and whose outlines wobble by a pixel; a gap of 2 px between bricks. The course pitch is
    /// 40 px. Returns the polygons and their border flags.
    fn rough_bond() -> (Vec<Vec<Point>>, Vec<bool>) {
        let mut rng = crate::synth::rng::Rng::new(11);
        let line = |k: usize, x: f64| 10.0 + 40.0 * k as f64 + 0.04 * x + 4.0 * (x / 90.0).sin();
        let (mut polys, mut border) = (Vec::new(), Vec::new());
        for k in 0..8 {
            let mut x = if k % 2 == 0 { 0.0 } else { -25.0 };
            while x < 480.0 {
                let len = rng.range(40.0, 60.0);
                let (x0, x1) = (f64::max(x, 0.0), f64::min(x + len - 2.0, 480.0));
                let (dt, db) = (rng.range(-3.0, 3.0), rng.range(-3.0, 3.0));
                let mut poly = Vec::new();
                for i in 0..=8 {
                    let xi = x0 + (x1 - x0) * i as f64 / 8.0;
                    poly.push([xi, line(k, xi) + 1.0 + dt + rng.range(-1.0, 1.0)]);
                }
                for i in (0..=8).rev() {
                    let xi = x0 + (x1 - x0) * i as f64 / 8.0;
                    poly.push([xi, line(k + 1, xi) - 1.0 + db + rng.range(-1.0, 1.0)]);
                }
                border.push(x0 <= 0.0 || x1 >= 480.0);
                polys.push(poly);
                x += len;
            }
        }
        (polys, border)
    }

    #[test]
    fn rough_courses_that_tilt_and_bend_are_layered() {
        let (polys, border) = rough_bond();
        let interior: Vec<bool> = border.iter().map(|b| !b).collect();
        let c = detect_courses(&polys, &border, &interior, [480.0, 360.0]);
        assert!(c.layered, "score {}", c.score);
        assert!(c.score >= 0.95, "score {}", c.score);
        assert_eq!(c.courses.len(), 8, "{:?}", c.courses.iter().map(|c| c.regions.len()).collect::<Vec<_>>());
        // Pitches measured region against region: 40 px give or take the bricks' offsets.
        assert!(c.heights.iter().all(|h| (h - 40.0).abs() <= 3.0), "{:?}", c.heights);
        assert!(c.lengths.iter().all(|&l| (40.0..=61.0).contains(&l)), "{:?}", c.lengths);
        let straight = c.stagger.iter().filter(|&&s| s <= STRAIGHT_JOINT).count();
        assert!(straight * 5 < c.stagger.len(), "{:?}", c.stagger);
    }

    #[test]
    fn a_spur_or_an_opening_does_not_break_a_course() {
        let (mut polys, border) = running_bond();
        let find = |polys: &[Vec<Point>], b: [f64; 4]| polys.iter().position(|p| bbox(p) == b).expect("brick");
        // A segmentation spur 8 px up out of a brick's top: its box grows, its line does not.
        let r = find(&polys, [20.0, 16.0, 60.0, 32.0]);
        polys[r] =
            vec![[20.0, 16.0], [38.0, 16.0], [40.0, 8.0], [42.0, 16.0], [60.0, 16.0], [60.0, 32.0], [20.0, 32.0]];
        // An opening from x = 60 to 140, y = 40 to 64: the fourth course's two bricks in it
        // are gone, the three third-course bricks it cuts keep what lies above it.
        let r = find(&polys, [40.0, 32.0, 80.0, 48.0]);
        polys[r] = vec![[40.0, 32.0], [80.0, 32.0], [80.0, 40.0], [60.0, 40.0], [60.0, 48.0], [40.0, 48.0]];
        let r = find(&polys, [80.0, 32.0, 120.0, 48.0]);
        polys[r] = rect(80.0, 32.0, 120.0, 40.0);
        let r = find(&polys, [120.0, 32.0, 160.0, 48.0]);
        polys[r] = vec![[120.0, 32.0], [160.0, 32.0], [160.0, 48.0], [140.0, 48.0], [140.0, 40.0], [120.0, 40.0]];
        let gone = [find(&polys, [60.0, 48.0, 100.0, 64.0]), find(&polys, [100.0, 48.0, 140.0, 64.0])];
        let (polys, border): (Vec<_>, Vec<_>) =
            polys.into_iter().zip(border).enumerate().filter(|(i, _)| !gone.contains(i)).map(|(_, p)| p).unzip();
        let interior: Vec<bool> = border.iter().map(|b| !b).collect();
        let c = detect_courses(&polys, &border, &interior, [200.0, 96.0]);
        assert!(c.layered, "{c:?}");
        assert_eq!(c.courses.len(), 6, "{:?}", c.courses);
        // Every region lies in a course, the fourth course across the opening.
        assert_eq!(c.courses.iter().map(|c| c.regions.len()).sum::<usize>(), polys.len());
        assert_eq!(c.courses[3].regions.len(), 4);
        assert!(c.heights.iter().all(|h| *h == 16.0), "{:?}", c.heights);
    }

    #[test]
    fn stacked_bond_joints_continue_straight() {
        let joints = vec![vec![40.0, 80.0], vec![40.5, 80.0], vec![60.0]];
        // Two straight joints above, two staggered ones below.
        assert_eq!(staggered_share(&joints, 40.0), Some(0.5));
    }
}
