//! Height from gradients and gradients from height [references: dong §4.5.3]
//!
//! - Integrability: `v P = u Q` for the spectra `P`, `Q` of an integrable `(p, q)`; the
//!   residual `‖vP − uQ‖₂` (unnormalised DFT, u, v in radians per pixel) measures how far a
//!   fitted field is from any surface.
//! - Frankot–Chellappa: `S = (−j u P − j v Q) / (u² + v²)`, `S(0, 0) = 0` (zero-mean height),
//!   periodic; the least-squares projection of `(p, q)` onto integrable fields. Any size.
//! - Least squares without wrap: `min Σ_edges (s_j − s_i − g_ij)²` with `g` the mean of the
//!   two pixels' gradient on each 4-neighbour edge, i.e. the Neumann Poisson problem, solved
//!   exactly by the DCT solver `synth::blend` uses.
//! - Re-differentiation: spectral (`P = j u S`) or forward differences (periodic).
//!
//! Frequencies follow the usual FFT order: bin `k` of `N` is `2πk/N` for `k < N/2` and
//! `2π(k − N)/N` above, with the Nyquist bin of an even size negative.

use rayon::prelude::*;
use rustfft::num_complex::Complex64;
use serde::{Deserialize, Serialize};

use super::represent::lambert;
use super::Light;
use crate::synth::blend::solve_neumann;
use crate::synth::fft::RealFft2;

/// Signed angular frequency of bin `k` of `n`.
fn freq(k: usize, n: usize) -> f64 {
    let s = if k < n.div_ceil(2) { k as f64 } else { k as f64 - n as f64 };
    2.0 * std::f64::consts::PI * s / n as f64
}

/// How the half spectrum's column `kx` counts in the full spectrum (its mirror is implicit).
fn weight(kx: usize, w: usize) -> f64 {
    if kx == 0 || (w % 2 == 0 && kx == w / 2) {
        1.0
    } else {
        2.0
    }
}

/// `‖vP − uQ‖₂` over the full (unnormalised) spectrum.
pub fn integrability_residual(p: &[f64], q: &[f64], width: usize, height: usize) -> f64 {
    let fft = RealFft2::new(width, height);
    let (sp, sq) = (fft.forward(p), fft.forward(q));
    let mut total = 0.0;
    for kx in 0..fft.half_width() {
        let u = freq(kx, width);
        for ky in 0..height {
            let v = freq(ky, height);
            let i = fft.index(kx, ky);
            total += weight(kx, width) * (sp[i] * v - sq[i] * u).norm_sqr();
        }
    }
    total.sqrt()
}

/// Frankot–Chellappa integration (periodic, zero-mean result) [references: dong §4.5.3]
pub fn frankot_chellappa(p: &[f64], q: &[f64], width: usize, height: usize) -> Vec<f64> {
    let fft = RealFft2::new(width, height);
    let (sp, mut sq) = (fft.forward(p), fft.forward(q));
    let n = (width * height) as f64;
    let j = Complex64::new(0.0, 1.0);
    let stride = fft.stride();
    sq.par_chunks_mut(stride).zip(sp.par_chunks(stride)).enumerate().for_each(|(kx, (cq, cp))| {
        let u = freq(kx, width);
        for ky in 0..height {
            let v = freq(ky, height);
            let d = u * u + v * v;
            // The inverse transform's 1/(W·H) is folded in here.
            cq[ky] = if d == 0.0 { Complex64::new(0.0, 0.0) } else { (-j * u * cp[ky] - j * v * cq[ky]) / (d * n) };
        }
    });
    fft.inverse(&mut sq)
}

/// How to differentiate a height map.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Differentiation {
    /// `P = j u S`, `Q = j v S` (exact for band-limited periodic heights).
    Spectral,
    /// `p = s(x+1, y) − s(x, y)`, `q = s(x, y+1) − s(x, y)`, wrapping at the border.
    Forward,
}

