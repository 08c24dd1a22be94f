//! Cones of directions, written with `z = 1 - cos(theta)` so that tiny cones (the sun's
//! 0.27 degrees: `z = 1.1e-5`, below what `cos` resolves in f32 near 1) keep their accuracy.

use crate::math::PI;
use glam::{Vec2, Vec3};

/// `1 - cos(angle)` for an angle in degrees, computed as `2 sin^2(angle / 2)` in f64 (no
/// cancellation for small angles).
pub(super) fn one_minus_cos_deg(degrees: f32) -> f32 {
    let h = 0.5 * (degrees as f64).to_radians();
    (2.0 * h.sin() * h.sin()) as f32
}

/// `1 - cos` of the angle between unit vectors `a` and `b`: `|a x b|^2 / (1 + cos)` near `a`
/// (accurate for tiny angles), `1 - a.b` elsewhere. In `[0, 2]`.
#[inline]
pub(super) fn one_minus_cos(a: Vec3, b: Vec3) -> f32 {
    let c = a.dot(b);
    if c > 0.5 {
        a.cross(b).length_squared() / (1.0 + c)
    } else {
        (1.0 - c).min(2.0)
    }
}

/// Uniform direction in the cone `1 - cos(theta) <= z_max` around +z.
#[inline]
pub(super) fn sample_uniform_cone(u: Vec2, z_max: f32) -> Vec3 {
    let z = u.x * z_max;
    let sin_theta = (z * (2.0 - z)).max(0.0).sqrt();
    let (sin, cos) = crate::math::warp::sin_cos_turn(u.y);
    Vec3::new(sin_theta * cos, sin_theta * sin, 1.0 - z)
}

/// Solid-angle density of [`sample_uniform_cone`]: `1 / (2 pi z_max)`.
#[inline]
pub(super) fn uniform_cone_pdf(z_max: f32) -> f32 {
    1.0 / (2.0 * PI * z_max)
}

/// Solid angle of the cone `1 - cos(theta) <= z_max`.
#[inline]
pub(super) fn cone_solid_angle(z_max: f32) -> f32 {
    2.0 * PI * z_max
}

/// A point on the disk of radius `radius` centred at `center + radius * w`, perpendicular to
/// the unit `w` (the disk the environment, directional and sun lights start their emitted rays
/// on), uniform by area.
#[inline]
pub(super) fn disk_origin(center: Vec3, radius: f32, w: Vec3, u: Vec2) -> Vec3 {
    let frame = crate::math::Frame::from_z(w);
    let d = crate::math::warp::square_to_disk_concentric(u) * radius;
    center + radius * w + frame.s * d.x + frame.t * d.y
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_minus_cos_is_accurate_for_tiny_angles() {
        let z = one_minus_cos_deg(0.27);
        let exact = 1.0 - 0.27f64.to_radians().cos();
        assert!(((z as f64 - exact) / exact).abs() < 1e-6);
        let w = Vec3::new(1e-3f32.sin(), 0.0, 1e-3f32.cos());
        let z = one_minus_cos(Vec3::Z, w);
        assert!(((z as f64 - 5e-7) / 5e-7).abs() < 1e-4, "{z}");
        assert_eq!(one_minus_cos(Vec3::Z, -Vec3::Z), 2.0);
    }

    #[test]
    fn cone_samples_stay_in_the_cone() {
        for z_max in [1e-6f32, 1.1e-5, 0.1, 1.0, 2.0] {
            for i in 0..=32 {
                for j in 0..8 {
                    let u = Vec2::new(i as f32 / 32.0, j as f32 / 8.0);
                    let w = sample_uniform_cone(u, z_max);
                    assert!((w.length() - 1.0).abs() < 1e-6);
                    assert!(one_minus_cos(Vec3::Z, w) <= z_max * (1.0 + 1e-5));
                }
            }
        }
    }
}
