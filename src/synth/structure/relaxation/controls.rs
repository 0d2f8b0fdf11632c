//! Constraint maps ([references: frasson §3.7.2]): density, occupancy, size, orientation and metric maps.
//!
//! Maps arrive as plain data at the target raster size (`width × height`, row-major):
//!
//! * **density** (`&[f32]`, luminance in `[0, 1]`): dark = dense. It weights the centroid step
//!   of Lloyd: `w(p) = ε + (1 − ε)·(1 − L(p))^γ` (`invert` swaps `L` and `1 − L`).
//! * **occupancy** (`&[f32]`, luminance): black (`L < 0.5`) = forbidden. The four thesis
//!   operations are (1) [`remove_forbidden`] removes ellipses (centre in a forbidden pixel, or
//!   any overlap), (2) forbidden pixels are never pushed into the flooding queue
//!   ([`crate::synth::structure::relaxation::voronoi::Domain::allowed`]), (3) so they never enter a centroid, and (4)
//!   polygonisation flags the mesh vertices on the border of the forbidden area
//!   ([`crate::synth::structure::mesh::polygonize::Polygonization::on_occupancy_border`]) so stage 2 can fix them.
//! * **size** (`&[f32]`, luminance), in one of two [`SizeMode`]s, read at the ellipse centre
//!   and multiplied into `(a, b)` ([`size_factor`]): `scale`, `k = k_min + (1 − k_min)·L`
//!   (tessera's choice), or `fixed`, the thesis's other mode: inside the marked area
//!   (`L < 0.5`) every ellipse gets one mean radius `√(ab)`, keeping its aspect ratio. The
//!   expected number of regions per pixel follows ([`area_weight`]).
//! * **orientation** (2-channel [`Image`] of unit vectors `(cos φ, sin φ)`): at every Lloyd
//!   iteration `θ` becomes the axial mean of the field over the region (`Region`) or the
//!   field at the centre (`Center`). Zero-length vectors impose nothing. Overrides `rotate`.
//! * **metric** (`&[MetricKind]`): the metric kind per pixel.

use serde::{Deserialize, Serialize};

use crate::raster::Image;
use crate::synth::structure::relaxation::metric::{wrap_axial, MetricKind};
use crate::synth::structure::relaxation::voronoi::pixel_coord;
use crate::synth::structure::types::{Ellipse, Point};

/// The density → weight mapping of [references: frasson §3.5.4].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DensityParams {
    /// Weight floor `ε` (a white pixel still weighs `ε`).
    pub eps: f32,
    pub gamma: f32,
    /// `true`: light = dense.
    pub invert: bool,
}

impl Default for DensityParams {
    fn default() -> Self {
        DensityParams { eps: 0.01, gamma: 1.0, invert: false }
    }
}

/// How [`remove_forbidden`] decides that an ellipse hits the forbidden area.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RemoveMode {
    /// The ellipse's centre lies in a forbidden pixel (default; tessera's choice, [references: frasson §3.7.2]).
    #[default]
    Center,
    /// Any pixel centre inside the ellipse is forbidden.
    AnyOverlap,
}

/// How the size map sizes the ellipses ([references: frasson §3.7.2]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SizeMode {
    /// `k = k_min + (1 − k_min)·L` at the centre: darker is smaller, down to `k_min`.
    Scale { k_min: f64 },
    /// Inside the marked area (`L < 0.5` at the centre) every ellipse gets the mean radius
    /// `√(ab) = radius` px with its aspect ratio and angle kept; elsewhere it is unchanged.
    Fixed { radius: f64 },
}

impl Default for SizeMode {
    fn default() -> Self {
        SizeMode::Scale { k_min: 0.3 }
    }
}

/// Where the orientation map is read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OrientationMode {
    /// Axial mean over the region's pixels.
    #[default]
    Region,
    /// The field at the generator's centre.
    Center,
}

