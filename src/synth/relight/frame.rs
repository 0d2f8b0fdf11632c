//! Relightable surfaces grown from rotated copies of a sample (quilting under an orientation
//! field): every pixel keeps the maps of the copy it came from, in that copy's frame, and is
//! relit by turning the light into its frame, `τ → τ − θ(x)` (option a) [references: dong §6.1]
//!
//! A copy rotated by θ shows the sample at `R(−θ)·d`, so its height is `s(R(−θ)·d)` and its
//! gradient `R(θ)·(p, q)`; lighting it at `l` is lighting the sample at `R(−θ)·l`, a change of
//! tilt only, so the slant stays where Eigen's grid has it. Every method relights this way.
//! Rewriting the maps themselves into the output frame (option b) is exact for 3I, Gradient and
//! PTM, whose relight coefficients are linear (3I, PTM) or a rotation (Gradient) in `l`; Eigen's
//! coefficients are interpolated on a light grid, which no per-pixel linear map rotates, so
//! [`to_output_frame`] refuses it.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use crate::raster::Image;
use crate::synth::relight::error::RelightError;
use crate::synth::relight::light::Light;
use crate::synth::relight::represent::{lambert, Basis, Kernel};

/// `light` as seen from a pixel whose copy was rotated by `angle` radians.
pub fn light_in_frame(light: &Light, angle: f32) -> Light {
    Light::new(light.tilt_deg - f64::from(angle).to_degrees(), light.slant_deg)
}

fn check(maps: &Image, basis: &Basis, angles: &Image) -> Result<(), RelightError> {
    if maps.channels != basis.channels() {
        return Err(RelightError::Channels { got: maps.channels, expected: basis.channels() });
    }
    if (angles.width, angles.height) != (maps.width, maps.height) || angles.channels != 1 {
        return Err(RelightError::Size {
            what: "the rotation map",
            got: [angles.width, angles.height],
            expected: [maps.width, maps.height],
        });
    }
    Ok(())
}

/// The distinct angles of the rotation map, in order of first appearance, and each pixel's
/// index into them. Quilting uses a few pre-rotated copies, so there are few.
fn distinct(angles: &Image) -> (Vec<f32>, Vec<u16>) {
    let mut seen: Vec<f32> = Vec::new();
    let mut which = Vec::with_capacity(angles.data.len());
    // Blocks make runs of one angle: try the previous pixel's first.
    let mut last = usize::MAX;
    for &a in &angles.data {
        if last == usize::MAX || seen[last].to_bits() != a.to_bits() {
            last = match seen.iter().position(|s| s.to_bits() == a.to_bits()) {
                Some(i) => i,
                None => {
                    seen.push(a);
                    seen.len() - 1
                }
            };
        }
        which.push(u16::try_from(last).unwrap_or(u16::MAX));
    }
    (seen, which)
}

/// Relights `maps` at `light`, each pixel in the frame its rotation `angles` (radians, one
/// channel) gives it. With every angle 0 this is [`relight_image`](super::relight_image) bit for
/// bit.
pub fn relight_rotated(maps: &Image, basis: &Basis, light: &Light, angles: &Image) -> Result<Image, RelightError> {
    check(maps, basis, angles)?;
    let (seen, which) = distinct(angles);
    if seen.len() > usize::from(u16::MAX) {
        return Err(RelightError::Size {
            what: "the number of distinct rotations",
            got: [seen.len(), 1],
            expected: [1, 1],
        });
    }
    let kernels: Vec<Kernel> =
        seen.iter().map(|&a| basis.kernel(&light_in_frame(light, a))).collect::<Result<_, _>>()?;
    let (w, m) = (maps.width, maps.width * maps.height);
    let planes: Vec<&[f32]> = (0..maps.channels).map(|c| maps.plane(c)).collect();
    let mut out = Image::new(maps.width, maps.height, 1);
    if w == 0 || m == 0 {
        return Ok(out);
    }
    out.data.par_chunks_mut(w).enumerate().with_min_len(8).for_each_init(
        || vec![0.0f64; w],
        |acc, (y, row)| {
            let s = y * w;
            let mut x0 = 0;
            // Runs of one rotation share a kernel; within a run the sums go plane by plane as
            // in `relight_image`, so angle 0 reproduces it exactly.
            while x0 < w {
                let k = which[s + x0];
                let x1 = (x0..w).find(|&x| which[s + x] != k).unwrap_or(w);
                match &kernels[usize::from(k)] {
                    Kernel::Linear(coef) => {
                        let acc = &mut acc[x0..x1];
                        acc.fill(0.0);
                        for (plane, &c) in planes.iter().zip(coef) {
                            for (a, &v) in acc.iter_mut().zip(&plane[s + x0..s + x1]) {
                                *a += c * f64::from(v);
                            }
                        }
                        for (o, &a) in row[x0..x1].iter_mut().zip(acc.iter()) {
                            *o = a as f32;
                        }
                    }
                    Kernel::Lambert(l) => {
                        for (x, o) in (x0..x1).zip(row[x0..x1].iter_mut()) {
                            let i = s + x;
                            *o = lambert(f64::from(planes[0][i]), f64::from(planes[1][i]), f64::from(planes[2][i]), *l)
                                as f32;
                        }
                    }
                }
                x0 = x1;
            }
        },
    );
    Ok(out)
}

