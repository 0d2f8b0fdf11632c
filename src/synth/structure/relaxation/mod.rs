//! Stage 1's relaxation ([references: frasson §3.5.1, §3.5.2, §3.7.2]): the elliptic metric, the control maps
//! that steer it, discrete anisotropic Voronoi diagrams and Lloyd iterations over them.
pub mod controls;
pub mod lloyd;
pub mod metric;
pub mod voronoi;
