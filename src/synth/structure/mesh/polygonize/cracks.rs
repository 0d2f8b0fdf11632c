//! Steps 2–4 of polygonisation: the crack graph between pixels of different labels, the
//! chains between its junctions, and each region's rings of chains (outer ring, then holes).

use std::collections::HashMap;

/// Label of the pixels outside the raster.
pub(super) const OUT: u32 = u32::MAX - 1;

#[inline]
pub(super) fn is_region(l: u32) -> bool {
    l < OUT
}

/// Directions: 0 = E (+x), 1 = S (+y), 2 = W, 3 = N.
pub(super) const DX: [i64; 4] = [1, 0, -1, 0];
pub(super) const DY: [i64; 4] = [0, 1, 0, -1];

pub(super) struct CrackGrid<'a> {
    pub(super) w: usize,
    pub(super) h: usize,
    pub(super) lab: &'a [u32],
}

/// A traced chain between two junctions (`raw` corner ids), the region on its positive side
/// when walked forward (`fwd`) and on the other side (`bwd`).
pub(super) struct Chain {
    pub(super) raw: Vec<u32>,
    pub(super) first_dir: u8,
    pub(super) last_dir: u8,
    pub(super) fwd: u32,
    pub(super) bwd: u32,
    pub(super) pts: Vec<u32>,
    pub(super) level: u32,
}

/// A region ring: `(chain, reversed)` pairs.
pub(super) type Ring = Vec<(usize, bool)>;

/// Rings of each region label: (label, rings); ring 0 is the outer one, then holes.
pub(super) struct RegionRings {
    pub(super) regions: Vec<(u32, Vec<Ring>)>,
}

