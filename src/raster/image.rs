//! Planar f32 images: the one pixel container every stage and algorithm shares.

/// A planar image: channel `c` of pixel `(x, y)` lives at `data[c * w * h + y * w + x]`.
///
/// Planar rather than interleaved because most algorithms (blur, FFT, Poisson, quilting
/// error sums) work one channel at a time, and a plane is then a contiguous slice.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    pub data: Vec<f32>,
}

impl Image {
    pub fn new(width: usize, height: usize, channels: usize) -> Self {
        Image { width, height, channels, data: vec![0.0; width * height * channels] }
    }

    pub fn filled(width: usize, height: usize, channels: usize, value: f32) -> Self {
        Image { width, height, channels, data: vec![value; width * height * channels] }
    }

    /// Builds an image from a function of `(x, y, channel)`.
    pub fn from_fn(width: usize, height: usize, channels: usize, f: impl Fn(usize, usize, usize) -> f32) -> Self {
        let mut data = Vec::with_capacity(width * height * channels);
        for c in 0..channels {
            for y in 0..height {
                for x in 0..width {
                    data.push(f(x, y, c));
                }
            }
        }
        Image { width, height, channels, data }
    }

    pub fn plane_len(&self) -> usize {
        self.width * self.height
    }

    pub fn plane(&self, c: usize) -> &[f32] {
        let n = self.plane_len();
        &self.data[c * n..(c + 1) * n]
    }

    pub fn plane_mut(&mut self, c: usize) -> &mut [f32] {
        let n = self.plane_len();
        &mut self.data[c * n..(c + 1) * n]
    }

    #[inline]
    pub fn get(&self, x: usize, y: usize, c: usize) -> f32 {
        self.data[c * self.width * self.height + y * self.width + x]
    }

    #[inline]
    pub fn set(&mut self, x: usize, y: usize, c: usize, v: f32) {
        let i = c * self.width * self.height + y * self.width + x;
        self.data[i] = v;
    }

    /// The channels of `images` (all of the first one's size) one after the other.
    pub fn stacked(images: &[&Image]) -> Image {
        let (width, height) = images.first().map_or((0, 0), |i| (i.width, i.height));
        assert!(images.iter().all(|i| (i.width, i.height) == (width, height)), "stacked images differ in size");
        let data = images.iter().flat_map(|i| i.data.iter().copied()).collect();
        Image { width, height, channels: images.iter().map(|i| i.channels).sum(), data }
    }

    /// The inverse of [`Image::stacked`]: images of `counts` channels each, in order (channels
    /// beyond the counts' sum are dropped).
    pub fn split(&self, counts: &[usize]) -> Vec<Image> {
        let n = self.plane_len();
        let mut at = 0;
        counts
            .iter()
            .map(|&k| {
                let k = k.min(self.channels - at.min(self.channels));
                let data = self.data[at * n..(at + k) * n].to_vec();
                at += k;
                Image { width: self.width, height: self.height, channels: k, data }
            })
            .collect()
    }

    pub fn same_size(&self, other: &Image) -> bool {
        self.width == other.width && self.height == other.height
    }
}