/// All control maps of one synthesis, each optional, at the target size.
#[derive(Clone, Copy, Debug)]
pub struct Controls<'a> {
    /// Luminance density map (dark = dense).
    pub density: Option<&'a [f32]>,
    pub density_params: DensityParams,
    /// Occupancy mask (luminance; `< 0.5` = forbidden).
    pub occupancy: Option<&'a [f32]>,
    /// Size map (luminance; dark = small).
    pub size: Option<&'a [f32]>,
    pub size_mode: SizeMode,
    /// Orientation field, 2 channels `(cos φ, sin φ)`.
    pub orientation: Option<&'a Image>,
    pub orientation_mode: OrientationMode,
    /// Metric kind per pixel.
    pub metric: Option<&'a [MetricKind]>,
    /// Told the number of iterations run, out of the most Lloyd may run.
    pub progress: crate::synth::Progress<'a>,
}

impl Default for Controls<'_> {
    fn default() -> Self {
        Controls {
            density: None,
            density_params: DensityParams::default(),
            occupancy: None,
            size: None,
            size_mode: SizeMode::default(),
            orientation: None,
            orientation_mode: OrientationMode::Region,
            metric: None,
            progress: crate::synth::Progress::none(),
        }
    }
}

impl<'a> Controls<'a> {
    /// Panics if a map does not have `width × height` pixels (and 2 channels for orientation).
    pub fn check(&self, width: usize, height: usize) {
        let n = width * height;
        for (name, m) in [("density", self.density), ("occupancy", self.occupancy), ("size", self.size)] {
            if let Some(m) = m {
                assert_eq!(m.len(), n, "{name} map has {} pixels, expected {n}", m.len());
            }
        }
        if let Some(o) = self.orientation {
            assert!(o.width == width && o.height == height && o.channels >= 2, "orientation map size/channels");
        }
        if let Some(m) = self.metric {
            assert_eq!(m.len(), n, "metric map size");
        }
    }

    /// The allowed mask of the occupancy map (`None` when there is no map).
    pub fn allowed(&self) -> Option<Vec<bool>> {
        self.occupancy.map(allowed_from_occupancy)
    }
}

/// `w = ε + (1 − ε)·(1 − L)^γ` per pixel (`L` clamped to `[0, 1]`).
pub fn density_weights(luminance: &[f32], p: &DensityParams) -> Vec<f32> {
    luminance.iter().map(|&l| density_weight(l, p)).collect()
}

#[inline]
pub fn density_weight(l: f32, p: &DensityParams) -> f32 {
    let l = l.clamp(0.0, 1.0);
    let dark = if p.invert { l } else { 1.0 - l };
    p.eps + (1.0 - p.eps) * dark.powf(p.gamma)
}

/// Quantises a weight in `[0, 1]` to `0..=65535` (integer centroid sums are exact, so
/// centroids do not depend on the thread count).
#[inline]
pub fn quantize_weight(w: f32) -> u32 {
    (w.clamp(0.0, 1.0) * 65535.0).round() as u32
}

/// `true` where the occupancy map allows regions (luminance ≥ 0.5).
pub fn allowed_from_occupancy(occupancy: &[f32]) -> Vec<bool> {
    occupancy.iter().map(|&l| l >= 0.5).collect()
}

/// Number of allowed pixels (`width × height` without a mask).
pub fn allowed_area(allowed: Option<&[bool]>, width: usize, height: usize) -> usize {
    allowed.map_or(width * height, |a| a.iter().filter(|&&x| x).count())
}

/// Is the pixel containing `p` allowed (points outside the raster are not)?
pub fn point_allowed(allowed: Option<&[bool]>, width: usize, height: usize, p: Point) -> bool {
    if !(p[0] >= 0.0 && p[1] >= 0.0 && p[0] < width as f64 && p[1] < height as f64) {
        return false;
    }
    allowed.is_none_or(|a| a[pixel_coord(p[1], height) * width + pixel_coord(p[0], width)])
}