/// The per-pixel linear map `T(θ)` with `c(R(−θ)·l) = T · c(l)` for every light, found by least
/// squares over a spread of lights; `None` when no linear map fits (Eigen), checked by the
/// residual.
fn coefficient_rotation(basis: &Basis, angle: f32) -> Result<Option<DMatrix<f64>>, RelightError> {
    let k = basis.channels();
    let mut lights = Vec::new();
    for slant in [20.0, 35.0, 50.0, 65.0, 80.0] {
        for t in 0..12 {
            lights.push(Light::new(f64::from(t) * 30.0 + slant, slant));
        }
    }
    let mut a = DMatrix::zeros(lights.len(), k);
    let mut b = DMatrix::zeros(lights.len(), k);
    for (j, l) in lights.iter().enumerate() {
        let c = basis.coefficients(l)?;
        let r = basis.coefficients(&light_in_frame(l, angle))?;
        for i in 0..k {
            a[(j, i)] = c[i];
            b[(j, i)] = r[i];
        }
    }
    // Rows of A·Tᵀ = B: least squares through the SVD (A has full column rank for 3I and PTM).
    let svd = a.clone().svd(true, true);
    let tt = svd.solve(&b, 1e-12).map_err(|_| RelightError::Degenerate {
        method: "rotation of the maps",
        smallest: 0.0,
        largest: 0.0,
    })?;
    let residual = (&a * &tt - &b).norm();
    Ok((residual <= 1e-9 * b.norm().max(1.0)).then(|| tt.transpose()))
}

