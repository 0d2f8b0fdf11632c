//! Colour [references: lagae §7] (the paper's §6 and Fig. 15; proposals 10 and 16): the PCA
//! that decorrelates a photo's RGB so each principal channel can get its own wavelet noise, with
//! a sign convention that makes the transform a rotation (so two textures' transforms can be
//! slerped), and the morph between two such transforms.
//!
//! The covariance is symmetric, so a cyclic Jacobi eigen-solver replaces the paper's SVD
//! (proposal 10, tessera's choice): it is a few dozen lines, converges to full f64 accuracy in a handful of
//! sweeps, and performs the same arithmetic on every platform. Everything is summed in input
//! order: the same pixels give the same bits.

use serde::{Deserialize, Serialize};

/// The colour modes of the paper's Fig. 7.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ColourMode {
    /// R, G and B analysed and synthesised separately, each with its own band offsets: false
    /// colours appear where the photo's channels move together (Fig. 7b).
    RgbIndependent,
    /// R, G and B with shared offsets: no false colours, but the channels are perfectly
    /// correlated, so the photo's colour variation is lost (Fig. 7c).
    RgbShared,
    /// The paper's method: noise on the decorrelated principal channels (Fig. 7d).
    Pca,
}

/// Why a PCA could not be computed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ColourError {
    #[error("no pixels: a colour covariance needs at least one")]
    Empty,
    #[error("the channels differ in length (R {r}, G {g}, B {b} values)")]
    LengthMismatch { r: usize, g: usize, b: usize },
    #[error("value {index} of channel {channel} is not a finite number ({value})")]
    NonFinite { channel: usize, index: usize, value: f64 },
    #[error("the colour covariance overflows (values too large to square)")]
    Overflow,
}

/// The principal axes of a photo's colours.
///
/// `u` is column-major, `u[c][r]`: column `c` is the axis of principal channel `c`. Columns are
/// ordered by descending eigenvalue; each column's largest-magnitude entry is positive, except
/// that column 3 is negated when that makes U a proper rotation (det U = +1).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pca {
    pub mean: [f64; 3],
    pub u: [[f64; 3]; 3],
    /// Variances of the principal channels (population, i.e. over P), descending.
    pub eigenvalues: [f64; 3],
    /// Which columns the sign convention negated relative to the eigen-solver's raw output
    /// (informational).
    pub flipped: [bool; 3],
}

/// Most Jacobi sweeps; a 3×3 converges to the last bit in about five.
const MAX_SWEEPS: usize = 64;

/// Two eigenvalues closer than this (relative to the largest) keep the solver's order, and two
/// entries of a column closer than this in magnitude count as tied for "largest" (the first
/// wins): a grey image, whose two minor eigenvalues are both zero and whose major axis is
/// (1, 1, 1)/√3, then gets the same transform whatever the last bits of its sums.
const TIE: f64 = 1e-12;

fn det(u: &[[f64; 3]; 3]) -> f64 {
    let [a, b, c] = u;
    a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Eigen-decomposition of a symmetric 3×3 by cyclic Jacobi rotations (the stable update of
/// Rutishauser, with `tan` from the smaller root). Returns the eigenvalues and the eigenvector
/// matrix `v[row][col]`, unsorted.
fn jacobi(mut a: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let scale: f64 = a.iter().flatten().map(|x| x * x).sum();
    for _ in 0..MAX_SWEEPS {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        if off == 0.0 || off <= scale * 1e-36 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            let apq = a[p][q];
            if apq == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * apq);
            // tan of the rotation angle; for huge θ the square would overflow, and 1/(2θ) is
            // the same number to rounding.
            let t = if theta.abs() > 1e150 {
                0.5 / theta
            } else {
                let t = 1.0 / (theta.abs() + libm::sqrt(theta * theta + 1.0));
                if theta < 0.0 {
                    -t
                } else {
                    t
                }
            };
            let c = 1.0 / libm::sqrt(t * t + 1.0);
            let s = t * c;
            let tau = s / (1.0 + c);
            a[p][p] -= t * apq;
            a[q][q] += t * apq;
            a[p][q] = 0.0;
            a[q][p] = 0.0;
            let r = 3 - p - q;
            let (g, h) = (a[r][p], a[r][q]);
            a[r][p] = g - s * (h + g * tau);
            a[p][r] = a[r][p];
            a[r][q] = h + s * (g - h * tau);
            a[q][r] = a[r][q];
            for row in &mut v {
                let (g, h) = (row[p], row[q]);
                row[p] = g - s * (h + g * tau);
                row[q] = h + s * (g - h * tau);
            }
        }
    }
    ([a[0][0], a[1][1], a[2][2]], v)
}

