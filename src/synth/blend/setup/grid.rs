//! The grid graph, the selector restricted to one channel, and the free pixels they define
//! (with the fixed rim of rim topology): what every later stage of a blend indexes by.

use std::borrow::Cow;

use crate::synth::blend::multigrid::wrap_or_skip;
use crate::synth::blend::params::{BlendParams, Domain, Topology};

/// The selector restricted to one channel.
pub(super) enum ChanSel<'a> {
    Labels(Cow<'a, [u32]>),
    Weights(Vec<f32>),
}

/// The grid graph.
#[derive(Clone, Copy)]
pub(super) struct Graph {
    pub(super) w: usize,
    pub(super) h: usize,
    pub(super) periodic: bool,
}

impl Graph {
    #[inline]
    pub(super) fn right(&self, x: usize, y: usize) -> Option<usize> {
        if x + 1 < self.w {
            Some(y * self.w + x + 1)
        } else if self.periodic {
            Some(y * self.w)
        } else {
            None
        }
    }
    #[inline]
    pub(super) fn down(&self, x: usize, y: usize) -> Option<usize> {
        if y + 1 < self.h {
            Some((y + 1) * self.w + x)
        } else if self.periodic {
            Some(x)
        } else {
            None
        }
    }
    #[inline]
    pub(super) fn left(&self, x: usize, y: usize) -> Option<usize> {
        if x > 0 {
            Some(y * self.w + x - 1)
        } else if self.periodic {
            Some(y * self.w + self.w - 1)
        } else {
            None
        }
    }
    #[inline]
    pub(super) fn up(&self, x: usize, y: usize) -> Option<usize> {
        if y > 0 {
            Some((y - 1) * self.w + x)
        } else if self.periodic {
            Some((self.h - 1) * self.w + x)
        } else {
            None
        }
    }
}

/// Sets the outer rim to `src`'s values averaged over opposite sides (corners: the mean of
/// the four corners), so opposite rim lines are bitwise equal.
pub(super) fn apply_rim(f: &mut [f32], src: &[f32], w: usize, h: usize) {
    for y in 0..h {
        let v = 0.5 * (src[y * w] + src[y * w + w - 1]);
        f[y * w] = v;
        f[y * w + w - 1] = v;
    }
    for x in 0..w {
        let v = 0.5 * (src[x] + src[(h - 1) * w + x]);
        f[x] = v;
        f[(h - 1) * w + x] = v;
    }
    let corner = 0.25 * (src[0] + src[w - 1] + src[(h - 1) * w] + src[(h - 1) * w + w - 1]);
    for i in [0, w - 1, (h - 1) * w, (h - 1) * w + w - 1] {
        f[i] = corner;
    }
}

/// Free pixels (1) for the domain, minus the rim in rim topology.
pub(super) fn free_pixels(g: &Graph, sel: &ChanSel<'_>, params: &BlendParams) -> Vec<u8> {
    let (w, h) = (g.w, g.h);
    let n = w * h;
    let mut free: Vec<u8> = match params.domain {
        Domain::Whole => vec![1; n],
        Domain::Mask => match sel {
            ChanSel::Labels(l) => l.iter().map(|&v| (v != 0) as u8).collect(),
            ChanSel::Weights(m) => m.iter().map(|&v| (v > 0.0) as u8).collect(),
        },
        Domain::Band { radius } => {
            let differs = |i: usize, j: usize| match sel {
                ChanSel::Labels(l) => l[i] != l[j],
                ChanSel::Weights(m) => m[i] != m[j],
            };
            let mut seam = vec![0u8; n];
            for y in 0..h {
                for x in 0..w {
                    let i = y * w + x;
                    let nbs = [g.left(x, y), g.right(x, y), g.up(x, y), g.down(x, y)];
                    if nbs.iter().flatten().any(|&j| differs(i, j)) {
                        seam[i] = 1;
                    }
                }
            }
            dilate(&seam, w, h, radius, g.periodic)
        }
    };
    if matches!(params.topology, Topology::Rim { .. }) {
        for y in 0..h {
            for x in 0..w {
                if x == 0 || y == 0 || x == w - 1 || y == h - 1 {
                    free[y * w + x] = 0;
                }
            }
        }
    }
    free
}

/// Chebyshev dilation by `r` (separable running maximum), wrapping when `periodic`.
fn dilate(m: &[u8], w: usize, h: usize, r: usize, periodic: bool) -> Vec<u8> {
    let pass = |src: &[u8], len: usize, count: usize, stride: usize, step: usize| -> Vec<u8> {
        let mut out = vec![0u8; src.len()];
        for line in 0..count {
            let base = line * stride;
            for i in 0..len {
                let mut v = 0u8;
                let ri = r as isize;
                for d in -ri..=ri {
                    let Some(j) = wrap_or_skip(i as isize + d, len, periodic) else { continue };
                    v |= src[base + j * step];
                    if v != 0 {
                        break;
                    }
                }
                out[base + i * step] = v;
            }
        }
        out
    };
    let a = pass(m, w, h, w, 1);
    pass(&a, h, w, 1, w)
}
