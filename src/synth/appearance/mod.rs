//! Structured appearance from example ([references: frasson §4]): a photo and its drawn
//! structure become a few unified textures and two atlases (analysis), and any mesh gets one
//! textured polygon per region, edge and vertex (synthesis), drawn by a 2-D renderer.
//!
//! Files: `types` (the plain data every step shares), `color` (CIELAB means, ΔE), `extract`,
//! `cluster` and `unified` (region interiors, analysis), `alpha` (stone vs mortar),
//! `interstice` and `junction` (the contour atlases), `dress/` (synthesis: interiors,
//! interstices, junctions, matching), `render` (the rasteriser of textured pieces).
//!
//! Images here are RGB, sRGB-encoded in `[0, 1]` (as samples are loaded by default); colour
//! distances are CIE76 ΔE in CIELAB (D65). Atlases carry alpha as a fourth channel.

pub mod alpha;
pub mod analysis;
pub mod cluster;
pub mod color;
pub mod dress;
pub mod extract;
pub mod interstice;
pub mod junction;
pub mod render;
pub mod types;
pub mod unified;

pub use types::*;