impl CrackGrid<'_> {
    #[inline]
    pub(super) fn pix(&self, x: i64, y: i64) -> u32 {
        if x < 0 || y < 0 || x >= self.w as i64 || y >= self.h as i64 {
            OUT
        } else {
            self.lab[y as usize * self.w + x as usize]
        }
    }

    #[inline]
    pub(super) fn corner(&self, x: i64, y: i64) -> u32 {
        (y as usize * (self.w + 1) + x as usize) as u32
    }

    #[inline]
    pub(super) fn corner_xy(&self, c: u32) -> (i64, i64) {
        let c = c as usize;
        ((c % (self.w + 1)) as i64, (c / (self.w + 1)) as i64)
    }

    pub(super) fn is_raster_corner(&self, c: u32) -> bool {
        let (x, y) = self.corner_xy(c);
        (x == 0 || x == self.w as i64) && (y == 0 || y == self.h as i64)
    }

    /// The four pixels around corner `(x, y)`: NW, NE, SW, SE.
    #[inline]
    pub(super) fn quad(&self, x: i64, y: i64) -> [u32; 4] {
        [self.pix(x - 1, y - 1), self.pix(x, y - 1), self.pix(x - 1, y), self.pix(x, y)]
    }

    /// `(positive side, other side)` of the crack leaving corner `(x, y)` in direction `d`,
    /// or `None` if there is no edge.
    #[inline]
    pub(super) fn edge(&self, x: i64, y: i64, d: u8) -> Option<(u32, u32)> {
        let [nw, ne, sw, se] = self.quad(x, y);
        let (pos, neg) = match d {
            0 => (se, ne), // E: below is positive
            1 => (sw, se), // S: left is positive
            2 => (nw, sw), // W: above is positive
            _ => (ne, nw), // N: right is positive
        };
        (pos != neg && (is_region(pos) || is_region(neg))).then_some((pos, neg))
    }

    pub(super) fn degree_and_junction(&self, x: i64, y: i64) -> (usize, bool) {
        let mut deg = 0;
        let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(4);
        for d in 0..4 {
            if let Some((a, b)) = self.edge(x, y, d) {
                deg += 1;
                pairs.push((a.min(b), a.max(b)));
            }
        }
        let raster_corner = (x == 0 || x == self.w as i64) && (y == 0 || y == self.h as i64);
        let junction = (deg != 2 && deg != 0) || (deg == 2 && pairs[0] != pairs[1]) || (deg > 0 && raster_corner);
        (deg, junction)
    }

    /// Index of the crack leaving `(x, y)` in direction `d` (horizontal cracks first).
    #[inline]
    pub(super) fn crack_index(&self, x: i64, y: i64, d: u8) -> usize {
        let nh = self.w * (self.h + 1);
        match d {
            0 => y as usize * self.w + x as usize,
            2 => y as usize * self.w + (x - 1) as usize,
            1 => nh + y as usize * (self.w + 1) + x as usize,
            _ => nh + (y - 1) as usize * (self.w + 1) + x as usize,
        }
    }

    pub(super) fn trace_chains(&self) -> Vec<Chain> {
        let (w, h) = (self.w as i64, self.h as i64);
        let ncracks = self.w * (self.h + 1) + (self.w + 1) * self.h;
        let mut visited = vec![false; ncracks];
        let mut is_junction = vec![false; (self.w + 1) * (self.h + 1)];
        for y in 0..=h {
            for x in 0..=w {
                is_junction[self.corner(x, y) as usize] = self.degree_and_junction(x, y).1;
            }
        }
        let mut chains = Vec::new();
        let trace = |x0: i64, y0: i64, d0: u8, visited: &mut Vec<bool>, is_junction: &Vec<bool>| -> Chain {
            let (fwd, bwd) = self.edge(x0, y0, d0).expect("edge");
            let mut raw = vec![self.corner(x0, y0)];
            let (mut x, mut y, mut d) = (x0, y0, d0);
            loop {
                visited[self.crack_index(x, y, d)] = true;
                x += DX[d as usize];
                y += DY[d as usize];
                let c = self.corner(x, y);
                raw.push(c);
                if is_junction[c as usize] {
                    break;
                }
                // Degree-2 corner: continue along the other crack.
                let back = (d + 2) % 4;
                let next = (0..4u8).find(|&nd| nd != back && self.edge(x, y, nd).is_some()).expect("degree-2 corner");
                d = next;
            }
            Chain { raw, first_dir: d0, last_dir: d, fwd, bwd, pts: Vec::new(), level: 0 }
        };
        for y in 0..=h {
            for x in 0..=w {
                if !is_junction[self.corner(x, y) as usize] {
                    continue;
                }
                for d in 0..4u8 {
                    if self.edge(x, y, d).is_some() && !visited[self.crack_index(x, y, d)] {
                        chains.push(trace(x, y, d, &mut visited, &is_junction));
                    }
                }
            }
        }
        // Closed loops without any junction: anchor at their first corner in index order.
        for y in 0..=h {
            for x in 0..=w {
                for d in 0..4u8 {
                    if self.edge(x, y, d).is_some() && !visited[self.crack_index(x, y, d)] {
                        is_junction[self.corner(x, y) as usize] = true;
                        chains.push(trace(x, y, d, &mut visited, &is_junction));
                    }
                }
            }
        }
        chains
    }

    /// The direction in which region `a` leaves corner `(x, y)` after arriving in direction
    /// `d_in`: the crack whose positive side is `a`; at a diagonal self-touch, the one owned by
    /// the same pixel as the arrival crack (the ring hugs the pixel, i.e. `a` is treated as
    /// 4-connected; after the cleanup every region is, so its boundary is one outer ring that
    /// may touch itself at such a corner, plus holes).
    pub(super) fn out_dir(&self, x: i64, y: i64, d_in: u8, a: u32) -> u8 {
        let [nw, ne, sw, se] = self.quad(x, y);
        // Pixel (as quad index) owning the incoming / outgoing crack.
        const IN_PIX: [usize; 4] = [2, 0, 1, 3]; // arrive E: SW, S: NW, W: NE, N: SE
        const OUT_PIX: [usize; 4] = [3, 2, 0, 1]; // leave E: SE, S: SW, W: NW, N: NE
        let _ = (nw, ne, sw, se);
        let cands: Vec<u8> = (0..4u8).filter(|&d| self.edge(x, y, d).is_some_and(|(p, _)| p == a)).collect();
        match cands.len() {
            1 => cands[0],
            0 => panic!("region {a} has no outgoing crack at ({x}, {y})"),
            _ => *cands.iter().find(|&&d| OUT_PIX[d as usize] == IN_PIX[d_in as usize]).unwrap_or(&cands[0]),
        }
    }
}

