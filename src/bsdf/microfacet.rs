//! Isotropic GGX / Trowbridge-Reitz microfacet distribution.
//!
//! Everything here works in the local shading frame (`z` = macro-surface normal) with the
//! directions in the **upper** hemisphere: callers mirror a configuration with `wo.z < 0`
//! through the `z = 0` plane first (the distribution is symmetric under that mirror).
//!
//! * `D(m) = 1 / (pi alpha^2 cos^4(theta_m) (1 + tan^2(theta_m) / alpha^2)^2)`, normalised
//!   so that the projected area `∫ D(m) cos(theta_m) dm` is 1.
//! * Smith `Lambda(w) = (sqrt(1 + alpha^2 tan^2(theta)) - 1) / 2`, `G1 = 1 / (1 + Lambda)`.
//! * `G2` is the **height-correlated** Smith form `1 / (1 + Lambda(wo) + Lambda(wi))` (Heitz
//!   2014, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs"). It is
//!   exact for reflection under the Smith assumptions. For transmission the same expression
//!   is used, as pbrt-v4 and Cycles do; the exact height-correlated transmission term is
//!   `B(1 + Lambda(wo), 1 + Lambda(wi))` (a Beta function, since the two directions look at
//!   the surface from opposite sides), which is smaller, so ours transmits slightly more at
//!   rough, grazing configurations. It is symmetric in its arguments, so reciprocity holds.
//! * Visible-normal sampling by spherical caps (Dupuy & Benyoub 2023, "Sampling Visible GGX
//!   Normals with Spherical Caps"), exact for the density
//!   `D_wo(m) = G1(wo) max(0, wo.m) D(m) / wo.z` (Heitz 2018).
//!
//! `alpha` is clamped to at least [`MIN_ALPHA`] so that every density stays finite in `f32`
//! (the peak of `D` is `1 / (pi alpha^2)`, 3.2e7 at the minimum).

use crate::math::PI;
use glam::{Vec2, Vec3};

/// Smallest roughness used; smaller (or NaN) values are raised to it.
pub const MIN_ALPHA: f32 = 1e-4;

/// Clamps a roughness to `[MIN_ALPHA, inf)`; NaN becomes `MIN_ALPHA`.
#[inline]
pub fn clamp_alpha(alpha: f32) -> f32 {
    // `f32::max` returns the non-NaN operand.
    alpha.max(MIN_ALPHA)
}

/// Isotropic GGX distribution of roughness `alpha` (the "alpha" of Walter et al.).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ggx {
    alpha: f32,
}

impl Ggx {
    /// `alpha` is clamped with [`clamp_alpha`].
    pub fn new(alpha: f32) -> Ggx {
        Ggx {
            alpha: clamp_alpha(alpha),
        }
    }

    /// The roughness alpha, as clamped.
    pub fn alpha(&self) -> f32 {
        self.alpha
    }

