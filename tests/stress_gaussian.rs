//! The guider's Gaussian machinery under stress: regression kernels from ill-conditioned,
//! rank-deficient or coincident neighbourhoods, conditioning points far from the data, and
//! huge or tiny coordinates. Each kernel is either rejected (`None`, and the caller falls back
//! to an isotropic kernel) or finite, and then its sampling and its density agree: a point
//! drawn as the sampler draws it (standard truncated normal `z`, warped by the kernel) has the
//! density `std_trunc_density(|z|^2) / prod(s)` when the density function evaluates it.
//! Deterministic (fixed seeds); no statistical test here.

use lodestar::integrators::guided::cache::regression_kernel;
use lodestar::integrators::guided::gaussian::{R, sample_std_trunc, std_trunc_density};
use lodestar::integrators::guided::kernel::Kernel;
use lodestar::math::IndependentSampler;

type Samples = Vec<([f64; 3], [f64; 3])>;

fn finite(k: &Kernel) -> bool {
    let f = |v: &[f32]| v.iter().all(|x| x.is_finite());
    f(&k.mu1)
        && f(&k.mu2)
        && k.k.iter().all(|r| f(r))
        && k.e.iter().all(|r| f(r))
        && f(&k.s)
        && k.s.iter().all(|&s| s > 0.0)
        && k.sigma_dist.is_finite()
        && k.sigma_dist > 0.0
}

/// Draw 2000 points from `k` around the mean given conditioning point `z`, and check that the
/// density function returns the density they were drawn with, to `tol` relative.
fn sample_matches_density(k: &Kernel, z: [f64; 3], dt: usize, dc: usize, tol: f64, what: &str) {
    assert!(finite(k), "{what}: kernel not finite: {k:?}");
    let m = k.mean(z, dc);
    assert!(m.iter().all(|v| v.is_finite()), "{what}: mean {m:?}");
    let norm: f64 = (0..dt).map(|i| k.s[i] as f64).product();
    let mut rng = IndependentSampler::new(5, 0, 0);
    let mut worst = 0.0f64;
    for _ in 0..2000 {
        let u = sample_std_trunc(dt, &mut rng);
        // Stay inside the truncation ball by a margin: at the rim a rounding error may move
        // a point out (density 0) in either direction, which is not what is measured here.
        let r2: f64 = u[..dt].iter().map(|x| x * x).sum();
        if r2 > (0.999 * R).powi(2) {
            continue;
        }
        let y = k.warp(u, m, dt);
        let drawn = std_trunc_density(dt, r2) / norm;
        let evaluated = k.density(y, m, dt);
        assert!(
            drawn.is_finite() && evaluated.is_finite(),
            "{what}: not finite"
        );
        worst = worst.max((evaluated - drawn).abs() / drawn);
    }
    assert!(
        worst < tol,
        "{what}: density off by {worst:e} (tolerance {tol:e})"
    );
}

/// Joint samples: y = b z + noise with per-axis noise stds `noise`, z with stds `spread`.
fn samples(dt: usize, dc: usize, noise: [f64; 3], spread: [f64; 3], n: usize) -> Samples {
    let mut rng = IndependentSampler::new(9, 0, 0);
    (0..n)
        .map(|_| {
            let a = sample_std_trunc(3, &mut rng);
            let b = sample_std_trunc(3, &mut rng);
            let mut y = [0.0; 3];
            let mut z = [0.0; 3];
            for i in 0..dc {
                z[i] = a[i] * spread[i];
            }
            for i in 0..dt {
                y[i] = 0.3 * z[0] - 0.2 * z[1] + b[i] * noise[i];
            }
            // Rotate the target noise off the axes, so the eigenvectors are not trivial.
            let (c, s) = (0.6f64.cos(), 0.6f64.sin());
            let (y0, y1) = (c * y[0] - s * y[1], s * y[0] + c * y[1]);
            ([y0, y1, y[2]], z)
        })
        .collect()
}

/// Condition numbers of the conditional covariance from 1e2 to 1e12, in 2D and 3D: the kernel
/// caps its anisotropy (`MAX_ANISOTROPY`) where f32 eigenvectors would no longer invert their
/// own warp, so the densities agree to 1e-3 whatever the input (without the cap, a condition
/// number of 1e9 already puts them 2e-3 apart).
#[test]
fn ill_conditioned_covariances() {
    for cond in [1e2f64, 1e6, 1e9, 1e12] {
        for (dt, dc) in [(2, 2), (3, 3), (2, 3), (3, 2)] {
            let noise = [1.0, 1.0 / cond.sqrt(), 1.0 / cond.powf(0.25)];
            let s = samples(dt, dc, noise, [1.0, 0.5, 0.7], 64);
            let what = format!("condition {cond:e}, dt {dt}, dc {dc}");
            if let Some(k) = regression_kernel(&s, dt, dc, 1e-30, 1e30, 1e-6, 1.0) {
                sample_matches_density(&k, [0.1, -0.2, 0.05], dt, dc, 1e-3, &what);
            }
        }
    }
}

