//! Truncated Gaussians in up to three dimensions (f64), and the small dense linear algebra
//! the kernels need (Cholesky, symmetric eigen-decomposition by Jacobi rotations).
//!
//! Every Gaussian of the guider is truncated to the Mahalanobis ball of radius [`R`] and
//! renormalised exactly by the ball's mass [`trunc_mass`] (spec §3.7): 1D `erf(r/√2)`, 2D
//! `1 − e^{−r²/2}`, 3D `erf(r/√2) − √(2/π) r e^{−r²/2}`. Sampling draws standard normals
//! (Box–Muller) and rejects draws outside the ball, so the acceptance rate is the mass.
//!
//! Section 4.4 of the spec also gives the solid-angle density of the direction towards a point
//! drawn from a 3D Gaussian (the "projected normal", truncated); [`direction_density_3d`]
//! implements it for experiments and tests.

use crate::math::Sampler;

/// Truncation radius (Mahalanobis).
pub const R: f64 = 3.0;

const SQRT_2: f64 = std::f64::consts::SQRT_2;
const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// erf(x) to about 1e-15 relative: Maclaurin series for |x| < 3, continued fraction for erfc
/// beyond.
pub fn erf(x: f64) -> f64 {
    if x.is_nan() {
        return f64::NAN;
    }
    if x < 0.0 {
        return -erf(-x);
    }
    if x < 3.0 {
        // erf(x) = 2/√π Σ (−1)^n x^{2n+1} / (n! (2n+1))
        let x2 = x * x;
        let (mut term, mut sum) = (x, x);
        for n in 1..200 {
            term *= -x2 / n as f64;
            let add = term / (2 * n + 1) as f64;
            sum += add;
            if add.abs() < 1e-17 * sum.abs() {
                break;
            }
        }
        return sum * std::f64::consts::FRAC_2_SQRT_PI;
    }
    1.0 - erfc_large(x)
}

/// erfc(x) for x >= 2 by the continued fraction erfc(x) = e^{−x²}/√π · 1/(x + (1/2)/(x + 1/(x
/// + (3/2)/(x + ...)))), evaluated from the tail.
fn erfc_large(x: f64) -> f64 {
    let mut f = x;
    for n in (1..80).rev() {
        f = x + (n as f64 * 0.5) / f;
    }
    (-x * x).exp() / (std::f64::consts::PI.sqrt() * f)
}

/// erfc(x) for any x, accurate in the tails.
pub fn erfc(x: f64) -> f64 {
    if x >= 2.0 {
        erfc_large(x)
    } else {
        1.0 - erf(x)
    }
}

/// Standard normal cdf Φ(s).
pub fn std_cdf(s: f64) -> f64 {
    0.5 * erfc(-s / SQRT_2)
}

/// Standard normal density φ(s).
pub fn std_pdf(s: f64) -> f64 {
    (-0.5 * s * s - 0.5 * LN_2PI).exp()
}

/// Mass of the d-dimensional standard normal inside the ball of radius `r` (d = 1, 2, 3).
pub fn trunc_mass(d: usize, r: f64) -> f64 {
    match d {
        1 => erf(r / SQRT_2),
        2 => 1.0 - (-0.5 * r * r).exp(),
        3 => erf(r / SQRT_2) - (2.0 / std::f64::consts::PI).sqrt() * r * (-0.5 * r * r).exp(),
        _ => panic!("truncated Gaussians are 1D to 3D"),
    }
}

/// Density of the standard d-dimensional normal truncated at [`R`], at squared norm `z2`.
pub fn std_trunc_density(d: usize, z2: f64) -> f64 {
    std_trunc_log_density(d, z2).value()
}

/// [`std_trunc_density`] as a [`LogDensity`] (no `exp` taken).
pub fn std_trunc_log_density(d: usize, z2: f64) -> LogDensity {
    if z2 > R * R {
        return LogDensity::ZERO;
    }
    LogDensity {
        scale: 1.0,
        log: -0.5 * z2 - log_normaliser(d),
    }
}

