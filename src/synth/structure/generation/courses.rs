//! Course-by-course synthesis of a layered sample (beyond the thesis, which regrows a brick
//! wall as cobbles): courses whose heights are drawn from the sample's course heights, bricks
//! whose lengths are drawn from its brick lengths, head joints staggered against the course
//! above as the sample's are [references: frasson §3.8.1]
//!
//! Heights and lengths are drawn from the sample's measured values (rounded to whole pixels at
//! the structure's `scale`; heights dealt in shuffled rounds of all the sample's — the first
//! course, cut by the target's top, gives its height back — lengths a bootstrap), so the
//! wall varies exactly as much as the sample does and no more. Each course starts with its
//! first head joint at a stagger drawn from the sample's, so a sample of equal bricks regrows
//! in its own bond; later joints that would continue a joint of the course above (nearer
//! than the sample's tenth-percentile stagger, at most a fifth of the mean length) are drawn
//! again, up to eight times. At the target's
//! border a course or brick is cut, but never to a sliver: one under a quarter of its size
//! (or 3 px) joins its neighbour.
//!
//! The occupancy map acts as on the statistical path: a brick whose centre is forbidden (or,
//! with `any_overlap`, any of whose pixels is) is removed, the others are cut by the forbidden
//! pixels. A removed brick's allowed pixels go to the nearest kept brick of its course along
//! the pixel row (as Lloyd would have grown a neighbour into them), unless a forbidden pixel
//! lies between; a brick cut into pieces keeps its largest piece and the others become
//! regions of their own.

use serde::{Deserialize, Serialize};

use crate::synth::rng::Rng;
use crate::synth::structure::analysis::courses::CourseAnalysis;
use crate::synth::structure::analysis::ellipse::fit_polygon;
use crate::synth::structure::relaxation::controls::RemoveMode;
use crate::synth::structure::{Ellipse, Labels, NO_REGION};

/// One brick of a synthesised wall: its box `[x0, y0, x1, y1]` (whole pixels, clipped to the
/// target), its course, and whether the occupancy map kept it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Brick {
    pub rect: [f64; 4],
    pub course: usize,
    pub kept: bool,
}

/// A synthesised wall: every brick of every course, top to bottom, left to right.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CourseLayout {
    pub bricks: Vec<Brick>,
}

impl CourseLayout {
    /// The kept bricks' ellipses (the generators their regions stand for), in brick order.
    pub fn ellipses(&self) -> Vec<Ellipse> {
        self.bricks.iter().filter(|b| b.kept).map(|b| rect_ellipse(b.rect)).collect()
    }
}

/// The ellipse of a box: the polygon fit of its four corners.
pub fn rect_ellipse(r: [f64; 4]) -> Ellipse {
    fit_polygon(&[[r[0], r[1]], [r[2], r[1]], [r[2], r[3]], [r[0], r[3]]]).expect("a brick has area")
}

/// Narrowest piece of a brick or course (px) left at the target's border; a narrower one
/// (or one under a quarter of a brick or course) joins its neighbour.
const MIN_PIECE: f64 = 3.0;

/// Most draws for a head joint that would continue one of the course above.
const JOINT_TRIES: usize = 8;

fn draw(pool: &[f64], scale: f64, least: f64, rng: &mut Rng) -> f64 {
    (pool[rng.below(pool.len())] * scale).round().max(least)
}

/// The sample's values dealt in shuffled rounds: every value once before any twice, so a
/// wall of few courses still has the sample's spread of heights (iid draws from a dozen
/// heights would not).
struct Deck {
    values: Vec<f64>,
    next: usize,
}

impl Deck {
    fn new(values: &[f64]) -> Self {
        Deck { values: values.to_vec(), next: values.len() }
    }

    fn deal(&mut self, scale: f64, least: f64, rng: &mut Rng) -> f64 {
        if self.next == self.values.len() {
            rng.shuffle(&mut self.values);
            self.next = 0;
        }
        self.next += 1;
        (self.values[self.next - 1] * scale).round().max(least)
    }
}

