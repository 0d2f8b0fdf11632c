//! Step 1 of polygonisation: every label reduced to one 4-connected component.

use std::collections::HashMap;

use super::cracks::is_region;
use crate::synth::structure::types::NO_REGION;

/// Keeps the largest 4-connected component of every label; returns the relabelled pixel count.
///
/// 4- rather than 8-connectivity: a region joined only through a diagonal pixel contact would
/// be two faces of the planar graph although its ring is one (the Euler relation would fail).
///
/// Smaller components are merged, smallest first, into the label of the *main* component that
/// shares the most pixel edges with them (ties: lowest label). Merged pixels join that main
/// component, so a component surrounded only by other small ones is merged once a neighbour
/// has been; components that never touch a main component become `NO_REGION`.
pub(super) fn single_components(lab: &mut [u32], w: usize, h: usize) -> usize {
    let n = lab.len();
    let mut comp = vec![u32::MAX; n];
    let mut comps: Vec<(u32, usize, usize)> = Vec::new(); // (label, size, first pixel)
    let mut members: Vec<Vec<usize>> = Vec::new();
    let mut stack = Vec::new();
    for s in 0..n {
        if comp[s] != u32::MAX || !is_region(lab[s]) {
            continue;
        }
        let id = comps.len() as u32;
        let l = lab[s];
        comp[s] = id;
        stack.push(s);
        let mut px = Vec::new();
        while let Some(p) = stack.pop() {
            px.push(p);
            let (x, y) = ((p % w) as i64, (p / w) as i64);
            for (dx, dy) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
                let (nx, ny) = (x + dx, y + dy);
                if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                    continue;
                }
                let q = ny as usize * w + nx as usize;
                if comp[q] == u32::MAX && lab[q] == l {
                    comp[q] = id;
                    stack.push(q);
                }
            }
        }
        comps.push((l, px.len(), s));
        members.push(px);
    }
    // The main component of each label: largest, ties by first pixel.
    let mut main: HashMap<u32, usize> = HashMap::new();
    for (i, c) in comps.iter().enumerate() {
        let e = main.entry(c.0).or_insert(i);
        let m = comps[*e];
        if c.1 > m.1 || (c.1 == m.1 && c.2 < m.2) {
            *e = i;
        }
    }
    let mut in_main = vec![false; n];
    for &m in main.values() {
        for &p in &members[m] {
            in_main[p] = true;
        }
    }
    let mut minor: Vec<usize> = (0..comps.len()).filter(|&i| main[&comps[i].0] != i).collect();
    minor.sort_by_key(|&i| (comps[i].1, comps[i].2));
    let mut total = 0;
    loop {
        let mut progress = false;
        let mut waiting = Vec::new();
        for &m in &minor {
            let mut votes: Vec<(u32, usize)> = Vec::new();
            for &p in &members[m] {
                let (x, y) = (p % w, p / w);
                let mut nb = [usize::MAX; 4];
                if x > 0 {
                    nb[0] = p - 1;
                }
                if x + 1 < w {
                    nb[1] = p + 1;
                }
                if y > 0 {
                    nb[2] = p - w;
                }
                if y + 1 < h {
                    nb[3] = p + w;
                }
                for q in nb.into_iter().filter(|&q| q != usize::MAX) {
                    if in_main[q] && comp[q] != m as u32 {
                        match votes.iter_mut().find(|v| v.0 == lab[q]) {
                            Some(v) => v.1 += 1,
                            None => votes.push((lab[q], 1)),
                        }
                    }
                }
            }
            if let Some(&(l, _)) = votes.iter().max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0))) {
                for &p in &members[m] {
                    lab[p] = l;
                    in_main[p] = true;
                }
                total += members[m].len();
                progress = true;
            } else {
                waiting.push(m);
            }
        }
        minor = waiting;
        if minor.is_empty() {
            break;
        }
        if !progress {
            // Enclosed only by forbidden / outside pixels or by each other.
            for &m in &minor {
                for &p in &members[m] {
                    lab[p] = NO_REGION;
                }
                total += members[m].len();
            }
            break;
        }
    }
    total
}
