//! Relightable surfaces: photometric stacks, their per-pixel representations and relighting
//! (Dong 2003, Ch. 4 and 6; [references: dong §4.4]).
//!
//! A [`PhotoStack`] holds `n` registered monochrome images of one surface, each under a known
//! distant [`Light`]. [`extract`] turns it into a [`Representation`]: `k` per-pixel maps (`M1`)
//! and a global [`Basis`] (`M2` or what stands for it) such that the image under any light is
//! the per-pixel dot product `i = M1 · c(light)` ([`Basis::kernel`]). Five methods
//! ([`Method`]): 3I, Gradient (photometric stereo), PTM, Eigen-k. Because relighting is per
//! pixel, a quilted representation (one index map driving every channel) relights exactly like
//! the gathered relit sample.
//!
//! Also here: height from gradients (Frankot–Chellappa and a least-squares Neumann
//! integration, `height`), the η evaluation in reconstruction and leave-one-out modes
//! (`evaluate`), renderer exports (`export`), PTM 1.2 files (`ptm_file`), and surfaces grown
//! from rotated copies under an orientation field, relit in each pixel's frame (`frame`).
//!
//! **Frame.** Array terms throughout: x = column, y = row, z toward the camera; `p = ∂s/∂x`,
//! `q = ∂s/∂y`; a light's tilt is measured from +x toward +y (`light`). Shown with row 0 on
//! top this frame is mirror-imaged, which is harmless as long as every formula uses it; the
//! PTM writer converts to the viewers' y-up frame.
//!
//! **Colour.** The representations are fitted on luminance; a colour stack also carries a
//! per-pixel chromaticity (RGB / luminance, intensity-weighted over the images), and a colour
//! relight is chromaticity × relit luminance (the LRGB model of PTM files). Mono stacks have
//! none.
//!
//! Everything is f64 inside; results do not depend on the rayon thread count (per-pixel work
//! has a fixed operation order, and reductions sum fixed chunks in a fixed order).

mod error;
pub mod evaluate;
pub mod export;
#[cfg(any(test, feature = "fixtures"))]
pub mod fixtures;
pub mod frame;
pub mod height;
mod light;
pub mod ptm_file;
pub mod represent;
mod stack;

pub use error::RelightError;
pub use light::{grid, Light};
pub use represent::{
    extract, relight_image, relight_planes, Basis, EigenBasis, Kernel, Method, Representation, NZ_MIN,
};
pub use stack::{PhotoStack, LUMA_WEIGHTS};
