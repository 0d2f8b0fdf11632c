//! The grey plane the patch, pyramid and spectrum measures compare (its own module so those
//! measures depend on it, not on the module that gathers them).

use crate::raster::Image;

/// Rec. 709 luma of channels 0–2, channel 0 for 1 or 2 channels, as a plane.
pub(crate) fn luma(img: &Image) -> Vec<f32> {
    const K: [f32; 3] = [0.2126, 0.7152, 0.0722];
    if img.channels >= 3 {
        let (r, g, b) = (img.plane(0), img.plane(1), img.plane(2));
        (0..img.plane_len()).map(|i| K[0] * r[i] + K[1] * g[i] + K[2] * b[i]).collect()
    } else if img.channels >= 1 {
        img.plane(0).to_vec()
    } else {
        vec![0.0; img.plane_len()]
    }
}