/// `(p, q)` of a height map.
pub fn differentiate(s: &[f64], width: usize, height: usize, how: Differentiation) -> (Vec<f64>, Vec<f64>) {
    match how {
        Differentiation::Forward => {
            let p = (0..width * height).map(|i| s[(i / width) * width + (i % width + 1) % width] - s[i]).collect();
            let q = (0..width * height).map(|i| s[((i / width + 1) % height) * width + i % width] - s[i]).collect();
            (p, q)
        }
        Differentiation::Spectral => {
            let fft = RealFft2::new(width, height);
            let spec = fft.forward(s);
            let n = (width * height) as f64;
            let j = Complex64::new(0.0, 1.0);
            let mut sp = spec.clone();
            let mut sq = spec;
            for kx in 0..fft.half_width() {
                let u = freq(kx, width);
                for ky in 0..height {
                    let v = freq(ky, height);
                    let i = fft.index(kx, ky);
                    sp[i] = j * u * sp[i] / n;
                    sq[i] = j * v * sq[i] / n;
                }
            }
            (fft.inverse(&mut sp), fft.inverse(&mut sq))
        }
    }
}

/// The integrable field nearest `(p, q)` (Frankot–Chellappa, then spectral derivatives).
pub fn project_integrable(p: &[f64], q: &[f64], width: usize, height: usize) -> (Vec<f64>, Vec<f64>) {
    differentiate(&frankot_chellappa(p, q, width, height), width, height, Differentiation::Spectral)
}

/// Least-squares integration without wrap (Neumann border), zero-mean result.
pub fn integrate_least_squares(p: &[f64], q: &[f64], width: usize, height: usize) -> Vec<f64> {
    let mut b = vec![0.0; width * height];
    for y in 0..height {
        for x in 0..width {
            let i = y * width + x;
            if x + 1 < width {
                let g = 0.5 * (p[i] + p[i + 1]);
                b[i + 1] += g;
                b[i] -= g;
            }
            if y + 1 < height {
                let g = 0.5 * (q[i] + q[i + width]);
                b[i + width] += g;
                b[i] -= g;
            }
        }
    }
    solve_neumann(&b, width, height, 0.0)
}

