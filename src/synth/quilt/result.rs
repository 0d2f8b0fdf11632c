//! What quilting returns: the image with its index map (where each pixel came from), the
//! sources and the placed blocks. Apart from the entry points so that the engine and the seam
//! remover use these types without importing the module that calls them.

use crate::raster::Image;

/// For every output pixel, where its values come from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct IndexMap {
    pub width: usize,
    pub height: usize,
    /// Index into [`QuiltResult::sources`], or [`IndexMap::EMPTY`] for pixels left empty.
    pub source: Vec<u32>,
    /// Pixel coordinates inside that source.
    pub x: Vec<u32>,
    pub y: Vec<u32>,
    /// Index into [`QuiltResult::blocks`] of the block that wrote the pixel.
    pub block: Vec<u32>,
}

impl IndexMap {
    pub const EMPTY: u32 = u32::MAX;

    pub(super) fn empty(width: usize, height: usize) -> IndexMap {
        let n = width * height;
        IndexMap {
            width,
            height,
            source: vec![Self::EMPTY; n],
            x: vec![0; n],
            y: vec![0; n],
            block: vec![Self::EMPTY; n],
        }
    }

    /// `(source, x, y)` of output pixel `(x, y)`, or `None` if it was left empty.
    pub fn get(&self, x: usize, y: usize) -> Option<(usize, usize, usize)> {
        let i = y * self.width + x;
        (self.source[i] != Self::EMPTY).then(|| (self.source[i] as usize, self.x[i] as usize, self.y[i] as usize))
    }

    /// Copies every pixel from its source image (empty pixels are 0).
    pub(super) fn gather_sources(&self, sources: &[&Image]) -> Image {
        let channels = sources.first().map_or(1, |s| s.channels);
        let n = self.width * self.height;
        let mut out = Image::new(self.width, self.height, channels);
        for i in 0..n {
            if self.source[i] == Self::EMPTY {
                continue;
            }
            let s = sources[self.source[i] as usize];
            let j = self.y[i] as usize * s.width + self.x[i] as usize;
            for c in 0..channels {
                out.data[c * n + i] = s.data[c * s.plane_len() + j];
            }
        }
        out
    }

    /// 1 where a 4-neighbour is not the continuation of the same source offset (a seam), else 0.
    pub(super) fn seam_mask(&self, wrap: bool) -> Image {
        let (w, h) = (self.width, self.height);
        let mut out = Image::new(w, h, 1);
        let cont = |a: usize, b: usize, dx: i64, dy: i64| {
            self.source[a] == self.source[b]
                && i64::from(self.x[b]) - i64::from(self.x[a]) == dx
                && i64::from(self.y[b]) - i64::from(self.y[a]) == dy
        };
        for y in 0..h {
            for x in 0..w {
                let a = y * w + x;
                if self.source[a] == Self::EMPTY {
                    continue;
                }
                let mut seam = false;
                for (dx, dy) in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)] {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    let inside = nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64;
                    if !inside && !wrap {
                        continue;
                    }
                    // Across the torus wrap a continuation still steps by (dx, dy) in the source.
                    let b = ny.rem_euclid(h as i64) as usize * w + nx.rem_euclid(w as i64) as usize;
                    seam |= self.source[b] != Self::EMPTY && !cont(a, b, dx, dy);
                }
                out.data[a] = f32::from(u8::from(seam));
            }
        }
        out
    }
}

/// One source image blocks were copied from: input sample `sample`, rotated by `angle` radians.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SourceInfo {
    pub sample: usize,
    pub angle: f32,
    /// Size of the sample (and of the rotated copy).
    pub width: usize,
    pub height: usize,
}

/// One placed block.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BlockRecord {
    /// Top-left corner in the output.
    pub x: usize,
    pub y: usize,
    /// Source and top-left corner in it.
    pub source: usize,
    pub sx: usize,
    pub sy: usize,
    /// The block's matching error (normalised, equalised units).
    pub error: f64,
    /// `false` when the coherence shortcut copied the block without a search.
    pub searched: bool,
    /// Number of candidates that were within the tolerance.
    pub within_tolerance: usize,
}

/// The output of quilting.
#[derive(Clone, Debug)]
pub struct QuiltResult {
    /// Raw sample values (never equalised or blended); empty pixels are 0.
    pub image: Image,
    pub index: IndexMap,
    /// 1-channel 0/1 map of pixels next to a source discontinuity.
    pub seams: Image,
    pub sources: Vec<SourceInfo>,
    pub blocks: Vec<BlockRecord>,
    /// Number of blocks that ran a search (all blocks unless the coherence shortcut applied).
    pub searches: usize,
    pub tileable: bool,
}

impl QuiltResult {
    /// Whether any block came from a rotated copy (an orientation field was used).
    pub fn rotated(&self) -> bool {
        self.sources.iter().any(|s| s.angle != 0.0)
    }

    /// For every output pixel, the rotation (radians) of the copy it came from; 0 where empty.
    pub fn angle_map(&self) -> Image {
        let (w, h) = (self.index.width, self.index.height);
        let mut out = Image::new(w, h, 1);
        for (o, &s) in out.data.iter_mut().zip(&self.index.source) {
            if s != IndexMap::EMPTY {
                *o = self.sources[s as usize].angle;
            }
        }
        out
    }
}