/// Lays courses over `w × h` from the sample's course measurement at `scale`. `courses` must
/// have heights and lengths (a layered sample has).
pub fn layout_courses(w: usize, h: usize, courses: &CourseAnalysis, scale: f64, rng: &mut Rng) -> CourseLayout {
    let (wf, hf) = (w as f64, h as f64);
    let heights = &courses.heights;
    let lengths = &courses.lengths;
    assert!(!heights.is_empty() && !lengths.is_empty(), "a layered sample has heights and lengths");
    let mean_l = (lengths.iter().sum::<f64>() / lengths.len() as f64 * scale).max(2.0);
    let mut stagger = courses.stagger.clone();
    stagger.sort_by(f64::total_cmp);
    let least_stagger = if stagger.is_empty() { 0.2 } else { stagger[stagger.len() / 10].min(0.2) };
    let mut bricks = Vec::new();
    let mut heights = Deck::new(heights);
    let first_h = heights.deal(scale, 1.0, rng);
    // The first course shows at least a quarter of its height. Cut by the target's top, it
    // gives its height back to the deck (the next course takes it), so the whole courses deal
    // the sample's heights in whole rounds.
    let mut y = -(rng.next_f64() * 0.75 * first_h).floor();
    if y < 0.0 {
        heights.next -= 1;
    }
    let mut h_k = first_h;
    // The previous course's boundaries (its first ≤ 0, its last ≥ w).
    let mut above: Vec<f64> = Vec::new();
    let mut k = 0;
    while y < hf {
        // A sliver of a course left below this one joins it.
        let rest = hf - (y + h_k);
        if rest > 0.0 && rest < (0.25 * h_k).max(MIN_PIECE) {
            h_k = hf - y;
        }
        let nearest = |x: f64, above: &[f64]| above.iter().map(|&a| (a - x).abs()).fold(f64::INFINITY, f64::min);
        let mut bounds = Vec::new();
        let mut x = if above.is_empty() {
            -(rng.next_f64() * mean_l).floor()
        } else {
            let s = if stagger.is_empty() { 0.5 } else { stagger[rng.below(stagger.len())] };
            let mut x0 = above[0] + (s * mean_l).round();
            while x0 > 0.0 {
                x0 -= mean_l.round();
            }
            x0
        };
        bounds.push(x);
        while x < wf {
            let mut best = (f64::NEG_INFINITY, 0.0);
            for _ in 0..JOINT_TRIES {
                let next = x + draw(lengths, scale, 2.0, rng);
                let d = if above.is_empty() { f64::INFINITY } else { nearest(next, &above) };
                if d > best.0 {
                    best = (d, next);
                }
                if d >= least_stagger * mean_l {
                    best = (d, next);
                    break;
                }
            }
            x = best.1;
            bounds.push(x);
        }
        // Slivers of bricks at the ends join their neighbours.
        let least = (0.25 * mean_l).max(MIN_PIECE);
        let n = bounds.len();
        if n >= 3 && wf - bounds[n - 2] < least {
            bounds.remove(n - 2);
        }
        if bounds.len() >= 3 && bounds[1] < least {
            bounds.remove(1);
        }
        let (y0, y1) = (y.max(0.0), (y + h_k).min(hf));
        for p in bounds.windows(2) {
            let (x0, x1) = (p[0].max(0.0), p[1].min(wf));
            if x1 - x0 >= 1.0 && y1 - y0 >= 1.0 {
                bricks.push(Brick { rect: [x0, y0, x1, y1], course: k, kept: true });
            }
        }
        above = bounds;
        y += h_k;
        h_k = heights.deal(scale, 1.0, rng);
        k += 1;
    }
    CourseLayout { bricks }
}

/// Removes the bricks the occupancy (`allowed` per pixel) forbids; returns how many.
pub fn drop_forbidden_bricks(layout: &mut CourseLayout, w: usize, allowed: &[bool], mode: RemoveMode) -> usize {
    let mut dropped = 0;
    for b in &mut layout.bricks {
        let r = b.rect;
        let forbidden = match mode {
            RemoveMode::Center => {
                let (cx, cy) = (0.5 * (r[0] + r[2]), 0.5 * (r[1] + r[3]));
                !allowed[(cy.floor() as usize) * w + cx.floor() as usize]
            }
            RemoveMode::AnyOverlap => {
                (r[1] as usize..r[3] as usize).any(|y| (r[0] as usize..r[2] as usize).any(|x| !allowed[y * w + x]))
            }
        };
        if forbidden {
            b.kept = false;
            dropped += 1;
        }
    }
    dropped
}