/// Proposal 10: the PCA of three equally long channels. Mean, covariance (over P; its
/// normalisation does not change U), Jacobi, eigenvalues sorted descending (ties, within 1e-12
/// of the largest, keep the solver's order), each column's largest-magnitude entry made
/// positive, then column 3 negated if det U = −1. Grey (R = G = B) and constant images are
/// valid and give a rotation.
pub fn pca(r: &[f64], g: &[f64], b: &[f64]) -> Result<Pca, ColourError> {
    if r.len() != g.len() || r.len() != b.len() {
        return Err(ColourError::LengthMismatch { r: r.len(), g: g.len(), b: b.len() });
    }
    if r.is_empty() {
        return Err(ColourError::Empty);
    }
    let channels = [r, g, b];
    for (channel, values) in channels.iter().enumerate() {
        if let Some(index) = values.iter().position(|v| !v.is_finite()) {
            return Err(ColourError::NonFinite { channel, index, value: values[index] });
        }
    }
    let n = r.len() as f64;
    let mean: [f64; 3] = std::array::from_fn(|c| channels[c].iter().sum::<f64>() / n);
    if !mean.iter().all(|m| m.is_finite()) {
        return Err(ColourError::Overflow);
    }
    // The six distinct sums of the upper triangle: 00 01 02 11 12 22.
    let mut sums = [0.0; 6];
    for i in 0..r.len() {
        let d = [r[i] - mean[0], g[i] - mean[1], b[i] - mean[2]];
        sums[0] += d[0] * d[0];
        sums[1] += d[0] * d[1];
        sums[2] += d[0] * d[2];
        sums[3] += d[1] * d[1];
        sums[4] += d[1] * d[2];
        sums[5] += d[2] * d[2];
    }
    let at = |p: usize, q: usize| {
        let (p, q) = (p.min(q), p.max(q));
        sums[[[0, 1, 2], [1, 3, 4], [2, 4, 5]][p][q]] / n
    };
    let cov: [[f64; 3]; 3] = std::array::from_fn(|p| std::array::from_fn(|q| at(p, q)));
    if !cov.iter().flatten().all(|v| v.is_finite()) {
        return Err(ColourError::Overflow);
    }
    let (values, v) = jacobi(cov);
    // Descending, by a fixed bubble order that swaps only on a clear difference.
    let tol = TIE * values.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let mut order = [0usize, 1, 2];
    for _ in 0..2 {
        for i in 0..2 {
            if values[order[i + 1]] > values[order[i]] + tol {
                order.swap(i, i + 1);
            }
        }
    }
    let mut u: [[f64; 3]; 3] = std::array::from_fn(|c| std::array::from_fn(|row| v[row][order[c]]));
    let mut flipped = [false; 3];
    for (col, f) in u.iter_mut().zip(&mut flipped) {
        let mut big = 0;
        for row in 1..3 {
            if col[row].abs() > col[big].abs() + TIE {
                big = row;
            }
        }
        if col[big] < 0.0 {
            col.iter_mut().for_each(|x| *x = -*x);
            *f = true;
        }
    }
    if det(&u) < 0.0 {
        u[2].iter_mut().for_each(|x| *x = -*x);
        flipped[2] = !flipped[2];
    }
    // Covariance eigenvalues are variances; the solver can leave −1e-17 where the truth is 0.
    let eigenvalues = std::array::from_fn(|c| values[order[c]].max(0.0));
    Ok(Pca { mean, u, eigenvalues, flipped })
}

