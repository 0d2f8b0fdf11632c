//! Where a vertex may move (free, sliding along the domain border, locked) and the validity
//! guard: whether moving one vertex keeps every region around it simple and uncrossed.

use crate::synth::structure::mesh::faces::signed_area;
use crate::synth::structure::types::Point;
use crate::synth::structure::validate::{point_segment_distance, segment_contact};

/// How a vertex may move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Freedom {
    Free,
    /// Only coordinate `axis` may change; the other one stays at `value`.
    Slide {
        axis: usize,
        value: f64,
    },
    Locked,
}

pub(super) fn freedom(p: Point, fixed: bool, border: bool, domain: [f64; 2], eps: f64) -> Freedom {
    if fixed {
        return Freedom::Locked;
    }
    if !border {
        return Freedom::Free;
    }
    let on_x = if p[0].abs() <= eps {
        Some(0.0)
    } else if (p[0] - domain[0]).abs() <= eps {
        Some(domain[0])
    } else {
        None
    };
    let on_y = if p[1].abs() <= eps {
        Some(0.0)
    } else if (p[1] - domain[1]).abs() <= eps {
        Some(domain[1])
    } else {
        None
    };
    match (on_x, on_y) {
        (Some(x), None) => Freedom::Slide { axis: 1, value: x },
        (None, Some(y)) => Freedom::Slide { axis: 0, value: y },
        // A corner, or flagged as border but on no side: it cannot slide.
        _ => Freedom::Locked,
    }
}

/// The position after displacing `p` by `d` under `f` (`None` if it cannot move).
pub(super) fn constrained(p: Point, d: Point, f: Freedom, domain: [f64; 2]) -> Option<Point> {
    match f {
        Freedom::Free => Some([p[0] + d[0], p[1] + d[1]]),
        Freedom::Slide { axis, value } => {
            let mut q = [0.0; 2];
            q[axis] = (p[axis] + d[axis]).clamp(0.0, domain[axis]);
            q[1 - axis] = value;
            Some(q)
        }
        Freedom::Locked => None,
    }
}

/// Whether the edge `(v, u)` (`v` at its new position) conflicts with the edge `(a, b)`:
/// crossing, touching away from shared ends, or overlapping collinearly.
pub(super) fn edges_conflict(pos: &impl Fn(usize) -> Point, v: usize, u: usize, a: usize, b: usize, eps: f64) -> bool {
    if (a == v && b == u) || (a == u && b == v) {
        return false;
    }
    let (pv, pu, pa, pb) = (pos(v), pos(u), pos(a), pos(b));
    // A shared end: the two segments only meet elsewhere by folding onto each other.
    let shared = if a == v || a == u {
        Some((a, b))
    } else if b == v || b == u {
        Some((b, a))
    } else {
        None
    };
    match shared {
        Some((s, o)) => {
            let eo = if s == v { pu } else { pv };
            let po = pos(o);
            let ps = pos(s);
            point_segment_distance(po, ps, eo) <= eps || point_segment_distance(eo, ps, po) <= eps
        }
        None => segment_contact(pv, pu, pa, pb, eps).is_some(),
    }
}

/// Validity of the star of `v` after a change that only touches edges at `v`: every cycle
/// has at least 3 distinct vertices and a positive signed area, and no edge at `v` conflicts
/// with any other edge of the cycles. `cycles` are all the regions containing `v`.
pub(super) fn star_valid(pos: &impl Fn(usize) -> Point, cycles: &[&[usize]], v: usize, eps: f64) -> bool {
    let mut spokes: Vec<usize> = Vec::with_capacity(8);
    for c in cycles {
        let n = c.len();
        if n < 3 {
            return false;
        }
        let poly: Vec<Point> = c.iter().map(|&i| pos(i)).collect();
        if signed_area(&poly).is_nan() || signed_area(&poly) <= 0.0 {
            return false;
        }
        for k in 0..n {
            if c[k] == v {
                for u in [c[(k + n - 1) % n], c[(k + 1) % n]] {
                    if !spokes.contains(&u) {
                        spokes.push(u);
                    }
                }
            }
        }
    }
    for &u in &spokes {
        for c in cycles {
            let n = c.len();
            for k in 0..n {
                let (a, b) = (c[k], c[(k + 1) % n]);
                if edges_conflict(pos, v, u, a, b, eps) {
                    return false;
                }
            }
        }
    }
    true
}

/// The distinct vertex indices of a cycle.
pub(super) fn distinct(c: &[usize]) -> bool {
    let mut s: Vec<usize> = c.to_vec();
    s.sort_unstable();
    s.windows(2).all(|w| w[0] != w[1])
}
