//! Analytic spheres.

use super::{Ray, gamma};
use glam::Vec3;

/// A sphere; its outside is its front side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius.
    pub radius: f32,
}

impl Sphere {
    /// Nearest `t` in `(0, ray.t_max)`, or `f32::INFINITY`.
    ///
    /// Uses the numerically robust form of Ray Tracing Gems ch. 7 (Haines et al.): the
    /// discriminant from `|f - (f.d) d|^2`, and the smaller root from `c / q`.
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, t_max: f32) -> f32 {
        let f = o - self.center;
        let b = -f.dot(d);
        let r2 = self.radius * self.radius;
        let l = f + b * d;
        let disc = r2 - l.length_squared();
        if disc < 0.0 {
            return f32::INFINITY;
        }
        let c = f.length_squared() - r2;
        let q = b + b.signum() * disc.sqrt();
        let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (c / q, q) };
        let (t0, t1) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
        if t0 > 0.0 && t0 < t_max {
            t0
        } else if t1 > 0.0 && t1 < t_max {
            t1
        } else {
            f32::INFINITY
        }
    }

    /// Hit point re-projected onto the sphere, its outward normal and position error bound.
    pub fn surface_at(&self, ray: &Ray, t: f32) -> (Vec3, Vec3, Vec3) {
        let n = (ray.at(t) - self.center).normalize();
        let p = self.center + self.radius * n;
        let err = gamma(6) * (self.center.abs() + self.radius * n.abs()) + gamma(5) * p.abs();
        (p, n, err)
    }

    /// Texture coordinates of the surface point `p`: (φ / 2π, θ / π) with θ measured from +z
    /// and φ from +x towards +y in [0, 2π), as Mitsuba's sphere.
    pub fn tex_coords(&self, p: Vec3) -> glam::Vec2 {
        let d = (p - self.center) / self.radius;
        let phi = d.y.atan2(d.x);
        let phi = if phi < 0.0 {
            phi + 2.0 * std::f32::consts::PI
        } else {
            phi
        };
        glam::Vec2::new(
            phi / (2.0 * std::f32::consts::PI),
            d.z.clamp(-1.0, 1.0).acos() / std::f32::consts::PI,
        )
    }

    /// The derivatives of position by the texture coordinates at surface point `p` (Mitsuba's
    /// sphere's): `2π (-y, x, 0)` by u (φ grows about +z), `π (z cos φ, z sin φ, -ρ)` by v
    /// (θ from +z), with `(x, y, z)` the point relative to the centre and `ρ` its distance
    /// from the axis; zero at the poles, where φ is undefined.
    pub fn dp_duv(&self, p: Vec3) -> [Vec3; 2] {
        use std::f32::consts::PI;
        let d = p - self.center;
        let rho = d.x.hypot(d.y);
        if rho == 0.0 {
            return [Vec3::ZERO; 2];
        }
        let (cos_phi, sin_phi) = (d.x / rho, d.y / rho);
        [
            Vec3::new(-d.y, d.x, 0.0) * (2.0 * PI),
            Vec3::new(d.z * cos_phi, d.z * sin_phi, -rho) * PI,
        ]
    }

    /// Surface area, `4 pi r^2`.
    pub fn area(&self) -> f32 {
        4.0 * std::f32::consts::PI * self.radius * self.radius
    }
}