/// Follows every region's chains into rings; per region the outer ring first, then holes.
pub(super) fn region_rings(grid: &CrackGrid, chains: &[Chain]) -> RegionRings {
    // Departures: (corner, direction) → (chain, reversed).
    let mut dep: HashMap<(u32, u8), (usize, bool)> = HashMap::new();
    for (i, c) in chains.iter().enumerate() {
        dep.insert((c.raw[0], c.first_dir), (i, false));
        dep.insert((*c.raw.last().unwrap(), (c.last_dir + 2) % 4), (i, true));
    }
    let mut used = vec![[false; 2]; chains.len()];
    let mut by_label: HashMap<u32, Vec<(i64, Ring)>> = HashMap::new();
    for start in 0..chains.len() {
        for rev in [false, true] {
            let region = if rev { chains[start].bwd } else { chains[start].fwd };
            if !is_region(region) || used[start][rev as usize] {
                continue;
            }
            let mut ring: Ring = Vec::new();
            let (mut ci, mut r) = (start, rev);
            loop {
                used[ci][r as usize] = true;
                ring.push((ci, r));
                let c = &chains[ci];
                let (end, d_in) =
                    if r { (c.raw[0], (c.first_dir + 2) % 4) } else { (*c.raw.last().unwrap(), c.last_dir) };
                let (x, y) = grid.corner_xy(end);
                let d_out = grid.out_dir(x, y, d_in, region);
                let next = dep[&(end, d_out)];
                if next == (start, rev) {
                    break;
                }
                (ci, r) = next;
            }
            let area2 = ring_area2_raw(grid, chains, &ring);
            by_label.entry(region).or_default().push((area2, ring));
            debug_assert!(
                by_label[&region].iter().filter(|r| r.0 > 0).count() <= 1,
                "region {region} has several outer rings (not 4-connected)"
            );
        }
    }
    let mut labels: Vec<u32> = by_label.keys().copied().collect();
    labels.sort_unstable();
    let regions = labels
        .into_iter()
        .map(|l| {
            let mut rings = by_label.remove(&l).unwrap();
            // Outer ring (largest positive area) first, then holes in trace order.
            let outer = (0..rings.len()).max_by_key(|&i| (rings[i].0, std::cmp::Reverse(i))).unwrap();
            let o = rings.remove(outer);
            let mut out = vec![o.1];
            out.extend(rings.into_iter().map(|r| r.1));
            (l, out)
        })
        .collect();
    RegionRings { regions }
}

/// Twice the signed area of a ring of raw chains (exact).
pub(super) fn ring_area2_raw(grid: &CrackGrid, chains: &[Chain], ring: &Ring) -> i64 {
    ring.iter().map(|&(ci, rev)| chain_area2_int(grid, &chains[ci].raw, rev)).sum()
}

pub(super) fn chain_area2_int(grid: &CrackGrid, pts: &[u32], rev: bool) -> i64 {
    let mut s = 0;
    for p in pts.windows(2) {
        let (x0, y0) = grid.corner_xy(p[0]);
        let (x1, y1) = grid.corner_xy(p[1]);
        s += x0 * y1 - x1 * y0;
    }
    if rev {
        -s
    } else {
        s
    }
}