// ---------------------------------------------------------------------------------------------
// Rotations as unit quaternions (w, x, y, z), for the morph.

/// The quaternion of a rotation matrix given by columns (Shepperd's method: the largest of the
/// four squared components is taken from the diagonal, the rest from off-diagonal sums, so no
/// square root of a small number is taken).
fn quat_from_columns(u: &[[f64; 3]; 3]) -> [f64; 4] {
    // m(r, c) = row r, column c.
    let m = |r: usize, c: usize| u[c][r];
    let trace = m(0, 0) + m(1, 1) + m(2, 2);
    let q = if trace > 0.0 {
        let s = 2.0 * libm::sqrt(trace + 1.0);
        [0.25 * s, (m(2, 1) - m(1, 2)) / s, (m(0, 2) - m(2, 0)) / s, (m(1, 0) - m(0, 1)) / s]
    } else if m(0, 0) > m(1, 1) && m(0, 0) > m(2, 2) {
        let s = 2.0 * libm::sqrt(1.0 + m(0, 0) - m(1, 1) - m(2, 2));
        [(m(2, 1) - m(1, 2)) / s, 0.25 * s, (m(0, 1) + m(1, 0)) / s, (m(0, 2) + m(2, 0)) / s]
    } else if m(1, 1) > m(2, 2) {
        let s = 2.0 * libm::sqrt(1.0 + m(1, 1) - m(0, 0) - m(2, 2));
        [(m(0, 2) - m(2, 0)) / s, (m(0, 1) + m(1, 0)) / s, 0.25 * s, (m(1, 2) + m(2, 1)) / s]
    } else {
        let s = 2.0 * libm::sqrt(1.0 + m(2, 2) - m(0, 0) - m(1, 1));
        [(m(1, 0) - m(0, 1)) / s, (m(0, 2) + m(2, 0)) / s, (m(1, 2) + m(2, 1)) / s, 0.25 * s]
    };
    normalise(q)
}

fn normalise(q: [f64; 4]) -> [f64; 4] {
    let n = libm::sqrt(q.iter().map(|x| x * x).sum::<f64>());
    if n > 0.0 && n.is_finite() {
        q.map(|x| x / n)
    } else {
        q
    }
}

/// The rotation matrix (by columns) of a unit quaternion.
fn columns_from_quat(q: [f64; 4]) -> [[f64; 3]; 3] {
    let [w, x, y, z] = q;
    [
        [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + w * z), 2.0 * (x * z - w * y)],
        [2.0 * (x * y - w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z + w * x)],
        [2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y)],
    ]
}

/// Spherical linear interpolation along the shorter arc, renormalised.
fn slerp(a: [f64; 4], b: [f64; 4], t: f64) -> [f64; 4] {
    let mut d: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
    let b = if d < 0.0 {
        d = -d;
        b.map(|x| -x)
    } else {
        b
    };
    // Nearly parallel: sin θ is tiny and the ratio ill-conditioned; the chord is the arc.
    let (ka, kb) = if d > 0.9995 {
        (1.0 - t, t)
    } else {
        let theta = libm::acos(d.min(1.0));
        let s = libm::sin(theta);
        (libm::sin((1.0 - t) * theta) / s, libm::sin(t * theta) / s)
    };
    normalise(std::array::from_fn(|i| ka * a[i] + kb * b[i]))
}

/// The six permutations of three channels, in a fixed order (ties go to the first).
const PERMUTATIONS: [[usize; 3]; 6] = [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]];

impl Pca {
    /// The decorrelated channels of a colour, `Uᵀ(p − μ)`.
    pub fn decorrelate(&self, p: [f64; 3]) -> [f64; 3] {
        let d = [p[0] - self.mean[0], p[1] - self.mean[1], p[2] - self.mean[2]];
        std::array::from_fn(|c| dot(&self.u[c], &d))
    }

