//! Seam texture (placeholder).