/// Does any forbidden pixel centre lie inside (or on) the ellipse?
pub fn ellipse_overlaps_forbidden(e: &Ellipse, width: usize, height: usize, allowed: &[bool]) -> bool {
    let frame = crate::synth::structure::relaxation::metric::EllipseFrame::new(e);
    let r = e.a;
    let x0 = pixel_coord(e.center[0] - r, width);
    let x1 = pixel_coord(e.center[0] + r, width);
    let y0 = pixel_coord(e.center[1] - r, height);
    let y1 = pixel_coord(e.center[1] + r, height);
    for y in y0..=y1 {
        for x in x0..=x1 {
            if !allowed[y * width + x] && frame.distance(MetricKind::Elliptic, x as f64 + 0.5, y as f64 + 0.5) <= 1.0 {
                return true;
            }
        }
    }
    false
}

/// Occupancy operation 1: the indices (ascending) of the ellipses to remove.
pub fn remove_forbidden(
    ellipses: &[Ellipse],
    width: usize,
    height: usize,
    allowed: &[bool],
    mode: RemoveMode,
) -> Vec<usize> {
    ellipses
        .iter()
        .enumerate()
        .filter(|(_, e)| {
            !point_allowed(Some(allowed), width, height, e.center)
                || (mode == RemoveMode::AnyOverlap && ellipse_overlaps_forbidden(e, width, height, allowed))
        })
        .map(|(i, _)| i)
        .collect()
}

/// Bilinear sample of a single-channel map at point `p` (pixel centres at `+0.5`, clamped).
pub fn sample_bilinear(map: &[f32], width: usize, height: usize, p: Point) -> f64 {
    let fx = (p[0] - 0.5).clamp(0.0, (width - 1) as f64);
    let fy = (p[1] - 0.5).clamp(0.0, (height - 1) as f64);
    let x0 = fx.floor() as usize;
    let y0 = fy.floor() as usize;
    let x1 = (x0 + 1).min(width - 1);
    let y1 = (y0 + 1).min(height - 1);
    let tx = fx - x0 as f64;
    let ty = fy - y0 as f64;
    let v = |x: usize, y: usize| map[y * width + x] as f64;
    let top = v(x0, y0) * (1.0 - tx) + v(x1, y0) * tx;
    let bot = v(x0, y1) * (1.0 - tx) + v(x1, y1) * tx;
    top * (1.0 - ty) + bot * ty
}

/// The factor the size map applies to the axes of `e` (read at its centre; `L` bilinear,
/// clamped to [0, 1]).
pub fn size_factor(size: &[f32], width: usize, height: usize, mode: SizeMode, e: &Ellipse) -> f64 {
    let l = sample_bilinear(size, width, height, e.center).clamp(0.0, 1.0);
    match mode {
        SizeMode::Scale { k_min } => k_min + (1.0 - k_min) * l,
        SizeMode::Fixed { radius } if l < 0.5 => radius / (e.a * e.b).sqrt(),
        SizeMode::Fixed { .. } => 1.0,
    }
}

/// How many regions pixel `p` holds relative to an unsized one, whose region has mean area
/// `region_area` px: `1/k(p)²` in `scale` mode; in `fixed` mode `region_area / (π·radius²)`
/// inside the marked area and 1 elsewhere. It weighs the region count `N'` and the placement
/// of the initial generators.
pub fn area_weight(size: &[f32], width: usize, height: usize, mode: SizeMode, p: Point, region_area: f64) -> f64 {
    let l = sample_bilinear(size, width, height, p).clamp(0.0, 1.0);
    match mode {
        SizeMode::Scale { k_min } => 1.0 / (k_min + (1.0 - k_min) * l).powi(2),
        SizeMode::Fixed { radius } if l < 0.5 => region_area / (std::f64::consts::PI * radius * radius),
        SizeMode::Fixed { .. } => 1.0,
    }
}

