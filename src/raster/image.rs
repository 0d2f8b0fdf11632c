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

/// Buffers from this size up are backed by transparent huge pages where the system offers them.
const HUGE_PAGE_MIN_BYTES: usize = 8 << 20;

/// Asks Linux to back `buffer` with transparent huge pages (2 MiB rather than 4 KiB).
///
/// A 4096² RGB output is 192 MiB: filled page by page it takes 49 152 page faults, which cost
/// 115 ms on the two-core development machine against 32 ms with huge pages (a third of a
/// 4096² tiling render). With `transparent_hugepage` set to `madvise`, the common default, the
/// kernel only does this for ranges it is asked to. The advice changes no byte and no
/// semantics; where it fails or is unsupported the buffer keeps its ordinary pages.
fn advise_huge_pages<T>(buffer: &[T]) {
    let bytes = std::mem::size_of_val(buffer);
    if bytes < HUGE_PAGE_MIN_BYTES {
        return;
    }
    #[cfg(target_os = "linux")]
    {
        const PAGE: usize = 4096;
        let start = (buffer.as_ptr() as usize).next_multiple_of(PAGE);
        let end = (buffer.as_ptr() as usize + bytes) & !(PAGE - 1);
        if end > start {
            // SAFETY: the range lies inside `buffer`'s allocation, which this thread owns, and
            // MADV_HUGEPAGE only changes how the kernel backs it, never its contents; an error
            // (say, a kernel without transparent huge pages) is ignored on purpose.
            unsafe {
                libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
            }
        }
    }
}

impl Image {
    pub fn new(width: usize, height: usize, channels: usize) -> Self {
        // Zeroed by the allocator (fresh pages for a large buffer, never written here), so the
        // advice comes before any page is touched.
        let data = vec![0.0; width * height * channels];
        advise_huge_pages(&data);
        Image { width, height, channels, data }
    }

    pub fn filled(width: usize, height: usize, channels: usize, value: f32) -> Self {
        let len = width * height * channels;
        let mut data = Vec::with_capacity(len);
        advise_huge_pages(data.spare_capacity_mut());
        data.resize(len, value);
        Image { width, height, channels, data }
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