/// Neighbourhoods of rank below the dimension: all conditioning points on a line, all
/// coincident, all targets coincident, fewer samples than dimensions, a single sample.
#[test]
fn rank_deficient_and_coincident_neighbourhoods() {
    let line: Samples = (0..32)
        .map(|i| {
            let t = i as f64 / 31.0;
            ([0.5 * t, -0.1 * t, 0.2 * t], [t, 2.0 * t, -t])
        })
        .collect();
    let coincident: Samples = vec![([0.1, 0.2, 0.3], [0.4, 0.5, 0.6]); 32];
    let targets_coincident: Samples = samples(3, 3, [1.0; 3], [1.0; 3], 32)
        .into_iter()
        .map(|(_, z)| ([0.0; 3], z))
        .collect();
    let two = samples(3, 3, [1.0; 3], [1.0; 3], 2);
    let one = samples(3, 3, [1.0; 3], [1.0; 3], 1);
    for (name, s) in [
        ("line", &line),
        ("coincident", &coincident),
        ("targets coincident", &targets_coincident),
        ("two samples", &two),
        ("one sample", &one),
    ] {
        for (dt, dc) in [(2, 2), (3, 3)] {
            let what = format!("{name}, dt {dt}, dc {dc}");
            // The ridge keeps every neighbourhood of two or more samples well posed; a single
            // sample has no covariance at all and is refused (the isotropic fallback).
            match regression_kernel(s, dt, dc, 1e-8, 1e2, 1e-4, 1.0) {
                Some(k) => sample_matches_density(&k, [0.2, 0.1, -0.3], dt, dc, 1e-4, &what),
                None => assert_eq!(name, "one sample", "{what}: refused"),
            }
            if name == "one sample" {
                assert!(
                    regression_kernel(s, dt, dc, 1e-8, 1e2, 1e-4, 1.0).is_none(),
                    "{what}"
                );
            }
        }
    }
}

/// A conditioning point 50 standard deviations from the neighbours' conditioning points.
#[test]
fn conditioning_point_far_from_the_data() {
    let s = samples(2, 2, [0.01, 0.02, 0.0], [0.1, 0.1, 0.0], 64);
    let k = regression_kernel(&s, 2, 2, 1e-8, 1e2, 1e-4, 1.0).expect("a well-posed kernel");
    sample_matches_density(&k, [5.0, -5.0, 0.0], 2, 2, 1e-4, "50 sigma away");
}

/// Coordinates of 1e4 (guide vertices far from where the kernel was fitted) and kernels of
/// width 1e-6 (guide segments of that length).
#[test]
fn huge_and_tiny_coordinates() {
    for scale in [1e4f64, 1e-6] {
        let s: Samples = samples(3, 3, [0.3, 0.2, 0.1], [1.0, 0.5, 0.7], 64)
            .into_iter()
            .map(|(y, z)| (y.map(|v| v * scale), z.map(|v| v * scale)))
            .collect();
        let k = regression_kernel(
            &s,
            3,
            3,
            1e-14 * scale * scale,
            1e2 * scale * scale,
            1e-4 * scale,
            1.0,
        )
        .expect("a well-posed kernel");
        sample_matches_density(
            &k,
            [0.1 * scale, 0.0, -0.2 * scale],
            3,
            3,
            1e-4,
            &format!("scale {scale:e}"),
        );
    }
}

/// Non-finite samples (a guide vertex at infinity or NaN) are rejected, never turned into a
/// kernel with NaN inside.
#[test]
fn non_finite_samples_are_rejected() {
    let mut s = samples(2, 2, [0.1; 3], [1.0; 3], 32);
    s[3].0[0] = f64::NAN;
    assert!(regression_kernel(&s, 2, 2, 1e-8, 1e2, 1e-4, 1.0).is_none());
    s[3].0[0] = f64::INFINITY;
    assert!(regression_kernel(&s, 2, 2, 1e-8, 1e2, 1e-4, 1.0).is_none());
}
