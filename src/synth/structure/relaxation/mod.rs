//! Stage 1's relaxation (digest 004 §2.5–2.7, §2.11): the elliptic metric, the control maps
//! that steer it, discrete anisotropic Voronoi diagrams and Lloyd iterations over them.
pub mod controls;
pub mod lloyd;
pub mod metric;
pub mod voronoi;
