//! Cell values of the multigrid solver: one f32 per solved channel ("lane").
//!
//! [`Lanes`] is implemented by `f32` (one channel) and by [`F32x4`] (up to four channels
//! solved together, one SSE register per cell on x86_64). Every operation is lane-wise IEEE
//! single precision with no fused multiply-add, so each lane computes exactly what the
//! one-channel code computes.

use std::ops::{Add, Div, Mul, Sub};

/// A cell's values, one per lane.
pub(crate) trait Lanes:
    Copy + Default + Send + Sync + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self>
{
    /// Number of lanes.
    const N: usize;
    fn splat(v: f32) -> Self;
    fn from_fn(f: impl FnMut(usize) -> f32) -> Self;
    fn get(self, k: usize) -> f32;
    fn set(&mut self, k: usize, v: f32);
    /// `|self|` per lane.
    fn abs(self) -> Self;
    /// Per lane `if self > m { self } else { m }` (NaN never wins against `m`).
    fn max_into(self, m: Self) -> Self;
}

impl Lanes for f32 {
    const N: usize = 1;
    #[inline(always)]
    fn splat(v: f32) -> Self {
        v
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f32) -> Self {
        f(0)
    }
    #[inline(always)]
    fn get(self, _k: usize) -> f32 {
        self
    }
    #[inline(always)]
    fn set(&mut self, _k: usize, v: f32) {
        *self = v;
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32::abs(self)
    }
    #[inline(always)]
    fn max_into(self, m: Self) -> Self {
        if self > m {
            self
        } else {
            m
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod imp {
    use std::arch::x86_64::*;

    /// Four f32 lanes in one SSE register (SSE2 is part of the x86_64 baseline).
    #[derive(Clone, Copy)]
    #[repr(transparent)]
    pub(crate) struct F32x4(pub(super) __m128);

    impl Default for F32x4 {
        #[inline(always)]
        fn default() -> Self {
            // SAFETY: SSE2 is always available on x86_64.
            F32x4(unsafe { _mm_setzero_ps() })
        }
    }

    macro_rules! binop {
        ($tr:ident, $f:ident, $intr:ident) => {
            impl std::ops::$tr for F32x4 {
                type Output = F32x4;
                #[inline(always)]
                fn $f(self, o: F32x4) -> F32x4 {
                    // SAFETY: SSE2 is always available on x86_64.
                    F32x4(unsafe { $intr(self.0, o.0) })
                }
            }
        };
    }
    binop!(Add, add, _mm_add_ps);
    binop!(Sub, sub, _mm_sub_ps);
    binop!(Mul, mul, _mm_mul_ps);
    binop!(Div, div, _mm_div_ps);

    impl F32x4 {
        #[inline(always)]
        pub(super) fn splat(v: f32) -> Self {
            // SAFETY: SSE2 is always available on x86_64.
            F32x4(unsafe { _mm_set1_ps(v) })
        }
        #[inline(always)]
        pub(super) fn to_array(self) -> [f32; 4] {
            // SAFETY: __m128 and [f32; 4] have the same size; lane 0 is the lowest address.
            unsafe { std::mem::transmute::<__m128, [f32; 4]>(self.0) }
        }
        #[inline(always)]
        pub(super) fn from_array(a: [f32; 4]) -> Self {
            // SAFETY: as above.
            F32x4(unsafe { std::mem::transmute::<[f32; 4], __m128>(a) })
        }
        #[inline(always)]
        pub(super) fn abs(self) -> Self {
            // SAFETY: SSE2 is always available on x86_64.
            unsafe { F32x4(_mm_andnot_ps(_mm_set1_ps(-0.0), self.0)) }
        }
        #[inline(always)]
        pub(super) fn max_into(self, m: Self) -> Self {
            // _mm_max_ps(a, b) = if a > b { a } else { b }, lane-wise.
            // SAFETY: SSE2 is always available on x86_64.
            F32x4(unsafe { _mm_max_ps(self.0, m.0) })
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
mod imp {
    /// Four f32 lanes (portable fallback).
    #[derive(Clone, Copy, Default)]
    #[repr(C, align(16))]
    pub(crate) struct F32x4(pub(super) [f32; 4]);

    macro_rules! binop {
        ($tr:ident, $f:ident, $op:tt) => {
            impl std::ops::$tr for F32x4 {
                type Output = F32x4;
                #[inline(always)]
                fn $f(self, o: F32x4) -> F32x4 {
                    F32x4(std::array::from_fn(|k| self.0[k] $op o.0[k]))
                }
            }
        };
    }
    binop!(Add, add, +);
    binop!(Sub, sub, -);
    binop!(Mul, mul, *);
    binop!(Div, div, /);

    impl F32x4 {
        #[inline(always)]
        pub(super) fn splat(v: f32) -> Self {
            F32x4([v; 4])
        }
        #[inline(always)]
        pub(super) fn to_array(self) -> [f32; 4] {
            self.0
        }
        #[inline(always)]
        pub(super) fn from_array(a: [f32; 4]) -> Self {
            F32x4(a)
        }
        #[inline(always)]
        pub(super) fn abs(self) -> Self {
            F32x4(self.0.map(f32::abs))
        }
        #[inline(always)]
        pub(super) fn max_into(self, m: Self) -> Self {
            F32x4(std::array::from_fn(|k| if self.0[k] > m.0[k] { self.0[k] } else { m.0[k] }))
        }
    }
}

pub(crate) use imp::F32x4;

impl Lanes for F32x4 {
    const N: usize = 4;
    #[inline(always)]
    fn splat(v: f32) -> Self {
        F32x4::splat(v)
    }
    #[inline(always)]
    fn from_fn(f: impl FnMut(usize) -> f32) -> Self {
        F32x4::from_array(std::array::from_fn(f))
    }
    #[inline(always)]
    fn get(self, k: usize) -> f32 {
        self.to_array()[k]
    }
    #[inline(always)]
    fn set(&mut self, k: usize, v: f32) {
        let mut a = self.to_array();
        a[k] = v;
        *self = F32x4::from_array(a);
    }
    #[inline(always)]
    fn abs(self) -> Self {
        F32x4::abs(self)
    }
    #[inline(always)]
    fn max_into(self, m: Self) -> Self {
        F32x4::max_into(self, m)
    }
}

/// Scratch planes kept between solves. A fresh 16 MB plane (1024² cells of four lanes) is
/// mapped page by page on first touch, which costs more here than several V-cycles, so the
/// solver's planes are returned to a small pool and reused by the next solve. Bounded (96 MB
/// of four-lane planes, 32 MB of one-lane planes: a 1024² RGB blend's working set); the
/// contents of a taken plane are unspecified.
pub(crate) struct Pool<V: 'static> {
    planes: &'static std::sync::Mutex<Vec<Vec<V>>>,
    /// Most bytes the pool keeps.
    budget: usize,
}

static POOL_F32: std::sync::Mutex<Vec<Vec<f32>>> = std::sync::Mutex::new(Vec::new());
static POOL_X4: std::sync::Mutex<Vec<Vec<F32x4>>> = std::sync::Mutex::new(Vec::new());

/// Lane types with a scratch pool.
pub(crate) trait Pooled: Lanes + 'static {
    fn pool() -> Pool<Self>;
}

impl Pooled for f32 {
    fn pool() -> Pool<f32> {
        Pool { planes: &POOL_F32, budget: 32 << 20 }
    }
}

impl Pooled for F32x4 {
    fn pool() -> Pool<F32x4> {
        Pool { planes: &POOL_X4, budget: 96 << 20 }
    }
}

impl<V: Lanes + 'static> Pool<V> {
    /// A plane of `n` cells with unspecified contents (the smallest pooled one that fits,
    /// else a new zeroed one).
    pub fn take(&self, n: usize) -> Vec<V> {
        let found = {
            let mut planes = self.planes.lock().unwrap_or_else(|e| e.into_inner());
            let best = planes
                .iter()
                .enumerate()
                .filter(|(_, p)| p.capacity() >= n)
                .min_by_key(|(_, p)| p.capacity())
                .map(|(i, _)| i);
            best.map(|i| planes.swap_remove(i))
        };
        match found {
            Some(mut p) => {
                p.resize(n, V::default());
                p.truncate(n);
                p
            }
            None => vec![V::default(); n],
        }
    }

    /// A zeroed plane of `n` cells.
    pub fn take_zeroed(&self, n: usize) -> Vec<V> {
        let mut p = self.take(n);
        par_fill(&mut p, V::default());
        p
    }

    /// Returns a plane to the pool (dropped when the pool would exceed its budget).
    pub fn give(&self, p: Vec<V>) {
        let bytes = |p: &Vec<V>| p.capacity() * std::mem::size_of::<V>();
        if p.capacity() == 0 || bytes(&p) > self.budget {
            return;
        }
        let mut planes = self.planes.lock().unwrap_or_else(|e| e.into_inner());
        planes.push(p);
        // Keep the most recent planes within the budget.
        while planes.iter().map(bytes).sum::<usize>() > self.budget {
            planes.remove(0);
        }
    }
}

/// Cells per parallel task of the plane-wide fills and copies below.
const COPY_CHUNK: usize = 1 << 16;

/// `dst.fill(v)`, in parallel on large planes.
pub(crate) fn par_fill<V: Lanes>(dst: &mut [V], v: V) {
    use rayon::prelude::*;
    dst.par_chunks_mut(COPY_CHUNK).for_each(|c| c.fill(v));
}

/// `dst.copy_from_slice(src)`, in parallel on large planes.
pub(crate) fn par_copy<V: Lanes>(dst: &mut [V], src: &[V]) {
    use rayon::prelude::*;
    assert_eq!(dst.len(), src.len(), "par_copy: lengths differ");
    dst.par_chunks_mut(COPY_CHUNK).zip(src.par_chunks(COPY_CHUNK)).for_each(|(d, s)| d.copy_from_slice(s));
}