/// The maps rewritten into the output frame (option b): 3I and PTM through the exact linear map
/// of their coefficients, Gradient by rotating `(p, q)`. Fails for Eigen.
pub fn to_output_frame(maps: &Image, basis: &Basis, angles: &Image) -> Result<Image, RelightError> {
    check(maps, basis, angles)?;
    let (seen, which) = distinct(angles);
    let m = maps.width * maps.height;
    let mut out = maps.clone();
    if *basis == Basis::Gradient {
        let turns: Vec<(f64, f64)> = seen.iter().map(|&a| f64::from(a).sin_cos()).collect();
        for i in 0..m {
            let (s, c) = turns[usize::from(which[i])];
            let (p, q) = (f64::from(maps.data[i]), f64::from(maps.data[m + i]));
            out.data[i] = (c * p - s * q) as f32;
            out.data[m + i] = (s * p + c * q) as f32;
        }
        return Ok(out);
    }
    if matches!(basis, Basis::Eigen(_)) {
        return Err(RelightError::NoRotation);
    }
    let k = basis.channels();
    let mut maps_t = Vec::with_capacity(seen.len());
    for &a in &seen {
        // Each pixel's relight is `c(l) · v`, so its maps in the output frame are `Tᵀ · v`.
        maps_t.push(coefficient_rotation(basis, a)?.ok_or(RelightError::NoRotation)?.transpose());
    }
    let mut v = DVector::zeros(k);
    for i in 0..m {
        for c in 0..k {
            v[c] = f64::from(maps.data[c * m + i]);
        }
        let r = &maps_t[usize::from(which[i])] * &v;
        for c in 0..k {
            out.data[c * m + i] = r[c] as f32;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::quilt::rotate_sample;
    use crate::synth::relight::fixtures::{scenario, Scenario};
    use crate::synth::relight::{extract, relight_image, Method};

    fn plane_image(v: &[f64], w: usize, h: usize) -> Image {
        Image { width: w, height: h, channels: 1, data: v.iter().map(|&x| x as f32).collect() }
    }

    fn worst(a: &Image, b: &Image) -> f64 {
        a.data.iter().zip(&b.data).map(|(x, y)| f64::from((x - y).abs())).fold(0.0, f64::max)
    }

    #[test]
    fn angle_zero_is_plain_relighting_bit_for_bit() {
        let cap = scenario(Scenario::B);
        let light = Light::new(75.0, 50.0);
        for method in [Method::ThreeI, Method::Gradient, Method::Ptm, Method::Eigen(6)] {
            let rep = extract(&cap.stack, method).unwrap();
            let maps = rep.to_image();
            let zero = Image::new(maps.width, maps.height, 1);
            let a = relight_rotated(&maps, &rep.basis, &light, &zero).unwrap();
            let b = relight_image(&maps, &rep.basis, &light).unwrap();
            assert_eq!(a.data, b.data, "{method:?}");
        }
    }

    /// A quarter turn of the whole sample is a permutation of pixels, so the rotated copy relit
    /// in its pixels' frames must be the rotated surface rendered directly: scenario A is exact
    /// Lambert, where every linear method reproduces the render.
    #[test]
    fn a_rotated_copy_relights_as_the_rotated_surface() {
        let cap = scenario(Scenario::A);
        let n = cap.n;
        let angle = std::f32::consts::FRAC_PI_2;
        // The surface rotated by a quarter turn: height permuted, gradient turned by R(θ).
        let truth_s = rotate_sample(&plane_image(&cap.height, n, n), angle).0;
        let albedo = rotate_sample(&plane_image(&cap.albedo, n, n), angle).0;
        let p = rotate_sample(&plane_image(&cap.p, n, n), angle).0;
        let q = rotate_sample(&plane_image(&cap.q, n, n), angle).0;
        assert_eq!(truth_s.width, n);
        let light = Light::new(60.0, 60.0);
        let l = light.vector();
        // R(θ) for a quarter turn: (p, q) → (−q, p).
        let expected = Image::from_fn(n, n, 1, |x, y, _| {
            let (pp, qq) = (-q.get(x, y, 0), p.get(x, y, 0));
            lambert(f64::from(pp), f64::from(qq), f64::from(albedo.get(x, y, 0)), l) as f32
        });
        let angles = Image { width: n, height: n, channels: 1, data: vec![angle; n * n] };
        for method in [Method::ThreeI, Method::Gradient, Method::Ptm, Method::Eigen(3)] {
            let rep = extract(&cap.stack, method).unwrap();
            let copy = rotate_sample(&rep.to_image(), angle).0;
            let lit = relight_rotated(&copy, &rep.basis, &light, &angles).unwrap();
            // Every method: the copy relit is the sample relit at the turned light, turned.
            let turned = relight_image(&rep.to_image(), &rep.basis, &light_in_frame(&light, angle)).unwrap();
            assert_eq!(lit.data, rotate_sample(&turned, angle).0.data, "{method:?}");
            if matches!(method, Method::ThreeI | Method::Gradient) {
                // Exact on Lambertian data: the render of the rotated surface itself.
                assert!(worst(&lit, &expected) < 1e-5, "{method:?}: {}", worst(&lit, &expected));
            }
            if method != Method::Eigen(3) {
                // Option b: the maps rewritten into the output frame relight at `light` directly.
                let framed = to_output_frame(&copy, &rep.basis, &angles).unwrap();
                let direct = relight_image(&framed, &rep.basis, &light).unwrap();
                assert!(worst(&direct, &lit) < 1e-5, "{method:?} option b: {}", worst(&direct, &lit));
            }
        }
    }

    #[test]
    fn any_angle_rewritten_into_the_output_frame_relights_the_same() {
        let cap = scenario(Scenario::C);
        let n = cap.n;
        let angles = Image::from_fn(n, n, 1, |x, y, _| [0.3f32, -1.1, 2.5, 0.0][(x / 7 + y / 5) % 4]);
        for method in [Method::ThreeI, Method::Gradient, Method::Ptm] {
            let rep = extract(&cap.stack, method).unwrap();
            let maps = rep.to_image();
            let framed = to_output_frame(&maps, &rep.basis, &angles).unwrap();
            for light in [Light::new(10.0, 30.0), Light::new(200.0, 70.0)] {
                let a = relight_rotated(&maps, &rep.basis, &light, &angles).unwrap();
                let b = relight_image(&framed, &rep.basis, &light).unwrap();
                assert!(worst(&a, &b) < 1e-5, "{method:?} {light:?}: {}", worst(&a, &b));
            }
        }
        let eigen = extract(&cap.stack, Method::Eigen(6)).unwrap();
        let err = to_output_frame(&eigen.to_image(), &eigen.basis, &angles).unwrap_err();
        assert_eq!(err, RelightError::NoRotation);
    }

    #[test]
    fn a_rotation_map_of_the_wrong_size_is_an_error() {
        let cap = scenario(Scenario::A);
        let rep = extract(&cap.stack, Method::Gradient).unwrap();
        let bad = Image::new(3, 3, 1);
        assert!(matches!(
            relight_rotated(&rep.to_image(), &rep.basis, &Light::new(0.0, 45.0), &bad),
            Err(RelightError::Size { .. })
        ));
    }
}