/// Axial angle in `[0, π)` of a direction vector, `None` for a (near) zero vector.
pub fn vector_angle(c: f64, s: f64) -> Option<f64> {
    if c * c + s * s < 1e-12 {
        None
    } else {
        Some(wrap_axial(s.atan2(c)))
    }
}

/// Orientation field value at `p` (nearest pixel), as an axial angle.
pub fn orientation_at(field: &Image, p: Point) -> Option<f64> {
    let x = pixel_coord(p[0], field.width);
    let y = pixel_coord(p[1], field.height);
    vector_angle(field.get(x, y, 0) as f64, field.get(x, y, 1) as f64)
}

/// The doubled-angle vectors `(|v|·cos 2φ, |v|·sin 2φ)` of an orientation field, resampled
/// bilinearly to `nw × nh` (summing them over a region gives its axial mean).
pub fn doubled_angle_field(field: &Image, nw: usize, nh: usize) -> (Vec<f32>, Vec<f32>) {
    let n = field.width * field.height;
    let mut c2 = Vec::with_capacity(n);
    let mut s2 = Vec::with_capacity(n);
    for i in 0..n {
        let (c, s) = (field.data[i], field.data[n + i]);
        let r = (c * c + s * s).sqrt();
        if r > 1e-6 {
            // |v|·(cos 2φ, sin 2φ) = (c² − s², 2cs) / |v|.
            c2.push((c * c - s * s) / r);
            s2.push(2.0 * c * s / r);
        } else {
            c2.push(0.0);
            s2.push(0.0);
        }
    }
    (
        resample_bilinear(&c2, field.width, field.height, nw, nh),
        resample_bilinear(&s2, field.width, field.height, nw, nh),
    )
}

/// Metric kinds from a level map: `round(2·v)` = 0 elliptic, 1 Manhattan, 2 Chebyshev.
pub fn metric_map_from_levels(levels: &[f32]) -> Vec<MetricKind> {
    levels
        .iter()
        .map(|&v| match (v.clamp(0.0, 1.0) * 2.0).round() as u8 {
            0 => MetricKind::Elliptic,
            1 => MetricKind::Manhattan,
            _ => MetricKind::Chebyshev,
        })
        .collect()
}

/// Bilinear resampling of a single-channel map (pixel centres aligned; identity when the size
/// does not change).
pub fn resample_bilinear(src: &[f32], w: usize, h: usize, nw: usize, nh: usize) -> Vec<f32> {
    if nw == w && nh == h {
        return src.to_vec();
    }
    let sx = w as f64 / nw as f64;
    let sy = h as f64 / nh as f64;
    let mut out = Vec::with_capacity(nw * nh);
    for y in 0..nh {
        for x in 0..nw {
            let p = [(x as f64 + 0.5) * sx, (y as f64 + 0.5) * sy];
            out.push(sample_bilinear(src, w, h, p) as f32);
        }
    }
    out
}

