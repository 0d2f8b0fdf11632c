//! Stage 2, shape correction (digest 004 §2.9): the turning-function distance, closest-shape
//! association and the optimisation that moves each region's vertices towards its original.
pub mod associate;
pub mod optimize;
pub mod turning;