    /// The colour of decorrelated channels, `U v + μ`.
    pub fn recorrelate(&self, v: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|r| self.mean[r] + (self.u[0][r] * v[0] + self.u[1][r] * v[1] + self.u[2][r] * v[2]))
    }

    /// `other` with its principal axes matched to `self`'s (proposal 16): the permutation that
    /// maximises Σ|⟨u_c, u′_π(c)⟩| (first of the six on ties), each column's sign that of its
    /// inner product, and, if that left det = −1, the least aligned column negated back so the
    /// result stays a rotation. Returns it with `(π(c), negated_c)` per channel `c`.
    fn matched(&self, other: &Pca) -> (Pca, [(usize, bool); 3]) {
        let mut best = PERMUTATIONS[0];
        let mut best_score = f64::NEG_INFINITY;
        for perm in PERMUTATIONS {
            let score: f64 = (0..3).map(|c| dot(&self.u[c], &other.u[perm[c]]).abs()).sum();
            if score > best_score {
                best_score = score;
                best = perm;
            }
        }
        let align: [f64; 3] = std::array::from_fn(|c| dot(&self.u[c], &other.u[best[c]]));
        let mut negate: [bool; 3] = std::array::from_fn(|c| align[c] < 0.0);
        let column = |c: usize, neg: bool| other.u[best[c]].map(|x| if neg { -x } else { x });
        let u: [[f64; 3]; 3] = std::array::from_fn(|c| column(c, negate[c]));
        if det(&u) < 0.0 {
            let mut weakest = 0;
            for c in 1..3 {
                if align[c].abs() < align[weakest].abs() {
                    weakest = c;
                }
            }
            negate[weakest] = !negate[weakest];
        }
        let u = std::array::from_fn(|c| column(c, negate[c]));
        let pca = Pca {
            mean: other.mean,
            u,
            eigenvalues: std::array::from_fn(|c| other.eigenvalues[best[c]]),
            flipped: std::array::from_fn(|c| other.flipped[best[c]] != negate[c]),
        };
        (pca, std::array::from_fn(|c| (best[c], negate[c])))
    }

    /// The paper's Fig. 15 morph from `self` (t = 0) to `other` (t = 1): `other`'s axes matched
    /// to `self`'s (permutation and sign, keeping it a rotation), the rotations slerped as unit
    /// quaternions, mean and eigenvalues linear. Returns the morphed PCA and, per channel `c`,
    /// `(j, negated)`: channel `c` of the morph continues `other`'s channel `j`, negated if
    /// `negated` (its curve becomes [`super::marginal::Curve::negated`]). t = 0 is `self` and
    /// t = 1 the matched `other`, bit for bit; `flipped` is taken from the nearer end.
    pub fn morph(&self, other: &Pca, t: f64) -> (Pca, [(usize, bool); 3]) {
        let (b, order) = self.matched(other);
        if t == 0.0 {
            return (self.clone(), order);
        }
        if t == 1.0 {
            return (b, order);
        }
        let q = slerp(quat_from_columns(&self.u), quat_from_columns(&b.u), t);
        let lerp = |x: f64, y: f64| x + (y - x) * t;
        let pca = Pca {
            mean: std::array::from_fn(|i| lerp(self.mean[i], b.mean[i])),
            u: columns_from_quat(q),
            eigenvalues: std::array::from_fn(|i| lerp(self.eigenvalues[i], b.eigenvalues[i])),
            flipped: if t < 0.5 { self.flipped } else { b.flipped },
        };
        (pca, order)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::rng::{derive_seed, Rng};

    fn rng(label: &str) -> Rng {
        Rng::new(derive_seed(2009, "noise", label))
    }

    /// ‖UᵀU − I‖ (Frobenius).
    fn orthonormality_error(u: &[[f64; 3]; 3]) -> f64 {
        let mut e = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                let d = dot(&u[i], &u[j]) - if i == j { 1.0 } else { 0.0 };
                e += d * d;
            }
        }
        e.sqrt()
    }

    /// Covariance (over P) of three channels.
    fn covariance(ch: &[Vec<f64>; 3]) -> [[f64; 3]; 3] {
        let n = ch[0].len() as f64;
        let mean: [f64; 3] = std::array::from_fn(|c| ch[c].iter().sum::<f64>() / n);
        std::array::from_fn(|p| {
            std::array::from_fn(|q| {
                (0..ch[0].len()).map(|i| (ch[p][i] - mean[p]) * (ch[q][i] - mean[q])).sum::<f64>() / n
            })
        })
    }

    /// A photo-like sample: strongly correlated RGB around a brownish mean.
    fn correlated_image(label: &str, n: usize) -> [Vec<f64>; 3] {
        let mut r = rng(label);
        let mut out = [Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n)];
        for _ in 0..n {
            let (a, b, c) = (r.normal(), r.normal(), r.normal());
            out[0].push(0.45 + 0.12 * a + 0.03 * b);
            out[1].push(0.35 + 0.10 * a - 0.04 * b + 0.01 * c);
            out[2].push(0.20 + 0.06 * a + 0.02 * c);
        }
        out
    }

    /// The sign convention, applied to a rotation's columns.
    fn conventional(mut u: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
        for col in &mut u {
            let big = (0..3).fold(0, |b, r| if col[r].abs() > col[b].abs() { r } else { b });
            if col[big] < 0.0 {
                *col = col.map(|x| -x);
            }
        }
        if det(&u) < 0.0 {
            u[2] = u[2].map(|x| -x);
        }
        u
    }

    fn check_rotation(u: &[[f64; 3]; 3]) {
        let e = orthonormality_error(u);
        assert!(e < 1e-9, "‖UᵀU − I‖ = {e:e}");
        assert!((det(u) - 1.0).abs() < 1e-9, "det {}", det(u));
    }

    #[test]
    fn pca_is_a_rotation_with_descending_eigenvalues_that_decorrelates() {
        let img = correlated_image("pca", 1 << 16);
        let p = pca(&img[0], &img[1], &img[2]).unwrap();
        check_rotation(&p.u);
        assert!(p.eigenvalues[0] >= p.eigenvalues[1] && p.eigenvalues[1] >= p.eigenvalues[2], "{:?}", p.eigenvalues);
        // Columns 1 and 2: largest-magnitude entry positive.
        for c in 0..2 {
            let big = (0..3).fold(0, |b, r| if p.u[c][r].abs() > p.u[c][b].abs() { r } else { b });
            assert!(p.u[c][big] > 0.0);
        }
        let mut dec: [Vec<f64>; 3] = Default::default();
        for ((&r, &g), &b) in img[0].iter().zip(&img[1]).zip(&img[2]) {
            let v = p.decorrelate([r, g, b]);
            let back = p.recorrelate(v);
            for (c, (&x, &y)) in back.iter().zip(&[r, g, b]).enumerate() {
                dec[c].push(v[c]);
                assert!((x - y).abs() < 1e-14);
            }
        }
        let cov = covariance(&dec);
        let mut worst: f64 = 0.0;
        for i in 0..3 {
            assert!((cov[i][i] - p.eigenvalues[i]).abs() < 1e-12 * p.eigenvalues[0]);
            for j in 0..3 {
                if i != j {
                    worst = worst.max(cov[i][j].abs() / (cov[i][i] * cov[j][j]).sqrt());
                }
            }
        }
        println!(
            "PCA: ‖UᵀU − I‖ = {:.1e}, det − 1 = {:.1e}, worst off-diagonal/diagonal = {worst:.1e}, λ = {:?}",
            orthonormality_error(&p.u),
            det(&p.u) - 1.0,
            p.eigenvalues
        );
        assert!(worst < 1e-9, "{worst:e}");
    }

    #[test]
    fn pca_recovers_a_known_rotation_up_to_the_sign_convention() {
        // Three independent channels made exactly uncorrelated in the sample (Gram–Schmidt on
        // the centred draws), variances 9, 4, 1, rotated by a known R.
        let n = 1 << 14;
        let mut r = rng("rotation");
        let mut basis: Vec<Vec<f64>> = Vec::new();
        for _ in 0..3 {
            let mut v: Vec<f64> = (0..n).map(|_| r.normal()).collect();
            let m = v.iter().sum::<f64>() / n as f64;
            v.iter_mut().for_each(|x| *x -= m);
            for b in &basis {
                let d: f64 = v.iter().zip(b).map(|(x, y)| x * y).sum();
                v.iter_mut().zip(b).for_each(|(x, y)| *x -= d * y);
            }
            let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            v.iter_mut().for_each(|x| *x /= norm);
            basis.push(v);
        }
        let sd = [3.0, 2.0, 1.0].map(|s: f64| s * (n as f64).sqrt());
        for (label, axis, angle) in
            [("a", [1.0, 2.0, 3.0], 0.7), ("b", [-2.0, 0.5, 1.0], 2.4), ("c", [0.3, -1.0, 0.2], -1.1)]
        {
            let len: f64 = axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2];
            let (s, c) = (libm::sin(angle / 2.0), libm::cos(angle / 2.0));
            let rot = columns_from_quat(normalise([
                c,
                s * axis[0] / len.sqrt(),
                s * axis[1] / len.sqrt(),
                s * axis[2] / len.sqrt(),
            ]));
            let img: [Vec<f64>; 3] = std::array::from_fn(|row| {
                (0..n).map(|i| 0.5 + (0..3).map(|k| rot[k][row] * sd[k] * basis[k][i]).sum::<f64>()).collect()
            });
            let p = pca(&img[0], &img[1], &img[2]).unwrap();
            let want = conventional(rot);
            let err = (0..3)
                .flat_map(|c| (0..3).map(move |r| (c, r)))
                .map(|(c, r)| (p.u[c][r] - want[c][r]).abs())
                .fold(0.0, f64::max);
            println!("rotation {label}: max |U − R·S| = {err:.1e}, λ = {:?}", p.eigenvalues);
            assert!(err < 1e-9, "{label}: {err:e}\n{:?}\n{:?}", p.u, want);
            for (l, v) in p.eigenvalues.iter().zip([9.0, 4.0, 1.0]) {
                assert!((l - v).abs() < 1e-9, "{:?}", p.eigenvalues);
            }
        }
    }

    #[test]
    fn the_sign_convention_is_deterministic() {
        let img = correlated_image("determinism", 1 << 14);
        let a = pca(&img[0], &img[1], &img[2]).unwrap();
        let b = pca(&img[0], &img[1], &img[2]).unwrap();
        assert_eq!(a, b);
        // Point-mirrored colours (2μ − p) have the same covariance, so the same axes: the sign
        // comes from the convention, not from the data's orientation.
        let mirrored: [Vec<f64>; 3] = std::array::from_fn(|c| img[c].iter().map(|v| 2.0 * a.mean[c] - v).collect());
        let m = pca(&mirrored[0], &mirrored[1], &mirrored[2]).unwrap();
        for c in 0..3 {
            for r in 0..3 {
                assert!((m.u[c][r] - a.u[c][r]).abs() < 1e-9);
            }
        }
        // Channels scaled by a power of two: the same axes bit for bit up to the scale.
        let scaled: [Vec<f64>; 3] = std::array::from_fn(|c| img[c].iter().map(|v| 4.0 * v).collect());
        let s = pca(&scaled[0], &scaled[1], &scaled[2]).unwrap();
        assert_eq!(s.u, a.u);
        assert_eq!(s.flipped, a.flipped);
    }

    #[test]
    fn grey_and_constant_images_give_a_valid_rotation() {
        let mut r = rng("grey");
        let grey: Vec<f64> = (0..10_000).map(|_| r.range(0.0, 1.0)).collect();
        let p = pca(&grey, &grey, &grey).unwrap();
        check_rotation(&p.u);
        let var = covariance(&[grey.clone(), grey.clone(), grey.clone()])[0][0];
        assert!((p.eigenvalues[0] - 3.0 * var).abs() < 1e-12, "{:?}", p.eigenvalues);
        assert!(p.eigenvalues[1] < 1e-15 && p.eigenvalues[2] < 1e-15, "{:?}", p.eigenvalues);
        let k = 1.0 / 3f64.sqrt();
        assert!(p.u[0].iter().all(|x| (x - k).abs() < 1e-12), "{:?}", p.u[0]);
        println!("grey: U = {:?}, λ = {:?}, flipped = {:?}", p.u, p.eigenvalues, p.flipped);
        // Grey with an offset per channel, and two equal channels.
        let shifted: Vec<f64> = grey.iter().map(|v| v + 0.25).collect();
        check_rotation(&pca(&grey, &shifted, &grey).unwrap().u);
        let other: Vec<f64> = (0..10_000).map(|_| r.range(0.0, 1.0)).collect();
        check_rotation(&pca(&grey, &grey, &other).unwrap().u);
        let flat = vec![0.25; 100];
        let p = pca(&flat, &flat, &flat).unwrap();
        check_rotation(&p.u);
        assert_eq!(p.eigenvalues, [0.0; 3]);
        // 0.3 is not a binary fraction: the mean is off by an ulp and the "variance" is 1e-31.
        let flat = vec![0.3; 100];
        let p = pca(&flat, &flat, &flat).unwrap();
        check_rotation(&p.u);
        assert!(p.eigenvalues.iter().all(|&l| l < 1e-30), "{:?}", p.eigenvalues);
        check_rotation(&pca(&[0.1], &[0.2], &[0.3]).unwrap().u);
    }

    #[test]
    fn pca_refuses_bad_input() {
        assert_eq!(pca(&[], &[], &[]), Err(ColourError::Empty));
        assert_eq!(pca(&[1.0], &[1.0, 2.0], &[1.0]), Err(ColourError::LengthMismatch { r: 1, g: 2, b: 1 }));
        assert!(matches!(
            pca(&[1.0, 2.0], &[1.0, f64::NAN], &[1.0, 2.0]),
            Err(ColourError::NonFinite { channel: 1, index: 1, .. })
        ));
        assert!(matches!(
            pca(&[f64::INFINITY], &[1.0], &[1.0]),
            Err(ColourError::NonFinite { channel: 0, index: 0, .. })
        ));
        assert_eq!(pca(&[1e300, -1e300], &[0.0, 1.0], &[0.0, 1.0]), Err(ColourError::Overflow));
        assert_eq!(pca(&[f64::MAX, f64::MAX], &[0.0, 1.0], &[0.0, 1.0]), Err(ColourError::Overflow));
    }

    fn two_textures() -> (Pca, Pca) {
        let a = correlated_image("morph a", 1 << 12);
        let mut r = rng("morph b");
        let b: [Vec<f64>; 3] = {
            let mut out = [Vec::new(), Vec::new(), Vec::new()];
            for _ in 0..1 << 12 {
                let (x, y, z) = (r.normal(), r.normal(), r.normal());
                out[0].push(0.6 + 0.05 * x + 0.08 * y);
                out[1].push(0.6 + 0.09 * y - 0.02 * z);
                out[2].push(0.5 - 0.07 * x + 0.04 * z);
            }
            out
        };
        (pca(&a[0], &a[1], &a[2]).unwrap(), pca(&b[0], &b[1], &b[2]).unwrap())
    }

    #[test]
    fn morph_is_exact_at_the_ends_and_stays_a_rotation() {
        let (a, b) = two_textures();
        let (m0, order) = a.morph(&b, 0.0);
        assert_eq!(m0, a);
        let (m1, order1) = a.morph(&b, 1.0);
        assert_eq!(order, order1);
        for (c, &(j, neg)) in order.iter().enumerate() {
            let want = b.u[j].map(|x| if neg { -x } else { x });
            assert_eq!(m1.u[c], want);
            assert_eq!(m1.eigenvalues[c], b.eigenvalues[j]);
        }
        assert_eq!(m1.mean, b.mean);
        check_rotation(&m1.u);
        let mut worst: f64 = 0.0;
        let mut previous = a.u;
        for i in 0..=20 {
            let t = i as f64 * 0.05;
            let (m, o) = a.morph(&b, t);
            assert_eq!(o, order);
            check_rotation(&m.u);
            worst = worst.max(orthonormality_error(&m.u)).max((det(&m.u) - 1.0).abs());
            // Continuous: each step turns the axes by a bounded amount.
            let step = (0..3).map(|c| 1.0 - dot(&m.u[c], &previous[c])).fold(0.0, f64::max);
            assert!(step < 0.05, "t = {t}: {step}");
            previous = m.u;
            for k in 0..3 {
                let lo = a.mean[k].min(b.mean[k]) - 1e-15;
                let hi = a.mean[k].max(b.mean[k]) + 1e-15;
                assert!((lo..=hi).contains(&m.mean[k]));
            }
        }
        println!("morph: order {order:?}, worst ‖UᵀU − I‖ or |det − 1| over t = 0..1 step 0.05: {worst:.1e}");
    }

    #[test]
    fn morph_matches_permuted_and_negated_axes() {
        let (a, _) = two_textures();
        // B: A's axes in the order (2, 0, 1), the first and third negated (det stays +1:
        // a cyclic permutation and two negations).
        let b = Pca {
            mean: [0.1, 0.2, 0.3],
            u: [a.u[2].map(|x| -x), a.u[0], a.u[1].map(|x| -x)],
            eigenvalues: [a.eigenvalues[2], a.eigenvalues[0], a.eigenvalues[1]],
            flipped: [false; 3],
        };
        check_rotation(&b.u);
        let (m, order) = a.morph(&b, 0.5);
        assert_eq!(order, [(1, false), (2, true), (0, true)]);
        for c in 0..3 {
            for r in 0..3 {
                assert!((m.u[c][r] - a.u[c][r]).abs() < 1e-12);
            }
            assert!((m.eigenvalues[c] - a.eigenvalues[c]).abs() < 1e-15);
        }
        let (m1, _) = a.morph(&b, 1.0);
        assert_eq!(m1.u, a.u);
        // A reflection: B = A with one axis negated has det −1; matching negates it back.
        let r = Pca { u: [a.u[0], a.u[1].map(|x| -x), a.u[2]], ..a.clone() };
        assert!(det(&r.u) < 0.0);
        let (m, order) = a.morph(&r, 1.0);
        assert_eq!(order, [(0, false), (1, true), (2, false)]);
        check_rotation(&m.u);
    }

    #[test]
    fn morph_does_not_panic_on_degenerate_input() {
        let (a, b) = two_textures();
        let _ = a.morph(&b, f64::NAN);
        let _ = a.morph(&b, 2.0);
        let nan = Pca { u: [[f64::NAN; 3]; 3], ..b.clone() };
        let _ = a.morph(&nan, 0.5);
        let zero = Pca { u: [[0.0; 3]; 3], ..b };
        let _ = a.morph(&zero, 0.5);
        // Identical textures: the morph is the texture.
        let (m, order) = a.morph(&a, 0.3);
        assert_eq!(order, [(0, false), (1, false), (2, false)]);
        for c in 0..3 {
            for r in 0..3 {
                assert!((m.u[c][r] - a.u[c][r]).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn colour_types_round_trip_through_toml() {
        #[derive(Serialize, Deserialize, PartialEq, Debug)]
        struct Wrap {
            mode: ColourMode,
            pca: Pca,
        }
        let (a, _) = two_textures();
        let w = Wrap { mode: ColourMode::RgbIndependent, pca: a };
        let text = toml::to_string(&w).unwrap();
        assert!(text.contains("mode = \"rgb_independent\""), "{text}");
        assert_eq!(toml::from_str::<Wrap>(&text).unwrap(), w);
    }
}
