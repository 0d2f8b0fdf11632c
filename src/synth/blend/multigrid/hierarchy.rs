//! The level hierarchy of one free-cell pattern: how coarse cells inherit the free/fixed label,
//! and the levels and transfers built down to the coarsest level.

use rayon::prelude::*;

use super::level::Level;
use super::transfer::{Transfer, Transfer1};

/// How coarse cells inherit the free/fixed label of their 2 × 2 children.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize)]
pub enum Coarsening {
    /// Free only when every child is free (McAdams et al. 2010). Default.
    #[default]
    AllChildren,
    /// Free when any child is free (the alternative of [references: welsman-dinelle §4.2]).
    AnyChild,
}

/// Coarsening stops once the shorter side is at most this.
const COARSEST_SIDE: usize = 8;

/// The level hierarchy of one free-cell pattern.
pub(crate) struct Hierarchy {
    pub levels: Vec<Level>,
    pub(super) transfers: Vec<Transfer>,
    /// Compact index of each free cell of the coarsest level (usize::MAX for fixed cells).
    pub(super) coarse_index: Vec<usize>,
    pub(super) coarse_cells: Vec<usize>,
}

impl Hierarchy {
    pub fn new(w: usize, h: usize, periodic: bool, free: Vec<u8>, rule: Coarsening) -> Hierarchy {
        let mut levels = vec![Level::new(w, h, periodic, free)];
        let mut transfers = Vec::new();
        loop {
            let f = levels.last().unwrap();
            if f.w.min(f.h) <= COARSEST_SIDE || f.count == 0 {
                break;
            }
            let (wc, hc) = (f.w.div_ceil(2), f.h.div_ceil(2));
            let mut cfree = vec![0u8; wc * hc];
            cfree.par_chunks_mut(wc).enumerate().with_min_len(8).for_each(|(j, crow)| {
                for (i, cv) in crow.iter_mut().enumerate() {
                    let mut all = true;
                    let mut any = false;
                    for dy in 0..2 {
                        for dx in 0..2 {
                            let (x, y) = (2 * i + dx, 2 * j + dy);
                            if x < f.w && y < f.h {
                                let v = f.free[y * f.w + x] != 0;
                                all &= v;
                                any |= v;
                            }
                        }
                    }
                    let v = match rule {
                        Coarsening::AllChildren => all,
                        Coarsening::AnyChild => any,
                    };
                    *cv = v as u8;
                }
            });
            let c = Level::new(wc, hc, periodic, cfree);
            if c.count == 0 {
                break;
            }
            transfers.push(Transfer { x: Transfer1::new(f.w, wc, periodic), y: Transfer1::new(f.h, hc, periodic) });
            levels.push(c);
        }
        let last = levels.last().unwrap();
        let mut coarse_index = vec![usize::MAX; last.w * last.h];
        let mut coarse_cells = Vec::new();
        for (i, &v) in last.free.iter().enumerate() {
            if v != 0 {
                coarse_index[i] = coarse_cells.len();
                coarse_cells.push(i);
            }
        }
        Hierarchy { levels, transfers, coarse_index, coarse_cells }
    }
}
