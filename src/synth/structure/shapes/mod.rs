//! Stage 2, shape correction ([references: frasson §3.5.4]): the turning-function distance, closest-shape
//! association and the optimisation that moves each region's vertices towards its original.
pub mod associate;
pub mod optimize;
pub mod turning;