/// The label raster of a layout and the ellipse of every label: kept bricks first (in brick
/// order, as [`CourseLayout::ellipses`]), then the pieces split off cut bricks.
pub fn rasterize_courses(
    layout: &CourseLayout,
    w: usize,
    h: usize,
    allowed: Option<&[bool]>,
) -> (Labels, Vec<Ellipse>) {
    let mut labels = Labels::new(w, h);
    let mut ids = vec![NO_REGION; layout.bricks.len()];
    let mut next = 0u32;
    for (i, b) in layout.bricks.iter().enumerate() {
        if b.kept {
            ids[i] = next;
            next += 1;
        }
    }
    let mut ellipses = layout.ellipses();
    let ok = |x: usize, y: usize| allowed.is_none_or(|a| a[y * w + x]);
    // Brick per pixel row: the bricks of the course covering the row, left to right.
    let mut row_owner: Vec<Option<usize>> = vec![None; w];
    let mut start = 0;
    for y in 0..h {
        let yc = y as f64 + 0.5;
        while start < layout.bricks.len() && layout.bricks[start].rect[3] <= yc {
            start += 1;
        }
        row_owner.iter_mut().for_each(|o| *o = None);
        for (i, b) in layout.bricks.iter().enumerate().skip(start) {
            if b.rect[1] > yc {
                break;
            }
            if b.rect[3] <= yc {
                continue;
            }
            row_owner[b.rect[0] as usize..b.rect[2] as usize].iter_mut().for_each(|o| *o = Some(i));
        }
        // Allowed runs: a removed brick's pixels go to the nearest kept brick of the run.
        let mut x = 0;
        while x < w {
            if !ok(x, y) {
                x += 1;
                continue;
            }
            let a = x;
            while x < w && ok(x, y) {
                x += 1;
            }
            let run = a..x;
            let kept = |i: usize| row_owner[i].filter(|&b| layout.bricks[b].kept);
            let mut left: Vec<Option<(usize, usize)>> = vec![None; run.len()];
            let mut last = None;
            for (j, i) in run.clone().enumerate() {
                if let Some(b) = kept(i) {
                    last = Some((b, i));
                }
                left[j] = last;
            }
            let mut right = None;
            for (j, i) in run.clone().enumerate().rev() {
                if let Some(b) = kept(i) {
                    right = Some((b, i));
                }
                let pick = match (left[j], right) {
                    (Some(l), Some(r)) => Some(if i - l.1 <= r.1 - i { l.0 } else { r.0 }),
                    (Some(l), None) => Some(l.0),
                    (None, Some(r)) => Some(r.0),
                    (None, None) => None,
                };
                if let Some(b) = pick {
                    labels.data[y * w + i] = ids[b];
                }
            }
        }
    }
    split_pieces(&mut labels, &mut ellipses);
    (labels, ellipses)
}