/// A density as `scale · e^log`. p(X | l), a product over the path's vertices of Gaussian
/// densities and their measure factors, multiplies the scales and adds the exponents, so it
/// takes one `exp` per candidate guide path instead of one per vertex.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LogDensity {
    /// The factor outside the exponential.
    pub scale: f64,
    /// The exponent.
    pub log: f64,
}

impl LogDensity {
    /// The density 0.
    pub const ZERO: LogDensity = LogDensity {
        scale: 0.0,
        log: 0.0,
    };
    /// The density 1 (the neutral factor of a product).
    pub const ONE: LogDensity = LogDensity {
        scale: 1.0,
        log: 0.0,
    };

    /// A plain density (no exponent).
    pub fn plain(p: f64) -> LogDensity {
        LogDensity { scale: p, log: 0.0 }
    }

    /// The density as a number, `scale · e^log` (0 when `scale` is 0).
    pub fn value(self) -> f64 {
        if self.scale == 0.0 {
            0.0
        } else {
            self.scale * self.log.exp()
        }
    }

    /// Whether the density is exactly 0.
    pub fn is_zero(self) -> bool {
        self.scale == 0.0
    }

    /// The density times `k`.
    pub fn scaled(self, k: f64) -> LogDensity {
        LogDensity {
            scale: self.scale * k,
            log: self.log,
        }
    }

    /// The product of two densities.
    pub fn times(self, o: LogDensity) -> LogDensity {
        LogDensity {
            scale: self.scale * o.scale,
            log: self.log + o.log,
        }
    }
}

/// `ln` of the normaliser of [`std_trunc_density`] in `d` = 1, 2, 3 dimensions,
/// `d/2 ln 2π + ln trunc_mass(d, R)`, computed once (p_g evaluates it per vertex and
/// candidate, and `erf` is a long series).
fn log_normaliser(d: usize) -> f64 {
    static LOG_NORM: std::sync::LazyLock<[f64; 3]> = std::sync::LazyLock::new(|| {
        [1, 2, 3].map(|d| 0.5 * d as f64 * LN_2PI + trunc_mass(d, R).ln())
    });
    assert!((1..=3).contains(&d), "truncated Gaussians are 1D to 3D");
    LOG_NORM[d - 1]
}

/// Two independent standard normals from two uniforms (Box–Muller).
pub fn normal_pair(u1: f32, u2: f32) -> (f64, f64) {
    let u1 = 1.0 - u1 as f64; // (0, 1]
    let r = (-2.0 * u1.ln()).sqrt();
    let phi = 2.0 * std::f64::consts::PI * u2 as f64;
    (r * phi.cos(), r * phi.sin())
}

/// A standard normal in `d` dimensions truncated to the ball of radius [`R`] (rejection).
pub fn sample_std_trunc(d: usize, sampler: &mut impl Sampler) -> [f64; 3] {
    loop {
        let (a, b) = normal_pair(sampler.next_1d(), sampler.next_1d());
        let c = if d == 3 {
            normal_pair(sampler.next_1d(), sampler.next_1d()).0
        } else {
            0.0
        };
        let z = match d {
            1 => [a, 0.0, 0.0],
            2 => [a, b, 0.0],
            _ => [a, b, c],
        };
        if z[0] * z[0] + z[1] * z[1] + z[2] * z[2] <= R * R {
            return z;
        }
    }
}

/// A 3 x 3 matrix, row-major (`m[row][column]`); the Gaussians of 1D and 2D targets use its
/// leading block.
pub type Mat3 = [[f64; 3]; 3];

