//! Sampling warps from the unit square, each next to its density. Densities are in solid angle
//! (directions) or area (points) as the name says.

use super::{INV_4PI, INV_PI, PI};
use glam::{Vec2, Vec3};
use std::ops::{Add, Mul};

/// Shirley-Chiu concentric map of the unit square onto the unit disk.
pub fn square_to_disk_concentric(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    // The angle is pi/4 (o.y / o.x), or pi/2 - pi/4 (o.x / o.y): both need sin and cos of an
    // angle in [-pi/4, pi/4] only, which short polynomials give to about an ulp.
    if o.x.abs() > o.y.abs() {
        let (sin, cos) = sin_cos_quarter((PI / 4.0) * (o.y / o.x));
        o.x * Vec2::new(cos, sin)
    } else {
        let (sin, cos) = sin_cos_quarter((PI / 4.0) * (o.x / o.y));
        o.y * Vec2::new(sin, cos)
    }
}

/// `(sin x, cos x)` for `|x| <= pi/4`: Taylor polynomials to x^9 and x^10, whose truncation
/// errors there (below 2e-9 and 1e-10) are far under f32's rounding. Sampling calls this
/// once per diffuse bounce; `f32::sin_cos` (a library call with range reduction) was 3 % of
/// pt's time on the Cornell box.
/// Generic over the number type so that the wavefront's sixteen-lane numbers
/// (`integrators/pt/wavefront/lanes.rs`) evaluate the same polynomials operation for operation.
#[inline(always)]
pub fn sin_cos_quarter<T>(x: T) -> (T, T)
where
    T: Copy + Mul<Output = T> + Mul<f32, Output = T>,
    f32: Add<T, Output = T>,
{
    let x2 = x * x;
    let sin = x
        * (1.0
            + x2 * (-1.0 / 6.0
                + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0)))));
    let cos = 1.0
        + x2 * (-0.5
            + x2 * (1.0 / 24.0
                + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40_320.0 + x2 * (-1.0 / 3_628_800.0)))));
    (sin, cos)
}

/// `(sin 2 pi u, cos 2 pi u)` for `u` in [0, 1] (an azimuth drawn from one number): the
/// quarter turn nearest `u` taken exactly (`u - q / 4` is exact in f32 for `u` in [0, 1]),
/// then [`sin_cos_quarter`] of the rest, within 3 ulps of 1 of the exact values. A library
/// `sin` and `cos` of `2 pi u` cost about as much as the rest of a light or phase sample.
#[inline]
pub fn sin_cos_turn(u: f32) -> (f32, f32) {
    let q = (4.0 * u + 0.5).floor();
    let (s, c) = sin_cos_quarter((2.0 * PI) * (u - 0.25 * q));
    match q as i32 & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// Cosine-weighted hemisphere around +z.
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = square_to_disk_concentric(u);
    // z = sqrt(1 - r^2) = sqrt((1 - r)(1 + r)) with 1 - r computed exactly: the concentric
    // map's radius is max |2 u_i - 1|, so 1 - r = 2 min(u_x, 1 - u_x, u_y, 1 - u_y) (exact in
    // floating point). `1 - |d|^2` would round to 0 for u_i below about 3e-8 and put the
    // sample on the rim with pdf 0.
    let one_minus_r = 2.0 * u.x.min(1.0 - u.x).min(u.y).min(1.0 - u.y).max(0.0);
    let z = (one_minus_r * (2.0 - one_minus_r)).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Solid-angle density of [`square_to_cosine_hemisphere`] at a direction of cosine
/// `cos_theta`: `cos / pi` (0 below the horizon).
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    if cos_theta > 0.0 {
        cos_theta * INV_PI
    } else {
        0.0
    }
}

/// A direction uniform on the unit sphere.
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin, cos) = sin_cos_turn(u.y);
    Vec3::new(r * cos, r * sin, z)
}

/// Solid-angle density of [`square_to_uniform_sphere`]: `1 / (4 pi)`.
pub const fn uniform_sphere_pdf() -> f32 {
    INV_4PI
}

/// Uniform direction in the cone of half-angle `acos(cos_max)` around +z.
pub fn square_to_uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let cos_theta = (1.0 - u.x) + u.x * cos_max;
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let (sin, cos) = sin_cos_turn(u.y);
    Vec3::new(sin_theta * cos, sin_theta * sin, cos_theta)
}

/// Solid-angle density of [`square_to_uniform_cone`]: `1 / (2 pi (1 - cos_max))`.
pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_max))
}

/// Uniform barycentrics (b1, b2) on a triangle; the point is (1-b1-b2) p0 + b1 p1 + b2 p2.
pub fn square_to_uniform_triangle(u: Vec2) -> Vec2 {
    // Heitz 2019's low-distortion map keeps strata compact.
    let (b0, b1);
    if u.x < u.y {
        b0 = u.x / 2.0;
        b1 = u.y - b0;
    } else {
        b1 = u.y / 2.0;
        b0 = u.x - b1;
    }
    Vec2::new(b1, 1.0 - b0 - b1)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Within 2 ulps of 1 (2.4e-7) of f64's sine and cosine on a fine grid of [-pi/4, pi/4]
    /// and at its ends; odd and even as the functions are.
    #[test]
    fn sin_cos_quarter_is_accurate() {
        let n = 200_000;
        let mut worst = 0.0f64;
        for i in 0..=n {
            let x = (-PI / 4.0) + (PI / 2.0) * (i as f32 / n as f32);
            let x = x.clamp(-PI / 4.0, PI / 4.0);
            let (s, c) = sin_cos_quarter(x);
            let (s64, c64) = (x as f64).sin_cos();
            worst = worst
                .max((s as f64 - s64).abs())
                .max((c as f64 - c64).abs());
            assert_eq!(sin_cos_quarter(-x), (-s, c));
        }
        assert!(worst < 2.4e-7, "worst error {worst:e}");
    }

    /// Within 3 ulps of 1 (3.6e-7) of f64's sine and cosine of 2 pi u on a fine grid of
    /// [0, 1], the quarter-turn boundaries and both ends included.
    #[test]
    fn sin_cos_turn_is_accurate() {
        let n = 400_000;
        let mut worst = 0.0f64;
        let grid = (0..=n).map(|i| i as f32 / n as f32);
        let edges = [0.125f32, 0.375, 0.625, 0.875]
            .into_iter()
            .flat_map(|e| [e.next_down(), e, e.next_up()]);
        for u in grid.chain(edges) {
            let (s, c) = sin_cos_turn(u);
            let (s64, c64) = (std::f64::consts::TAU * u as f64).sin_cos();
            worst = worst
                .max((s as f64 - s64).abs())
                .max((c as f64 - c64).abs());
        }
        assert!(worst < 3.6e-7, "worst error {worst:e}");
    }

    #[test]
    fn concentric_disk_stays_inside() {
        for i in 0..=16 {
            for j in 0..=16 {
                let d = square_to_disk_concentric(Vec2::new(i as f32 / 16.0, j as f32 / 16.0));
                assert!(d.length() <= 1.0 + 1e-6);
            }
        }
    }

    #[test]
    fn triangle_barycentrics_are_valid() {
        for i in 0..=16 {
            for j in 0..=16 {
                let b = square_to_uniform_triangle(Vec2::new(i as f32 / 16.0, j as f32 / 16.0));
                assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
            }
        }
    }
}