/// Height-based relighting: Lambert with the given albedo and the derivatives of `s`.
pub fn relight_from_height(
    s: &[f64],
    albedo: &[f64],
    width: usize,
    height: usize,
    how: Differentiation,
    light: &Light,
) -> Vec<f64> {
    let (p, q) = differentiate(s, width, height, how);
    let l = light.vector();
    (0..width * height).map(|i| lambert(p[i], q[i], albedo[i], l)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::relight::evaluate::eta;
    use crate::synth::relight::fixtures::{scenario, surface, Scenario};
    use crate::synth::relight::represent::{extract, Method};

    fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
    }

    fn zero_mean(v: &[f64]) -> Vec<f64> {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        v.iter().map(|x| x - m).collect()
    }

    /// Dong `item 13`: integrability, Frankot–Chellappa, and projection of a curl field.
    #[test]
    fn frankot_chellappa_integrates_and_projects() {
        for (w, h) in [(32, 32), (30, 21)] {
            // The analytic surface is periodic on n × n only; other sizes use a band-limited one.
            let (s, p, q) = if w == h {
                surface(w, 0.8)
            } else {
                let (fx, fy) = (2.0 * std::f64::consts::PI / w as f64, 2.0 * std::f64::consts::PI / h as f64);
                let f = |x: f64, y: f64| {
                    (
                        (2.0 * fx * x).sin() + 0.5 * (3.0 * fy * y + fx * x).cos(),
                        2.0 * fx * (2.0 * fx * x).cos() - 0.5 * fx * (3.0 * fy * y + fx * x).sin(),
                        -1.5 * fy * (3.0 * fy * y + fx * x).sin(),
                    )
                };
                let v: Vec<(f64, f64, f64)> = (0..w * h).map(|i| f((i % w) as f64, (i / w) as f64)).collect();
                (v.iter().map(|t| t.0).collect(), v.iter().map(|t| t.1).collect(), v.iter().map(|t| t.2).collect())
            };
            let r = integrability_residual(&p, &q, w, h);
            assert!(r < 1e-9, "{w}x{h}: residual {r}");
            let got = frankot_chellappa(&p, &q, w, h);
            assert!(max_abs_diff(&got, &zero_mean(&s)) <= 1e-9, "{w}x{h}");
            // A curl-only field (the perpendicular gradient of a periodic ψ) is removed.
            let psi = |x: f64, y: f64| (2.0 * std::f64::consts::PI * (x / w as f64 + 2.0 * y / h as f64)).sin();
            let (mut p2, mut q2) = (p.clone(), q.clone());
            let (pp, pq) = differentiate(
                &(0..w * h).map(|i| psi((i % w) as f64, (i / w) as f64)).collect::<Vec<_>>(),
                w,
                h,
                Differentiation::Spectral,
            );
            for i in 0..w * h {
                p2[i] += pq[i];
                q2[i] -= pp[i];
            }
            assert!(integrability_residual(&p2, &q2, w, h) > 1.0);
            let (p3, q3) = project_integrable(&p2, &q2, w, h);
            assert!(max_abs_diff(&p3, &p) < 1e-9 && max_abs_diff(&q3, &q) < 1e-9);
        }
    }

    /// The least-squares (Neumann) integration is exact for quadratic surfaces, which no
    /// periodic method can represent.
    #[test]
    fn least_squares_integration_recovers_non_periodic_surfaces() {
        let (w, h) = (23, 17);
        let s: Vec<f64> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                0.01 * x * x + 0.02 * x * y - 0.03 * y + 0.005 * y * y
            })
            .collect();
        let p: Vec<f64> = (0..w * h).map(|i| 0.02 * (i % w) as f64 + 0.02 * (i / w) as f64).collect();
        let q: Vec<f64> = (0..w * h).map(|i| 0.02 * (i % w) as f64 - 0.03 + 0.01 * (i / w) as f64).collect();
        let got = integrate_least_squares(&p, &q, w, h);
        assert!(max_abs_diff(&got, &zero_mean(&s)) < 1e-9);
    }

    /// Dong `item 14`: height-based relighting with both re-differentiations: the prototype
    /// values, spectral better than forward differences, forward worse than 3I on D, and
    /// never better than Gradient in total error.
    #[test]
    fn height_based_relighting_reproduces_the_prototype() {
        // (scenario, Gradient, spectral, forward, 3I recon, integrability residual)
        let table = [
            (Scenario::A, 0.0, 0.0, 0.1788, 0.0, 0.0),
            (Scenario::B, 0.3823, 0.3851, 0.4413, 0.5358, 21.2),
            (Scenario::D, 0.1569, 0.1643, 0.3022, 0.1665, 48.4),
        ];
        let close = |g: f64, w: f64| if w == 0.0 { g.abs() <= 1e-6 } else { ((g - w) / w).abs() <= 0.02 };
        let mut bad = Vec::new();
        for (s, grad, spec, fwd, three, resid) in table {
            let st = scenario(s).stack;
            let (w, h) = (st.width, st.height);
            let rep = extract(&st, Method::Gradient).unwrap();
            let height = frankot_chellappa(rep.plane(0), rep.plane(1), w, h);
            let originals: Vec<&[f64]> = st.images.iter().map(|v| v.as_slice()).collect();
            let run = |how| {
                let relit: Vec<Vec<f64>> =
                    st.lights.iter().map(|l| relight_from_height(&height, rep.plane(2), w, h, how, l)).collect();
                eta(&relit, &originals)
            };
            let (es, ef) = (run(Differentiation::Spectral), run(Differentiation::Forward));
            let g = eta(&st.lights.iter().map(|l| rep.relight(l).unwrap()).collect::<Vec<_>>(), &originals);
            let r = integrability_residual(rep.plane(0), rep.plane(1), w, h);
            println!("{s:?}: Gradient {:.4} spectral {:.4} forward {:.4} residual {r:.4}", g.eta, es.eta, ef.eta);
            for (name, got, want) in [("Gradient", g.eta, grad), ("spectral", es.eta, spec), ("forward", ef.eta, fwd)] {
                if !close(got, want) {
                    bad.push(format!("{s:?} {name}: {got} vs {want}"));
                }
            }
            if s == Scenario::A {
                assert!(r < 1e-9, "A residual {r}");
            } else if !close(r, resid) {
                bad.push(format!("{s:?} residual: {r} vs {resid}"));
            }
            assert!(es.eta <= ef.eta);
            assert!(es.frobenius >= g.frobenius - 1e-12 && ef.frobenius >= g.frobenius - 1e-12);
            if s == Scenario::D {
                assert!(ef.eta > three, "forward-difference height relighting {} vs 3I {three}", ef.eta);
            }
        }
        assert!(bad.is_empty(), "not reproduced:\n{}", bad.join("\n"));
    }
}