/// Cholesky factor L (lower, L Lᵀ = a) of the leading n×n block; None unless positive definite.
pub fn cholesky(a: &Mat3, n: usize) -> Option<Mat3> {
    let mut l = [[0.0; 3]; 3];
    for i in 0..n {
        for j in 0..=i {
            let mut s = a[i][j];
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            if i == j {
                if !(s > 0.0) || !s.is_finite() {
                    return None;
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    Some(l)
}

/// Solve (L Lᵀ) x = b for the n×n Cholesky factor `l`.
pub fn cholesky_solve(l: &Mat3, n: usize, b: [f64; 3]) -> [f64; 3] {
    let mut y = [0.0; 3];
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i][k] * y[k];
        }
        y[i] = s / l[i][i];
    }
    let mut x = [0.0; 3];
    for i in (0..n).rev() {
        let mut s = y[i];
        for k in i + 1..n {
            s -= l[k][i] * x[k];
        }
        x[i] = s / l[i][i];
    }
    x
}

/// Eigen-decomposition of the symmetric leading n×n block of `a` by cyclic Jacobi rotations:
/// (eigenvalues, eigenvectors as columns).
pub fn symmetric_eigen(a: &Mat3, n: usize) -> ([f64; 3], Mat3) {
    let mut m = *a;
    let mut v = [[0.0; 3]; 3];
    for (i, row) in v.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for _sweep in 0..50 {
        let mut off = 0.0;
        for i in 0..n {
            for j in i + 1..n {
                off += m[i][j] * m[i][j];
            }
        }
        let scale: f64 = (0..n).map(|i| m[i][i] * m[i][i]).sum();
        if off <= 1e-30 * scale.max(1e-300) {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                if m[p][q] == 0.0 {
                    continue;
                }
                let theta = (m[q][q] - m[p][p]) / (2.0 * m[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..n {
                    let (mkp, mkq) = (m[k][p], m[k][q]);
                    m[k][p] = c * mkp - s * mkq;
                    m[k][q] = s * mkp + c * mkq;
                }
                for k in 0..n {
                    let (mpk, mqk) = (m[p][k], m[q][k]);
                    m[p][k] = c * mpk - s * mqk;
                    m[q][k] = s * mpk + c * mqk;
                }
                for row in v.iter_mut().take(n) {
                    let (vp, vq) = (row[p], row[q]);
                    row[p] = c * vp - s * vq;
                    row[q] = s * vp + c * vq;
                }
            }
        }
    }
    let mut lambda = [0.0; 3];
    for (i, l) in lambda.iter_mut().enumerate().take(n) {
        *l = m[i][i];
    }
    (lambda, v)
}

/// Solid-angle density of the direction `w` (unit) from `x` towards a point drawn from the 3D
/// Gaussian N(mu, sigma) truncated to the Mahalanobis ball of radius `r` and renormalised by
/// its mass (spec §4.4): `e^{−q/2} / (2π |Σ|^{1/2} a^{3/2}) [G(h) − G(max(−h, −β))] / M_3(r)`.
/// `r = inf` gives the untruncated projected normal.
pub fn direction_density_3d(x: [f64; 3], mu: [f64; 3], sigma: &Mat3, r: f64, w: [f64; 3]) -> f64 {
    let Some(l) = cholesky(sigma, 3) else {
        return 0.0;
    };
    let det = (l[0][0] * l[1][1] * l[2][2]).powi(2);
    let m = [mu[0] - x[0], mu[1] - x[1], mu[2] - x[2]];
    let aw = cholesky_solve(&l, 3, w);
    let am = cholesky_solve(&l, 3, m);
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let a = dot(w, aw);
    let b = dot(w, am);
    let c = dot(m, am);
    let beta = b / a.sqrt();
    let q = (c - beta * beta).max(0.0);
    let front = (-0.5 * q).exp() / (2.0 * std::f64::consts::PI * det.sqrt() * a.powf(1.5));
    if r.is_infinite() {
        let bracket = (1.0 + beta * beta) * std_cdf(beta) + beta * std_pdf(beta);
        return front * bracket;
    }
    let h2 = r * r - q;
    if h2 <= 0.0 {
        return 0.0;
    }
    let h = h2.sqrt();
    let lo = (-h).max(-beta);
    if h <= lo {
        return 0.0;
    }
    // Antiderivative of (β + s)² φ(s).
    let g = |s: f64| (1.0 + beta * beta) * std_cdf(s) - (2.0 * beta + s) * std_pdf(s);
    front * (g(h) - g(lo)) / trunc_mass(3, r)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// p(X | l) is assembled as one `exp` of summed exponents: it must equal the product of
    /// the per-vertex densities (to rounding), and a zero factor anywhere must make it 0.
    #[test]
    fn log_density_products_equal_products_of_densities() {
        let z2s = [(2, 0.3), (3, 4.1), (1, 8.9), (2, 0.0)];
        let mut acc = LogDensity::ONE;
        let mut direct = 1.0;
        for (i, &(d, z2)) in z2s.iter().enumerate() {
            let k = 0.5 + i as f64;
            acc = acc.times(std_trunc_log_density(d, z2).scaled(k));
            direct *= std_trunc_density(d, z2) * k;
        }
        assert!(
            (acc.value() - direct).abs() <= 1e-14 * direct,
            "{acc:?} vs {direct}"
        );
        let zero = acc.times(std_trunc_log_density(2, R * R * 1.0001));
        assert!(zero.is_zero() && zero.value() == 0.0);
        assert_eq!(LogDensity::plain(0.25).value(), 0.25);
    }

    #[test]
    fn erf_matches_known_values() {
        // Values from Abramowitz & Stegun table 7.1 / high-precision references.
        let cases = [
            (0.5, 0.520_499_877_813_046_5),
            (1.0, 0.842_700_792_949_714_9),
            (2.0, 0.995_322_265_018_952_7),
            (3.0 / SQRT_2, 0.997_300_203_936_739_8),
        ];
        for (x, e) in cases {
            assert!((erf(x) - e).abs() < 1e-14, "erf({x}) = {} vs {e}", erf(x));
        }
        // erfc in the tail: erfc(5) = 1.5374597944280349e-12.
        assert!((erfc(5.0) / 1.537_459_794_428_035e-12 - 1.0).abs() < 1e-12);
        assert!((erfc(2.9) / 4.109_787_809_945_884e-5 - 1.0).abs() < 1e-14);
    }

    #[test]
    fn truncation_masses() {
        assert!((trunc_mass(1, 3.0) - 0.997_300_203_936_74).abs() < 1e-12);
        assert!((trunc_mass(2, 3.0) - 0.988_891_003_461_758).abs() < 1e-12);
        assert!((trunc_mass(3, 3.0) - 0.970_709_113_465_111_8).abs() < 1e-12);
    }

    #[test]
    fn cholesky_and_eigen_reconstruct() {
        let a = [[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 2.0]];
        let l = cholesky(&a, 3).unwrap();
        let x = cholesky_solve(&l, 3, [1.0, 2.0, 3.0]);
        for i in 0..3 {
            let ax: f64 = (0..3).map(|j| a[i][j] * x[j]).sum();
            assert!((ax - [1.0, 2.0, 3.0][i]).abs() < 1e-12);
        }
        let (lam, v) = symmetric_eigen(&a, 3);
        for i in 0..3 {
            for j in 0..3 {
                let r: f64 = (0..3).map(|k| v[i][k] * lam[k] * v[j][k]).sum();
                assert!((r - a[i][j]).abs() < 1e-12, "{i} {j}");
            }
        }
        let (lam2, _) = symmetric_eigen(&[[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0; 3]], 2);
        let mut l2 = [lam2[0], lam2[1]];
        l2.sort_by(f64::total_cmp);
        assert!((l2[0] - 1.0).abs() < 1e-12 && (l2[1] - 3.0).abs() < 1e-12);
        assert!(cholesky(&[[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0; 3]], 2).is_none());
    }
}