/// Keeps each label's largest 4-connected piece; the others become labels of their own
/// (their ellipse that of their bounding box).
fn split_pieces(labels: &mut Labels, ellipses: &mut Vec<Ellipse>) {
    let (w, h) = (labels.width, labels.height);
    let mut piece = vec![u32::MAX; w * h];
    // (label, size, bbox) per piece.
    let mut pieces: Vec<(u32, usize, [usize; 4])> = Vec::new();
    let mut stack = Vec::new();
    for s in 0..w * h {
        let l = labels.data[s];
        if l == NO_REGION || piece[s] != u32::MAX {
            continue;
        }
        let id = pieces.len() as u32;
        let (mut n, mut bb) = (0, [usize::MAX, usize::MAX, 0, 0]);
        piece[s] = id;
        stack.push(s);
        while let Some(p) = stack.pop() {
            let (x, y) = (p % w, p / w);
            n += 1;
            bb = [bb[0].min(x), bb[1].min(y), bb[2].max(x + 1), bb[3].max(y + 1)];
            let mut visit = |q: usize| {
                if labels.data[q] == l && piece[q] == u32::MAX {
                    piece[q] = id;
                    stack.push(q);
                }
            };
            if x > 0 {
                visit(p - 1);
            }
            if x + 1 < w {
                visit(p + 1);
            }
            if y > 0 {
                visit(p - w);
            }
            if y + 1 < h {
                visit(p + w);
            }
        }
        pieces.push((l, n, bb));
    }
    // The largest piece of each label (the first found on a tie) keeps it.
    let mut largest: std::collections::HashMap<u32, usize> = Default::default();
    for (i, &(l, n, _)) in pieces.iter().enumerate() {
        let e = largest.entry(l).or_insert(i);
        if n > pieces[*e].1 {
            *e = i;
        }
    }
    let mut relabel: Vec<Option<u32>> = vec![None; pieces.len()];
    for (i, &(l, _, bb)) in pieces.iter().enumerate() {
        if largest[&l] != i {
            relabel[i] = Some(ellipses.len() as u32);
            ellipses.push(rect_ellipse([bb[0] as f64, bb[1] as f64, bb[2] as f64, bb[3] as f64]));
        }
    }
    for s in 0..w * h {
        if piece[s] != u32::MAX {
            if let Some(n) = relabel[piece[s] as usize] {
                labels.data[s] = n;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::structure::analysis::courses::{detect_courses, staggered_share};

    fn running_bond_analysis() -> CourseAnalysis {
        CourseAnalysis {
            layered: true,
            score: 1.0,
            courses: vec![],
            heights: vec![16.0; 6],
            lengths: vec![40.0; 10],
            lengths_per_course: vec![],
            stagger: vec![0.5; 10],
        }
    }

    #[test]
    fn equal_bricks_regrow_in_running_bond_filling_the_target() {
        let c = running_bond_analysis();
        let layout = layout_courses(200, 120, &c, 1.0, &mut Rng::new(3));
        let (labels, ellipses) = rasterize_courses(&layout, 200, 120, None);
        assert!(labels.data.iter().all(|&l| l != NO_REGION));
        assert_eq!(ellipses.len(), layout.bricks.len());
        // Detected again from the bricks' boxes: the same courses and bond.
        let polys: Vec<Vec<[f64; 2]>> = layout
            .bricks
            .iter()
            .map(|b| {
                vec![[b.rect[0], b.rect[1]], [b.rect[2], b.rect[1]], [b.rect[2], b.rect[3]], [b.rect[0], b.rect[3]]]
            })
            .collect();
        let border: Vec<bool> = layout
            .bricks
            .iter()
            .map(|b| b.rect[0] <= 0.0 || b.rect[1] <= 0.0 || b.rect[2] >= 200.0 || b.rect[3] >= 120.0)
            .collect();
        let interior: Vec<bool> = border.iter().map(|b| !b).collect();
        let found = detect_courses(&polys, &border, &interior, [200.0, 120.0]);
        assert!(found.layered);
        assert!(found.heights.iter().all(|&h| h == 16.0), "{:?}", found.heights);
        assert!(found.lengths.iter().all(|&l| l == 40.0), "{:?}", found.lengths);
        let joints: Vec<Vec<f64>> = found.courses.iter().map(|c| c.joints.clone()).collect();
        assert_eq!(staggered_share(&joints, 40.0), Some(1.0));
    }

    #[test]
    fn the_same_seed_lays_the_same_wall() {
        let c = running_bond_analysis();
        let a = layout_courses(150, 90, &c, 1.3, &mut Rng::new(9));
        let b = layout_courses(150, 90, &c, 1.3, &mut Rng::new(9));
        assert_eq!(a, b);
    }

    #[test]
    fn an_opening_removes_and_cuts_bricks_and_leaves_connected_regions() {
        let c = running_bond_analysis();
        let (w, h) = (200, 120);
        let mut layout = layout_courses(w, h, &c, 1.0, &mut Rng::new(5));
        // A window 30 px wide from x = 85, y = 30 to 70.
        let allowed: Vec<bool> =
            (0..w * h).map(|i| !((85..115).contains(&(i % w)) && (30..70).contains(&(i / w)))).collect();
        let dropped = drop_forbidden_bricks(&mut layout, w, &allowed, RemoveMode::Center);
        assert!(dropped > 0);
        let (labels, ellipses) = rasterize_courses(&layout, w, h, Some(&allowed));
        for (i, &l) in labels.data.iter().enumerate() {
            assert_eq!(l == NO_REGION, !allowed[i], "pixel {i}");
        }
        // Every label is one 4-connected piece.
        let mut clone = labels.clone();
        let before = ellipses.len();
        let mut e = ellipses.clone();
        split_pieces(&mut clone, &mut e);
        assert_eq!(e.len(), before);
        assert_eq!(clone, labels);
        assert!(labels.data.iter().filter(|&&l| l != NO_REGION).all(|&l| (l as usize) < ellipses.len()));
    }
}