/// Nearest-neighbour resampling (masks, metric kinds).
pub fn resample_nearest<T: Copy>(src: &[T], w: usize, h: usize, nw: usize, nh: usize) -> Vec<T> {
    if nw == w && nh == h {
        return src.to_vec();
    }
    let sx = w as f64 / nw as f64;
    let sy = h as f64 / nh as f64;
    let mut out = Vec::with_capacity(nw * nh);
    for y in 0..nh {
        let yy = pixel_coord((y as f64 + 0.5) * sy, h);
        for x in 0..nw {
            let xx = pixel_coord((x as f64 + 0.5) * sx, w);
            out.push(src[yy * w + xx]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn density_weight_formula() {
        let p = DensityParams::default();
        assert!((density_weight(0.0, &p) - 1.0).abs() < 1e-7);
        assert!((density_weight(1.0, &p) - 0.01).abs() < 1e-7);
        assert!((density_weight(0.5, &p) - (0.01 + 0.99 * 0.5)).abs() < 1e-7);
        let inv = DensityParams { invert: true, gamma: 2.0, ..p };
        assert!((density_weight(1.0, &inv) - 1.0).abs() < 1e-7);
        assert!((density_weight(0.5, &inv) - (0.01 + 0.99 * 0.25)).abs() < 1e-7);
        assert_eq!(quantize_weight(1.0), 65535);
        assert_eq!(quantize_weight(0.0), 0);
    }

    #[test]
    fn occupancy_removal_modes() {
        let (w, h) = (40, 30);
        let occ: Vec<f32> = (0..w * h).map(|i| if (20..30).contains(&(i % w)) { 0.0 } else { 1.0 }).collect();
        let allowed = allowed_from_occupancy(&occ);
        assert_eq!(allowed_area(Some(&allowed), w, h), 30 * 30);
        let es = [
            Ellipse { center: [5.0, 5.0], a: 3.0, b: 2.0, theta: 0.0 }, // clear
            Ellipse { center: [25.0, 5.0], a: 3.0, b: 2.0, theta: 0.0 }, // centre forbidden
            Ellipse { center: [17.5, 15.0], a: 4.0, b: 2.0, theta: 0.0 }, // overlaps only
        ];
        assert_eq!(remove_forbidden(&es, w, h, &allowed, RemoveMode::Center), vec![1]);
        assert_eq!(remove_forbidden(&es, w, h, &allowed, RemoveMode::AnyOverlap), vec![1, 2]);
    }

    #[test]
    fn size_and_orientation_helpers() {
        let (w, h) = (10, 10);
        let size: Vec<f32> = (0..w * h).map(|i| if i % w < 5 { 0.0 } else { 1.0 }).collect();
        let at = |x: f64| Ellipse { center: [x, 1.0], a: 8.0, b: 2.0, theta: 0.3 };
        let scale = SizeMode::Scale { k_min: 0.3 };
        assert!((size_factor(&size, w, h, scale, &at(1.0)) - 0.3).abs() < 1e-12);
        assert!((size_factor(&size, w, h, scale, &at(9.0)) - 1.0).abs() < 1e-12);
        assert!((area_weight(&size, w, h, scale, [1.0, 1.0], 50.0) - 1.0 / 0.09).abs() < 1e-9);
        // Fixed: √(ab) = 2 inside the marked (dark) half; unchanged outside.
        let fixed = SizeMode::Fixed { radius: 2.0 };
        let k = size_factor(&size, w, h, fixed, &at(1.0));
        assert!((k * (at(1.0).a * at(1.0).b).sqrt() - 2.0).abs() < 1e-12);
        assert_eq!(size_factor(&size, w, h, fixed, &at(9.0)), 1.0);
        let pi4 = std::f64::consts::PI * 4.0;
        assert!((area_weight(&size, w, h, fixed, [1.0, 1.0], 50.0) - 50.0 / pi4).abs() < 1e-12);
        assert_eq!(area_weight(&size, w, h, fixed, [9.0, 1.0], 50.0), 1.0);
        let f = Image::from_fn(w, h, 2, |_, _, c| if c == 0 { 0.0 } else { 1.0 });
        assert!((orientation_at(&f, [3.0, 3.0]).unwrap() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        let (c2, s2) = doubled_angle_field(&f, 5, 5);
        assert!(c2.iter().all(|&c| (c + 1.0).abs() < 1e-6) && s2.iter().all(|&s| s.abs() < 1e-6));
        assert_eq!(vector_angle(0.0, 0.0), None);
        assert_eq!(
            metric_map_from_levels(&[0.0, 0.5, 1.0]),
            vec![MetricKind::Elliptic, MetricKind::Manhattan, MetricKind::Chebyshev]
        );
        let r = resample_nearest(&size, w, h, 5, 5);
        assert_eq!(r[0], 0.0);
        assert_eq!(r[4], 1.0);
    }
}