    /// Normal distribution `D(m)` for a unit `m`; zero for `m.z <= 0`.
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        // cos^2 (1 + tan^2 / alpha^2) = cos^2 + sin^2 / alpha^2, without the tan.
        let t = (m.x * m.x + m.y * m.y) / a2 + m.z * m.z;
        1.0 / (PI * a2 * t * t)
    }

    /// Smith's `Lambda(w)`; infinite at (or numerically at) the horizon. Uses `|w.z|`.
    #[inline]
    pub fn lambda(&self, w: Vec3) -> f32 {
        let z2 = w.z * w.z;
        if z2 == 0.0 {
            return f32::INFINITY;
        }
        let a = self.alpha * self.alpha * (w.x * w.x + w.y * w.y) / z2;
        if !a.is_finite() {
            return f32::INFINITY;
        }
        // (sqrt(1 + a) - 1) / 2 without the cancellation for small a.
        0.5 * a / (1.0 + (1.0 + a).sqrt())
    }

    /// Smith masking `G1(w) = 1 / (1 + Lambda(w))`.
    #[inline]
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated masking-shadowing `G2 = 1 / (1 + Lambda(wo) + Lambda(wi))`.
    #[inline]
    pub fn g2(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Distribution of visible normals `D_wo(m) = G1(wo) max(0, wo.m) D(m) / |wo.z|`, a density
    /// over the solid angle of `m`. `wo` must be in the upper hemisphere.
    #[inline]
    pub fn d_visible(&self, wo: Vec3, m: Vec3) -> f32 {
        let cos_o = wo.z.abs();
        let wo_m = wo.dot(m);
        if cos_o == 0.0 || wo_m <= 0.0 {
            return 0.0;
        }
        let v = self.g1(wo) * wo_m * self.d(m) / cos_o;
        if v.is_finite() { v } else { 0.0 }
    }

    /// Samples a visible normal for `wo` (upper hemisphere, unit) with density
    /// [`Ggx::d_visible`]. `None` for the measure-zero draws where the construction
    /// degenerates.
    pub fn sample_visible(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        let a = self.alpha;
        // Stretch to the configuration of alpha = 1, where the visible normals are uniform on
        // the spherical cap z >= -wo_std.z, shifted by wo_std.
        let wo_std = Vec3::new(wo.x * a, wo.y * a, wo.z).normalize();
        let phi = 2.0 * PI * u.x;
        let z = (1.0 - u.y) * (1.0 + wo_std.z) - wo_std.z;
        let sin_t = (1.0 - z * z).max(0.0).sqrt();
        let (s, c) = phi.sin_cos();
        let h = Vec3::new(sin_t * c, sin_t * s, z) + wo_std;
        // Unstretch.
        let m = Vec3::new(h.x * a, h.y * a, h.z.max(0.0));
        let len = m.length();
        if !(len > 0.0 && len.is_finite()) {
            return None;
        }
        let m = m / len;
        (m.z > 0.0).then_some(m)
    }
}

/// Mirror reflection of `wo` about `m`.
#[inline]
pub fn reflect(wo: Vec3, m: Vec3) -> Vec3 {
    2.0 * wo.dot(m) * m - wo
}

/// Refraction of `wo` (on the side of `m`, `cos_o = wo.m > 0`) through a facet with normal
/// `m`, given `cos_t = |wi.m|` and `eta` = n(other side) / n(side of wo).
#[inline]
pub fn refract(wo: Vec3, m: Vec3, cos_o: f32, cos_t: f32, eta: f32) -> Vec3 {
    -wo / eta + (cos_o / eta - cos_t) * m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_forms() {
        let g = Ggx::new(0.5);
        // D at the normal is 1 / (pi alpha^2).
        assert!((g.d(Vec3::Z) - 1.0 / (PI * 0.25)).abs() < 1e-5);
        assert_eq!(g.d(-Vec3::Z), 0.0);
        // Lambda at the normal is 0, G1 = 1; at theta = 45 deg, alpha tan = 0.5.
        assert_eq!(g.lambda(Vec3::Z), 0.0);
        let w = Vec3::new(1.0, 0.0, 1.0).normalize();
        let expected = ((1.0f32 + 0.25).sqrt() - 1.0) / 2.0;
        assert!((g.lambda(w) - expected).abs() < 1e-6);
        assert_eq!(g.lambda(Vec3::X), f32::INFINITY);
        assert_eq!(g.g1(Vec3::X), 0.0);
        assert!((g.g2(w, w) - 1.0 / (1.0 + 2.0 * expected)).abs() < 1e-6);
        // Clamping.
        assert_eq!(Ggx::new(0.0).alpha(), MIN_ALPHA);
        assert_eq!(Ggx::new(f32::NAN).alpha(), MIN_ALPHA);
    }

    #[test]
    fn refraction_obeys_snell() {
        let m = Vec3::new(0.2, -0.1, 1.0).normalize();
        let wo = Vec3::new(-0.5, 0.3, 0.8).normalize();
        let eta = 1.5;
        let cos_o = wo.dot(m);
        let sin2_t = (1.0 - cos_o * cos_o) / (eta * eta);
        let cos_t = (1.0 - sin2_t).sqrt();
        let wi = refract(wo, m, cos_o, cos_t, eta);
        assert!((wi.length() - 1.0).abs() < 1e-5);
        assert!((wi.dot(m) + cos_t).abs() < 1e-5);
        // The generalised half vector of the pair is m again.
        let h = (wo + eta * wi).normalize();
        assert!((h.dot(m).abs() - 1.0).abs() < 1e-5);
    }
}
